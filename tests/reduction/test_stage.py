"""End to end: a synthetic body file through ``python -m gimbal_reduction.reduction.stage``."""

import json
import os
import subprocess
import sys

import h5py
import numpy as np
import pytest

from tests import synthetic_bodies as sb  # noqa: E402

from gimbal_reduction.reduction import modal_integrals as mi  # noqa: E402
from gimbal_reduction.reduction import ranking as rk  # noqa: E402
from gimbal_reduction.reduction import stage  # noqa: E402
from gimbal_reduction.reduction import static_modes as st  # noqa: E402
from gimbal_reduction.workflow.provenance import atomic_h5

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("stage")
    ring = sb.ring_body(connection="rigid_fit", mass_model="shell_like", eccentric="rigid_fit",
                        n_elements=24, n_modes=50, body=2)
    plate = sb.ring_body(connection="rigid_fit", mass_model="consistent", output_bearings=False,
                         n_elements=16, n_modes=40, body=5)
    return {"ring": ring, "plate": plate, "folder": folder,
            "ring_file": sb.write_body_file(folder / "body2.h5", ring),
            "plate_file": sb.write_body_file(folder / "body5.h5", plate)}


def run(*args):
    return stage.main([str(a) for a in args] + ["--quiet"])


def test_outputs_match_the_pure_functions(files):
    out = files["folder"] / "reduction" / "body2.h5"
    assert run("--body-file", files["ring_file"], "--out", out, "--static-kept", 6) == 0
    ring = files["ring"]
    M, K, T, X = ring["M"], ring["K"], ring["T"], ring["rigid_modes"]
    P, H = mi.momentum_coefficients(M, X, ring["modes"])
    M_inf = mi.supported_rigid_mass(M, T, X, mi.node_index(ring["dof_coords"]))
    G = mi.supported_flexibility(K, T, X)
    with h5py.File(out, "r") as f:
        for key in ("P", "H", "M_inf", "MGM_inf", "M_rigid", "rho_xmx", "rho_xmgmx",
                    "rank_frequency", "rank_xmx", "rank_xmgmx"):
            assert key in f, key
        np.testing.assert_allclose(f["P"][...], P, atol=1e-14)
        np.testing.assert_allclose(f["H"][...], H, atol=1e-14)
        np.testing.assert_allclose(f["M_inf"][...], M_inf, rtol=1e-12)
        rho = rk.xmx_radii(P, H, M_inf)
        np.testing.assert_allclose(f["rho_xmx"][...], rho, rtol=1e-10)
        np.testing.assert_array_equal(f["rank_xmx"][...], rk.rank_by_radius(rho))
        np.testing.assert_array_equal(f["rank_frequency"][...], np.arange(50))
        assert f["rank_xmgmx"].dtype.kind == "i" and sorted(f["rank_xmgmx"][...]) == list(range(50))
        assert f.attrs["mode_index_base"] == 0 and f.attrs["body"] == 2
        # joint data (3, D) and the table
        assert f["joint/psi"].shape == (3, 50) and f["joint/theta"].shape == (3, 50)
        assert f["joint"].attrs["has_inside_frame"]
        assert f["ranking_table/xmx"].shape == (40,)
        assert f["ranking_table/xmx"][0] == f["rank_xmx"][0] + 1
        # static modes: seven groups against the 6 lowest modes
        s = f["static_modes"]
        assert sorted(s.keys()) == sorted(st.THESIS_LOAD_CASES)
        assert s.attrs["n_kept"] == 6 and json.loads(s.attrs["skipped_load_cases"]) == []
        g = s["output_motor_fz"]
        phi = g["mode"][...]
        np.testing.assert_array_equal(g["kept_modes"][...], np.arange(6))
        assert g.attrs["n_kept"] == 6
        assert g.attrs["modal_mass"] == pytest.approx(1.0, rel=1e-12)
        assert phi @ (M @ phi) == pytest.approx(1.0, rel=1e-12)
        assert phi @ (K @ phi) == pytest.approx(g.attrs["modal_stiffness"], rel=1e-12)
        Ps, Hs = mi.momentum_coefficients(M, X, phi)
        np.testing.assert_allclose(g["P"][...], Ps, atol=1e-15)
        np.testing.assert_allclose(g["H"][...], Hs, atol=1e-15)
        assert np.max(np.abs(ring["modes"][:, :6].T @ (M @ phi))) < 1e-10
        assert g["psi"].shape == (3,) and g["theta"].shape == (3,)
        np.testing.assert_allclose(
            g["theta"][...],
            mi.inside_frame_motion(np.asarray(ring["bearing_operator"] @ phi).reshape(4, 6),
                                   ring["bearing_points"])["theta"], atol=1e-15)
        checks = json.loads(f.attrs["checks"])
        assert all(c["passed"] for c in checks), [c for c in checks if not c["passed"]]
        assert {"name", "value", "tolerance", "passed"} <= set(checks[0])
        assert np.isfinite(s.attrs["set_gram_condition"])
    # the same static mode from the pure function for that kept set
    F = st.load_case_vector(ring["bearing_operator"], "output_motor_fz")
    res = st.static_correction_modes(M, K, G, F, ring["modes"][:, :6], ring["eigenvalues"][:6])
    np.testing.assert_allclose(phi, res["modes"][:, 0], atol=1e-12 * np.abs(phi).max())


