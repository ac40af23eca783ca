"""The sim-to-real diagnosis section of the report (from :class:`allanite.diagnosis.Diagnosis`)."""

from __future__ import annotations

from typing import Any

from allanite.io.record import Record
from allanite.report import html as h

__all__ = ["channels_html", "diagnosis_html", "diagnosis_section", "run_diagnosis", "verdict_of"]


def run_diagnosis(record: Record, model: Any, channel: int = 0, **options: Any) -> Any:
    """Diagnose one channel of a record (its longest segment) against a noise model."""
    from allanite.diagnosis import diagnose

    part = record.longest_segment()
    return diagnose(
        part.samples[:, channel],
        model,
        fs=part.require_fs(),
        input=part.input,
        units=part.rate_unit(),
        **options,
    )


def _p(value: float, n_mc: int | None) -> str:
    """Format a Monte Carlo p-value; 0 means below the resolution 1/(n_mc + 1)."""
    if value <= 0 and n_mc:
        return f"< {1.0 / (n_mc + 1):.2g}"
    return h.fmt(value, 3)


def _ranges(items: list[Any], unit: str) -> str:
    if not items:
        return "none"
    out = []
    for item in items:
        if isinstance(item, (list, tuple)) and len(item) == 2:
            out.append(f"{h.fmt(item[0], 3)} … {h.fmt(item[1], 3)} {unit}")
        else:
            out.append(f"{h.fmt(item, 4)} {unit}")
    return "; ".join(out)


def verdict_of(diagnosis: Any) -> tuple[str, str]:
    """The one badge status and label of a diagnosis (as ``allanite diagnose`` words it).

    A significant gap is a FAIL of the simulated sensor whether or not the effects close it
    (then the label says so); no gap in the noise with something unexplained elsewhere (the
    time base, ...) is MARGINAL; no gap at all is a PASS.
    """
    closed = bool(getattr(diagnosis, "closed", False))
    if diagnosis.significant:
        return "fail", (
            "gap, closed by the effects below" if closed else "gap, not fully explained"
        )
    return (
        ("pass", "no gap") if closed else ("marginal", "no gap in the noise, not fully explained")
    )


def diagnosis_html(
    diagnosis: Any, *, channel: str, model_name: str, changes: list[str] | None = None
) -> str:
    """HTML of a diagnosis: verdict, per-view p-values, where the gap is and what explains it.

    One verdict with one badge (:func:`verdict_of`); ``changes`` (the config lines to change,
    ``old -> new``) are listed after the explanation when given.
    """
    text = (
        "the real record differs significantly from the simulated sensor"
        if diagnosis.significant
        else "the real record is consistent with the simulated sensor"
    )
    where = diagnosis.where
    n_mc = diagnosis.meta.get("n_mc")
    views = [
        [
            "averaging time (Allan variance)",
            _p(diagnosis.tau.p_value, n_mc),
            _ranges(where["tau_bands_s"], "s"),
        ],
        [
            "frequency (PSD, lines)",
            _p(diagnosis.frequency.p_value, n_mc),
            _ranges(where["frequency_bands_hz"], "Hz")
            + " · lines: "
            + _ranges(where["frequency_lines_hz"], "Hz"),
        ],
        [
            "time (jumps, bursts, warm-up)",
            _p(diagnosis.time.p_value, n_mc),
            _ranges(where["time_segments_s"], "s"),
        ],
    ]
    headline = getattr(diagnosis, "headline", "")
    status, label = verdict_of(diagnosis)
    parts = [
        f'<p class="verdict">{h.badge(status)} <b>{h.escape(label)}</b>'
        + (f": {h.escape(headline)}" if headline else "")
        + "</p>"
    ]
    if getattr(diagnosis, "unexplained", None):
        rows_u = [[u.view, u.evidence, u.text, _p(u.p_value, None)] for u in diagnosis.unexplained]
        parts.append("<h3>What no candidate explains</h3>")
        parts.append(h.table(["view", "evidence", "where and how large", "p-value"], rows_u,
                             text_columns=3))  # fmt: skip
    parts += [
        f"<p>Channel <b>{h.escape(channel)}</b> against model "
        f"<b>{h.escape(model_name)}</b>: {h.escape(text)} "
        f"(combined p = {_p(diagnosis.p_value, n_mc)}, "
        f"gap G = {h.fmt(diagnosis.statistic, 3)}).</p>",
        h.table(["view", "p-value", "where the gap is"], views, text_columns=1),
    ]
    units = diagnosis.meta.get("units")
    scan, steps = diagnosis.time.steps, diagnosis.level_steps
    if steps and scan is not None:
        parts.append(f"<h3>Level steps (p = {_p(scan.p_value, None)})</h3>")
        items = "".join(f"<li>{h.escape(s.text(units))}</li>" for s in steps)
        parts.append(f"<ul>{items}</ul>")
    if diagnosis.attribution:
        from allanite.diagnosis.verdict import format_params, percent

        rows = [
            [
                a.effect,
                format_params(a, units, fs=diagnosis.meta.get("fs"), sigma=True),
                percent(a.shrinkage),
                "yes" if a.consistent_after else "no",
                ", ".join(a.alternatives) or "–",
            ]
            for a in diagnosis.attribution[:6]
        ]
        parts.append("<h3>What explains the gap (best first)</h3>")
        parts.append(
            h.table(
                [
                    "effect",
                    "fitted parameters",
                    "gap explained",
                    "consistent after",
                    "indistinguishable from",
                ],
                rows,
                text_columns=2,
            )
        )
    if diagnosis.holdout is not None:
        hold = diagnosis.holdout
        share = "–" if hold.gap_before <= 0 else percent(hold.shrinkage)
        text = (
            f"{h.escape(hold.effect)} explains {share} of the gap there."
            if hold.checkable
            else f"{h.escape(hold.effect)} is not checkable on the held-out part."
        )
        parts.append(
            f"<p>Held-out check ({h.escape(hold.source)}, {hold.n_samples:,} samples): "
            + (h.escape(hold.note) if hold.note else text)
            + "</p>"
        )
    explanation = getattr(diagnosis, "explanation", None)
    if explanation is not None and diagnosis.attribution:
        model = diagnosis.meta.get("sim") != "record"
        parts.append(_explanation_html(explanation, units, diagnosis.meta.get("fs"), model))
    if changes:
        items = "".join(f"<li><code>{h.escape(c)}</code></li>" for c in changes)
        parts.append(f"<h3>To close the gap, change in {h.escape(model_name)}</h3><ul>{items}</ul>")
    return "".join(parts)


