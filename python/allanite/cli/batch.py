"""``allanite batch``: coefficients and pass/fail of many recordings in one table."""

from __future__ import annotations

import argparse
import glob
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from allanite.cli import cli_spelling
from allanite.cli.commands import SUMMARIES
from allanite.cli.progress import progress_bars
from allanite.cli.record_options import add_record_arguments, read_options
from allanite.confidence import DEFAULT_LEVEL
from allanite.extras import require
from allanite.io.atomic import atomic_output

__all__ = ["register", "run"]

EXAMPLES = """examples:
  allanite batch 'lot42/*.npy' --fs 2000 --units deg/s --datasheet sheet.json -o lot42.csv
  allanite batch 'logs/**/*.csv' --time-column t --channels gx,gy,gz --json
  allanite batch 'lot42/*.bin' --dtype int16 --n-channels 3 --fs 1000 --scale 0.01 \\
      --datasheet sheet.yaml --dask tcp://scheduler:8786
  allanite batch 'big/*.npy' --fs 1000 --memory-limit 1GB --dask local:2
  allanite batch 'lot7/*.npy' --fs 400 --units deg/s --terms N,B,K --level 0.99 --json

Every channel is fitted (allanite fit, terms chosen automatically unless --terms) and each
coefficient is reported with its --level confidence interval and the fit's p-value.
A datasheet is JSON or YAML, compact in the record's units
  {"N": 0.01, "B": {"max": 0.003}, "K": {"min": 0, "max": 1e-4}}
(numbers are upper limits; N in unit*sqrt(s), B in unit, K in unit/sqrt(s)) or with units
  {"device": "...", "limits": [{"quantity": "N", "max": 0.3, "unit": "deg/sqrt(h)"},
                              {"quantity": "adev", "tau": 1, "max": 0.01, "unit": "deg/s"}]}
A limit PASSes when the whole interval meets it, is MARGINAL when only the interval crosses
it, FAILs when the estimate violates it. A term the fit did not detect is judged by its upper
limit (column <name>_upper): PASS when within the limit, NOT DETERMINED (<= upper) when above
(the record cannot tell). Exit code 0 when no record fails (MARGINAL and NOT DETERMINED are
undecided, not failures), 1 when one fails or cannot be analysed, 2 on bad input.
"""


def register(subparsers: Any) -> None:
    """Add the ``batch`` subcommand."""
    parser = subparsers.add_parser(
        "batch",
        help=SUMMARIES["batch"],
        description="Analyse every file matching the patterns: overlapping Allan variance, "
        "noise-model fit per channel (coefficients with confidence intervals, goodness of "
        "fit), pass/marginal/fail against a datasheet; one table out. Runs locally, or on a "
        "Dask cluster with --dask.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "patterns", nargs="+", metavar="GLOB", help="files or glob patterns (** ok)"
    )
    add_record_arguments(parser)
    group = parser.add_argument_group("batch")
    group.add_argument("--datasheet", help="JSON or YAML file of limits (see below)")
    group.add_argument("-o", "--output", help="write the table to this .csv or .json file")
    group.add_argument("--json", action="store_true", help="print the table as JSON")
    group.add_argument(
        "--terms",
        default="auto",
        help="terms to fit, comma separated (Q,N,B,K,R, markov, sine; default auto: chosen "
        "from Q,N,B,K,R)",
    )
    group.add_argument(
        "--level",
        type=float,
        default=DEFAULT_LEVEL,
        help="confidence level of the intervals and the datasheet checks (default 0.95)",
    )
    group.add_argument(
        "--points", type=int, default=100, help="points of the log tau grid (default 100)"
    )
    group.add_argument("--threads", type=int, help="threads per record (default: all cores)")
    group.add_argument(
        "--memory-limit", help="memory budget per record, e.g. 1GB (larger phases go to disk)"
    )
    group.add_argument(
        "--dask",
        metavar="ADDRESS",
        help="run on a Dask cluster: a scheduler address, or local[:WORKERS] for a local one "
        "(needs the dask extra)",
    )
    bar = group.add_mutually_exclusive_group()
    bar.add_argument(
        "--progress",
        dest="progress",
        action="store_true",
        default=None,
        help="progress bar even when stderr is not a terminal",
    )
    bar.add_argument("--no-progress", dest="progress", action="store_false", help="no bar")
    parser.set_defaults(func=run)