def test_platform_skips_output_bearing_cases(files):
    out = files["folder"] / "body5_reduction.h5"
    assert run("--body-file", files["plate_file"], "--out", out) == 0
    with h5py.File(out, "r") as f:
        s = f["static_modes"]
        assert sorted(s.keys()) == ["input_motor_fx", "input_motor_my", "input_motor_mz"]
        assert sorted(json.loads(s.attrs["skipped_load_cases"])) == sorted(
            c for c in st.THESIS_LOAD_CASES if c.startswith("output"))
        assert not f["joint"].attrs["has_inside_frame"] and "psi" not in f["joint"]
        assert s.attrs["n_kept"] == 10


def test_explicit_output_case_on_platform_is_an_error(files, capsys):
    out = files["folder"] / "never.h5"
    assert run("--body-file", files["plate_file"], "--out", out, "--load-cases",
               "output_motor_fz") == 2
    assert "output_motor" in capsys.readouterr().err
    assert not out.exists()


def test_mode_subset_and_ranked_kept_set(files):
    out = files["folder"] / "subset.h5"
    assert run("--body-file", files["ring_file"], "--out", out, "--n-modes", 20,
               "--static-kept", 4, "--static-ranking", "xmgmx",
               "--load-cases", "output_motor_my", "input_motor_fx") == 0
    with h5py.File(out, "r") as f:
        assert f["P"].shape == (3, 20) and f.attrs["n_modes"] == 20
        kept = f["static_modes/output_motor_my/kept_modes"][...]
        np.testing.assert_array_equal(kept, f["rank_xmgmx"][:4])
        assert f["static_modes"].attrs["kept_ranking"] == "xmgmx"


def test_failed_write_leaves_old_file_and_no_temp(files, monkeypatch):
    out = files["folder"] / "atomic.h5"
    assert run("--body-file", files["ring_file"], "--out", out) == 0
    before = out.read_bytes()
    listing = sorted(p.name for p in out.parent.iterdir())

    def interrupted(path, result, body):
        with atomic_h5(path) as f:
            f.create_dataset("P", data=result["P"])
            raise KeyboardInterrupt  # killed half way through the write

    monkeypatch.setattr(stage, "write_reduction_file", interrupted)
    with pytest.raises(KeyboardInterrupt):
        run("--body-file", files["ring_file"], "--out", out)
    assert out.read_bytes() == before
    assert sorted(p.name for p in out.parent.iterdir()) == listing      # no temporary file left


def test_command_line_module(files):
    out = files["folder"] / "cli.h5"
    proc = subprocess.run(
        [sys.executable, "-m", "gimbal_reduction.reduction.stage", "--body-file", str(files["ring_file"]),
         "--out", str(out)], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "static modes" in proc.stdout
    with h5py.File(out, "r") as f:
        assert f["rank_xmx"].shape == (50,)
    bad = subprocess.run(
        [sys.executable, "-m", "gimbal_reduction.reduction.stage", "--body-file", str(files["folder"] / "x.h5"),
         "--out", str(out)], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2
    assert bad.stderr.count("\n") == 1 and "x.h5" in bad.stderr
