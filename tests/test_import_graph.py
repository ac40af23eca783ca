"""The package's import graph has no cycles, and library code does not import the CLI.

The graph is built from the source with :mod:`ast` (nothing is imported). Every ``import`` of an
``allanite`` module is an edge, wherever it is written:

- function-level (lazy) imports count like module-level ones. A lazy import that only dodges a
  cycle at import time still makes the two modules depend on each other, which is what this
  test is about; an optional *third-party* dependency imported lazily is not an edge at all;
- ``from allanite.pkg import name`` is an edge to ``allanite.pkg.name`` when that is a module,
  else to the package ``allanite.pkg`` (whose ``__init__`` runs);
- imports under ``if TYPE_CHECKING:`` are not edges (they never run);
- the implicit import of a module's parent packages is not an edge (Python always runs them
  first, so it cannot be ordered otherwise).
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "python" / "allanite"


def _modules() -> dict[str, Path]:
    found = {}
    for path in sorted(PACKAGE.rglob("*.py*")):
        if path.suffix not in (".py", ".pyi"):
            continue
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        found[".".join(parts)] = path
    return found


def _type_checking_lines(tree: ast.Module) -> set[int]:
    lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for child in node.body:
                lines.update(range(child.lineno, (child.end_lineno or child.lineno) + 1))
    return lines


@functools.cache
def import_graph() -> dict[str, set[str]]:
    """Module -> the allanite modules it imports (see the module docstring for the rules).

    Built once per session (the tests only read it).
    """
    modules = _modules()

    def owner(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    graph: dict[str, set[str]] = {}
    for module, path in modules.items():
        graph[module] = set()
        if path.suffix == ".pyi":  # the compiled extension: imports nothing of ours
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        skip = _type_checking_lines(tree)
        package = module if path.name == "__init__.py" else module.rpartition(".")[0]
        for node in ast.walk(tree):
            if getattr(node, "lineno", None) in skip:
                continue
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join([*up, base] if base else up)
                targets = [
                    f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base
                    for alias in node.names
                ]
            for target in targets:
                if target == "allanite" or target.startswith("allanite."):
                    found = owner(target)
                    if found is not None and found != module:
                        graph[module].add(found)
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def _describe(component: list[str], graph: dict[str, set[str]]) -> str:
    inside = set(component)
    edges = [f"{a} -> {b}" for a in component for b in sorted(graph[a] & inside)]
    return "; ".join(edges)


def test_the_graph_sees_the_package():
    graph = import_graph()
    assert "allanite.variance.estimate" in graph
    assert "allanite.variance.outofcore" in graph["allanite.variance.estimate"]
    assert "allanite._core" in graph["allanite.variance.kernel"]


def test_cycle_detection_finds_a_planted_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert cycles(graph) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycles():
    graph = import_graph()
    found = cycles(graph)
    assert not found, "import cycles: " + " | ".join(_describe(c, graph) for c in found)


def test_library_code_does_not_import_the_cli():
    graph = import_graph()
    offenders = [
        f"{module} -> {target}"
        for module, targets in graph.items()
        if not module.startswith("allanite.cli") and module != "allanite.__main__"
        for target in targets
        if target == "allanite.cli" or target.startswith("allanite.cli.")
    ]
    assert not offenders, "library modules importing allanite.cli: " + ", ".join(offenders)


def test_variance_package_imports_nothing_above_it():
    """allanite.variance depends only on the compiled core and the package's leaf helpers."""
    graph = import_graph()
    allowed = {"allanite._core", "allanite._deprecation", "allanite.units", "allanite.errors"}
    allowed |= {"allanite.extras", "allanite.confidence"}
    allowed |= {"allanite.notebook", "allanite.io.record"}
    for module, targets in graph.items():
        if module.startswith("allanite.variance"):
            outside = {t for t in targets if not t.startswith("allanite.variance")} - allowed
            assert not outside, f"{module} imports {sorted(outside)}"
