"""The error measure of the thesis (eq. 3.53), the one definition every stage uses.

For every gimbal rate n (gamma_dot[:, n], rad/s)::

    E_n = int e_n(t)^2 dt / int r_n(t)^2 dt,   r = truth rate, e = reduced rate - r

with both integrals by the trapezoid rule on the common output grid ``t`` (s).
E is dimensionless; E = 1 means an error as large as the signal.  Two runs are
compared only on the same grid (``check_same_grid``): no resampling, which
would hide a scene mismatch.

The sampling rule
-----------------
E is a mean square over the samples, so the grid must resolve what the rates hold.  The
square of a rate whose highest frequency is f_max holds frequencies up to 2 f_max, and the
trapezoid rule on a uniform grid of step dt integrates e^{i w t} exactly (to end terms) for
0 < |w| < 2 pi / dt: so E is the integral's own value when 2 f_max < 1 / dt, the grid's
Nyquist frequency 1 / (2 dt) above f_max.  Beyond it a mode's samples alias, and a sum
frequency f_j + f_k near 1 / dt beats at a low frequency that the window does not average
out: E moved by up to 3.9 % (thesis scene, 1e-5 s against 6.25e-7 s, measured).  The rule
(``check_sampling``):

    1 / (2 dt) >= SAMPLING_MARGIN x f_max,

f_max the highest coupled frequency of the truth (every model is compared with it, so its
modes are in every error signal) whose share of a gimbal rate's mean square under the scene's
drive is at least SAMPLING_SHARE (``gimbal_reduction.reduction.frequency_error.sampling_band``).
"""
from __future__ import annotations

import numpy as np

GRID_RTOL = 1e-9

# [1] Nyquist frequency / f_max at least this (chosen: the square's alias nearest zero frequency
# lies at 1/dt - 2 f_max >= 0.2 / dt, on thesis's 2.5e-6 s grid 80 kHz, 1200 periods of its 15 ms;
# one sinusoid's n samples hold its mean square to 1 / (n |sin(2 pi f dt)|) <= 1.7 / n)
SAMPLING_MARGIN = 1.25
# [1] share of a gimbal rate's mean square that makes a coupled mode count for the sampling rule.
# Chosen by measurement (key models, thesis scene): on the 2.5e-6 s grid the rule asks for, E moved
# by < 0.01 % where E > 1e-6 (0.3 % at E ~ 2e-8) against a grid 4 times finer; the 1e-5 s grid it
# refuses moved E by up to 3.7 %. The 1e-10 of the frequency-domain band would ask for ~1 us
# grids (1e6 samples on the 1 s scene).
SAMPLING_SHARE = 1e-6


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


def resolving_interval(f_max_hz, margin=SAMPLING_MARGIN):
    """The longest output interval [s] that meets the sampling rule for a highest frequency
    f_max_hz [Hz] (module docstring): 1 / (2 margin f_max); inf when nothing is excited (NaN, 0)."""
    f = float(f_max_hz)
    return 1.0 / (2.0 * margin * f) if np.isfinite(f) and f > 0 else float("inf")


def sampling_problem(output_interval, f_max_hz, label="scene", margin=SAMPLING_MARGIN):
    """None if an output interval [s] resolves f_max_hz [Hz] by the sampling rule, else the one-line
    reason, naming ``label``, the interval, its Nyquist frequency and the longest one that holds."""
    dt = float(output_interval)
    if not (np.isfinite(dt) and dt > 0):
        return f"{label}: output interval {output_interval!r} s is not a positive number"
    need = resolving_interval(f_max_hz, margin)
    if dt <= need * (1 + 1e-9):
        return None
    return (f"{label}: output interval {dt:.4g} s (Nyquist {0.5 / dt:.4g} Hz) does not resolve the "
            f"truth's coupled mode at {float(f_max_hz):.4g} Hz that the scene excites (E's sampling "
            f"rule: Nyquist >= {margin:g} x f_max, i.e. an interval <= {need:.3g} s)")


def check_sampling(output_interval, f_max_hz, label="scene", margin=SAMPLING_MARGIN):
    """Raise ErrorsInputError (one line) unless the output interval [s] meets the sampling rule for
    f_max_hz [Hz] (``sampling_problem``)."""
    problem = sampling_problem(output_interval, f_max_hz, label, margin)
    if problem:
        raise ErrorsInputError(problem)


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
