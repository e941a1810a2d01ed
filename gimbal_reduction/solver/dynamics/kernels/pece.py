"""The exponential integrator's step loop, compiled (``gimbal_reduction.solver.dynamics.exponential``).

Why: the exponential Adams step of ``docs/exponential.md`` (Sections 4-6) is a few
dozen small array operations per step -- two polynomial fits, two phi-weighted advances
of the modal state, one or two physical transforms and projections (PEC or PECE), the
error norm, the dense outputs, the phase-error estimate and the step-size decisions.  As
NumPy calls from a Python loop that cost ~0.3 ms per step on the truth model (~60 calls of
~5 us overhead each) besides the arithmetic.  Here the whole loop is compiled: ``pece_run``
calls one function per stage of the step (``STAGES``) until a stage asks Python for
something it owns, and is called again to go on from where it stopped (``Loop.stage``):

* ``NEED_RHS``: the right-hand side a(t, y, y') at (ev.t, ev.y, ev.yd), written into ev.a by
  Python (the problem's own, compiled or not, wrapped or overridden: the loop never needs to
  know which); once per step attempt, and at the accepted state too under PECE;
* ``NEED_PROBE``, ``NEED_FREQUENCIES``, ``NEED_BASIS``: the first basis's frequency
  sensitivity, new frequencies of the same shapes, a new basis (eigenproblem) at the
  accepted state in ev (Section 6); Python rewrites the basis arrays ``b`` and the phase
  arrays of ``st`` in place, the loop then carries its history into the new basis;
* ``OUTPUTS`` (fixed steps only): outputs Loop.out_first..out_last are new (the
  integrators' energy watch);
* ``FAILED``: the run cannot go on (Loop.failure says why, Loop.event_* the numbers);
* ``DONE``: the last output is reached.

Why a function called again and not a Numba generator that yields the requests: the
generator was the same code, but LLVM took ~460 s to optimise it against ~50 s for a
plain function.  Why the right-hand side is not evaluated in here (for the compiled one):
it saved ~7 us per evaluation (1 ms of a thesis truth run) but the recursion, linked into
the loop, doubled its compile time.

Every array the loop and Python share is allocated once per run (``exponential.
ExponentialAdams``) and rewritten in place.  The arithmetic is that of the Python loop it
replaced, up to rounding (docs/exponential.md Sec. 8).

The containers: the named tuples ``Basis`` b, ``WeightCache`` w, ``State`` st, ``History``
hist, ``Evaluation`` ev, ``Outputs`` out, ``Work`` work (each field documented in its class),
and two NumPy records of one element each, ``SETTINGS`` cfg (what does not change in a run)
and ``LOOP`` (st.loop: the loop's counters, flags and scalars), read and written by field
name in the kernels and in Python (``st.loop["steps"]``).  Shapes: n coordinates (4 joint
angles first), m = n - 4 elastic modes, K + 1 polynomial coefficients at most (K =
max(order, 2): the first step's midpoint fit has one node more than the corrector).  Units:
s, rad, the chain's units.
"""

import math
from typing import NamedTuple

import numba
import numpy as np

from gimbal_reduction.solver.dynamics.kernels import JIT, extension
from gimbal_reduction.solver.dynamics.kernels.exponential import (advance_diagonal, dense_coupled, dense_diagonal,
                                                                  modal_xi, phi_table)

N_JOINTS = 4
# The stages and their thin wrappers are inlined into ``pece_run`` by Numba (its IR, before LLVM):
# compiled as functions of their own, each would be optimised by LLVM once alone and again inside
# every caller (Numba links a callee's code into each caller's module), one level more for the
# whole step's code
STAGE = dict(JIT, inline="always")

# what a stage returns: a request to Python, DONE, or CONTINUE (the next stage, no return)
CONTINUE = -1
DONE = 0
NEED_RHS = 1
NEED_PROBE = 2
NEED_FREQUENCIES = 3
NEED_BASIS = 4
OUTPUTS = 5
FAILED = 6

# the stages (Loop.stage: where pece_run goes on); the step's order of work
STEP = 0            # a step attempt starts: predict, ask for g at the predicted state
PREDICTED = 1       # the predicted state's g is there: correct, estimate the error
MIDPOINT = 2        # the first step's midpoint g is there: the quadratic fit
DECIDE = 3          # accept or reject (after PREDICTED or MIDPOINT, without a request)
ACCEPTED = 4        # g at the accepted state is there: outputs, history, drift
PHASE = 5           # (after the OUTPUTS request) the first basis's frequency probe if due
PHASE_ERROR = 6     # the phase error and what it asks for: new frequencies or a new basis
UPDATED = 7         # new frequencies are there: carry the history
REBASED = 8         # a new basis after an accepted step: carry the history, state in it
RETRY = 9           # a new basis after repeated rejections: the same, then the step again
GROW = 10           # double the step if the error allows

# failure causes (Loop.failure); the messages are written in exponential.py
FAIL_STEP_TOO_SMALL = 1     # the step fell below the grid with the error above tol (t = event_time)
FAIL_NON_FINITE_STATE = 2   # non-finite state after a step (t = event_time)
FAIL_NON_FINITE_RHS = 3     # non-finite accelerations at an accepted state
FAIL_FROZEN_DRIFT = 4       # a frozen basis beyond its validity (event_value: the drift)

# What does not change during a run (``exponential.ExponentialOptions`` and the run's grid),
# one record: tol (local error per step; <= 0: fixed steps), tick [s] (the step grid: dt_out /
# ticks_per_output), ticks_per_output, i_end (the last tick), order (Adams predictor order),
# relinearise, every_ticks (fixed steps: re-linearise every this many ticks, 0: never), drift
# [rad] (new basis beyond this gimbal drift), frozen_validity [rad], probe_drift [rad],
# phase_bound (the phase error that asks for new frequencies or a new basis:
# ``ExponentialOptions.phase_bound``), update_drift (a phase error at a drift <= update_drift x
# drift: new frequencies), update_min_modes, max_rejections (in a basis that is not fresh),
# grow_safety, rate_floor, series_radius and series_terms (``phi_table``), watch (return
# OUTPUTS), error_energy_weight (the energy norm's weight in ``local_error``, 0: the gimbal
# rates alone), evaluate_accepted (PECE, g at every accepted state; False: PEC, the accepted
# node keeps the predicted state's g; docs/exponential.md Section 5).
SETTINGS = np.dtype([
    ("tol", np.float64), ("tick", np.float64), ("ticks_per_output", np.int64), ("i_end", np.int64),
    ("order", np.int64), ("relinearise", np.bool_), ("every_ticks", np.int64), ("drift", np.float64),
    ("frozen_validity", np.float64), ("probe_drift", np.float64), ("phase_bound", np.float64),
    ("update_drift", np.float64), ("update_min_modes", np.int64), ("max_rejections", np.int64),
    ("grow_safety", np.float64), ("rate_floor", np.float64), ("series_radius", np.float64),
    ("series_terms", np.int64), ("watch", np.bool_), ("error_energy_weight", np.float64),
    ("evaluate_accepted", np.bool_)])

