"""``allanite diagnose`` options for simulator configs, and the loading/writing behind them.

``--sim-format``, ``--sim-sensor``, ``--sim-rate`` and ``--write-corrected``.

``--sim-model`` accepts a model JSON or any format of :mod:`allanite.formats`; the config's
model (SI units) is converted to the real record's rate unit for the diagnosis, and with
``--write-corrected OUT`` the diagnosed effect is folded into the config, which is written in
its own format with the user's other settings kept (the input config is the template).
"""

from __future__ import annotations

import argparse
import difflib
import re
import sys
from dataclasses import dataclass
from typing import Any

from allanite.formats import (
    CONFIG_TEXT,
    FORMATS,
    ImuConfig,
    detect_format,
    read_config,
    write_config,
)
from allanite.model import NoiseModel, read_text_file
from allanite.units import RECORD_UNIT, sensor_kind

__all__ = [
    "CorrectedWrite",
    "LoadedSim",
    "add_sim_config_arguments",
    "check_sim_model",
    "config_changes",
    "load_sim_model",
    "recheck_corrected",
    "write_corrected",
]


def add_sim_config_arguments(group: Any, *, corrected: bool = True) -> None:
    """Add ``--sim-format``, ``--sim-sensor``, ``--sim-rate`` and ``--write-corrected``.

    ``corrected=False`` leaves out ``--write-corrected`` (commands that write no config).
    """
    group.add_argument(
        "--sim-format",
        choices=tuple(FORMATS),
        help="format of the --sim-model config (default: from its content and suffix)",
    )
    group.add_argument(
        "--sim-sensor",
        choices=("gyro", "accel"),
        help="which sensor of the config to compare with the record (default: from the "
        "record's --units, rad/s-like -> gyro, m/s^2-like -> accel)",
    )
    group.add_argument(
        "--sim-rate",
        type=float,
        help="simulator IMU rate in Hz for per-sample configs without one (default: the "
        "record's --fs)",
    )
    if not corrected:
        return
    group.add_argument(
        "--write-corrected",
        metavar="OUT",
        help="write the --sim-model config with the diagnosed effect folded in (what the "
        "format can hold; the rest is listed), in the config's own format",
    )


@dataclass(frozen=True)
class LoadedSim:
    """The simulated sensor read from ``--sim-model``."""

    model: NoiseModel
    config: ImuConfig
    format: str
    rate: float
    sensor: str = "gyro"


def _noisy(config: ImuConfig, sensor: str, name: str, fmt: str) -> NoiseModel:
    """The model of ``sensor``, or a ValueError when the config gives it no noise at all."""
    model = config.model(sensor)
    if model.terms:
        return model
    off = [n for n in config.notes if n.startswith(f"{sensor}:") and 'type="none"' in n]
    if off:  # the entries are there, but the simulator does not use them
        raise ValueError(f"{name} ({fmt}) gives the {sensor} no noise: {off[0].split(': ', 1)[1]}")
    # a simulator config with every noise entry zero: a noiseless sensor
    raise ValueError(
        f"{name} ({fmt}) gives the {sensor} no noise: every {sensor} noise entry is "
        f"zero, so there is no simulated sensor to compare; set its {sensor} noise, or "
        "give a config that holds it (allanite model convert FITTED.json CONFIG --template "
        "CONFIG writes a fitted model into it)"
    )


def check_sim_model(args: argparse.Namespace) -> None:
    """Check ``--sim-model`` before the record is read (a bag may take minutes to read).

    The config must be readable and give the compared sensor (``--sim-sensor``, else the
    sensor of the first ``--units``) some noise; its rate, when it needs one, comes later from
    the record, so a stand-in rate is used here only to read it.
    """
    from pathlib import Path

    if not getattr(args, "sim_model", None):
        return
    path = Path(args.sim_model)
    fmt = args.sim_format or detect_format(path, read_text_file(path, CONFIG_TEXT))
    rate = args.sim_rate or getattr(args, "fs", None)
    try:
        config = read_config(path, format=fmt, rate=rate)
    except ValueError as exc:
        if rate is not None or "update rate is needed" not in str(exc):
            raise
        config = read_config(path, format=fmt, rate=1.0)  # the laws' zero tests need no rate
    units = (getattr(args, "units", None) or "").split(",")[0].strip() or None
    kind = sensor_kind(units) if units else None
    if args.sim_sensor is None and kind not in ("gyro", "accelerometer"):
        return  # the sensor is known once the record's unit is
    sensor = args.sim_sensor or _sensor_of(units)
    if getattr(config, sensor) is not None:
        _noisy(config, sensor, path.name, fmt)


