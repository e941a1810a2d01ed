"""The exponential integrator's step loop, compiled (``gimbal_reduction.solver.dynamics.exponential``).

Why: the exponential Adams step of ``docs/exponential.md`` (Sections 4-6) is a few
dozen small array operations per step -- two polynomial fits, two phi-weighted advances
of the modal state, one or two physical transforms and projections (PEC or PECE), the
error norm, the dense
outputs, the phase-error estimate and the step-size decisions.  As NumPy calls from a
Python loop that cost ~0.3 ms per step on the truth model (~60 calls of ~5 us overhead
each) besides the arithmetic.  Here the whole loop is one compiled function, ``pece_run``.
It returns to Python only with a request for something Python owns, and is called again to
go on from where it stopped (st.ints[STAGE]):

* ``NEED_RHS``: the right-hand side a(t, y, y') at (ev.t, ev.y, ev.yd), written into ev.a by
  Python (the problem's own, compiled or not, wrapped or overridden: the loop never needs to
  know which); once per step attempt, and at the accepted state too under PECE;
* ``NEED_PROBE``, ``NEED_FREQUENCIES``, ``NEED_BASIS``: the first basis's frequency
  sensitivity, new frequencies of the same shapes, a new basis (eigenproblem) at the
  accepted state in ev (Section 6); Python rewrites the basis arrays ``b`` and the phase
  arrays of ``st`` in place, the loop then carries its history into the new basis;
* ``OUTPUTS`` (fixed steps only): outputs st.ints[OUT_FIRST..OUT_LAST] are new (the
  integrators' energy watch);
* ``FAILED``: the run cannot go on (st.ints[FAILURE] says why, st.reals the numbers);
* ``DONE``: the last output is reached.

Why a function called again and not a Numba generator that yields the requests: the
generator was the same code, but LLVM took ~460 s to optimise it against ~50 s for this
plain function (measured on the loaded 2-core machine; 20 s with NUMBA_OPT=0).  Why the
right-hand side is not evaluated in here (for the compiled one): it saved ~7 us per
evaluation (1 ms of a thesis truth run) but the recursion, linked into this function,
doubled its compile time (~50 s more).

Every array the loop and Python share is allocated once per run (``exponential.
ExponentialAdams``) and rewritten in place.  The arithmetic is that of the Python loop it
replaced, up to rounding: with the same formulas and order of operations the runs measured
gave the same steps and bitwise the same outputs; with the weights in real and imaginary
parts and the faster phi-functions since, the same steps and outputs within 1.5e-13
relative (the damped bank, whose eigenvectors amplify the rounding, within 4e-10), E
unchanged (docs/exponential.md Sec. 8).

The containers (named tuples, each field documented in its class): ``Basis`` b,
``WeightCache`` w, ``Settings`` cfg, ``State`` st, ``History`` hist, ``Evaluation`` ev,
``Outputs`` out, ``Work`` work.  Shapes: n coordinates (4 joint angles first), m = n - 4
elastic modes, K + 1 polynomial coefficients at most (K = max(order, 2): the first step's
midpoint fit has one node more than the corrector).  Units: s, rad, the chain's units.
"""

import math
from typing import NamedTuple

import numba
import numpy as np

from gimbal_reduction.solver.dynamics.kernels import JIT
from gimbal_reduction.solver.dynamics.kernels.exponential import advance_diagonal, dense_diagonal, modal_xi, phi_table

N_JOINTS = 4
# the undamped bank's dense outputs by the particular polynomial (dense_diagonal), not per-output weights
DENSE_POLYNOMIAL = True
# adaptive runs: the last step takes the rest of the run when that is whole output intervals
# (28 of them on thesis, instead of 16 + 8 + 4); before the run's first rejection the step may
# double after one accepted step at its size, not two (thesis truth: 41 -> 34 steps, the same
# E; docs/exponential.md Sec. 8 item 9)
LAST_STEP_REST = True
RAMP_UNTIL_REJECTION = True

# what pece_run returns: a request to Python, or DONE (module docstring)
DONE = 0
NEED_RHS = 1
NEED_PROBE = 2
NEED_FREQUENCIES = 3
NEED_BASIS = 4
OUTPUTS = 5
FAILED = 6

# where pece_run goes on when called again (st.ints[STAGE]); the step's order of work
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

