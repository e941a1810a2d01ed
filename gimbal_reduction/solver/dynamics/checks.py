"""Verification checks of the dynamics, each a pure function returning check records
(``gimbal_reduction.workflow.provenance.check_record``: {name, value, tolerance, passed}) for
results/verification/dynamics.json.

The tests (tests/test_dynamics*.py) call these on synthetic bodies; a later
workflow stage calls the same functions on the real bodies.
"""

import numpy as np

from gimbal_reduction.solver.dynamics.error_measure import error_measure  # thesis eq. 3.53, one definition
from gimbal_reduction.solver.dynamics import integrators, linearized, multibody
from gimbal_reduction.solver.dynamics.problem import Problem
from gimbal_reduction.workflow.provenance import check_record


def check(name, value, tolerance, passed=None):
    """The check record {name, value, tolerance, passed}; passed = value <= tolerance unless given."""
    return check_record(str(name), value, tolerance, passed)


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


def _rk4_step(chain, y0, fraction):
    """fraction x the RK4 stability limit of the chain linearised at y0 (coupled frequencies)."""
    w = linearized.coupled_omega_max(chain, y0)
    return fraction * integrators.rk4_stability_limit(w) if w > 0 else 1e-3


def _rk4_drift(chain, y0, yd0, quantities, n_steps, fraction, chunks=20):
    """Largest relative change of each ``quantity(y, yd)`` over n_steps RK4 steps at
    ``fraction`` of the stability limit, sampled every n_steps / chunks steps."""
    problem = Problem(chain, omega_max=0.0)       # case at rest, no torques (its step: below)
    h = _rk4_step(chain, y0, fraction)
    start = [q(y0, yd0) for q in quantities]
    worst = [0.0] * len(quantities)
    y, yd = np.array(y0, float), np.array(yd0, float)
    t = 0.0
    for _ in range(chunks):
        y, yd = integrators.rk4_advance(problem, y, yd, t, h, n_steps // chunks)
        t += h * (n_steps // chunks)
        worst = [max(w, abs(q(y, yd) - q0) / abs(q0)) for w, q, q0 in zip(worst, quantities, start)]
    return worst


def _energy(chain):
    return lambda y, yd: multibody.kinetic_energy(chain, y, yd) + multibody.potential_energy(chain, y)


def _axial_momentum(chain):
    return lambda y, yd: multibody.generalized_momentum(chain, y, yd)[0]


def conservation(name, chain, y0, yd0, n_steps=100_000, fraction=0.1, tol=1e-9):
    """Energy and axial angular momentum drift from one RK4 run (case at rest)."""
    dE, dp = _rk4_drift(chain, y0, yd0, [_energy(chain), _axial_momentum(chain)], n_steps, fraction)
    what = f"over {n_steps} RK4 steps at {fraction} x stability limit"
    return [check(f"{name}: energy drift {what}", dE, tol),
            check(f"{name}: axial angular momentum drift {what}", dp, tol)]


def rk4_order(name, problem, t_end, steps=(0.004, 0.002, 0.001), lo=3.9, hi=4.1):
    """Observed order of RK4 from final-state errors against a run at steps[-1] / 8."""
    ref = _final_state(problem, t_end, steps[-1] / 8)
    errs = [np.abs(_final_state(problem, t_end, h) - ref).max() for h in steps]
    orders = [np.log(errs[i] / errs[i + 1]) / np.log(steps[i] / steps[i + 1])
              for i in range(len(steps) - 1)]
    p = orders[-1]
    return check(f"{name}: RK4 observed order (errors {', '.join(f'{e:.2e}' for e in errs)})",
                 p, hi, passed=bool(lo <= p <= hi))


def _final_state(problem, t_end, h):
    n = int(round(t_end / h))
    y, yd = integrators.rk4_advance(problem, problem.y0, problem.yd0, 0.0, t_end / n, n)
    return np.concatenate([y, yd])


def rigid_spin_about_outer_axis(name, chain, amplitude=1.0, frequency=2.0, t_end=0.5, tol=1e-10):
    """Closed form: the case turns about the outer drive axis (case Z, on which the gimbal
    point lies) with omega_Z' = a cos(2 pi f t); bodies 2-5, at rest, feel no force and stay
    at rest in inertial space, so gamma_1' = -omega_Z(t), the other rates and all modal
    coordinates stay zero (any inertia, elastic or rigid).  Max rate error / max rate."""
    case = multibody.CaseMotion(amplitude=(0.0, 0.0, amplitude), frequency=(0.0, 0.0, frequency))
    prob = Problem(chain, case=case)
    run = integrators.integrate(prob, t_end, t_end / 50, method="rk4",
                                step=min(1e-3, 0.5 * integrators.rk4_stability_limit(prob.omega_max)))
    exact = -np.array([case.angular_velocity(t)[2] for t in run.t])
    err = max(np.abs(run.yd[:, 0] - exact).max(), np.abs(run.yd[:, 1:4]).max(),
              np.abs(run.y[:, 4:]).max(initial=0.0))
    return check(f"{name}: case spin about the outer axis, gamma_1' = -omega_Z", err / np.abs(exact).max(), tol)


def rigid_motor_spin_up(name, inertias, torque=2.0, t_end=1.0, tol=1e-10):
    """Closed form: rigid bodies with centre of mass at the gimbal point and principal
    axes along their local axes, all angles zero, case at rest, torque tau on joint 1
    only.  Bodies 2 and 3 turn together about x_2 (body 3's z axis lies along it, a
    principal axis: no gyroscopic torque, nothing about its drive axis); bodies 4 and 5,
    whose drive axis x_4 = z_3 = -x_2 is parallel, feel no torque about it and stay at
    rest.  So gamma_1'' = tau / (J2_xx + J3_zz), gamma_3' = gamma_1', gamma_2' = gamma_4' = 0.
    inertias: 4 tuples (m, Jxx, Jyy, Jzz)."""
    bodies = []
    for number, (m, jx, jy, jz) in zip((2, 3, 4, 5), inertias):
        Mr = np.diag([m, m, m, jx, jy, jz]).astype(float)
        integ = {"rigid_mass": Mr, "momentum": np.zeros((6, 0)),
                 "inertia_gradient": np.zeros((0, 6, 6)), "coriolis": np.zeros((0, 3, 0))}
        bodies.append(multibody.make_body(number, integ, np.zeros(0)))
    chain = multibody.Chain(tuple(bodies))
    prob = Problem(chain, torque=(torque, 0.0, 0.0, 0.0))
    run = integrators.integrate(prob, t_end, t_end / 20, method="rk4", step=1e-3)
    J = inertias[0][1] + inertias[1][3]
    rate = torque * run.t / J
    exact = np.column_stack([rate, 0 * rate, rate, 0 * rate])
    err = np.abs(run.yd[:, :4] - exact).max() / np.abs(rate).max()
    return check(f"{name}: motor spin-up, gamma_1'' = tau/(J2xx + J3zz)", err, tol)


def step_halving_convergence(name, problem, t_end, output_dt, step=None, fraction=None, tol=1e-10):
    """Truth-model convergence: RK4 at h and h/2; the largest error measure E (thesis
    eq. 3.53) over the four gimbal rates must stay below tol.  With step None the
    default step (fraction of the stability limit) is used."""
    a = integrators.integrate(problem, t_end, output_dt, method="rk4", step=step, fraction=fraction)
    b = integrators.integrate(problem, t_end, output_dt, method="rk4", step=a.step / 2)
    E = error_measure(a.t, b.yd[:, :4], a.yd[:, :4])  # reference: the finer step
    return check(f"{name}: RK4 step halving ({a.step:.3e} s -> {b.step:.3e} s), max E over rates",
                 float(np.max(E)), tol)


def exponential_conservation(name, problem, t_end, output_dt, limit=1e-9, **options):
    """Case at rest, no torques: the exponential integrator (options: its own, e.g. tol)
    over [0, t_end]; the check passes when each drift is <= limit.  The largest
    relative drift of the energy T + U and of the axial angular momentum (conjugate to
    gamma_1) over the outputs.  Returns (two check records, the Run)."""
    run = integrators.integrate(problem, t_end, output_dt, method="exponential", **options)
    chain = problem.chain
    E = np.array([problem.energy(t, y, v) for t, y, v in zip(run.t, run.y, run.yd)])
    p = np.array([multibody.generalized_momentum(chain, y, v)[0] for y, v in zip(run.y, run.yd)])
    what = (f"over {t_end:g} s, exponential ({run.steps} steps, "
            f"{run.stats['relinearisations']} re-linearisations)")
    return [check(f"{name}: energy drift {what}", float(np.abs(E - E[0]).max() / abs(E[0])), limit),
            check(f"{name}: axial angular momentum drift {what}",
                  float(np.abs(p - p[0]).max() / abs(p[0])), limit)], run