#: formats that hold each axis apart (an SDF's x, y and z noise blocks)
PER_AXIS = ("gz-sdf", "gazebo-classic")
_AXIS = re.compile(r"(?:^|[^a-z0-9])([xyz])$", re.I)


def record_axis(channel: str | None) -> tuple[str, bool]:
    """``(axis, named)``: the axis a channel name ends in (``gyro_y`` -> y), else x, unnamed."""
    found = _AXIS.search(channel or "")
    return (found.group(1).lower(), True) if found else ("x", False)


def _per_axis(config: ImuConfig, fmt: str, path: Any, rate: float, axis: str) -> ImuConfig:
    """A per-axis config read for the measured ``axis`` only (its model; the write sets it)."""
    import dataclasses

    if fmt not in PER_AXIS:
        return config
    if axis != "x":
        from allanite.formats import format_module

        text = read_text_file(path, CONFIG_TEXT)
        config = format_module(fmt).read(text, rate=rate, axis=axis)
    return dataclasses.replace(config, axes=(axis,))


def load_sim_model(
    args: argparse.Namespace, fs: float, units: str | None, channel: str | None = None
) -> LoadedSim:
    """Read ``--sim-model`` in any format; the model comes in the record's rate unit.

    A per-axis config (an SDF) gives the model of the axis ``channel`` names (``gyro_y``: y;
    a name without an axis: x), and a corrected write sets only that axis.
    """
    from pathlib import Path

    path = Path(args.sim_model)
    fmt = args.sim_format or detect_format(path, read_text_file(path, CONFIG_TEXT))
    rate = args.sim_rate
    try:
        config = read_config(path, format=fmt, rate=rate)
    except ValueError as exc:
        if rate is not None or "update rate is needed" not in str(exc):
            raise
        config = None
    if config is None:
        # a per-sample config without its rate: the record's rate is the natural one
        config = read_config(path, format=fmt, rate=fs)
        print(f"note: simulator IMU rate taken from the record: {fs:g} Hz", file=sys.stderr)
    elif config.rate is None and rate is None and fmt != "allanite":
        config = read_config(path, format=fmt, rate=fs)  # rate-dependent laws (AirSim > 1 kHz)
    config = _per_axis(config, fmt, path, float(config.rate or fs), record_axis(channel)[0])
    sensor = args.sim_sensor or _sensor_of(units)
    _check_sensor(config, sensor, units, path.name, chosen=args.sim_sensor is not None)
    model = _noisy(config, sensor, path.name, fmt)
    if fmt == "allanite":
        model = NoiseModel.from_json(path.read_text(encoding="utf-8"))
    model_unit = model.units["rate"]
    if units is None:
        if model_unit == RECORD_UNIT:
            return LoadedSim(model, config, fmt, float(config.rate or fs), sensor)
        where = f"{fmt} config is in SI units" if fmt != "allanite" else "model is in"
        raise ValueError(
            f"the {where} ({model_unit}); give the unit of the real record with "
            "--units (e.g. --units deg/s): units are never guessed"
        )
    convertible = model_unit != RECORD_UNIT and sensor_kind(model_unit) == sensor_kind(units)
    if model_unit != units and convertible:
        model = model.in_units(units)  # a mismatch of quantities is reported by diagnose
    other = "accel" if sensor == "gyro" else "gyro"
    for note in config.notes:
        if not note.startswith(f"{other}:"):  # notes on the other sensor are beside the point
            print(f"note: {note}", file=sys.stderr)
    return LoadedSim(model, config, fmt, float(config.rate or fs), sensor)


_NAMES = {"gyro": "a gyro", "accel": "an accelerometer"}


