"""Verification checks of the reduction stage, as pure functions.

Every check returns the project's check record ``{"name", "value", "tolerance",
"passed"}`` (``gimbal_reduction.workflow.provenance.check_record``) with plain Python types
(JSON-ready): passed = value <= tolerance.  ``tolerance`` None marks a measured
report (e.g. how far the kept modes alone fall short), which passes when finite.
"""

import numpy as np

from gimbal_reduction.reduction.modal_integrals import inside_frame_motion, mode_contributions
from gimbal_reduction.reduction.ranking import symmetric_inverse_sqrt
from gimbal_reduction.reduction.static_modes import reduced_static_response
from gimbal_reduction.workflow.provenance import check_record


def identity_defect(partial_sum, reference):
    """max |A^-1/2 C A^-1/2 - I|: dimensionless defect of C against A (both (6, 6))."""
    S = symmetric_inverse_sqrt(reference)
    return float(np.max(np.abs(S @ partial_sum @ S - np.eye(reference.shape[0]))))


def check_hughes_mass_identity(P, H, M_inf, tol=1e-8, name="hughes_mass_identity"):
    """sum_i Mbar_i = M_inf over all finite supported modes (eq 3.32)."""
    return check_record(name, identity_defect(mode_contributions(P, H).sum(axis=0), M_inf), tol)


def check_hughes_flexibility_identity(P, H, eigenvalues, MGM_inf, tol=1e-8,
                                      name="hughes_flexibility_identity"):
    """sum_i Mbar_i / Omega_i^2 = MGM_inf over all finite supported modes (eq 3.46)."""
    C = mode_contributions(P, H) / np.asarray(eigenvalues, float)[:, None, None]
    return check_record(name, identity_defect(C.sum(axis=0), MGM_inf), tol)


def static_response_error(apply_G, load, modes, modal_stiffness):
    """||Psi K_r^-1 Psi^T F - G F|| / ||G F|| for a modal basis Psi with diagonal stiffness."""
    exact = apply_G(np.asarray(load, float))
    approx = reduced_static_response(load, modes, modal_stiffness)
    return float(np.linalg.norm(approx - exact) / np.linalg.norm(exact))


def check_static_completeness(apply_G, load, kept_modes, kept_eigenvalues, static_modes,
                              static_stiffness, tol=1e-10, name="static_mode_completeness"):
    """Kept modes plus the static mode(s) of ``load`` reproduce G F exactly."""
    modes = np.column_stack([kept_modes, static_modes])
    stiffness = np.r_[np.asarray(kept_eigenvalues, float), np.atleast_1d(static_stiffness)]
    return check_record(name, static_response_error(apply_G, load, modes, stiffness), tol)


def static_energy_shortfall(apply_G, load, kept_modes, kept_eigenvalues):
    """Energy-norm share of the static response G F that the kept modes miss, in [0, 1].

    The kept-mode response u_k = Phi Lambda^-1 Phi^T F is the K-orthogonal
    projection of u = G F, so ||u - u_k||_K^2 = F.u - F.u_k and the share is
    sqrt(1 - F.u_k / F.u) (dimensionless; needs no K).
    """
    F = np.asarray(load, float)
    full = F @ apply_G(F)
    kept = F @ reduced_static_response(F, kept_modes, kept_eigenvalues)
    return float(np.sqrt(max(1.0 - kept / full, 0.0)))


def check_truncation_shortfall(apply_G, load, kept_modes, kept_eigenvalues,
                               name="kept_modes_static_shortfall"):
    """Report: energy-norm share of the static response the kept vibration modes alone miss."""
    return check_record(name, static_energy_shortfall(apply_G, load, kept_modes, kept_eigenvalues),
                        None)


def check_static_orthogonality(static_result, tol=1e-10, name="static_mode_orthogonality"):
    """Largest relative M- and K-coupling between static and kept modes (``static_correction_modes``)."""
    value = max(static_result["mass_coupling"], static_result["stiffness_coupling"])
    return check_record(name, value, tol)


def check_ranking_invariance(rho_a, rho_b, rank_a, rank_b, tol=1e-10, name="ranking_invariance"):
    """Two evaluations of one ranking agree: max relative radius change, and equal orders.

    value = max |rho_a - rho_b| / max |rho_a|; fails also if the orders differ.
    """
    rho_a, rho_b = np.asarray(rho_a, float), np.asarray(rho_b, float)
    value = float(np.max(np.abs(rho_a - rho_b)) / np.max(np.abs(rho_a)))
    return check_record(name, value, tol,
                        passed=bool(np.isfinite(value) and value <= tol and np.array_equal(rank_a, rank_b)))


def check_inside_frame_rigid(bearing_points, translation, rotation, tol=1e-12,
                             name="inside_frame_rigid_motion"):
    """A rigid motion u(p) = t + w x p at the bearings gives theta = w and psi = t + w x c."""
    points = np.asarray(bearing_points, float)
    t, w = np.asarray(translation, float), np.asarray(rotation, float)
    motion = np.zeros((4, 6))
    finite = np.all(np.isfinite(points), axis=1)
    motion[finite, :3] = t + np.cross(w, points[finite])
    motion[finite, 3:] = w
    out = inside_frame_motion(motion, points)
    centre = 0.5 * (points[2] + points[3])
    expected_psi = t + np.cross(w, centre)
    scale = max(np.linalg.norm(expected_psi), np.linalg.norm(w), 1e-300)
    value = max(np.max(np.abs(out["theta"] - w)), np.max(np.abs(out["psi"] - expected_psi)),
                np.max(np.abs(out["psi_midpoint"] - expected_psi)), abs(out["stretch"])) / scale
    return check_record(name, value, tol)