# st.ints: the loop's integers between calls, counters and flags shared with Python
STAGE = 0                   # where to go on (above)
TICK = 1                    # i: the grid tick of the current state
STEP_TICKS = 2              # m: the step in ticks
SINCE_CHANGE = 3            # accepted steps since the step last changed
BASIS_TICK = 4              # the tick of the current basis
REJECTIONS_IN_BASIS = 5
SEGMENT = 6                 # the current basis's index in the run's list of bases
NODES = 7                   # q: history nodes of the current step's fits
COEF_ROWS = 8               # rows of work.coef in use (the corrector's polynomial)
STEPS = 9                   # accepted steps
REJECTED = 10               # rejected step attempts
EVALUATIONS = 11            # right-hand sides evaluated
PHASE_RELINEARISATIONS = 12  # bases asked for by the phase error (not the drift)
PROBED = 13                 # 1 once the current basis knows its frequency sensitivity (Python sets it)
OUT_FIRST = 14              # OUTPUTS: the first and last new output index
OUT_LAST = 15
FAILURE = 16                # FAILED: one of the FAIL_* causes below
PREDICTED_NODE = 17         # 1: the newest history node is the predicted state's (PEC, no final evaluation)
N_INTS = 18
# st.reals
SMALLEST_STEP = 0           # [s]
LARGEST_STEP = 1            # [s]
EVENT_TIME = 2              # [s] time of a basis request or a failure
EVENT_STEP = 3              # [s] the step h of a failure or of new outputs
EVENT_VALUE = 4             # a failure's error estimate, or the drift [rad] of a probe / frozen basis
ENERGY_SCALE = 5            # the error norm's scales: the largest energy norm of the solution so far
RATE_SCALE = 6              # ... and the largest gimbal rate so far [rad/s]
ERROR = 7                   # the current step's local error estimate
DRIFT = 8                   # [rad] the accepted state's gimbal drift from the basis's angles
PHASE_DRIFT = 9             # [rad] ... from the angles the phase is counted from
DRIFT_PREVIOUS = 10         # [rad] PHASE_DRIFT of the previous step (0 after a basis change)
N_REALS = 11
# failure causes (st.ints[FAILURE]); the messages are written in exponential.py
FAIL_STEP_TOO_SMALL = 1     # the step fell below the grid with the error above tol (t = EVENT_TIME)
FAIL_NON_FINITE_STATE = 2   # non-finite state after a step (t = EVENT_TIME)
FAIL_NON_FINITE_RHS = 3     # non-finite accelerations at an accepted state
FAIL_FROZEN_DRIFT = 4       # a frozen basis beyond its validity (EVENT_VALUE: the drift)


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
    / delta); damped (``CoupledBank``) mu (m,) and P_eta, P_vel, V_eta, V_vel (m, m) complex,
    Ct (m, m) [1/s] the modal damping (all (0, 0) undamped; delta of size 0 damped).
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


class Settings(NamedTuple):
    """What does not change during a run (``exponential`` constants and options, read from the
    module when the run starts): tol (local error per step; <= 0: fixed steps), tick [s] (the
    step grid: dt_out / ticks_per_output), ticks_per_output, i_end (the last tick), order (Adams
    predictor order), relinearise (bool), every_ticks
    (fixed steps: re-linearise every this many ticks, 0: never), drift [rad] (new basis beyond
    this gimbal drift), frozen_validity [rad], probe_drift [rad], phase_bound (the phase error
    that asks for new frequencies or a new basis: ``exponential.phase_bound``), update_drift
    (a phase error at a drift <= update_drift x drift: new frequencies), update_min_modes,
    max_rejections (in a basis that is not fresh), grow_safety, rate_floor, series_radius and
    series_terms (``phi_functions``), watch (bool: return OUTPUTS), error_energy_weight (the
    energy norm's weight in ``local_error``, 0: the gimbal rates alone), evaluate_accepted (bool:
    PECE, g at every accepted state; False: PEC, the accepted node keeps the predicted state's g,
    one evaluation per step; docs/exponential.md Section 5).  The first step and the
    tick the run starts at are st.ints[STEP_TICKS], st.ints[TICK], set by Python."""
    tol: float
    tick: float
    ticks_per_output: int
    i_end: int
    order: int
    relinearise: bool
    every_ticks: int
    drift: float
    frozen_validity: float
    probe_drift: float
    phase_bound: float
    update_drift: float
    update_min_modes: int
    max_rejections: int
    grow_safety: float
    rate_floor: float
    series_radius: float
    series_terms: int
    watch: bool
    error_energy_weight: float
    evaluate_accepted: bool


class State(NamedTuple):
    """The loop's state between calls and what Python reads or sets: ints (N_INTS,) and reals
    (N_REALS,) (indices above); rate_scales (4,) [rad/s] each gimbal rate's largest magnitude
    so far (the error norm's); phase (m,) [rad] the accumulated phase error estimate of the
    frozen frequencies, kappa (m,) [1/rad] their relative sensitivity to drift, phase_ref (4,)
    [rad] the angles the phase is counted from (Python resets the three on a new basis or a
    frequency update)."""
    ints: np.ndarray
    reals: np.ndarray
    rate_scales: np.ndarray
    phase: np.ndarray
    kappa: np.ndarray
    phase_ref: np.ndarray