def _check_sensor(config: Any, sensor: str, units: str | None, name: str, *, chosen: bool) -> None:
    """A clear error when the record and the model are of different sensors.

    A gyro record (``--units deg/s``) against an accelerometer model, or the reverse, cannot
    be compared whatever ``--sim-sensor`` says: the error names both sides and what to give,
    instead of advising a ``--sim-sensor`` that then fails on the units.
    """
    if units is None or sensor_kind(units) not in ("gyro", "accelerometer"):
        return
    record = _sensor_of(units)
    if chosen and sensor != record:
        raise ValueError(
            f"--sim-sensor {sensor} compares {_NAMES[sensor]} model with {_NAMES[record]} "
            f"record (--units {units}); use --sim-sensor {record}, or give the record's own "
            "unit with --units"
        )
    other = "accel" if sensor == "gyro" else "gyro"
    if getattr(config, sensor) is None and getattr(config, other) is not None:
        unit = getattr(config, other).units["rate"]
        raise ValueError(
            f"the {config.source_format or 'given'} config holds no {sensor} noise model: "
            f"{name} is {_NAMES[other]} model ({unit}) and the record is {_NAMES[record]} "
            f"record (--units {units}); compare it with {_NAMES[other]} record, or give "
            f"{_NAMES[sensor]} model"
        )


def _sensor_of(units: str | None) -> str:
    if units is None:
        return "gyro"
    from allanite.units import sensor_kind

    return "accel" if sensor_kind(units) == "accelerometer" else "gyro"


def _corrected(loaded: LoadedSim, diagnosis: Any) -> tuple[ImuConfig, NoiseModel, str]:
    """The config with the diagnosed effects folded in, its sensor's model, what was folded."""
    from allanite.formats import format_module
    from allanite.formats.corrected import corrected_model

    holds = format_module(loaded.format).HOLDS
    model, what = corrected_model(loaded.model, diagnosis, holds)
    return loaded.config.with_model(loaded.sensor, model), model, what


def _tau_range(diagnosis: Any) -> tuple[float, float]:
    tau = diagnosis.tau.tau
    return float(tau[0]), float(tau[-1])


#: lines of an export note (``# projected: ...``), not parameters
_NOTE_LINE = re.compile(r"(projected|dropped|not representable[^:]*):")


_ELEMENTS = re.compile(r">[ \t]*<")
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def _same_values(a: str, b: str) -> bool:
    """Whether two config lines say the same: the same text around equal numbers."""
    if _NUMBER.sub("#", a) != _NUMBER.sub("#", b):
        return False
    x = [float(v) for v in _NUMBER.findall(a)]
    y = [float(v) for v in _NUMBER.findall(b)]
    return all(abs(u - v) <= 1e-9 * max(abs(u), abs(v)) for u, v in zip(x, y, strict=True))