# The loop's state between calls, counters and flags shared with Python, one record:
# stage (where to go on), tick (i: the grid tick of the current state), step_ticks (m: the step
# in ticks), since_change (accepted steps since the step last changed), basis_tick (the tick of
# the current basis), rejections_in_basis, segment (the current basis's index in the run's list
# of bases), nodes (q: history nodes of the current step's fits), coef_rows (rows of work.coef
# in use: the corrector's polynomial), steps (accepted), rejected (step attempts),
# evaluations (right-hand sides), phase_relinearisations (bases asked for by the phase error,
# not the drift), probed (1 once the current basis knows its frequency sensitivity; Python sets
# it), out_first, out_last (OUTPUTS: the new output indices), failure (FAIL_*), predicted_node
# (1: the newest history node is the predicted state's: PEC), finite (the step's corrected
# state is finite); smallest_step, largest_step [s]; event_time [s] (of a basis request or a
# failure), event_step [s] (the step h of a failure or of new outputs), event_value (a
# failure's error estimate, or the drift [rad] of a probe or a frozen basis); energy_scale,
# rate_scale [rad/s] (the error norm's scales: the largest energy norm and gimbal rate of the
# solution so far); error (the current step's local error estimate); drift, phase_drift [rad]
# (the accepted state's gimbal drift from the basis's angles, and from the angles the phase is
# counted from), drift_previous [rad] (phase_drift of the previous step, 0 after a basis change).
LOOP = np.dtype([
    ("stage", np.int64), ("tick", np.int64), ("step_ticks", np.int64), ("since_change", np.int64),
    ("basis_tick", np.int64), ("rejections_in_basis", np.int64), ("segment", np.int64),
    ("nodes", np.int64), ("coef_rows", np.int64), ("steps", np.int64), ("rejected", np.int64),
    ("evaluations", np.int64), ("phase_relinearisations", np.int64), ("probed", np.int64),
    ("out_first", np.int64), ("out_last", np.int64), ("failure", np.int64),
    ("predicted_node", np.int64), ("finite", np.int64),
    ("smallest_step", np.float64), ("largest_step", np.float64), ("event_time", np.float64),
    ("event_step", np.float64), ("event_value", np.float64), ("energy_scale", np.float64),
    ("rate_scale", np.float64), ("error", np.float64), ("drift", np.float64),
    ("phase_drift", np.float64), ("drift_previous", np.float64)])


class Basis(NamedTuple):
    """The current coupled modal basis (``exponential.ModalBasis``) as the loop reads it,
    rewritten in place by Python on every new basis or frequency update.

    y_ref (n,) linearisation state; X (m, m) elastic block of phi; YT (m, m) X^-1 (only when
    some stiffness is zero, else (0, 0)) and Ky (m,) the stiffness Omega^2 [(rad/s)^2] (the
    projection Lambda^-1 X^T K v otherwise); omega_ref (n,) [rad/s] the eigenfrequencies at
    y_ref, omega (n,) [rad/s] the current ones (a frequency update changes them) and omega2
    (n,) = omega^2 (Lambda); Lt (4, 4) L^-T; J (4, m) the joints' motion per modal motion;
    Lg (4, n) L^-1 M0[:4]; rates (4, n) = phi[:4], the gimbal rows of phi.
    The elastic oscillators: undamped bank mu, delta (m,) complex (xi = (eta' - conj(mu) eta)
    / delta); damped (``CoupledBank``, any damping) mu (p,) (p >= m: a pair per underdamped
    mode, two real eigenvalues per overdamped one), P_eta, P_vel (p, m) and V_eta, V_vel (m, p)
    complex (V scaled: z = Re(V xi)), phase_mode (p,) int (the coupled mode whose phase error
    an entry takes, -1 none), V_real (2p, 2m) = [[Re V_eta^T, Re V_vel^T], [-Im V_eta^T,
    -Im V_vel^T]] (the dense outputs' map back, ``dense_coupled``), Ct (m, m) [1/s] the modal
    damping (all size 0 undamped; delta of size 0 damped).
    version (1,) int: counted up by Python on every change (the loop then clears its weight
    cache)."""
    y_ref: np.ndarray
    X: np.ndarray
    YT: np.ndarray
    Ky: np.ndarray
    omega_ref: np.ndarray
    omega: np.ndarray
    omega2: np.ndarray
    Lt: np.ndarray
    J: np.ndarray
    Lg: np.ndarray
    rates: np.ndarray
    mu: np.ndarray
    delta: np.ndarray
    P_eta: np.ndarray
    P_vel: np.ndarray
    V_eta: np.ndarray
    V_vel: np.ndarray
    phase_mode: np.ndarray
    V_real: np.ndarray
    Ct: np.ndarray
    version: np.ndarray


class WeightCache(NamedTuple):
    """The variation-of-constants weights of the current basis (``fill_weights``), one entry per
    (step length m, offset o) in grid ticks: the length H = o tick of a step of m ticks (o = m:
    the step itself; o < m: a dense output, theta = o / m, whose powers theta^r are folded into
    the weights).  keys (C, 2) int, -1 = empty; E_re, E_im (C, m) = e^{H mu}; F_re, F_im
    (C, K + 1, m) the forcing weights H r! phi_{r+1}(H mu) (over delta for the undamped bank);
    wpos, wvel (C, K + 1) = H^2 r!/(r+2)!, H r!/(r+1)!; H (C,) [s]; used (3,) int: [entries
    filled, basis version they belong to, entries computed in the run]; inv_fact, fact
    (>= series_terms + K + 3,) 1/k!, k!;
    z (m,) complex and phis (K + 2, m) complex scratch."""
    keys: np.ndarray
    E_re: np.ndarray
    E_im: np.ndarray
    F_re: np.ndarray
    F_im: np.ndarray
    wpos: np.ndarray
    wvel: np.ndarray
    H: np.ndarray
    used: np.ndarray
    inv_fact: np.ndarray
    fact: np.ndarray
    z: np.ndarray
    phis: np.ndarray


class State(NamedTuple):
    """The loop's state between calls and what Python reads or sets: loop (1,) ``LOOP`` record
    (counters, flags, scalars by name); rate_scales (4,) [rad/s] each gimbal rate's largest
    magnitude so far (the error norm's); phase (m,) [rad] the accumulated phase error estimate
    of the frozen frequencies, kappa (m,) [1/rad] their relative sensitivity to drift,
    phase_ref (4,) [rad] the angles the phase is counted from (Python resets the three on a new
    basis or a frequency update)."""
    loop: np.ndarray
    rate_scales: np.ndarray
    phase: np.ndarray
    kappa: np.ndarray
    phase_ref: np.ndarray


class Work(NamedTuple):
    """The step's modal vectors (n,) each, kept between calls: eta, etad the current state (set
    by Python at the start), eta_p, etad_p the predicted, eta_c, etad_c the corrected, eta_q,
    etad_q the first step's midpoint and quadratic states; g_p, g_m, g_1 the modal forcing at
    the predicted state, the midpoint and the accepted state; coef (K + 2, n) the corrector's
    polynomial (Loop.coef_rows rows), which the dense outputs reuse; xi_re, xi_im (m,) the
    undamped bank's complex coordinates of the step's start (``modal_xi``; unused damped);
    omega2_old (n,) Lambda before a frequency update (the history's g follows the change)."""
    eta: np.ndarray
    etad: np.ndarray
    eta_p: np.ndarray
    etad_p: np.ndarray
    eta_c: np.ndarray
    etad_c: np.ndarray
    eta_q: np.ndarray
    etad_q: np.ndarray
    g_p: np.ndarray
    g_m: np.ndarray
    g_1: np.ndarray
    coef: np.ndarray
    xi_re: np.ndarray
    xi_im: np.ndarray
    omega2_old: np.ndarray


