"""Assemble the HTML report of one or more analysed records.

Sections: record summary, Allan deviation plot (all channels, reference overlaid), fitted
model plots with each term's slope, coefficient table in customary units with intervals,
slope table, Allan deviation table, comparison against a reference device and datasheet limits
with pass/fail, and the sim-to-real diagnosis when one is given.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from allanite.confidence import DEFAULT_LEVEL
from allanite.datasheet import Check, Datasheet, adev_at, check_limits, undetected_measured
from allanite.datasheet import verdict as checks_verdict
from allanite.io.atomic import atomic_output
from allanite.io.record import Record
from allanite.report import html as h
from allanite.report.coefficients import CoefficientRow, ambiguous_rows, coefficient_table
from allanite.slopes import MIN_EDF, slope_table
from allanite.units import sensor_kind
from allanite.variance import AllanResult

__all__ = ["DeviceAnalysis", "Report", "build_report"]

_TABLE_ROWS = 14


@dataclass(frozen=True)
class DeviceAnalysis:
    """What the report shows of one record: the record, its Allan result, optional fits.

    ``fits`` holds one fit result (or None) per channel of ``result``; ``thermal`` one
    :class:`~allanite.fit.thermal.ThermalFit` per channel when the record had a temperature
    (``record`` is then the compensated record the noise was analysed on).
    """

    record: Record
    result: AllanResult
    fits: tuple[Any, ...] = ()
    name: str = ""
    thermal: tuple[Any, ...] = ()

    @property
    def label(self) -> str:
        """Display name: ``name`` or the file name."""
        return self.name or Path(self.record.source).name

    def fit(self, channel: int) -> Any:
        """Fit result of ``channel`` or None."""
        return self.fits[channel] if channel < len(self.fits) else None


@dataclass(frozen=True)
class Report:
    """A rendered report: the HTML, the datasheet checks and the figures."""

    html: str
    checks: tuple[Check, ...] = ()
    figures: dict[str, Any] = field(default_factory=dict, compare=False)

    @property
    def passed(self) -> bool:
        """False when any datasheet check failed outright."""
        return all(c.passed for c in self.checks)

    def write(self, path: str | os.PathLike[str]) -> None:
        """Write the HTML atomically."""
        with atomic_output(path) as tmp:
            tmp.write_text(self.html, encoding="utf-8")

    def export_figures(self, stem: str | os.PathLike[str], fmt: str) -> list[Path]:
        """Save every figure as ``<stem>-<name>.<fmt>`` (png or pdf); return the paths."""
        from allanite.plot import save_figure

        paths = []
        base = Path(stem)
        for name, fig in self.figures.items():
            path = base.with_name(f"{base.name}-{name}.{fmt}")
            save_figure(fig, path)
            paths.append(path)
        return paths

    def to_dict(self) -> dict[str, Any]:
        """Verdict and checks as JSON-ready data."""
        return {"passed": self.passed, "checks": [c.to_dict() for c in self.checks]}


def _summary_rows(device: DeviceAnalysis) -> list[list[str]]:
    r = device.record
    rows = [
        ["file", r.source],
        ["channels", ", ".join(r.channels)],
        ["samples", f"{r.n_samples:,}"],
        ["sampling frequency", f"{r.fs:g} Hz" if r.fs else "unknown"],
        ["duration", _duration(r.duration)],
        ["input", r.input],
        [
            "units",
            r.units
            or "not given: coefficients and deviations are in the record's own units "
            "(give --units for physical units)",
        ],
        ["sensor", _sensor_of(device.result.units)],
        ["mean (static bias; gravity on an accelerometer)", _means(r)],
    ]
    if r.scale is not None:
        rows.append(["scale (counts → units)", f"{r.scale:g}"])
    if r.timing is not None:
        t = r.timing
        rows.append(
            [
                "time stamps",
                f"jitter {100 * t.jitter_relative:.3g} % rms, {len(t.gaps)} gap(s)"
                + (f", {t.filled} sample(s) filled" if t.filled else ""),
            ]
        )
    if len(r.segments) > 1:
        longest = max(r.segments, key=lambda s: s.n_samples)
        rows.append(
            [
                "segments",
                f"{len(r.segments)}; the longest ({longest.n_samples:,} samples) is analysed",
            ]
        )
    res = device.result
    rows.append(
        [
            "estimator",
            f"{res.kind} ({res.tau.size} averaging times, {res.tau[0]:.3g} … {res.tau[-1]:.4g} s)",
        ]
    )
    return rows


def _means(record: Any) -> str:
    """Each channel's mean in the record's unit: a gyro's static bias, an accelerometer's 1 g.

    For an accelerometer triad the magnitude of the mean follows (1 g at rest).
    """
    part = record.longest_segment()
    means = [float(np.mean(part.samples[:, c], dtype=np.float64)) for c in range(part.n_channels)]
    unit = f" {record.units}" if record.units else ""
    text = ", ".join(f"{name} {m:.6g}{unit}" for name, m in zip(part.channels, means, strict=True))
    if len(means) == 3 and _sensor_of(record.units) == "accelerometer":
        text += f"; magnitude {float(np.linalg.norm(means)):.6g}{unit}"
    return text


def _sensor_of(rate: str | None) -> str:
    """``gyro``, ``accelerometer`` or ``unknown`` (record without a unit)."""
    if rate is None:
        return "unknown"
    try:
        return sensor_kind(rate)
    except ValueError:
        return "unknown"


def _duration(seconds: float | None) -> str:
    if seconds is None:
        return "unknown"
    if seconds >= 3600:
        return f"{seconds / 3600:.3g} h ({seconds:,.0f} s)"
    if seconds >= 60:
        return f"{seconds / 60:.3g} min ({seconds:,.0f} s)"
    return f"{seconds:.3g} s"


def _curve_labels(device: DeviceAnalysis, multi: bool) -> list[str]:
    prefix = f"{device.label}: " if multi else ""
    return [f"{prefix}{c}" for c in device.record.channels]


def _allan_figures(
    devices: Sequence[DeviceAnalysis], reference: DeviceAnalysis | None, level: float
) -> dict[str, Any]:
    """One Allan deviation figure per unit (a six-axis record: gyro and accelerometer)."""
    from allanite.plot import allan_figure

    items = list(devices) + ([reference] if reference is not None else [])
    labels: list[list[str]] = []
    for k, d in enumerate(items):
        names = _curve_labels(d, len(items) > 1)
        if reference is not None and k == len(items) - 1:
            names = [f"reference {d.label}: {c}" for c in d.record.channels]
        labels.append(names)
    groups: dict[str | None, list[int]] = {}
    for k, d in enumerate(items):
        groups.setdefault(d.result.units, []).append(k)
    figures = {}
    for g, (unit, members) in enumerate(groups.items()):
        title = f"Allan deviation with {100 * level:.3g} % confidence intervals"
        if len(groups) > 1:
            title = f"{_sensor_of(unit)} ({unit}): " + title
        figures["adev" if g == 0 else f"adev-{g + 1}"] = allan_figure(
            [items[k].result for k in members],
            labels=[name for k in members for name in labels[k]],
            level=level,
            title=title,
        )
    return figures


def _pick_rows(n: int) -> np.ndarray:
    if n <= _TABLE_ROWS:
        return np.arange(n)
    return np.unique(np.rint(np.linspace(0, n - 1, _TABLE_ROWS)).astype(int))


def _adev_table(device: DeviceAnalysis, level: float) -> str:
    res = device.result
    dev = res.dev.reshape(res.tau.size, -1)
    lo, hi = (a.reshape(dev.shape) for a in res.ci(level))
    unit = res.units or "rate units"
    header = ["τ [s]"]
    for name in device.record.channels:
        header += [f"{name} [{unit}]", f"{name} interval"]
    rows = []
    for k in _pick_rows(res.tau.size):
        row = [h.fmt(res.tau[k])]
        for c in range(dev.shape[1]):
            row += [h.fmt(dev[k, c]), f"{h.fmt(lo[k, c])} … {h.fmt(hi[k, c])}"]
        rows.append(row)
    return h.table(header, rows, text_columns=0)


def _fit_column(symbol: str, fitted: set[str] | None) -> list[str]:
    """The slope table's "in the fitted model" cell: yes, or why the term is absent."""
    if fitted is None:
        return []
    if symbol in fitted:
        return ["yes"]
    if symbol == "B":
        return [
            "no: the fitted model follows this flat stretch with its neighbouring terms (the "
            "bottom of the curve between the N and K slopes), so its selection found no B term "
            "significant; the minimum is not a bias-instability plateau"
        ]
    return [f"no: the fit's term selection found no significant {symbol} term"]


