"""Small text helpers shared by the config formats: lenient YAML, in-place key updates."""

from __future__ import annotations

import re
from collections.abc import Collection
from typing import Any

from allanite.extras import require

__all__ = ["keep_number", "load_yaml", "number_text", "update_keys"]


def number_text(value: float) -> str:
    """A float as config text, round-trip exact to 10 significant digits."""
    return f"{value:.10g}"


def keep_number(old: str, new: str) -> str:
    """``old`` when both texts are the same number (``0.0`` and ``0``), else ``new``.

    A config written into a user's file keeps the user's spelling of the values it does not
    change (:func:`number_text` writes 10 significant digits, so equal within 1e-9).
    """
    try:
        a, b = float(old), float(new)
    except ValueError:
        return new
    return old if abs(a - b) <= 1e-9 * max(abs(a), abs(b)) else new


def load_yaml(text: str, what: str) -> dict[str, Any]:
    """Parse YAML as OpenCV-style configs write it (``%YAML:1.0``, ``!!opencv-matrix`` tags)."""
    yaml = require("yaml", extra="yaml", purpose=f"reading {what}", package="pyyaml")

    class Loader(yaml.SafeLoader):  # type: ignore[name-defined,misc]
        def compose_node(self, parent: Any, index: Any) -> Any:
            # an alias of a list or mapping can expand exponentially (a "billion laughs"
            # bomb): refuse it; an alias of a single value cannot grow and is kept
            if self.check_event(yaml.AliasEvent):
                anchor = self.peek_event().anchor
                node = self.anchors.get(anchor)
                if node is not None and not isinstance(node, yaml.ScalarNode):
                    raise ValueError(
                        f"{what}: the YAML alias *{str(anchor)[:40]} repeats a list or "
                        "mapping; allanite refuses such aliases (they can expand without "
                        "bound): write the values out"
                    )
            return super().compose_node(parent, index)

    def any_tag(loader: Any, suffix: str, node: Any) -> Any:
        if isinstance(node, yaml.MappingNode):
            return loader.construct_mapping(node)
        if isinstance(node, yaml.SequenceNode):
            return loader.construct_sequence(node)
        return loader.construct_scalar(node)

    Loader.add_multi_constructor("", any_tag)
    body = "\n".join(
        "" if line.lstrip().startswith("%YAML") else line for line in text.splitlines()
    )
    try:
        data = yaml.load(body, Loader=Loader)  # a SafeLoader subclass
    except yaml.YAMLError as exc:
        raise ValueError(f"{what} is not valid YAML: {exc}") from None
    if not isinstance(data, dict):
        raise ValueError(f"{what} must be a YAML mapping of keys to values")
    return data


def update_keys(text: str, values: dict[str, str], *, indent: str = "") -> str:
    """Replace the values of ``key: value`` lines in ``text``; append missing keys.

    Comments after a value and every other line are kept, so a user's config stays theirs.
    """
    lines = text.splitlines()
    missing = []
    for key, value in values.items():
        pattern = re.compile(rf"^(\s*{re.escape(key)}\s*:\s*)([^#\n]*?)(\s*(#.*)?)$")
        for i, line in enumerate(lines):
            match = pattern.match(line)
            if match:
                kept = keep_number(match.group(2).strip(), value)
                lines[i] = f"{match.group(1)}{kept}{match.group(3)}"
                break
        else:
            missing.append(f"{indent}{key}: {value}")
    return "\n".join(lines + missing) + "\n"


_NOTE = re.compile(r"^\s*# (projected|dropped|not representable[^:]*, dropped): (\w+)?")


def with_notes(
    text: str,
    dropped: list[str],
    projections: list[str],
    sensors: Collection[str] | None = None,
) -> str:
    """``text`` with ``# dropped: ...`` / ``# projected: ...`` lines for what it cannot hold.

    For configs written into a user's template: the notes of an earlier allanite write are
    replaced, so a corrected config says what this write projected or left out, once. With
    ``sensors`` (the sensors this write sets, e.g. ``("accel",)``) only their notes are
    replaced: the other sensor's entries stay as the template had them, and so do its notes.
    """

    def replaced(line: str) -> bool:
        match = _NOTE.match(line)
        return match is not None and (sensors is None or match.group(2) in sensors)

    lines = [line for line in text.splitlines() if not replaced(line)]
    lines += [f"# dropped: {d}" for d in dropped] + [f"# projected: {p}" for p in projections]
    return "\n".join(lines) + "\n"