class History(NamedTuple):
    """The accepted nodes, newest first (row 0): t (order + 1,) [s], y, yd, a (order + 1, n) the
    physical state and accelerations (to carry g into a new basis), g (order + 1, n) the modal
    forcing in the current basis; length (1,) int the rows in use.  A node's y, y', a and g
    belong to one state: the accepted (corrected) state's with a final evaluation (PECE), the
    predicted state's of the same time without (PEC, Loop.predicted_node); the accepted
    state itself is (work.eta, work.etad)."""
    t: np.ndarray
    y: np.ndarray
    yd: np.ndarray
    a: np.ndarray
    g: np.ndarray
    length: np.ndarray


class Evaluation(NamedTuple):
    """The exchange with Python: t (1,) [s], y, yd (n,) the state of a request, a (n,) the
    accelerations Python writes back (NEED_RHS)."""
    t: np.ndarray
    y: np.ndarray
    yd: np.ndarray
    a: np.ndarray


class Outputs(NamedTuple):
    """eta, etad (T, n) the modal outputs at the output times, segment (T,) int the basis
    (index into the run's list of bases) each was computed in."""
    eta: np.ndarray
    etad: np.ndarray
    segment: np.ndarray


# ------------------------------------------------------------ transforms (ModalBasis)
# The helpers take plain arrays, not the named tuples, so that ``exponential.ModalBasis`` calls
# the same code from Python at the dispatch cost of a few arrays (~2 us; a tuple of many arrays
# costs ~0.2 ms to dispatch, ``gimbal_reduction.solver.dynamics.compiled``).
@numba.njit(**JIT)
def to_physical(y_ref, Lt, J, X, eta, etad, y, yd):
    """(y, y') (n,) of a modal state (eta, eta') (n,) into y, yd: y = y_ref + phi eta,
    y' = phi eta' with phi = [[Lt, J X], [0, X]] (``exponential.ModalBasis``): one product of
    X (m, m) with both elastic parts, then the four joint rows."""
    j = N_JOINTS
    nm = eta.shape[0] - j
    Z = np.empty((2, nm))
    Z[0] = eta[j:]
    Z[1] = etad[j:]
    Q = np.dot(Z, X.T)                                     # (2, m)
    y[j:] = Q[0]
    yd[j:] = Q[1]
    y[:j] = y_ref[:j] + np.dot(Lt, eta[:j]) + np.dot(J, Q[0])
    yd[:j] = np.dot(Lt, etad[:j]) + np.dot(J, Q[1])


@numba.njit(**JIT)
def project(Lg, X, Ky, omega_ref, YT, v, out):
    """out (n,) = phi^-1 v = [L^-1 M0[:4] v; Y^T v[4:]] of a physical vector v (n,): with every
    stiffness positive (YT of size 0) Y^T v = Lambda^-1 X^T (K v), the same matrix X as
    ``to_physical`` (Ky (m,) = Omega^2, omega_ref (n,) [rad/s]), else the stored Y^T = X^-1."""
    j = N_JOINTS
    out[:j] = np.dot(Lg, v)
    if YT.shape[0] == 0:
        out[j:] = np.dot(X.T, Ky * v[j:]) / omega_ref[j:] ** 2
    else:
        out[j:] = np.dot(YT, v[j:])


@numba.njit(**JIT)
def add_linear_terms(omega2, Ct, eta, etad, g):
    """g += Lambda eta + Ct eta' (n,): the linear terms the modal equations' left side holds
    (omega2 (n,) = Lambda; Ct (m, m) [1/s] the elastic modes' damping, size 0 undamped)."""
    j = N_JOINTS
    g += omega2 * eta
    if Ct.shape[0]:
        g[j:] += np.dot(Ct, etad[j:])


@numba.njit(**JIT)
def coupled_advance(P_eta, P_vel, V_eta, V_vel, eta, etad, coef, theta_pow, E_re, E_im, W_re, W_im,
                    wpos, wvel, H, out_eta, out_etad):
    """The damped bank's advance (``exponential.CoupledBank``; the undamped one is
    ``kernels.exponential.advance_diagonal``): xi = P [eta; eta'] (p,) complex,
    xi <- E xi + sum_r W_r (P_vel theta^r c_r), (eta, eta') = Re(V xi); the joints as in
    ``advance_diagonal``.  P_eta, P_vel (p, m), V_eta, V_vel (m, p) complex; E, W (real and
    imaginary parts, (p,) and (>= kk, p)) the weights of ``fill_weights``."""
    j = N_JOINTS
    kk = coef.shape[0]
    p = P_eta.shape[0]
    xi = (E_re[:p] + 1j * E_im[:p]) * (np.dot(P_eta, eta[j:].astype(np.complex128))
                                       + np.dot(P_vel, etad[j:].astype(np.complex128)))
    for r in range(kk):
        xi += np.dot(P_vel, (coef[r, j:] * theta_pow[r]).astype(np.complex128)) \
            * (W_re[r, :p] + 1j * W_im[r, :p])
    out_eta[j:] = np.dot(V_eta, xi).real
    out_etad[j:] = np.dot(V_vel, xi).real
    for a in range(j):
        p = eta[a] + H * etad[a]
        v = etad[a]
        for r in range(kk):
            p += wpos[r] * (coef[r, a] * theta_pow[r])
            v += wvel[r] * (coef[r, a] * theta_pow[r])
        out_eta[a] = p
        out_etad[a] = v


@numba.njit(**JIT)
def phase_shift(mu, delta, P_eta, P_vel, V_eta, V_vel, phase_mode, phase, eta_e, etad_e, d_eta,
                d_etad):
    """(d_eta, d_etad) (m,): the change of the elastic state (eta_e, etad_e) (m,) when mode i's
    complex coordinate turns by the phase phase_i [rad], xi_i -> xi_i + i phase_i xi_i: the
    undamped bank's (P_eta of size 0) xi = (eta' - conj(mu) eta) / delta, eta = 2 Re xi,
    eta' = 2 Re(mu xi); the damped bank's through its eigenvectors, entry k turning by the
    phase of mode phase_mode[k] (none for -1: a real eigenvalue)."""
    if P_eta.shape[0]:
        xi = np.dot(P_eta, eta_e.astype(np.complex128)) + np.dot(P_vel, etad_e.astype(np.complex128))
        dxi = np.zeros(xi.shape[0], dtype=np.complex128)
        for k in range(xi.shape[0]):
            if phase_mode[k] >= 0:
                dxi[k] = 1j * phase[phase_mode[k]] * xi[k]
        d_eta[:] = np.dot(V_eta, dxi).real
        d_etad[:] = np.dot(V_vel, dxi).real
        return
    for i in range(mu.shape[0]):
        xi = (etad_e[i] - np.conj(mu[i]) * eta_e[i]) / delta[i]
        dxi = 1j * phase[i] * xi
        d_eta[i] = 2.0 * dxi.real
        d_etad[i] = 2.0 * (mu[i] * dxi).real


