"""Bad command-line options: negative values read as values and refused naming the option,
conflicting options refused, options of another method refused; one line, nothing written."""
import pytest

from gimbal_reduction.geometry import mesh
from gimbal_reduction.reduction import load_aware, models, stage
from gimbal_reduction.results.study import run_scene
from gimbal_reduction.solver.dynamics import simulate
from gimbal_reduction.solver.fe import modes

from .conftest import body_args, reduction_args

MODEL = ("models", "scene", "xmx-2.h5")

SIMULATE = {
    "step negative exponent": (["--integrator", "rk4", "--step", "-1e-6"], ("--step", "positive")),
    "step negative": (["--integrator", "rk4", "--step", "-0.001"], ("--step", "positive")),
    "step zero": (["--integrator", "rk4", "--step", "0"], ("--step",)),
    "step nan": (["--integrator", "rk4", "--step", "nan"], ("--step",)),
    "step inf": (["--integrator", "rk4", "--step", "inf"], ("--step",)),
    "step not a number": (["--integrator", "rk4", "--step", "1ms"], ("--step", "number")),
    "rtol negative": (["--integrator", "dop853", "--rtol", "-1"], ("--rtol", "positive")),
    "tol negative": (["--tol", "-1e-8"], ("--tol", "positive")),
    "tol below double precision": (["--tol", "1e-300"], ("tolerance 1e-300", "below 1e-13")),
    "fraction negative": (["--integrator", "rk4", "--fraction", "-0.5"], ("--fraction",)),
    "fraction above 1": (["--integrator", "rk4", "--fraction", "2"], ("--fraction",)),
    "step with fraction": (["--integrator", "rk4", "--step", "1e-6", "--fraction", "0.5"],
                           ("--step", "--fraction")),
    "tol with step": (["--tol", "1e-8", "--step", "1e-5"], ("tolerance", "step")),
    "rho-inf above 1": (["--integrator", "generalized-alpha", "--rho-inf", "1.5"], ("--rho-inf",)),
    "rho-inf negative": (["--integrator", "generalized-alpha", "--rho-inf", "-0.2"], ("--rho-inf",)),
    "order zero": (["--order", "0"], ("--order",)),
    "order not whole": (["--order", "2.5"], ("--order",)),
    "max-steps negative": (["--max-steps", "-5"], ("--max-steps",)),
    "rtol with rk4": (["--integrator", "rk4", "--rtol", "1e-8"], ("--rtol", "dop853")),
    "fraction with exponential": (["--fraction", "0.5"], ("--fraction", "rk4")),
    "unknown integrator": (["--integrator", "euler"], ("--integrator", "euler")),
    "unknown option": (["--stepsize", "1e-6"], ("--stepsize",)),
    "missing value": (["--step"], ("--step",)),
}


@pytest.mark.parametrize("case", sorted(SIMULATE))
def test_simulate_option(case, work, refused):
    extra, words = SIMULATE[case]
    argv = ["--scene", work / "scene.yaml", "--model-file", work.joinpath(*MODEL),
            "--out", work / "out" / "s.h5", *extra]
    refused(simulate.main, argv, words, work / "out")


def test_simulate_neither_model_nor_file(work, refused):
    refused(simulate.main, ["--scene", work / "scene.yaml"], ("--model-file", "--model"), work / "out")


def test_models_missing_out(work, refused):
    refused(models.main, ["--model", "freq-2", "--scene", work / "scene.yaml", "--bodies", "a", "b", "c", "d"],
            ("--out",), work / "out")


def test_models_three_body_files(work, refused):
    refused(models.main, ["--model", "freq-2", "--scene", work / "scene.yaml", "--bodies", "a", "b", "c",
                          "--out", work / "out" / "m.h5"], ("--bodies",), work / "out")


def test_mesh_negative_size(work, refused):
    refused(mesh.main, ["--body", "2", "--out", work / "out" / "b.msh", "--size", "-0.25"],
            ("--size", "positive"), work / "out")


def test_mesh_nan_size(work, refused):
    refused(mesh.main, ["--body", "2", "--out", work / "out" / "b.msh", "--size", "nan"],
            ("--size",), work / "out")


def test_modes_negative_count(work, refused):
    refused(modes.main, ["--body", "2", "--mesh", work / "out" / "b.msh", "--out", work / "out" / "b.h5",
                         "--count", "-3"], ("--count",), work / "out")


def test_modes_unknown_body(work, refused, tmp_path):
    msh = tmp_path / "b.msh"
    msh.write_text("")
    refused(modes.main, ["--body", "7", "--mesh", msh, "--out", work / "out" / "b.h5"],
            ("7",), work / "out")


# the study's stage (gimbal_reduction.results.study.run_scene, rule study_scene) and the load-aware ranking: checked
# before any model is reduced
RUN_SCENE = {
    "tol negative exponent": (["--tol", "-1e-6"], ("--tol", "positive")),
    "tol negative": (["--tol", "-1"], ("--tol", "positive")),
    "tol with rk4": (["--integrator", "rk4", "--tol", "1e-6"], ("--tol", "rk4")),
    "unknown integrator": (["--integrator", "euler"], ("--integrator", "euler")),
    "frequency error without the truth": (["--frequency-error", "f.json"], ("--frequency-error", "truth")),
}


@pytest.mark.parametrize("case", sorted(RUN_SCENE))
def test_run_scene_option(case, work, refused):
    extra, words = RUN_SCENE[case]
    refused(run_scene.main, ["--scene", work / "scene.yaml", "--models", "freq-2", *body_args(work),
                             "--out-dir", work / "out", *extra], words, work / "out")


LOAD_AWARE = {
    "drop-fraction negative exponent": (["--drop-fraction", "-1e-3"], ("--drop-fraction",)),
    "pool negative": (["--pool", "-1"], ("--pool",)),
}


@pytest.mark.parametrize("case", sorted(LOAD_AWARE))
def test_load_aware_option(case, work, refused):
    extra, words = LOAD_AWARE[case]
    refused(load_aware.main, ["--scene", work / "scene.yaml", *body_args(work), *reduction_args(work),
                              "--out", work / "out" / "l.h5", *extra], words, work / "out")


@pytest.mark.parametrize("extra, words", [(["--static-kept", "-1e-3"], ("--static-kept", "-1e-3")),
                                          (["--n-modes", "-3"], ("modes", "-3"))], ids=["static-kept", "n-modes"])
def test_reduction_stage_negative_count(extra, words, work, refused):
    refused(stage.main, ["--body-file", work / "modes" / "body2.h5", "--out", work / "out" / "r.h5", *extra],
            words, work / "out")


def test_heavy_damping_runs_with_the_default_integrator(work):
    """Damping ratio 2 makes coupled modes overdamped (real eigenvalue pairs); the default
    integrator solves them in closed form too (``exponential.CoupledBank``) and agrees with
    DOP853 within its own tolerance (E of the gimbal rates <= the default local tolerance)."""
    from gimbal_reduction import api
    from gimbal_reduction.solver.dynamics import exponential
    from .conftest import write_scene
    scene = write_scene(work / "heavy.yaml", damping_ratio={"value": 2.0, "unit": "1", "source": "test"})
    runs = {}
    for integrator in ("exponential", "dop853"):
        out = work / "out" / f"{integrator}.h5"
        argv = ["--scene", scene, "--model-file", work.joinpath(*MODEL), "--out", out,
                "--integrator", integrator]
        assert simulate.main([str(a) for a in argv]) == 0, integrator
        runs[integrator] = api.read_simulation(out)
    assert api.error(runs["dop853"], runs["exponential"]).max() <= exponential.DEFAULTS.tol
