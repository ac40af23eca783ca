"""Speed of every variance kind against allantools, the numpy oracle and the memory floor.

One run measures, for each record size (white rate noise with a bias, log grid of averaging
factors common to all kinds, i.e. m <= M/3), and for the kinds overlapping, modified,
Hadamard and total:

* ``end_to_end``: ``allanite.avar`` with the noise type identified (``alpha=None``), and
  ``given_alpha``: with ``alpha=0`` (no identification); all cores;
* the compiled parts alone: ``phase`` (``_core.phase``), ``kernel`` (``_core.variance``)
  and ``identification`` (``identify_alpha`` on the same phase, lag-1 and B1/R(n) passes);
* ``allantools``: ``oadev``/``mdev``/``ohdev``/``totdev`` on the same frequency data and taus;
* ``oracle``: the numpy oracle (:mod:`allanite.variance.oracle`, vectorised per tau; its modified
  variance is O(N m) per tau, so there only the taus with m <= 16 are timed, against the
  kernel on the same taus);

and derives the ratios of the goals of issue 17: allantools / end-to-end (>= 10 for every
kind, >= 20 for the overlapping kind at 1e7 samples and 100 taus), kernel time per tau of each
kind / the overlapping kernel's (<= 2), identification / kernel (<= 0.5). The memory floor of
a kernel is the time to stream the phase once per tau (``8 M`` bytes per tau) at the
bandwidth of a numpy copy measured in the same run (read + write bytes / time); a kernel
below its floor shares passes between taus (tiles in cache).

The two sides of every goal's ratio are timed in pairs (:func:`paired_runs`), ``--pairs``
times each, alternately (A then B, then B then A, ...), so that a change of the machine's
load hits both sides of a pair: end to end against allantools, each kind's kernel against
the overlapping kernel, the identification against the kernel. Each goal uses the median of
its paired ratios, reported with the inter-quartile range (:func:`ratio_summary`); next to
the median against allantools the best-of-k ratio (fastest allantools run / fastest allanite
run of the same pairs). Best-of-k alone is noisy at these margins: on a shared machine each
side's fastest run comes from a different moment. The seconds reported are the fastest of
the pairs; the other timings (given alpha, phase, oracle) the best of ``--repeat``. Every
timing follows one untimed warm-up call (allantools and the oracle included, so that no kind
runs cold); the 1-minute load average is recorded before and after each record size and each
kind, since the machine may be shared.

Writes benchmarks/results/bench_kinds.json and .md.

Usage: ``python benchmarks/bench_kinds.py [--sizes 1000000:50 10000000:100:1:3] [--repeat 3]
[--pairs 15] [--out STEM] [--results DIR]`` (``N:points[:repeat[:pairs]]``; the default times
1e7 samples once for the best-of timings and in 3 pairs).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Literal

import numpy as np

import allanite
from allanite import _core
from allanite.variance import oracle as numpy_oracle
from allanite.variance.edf import identify_alpha
from allanite.variance.taus import log_grid
from bench_core import _best  # the benchmarks' one best-of-N timer (same folder)

RESULTS = Path(__file__).resolve().parent / "results"
KindName = Literal["overlapping", "modified", "hadamard", "total"]
KINDS: tuple[KindName, ...] = ("overlapping", "modified", "hadamard", "total")
ALLANTOOLS = {"overlapping": "oadev", "modified": "mdev", "hadamard": "ohdev", "total": "totdev"}
GOAL_VS_ALLANTOOLS = 10.0
GOAL_OVERLAPPING_LARGE = 20.0  # at 1e7 samples and 100 log taus
GOAL_PER_TAU = 2.0
GOAL_IDENTIFICATION = 0.5
ORACLE_MODIFIED_MAX_M = 16


def copy_bandwidth(n_bytes: int, repeat: int) -> float:
    """Bytes per second of ``np.copyto`` on an array of ``n_bytes`` (read + write counted)."""
    src = np.ones(n_bytes // 8)
    dst = np.empty_like(src)
    np.copyto(dst, src)  # touch both
    seconds, _ = _best(lambda: np.copyto(dst, src), max(repeat, 3))
    return 2.0 * src.nbytes / seconds


def _warm_best(fn: Callable[[], Any], repeat: int) -> tuple[float, Any]:
    """``_best`` after one untimed call, so that no kind and no stage is timed cold (first
    touch of its arrays, first start of its threads, lazy imports)."""
    fn()
    return _best(fn, repeat)


def paired_runs(
    first: Callable[[], Any],
    second: Callable[[], Any],
    pairs: int,
    clock: Callable[[], float] = time.perf_counter,
) -> tuple[np.ndarray, np.ndarray, Any, Any]:
    """Seconds of ``pairs`` runs of ``first`` and of ``second``, timed alternately.

    After one untimed warm-up call of each, pair ``i`` runs ``first`` then ``second`` for even
    ``i`` and ``second`` then ``first`` for odd ``i``: a load that rises or falls during the
    measurement slows both sides of a pair alike, and neither side always runs right after the
    other (caches, clock boost).

    Returns
    -------
    tuple
        ``(seconds_first, seconds_second, last_result_first, last_result_second)``, the
        seconds as arrays of length ``pairs``.
    """
    if pairs < 1:
        raise ValueError(f"pairs must be at least 1, got {pairs}; pass --pairs 1 or more")
    fns = (first, second)
    seconds = np.empty((2, pairs))
    results: list[Any] = [fn() for fn in fns]  # warm-up
    for i in range(pairs):
        for side in (0, 1) if i % 2 == 0 else (1, 0):
            t0 = clock()
            results[side] = fns[side]()
            seconds[side, i] = clock() - t0
    return seconds[0], seconds[1], results[0], results[1]


def ratio_summary(fast: np.ndarray, slow: np.ndarray) -> dict[str, float]:
    """Median and quartiles of the paired ratios ``slow / fast``, and the best-of-k ratio.

    ``best_of`` is ``min(slow) / min(fast)``: the ratio of the two fastest runs, which may come
    from different moments of a shared machine.
    """
    fast, slow = np.asarray(fast, dtype=float), np.asarray(slow, dtype=float)
    if fast.shape != slow.shape or fast.ndim != 1 or fast.size == 0:
        raise ValueError(
            f"need two equal, non-empty 1-D series of paired seconds, got {fast.shape} and "
            f"{slow.shape}"
        )
    q25, median, q75 = np.percentile(slow / fast, [25.0, 50.0, 75.0])
    return {
        "pairs": float(fast.size),
        "median": float(median),
        "q25": float(q25),
        "q75": float(q75),
        "best_of": float(slow.min() / fast.min()),
    }


def _allantools(kind: str, y: np.ndarray, m: np.ndarray) -> np.ndarray:
    import allantools

    fn = getattr(allantools, ALLANTOOLS[kind])
    tau, dev = fn(y, rate=1.0, data_type="freq", taus=m.astype(float))[:2]
    if tau.size != m.size:
        raise RuntimeError(f"allantools.{ALLANTOOLS[kind]} returned {tau.size} of {m.size} taus")
    return np.asarray(dev, dtype=np.float64) ** 2


def bench_kind(
    kind: KindName,
    y: np.ndarray,
    phase: np.ndarray,
    m: np.ndarray,
    *,
    repeat: int,
    pairs: int,
    threads: int,
    oracle: bool,
    floor_per_tau: float,
) -> dict[str, Any]:
    """Timings and differences of one kind on one record (see the module docstring)."""
    load = os.getloadavg()[0]

    def kernel() -> np.ndarray:
        return np.asarray(_core.variance(phase, m, kind, threads))

    s_over, s_kernel, _, var = paired_runs(
        lambda: _core.variance(phase, m, "overlapping", threads), kernel, pairs
    )
    var1 = np.asarray(_core.variance(phase, m, kind, 1))
    s_kernel2, s_id, _, _ = paired_runs(
        kernel, lambda: identify_alpha(phase, m, kind, data="frequency", threads=threads), pairs
    )
    t_kernel = float(min(s_kernel.min(), s_kernel2.min()))
    t_given, _ = _warm_best(
        lambda: allanite.avar(y, fs=1.0, kind=kind, m=m, alpha=0, threads=threads), repeat
    )
    s_e2e, s_at, res, v_at = paired_runs(
        lambda: allanite.avar(y, fs=1.0, kind=kind, m=m, threads=threads),
        lambda: _allantools(kind, y, m),
        pairs,
    )
    entry: dict[str, Any] = {
        "seconds": {
            "kernel": t_kernel,
            "identification": float(s_id.min()),
            "end_to_end": float(s_e2e.min()),
            "given_alpha": t_given,
            "allantools": float(s_at.min()),
        },
        "paired": {
            "end_to_end_median_seconds": float(np.median(s_e2e)),
            "allantools_median_seconds": float(np.median(s_at)),
            "allantools_over_end_to_end": ratio_summary(s_e2e, s_at),
            "kernel_over_overlapping": ratio_summary(s_over, s_kernel),
            "identification_over_kernel": ratio_summary(s_kernel2, s_id),
        },
        "bit_identical_1_vs_all_threads": bool(np.array_equal(var[:, 0], var1[:, 0])),
        "max_rel_diff": {
            "end_to_end_vs_kernel": float(np.max(np.abs(res.var / var[:, 0] - 1))),
            "allantools": float(np.max(np.abs(v_at / var[:, 0] - 1))),
        },
        "memory_floor_seconds": floor_per_tau * m.size,
        "load_average_1min": {"before": load, "after": os.getloadavg()[0]},
    }
    if oracle:
        # the oracle's modified variance is O(N m) per tau: there it runs on m <= 16 only,
        # and its ratio is taken against the kernel on the same taus
        sub = m <= ORACLE_MODIFIED_MAX_M if kind == "modified" else np.ones(m.size, bool)
        t_ref, v_ref = _warm_best(
            lambda: np.asarray(numpy_oracle.variance(y, m[sub], kind, input="rate")).reshape(-1),
            repeat,
        )
        t_sub = t_kernel
        if not sub.all():
            t_sub, _ = _warm_best(lambda: _core.variance(phase, m[sub], kind, threads), repeat)
        entry["seconds"]["oracle"] = t_ref
        entry["oracle_taus"] = int(sub.sum())
        entry["max_rel_diff"]["oracle"] = float(np.max(np.abs(v_ref / var[sub, 0] - 1)))
        entry["oracle_over_kernel_same_taus"] = t_ref / t_sub
    return entry


def bench_size(
    n: int, points: int, repeat: int, pairs: int, threads: int, oracle: bool
) -> dict[str, Any]:
    """Every timing and ratio for one record size."""
    load_before = os.getloadavg()[0]
    rng = np.random.default_rng(12345)
    y = 0.01 + rng.standard_normal(n)  # rate samples, fs = 1 Hz
    x2 = y.reshape(-1, 1)
    m = log_grid(n, points)
    m = m[m <= min(_core.max_m(k, n + 1) for k in KINDS)]
    bandwidth = copy_bandwidth(8 * (n + 1), repeat)
    floor_per_tau = 8.0 * (n + 1) / bandwidth
    t_phase, phase = _warm_best(lambda: _core.phase(x2, "rate", threads), repeat)
    kinds = {
        kind: bench_kind(
            kind,
            y,
            phase,
            m,
            repeat=repeat,
            pairs=pairs,
            threads=threads,
            oracle=oracle,
            floor_per_tau=floor_per_tau,
        )
        for kind in KINDS
    }
    t_over = kinds["overlapping"]["seconds"]["kernel"]
    for entry in kinds.values():
        s = entry["seconds"]
        paired = entry["paired"]
        ratios = {
            "allantools_over_end_to_end": s["allantools"] / s["end_to_end"],
            "allantools_over_end_to_end_median": paired["allantools_over_end_to_end"]["median"],
            "allantools_over_given_alpha": s["allantools"] / s["given_alpha"],
            "kernel_per_tau_over_overlapping": s["kernel"] / t_over,
            "kernel_per_tau_over_overlapping_median": paired["kernel_over_overlapping"]["median"],
            "identification_over_kernel": s["identification"] / s["kernel"],
            "identification_over_kernel_median": paired["identification_over_kernel"]["median"],
            "kernel_over_memory_floor": s["kernel"] / entry["memory_floor_seconds"],
        }
        if "oracle" in s:
            ratios["oracle_over_kernel"] = entry["oracle_over_kernel_same_taus"]
        entry["ratios"] = ratios
    return {
        "n_samples": n,
        "points": points,
        "n_taus": int(m.size),
        "m_min": int(m[0]),
        "m_max": int(m[-1]),
        "threads": threads,
        "repeat": repeat,
        "pairs": pairs,
        "phase_seconds": t_phase,
        "copy_bandwidth_GBps": bandwidth / 1e9,
        "load_average_1min": {"before": load_before, "after": os.getloadavg()[0]},
        "kinds": kinds,
    }


def goals(record: dict[str, Any]) -> list[tuple[str, float, float, bool]]:
    """(goal, measured, bound, met) of issue 17 for one record size.

    Every goal is judged on the median of its paired ratios (see :func:`paired_runs`): end to
    end against allantools, each kernel against the overlapping one, the identification
    against the kernel; not on ratios of best-of-k timings taken at different moments.
    """
    out = []
    large = record["n_samples"] >= 10_000_000 and record["n_taus"] >= 90
    for kind, entry in record["kinds"].items():
        r = entry["ratios"]
        bound = GOAL_OVERLAPPING_LARGE if (kind == "overlapping" and large) else GOAL_VS_ALLANTOOLS
        median = r["allantools_over_end_to_end_median"]
        out.append(
            (f"{kind}: allantools / allanite (identified), median", median, bound, median >= bound)
        )
        if kind in ("modified", "total"):
            v = r["kernel_per_tau_over_overlapping_median"]
            out.append(
                (
                    f"{kind}: kernel per tau / overlapping, median",
                    v,
                    GOAL_PER_TAU,
                    v <= GOAL_PER_TAU,
                )
            )
        v = r["identification_over_kernel_median"]
        out.append(
            (
                f"{kind}: identification / kernel, median",
                v,
                GOAL_IDENTIFICATION,
                v <= GOAL_IDENTIFICATION,
            )
        )
    return out


def _spread(summary: dict[str, float], fmt: str, unit: str = "") -> str:
    """``median [q25-q75]`` of a :func:`ratio_summary` (``unit`` after the median)."""
    return f"{summary['median']:{fmt}}{unit} [{summary['q25']:{fmt}}-{summary['q75']:{fmt}}]"


def markdown(records: list[dict[str, Any]]) -> str:
    lines = ["# Every variance kind against allantools (benchmarks/bench_kinds.py)", ""]
    for rec in records:
        load = rec["load_average_1min"]
        lines += [
            f"## N = {rec['n_samples']:,}, {rec['n_taus']} taus (m = {rec['m_min']} .. "
            f"{rec['m_max']}), {rec['threads']} threads; ratios: median [inter-quartile range] "
            f"of {rec['pairs']} alternating pairs; other timings best of {rec['repeat']}",
            "",
            f"load average (1 min) {load['before']:.2f} before, {load['after']:.2f} after; "
            f"numpy copy bandwidth {rec['copy_bandwidth_GBps']:.1f} GB/s; phase "
            f"{rec['phase_seconds'] * 1e3:.1f} ms",
            "",
            "| kind | kernel ms | floor ms | ident ms | allanite ms (median) | given alpha ms | "
            "allantools ms (median) | oracle ms | vs allantools, median [IQR] | best of pairs | "
            "(alpha given) | per tau / overl., median [IQR] | ident / kernel, median [IQR] | "
            "oracle / kernel | bit-identical threads |",
            "|---|" + "---:|" * 14 + "---|",
        ]
        for kind, e in rec["kinds"].items():
            s, r, p = e["seconds"], e["ratios"], e["paired"]
            pr = p["allantools_over_end_to_end"]
            ref = f"{s['oracle'] * 1e3:.0f}" if "oracle" in s else "-"
            vs_ref = f"{r['oracle_over_kernel']:.1f}x" if "oracle" in s else "-"
            if "oracle" in s and e["oracle_taus"] < rec["n_taus"]:
                ref += f" ({e['oracle_taus']} taus)"
            lines.append(
                f"| {kind} | {s['kernel'] * 1e3:.1f} | {e['memory_floor_seconds'] * 1e3:.1f} | "
                f"{s['identification'] * 1e3:.1f} | {s['end_to_end'] * 1e3:.1f} "
                f"({p['end_to_end_median_seconds'] * 1e3:.1f}) | {s['given_alpha'] * 1e3:.1f} | "
                f"{s['allantools'] * 1e3:.0f} ({p['allantools_median_seconds'] * 1e3:.0f}) | "
                f"{ref} | {_spread(pr, '.1f', 'x')} | "
                f"{pr['best_of']:.1f}x | "
                f"{r['allantools_over_given_alpha']:.1f}x | "
                f"{_spread(p['kernel_over_overlapping'], '.2f')} | "
                f"{_spread(p['identification_over_kernel'], '.2f')} | {vs_ref} | "
                f"{e['bit_identical_1_vs_all_threads']} |"
            )
        lines += ["", "| goal | measured | bound | met |", "|---|---:|---:|---|"]
        for name, value, bound, met in goals(rec):
            lines.append(f"| {name} | {value:.2f} | {bound:g} | {'yes' if met else 'NO'} |")
        lines.append("")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--sizes",
        nargs="+",
        default=["1000000:50", "10000000:100:1:3"],
        help="record sizes as N:points of the log grid[:repeat[:pairs]]",
    )
    parser.add_argument("--repeat", type=int, default=3, help="best of this many runs")
    parser.add_argument(
        "--pairs",
        type=int,
        default=15,
        help="alternating runs of allanite and allantools (end to end) whose median ratio is "
        "the goal",
    )
    parser.add_argument("--threads", type=int, default=0, help="worker threads (0: all cores)")
    parser.add_argument("--no-oracle", action="store_true", help="skip the numpy oracle")
    parser.add_argument("--out", default="bench_kinds", help="stem of the result files")
    parser.add_argument("--results", type=Path, default=RESULTS, help="directory of the results")
    args = parser.parse_args()

    records = []
    for spec in args.sizes:
        fields = [int(float(v)) for v in spec.split(":")]
        n, points = fields[0], fields[1]
        repeat = fields[2] if len(fields) > 2 else args.repeat
        pairs = fields[3] if len(fields) > 3 else args.pairs
        threads = args.threads if args.threads > 0 else (os.cpu_count() or 1)
        rec = bench_size(n, points, repeat, pairs, threads, oracle=not args.no_oracle)
        records.append(rec)
        print(markdown([rec]), flush=True)
    result = {
        "benchmark": "every variance kind: allanite vs allantools, oracle and memory floor",
        "records": records,
        "machine": {
            "python": platform.python_version(),
            "platform": platform.platform(),
            "cpus": os.cpu_count(),
            "niceness": os.nice(0),
        },
    }
    args.results.mkdir(parents=True, exist_ok=True)
    (args.results / f"{args.out}.json").write_text(json.dumps(result, indent=2) + "\n")
    (args.results / f"{args.out}.md").write_text(markdown(records) + "\n")
    print(f"written to {args.results / args.out}.json and .md")


if __name__ == "__main__":
    main()
