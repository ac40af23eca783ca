"""The robotics loop on a real record: simulator config -> diagnose -> corrected config.

A deliberately wrong simulator config — the PX4/RotorS Gazebo IMU plugin with its defaults
(ADIS16448 values) — is compared with the real ADIS16405 run 2 gyro X (100 Hz, 1e6 samples,
deg/s). Each round: ``allanite.diagnose`` of the real record against the config's model, the
best effect folded into the config (``--write-corrected``: what the plugin can hold, the rest
projected), the corrected config re-simulated with the plugin's own discrete law
(``tests/sim_laws.px4_plugin``, an independent implementation of gazebo_imu_plugin.cpp) and
diagnosed again as a simulated record. The measured gap of the next round is compared with
the shrinkage the diagnosis reported. The loop stops when the gap is closed, when no
attributed effect fits the format, or when everything a round folded in is lost in the export
(``Written.lost``: the export's own "dropped"/"projected" notes, quoted in the output), since
another round would fold it in again. Writes ``results/sim_loop_adis.json`` and the configs
``results/sim_loop_adis_round*.sdf`` the loop used.

Run: ``nice python benchmarks/sim_loop_adis.py`` (needs ../shared/data; ~5 min on 2 cores),
the same as ``allanite diagnose run2.npz --key gyro_counts --channels 0 --scale 0.05 --units
deg/s --fs 100 --sim-model px4.sdf --write-corrected px4_fixed.sdf`` per round.
"""

from __future__ import annotations

import json
import math
import re
import sys
import time
from pathlib import Path

import numpy as np

import allanite
from allanite.formats import px4_plugin, read_config, write_config
from allanite.formats.base import describe_term
from allanite.formats.corrected import corrected_model, representable

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
import sim_laws  # noqa: E402 - the independent simulator laws live with the tests

DATA = ROOT.parent / "shared" / "data" / "imu" / "adis16405" / "run2.npz"
RESULTS = Path(__file__).resolve().parent / "results"
FS = 100.0
LSB = 0.05  # deg/s per count
N_MC = 100
ROUNDS = 3
R2D = 180.0 / math.pi

PX4_DEFAULTS = """<?xml version="1.0"?>
<sdf version="1.6">
  <model name="iris">
    <!-- PX4 SITL iris IMU: the plugin's defaults (ADIS16448), a deliberately wrong sim -->
    <plugin name="rotors_gazebo_imu_plugin" filename="libgazebo_imu_plugin.so">
      <linkName>/imu_link</linkName>
      <imuTopic>/imu</imuTopic>
      <gyroscopeNoiseDensity>0.0003394</gyroscopeNoiseDensity>
      <gyroscopeRandomWalk>3.8785e-05</gyroscopeRandomWalk>
      <gyroscopeBiasCorrelationTime>1000.0</gyroscopeBiasCorrelationTime>
      <gyroscopeTurnOnBiasSigma>0.0087</gyroscopeTurnOnBiasSigma>
      <accelerometerNoiseDensity>0.004</accelerometerNoiseDensity>
      <accelerometerRandomWalk>0.006</accelerometerRandomWalk>
      <accelerometerBiasCorrelationTime>300.0</accelerometerBiasCorrelationTime>
      <accelerometerTurnOnBiasSigma>0.196</accelerometerTurnOnBiasSigma>
    </plugin>
  </model>
</sdf>
"""


def plugin_parameters(text: str) -> dict[str, float]:
    """The gyroscope parameters as the plugin reads them (plain element text)."""
    out = {}
    for key in ("NoiseDensity", "RandomWalk", "BiasCorrelationTime", "TurnOnBiasSigma"):
        match = re.search(rf"<gyroscope{key}>\s*([^<]+?)\s*</gyroscope{key}>", text)
        assert match is not None, key
        out["gyroscope" + key] = float(match.group(1))
    return out


