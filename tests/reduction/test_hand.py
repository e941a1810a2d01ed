"""Hand-checkable model: three point masses on springs to ground (T = I).

Masses m = 1/2 at p1 = (2, 0, 0), p2 = (-1, 1, 0), p3 = (-1, -1, 0); 3
translational DOFs each, isotropic spring k_n to ground.  The centre of mass
is the origin and the inertia tensor is diagonal: J = m diag(2 b^2, 1.5 a^2,
2 b^2 + 1.5 a^2) = diag(1, 3, 4) for a = 2, b = 1.  Modes e_d / sqrt(m_n),
Omega^2 = k_n / m_n, so P_i = sqrt(m) e_d, H_i = sqrt(m) p_n x e_d and
rho_XMX = v^T M_inf^-1 v = 1/3 + m sum_k (p_n x e_d)_k^2 / J_kk:

    node 1: e_x 1/3, e_y 1/3 + 1/2 = 5/6, e_z 1/3 + 2/3 = 1
    node 2: e_x 11/24, e_y 11/24, e_z 1
    node 3: e_x 11/24, e_y 11/24, e_z 1          (sum 6: Hughes)

Nothing here calls the code under test to produce an expected value.
"""

import os

import numpy as np
import pytest
import scipy.sparse as sp

from tests import synthetic_bodies as sb  # noqa: E402

from gimbal_reduction.reduction import modal_integrals as mi  # noqa: E402
from gimbal_reduction.reduction import ranking as rk  # noqa: E402
from gimbal_reduction.reduction import static_modes as st  # noqa: E402
from gimbal_reduction.reduction.errors import StaticModeError  # noqa: E402

m = 0.5
POS = np.array([[2.0, 0, 0], [-1.0, 1.0, 0], [-1.0, -1.0, 0]])


def hand_model(k=(100.0, 100.0, 100.0)):
    return sb.grounded_masses([m, m, m], POS, k)


def block(p):
    """Rigid mass of a unit point mass at p: [[I, -[p]x], [[p]x, -[p]x^2]] (by hand)."""
    s = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
    return np.block([[np.eye(3), -s], [s, -s @ s]])


def test_momentum_coefficients_by_hand():
    h = hand_model()
    P, H = mi.momentum_coefficients(h["M"], h["X"], h["modes"])
    for n in range(3):
        for d in range(3):
            i = 3 * n + d
            e = np.eye(3)[d]
            np.testing.assert_allclose(P[:, i], np.sqrt(m) * e, atol=1e-15)
            np.testing.assert_allclose(H[:, i], np.sqrt(m) * np.cross(POS[n], e), atol=1e-15)


def test_rigid_and_flexibility_matrices_by_hand():
    h = hand_model(k=(100.0, 100.0, 100.0))
    M_inf = mi.supported_rigid_mass(h["M"], h["T"], h["X"])
    expected = np.zeros((6, 6))
    expected[:3, :3] = 1.5 * np.eye(3)
    expected[3:, 3:] = np.diag([1.0, 3.0, 4.0])
    np.testing.assert_allclose(M_inf, expected, atol=1e-13)
    np.testing.assert_allclose(mi.rigid_mass(h["M"], h["X"]), expected, atol=1e-13)
    apply_G = mi.supported_flexibility(h["K"], h["T"], h["X"])
    MGM = mi.flexibility_matrix(h["M"], h["X"], apply_G)
    np.testing.assert_allclose(MGM, expected * m / 100.0, atol=1e-15)


def test_xmx_radii_and_ranking_by_hand():
    h = hand_model()
    P, H = mi.momentum_coefficients(h["M"], h["X"], h["modes"])
    M_inf = mi.supported_rigid_mass(h["M"], h["T"], h["X"])
    rho = rk.xmx_radii(P, H, M_inf)
    expected = np.array([1 / 3, 5 / 6, 1, 11 / 24, 11 / 24, 1, 11 / 24, 11 / 24, 1])
    np.testing.assert_allclose(rho, expected, rtol=1e-13)
    assert rho.sum() == pytest.approx(6.0, rel=1e-13)
    # ties go to the lower index: 1 (modes 2, 5, 8), 5/6 (1), 11/24 (3, 4, 6, 7), 1/3 (0)
    np.testing.assert_array_equal(rk.rank_by_radius(rho), [2, 5, 8, 1, 3, 4, 6, 7, 0])
    # equal springs: MGM_inf = (m/k) M_inf and Mbar_i / Omega_i^2 = (m/k) Mbar_i -> same radii
    apply_G = mi.supported_flexibility(h["K"], h["T"], h["X"])
    rho_g = rk.xmgmx_radii(P, H, h["eigenvalues"], mi.flexibility_matrix(h["M"], h["X"], apply_G))
    np.testing.assert_allclose(rho_g, expected, rtol=1e-12)