class Work(NamedTuple):
    """The step's modal vectors (n,) each, kept between calls: eta, etad the current state (set
    by Python at the start), eta_p, etad_p the predicted, eta_c, etad_c the corrected, eta_q,
    etad_q the first step's midpoint and quadratic states; g_p, g_m, g_1 the modal forcing at
    the predicted state, the midpoint and the accepted state; coef (K + 2, n) the corrector's
    polynomial (st.ints[COEF_ROWS] rows), which the dense outputs reuse; xi_re, xi_im (m,) the
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
    predicted state's of the same time without (PEC, st.ints[PREDICTED_NODE]); the accepted
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
    ``kernels.exponential.advance_diagonal``): xi = P+ [eta; eta'] (m,) complex,
    xi <- E xi + sum_r W_r (P_vel theta^r c_r), (eta, eta') = 2 Re(V+ xi); the joints as in
    ``advance_diagonal``.  P_eta, P_vel, V_eta, V_vel (m, m) complex; E, W (real and imaginary
    parts, (m,) and (>= kk, m)) the weights of ``fill_weights``."""
    j = N_JOINTS
    kk = coef.shape[0]
    nm = eta.shape[0] - j
    xi = (E_re + 1j * E_im) * (np.dot(P_eta, eta[j:].astype(np.complex128))
                               + np.dot(P_vel, etad[j:].astype(np.complex128)))
    for r in range(kk):
        xi += np.dot(P_vel, (coef[r, j:] * theta_pow[r]).astype(np.complex128)) \
            * (W_re[r, :nm] + 1j * W_im[r, :nm])
    out_eta[j:] = 2.0 * np.dot(V_eta, xi).real
    out_etad[j:] = 2.0 * np.dot(V_vel, xi).real
    for a in range(j):
        p = eta[a] + H * etad[a]
        v = etad[a]
        for r in range(kk):
            p += wpos[r] * (coef[r, a] * theta_pow[r])
            v += wvel[r] * (coef[r, a] * theta_pow[r])
        out_eta[a] = p
        out_etad[a] = v


@numba.njit(**JIT)
def phase_shift(mu, delta, P_eta, P_vel, V_eta, V_vel, phase, eta_e, etad_e, d_eta, d_etad):
    """(d_eta, d_etad) (m,): the change of the elastic state (eta_e, etad_e) (m,) when mode i's
    complex coordinate turns by the phase phase_i [rad], xi_i -> xi_i + i phase_i xi_i: the
    undamped bank's (P_eta of size 0) xi = (eta' - conj(mu) eta) / delta, eta = 2 Re xi,
    eta' = 2 Re(mu xi); the damped bank's through its eigenvectors."""
    if P_eta.shape[0]:
        dxi = 1j * phase * (np.dot(P_eta, eta_e.astype(np.complex128))
                            + np.dot(P_vel, etad_e.astype(np.complex128)))
        d_eta[:] = 2.0 * np.dot(V_eta, dxi).real
        d_etad[:] = 2.0 * np.dot(V_vel, dxi).real
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
def local_error(omega2, rates, scales, eta_c, etad_c, eta_p, etad_p, energy_weight):
    """The relative local error of a step: the largest gimbal-rate difference of corrector -
    predictor (rates (4, n) = phi[:4]) over the largest gimbal rate so far (scales[RATE_SCALE],
    or the corrector's): all four rates share that scale, so a rate that stays ~0 does not
    demand an absolute accuracy.  With energy_weight > 0, the larger of that and energy_weight
    x the energy norm of corrector - predictor over the largest energy norm of the solution
    (scales[ENERGY_SCALE], or the corrector's): every modal coordinate weighted by its energy
    (the default, weight 1: it holds the platform attitude too; docs/exponential.md Sec. 8)."""
    d_etad = etad_c - etad_p
    err = 0.0
    if energy_weight > 0.0:
        d_eta = eta_c - eta_p
        e_scale = max(scales[ENERGY_SCALE], energy_norm(omega2, eta_c, etad_c), 1e-300)
        err = energy_weight * energy_norm(omega2, d_eta, d_etad) / e_scale
    r = np.empty(N_JOINTS)
    gimbal_rates(rates, etad_c, r)
    r_scale = max(scales[RATE_SCALE], np.abs(r).max(), 1e-300)
    gimbal_rates(rates, d_etad, r)
    return max(err, np.abs(r).max() / r_scale)


@numba.njit(**JIT)
def accept_scales(omega2, eta, etad, yd, scales, rate_scales):
    """The error scales grow with an accepted state (eta, eta', y') (n,): the energy norm and
    the largest gimbal rate into scales (ENERGY_SCALE, RATE_SCALE), each gimbal rate's largest
    magnitude into rate_scales (4,) [rad/s]."""
    scales[ENERGY_SCALE] = max(scales[ENERGY_SCALE], energy_norm(omega2, eta, etad))
    scales[RATE_SCALE] = max(scales[RATE_SCALE], np.abs(yd[:N_JOINTS]).max())
    for k in range(N_JOINTS):
        rate_scales[k] = max(rate_scales[k], abs(yd[k]))