def main() -> int:
    if not DATA.exists():
        print(f"reference data {DATA} not found", file=sys.stderr)
        return 1
    RESULTS.mkdir(exist_ok=True)
    with np.load(DATA) as data:
        x = data["gyro_counts"][:, 0].astype(np.float64) * LSB
    path = RESULTS / "sim_loop_adis_round0.sdf"
    path.write_text(PX4_DEFAULTS)
    rounds = []
    start = time.perf_counter()
    for k in range(ROUNDS + 1):
        config = read_config(path, rate=FS)
        model = config.model("gyro").in_units("deg/s")
        d = allanite.diagnose(x, model, fs=FS, units="deg/s", n_mc=N_MC, seed=k)
        sim_x = sim_laws.px4_plugin(
            plugin_parameters(path.read_text()), x.size, FS, np.random.default_rng(100 + k)
        )
        d_rec = allanite.diagnose(x, sim_x * R2D, fs=FS, units="deg/s", n_mc=N_MC, seed=k)
        entry = {
            "config": path.name,
            "gyro_model_deg_s": model.to_dict(),
            "gap": d.statistic,
            "p_value": d.p_value,
            "significant": d.significant,
            "gap_vs_plugin_law_record": d_rec.statistic,
            "best": None,
        }
        if rounds and rounds[-1]["best"] is not None:
            before = rounds[-1]["gap"]
            entry["measured_shrinkage"] = 1.0 - d.statistic / before if before > 0 else 0.0
        rounds.append(entry)
        print(
            f"round {k}: G = {d.statistic:.4g} (p = {d.p_value:.3g}), "
            f"plugin-law record G = {d_rec.statistic:.4g}",
            flush=True,
        )
        if (
            not d.significant
            or not any(
                representable(a.effect, str(a.term["type"]), px4_plugin.HOLDS)
                for a in d.attribution
            )
            or k == ROUNDS
        ):
            break
        corrected, what = corrected_model(model, d, px4_plugin.HOLDS)
        best = next(
            a
            for a in d.attribution
            if representable(a.effect, str(a.term["type"]), px4_plugin.HOLDS)
        )
        nxt = RESULTS / f"sim_loop_adis_round{k + 1}.sdf"
        target = config.with_model("gyro", corrected)
        written = write_config(
            target,
            nxt,
            rate=FS,
            template=path,
            tau_range=(float(d.tau.tau[0]), float(d.tau.tau[-1])),
        )
        entry["best"] = {
            "effect": best.effect,
            "top_ranked": d.attribution[0].effect,
            "params": best.params,
            "reported_gap_after": best.gap_after,
            "reported_shrinkage": best.shrinkage,
            "folded": what,
            "written": written.report(),
        }
        print(f"  {what}", flush=True)
        for line in written.report():
            print(f"  {line}", flush=True)
        # what this round folded in, and what of it the export could not hold (its own notes)
        before, after = config.model("gyro"), target.model("gyro")
        folded = [t for t in after.terms if t not in before.terms]
        lost = {describe_term(t): written.lost("gyro", t) for t in folded}
        entry["best"]["lost"] = {term: lines for term, lines in lost.items() if lines}
        stop = None
        if nxt.read_text() == path.read_text():
            stop = "the corrected config equals this one"
        elif folded and all(lost.values()):
            notes = "; ".join(sorted({line for lines in lost.values() for line in lines}))
            stop = (
                f"the PX4 plugin cannot hold what this round folded in "
                f"({', '.join(lost)}): {notes}; another round would fold it in again"
            )
        if stop is not None:
            entry["best"]["stopped"] = stop
            print(f"  stopped: {stop}", flush=True)
            nxt.unlink()  # not a config of the loop: the previous one is the corrected config
            break
        path = nxt
    out = {
        "record": "ADIS16405 run 2, gyro X, 100 Hz, 1e6 samples, deg/s",
        "n_mc": N_MC,
        "rounds": rounds,
        "seconds": time.perf_counter() - start,
    }
    (RESULTS / "sim_loop_adis.json").write_text(json.dumps(out, indent=1, default=float) + "\n")
    return 0


if __name__ == "__main__":
    import argparse

    argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    ).parse_args()  # --help describes the run instead of starting it
    sys.exit(main())
