"""One run of the truth read by two checks: the integrator table writes its RK4 run of the truth
(gimbal_reduction.results.bench.integrator_tables.write_truth_run) and the Pareto benchmark's untimed
part takes it for its rk4-0.5 setting (gimbal_reduction.results.bench.pareto.truth_file_row) only if
it is that run."""
from types import SimpleNamespace

import numpy as np
import pytest

from gimbal_reduction.results.bench import integrator_tables, pareto
from gimbal_reduction.solver.dynamics import scenes

MODEL_HASH = "feb4a99b928bcaf3"


def fake_run(t):
    """A run of 4 gimbal coordinates and 2 modal ones on the grid t (T,) [s]."""
    yd = np.column_stack([np.sin(50 * t), np.cos(40 * t), 0.5 * np.sin(30 * t), np.cos(20 * t),
                          1e-3 * np.sin(900 * t), 1e-3 * np.cos(700 * t)])
    return SimpleNamespace(t=t, y=np.cumsum(yd, axis=0) * (t[1] - t[0]), yd=yd, stats={"fraction": 0.47},
                           method="rk4", step=2.5e-7, steps=(t.size - 1) * 10, wall_time=1.5)


@pytest.fixture
def written(tmp_path):
    scene = scenes.load_scene("thesis")
    t = np.linspace(0.0, 0.01, 101)
    run = fake_run(t)
    path = tmp_path / "truth_rk4.h5"
    integrator_tables.write_truth_run(str(path), run, scene, MODEL_HASH, "rk4", 1e-5)
    return scene, run, str(path)


def settings():
    return {s.name: s for s in pareto.default_settings((1.0, 0.5), (1e-6,), (2.5e-6,), (1e-5,))}


def test_the_tables_rk4_run_is_the_paretos_rk4_half_row(written):
    """The row read from the file: E of eq. 3.53 against the reference computed from the file's
    rates as a run's would be, the file's steps, step and time, the time basis saying so."""
    scene, run, path = written
    ref = run.yd[:, :4] * (1.0 + 1e-4 * np.arange(1, 5))        # a reference 1e-4 away per rate
    row = pareto.truth_file_row(path, settings()["rk4-0.5"], scene, MODEL_HASH, run.t, ref)
    E, per = pareto.max_rate_error(run.t, ref, run.yd[:, :4])
    assert row["E"] == pytest.approx(E, rel=1e-12) and row["E"] > 0
    assert [row[c] for c in pareto.RATE_COLUMNS] == pytest.approx(list(per), rel=1e-12)
    assert (row["steps"], row["step_s"], row["wall_time_s"]) == (run.steps, run.step, run.wall_time)
    assert row["status"] == "ok" and "not timed alone" in row["time_basis"]


@pytest.mark.parametrize("setting, scene_name, model_hash, culprit", [
    ("rk4-1", "thesis", MODEL_HASH, "option_fraction"),            # another fraction of the limit
    ("exp-1e-05", "thesis", MODEL_HASH, "integrator"),             # another integrator
    ("rk4-0.5", "damped", MODEL_HASH, "scene"),                    # another scene
    ("rk4-0.5", "thesis", "0123456789abcdef", "model_config_hash"),  # another truth model
])
def test_another_run_is_refused_in_one_line(written, setting, scene_name, model_hash, culprit):
    _, run, path = written
    with pytest.raises(ValueError) as err:
        pareto.truth_file_row(path, settings()[setting], scenes.load_scene(scene_name), model_hash,
                              run.t, run.yd[:, :4])
    assert culprit in str(err.value) and "\n" not in str(err.value)


def test_another_output_grid_is_refused(written):
    scene, run, path = written
    with pytest.raises(Exception, match="truth-runs"):
        pareto.truth_file_row(path, settings()["rk4-0.5"], scene, MODEL_HASH, run.t[:50], run.yd[:50, :4])


def test_truth_runs_are_for_the_untimed_run_only():
    with pytest.raises(ValueError, match="--errors-only"):
        pareto.parse_truth_runs(["rk4-0.5=x.h5"], list(settings().values()), False, None, {}, 0.01, None)
