"""The error measure of the thesis (eq. 3.53), the one definition every stage uses.

For every gimbal rate n (gamma_dot[:, n], rad/s)::

    E_n = int e_n(t)^2 dt / int r_n(t)^2 dt,   r = truth rate, e = reduced rate - r

with both integrals by the trapezoid rule on the common output grid ``t`` (s).
E is dimensionless; E = 1 means an error as large as the signal.  Two runs are
compared only on the same grid (``check_same_grid``): no resampling, which
would hide a scene mismatch.
"""
from __future__ import annotations

import numpy as np

GRID_RTOL = 1e-9


class ErrorsInputError(ValueError):
    """A missing, corrupt or mismatched simulation file (one-line message)."""


def error_measure(t, reference, reduced):
    """Eq 3.53 per column: E_n = trapezoid((reduced - reference)_n^2, t) / trapezoid(reference_n^2, t).

    t: (T,) [s], strictly increasing; reference, reduced: (T,) or (T, K) in the same
    unit (rad/s here).  Returns (K,) (or a float for 1-D input), dimensionless; NaN for
    a column whose reference is identically zero.
    """
    t = np.asarray(t, dtype=float)
    r = np.asarray(reference, dtype=float)
    x = np.asarray(reduced, dtype=float)
    if r.shape != x.shape or r.shape[0] != t.shape[0] or t.ndim != 1:
        raise ErrorsInputError(f"error_measure: shapes t {t.shape}, reference {r.shape}, "
                               f"reduced {x.shape} do not match")
    if t.size < 2 or np.any(np.diff(t) <= 0):
        raise ErrorsInputError("error_measure: t must hold at least 2 strictly increasing samples")
    num = np.trapezoid((x - r) ** 2, t, axis=0)
    den = np.trapezoid(r ** 2, t, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)
    return float(out) if np.ndim(out) == 0 else out


ARCSEC_PER_RAD = 180.0 * 3600.0 / np.pi


def attitude_error(R_reference, R_reduced):
    """Angle (T,) [rad] of the rotation between two attitude histories (T, 3, 3): the angle of
    R_reference^T R_reduced, from its skew part (asin |vee(A - A^T)| / 2, exact to rounding
    for the small angles of interest, where the trace formula loses half the digits) and its
    trace (the branch beyond pi/2)."""
    A = np.einsum("tji,tjk->tik", np.asarray(R_reference, float), np.asarray(R_reduced, float))
    v = np.stack([A[:, 2, 1] - A[:, 1, 2], A[:, 0, 2] - A[:, 2, 0], A[:, 1, 0] - A[:, 0, 1]], axis=1)
    s = np.clip(0.5 * np.linalg.norm(v, axis=1), 0.0, 1.0)
    c = 0.5 * (np.trace(A, axis1=1, axis2=2) - 1.0)
    return np.where(c >= 0, np.arcsin(s), np.pi - np.arcsin(s))


def check_same_grid(t_truth, t_case, label="case"):
    """Raise ErrorsInputError (one line) unless the two output grids (s) are the same."""
    a, b = np.asarray(t_truth, float), np.asarray(t_case, float)
    if a.shape != b.shape:
        raise ErrorsInputError(f"{label}: {b.size} output samples, the truth has {a.size} "
                               f"(different scene or output interval)")
    tol = GRID_RTOL * max(float(np.max(np.abs(a))), 1e-300)
    dev = float(np.max(np.abs(a - b))) if a.size else 0.0
    if dev > tol:
        raise ErrorsInputError(f"{label}: output times differ from the truth's by up to {dev:.3g} s "
                               f"(different scene or output interval)")
