"""``allanite fit``: fit a noise model (IEEE terms) to the Allan variance of a record."""

from __future__ import annotations

import argparse
import math
import sys
import warnings
from typing import Any

from allanite.cli.commands import SUMMARIES
from allanite.cli.progress import progress
from allanite.cli.record_options import (
    add_grid_arguments,
    add_record_arguments,
    add_still_argument,
    avar_from_args,
    dump_json,
    read_sensors,
    warn_coefficients,
    warn_implausible,
)
from allanite.errors import ImplausibleInputWarning, RecordTooShortError
from allanite.io.atomic import atomic_output
from allanite.variance import AllanResult

__all__ = [
    "fit_lines",
    "fit_possible",
    "fit_result",
    "goodness",
    "register",
    "run",
    "thermal_fits",
]

EXAMPLES = """examples:
  allanite fit --example
  allanite fit rec.npy --fs 2000 --units deg/s -o model.json
  allanite fit run1.npz --key gyro_counts --fs 100 --scale 0.05 --units deg/s --channels 0 \\
      --plot fit.png --json
  allanite fit dut.csv --time-column t --units deg/s --datasheet limits.json
  allanite fit logger.nc --key angular_velocity --units rad/s --temperature temperature
      # thermal bias (deg/h/degC) fitted, the noise terms fitted on the compensated record
  allanite fit imu.csv --time-column t --channels gx,gy,gz,ax,ay,az \\
      --units deg/s,deg/s,deg/s,m/s^2,m/s^2,m/s^2          # six-axis: a table per sensor

datasheet checks: PASS, MARGINAL (the interval crosses the limit), FAIL, and for a term the fit
did not detect its upper limit: PASS (not detected, <= u) or NOT DETERMINED (<= u) when u is
above the limit (a longer record decides); MISSING when nothing bounds it.
exit codes: 0 fitted (and every datasheet limit met or undecided: MARGINAL, NOT DETERMINED),
1 a datasheet limit failed, 2 bad input (no output written).
"""


