"""Static correction modes (thesis eq 3.48, Section 4.4) and the inside-frame joint data."""

import os

import numpy as np
import pytest

from tests import synthetic_bodies as sb  # noqa: E402

from gimbal_reduction.reduction import modal_integrals as mi  # noqa: E402
from gimbal_reduction.reduction import ranking as rk  # noqa: E402
from gimbal_reduction.reduction import static_modes as st  # noqa: E402
from gimbal_reduction.reduction import verification as vf  # noqa: E402
from gimbal_reduction.reduction.errors import MissingBearingError, StaticModeError  # noqa: E402


@pytest.fixture(scope="module", params=["rods", "rigid_fit"])
def body(request):
    b = sb.ring_body(connection=request.param, mass_model="shell_like", eccentric="rigid_fit",
                     n_modes=40, rod_factor=5.0)
    b["apply_G"] = mi.supported_flexibility(b["K"], b["T"], b["rigid_modes"])
    return b


@pytest.mark.parametrize("case", st.THESIS_LOAD_CASES)
@pytest.mark.parametrize("n_kept", [2, 8])
def test_static_mode_completes_the_static_response(body, case, n_kept):
    M, K, G = body["M"], body["K"], body["apply_G"]
    F = st.load_case_vector(body["bearing_operator"], case, body["bearing_points"])
    Phi, lam = st.check_kept_set(body["modes"], body["eigenvalues"], np.arange(n_kept))
    res = st.static_correction_modes(M, K, G, F, Phi, lam, [case])
    phi = res["modes"][:, 0]
    assert res["modal_mass"][0] == pytest.approx(1.0, rel=1e-12)
    assert vf.check_static_orthogonality(res)["passed"], res
    # independent re-check of eq 3.52's block diagonality
    assert np.max(np.abs(Phi.T @ (M @ phi))) < 1e-10
    assert np.max(np.abs(Phi.T @ (K @ phi)) / np.sqrt(lam * res["modal_stiffness"][0])) < 1e-10
    complete = vf.check_static_completeness(G, F, Phi, lam, phi, res["modal_stiffness"][0])
    assert complete["passed"], complete
    short = vf.check_truncation_shortfall(G, F, Phi, lam)
    assert short["tolerance"] is None and 1e-4 < short["value"] < 1.0
    # the static mode is stiffer than every kept mode (it stands for the truncated ones)
    assert res["modal_stiffness"][0] > lam.max()
    # positive work with its own load (sign convention)
    assert F @ phi > 0


def test_static_mode_matches_eq_348_directly(body):
    """phi proportional to [G - Phi Lambda^-1 Phi^T] F, formed here with a dense inverse."""
    T = body["T"]
    Kt = (T.T @ body["K"] @ T).toarray()
    G = T @ np.linalg.solve(Kt, T.T.toarray())
    F = st.load_case_vector(body["bearing_operator"], "output_motor_fz")
    Phi, lam = body["modes"][:, :6], body["eigenvalues"][:6]
    raw = (G - Phi @ np.diag(1 / lam) @ Phi.T) @ F
    raw /= np.sqrt(raw @ (body["M"] @ raw))
    res = st.static_correction_modes(body["M"], body["K"], body["apply_G"], F, Phi, lam)
    np.testing.assert_allclose(res["modes"][:, 0], raw, atol=1e-8 * np.abs(raw).max())


def test_several_static_modes_are_orthogonalised(body):
    M, K, G = body["M"], body["K"], body["apply_G"]
    names = list(st.THESIS_LOAD_CASES)
    F = np.column_stack([st.load_case_vector(body["bearing_operator"], n) for n in names])
    Phi, lam = st.check_kept_set(body["modes"], body["eigenvalues"], np.arange(8))
    res = st.static_correction_modes(M, K, G, F, Phi, lam, names)
    S = res["modes"]
    np.testing.assert_allclose(S.T @ (M @ S), np.eye(7), atol=1e-10)
    KS = S.T @ (K @ S)
    np.testing.assert_allclose(KS, np.diag(res["modal_stiffness"]),
                               atol=1e-10 * res["modal_stiffness"].max())
    assert np.all(np.diff(res["modal_stiffness"]) >= 0)
    assert 1.0 < res["gram_condition"] < 1e6
    assert max(res["mass_coupling"], res["stiffness_coupling"]) < 1e-10
    # together they reproduce each load's static response exactly
    for j in range(7):
        err = vf.static_response_error(G, F[:, j], np.column_stack([Phi, S]),
                                       np.r_[lam, res["modal_stiffness"]])
        assert err < 1e-10


def test_static_mode_for_a_ranked_kept_set(body):
    """Static modes for any kept set (here the 5 XMX-ranked modes)."""
    M, T, X = body["M"], body["T"], body["rigid_modes"]
    P, H = mi.momentum_coefficients(M, X, body["modes"])
    M_inf = mi.supported_rigid_mass(M, T, X, mi.node_index(body["dof_coords"]))
    kept = rk.kept_modes(rk.rank_by_radius(rk.xmx_radii(P, H, M_inf)), 5)
    Phi, lam = st.check_kept_set(body["modes"], body["eigenvalues"], kept)
    F = st.load_case_vector(body["bearing_operator"], "output_motor_my")
    res = st.static_correction_modes(M, body["K"], body["apply_G"], F, Phi, lam)
    assert vf.check_static_completeness(body["apply_G"], F, Phi, lam, res["modes"],
                                        res["modal_stiffness"])["passed"]


