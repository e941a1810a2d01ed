"""Modal exponential integrator: the linearised chain solved exactly, the rest by Adams.

Why: every time stepper that treats the chain's fast modes numerically (explicit or
implicit) must keep the phase of modes up to ~2e6 rad/s right over the window, so
it needs ~1e5 steps on the truth model (docs/exponential.md, Section 1).  Here the
fast modes are never stepped: their oscillators are solved in closed form and the
step is set by the smoothness of what is left.

The equations (``docs/exponential.md`` has the derivation).  Linearise at a
configuration y_r: M0 = M(y_r), K = diag(0_4, Omega^2), modal damping
C = diag(0_4, 2 zeta Omega).  The coupled modes Phi (n, n) solve K Phi = M0 Phi Lambda
with Phi^T M0 Phi = I: four joint modes (Lambda = 0, Phi_r = [L^-T; 0], M0_gg = L L^T)
and the elastic ones (``linearized.free_joint_basis``).  Write y = y_r + Phi eta,
y_r holding the linearisation angles and zero elastic coordinates.  With
a(t, y, y') the full nonlinear accelerations (the project's right-hand side),

    eta'' + Ct eta' + Lambda eta = g(t, eta, eta'),
    g = Phi^T M0 a + Lambda eta + Ct eta',          Ct = Phi^T C Phi,

is exact (g just moves the linear part to the left).  g holds the case forcing and
every nonlinear and coupling term; while the gimbals stay
near y_r it is small and slow.  Undamped, each elastic mode (eigenvalues lambda,
conj lambda, lambda = i omega) is one complex coordinate xi = (eta' - conj(lambda) eta) /
Delta, Delta = 2 i omega, with eta = 2 Re xi, eta' = 2 Re(lambda xi) and
xi' = lambda xi + g / Delta (``DiagonalBank``); with damping, the damped elastic block is
diagonalised in state space the same way, at any damping (``CoupledBank``: xi' = mu xi + P g,
mu real for an overdamped mode); a joint
mode is eta'' = g.
Over a step t_n -> t_n + H with g replaced by a polynomial
p(s) = sum_j c_j (s / h)^j the variation-of-constants formula is exact:

    xi(t_n + H) = e^{H lambda} xi_n + (H / Delta) sum_j c_j (H / h)^j j! phi_{j+1}(H lambda),
    eta(t_n + H) = eta_n + H eta'_n + H^2 sum_j c_j (H / h)^j j! / (j + 2)!   (joint modes),
    eta'(t_n + H) = eta'_n + H sum_j c_j (H / h)^j j! / (j + 1)!,

phi_0(z) = e^z, phi_{j+1}(z) = (phi_j(z) - 1/j!) / z (``phi_functions``).  H = h is the
step, H < h the dense output at the scene's output times.

The scheme: exponential Adams, predict-evaluate-correct.  The predictor's p interpolates g
at the last q accepted times (order q), the corrector's adds the predicted g at t_n + h
(order q + 1); every node pattern is handled by a q x q Vandermonde solve, so variable
steps cost nothing extra.  Adaptive runs end the step there (PEC): the accepted node keeps
the predicted state's g, one right-hand side per step; fixed steps evaluate again at the
corrected state (PECE; ``ExponentialOptions.evaluate_accepted``, docs/exponential.md Sec. 5).  The difference corrector - predictor estimates the local
error, in the energy norm of every modal coordinate and in the gimbal rates
(``kernels.pece.local_error``); the step is halved or doubled on a
dyadic grid of the output interval, so dense outputs reuse cached weights.  The basis is rebuilt
(re-linearised) when the gimbal angles drift from y_r by more than ``drift`` [rad], or when
steps keep failing in an aged basis; the stored history of accelerations is carried over.
A run that cannot hold (steps below the floor, a singular joint mass matrix, a damped bank
that cannot be diagonalised, a frozen basis beyond its validity) stops with ``ExponentialError`` naming the
time and the cause.

The step loop is compiled (``kernels.pece.pece_run``, docs/exponential.md Sec. 8): this
module builds the bases, answers the loop's requests (right-hand sides, bases, frequency
updates) and holds the Python forms of its pieces (``ModalBasis``' transforms,
``StepWeights``, ``advance``), which call the same compiled helpers.

Units: in, lbf, s, rad as everywhere (``gimbal_reduction.solver.dynamics.multibody``).
"""

import math
import time
from dataclasses import asdict, dataclass, field, replace

import numpy as np
import scipy.linalg

from gimbal_reduction.solver.dynamics.kernels import extension
from gimbal_reduction.solver.dynamics.kernels import exponential as kernels
from gimbal_reduction.solver.dynamics.kernels import pece
from gimbal_reduction.solver.dynamics.linearized import free_joint_basis, free_joint_frequencies

N_JOINTS = 4
JOINT_MASS_COND = 1e12     # refuse a basis whose joint mass block is this ill-conditioned
SERIES_RADIUS = 2.0        # |z| below which phi_j uses its Taylor series
SERIES_TERMS = 30


TOL_FLOOR = 1e-13           # [1] the smallest tolerance: a local error in double precision
#                             is rounding below it (the state's own ~1e-16 times the step's terms)


