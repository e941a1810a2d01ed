"""Scenes, model names, body-file loading and the simulate CLI (synthetic body files)."""

import os

import h5py
import numpy as np
import pytest
import scipy.sparse as sp

from gimbal_reduction.reduction import models
from gimbal_reduction.solver.dynamics import multibody, scenes, simulate
from gimbal_reduction.results.bench.oracle import synthetic_body
from tests.dynamics_fixtures import run_model


def rankings(D=12):
    rng = np.random.default_rng(0)
    return {b: {"rank_frequency": np.arange(D), "rank_xmx": rng.permutation(D),
                "rank_xmgmx": rng.permutation(D)} for b in models.BODIES}


# ---------------------------------------------------------------- model names
def test_model_spec_families_and_counts():
    r = rankings()
    s = models.model_spec("freq-10", r)
    assert all(list(s.kept[b]) == list(range(10)) for b in models.BODIES)
    assert all(s.static[b] == () for b in models.BODIES)
    s = models.model_spec("xmx-3", r)
    assert list(s.kept[2]) == sorted(r[2]["rank_xmx"][:3])
    s = models.model_spec("freq-10,10,5,5", r)
    assert [len(s.kept[b]) for b in models.BODIES] == [10, 10, 5, 5]
    s = models.model_spec("static-8", r)
    assert s.static == {2: ("output_motor_fz",), 3: ("output_motor_fz",),
                        4: ("output_motor_fz",), 5: ("input_motor_fx",)}
    s = models.model_spec("static-xmx-8", r)
    assert s.ranking == "xmx" and s.n_modes(2) == 9
    s = models.model_spec("static-10@2:output_motor_my", r)
    assert s.static[2] == ("output_motor_my",) and s.static[3] == ()
    s = models.model_spec("freq-4@2:output_motor_fz+output_motor_my@4:input_motor_mz", r)
    assert s.static[2] == ("output_motor_fz", "output_motor_my") and s.static[4] == ("input_motor_mz",)
    assert all(len(models.model_spec("rigid", r).kept[b]) == 0 for b in models.BODIES)


@pytest.mark.parametrize("name, message", [
    ("bogus-3", "unknown model"),
    ("freq-13", "only 12 computed"),
    ("truth", "only 12 computed"),
    ("freq-1,2,3", "counts must be"),
    ("static-8@2:output_motor_qq", "unknown load case"),
    ("static-8@5:output_motor_fz", "no output bearings"),
    ("static-8@7:output_motor_fz", "body 2..5"),
    ("freq-", "unknown model"),
    ("", "non-empty"),
])
def test_model_spec_errors(name, message):
    with pytest.raises(models.ModelError, match=message):
        models.model_spec(name, rankings())


# --------------------------------------------------------------------- scenes
def test_scenes_load():
    for name in ("thesis", "free", "long"):
        s = scenes.load_scene(name)
        assert s.name == name
    s = scenes.load_scene("thesis")
    assert s.duration == 0.015 and s.initial_angles[1] == pytest.approx(-np.pi / 2)
    assert s.case.amplitude == (1.0, 0.0, 0.0) and s.case.frequency == (2.0, 0.0, 0.0)
    assert scenes.load_scene("free").case.at_rest
    assert scenes.load_scene("long").duration == 1.0


def _raw(**change):
    import yaml
    with open(os.path.join(scenes.SCENES_DIR, "thesis.yaml")) as fh:
        raw = yaml.safe_load(fh)
    raw.update(change)
    return raw


@pytest.mark.parametrize("change, message", [
    ({"duration": {"value": -1.0, "unit": "s"}}, "duration must be > 0"),
    ({"initial_rates": {"value": [0.0, float("nan"), 0, 0], "unit": "rad/s"}}, "non-finite"),
    ({"initial_angles": {"value": [0.0, 0.0], "unit": "rad"}}, "expected 4 values"),
    ({"wind": {"value": 1.0}}, "unknown key"),
    ({"output_interval": {"value": 0.0, "unit": "s"}}, "output_interval must be > 0"),
    # a consistent unit (ms) is converted since the units work; one of another dimension is refused
    ({"duration": {"value": 1.0, "unit": "in"}}, "is a length, expected a time"),
    ({"output_interval": {"value": 0.02, "unit": "s"}}, "longer than the duration"),
    ({"output_interval": {"value": 4e-4, "unit": "s"}}, "does not divide the duration"),
])
def test_scene_errors(change, message):
    with pytest.raises(scenes.SceneError, match=message):
        scenes.parse_scene(_raw(**change))


