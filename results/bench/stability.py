"""Numerical stability stress tests of the gimbal-chain integrators (issue 6, "Fast and stable").

    MPLBACKEND=Agg .venv/bin/python -m results.bench.stability --modes-dir results/modes \\
        --reduction-dir results/reduction --out-dir results/stability \\
        --figures-dir results/figures/stability [--quick]

Three parts (method and measured numbers: docs/stability.md):

a. **RK4 step sweep.**  For several reduced models the actual stability limit h*
   of RK4 is found by bisection on the step: every coupled mode of the chain
   (linearised at the thesis configuration) gets the same small kinetic energy,
   RK4 runs ``n_steps`` steps, and a step is unstable when the energy grows by
   ``growth``.  h* is compared with the project's bound 2.785/omega_max
   (``integrators.RK4_STABILITY``, the negative-real-axis bound) and with the
   exact bound for undamped modes, 2 sqrt 2 / omega (the imaginary-axis bound).
b. **Energy drift** |E(t) - E(0)| / |E(0)| of every integrator over the 10 s
   scene ``free_10s`` (case at rest: E = T + U is conserved).
c. **Hard cases**: large gimbal rates, the case driven at the first coupled
   elastic resonance, gimbal lock, several static modes on one body, and steps
   beyond the limit.  Each must either run and agree with a tighter run
   (thesis eq. 3.53 error measure E of the four gimbal rates) or stop with a
   one-line diagnosis; a run that finishes but disagrees is ``garbage``.

Outputs (atomic: temporary name, then rename): ``{out}/stability.json`` (every
number, a boolean ``pass`` per check, provenance), ``{out}/rk4_limit.csv``,
``{out}/energy_drift.csv``, ``{out}/hard_cases.csv``, ``{out}/gimbal_lock.csv``, and the figures
``{figures}/rk4_limit.png``, ``{figures}/energy_drift.png``.

Units: inch, lbf, second, rad; energies in in lbf; frequencies in rad/s.
"""
from __future__ import annotations

import argparse
import csv
import io
import os
import sys
import time

import numpy as np

from solver.dynamics.error_measure import error_measure
from solver.dynamics import integrators, multibody, scenes, simulate
from reduction import models

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

RK4_BOUND = integrators.RK4_STABILITY      # 2.785: the project's bound h omega_max (real axis)
LIMIT_TOLERANCE = 0.05                     # |h* / (2.785 / omega_max) - 1| must stay below this
DRIFT_TOLERANCE = 1e-6                     # relative energy drift over the 10 s free run
HARD_CASE_TOLERANCE = 1e-6                 # E (eq. 3.53) of a run against its tighter run
THESIS_ANGLES = (0.0, -np.pi / 2, 0.0, 0.0)

# Models of the step sweep: vibration modes only (two rankings), one static mode per
# body, one static mode on one body, and three static modes on one body (their Rayleigh
# frequencies lie far above the kept modes: they set omega_max).
SWEEP_MODELS = ("freq-5", "xmx-10", "static-8", "static-10@2:output_motor_fz",
                "freq-6@2:output_motor_fz+output_motor_my+output_motor_mz")
QUICK_SWEEP_MODELS = ("freq-5", "freq-6@2:output_motor_fz+output_motor_my+output_motor_mz")
# The 10 s drift model: the first mode of the outer and of the middle gimbal only.  The cost
# of every integrator grows with omega_max x duration: the first modes of the inner gimbal
# and of the platform couple at 4.5e4 and 4.1e5 rad/s, which would take 10 s of RK4 to
# 3e5 .. 3e6 steps (25 .. 250 s at the ~85 us per step measured for freq-2); this model's
# omega_max is 1.2e4 rad/s (9e4 RK4 steps, ~10 s).
DRIFT_MODEL = "freq-1,1,0,0"
# Integrator settings of the drift runs: the defaults (rk4 at RK4_DEFAULT_FRACTION of its
# limit, dop853 at rtol 1e-10 / atol 1e-14), except generalized-alpha, whose default step is
# the output interval (10 ms here): it gets 1 ms (h omega_max = 12: every elastic mode is
# filtered, the gimbal motion resolved), rho_inf 0.9.
DRIFT_OPTIONS = {"rk4": {}, "dop853": {}, "generalized-alpha": {"step": 1e-3}}
HARD_MODEL = "freq-5"
# The twelve load cases of the output bearings: the most static modes one body can carry
# (input-bearing loads partly act on the supports).
OUTPUT_LOADS = tuple(f"output_{b}_{c}" for b in ("motor", "resolver")
                     for c in ("fx", "fy", "fz", "mx", "my", "mz"))
ALL_LOADS = tuple(f"{b}_{c}" for b in models.BEARINGS for c in ("fx", "fy", "fz", "mx", "my", "mz"))


class StabilityInputError(ValueError):
    """Bad input to a stability function (one-line message)."""


def log(message):
    """Progress on stderr (flushed, so a piped log shows where the run is)."""
    print(f"stability: {message}", file=sys.stderr, flush=True)


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
    from scipy.optimize import brentq
    return float(brentq(lambda x: abs(rk4_amplification(1j * x)) - 1.0, 2.5, 3.0, xtol=1e-15))


