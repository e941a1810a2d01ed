"""The timing helper of the benchmarks (gimbal_reduction.results.bench.timing): whole runs within the
budget, else a prefix of the scene scaled to the whole run by the step count."""
from types import SimpleNamespace

import pytest

from gimbal_reduction.results.bench import timing

DURATION, DT = 0.015, 1e-5          # scene thesis: 1500 output intervals


def fake_run(seconds_per_step, step_s, calls):
    """A run over d seconds: fixed steps of step_s, each costing seconds_per_step (no clock)."""
    def run(d):
        calls.append(d)
        steps = round(d / step_s)
        return SimpleNamespace(wall_time=steps * seconds_per_step, steps=steps)
    return run


def test_whole_runs_where_they_fit_the_budget():
    calls = []
    out = timing.median_timing(fake_run(1e-5, 1e-6, calls), DURATION, DT, whole_wall_s=0.15,
                               whole_steps=15000, repeats=5, budget_s=1.0)
    assert calls == [DURATION] * 5
    assert out["time_basis"] == "measured" and out["runs"] == 5
    assert out["wall_time_s"] == pytest.approx(0.15)


def test_a_slow_run_is_timed_over_a_prefix_and_scaled_by_its_steps():
    calls = []
    out = timing.median_timing(fake_run(1e-5, 1e-6, calls), DURATION, DT, whole_wall_s=0.15,
                               whole_steps=15000, repeats=5, budget_s=0.1)
    # 5 runs of about 0.1 / 5 s at the whole run's pace: 1500 * 0.02 / 0.15 = 200 intervals, each
    # after a run of the first interval (the per-run cost)
    assert calls == [pytest.approx(DT), pytest.approx(200 * DT)] * 5 and out["runs"] == 5
    assert out["duration_timed_s"] == pytest.approx(200 * DT)
    assert out["time_basis"] == "extrapolated from 2000 and 10 of 15000 steps"
    # fixed steps of a fixed cost: the scaled prefix is the whole run's time
    assert out["wall_time_s"] == pytest.approx(0.15, rel=1e-12)
    # a fixed cost per run (an initial basis) is counted once, not scaled with the steps
    def with_setup(d, inner=fake_run(1e-5, 1e-6, [])):
        r = inner(d)
        return SimpleNamespace(wall_time=r.wall_time + 0.05, steps=r.steps)
    out = timing.median_timing(with_setup, DURATION, DT, 0.2, 15000, 5, 0.1)
    assert out["wall_time_s"] == pytest.approx(0.2, rel=1e-9)
    # no budget: always whole runs, however slow
    assert timing.median_timing(fake_run(1e-5, 1e-6, []), DURATION, DT, 0.15, 15000, 5,
                                None)["time_basis"] == "measured"


def test_the_prefix_is_whole_intervals_at_least_two_at_most_the_scene():
    assert timing.prefix_duration(100.0, DURATION, DT, 1e-6) == pytest.approx(2 * DT)
    assert timing.prefix_duration(1e-3, DURATION, DT, 10.0) == pytest.approx(DURATION)
    k = timing.prefix_duration(1.0, DURATION, DT, 0.1) / DT
    assert k == pytest.approx(round(k)) and round(k) == 150


def test_a_method_whose_steps_vary_in_cost_is_timed_whole_as_often_as_fits():
    calls = []
    out = timing.median_timing(fake_run(1e-5, 1e-6, calls), DURATION, DT, whole_wall_s=0.15,
                               whole_steps=15000, repeats=5, budget_s=0.35, scalable=False)
    assert calls == [DURATION, DURATION] and out["runs"] == 2 and out["time_basis"] == "measured"
    calls.clear()
    assert timing.median_timing(fake_run(1e-5, 1e-6, calls), DURATION, DT, 0.15, 15000, 5, 0.01,
                                scalable=False)["runs"] == 1 and calls == [DURATION]