# ------------------------------------------------------------ weights (StepWeights)
@numba.njit(**JIT)
def fill_weights(mu, delta, H, theta, dense, radius, terms, inv_fact, fact, z, phis, E_re, E_im, F_re,
                 F_im, wpos, wvel):
    """The variation-of-constants weights of one length H [s] (``exponential.StepWeights``):
    phi_0 .. phi_{K+1} at H mu (m,) (``phi_table``; z (m,), phis (K + 2, m) complex scratch),
    E (m,) = e^{H mu} and the forcing weights F (K + 1, m) = (H r!) phi_{r+1}(H mu) theta^r,
    over delta (m,) for the undamped bank (delta of size 0: the damped bank, whose forcing is
    P_vel c), real and imaginary parts apart; the joints' wpos (K + 1,) = H H r! / (r+2)!,
    wvel = H r! / (r+1)! for a step (dense False, theta 1), H^2 (r!/(r+2)!) theta^r and
    H (r!/(r+1)!) theta^r for a dense output at theta = H / h (the two orders of operations
    of the Python weights they replaced).  inv_fact, fact (>= terms + K + 3,) = 1/k!, k!."""
    K = F_re.shape[0] - 1
    nm = mu.shape[0]
    for i in range(nm):
        z[i] = H * mu[i]
    phi_table(z, K + 1, radius, terms, inv_fact, phis)
    for i in range(nm):
        E_re[i] = phis[0, i].real
        E_im[i] = phis[0, i].imag
    over = np.ones(nm, dtype=np.complex128)         # 1 / delta (undamped), 1 (damped)
    if delta.shape[0]:
        over = 1.0 / delta
    for r in range(K + 1):
        tp = theta ** float(r) if dense else 1.0
        hf = H * fact[r]
        for i in range(nm):
            f = hf * phis[r + 1, i] * tp * over[i]
            F_re[r, i] = f.real
            F_im[r, i] = f.imag
        if dense:
            wpos[r] = H ** 2 * (fact[r] / fact[r + 2]) * tp
            wvel[r] = H * (fact[r] / fact[r + 1]) * tp
        else:
            wpos[r] = H * H * fact[r] / fact[r + 2]
            wvel[r] = H * fact[r] / fact[r + 1]


# ------------------------------------------------------------ the Adams fits
@numba.njit(**JIT)
def poly_coefficients(nodes, values):
    """Monomial coefficients c (q, n) of the polynomial through (nodes[k], values[k]), nodes
    (q,) in units of the step, values (q, n): the q x q Vandermonde matrix (q <= 7) inverted
    by LAPACK gesv against the identity (as ``numpy.linalg.inv``), then one product."""
    q = nodes.shape[0]
    V = np.empty((q, q))
    for r in range(q):
        p = 1.0
        for k in range(q):
            V[r, k] = p
            p *= nodes[r]
    Vinv = np.linalg.solve(V, np.eye(q))
    return np.dot(Vinv, values)


# ------------------------------------------------------------ error measures
@numba.njit(**JIT)
def energy_norm(omega2, eta, etad):
    """sqrt(sum eta'^2 + omega^2 eta^2) of a modal state (n,) each: twice the linearised
    kinetic plus strain energy (joints included), the local error's scale."""
    return math.sqrt(np.dot(etad, etad) + np.dot(omega2 * eta, eta))


@numba.njit(**JIT)
def gimbal_rates(rates, v, out):
    """out (4,) = rates v: the four gimbal rows of phi (4, >= k) applied to a modal vector (k,)
    that holds the last k coordinates (k = n: the whole state; k = m: its elastic part)."""
    off = rates.shape[1] - v.shape[0]
    # BLAS: the loop's sum over c does not vectorise without reassociation (1.7 against ~0.4 us
    # for n = 404, measured); the same products to rounding
    out[:] = np.dot(np.ascontiguousarray(rates[:, off:]), v)


@numba.njit(**JIT)
def local_error(omega2, rates, energy_scale, rate_scale, eta_c, etad_c, eta_p, etad_p, energy_weight):
    """The relative local error of a step: the largest gimbal-rate difference of corrector -
    predictor (rates (4, n) = phi[:4]) over the largest gimbal rate so far (rate_scale [rad/s],
    or the corrector's): all four rates share that scale, so a rate that stays ~0 does not
    demand an absolute accuracy.  With energy_weight > 0, the larger of that and energy_weight
    x the energy norm of corrector - predictor over the largest energy norm of the solution
    (energy_scale, or the corrector's): every modal coordinate weighted by its energy (the
    default, weight 1: it holds the platform attitude too; docs/exponential.md Sec. 8)."""
    d_etad = etad_c - etad_p
    err = 0.0
    if energy_weight > 0.0:
        d_eta = eta_c - eta_p
        e_scale = max(energy_scale, energy_norm(omega2, eta_c, etad_c), 1e-300)
        err = energy_weight * energy_norm(omega2, d_eta, d_etad) / e_scale
    r = np.empty(N_JOINTS)
    gimbal_rates(rates, etad_c, r)
    r_scale = max(rate_scale, np.abs(r).max(), 1e-300)
    gimbal_rates(rates, d_etad, r)
    return max(err, np.abs(r).max() / r_scale)


@numba.njit(**JIT)
def accept_scales(omega2, eta, etad, yd, loop, rate_scales):
    """The error scales grow with an accepted state (eta, eta', y') (n,): the energy norm and
    the largest gimbal rate into the ``LOOP`` record loop (1,) (energy_scale, rate_scale), each
    gimbal rate's largest magnitude into rate_scales (4,) [rad/s]."""
    s = loop[0]
    s.energy_scale = max(s.energy_scale, energy_norm(omega2, eta, etad))
    s.rate_scale = max(s.rate_scale, np.abs(yd[:N_JOINTS]).max())
    for k in range(N_JOINTS):
        rate_scales[k] = max(rate_scales[k], abs(yd[k]))


@numba.njit(**STAGE)
def phase_error(b, st, rate_floor, eta, etad, h, drift0, drift1):
    """Add the phase every elastic mode gains in a step of h [s] while the gimbals drift from
    drift0 to drift1 [rad] (delta omega_i = kappa_i omega_i drift, st.phase) and return the
    error it causes: the larger of the energy norm of the state's change (``phase_shift``)
    over the solution's and of its gimbal rates, each over that rate's own scale (the phase
    error accumulates, and E weighs every rate against its own signal), floored at
    rate_floor of the largest (b, st: ``Basis``, ``State``)."""
    j = N_JOINTS
    w = b.omega[j:]
    nm = w.shape[0]
    st.phase[:] += st.kappa * w * 0.5 * (drift0 + drift1) * h
    d_eta = np.empty(nm)
    d_etad = np.empty(nm)
    phase_shift(b.mu, b.delta, b.P_eta, b.P_vel, b.V_eta, b.V_vel, b.phase_mode, st.phase, eta[j:],
                etad[j:], d_eta, d_etad)
    e_scale = max(st.loop[0].energy_scale, 1e-300)
    energy = math.sqrt(np.dot(d_etad, d_etad) + np.dot((w * d_eta) ** 2, np.ones(nm)))
    floor = rate_floor * max(st.loop[0].rate_scale, 1e-300)
    d_rates = np.empty(j)
    gimbal_rates(b.rates, d_etad, d_rates)
    rates = 0.0
    for k in range(j):
        rates = max(rates, abs(d_rates[k]) / max(st.rate_scales[k], floor))
    return max(energy / e_scale, rates)