def config_changes(args: argparse.Namespace, loaded: LoadedSim, diagnosis: Any) -> list[str]:
    """What to change in the ``--sim-model`` config, in its own parameter names and units.

    The parameter lines of the config that the correction ``--write-corrected`` would write
    changes, ``old  ->  new``, with the unit where the format names one (identical changes,
    such as the x, y and z blocks of an SDF, are shown once with a count). Empty for a model
    JSON, or when the gap is not significant.
    """
    from pathlib import Path

    from allanite.formats import format_module

    if loaded.format == "allanite" or not diagnosis.significant:
        return []
    module = format_module(loaded.format)
    # both sides written by the format's writer into the user's file, so the writer's own
    # layout (a one-line SDF indented, 2e-3 written as 0.002) is no change
    text = Path(args.sim_model).read_text(encoding="utf-8")
    try:
        config, _, _ = _corrected(loaded, diagnosis)
        before, after = (
            module.write(c, rate=loaded.rate, template=text, tau_range=_tau_range(diagnosis)).text
            for c in (loaded.config, config)
        )
    except ValueError as exc:  # the diagnosis stands; only this listing is not possible
        return [f"(the changes cannot be listed: {exc})"]
    # one XML element per line, so a one-line SDF or plugin block diffs element by element
    old, new = (
        [ln.strip() for ln in _ELEMENTS.sub(">\n<", t).splitlines()] for t in (before, after)
    )
    pairs: list[tuple[str, str]] = []
    matcher = difflib.SequenceMatcher(a=old, b=new, autojunk=False)
    for op, a0, a1, b0, b1 in matcher.get_opcodes():
        if op == "equal":
            continue
        gone = [ln for ln in old[a0:a1] if ln and not _NOTE_LINE.search(ln)]
        came = [ln for ln in new[b0:b1] if ln and not _NOTE_LINE.search(ln)]
        for i in range(max(len(gone), len(came))):
            pair = (gone[i] if i < len(gone) else "", came[i] if i < len(came) else "")
            if not _same_values(*pair):  # 2e-3 rewritten as 0.002 is no change
                pairs.append(pair)
    named: dict[str, Any] = getattr(module, "UNITS", {})
    # longest name first: gnss-ins-sim's gyro_b_stability before gyro_b
    units = {k: named[k] for k in sorted(named, key=len, reverse=True)}
    out: list[str] = []
    for pair in dict.fromkeys(pairs):
        was, now = pair
        unit = next((u for k, u in units.items() if isinstance(u, str) and k in now), "")
        shown = f"{was or '(absent)'}  ->  {now or '(removed)'}"
        if unit and f"# {unit}" not in now:  # Kalibr files written by allanite say it
            shown += f"  [{unit}]"
        count = pairs.count(pair)
        out.append(shown + (f"  (x{count})" if count > 1 else ""))
    return out


#: the gap and shrinkage of the unprojected effects in a fold description (``corrected_model``)
_UNPROJECTED_GAP = re.compile(r";? ?gap [^;]*? -> [^;]*? \(shrinkage [^)]*\)")


@dataclass(frozen=True)
class CorrectedWrite:
    """A corrected config as written, and the gap it leaves on the diagnosed record.

    Attributes
    ----------
    path, format : str
        The file written and its format.
    folded : str
        What was folded in (the effects, in customary units); without the shrinkage of the
        unprojected effects when the file holds a projection of them.
    report : list of str
        What the format dropped or projected (:meth:`Written.report`).
    adev_error : float
        Largest relative difference between the Allan deviation of the model read back from the
        file (the format's own law) and of the corrected model, over ``tau_range``.
    tau_range : tuple of float
        The diagnosis' tau range (s).
    recheck : GapTest or None
        The gap test of the record against the file as written (same n_mc, seed, level).
    """

    path: str
    format: str
    folded: str
    report: list[str]
    adev_error: float
    tau_range: tuple[float, float]
    recheck: Any = None
    gap_before: float = 0.0

    @property
    def closes(self) -> bool:
        """Whether the file as written, re-checked against the record, leaves no gap."""
        return self.recheck is not None and not self.recheck.significant

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields (``corrected`` in ``diagnose --json``)."""
        return {
            "path": self.path,
            "format": self.format,
            "folded": self.folded,
            "projections": list(self.report),
            "adev_error": float(self.adev_error),
            "tau_range_s": list(self.tau_range),
            "recheck": self.recheck.to_dict() if self.recheck is not None else None,
            "shrinkage": self._shrinkage(),
        }

    def _shrinkage(self) -> float | None:
        """The re-check's shrinkage of the gap: ``1 - G_written / G_diagnosed`` (None: none)."""
        if self.recheck is None or not self.gap_before > 0:
            return None
        return float(1.0 - self.recheck.statistic / self.gap_before)

    def lines(self) -> list[str]:
        """The summary lines: the gap after projection into the format, with its error."""
        a, b = self.tau_range
        held = (
            f"the file holds a projection: its Allan deviation differs from the corrected "
            f"model's by up to {100 * self.adev_error:.0f} % over {a:.3g}-{b:.3g} s"
            if self.report
            else f"the format holds the correction (Allan deviation within "
            f"{100 * self.adev_error:.2g} % over {a:.3g}-{b:.3g} s)"
        )
        out = [f"corrected config {self.path} ({self.format}), re-checked as written:", f"  {held}"]
        out.extend(f"  {line}" for line in self.report)
        if self.recheck is not None:
            r = self.recheck
            verdict = (
                "SIGNIFICANT: the written config leaves a gap"
                if r.significant
                else "consistent with chance: the written config closes the gap"
            )
            shrink = self._shrinkage()
            was = (
                f" (diagnosed G = {self.gap_before:.4g}: shrinkage {100 * shrink:.0f} %)"
                if shrink is not None
                else ""
            )
            out.append(
                f"  gap against the same record as written: G = {r.statistic:.4g}{was}, "
                f"p = {r.p_value:.3g}: {verdict}"
            )
        return out