def _slope_section(device: DeviceAnalysis) -> str:
    res = device.result
    dev = res.dev.reshape(res.tau.size, -1)
    edf = res.edf.reshape(dev.shape)
    parts = []
    sensor = _sensor_of(res.units)
    for c, name in enumerate(device.record.channels):
        fit = device.fit(c)
        model = getattr(fit, "model", fit)  # a FitResult or a NoiseModel
        fitted = None if model is None else {t.symbol for t in model.terms}
        rows = [
            [
                f"{r.tau_min:.3g} … {r.tau_max:.4g}",
                r.term,
                r.symbol,
                r.label,
                f"{r.slope:+.2f}",
                str(r.n_points),
                *_fit_column(r.symbol, fitted),
            ]
            for r in slope_table(res.tau, dev[:, c], edf[:, c], sensor=sensor)
        ]
        header = ["τ range [s]", "dominant term", "symbol", "slope", "measured slope", "points"]
        parts.append(f"<h3>{h.escape(device.label)} — {h.escape(name)}</h3>")
        parts.append(
            h.table(
                header + ([] if fitted is None else ["in the fitted model"]),
                rows,
                text_columns=3,
            )
        )
    return "".join(parts)


def _coefficient_section(
    devices: Sequence[DeviceAnalysis], coefficients: dict[tuple[int, int], list[CoefficientRow]]
) -> str:
    if not coefficients:
        return (
            '<p class="note">No noise model was fitted: the fit was switched off (--no-fit), '
            "the estimator is not the overlapping Allan variance the fit models, or no fitter "
            "is installed.</p>"
        )
    parts = []
    for (d, c), coefs in coefficients.items():
        device = devices[d]
        rate = device.result.units
        what = f"{_sensor_of(rate)}, {rate}" if rate else "record units: no --units given"
        suffix = "" if what in device.label else f" ({h.escape(what)})"
        parts.append(
            f"<h3>{h.escape(device.label)} — {h.escape(device.record.channels[c])}{suffix}</h3>"
        )
        rows = [
            [
                k.quantity or k.term,
                k.symbol,
                h.fmt(k.value),
                "–" if k.low != k.low else f"{h.fmt(k.low)} … {h.fmt(k.high)}",
                k.unit,
                k.slope or "–",
            ]
            for k in (*coefs, *ambiguous_rows(device.fit(c), rate))
        ]
        parts.append(
            h.table(
                ["quantity", "symbol", "value", "interval", "unit", "ADEV slope"],
                rows,
                text_columns=2,
            )
        )
        parts.append(_goodness(device.fit(c)))
    return "".join(parts)