# ------------------------------------------------------------ the basis as the loop uses it
# (arrays one by one, not the named tuples: every call passes only what it reads.  With the
# tuples passed whole, the loop took 2-3x longer to compile.)
@numba.njit(**STAGE)
def to_modal(y_ref, Lg, X, Ky, omega_ref, YT, y, yd, eta, etad):
    """(eta, eta') (n,) of a physical state (y, y') (n,): phi^-1 (y - y_ref), phi^-1 y'
    (``project``'s arrays)."""
    project(Lg, X, Ky, omega_ref, YT, y - y_ref, eta)
    project(Lg, X, Ky, omega_ref, YT, yd, etad)


@numba.njit(**STAGE)
def modal_forcing(Lg, X, Ky, omega_ref, YT, omega2, Ct, eta, etad, a, g):
    """g (n,) = phi^-1 a + Lambda eta + Ct eta': the modal forcing of the accelerations a (n,)
    at the modal state (eta, eta') (``project``'s and ``add_linear_terms``' arrays)."""
    project(Lg, X, Ky, omega_ref, YT, a, g)
    add_linear_terms(omega2, Ct, eta, etad, g)


@numba.njit(**JIT)
def advance_bank(mu, xi_re, xi_im, P_eta, P_vel, V_eta, V_vel, E_re, E_im, F_re, F_im, wpos, wvel,
                 H, eta, etad, coef, theta_pow, out_eta, out_etad):
    """The modal state after a length H [s] from (eta, eta') with the forcing polynomial coef
    (kk, n) (theta_pow (kk,) = theta^r, ones when folded into the weights), the weights
    (``fill_weights``) of that length: the undamped bank (P_eta of size 0: mu, and xi_re, xi_im
    of (eta, eta'), ``modal_xi``) or the damped one (P+, V+)."""
    if P_eta.shape[0]:
        coupled_advance(P_eta, P_vel, V_eta, V_vel, eta, etad, coef, theta_pow, E_re, E_im, F_re, F_im,
                        wpos, wvel, H, out_eta, out_etad)
    else:
        advance_diagonal(eta, etad, xi_re, xi_im, coef, theta_pow, E_re, E_im, F_re, F_im, wpos, wvel,
                         mu, H, out_eta, out_etad)


@numba.njit(**JIT)
def weights(keys, used, E_re, E_im, F_re, F_im, wpos, wvel, H, inv_fact, fact, z, phis, mu, delta,
            version, tick, radius, terms, m, offset):
    """The index of the cache entry (``WeightCache``'s arrays) of a length of ``offset`` ticks
    (tick [s]) inside a step of m ticks (offset = m: the step), filled on first use
    (``fill_weights``, the bank's mu, delta); the basis version ``version`` differing
    from the cache's empties it, and so does a full cache (a new pattern of steps)."""
    if used[1] != version:
        keys[:] = -1
        used[0] = 0
        used[1] = version
    filled = used[0]
    for c in range(filled):
        if keys[c, 0] == m and keys[c, 1] == offset:
            return c
    if filled == keys.shape[0]:
        keys[:] = -1
        filled = 0
    c = filled
    used[0] = filled + 1
    used[2] += 1
    fill_weights(mu, delta, offset * tick, offset / m, offset != m, radius, terms, inv_fact, fact, z,
                 phis, E_re[c], E_im[c], F_re[c], F_im[c], wpos[c], wvel[c])
    H[c] = offset * tick
    keys[c, 0] = m
    keys[c, 1] = offset
    return c


@numba.njit(**STAGE)
def advance_over(m, offset, eta, etad, xi_re, xi_im, coef, out_eta, out_etad, version, tick, radius,
                 terms, w, bank):
    """The modal state after ``offset`` ticks of a step of m ticks from (eta, eta') (n,) (xi_re,
    xi_im: the undamped bank's complex coordinates of it) with the forcing polynomial coef
    (kk, n), into out_eta, out_etad (n,): the cached weights of that length (``weights``: the
    ``WeightCache`` w of the basis ``version``, tick [s], the series radius and terms), then
    the bank's advance (``advance_bank``; bank = (mu, delta, P_eta, P_vel, V_eta, V_vel))."""
    mu, delta, P_eta, P_vel, V_eta, V_vel = bank
    c = weights(w.keys, w.used, w.E_re, w.E_im, w.F_re, w.F_im, w.wpos, w.wvel, w.H, w.inv_fact,
                w.fact, w.z, w.phis, mu, delta, version, tick, radius, terms, m, offset)
    advance_bank(mu, xi_re, xi_im, P_eta, P_vel, V_eta, V_vel, w.E_re[c], w.E_im[c], w.F_re[c],
                 w.F_im[c], w.wpos[c], w.wvel[c], w.H[c], eta, etad, coef, np.ones(coef.shape[0]),
                 out_eta, out_etad)


# ------------------------------------------------------------ the history
@numba.njit(**JIT)
def carry_history(y_ref, Lg, X, Ky, omega_ref, YT, omega2, Ct, hist_y, hist_yd, hist_a, hist_g,
                  length):
    """g of the first ``length`` stored nodes (``History``'s arrays) in the current basis, from
    their physical a, y, y'."""
    n = hist_y.shape[1]
    eta = np.empty(n)
    etad = np.empty(n)
    for k in range(length):
        to_modal(y_ref, Lg, X, Ky, omega_ref, YT, hist_y[k], hist_yd[k], eta, etad)
        modal_forcing(Lg, X, Ky, omega_ref, YT, omega2, Ct, eta, etad, hist_a[k], hist_g[k])


@numba.njit(**JIT)
def push_history(hist_t, hist_y, hist_yd, hist_a, hist_g, length, order, t, y, yd, a, g):
    """Insert an accepted node (t, y, y', a, g) as row 0 of the history arrays (``History``'s
    fields), keeping the newest order + 1; length (1,) the rows in use."""
    keep = min(length[0] + 1, order + 1)
    for k in range(keep - 1, 0, -1):
        hist_t[k] = hist_t[k - 1]
        hist_y[k] = hist_y[k - 1]
        hist_yd[k] = hist_yd[k - 1]
        hist_a[k] = hist_a[k - 1]
        hist_g[k] = hist_g[k - 1]
    hist_t[0] = t
    hist_y[0] = y
    hist_yd[0] = yd
    hist_a[0] = a
    hist_g[0] = g
    length[0] = keep


@numba.njit(**JIT)
def all_finite(x):
    for v in x.ravel():
        if not np.isfinite(v):
            return False
    return True


