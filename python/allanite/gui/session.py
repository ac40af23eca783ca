"""The state behind the GUI, free of Qt: a file, its options, the results, fits and diagnosis.

Keeping the logic here lets it be tested without a display and keeps the window a thin view:
every button calls one method of :class:`Session` and redraws from its attributes.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from allanite.confidence import DEFAULT_LEVEL
from allanite.io.options import ReadOptions
from allanite.io.readers import read_record
from allanite.io.record import Record
from allanite.units import convert, rate_unit, sensor_kind
from allanite.variance import AllanResult, avar

__all__ = ["DISPLAY_UNITS", "RECORD_UNITS", "Options", "Session", "display_units_for"]

#: rate units offered for display (converted from the record's unit): gyro, then accelerometer
DISPLAY_UNITS: tuple[str, ...] = (
    "as recorded",
    "deg/s",
    "deg/h",
    "rad/s",
    "mrad/s",
    "m/s^2",
    "g",
    "mg",
    "ug",
)
#: units offered for a record's samples (rate, angle/increment; gyro and accelerometer)
RECORD_UNITS: tuple[str, ...] = (
    "deg/s",
    "rad/s",
    "deg/h",
    "dph",
    "deg",
    "rad",
    "m/s^2",
    "g",
    "mg",
    "m/s",
    "",
)


def display_units_for(rate: str | None) -> tuple[str, ...]:
    """The display units that suit a record in ``rate``: those of the same sensor.

    A gyro record is offered deg/s, deg/h, ...; an accelerometer record m/s^2, g, mg, ug; a
    record without a unit only "as recorded".
    """
    if rate is None:
        return DISPLAY_UNITS[:1]
    kind = sensor_kind(rate)
    return DISPLAY_UNITS[:1] + tuple(
        u for u in DISPLAY_UNITS[1:] if kind != "unknown" and sensor_kind(u) == kind
    )


@dataclass
class Options:
    """What the user set in the side panel."""

    fs: float | None = None
    points: int = 100
    input: str = "rate"
    units: str | None = None
    scale: float | None = None
    time_column: str | None = None
    gaps: str = "error"
    key: str | None = None
    kind: str = "overlapping"
    level: float = DEFAULT_LEVEL
    n_mc: int = 200


@dataclass
class Session:
    """A loaded record and what was computed from it."""

    options: Options = field(default_factory=Options)
    path: Path | None = None
    record: Record | None = None
    result: AllanResult | None = None
    fits: dict[int, Any] = field(default_factory=dict)
    diagnosis: Any = None
    diagnosis_channel: int = 0
    model_path: Path | None = None

    def load(self, path: str | Path) -> Record:
        """Read ``path`` with the current options (fs may come from a time column)."""
        o = self.options
        time_column: int | str | None = o.time_column
        if isinstance(time_column, str) and time_column.lstrip("-").isdigit():
            time_column = int(time_column)
        reader = ReadOptions(
            fs=o.fs,
            input=o.input,
            units=o.units,
            scale=o.scale,
            time_column=time_column or None,
            gaps=o.gaps,
            key=o.key or None,
        )
        record = read_record(path, reader)
        self.path = Path(path)
        self.record = record
        self.result = None
        self.fits = {}
        self.diagnosis = None
        return record

    def use_record(self, record: Record | None) -> None:
        """Work on an already built record (e.g. the example); None: no record."""
        self.path = None
        self.record = record
        self.result = None
        self.fits = {}
        self.diagnosis = None

    def _require_record(self) -> Record:
        if self.record is None:
            raise ValueError("open a record file first")
        return self.record

    def compute(self) -> AllanResult:
        """Allan deviation of every channel on the log grid with ``options.points`` points."""
        record = self._require_record()
        o = self.options
        fs = o.fs if o.fs is not None else record.fs
        if fs is None:
            raise ValueError("set the sampling frequency (Hz) or a time column")
        if record.fs != fs:
            record = dataclasses.replace(record, fs=fs)
            self.record = record
        part = record.longest_segment()
        self.result = avar(
            part.samples,
            fs=fs,
            input=part.input,  # type: ignore[arg-type]
            kind=o.kind,  # type: ignore[arg-type]
            points=o.points,
            units=part.rate_unit(),
        )
        self.fits = {}
        return self.result

    def fit(self, channel: int) -> Any:
        """Fit a noise model to one channel (None unless the estimator is the overlapping AVAR).

        The fit models the overlapping Allan variance's covariance, so other kinds get no fit.
        """
        from allanite.fit import fit

        result = self.result if self.result is not None else self.compute()
        if channel not in self.fits:
            one = result.channel(channel)
            self.fits[channel] = fit(one) if one.kind == "overlapping" else None
        return self.fits[channel]

    def diagnose(self, model_path: str | Path, channel: int) -> Any:
        """Diagnose one channel against a noise-model JSON file."""
        from allanite.report.diagnosis import run_diagnosis

        record = self._require_record()
        self.model_path = Path(model_path)
        self.diagnosis = run_diagnosis(record, str(model_path), channel, n_mc=self.options.n_mc)
        self.diagnosis_channel = channel
        return self.diagnosis

    def display_result(self, unit: str) -> AllanResult:
        """Return the result converted to a display rate unit (``"as recorded"`` keeps it)."""
        result = self.result if self.result is not None else self.compute()
        if unit == "as recorded" or result.units in (None, unit):
            return result
        rate_unit(unit)
        factor = convert(1.0, result.units, unit)  # refuses a unit of another sensor
        return dataclasses.replace(result, var=result.var * factor**2, units=unit)

    def report_html(self, channels: list[int]) -> Any:
        """Build the HTML report of the selected channels (fits and diagnosis included)."""
        from allanite.report import DeviceAnalysis, build_report
        from allanite.report.diagnosis import diagnosis_html

        record = self._require_record()
        result = self.result if self.result is not None else self.compute()
        chosen = channels or list(range(record.n_channels))
        sub_record = record.select(list[int | str](chosen))
        if result.n_channels == 1:
            sub_result = result
        else:
            sub_result = dataclasses.replace(
                result,
                var=result.var[:, chosen],
                edf=result.edf[:, chosen],
                alpha=result.alpha[:, chosen],
            )
            if len(chosen) == 1:
                sub_result = sub_result.channel(0)
        fits = tuple(self.fits.get(c) for c in chosen)
        device = DeviceAnalysis(sub_record, sub_result, fits)
        diag_html = None
        diag_figures = None
        if self.diagnosis is not None and self.model_path is not None:
            diag_html = diagnosis_html(
                self.diagnosis,
                channel=record.channels[self.diagnosis_channel],
                model_name=self.model_path.name,
            )
            try:
                from allanite.plot.diagnosis import diagnosis_figure
            except ImportError:
                diag_figures = None
            else:
                diag_figures = {"views": diagnosis_figure(self.diagnosis)}
        return build_report(
            [device],
            diagnosis_html=diag_html,
            diagnosis_figures=diag_figures,
            level=self.options.level,
        )

    def channel_names(self) -> tuple[str, ...]:
        """Names of the loaded channels (empty before loading)."""
        return () if self.record is None else self.record.channels

    def summary_text(self) -> str:
        """One-line description of the loaded record."""
        r = self.record
        if r is None:
            return "no record loaded"
        fs = "fs unknown" if r.fs is None else f"{r.fs:g} Hz"
        dur = "" if r.duration is None else f", {r.duration / 60:.3g} min"
        return (
            f"{Path(r.source).name}: {r.n_channels} channel(s), {r.n_samples:,} samples, "
            f"{fs}{dur}, {r.input}" + (f" [{r.units}]" if r.units else "")
        )


def finite_or_none(values: Any) -> list[float | None]:
    """Values as floats, NaN/inf as None (for tables)."""
    return [float(v) if np.isfinite(v) else None for v in np.asarray(values, dtype=float)]
