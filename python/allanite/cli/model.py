"""``allanite model convert``: convert an IMU noise model between simulator/estimator formats."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from typing import Any

import numpy as np

from allanite.cli.commands import SUMMARIES
from allanite.formats import FORMATS, read_config, write_config
from allanite.formats.base import ImuConfig
from allanite.formats.projection import adev_error, default_tau_range

__all__ = ["register", "run"]

EXAMPLES = (
    """examples:
  allanite model convert model.json kalibr.yaml --rate 200
  allanite model convert model.sdf imu.yaml --to kalibr          # rate from <update_rate>
  allanite model convert kalibr.yaml px4_imu.sdf --to px4-plugin
  allanite model convert settings.json gyro.m --rate 400 --tau-range 0.1 1000

formats:
"""
    + "\n".join(f"  {name:<15} {m.TITLE}" for name, m in FORMATS.items())
    + """

What the target format cannot hold is projected (slow terms onto its Gauss-Markov bias or
random walk, matching the Allan deviation over the stated tau range) or dropped; both are
listed on stderr and in the written file.
"""
)


def register(subparsers: Any) -> None:
    """Add the ``model`` subcommand (with ``convert``)."""
    parser = subparsers.add_parser(
        "model",
        help=SUMMARIES["model"],
        description="Work with IMU noise models in the formats simulators and estimators read.",
        epilog="examples:\n  allanite model convert model.json kalibr.yaml --rate 200\n"
        "Run 'allanite model convert --help' for the formats and more examples.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="model_command", metavar="ACTION", required=True)
    conv = sub.add_parser(
        "convert",
        help="convert between model JSON and simulator/estimator IMU configs",
        description="Read an IMU noise config (gz-sensors SDF, PX4 plugin, Kalibr, OpenVINS, "
        "ORB-SLAM3, VINS, AirSim, MATLAB, gnss-ins-sim, model JSON) with its simulator's "
        "discrete law and write it in another format.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    conv.add_argument("input", metavar="IN", help="model or config file")
    conv.add_argument("output", metavar="OUT", help="file to write")
    conv.add_argument("--from", dest="from_format", choices=tuple(FORMATS), help="input format")
    conv.add_argument("--to", dest="to_format", choices=tuple(FORMATS), help="output format")
    conv.add_argument(
        "--rate",
        type=float,
        help="IMU update rate in Hz (needed by per-sample formats when the file has none)",
    )
    conv.add_argument(
        "--template",
        help="config to write into (its other settings are kept); default: a new file",
    )
    conv.add_argument(
        "--tau-range",
        nargs=2,
        type=float,
        metavar=("LO", "HI"),
        help="averaging times in s a projection matches (default 10 samples to 1 h)",
    )
    conv.add_argument(
        "--sensor",
        choices=("gyro", "accel"),
        help="convert only this sensor's model (a model JSON holds one: the gyro's by default)",
    )
    conv.set_defaults(func=run)


_OTHER = {"gyro": "accel:", "accel": "gyro:"}


def run(args: argparse.Namespace) -> int:
    """Run ``allanite model convert``."""
    if args.rate is not None and not args.rate > 0:
        raise ValueError(f"--rate must be a positive frequency in Hz, got {args.rate}")
    config = read_config(args.input, format=args.from_format, rate=args.rate)
    if args.sensor is not None:
        kept = config.model(args.sensor, option="--sensor")  # a clear error when it has none
        config = dataclasses.replace(
            config,
            gyro=kept if args.sensor == "gyro" else None,
            accel=kept if args.sensor == "accel" else None,
            notes=tuple(n for n in config.notes if not n.startswith(_OTHER[args.sensor])),
        )
    rate = args.rate or config.rate
    for note in config.notes:
        print(f"note: {note}", file=sys.stderr)
    written = write_config(
        config,
        args.output,
        format=args.to_format,
        rate=rate,
        template=args.template,
        tau_range=tuple(args.tau_range) if args.tau_range else None,
        read_back=True,  # check_written reads it: a missing reader extra fails before writing
    )
    for line in written.report():
        print(line, file=sys.stderr)
    checks = check_written(
        config,
        args.output,
        args.to_format,
        rate,
        args.tau_range,
        template=args.template,
        report=tuple(written.report()),
    )
    for line in checks:
        print(f"allanite model convert: warning: {line}", file=sys.stderr)
    return 0


#: a written model whose Allan deviation departs from the source's by more than this (over the
#: projection's tau range) is warned about on stderr
POOR_ADEV_ERROR = 0.25


def check_written(
    source: ImuConfig,
    path: str,
    format: str | None,
    rate: float | None,
    tau_range: list[float] | None,
    *,
    template: str | None = None,
    report: tuple[str, ...] = (),
) -> list[str]:
    """What a user must know about the written file, read back as the simulator reads it.

    A sensor of the source missing from the output (unless the ``template`` written into
    holds it: its entries are kept), and a sensor whose read-back Allan
    deviation departs from the source's by more than :data:`POOR_ADEV_ERROR` anywhere over
    the tau range (default: 10 samples to one hour; at 100 Hz without a rate). ``report``
    (the writer's :meth:`~allanite.formats.Written.report` lines) lets the warning point at
    the lines that say why: ``projected`` or ``dropped``.
    """
    back = read_config(path, format=format, rate=rate)
    dt = 1.0 / (rate or back.rate or 100.0)
    lo, hi = tau_range if tau_range else default_tau_range(dt)
    taus = np.geomspace(lo, hi, 60)
    out = []
    for sensor in ("gyro", "accel"):
        model = getattr(source, sensor)
        if model is None:
            if back.source_format == "allanite":
                continue  # a model JSON holds one sensor by design
            if template is not None and getattr(back, sensor) is not None:
                continue  # the template's own entries, kept
            if getattr(back, sensor) is not None:  # the format requires the entries
                out.append(
                    f"{path} has {sensor} noise entries of zero: the source holds no {sensor} "
                    "model and the format needs the entries (for a noisy sensor set them by "
                    "hand, or convert a config that holds both sensors)"
                )
                continue
            out.append(
                f"{path} has no {sensor} noise entries: the source holds no {sensor} model "
                "(add them by hand if the simulator or estimator needs them)"
            )
            continue
        written = getattr(back, sensor)
        if written is None:
            if back.source_format != "allanite":  # a model JSON: the writer's 'dropped' line
                out.append(f"{path} lost the {sensor} model (the format cannot hold it)")
            continue
        worst = adev_error(written, model.avar(taus, dt), taus, dt)
        if worst > POOR_ADEV_ERROR:
            kinds = [k for k in ("projected", "dropped") if f"{k} {sensor}" in "\n".join(report)]
            seen = "/".join(f"'{k}'" for k in kinds) or "'projected' or 'dropped'"
            out.append(
                f"the written {sensor} model departs from the source by up to {100 * worst:.0f} % "
                f"in Allan deviation over {lo:.3g}-{hi:.3g} s: the format cannot hold the "
                f"source's terms (see the {seen} lines); check it before use"
            )
    return out
