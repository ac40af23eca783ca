"""``allanite diagnose``: where and why a simulated sensor differs from a real record."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from allanite.cli.commands import SUMMARIES
from allanite.cli.record_options import (
    add_record_arguments,
    add_still_argument,
    print_reader_notes,
    rate_unit,
    read_from_args,
    warn_implausible,
)
from allanite.cli.sim_config import (
    add_sim_config_arguments,
    check_sim_model,
    config_changes,
    load_sim_model,
    recheck_corrected,
    write_corrected,
)
from allanite.io.atomic import atomic_output, check_output_path, input_source, note_input
from allanite.io.readers import read_record
from allanite.io.record import INPUT_KINDS, Record

__all__ = ["register", "run"]

EXAMPLES = """examples:
  allanite diagnose real.npy --fs 100 --sim-model model.json --json
  allanite diagnose run2.npz --key gyro_counts --channels 0 --scale 0.05 --units deg/s \\
      --fs 100 --sim-model run1_model.json --holdout 0.5 --report gap.html
  allanite diagnose real.csv --fs 2000 --sim-record sim.npy --input angle --json

JSON (--json) is one object: headline, closed (true only when the tau, frequency and time views
all agree after the effects and no effect of another law closes the gap alike),
indistinguishable (the effect and its rivals when not identified, else empty), unexplained
[{view, evidence, where, size, p_value, text}, ...], gap {statistic, p_value, significant, T,
T0, view_p_values}, where {tau_bands_s, frequency_lines_hz, time_segments_s,
frequency_bands_hz}, steps (the level changes found, with times and sizes and their
intervals), level_steps (the times of those listed as findings: not inside a named warm-up's
settling), attribution [{effect, params, params_units, gap_before, gap_after, shrinkage,
consistent_after, ...}, ...] (single effects, best first), explanation {effects, gap_before,
gap_after, consistent_after, p_after, share, explained, terms, holdout} or null (the joint set;
terms: the model JSON "terms" with the effects added; with --sim-record, the effects' terms
alone), holdout {shrinkage, checkable, disagrees, fit_effects, deciding_length_s, note, ...} or
null (the best single effect; with a fraction, the fit part's, checked on the held-out part),
meta, warnings, corrected {path, format, folded, projections, adev_error, tau_range_s, recheck
{statistic, p_value, significant, n_samples}} or null (with --write-corrected: the file read
back under its format's law and re-checked against the same record), thermal (with
--temperature: the channel's thermal fit as allanite fit --json gives it, {sensitivity, degree,
model, ...}; the diagnosis does not use it yet; else null). The text leads with the
headline and what remains unexplained, and shows parameters in the customary units of
`allanite fit` (N in
deg/sqrt(h), ...); the JSON keeps them in the units of --units, named in params_units.
"""


def register(subparsers: Any) -> None:
    """Add the ``diagnose`` subcommand."""
    parser = subparsers.add_parser(
        "diagnose",
        help=SUMMARIES["diagnose"],
        description="Compare a real record with a simulated sensor (a noise model or a "
        "simulated record) in averaging time, frequency and time, test whether they differ "
        "beyond chance, and attribute the gap to the unmodelled effect that closes it.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("real", metavar="REAL", help="the real record file")
    add_record_arguments(parser)
    add_still_argument(parser)
    sim = parser.add_argument_group("simulated sensor (one of)")
    which = sim.add_mutually_exclusive_group(required=True)
    which.add_argument(
        "--sim-model",
        metavar="CONFIG",
        help="noise model: model JSON or a simulator/estimator IMU config (gz SDF, PX4 plugin, "
        "Kalibr/OpenVINS/ORB-SLAM3/VINS yaml, AirSim json, MATLAB .m, gnss-ins-sim .py)",
    )
    which.add_argument("--sim-record", metavar="SIM", help="simulated record file (.npy, ...)")
    sim.add_argument(
        "--sim-input",
        choices=INPUT_KINDS,
        default="rate",
        help="what the simulated record's samples are (default rate)",
    )
    sim.add_argument("--sim-units", help="rate unit of the simulated record, e.g. deg/s")
    sim.add_argument(
        "--sim-fs", type=float, help="sampling frequency of the simulated record (must equal --fs)"
    )
    sim.add_argument("--sim-key", help="array name in an .npz simulated record")
    add_sim_config_arguments(sim)
    diag = parser.add_argument_group("diagnosis")
    diag.add_argument(
        "--holdout",
        metavar="FRACTION|FILE",
        help="a fraction (e.g. 0.5): the gap is tested and attributed on the whole record, "
        "then validated: attributed on the start, checked on the held-out end (effects beyond "
        "its taus: 'not checkable'; a different attribution is flagged); or a second real "
        "record read with the same options, where the effects' shrinkage is measured",
    )
    diag.add_argument(
        "--effects", help="comma-separated candidate effects (default: all), e.g. white,sine"
    )
    diag.add_argument(
        "--n-mc", type=int, default=200, help="Monte Carlo replicates of the null (default 200)"
    )
    diag.add_argument(
        "--significance",
        "--alpha",
        dest="significance",
        type=float,
        default=0.05,
        help="significance level of the tests (default 0.05; --alpha is its old name)",
    )
    diag.add_argument("--seed", type=int, default=0, help="Monte Carlo seed (default 0)")
    diag.add_argument(
        "--progress",
        choices=("auto", "on", "off"),
        default="auto",
        help="progress on stderr (auto: on a terminal, and for records of 2^20 samples or more)",
    )
    out = parser.add_argument_group("output")
    out.add_argument("--json", action="store_true", help="print one JSON object to stdout")
    out.add_argument(
        "-o", "--output", help="write the full diagnosis (with the view arrays) to FILE.json"
    )
    out.add_argument("--report", metavar="OUT.html", help="write an HTML report of the diagnosis")
    parser.set_defaults(func=run)


def _one_channel(record: Record, what: str) -> Any:
    part = record.longest_segment()
    if part.n_channels != 1:
        raise ValueError(
            f"the {what} record has {part.n_channels} channels ({', '.join(part.channels)}); "
            "choose one with --channels"
        )
    return part.samples[:, 0], part


def _sim_record(args: argparse.Namespace, fs: float) -> Any:
    record = read_record(args.sim_record, fs=fs, input=args.sim_input, key=args.sim_key)
    samples, _ = _one_channel(record, "simulated")
    return samples


def _holdout(args: argparse.Namespace) -> Any:
    if args.holdout is None:
        return None
    try:
        return float(args.holdout)
    except ValueError:
        pass
    if not Path(args.holdout).exists():
        raise ValueError(
            f"--holdout {args.holdout!r} is neither a fraction in (0, 1) nor an existing file"
        )
    samples, _ = _one_channel(read_from_args(args.holdout, args), "held-out")
    return samples


def _thermal_note(part: Record, args: argparse.Namespace) -> dict[str, Any] | None:
    """With ``--temperature``: the channel's thermal sensitivity as a note on stderr.

    The diagnosis itself does not use the temperature yet (no thermal candidate): the note
    gives the number a calibration engineer would fit by hand, and says so. Returns the
    thermal fit's JSON (None without a temperature, or the reason it could not be fitted).
    """
    if part.temperature is None:
        return None
    from allanite.fit.thermal import fit_thermal

    try:
        (fit,) = fit_thermal(part)
    except ValueError as exc:
        print(f"allanite diagnose: note: no thermal fit: {exc}", file=sys.stderr)
        return {"error": str(exc)}
    value, low, high, unit = fit.customary_sensitivity()
    verdict = "significant" if fit.significant else "not significant (the interval covers 0)"
    print(
        f"allanite diagnose: note: thermal sensitivity of {fit.channel}: {value:.4g} {unit} "
        f"[{low:.4g}, {high:.4g}] ({100 * fit.level:g} %), {verdict}, degree {fit.degree} "
        f"over {fit.temperature_range[0]:.4g} to {fit.temperature_range[1]:.4g} °C; the "
        "diagnosis below does not use the temperature (allanite fit --temperature fits the "
        "noise on the compensated record)",
        file=sys.stderr,
    )
    return fit.to_dict()


def _summary(d: Any) -> str:
    from allanite.diagnosis.verdict import explanation_lines, format_params, percent

    units = d.meta.get("units")
    status = "CLOSED" if d.closed else "NOT FULLY EXPLAINED"
    if d.indistinguishable and not d.closed:
        status = "NOT IDENTIFIED"
    if not d.significant:
        status = "NO GAP" if d.closed else "NO GAP IN THE NOISE, NOT FULLY EXPLAINED"
    lines = [f"{status}: {d.headline}"]
    if d.unexplained:
        lines.append("unexplained:")
        lines.extend(f"  - {u.text}" for u in d.unexplained)
    lines.append(
        f"gap G = {d.statistic:.4g}  (T = {d.tau.statistic:.4g}, chance level T0 = "
        f"{d.tau.t0:.3g}), p = {d.p_value:.3g}: "
        + ("SIGNIFICANT" if d.significant else "consistent with chance"),
    )
    where = d.where
    if where["tau_bands_s"]:
        bands = ", ".join(f"{a:.3g}-{b:.3g} s" for a, b in where["tau_bands_s"])
        lines.append(f"tau bands:        {bands}")
    if where["frequency_lines_hz"]:
        lines.append(
            "spectral lines:   " + ", ".join(f"{f:.5g} Hz" for f in where["frequency_lines_hz"])
        )
    if where["time_segments_s"]:
        segs = where["time_segments_s"]
        text = ", ".join(f"{a:.4g}-{b:.4g} s" for a, b in segs[:8])
        lines.append(
            f"time segments:    {text}" + (f" (+{len(segs) - 8} more)" if len(segs) > 8 else "")
        )
    steps = d.level_steps
    if steps and d.time.steps is not None:
        lines.append(f"level steps (p = {d.time.steps.p_value:.3g}):")
        lines.extend(f"  - {s.text(units)}" for s in steps)
    if d.attribution:
        lines.append("attribution (best first):")
        for a in d.attribution:
            params = format_params(a, units, fs=d.meta.get("fs"))
            lines.append(
                f"  {a.effect:<22} {params}  gap {a.gap_before:.4g} -> {a.gap_after:.4g} "
                f"(shrinkage {percent(a.shrinkage)}, "
                + ("consistent after" if a.consistent_after else "gap remains")
                + ")"
                + (
                    f"; indistinguishable from {', '.join(a.alternatives)}"
                    if a.alternatives
                    else ""
                )
            )
    if d.holdout is not None and d.holdout.note:
        lines.append(d.holdout.note)
    elif d.holdout is not None:
        shrink = d.holdout.shrinkage
        text = "n/a (no gap in the held-out data)" if d.holdout.gap_before <= 0 else percent(shrink)
        text = text if d.holdout.checkable else "not checkable on the held-out part"
        lines.append(f"held-out shrinkage of {d.holdout.effect}: {text}")
    if d.explanation is not None and d.attribution:
        model = d.meta.get("sim") != "record"
        lines.extend(explanation_lines(d.explanation, units, d.meta.get("fs"), model=model))
    return "\n".join(lines)


def _progress_printer() -> Any:
    """Progress callback writing one line per step to stderr (stdout stays clean)."""
    import time

    start = time.perf_counter()

    def show(stage: str, done: int, total: int) -> None:
        sys.stderr.write(
            f"diagnose: {stage} {done}/{total} ({time.perf_counter() - start:.0f} s)\n"
        )
        sys.stderr.flush()

    return show


def _check_outputs(args: argparse.Namespace) -> None:
    """Refuse, before the computation, outputs that cannot be written or would replace an input.

    ``--write-corrected`` onto the ``--sim-model`` config itself is refused here; an unwritable
    ``--write-corrected`` path is reported after the diagnosis, which stands without it.
    """
    if args.sim_model:
        note_input(args.sim_model)  # no output may replace the config it is compared with
    for output in (args.output, args.report):
        if output:
            check_output_path(output)
    if args.write_corrected and args.sim_model and input_source(args.write_corrected) is not None:
        raise ValueError(
            f"--write-corrected {args.write_corrected} is the --sim-model config itself; "
            "writing it would replace your config: give another output name (e.g. "
            "corrected.yaml) and compare the two"
        )


def run(args: argparse.Namespace) -> int:
    """Run ``allanite diagnose``."""
    from allanite.diagnosis import diagnose

    if args.seed < 0:
        raise ValueError(f"--seed must be a non-negative integer, got {args.seed}")
    _check_outputs(args)
    check_sim_model(args)  # before the record: a bag may take minutes to read
    record = read_from_args(args.real, args)
    print_reader_notes([record], args)
    real, part = _one_channel(record, "real")
    thermal = _thermal_note(part, args)
    warnings = warn_implausible(part, args).warnings[len(part.warnings) :]
    fs = part.require_fs()
    if args.write_corrected and not args.sim_model:
        raise ValueError(
            "--write-corrected needs --sim-model CONFIG: a simulated record has no config to "
            "correct"
        )
    channel = part.channels[0] if part.channels else None
    loaded = load_sim_model(args, fs, rate_unit(part), channel) if args.sim_model else None
    sim: Any = loaded.model if loaded is not None else _sim_record(args, fs)
    effects = [e.strip() for e in args.effects.split(",") if e.strip()] if args.effects else None
    # auto: on a terminal (a diagnosis takes tens of seconds from 1e5 samples on), and in
    # logs for records of 2^20 samples or more
    show = args.progress == "on" or (
        args.progress == "auto" and (real.size >= 2**20 or sys.stderr.isatty())
    )
    result = diagnose(
        record if record.timing is not None else real,  # its time base is evidence too
        sim,
        fs=fs,
        input=part.input,
        units=rate_unit(part),
        sim_units=args.sim_units,
        sim_input=args.sim_input,
        sim_fs=args.sim_fs,
        holdout=_holdout(args),
        effects=effects,
        n_mc=args.n_mc,
        significance=args.significance,
        seed=args.seed,
        progress=_progress_printer() if show else None,
    )
    failure: Exception | None = None
    corrected = None
    if loaded is not None and args.write_corrected:
        try:
            corrected = write_corrected(args, loaded, result)
        except (ValueError, OSError) as exc:  # the diagnosis stands: shown first, then this
            failure = exc
    if corrected is not None and loaded is not None:  # the file as written, same record
        try:
            corrected = recheck_corrected(
                corrected,
                loaded,
                record if record.timing is not None else real,
                result,
                input=part.input,
                units=rate_unit(part),
                progress=_progress_printer() if show else None,
            )
        except ValueError as exc:  # the diagnosis stands: shown first, then this
            failure = ValueError(f"it was written, but could not be re-checked as written: {exc}")
    if args.output:
        with atomic_output(args.output) as tmp:
            tmp.write_text(result.to_json(indent=1))
    changes = config_changes(args, loaded, result) if loaded is not None else []
    if args.report:
        sim_name = Path(args.sim_model or args.sim_record).name
        channel = part.channels[0] if part.channels else Path(args.real).name
        _write_report(result, args.report, channel=channel, model_name=sim_name, changes=changes)
    if args.json:
        data = json.loads(result.to_json(views=False))
        data["warnings"] = list(warnings)  # plausibility findings on the real record
        data["corrected"] = corrected.to_dict() if corrected is not None else None
        data["thermal"] = thermal
        sys.stdout.write(json.dumps(data) + "\n")
    else:
        print(_summary(result))
        if changes and loaded is not None:
            how = (
                f"written to {args.write_corrected}"
                if args.write_corrected and corrected is not None
                else "--write-corrected OUT writes it"
            )
            closes = corrected is not None and corrected.closes
            lead = "to close the gap" if closes else "the diagnosed correction"
            if corrected is not None and not closes:
                how += "; the re-check below says whether it closes the gap"
            print(f"{lead}, change in {Path(args.sim_model).name} ({loaded.format}; {how}):")
            print("\n".join(f"  {line}" for line in changes))
        if corrected is not None:
            print("\n".join(corrected.lines()))
    if failure is not None:
        done = "" if corrected is not None else " was not written"
        raise ValueError(
            f"the diagnosis above stands, but --write-corrected {args.write_corrected}{done}: "
            f"{failure}"
        ) from failure
    return 0


def _write_report(
    result: Any, path: str, *, channel: str, model_name: str, changes: list[str]
) -> None:
    """Write a self-contained HTML page: the report's diagnosis section and the three views."""
    from allanite.plot.diagnosis import diagnosis_figure
    from allanite.plot.export import figure_bytes
    from allanite.report import html as h
    from allanite.report.diagnosis import diagnosis_html

    body = diagnosis_html(result, channel=channel, model_name=model_name, changes=changes)
    png = figure_bytes(diagnosis_figure(result), "png")
    body += h.figure(
        png,
        "Tau view (Allan deviation, real vs simulated with the chance band), frequency view "
        "(PSD ratio with its band and the detected lines) and time view (normalised window "
        "residuals with the simultaneous threshold).",
        "three views of the sim-to-real gap",
    )
    page = h.document(
        "allanite sim-to-real diagnosis",
        f"{channel} against {model_name}",
        h.section("Sim-to-real diagnosis", body, anchor="diagnosis"),
    )
    with atomic_output(path) as tmp:
        tmp.write_text(page, encoding="utf-8")