@dataclass(frozen=True)
class ExponentialOptions:
    """The exponential integrator's options (module docstring; docs/exponential.md Sections 5-8
    give each its reason and measurements).  Adaptive (tol) or fixed steps (step), not both.

    tol [1]: the local error per step, relative (``kernels.pece.local_error``); None: 1e-5
        unless a fixed step is given (Section 5).
    step [s]: a fixed step (PECE, the start-up block; no error control); None: adaptive.
    relinearise_every [s]: fixed steps only, a new basis every this long (None: never).
    order: the Adams predictor order q, 1..6 (the corrector's q + 1).
    drift [rad]: the gimbal-angle drift from the basis's angles that asks for a new basis.
    relinearise: False freezes the first basis (refused beyond frozen_validity of drift).
    evaluate_accepted: adaptive steps, PECE (g at every accepted state, two evaluations per
        step) instead of PEC (the accepted node keeps the predicted state's g, one); fixed
        steps are always PECE (their start-up block and order study).  PEC gave the same E on
        every verified scene within 10 % (Section 5).
    frozen_validity [rad]: the drift beyond which a frozen basis is refused (Section 6).
    probe_drift [rad]: the drift at which the first basis measures its frequency sensitivity.
    phase_tol [1]: new frequencies or a new basis when the estimated phase error of the frozen
        frequencies exceeds min(tol, phase_tol) (``phase_bound``; Section 6).
    frequency_update_drift [1]: a phase error at a drift <= this x drift is met by new
        frequencies of the same shapes, ...
    frequency_update_min_modes: ... if the chain has this many elastic modes (else a new basis
        is cheaper).
    max_rejections: rejected steps in a basis that is not fresh before a new one is asked for.
    grow_safety [1]: the step doubles when err 2^(q+1) <= grow_safety tol.
    rate_floor [1]: a gimbal rate's phase-error scale is at least this fraction of the largest.
    error_energy_weight [1]: the local error is the larger of the gimbal-rate difference and
        this x the energy norm of every modal coordinate (0: the rates alone; Section 8).
    subdivisions: the step grid is the output interval / 2^subdivisions.
    weight_cache_entries: step weights (step, offset pairs) the compiled loop keeps per basis."""
    tol: float | None = None
    step: float | None = None
    relinearise_every: float | None = None
    order: int = 4
    drift: float = 0.01
    relinearise: bool = True
    evaluate_accepted: bool = False
    frozen_validity: float = 0.05
    probe_drift: float = 1e-5
    phase_tol: float = 5e-6
    frequency_update_drift: float = 0.02
    frequency_update_min_modes: int = 200
    max_rejections: int = 3
    grow_safety: float = 0.5
    rate_floor: float = 1e-3
    error_energy_weight: float = 1.0
    subdivisions: int = 24
    weight_cache_entries: int = 128

    def __post_init__(self):
        """ValueError (one line) on bad options, before any work; tol's default."""
        if self.tol is None and self.step is None:
            object.__setattr__(self, "tol", 1e-5)
        tol, step, every = self.tol, self.step, self.relinearise_every
        if tol is not None and (step is not None or every is not None):
            raise ValueError("exponential: give a tolerance, or a fixed step (and re-linearisation "
                             "interval), not both")
        if tol is not None and not (np.isfinite(tol) and tol > 0):
            raise ValueError(f"exponential: tolerance must be finite and > 0, got {tol}")
        if tol is not None and tol < TOL_FLOOR:
            # the local error of a step is a difference of double-precision states: below this
            # floor the estimate is its own rounding, and the step would shrink to nothing
            raise ValueError(f"exponential: tolerance {tol:g} is below {TOL_FLOOR:g}, the smallest "
                             f"relative local error a double-precision step can resolve")
        if step is not None and not (np.isfinite(step) and step > 0):
            raise ValueError(f"exponential: step must be finite and > 0, got {step}")
        if every is not None and not (np.isfinite(every) and every > 0):
            raise ValueError(f"exponential: re-linearisation interval must be finite and > 0 s, "
                             f"got {every}")
        order = self.order
        if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or not 1 <= order <= 6:
            raise ValueError(f"exponential: order must be an integer in 1..6, got {order!r}")
        if not (np.isfinite(self.drift) and self.drift > 0):
            raise ValueError(f"exponential: drift must be finite and > 0 rad, got {self.drift}")
        for name in ("frozen_validity", "probe_drift", "phase_tol", "frequency_update_drift",
                     "grow_safety", "rate_floor"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"exponential: {name} must be finite and > 0, got {value}")
        if not (np.isfinite(self.error_energy_weight) and self.error_energy_weight >= 0):
            raise ValueError(f"exponential: error_energy_weight must be finite and >= 0, "
                             f"got {self.error_energy_weight}")
        for name, low in (("frequency_update_min_modes", 0), ("max_rejections", 0),
                          ("subdivisions", 0), ("weight_cache_entries", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
                raise ValueError(f"exponential: {name} must be an integer >= {low}, got {value!r}")
        object.__setattr__(self, "order", int(order))
        object.__setattr__(self, "drift", float(self.drift))
        object.__setattr__(self, "relinearise", bool(self.relinearise))
        object.__setattr__(self, "evaluate_accepted", bool(self.evaluate_accepted))

    @property
    def phase_bound(self):
        """The phase error (relative, as the local error) that asks for new frequencies or a
        new basis: min(tol, phase_tol), phase_tol for fixed steps.  The step tolerance and the
        frozen frequencies' phase are two error sources: the phase error accumulates over the
        run, the local error of each step does not add up the same way (it is the predictor's,
        the corrector is kept), so the phase keeps the tighter bound."""
        return self.phase_tol if self.tol is None else min(float(self.tol), self.phase_tol)

    def attributes(self):
        """{exponential_<name>: value} of every option, None as NaN (the simulation file's
        attributes)."""
        return {f"exponential_{k}": (np.nan if v is None else v) for k, v in asdict(self).items()}


DEFAULTS = ExponentialOptions()


class ExponentialError(RuntimeError):
    """The exponential integrator cannot continue (one-line diagnosis with time and cause)."""


def coupled_frequencies_at(M, stiffness):
    """Elastic coupled frequencies [rad/s] (ascending, (n - 4,)) of the chain with mass matrix
    M (n, n) and stiffness diagonal (n,): eigenvalues only of the Schur-complement pencil
    (``linearized.free_joint_frequencies``: the scaled standard problem of the basis)."""
    return free_joint_frequencies(M, np.asarray(stiffness, float)[N_JOINTS:])


_INV_FACTORIALS = np.array([1.0 / math.factorial(k) for k in range(SERIES_TERMS + 16)])
_FACTORIALS = np.array([float(math.factorial(k)) for k in range(_INV_FACTORIALS.size)])


def phi_functions(z, order):
    """phi_0 .. phi_order at z: (order + 1, *z.shape) complex.

    phi_0 = exp(z), phi_{j+1}(z) = (phi_j(z) - 1/j!) / z, phi_j(0) = 1/j!.  The
    recurrence for |z| >= SERIES_RADIUS (it loses at most a factor ~(j + 1)/|z| per
    step there), below it the Taylor series phi_order(z) = sum_m z^m / (m + order)! and the
    same recurrence downwards (``kernels.exponential.phi_table``, compiled)."""
    z = np.atleast_1d(np.asarray(z, dtype=complex))
    if SERIES_TERMS + order + 1 > _INV_FACTORIALS.size:
        raise ValueError(f"phi_functions: order {order} above the {_INV_FACTORIALS.size - SERIES_TERMS - 1} "
                         f"the factorial table holds")
    out = np.empty((order + 1, z.size), dtype=complex)
    kernels.phi_table(np.ascontiguousarray(z.ravel()), int(order), SERIES_RADIUS, SERIES_TERMS,
                      _INV_FACTORIALS, out)
    return out.reshape((order + 1,) + z.shape)


class DiagonalBank:
    """The elastic modes as independent damped oscillators (module docstring): eigenvalues
    mu = -d/2 + i nu (m,), xi = (eta' - conj(mu) eta) / Delta, Delta = 2 i nu,
    eta = 2 Re xi, eta' = 2 Re(mu xi), xi' = mu xi + g / Delta."""

    def __init__(self, omega, damping):
        nu = np.sqrt(omega ** 2 - 0.25 * damping ** 2)
        self.mu = -0.5 * damping + 1j * nu
        self.delta = 2j * nu


class CoupledBank:
    """The elastic modes with a non-diagonal damping Ct = phi^T C phi (m, m): the first-order
    system z' = A z + [0; g], z = [eta; eta'], A = [[0, I], [-Omega^2, -Ct]], diagonalised,
    A = V diag(lambda) V^-1, at any damping.  Each underdamped mode is a conjugate pair
    lambda, conj(lambda): one coordinate xi of the pair's upper member stands for both (its
    column of V counted twice, z gets 2 Re(v xi)).  An overdamped mode (beyond critical
    damping) is a pair of real eigenvalues with real eigenvectors: two coordinates, each its
    own real exponential (column counted once).  With the kept eigenvalues mu (p,), p = m +
    (number of real eigenvalues) / 2, their rows P of V^-1 and columns V' of V (times 2 for a
    pair, 1 for a real one), the real state is z = Re(V' xi), xi = P z, xi' = mu xi +
    P[:, m:] g, and every exponential weight is the same phi-function of H mu whether mu is
    complex or real.  (Modal damping diagonal in every body's own modes is not diagonal in
    the coupled modes; leaving the off-diagonal part in g would put fast oscillations into g
    and collapse the step, docs/exponential.md Sec. 4.)

    Critical damping.  Where a pair's two eigenvalues meet, A loses an eigenvector: near it the
    pair's eigenvectors are nearly parallel, and V^-1 amplifies rounding by the eigenvalue
    condition number kappa_k = |v_k| |p_k| (~ 1 / the pair's relative gap, ~1e8 for a mode at
    critical damping to the last bit, as an uncoupled mode at damping ratio 1 is).  Beyond
    ``NUDGE_CONDITION`` at such a pair (``nudge_can_help``) the bank is built for the damping
    Ct (1 +- CRITICAL_NUDGE) instead,
    which splits such a pair by ~sqrt(2 CRITICAL_NUDGE) of its magnitude (kappa ~1e5), and
    ``damping`` records it: the modal forcing g = phi^-1 a + Lambda eta + damping eta' is
    formed with the same matrix, so the equations stay exact and the nudge, +-CRITICAL_NUDGE
    Ct eta' in g, is a forcing ~5e-11 of the damping force that the Adams polynomial carries.
    Measured on one mode over e^-30 of decay against the closed form with cosh(s H) and
    sinh(s H) / s (s^2 = zeta^2 - 1, entire in s^2): <= 6e-13 just below critical, 1.6e-10 at
    1 + 1e-10 (a real pair's exponentials lose their argument's rounding times kappa), 3e-13
    at 1 + 1e-6.  A basis still beyond ``CONDITION_LIMIT`` is refused, one line.

    mu (p,) complex; P_eta, P_vel (p, m) complex the rows P[:, :m], P[:, m:]; V_eta, V_vel
    (m, p) complex the scaled columns' eta and eta' parts; phase_mode (p,) int the coupled mode
    (0..m-1) whose frozen-frequency phase error an entry takes, -1 for a real eigenvalue (it
    does not oscillate); V_real (2p, 2m) real, [Re xi, Im xi] V_real = [eta, eta'];
    damping (m, m) [1/s] the Ct the bank solves (Ct, or nudged), nudge its sign (0, -1, 1:
    Ct (1 + nudge CRITICAL_NUDGE)), decompositions the tries it took."""

    NUDGE_CONDITION = 1e6
    CRITICAL_NUDGE = 5e-11
    NUDGE_SIGNS = (0, -1, 1)     # nominal, down, up: the order of the tries
    NUDGE_GAP = 1e-4             # [1] a relative eigenvalue gap below which a nudge is tried
    CONDITION_LIMIT = 1e8

    def __init__(self, omega, Ct, t=0.0, first_nudge=0):
        m = omega.size
        # the dampings tried, Ct (1 + sign CRITICAL_NUDGE), each one eigendecomposition of the
        # (2m, 2m) state matrix: first_nudge first (the sign the run's previous basis took: its
        # near-critical modes stay), then nominal (sign 0), down (an underdamped pair near
        # critical keeps ~1e-13: its phase e^{i nu H} is exact; a real pair loses its
        # exponentials' argument rounding times kappa), up.  The first try that a nudge cannot
        # improve (``nudge_can_help``: none beyond NUDGE_CONDITION, or none near critical
        # damping) is taken; if none, the up one goes to the refusal check below.
        if first_nudge not in self.NUDGE_SIGNS:
            raise ValueError(f"CoupledBank: first_nudge {first_nudge!r} is not one of {self.NUDGE_SIGNS}")
        order = (first_nudge,) + tuple(s for s in self.NUDGE_SIGNS if s != first_nudge)
        tried = {}
        for sign in order:
            damping = Ct * (1.0 + sign * self.CRITICAL_NUDGE) if sign else Ct
            tried[sign] = damping, self._decompose(omega, damping, t)
            mu, _, _, condition = tried[sign][1]
            if not self.nudge_can_help(mu, condition):
                break
        else:
            sign = self.NUDGE_SIGNS[-1]
        self.nudge = sign
        self.decompositions = len(tried)
        self.damping, (mu, P, V, condition) = tried[sign]
        if not np.all(np.isfinite(condition)) or condition.max(initial=0.0) > self.CONDITION_LIMIT:
            k = int(np.argmax(np.where(np.isfinite(condition), condition, np.inf)))
            raise ExponentialError(
                f"t = {t:.6g} s: the damped modes cannot be diagonalised (eigenvalue "
                f"{mu[k]:.6g}, condition {condition[k]:.3g} > {self.CONDITION_LIMIT:.0e}): "
                f"change damping_ratio slightly")
        self.mu = mu

        def contiguous(a):                                      # (p, m) and (m, p) complex
            return np.ascontiguousarray(a, dtype=complex)
        self.P_eta, self.P_vel = contiguous(P[:, :m]), contiguous(P[:, m:])
        self.V_eta, self.V_vel = contiguous(V[:m]), contiguous(V[m:])
        # Re(V xi) = Re V Re xi - Im V Im xi: [Re xi, Im xi] (2p,) times V_real (2p, 2m) gives
        # [eta, eta'] by one real product (the dense outputs', ``kernels.exponential.dense_coupled``)
        self.V_real = np.ascontiguousarray(np.vstack([V.real.T, -V.imag.T]))
        # a pair takes the phase of its coupled mode: the same index while every mode is a pair
        # (sorted alike), else the coupled frequency nearest its undamped one |mu|
        nearest = (np.arange(m) if mu.size == m else
                   np.abs(np.abs(mu)[:, None] - omega[None, :]).argmin(axis=1))
        self.phase_mode = np.where(mu.imag > 0, nearest, -1).astype(np.int64)

    @classmethod
    def nudge_can_help(cls, mu, condition):
        """Whether a nudge may lower the condition of the decomposition (mu (p,), condition (p,)
        of ``_decompose``): some condition is non-finite, or an entry beyond NUDGE_CONDITION
        is near critical damping, where its pair meets: a complex mu within NUDGE_GAP (relative)
        of its own conjugate, 2 |Im mu| < NUDGE_GAP |mu|, or a real one as near another real
        one.  A nudge eps of the damping moves such a pair's relative gap g by ~4 eps / g and
        its condition ~1 / g with it; at g >= NUDGE_GAP by < 4 eps / g^2 = 2e-2 relative.  Other
        causes it cannot touch: eta' ~ |mu| eta in z = [eta; eta'] alone gives a condition
        ~|mu| / 2 (2e6-1.3e7 on the truth's and freq-200's fast damped modes), and two modes
        of nearly one frequency (freq-200: gaps 6e-5) both move by ~eps.  Each try is one
        eigendecomposition."""
        if not np.all(np.isfinite(condition)):
            return True
        real = mu.imag == 0
        real_values = mu.real[real]
        for k in np.flatnonzero(condition > cls.NUDGE_CONDITION):
            if real[k]:
                distance = np.abs(real_values - mu[k].real)
                gap = np.partition(distance, 1)[1] if distance.size > 1 else np.inf  # not itself
            else:
                gap = 2.0 * abs(mu[k].imag)
            if gap < cls.NUDGE_GAP * abs(mu[k]):
                return True
        return False

    @staticmethod
    def _decompose(omega, Ct, t):
        """(mu (p,): the upper members of the pairs by frequency, then the real eigenvalues
        from the slowest; P (p, 2m), V' (2m, p) complex; the condition numbers (p,)).

        P is the inverse of the real basis B = [2 Re V+, -2 Im V+, V_real] (2m, 2m) of
        z = Re(V' xi) = B [Re xi; Im xi; xi_real], not rows of V^-1: near critical damping the
        rows of a numerical V^-1 for lambda and conj(lambda) are conjugate only to rounding
        times the condition number, and 2 Re(v p z) of the upper one alone would square it."""
        m = omega.size
        A = np.zeros((2 * m, 2 * m))
        A[:m, m:] = np.eye(m)
        A[m:, :m] = -np.diag(omega ** 2)
        A[m:, m:] = -Ct
        lam, V = scipy.linalg.eig(A)
        # LAPACK's real eigensolver returns a real matrix's real eigenvalues with imaginary part
        # exactly 0 and its complex ones in exact conjugate pairs
        pair = lam.imag > 0
        real = lam.imag == 0
        if 2 * int(pair.sum()) + int(real.sum()) != 2 * m:
            raise ExponentialError(f"t = {t:.6g} s: the damped modes' eigenvalues are not in "
                                   f"conjugate pairs (a non-finite damping or frequency?)")
        up = np.flatnonzero(pair)[np.argsort(lam[pair].imag, kind="stable")]
        re = np.flatnonzero(real)[np.argsort(-lam[real].real, kind="stable")]
        q = up.size
        Vp = 2.0 * V[:, up]
        Binv = np.linalg.inv(np.hstack([Vp.real, -Vp.imag, V[:, re].real]))
        P = np.vstack([Binv[:q] + 1j * Binv[q:2 * q], Binv[2 * q:]])
        Vk = np.hstack([Vp, V[:, re].real])
        condition = np.linalg.norm(Vk, axis=0) * np.linalg.norm(P, axis=1)
        return np.concatenate([lam[up], lam[re]]), P, Vk, condition


@dataclass
class ModalBasis:
    """The chain linearised at y_r (module docstring).

    y_ref (n,): linearisation angles, elastic coordinates zero; phi (n, n) columns =
    modes (4 joint modes first), phi^T M0 phi = I; M0 (n, n) the frozen mass matrix;
    omega (n,) [rad/s] (0 for the joint modes); bank: the elastic modes' oscillators
    (``DiagonalBank`` undamped, ``CoupledBank`` damped); t [s] when it was built;
    damping_matrix (m, m) [1/s] Ct = phi_e^T C phi_e of the elastic modes (None undamped).

    The transforms use the block structure of phi (``linearized.free_joint_basis``):
    phi = [[Lt, J X], [0, X]] (Lt = L^-T, M0_gg = L L^T; J (4, m) the joints' motion per
    unit modal motion; X (m, m)), and phi^-1 = phi^T M0 = [[L^-1 M0[:4]], [0, Y^T]] with
    Y = S X = X^-T = K X Lambda^-1 (J^T M0_gg = -M0_qg cancels the joint columns of the elastic
    rows; the last form lets the projection reuse X).
    So a physical state of (eta, eta') costs one (m, m) x (m, 2) product and a
    projection one (m, m) matrix-vector product, against four n^2 products with phi and
    M0 (docs/exponential.md Sec. 8)."""
    y_ref: np.ndarray
    phi: np.ndarray
    M0: np.ndarray
    omega: np.ndarray
    bank: object
    t: float
    damping_matrix: np.ndarray = None
    X: np.ndarray = None            # (m, m) elastic block of phi
    YT: np.ndarray = None           # (m, m) Y^T = X^-1 (C-contiguous); None: Y = K X Lambda^-1
    Ky: np.ndarray = None           # (m,) stiffness Omega^2 of the elastic coordinates (YT None)
    J: np.ndarray = None            # (4, m)
    Lt: np.ndarray = None           # (4, 4) L^-T
    Lg: np.ndarray = None           # (4, n) L^-1 M0[:4]
    omega_ref: np.ndarray = None    # (n,) [rad/s] the eigenfrequencies at y_ref (omega may be updated)

    def __post_init__(self):
        self.omega2 = self.omega ** 2       # (n,) Lambda, read on every evaluation and error norm

    def linear_terms(self, eta, etad):
        """Lambda eta + Ct eta' (n,): what the left side of the modal equations holds
        (Ct = phi^T C phi, the bank's damping), added to Phi^T M0 a to form g
        (``kernels.pece.add_linear_terms``, as in the compiled step loop)."""
        out = np.zeros(eta.shape[0])
        pece.add_linear_terms(self.omega2, _or_empty(self.damping_matrix, 2), eta, etad, out)
        return out

    def to_modal(self, y, yd):
        """(eta, eta') (n,) of a physical state."""
        return self.project(y - self.y_ref), self.project(yd)

    def project(self, v):
        """phi^-1 v = phi^T (M0 v) (n,) of a physical vector v (n,) (class docstring; Y^T v =
        Lambda^-1 X^T (K v) when YT is None: the same matrix X as to_physical), by
        ``kernels.pece.project`` as in the compiled step loop."""
        out = np.empty(v.shape[0])
        pece.project(self.Lg, self.X, _or_empty(self.Ky, 1), self.omega_ref, _or_empty(self.YT, 2),
                     np.ascontiguousarray(v, dtype=float), out)
        return out

    def rayleigh_frequencies(self, M):
        """The elastic frequencies [rad/s] (m,) of these shapes with the mass matrix M (n, n)
        of another configuration: the Rayleigh quotients omega_i^2 / (x_i^T S(M) x_i) of the
        pencil (K, S(M)) at the shapes X (x_i^T K x_i = omega_i^2, x_i^T S x_i = 1 at y_ref),
        S(M) = M_qq - M_qg M_gg^-1 M_gq: one (m, m) product, no eigenproblem.  To first order
        in M - M0 they are the diagonal of phi^-1 M^-1 K phi, the frequencies the modes
        actually oscillate at while the shapes are kept (docs/exponential.md Sec. 6)."""
        j = N_JOINTS
        X = self.X
        L = np.linalg.cholesky(M[:j, :j])
        R = scipy.linalg.solve_triangular(L, M[:j, j:] @ X, lower=True)       # (4, m)
        d = np.einsum("km,km->m", X, M[j:, j:] @ X) - np.einsum("km,km->m", R, R)
        return self.omega_ref[j:] / np.sqrt(d)

    def rayleigh_frequencies_factored(self, F):
        """``rayleigh_frequencies`` from the composite factors F of the mass matrix
        (``compiled.MassFactors``: M = J^T P + [0; B_k^T J_k] + I on the modal block), without
        forming M or the (m, m, m) product M_qq X.  For a shape x (its elastic part; e = [0; x],
        x_k body k's part, J_k, P_k rows 6k..6k+5 of J, P):

            x^T M_qq x = |x|^2 + sum_k (J_k e).(P_k e) + (B_k x_k).(J_k e),
            M_qg x = J_g^T P e,    M_gg = J_g^T P_g    (J_g, P_g: the joint columns),

        i.e. the products of J_k, P_k (6, m) and B_k (6, D_k) with X; J_k is zero beyond the joints
        and the modes of body k's ancestors, P_k beyond its own (the chain is a chain), so these
        are ~30 m^2 multiply-adds against m^3 (M_qq - I is of low rank, 36 of 400 measured on the
        truth model: the bodies' modal motion enters M through six rigid velocities each).  The
        same quotients to rounding (docs/exponential.md Sec. 6)."""
        j = N_JOINTS
        X = self.X
        q = np.einsum("km,km->m", X, X)
        MgqX = np.zeros((j, X.shape[1]))                # M_gq X = J_g^T P_e X, body by body
        for k in range(N_JOINTS):
            o, D = int(F.off[k]), int(F.D[k])
            rows = slice(6 * k, 6 * k + 6)
            PX = F.P[rows, j:j + o + D] @ X[:o + D]     # (6, m): P_k e (zero beyond its modes)
            MgqX += F.J[rows, :j].T @ PX
            if o:                                       # J_k e: the ancestors' modes only
                JX = F.J[rows, j:j + o] @ X[:o]
                q += np.einsum("km,km->m", JX, PX)
                if D:
                    q += np.einsum("km,km->m", F.B[:, o:o + D] @ X[o:o + D], JX)
        Jg = F.J[:, :j]
        Mgg = Jg.T @ F.P[:, :j]
        L = np.linalg.cholesky(0.5 * (Mgg + Mgg.T))
        R = scipy.linalg.solve_triangular(L, MgqX, lower=True)          # (4, m) L^-1 M_gq X
        return self.omega_ref[j:] / np.sqrt(q - np.einsum("km,km->m", R, R))

    def with_frequencies(self, om):
        """The same basis (shapes, y_ref, M0) with the elastic frequencies om (m,) [rad/s]:
        the modal equations eta'' + Lambda' eta = g' with g' = phi^-1 a + Lambda' eta stay an
        identity for any diagonal Lambda' (undamped bank only)."""
        omega = np.concatenate([np.zeros(N_JOINTS), om])
        return replace(self, omega=omega, bank=DiagonalBank(om, np.zeros_like(om)))

    def to_physical(self, eta, etad):
        """(y, y') (n,) of a modal state: one product of X with both (class docstring;
        ``kernels.pece.to_physical``, as in the compiled step loop)."""
        n = eta.shape[0]
        y, yd = np.empty(n), np.empty(n)
        pece.to_physical(self.y_ref, self.Lt, self.J, self.X, np.ascontiguousarray(eta, dtype=float),
                         np.ascontiguousarray(etad, dtype=float), y, yd)
        return y, yd


def _or_empty(a, ndim):
    """a as a float array, or an empty one of ndim dimensions for None (the compiled helpers
    take an empty array for "not there")."""
    return np.zeros((0,) * ndim) if a is None else a


def linearise(mass_matrix, stiffness, damping, y, t=0.0, first_nudge=0):
    """The ``ModalBasis`` of a chain at configuration y (n,).

    mass_matrix: y -> M(y) (n, n); stiffness (n,) Omega^2 [(rad/s)^2] and damping (n,)
    2 zeta Omega [1/s] on the diagonal (zero for the joints); first_nudge: the damped bank's
    critical-damping nudge to try first (``CoupledBank``; a previous basis's).  Raises
    ExponentialError when the joint mass block is singular (cond > JOINT_MASS_COND: gimbal
    lock) or the damped bank cannot be diagonalised (``CoupledBank``)."""
    y = np.asarray(y, float)
    n = y.size
    M0 = mass_matrix(y)
    Mgg = M0[:N_JOINTS, :N_JOINTS]
    cond = np.linalg.cond(Mgg)
    if not np.isfinite(cond) or cond > JOINT_MASS_COND:
        raise ExponentialError(
            f"t = {t:.6g} s: the joint mass matrix is singular (condition {cond:.3g} at gimbal "
            f"angles {np.array2string(y[:N_JOINTS], precision=4)} rad): gimbal lock")
    y_ref = np.zeros(n)
    y_ref[:N_JOINTS] = y[:N_JOINTS]
    L = np.linalg.cholesky(Mgg)
    Linv = scipy.linalg.solve_triangular(L, np.eye(N_JOINTS), lower=True)
    Lt = np.ascontiguousarray(Linv.T)                                          # L^-T
    j = N_JOINTS
    k = np.asarray(stiffness, float)[j:]
    if n > j:
        om, J, X, Y = free_joint_basis(M0, k)
    else:
        om, J, X, Y = np.zeros(0), np.zeros((j, 0)), np.zeros((0, 0)), np.zeros((0, 0))
    JX = J @ X
    # every elastic coordinate stiff: Y = S X = K X Lambda^-1 (the eigen-equation), so the
    # projection reuses X (one matrix in cache for both transforms: 2.3x faster measured)
    stiff = n > j and bool(np.all(k > 0))
    phi = np.zeros((n, n))
    phi[:j, :j] = Lt
    phi[:j, j:] = JX
    phi[j:, j:] = X
    omega = np.concatenate([np.zeros(N_JOINTS), om])
    c = np.asarray(damping, float)
    Ct = None
    if np.any(om <= 0):
        i = int(np.argmax(om <= 0))
        raise ExponentialError(f"t = {t:.6g} s: coupled mode {i + 1} has no stiffness "
                               f"(omega {om[i]:.4g} rad/s): not an oscillator")
    if np.any(c != 0):
        # C phi_r = 0 exactly (joints carry no damping): only the elastic block
        Ct = X.T @ (c[j:, None] * X)            # phi_e = [J X; X], c zero on the joints
        Ct = 0.5 * (Ct + Ct.T)
        bank = CoupledBank(om, Ct, t, first_nudge)
        Ct = bank.damping                       # nudged off critical damping if it had to be
    else:
        bank = DiagonalBank(om, np.zeros_like(om))
    return ModalBasis(y_ref=y_ref, phi=phi, M0=M0, omega=omega, bank=bank, t=float(t),
                      damping_matrix=Ct, X=np.ascontiguousarray(X),
                      YT=None if stiff else np.ascontiguousarray(Y.T), Ky=k if stiff else None,
                      J=J, Lt=Lt, Lg=Linv @ M0[:j], omega_ref=omega)


class StepWeights:
    """Cached weights of the variation-of-constants formula for one basis (module docstring):
    for a length H [s], ``get(H)`` -> (E_re, E_im (m,), F_re, F_im (K+1, m), wpos, wvel (K+1,))
    with E = e^{H mu}, the forcing weights F_j = H j! phi_{j+1}(H mu) (mu: the bank's
    eigenvalues; over Delta for the undamped bank, whose forcing is g / Delta), wpos_j =
    H^2 j!/(j+2)!, wvel_j = H j!/(j+1)!, K the highest polynomial degree; ``dense(offsets, m,
    tick)`` the same for several points inside one step with the powers theta^j (theta = the
    point's fraction of the step) folded in.  Both by ``kernels.pece.fill_weights``, the
    compiled step loop's own weights (which it caches per step pattern itself)."""

    def __init__(self, basis, degree):
        bank = basis.bank
        self.mu = np.ascontiguousarray(bank.mu, dtype=complex)
        self.delta = bank.delta if isinstance(bank, DiagonalBank) else np.zeros(0, complex)
        self.K = degree
        self.cache = {}
        self.dense_cache = {}

    def _fill(self, H, theta, dense):
        m, K = self.mu.size, self.K
        E_re, E_im = np.empty(m), np.empty(m)
        F_re, F_im = np.empty((K + 1, m)), np.empty((K + 1, m))
        wpos, wvel = np.empty(K + 1), np.empty(K + 1)
        pece.fill_weights(self.mu, self.delta, float(H), float(theta), dense, SERIES_RADIUS, SERIES_TERMS,
                          _INV_FACTORIALS, _FACTORIALS, np.empty(m, complex),
                          np.empty((K + 2, m), complex), E_re, E_im, F_re, F_im, wpos, wvel)
        return E_re, E_im, F_re, F_im, wpos, wvel

    def get(self, H):
        w = self.cache.get(H)
        if w is None:
            w = self.cache[H] = self._fill(H, 1.0, False)
        return w

    def dense(self, offsets, m, tick):
        """The weights of ``get`` stacked for the offsets (k,) [ticks] inside a step of m ticks of
        tick [s] each (theta^j folded in), and H (k,) [s]; cached per pattern (with a steady step
        every step has the same one)."""
        key = (offsets, m)
        w = self.dense_cache.get(key)
        if w is None:
            points = [self._fill(o * tick, o / m, True) for o in offsets]
            w = tuple(np.array([p[k] for p in points]) for k in range(6)) + \
                (np.array(offsets, float) * tick,)
            self.dense_cache[key] = w
        return w


def advance(basis, weights, eta, etad, coef, H, theta):
    """The modal state (eta, eta') (n,) after a length H = theta h from (eta, eta'), with g
    replaced by sum_j coef[j] (s / h)^j, coef (K'+1, n), K' <= K (module docstring), by the
    compiled loops of the step (``kernels.pece.advance_bank``)."""
    kk = coef.shape[0]
    theta_pow = theta ** np.arange(kk, dtype=float)
    out_eta, out_etad = np.empty_like(eta), np.empty_like(etad)
    _advance_bank(basis.bank, eta, etad, np.ascontiguousarray(coef, dtype=float), theta_pow,
                  weights.get(H), float(H), out_eta, out_etad)
    return out_eta, out_etad


def _bank_arrays(bank, eta, etad):
    """(mu, xi_re, xi_im, P_eta, P_vel, V_eta, V_vel): the bank as ``kernels.pece.advance_bank``
    takes it, with the undamped bank's complex coordinates of (eta, eta') (``modal_xi``)."""
    if isinstance(bank, DiagonalBank):
        m = bank.mu.size
        xi_re, xi_im = np.empty(m), np.empty(m)
        kernels.modal_xi(eta, etad, bank.mu, bank.delta, xi_re, xi_im)
        none = np.zeros((0, 0), complex)
        return bank.mu, xi_re, xi_im, none, none, none, none
    return bank.mu, np.zeros(0), np.zeros(0), bank.P_eta, bank.P_vel, bank.V_eta, bank.V_vel


def _advance_bank(bank, eta, etad, coef, theta_pow, w, H, out_eta, out_etad, arrays=None):
    """``kernels.pece.advance_bank`` with the weights w = (E_re, E_im, F_re, F_im, wpos, wvel) of
    the length H; arrays: ``_bank_arrays`` of (eta, eta') if known."""
    arrays = _bank_arrays(bank, eta, etad) if arrays is None else arrays
    pece.advance_bank(*arrays, *w, H, eta, etad, coef, theta_pow, out_eta, out_etad)


def dense_advance(basis, weights, eta, etad, coef, offsets, m, tick):
    """``advance`` to several points inside one step of m grid ticks: offsets (k,) in ticks
    (tuple, a cache key), tick [s]; returns (eta, eta') (k, n)."""
    *w, H = weights.dense(offsets, m, tick)
    coef = np.ascontiguousarray(coef, dtype=float)
    ones = np.ones(coef.shape[0])
    arrays = _bank_arrays(basis.bank, eta, etad)
    eta_out = np.empty((len(offsets), eta.size))
    etad_out = np.empty_like(eta_out)
    for k in range(len(offsets)):
        _advance_bank(basis.bank, eta, etad, coef, ones, [x[k] for x in w], float(H[k]), eta_out[k],
                      etad_out[k], arrays)
    return eta_out, etad_out


class ModalStates:
    """Physical states (T, n) of a modal trajectory, computed when read: row k is
    offset_s + phi_s eta[k], s = segment[k] the basis active at output k (offset y_ref for
    positions, 0 for velocities).  Indexing [rows, cols] computes only those entries (the
    gimbal columns [:, :4] cost 4 n per row, not n^2: the output transform of every
    coordinate is ~1 GFlop on the thesis scene, more than the integration); anything
    else (np.asarray, arithmetic, [k]) builds the whole (T, n) array once and keeps it."""

    def __init__(self, eta, segment, offsets, phis):
        self.eta = eta                   # (T, n) modal coordinates
        self.segment = segment           # (T,) int, index into offsets / phis
        self.offsets = offsets           # list of (n,)
        self.phis = phis                 # list of (n, n)
        self.shape = eta.shape
        self.ndim = 2
        self.dtype = np.dtype(float)
        self._full = None

    def __len__(self):
        return self.shape[0]

    def _groups(self, rows):
        """(segment, positions into rows) of every segment the outputs ``rows`` (k,) fall in, the
        positions ascending: one stable sort, not a mask over all rows per segment (a run of ~800
        bases over the 40,001 outputs of long spent 0.4 s a read on the masks)."""
        seg = self.segment[rows]
        order = np.argsort(seg, kind="stable")
        bounds = np.flatnonzero(np.diff(seg[order])) + 1
        return [(int(seg[idx[0]]), idx) for idx in np.split(order, bounds) if idx.size]

    def _block(self, rows, cols):
        out = np.empty((rows.size, cols.size))
        for s, idx in self._groups(rows):
            out[idx] = self.offsets[s][cols] + self.eta[rows[idx]] @ self.phis[s][cols].T
        return out

    def functionals(self, L):
        """L y (T, r) at every output for the linear functionals L (r, n): per segment
        L offset_s + eta (L phi_s)^T, an (n, r) product per basis instead of the (T, n) states
        (``multibody.attitude_functionals``: r = 13 against n ~ 400 on the truth)."""
        if self._full is not None:
            return self._full @ L.T
        out = np.empty((self.shape[0], L.shape[0]))
        for s, idx in self._groups(np.arange(self.shape[0])):
            out[idx] = L @ self.offsets[s] + self.eta[idx] @ (L @ self.phis[s]).T
        return out

    def full(self):
        """The (T, n) array (built once)."""
        if self._full is None:
            self._full = self._block(np.arange(self.shape[0]), np.arange(self.shape[1]))
        return self._full

    def __getitem__(self, key):
        if self._full is None and isinstance(key, tuple) and len(key) == 2:
            r = np.arange(self.shape[0])[key[0]]
            c = np.arange(self.shape[1])[key[1]]
            out = self._block(np.atleast_1d(r), np.atleast_1d(c))
            if np.ndim(r) == 0:
                out = out[0]
            if np.ndim(c) == 0:
                out = out[..., 0]
            return out
        return self.full()[key]

    def __array__(self, dtype=None):
        a = self.full()
        return a if dtype is None else a.astype(dtype)


@dataclass
class ExponentialStats:
    steps: int = 0
    rejected: int = 0
    evaluations: int = 0
    relinearisations: int = 0
    basis_time: float = 0.0
    smallest_step: float = np.inf
    largest_step: float = 0.0
    bases: list = field(default_factory=list)     # times [s] of every basis
    coupled_omega_max: float = 0.0                # [rad/s] highest coupled frequency, first basis
    phase_relinearisations: int = 0               # bases renewed for the phase error, not drift
    frequency_updates: int = 0                    # phase errors met by new frequencies, same shapes
    first_basis_time: float = 0.0                 # [s] the initial basis's set-up (in basis_time too)
    weight_sets: int = 0                          # step weights computed (per basis and step pattern)


class ExponentialAdams:
    """Exponential Adams (PEC adaptive, PECE fixed steps) in the coupled modal basis (module
    docstring).

    problem: the integrators' problem interface (rhs, mass_matrix, stiffness_diagonal,
    damping_diagonal); options: ``ExponentialOptions`` (adaptive or fixed steps, the basis's
    drift, ...).

    The step loop is compiled (``kernels.pece.pece_run``, called until it is done); this class
    owns what it asks for: the right-hand side, the bases (eigenproblems), the frequency probe
    and updates, the outputs' physical states for ``on_outputs`` and the error messages.  The
    loop and this class share arrays allocated once per run (``_allocate``) and passed on every
    call, so a new basis is copied into them (``_load_basis``), never rebound."""

    def __init__(self, problem, options=DEFAULTS, model=""):
        self.problem = problem
        self.options = options
        self.tol, self.step, self.every = options.tol, options.step, options.relinearise_every
        self.order, self.drift, self.relinearise = options.order, options.drift, options.relinearise
        self.model = model
        self.stats = ExponentialStats()

    # -- the arrays shared with the compiled loop
    def _allocate(self, n, damped, stiff, p):
        """The loop's containers (``kernels.pece``: Basis, WeightCache, State, History,
        Evaluation) for n coordinates, m = n - 4 elastic modes; ``damped``: the damped bank's
        matrices are needed, ``stiff``: every stiffness > 0 (no X^-1 is stored); p the bank's
        eigenvalues (``_allocate_bank``)."""
        j = N_JOINTS
        m = n - j
        square = (m, m)
        K = max(self.order, 2)                       # the first step's midpoint fit: degree 2
        self.kb = pece.Basis(
            y_ref=np.zeros(n), X=np.zeros(square), YT=np.zeros((0, 0) if stiff else square),
            Ky=np.zeros(m), omega_ref=np.zeros(n), omega=np.zeros(n), omega2=np.zeros(n),
            Lt=np.zeros((j, j)), J=np.zeros((j, m)), Lg=np.zeros((j, n)), rates=np.zeros((j, n)),
            mu=None, delta=np.zeros(0 if damped else m, complex), P_eta=None, P_vel=None,
            V_eta=None, V_vel=None, phase_mode=None, V_real=None,
            Ct=np.zeros(square if damped else (0, 0)),
            version=np.zeros(1, dtype=np.int64))
        self.kw = None
        self._allocate_bank(p)
        loop = np.zeros(1, dtype=pece.LOOP)
        loop["smallest_step"] = np.inf
        self.kst = pece.State(loop=loop, rate_scales=np.zeros(j), phase=np.zeros(m), kappa=np.zeros(m),
                              phase_ref=np.zeros(j))
        self.work = pece.Work(*(np.zeros(n) for _ in range(11)), coef=np.zeros((K + 2, n)),
                              xi_re=np.zeros(m), xi_im=np.zeros(m), omega2_old=np.zeros(n))
        H = self.order + 1
        self.hist = pece.History(t=np.zeros(H), y=np.zeros((H, n)), yd=np.zeros((H, n)),
                                 a=np.zeros((H, n)), g=np.zeros((H, n)),
                                 length=np.zeros(1, dtype=np.int64))
        self.ev = pece.Evaluation(t=np.zeros(1), y=np.zeros(n), yd=np.zeros(n), a=np.zeros(n))

    def _allocate_bank(self, p):
        """The bank's arrays of the loop's Basis and the weight cache for p eigenvalues (p = m
        undamped and underdamped; a damped basis with overdamped modes has more, and the next
        basis may have another count: then they are allocated again, the cache emptied)."""
        kb = self.kb
        m = kb.X.shape[0]
        damped = kb.Ct.shape[0] > 0
        rows, cols = ((p, m), (m, p)) if damped else ((0, 0), (0, 0))
        self.kb = kb._replace(mu=np.zeros(p, complex), P_eta=np.zeros(rows, complex),
                              P_vel=np.zeros(rows, complex), V_eta=np.zeros(cols, complex),
                              V_vel=np.zeros(cols, complex),
                              phase_mode=np.zeros(p if damped else 0, dtype=np.int64),
                              V_real=np.zeros((2 * p, 2 * m) if damped else (0, 0)))
        K = max(self.order, 2)                       # the first step's midpoint fit: degree 2
        C = self.options.weight_cache_entries
        computed = 0 if self.kw is None else int(self.kw.used[2])
        # the cache's entries are read only once filled (keys >= 0): np.empty, no 4 MB of fresh
        # zero pages to fault in while the loop fills them
        self.kw = pece.WeightCache(
            keys=np.full((C, 2), -1, dtype=np.int64), E_re=np.empty((C, p)), E_im=np.empty((C, p)),
            F_re=np.empty((C, K + 1, p)), F_im=np.empty((C, K + 1, p)), wpos=np.empty((C, K + 1)),
            wvel=np.empty((C, K + 1)),
            H=np.empty(C), used=np.array([0, -1, computed], dtype=np.int64), inv_fact=_INV_FACTORIALS,
            fact=_FACTORIALS, z=np.zeros(p, complex), phis=np.zeros((K + 2, p), complex))

    def _load_basis(self):
        """Copy the current ``ModalBasis`` into the loop's Basis arrays (in place) and count
        up its version (the loop then recomputes its step weights)."""
        b, kb = self.basis, self.kb
        j = N_JOINTS
        kb.y_ref[:] = b.y_ref
        kb.X[:] = b.X
        if kb.YT.size:
            kb.YT[:] = b.YT
        else:
            kb.Ky[:] = b.Ky
        kb.omega_ref[:] = b.omega_ref
        kb.Lt[:] = b.Lt
        kb.J[:] = b.J
        kb.Lg[:] = b.Lg
        kb.rates[:] = b.phi[:j]
        if kb.Ct.size:
            kb.Ct[:] = b.damping_matrix
            for name in ("P_eta", "P_vel", "V_eta", "V_vel", "phase_mode", "V_real"):
                getattr(kb, name)[:] = getattr(b.bank, name)
        self._load_frequencies()

    def _load_frequencies(self):
        """The current frequencies (omega, Lambda and the bank's eigenvalues) into the loop's
        Basis arrays; a new version."""
        b, kb = self.basis, self.kb
        kb.omega[:] = b.omega
        kb.omega2[:] = b.omega2
        kb.mu[:] = b.bank.mu
        if isinstance(b.bank, DiagonalBank):
            kb.delta[:] = b.bank.delta
        kb.version[0] += 1

    def _push_history(self, t, y, yd, a, g):
        """A node (t, y, y', a, g) as the newest of the history (``kernels.pece.push_history``)."""
        h = self.hist
        pece.push_history(h.t, h.y, h.yd, h.a, h.g, h.length, self.order, float(t), y, yd, a, g)

    # -- the basis
    def _new_basis(self, t, y):
        t0 = time.perf_counter()
        p = self.problem
        old = getattr(self, "basis", None)
        # the nudge the previous basis needed first (the run's near-critical modes stay)
        nudge = old.bank.nudge if old is not None and isinstance(old.bank, CoupledBank) else 0
        self.basis = linearise(p.mass_matrix, p.stiffness_diagonal, p.damping_diagonal, y, t, nudge)
        p = self.basis.bank.mu.size
        if old is None:
            b = self.basis
            self._allocate(np.asarray(y).size, b.damping_matrix is not None, b.YT is None, p)
        elif p != self.kb.mu.size:
            self._allocate_bank(p)
        self._load_basis()
        self._phase_start(old)
        self.stats.basis_time += time.perf_counter() - t0
        if old is None:
            self.stats.first_basis_time = time.perf_counter() - t0
        self.stats.bases.append(float(t))
        if hasattr(self, "segments"):
            self.segments.append((self.basis.y_ref, self.basis.phi))
        if len(self.stats.bases) == 1:
            self.stats.coupled_omega_max = float(self.basis.omega.max(initial=0.0))

    def _evaluate(self, t, eta, etad):
        """(g, y, y', a) at a modal state: the project's right-hand side, moved to the modal
        forcing g = Phi^T M0 a + Lambda eta + D eta' (the start; the loop has its own)."""
        b = self.basis
        y, yd = b.to_physical(eta, etad)
        a = self.problem.rhs(t, y, yd)
        self.stats.evaluations += 1
        g = b.project(a) + b.linear_terms(eta, etad)
        return g, y, yd, a

    def _fail(self, t, cause):
        raise ExponentialError(f"exponential: t = {t:.6g} s, model {self.model!r}: {cause}")

    # -- the run
    def run(self, t_out, y0, yd0, on_outputs=None):
        """Integrate from t_out[0] = 0 to t_out[-1] (equally spaced).  Returns (stats,
        positions, velocities), the last two ``ModalStates`` (T, n) at t_out.  If given,
        on_outputs(ks, Y, V, h) is called after every step that reaches output times: ks
        (k,) their indices into t_out, Y, V (k, n) the physical states there, h [s] the step
        (the fixed-step runs' energy watch)."""
        n = np.asarray(y0).size
        # np.empty, not zeros: every row is written (segment -1 marks a row not yet written, checked
        # in _result); np.zeros of these 2 x 4.8 MB (thesis) took fresh pages from the system on every
        # run, and their first writes cost ~3 ms of page faults in the loop (measured: zeros 4.7 ms,
        # empty 1.5 ms to allocate and touch both)
        self.out_eta = np.empty((t_out.size, n))
        self.out_etad = np.empty((t_out.size, n))
        self.out_segment = np.full(t_out.size, -1, dtype=np.int64)
        self.segments = []
        self.on_outputs = on_outputs
        n_out = t_out.size - 1
        if n_out == 0:
            self._new_basis(0.0, np.asarray(y0, float))
            self.out_eta[0], self.out_etad[0] = self.basis.to_modal(np.asarray(y0, float),
                                                                    np.asarray(yd0, float))
            return self._result()
        dt_out = float(t_out[1] - t_out[0])
        if self.step is None:
            tpo = 2 ** self.options.subdivisions                         # grid points per output interval
            m = tpo                                         # first try: one output interval
        elif self.step <= dt_out:
            tpo = max(int(math.ceil(dt_out / self.step - 1e-9)), 1)
            m = 1
        else:
            tpo, m = 1, max(int(round(self.step / dt_out)), 1)
        tick = dt_out / tpo
        i_end = n_out * tpo
        fixed = self.step is not None

        y, yd = np.array(y0, float), np.array(yd0, float)
        self._new_basis(0.0, y)
        eta, etad = self.basis.to_modal(y, yd)
        self._record(np.array([0]), eta[None, :], etad[None, :], 0.0)
        g, y, yd, a = self._evaluate(0.0, eta, etad)
        self._push_history(0.0, y, yd, a, g)
        st = self.kst
        pece.accept_scales(self.basis.omega2, eta, etad, yd, st.loop, st.rate_scales)
        i = 0
        if fixed and self.order > 1 and self.order * m <= i_end:
            i, eta, etad = self._block_start(eta, etad, m, tick, tpo)
        self.work.eta[:], self.work.etad[:] = eta, etad
        st.loop["stage"], st.loop["tick"], st.loop["step_ticks"] = pece.STEP, i, m
        o = self.options
        settings = np.zeros(1, dtype=pece.SETTINGS)
        for name, value in (
                ("tol", 0.0 if fixed else float(self.tol)), ("tick", tick), ("ticks_per_output", tpo),
                ("i_end", i_end), ("order", self.order), ("relinearise", self.relinearise),
                ("every_ticks", 0 if self.every is None else max(int(round(self.every / tick)), 1)),
                ("drift", self.drift), ("frozen_validity", o.frozen_validity),
                ("probe_drift", o.probe_drift), ("phase_bound", o.phase_bound),
                ("update_drift", o.frequency_update_drift),
                ("update_min_modes", o.frequency_update_min_modes),
                ("max_rejections", o.max_rejections), ("grow_safety", o.grow_safety),
                ("rate_floor", o.rate_floor), ("series_radius", SERIES_RADIUS),
                ("series_terms", SERIES_TERMS), ("watch", on_outputs is not None),
                ("error_energy_weight", o.error_energy_weight),
                ("evaluate_accepted", fixed or o.evaluate_accepted)):
            settings[name] = value
        outputs = pece.Outputs(self.out_eta, self.out_etad, self.out_segment)
        self._drive(settings, outputs)
        return self._result()

    def _drive(self, settings, outputs):
        """Call the compiled loop (``kernels.pece.pece_run``) and answer its requests until it
        is done (the basis and weight containers are read on every call: a new basis may have
        reallocated them)."""
        ev, st, rhs = self.ev, self.kst, self.problem.rhs
        loop = st.loop[0]
        # the loop's compiled function, typed once: every container keeps its types when a new
        # basis reallocates it (``_allocate_bank``), so the dispatcher's typing of ~70 arrays on
        # every call (once or twice a step) is left out (``kernels.extension.entry``)
        step_loop = extension.entry(pece.pece_run, (self.kb, self.kw, settings, st, self.hist, ev,
                                                    outputs, self.work))
        while True:
            request = step_loop(self.kb, self.kw, settings, st, self.hist, ev, outputs, self.work)
            if request == pece.DONE:
                break
            if request == pece.NEED_RHS:
                ev.a[:] = rhs(ev.t[0], ev.y, ev.yd)
            elif request == pece.NEED_PROBE:
                self._phase_probe(ev.y, loop["event_value"])
            elif request == pece.NEED_FREQUENCIES:
                self._update_frequencies(ev.y)
            elif request == pece.NEED_BASIS:
                self._new_basis(ev.t[0], ev.y.copy())
                self.stats.relinearisations += 1
            elif request == pece.OUTPUTS:
                self._emit(np.arange(loop["out_first"], loop["out_last"] + 1), loop["event_step"])
            elif request == pece.FAILED:
                self._failure()
        s = self.stats
        s.steps += int(loop["steps"])
        s.rejected += int(loop["rejected"])
        s.evaluations += int(loop["evaluations"])
        s.phase_relinearisations += int(loop["phase_relinearisations"])
        s.weight_sets = int(self.kw.used[2])
        s.smallest_step = min(s.smallest_step, float(loop["smallest_step"]))
        s.largest_step = max(s.largest_step, float(loop["largest_step"]))

    def _failure(self):
        """The compiled loop's failure as ExponentialError (one line, the time and the cause)."""
        loop = self.kst.loop[0]
        cause = loop["failure"]
        t, h, value = (float(loop[k]) for k in ("event_time", "event_step", "event_value"))
        if cause == pece.FAIL_STEP_TOO_SMALL:
            self._fail(t, f"the step fell to {h:.3g} s with the local error {value:.3g} "
                          f"above the tolerance {self.tol:.3g}"
                          + ("" if self.relinearise else " (frozen basis: resonance?)"))
        if cause == pece.FAIL_NON_FINITE_STATE:
            self._fail(t, "non-finite state (the fixed step is too large for the forcing, or the "
                          "basis is invalid)")
        if cause == pece.FAIL_NON_FINITE_RHS:
            self._fail(t, "non-finite accelerations")
        self._fail(t, f"the gimbals have turned {value:.3g} rad from the frozen basis (valid to "
                      f"{self.options.frozen_validity} rad): re-linearise")

    def _record(self, ks, eta, etad, h):
        """Keep the modal outputs ks (k,), eta, eta' (k, n) in the current basis's segment
        (the start and the fixed-step start-up block; the loop writes its own); hand the
        physical states to on_outputs if there is one."""
        self.out_eta[ks], self.out_etad[ks] = eta, etad
        self.out_segment[ks] = len(self.segments) - 1
        self._emit(ks, h)

    def _emit(self, ks, h):
        """on_outputs(ks, Y, V, h) with the physical states of the outputs ks, if asked for."""
        if self.on_outputs is not None:
            b = self.basis
            self.on_outputs(ks, b.y_ref + self.out_eta[ks] @ b.phi.T, self.out_etad[ks] @ b.phi.T, h)

    def _result(self):
        if np.any(self.out_segment < 0):
            raise ExponentialError(f"exponential: model {self.model!r}: output "
                                   f"{int(np.argmax(self.out_segment < 0))} was never written (a bug)")
        offsets = [sg[0] for sg in self.segments]
        phis = [sg[1] for sg in self.segments]
        zeros = [np.zeros_like(o) for o in offsets]
        return (self.stats, ModalStates(self.out_eta, self.out_segment, offsets, phis),
                ModalStates(self.out_etad, self.out_segment, zeros, phis))

    def _block_start(self, eta, etad, m, tick, tpo, iterations=None):
        """The first `order` fixed steps at full order: the states at t_1..t_k (k = order,
        t_j = j h) from one polynomial through g at t_0..t_k, iterated to a fixed point
        (each sweep gains one order; 2k + 2 sweeps), so that a fixed-step run is of order
        k + 1 from the start (a low-order start would cost its order: O(h^2) from an order-1
        first step).  Outputs inside [0, t_k] come from the same polynomial.  Returns
        (i, eta, eta') at t_k, the history holding t_k..t_0."""
        k = self.order
        total = k * m
        offsets = tuple(j * m for j in range(1, k + 1))
        nodes = np.arange(k + 1) / k
        weights = StepWeights(self.basis, self.order)
        G = np.repeat(self.hist.g[:1], k + 1, axis=0)
        for _ in range(iterations or 2 * k + 2):
            c = pece.poly_coefficients(nodes, G)
            e_, ed_ = dense_advance(self.basis, weights, eta, etad, c, offsets, total, tick)
            evals = [self._evaluate(j * m * tick, e_[j - 1], ed_[j - 1]) for j in range(1, k + 1)]
            G = np.vstack([G[:1], np.array([ev[0] for ev in evals])])
            bad = [j for j in range(1, k + 1) if not np.all(np.isfinite(G[j]))]
            if bad:
                self._fail(bad[0] * m * tick, "non-finite accelerations in the start-up block "
                                              "(the first steps)")
        c = pece.poly_coefficients(nodes, G)
        e_, ed_ = dense_advance(self.basis, weights, eta, etad, c, offsets, total, tick)
        for j in range(1, k + 1):
            g, y, yd, a = self._evaluate(j * m * tick, e_[j - 1], ed_[j - 1])
            self._push_history(j * m * tick, y, yd, a, g)
        ks = np.arange(1, total // tpo + 1)
        if ks.size:
            oe, oed = dense_advance(self.basis, weights, eta, etad, c,
                                    tuple(int(x) for x in ks * tpo), total, tick)
            self._record(ks, oe, oed, m * tick)
        self.stats.steps += k
        return total, e_[-1], ed_[-1]

    # -- the frozen basis's phase error (docs/exponential.md Section 6; the loop accumulates
    # it, kernels.pece.phase_error)
    def _phase_start(self, old):
        """A new basis: reset the accumulated phase, and take the relative frequency
        sensitivity kappa (m,) [1/rad] from the change since the previous basis if there is
        one (the first basis measures it with a probe, ``_phase_probe``)."""
        st = self.kst
        m = self.basis.omega.size - N_JOINTS
        st.phase[:] = 0.0
        st.phase_ref[:] = self.basis.y_ref[:N_JOINTS]
        st.loop["probed"] = old is not None or m == 0     # a rigid chain has no phase to lose
        if old is None:
            st.kappa[:] = 0.0
            return
        dg = float(np.abs(self.basis.y_ref[:N_JOINTS] - old.y_ref[:N_JOINTS]).max())
        w_old, w_new = old.omega_ref[N_JOINTS:], self.basis.omega_ref[N_JOINTS:]
        if dg > 0:
            st.kappa[:] = np.maximum(np.abs(w_new - w_old) / (w_old * dg), 0.5 * st.kappa)

    def _phase_probe(self, y, drift):
        """The first basis's frequency sensitivity: the frequencies of its shapes at the
        current configuration (Rayleigh quotients), compared with the basis's, per radian of
        drift."""
        t0 = time.perf_counter()
        om = self._frequencies_at(y)
        self.stats.basis_time += time.perf_counter() - t0
        w = self.basis.omega_ref[N_JOINTS:]
        self.kst.kappa[:] = np.abs(om - w) / (w * drift)
        self.kst.loop["probed"] = 1

    def _frequencies_at(self, y):
        """The current shapes' elastic frequencies (m,) [rad/s] at the configuration y (n,): their
        Rayleigh quotients, from the mass matrix's composite factors when the problem has them
        (``ModalBasis.rayleigh_frequencies_factored``: 0.40 against 3.4 ms with M(y) on the truth
        model, measured; the same to rounding), else from M(y)."""
        factors = getattr(self.problem, "mass_factors", None)
        F = None if factors is None else factors(y)
        if F is None:
            return self.basis.rayleigh_frequencies(self.problem.mass_matrix(y))
        return self.basis.rayleigh_frequencies_factored(F)

    def _update_frequencies(self, y):
        """Meet the phase error of the frozen shapes with their frequencies at y (n,) (the
        Rayleigh quotients, ``ModalBasis.rayleigh_frequencies``) instead of a new basis:
        the shapes, y_ref and the modal state stay, the weights and the history's g follow
        the new Lambda (the loop carries the history), the phase restarts from y
        (docs/exponential.md Sec. 6)."""
        t0 = time.perf_counter()
        om = self._frequencies_at(y)
        self.basis = self.basis.with_frequencies(om)
        self._load_frequencies()
        self.kst.phase[:] = 0.0
        self.kst.phase_ref[:] = y[:N_JOINTS]
        self.stats.frequency_updates += 1
        self.stats.basis_time += time.perf_counter() - t0
