"""RK4's stability theory and the bisection that measures a stability limit.

One RK4 step multiplies the component of y' = lambda y along an eigenvector by the
amplification factor R(h lambda) = 1 + z + z^2/2 + z^3/6 + z^4/24; the step is
stable for that mode while |R| <= 1.  Two bounds follow:

* an undamped mode (lambda = +-i omega): h omega <= 2 sqrt 2 = 2.8284
  (|R(ix)|^2 = 1 - x^6/72 + x^8/576), the imaginary-axis bound;
* a decaying mode (lambda < 0): h |lambda| <= 2.7853, the real root of
  x^3 - 4x^2 + 12x - 24, which the thesis quotes as 2.785 and the project uses
  as its bound 2.785 / omega_max (``integrators.RK4_STABILITY``).

``bisect_stability_limit`` finds the largest stable step of any stability test;
on the scalar oscillator x'' = -omega^2 x (``oscillator_rk4_limit``) it must
reproduce 2 sqrt 2 / omega, which checks the bisection and the growth test
before they are used on the chain (``gimbal_reduction.results.bench.chain_stability``).

Units: s, rad/s; the bounds are dimensionless (h omega).
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from gimbal_reduction.solver.dynamics import integrators

RK4_BOUND = integrators.RK4_STABILITY      # 2.785: the project's bound h omega_max (real axis)


class StabilityInputError(ValueError):
    """Bad input to a stability function (one-line message)."""


# ============================================================== RK4 theory
def rk4_amplification(z):
    """RK4's amplification factor R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24.

    z: complex array (any shape), z = h lambda (dimensionless).  One RK4 step
    multiplies the component of y' = lambda y along an eigenvector by R(h lambda):
    the step is stable for that mode while |R| <= 1.  Returns complex, shape of z.
    """
    z = np.asarray(z, dtype=complex)
    return 1.0 + z * (1.0 + z / 2.0 * (1.0 + z / 3.0 * (1.0 + z / 4.0)))   # Horner form


def rk4_imaginary_axis_limit():
    """Largest x with |R(i x)| <= 1: RK4's bound h omega for an undamped mode (lambda = +-i omega).

    |R(ix)|^2 = (1 - x^2/2 + x^4/24)^2 + (x - x^3/6)^2 = 1 - x^6/72 + x^8/576, which
    is <= 1 exactly for x^2 <= 8: x = 2 sqrt 2 = 2.8284.  Found here by root finding
    on R itself (so a wrong R would show), returned as a float.
    """
    return float(brentq(lambda x: abs(rk4_amplification(1j * x)) - 1.0, 2.5, 3.0, xtol=1e-15))


def rk4_real_axis_limit():
    """Largest x with |R(-x)| <= 1: RK4's bound h|lambda| for a decaying mode (lambda < 0).

    R(-x) - 1 = x(-1 + x/2 - x^2/6 + x^3/24) vanishes at the real root of
    x^3 - 4x^2 + 12x - 24 = 0, x = 2.7853 (the 2.785 the thesis quotes); beyond it
    R(-x) > 1.  Float.
    """
    return float(brentq(lambda x: rk4_amplification(-x).real - 1.0, 2.5, 3.0, xtol=1e-15))


# ============================================================== bisection
def bisect_stability_limit(is_stable, h_stable, h_unstable, rtol=1e-3, max_iter=60):
    """The largest stable step [s] between a stable and an unstable one, by bisection.

    is_stable: callable h [s] -> bool; h_stable < h_unstable [s] must bracket the
    limit (checked first: a bad bracket raises StabilityInputError naming it).
    Halves the bracket until (hi - lo) <= rtol lo.  Returns a dict: ``step`` the
    bracket's midpoint [s], ``lo`` (largest stable step tried), ``hi`` (smallest
    unstable one), ``trials`` list of (h, stable).
    """
    lo, hi = float(h_stable), float(h_unstable)
    if not (np.isfinite(lo) and np.isfinite(hi) and 0.0 < lo < hi):
        raise StabilityInputError(f"bisection needs 0 < h_stable < h_unstable, got {lo!r}, {hi!r}")
    if not 0.0 < rtol < 1.0:
        raise StabilityInputError(f"bisection rtol must lie in (0, 1), got {rtol!r}")
    trials = []

    def judge(h):
        ok = bool(is_stable(h))
        trials.append((h, ok))
        return ok

    if not judge(lo):
        raise StabilityInputError(f"bisection bracket: h = {lo:.4e} s is already unstable")
    if judge(hi):
        raise StabilityInputError(f"bisection bracket: h = {hi:.4e} s is still stable")
    for _ in range(max_iter):
        if hi - lo <= rtol * lo:
            break
        mid = 0.5 * (lo + hi)
        if judge(mid):
            lo = mid
        else:
            hi = mid
    return {"step": 0.5 * (lo + hi), "lo": lo, "hi": hi, "trials": trials}


# ============================================================== scalar oscillator
def oscillator_energy_ratio(omega, h, n_steps):
    """E(n h) / E(0) of RK4 (``integrators.rk4_step``) on x'' = -omega^2 x.

    omega [rad/s], h [s], n_steps int; from x = 0, x' = 1; E = x'^2/2 + omega^2 x^2/2.
    In the scaled state (omega x, x') one step is a normal matrix with eigenvalues
    R(+-i h omega), so the ratio is |R(i h omega)|^(2n) exactly, for any start.
    Returns a float (inf once the state overflows).
    """
    if not (omega > 0 and h > 0 and int(n_steps) >= 1):
        raise StabilityInputError(f"oscillator needs omega > 0, h > 0, n_steps >= 1, got "
                                  f"{omega}, {h}, {n_steps}")
    w2 = float(omega) ** 2

    def rhs(t, x, v):
        return -w2 * x

    with np.errstate(over="ignore", invalid="ignore"):
        x, v = integrators.rk4_steps(rhs, np.zeros(1), np.ones(1), 0.0, float(h), int(n_steps))
        ratio = float(v[0] ** 2 + w2 * x[0] ** 2)
    return ratio if np.isfinite(ratio) else np.inf


def oscillator_rk4_limit(omega, n_steps=2000, growth=10.0, rtol=1e-6):
    """Measured RK4 limit [s] of x'' = -omega^2 x (omega [rad/s]) by ``bisect_stability_limit``:
    a step is unstable when the energy grows by ``growth`` in n_steps.  Should equal
    2 sqrt 2 / omega up to ln(growth) / (2 n_steps x 7.1) (the slope of |R(ix)|^2 at the
    root is x^5/36 = 5.03, times x = 2.83: growth per step 1 + 14.2 delta at h = h*(1 + delta)).
    Returns the bisection dict."""
    h0 = 2.0 * np.sqrt(2.0) / omega
    return bisect_stability_limit(lambda h: oscillator_energy_ratio(omega, h, n_steps) <= growth,
                                  0.8 * h0, 1.25 * h0, rtol=rtol)