def _expand(patterns: list[str]) -> list[str]:
    """The records the patterns match: files, and ROS 2 bag directories (``metadata.yaml``)."""
    from allanite.io.robot_logs import is_ros2_bag_dir

    paths: list[str] = []
    for pattern in patterns:
        matches = sorted(glob.glob(pattern, recursive=True))
        if not matches and Path(pattern).exists():
            matches = [pattern]
        # a directory the pattern names (not one ``**`` walks through) gets an error row
        # from the reader ("is a directory"), never silently dropped
        named_dirs = Path(pattern).name != "**"
        paths += [
            m
            for m in matches
            if (Path(m).is_file() or is_ros2_bag_dir(Path(m)) or (named_dirs and Path(m).is_dir()))
            and m not in paths
        ]
    if not paths:
        raise ValueError(f"no files match {' '.join(patterns)}; check the pattern (quote it)")
    return paths


@contextmanager
def _client(address: str | None) -> Iterator[Any]:
    if address is None:
        yield None
        return
    distributed = require("distributed", extra="dask", purpose="--dask")
    if address == "local" or address.startswith("local:"):
        workers = int(address.split(":", 1)[1]) if ":" in address else None
        with (
            distributed.LocalCluster(
                n_workers=workers, threads_per_worker=1, dashboard_address=None
            ) as cluster,
            distributed.Client(cluster) as client,
        ):
            yield client
    else:
        with distributed.Client(address) as client:
            yield client