def test_xmgmx_with_unequal_springs_by_hand():
    k = np.array([50.0, 200.0, 800.0])
    h = hand_model(k=tuple(k))
    # by hand: MGM_inf = sum_n (m^2 / k_n) block(p_n); rho = (m^2/k_n) u^T MGM^-1 u, u = [e; p x e]
    MGM_hand = sum(m ** 2 / k[n] * block(POS[n]) for n in range(3))
    rho_hand = []
    for n in range(3):
        for d in range(3):
            e = np.eye(3)[d]
            u = np.r_[e, np.cross(POS[n], e)]
            rho_hand.append(m ** 2 / k[n] * u @ np.linalg.solve(MGM_hand, u))
    rho_hand = np.array(rho_hand)
    P, H = mi.momentum_coefficients(h["M"], h["X"], h["modes"])
    apply_G = mi.supported_flexibility(h["K"], h["T"], h["X"])
    MGM = mi.flexibility_matrix(h["M"], h["X"], apply_G)
    np.testing.assert_allclose(MGM, MGM_hand, rtol=1e-13, atol=1e-18)
    rho = rk.xmgmx_radii(P, H, h["eigenvalues"], MGM)
    np.testing.assert_allclose(rho, rho_hand, rtol=1e-12)
    assert rho.sum() == pytest.approx(6.0, rel=1e-12)
    np.testing.assert_array_equal(rk.rank_by_radius(rho), np.lexsort((np.arange(9), -np.round(rho_hand, 10))))
    # frequency order: Omega^2 = k/m -> node 1 modes first, then node 2, then node 3
    np.testing.assert_array_equal(rk.rank_by_frequency(h["eigenvalues"]), np.arange(9))


def test_static_mode_by_hand():
    """Unit load at node 2 along x with node 1's modes kept: phi = e / sqrt(m), k_s = k_2 / m."""
    k = (50.0, 200.0, 800.0)
    h = hand_model(k=k)
    apply_G = mi.supported_flexibility(h["K"], h["T"], h["X"])
    B = sp.lil_matrix((24, 9))
    for b in range(3):  # bearing b = node b's translations (no rotation rows)
        for c in range(3):
            B[6 * b + c, 3 * b + c] = 1.0
    B = B.tocsr()
    F = st.load_case_vector(B, "input_resolver_fx")  # bearing 1 = node 2
    Phi, lam = st.check_kept_set(h["modes"], h["eigenvalues"], [0, 1, 2])
    res = st.static_correction_modes(h["M"], h["K"], apply_G, F, Phi, lam)
    expected = np.zeros(9)
    expected[3] = 1 / np.sqrt(m)
    np.testing.assert_allclose(res["modes"][:, 0], expected, atol=1e-14)
    assert res["modal_mass"][0] == pytest.approx(1.0, rel=1e-14)
    assert res["modal_stiffness"][0] == pytest.approx(200.0 / m, rel=1e-14)
    P, H = mi.momentum_coefficients(h["M"], h["X"], res["modes"][:, 0])
    np.testing.assert_allclose(P, [np.sqrt(m), 0, 0], atol=1e-14)
    np.testing.assert_allclose(H, np.sqrt(m) * np.cross(POS[1], [1, 0, 0]), atol=1e-14)
    # the same load with node 2's x mode kept: the static response is in the kept set
    Phi, lam = st.check_kept_set(h["modes"], h["eigenvalues"], [3])
    with pytest.raises(StaticModeError, match="input_resolver_fx"):
        st.static_correction_modes(h["M"], h["K"], apply_G, F, Phi, lam, ["input_resolver_fx"])


def test_captured_share_by_hand():
    h = hand_model()
    P, H = mi.momentum_coefficients(h["M"], h["X"], h["modes"])
    M_inf = mi.supported_rigid_mass(h["M"], h["T"], h["X"])
    # node 1 alone: translations m = 1/2 of 3/2 each -> 1/3 per direction; rotations: node 1 has
    # J1 = m diag(0, 4, 4) of J = diag(1, 3, 4) -> shares 0, 2/3, 1/2; trace share (1 + 7/6) / 6
    share = rk.captured_share(P, H, [0, 1, 2], M_inf)
    assert share["trace_share"] == pytest.approx((1.0 + 2 / 3 + 1 / 2) / 6, rel=1e-13)
    assert share["min_eigenvalue"] == pytest.approx(0.0, abs=1e-13)
    full = rk.captured_share(P, H, np.arange(9), M_inf)
    assert full["trace_share"] == pytest.approx(1.0, rel=1e-13)
    assert full["min_eigenvalue"] == pytest.approx(1.0, rel=1e-12)
