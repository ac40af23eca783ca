"""Speed and memory of the overlapping Allan variance at scale, against other implementations.

One run measures, for N = 1e6, 1e7, 1e8 samples and 1 and 3 channels, with the ~100-point log
tau grid (``allanite.variance.taus.log_grid(N, 100)``):

- allanite ``avar`` with 1 and 2 threads (``alpha=0``: the variance path, without the
  noise identification that :mod:`allanite.variance.edf` adds on top),
- ``allanite.variance.oracle.variance`` (the numpy oracle),
- ``allantools.oadev`` (per channel) where it finishes in reasonable time,
- nmayorov's ``allan_variance.compute_avar`` (PyPI ``allan-variance``) on the same taus,
- the memory-bandwidth floor: ``n_taus x`` the best time of one streaming read (``numpy.sum``)
  of the float64 prefix array, measured in the allanite worker process,

each in its own subprocess so that the peak resident set size (``ru_maxrss``) is that of the
method alone (it includes loading the input). With ``--outofcore`` it also writes a raw file
of 4e8 float32 samples (1.6 GB) to the temporary directory, analyses it with
``avar_large(path, memory_limit="1GB")`` and deletes it.

Results go to ``benchmarks/results/scale.json`` and ``scale.md``. Usage::

    python benchmarks/bench_scale.py                 # 1e6 and 1e7 (a few minutes)
    python benchmarks/bench_scale.py --big           # also 1e8
    python benchmarks/bench_scale.py --big --outofcore
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
FS = 100.0

#: skip a method when N x channels exceeds this (it would take minutes or tens of GB)
LIMITS = {"oracle": 10**7, "allantools": 3 * 10**7, "allan_variance": 3 * 10**7}


def _rss_mb() -> float:
    """Peak resident set size of this process image in MB.

    VmHWM from /proc (Linux): unlike ``ru_maxrss`` it starts afresh at ``exec``, so a worker
    does not inherit the resident size its parent had when it was forked.
    """
    try:
        with open("/proc/self/status", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _best(fn: Any, repeats: int) -> tuple[float, Any]:
    best, out = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def worker(method: str, path: str, threads: int, repeats: int) -> dict[str, Any]:
    """Run one method on the record in ``path`` (a .npy file); returns timings and RSS."""
    x = np.load(path)
    n, c = x.shape
    from allanite.variance.taus import log_grid

    m = log_grid(n, 100)
    out: dict[str, Any] = {"method": method, "n": n, "channels": c, "n_taus": int(m.size)}
    if method == "allanite":
        import allanite

        seconds, res = _best(
            lambda: allanite.avar(x, fs=FS, m=m, alpha=0, threads=threads), repeats
        )
        out["threads"] = threads
        out["checksum"] = float(np.sum(res.var))
        # floor: one streaming read of the prefix array per tau, measured here
        from allanite import _core

        phase = _core.phase(x, "rate")
        flat = phase.reshape(-1)  # a flat streaming read (a 2-D numpy sum is slower)
        t_read, _ = _best(lambda: float(flat.sum()), 7)
        t_kernel, _ = _best(lambda: _core.variance(phase, m, "overlapping", threads), repeats)
        out["kernel_seconds"] = t_kernel
        out["read_seconds"] = t_read
        out["floor_seconds"] = t_read * m.size
        out["prefix_mb"] = phase.nbytes / 1e6
        del phase
    elif method == "oracle":
        from allanite.variance import oracle

        seconds, v = _best(lambda: oracle.variance(x, m, "overlapping"), 1)
        out["checksum"] = float(np.sum(v))
    elif method == "allantools":
        import allantools

        def run() -> list[Any]:
            return [
                allantools.oadev(x[:, ch], rate=FS, data_type="freq", taus=m / FS)
                for ch in range(c)
            ]

        seconds, _ = _best(run, 1)
    elif method == "allan_variance":
        from allan_variance import avar as nm

        # compute_avar picks its own log2-spaced cluster sizes from (tau_min, tau_max,
        # n_clusters): pointed at the same range and count, its grid is close to ours
        def run_nm() -> Any:
            return nm.compute_avar(
                x, dt=1 / FS, tau_min=1 / FS, tau_max=m[-1] / FS, n_clusters=m.size
            )

        seconds, (tau_nm, _) = _best(run_nm, 1)
        out["n_taus"] = len(tau_nm)
    else:  # pragma: no cover - usage error
        raise ValueError(method)
    out["seconds"] = seconds
    out["peak_rss_mb"] = _rss_mb()
    out["input_mb"] = x.nbytes / 1e6
    return out


def outofcore_worker(path: str, n: int, limit: str, threads: int) -> dict[str, Any]:
    """Analyse a raw float32 file with a memory budget."""
    from allanite.variance.outofcore import avar_large

    t0 = time.perf_counter()
    res = avar_large(
        path, fs=FS, dtype="float32", n_channels=1, memory_limit=limit, threads=threads
    )
    seconds = time.perf_counter() - t0
    return {
        "method": "allanite avar_large",
        "n": n,
        "channels": 1,
        "memory_limit": limit,
        "threads": threads,
        "n_taus": int(res.tau.size),
        "seconds": seconds,
        "peak_rss_mb": _rss_mb(),
        "file_mb": Path(path).stat().st_size / 1e6,
        "phase_in_memory": res.meta["phase_in_memory"],
        "phase_mb": res.meta["phase_bytes"] / 1e6,
    }


def _spawn(args: list[str], timeout: float) -> dict[str, Any] | str:
    cmd = [sys.executable, str(Path(__file__).resolve()), *args]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return f"did not finish in {timeout:.0f} s"
    if proc.returncode != 0:
        return "failed: " + (proc.stderr.strip().splitlines() or ["?"])[-1]
    result: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    return result


def _write_record(n: int, c: int, directory: str) -> str:
    path = os.path.join(directory, f"rec_{n}_{c}.npy")
    rng = np.random.default_rng(12345)
    step = 1 << 22
    with open(path, "wb") as handle:  # plain writes: a memory map would inflate our RSS
        header = {"descr": "<f8", "fortran_order": False, "shape": (n, c)}
        np.lib.format.write_array_header_2_0(handle, header)
        for start in range(0, n, step):
            stop = min(n, start + step)
            handle.write(rng.standard_normal((stop - start, c)).astype("<f8").tobytes())
    return path


def _write_raw(n: int, directory: str) -> str:
    path = os.path.join(directory, "big_float32.bin")
    rng = np.random.default_rng(7)
    step = 1 << 24
    with open(path, "wb") as handle:
        for start in range(0, n, step):
            handle.write(rng.standard_normal(min(step, n - start)).astype(np.float32).tobytes())
    return path


def run_suite(sizes: list[int], outofcore: bool, timeout: float) -> dict[str, Any]:
    rows: list[dict[str, Any]] = []
    skipped: list[str] = []
    with tempfile.TemporaryDirectory(prefix="allanite-bench-") as tmp:
        for n in sizes:
            for c in (1, 3):
                path = _write_record(n, c, tmp)
                repeats = 3 if n <= 10**7 else 1
                plan: list[tuple[str, int]] = [("allanite", 1), ("allanite", 2)]
                plan += [("oracle", 1), ("allantools", 1), ("allan_variance", 1)]
                for method, threads in plan:
                    if n * c > LIMITS.get(method, 10**12):
                        skipped.append(
                            f"{method} N={n:.0e} C={c}: skipped (N x C > {LIMITS[method]:.0e})"
                        )
                        continue
                    args = ["--worker", method, "--path", path, "--threads", str(threads)]
                    args += ["--repeats", str(repeats)]
                    res = _spawn(args, timeout)
                    if isinstance(res, str):
                        skipped.append(f"{method} N={n:.0e} C={c}: {res}")
                    else:
                        rows.append(res)
                    print(rows[-1] if not isinstance(res, str) else skipped[-1], file=sys.stderr)
                os.unlink(path)
        ooc: list[dict[str, Any]] = []
        if outofcore:
            n_big = 4 * 10**8
            path = _write_raw(n_big, tmp)
            try:
                for threads in (2,):
                    res = _spawn(
                        ["--ooc", path, "--n", str(n_big), "--threads", str(threads)], 3 * timeout
                    )
                    if isinstance(res, str):
                        skipped.append(f"out-of-core 4e8 float32: {res}")
                    else:
                        ooc.append(res)
                        print(res, file=sys.stderr)
            finally:
                os.unlink(path)
    return {
        "machine": {
            "python": platform.python_version(),
            "cpu": platform.processor() or platform.machine(),
            "cores": os.cpu_count(),
            "loadavg_at_end": os.getloadavg(),
        },
        "rows": rows,
        "outofcore": ooc,
        "skipped": skipped,
    }


def markdown(data: dict[str, Any]) -> str:
    lines = [
        "| N | C | method | threads | taus | time [s] | kernel [s] | floor [s] | kernel / floor "
        "| allantools / this | peak RSS [MB] | input + prefix [MB] |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    rows = data["rows"]
    for row in rows:
        n, c = row["n"], row["channels"]
        floor = next(
            (
                r["floor_seconds"]
                for r in rows
                if r["method"] == "allanite"
                and r["n"] == n
                and r["channels"] == c
                and r["threads"] == 2
            ),
            None,
        )
        at = next(
            (
                r["seconds"]
                for r in rows
                if r["method"] == "allantools" and r["n"] == n and r["channels"] == c
            ),
            None,
        )
        kernel = row.get("kernel_seconds")
        ratio_floor = f"{kernel / floor:.2f}" if floor and kernel else ""
        speedup = f"{at / row['seconds']:.1f}" if at and row["method"] != "allantools" else ""
        prefix = row.get("prefix_mb", (n + 1) * c * 8 / 1e6)
        lines.append(
            f"| {n:.0e} | {c} | {row['method']} | {row.get('threads', '')} | {row['n_taus']} | "
            f"{row['seconds']:.3f} | {'' if kernel is None else f'{kernel:.3f}'} | "
            f"{f'{floor:.3f}' if floor and row['method'] == 'allanite' else ''} | {ratio_floor} | "
            f"{speedup} | "
            f"{row['peak_rss_mb']:.0f} | {row['input_mb'] + prefix:.0f} |"
        )
    for row in data["outofcore"]:
        lines.append("")
        lines.append(
            f"Out of core: {row['n']:.0e} float32 samples ({row['file_mb']:.0f} MB raw file), "
            f"memory_limit={row['memory_limit']}, {row['threads']} threads, {row['n_taus']} taus: "
            f"{row['seconds']:.0f} s, peak RSS {row['peak_rss_mb']:.0f} MB "
            f"(phase {row['phase_mb']:.0f} MB in "
            f"{'memory' if row['phase_in_memory'] else 'a temporary file'})."
        )
    if data["skipped"]:
        lines.append("")
        lines += [f"- {s}" for s in data["skipped"]]
    m = data["machine"]
    lines.append("")
    lines.append(
        f"Machine: {m['cores']} cores, Python {m['python']}, "
        f"load average at the end {m['loadavg_at_end']}."
    )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--big", action="store_true", help="include N = 1e8")
    parser.add_argument(
        "--outofcore", action="store_true", help="4e8 float32 raw file, memory_limit=1GB"
    )
    parser.add_argument("--timeout", type=float, default=600.0)
    parser.add_argument(
        "--only-outofcore",
        action="store_true",
        help="rerun only the out-of-core case and merge it into results/scale.json",
    )
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--path", help=argparse.SUPPRESS)
    parser.add_argument("--threads", type=int, default=1, help=argparse.SUPPRESS)
    parser.add_argument("--repeats", type=int, default=1, help=argparse.SUPPRESS)
    parser.add_argument("--ooc", help=argparse.SUPPRESS)
    parser.add_argument("--n", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args.worker, args.path, args.threads, args.repeats)))
        return
    if args.ooc:
        print(json.dumps(outofcore_worker(args.ooc, args.n, "1GB", args.threads)))
        return
    sizes = [10**6, 10**7] + ([10**8] if args.big else [])
    if args.only_outofcore:
        data = json.loads((RESULTS / "scale.json").read_text())
        fresh = run_suite([], True, args.timeout)
        data["outofcore"] = fresh["outofcore"]
        data["skipped"] = [s for s in data["skipped"] if "out-of-core" not in s] + fresh["skipped"]
        data["machine_outofcore"] = fresh["machine"]
    else:
        data = run_suite(sizes, args.outofcore, args.timeout)
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "scale.json").write_text(json.dumps(data, indent=2))
    (RESULTS / "scale.md").write_text(markdown(data))
    print(markdown(data))


if __name__ == "__main__":
    main()