def rk4_real_axis_limit():
    """Largest x with |R(-x)| <= 1: RK4's bound h|lambda| for a decaying mode (lambda < 0).

    R(-x) - 1 = x(-1 + x/2 - x^2/6 + x^3/24) vanishes at the real root of
    x^3 - 4x^2 + 12x - 24 = 0, x = 2.7853 (the 2.785 the thesis quotes); beyond it
    R(-x) > 1.  Float.
    """
    from scipy.optimize import brentq
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
                                  f"{omega!r}, {h!r}, {n_steps!r}")
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


# ============================================================== coupled modes of the chain
def coupled_modes(M, stiffness):
    """Natural modes of the chain linearised at one configuration, in all coordinates.

    M (n, n): the mass matrix M(y) (``multibody.mass_matrix_fast``); stiffness
    (n - 4,) modal stiffness Omega^2 [(rad/s)^2] (the four joint angles have none).
    The joints are free, so they are eliminated: S = M_qq - M_qg M_gg^-1 M_gq and
    Omega^2 x = lambda S x (``multibody.coupled_frequencies``).  Each mode moves the
    joints by g = -M_gg^-1 M_gq x, which makes its joint momenta M_gg g + M_gq x
    vanish, so phi = [g; x] satisfies K phi = lambda M phi and phi_i^T M phi_j =
    x_i^T S x_j = delta_ij: M-orthonormal in the full coordinates.

    Returns (omega (m,) [rad/s] ascending, shapes (n, m)), m = n - 4.
    """
    import scipy.linalg
    M = np.asarray(M, dtype=float)
    k = np.asarray(stiffness, dtype=float)
    n = M.shape[0]
    if M.shape != (n, n) or k.shape != (n - 4,) or n < 5:
        raise StabilityInputError(f"coupled_modes: M {M.shape} and stiffness {k.shape} do not match "
                                  f"(need (n, n) and (n - 4,), n > 4)")
    Mgg, Mgq, Mqq = M[:4, :4], M[:4, 4:], M[4:, 4:]
    joint_of_mode = -np.linalg.solve(Mgg, Mgq)           # (4, m): g = joint_of_mode @ x
    S = Mqq + Mgq.T @ joint_of_mode                       # Schur complement
    lam, X = scipy.linalg.eigh(np.diag(k), 0.5 * (S + S.T))   # X^T S X = I
    return np.sqrt(np.maximum(lam, 0.0)), np.vstack([joint_of_mode @ X, X])


def equal_energy_velocity(shapes, energy, signs=None):
    """Initial velocity (n,) that gives every coupled mode the kinetic energy energy/m [in lbf].

    shapes (n, m): M-orthonormal modes (``coupled_modes``); energy [in lbf] total.
    y' = sum_k s_k phi_k with |s_k| = sqrt(2 energy / m): the modes are M-orthogonal,
    so T = sum s_k^2 / 2 = energy.  signs (m,) of +-1 (default all +1).
    """
    shapes = np.asarray(shapes, dtype=float)
    m = shapes.shape[1]
    if not (np.isfinite(energy) and energy > 0) or m == 0:
        raise StabilityInputError(f"equal_energy_velocity needs energy > 0 and modes, got "
                                  f"{energy!r}, {m} modes")
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
    M = multibody.mass_matrix_fast(chain, y0)
    omega, shapes = coupled_modes(M, chain.stiffness_diagonal()[4:])
    return y0, equal_energy_velocity(shapes, energy), omega, M