def test_unknown_scene_name():
    with pytest.raises(scenes.SceneError, match="unknown scene 'nope'"):
        scenes.load_scene("nope")


# ------------------------------------------------------------ files and CLI
def write_csr(group, A):
    A = sp.csr_matrix(A)
    group["data"], group["indices"], group["indptr"] = A.data, A.indices, A.indptr
    group.attrs["shape"] = A.shape


def project_body_hash(number):
    """The config_hash the project's configuration gives body ``number``'s file: a synthetic file
    written with it passes the stages' check against the configuration in use (their default)."""
    from gimbal_reduction.solver import bodyconfig
    from gimbal_reduction.workflow.config import DEFAULT_CONFIG
    return bodyconfig.expected_hashes(str(DEFAULT_CONFIG))[int(number)]


def project_model_attrs():
    """The reduced-model file attribute of body files made from the project's configuration (a
    synthetic model file with it passes simulate's and export's check against the configuration)."""
    import json
    return {"body_config_hashes": json.dumps([project_body_hash(b) for b in (2, 3, 4, 5)])}


def write_body(path, d, number=None, config_hash=None):
    """A body file in the contract's layout (docs/body-data.md) from a synthetic body dict
    (``gimbal_reduction.results.bench.oracle.synthetic_body``); the body number from ``d`` unless given;
    config_hash: by default the one the project's configuration gives the body (``project_body_hash``)."""
    with h5py.File(path, "w") as f:
        lam = d["eigenvalues"]
        f["frequencies_hz"] = np.sqrt(lam) / (2 * np.pi)
        f["eigenvalues"] = lam
        for k in ("modes", "rigid_modes", "dof_coords", "dof_component", "bearing_points",
                  "bearing_modes"):
            f[k] = d[k]
        for k in ("M", "K", "T", "bearing_operator"):
            write_csr(f.create_group(k), d[k])
        f.attrs["body"] = d["number"] if number is None else number
        f.attrs["config_hash"] = project_body_hash(d["number"]) if config_hash is None else config_hash


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("sim")
    rng = np.random.default_rng(3)
    modes_dir, red_dir = root / "modes", root / "reduction"
    modes_dir.mkdir()
    red_dir.mkdir()
    datas = {}
    for b in models.BODIES:
        d = synthetic_body(rng, b, n_nodes=8, rotations=(b % 2 == 0), n_modes=6, omega_max=3e3)
        write_body(modes_dir / f"body{b}.h5", d)
        datas[b] = d
        with h5py.File(red_dir / f"body{b}.h5", "w") as f:
            f["rank_frequency"] = np.arange(6)
            f["rank_xmx"] = np.array([3, 1, 0, 2, 5, 4])
            f["rank_xmgmx"] = np.array([3, 1, 0, 2, 4, 5])
            f.attrs["body"], f.attrs["config_hash"] = b, project_body_hash(b)   # as the reduction stage copies
    return root, datas


def test_body_file_roundtrip_gives_same_chain(files):
    root, datas = files
    data = models.load_body_file(str(root / "modes" / "body2.h5"))
    assert data["number"] == 2
    body = models.build_body(2, data, np.arange(6))
    from gimbal_reduction.results.bench.oracle import chain_body
    ref = chain_body(datas[2])
    assert np.allclose(body.rigid_mass, ref.rigid_mass, rtol=1e-13, atol=1e-16)
    assert np.allclose(body.coriolis, ref.coriolis, rtol=1e-12, atol=1e-16)