def _cell(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "PASS" if v else "FAIL"
    if isinstance(v, float):
        return f"{v:.4g}"
    if v == "undetermined":
        return "NOT DETERMINED"
    return str(v).upper() if v in ("pass", "marginal", "fail", "missing", "error") else str(v)


def _display_unit(rate: str | None, name: str) -> tuple[str, float]:
    """``(unit, factor)`` of coefficient ``name`` of a model in ``rate``, as ``allanite fit``.

    The customary unit (:func:`allanite.units.customary_unit`: N in deg/sqrt(h), ...) and the
    factor from the model's unit to it.
    """
    from allanite.units import RECORD_UNIT, SYMBOL_POWERS, coefficient_unit, convert, customary_unit

    own = coefficient_unit(rate or RECORD_UNIT, *SYMBOL_POWERS[name]).text
    if rate is None:
        return own, 1.0
    shown = customary_unit(rate, name, own)
    return shown, convert(1.0, own, shown)


def _customary(values: dict[str, Any], shown: list[str]) -> dict[str, Any]:
    """A row's coefficient values, low and high in the customary units of its rate unit."""
    from allanite.units import SYMBOL_POWERS

    out = dict(values)
    for name in (c for c in shown if c in SYMBOL_POWERS):
        _, factor = _display_unit(values.get("units"), name)
        for key in (name, f"{name}_low", f"{name}_high", f"{name}_upper"):
            if isinstance(out.get(key), float):
                out[key] = out[key] * factor
    return out


def _text_table(result: Any, limits: bool = True) -> str:
    """Aligned text: one column per coefficient as ``value [low, high]``, checks, status.

    Coefficients are shown in the customary units ``allanite fit`` prints (the CSV and JSON
    outputs keep the model's units, named in their ``units`` column). Without datasheet
    ``limits`` a fitted record's status is ``OK``, not ``PASS`` (nothing was checked).
    """
    columns = list(result.columns)
    shown = [c for c in columns if c not in ("n_samples", "fs", "units", "pass", "error")]
    shown = [c for c in shown if not c.endswith(("_low", "_high", "_upper"))]
    header = [c if c != "p_value" else "p" for c in shown]
    # check_<quantity>[_k] column -> its limit's quantity (the columns follow the limits)
    sheet = result.datasheet.limits if result.datasheet is not None else ()
    checks = [c for c in columns if c.startswith("check_")]
    quantity = dict(zip(checks, [x.quantity for x in sheet], strict=True))
    cells = []
    for row in result.rows:
        values = _customary(dict(zip(columns, row, strict=True)), shown)
        line = []
        for c in shown:
            if c == "rejected":  # flag a rejected model plainly, leave the others blank
                line.append("REJECTED" if values[c] else "-")
                continue
            text = _cell(values[c])
            if c == "status" and not limits and values[c] == "pass":
                text = "OK"
            if f"{c}_low" in values and values[c] is not None:
                text += f" [{_cell(values[c + '_low'])}, {_cell(values[c + '_high'])}]"
            elif values.get(f"{c}_upper") is not None:  # not detected: its upper limit
                text = f"<={_cell(values[c + '_upper'])}"
            upper = values.get(f"{quantity.get(c)}_upper")
            if c.startswith("check_") and upper is not None and values[c] == "undetermined":
                text = f"NOT DETERMINED (<= {_cell(upper)})"
            line.append(text)
        cells.append(line)
    widths = [max([len(h)] + [len(r[i]) for r in cells]) for i, h in enumerate(header)]
    lines = ["  ".join(h.ljust(w) for h, w in zip(header, widths, strict=True))]
    lines += ["  ".join(v.ljust(w) for v, w in zip(r, widths, strict=True)) for r in cells]
    errors = [
        values["error"]
        if str(values["error"]).startswith(f"{values['record']}: ")
        else f"{values['record']}: {values['error']}"
        for values in (dict(zip(columns, row, strict=True)) for row in result.rows)
        if values["error"]
    ]
    return "\n".join(
        [line.rstrip() for line in lines]
        + _unit_legend(result, shown)
        + [f"error: {cli_spelling(e)}" for e in errors]
    )


def _unit_legend(result: Any, shown: list[str]) -> list[str]:
    """One line per display unit set of the table: what unit each coefficient column is in."""
    from allanite.units import SYMBOL_POWERS

    names = [c for c in shown if c in SYMBOL_POWERS]
    if not names or "units" not in result.columns:
        return []
    lines = []
    errors = result.column("error") if "error" in result.columns else [None] * len(result)
    legends = dict.fromkeys(
        (rate is None, ", ".join(f"{n} in {_display_unit(rate, n)[0]}" for n in names))
        for rate, error in zip(result.column("units"), errors, strict=True)
        if not error  # a row that could not be analysed has no coefficients
    )
    for unitless, units in legends:  # deg/s and deg/h records share one legend line
        if unitless:
            lines.append(
                f"units: the records have no unit (give --units): coefficients in record units, "
                f"{units}"
            )
        else:
            lines.append(f"units: {units}")
    return lines


def _terms(text: str) -> str | list[str]:
    if text.strip() == "auto":
        return "auto"
    names = [t.strip() for t in text.split(",") if t.strip()]
    if not names:
        raise ValueError(f"--terms {text!r}: give auto or names like N,B,K")
    return names


def run(args: argparse.Namespace) -> int:
    """Run ``allanite batch``; exit code 0 if no record failed, 1 if one failed."""
    from allanite.batch import batch

    paths = _expand(args.patterns)
    if args.output and Path(args.output).suffix.lower() not in (".csv", ".json"):
        raise ValueError(f"--output {args.output}: use a .csv or .json file name")
    options = read_options(args).as_dict()
    options.pop("fs")  # given to batch() as its own argument
    with _client(args.dask) as client, progress_bars(args.progress) as bar:
        result = batch(
            paths,
            fs=args.fs,
            datasheet=args.datasheet,
            terms=_terms(args.terms),
            level=args.level,
            client=client,
            points=args.points,
            threads=args.threads,
            memory_limit=args.memory_limit,
            progress=bar,
            **options,
        )
    if args.output:
        with atomic_output(args.output) as tmp:
            if Path(args.output).suffix.lower() == ".json":
                tmp.write_text(result.to_json(indent=1) + "\n")
            else:
                result.to_csv(tmp)
    print(result.to_json(indent=1) if args.json else _text_table(result, bool(args.datasheet)))
    return 0 if result.passed else 1