# ============================================================== energy growth of a chain run
def energy_growth(problem, y0, yd0, h, n_steps, growth=10.0, chunks=20):
    """Largest E(t) / E(0) of an RK4 run [1], E = T + U (``problem.energy``, case at rest).

    problem: ``multibody.Problem``; y0, yd0 (n,); h [s]; n_steps RK4 steps, checked every
    n_steps / chunks steps (compiled loop ``integrators.rk4_steps``).  Stops as soon as
    the ratio exceeds ``growth`` (returns it); inf for a non-finite state.
    """
    E0 = problem.energy(0.0, y0, yd0)
    if not (np.isfinite(E0) and E0 > 0):
        raise StabilityInputError(f"energy_growth needs a positive initial energy, got {E0!r}")
    y, yd = np.array(y0, float), np.array(yd0, float)
    per = max(int(n_steps) // int(chunks), 1)
    worst, t, done = 1.0, 0.0, 0
    with np.errstate(over="ignore", invalid="ignore"):
        while done < n_steps:
            k = min(per, n_steps - done)
            y, yd = integrators.rk4_steps(problem.rhs, y, yd, t, h, k)
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
    problem = multibody.Problem(chain, y0=y0, yd0=yd0)
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
                w = float(multibody.coupled_frequencies(chain, y)[-1])
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


# ============================================================== static-mode conditioning
def static_mode_conditioning(body, kept, load_cases):
    """Conditioning of several static correction modes on one body (a dict).

    body: a body-file dict (``models.load_body_file``); kept (k,) kept mode indices;
    load_cases: names.  gram_condition: condition number of the mass Gram matrix of the
    unit-mass residual attachment modes before they are made M-orthogonal (the modal
    mass the thesis's eq. 3.52 would carry; large = nearly dependent loads);
    frequencies_hz (p,) their Rayleigh frequencies; mass_coupling, stiffness_coupling
    (largest normalised coupling to the kept modes).  Raises the reduction's one-line
    StaticModeError for loads that act only on the supports.
    """
    from reduction.modal_integrals import supported_flexibility
    from reduction.static_modes import load_case_vector, static_correction_modes
    kept = np.asarray(kept, dtype=int)
    Phi = np.asarray(body["modes"])[:, kept]
    lam = np.asarray(body["eigenvalues"])[kept]
    F = np.column_stack([load_case_vector(body["bearing_operator"], c, body["bearing_points"])
                         for c in load_cases])
    res = static_correction_modes(body["M"], body["K"],
                                  supported_flexibility(body["K"], body["T"], body["rigid_modes"]),
                                  F, Phi, lam, names=list(load_cases))
    return {"gram_condition": float(res["gram_condition"]),
            "frequencies_hz": [float(f) for f in res["frequencies_hz"]],
            "mass_coupling": float(res["mass_coupling"]),
            "stiffness_coupling": float(res["stiffness_coupling"])}


# ============================================================== hard cases
def scene_variant(scene, name, **changes):
    """A copy of ``scene`` (scenes.Scene) with top-level or case_motion numbers replaced.

    changes: key=value with key a scene key (duration, initial_rates, ...) or
    ``case_<key>`` for a case_motion key; values in the scene file's units.  The result
    is validated by ``scenes.parse_scene`` like a file (one-line SceneError).
    """
    raw = {k: (dict(v) if isinstance(v, dict) else v) for k, v in scene.raw.items()}
    raw["case_motion"] = {k: dict(v) for k, v in scene.raw["case_motion"].items()}
    raw["name"] = name
    raw.pop("needs", None)          # what the base scene's results need is not the variant's
    for key, value in changes.items():
        value = np.asarray(value, float).tolist()
        if key.startswith("case_"):
            raw["case_motion"][key[5:]] = dict(raw["case_motion"][key[5:]], value=value,
                                               source="results.bench.stability (hard case)")
        else:
            raw[key] = dict(raw[key], value=value, source="results.bench.stability (hard case)")
    return scenes.parse_scene(raw, origin=name)


def rate_error(reference, candidate, t):
    """Eq. 3.53 E (4,) of the four gimbal rates of ``candidate`` against ``reference``.

    reference, candidate (T, 4) [rad/s]; t (T,) [s].  A rate identically zero in both
    counts as E = 0 (error_measure gives NaN for a zero reference)."""
    E = np.asarray(error_measure(t, reference, candidate), float)
    both_zero = np.all(reference == 0, axis=0) & np.all(candidate == 0, axis=0)
    return np.where(np.isnan(E) & both_zero, 0.0, np.where(np.isnan(E), np.inf, E))


def is_one_line_diagnosis(message, *must_name):
    """A diagnosis is usable when it is one non-empty line naming what it must
    (e.g. the model and the step): bool."""
    text = str(message)
    return bool(text) and "\n" not in text.strip() and all(str(m) in text for m in must_name)


def checked_run(chain, scene, model_name, method="rk4", tol=HARD_CASE_TOLERANCE, problem=None,
                observe=None, **options):
    """Run ``scene`` and judge the result against a tighter run (one dict).

    The tighter run halves the step (rk4, generalized-alpha) or divides rtol by 100
    (dop853).  outcome: ``verified`` (finite, E <= tol for every gimbal rate),
    ``diagnosed`` (the run stopped with a DivergenceError / StepTooLargeError /
    ValueError: message, and ``one_line`` whether it is one line naming the model),
    or ``garbage`` (finished, but disagrees with the tighter run or is not finite).
    Also: E (4,), energy_balance max |E(t) - E(0) - W(t)| / max(|E|, |W|) (W by the
    trapezoid rule at the output samples, so only as good as their spacing), steps,
    step [s], wall_s, omega_max.  observe: optional callable (run, problem) -> dict of
    extra numbers about the (finished) run, merged into the result.
    """
    out = {"model": model_name, "scene": scene.name, "method": method,
           "options": {k: v for k, v in options.items() if v is not None}}
    start = time.perf_counter()
    try:
        prob = simulate.scene_problem(chain, scene) if problem is None else problem
        out["omega_max"] = float(prob.omega_max)
        run, _ = simulate.run_scene(chain, scene, method, model_name=model_name, problem=prob,
                                    **options)
    except (integrators.DivergenceError, integrators.StepTooLargeError, ValueError) as exc:
        msg = str(exc)
        out.update(outcome="diagnosed", error=type(exc).__name__, message=msg,
                   one_line=is_one_line_diagnosis(msg, repr(model_name)),
                   wall_s=time.perf_counter() - start)
        return out
    tight = dict(options)
    if method == "dop853":
        tight["rtol"] = options.get("rtol", 1e-10) / 100.0
    else:
        tight.pop("fraction", None)
        tight["step"] = run.step / 2.0
    out.update(steps=int(run.steps), step=float(run.step))
    try:
        ref, _ = simulate.run_scene(chain, scene, method, model_name=model_name, problem=prob,
                                    **tight)
    except (integrators.DivergenceError, ValueError) as exc:
        out.update(outcome="garbage", message=f"the run finished but its tighter run failed: {exc}",
                   wall_s=time.perf_counter() - start)
        return out
    finite = bool(np.all(np.isfinite(run.yd)) and np.all(np.isfinite(run.y)))
    E = rate_error(ref.yd[:, :4], run.yd[:, :4], run.t) if finite else np.full(4, np.inf)
    T, U, W = simulate.energy_history(prob, run)
    Etot = T + U
    scale = max(float(np.abs(Etot).max()), float(np.abs(W).max()), 1e-300)
    balance = float(np.abs(Etot - Etot[0] - W).max() / scale)
    ok = finite and bool(np.all(E <= tol))
    out.update(outcome="verified" if ok else "garbage", E=[float(e) for e in E], E_max=float(E.max()),
               tolerance=tol, energy_balance=balance, tighter=tight,
               max_rate=float(np.abs(run.yd[:, :4]).max()),
               max_modal=float(np.abs(run.y[:, 4:]).max(initial=0.0)),
               wall_s=time.perf_counter() - start)
    if observe is not None:
        out.update(observe(run, prob))
    if not ok:
        out["message"] = (f"finished but E = {E.max():.3e} against the tighter run "
                          f"(tolerance {tol:.0e})" if finite else "non-finite state")
    return out


def case_passes(result, expect=None):
    """A hard case passes unless it is garbage; a diagnosis must be one line naming the
    model.  expect: 'verified' or 'diagnosed' to demand that outcome.  bool."""
    outcome = result.get("outcome")
    if outcome == "garbage" or outcome is None:
        return False
    if expect is not None and outcome != expect:
        return False
    if outcome == "diagnosed":
        return bool(result.get("one_line", False))
    return True


def case_axis_loading(chain, y, shape):
    """Generalised force (3,) [lbf in-ish, per rad/s^2] that a unit case angular acceleration
    about case X, Y, Z puts on one mode: -shape . c_a, c_a = inverse dynamics at rest with
    only the case accelerating (the inertia load of the case motion).

    chain, y (n,) configuration, shape (n,) a coupled mode (``coupled_modes``).  The case
    axis with the largest |value| drives the mode hardest."""
    n = chain.n_coordinates
    out = np.zeros(3)
    for a in range(3):
        amp = np.zeros(3)
        amp[a] = 1.0
        c = multibody.inverse_dynamics(chain, np.asarray(y, float), np.zeros(n), np.zeros(n), 0.0,
                                       multibody.CaseMotion(amplitude=tuple(amp)))
        out[a] = -float(np.asarray(shape, float) @ c)
    return out


def potential_growth(run, fraction=0.2):
    """max U over the last ``fraction`` of a run / max U over its first ``fraction`` [1]
    (U = elastic energy at the output samples): ~ (1/f)^2 = 25 for f = 0.2 when an
    undamped mode is driven at resonance (amplitude, so the envelope of U^(1/2), growing
    linearly in time); ~1 for a bounded response."""
    U = np.asarray(run.energy.get("potential", []), float)
    k = max(int(round(fraction * U.size)), 1)
    early = float(U[1:k + 1].max()) if U.size > 1 else 0.0
    late = float(U[-k:].max()) if U.size else 0.0
    return {"potential_growth": late / early if early > 0 else np.inf,
            "potential_max": float(U.max()) if U.size else 0.0}


# ============================================================== the study (CLI)
def load_inputs(modes_dir, reduction_dir):
    """(rankings, body data, provenance of the inputs) with one-line errors for missing files."""
    for d, what in ((modes_dir, "modes"), (reduction_dir, "reduction")):
        for b in models.BODIES:
            path = os.path.join(d, f"body{b}.h5")
            if not os.path.exists(path):
                raise FileNotFoundError(f"{path} missing (run the {what} stage first)")
    rankings = models.load_rankings(reduction_dir)
    data = {b: models.load_body_file(os.path.join(modes_dir, f"body{b}.h5")) for b in models.BODIES}
    prov = {f"body{b}": {"path": os.path.join(modes_dir, f"body{b}.h5"),
                         "config_hash": str(data[b]["attrs"].get("config_hash", ""))}
            for b in models.BODIES}
    return rankings, data, prov


def build(name, rankings, data, damping_ratio=0.0):
    """Chain of a model name (``models.parse_model`` + ``models.build_chain``)."""
    return models.build_chain(models.parse_model(name, rankings), data, damping_ratio)


def run_rk4_sweep(model_names, rankings, data, n_steps, rtol=2e-4):
    """Part a: ``measure_chain_rk4_limit`` per model at the thesis configuration, plus the
    top coupled frequency over a grid of angles.  {model: dict with ``pass``}."""
    out = {}
    for name in model_names:
        log(f"rk4 limit: {name} ...")
        chain = build(name, rankings, data)
        res = measure_chain_rk4_limit(chain, n_steps=n_steps, rtol=rtol)
        grid_max, where = omega_top_over_angles(chain)
        res.update(omega_grid_max=grid_max, omega_grid_argmax=where.tolist(),
                   grid_over_omega_max=grid_max / res["omega_max"])
        res["pass"] = bool(abs(res["ratio_bound"] - 1.0) < LIMIT_TOLERANCE)
        log(f"rk4 limit: {name}: h* = {res['h_measured']:.4e} s, 2.785/omega_max = "
            f"{res['h_bound']:.4e} s (ratio {res['ratio_bound']:.4f}), h* omega_top = "
            f"{res['h_omega_top']:.4f} (2 sqrt 2 = 2.8284), {res['wall_s']:.1f} s")
        out[name] = res
    return out


def run_energy_drift(scene, rankings, data, model=DRIFT_MODEL):
    """Part b: every integrator of ``integrators.METHODS`` on ``scene`` with the settings
    ``DRIFT_OPTIONS``.  {method: dict with ``pass``}."""
    chain = build(model, rankings, data)
    out = {}
    for method in integrators.METHODS:
        log(f"energy drift: {method} on {scene.name} ({scene.duration:g} s), model {model} ...")
        res = drift_run(chain, scene, method, model_name=model, **DRIFT_OPTIONS.get(method, {}))
        res["pass"] = bool(res["drift_max"] < DRIFT_TOLERANCE)
        log(f"energy drift: {method}: max {res['drift_max']:.3e}, final {res['drift_final']:.3e}, "
            f"{res['steps']} steps, {res['wall_s']:.1f} s")
        out[method] = res
    return out


def _diagnosed_build(name, exc, *must_name):
    """Result dict of a model that could not be built (a one-line ValueError naming must_name)."""
    msg = str(exc)
    return {"model": name, "outcome": "diagnosed", "error": type(exc).__name__, "message": msg,
            "one_line": is_one_line_diagnosis(msg, *must_name)}


def lock_table(chain, base_angles=(0.0, 0.0, 0.0, 0.0), distances=(1e-1, 1e-2, 1e-3, 0.0)):
    """Conditioning of M(y) against the distance from the double gimbal lock gamma_2 =
    gamma_3 = 0 (list of dicts), plus the thesis and free configurations for reference."""
    rows = []
    configs = [("thesis", THESIS_ANGLES), ("free", (0.1, -1.3707963267948966, -0.3, 0.4))]
    configs += [(f"lock+{d:g}", (base_angles[0], d, d, base_angles[3])) for d in distances]
    for label, ang in configs:
        y = np.zeros(chain.n_coordinates)
        y[:4] = ang
        axes = drive_axes(ang)
        row = {"configuration": label, "angles": [float(a) for a in ang],
               "lock_distance": lock_distance(axes), "axis_alignment": axis_alignment(axes),
               "omega_top": float(multibody.coupled_frequencies(chain, y)[-1])}
        row.update(mass_conditioning(multibody.mass_matrix_fast(chain, y)))
        rows.append(row)
    return rows


def run_hard_cases(rankings, data, quick=False, model=HARD_MODEL):
    """Part c: every hard case (dict name -> result with ``pass``, ``expect`` and ``what``)."""
    short = 0.005 if quick else 0.015
    chain = build(model, rankings, data)
    thesis = scenes.load_scene("thesis")
    cases = {}

    def record(name, what, result, expect=None):
        result.update(what=what, expect=expect, **{"pass": case_passes(result, expect)})
        cases[name] = result
        extra = f"E = {result['E_max']:.2e}" if "E_max" in result else result.get("message", "")
        log(f"hard case {name}: {result['outcome']} ({extra}), {result.get('wall_s', 0.0):.1f} s")

    # 1, 2: large initial gimbal rates (case at rest)
    for r in (10, 100):
        sc = scenes.load_scene(f"stress_rates_{r}")
        if quick:
            sc = scene_variant(sc, sc.name, duration=short)
        log(f"hard case rates_{r}: {model} on {sc.name} ...")
        record(f"rates_{r}", f"initial gimbal rates {r} rad/s (scene {sc.name}), rk4 default step",
               checked_run(chain, sc, model))

    # 3: case driven at the first coupled elastic resonance, about the case axis loading it most
    y0 = np.zeros(chain.n_coordinates)
    y0[:4] = thesis.initial_angles
    omega, shapes = coupled_modes(multibody.mass_matrix_fast(chain, y0), chain.stiffness_diagonal()[4:])
    load = case_axis_loading(chain, y0, shapes[:, 0])
    axis = int(np.argmax(np.abs(load)))
    amp = np.zeros(3)
    amp[axis] = 1.0
    freq = np.zeros(3)
    freq[axis] = omega[0] / (2 * np.pi)
    sc = scene_variant(thesis, "stress_resonance", duration=0.01 if quick else 0.03,
                       case_angular_acceleration_amplitude=amp,
                       case_angular_acceleration_frequency=freq)
    log(f"hard case resonance: {model}, case axis {'XYZ'[axis]} at {freq[axis]:.2f} Hz ...")
    res = checked_run(chain, sc, model, observe=lambda run, prob: potential_growth(run))
    res.update(resonance_omega=float(omega[0]), resonance_hz=float(freq[axis]), case_axis="XYZ"[axis],
               case_axis_loading=load.tolist())
    record("resonance", f"case rocked at the first coupled elastic frequency "
                        f"({omega[0]:.1f} rad/s) about case {'XYZ'[axis]}, 1 rad/s^2", res)

    # 4: near gimbal lock (thesis case motion about X, the normal of the locked axes' plane)
    sc = scenes.load_scene("stress_lock")
    if quick:
        sc = scene_variant(sc, sc.name, duration=short)
    log(f"hard case gimbal_lock: {model} on {sc.name} ...")
    res = checked_run(chain, sc, model)
    res["conditioning"] = lock_table(chain)
    record("gimbal_lock", "gamma_2 = gamma_3 = 1e-3 rad from the double lock (all four drive axes "
                          "within 1e-3 of one plane), case rocked about its normal", res)

    # 5: twelve static modes on one body (every output-bearing load case of the outer gimbal)
    name12 = "freq-6@2:" + "+".join(OUTPUT_LOADS)
    log(f"hard case static_modes: {name12} ...")
    spec = models.parse_model(name12, rankings)
    cond = static_mode_conditioning(data[2], spec.kept[2], OUTPUT_LOADS)
    chain12 = models.build_chain(spec, data)
    y12 = np.zeros(chain12.n_coordinates)
    y12[:4] = thesis.initial_angles
    res = checked_run(chain12, scene_variant(thesis, "thesis", duration=short) if quick else thesis,
                      name12)
    chain6 = build("freq-6", rankings, data)
    y6 = np.zeros(chain6.n_coordinates)
    y6[:4] = thesis.initial_angles
    res.update(static=cond, chain=mass_conditioning(multibody.mass_matrix_fast(chain12, y12)),
               chain_without_static=mass_conditioning(multibody.mass_matrix_fast(chain6, y6)))
    record("static_modes", f"12 static modes on the outer gimbal ({len(OUTPUT_LOADS)} output-bearing "
                           f"load cases), thesis scene", res)

    # 6: all 24 bearing load cases on one body: some act only on the supports
    name24 = "freq-6@2:" + "+".join(ALL_LOADS)
    try:
        models.build_chain(models.parse_model(name24, rankings), data)
        res = {"model": name24, "outcome": "garbage", "message": "built a model with loads on supports"}
    except ValueError as exc:
        # the reduction's message names the load case, not the model (build_chain does not add it)
        res = _diagnosed_build(name24, exc, "static mode", "vanishes")
    record("static_modes_on_supports", "all 24 bearing load cases on the outer gimbal", res,
           expect="diagnosed")

    # 7: a requested step beyond the limit
    record("step_beyond_limit", "rk4 at 1.3 x 2.785/omega_max, thesis scene",
           checked_run(chain, thesis, model, fraction=1.3), expect="diagnosed")

    # 8: the old bound (largest kept modal frequency): the step is 3.5x too large
    prob = multibody.Problem(chain, case=thesis.case, y0=y0, omega_max=chain.omega_max)
    record("modal_frequency_bound", "rk4 at 0.5 x 2.785/(largest kept modal frequency), the bound "
                                    "before the coupled-frequency fix, thesis scene",
           checked_run(chain, thesis, model, problem=prob), expect="diagnosed")

    # 9: a permitted step (fraction 1.0 of the sampled limit) through the configuration where
    # the small model's top coupled frequency peaks (gamma_2 = 0), missed by the sampling
    small = build(DRIFT_MODEL, rankings, data)
    free = scenes.load_scene("free")
    sc = scene_variant(free, "stress_sampling", duration=0.2, output_interval=0.02,
                       initial_rates=(0.0, 10.0, 0.0, 0.0))
    log(f"hard case sampled_omega_max: {DRIFT_MODEL} ...")
    res = checked_run(small, sc, DRIFT_MODEL, fraction=1.0)
    grid_max, where = omega_top_over_angles(small)
    res.update(omega_grid_max=grid_max, omega_grid_argmax=where.tolist(),
               grid_over_omega_max=grid_max / res.get("omega_max", np.nan),
               h_omega_grid_max=integrators.RK4_STABILITY * grid_max / res.get("omega_max", np.nan))
    record("sampled_omega_max", f"{DRIFT_MODEL}, rk4 at 1.0 x the limit, gamma_2 from -1.37 rad "
                                f"through 0 at 10 rad/s", res)
    return cases


# ============================================================== outputs
def _write_csv(path, header, rows):
    from workflow.provenance import atomic_path
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    w.writerows(rows)
    with atomic_path(path) as tmp:
        tmp.write_text(buf.getvalue())
    return path


def write_csvs(out_dir, sweep, drift, cases):
    """rk4_limit.csv, energy_drift.csv, hard_cases.csv, gimbal_lock.csv in out_dir; list of paths."""
    paths = []
    cols = ("n_modes", "modal_omega_max", "omega_top", "omega_max", "omega_grid_max", "h_measured",
            "h_lo", "h_hi", "h_bound", "h_imaginary", "ratio_bound", "ratio_imaginary", "pass")
    paths.append(_write_csv(os.path.join(out_dir, "rk4_limit.csv"), ("model",) + cols,
                            [[m] + [("+".join(map(str, r[c])) if c == "n_modes" else r[c]) for c in cols]
                             for m, r in sweep.items()]))
    if drift:
        methods = list(drift)
        t = drift[methods[0]]["t"]
        rows = [[f"{t[i]:.6g}"] + [f"{drift[m]['drift'][i]:.6e}" for m in methods] for i in range(t.size)]
        paths.append(_write_csv(os.path.join(out_dir, "energy_drift.csv"),
                                ["t_s"] + [f"drift_{m}" for m in methods], rows))
    paths.append(_write_csv(os.path.join(out_dir, "hard_cases.csv"),
                            ("case", "model", "scene", "outcome", "E_max", "message", "wall_s", "pass"),
                            [[k, r.get("model", ""), r.get("scene", ""), r["outcome"], r.get("E_max", ""),
                              r.get("message", ""), r.get("wall_s", ""), r["pass"]]
                             for k, r in cases.items()]))
    lock = cases.get("gimbal_lock", {}).get("conditioning")
    if lock:
        keys = ("lock_distance", "axis_alignment", "omega_top", "cond_M", "cond_joints", "cond_schur",
                "min_eig_schur")
        paths.append(_write_csv(os.path.join(out_dir, "gimbal_lock.csv"), ("configuration",) + keys,
                                [[r["configuration"]] + [r[k] for k in keys] for r in lock]))
    return paths


def _save(fig, path):
    from workflow.provenance import atomic_path
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=150)
    return path


