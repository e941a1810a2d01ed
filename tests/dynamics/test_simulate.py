"""The simulate CLI takes its output path from the caller (the DAG), never from a field
inside the scene file: a scene copied from thesis.yaml with its name: left in it is refused
before any work, and a renamed copy writes exactly where it is told."""
import os

import h5py
import numpy as np
import pytest
import yaml

from gimbal_reduction.results.bench.oracle import synthetic_chain
from gimbal_reduction.solver.dynamics import chainfile, scenes, simulate
from tests.reduction.test_models import project_model_attrs


@pytest.fixture
def model_file(tmp_path):
    chain, _ = synthetic_chain(seed=1)
    path = tmp_path / "models" / "m.h5"
    chainfile.write_chain(path, chain, {b.number: np.arange(b.n_modes) for b in chain.bodies},
                          {b.number: () for b in chain.bodies}, {"model": "freq-2", "config_hash": "x", **project_model_attrs()})
    return path


def copied_scene(tmp_path, stem, name):
    raw = yaml.safe_load(open(os.path.join(scenes.SCENES_DIR, "thesis.yaml")))
    raw["name"] = name
    raw["duration"]["value"] = 1e-3
    path = tmp_path / f"{stem}.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


def test_copied_scene_with_the_old_name_is_refused(tmp_path, model_file, capsys):
    scene = copied_scene(tmp_path, "thesis_copy", "thesis")
    out = tmp_path / "sim" / "thesis_copy" / "freq-2.h5"
    rc = simulate.main(["--scene", str(scene), "--model-file", str(model_file), "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "thesis_copy" in err[0] and "name" in err[0]
    assert not (tmp_path / "sim").exists()


def test_output_goes_where_the_caller_says(tmp_path, model_file):
    scene = copied_scene(tmp_path, "thesis_copy", "thesis_copy")
    out = tmp_path / "elsewhere" / "run.h5"
    assert simulate.main(["--scene", str(scene), "--model-file", str(model_file), "--out", str(out)]) == 0
    with h5py.File(out, "r") as f:
        assert f.attrs["scene"] == "thesis_copy" and f.attrs["model"] == "freq-2"
        samples = int(round(1e-3 / scenes.load_scene(str(scene)).output_interval)) + 1   # 1 ms
        assert f["gamma_dot"].shape == (samples, 4) and np.all(np.isfinite(f["gamma_dot"][()]))
    assert sorted(os.listdir(tmp_path / "elsewhere")) == ["run.h5"]


def test_no_energy_leaves_out_only_the_energy_group(tmp_path, model_file):
    """--no-energy (the study's reduced models): the same run, the energy group left out, and the
    file still reads (simfile.read_sim has no energy then)."""
    from gimbal_reduction.solver.dynamics import simfile
    scene = copied_scene(tmp_path, "thesis_copy", "thesis_copy")
    paths = {flag: tmp_path / f"run{k}.h5" for k, flag in enumerate(((), ("--no-energy",)))}
    for flag, out in paths.items():
        assert simulate.main(["--scene", str(scene), "--model-file", str(model_file), "--out", str(out),
                              *flag]) == 0
    full, bare = (simfile.read_sim(paths[f]) for f in ((), ("--no-energy",)))
    assert "energy" in full and "energy" not in bare
    assert np.all(np.isfinite(full["energy"]["kinetic"])) and np.ptp(full["energy"]["kinetic"]) > 0
    # The same integration, but not one code path: the two runs may take differently aligned
    # arrays through BLAS, which on some CPUs rounds differently (3.6e-15 relative seen on an
    # AMD EPYC).  So the bound is a few hundred roundings of each quantity's own scale: a real
    # change of the run (a step more or less) moves these by far more than 1e-12 relative.
    for key in ("gamma_dot", "platform_attitude"):
        scale = np.max(np.abs(full[key]))
        np.testing.assert_allclose(full[key], bare[key], rtol=0, atol=1e-13 * scale, err_msg=key)


@pytest.mark.parametrize("scene_name, fast", [("thesis", True), ("thesis", False), ("free", True)])
def test_energy_history_equals_the_per_sample_energies(scene_name, fast):
    """Problem.energy_history (the simulation file's energies, all samples at once) gives what
    kinetic_energy, potential_energy and input_power give sample by sample: compiled and NumPy
    paths, a moving case (thesis: case power from the accelerations) and a case at rest (free)."""
    from gimbal_reduction.solver.dynamics.problem import Problem
    from gimbal_reduction.solver.dynamics.synthetic import synthetic_modal_chain
    scene = scenes.load_scene(scene_name)
    chain = synthetic_modal_chain(2, seed=1)
    y0, yd0 = scenes.initial_state(scene, chain.n_coordinates)
    prob = Problem(chain, case=scene.case, torque=lambda t: np.array([0.3, -0.2, 0.1, 0.05]) * (1 + t),
                   y0=y0, yd0=yd0, fast=fast)
    rng = np.random.default_rng(2)
    t = np.linspace(0.0, 0.01, 7)
    Y = 1e-3 * rng.standard_normal((t.size, chain.n_coordinates))
    Yd = 1e-1 * rng.standard_normal((t.size, chain.n_coordinates))
    T, U, P = prob.energy_history(t, Y, Yd)
    T1 = [prob.kinetic_energy(tk, y, v) for tk, y, v in zip(t, Y, Yd)]
    U1 = [prob.potential_energy(y) for y in Y]
    P1 = [prob.input_power(tk, y, v) for tk, y, v in zip(t, Y, Yd)]
    for got, want in ((T, T1), (U, U1), (P, P1)):
        assert got.shape == (t.size,)
        assert np.allclose(got, want, rtol=1e-12, atol=1e-14 * np.max(np.abs(want)))
    assert np.ptp(P) > 0 and np.ptp(T) > 0


def test_the_scene_tolerance_applies_unless_one_is_given(tmp_path, model_file):
    """A scene's exponential_tolerance is the exponential integrator's tolerance of its
    simulations; an explicit --tol wins, and neither a fixed --step nor rk4 takes it."""
    raw = yaml.safe_load(open(os.path.join(scenes.SCENES_DIR, "thesis.yaml")))
    raw.update(name="tight", exponential_tolerance={"value": 3e-7, "unit": "1", "source": "test"})
    raw["duration"]["value"] = 1e-3
    scene = tmp_path / "tight.yaml"
    scene.write_text(yaml.safe_dump(raw))

    def tol_of(*flags):
        out = tmp_path / f"run{len(list(tmp_path.glob('run*.h5')))}.h5"
        assert simulate.main(["--scene", str(scene), "--model-file", str(model_file), "--out", str(out),
                              "--no-energy", *flags]) == 0
        with h5py.File(out, "r") as f:
            return float(f.attrs["stat_tol"])
    assert tol_of() == 3e-7 and tol_of("--tol", "1e-4") == 1e-4
    assert np.isnan(tol_of("--step", "1e-5"))
    s = scenes.load_scene(str(scene))
    assert simulate.scene_options(s, "exponential", None, {}) == {"tol": 3e-7}
    assert simulate.scene_options(s, "rk4", None, {}) == {}
    assert simulate.scene_options(s, "exponential", 1e-5, {}) == {}
    assert simulate.scene_options(scenes.load_scene("thesis"), "exponential", None, {}) == {}


def test_the_file_records_the_exponential_options_and_what_the_timings_include(tmp_path, model_file):
    """Every ``ExponentialOptions`` field is an attribute (stat_exponential_<field>, None as NaN,
    the scene's tolerance in it); the timings: integration_time_s without kernel_load_s, both
    inside wall_time_s; which kernels ran."""
    from gimbal_reduction.solver.dynamics import exponential
    scene = copied_scene(tmp_path, "thesis_copy", "thesis_copy")
    out = tmp_path / "run.h5"
    assert simulate.main(["--scene", str(scene), "--model-file", str(model_file), "--out", str(out),
                          "--no-energy", "--drift", "0.02"]) == 0
    with h5py.File(out, "r") as f:
        attrs = dict(f.attrs)
    defaults = exponential.DEFAULTS
    for name in exponential.ExponentialOptions.__dataclass_fields__:
        assert f"stat_exponential_{name}" in attrs, name
    assert attrs["stat_exponential_drift"] == 0.02 and attrs["stat_exponential_tol"] == defaults.tol
    assert np.isnan(attrs["stat_exponential_step"])
    assert attrs["stat_exponential_evaluate_accepted"] == defaults.evaluate_accepted
    assert attrs["kernel_load_s"] >= 0 and attrs["integration_time_s"] > 0
    assert attrs["integration_time_s"] + attrs["kernel_load_s"] <= attrs["wall_time_s"]
    # which kernels ran: the extension compiled ahead of time when it is current, else the JIT
    from gimbal_reduction.solver.dynamics.kernels import extension
    assert attrs["kernels"] == ("extension" if extension.attached() else "jit")


def test_attitude_from_the_modal_outputs_equals_the_full_states(tmp_path):
    """simulate.platform_attitude reads the 13 functionals of the state per basis
    (``ModalStates.functionals``); multibody.platform_attitude of the run's full (T, n) states is the
    other route.  Several bases (fixed steps, a new basis every 0.2 ms), rotations of scale 1: a
    few roundings apart.
    Leaving the bearings' elastic rotations out moves it far beyond that (the check can fail)."""
    from gimbal_reduction.solver.dynamics import multibody
    chain, _ = synthetic_chain(seed=1)
    scene = scenes.load_scene(str(copied_scene(tmp_path, "thesis_copy", "thesis_copy")))
    run, _ = simulate.run_scene(chain, scene, step=1e-4, relinearise_every=2e-4)
    assert len(run.y.phis) > 2                                   # several bases, each its own segment
    fast = simulate.platform_attitude(chain, run)
    full = multibody.platform_attitude(chain, np.asarray(run.y))
    assert np.abs(fast - full).max() <= 1e-13
    L = multibody.attitude_functionals(chain)
    L[4:] = 0.0
    rigid = multibody.attitude_of_functionals(chain, np.asarray(run.y) @ L.T)
    assert np.abs(rigid - full).max() > 1e3 * 1e-13


def test_a_files_attributes_are_matched_by_value_str_form_or_tolerance():
    """simfile.mismatches: what a reader of a given run names when it refuses the file."""
    from gimbal_reduction.solver.dynamics import simfile
    attrs = {"scene": b"thesis", "model": "truth", "stat_rtol": np.float64(1e-10), "stat_exponential_tol": 1e-7}
    assert simfile.mismatches(attrs, {"scene": "thesis", "model": "truth", "stat_rtol": 1e-10}) == {}
    assert simfile.mismatches(attrs, {"model": "freq-10", "integrator": "dop853"}) == {"model": "truth",
                                                                                      "integrator": None}
    tol = {"stat_exponential_tol": 1e-9}
    assert simfile.mismatches(attrs, {"stat_exponential_tol": 1e-7 * (1 + 1e-12)}, tol) == {}
    assert simfile.mismatches(attrs, {"stat_exponential_tol": 1.1e-7}, tol) == {"stat_exponential_tol": 1e-7}
    assert simfile.mismatches({}, {"stat_exponential_tol": 1e-7}, tol) == {"stat_exponential_tol": None}
