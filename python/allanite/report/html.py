"""Small HTML building blocks for a self-contained report (inline CSS, images as data URIs).

Everything a report shows is in the one file: no scripts, fonts, style sheets or images are
fetched from anywhere, so it opens the same offline, in a mail attachment or in an archive.
"""

from __future__ import annotations

import base64
import html
from collections.abc import Iterable, Sequence

from allanite.datasheet import status_text

__all__ = ["STYLE", "badge", "data_uri", "document", "escape", "figure", "fmt", "section", "table"]

STYLE = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif;
       margin: 0; color: #1d2329; background: #f4f6f8; }
main { max-width: 1060px; margin: 0 auto; padding: 24px 28px 48px; background: #fff; }
header { border-bottom: 3px solid #2c6fbb; margin-bottom: 18px; padding-bottom: 8px; }
h1 { font-size: 1.6em; margin: 0 0 4px; }
h2 { font-size: 1.25em; margin: 28px 0 10px; color: #1f4f86; border-bottom: 1px solid #d5dde6;
     padding-bottom: 4px; }
h3 { font-size: 1.05em; margin: 18px 0 8px; }
.meta { color: #5b6773; font-size: 0.9em; }
table { border-collapse: collapse; margin: 6px 0 12px; font-size: 0.92em; }
th, td { border: 1px solid #c9d3dd; padding: 4px 10px; text-align: right; }
th { background: #e8eef5; font-weight: 600; }
td.text, th.text { text-align: left; }
table.summary td:first-child { font-weight: 600; background: #f1f5f9; }
tr:nth-child(even) td { background: #f8fafc; }
figure { margin: 10px 0 16px; }
figure img { max-width: 100%; border: 1px solid #d5dde6; }
figcaption { color: #5b6773; font-size: 0.88em; margin-top: 4px; }
.badge { display: inline-block; padding: 1px 9px; border-radius: 10px; font-weight: 700;
         font-size: 0.85em; color: #fff; }
.pass { background: #2e8b57; } .fail { background: #c0392b; }
.marginal { background: #d68910; } .missing { background: #7f8c8d; }
.undetermined { background: #2874a6; }
.verdict { font-size: 1.1em; margin: 8px 0 14px; }
.warn { background: #fff6e0; border-left: 4px solid #d68910; padding: 6px 10px; margin: 6px 0; }
.note { color: #5b6773; font-size: 0.88em; }
.rejected { background: #fdecea; border-left: 4px solid #c0392b; color: #c0392b;
            padding: 6px 10px; margin: 6px 0; font-weight: 600; }
"""


def escape(text: object) -> str:
    """HTML-escape any value's text."""
    return html.escape(str(text), quote=True)


def fmt(value: float | None, digits: int = 4) -> str:
    """Format a number with ``digits`` significant digits (an en dash for missing values)."""
    if value is None or value != value:  # None or NaN
        return "–"
    return f"{value:.{digits}g}"


def data_uri(payload: bytes, mime: str) -> str:
    """Encode a payload as a base64 ``data:`` URI."""
    return f"data:{mime};base64,{base64.b64encode(payload).decode('ascii')}"


def figure(png: bytes, caption: str, alt: str) -> str:
    """Embed a PNG figure with a caption."""
    return (
        f'<figure><img src="{data_uri(png, "image/png")}" alt="{escape(alt)}">'
        f"<figcaption>{escape(caption)}</figcaption></figure>"
    )


def table(
    header: Sequence[str] | None,
    rows: Iterable[Sequence[str]],
    *,
    text_columns: int = 1,
    raw: bool = False,
    css_class: str = "",
) -> str:
    """Build an HTML table; the first ``text_columns`` columns are left aligned.

    Cells are escaped unless ``raw`` is true (then they must already be safe HTML).
    """

    def cell(tag: str, k: int, value: str) -> str:
        cls = ' class="text"' if k < text_columns else ""
        return f"<{tag}{cls}>{value if raw else escape(value)}</{tag}>"

    head = (
        ""
        if header is None
        else (
            "<thead><tr>"
            + "".join(cell("th", k, h) for k, h in enumerate(header))
            + "</tr></thead>"
        )
    )
    body = "".join(
        "<tr>" + "".join(cell("td", k, v) for k, v in enumerate(row)) + "</tr>" for row in rows
    )
    cls = f' class="{css_class}"' if css_class else ""
    return f"<table{cls}>{head}<tbody>{body}</tbody></table>"


def badge(status: str) -> str:
    """Render a coloured badge of a check's status (one of :data:`allanite.datasheet.STATUSES`).

    Every status has its colour in :data:`STYLE`; the text is the one the CLI prints
    (:func:`allanite.datasheet.status_text`: ``NOT DETERMINED`` for ``undetermined``).
    """
    return f'<span class="badge {escape(status)}">{escape(status_text(status))}</span>'


def section(title: str, body: str, *, anchor: str | None = None) -> str:
    """Wrap ``body`` in a titled section."""
    ident = f' id="{escape(anchor)}"' if anchor else ""
    return f"<section{ident}><h2>{escape(title)}</h2>{body}</section>"


def document(title: str, subtitle: str, body: str) -> str:
    """Assemble the complete HTML page."""
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{escape(title)}</title><style>{STYLE}</style></head><body><main>"
        f'<header><h1>{escape(title)}</h1><div class="meta">{escape(subtitle)}</div></header>'
        f"{body}</main></body></html>\n"
    )