def _read_back(path: str, loaded: LoadedSim) -> NoiseModel:
    """The model the written file gives the sensor, under the format's own law."""
    from pathlib import Path

    if loaded.format == "allanite":
        model = NoiseModel.from_json(Path(path).read_text(encoding="utf-8"))
    else:
        model = read_config(path, format=loaded.format, rate=loaded.rate).model(loaded.sensor)
    unit = loaded.model.units["rate"]
    return model if model.units["rate"] == unit else model.in_units(unit)


def _adev_error(a: NoiseModel, b: NoiseModel, tau: Any, dt: float) -> float:
    """Largest ``|ADEV_b / ADEV_a - 1|`` over ``tau`` (0 where both vanish)."""
    import numpy as np

    x, y = a.adev(tau, dt), b.adev(tau, dt)
    keep = x > 0
    if not np.any(keep):
        return 0.0 if not np.any(y > 0) else float("inf")
    return float(np.max(np.abs(y[keep] / x[keep] - 1.0)))


def write_corrected(args: argparse.Namespace, loaded: LoadedSim, diagnosis: Any) -> CorrectedWrite:
    """Write the corrected config and list what was folded in, dropped and projected.

    The file is read back with the format's own law: the returned record says how far its
    Allan deviation departs from the corrected model's (:func:`recheck_corrected` then
    tests it against the record).
    """
    config, model, what = _corrected(loaded, diagnosis)
    written = write_config(
        config,
        args.write_corrected,
        format=loaded.format,
        rate=loaded.rate,
        template=args.sim_model,
        tau_range=_tau_range(diagnosis),
    )
    mine = [ln for ln in written.report() if ln.split(" ", 1)[1].startswith(f"{loaded.sensor}:")]
    # the gap the file leaves is the re-check's, never the fitted effects' shrinkage
    what = _UNPROJECTED_GAP.sub("", what) + "; the gap as written: see the re-check"
    if loaded.config.axes:  # a per-axis format: the axes not measured keep their values
        kept = ", ".join(a for a in ("x", "y", "z") if a not in loaded.config.axes)
        what += (
            f"; only axis {', '.join(loaded.config.axes)} was measured and changed: axes "
            f"{kept} were not measured and keep their values"
        )
    print(f"corrected config {args.write_corrected}: {what}", file=sys.stderr)
    for line in written.report():
        print(f"  {line}", file=sys.stderr)
    back = _read_back(args.write_corrected, loaded)
    error = _adev_error(model, back, diagnosis.tau.tau, 1.0 / float(diagnosis.meta["fs"]))
    return CorrectedWrite(
        args.write_corrected,
        loaded.format,
        what,
        mine,
        error,
        _tau_range(diagnosis),
        gap_before=float(diagnosis.statistic),
    )


def recheck_corrected(
    done: CorrectedWrite, loaded: LoadedSim, real: Any, diagnosis: Any, **options: Any
) -> CorrectedWrite:
    """``done`` with the gap test of ``real`` against the file as written.

    ``options`` are :func:`~allanite.diagnosis.recheck.gap_test`'s (``input``, ``units``,
    ``progress``); the diagnosis' sampling rate, n_mc, significance and seed are used.
    """
    import dataclasses

    from allanite.diagnosis.recheck import gap_test

    meta = diagnosis.meta
    test = gap_test(
        real,
        _read_back(done.path, loaded),
        fs=float(meta["fs"]),
        n_mc=int(meta["n_mc"]),
        significance=float(meta["significance"]),
        seed=int(meta["seed"]),
        **options,
    )
    return dataclasses.replace(done, recheck=test)