@numba.njit(**JIT)
def phase_error(b, st, cfg, eta, etad, h, drift0, drift1):
    """Add the phase every elastic mode gains in a step of h [s] while the gimbals drift from
    drift0 to drift1 [rad] (delta omega_i = kappa_i omega_i drift, st.phase) and return the
    error it causes: the larger of the energy norm of the state's change (``phase_shift``)
    over the solution's and of its gimbal rates, each over that rate's own scale (the phase
    error accumulates, and E weighs every rate against its own signal), floored at
    rate_floor of the largest."""
    j = N_JOINTS
    w = b.omega[j:]
    nm = w.shape[0]
    st.phase[:] += st.kappa * w * 0.5 * (drift0 + drift1) * h
    d_eta = np.empty(nm)
    d_etad = np.empty(nm)
    phase_shift(b.mu, b.delta, b.P_eta, b.P_vel, b.V_eta, b.V_vel, st.phase, eta[j:], etad[j:],
                d_eta, d_etad)
    e_scale = max(st.reals[ENERGY_SCALE], 1e-300)
    energy = math.sqrt(np.dot(d_etad, d_etad) + np.dot((w * d_eta) ** 2, np.ones(nm)))
    floor = cfg.rate_floor * max(st.reals[RATE_SCALE], 1e-300)
    d_rates = np.empty(j)
    gimbal_rates(b.rates, d_etad, d_rates)
    rates = 0.0
    for k in range(j):
        rates = max(rates, abs(d_rates[k]) / max(st.rate_scales[k], floor))
    return max(energy / e_scale, rates)


# ------------------------------------------------------------ the basis as the loop uses it
# (arrays one by one, not the named tuples: every call passes only what it reads.  With the
# tuples passed whole, the loop took 2-3x longer to compile.)
@numba.njit(**JIT)
def to_modal(y_ref, Lg, X, Ky, omega_ref, YT, y, yd, eta, etad):
    """(eta, eta') (n,) of a physical state (y, y') (n,): phi^-1 (y - y_ref), phi^-1 y'
    (``project``'s arrays)."""
    project(Lg, X, Ky, omega_ref, YT, y - y_ref, eta)
    project(Lg, X, Ky, omega_ref, YT, yd, etad)


@numba.njit(**JIT)
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


@numba.njit(**JIT)
def advance_over(m, offset, eta, etad, xi, coef, out_eta, out_etad, grid, keys, used, E_re, E_im,
                 F_re, F_im, wpos, wvel, H, inv_fact, fact, z, phis, mu, delta, P_eta, P_vel, V_eta, V_vel):
    """The modal state after ``offset`` ticks of a step of m ticks from (eta, eta') (n,) (xi: the
    undamped bank's (xi_re, xi_im) of it) with the forcing polynomial coef (kk, n), into
    out_eta, out_etad (n,): the cached weights of that length (``weights``; grid = (basis
    version, tick [s], series radius, series terms), then the ``WeightCache`` arrays), the
    bank's advance (``advance_bank``: mu, delta, P+, V+)."""
    version, tick, radius, terms = grid
    c = weights(keys, used, E_re, E_im, F_re, F_im, wpos, wvel, H, inv_fact, fact, z, phis, mu, delta,
                version, tick, radius, terms, m, offset)
    advance_bank(mu, xi[0], xi[1], P_eta, P_vel, V_eta, V_vel, E_re[c], E_im[c], F_re[c], F_im[c],
                 wpos[c], wvel[c], H[c], eta, etad, coef, np.ones(coef.shape[0]), out_eta, out_etad)


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


@numba.njit(**JIT)
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


# ------------------------------------------------------------ the loop
@numba.njit(**JIT)
def history_nodes(hist, q, t, h, lead):
    """(lead + q,) nodes in units of the step h from t: lead free places (the corrector's
    1, the midpoint fit's 1 and 1/2), then (t_k - t) / h of the q newest history nodes."""
    nodes = np.empty(lead + q)
    for k in range(q):
        nodes[lead + k] = (hist.t[k] - t) / h
    return nodes