#: p-value of the fit's chi-square below which the report warns that the model misfits
MISFIT_P = 0.001


def _goodness(fit: Any) -> str:
    """Goodness of fit of a FitResult; a rejected model is said plainly, in red."""
    chi2, dof, p = (getattr(fit, k, None) for k in ("chi2", "dof", "p_value"))
    if chi2 is None or dof is None or p is None or p != p:
        return ""
    text = (
        f"Generalised χ² = {chi2:.4g} for {dof} degrees of freedom (correlations between τ "
        f"accounted for), p = {p:.2g}."
    )
    rejected = getattr(fit, "rejected", p < MISFIT_P)
    note = getattr(fit, "ambiguity_note", None)
    ambiguous = "" if note is None else note()
    undetected = getattr(fit, "undetected_line", None)  # the left-out terms' upper limits
    if undetected is not None and undetected():
        ambiguous = "\n".join(x for x in (ambiguous, undetected()) if x)
    ambiguous = "".join(f'<p class="note">{h.escape(line)}</p>' for line in ambiguous.splitlines())
    if rejected:
        missed = getattr(fit, "missed_taus", None)
        where = (
            ""
            if missed is None or len(missed) == 0
            else " Missed at τ = " + ", ".join(f"{t:.3g}" for t in missed) + " s."
        )
        return (
            f'<div class="rejected">Model REJECTED: {h.escape(text)} The fitted terms do not '
            "describe this Allan curve within its uncertainty, so its coefficients are not "
            f"trustworthy; look at the model plot before using them.{h.escape(where)}</div>"
            + ambiguous
        )
    return f'<p class="note">{h.escape(text)} Model not rejected.</p>' + ambiguous