def channels_html(items: list[tuple[str, Any, list[str]]], *, model_name: str) -> str:
    """Every diagnosed channel: an overview (one verdict each), then each channel's section.

    ``items`` are ``(channel name, diagnosis, config changes)``; a diagnosis of None is a
    channel that could not be diagnosed, its reason the one change line.
    """
    rows = []
    sections = []
    for name, diagnosis, changes in items:
        if diagnosis is None:
            why = changes[0] if changes else "not diagnosed"
            rows.append([h.escape(name), "–", h.escape(f"not diagnosed: {why}"), "–"])
            continue
        status, label = verdict_of(diagnosis)
        headline = getattr(diagnosis, "headline", "")
        rows.append(
            [h.escape(name), h.badge(status),
             h.escape(f"{label}: {headline}" if headline else label),
             h.escape(_p(diagnosis.p_value, diagnosis.meta.get("n_mc")))]
        )  # fmt: skip
        sections.append(
            f"<h3>Channel {h.escape(name)}</h3>"
            + diagnosis_html(diagnosis, channel=name, model_name=model_name, changes=changes)
        )
    overview = (
        f"<p>Every channel against <b>{h.escape(model_name)}</b>, one verdict each:</p>"
        + h.table(["channel", "verdict", "headline", "combined p"], rows, text_columns=3, raw=True)
    )
    return overview + "".join(sections)


def _explanation_html(e: Any, units: str | None, fs: float | None, model: bool) -> str:
    """The joint explanation: the set with shares, its gap, held-out check and term list."""
    import json

    from allanite.diagnosis.verdict import format_params, percent, terms_label

    rows = [
        [a.effect, format_params(a, units, fs=fs), percent(e.share.get(a.effect, 0.0))]
        for a in e.effects
    ]
    after = "consistent with chance" if e.consistent_after else "a gap remains"
    out = [
        "<h3>The effects together (joint explanation)</h3>",
        h.table(["effect", "fitted parameters", "share of the gap"], rows, text_columns=2),
        f"<p>Gap G {h.fmt(e.gap_before, 4)} → {h.fmt(e.gap_after, 4)} with all of them "
        f"(tau view: {after}, p = {h.fmt(e.p_after, 2)}; remainder "
        f"{percent(e.share.get('remainder', 0.0))}).</p>",
    ]
    hold = e.holdout
    if hold is not None and hold.get("note"):
        out.append(f"<p>{h.escape(str(hold['note']))}</p>")
    elif hold is not None:
        shrink = "–" if hold.get("gap_before", 0.0) <= 0 else percent(hold["shrinkage"])
        out.append(
            f"<p>Held-out check of the set ({h.escape(hold.get('source', ''))}, "
            f"{int(hold.get('n_samples', 0)):,} samples): the effects explain {shrink} of the "
            "gap there"
            + (", consistent with chance" if hold.get("consistent_after") else "")
            + ".</p>"
        )
    if e.terms:
        out.append(
            f"<p>{h.escape(terms_label(model))}, ready to paste:</p>"
            f"<pre>{h.escape(json.dumps(e.terms, allow_nan=False))}</pre>"
        )
    return "".join(out)


def diagnosis_section(
    record: Record,
    model: Any,
    channel: int = 0,
    *,
    model_name: str | None = None,
    **options: Any,
) -> tuple[str, dict[str, Any]]:
    """Run the diagnosis of ``record`` against a model (or model file) and render it.

    ``model_name`` names the model in the section (default: the file name of a path).
    """
    from pathlib import Path

    if model_name is None:
        model_name = Path(model).name if isinstance(model, (str, Path)) else "the model"
    diagnosis = run_diagnosis(record, model, channel, **options)
    html = diagnosis_html(diagnosis, channel=record.channels[channel], model_name=model_name)
    figures: dict[str, Any] = {}
    try:
        from allanite.plot.diagnosis import diagnosis_figure
    except ImportError:
        return html, figures
    figures["views"] = diagnosis_figure(diagnosis)
    return html, figures
