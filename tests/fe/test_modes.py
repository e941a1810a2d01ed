"""The modal stage end to end on the inner gimbal: the body-file contract and bad input."""
import json
import math

import h5py
import numpy as np
import pytest

from gimbal_reduction.geometry import mesh as meshcli
from gimbal_reduction.solver.bodydata import BodyFileError, read_body_file
from gimbal_reduction.solver.fe import eigen, modes
from gimbal_reduction.workflow import config as cfgmod


def test_body_file_contract(inner_gimbal_file):
    body = read_body_file(inner_gimbal_file[0])
    body.update(body["attrs"])
    ndof, count = body["modes"].shape
    assert count == 20 and ndof % 6 == 0
    assert body["frequencies_hz"].shape == (20,) and np.all(np.diff(body["frequencies_hz"]) >= 0)
    np.testing.assert_allclose(body["eigenvalues"], (2 * math.pi * body["frequencies_hz"]) ** 2)
    assert body["M"].shape == body["K"].shape == (ndof, ndof)
    assert body["T"].shape == (ndof, ndof - 6)
    assert body["rigid_modes"].shape == (ndof, 6) and body["dof_coords"].shape == (ndof, 3)
    assert set(np.unique(body["dof_component"])) == set(range(6))
    assert body["bearing_points"].shape == (4, 3) and body["bearing_modes"].shape == (20, 4, 6)
    assert body["point_mass"] == pytest.approx(0.1 * body["structural_mass"])
    # every mode is T x: zero motion of the supported components at the input bearings
    R = body["bearing_operator"]
    motor = R[0:6] @ body["modes"]
    resolver = R[6:12] @ body["modes"]
    scale = np.abs(body["modes"]).max()
    assert np.abs(motor[[1, 2, 3]]).max() < 1e-10 * scale
    assert np.abs(resolver[[0, 1, 2]]).max() < 1e-10 * scale
    # the reduced pencil holds for every mode, and the modes are M-orthonormal
    residuals = eigen.relative_residuals(body["K"], body["M"], body["eigenvalues"], body["modes"], body["T"])
    assert residuals.max() < 1e-8
    assert eigen.orthonormality_error(body["M"], body["modes"]) < 1e-10
    # total mass = structure + eccentric mass; the rigid mass matrix is symmetric positive definite
    X = body["rigid_modes"]
    rigid = X.T @ body["M"] @ X
    assert rigid[0, 0] == pytest.approx(body["structural_mass"] + body["point_mass"], rel=1e-10)
    assert np.all(np.linalg.eigvalsh(rigid) > 0)


def test_eccentric_mass_moves_the_centre_of_mass(inner_gimbal_file):
    """First moment of the rigid mass matrix: the 10 % mass at 45 deg on the mid-surface."""
    body = read_body_file(inner_gimbal_file[0])
    body.update(body["attrs"])
    X = body["rigid_modes"]
    rigid = X.T @ body["M"] @ X
    mass = rigid[0, 0]
    # translation-rotation coupling block = m [r_c]x^T: centre of mass from it
    coupling = rigid[0:3, 3:6]
    centre = np.array([coupling[1, 2], coupling[2, 0], coupling[0, 1]]) / mass
    expected = body["point_mass"] * np.asarray(body["point_mass_position"]) / mass
    # the unstructured mesh leaves the bare ring's own centre of mass ~1e-5 in off the origin
    np.testing.assert_allclose(centre, expected, atol=5e-5)


def test_too_many_modes(tmp_path, config, inner_gimbal_file):
    with pytest.raises(ValueError, match="exceeds"):
        modes.compute_body(4, config, inner_gimbal_file[1], 10**7, log=lambda *a, **k: None)


def test_missing_and_corrupt_inputs(tmp_path, config):
    assert modes.main(["--body", "4", "--mesh", str(tmp_path / "none.msh"), "--out", str(tmp_path / "o.h5")]) == 1
    assert not (tmp_path / "o.h5").exists()
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"not an hdf5 file")
    with pytest.raises(BodyFileError, match="corrupt"):
        read_body_file(bad)
    partial = tmp_path / "partial.h5"
    with h5py.File(partial, "w") as h5:
        h5["modes"] = np.zeros((3, 1))
    with pytest.raises(BodyFileError, match="stale or incomplete"):
        read_body_file(partial)