@numba.njit(**STAGE)
def accepted_joints(y_ref, rates, eta, etad, node_y, node_yd, predicted_node):
    """(2, 4): the accepted state's joint angles [rad] and rates [rad/s]: the newest node's
    (node_y, node_yd (n,)) when it is the accepted state (PECE), else from the modal state
    (eta, eta') (n,) by the gimbal rows of phi, rates (4, n): y[:4] = y_ref[:4] + phi[:4] eta."""
    out = np.empty((2, N_JOINTS))
    if predicted_node:
        gimbal_rates(rates, eta, out[0])
        gimbal_rates(rates, etad, out[1])
        for k in range(N_JOINTS):
            out[0, k] += y_ref[k]
    else:
        out[0] = node_y[:N_JOINTS]
        out[1] = node_yd[:N_JOINTS]
    return out


# ------------------------------------------------------------ the stages of a step
# Each stage reads and writes the containers (named tuples of arrays, the LOOP and SETTINGS
# records), returns a request to Python, DONE or CONTINUE, and sets Loop.stage to the next.
# The helpers they call take arrays one by one: every call passes only what it reads.
@numba.njit(**STAGE)
def history_nodes(hist_t, q, t, h, lead):
    """(lead + q,) nodes in units of the step h from t: lead free places (the corrector's
    1, the midpoint fit's 1 and 1/2), then (t_k - t) / h of the q newest history nodes
    (hist_t: ``History.t``)."""
    nodes = np.empty(lead + q)
    for k in range(q):
        nodes[lead + k] = (hist_t[k] - t) / h
    return nodes


@numba.njit(**STAGE)
def bank_of(b):
    """The oscillator bank's arrays of a ``Basis`` as ``advance_over`` takes them."""
    return (b.mu, b.delta, b.P_eta, b.P_vel, b.V_eta, b.V_vel)


@numba.njit(**STAGE)
def advance_step(b, w, c, work, m, offset, coef, out_eta, out_etad):
    """``advance_over`` from the step's start (work.eta, work.etad) with the basis b, the
    weight cache w and the settings record c."""
    advance_over(m, offset, work.eta, work.etad, work.xi_re, work.xi_im, coef, out_eta, out_etad,
                 b.version[0], c.tick, c.series_radius, c.series_terms, w, bank_of(b))


@numba.njit(**STAGE)
def physical_request(b, eta, etad, ev, t):
    """The physical form of a modal state (eta, eta') (n,) at t [s] into ev (a request's
    state)."""
    to_physical(b.y_ref, b.Lt, b.J, b.X, eta, etad, ev.y, ev.yd)
    ev.t[0] = t


@numba.njit(**STAGE)
def forcing_of(b, eta, etad, a, g):
    """``modal_forcing`` in the basis b: g (n,) of the accelerations a at (eta, eta')."""
    modal_forcing(b.Lg, b.X, b.Ky, b.omega_ref, b.YT, b.omega2, b.Ct, eta, etad, a, g)


@numba.njit(**STAGE)
def predict(b, w, cfg, st, hist, ev, work):
    """STEP: the step m (the rest of the run in whole output intervals if that is shorter,
    halved to fit), the predictor p through g at the last q = min(order, nodes) history nodes,
    the state advanced over h = m tick; asks for g at the predicted state."""
    c, s = cfg[0], st.loop[0]
    i, m = s.tick, s.step_ticks
    if i >= c.i_end:
        return DONE
    if m > c.i_end - i and i % c.ticks_per_output == 0 and not c.tol <= 0.0:
        m = c.i_end - i                     # the last step: the rest (output intervals)
    while m > c.i_end - i:
        m //= 2
    s.step_ticks = m
    h = m * c.tick
    t = i * c.tick
    q = min(c.order, hist.length[0])
    s.nodes = q
    if b.P_eta.shape[0] == 0:
        modal_xi(work.eta, work.etad, b.mu, b.delta, work.xi_re, work.xi_im)  # for every advance
    cP = poly_coefficients(history_nodes(hist.t, q, t, h, 0), hist.g[:q])
    advance_step(b, w, c, work, m, m, cP, work.eta_p, work.etad_p)
    physical_request(b, work.eta_p, work.etad_p, ev, t + h)
    s.evaluations += 1
    s.stage = PREDICTED
    return NEED_RHS


