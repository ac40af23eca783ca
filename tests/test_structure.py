"""The tree keeps the shape CONTRIBUTING.md and the packages' docstrings describe.

- ``allanite.variance`` imports in one direction: each module only those listed above it in
  the package docstring (the in-memory path never reaches the out-of-core module);
- CONTRIBUTING.md's map names every package and top-level module, every path it names
  exists, and it sends no reader outside the repository;
- no new function over 100 lines of code (docstring excluded): the ones that remain are
  listed here with the reason, so a new one fails.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from test_import_graph import PACKAGE, import_graph

ROOT = PACKAGE.parents[1]
MAX_LINES = 100

#: functions over MAX_LINES lines of code that stay whole, and why (keep this list short)
LONG_FUNCTIONS = {
    # one table of explanations per view, in the diagnosis remit (another engineer's)
    "allanite.diagnosis.joint.explain",
}


def _variance_order() -> list[str]:
    doc = ast.get_docstring(ast.parse((PACKAGE / "variance" / "__init__.py").read_text()))
    assert doc is not None
    return re.findall(r":mod:`~allanite\.variance\.(\w+)`", doc)


def test_variance_modules_import_only_those_listed_above_them():
    order = _variance_order()
    modules = {p.stem for p in (PACKAGE / "variance").glob("*.py")} - {"__init__"}
    assert set(order) == modules, "the variance package docstring lists every module once"
    graph = import_graph()
    for i, name in enumerate(order):
        inside = {
            t.rpartition(".")[2]
            for t in graph[f"allanite.variance.{name}"]
            if t.startswith("allanite.variance.")
        }
        below = inside - set(order[:i])
        assert not below, f"allanite.variance.{name} imports {sorted(below)}, listed below it"


def test_the_in_memory_path_does_not_reach_the_out_of_core_module():
    graph = import_graph()
    seen, todo = set(), ["allanite.variance.kernel", "allanite.variance.result"]
    while todo:
        module = todo.pop()
        if module in seen:
            continue
        seen.add(module)
        todo += [t for t in graph[module] if t.startswith("allanite.variance.")]
    assert "allanite.variance.outofcore" not in seen
    assert "allanite.variance.phase_store" not in seen


def _contributing() -> str:
    return (ROOT / "CONTRIBUTING.md").read_text(encoding="utf-8")


def test_contributing_map_names_every_package_and_top_level_module():
    text = _contributing()
    named = set(re.findall(r"`([^`\s]+)`", text))
    missing = []
    for path in sorted(PACKAGE.iterdir()):
        if path.name.startswith("__") or path.suffix in (".pyi", ".typed"):
            continue
        if path.is_dir() and (path / "__init__.py").exists():
            key = f"python/allanite/{path.name}/"
            if key not in named and f"{path.name}/" not in named:
                missing.append(key)
        elif path.suffix == ".py" and not {path.name, f"python/allanite/{path.name}"} & named:
            missing.append(path.name)
    assert not missing, f"CONTRIBUTING.md's map does not name {missing}"


def test_every_path_contributing_names_exists_and_none_is_outside():
    text = _contributing()
    rows = [line for line in text.splitlines() if line.startswith("| `")]
    assert rows, "the map is a table whose rows start with a path"
    for row in rows:
        first, *others = re.findall(r"`([^`]+)`", row.split("|")[1])
        base = Path(first).parent  # the cell's other names are siblings of its first path
        for path in [Path(first), *(base / other for other in others)]:
            assert (ROOT / path).exists(), f"CONTRIBUTING.md names {path}, which does not exist"
        # files the description names: in the row's folder or beside it
        for name in re.findall(r"`([\w/]+\.(?:py|hpp|cpp|md))`", row.split("|")[2]):
            places = [ROOT / first / name, ROOT / base / name, ROOT / name]
            assert any(p.exists() for p in places), f"CONTRIBUTING.md's row {first} names {name}"
    for target in re.findall(r"\]\(([^)]+)\)", text):
        assert not target.startswith(("http", "/", "..")), f"link outside the repo: {target}"
        assert (ROOT / target).exists(), f"CONTRIBUTING.md links {target}, which does not exist"


def _long_functions() -> dict[str, int]:
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        module = ".".join(parts)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            body = node.body
            has_doc = ast.get_docstring(node) is not None and len(body) > 1
            start = body[1].lineno if has_doc else body[0].lineno
            length = (node.end_lineno or start) - start + 1
            if length > MAX_LINES:
                found[f"{module}.{node.name}"] = length
    return found


def test_no_new_function_over_100_lines():
    found = _long_functions()
    new = {name: n for name, n in found.items() if name not in LONG_FUNCTIONS}
    assert not new, f"functions over {MAX_LINES} lines of code (split them): {new}"


@pytest.mark.parametrize("name", sorted(LONG_FUNCTIONS))
def test_the_long_function_list_is_not_stale(name):
    assert name in _long_functions(), f"{name} is no longer long: drop it from LONG_FUNCTIONS"


#: imports that go up the layers of docs/architecture.md, each stated there
LAYER_EXCEPTIONS = {
    # the Jupyter views draw their figures lazily; those plot modules import only leaves
    ("allanite.notebook", "allanite.plot.allan"),
    ("allanite.notebook", "allanite.plot.diagnosis"),
    ("allanite.notebook", "allanite.plot.export"),
}


def _layers() -> list[list[str]]:
    """The layer table of docs/architecture.md, bottom first: the modules of each row."""
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    table = text.split("| layer | modules |", 1)[1].split("\n\n", 1)[0]
    graph = import_graph()
    layers = []
    for row in table.strip().splitlines()[1:]:
        cell = re.sub(r"\([^)]*\)", "", row.split("|")[2])  # (descriptions) name no layer
        names = re.findall(r"`([\w.]+)`", cell)
        full = [n if n.startswith("allanite") else f"allanite.{n}" for n in names]
        layers.append([n for n in full if n in graph])
    return layers


def test_imports_go_down_the_documented_layers():
    layers = _layers()
    assert len(layers) == 8, "the layer table of docs/architecture.md"

    def layer(module: str) -> int | None:
        found = [
            (len(name), i)
            for i, names in enumerate(layers)
            for name in names
            if module == name or module.startswith(name + ".")
        ]
        return max(found)[1] if found else None

    graph = import_graph()
    unplaced = sorted(m for m in graph if m != "allanite" and layer(m) is None)
    assert not unplaced, f"modules docs/architecture.md's layer table does not place: {unplaced}"
    upward = [
        f"{m} -> {d}"
        for m, targets in graph.items()
        if m != "allanite"
        for d in targets
        if d != "allanite"
        and layer(d) > layer(m)  # type: ignore[operator]
        and (m, d) not in LAYER_EXCEPTIONS
    ]
    assert not upward, f"imports up the layers of docs/architecture.md: {upward}"
