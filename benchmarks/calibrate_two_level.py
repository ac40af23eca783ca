"""Power and false-alarm rate of the telegraph's two-level test (allanite.diagnosis.two_level).

Records of the validation's base sensor (white, quantization, flicker, random walk; 100 Hz,
2^15 samples, the fitted half of a designed pair case) plus extra white noise plus either a
telegraph (+-a, T_c = 3 s) or its Gaussian twin (Gauss-Markov, sigma = a, the same T_c), at the
sizes of the designed grid's telegraph + white cases (2x/16x, 5x/5x, 16x/2x the clear level).
The test is run at the true amplitude and correlation time; it rejects the Gaussian twin when
``p_gauss < 0.05 / 8`` (the diagnosis' evidence level).

With ``--set`` also the same records next to a slow Gauss-Markov process the joint attribution
already chose (:data:`SET_PROCESS`), the null holding it (``two_level.with_set``: the sensor's
replicates plus the set's) or not (the process taken for white noise).

``python benchmarks/calibrate_two_level.py [--telegraphs 30 --twins 100 --set]`` writes
``benchmarks/results/calibrate_two_level.json``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

import validate_diagnosis
from allanite.diagnosis.two_level import two_level_context, two_level_p
from allanite.model import NoiseModel
from allanite.terms import TERM_TYPES

UNITS = {"rate": "deg/s", "time": "s"}
T = TERM_TYPES
FS, N = 100.0, 2**15
LEVEL = 0.05 / 8
#: (label, telegraph amplitude, extra white N) of the designed telegraph + white cases
SIZES = (("2x/16x", 0.05695, 0.02518), ("5x/5x", 0.08093, 0.01848), ("16x/2x", 0.1443, 0.01474))


def base_model() -> NoiseModel:
    """The validation suite's base sensor at ``FS`` (one definition: validate_diagnosis)."""
    return validate_diagnosis.base_model(FS)


#: a slow process the joint attribution already chose (the ``--set`` rows: it is in the record,
#: and in the null with ``with_set`` or taken for white noise without it)
SET_PROCESS = T["markov"](sigma=0.1, tau_c=30.0)


def record(slow: Any, white: float, seed: int, extra: tuple[Any, ...] = ()) -> np.ndarray:
    x = base_model().simulate(N, fs=FS, seed=seed)
    for k, term in enumerate((T["white"](N=white), slow, *extra)):
        one = NoiseModel((term,), UNITS).simulate(N, fs=FS, seed=seed + 7 + k, allow_aliasing=True)
        x = x + one
    return np.asarray(x, dtype=np.float64).ravel()


def row(
    ctx: dict[str, Any], a: float, white: float, n_tel: int, n_twin: int, extra: tuple[Any, ...]
) -> dict[str, Any]:
    """Telegraphs shown and Gaussian twins rejected at ``LEVEL`` (true parameters)."""
    tele = T["telegraph"](amplitude=a, tau_c=3.0)

    def p(x: np.ndarray) -> float:
        got = two_level_p(tele, {**ctx, "means": x.reshape(-1, 8).mean(axis=1)})
        assert got is not None
        return got[0]

    p_tel = np.array([p(record(tele, white, 5000 + 11 * k, extra)) for k in range(n_tel)])
    twin = T["markov"](sigma=a, tau_c=3.0)
    p_gm = np.array([p(record(twin, white, 9000 + 11 * k, extra)) for k in range(n_twin)])
    return {
        "telegraph_shown": int(np.sum(p_tel < LEVEL)),
        "telegraphs": int(p_tel.size),
        "telegraph_median_p": float(np.median(p_tel)),
        "twin_rejected": int(np.sum(p_gm < LEVEL)),
        "twin_below_0.05": int(np.sum(p_gm < 0.05)),
        "twin_above_0.95": int(np.sum(p_gm > 0.95)),
        "twins": int(p_gm.size),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--telegraphs", type=int, default=30)
    parser.add_argument("--twins", type=int, default=100)
    parser.add_argument(
        "--set", action="store_true", help="also the rows next to a slow process of the set"
    )
    args = parser.parse_args()
    t0 = time.perf_counter()
    ctx = two_level_context(np.zeros(N), base_model(), FS, seed=5)
    out: dict[str, Any] = {"level": LEVEL, "sizes": {}}
    for label, a, white in SIZES:
        out["sizes"][label] = row(ctx, a, white, args.telegraphs, args.twins, ())
        print(label, out["sizes"][label], flush=True)
    if args.set:
        out["next_to_set"] = {"process": SET_PROCESS.to_dict()}
        for label, a, white in SIZES:
            for name, bg in (("null_with_set", (SET_PROCESS,)), ("null_without", ())):
                got = row({**ctx, "background": bg}, a, white, args.telegraphs, args.twins,
                          (SET_PROCESS,))  # fmt: skip
                out["next_to_set"].setdefault(label, {})[name] = got
                print(label, name, got, flush=True)
    out["seconds"] = time.perf_counter() - t0
    path = Path(__file__).parent / "results" / "calibrate_two_level.json"
    path.write_text(json.dumps(out, indent=2) + "\n")


if __name__ == "__main__":
    main()