def register(subparsers: Any) -> None:
    """Add the ``fit`` subcommand."""
    parser = subparsers.add_parser(
        "fit",
        help=SUMMARIES["fit"],
        description="Compute the Allan variance of a record, fit a noise model (quantization, "
        "angle random walk, bias instability, rate random walk, rate ramp, ...) with "
        "uncertainties, print the coefficients in customary units and save the model as JSON.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("file", nargs="?", help="record file")
    parser.add_argument("--example", action="store_true", help="fit the example record")
    parser.add_argument(
        "-o",
        "--output",
        help="write the noise model (JSON) of the first channel (of the first sensor)",
    )
    parser.add_argument("--plot", help="save the data, model and terms to FILE.png/.svg/.pdf")
    parser.add_argument("--json", action="store_true", help="print machine-readable JSON")
    parser.add_argument(
        "--datasheet",
        metavar="LIMITS.json",
        help="check the coefficients against datasheet limits (exit code 1 when one fails)",
    )
    add_fit_arguments(parser)
    add_thermal_arguments(parser)
    add_record_arguments(parser)
    add_still_argument(parser)
    add_grid_arguments(parser)
    parser.set_defaults(func=run)


def add_fit_arguments(parser: Any) -> None:
    """``--terms`` and ``--tau-range``: the options of :func:`allanite.fit.fit` of that name."""
    parser.add_argument(
        "--terms",
        default="auto",
        help="terms to fit: 'auto' (default), a list such as N,B,K or white,flicker,rrw "
        "(a sensor filter by its kind: lowpass, one_pole, butterworth4, moving_average, "
        "bartlett, in place of N), or auto+markov / auto+filter to add candidates",
    )
    parser.add_argument(
        "--tau-range",
        metavar="LO:HI",
        help="fit only the taus from LO to HI seconds (either may be empty: 5: or :100)",
    )


def add_thermal_arguments(parser: Any) -> None:
    """``--thermal-degree`` and ``--thermal-lag``: the thermal fit with ``--temperature``."""
    group = parser.add_argument_group("thermal bias (with --temperature)")
    group.add_argument(
        "--thermal-degree",
        default="auto",
        help="degree of the bias polynomial in temperature: auto (BIC from 0 to 3, default) "
        "or a number from 0 to 6",
    )
    group.add_argument(
        "--thermal-lag",
        action="store_true",
        help="add a term in the temperature rate dT/dt (thermal lag, hysteresis)",
    )


def thermal_fits(sensors: list[Any], args: argparse.Namespace) -> tuple[list[Any], list[Any]]:
    """The records with their thermal bias removed, and one :class:`ThermalFit` per channel.

    Without ``--temperature`` the records come back unchanged and the fits are None.
    """
    if all(record.temperature is None for record in sensors):
        return sensors, [None for record in sensors for _ in record.channels]
    from allanite.fit.thermal import compensate_thermal, fit_thermal

    text = str(getattr(args, "thermal_degree", "auto") or "auto")
    if text != "auto" and not text.isdigit():
        raise ValueError(f"--thermal-degree {text!r}: give auto or a whole number from 0 to 6")
    degree = None if text == "auto" else int(text)
    out: list[Any] = []
    fits: list[Any] = []
    for record in sensors:
        found = fit_thermal(
            record,
            degree=degree,
            rate_term=bool(getattr(args, "thermal_lag", False)),
            level=args.level,
        )
        out.append(compensate_thermal(record, found))
        fits.extend(found)
    return out, fits


def fit_options(args: argparse.Namespace) -> dict[str, Any]:
    """The keyword arguments of :func:`allanite.fit.fit` that ``--terms``/``--tau-range`` give."""
    options: dict[str, Any] = {"terms": getattr(args, "terms", None) or "auto"}
    text = getattr(args, "tau_range", None)
    if text:
        lo, sep, hi = text.partition(":")
        try:
            if not sep:
                raise ValueError
            options["tau_range"] = (float(lo) if lo else 0.0, float(hi) if hi else math.inf)
        except ValueError:
            raise ValueError(
                f"--tau-range {text!r}: write LO:HI in seconds, e.g. --tau-range 5:1000"
            ) from None
    return options


def _fit_function() -> Any:
    try:
        from allanite.fit import fit
    except ImportError:
        return None
    return fit


def fit_result(result: AllanResult, options: dict[str, Any] | None = None) -> Any:
    """Fit a noise model (terms chosen automatically) to one channel of an overlapping AVAR.

    Returns None when this installation has no fitter or the estimator is not the overlapping
    Allan variance (the fit models that estimator's covariance).
    """
    fit = _fit_function()
    if fit is None or result.kind != "overlapping":
        return None
    with warnings.catch_warnings():
        # the library's wrong-units warning: the CLI prints the same check with its own
        # spelling of the fix (--units), through warn_coefficients
        warnings.simplefilter("ignore", ImplausibleInputWarning)
        try:
            return fit(result, **(options or {}))
        except RecordTooShortError as exc:
            # the library's advice names the API call; on the command line a longer record is
            # what works, or naming fewer terms (--terms)
            raise ValueError(
                f"{exc.reason}; use a longer record, or name fewer terms with "
                "--terms (e.g. --terms N,K)"
            ) from None


def fit_possible(result: AllanResult) -> bool:
    """Whether :func:`fit_result` can choose terms on ``result`` (enough usable taus).

    The taus the fit uses (:func:`allanite.fit.fit_factors` with its defaults) must number
    at least :data:`allanite.fit.api.AUTO_MIN_POINTS`; False without a fitter.
    """
    try:
        from allanite.fit import fit_factors
        from allanite.fit.api import AUTO_MIN_POINTS
    except ImportError:
        return False
    return len(fit_factors(result.m, result.n_samples)) >= AUTO_MIN_POINTS


def fit_impossible_reason(result: AllanResult) -> str:
    """Why :func:`fit_possible` is False, with the fit's own numbers and what to do.

    A record shorter than :func:`allanite.fit.api.min_auto_samples` is too short on any grid;
    a longer one has a grid too sparse for :data:`~allanite.fit.api.AUTO_MIN_POINTS` fitted
    taus.
    """
    try:
        from allanite.fit import fit_factors
        from allanite.fit.api import AUTO_MIN_POINTS, min_auto_samples
    except ImportError:
        return "this installation has no fitter"
    n, need = result.n_samples, min_auto_samples()
    if n < need:
        return (
            f"the record is too short for a fit ({n} samples; choosing the terms needs "
            f"{AUTO_MIN_POINTS} usable taus, {need} samples or more): use a longer record"
        )
    usable = len(fit_factors(result.m, n))
    return (
        f"the tau grid gives only {usable} usable tau{'s' if usable != 1 else ''} for a fit "
        f"(choosing the terms needs {AUTO_MIN_POINTS}): use a denser grid (--taus log, "
        "default --points)"
    )


def _model_of(fit: Any) -> Any:
    return getattr(fit, "model", fit)


def fit_lines(fit: Any, level: float) -> list[str]:
    """The text lines under the coefficients: interval level, chi-square, p, rejection."""
    if getattr(fit, "method", None) != "gls":
        return [f"brackets: {100 * level:g} % intervals"]
    lines: list[str] = fit.goodness_line(level).splitlines()
    return lines


def goodness(fit: Any, level: float) -> dict[str, Any]:
    """Interval level and goodness of fit of one channel's fit, for the text and JSON output.

    ``rejected`` is True when the generalized chi-square test rejects the fitted model
    (p below the fit's ``misfit_level``); ``missed_taus`` are the taus it misses;
    ``alternatives`` the term choices the record cannot tell apart
    (:meth:`allanite.fit.FitResult.alternatives_dict`); ``undetected`` the upper limits of the
    candidates left out, in customary units (:meth:`allanite.fit.FitResult.upper_limits`, the
    text's "not detected" line).
    """
    if getattr(fit, "method", None) != "gls":
        return {"level": level}
    return {
        "level": level,
        "chi2": fit.chi2,
        "dof": fit.dof,
        "p_value": fit.p_value,
        "rejected": fit.rejected,
        "missed_taus": fit.missed_taus.tolist(),
        "alternatives": fit.alternatives_dict(level),
        # the text's "not detected (95 % upper limits)" line: a term left out is bounded
        "undetected": [
            {"symbol": symbol, "high": high, "unit": unit}
            for symbol, (high, unit) in fit.upper_limits(level).items()
        ],
    }


def run(args: argparse.Namespace) -> int:
    """Run ``allanite fit``."""
    from allanite.datasheet import Datasheet

    sheet = Datasheet.load(args.datasheet) if args.datasheet else None
    if _fit_function() is None:
        raise ValueError("fitting is not available in this installation (allanite.fit.fit)")
    if args.kind != "overlapping":
        raise ValueError(
            f"--kind {args.kind}: the fit models the overlapping Allan variance; leave --kind out"
        )
    sensors, thermal = thermal_fits(read_sensors(args.file, args), args)
    analysed = []
    for record in sensors:
        result = avar_from_args(record, args)
        analysed.append((warn_implausible(record, args, result, readouts=False), result))
    work = [(record, result, c) for record, result in analysed for c in range(record.n_channels)]
    channels = []
    fits = []
    for (record, result, c), warm in zip(
        progress(work, desc="fitting", total=len(work)), thermal, strict=True
    ):
        fit = fit_result(result.channel(c), fit_options(args))
        fits.append(fit)
        channels.append(_channel_summary(fit, record, result, c, sheet, args))
        channels[-1]["thermal"] = None if warm is None else warm.to_dict()
        channels[-1]["thermal_lines"] = None if warm is None else warm.lines()
    _write_outputs(analysed[0], fits[0], args)
    failed = [k for item in channels for k in item["checks"] if k["status"] == "fail"]
    if args.json:
        for item in channels:
            item.pop("thermal_lines")
        summary = analysed[0][0].summary()
        if len(sensors) > 1:
            summary["units"] = [r.units for r in sensors for _ in r.channels]
            summary["channels"] = [name for r in sensors for name in r.channels]
        print(dump_json({"record": summary, "channels": channels, "passed": not failed}))
    else:
        _print_channels(channels, fits, args)
    return 1 if failed else 0


def _channel_summary(
    fit: Any, record: Any, result: AllanResult, c: int, sheet: Any, args: argparse.Namespace
) -> dict[str, Any]:
    """One channel's fit as the JSON/text output holds it: coefficients, checks, warnings."""
    from allanite.datasheet import check_limits, undetected_measured
    from allanite.report.coefficients import coefficient_table

    name = record.channels[c]
    unit_warnings = (
        [] if fit is None else warn_coefficients(_model_of(fit).coefficients(), record, args, name)
    )
    rows = coefficient_table(fit, result.units, args.level)
    checks = []
    if sheet is not None:
        one = result.channel(c)
        lo, hi = one.ci(args.level)
        measured = {r.symbol: r.measured() for r in rows}
        curve = (one.tau, one.dev, lo, hi, one.units)
        checks = check_limits(sheet, name, measured, curve, undetected_measured(fit, args.level))
    return {
        "channel": name,
        "sensor": _model_of(fit).sensor,
        "units": result.units,
        "checks": [k.to_dict() for k in checks],
        "warnings": unit_warnings,
        "model": _model_of(fit).to_dict(),
        **goodness(fit, args.level),
        "coefficients": [
            {
                "term": r.term,
                "quantity": r.quantity,
                "symbol": r.symbol,
                "value": r.value,
                "low": r.low,
                "high": r.high,
                "unit": r.unit,
            }
            for r in rows
        ],
    }


def _write_outputs(first: tuple[Any, AllanResult], fit: Any, args: argparse.Namespace) -> None:
    """``--plot`` and ``-o``: the first channel's figure and model file."""
    record, result = first
    if args.plot:
        from allanite.plot import model_figure, save_figure

        fig = model_figure(
            result,
            fit,
            channel=0,
            labels=list(record.channels),
            level=args.level,
            title=f"{record.source} — {record.channels[0]}",
        )
        save_figure(fig, args.plot)
    if args.output:
        with atomic_output(args.output) as tmp:
            tmp.write_text(_model_of(fit).to_json(), encoding="utf-8")
        if record.temperature is not None:
            print(
                f"allanite fit: note: {args.output} holds the noise terms of the thermally "
                "compensated record; the thermal law is not in the model file yet (it is in "
                "the --json output, channels[].thermal.model)",
                file=sys.stderr,
            )
        if getattr(fit, "rejected", False):
            print(
                f"allanite fit: warning: wrote {args.output}, but the model of channel "
                f"{record.channels[0]} is REJECTED by its goodness-of-fit test "
                f"(p = {fit.p_value:.3g}); check it before use",
                file=sys.stderr,
            )


def _print_channels(
    channels: list[dict[str, Any]], fits: list[Any], args: argparse.Namespace
) -> None:
    """The text output: per channel its coefficients, goodness of fit and datasheet checks."""
    from allanite.datasheet import status_text

    for item, fit in zip(channels, fits, strict=True):
        print(f"channel {item['channel']} ({_what(item)}):")
        for line in item.get("thermal_lines") or ():
            print(f"  {line}")
        for row in item["coefficients"]:
            interval = (
                "" if row["low"] != row["low"] else f"  [{row['low']:.4g}, {row['high']:.4g}]"
            )
            print(
                f"  {row['quantity'] or row['term']:>26} {row['symbol']:>6} = "
                f"{row['value']:.4g} {row['unit']}{interval}"
            )
        for line in fit_lines(fit, args.level):
            print(f"  {line}")
        for check in item["checks"]:
            print(f"  {_check_line(check, status_text)}")
    if args.output:
        print(_written(args.output, channels))


def _check_line(check: dict[str, Any], status_text: Any) -> str:
    """``datasheet B: not detected (<= 8.57 deg/h) -> NOT DETERMINED``, ``datasheet N: ...``."""
    unit = f" {check['unit']}" if check["unit"] else ""
    status = status_text(check["status"])
    if check["upper"] is not None:
        value = f"not detected (<= {check['upper']:.3g}{unit})"
    else:
        value = "not measured" if check["value"] is None else f"{check['value']:.4g}{unit}"
    return f"datasheet {check['quantity']}: {value} -> {status}"


def _written(path: str, channels: list[dict[str, Any]]) -> str:
    """What ``-o`` wrote: the model of the first channel, and how to get another's."""
    first = channels[0]
    text = f"wrote {path}: the noise model of channel {first['channel']} ({_what(first)})"
    if len(channels) > 1:
        text += (
            f"; {len(channels) - 1} other channel(s) not saved: fit one with --channels NAME "
            "-o FILE"
        )
    return text


def _what(item: dict[str, Any]) -> str:
    """``gyro, deg/s`` or the note that a record without a unit is shown in record units."""
    if item["units"] is None:
        return "no --units given: coefficients in the record's own units"
    return f"{item['sensor']}, {item['units']}"