def plot_rk4_limit(sweep, path):
    """Measured h* against 2.785/omega_max (left), and h*/(2.785/omega_max) per model (right)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(sweep)
    hb = np.array([sweep[m]["h_bound"] for m in names])
    hm = np.array([sweep[m]["h_measured"] for m in names])
    ratio = hm / hb
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
    lo, hi = hb.min() / 1.3, hb.max() * 1.3
    a1.loglog([lo, hi], [lo, hi], "k-", lw=0.8, label="h* = 2.785 / omega_max")
    undamped = 2 * np.sqrt(2) / RK4_BOUND
    a1.loglog([lo, hi], [lo * undamped, hi * undamped], "k--", lw=0.8,
              label="h* = 2 sqrt 2 / omega_max")
    for m, x, y in zip(names, hb, hm):
        a1.loglog(x, y, "o", label=m if len(m) < 30 else m[:28] + "...")
    a1.set_xlabel("theory 2.785 / omega_max [s]")
    a1.set_ylabel("measured RK4 limit h* [s]")
    a1.legend(fontsize=7, loc="upper left")
    x = np.arange(len(names))
    a2.axhspan(1 - LIMIT_TOLERANCE, 1 + LIMIT_TOLERANCE, color="0.9", label="check: +-5 %")
    a2.axhline(1.0, color="k", lw=0.8)
    a2.axhline(2 * np.sqrt(2) / RK4_BOUND, color="k", ls="--", lw=0.8,
               label="2 sqrt 2 / 2.785 = 1.0156 (undamped)")
    a2.plot(x, ratio, "o", label="vs 2.785 / omega_max (Problem: max over 4 configurations)")
    top = np.array([sweep[m]["h_measured"] * sweep[m]["omega_top"] / RK4_BOUND for m in names])
    a2.plot(x, top, "o", mfc="none", label="vs 2.785 / omega_top (thesis configuration)")
    a2.set_xticks(x)
    a2.set_xticklabels([m if len(m) < 16 else m[:14] + "..." for m in names], rotation=20, fontsize=7)
    a2.set_ylabel("h* / (2.785 / omega_max)")
    a2.set_ylim(0.93, 1.07)
    a2.legend(fontsize=7, loc="lower right")
    fig.suptitle("RK4 stability limit: measured (bisection) vs theory, thesis configuration")
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)
    return path


def plot_energy_drift(drift, path, title=""):
    """|E(t) - E(0)| / |E(0)| against t for every integrator (log scale)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    floor = 1e-17
    for m, r in drift.items():
        label = f"{m} ({r['steps']} steps, {r['wall_s']:.1f} s)"
        ax.semilogy(r["t"][1:], np.maximum(r["drift"][1:], floor), lw=0.8, label=label)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("|E(t) - E(0)| / |E(0)|")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)
    return path


