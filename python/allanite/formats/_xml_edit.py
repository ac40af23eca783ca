"""Write an edited XML tree back into the user's text, changing only what was edited.

A config written into a user's SDF must keep the user's file: indentation, quotes, empty
elements, comments and numbers such as ``0.0`` or ``100000.0`` outside the values that change.
:func:`parse` reads the text into an :mod:`xml.etree.ElementTree` tree and records where each
element lies in the text (expat reports the elements in the same document order);
:func:`serialize` then edits the text in place: changed values and attributes, added and
removed elements. A value rewritten as the same number (``0`` for ``0.0``) is left as it was.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
import xml.parsers.expat
from dataclasses import dataclass, field

from allanite.formats._text import keep_number

__all__ = ["Spans", "parse", "serialize"]

#: a start tag from its ``<``: name, attributes (quoted values may hold ``>``), ``>`` or ``/>``
_START = re.compile(rb"<[^\s/>]+(?:\s+[^\s=/>]+\s*=\s*(?:\"[^\"]*\"|'[^']*'))*\s*(/?)>")


@dataclass
class _Span:
    """Where one element lies in the text (byte offsets) and what it held when parsed."""

    start: int
    open_end: int
    empty: bool
    close_start: int = -1
    end: int = -1
    text: str = ""
    attrib: dict[str, str] = field(default_factory=dict)
    children: list[int] = field(default_factory=list)


@dataclass
class Spans:
    """The parsed text (UTF-8 bytes) and the span of each element, by ``id(element)``."""

    data: bytes
    spans: dict[int, _Span]
    #: the parsed elements, kept alive so that no new element takes a removed one's id
    elements: list[ET.Element] = field(default_factory=list)


def _positions(data: bytes) -> list[_Span]:
    """The spans of every element, in document order (start tags)."""
    parser = xml.parsers.expat.ParserCreate()
    out: list[_Span] = []
    stack: list[_Span] = []

    def start(name: str, attrs: dict[str, str]) -> None:
        at = parser.CurrentByteIndex
        match = _START.match(data, at)
        if match is None:
            raise ValueError("unexpected start tag")
        span = _Span(at, match.end(), bool(match.group(1)))
        out.append(span)
        stack.append(span)

    def end(name: str) -> None:
        span = stack.pop()
        if span.empty:
            span.close_start = span.end = span.open_end
        else:
            span.close_start = parser.CurrentByteIndex
            span.end = data.index(b">", span.close_start) + 1

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.Parse(data, True)
    return out


def parse(text: str) -> tuple[ET.Element, Spans | None]:
    """The tree of ``text`` (comments kept) and the elements' spans (None if not located)."""
    try:
        root = ET.fromstring(text, parser=ET.XMLParser(target=ET.TreeBuilder(insert_comments=True)))
    except ET.ParseError as exc:
        raise ValueError(f"SDF is not valid XML: {exc}") from None
    data = text.encode("utf-8")
    elements = [e for e in root.iter() if isinstance(e.tag, str)]
    try:
        found = _positions(data)
    except (ValueError, xml.parsers.expat.ExpatError):
        return root, None
    if len(found) != len(elements):
        return root, None
    spans = {}
    for el, span in zip(elements, found, strict=True):
        span.text = el.text or ""
        span.attrib = dict(el.attrib)
        span.children = [id(c) for c in el if isinstance(c.tag, str)]
        spans[id(el)] = span
    return root, Spans(data, spans, elements)


def _line_indent(data: bytes, at: int) -> bytes | None:
    """The whitespace from the line start to ``at`` (None when other text precedes it)."""
    begin = data.rfind(b"\n", 0, at) + 1
    head = data[begin:at]
    return head if not head.strip() else None


def _bare(el: ET.Element) -> bytes:
    """An element as XML without its tail."""
    tail, el.tail = el.tail, None
    try:
        return ET.tostring(el, encoding="unicode").encode("utf-8")
    finally:
        el.tail = tail


def _attributes(tag: bytes, old: dict[str, str], new: dict[str, str]) -> bytes:
    """A start tag with the changed attribute values replaced and new attributes added."""
    for name, value in new.items():
        if old.get(name) == value:
            continue
        quoted = value.replace("&", "&amp;").replace('"', "&quot;").encode("utf-8")
        pattern = re.compile(rb"(\s" + re.escape(name.encode()) + rb"\s*=\s*)([\"'])[^\"']*\2")
        found = pattern.search(tag)
        if found is not None:
            tag = tag[: found.start()] + found.group(1) + b'"' + quoted + b'"' + tag[found.end() :]
        else:
            cut = len(tag) - (2 if tag.endswith(b"/>") else 1)
            tag = tag[:cut] + b" " + name.encode() + b'="' + quoted + b'"' + tag[cut:]
    return tag


def _removal(data: bytes, span: _Span) -> tuple[int, int]:
    """The bytes to remove with an element: its whole line when it stands alone on one."""
    begin, end = span.start, span.end
    indent = _line_indent(data, begin)
    rest = data[end:].split(b"\n", 1)[0]
    if indent is not None and not rest.strip() and data.find(b"\n", end) >= 0:
        return begin - len(indent), data.index(b"\n", end) + 1
    return begin, end


def _children_edits(el: ET.Element, span: _Span, where: Spans) -> list[tuple[int, int, bytes]]:
    """Removed children cut out, new children inserted after the last kept one."""
    data, spans = where.data, where.spans
    kids = [c for c in el if isinstance(c.tag, str)]
    now = {id(c) for c in kids}
    edits = [(*_removal(data, spans[k]), b"") for k in span.children if k not in now]
    new = [c for c in kids if id(c) not in spans]
    if not new:
        return edits
    kept = [spans[id(c)] for c in kids if id(c) in spans]
    if span.empty:  # <x/> gains children: the element is written whole
        return [(span.start, span.end, _bare(el))]
    at = kept[-1].end if kept else span.open_end
    indent = _line_indent(data, kept[-1].start) if kept else None
    if indent is None and not kept:
        outer = _line_indent(data, span.start)
        indent = None if outer is None else outer + b"  "
    sep = b"\n" + indent if indent is not None else b""
    edits.append((at, at, b"".join(sep + _bare(c) for c in new)))
    return edits


def serialize(root: ET.Element, where: Spans) -> str:
    """The parsed text with the tree's edits applied in place; the rest byte for byte."""
    data, spans = where.data, where.spans
    edits: list[tuple[int, int, bytes]] = []
    for el in root.iter():
        span = spans.get(id(el)) if isinstance(el.tag, str) else None
        if span is None:
            continue
        if dict(el.attrib) != span.attrib:
            tag = _attributes(data[span.start : span.open_end], span.attrib, dict(el.attrib))
            edits.append((span.start, span.open_end, tag))
        has_kids = any(isinstance(c.tag, str) for c in el) or span.children
        if not has_kids and (el.text or "").strip() != span.text.strip():
            value = keep_number(span.text.strip(), (el.text or "").strip())
            if value != span.text.strip():
                if span.empty:
                    edits.append((span.start, span.end, _bare(el)))
                    continue
                old = data[span.open_end : span.close_start].decode("utf-8")
                lead = old[: len(old) - len(old.lstrip())]
                trail = old[len(old.rstrip()) :]
                text = (lead + _escape(value) + trail).encode("utf-8")
                edits.append((span.open_end, span.close_start, text))
        edits.extend(_children_edits(el, span, where))
    out = data
    for begin, end, text in sorted(edits, key=lambda e: (e[0], e[1]), reverse=True):
        out = out[:begin] + text + out[end:]
    return out.decode("utf-8")


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
