"""Verification checks of the dynamics, each a pure function returning
``(name, value, tolerance, passed)`` for results/verification/dynamics.json.

The tests (tests/test_dynamics*.py) call these on synthetic bodies; a later
workflow stage calls the same functions on the real bodies.
"""

import numpy as np

from solver import integrators, multibody


def check(name, value, tolerance, passed=None):
    """(name, value, tolerance, passed) with passed = value <= tolerance unless given."""
    value = float(value)
    tolerance = float(tolerance)
    if passed is None:
        passed = bool(np.isfinite(value) and value <= tolerance)
    return (str(name), value, tolerance, bool(passed))


def relative_difference(a, b):
    """max |a - b| / max |b| (0 if both vanish)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = np.abs(b).max(initial=0.0)
    diff = np.abs(a - b).max(initial=0.0)
    return diff / scale if scale > 0 else diff


def oracle_agreement(name, fast_M, fast_f, oracle_M, oracle_f, tol=1e-10):
    """Two checks: the fast M(y) and f(y, y', t) against an independent oracle's."""
    return [check(f"{name}: mass matrix vs oracle", relative_difference(fast_M, oracle_M), tol),
            check(f"{name}: generalised force vs oracle", relative_difference(fast_f, oracle_f), tol)]


def solve_consistency(name, chain, y, r, tol=1e-11):
    """The articulated-body solve against a dense solve of the assembled M(y)."""
    x = multibody.solve_mass(chain, y, r)
    M = multibody.mass_matrix(chain, y)
    return check(f"{name}: articulated-body solve vs dense solve",
                 relative_difference(x, np.linalg.solve(M, r)), tol)


def energy_conservation(name, chain, y0, yd0, n_steps=100_000, fraction=0.1, tol=1e-9):
    """Scene with the case at rest and no torques: RK4 at ``fraction`` of its stability
    limit for n_steps; max |E(t) - E(0)| / E(0) with E = T + U."""
    rhs = integrators.make_rhs(chain)
    h = fraction * integrators.rk4_stability_limit(chain.omega_max) if chain.omega_max else 1e-3
    E0 = multibody.kinetic_energy(chain, y0, yd0) + multibody.potential_energy(chain, y0)
    worst = 0.0
    chunks = 20
    y, yd = np.array(y0, float), np.array(yd0, float)
    t = 0.0
    for _ in range(chunks):
        y, yd = integrators.rk4_steps(rhs, y, yd, t, h, n_steps // chunks)
        t += h * (n_steps // chunks)
        E = multibody.kinetic_energy(chain, y, yd) + multibody.potential_energy(chain, y)
        worst = max(worst, abs(E - E0) / abs(E0))
    return check(f"{name}: energy drift over {n_steps} RK4 steps (h = {fraction} x limit)", worst, tol)