def _rate_adev(device: DeviceAnalysis, channel: int, level: float) -> tuple[Any, ...]:
    res = device.result.channel(min(channel, device.result.n_channels - 1))
    lo, hi = res.ci(level)
    return res.tau, res.dev, lo, hi, res.units


def _datasheet_section(
    sheet: Datasheet,
    devices: Sequence[DeviceAnalysis],
    coefficients: dict[tuple[int, int], list[CoefficientRow]],
    level: float,
) -> tuple[str, list[Check]]:
    checks: list[Check] = []
    for d, device in enumerate(devices):
        for c, name in enumerate(device.record.channels):
            measured = {k.symbol: k.measured() for k in coefficients.get((d, c), [])}
            label = f"{device.label}: {name}" if len(devices) > 1 else name
            bounds = undetected_measured(device.fit(c), level)
            checks += check_limits(sheet, label, measured, _rate_adev(device, c, level), bounds)
    verdict = checks_verdict(c.status for c in checks)
    rows = [
        [
            c.channel,
            c.limit.label,
            c.limit.bounds_text(),
            h.fmt(c.value),
            f"≤ {h.fmt(c.upper)} (not detected)"
            if c.upper is not None
            else "–"
            if c.low is None
            else f"{h.fmt(c.low)} … {h.fmt(c.high)}",
            h.badge(c.status),
        ]
        for c in checks
    ]
    body = (
        f'<p class="verdict">Against <b>{h.escape(sheet.device)}</b>: {h.badge(verdict)}</p>'
        + h.table(
            ["channel", "quantity", "limit", "measured", "interval", "result"],
            [[h.escape(v) if k < 5 else v for k, v in enumerate(r)] for r in rows],
            text_columns=3,
            raw=True,
        )
        + '<p class="note">PASS: the whole confidence interval meets the limit; MARGINAL: the '
        "estimate meets it but the interval crosses it; FAIL: the estimate violates it; "
        "UNDETERMINED: a term the fit did not detect whose upper limit lies above the limit "
        "(below it: PASS); MISSING: the quantity was not measured (no such fitted term or τ "
        "outside the measured range).</p>"
    )
    return body, checks


def _reference_section(
    devices: Sequence[DeviceAnalysis], reference: DeviceAnalysis, level: float
) -> str:
    ref = reference.result
    parts = []
    for device in devices:
        for c, name in enumerate(device.record.channels):
            tau, dev, lo, hi, unit = _rate_adev(device, c, level)
            rtau, rdev, rlo, rhi, _ = _rate_adev(reference, c, level)
            lo_tau, hi_tau = max(tau[0], rtau[0]), min(tau[-1], rtau[-1])
            decades = 10.0 ** np.arange(np.ceil(np.log10(lo_tau)), np.floor(np.log10(hi_tau)) + 1)
            rows = []
            for t in decades:
                a = adev_at(tau, dev, lo, hi, float(t))
                b = adev_at(rtau, rdev, rlo, rhi, float(t))
                if a is None or b is None:
                    continue
                verdict = "higher" if a[1] > b[2] else "lower" if a[2] < b[1] else "consistent"
                rows.append([h.fmt(t), h.fmt(a[0]), h.fmt(b[0]), f"{a[0] / b[0]:.3g}", verdict])
            ref_name = reference.record.channels[min(c, ref.n_channels - 1)]
            parts.append(
                f"<h3>{h.escape(device.label)} — {h.escape(name)} vs reference "
                f"{h.escape(reference.label)} — {h.escape(ref_name)}</h3>"
            )
            parts.append(
                h.table(
                    ["τ [s]", f"device [{unit}]", f"reference [{unit}]", "ratio", "intervals"],
                    rows,
                    text_columns=0,
                )
            )
            parts.append(_coefficient_comparison(device, reference, c))
    parts.append(
        '<p class="note">"higher"/"lower": the confidence intervals do not overlap; '
        '"consistent": they do.</p>'
    )
    return "".join(parts)


