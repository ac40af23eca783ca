"""``allanite batch``: coefficients and pass/fail of many recordings in one table."""

from __future__ import annotations

import argparse
import glob
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from allanite.cli.record_options import add_record_arguments, read_options
from allanite.io.atomic import atomic_output

__all__ = ["progress_bars", "register", "run"]

EXAMPLES = """examples:
  allanite batch 'lot42/*.npy' --fs 2000 --units deg/s --datasheet sheet.json -o lot42.csv
  allanite batch 'logs/**/*.csv' --time-column t --channels gx,gy,gz --json
  allanite batch 'lot42/*.bin' --dtype int16 --n-channels 3 --fs 1000 --scale 0.01 \\
      --datasheet sheet.yaml --dask tcp://scheduler:8786
  allanite batch 'big/*.npy' --fs 1000 --memory-limit 1GB --dask local:2

A datasheet is JSON or YAML: {"N": 0.01, "B": {"max": 0.003}, "K": {"min": 0, "max": 1e-4}}
(numbers are upper limits; names are the coefficient columns Q, N, B, K, R in the record's
units times seconds^p). Exit code 0 when every record passes, 1 when one fails, 2 on bad input.
"""


def register(subparsers: Any) -> None:
    """Add the ``batch`` subcommand."""
    parser = subparsers.add_parser(
        "batch",
        help="noise coefficients and datasheet pass/fail of many recordings",
        description="Analyse every file matching the patterns: Allan variance, coefficients "
        "Q, N, B, K, R per channel, pass/fail against a datasheet; one table out. Runs "
        "locally, or on a Dask cluster with --dask.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "patterns", nargs="+", metavar="GLOB", help="files or glob patterns (** ok)"
    )
    add_record_arguments(parser)
    group = parser.add_argument_group("batch")
    group.add_argument("--datasheet", help="JSON or YAML file of coefficient limits")
    group.add_argument("-o", "--output", help="write the table to this .csv or .json file")
    group.add_argument("--json", action="store_true", help="print the table as JSON")
    group.add_argument(
        "--kind",
        choices=("overlapping", "standard", "hadamard", "standard_hadamard", "modified", "total"),
        default="overlapping",
        help="estimator (default overlapping)",
    )
    group.add_argument("--points", type=int, default=100, help="points of the log tau grid")
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
    bar.add_argument("--progress", dest="progress", action="store_true", default=None)
    bar.add_argument("--no-progress", dest="progress", action="store_false")
    parser.set_defaults(func=run)


def _expand(patterns: list[str]) -> list[str]:
    paths: list[str] = []
    for pattern in patterns:
        matches = sorted(glob.glob(pattern, recursive=True))
        if not matches and Path(pattern).exists():
            matches = [pattern]
        paths += [m for m in matches if Path(m).is_file() and m not in paths]
    if not paths:
        raise ValueError(f"no files match {' '.join(patterns)}; check the pattern (quote it)")
    return paths


@contextmanager
def progress_bars(enabled: bool | None = None) -> Iterator[Any]:
    """Yield a ``progress(stage, done, total)`` callback drawing one tqdm bar per stage.

    ``enabled=None`` draws the bars when stderr is a terminal and tqdm (the ``progress``
    extra) is installed; without tqdm the callback does nothing.
    """
    use = sys.stderr.isatty() if enabled is None else enabled
    tqdm: Any = None
    if use:
        try:
            import tqdm as tqdm_module
        except ImportError:
            pass
        else:
            tqdm = tqdm_module.tqdm
    bars: dict[str, Any] = {}

    def callback(stage: str, done: int, total: int) -> None:
        if tqdm is None:
            return
        bar = bars.get(stage)
        if bar is None:
            for other in bars.values():
                other.close()
            bars.clear()
            bar = bars[stage] = tqdm(total=total, desc=stage, file=sys.stderr, leave=False)
        bar.total = total
        bar.update(done - bar.n)

    try:
        yield callback
    finally:
        for bar in bars.values():
            bar.close()


@contextmanager
def _client(address: str | None) -> Iterator[Any]:
    if address is None:
        yield None
        return
    try:
        import distributed
    except ImportError as exc:
        raise ValueError("--dask needs dask: pip install 'allanite[dask]'") from exc
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


def _text_table(columns: tuple[str, ...], rows: tuple[tuple[Any, ...], ...]) -> str:
    def cell(v: Any) -> str:
        if v is None:
            return "-"
        if isinstance(v, bool):
            return "PASS" if v else "FAIL"
        if isinstance(v, float):
            return f"{v:.4g}"
        return str(v)

    cells = [[cell(v) for v in row] for row in rows]
    widths = [max([len(c)] + [len(r[i]) for r in cells]) for i, c in enumerate(columns)]
    lines = ["  ".join(c.ljust(w) for c, w in zip(columns, widths, strict=True))]
    lines += ["  ".join(v.ljust(w) for v, w in zip(r, widths, strict=True)) for r in cells]
    return "\n".join(line.rstrip() for line in lines)


def run(args: argparse.Namespace) -> int:
    """Run ``allanite batch``; exit code 0 if every record passed, 1 if one failed."""
    from allanite.batch import batch

    paths = _expand(args.patterns)
    if args.output and Path(args.output).suffix.lower() not in (".csv", ".json"):
        raise ValueError(f"--output {args.output}: use a .csv or .json file name")
    options = read_options(args)
    with _client(args.dask) as client, progress_bars(args.progress) as bar:
        result = batch(
            paths,
            args.fs,
            datasheet=args.datasheet,
            client=client,
            kind=args.kind,
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
    print(result.to_json(indent=1) if args.json else _text_table(result.columns, result.rows))
    return 0 if result.passed else 1