def test_body_file_records_the_size_its_mesh_was_made_with(tmp_path, config):
    """The coarse body (meshed at 0.5 in, not the config's 0.25 in): gimbal_reduction.geometry.mesh --meta records
    the size, gimbal_reduction.solver.fe.modes --mesh-meta reads it into the body file; the body file's config_hash
    is the hash of the inputs the stage read."""
    mesh, meta, out = tmp_path / "b4.msh", tmp_path / "b4.json", tmp_path / "b4.h5"
    assert meshcli.main(["--body", "4", "--size", "0.5", "--out", str(mesh), "--meta", str(meta)]) == 0
    assert modes.main(["--body", "4", "--mesh", str(mesh), "--mesh-meta", str(meta), "--out", str(out),
                       "--count", "4"]) == 0
    attrs = read_body_file(out)["attrs"]
    assert attrs["mesh_size"] == 0.5 != cfgmod.value(config, "mesh.ring_size")
    assert attrs["config_hash"] == cfgmod.inputs_hash(cfgmod.body_inputs(config, 4, 0.5))
    meta.write_text("{}")
    assert modes.main(["--body", "4", "--mesh", str(mesh), "--mesh-meta", str(meta), "--out",
                       str(tmp_path / "x.h5"), "--count", "4"]) == 1
    assert not (tmp_path / "x.h5").exists()


def test_further_modes_after_known_ones(tmp_path, config, inner_gimbal_file):
    """--known-modes: the 12 modes of a body file kept, the next 8 solved in their M-orthogonal
    complement: the 20 lowest of a direct solve, checked as usual; files of other inputs, another
    mesh or not fewer modes are refused."""
    quiet = lambda *a, **k: None  # noqa: E731
    path, mesh = inner_gimbal_file
    known_path = tmp_path / "known.h5"
    modes.write_body_file(known_path, modes.compute_body(4, config, mesh, 12, log=quiet),
                          cfgmod.inputs_hash(cfgmod.body_inputs(config, 4)), 0.0)
    known = read_body_file(known_path)
    further = modes.compute_body(4, config, mesh, 20, log=quiet, known=known)
    direct = read_body_file(path, check=False)
    np.testing.assert_allclose(further["eigenvalues"], direct["eigenvalues"], rtol=1e-10)
    assert further["timings"]["known_modes"] == 12
    assert further["attrs"]["max_relative_residual"] < 1e-8 and further["attrs"]["orthonormality_error"] < 1e-10
    np.testing.assert_allclose(np.abs(further["modes"][:, 0] @ (further["M"] @ known["modes"][:, 0])), 1.0,
                               rtol=1e-9)
    with pytest.raises(ValueError, match="not fewer"):
        modes.compute_body(4, config, mesh, 12, log=quiet, known=known)
    with pytest.raises(ValueError, match="other inputs"):
        modes.compute_body(4, config, mesh, 20, log=quiet,
                           known={**known, "attrs": {**known["attrs"], "config_hash": "another"}})
    coarse = tmp_path / "coarse.msh"
    meshcli.main(["--body", "4", "--size", "0.5", "--out", str(coarse)])
    with pytest.raises(ValueError, match="another mesh"):
        modes.compute_body(4, config, coarse, 20, log=quiet, known=known, mesh_size=0.25)


def test_coarse_ring_mesh_may_exceed_the_width(tmp_path):
    """gimbal_reduction.geometry.mesh --coarse (the Hughes identities' mesh): a ring's size up to its radius, not only
    its width; the mesh stops coarsening at the cut lines. Without it the width bounds the size."""
    out, meta = tmp_path / "c.msh", tmp_path / "c.json"
    assert meshcli.main(["--body", "4", "--size", "0.75", "--out", str(out)]) == 1 and not out.exists()
    assert meshcli.main(["--body", "4", "--size", "0.75", "--coarse", "--out", str(out), "--meta", str(meta)]) == 0
    coarse = json.loads(meta.read_text())
    assert meshcli.main(["--body", "4", "--size", "0.5", "--out", str(out), "--meta", str(meta)]) == 0
    assert coarse["mesh_size"] == 0.75 and coarse["cells"] < json.loads(meta.read_text())["cells"]
    assert meshcli.main(["--body", "4", "--size", "3", "--coarse", "--out", str(out)]) == 1   # beyond the radius