@numba.njit(**JIT)
def pece_run(b_y_ref, b_X, b_YT, b_Ky, b_omega_ref, b_omega, b_omega2, b_Lt, b_J, b_Lg, b_rates,
             b_mu, b_delta, b_P_eta, b_P_vel, b_V_eta, b_V_vel, b_Ct, b_version, w_keys, w_E_re,
             w_E_im, w_F_re, w_F_im, w_wpos, w_wvel, w_H, w_used, w_inv_fact, w_fact, w_z, w_phis,
             cfg_tol, cfg_tick, cfg_ticks_per_output, cfg_i_end, cfg_order, cfg_relinearise,
             cfg_every_ticks, cfg_drift, cfg_frozen_validity, cfg_probe_drift, cfg_phase_bound,
             cfg_update_drift, cfg_update_min_modes, cfg_max_rejections, cfg_grow_safety,
             cfg_rate_floor, cfg_series_radius, cfg_series_terms, cfg_watch,
             cfg_error_energy_weight, cfg_evaluate_accepted, st_ints, st_reals, st_rate_scales, st_phase, st_kappa,
             st_phase_ref, hist_t, hist_y, hist_yd, hist_a,
             hist_g, hist_length, ev_t, ev_y, ev_yd, ev_a, out_eta, out_etad, out_segment,
             work_eta, work_etad, work_eta_p, work_etad_p, work_eta_c, work_etad_c, work_eta_q,
             work_etad_q, work_g_p, work_g_m, work_g_1, work_coef, work_xi_re, work_xi_im,
             work_omega2_old):
    """The exponential Adams PEC / PECE loop from where it stopped (st.ints[STAGE]) to the next
    request or to the end (module docstring); returns DONE or the request.

    Arguments: the fields of the eight containers in order,
    ``pece_run(*b, *w, *cfg, *st, *hist, *ev, *out, *work)``.
    The containers are built here: handing Numba's dispatcher named tuples of many arrays
    costs ~0.3 ms per call (``gimbal_reduction.solver.dynamics.compiled``), the arrays one by one a few us; and
    the loop is this function's body, not a second function, because LLVM's optimisation of
    the one inlined into the other took ~90 s more to compile.

    The algorithm is ``docs/exponential.md`` Sections 5-6, stage by stage:

    * STEP, predict: p through g at the last q = min(order, nodes) history nodes, the state
      advanced over h = m tick; g at the predicted state;
    * PREDICTED, correct: p through the predicted g at t + h and the same nodes, the local
      error of corrector - predictor; the first step (one node) adds a midpoint evaluation
      (MIDPOINT) and the quadratic fit, its estimate quadratic - linear;
    * DECIDE: accepted when the error is <= tol (ACCEPTED; with g at the accepted state
      under PECE, the predicted state's under PEC: cfg.evaluate_accepted); a
      rejection halves m and, after max_rejections in an aged basis, asks for a new basis
      (RETRY);
    * ACCEPTED: the outputs at the output ticks inside the step by the exact formula (dense),
      the node joins the history, the gimbal drift; PHASE: the first basis's frequency
      probe once it has drifted probe_drift; PHASE_ERROR: the phase error, new frequencies
      (UPDATED) or a new basis (REBASED) when due;
    * GROW: the step doubles after two accepted steps (one before the run's first rejection,
      ``RAMP_UNTIL_REJECTION``) when err 2^(q+1) <= grow_safety tol on a tick that is a
      multiple of 2 m; the last step takes the rest in whole output intervals
      (``LAST_STEP_REST``)."""
    b = Basis(b_y_ref, b_X, b_YT, b_Ky, b_omega_ref, b_omega, b_omega2, b_Lt, b_J, b_Lg, b_rates,
              b_mu, b_delta, b_P_eta, b_P_vel, b_V_eta, b_V_vel, b_Ct, b_version)
    w = WeightCache(w_keys, w_E_re, w_E_im, w_F_re, w_F_im, w_wpos, w_wvel, w_H, w_used,
                    w_inv_fact, w_fact, w_z, w_phis)
    cfg = Settings(cfg_tol, cfg_tick, cfg_ticks_per_output, cfg_i_end, cfg_order, cfg_relinearise,
                   cfg_every_ticks, cfg_drift, cfg_frozen_validity, cfg_probe_drift,
                   cfg_phase_bound, cfg_update_drift, cfg_update_min_modes, cfg_max_rejections,
                   cfg_grow_safety, cfg_rate_floor, cfg_series_radius, cfg_series_terms,
                   cfg_watch, cfg_error_energy_weight, cfg_evaluate_accepted)
    st = State(st_ints, st_reals, st_rate_scales, st_phase, st_kappa, st_phase_ref)
    hist = History(hist_t, hist_y, hist_yd, hist_a, hist_g, hist_length)
    ev = Evaluation(ev_t, ev_y, ev_yd, ev_a)
    out = Outputs(out_eta, out_etad, out_segment)
    work = Work(work_eta, work_etad, work_eta_p, work_etad_p, work_eta_c, work_etad_c, work_eta_q,
                work_etad_q, work_g_p, work_g_m, work_g_1, work_coef, work_xi_re, work_xi_im,
                work_omega2_old)
    j = N_JOINTS
    n = work.eta.shape[0]
    nm = n - j
    fixed = cfg.tol <= 0.0
    tpo = cfg.ticks_per_output
    tick = cfg.tick
    ints, reals = st.ints, st.reals
    eta, etad = work.eta, work.etad
    eta_p, etad_p, eta_c, etad_c = work.eta_p, work.etad_p, work.eta_c, work.etad_c
    eta_q, etad_q = work.eta_q, work.etad_q
    # the arrays the helpers take, grouped and star-unpacked into the calls: the helpers take
    # arrays one by one, not the containers (passing the containers whole made this function
    # take 2-3x longer to compile: every call passes every field)
    physical_map = (b.y_ref, b.Lt, b.J, b.X)                # to_physical
    projection = (b.Lg, b.X, b.Ky, b.omega_ref, b.YT)       # project
    linear = (b.omega2, b.Ct)                               # add_linear_terms
    bank = (b.mu, b.delta, b.P_eta, b.P_vel, b.V_eta, b.V_vel)
    cache = (w.keys, w.used, w.E_re, w.E_im, w.F_re, w.F_im, w.wpos, w.wvel, w.H, w.inv_fact, w.fact, w.z,
             w.phis)
    xi = (work.xi_re, work.xi_im)
    grid = (b.version[0], tick, cfg.series_radius, cfg.series_terms)
    finite = True
    while True:
        stage = ints[STAGE]
        i = ints[TICK]
        m = ints[STEP_TICKS]
        q = ints[NODES]
        h = m * tick
        t = i * tick
        if stage == STEP:
            if i >= cfg.i_end:
                return DONE
            if LAST_STEP_REST and m > cfg.i_end - i and i % tpo == 0 and not fixed:
                m = cfg.i_end - i                   # the last step: the rest (output intervals)
            while m > cfg.i_end - i:
                m //= 2
            ints[STEP_TICKS] = m
            h = m * tick
            q = min(cfg.order, hist.length[0])
            ints[NODES] = q
            if b.P_eta.shape[0] == 0:
                modal_xi(eta, etad, b.mu, b.delta, work.xi_re, work.xi_im)    # for every advance below
            cP = poly_coefficients(history_nodes(hist, q, t, h, 0), hist.g[:q])
            advance_over(m, m, eta, etad, xi, cP, eta_p, etad_p, grid, *cache, *bank)
            to_physical(*physical_map, eta_p, etad_p, ev.y, ev.yd)
            ev.t[0] = t + h
            ints[EVALUATIONS] += 1
            ints[STAGE] = PREDICTED
            return NEED_RHS
        elif stage == PREDICTED:
            modal_forcing(*projection, *linear, eta_p, etad_p, ev.a, work.g_p)
            nodes = history_nodes(hist, q, t, h, 1)
            nodes[0] = 1.0
            values = np.empty((q + 1, n))
            values[0] = work.g_p
            values[1:] = hist.g[:q]
            work.coef[:q + 1] = poly_coefficients(nodes, values)
            ints[COEF_ROWS] = q + 1
            advance_over(m, m, eta, etad, xi, work.coef[:q + 1], eta_c, etad_c, grid, *cache, *bank)
            finite = all_finite(work.g_p) and all_finite(eta_c) and all_finite(etad_c)
            reals[ERROR] = local_error(b.omega2, b.rates, reals, eta_c, etad_c, eta_p, etad_p,
                                       cfg.error_energy_weight) \
                if finite else np.inf
            ints[STAGE] = DECIDE
            if finite and not fixed and q == 1 and m >= 2:
                # The first step has one node: its predictor holds g(0), so from rest under a
                # forcing that starts at zero (scene smooth) the predictor is exactly the rest
                # state and the estimate is 100 % at every step size.  Instead: one more
                # evaluation at the midpoint, the quadratic through g(0), g(h/2), g(h), and the
                # difference quadratic - linear as the estimate (the higher order is kept).
                advance_over(m, m // 2, eta, etad, xi, work.coef[:q + 1], eta_q, etad_q, grid, *cache,
                             *bank)
                to_physical(*physical_map, eta_q, etad_q, ev.y, ev.yd)
                ev.t[0] = t + 0.5 * h
                ints[EVALUATIONS] += 1
                ints[STAGE] = MIDPOINT
                return NEED_RHS
        elif stage == MIDPOINT:
            modal_forcing(*projection, *linear, eta_q, etad_q, ev.a, work.g_m)
            nodes = history_nodes(hist, q, t, h, 2)
            nodes[0], nodes[1] = 1.0, 0.5
            values = np.empty((q + 2, n))
            values[0] = work.g_p
            values[1] = work.g_m
            values[2:] = hist.g[:q]
            work.coef[:q + 2] = poly_coefficients(nodes, values)
            ints[COEF_ROWS] = q + 2
            advance_over(m, m, eta, etad, xi, work.coef[:q + 2], eta_q, etad_q, grid, *cache, *bank)
            finite = all_finite(eta_q) and all_finite(etad_q)
            reals[ERROR] = local_error(b.omega2, b.rates, reals, eta_q, etad_q, eta_c, etad_c,
                                       cfg.error_energy_weight) \
                if finite else np.inf
            eta_c[:] = eta_q
            etad_c[:] = etad_q
            ints[STAGE] = DECIDE
        elif stage == DECIDE:
            err = reals[ERROR]
            if not fixed and not err <= cfg.tol:
                ints[REJECTED] += 1
                ints[REJECTIONS_IN_BASIS] += 1
                if cfg.relinearise and i > ints[BASIS_TICK] \
                        and ints[REJECTIONS_IN_BASIS] > cfg.max_rejections:
                    # a new basis at the last accepted state; the step is retried in it
                    to_physical(*physical_map, eta, etad, ev.y, ev.yd)
                    ev.t[0] = t
                    ints[STAGE] = RETRY
                    return NEED_BASIS
                if m == 1:
                    ints[FAILURE] = FAIL_STEP_TOO_SMALL
                    reals[EVENT_TIME], reals[EVENT_STEP], reals[EVENT_VALUE] = t, h, err
                    return FAILED
                ints[STEP_TICKS] = m // 2
                ints[SINCE_CHANGE] = 0
                ints[STAGE] = STEP
                continue
            if not finite:
                ints[FAILURE] = FAIL_NON_FINITE_STATE
                reals[EVENT_TIME] = t + h
                return FAILED
            ints[STAGE] = ACCEPTED
            if not cfg.evaluate_accepted and ints[COEF_ROWS] == q + 1:
                # PEC: the node at t + h keeps g, y, y', a of the predicted state (ev still
                # holds them; not after the first step's midpoint, which overwrote ev).  The
                # final evaluation at the corrected state would change g by dg/dy (y_c - y_p),
                # the corrector's own O(h^(q+1)) difference: the same order, one evaluation
                # and two passes through X fewer per step (docs/exponential.md Section 5)
                work.g_1[:] = work.g_p
                ints[PREDICTED_NODE] = 1
                continue
            to_physical(*physical_map, eta_c, etad_c, ev.y, ev.yd)
            ev.t[0] = t + h
            ints[EVALUATIONS] += 1
            ints[PREDICTED_NODE] = 0
            return NEED_RHS
        elif stage == ACCEPTED:
            if not ints[PREDICTED_NODE]:
                modal_forcing(*projection, *linear, eta_c, etad_c, ev.a, work.g_1)
            if not all_finite(work.g_1):
                ints[FAILURE] = FAIL_NON_FINITE_RHS
                reals[EVENT_TIME] = t + h
                return FAILED
            coef = work.coef[:ints[COEF_ROWS]]
            first = i // tpo + 1
            last = (i + m) // tpo
            inside = last - first + 1 if (i + m) % tpo else last - first   # outputs before t + h
            if DENSE_POLYNOMIAL and b.P_eta.shape[0] == 0 and i % tpo == 0 and inside >= 1:
                # the undamped bank: particular polynomial + free oscillation, one set of weights
                # (one output interval) for all outputs (kernels.exponential.dense_diagonal)
                c = weights(*cache, *bank[:2], grid[0], tick, grid[2], grid[3], tpo, tpo)
                dense_diagonal(eta, etad, work.xi_re, work.xi_im, coef, b.mu, b.delta, h, tpo * tick,
                               inside, w.E_re[c], w.E_im[c], cfg.series_radius, cfg.series_terms,
                               w.inv_fact, w.fact, out.eta[first:first + inside],
                               out.etad[first:first + inside])
                for k in range(first, first + inside):
                    out.segment[k] = ints[SEGMENT]
                first += inside
            for k in range(first, last + 1):
                offset = k * tpo - i
                if offset < m:
                    advance_over(m, offset, eta, etad, xi, coef, out.eta[k], out.etad[k], grid, *cache,
                                 *bank)
                else:
                    out.eta[k] = eta_c
                    out.etad[k] = etad_c
                out.segment[k] = ints[SEGMENT]
            push_history(hist.t, hist.y, hist.yd, hist.a, hist.g, hist.length, cfg.order, t + h,
                         ev.y, ev.yd, ev.a, work.g_1)
            eta[:] = eta_c
            etad[:] = etad_c
            joints = accepted_joints(b.y_ref, b.rates, eta, etad, hist.y[0], hist.yd[0],
                                     ints[PREDICTED_NODE])
            accept_scales(b.omega2, eta, etad, joints[1], reals, st.rate_scales)
            ints[STEPS] += 1
            reals[SMALLEST_STEP] = min(reals[SMALLEST_STEP], h)
            reals[LARGEST_STEP] = max(reals[LARGEST_STEP], h)
            ints[TICK] = i + m
            ints[SINCE_CHANGE] += 1
            drift = 0.0
            phase_drift = 0.0
            for k in range(j):
                drift = max(drift, abs(joints[0, k] - b.y_ref[k]))
                phase_drift = max(phase_drift, abs(joints[0, k] - st.phase_ref[k]))
            reals[DRIFT], reals[PHASE_DRIFT] = drift, phase_drift
            ints[STAGE] = PHASE
            if cfg.watch and last >= first:
                ints[OUT_FIRST], ints[OUT_LAST] = first, last
                reals[EVENT_STEP] = h
                return OUTPUTS
        elif stage == PHASE:                # i is the accepted tick from here on: t + h = i tick
            ints[STAGE] = PHASE_ERROR
            if not fixed and cfg.relinearise and nm > 0 and not ints[PROBED] \
                    and reals[DRIFT] >= cfg.probe_drift:
                # the accepted state in ev, as for NEED_BASIS (under PECE the newest node's
                # y, y' to the bit: the same transform of the same eta; under PEC that node is
                # the predicted state)
                to_physical(*physical_map, eta, etad, ev.y, ev.yd)
                ev.t[0] = hist.t[0]
                reals[EVENT_VALUE] = reals[DRIFT]
                return NEED_PROBE
        elif stage == PHASE_ERROR:
            drift = reals[DRIFT]
            phase_err = 0.0
            if not fixed and cfg.relinearise and nm > 0:
                phase_err = phase_error(b, st, cfg, eta, etad, h,
                                        reals[DRIFT_PREVIOUS], reals[PHASE_DRIFT])
            reals[DRIFT_PREVIOUS] = reals[PHASE_DRIFT]
            ints[STAGE] = GROW
            if i < cfg.i_end:
                if fixed:
                    due = cfg.every_ticks > 0 and i - ints[BASIS_TICK] >= cfg.every_ticks
                else:
                    due = cfg.relinearise and (drift > cfg.drift
                                               or phase_err > cfg.phase_bound)
                    if due and drift <= cfg.drift:
                        if (drift <= cfg.update_drift * cfg.drift and b.P_eta.shape[0] == 0
                                and nm >= cfg.update_min_modes):
                            to_physical(*physical_map, eta, etad, ev.y, ev.yd)
                            ev.t[0] = hist.t[0]
                            work.omega2_old[:] = b.omega2
                            ints[STAGE] = UPDATED
                            return NEED_FREQUENCIES
                        ints[PHASE_RELINEARISATIONS] += 1
                if due:
                    to_physical(*physical_map, eta, etad, ev.y, ev.yd)
                    ev.t[0] = hist.t[0]
                    ints[STAGE] = REBASED
                    return NEED_BASIS
                if drift > cfg.frozen_validity and (not cfg.relinearise or fixed):
                    ints[FAILURE] = FAIL_FROZEN_DRIFT
                    reals[EVENT_TIME], reals[EVENT_VALUE] = hist.t[0], drift
                    return FAILED
        elif stage == UPDATED:
            # new frequencies of the same shapes (undamped bank): X, y_ref and the projection
            # are kept, so g = phi^-1 a + Lambda eta of each node moves by (Lambda_new -
            # Lambda_old) eta_k, eta_k from one projection (carry_history's three projections
            # per node give the same to rounding)
            d_lambda = b.omega2 - work.omega2_old
            eta_k = np.empty(n)
            for k in range(hist.length[0]):
                project(*projection, hist.y[k] - b.y_ref, eta_k)
                hist.g[k] += d_lambda * eta_k
            reals[DRIFT_PREVIOUS] = 0.0
            ints[STAGE] = GROW
        elif stage == REBASED or stage == RETRY:
            carry_history(b.y_ref, *projection, *linear, hist.y, hist.yd, hist.a, hist.g,
                          hist.length[0])
            ints[SEGMENT] += 1
            ints[REJECTIONS_IN_BASIS] = 0
            # the accepted state (eta, eta') in the new basis, from its physical form that
            # to_physical wrote into ev before NEED_BASIS (not the newest node: under PEC
            # that is the predicted state)
            to_modal(b.y_ref, *projection, ev.y, ev.yd, eta, etad)
            ints[BASIS_TICK] = i
            reals[DRIFT_PREVIOUS] = 0.0
            ints[STAGE] = GROW if stage == REBASED else STEP
        else:                               # GROW (dyadic, aligned, after >= 2 steps at this size,
            #                                   >= 1 before the run's first rejection)
            wait = 1 if RAMP_UNTIL_REJECTION and ints[REJECTED] == 0 else 2
            if not fixed and ints[SINCE_CHANGE] >= wait and i % (2 * m) == 0 \
                    and reals[ERROR] * 2.0 ** (q + 1) <= cfg.grow_safety * cfg.tol:
                ints[STEP_TICKS] = 2 * m
                ints[SINCE_CHANGE] = 0
            ints[STAGE] = STEP
