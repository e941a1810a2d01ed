"""Guards before the work: integration steps, output samples and mesh size above a stated limit
are refused at once in one line (naming the culprit and the option that lifts the limit); the
option lifts it."""
import json
import time

import numpy as np
import pytest

from gimbal_reduction.geometry import mesh
from gimbal_reduction.results.study import run_scene
from gimbal_reduction.solver.dynamics import scenes, simulate
from gimbal_reduction.solver.fe import modes
from gimbal_reduction.workflow import config as cfgmod

from .conftest import body_args, write_scene

MODEL = ("models", "scene", "xmx-2.h5")


def sim(work, scene, extra=()):
    return ["--scene", scene, "--model-file", work.joinpath(*MODEL), "--out", work / "out" / "s.h5", *extra]


@pytest.mark.parametrize("integrator", ["rk4", "generalized-alpha", "exponential"])
def test_tiny_step_on_the_15_ms_scene_refused_at_once(integrator, work, refused):
    scene = write_scene(work / "window.yaml", duration=0.015, output_interval=1e-5)
    t0 = time.perf_counter()
    message = refused(simulate.main, sim(work, scene, ["--integrator", integrator, "--step", "1e-12"]),
                      ("steps", "--max-steps", "window"), work / "out")
    assert time.perf_counter() - t0 < 10
    assert "1.5e+10" in message


def test_duration_of_a_million_seconds_refused(work, refused):
    scene = write_scene(work / "forever.yaml", duration=1e6, output_interval=1e-5)
    refused(simulate.main, sim(work, scene), ("samples", "--max-samples", "forever"), work / "out")


def test_output_interval_of_a_nanosecond_refused(work, refused):
    scene = write_scene(work / "dense.yaml", duration=0.015, output_interval=1e-9)
    refused(simulate.main, sim(work, scene), ("samples", "--max-samples"), work / "out")


def test_max_samples_lowered_refuses(work, refused):
    scene = scenes.load_scene(str(work / "scene.yaml"))
    samples = int(round(scene.duration / scene.output_interval)) + 1
    refused(simulate.main, sim(work, work / "scene.yaml", ["--max-samples", "50"]),
            (f"{samples} output samples", "--max-samples"), work / "out")


def test_max_steps_lowered_refuses_rk4(work, refused):
    refused(simulate.main, sim(work, work / "scene.yaml", ["--integrator", "rk4", "--max-steps", "10"]),
            ("steps", "--max-steps"), work / "out")


def test_the_option_lifts_the_step_limit(work):
    """With --max-steps raised, the 1e-12 step passes the guard (check_size returns the estimate)."""
    from gimbal_reduction.solver.dynamics import chainfile
    scene = scenes.load_scene(str(write_scene(work / "window.yaml", duration=0.015, output_interval=1e-5)))
    chain, _ = chainfile.read_chain(work.joinpath(*MODEL), scene.damping_ratio)
    prob = simulate.scene_problem(chain, scene)
    steps, h = simulate.check_size(scene, chain, "rk4", 1e-12, {}, prob, 10**11, simulate.MAX_SAMPLES, "m")
    assert steps == pytest.approx(1.5e10, rel=1e-6) and h == 1e-12


def big_mesh_config(tmp_path, size):
    raw = cfgmod.read_config_file(cfgmod.DEFAULT_CONFIG)
    raw["mesh"]["ring_size"]["value"] = size
    path = tmp_path / "big.yaml"
    import yaml
    path.write_text(yaml.safe_dump(raw))
    return path


def test_mesh_ring_size_0_01_refused_before_gmsh(work, refused, tmp_path):
    config = big_mesh_config(tmp_path, 0.01)
    t0 = time.perf_counter()
    refused(mesh.main, ["--body", "2", "--out", work / "out" / "b.msh", "--meta", work / "out" / "b.json",
                        "--config", config], ("outer_gimbal", "DOFs", "--max-dofs", "mesh.ring_size"),
            work / "out")
    assert time.perf_counter() - t0 < 5


def test_mesh_platform_size_refused(work, refused):
    refused(mesh.main, ["--body", "5", "--out", work / "out" / "b.msh", "--size", "0.05"],
            ("stable_platform", "DOFs", "--size"), work / "out")


def test_modes_refuses_a_fine_mesh_before_assembly(work, refused, tmp_path):
    meta = tmp_path / "b.json"
    meta.write_text('{"mesh_size": 0.01}')
    msh = tmp_path / "b.msh"
    msh.write_text("")
    refused(modes.main, ["--body", "3", "--mesh", msh, "--mesh-meta", meta, "--out", work / "out" / "b.h5"],
            ("middle_gimbal", "DOFs", "--max-dofs"), work / "out")


def test_modes_missing_mesh(work, refused):
    msh = work / "out" / "none.msh"
    refused(modes.main, ["--body", "3", "--mesh", msh, "--out", work / "out" / "b.h5"],
            (str(msh), "not found"), work / "out")


def test_a_kernel_compiled_on_first_use_is_announced_once(capsys):
    """Numba compiling a kernel its cache does not hold (numba:compile fires on a cache miss only)
    gets one console line before the work, naming the path; a second compile in the run is silent."""
    import numba
    from numba.core import event

    @numba.njit(cache=False)
    def first(x):
        return x + 1

    @numba.njit(cache=False)
    def second(x):
        return x * 2
    notice = simulate.CompileNotice("the damped rk4 kernels")
    with event.install_listener("numba:compile", notice):
        assert first(1) == 2 and second(2) == 4
    out = capsys.readouterr().out.strip().splitlines()
    assert out == [out[0]] and out[0].startswith("simulate: compiling the damped rk4 kernels (first use")
    with event.install_listener("numba:compile", simulate.CompileNotice("x")):
        assert first(3) == 4                                   # compiled already: nothing said
    assert capsys.readouterr().out == ""


def test_study_refuses_a_grid_too_coarse_for_E_before_the_truth_runs(work, capsys, monkeypatch):
    """E's sampling rule (error_measure) at the study's set-up: on a 1 ms grid the synthetic truth's
    excited modes (up to ~690 Hz) alias (must fail: one line naming the scene and the longest interval, no
    simulation written); on a grid at the longest interval the rule allows it runs (must pass) and
    the coupled-mode table records the verdict.  The synthetic bodies hold 6 modes each: their
    truth is freq-6 (every mode), made under the name truth."""
    reduce = run_scene.reduction_models.main
    monkeypatch.setattr(run_scene.reduction_models, "main",
                        lambda argv: reduce(["freq-6" if a == "truth" else a for a in argv]))
    coarse = write_scene(work / "coarse.yaml", duration=4e-3, output_interval=1e-3)
    args = [*body_args(work), "--out-dir", str(work / "out")]
    rc = run_scene.main(["--scene", str(coarse), "--models", "truth", "rigid", *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and "scene coarse" in err[0] and "does not resolve" in err[0]
    assert not (work / "out" / "truth.h5").exists() and not (work / "out" / "rigid.h5").exists()
    longest = float(err[0].split("interval <= ")[1].split(" s")[0])
    interval = float(4e-3 / np.ceil(4e-3 / (0.9 * longest)))           # divides the 4 ms, < the longest
    fine = write_scene(work / "fine.yaml", duration=4e-3, output_interval=interval)
    table = work / "out" / "coupled.json"
    assert run_scene.main(["--scene", str(fine), "--models", "truth", *args, "--coupled-modes", str(table)]) == 0
    sampling = json.load(open(table))["sampling"]
    assert sampling["resolved"] is True and sampling["f_max_hz"] > 0.5 / 1e-3 / 1.25
