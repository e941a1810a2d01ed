"""Rankings: invariance (mode signs, DOF numbering, density), table, shares, ties."""

import os

import numpy as np
import pytest

from tests import synthetic_bodies as sb  # noqa: E402

from gimbal_reduction.reduction import modal_integrals as mi  # noqa: E402
from gimbal_reduction.reduction import ranking as rk  # noqa: E402
from gimbal_reduction.reduction import verification as vf  # noqa: E402


def rankings(body):
    M, K, T, X = body["M"], body["K"], body["T"], body["rigid_modes"]
    P, H = mi.momentum_coefficients(M, X, body["modes"])
    M_inf = mi.supported_rigid_mass(M, T, X, mi.node_index(body["dof_coords"]))
    MGM_inf = mi.flexibility_matrix(M, X, mi.supported_flexibility(K, T, X))
    rho_x = rk.xmx_radii(P, H, M_inf)
    rho_g = rk.xmgmx_radii(P, H, body["eigenvalues"], MGM_inf)
    return rho_x, rho_g, rk.rank_by_radius(rho_x), rk.rank_by_radius(rho_g)


@pytest.fixture(scope="module")
def body():
    # an asymmetric ring (eccentric mass, motor on -x for the output pair) so ranks have gaps
    return sb.ring_body(connection="rigid_fit", mass_model="shell_like", eccentric="rigid_fit",
                        n_elements=24, output_motor_side=-1, n_modes=60)


@pytest.fixture(scope="module")
def reference(body):
    return rankings(body)


def assert_same(reference, other, label):
    for which, (ra, rb, ka, kb) in {"xmx": (reference[0], other[0], reference[2], other[2]),
                                    "xmgmx": (reference[1], other[1], reference[3], other[3])}.items():
        check = vf.check_ranking_invariance(ra, rb, ka, kb, tol=1e-9, name=f"{label}/{which}")
        assert check["passed"], check


def test_invariant_to_mode_signs(body, reference):
    rng = np.random.default_rng(1)
    signs = rng.choice([-1.0, 1.0], size=body["modes"].shape[1])
    flipped = dict(body, modes=body["modes"] * signs)
    assert_same(reference, rankings(flipped), "signs")


def test_invariant_to_dof_numbering(body, reference):
    perm = np.random.default_rng(2).permutation(body["M"].shape[0])
    assert_same(reference, rankings(sb.permute_dofs(body, perm)), "renumbering")


@pytest.mark.parametrize("factor", [1e-3, 7.5, 1e4])
def test_invariant_to_density_scaling(body, reference, factor):
    assert_same(reference, rankings(sb.scale_density(body, factor)), f"density x{factor}")


def test_radii_are_rank_one_quadratic_forms(body, reference):
    """rho_i = v_i^T A^-1 v_i (Mbar_i has rank one), and the spectral-radius route agrees."""
    M, T, X = body["M"], body["T"], body["rigid_modes"]
    P, H = mi.momentum_coefficients(M, X, body["modes"])
    M_inf = mi.supported_rigid_mass(M, T, X, mi.node_index(body["dof_coords"]))
    v = np.r_[P, H]
    np.testing.assert_allclose(reference[0], np.einsum("ai,ai->i", v, np.linalg.solve(M_inf, v)),
                               rtol=1e-10)
    assert np.all(reference[0] >= 0) and np.all(reference[0] <= 1 + 1e-12)


def test_symmetric_inverse_sqrt():
    A = np.array([[4.0, 1.0, 0.0], [1.0, 3.0, 0.5], [0.0, 0.5, 2.0]])
    S = rk.symmetric_inverse_sqrt(A)
    np.testing.assert_allclose(S, S.T, atol=1e-15)
    np.testing.assert_allclose(S @ A @ S, np.eye(3), atol=1e-14)
    with pytest.raises(ValueError, match="not positive definite"):
        rk.symmetric_inverse_sqrt(np.diag([1.0, 0.0, 1.0]))


def test_rank_ties_and_order():
    rho = np.array([0.2, 0.5, 0.5 * (1 + 1e-14), 0.1, 0.5])
    np.testing.assert_array_equal(rk.rank_by_radius(rho), [1, 2, 4, 0, 3])
    np.testing.assert_array_equal(rk.rank_by_frequency([3.0, 1.0, 2.0, 1.0]), [1, 3, 2, 0])


def test_ranking_table_agreement():
    a = np.array([3, 2, 0, 1, 5, 4, 6, 7])
    b = np.array([3, 2, 0, 5, 1, 4, 7, 6])
    table = rk.ranking_table(a, b, n_rows=6, top_k=(2, 4, 5, 8))
    np.testing.assert_array_equal(table["xmx"], a[:6] + 1)  # 1-based mode numbers
    assert table["common_prefix"] == 3
    np.testing.assert_array_equal(table["top_k"], [2, 4, 5, 8])
    np.testing.assert_array_equal(table["overlap"], [2, 3, 5, 8])
    np.testing.assert_array_equal(table["same_set"], [True, False, True, True])


def test_cumulative_share_matches_captured_share(body):
    M, T, X = body["M"], body["T"], body["rigid_modes"]
    P, H = mi.momentum_coefficients(M, X, body["modes"])
    M_inf = mi.supported_rigid_mass(M, T, X, mi.node_index(body["dof_coords"]))
    order = rk.rank_by_radius(rk.xmx_radii(P, H, M_inf))
    trace, smallest = rk.cumulative_share(P, H, order, M_inf)
    for k in (1, 6, 17, 60):
        share = rk.captured_share(P, H, order[:k], M_inf)
        assert trace[k - 1] == pytest.approx(share["trace_share"], rel=1e-12)
        assert smallest[k - 1] == pytest.approx(share["min_eigenvalue"], abs=1e-12)
    assert np.all(np.diff(trace) >= -1e-15)
    # XMX order captures the trace share greedily: never below frequency order at any k
    trace_f, _ = rk.cumulative_share(P, H, rk.rank_by_frequency(body["eigenvalues"]), M_inf)
    assert np.all(trace >= trace_f - 1e-12)


def test_kept_modes_count():
    with pytest.raises(ValueError, match="asked for 11, only 10"):
        rk.kept_modes(np.arange(10), 11)
    np.testing.assert_array_equal(rk.kept_modes(np.array([4, 2, 0]), 2), [4, 2])