def _summary(obj):
    """JSON-ready copy: arrays to lists, long time series dropped (they go to the CSVs)."""
    if isinstance(obj, dict):
        return {k: _summary(v) for k, v in obj.items() if k not in ("t", "drift")}
    if isinstance(obj, (list, tuple)):
        return [_summary(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer, np.bool_)):
        return obj.item()
    if isinstance(obj, float) and not np.isfinite(obj):
        return str(obj)
    return obj


def _versions(versions):
    """workflow.provenance.versions() plus numba (the compiled right-hand side)."""
    out = versions()
    try:
        import numba
        out["numba"] = numba.__version__
    except ImportError:
        out["numba"] = "missing (NumPy right-hand side)"
    return out


class _Parser(argparse.ArgumentParser):
    """Argument errors as one line, exit status 2."""

    def error(self, message):
        self.exit(2, f"stability: {message} (see --help)\n")


def main(argv=None):
    ap = _Parser(prog="python -m results.bench.stability",
                 description="Numerical stability stress tests of the integrators (issue 6; "
                             "docs/stability.md).")
    ap.add_argument("--modes-dir", default=os.path.join(ROOT, "results", "modes"))
    ap.add_argument("--reduction-dir", default=os.path.join(ROOT, "results", "reduction"))
    ap.add_argument("--out-dir", default=os.path.join(ROOT, "results", "stability"))
    ap.add_argument("--figures-dir", default=os.path.join(ROOT, "results", "figures", "stability"))
    ap.add_argument("--quick", action="store_true",
                    help="reduced version (2 models, 2000-step trials, 1 s drift, 5 ms hard cases)")
    args = ap.parse_args(argv)
    command_args = list(sys.argv[1:] if argv is None else argv)
    os.environ.setdefault("MPLBACKEND", "Agg")
    start = time.perf_counter()
    try:
        rankings, data, inputs = load_inputs(args.modes_dir, args.reduction_dir)
        drift_scene = scenes.load_scene("free_10s")
    except (FileNotFoundError, ValueError) as exc:
        print(f"stability: {exc}", file=sys.stderr)
        return 2
    from workflow.provenance import versions, write_json
    if args.quick:
        drift_scene = scene_variant(drift_scene, "free_10s (quick: 1 s)", duration=1.0)
    log(f"{'quick' if args.quick else 'full'} run; inputs {args.modes_dir}, {args.reduction_dir}")

    omega = 1000.0
    osc = oscillator_rk4_limit(omega)
    x_imag = rk4_imaginary_axis_limit()
    oscillator = {"omega": omega, "h_measured": osc["step"], "h_omega": osc["step"] * omega,
                  "exact": x_imag, "relative_offset": osc["step"] * omega / x_imag - 1.0,
                  "pass": bool(abs(osc["step"] * omega / x_imag - 1.0) < 2e-4)}
    log(f"scalar oscillator: h* omega = {oscillator['h_omega']:.6f} (2 sqrt 2 = {x_imag:.6f})")

    sweep = run_rk4_sweep(QUICK_SWEEP_MODELS if args.quick else SWEEP_MODELS, rankings, data,
                          n_steps=2000 if args.quick else 4000)
    drift = run_energy_drift(drift_scene, rankings, data)
    cases = run_hard_cases(rankings, data, quick=args.quick)

    os.makedirs(args.out_dir, exist_ok=True)
    csvs = write_csvs(args.out_dir, sweep, drift, cases)
    figs = [plot_rk4_limit(sweep, os.path.join(args.figures_dir, "rk4_limit.png")),
            plot_energy_drift(drift, os.path.join(args.figures_dir, "energy_drift.png"),
                              f"scene {drift_scene.name}, model {DRIFT_MODEL}: relative energy drift")]
    parts = {"scalar_oscillator": oscillator["pass"],
             "rk4_limit": all(r["pass"] for r in sweep.values()),
             "energy_drift": all(r["pass"] for r in drift.values()),
             "hard_cases": all(r["pass"] for r in cases.values())}
    wall = time.perf_counter() - start
    report = {
        "title": "Numerical stability stress tests (issue 6)",
        "quick": bool(args.quick),
        "theory": {"rk4_imaginary_axis": x_imag, "rk4_real_axis": rk4_real_axis_limit(),
                   "project_bound": RK4_BOUND,
                   "imaginary_over_bound": x_imag / RK4_BOUND},
        "scalar_oscillator": oscillator,
        "rk4_limit": {"tolerance": LIMIT_TOLERANCE, "configuration": list(THESIS_ANGLES),
                      "check": "|h* / (2.785 / Problem.omega_max) - 1| < tolerance",
                      "models": sweep, "pass": parts["rk4_limit"]},
        "energy_drift": {"scene": drift_scene.name, "duration_s": drift_scene.duration,
                         "model": DRIFT_MODEL, "tolerance": DRIFT_TOLERANCE,
                         "model_choice": "first mode of the outer and middle gimbals only: omega_max "
                                         "1.2e4 rad/s, so 10 s cost 9e4 RK4 steps; the first modes of "
                                         "bodies 4 and 5 couple at 4.5e4 and 4.1e5 rad/s",
                         "methods": drift, "pass": parts["energy_drift"]},
        "hard_cases": {"model": HARD_MODEL, "tolerance": HARD_CASE_TOLERANCE, "cases": cases,
                       "pass": parts["hard_cases"]},
        "pass": all(parts.values()),
        "parts": parts,
        "outputs": {"csv": csvs, "figures": figs},
        "provenance": {"command": " ".join(["python -m results.bench.stability"] + command_args),
                       "wall_time_s": wall, "created": time.strftime("%Y-%m-%dT%H:%M:%S"),
                       "versions": _versions(versions), "inputs": inputs},
    }
    path = os.path.join(args.out_dir, "stability.json")
    write_json(path, _summary(report))
    failed = [k for k, v in parts.items() if not v]
    log(f"{path}: {'FAILED: ' + ', '.join(failed) if failed else 'all checks pass'} ({wall:.0f} s)")
    return 0 if report["pass"] else 1


if __name__ == "__main__":
    sys.exit(main())
