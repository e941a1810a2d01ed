"""Stability experiments on the gimbal chain: the measured RK4 limit and the energy drift.

* **Coupled modes.**  The chain linearised at a configuration has natural modes in
  all coordinates (the free joint angles eliminated by a Schur complement,
  ``gimbal_reduction.solver.dynamics.linearized.coupled_modes``); their top frequency omega_top, not the largest kept modal
  frequency, limits RK4.
* **Measured limit.**  Every coupled mode gets the same small kinetic energy
  (``excited_state``); a step is stable when E = T + U grows by less than a factor
  in n steps (``energy_growth``), and ``measure_chain_rk4_limit`` bisects on the
  step (``rk4_theory.bisect_stability_limit``) and compares with 2.785/omega_max
  and 2 sqrt 2/omega_top.
* **Energy drift** |E(t) - E(0) - W(t)| / |E(0)| of one integrator over a scene
  (``drift_run``).
* **Gimbal-lock geometry**: the drive axes, their distance from one plane, and the
  conditioning of M(y) there.

Units: inch, lbf, second, rad; energies in in lbf; frequencies in rad/s.
"""
from __future__ import annotations

import sys
import time

import numpy as np

from gimbal_reduction.reduction import models
from gimbal_reduction.results.bench.rk4_theory import StabilityInputError, bisect_stability_limit
from gimbal_reduction.solver.dynamics import integrators, linearized, multibody, simulate
from gimbal_reduction.solver.dynamics.problem import Problem

THESIS_ANGLES = (0.0, -np.pi / 2, 0.0, 0.0)
# The 10 s drift model: the first mode of the outer and of the middle gimbal only.  The cost
# of every integrator grows with omega_max x duration: the first modes of the inner gimbal
# and of the platform couple at 4.5e4 and 4.1e5 rad/s, which would take 10 s of RK4 to
# 3e5 .. 3e6 steps (25 .. 250 s at the ~85 us per step measured for freq-2); this model's
# omega_max is 1.2e4 rad/s (9e4 RK4 steps, ~10 s).
DRIFT_MODEL = "freq-1,1,0,0"


def log(message):
    """Progress on stderr (flushed, so a piped log shows where the run is)."""
    print(f"stability: {message}", file=sys.stderr, flush=True)


def build(name, rankings, data, damping_ratio=0.0):
    """Chain of a model name (``models.model_spec`` + ``models.build_chain``)."""
    return models.build_chain(models.model_spec(name, rankings), data, damping_ratio)


# ============================================================== coupled modes of the chain
def equal_energy_velocity(shapes, energy, signs=None):
    """Initial velocity (n,) that gives every coupled mode the kinetic energy energy/m [in lbf].

    shapes (n, m): M-orthonormal modes (``linearized.coupled_modes``); energy [in lbf] total.
    y' = sum_k s_k phi_k with |s_k| = sqrt(2 energy / m): the modes are M-orthogonal,
    so T = sum s_k^2 / 2 = energy.  signs (m,) of +-1 (default all +1).
    """
    shapes = np.asarray(shapes, dtype=float)
    m = shapes.shape[1]
    if not (np.isfinite(energy) and energy > 0) or m == 0:
        raise StabilityInputError(f"equal_energy_velocity needs energy > 0 and modes, got "
                                  f"{energy}, {m} modes")
    s = np.full(m, np.sqrt(2.0 * energy / m))
    if signs is not None:
        s = s * np.sign(np.asarray(signs, dtype=float))
    return shapes @ s


def excited_state(chain, angles=THESIS_ANGLES, energy=1e-6):
    """(y0, y'0, omega (m,), M): the chain at gimbal ``angles`` [rad], undeformed, with
    every coupled mode given energy / m of kinetic energy [in lbf] (``equal_energy_velocity``).
    The joint rates of this state carry no momentum, so the gimbals do not drift away:
    the linearisation at y0 holds for the whole run (small energy: linear regime)."""
    n = chain.n_coordinates
    if n == 4:
        raise StabilityInputError("a rigid chain has no elastic modes to excite")
    y0 = np.zeros(n)
    y0[:4] = angles
    M = linearized.mass_matrix_fast(chain, y0)
    omega, shapes = linearized.free_joint_modes(M, chain.stiffness_diagonal()[4:])
    return y0, equal_energy_velocity(shapes, energy), omega, M