@pytest.mark.parametrize("rotate", [True, False])
def test_selected_integrals_equal_those_computed_for_the_subset(files, rotate):
    """build_body without static modes selects from the body's all-mode integrals (kept in its
    dict); they must equal chain_integrals computed on the kept modes alone, for a permuted
    subset, on a body with output bearings (body 2) and on the platform (body 5)."""
    from gimbal_reduction.reduction import modal_integrals
    root, _ = files
    kept = np.array([4, 0, 3])
    for b in (2, 5):
        data = dict(models.load_body_file(str(root / "modes" / f"body{b}.h5")))   # own cache
        body = models.build_body(b, data, kept, rotate_rotation_blocks=rotate)
        direct = modal_integrals.chain_integrals(
            data["M"], data["modes"][:, kept], data["rigid_modes"], data["dof_coords"],
            data["dof_component"], data["bearing_modes"][kept], data["bearing_points"],
            rotate_rotation_blocks=rotate)
        ref = multibody.make_body(b, direct, data["eigenvalues"][kept])
        for name in ("rigid_mass", "momentum", "inertia_gradient", "coriolis", "omega2"):
            got, want = getattr(body, name), getattr(ref, name)
            assert got.shape == want.shape and got.flags.c_contiguous
            assert np.allclose(got, want, rtol=1e-12, atol=1e-14 * np.abs(want).max()), name
        assert (body.inside_translation is None) == (b == 5)
        if b != 5:
            assert np.allclose(body.inside_rotation, ref.inside_rotation, rtol=1e-12, atol=1e-15)
        assert np.any(body.coriolis != 0)
        # the selection is a selection: a different subset gives different integrals
        other = models.build_body(b, data, np.array([1, 2, 5]), rotate_rotation_blocks=rotate)
        assert not np.allclose(other.momentum, body.momentum)


def test_static_mode_model_builds_and_orthonormal(files):
    root, _ = files
    data = {b: models.load_body_file(str(root / "modes" / f"body{b}.h5")) for b in models.BODIES}
    spec = models.model_spec("static-3", models.load_rankings(str(root / "reduction")))
    chain = models.build_chain(spec, data)
    assert chain.n_modes == (4, 4, 4, 4)
    b2 = chain.bodies[0]
    assert b2.labels[-1] == "static output_motor_fz"
    # static mode's Rayleigh frequency lies above the kept modes and counts in omega_max
    assert b2.omega2[-1] > b2.omega2[:-1].max()
    assert chain.omega_max == pytest.approx(max(np.sqrt(b.omega2.max()) for b in chain.bodies))


def test_simulate_cli_writes_result(files, tmp_path):
    root, _ = files
    out = tmp_path / "sim"
    rc = run_model("thesis", "static-xmx-2", str(root / "modes"), str(root / "reduction"), str(out))
    assert rc == 0
    path = out / "thesis" / "static-xmx-2.h5"
    with h5py.File(path, "r") as f:
        thesis = scenes.load_scene("thesis")
        n = int(round(thesis.duration / thesis.output_interval)) + 1     # the scene's output samples
        assert f["gamma"].shape == (n, 4) and f["gamma_dot"].shape == (n, 4)
        assert f.attrs["integrator"] == "exponential" and f.attrs["steps"] > 0   # the default
        assert len(f.attrs["config_hash"]) == 16
        T, W = f["energy/total"][()], f["energy/input_work"][()]
        assert abs(T[-1] - T[0] - W[-1]) < 1e-3 * abs(W[-1])
    assert not [p for p in os.listdir(out / "thesis") if p.endswith(".tmp")]


def test_simulate_cli_errors_are_one_line(files, tmp_path, capsys):
    root, _ = files
    common = (str(root / "modes"), str(root / "reduction"), str(tmp_path))
    assert run_model("thesis", "freq-99", *common) == 2
    assert run_model("thesis", "freq-6", *common, options=["--integrator", "rk4", "--step", "1.0"]) == 2
    assert run_model("nope", "freq-6", *common) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and "only 6 computed" in err[0] and "stability limit" in err[1]
