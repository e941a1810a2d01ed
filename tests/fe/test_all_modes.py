"""Every finite supported mode by the dense solve (gimbal_reduction.solver.fe.eigen.all_supported_modes) and the
Hughes identity check on a body file holding them (gimbal_reduction.solver.fe.checks.check_hughes_identity).

References: the synthetic rings of tests/synthetic_bodies.py (beam elements, their own dense
solve through the K-inner product), with massless rotations (lumped and shell-like mass: an
oblique massless direction per node), nearly massless ones and none; and the check must fail
on a file that lacks a mode or whose mass matrix is not the one the modes were solved with.
"""
import numpy as np
import pytest
import scipy.linalg

from gimbal_reduction.solver.fe import checks, eigen
from tests import synthetic_bodies as sb

RINGS = {
    "shell_like": dict(mass_model="shell_like", connection="rigid_fit", eccentric="rigid_fit"),
    "lumped": dict(mass_model="lumped", connection="rigid_links"),
    "consistent_no_polar": dict(mass_model="consistent_no_polar", connection="rigid_fit"),
    "consistent": dict(mass_model="consistent", connection="rods"),
}


@pytest.fixture(scope="module", params=sorted(RINGS))
def ring(request):
    return sb.ring_body(n_elements=16, **RINGS[request.param])


def test_all_supported_modes_against_the_independent_dense_solve(ring):
    K, M, T = ring["K"], ring["M"], ring["T"]
    values, modes = eigen.all_supported_modes(K, M, T)
    # every finite mode, the same spectrum as the synthetic bodies' own solve
    assert values.shape == ring["eigenvalues"].shape
    np.testing.assert_allclose(values, ring["eigenvalues"], rtol=1e-9)
    assert eigen.relative_residuals(K, M, values, modes, T).max() < 1e-9
    assert eigen.orthonormality_error(M, modes) < 1e-10
    # admissible: in the range of T (the supports hold)
    coords = np.linalg.lstsq(T.toarray(), modes, rcond=None)[0]
    np.testing.assert_allclose(T @ coords, modes, atol=1e-10 * np.abs(modes).max())


def test_massless_split_spans_the_null_space():
    """An oblique massless direction per node (not a coordinate) and a definite rest."""
    rng = np.random.default_rng(3)
    n, blocks = 12, []
    for _ in range(n // 3):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        blocks.append(q @ np.diag([2.0, 0.5, 0.0]) @ q.T)
    m = scipy.linalg.block_diag(*blocks)
    S, Z = eigen.massless_split(m)
    assert len(S) == 8 and Z.shape == (n, 4)
    assert np.abs(m @ Z).max() < 1e-14
    assert np.linalg.eigvalsh(m[np.ix_(S, S)]).min() > 1e-3
    assert np.linalg.matrix_rank(np.column_stack([np.eye(n)[:, S], Z])) == n


@pytest.fixture(scope="module")
def coarse_ring_file(tmp_path_factory):
    """A rigid-fit ring with massless rotations and every finite mode, as a body file."""
    body = sb.ring_body(n_elements=16, **RINGS["shell_like"])
    return body, sb.write_body_file(tmp_path_factory.mktemp("hughes") / "ring.h5", body)


def test_hughes_identity_holds_with_every_mode(coarse_ring_file):
    body, path = coarse_ring_file
    result = checks.check_hughes_identity(path)
    assert result["passed"], result["value"]
    assert result["value"] < 1e-10 and result["modes"] == result["finite_modes"] == len(body["eigenvalues"])


@pytest.mark.parametrize("drop", [0, -1])
def test_hughes_identity_fails_without_one_mode(coarse_ring_file, tmp_path, drop):
    """Without the lowest or the highest mode the sum misses its momentum (the value fails) and
    the file holds one mode fewer than the finite ones (the count fails; on the FE coarse body a
    third of the modes carry too little momentum to show in the value: tests/fe/test_checks.py)."""
    body, _ = coarse_ring_file
    keep = np.delete(np.arange(len(body["eigenvalues"])), drop)
    short = sb.body_dict(body["M"], body["K"], body["T"], body["modes"][:, keep], body["eigenvalues"][keep],
                         body["dof_coords"], body["dof_component"], body["bearing_points"],
                         body["bearing_operator"], mesh_size=1.0)
    result = checks.check_hughes_identity(sb.write_body_file(tmp_path / "short.h5", short))
    assert not result["passed"]
    assert result["modes"] == result["finite_modes"] - 1
    assert result["value"] > 1e-3


def test_hughes_identity_fails_on_another_mass_matrix(coarse_ring_file, tmp_path):
    """Modes solved with the eccentric mass, checked against a mass matrix without it."""
    body, _ = coarse_ring_file
    bare = sb.ring_body(n_elements=16, eccentric_fraction=0.0, **RINGS["shell_like"])
    mixed = dict(body, M=bare["M"])
    result = checks.check_hughes_identity(sb.write_body_file(tmp_path / "mixed.h5", mixed))
    assert not result["passed"] and result["value"] > 1e-3


def test_constrained_eigenvalues_equal_the_eliminated_ones(inner_gimbal_file):
    """The supports as Lagrange multipliers (the connection study's solve) against the modal
    stage's elimination with master DOFs: the body file's lowest supported eigenvalues."""
    from gimbal_reduction.solver.bodydata import read_body_file
    from gimbal_reduction.solver.fe import bearings

    body = read_body_file(inner_gimbal_file[0])
    B = body["bearing_operator"]
    C = bearings.support_constraints({"input_motor": B[0:6], "input_resolver": B[6:12]})
    values = eigen.constrained_eigenvalues(body["K"], body["M"], C, 10, 1e-12)
    np.testing.assert_allclose(values, body["eigenvalues"][:10], rtol=1e-9)