def _coefficient_comparison(device: DeviceAnalysis, reference: DeviceAnalysis, channel: int) -> str:
    """Fitted coefficients of the device next to the reference's (when both were fitted)."""
    fit = device.fit(channel)
    ref_fit = reference.fit(min(channel, reference.result.n_channels - 1))
    if fit is None or ref_fit is None:
        return ""
    mine = {(k.term, k.symbol): k for k in coefficient_table(fit, device.result.units)}
    theirs = {(k.term, k.symbol): k for k in coefficient_table(ref_fit, reference.result.units)}
    rows = []
    for key in [k for k in mine if k in theirs]:
        a, b = mine[key], theirs[key]
        if a.unit != b.unit:
            continue
        ratio = f"{a.value / b.value:.3g}" if b.value else "–"
        rows.append([a.term, a.symbol, h.fmt(a.value), h.fmt(b.value), a.unit, ratio])
    if not rows:
        return '<p class="note">The fitted models share no coefficient to compare.</p>'
    return h.table(["term", "symbol", "device", "reference", "unit", "ratio"], rows, text_columns=2)


def _fit_figures(devices: Sequence[DeviceAnalysis], level: float) -> dict[str, Any]:
    from allanite.plot import model_figure

    figures = {}
    for d, device in enumerate(devices):
        for c, name in enumerate(device.record.channels):
            fit = device.fit(c)
            if fit is None:
                continue
            key = f"fit-{d}-{c}" if len(devices) > 1 else f"fit-{c}"
            figures[key] = model_figure(
                device.result,
                fit,
                channel=c,
                labels=list(device.record.channels),
                level=level,
                title=f"{device.label} — {name}: fitted noise model and its terms",
            )
    return figures


def _summary_section(devices: Sequence[DeviceAnalysis]) -> str:
    """Record summary: file, channels, samples, fs, units, estimator; the reader's warnings."""
    summary = "".join(
        (f"<h3>{h.escape(d.label)}</h3>" if len(devices) > 1 else "")
        + h.table(None, _summary_rows(d), text_columns=2, css_class="summary")
        + "".join(f'<div class="warn">{h.escape(w)}</div>' for w in d.record.warnings)
        for d in devices
    )
    return h.section("Record summary", summary, anchor="summary")


def _allan_section(figures: dict[str, Any], level: float) -> str:
    """The Allan deviation plots (with the level of their error bars) and the fitted models."""
    from allanite.plot import figure_bytes

    return h.section(
        "Allan deviation",
        "".join(
            h.figure(
                figure_bytes(fig),
                f"Error bars: {100 * level:.3g} % chi-square confidence intervals "
                "from the equivalent degrees of freedom.",
                "Allan deviation plot",
            )
            for key, fig in figures.items()
            if key.startswith("adev")
        )
        + "".join(
            h.figure(
                figure_bytes(fig),
                "Dashed: each term's exact Allan deviation with its "
                "log-log slope; black: their sum.",
                f"fitted model {key}",
            )
            for key, fig in figures.items()
            if key.startswith("fit")
        ),
        anchor="adev",
    )


def _slope_table_section(devices: Sequence[DeviceAnalysis]) -> str:
    """Measured log-log slopes per band, assigned to the canonical noise terms."""
    return h.section(
        "Slope table",
        "".join(_slope_section(d) for d in devices)
        + '<p class="note">Least-squares log-log slope in a half-decade window, '
        "assigned to the nearest canonical slope (IEEE Std 952-1997, Annex C); points "
        f"with fewer than {MIN_EDF:g} equivalent degrees of freedom are left out.</p>",
        anchor="slopes",
    )


def _adev_table_section(devices: Sequence[DeviceAnalysis], level: float) -> str:
    """The Allan deviation of every device as a table with its intervals."""
    return h.section(
        "Allan deviation table",
        "".join(
            (f"<h3>{h.escape(d.label)}</h3>" if len(devices) > 1 else "") + _adev_table(d, level)
            for d in devices
        ),
        anchor="table",
    )


def _thermal_section(devices: Sequence[DeviceAnalysis], figures: dict[str, Any]) -> str:
    """Bias against temperature: each channel's thermal fit as text and as a figure.

    The figures are added to ``figures`` (``thermal-<device>-<channel>``).
    """
    parts = []
    for d, device in enumerate(devices):
        for c, fit in enumerate(device.thermal):
            if fit is None:
                continue
            lines = "\n".join(fit.lines())
            parts.append(f"<h3>{h.escape(device.label)}: {h.escape(fit.channel)}</h3>")
            parts.append(f"<pre>{h.escape(lines)}</pre>")
            try:
                from allanite.plot import figure_bytes
                from allanite.plot.thermal import thermal_figure
            except ImportError:  # no plot extra: the text alone
                continue
            fig = thermal_figure(device.record, fit, c, compensated=True)
            figures[f"thermal-{d}-{c}"] = fig
            parts.append(
                h.figure(
                    figure_bytes(fig),
                    f"Bias of {fit.channel} against temperature: block means of the record and "
                    "the fitted law (the noise terms are fitted on the compensated record).",
                    f"thermal {fit.channel}",
                )
            )
    return h.section("Bias against temperature", "".join(parts), anchor="thermal")