def test_dependent_load_cases_are_rejected(body):
    F = st.load_case_vector(body["bearing_operator"], "output_motor_fz")
    Phi, lam = body["modes"][:, :4], body["eigenvalues"][:4]
    with pytest.raises(StaticModeError, match="nearly linearly dependent"):
        st.static_correction_modes(body["M"], body["K"], body["apply_G"],
                                   np.column_stack([F, 2 * F]), Phi, lam, ["a", "b"])


def test_load_on_a_supported_direction_vanishes(body):
    # input motor u_y is held by the supports: G F = 0
    F = st.bearing_load(body["bearing_operator"], 0, [0, 1.0, 0, 0, 0, 0])
    with pytest.raises(StaticModeError, match="input_motor_fy.*supported"):
        st.static_correction_modes(body["M"], body["K"], body["apply_G"], F,
                                   body["modes"][:, :4], body["eigenvalues"][:4],
                                   ["input_motor_fy"])


def test_platform_has_no_output_bearing_loads():
    plat = sb.ring_body(connection="rigid_fit", output_bearings=False, n_elements=16)
    with pytest.raises(MissingBearingError, match="output_motor"):
        st.load_case_vector(plat["bearing_operator"], "output_motor_fz", plat["bearing_points"])
    with pytest.raises(MissingBearingError):  # operator rows are zero even without points
        st.load_case_vector(plat["bearing_operator"], "output_resolver_mx")
    F = st.load_case_vector(plat["bearing_operator"], "input_motor_fx", plat["bearing_points"])
    assert np.any(F)


# ---------------------------------------------------------------- joint data


def test_inside_frame_of_rigid_motion():
    rng = np.random.default_rng(3)
    for motor_side in (1, -1):
        points = np.array([[3.6, 0, 0], [-3.6, 0, 0], [0, 0, 3.1 * motor_side],
                           [0, 0, -3.1 * motor_side]])
        for _ in range(5):
            check = vf.check_inside_frame_rigid(points, rng.normal(size=3), rng.normal(size=3))
            assert check["passed"], check
    # an oblique, off-centre bearing pair
    points = np.array([[1, 0, 0], [-1, 0, 0], [0.3, 1.0, 2.0], [-0.5, -0.2, -1.0]])
    assert vf.check_inside_frame_rigid(points, [0.1, -0.2, 0.3], [1e-3, 2e-3, -3e-3])["passed"]


def test_inside_frame_matches_thesis_formulas():
    """Bearings on z (motor +z): thetaX = (u_ry - u_my)/d, thetaY = (u_mx - u_rx)/d,
    thetaZ = th_mz, PSI = ((u_mx + u_rx)/2, (u_my + u_ry)/2, u_rz) (Appendix A.2)."""
    rng = np.random.default_rng(4)
    a = 3.125
    points = np.array([[3.625, 0, 0], [-3.625, 0, 0], [0, 0, a], [0, 0, -a]])
    motion = rng.normal(size=(7, 4, 6))
    out = mi.inside_frame_motion(motion, points)
    um, ur, thm = motion[:, 2, :3], motion[:, 3, :3], motion[:, 2, 3:]
    d = 2 * a
    np.testing.assert_allclose(out["theta"][:, 0], (ur[:, 1] - um[:, 1]) / d, atol=1e-14)
    np.testing.assert_allclose(out["theta"][:, 1], (um[:, 0] - ur[:, 0]) / d, atol=1e-14)
    np.testing.assert_allclose(out["theta"][:, 2], thm[:, 2], atol=1e-14)
    np.testing.assert_allclose(out["psi"], np.c_[(um[:, :2] + ur[:, :2]) / 2, ur[:, 2]], atol=1e-14)
    np.testing.assert_allclose(out["psi_midpoint"], (um + ur) / 2, atol=1e-14)
    np.testing.assert_allclose(out["stretch"], um[:, 2] - ur[:, 2], atol=1e-14)


def test_outside_frame_is_held_in_supported_modes():
    """The supports hold the input-bearing frame: its motion vanishes in every supported mode."""
    body = sb.ring_body(connection="rigid_fit", n_elements=16)
    out = mi.inside_frame_motion(body["bearing_modes"], body["bearing_points"], motor=0, resolver=1)
    scale = np.max(np.abs(body["bearing_modes"]))
    for key in ("psi", "theta"):
        assert np.max(np.abs(out[key])) < 1e-10 * scale
    # ... while the inside frame moves
    inside = mi.inside_frame_motion(body["bearing_modes"], body["bearing_points"])
    assert np.max(np.abs(inside["theta"])) > 1e-3 * scale


def test_platform_inside_frame_is_an_error():
    points = np.array([[1.9, 0, 0], [-1.9, 0, 0], [np.nan] * 3, [np.nan] * 3])
    with pytest.raises(MissingBearingError, match="output_motor"):
        mi.inside_frame_motion(np.zeros((3, 4, 6)), points)
