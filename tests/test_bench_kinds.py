"""The design of benchmarks/bench_kinds.py: paired timing, its summary and the goal verdict."""

from __future__ import annotations

import numpy as np
import pytest

import benchmark_module

benchmark_module.load("bench_core")  # bench_kinds imports its best-of timer from there
bench_kinds = benchmark_module.load("bench_kinds")


class FakeClock:
    """A clock that the timed functions move on by fixed amounts (no real timing)."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_paired_runs_alternate_and_time_each_side() -> None:
    clock = FakeClock()
    calls: list[str] = []
    # the "load" grows with every call: side A costs 1 + load, side B 10 (1 + load)
    load = [0.0]

    def side(name: str, scale: float):
        def fn() -> str:
            calls.append(name)
            clock.now += scale * (1.0 + load[0])
            load[0] += 0.5
            return name

        return fn

    t_a, t_b, out_a, out_b = bench_kinds.paired_runs(side("a", 1.0), side("b", 10.0), 4, clock)
    # one warm-up of each, then a b, b a, a b, b a
    assert calls == ["a", "b", "a", "b", "b", "a", "a", "b", "b", "a"]
    assert (out_a, out_b) == ("a", "b")
    # the warm-ups run at loads 0 and 0.5, the pairs at (a 1.0, b 1.5), (b 2.0, a 2.5), ...
    np.testing.assert_allclose(t_a, [2.0, 3.5, 4.0, 5.5])
    np.testing.assert_allclose(t_b, [25.0, 30.0, 45.0, 50.0])


def test_paired_runs_rejects_no_pairs() -> None:
    with pytest.raises(ValueError, match="pairs must be at least 1"):
        bench_kinds.paired_runs(lambda: None, lambda: None, 0)


def test_ratio_summary_median_quartiles_and_best_of() -> None:
    fast = np.array([1.0, 1.0, 2.0, 1.0, 1.0])
    slow = np.array([10.0, 12.0, 16.0, 9.0, 30.0])  # ratios 10, 12, 8, 9, 30
    s = bench_kinds.ratio_summary(fast, slow)
    assert s["pairs"] == 5
    assert s["median"] == 10.0
    assert (s["q25"], s["q75"]) == (9.0, 12.0)
    assert s["best_of"] == 9.0  # fastest slow run / fastest fast run, different pairs


def test_ratio_summary_rejects_unpaired_series() -> None:
    with pytest.raises(ValueError, match="paired seconds"):
        bench_kinds.ratio_summary(np.ones(3), np.ones(4))


def _summary(median: float, best_of: float) -> dict:
    return {
        "pairs": 15.0,
        "median": median,
        "q25": median - 0.5,
        "q75": median + 0.5,
        "best_of": best_of,
    }


def _record(best_of: float, median: float, kind: str = "hadamard", per_tau: float = 1.1) -> dict:
    """A one-kind record with the fields goals() and markdown() read: the best-of ratios on
    one side of each bound, the paired medians (``median``, ``per_tau``, 0.6) on the other."""
    seconds = {
        "kernel": 0.006,
        "identification": 0.0015,
        "end_to_end": 0.009,
        "given_alpha": 0.008,
        "allantools": 0.009 * best_of,
    }
    return {
        "n_samples": 1_000_000,
        "points": 50,
        "n_taus": 48,
        "m_min": 1,
        "m_max": 262144,
        "threads": 2,
        "repeat": 7,
        "pairs": 15,
        "phase_seconds": 0.001,
        "copy_bandwidth_GBps": 80.0,
        "load_average_1min": {"before": 1.0, "after": 1.0},
        "kinds": {
            kind: {
                "seconds": seconds,
                "paired": {
                    "end_to_end_median_seconds": 0.0095,
                    "allantools_median_seconds": 0.0095 * median,
                    "allantools_over_end_to_end": _summary(median, best_of),
                    "kernel_over_overlapping": _summary(per_tau, 3.0 - per_tau),
                    "identification_over_kernel": _summary(0.6, 0.4),
                },
                "bit_identical_1_vs_all_threads": True,
                "memory_floor_seconds": 0.0047,
                "ratios": {
                    "allantools_over_end_to_end": best_of,
                    "allantools_over_end_to_end_median": median,
                    "allantools_over_given_alpha": 12.0,
                    "kernel_per_tau_over_overlapping": 3.0 - per_tau,
                    "kernel_per_tau_over_overlapping_median": per_tau,
                    "identification_over_kernel": 0.4,
                    "identification_over_kernel_median": 0.6,
                    "kernel_over_memory_floor": 1.3,
                },
            }
        },
    }


@pytest.mark.parametrize(("best_of", "median", "met"), [(10.5, 9.5, False), (9.5, 10.5, True)])
def test_goal_against_allantools_uses_the_median(best_of: float, median: float, met: bool) -> None:
    (name, value, bound, ok), _ = bench_kinds.goals(_record(best_of, median))
    assert name == "hadamard: allantools / allanite (identified), median"
    assert (value, bound, ok) == (median, 10.0, met)


@pytest.mark.parametrize(("per_tau", "met"), [(2.2, False), (1.8, True)])
def test_per_tau_and_identification_goals_use_the_medians(per_tau: float, met: bool) -> None:
    goals = bench_kinds.goals(_record(10.5, 10.5, kind="modified", per_tau=per_tau))
    assert [g[0] for g in goals] == [
        "modified: allantools / allanite (identified), median",
        "modified: kernel per tau / overlapping, median",
        "modified: identification / kernel, median",
    ]
    # best-of ratios 3 - per_tau and 0.4 would give the opposite verdicts
    assert goals[1][1:] == (per_tau, 2.0, met)
    assert goals[2][1:] == (0.6, 0.5, False)


def test_markdown_reports_median_with_spread_next_to_best_of() -> None:
    text = bench_kinds.markdown([_record(10.5, 9.5)])
    assert "15 alternating pairs" in text
    row = next(line for line in text.splitlines() if line.startswith("| hadamard |"))
    assert "| 9.5x [9.0-10.0] | 10.5x |" in row
    assert "| 1.10 [0.60-1.60] | 0.60 [0.10-1.10] |" in row
    assert "| 9.50 | 10 | NO |" in text