def _diagnosis_section(diagnosis_html: str, figures: dict[str, Any]) -> str:
    """The sim-to-real diagnosis text followed by its figures."""
    from allanite.plot import figure_bytes

    extra = "".join(
        h.figure(
            figure_bytes(fig),
            f"Sim-vs-real {name}: real record against the Monte Carlo "
            "band of the simulated sensor.",
            f"diagnosis {name}",
        )
        for name, fig in figures.items()
    )
    return h.section("Sim-to-real diagnosis", diagnosis_html + extra, anchor="diagnosis")


def build_report(
    devices: Sequence[DeviceAnalysis],
    *,
    reference: DeviceAnalysis | None = None,
    datasheet: Datasheet | None = None,
    diagnosis_html: str | None = None,
    diagnosis_figures: dict[str, Any] | None = None,
    level: float = DEFAULT_LEVEL,
    title: str | None = None,
) -> Report:
    """Render the report.

    Parameters
    ----------
    devices : sequence of DeviceAnalysis
        The analysed records (their channels are overlaid in one plot).
    reference : DeviceAnalysis, optional
        A reference device, overlaid and compared point by point.
    datasheet : Datasheet, optional
        Limits to check every channel against (pass / marginal / fail / missing).
    diagnosis_html : str, optional
        Ready HTML of the sim-to-real diagnosis section.
    diagnosis_figures : dict, optional
        Figures of the diagnosis (embedded after its text).
    level : float
        Confidence level of every interval.
    title : str, optional
        Page title.

    Returns
    -------
    Report
    """
    from allanite import __version__

    if not devices:
        raise ValueError("a report needs at least one analysed record")
    figures: dict[str, Any] = _allan_figures(devices, reference, level)
    figures.update(_fit_figures(devices, level))
    coefficients = {
        (d, c): coefficient_table(device.fit(c), device.result.units, level)
        for d, device in enumerate(devices)
        for c in range(device.result.n_channels)
        if device.fit(c) is not None
    }
    body: list[str] = []
    checks: list[Check] = []
    sheet_html = ""
    if datasheet is not None:
        sheet_html, checks = _datasheet_section(datasheet, devices, coefficients, level)
        verdict = checks_verdict(c.status for c in checks)
        body.append(
            f'<p class="verdict">Datasheet check ({h.escape(datasheet.device)}): '
            f"{h.badge(verdict)}</p>"
        )
    body.append(_summary_section(devices))
    # the answer first: coefficients on the first screen, the curve they come from next
    body.append(
        h.section(
            "Noise coefficients", _coefficient_section(devices, coefficients), anchor="coefficients"
        )
    )
    body.append(_allan_section(figures, level))
    if any(fit is not None for device in devices for fit in device.thermal):
        body.append(_thermal_section(devices, figures))
    body.append(_slope_table_section(devices))
    body.append(_adev_table_section(devices, level))
    if datasheet is not None:
        body.append(h.section("Datasheet comparison", sheet_html, anchor="datasheet"))
    if reference is not None:
        body.append(
            h.section(
                "Comparison with the reference device",
                _reference_section(devices, reference, level),
                anchor="reference",
            )
        )
    if diagnosis_html is not None:
        body.append(_diagnosis_section(diagnosis_html, diagnosis_figures or {}))
        figures.update({f"diagnosis-{k}": v for k, v in (diagnosis_figures or {}).items()})
    stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    page_title = title or "Noise report: " + ", ".join(d.label for d in devices)
    subtitle = f"allanite {__version__} · {stamp} · confidence level {100 * level:.3g} %"
    return Report(
        html=h.document(page_title, subtitle, "".join(body)), checks=tuple(checks), figures=figures
    )


def with_fits(device: DeviceAnalysis, fits: Sequence[Any]) -> DeviceAnalysis:
    """Return a copy of ``device`` with per-channel fit results attached."""
    return dataclasses.replace(device, fits=tuple(fits))
