"""Rich display in Jupyter: ``_repr_html_`` of AllanResult, FitResult and Diagnosis.

A result shown as the last expression of a notebook cell appears as a compact table with its
plot (an inline PNG when matplotlib is installed; the table alone otherwise), the way pandas
and matplotlib users expect. Each class's ``_repr_html_`` is one of :func:`allan_html`,
:func:`fit_html` and :func:`diagnosis_html` (the results know their view; this module imports
none of them, so it sits below them in the import graph); the HTML is self-contained (no
scripts, no external files) and escaped.
"""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from allanite.confidence import DEFAULT_LEVEL

__all__ = ["allan_html", "diagnosis_html", "fit_html"]

#: longest table shown inline; longer ones show their first and last rows
MAX_ROWS = 12


def _num(value: Any) -> str:
    try:
        x = float(value)
    except (TypeError, ValueError):
        return html.escape(str(value))
    return "—" if not math.isfinite(x) else f"{x:.4g}"


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]], caption: str = "") -> str:
    """An HTML table; rows beyond :data:`MAX_ROWS` are elided in the middle."""
    shown: list[Sequence[Any] | None] = list(rows)
    if len(rows) > MAX_ROWS:
        half = MAX_ROWS // 2
        shown = [*rows[:half], None, *rows[-half:]]
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = []
    for row in shown:
        if row is None:
            body.append(
                f'<tr><td colspan="{len(header)}" style="text-align:center">'
                f"… {len(rows) - MAX_ROWS} more rows …</td></tr>"
            )
            continue
        cells = "".join(
            f"<td>{html.escape(c) if isinstance(c, str) else _num(c)}</td>" for c in row
        )
        body.append(f"<tr>{cells}</tr>")
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return (
        f'<table class="allanite">{cap}<thead><tr>{head}</tr></thead>'
        f"<tbody>{''.join(body)}</tbody></table>"
    )


def _png(build: Any) -> str:
    """``<img>`` of the figure ``build()`` returns, or '' without matplotlib."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return ""
    from allanite.plot.export import figure_bytes

    fig = build()
    data = base64.b64encode(figure_bytes(fig, "png", dpi=80)).decode("ascii")
    return f'<img style="max-width:36em" src="data:image/png;base64,{data}"/>'


def _layout(title: str, tables: str, image: str) -> str:
    return (
        f'<div class="allanite-result"><strong>{html.escape(title)}</strong>'
        '<div style="display:flex;flex-wrap:wrap;gap:1em;align-items:flex-start">'
        f"<div>{tables}</div>{image}</div></div>"
    )


def allan_html(result: Any) -> str:
    """HTML of an :class:`allanite.variance.AllanResult`: its table and plot."""
    from allanite.plot.allan import allan_figure

    dev = np.asarray(result.dev, dtype=np.float64).reshape(result.tau.size, -1)
    level = DEFAULT_LEVEL
    lo, hi = result.ci(level)
    lo, hi = np.reshape(lo, dev.shape), np.reshape(hi, dev.shape)
    unit = f" [{result.units}]" if result.units else ""
    header = ["tau [s]"]
    for c in range(dev.shape[1]):
        tag = f" {c}" if dev.shape[1] > 1 else ""
        header += [f"deviation{tag}{unit}", f"{100 * level:g} % interval{tag}"]
    rows = []
    for k in range(result.tau.size):
        row: list[Any] = [result.tau[k]]
        for c in range(dev.shape[1]):
            row += [dev[k, c], f"{_num(lo[k, c])} – {_num(hi[k, c])}"]
        rows.append(row)
    title = (
        f"AllanResult: {result.kind} deviation of {result.n_samples} {result.input} samples at "
        f"{result.fs:g} Hz, {result.tau.size} taus, {dev.shape[1]} channel(s)"
    )
    return _layout(title, _table(header, rows), _png(lambda: allan_figure(result)))


def _fit_figure(fit: Any) -> Any:
    from allanite.plot.allan import _matplotlib, plot_model

    fig = _matplotlib()(figsize=(6.0, 4.0), layout="constrained")
    ax = fig.add_subplot()
    ax.loglog(fit.tau, np.sqrt(fit.var), "o", ms=3, color="C0", label="data")
    fs = fit.meta.get("fs")
    if fs:
        plot_model(ax, fit.model, np.asarray(fit.tau, dtype=np.float64), 1.0 / float(fs))
    else:
        ax.loglog(fit.tau, np.sqrt(np.clip(fit.fitted, 0, None)), "-", color="black")
    ax.set_xlabel("tau [s]")
    ax.set_ylabel(f"Allan deviation [{fit.model.units.get('rate', '')}]")
    ax.legend(fontsize="small")
    return fig


def fit_html(fit: Any) -> str:
    """HTML of an :class:`allanite.fit.FitResult`: its coefficients, the misfit test, the plot."""
    level = DEFAULT_LEVEL
    rows = [
        [r["name"], r["value"], r["stderr"], f"{_num(r['low'])} – {_num(r['high'])}", r["unit"]]
        for r in fit.table("customary", level)
    ]
    table = _table(["coefficient", "value", "stderr", f"{100 * level:g} % interval", "unit"], rows)
    if fit.method == "gls":
        verdict = (
            f"misspecified (p < {fit.misfit_level:g}): intervals include a "
            f"{100 * fit.discrepancy:.3g} % model discrepancy per tau"
            if fit.discrepancy > 0
            else "not rejected"
        )
        table += (
            f"<p>chi² = {_num(fit.chi2)} for {fit.dof} dof (correlated GLS), "
            f"p = {_num(fit.p_value)}: model {html.escape(verdict)}</p>"
        )
    terms = ", ".join(t.type for t in fit.model.terms)
    title = f"FitResult ({fit.method}): {terms}"
    return _layout(title, table, _png(lambda: _fit_figure(fit)))


def diagnosis_html(diagnosis: Any) -> str:
    """HTML of an :class:`allanite.diagnosis.Diagnosis`: the gap, its attribution, the views."""
    from allanite.plot.diagnosis import diagnosis_figure

    verdict = "differ beyond chance" if diagnosis.significant else "agree within chance"
    where = diagnosis.where
    rows = [
        ["gap G", diagnosis.statistic],
        ["p-value", diagnosis.p_value],
        ["real and simulated", verdict],
        ["tau bands [s]", ", ".join(f"{a:.3g}–{b:.3g}" for a, b in where["tau_bands_s"]) or "—"],
        ["lines [Hz]", ", ".join(f"{f:.4g}" for f in where["frequency_lines_hz"]) or "—"],
        [
            "time segments [s]",
            ", ".join(f"{a:.4g}–{b:.4g}" for a, b in where["time_segments_s"]) or "—",
        ],
    ]
    table = _table(["", ""], rows)
    if diagnosis.attribution:
        effects = [
            [
                a.effect,
                ", ".join(f"{k} = {_num(v)}" for k, v in a.params.items()),
                a.shrinkage,
                "yes" if a.consistent_after else "no",
            ]
            for a in diagnosis.attribution
        ]
        table += _table(
            ["effect", "parameters", "gap shrinkage", "consistent after"],
            effects,
            caption="attribution, best first",
        )
    return _layout("Diagnosis", table, _png(lambda: diagnosis_figure(diagnosis, figsize=(6, 7))))