# ============================================================== energy growth of a chain run
def energy_growth(problem, y0, yd0, h, n_steps, growth=10.0, chunks=20):
    """Largest E(t) / E(0) of an RK4 run [1], E = T + U (``problem.energy``, case at rest).

    problem: ``problem.Problem``; y0, yd0 (n,); h [s]; n_steps RK4 steps, checked every
    n_steps / chunks steps (compiled loop ``integrators.rk4_advance``).  Stops as soon as
    the ratio exceeds ``growth`` (returns it); inf for a non-finite state.
    """
    E0 = problem.energy(0.0, y0, yd0)
    if not (np.isfinite(E0) and E0 > 0):
        raise StabilityInputError(f"energy_growth needs a positive initial energy, got {E0}")
    y, yd = np.array(y0, float), np.array(yd0, float)
    per = max(int(n_steps) // int(chunks), 1)
    worst, t, done = 1.0, 0.0, 0
    with np.errstate(over="ignore", invalid="ignore"):
        while done < n_steps:
            k = min(per, n_steps - done)
            y, yd = integrators.rk4_advance(problem, y, yd, t, h, k)
            t += k * h
            done += k
            if not (np.all(np.isfinite(y)) and np.all(np.isfinite(yd))):
                return np.inf
            ratio = problem.energy(t, y, yd) / E0
            if not np.isfinite(ratio):
                return np.inf
            worst = max(worst, ratio)
            if worst > growth:
                break
    return float(worst)


def measure_chain_rk4_limit(chain, angles=THESIS_ANGLES, energy=1e-6, n_steps=4000, growth=10.0,
                            rtol=2e-4, bracket=(0.8, 1.3)):
    """Measured RK4 stability limit of a chain against the theory (one dict).

    The chain sits at gimbal ``angles`` [rad], undeformed, case at rest, with every
    coupled mode excited equally (``excited_state``); a step h is stable when the energy
    grows by less than ``growth`` in n_steps steps (the top mode's energy share is 1/m
    and grows by 1 + 14.2 delta per step at h = h*(1 + delta): 4000 steps resolve
    delta ~ 1e-4).  bracket: the bisection's start, in units of 2 sqrt 2 / omega_top.

    Keys: omega_top (coupled top frequency at the configuration [rad/s]); omega_max
    (``Problem.omega_max``: the maximum over it and three more sampled configurations,
    what ``integrators.integrate`` uses); modal_omega_max (largest kept modal frequency);
    h_measured, h_lo, h_hi [s]; h_bound = 2.785 / omega_max [s] (the project's limit);
    h_imaginary = 2 sqrt 2 / omega_top [s]; ratio_bound = h_measured / h_bound (the
    check); ratio_imaginary = h_measured / h_imaginary; trials; wall_s.
    """
    start = time.perf_counter()
    y0, yd0, omega, _ = excited_state(chain, angles, energy)
    problem = Problem(chain, y0=y0, yd0=yd0)
    omega_top = float(omega[-1])
    h_imag = 2.0 * np.sqrt(2.0) / omega_top
    res = bisect_stability_limit(
        lambda h: energy_growth(problem, y0, yd0, h, n_steps, growth) <= growth,
        bracket[0] * h_imag, bracket[1] * h_imag, rtol=rtol)
    h_bound = integrators.rk4_stability_limit(problem.omega_max)
    return {"omega_top": omega_top, "omega_max": float(problem.omega_max),
            "modal_omega_max": float(chain.omega_max), "n_modes": list(chain.n_modes),
            "h_measured": res["step"], "h_lo": res["lo"], "h_hi": res["hi"],
            "h_bound": h_bound, "h_imaginary": h_imag,
            "ratio_bound": res["step"] / h_bound, "ratio_imaginary": res["step"] / h_imag,
            "h_omega_top": res["step"] * omega_top, "trials": [[float(h), bool(s)] for h, s in res["trials"]],
            "n_steps": int(n_steps), "growth": float(growth), "energy": float(energy),
            "wall_s": time.perf_counter() - start}


def omega_top_over_angles(chain, n_grid=12, gamma4=(0.0, 0.75)):
    """Coupled top frequency [rad/s] over a grid of gimbal angles: (max, argmax angles (4,)).

    gamma_2, gamma_3 on n_grid points in [-pi, pi), gamma_4 in ``gamma4``; gamma_1 does
    not enter M(y) (the case is at rest).  ``Problem.omega_max`` samples four
    configurations only; this shows how much the maximum over all of them can exceed it.
    """
    g = np.linspace(-np.pi, np.pi, int(n_grid), endpoint=False)
    best, where = 0.0, None
    y = np.zeros(chain.n_coordinates)
    for a in g:
        for b in g:
            for c in gamma4:
                y[1:4] = a, b, c
                w = float(linearized.coupled_frequencies(chain, y)[-1])
                if w > best:
                    best, where = w, y[:4].copy()
    return best, where


# ============================================================== energy drift
def relative_energy_drift(kinetic, potential, input_work=None):
    """|E(t) - E(0) - W(t)| / |E(0)| (T,) [1], E = T + U [in lbf], W the work fed in [in lbf]
    (None: a conservative scene, W = 0).  kinetic, potential, input_work (T,)."""
    E = np.asarray(kinetic, float) + np.asarray(potential, float)
    W = np.zeros_like(E) if input_work is None else np.asarray(input_work, float)
    if E.shape != W.shape or E.ndim != 1 or E.size == 0:
        raise StabilityInputError(f"energy histories of shapes {E.shape}, {W.shape} do not match")
    if not E[0] != 0:
        raise StabilityInputError("relative energy drift needs E(0) != 0")
    return np.abs(E - E[0] - W) / abs(E[0])


def drift_run(chain, scene, method, model_name="", **options):
    """One run of ``scene`` (case at rest) with one integrator: its energy drift.

    options: step, fraction, rho_inf, rtol, atol of ``simulate.run_scene``.
    Returns a dict: t (T,) [s], drift (T,) [1], drift_max, drift_final, steps, step [s]
    (dop853: mean step), wall_s, method, options.
    """
    run, prob = simulate.run_scene(chain, scene, method, model_name=model_name, **options)
    T, U, W = simulate.energy_history(prob, run)
    d = relative_energy_drift(T, U, W)
    step = scene.duration / max(run.steps, 1) if method == "dop853" else run.step
    return {"t": run.t, "drift": d, "drift_max": float(d.max()), "drift_final": float(d[-1]),
            "steps": int(run.steps), "step": float(step), "wall_s": float(run.wall_time),
            "method": method, "options": {k: v for k, v in options.items() if v is not None}}


# ============================================================== gimbal lock geometry
def drive_axes(angles):
    """Drive axes (4, 3) of joints 1..4 in case axes, for the undeformed chain.

    angles (4,) [rad].  Joint poses from docs/dynamics.md: A_2 = C_1 R_x(g_1),
    A_{n+1} = A_n C R_x(g_{n+1}); joint j turns body j+1 about its own x, so its axis
    is the first column of A_{j+1}.  x_4 is parallel to x_2 when g_2 = 0 (mod pi) and
    x_5 to x_3 when g_3 = 0 (mod pi).
    """
    g = np.asarray(angles, dtype=float)
    if g.shape != (4,):
        raise StabilityInputError(f"drive_axes needs 4 gimbal angles, got shape {g.shape}")
    A = multibody.CASE_TO_OUTER @ multibody.rot_x(g[0])
    axes = [A[:, 0]]
    for k in range(1, 4):
        A = A @ multibody.PARENT_TO_CHILD @ multibody.rot_x(g[k])
        axes.append(A[:, 0])
    return np.array(axes)


def lock_distance(axes):
    """Smallest singular value of the (4, 3) matrix of unit drive axes [1].

    0 exactly when the four axes lie in one plane (gimbal lock of the four-gimbal
    platform: no joint rate turns the platform about the plane's normal); about the
    angle [rad] by which the closest configuration misses it, near lock.
    """
    return float(np.linalg.svd(np.asarray(axes, float), compute_uv=False)[-1])


def axis_alignment(axes):
    """Smallest angle [rad] between two drive axes (lines, so 0 for parallel or antiparallel)."""
    a = np.asarray(axes, float)
    best = np.pi / 2
    for i in range(len(a)):
        for j in range(i + 1, len(a)):
            c = abs(float(a[i] @ a[j])) / (np.linalg.norm(a[i]) * np.linalg.norm(a[j]))
            best = min(best, float(np.arccos(min(c, 1.0))))
    return best


def mass_conditioning(M):
    """Condition numbers (2-norm) of the chain's mass matrix M (n, n) at one configuration:
    dict cond_M (all of it), cond_joints (M_gg, 4 x 4, the gimbals' articulated inertia
    with the modes held), cond_schur (S = M_qq - M_qg M_gg^-1 M_gq, the modal inertia with
    the joints free; its smallest eigenvalue is the share of a mode's unit mass left once
    its rigid turn is shed), min_eig_schur."""
    M = np.asarray(M, float)
    out = {"cond_M": float(np.linalg.cond(M)), "cond_joints": float(np.linalg.cond(M[:4, :4]))}
    if M.shape[0] > 4:
        S = M[4:, 4:] - M[4:, :4] @ np.linalg.solve(M[:4, :4], M[:4, 4:])
        ev = np.linalg.eigvalsh(0.5 * (S + S.T))
        out.update(cond_schur=float(ev[-1] / ev[0]), min_eig_schur=float(ev[0]))
    return out
