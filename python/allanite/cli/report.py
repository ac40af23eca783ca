"""``allanite report``: one self-contained HTML file with plots, tables, pass/fail and diagnosis."""

from __future__ import annotations

import argparse
import dataclasses
import re
from pathlib import Path
from typing import Any

from allanite.cli.commands import SUMMARIES
from allanite.cli.progress import progress
from allanite.cli.record_options import (
    add_grid_arguments,
    add_record_arguments,
    add_still_argument,
    avar_from_args,
    dump_json,
    rate_unit,
    read_from_args,
    read_sensors,
    warn_implausible,
)
from allanite.cli.sim_config import (
    add_sim_config_arguments,
    check_sim_model,
    config_changes,
    load_sim_model,
)
from allanite.io.atomic import check_output_path
from allanite.report import Datasheet, DeviceAnalysis, build_report

__all__ = ["register", "run"]

EXAMPLES = """examples:
  allanite report --example -o report.html
  allanite report run1.npz --key gyro_counts --fs 100 --scale 0.05 --units deg/s -o run1.html
  allanite report dut.csv --time-column t --units deg/s --reference ref.csv \\
      --datasheet limits.json -o dut.html --png
  allanite report real.npy --fs 400 --units rad/s --sim-model model.json -o gap.html
  allanite report imu.csv --time-column t --channels gx,gy,gz,ax,ay,az \\
      --units deg/s,m/s^2 -o imu.html                    # six-axis: gyro and accelerometer

exit codes: 0 report written (datasheet passed or not given), 1 report written but a datasheet
limit failed, 2 bad input (nothing written).

limits.json: {"device": "...", "limits": [{"quantity": "N", "max": 0.3, "unit": "deg/sqrt(h)"},
              {"quantity": "adev", "tau": 1, "max": 0.01, "unit": "deg/s"}]}
"""


