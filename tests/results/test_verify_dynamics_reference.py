"""`all`'s dynamics verification takes the truth's default DOP853 run from the converged reference
of thesis (gimbal_reduction.results.bench.verify_dynamics.reference_run): that file only, in one
line otherwise."""
import h5py
import numpy as np
import pytest

from gimbal_reduction.results.bench.verify_dynamics import reference_run
from gimbal_reduction.solver.dynamics import scenes, simulate


def sim_file(path, **attrs):
    """A minimal simulation file: 11 samples of the thesis grid, the given attributes."""
    t = np.linspace(0.0, 1e-4, 11)
    with h5py.File(path, "w") as f:
        f["t"] = t
        f["gamma_dot"] = np.outer(np.sin(t * 1e4), [1.0, 2.0, 3.0, 4.0])
        for k, v in attrs.items():
            f.attrs[k] = v
    return str(path)


REFERENCE = {"scene": "thesis", "model": "truth", "integrator": simulate.REFERENCE["integrator"],
             "stat_rtol": simulate.REFERENCE["rtol"], "stat_atol": simulate.REFERENCE["atol"],
             "steps": 21464, "integration_time_s": 16.5}


def test_the_reference_is_taken_as_the_default_run(tmp_path):
    scene = scenes.load_scene("thesis")
    run, seconds = reference_run(sim_file(tmp_path / "ref.h5", **REFERENCE), scene)
    assert run.steps == 21464 and seconds == 16.5
    assert run.step == pytest.approx(scene.duration / 21464) and run.yd.shape == (11, 4)


@pytest.mark.parametrize("change", [{"integrator": "exponential"}, {"stat_rtol": 1e-8},
                                    {"model": "freq-10"}, {"scene": "damped"}])
def test_another_run_is_refused_in_one_line(tmp_path, change):
    path = sim_file(tmp_path / "other.h5", **{**REFERENCE, **change})
    with pytest.raises(ValueError) as err:
        reference_run(path, scenes.load_scene("thesis"))
    message = str(err.value)
    assert "other.h5" in message and "\n" not in message
    assert all(str(v) in message for v in change.values())