@numba.njit(**STAGE)
def correct(b, w, cfg, st, hist, ev, work):
    """PREDICTED: the corrector p through the predicted g at t + h and the same nodes, the
    local error of corrector - predictor.  The first step has one node: its predictor holds
    g(0), so from rest under a forcing that starts at zero (scene smooth) the predictor is
    exactly the rest state and the estimate is 100 % at every step size.  Instead: one more
    evaluation at the midpoint (MIDPOINT), the quadratic through g(0), g(h/2), g(h), and the
    difference quadratic - linear as the estimate (the higher order is kept)."""
    c, s = cfg[0], st.loop[0]
    i, m, q = s.tick, s.step_ticks, s.nodes
    h = m * c.tick
    t = i * c.tick
    n = work.eta.shape[0]
    forcing_of(b, work.eta_p, work.etad_p, ev.a, work.g_p)
    nodes = history_nodes(hist.t, q, t, h, 1)
    nodes[0] = 1.0
    values = np.empty((q + 1, n))
    values[0] = work.g_p
    values[1:] = hist.g[:q]
    work.coef[:q + 1] = poly_coefficients(nodes, values)
    s.coef_rows = q + 1
    advance_step(b, w, c, work, m, m, work.coef[:q + 1], work.eta_c, work.etad_c)
    finite = all_finite(work.g_p) and all_finite(work.eta_c) and all_finite(work.etad_c)
    s.error = local_error(b.omega2, b.rates, s.energy_scale, s.rate_scale, work.eta_c, work.etad_c,
                          work.eta_p, work.etad_p, c.error_energy_weight) if finite else np.inf
    s.finite = finite
    s.stage = DECIDE
    if finite and not c.tol <= 0.0 and q == 1 and m >= 2:
        advance_step(b, w, c, work, m, m // 2, work.coef[:q + 1], work.eta_q, work.etad_q)
        physical_request(b, work.eta_q, work.etad_q, ev, t + 0.5 * h)
        s.evaluations += 1
        s.stage = MIDPOINT
        return NEED_RHS
    return CONTINUE


@numba.njit(**STAGE)
def midpoint(b, w, cfg, st, hist, ev, work):
    """MIDPOINT: the first step's quadratic fit through g(h), g(h/2) and g(0); its state is
    the corrected one, its difference to the linear fit's the error estimate."""
    c, s = cfg[0], st.loop[0]
    i, m, q = s.tick, s.step_ticks, s.nodes
    h = m * c.tick
    t = i * c.tick
    n = work.eta.shape[0]
    forcing_of(b, work.eta_q, work.etad_q, ev.a, work.g_m)
    nodes = history_nodes(hist.t, q, t, h, 2)
    nodes[0], nodes[1] = 1.0, 0.5
    values = np.empty((q + 2, n))
    values[0] = work.g_p
    values[1] = work.g_m
    values[2:] = hist.g[:q]
    work.coef[:q + 2] = poly_coefficients(nodes, values)
    s.coef_rows = q + 2
    advance_step(b, w, c, work, m, m, work.coef[:q + 2], work.eta_q, work.etad_q)
    finite = all_finite(work.eta_q) and all_finite(work.etad_q)
    s.error = local_error(b.omega2, b.rates, s.energy_scale, s.rate_scale, work.eta_q, work.etad_q,
                          work.eta_c, work.etad_c, c.error_energy_weight) if finite else np.inf
    s.finite = finite
    work.eta_c[:] = work.eta_q
    work.etad_c[:] = work.etad_q
    s.stage = DECIDE
    return CONTINUE


@numba.njit(**STAGE)
def decide(b, cfg, st, ev, work):
    """DECIDE: accepted when the error is <= tol (ACCEPTED; with g at the accepted state under
    PECE, the predicted state's under PEC: cfg evaluate_accepted); a rejection halves m and,
    after max_rejections in an aged basis, asks for a new basis (RETRY)."""
    c, s = cfg[0], st.loop[0]
    i, m, q = s.tick, s.step_ticks, s.nodes
    h = m * c.tick
    t = i * c.tick
    err = s.error
    if not c.tol <= 0.0 and not err <= c.tol:
        s.rejected += 1
        s.rejections_in_basis += 1
        if c.relinearise and i > s.basis_tick and s.rejections_in_basis > c.max_rejections:
            # a new basis at the last accepted state; the step is retried in it
            physical_request(b, work.eta, work.etad, ev, t)
            s.stage = RETRY
            return NEED_BASIS
        if m == 1:
            s.failure = FAIL_STEP_TOO_SMALL
            s.event_time, s.event_step, s.event_value = t, h, err
            return FAILED
        s.step_ticks = m // 2
        s.since_change = 0
        s.stage = STEP
        return CONTINUE
    if not s.finite:
        s.failure = FAIL_NON_FINITE_STATE
        s.event_time = t + h
        return FAILED
    s.stage = ACCEPTED
    if not c.evaluate_accepted and s.coef_rows == q + 1:
        # PEC: the node at t + h keeps g, y, y', a of the predicted state (ev still holds
        # them; not after the first step's midpoint, which overwrote ev).  The final evaluation
        # at the corrected state would change g by dg/dy (y_c - y_p), the corrector's own
        # O(h^(q+1)) difference: the same order, one evaluation and two passes through X fewer
        # per step (docs/exponential.md Section 5)
        work.g_1[:] = work.g_p
        s.predicted_node = 1
        return CONTINUE
    physical_request(b, work.eta_c, work.etad_c, ev, t + h)
    s.evaluations += 1
    s.predicted_node = 0
    return NEED_RHS


@numba.njit(**STAGE)
def dense_outputs(b, w, c, s, out, work, coef, first, last):
    """The outputs first..last (indices) inside or at the end of the accepted step (Loop s,
    settings c) by the exact formula: the damped bank's all before t + h together, the step's
    start and forcing mapped to the bank once, the outputs back by one matrix product
    (``kernels.exponential.dense_coupled``); the undamped bank's from a step start on an output
    tick by the particular polynomial + free oscillation, one set of weights (one output
    interval) for all outputs before t + h (``kernels.exponential.dense_diagonal``); the others
    one advance each (the end of the step: the corrected state).  Returns the first output of the
    second kind (what the OUTPUTS request reports from)."""
    i, m = s.tick, s.step_ticks
    tpo = c.ticks_per_output
    inside = last - first + 1 if (i + m) % tpo else last - first     # outputs before t + h
    damped = b.P_eta.shape[0] > 0
    if inside >= 1 and (damped or i % tpo == 0):
        if damped:
            dense_coupled(work.eta, work.etad, coef, b.mu, b.P_eta, b.P_vel, b.V_real, m * c.tick,
                          c.tick, first * tpo - i, tpo, inside, c.series_radius, c.series_terms,
                          w.inv_fact, w.fact, out.eta[first:first + inside],
                          out.etad[first:first + inside])
        else:
            k = weights(w.keys, w.used, w.E_re, w.E_im, w.F_re, w.F_im, w.wpos, w.wvel, w.H,
                        w.inv_fact, w.fact, w.z, w.phis, b.mu, b.delta, b.version[0], c.tick,
                        c.series_radius, c.series_terms, tpo, tpo)
            dense_diagonal(work.eta, work.etad, work.xi_re, work.xi_im, coef, b.mu, b.delta,
                           m * c.tick, tpo * c.tick, inside, w.E_re[k], w.E_im[k], c.series_radius,
                           c.series_terms, w.inv_fact, w.fact, out.eta[first:first + inside],
                           out.etad[first:first + inside])
        for k in range(first, first + inside):
            out.segment[k] = s.segment
        first += inside
    for k in range(first, last + 1):
        offset = k * tpo - i
        if offset < m:
            advance_step(b, w, c, work, m, offset, coef, out.eta[k], out.etad[k])
        else:
            out.eta[k] = work.eta_c
            out.etad[k] = work.etad_c
        out.segment[k] = s.segment
    return first


@numba.njit(**STAGE)
def accept(b, w, cfg, st, hist, ev, out, work):
    """ACCEPTED: the outputs inside the step (``dense_outputs``), the node joins the history,
    the accepted state becomes the step's start, the error scales and counters grow, the
    gimbal drift from the basis and from the phase's angles; OUTPUTS if watched."""
    c, s = cfg[0], st.loop[0]
    i, m = s.tick, s.step_ticks
    h = m * c.tick
    t = i * c.tick
    tpo = c.ticks_per_output
    if not s.predicted_node:
        forcing_of(b, work.eta_c, work.etad_c, ev.a, work.g_1)
    if not all_finite(work.g_1):
        s.failure = FAIL_NON_FINITE_RHS
        s.event_time = t + h
        return FAILED
    first = i // tpo + 1
    last = (i + m) // tpo
    first = dense_outputs(b, w, c, s, out, work, work.coef[:s.coef_rows], first, last)
    push_history(hist.t, hist.y, hist.yd, hist.a, hist.g, hist.length, c.order, t + h,
                 ev.y, ev.yd, ev.a, work.g_1)
    work.eta[:] = work.eta_c
    work.etad[:] = work.etad_c
    joints = accepted_joints(b.y_ref, b.rates, work.eta, work.etad, hist.y[0], hist.yd[0],
                             s.predicted_node)
    accept_scales(b.omega2, work.eta, work.etad, joints[1], st.loop, st.rate_scales)
    s.steps += 1
    s.smallest_step = min(s.smallest_step, h)
    s.largest_step = max(s.largest_step, h)
    s.tick = i + m
    s.since_change += 1
    drift = 0.0
    phase_drift = 0.0
    for k in range(N_JOINTS):
        drift = max(drift, abs(joints[0, k] - b.y_ref[k]))
        phase_drift = max(phase_drift, abs(joints[0, k] - st.phase_ref[k]))
    s.drift, s.phase_drift = drift, phase_drift
    s.stage = PHASE
    if c.watch and last >= first:
        s.out_first, s.out_last = first, last
        s.event_step = h
        return OUTPUTS
    return CONTINUE


@numba.njit(**STAGE)
def probe(b, cfg, st, hist, ev, work):
    """PHASE (s.tick is the accepted tick from here on: t + h): the first basis's frequency
    probe once it has drifted probe_drift; the accepted state in ev, as for NEED_BASIS (under
    PECE the newest node's y, y' to the bit: the same transform of the same eta; under PEC that
    node is the predicted state)."""
    c, s = cfg[0], st.loop[0]
    s.stage = PHASE_ERROR
    if not c.tol <= 0.0 and c.relinearise and work.eta.shape[0] > N_JOINTS and not s.probed \
            and s.drift >= c.probe_drift:
        physical_request(b, work.eta, work.etad, ev, hist.t[0])
        s.event_value = s.drift
        return NEED_PROBE
    return CONTINUE


@numba.njit(**STAGE)
def check_phase(b, cfg, st, hist, ev, work):
    """PHASE_ERROR: the frozen frequencies' phase error of the step (``phase_error``) and what
    is due: new frequencies of the same shapes (UPDATED) or a new basis (REBASED) beyond the
    drift or the phase bound (fixed steps: every every_ticks), or the failure of a frozen basis
    beyond its validity; else GROW."""
    c, s = cfg[0], st.loop[0]
    i, m = s.tick, s.step_ticks
    h = m * c.tick
    fixed = c.tol <= 0.0
    nm = work.eta.shape[0] - N_JOINTS
    drift = s.drift
    phase_err = 0.0
    if not fixed and c.relinearise and nm > 0:
        phase_err = phase_error(b, st, c.rate_floor, work.eta, work.etad, h, s.drift_previous,
                                s.phase_drift)
    s.drift_previous = s.phase_drift
    s.stage = GROW
    if i < c.i_end:
        if fixed:
            due = c.every_ticks > 0 and i - s.basis_tick >= c.every_ticks
        else:
            due = c.relinearise and (drift > c.drift or phase_err > c.phase_bound)
            if due and drift <= c.drift:
                if (drift <= c.update_drift * c.drift and b.P_eta.shape[0] == 0
                        and nm >= c.update_min_modes):
                    physical_request(b, work.eta, work.etad, ev, hist.t[0])
                    work.omega2_old[:] = b.omega2
                    s.stage = UPDATED
                    return NEED_FREQUENCIES
                s.phase_relinearisations += 1
        if due:
            physical_request(b, work.eta, work.etad, ev, hist.t[0])
            s.stage = REBASED
            return NEED_BASIS
        if drift > c.frozen_validity and (not c.relinearise or fixed):
            s.failure = FAIL_FROZEN_DRIFT
            s.event_time, s.event_value = hist.t[0], drift
            return FAILED
    return CONTINUE


@numba.njit(**STAGE)
def carry_frequencies(b, st, hist, work):
    """UPDATED: new frequencies of the same shapes (undamped bank): X, y_ref and the projection
    are kept, so g = phi^-1 a + Lambda eta of each node moves by (Lambda_new - Lambda_old)
    eta_k, eta_k from one projection (carry_history's three projections per node give the
    same to rounding)."""
    s = st.loop[0]
    d_lambda = b.omega2 - work.omega2_old
    eta_k = np.empty(work.eta.shape[0])
    for k in range(hist.length[0]):
        project(b.Lg, b.X, b.Ky, b.omega_ref, b.YT, hist.y[k] - b.y_ref, eta_k)
        hist.g[k] += d_lambda * eta_k
    s.drift_previous = 0.0
    s.stage = GROW
    return CONTINUE


@numba.njit(**STAGE)
def rebase(b, st, hist, ev, work):
    """REBASED, RETRY: a new basis is there: the history's g in it, the accepted state (eta,
    eta') in it from its physical form that ``physical_request`` wrote into ev before
    NEED_BASIS (not the newest node: under PEC that is the predicted state); then GROW, or the
    step again (RETRY)."""
    s = st.loop[0]
    carry_history(b.y_ref, b.Lg, b.X, b.Ky, b.omega_ref, b.YT, b.omega2, b.Ct, hist.y, hist.yd,
                  hist.a, hist.g, hist.length[0])
    s.segment += 1
    s.rejections_in_basis = 0
    to_modal(b.y_ref, b.Lg, b.X, b.Ky, b.omega_ref, b.YT, ev.y, ev.yd, work.eta, work.etad)
    s.basis_tick = s.tick
    s.drift_previous = 0.0
    s.stage = GROW if s.stage == REBASED else STEP
    return CONTINUE


@numba.njit(**STAGE)
def grow(cfg, st):
    """GROW: the step doubles (dyadic, aligned: on a tick that is a multiple of 2 m) after two
    accepted steps at its size, one before the run's first rejection, when err 2^(q+1) <=
    grow_safety tol; then the next STEP."""
    c, s = cfg[0], st.loop[0]
    m = s.step_ticks
    wait = 1 if s.rejected == 0 else 2
    if not c.tol <= 0.0 and s.since_change >= wait and s.tick % (2 * m) == 0 \
            and s.error * 2.0 ** (s.nodes + 1) <= c.grow_safety * c.tol:
        s.step_ticks = 2 * m
        s.since_change = 0
    s.stage = STEP
    return CONTINUE


# ------------------------------------------------------------ the loop
@numba.njit(**JIT)
def pece_run(b, w, cfg, st, hist, ev, out, work):
    """The exponential Adams PEC / PECE loop from where it stopped (st.loop stage) to the next
    request or to the end (module docstring); returns DONE or the request.  b ``Basis``, w
    ``WeightCache``, cfg (1,) ``SETTINGS``, st ``State``, hist ``History``, ev ``Evaluation``,
    out ``Outputs``, work ``Work``.

    The algorithm is ``docs/exponential.md`` Sections 5-6, one function per stage: ``predict``
    (STEP), ``correct`` (PREDICTED), ``midpoint`` (MIDPOINT), ``decide`` (DECIDE), ``accept``
    (ACCEPTED), ``probe`` (PHASE), ``check_phase`` (PHASE_ERROR), ``carry_frequencies``
    (UPDATED), ``rebase`` (REBASED, RETRY), ``grow`` (GROW)."""
    loop = st.loop
    while True:
        stage = loop[0].stage
        if stage == STEP:
            r = predict(b, w, cfg, st, hist, ev, work)
        elif stage == PREDICTED:
            r = correct(b, w, cfg, st, hist, ev, work)
        elif stage == MIDPOINT:
            r = midpoint(b, w, cfg, st, hist, ev, work)
        elif stage == DECIDE:
            r = decide(b, cfg, st, ev, work)
        elif stage == ACCEPTED:
            r = accept(b, w, cfg, st, hist, ev, out, work)
        elif stage == PHASE:
            r = probe(b, cfg, st, hist, ev, work)
        elif stage == PHASE_ERROR:
            r = check_phase(b, cfg, st, hist, ev, work)
        elif stage == UPDATED:
            r = carry_frequencies(b, st, hist, work)
        elif stage == REBASED or stage == RETRY:
            r = rebase(b, st, hist, ev, work)
        else:
            r = grow(cfg, st)
        if r != CONTINUE:
            return r


# this module's entries compiled ahead of time, when built and current (kernels.extension)
extension.attach(__name__)