def register(subparsers: Any) -> None:
    """Add the ``report`` subcommand."""
    parser = subparsers.add_parser(
        "report",
        help=SUMMARIES["report"],
        description="Analyse one or more records and write one self-contained HTML report: "
        "record summary, Allan deviation plot, fitted noise coefficients in customary units "
        "with intervals, slope table, comparison with a reference device or datasheet limits, "
        "and (with --sim-model) the sim-to-real diagnosis.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("files", nargs="*", metavar="FILE", help="record files")
    parser.add_argument("--example", action="store_true", help="report on the example record")
    parser.add_argument(
        "-o",
        "--output",
        help="HTML file to write (default: the record's name with .html, in the current "
        "directory: report.html for --example)",
    )
    parser.add_argument("--title", help="page title")
    parser.add_argument(
        "--reference", metavar="FILE", help="reference device record (same options)"
    )
    parser.add_argument("--datasheet", metavar="LIMITS.json", help="datasheet limits to check")
    parser.add_argument(
        "--sim-model",
        metavar="CONFIG",
        help="simulated sensor to diagnose against: a model JSON or a simulator/estimator IMU "
        "config (Gazebo SDF, PX4, AirSim, Kalibr, OpenVINS, ORB-SLAM3, VINS, MATLAB, "
        "gnss-ins-sim), as for allanite diagnose",
    )
    add_sim_config_arguments(parser, corrected=False)
    parser.add_argument(
        "--n-mc",
        type=int,
        default=200,
        help="Monte Carlo replicates of the diagnosis null (default 200; at least 20)",
    )
    parser.add_argument("--no-fit", action="store_true", help="skip the noise-model fit")
    parser.add_argument("--png", action="store_true", help="also export the figures as PNG")
    parser.add_argument("--pdf", action="store_true", help="also export the figures as PDF")
    parser.add_argument("--json", action="store_true", help="print the verdict and checks as JSON")
    add_record_arguments(parser)
    add_still_argument(parser)
    add_grid_arguments(parser)
    parser.set_defaults(func=run)


def fit_channels(device: DeviceAnalysis) -> tuple[Any, ...]:
    """Fit a noise model to every channel (None per channel when fitting is unavailable)."""
    from allanite.cli.fit import fit_result

    channels = range(device.result.n_channels)
    return tuple(
        fit_result(device.result.channel(c))
        for c in progress(channels, desc="fitting", total=len(channels))
    )


def _diagnose_device(
    device: DeviceAnalysis, args: argparse.Namespace
) -> list[tuple[str, Any, list[str]]]:
    """``(channel, diagnosis, config changes)`` of every channel of one device.

    The config is read as ``allanite diagnose`` reads it (any format, in the device's unit);
    a device whose sensor the config holds no model of is listed as not diagnosed, with why.
    """
    from allanite.report.diagnosis import run_diagnosis

    record = device.record
    prefix = f"{device.name}: " if device.name else ""
    try:
        loaded = load_sim_model(args, record.longest_segment().require_fs(), rate_unit(record))
    except ValueError as exc:
        if "holds no" not in str(exc):
            raise
        return [(prefix + c, None, [str(exc)]) for c in record.channels]
    out = []
    channels = range(len(record.channels))
    for c in progress(channels, desc="diagnosing", total=len(channels)):
        diagnosis = run_diagnosis(record, loaded.model, c, n_mc=args.n_mc)
        changes = config_changes(args, loaded, diagnosis)
        out.append((prefix + record.channels[c], diagnosis, changes))
    return out


def diagnosis_parts(
    devices: list[DeviceAnalysis], args: argparse.Namespace
) -> tuple[str, dict[str, Any]]:
    """HTML and figures of the sim-to-real diagnosis of every channel against ``--sim-model``.

    One verdict per channel (an overview table first), the config changes each would need,
    and each channel's three views.
    """
    from allanite.report.diagnosis import channels_html

    items = [item for device in devices for item in _diagnose_device(device, args)]
    name = Path(args.sim_model).name
    html = channels_html(items, model_name=name)
    figures: dict[str, Any] = {}
    try:
        from allanite.plot.diagnosis import diagnosis_figure
    except ImportError:
        return html, figures
    for channel, diagnosis, _ in items:
        if diagnosis is not None:
            figures["views-" + re.sub(r"[^\w.-]+", "_", channel)] = diagnosis_figure(diagnosis)
    return html, figures


def _sensor_name(record: Any) -> str:
    from allanite.units import sensor_kind

    return f"{sensor_kind(rate_unit(record) or 'unit')}, {record.units}"


def _default_output(args: argparse.Namespace) -> str:
    """``-o`` when not given: ``NAME.html`` in the current directory for one record."""
    if len(args.files) > 1:
        raise ValueError(f"{len(args.files)} records go into one report: name it with -o FILE.html")
    if not args.files:
        return "report.html"
    stem = Path(args.files[0].rstrip("/\\")).stem  # a ROS 2 bag is a directory
    return f"{stem or 'report'}.html"


def run(args: argparse.Namespace) -> int:
    """Run ``allanite report``."""
    if args.output is None:
        args.output = _default_output(args)
    if Path(args.output).suffix.lower() not in (".html", ".htm"):
        raise ValueError(f"output {args.output}: give an .html file name")
    check_output_path(args.output)  # before the analysis, not after it
    if not args.files and not args.example:
        raise ValueError("give at least one record FILE, or --example")
    from allanite.cli.fit import thermal_fits

    sheet = Datasheet.load(args.datasheet) if args.datasheet else None
    check_sim_model(args)  # before the records: a bag may take minutes to read
    sources: list[str | None] = list(args.files) or [None]
    devices = []
    for path in progress(sources, desc="analysing", total=len(sources)):
        sensors, thermal = thermal_fits(read_sensors(path, args), args)
        for record in sensors:
            warm, thermal = tuple(thermal[: record.n_channels]), thermal[record.n_channels :]
            name = ""
            if len(sensors) > 1:  # one device per sensor of a six-axis record
                name = f"{Path(record.source).name} ({_sensor_name(record)})"
            result = avar_from_args(record, args)
            device = DeviceAnalysis(
                warn_implausible(record, args, result), result, name=name, thermal=warm
            )
            if not args.no_fit:
                device = dataclasses.replace(device, fits=fit_channels(device))
            devices.append(device)
    reference = None
    if args.reference:
        ref_record = read_from_args(args.reference, args)
        ref_result = avar_from_args(ref_record, args)
        reference = DeviceAnalysis(warn_implausible(ref_record, args, ref_result), ref_result)
        if not args.no_fit:
            reference = DeviceAnalysis(reference.record, reference.result, fit_channels(reference))
    diag_html = None
    diag_figures = None
    if args.sim_model:
        diag_html, diag_figures = diagnosis_parts(devices, args)
    report = build_report(
        devices,
        reference=reference,
        datasheet=sheet,
        diagnosis_html=diag_html,
        diagnosis_figures=diag_figures,
        level=args.level,
        title=args.title,
    )
    report.write(args.output)
    exported: list[Path] = []
    stem = Path(args.output).with_suffix("")
    for fmt, wanted in (("png", args.png), ("pdf", args.pdf)):
        if wanted:
            exported += report.export_figures(stem, fmt)
    if args.json:
        data = report.to_dict()
        data.update({"output": args.output, "figures": [str(p) for p in exported]})
        print(dump_json(data))
    else:
        print(f"wrote {args.output}")
        for figure_path in exported:
            print(f"wrote {figure_path}")
        if sheet is not None:
            from allanite.datasheet import status_text, verdict

            failed = [c for c in report.checks if c.status == "fail"]
            overall = status_text(verdict(c.status for c in report.checks))  # as the HTML badge
            print(
                f"datasheet {sheet.device}: {overall}"
                + (f" ({len(failed)} limit(s) failed)" if failed else "")
            )
    return 0 if report.passed else 1
