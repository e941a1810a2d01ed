"""Bad command-line options: negative values read as values and refused naming the option,
conflicting options refused, options of another method refused; one line, nothing written."""
import pytest

from geometry import mesh
from reduction import models
from solver.dynamics import simulate
from solver.fe import modes

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
