"""Compiled right-hand side of the chain: the same equations as ``gimbal_reduction.solver.dynamics.multibody``.

Why compiled: the recursion of ``multibody.accelerations`` is a few hundred
tiny array operations (3-vectors, 6x6 matrices) per evaluation; in NumPy each
costs ~1-5 us of call overhead, so one evaluation takes milliseconds, while
the truth model needs ~1e5 evaluations.  The profile shows the time goes to
call overhead (``np.cross``, small ``inv``, ``tensordot``), not arithmetic,
which is exactly what Numba removes.  The arithmetic that remains is the
O(D^2) contraction of the modal Coriolis tensor G (D, 3, D) with q, q' and
omega, done in one fused pass over G per body (``kernels.modal``).

This module is the Python side of the kernels (``gimbal_reduction.solver.dynamics.kernels``): ``pack``
turns a ``multibody.Chain`` into the named tuple ``PackedChain`` the kernels take,
bodies' modes concatenated; ``FastChain`` offers ``multibody``'s functions on it, and
``CompiledRhs`` (``make_rhs``) is the right-hand side of a chain in a scene with its
compiled RK4 loops.  Importing it raises ImportError when Numba is missing
(``gimbal_reduction.solver.dynamics.problem`` then falls back to the NumPy reference path).  Tests
compare it with ``multibody`` to round-off.

Calls from Python go through small entry functions here that take the chain's twelve
arrays as separate arguments (``*fast_chain.data``) and build the named tuple inside
compiled code: the only place where the flat argument list remains.  Handing Numba's
dispatcher the tuple itself costs ~0.2 ms per call on the truth model (typing a tuple of
many arrays falls off its fast path; measured 200-230 us for a plain or named tuple, and
for ``*args``, against 2 us for twelve separate arrays), six times a whole evaluation.
"""

import math
from typing import NamedTuple

import numba
import numpy as np

from gimbal_reduction.solver.dynamics import multibody
from gimbal_reduction.solver.dynamics.kernels import JIT, extension
from gimbal_reduction.solver.dynamics.kernels import linalg, modal, recursion, rk4
from gimbal_reduction.solver.dynamics.kernels.modal import YS_PAIRS


class PackedChain(NamedTuple):
    """The chain as flat arrays for the kernels (``pack``).

    D (4,) modes per body; off (4,) offsets of each body's modes in q (S = sum D);
    M6 (4, 6, 6) rigid mass X^T M X; V (12, S) rows [P; H; Psi; Theta] per body
    (Psi = Theta = 0 for the platform); gram (4, 12, 12) V_k V_k^T; M1 (15, S) the 15
    independent entries of dM_X/dq_i (``inertia_gradient_rows``); G: 4-tuple of
    (D_k, 3 D_k) Coriolis tensors G[j, a D + i] = (G_j)_{a i}; om2 (S,) Omega^2
    [(rad/s)^2]; cd (S,) 2 zeta Omega [1/s]; C1, C (3, 3) fixed joint axes; rho (3,)
    gimbal offset [in]."""
    D: np.ndarray
    off: np.ndarray
    M6: np.ndarray
    V: np.ndarray
    gram: np.ndarray
    M1: np.ndarray
    G: tuple
    om2: np.ndarray
    cd: np.ndarray
    C1: np.ndarray
    C: np.ndarray
    rho: np.ndarray


def inertia_gradient_rows(inertia_gradient, number=0):
    """(15, D): per mode the entries Yv[a, b] (rows 3a + b) and Ys[a, b], a <= b (rows
    9.. in the order of kernels.modal.YS_PAIRS) of dM_X/dq_i (D, 6, 6), whose structure
    (zero translational block, symmetry) is checked: the kernels rely on it."""
    M1 = np.asarray(inertia_gradient, float)
    scale = max(np.abs(M1).max(), 1e-300)
    if np.abs(M1[:, :3, :3]).max() > 1e-12 * scale or \
            np.abs(M1 - M1.transpose(0, 2, 1)).max() > 1e-12 * scale:
        raise ValueError(f"body {number}: inertia_gradient is not [[0, Yv^T], [Yv, Ys]] "
                         f"with Ys symmetric (gimbal_reduction.reduction.modal_integrals.inertia_gradient)")
    rows = np.empty((15, M1.shape[0]))
    for a in range(3):
        for b in range(3):
            rows[3 * a + b] = M1[:, 3 + a, b]
    for c, (a, b) in enumerate(YS_PAIRS):
        rows[9 + c] = M1[:, 3 + a, 3 + b]
    return rows


def pack(chain):
    """The ``PackedChain`` of a ``multibody.Chain`` (field meanings there)."""
    D = np.array(chain.n_modes, dtype=np.int64)
    off = np.zeros(4, dtype=np.int64)
    off[1:] = np.cumsum(D)[:3]
    S = int(D.sum())
    M6 = np.zeros((4, 6, 6))
    V = np.zeros((12, S))
    gram = np.zeros((4, 12, 12))
    M1 = np.zeros((15, S))
    om2 = np.zeros(S)
    cd = np.zeros(S)
    G = []
    for k, b in enumerate(chain.bodies):
        s = slice(off[k], off[k] + D[k])
        G.append(np.ascontiguousarray(np.asarray(b.coriolis, float).reshape(D[k], 3 * D[k])))
        M6[k] = b.rigid_mass
        if D[k]:
            V[0:6, s] = b.momentum
            if b.inside_translation is not None and k < 3:
                V[6:9, s] = b.inside_translation
                V[9:12, s] = b.inside_rotation
            gram[k] = V[:, s] @ V[:, s].T
            M1[:, s] = inertia_gradient_rows(b.inertia_gradient, b.number)
            om2[s] = b.omega2
            cd[s] = b.damping
    return PackedChain(D, off, M6, V, gram, M1, tuple(G), om2, cd,
                       np.ascontiguousarray(chain.case_to_outer, dtype=float),
                       np.ascontiguousarray(chain.parent_to_child, dtype=float),
                       np.ascontiguousarray(chain.gimbal_offset, dtype=float))


def case_arrays(case):
    """The case motion as the kernels take it (``kernels.recursion.case_twist``): a tuple
    (amplitude, 2 pi frequency, phase, omega0) of (3,) arrays (multibody.CaseMotion)."""
    return (np.array(case.amplitude, float), 2 * math.pi * np.array(case.frequency, float),
            np.array(case.phase, float), np.array(case.omega0, float))


# ------------------------------------------------------------------ entries from Python
# Each takes the packed chain's twelve arrays as separate arguments (``*chain.data``) and
# builds the PackedChain inside (module docstring: dispatch cost).
@numba.njit(**JIT)
def _inverse_dynamics(y, yd, ydd, w1, dw1, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    ch = PackedChain(D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
    return recursion.inverse_dynamics(y, yd, ydd, w1, dw1, ch)[0]


@numba.njit(**JIT)
def _solve_mass(y, r, dg, unit, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    ch = PackedChain(D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
    zero = np.zeros(y.shape[0])
    _, fr, _ = recursion.inverse_dynamics(y, zero, zero, np.zeros(6), np.zeros(6), ch)
    return recursion.solve(r, dg, unit, ch, fr)


@numba.njit(**JIT)
def _accelerations(y, yd, w1, dw1, tau, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    ch = PackedChain(D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
    return recursion.accelerations(y, yd, w1, dw1, tau, ch)


@numba.njit(**JIT)
def _rhs(t, y, yd, at_rest, amp, omf, phase, om0, w1, dw1, tau,
         D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """y'' at t: the case twist (into w1, dw1; left alone if at_rest), then the accelerations.
    The case arrays come separately too (a tuple of them costs ~10 us to dispatch)."""
    if not at_rest:
        recursion.case_twist(t, (amp, omf, phase, om0), w1, dw1)
    ch = PackedChain(D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
    return recursion.accelerations(y, yd, w1, dw1, tau, ch)


@numba.njit(**JIT)
def _kinetic_energy(y, yd, w1, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    ch = PackedChain(D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
    return recursion.kinetic_energy(y, yd, w1, ch)


@numba.njit(**JIT)
def _case_power_at_acc(y, yd, ydd, w1, dw1, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """(Ad_{g1^-1} w1) . F0 at accelerations ydd: the inverse dynamics only.  The accelerations
    come from ``_rhs``, compiled for the integration anyway: an entry that computed them itself
    compiled the whole articulated-body solve a second time (52 of the kernels' 138 CPU-s)."""
    ch = PackedChain(D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
    _, fr, F0 = recursion.inverse_dynamics(y, yd, ydd, w1, dw1, ch)
    return np.dot(linalg.adinv(fr.R[0], fr.p[0], w1), F0)


@numba.njit(**JIT)
def _rk4_integrate(y0, yd0, t_out, h, n_sub, growth, at_rest, amp, omf, phase, om0, tau,
                   D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    ch = PackedChain(D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
    return rk4.rk4_integrate(y0, yd0, t_out, h, n_sub, growth, at_rest, (amp, omf, phase, om0), tau, ch)


@numba.njit(**JIT)
def _mass_factors(y, Jall, Pall, BtJ, Ball, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """The composite (Jacobian) assembly of M(y) = sum_k J_k^T N_k J_k (docs in
    ``gimbal_reduction.solver.dynamics.dense_baseline``, whose baseline it was first written for).  Fill Jall (24, n) (the four bodies' twist Jacobians J_k), Pall (24, n)
    (P_k = M_X J_k + B E_k), BtJ (S, n) (rows of the modal coordinates, B_k^T J_k) and Ball
    (6, S) (B_k = [P; H + sum_j q_j G_j] of body k in its own modes' columns), so that
    M(y) = Jall^T Pall + [0; BtJ] + I_modal (module docstring).  The joint
    poses and maps are those of the structured solver's kinematics
    (``kernels.recursion.kinematics``: L = [R^T Psi; Lw Theta] on the parent's modes).
    The chain's arrays come as separate arguments (``*pack(chain)``): the dispatch of
    a tuple of many arrays is slow (``gimbal_reduction.solver.dynamics.compiled``)."""
    ch = PackedChain(D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
    S = V.shape[1]
    n = 4 + S
    fr = recursion.new_frames(int(0))
    R_all, p_all, Lw_all = fr.R, fr.p, fr.Lw
    zero_n, zero6 = np.zeros(n), np.zeros(6)
    recursion.kinematics(y, zero_n, zero_n, zero6, zero6, ch, fr)
    J = np.zeros((6, n))                        # twist Jacobian of the parent (case: zero)
    for k in range(4):
        R, p = R_all[k], p_all[k]
        o, Dk = off[k], D[k]
        m = 4 + o                               # J_k is zero beyond the angles and ancestors' modes
        # J_k = Ad^-1(R, p) J_parent + L E_parent + s e_k;  Ad^-1 = [[R^T, -R^T p~], [0, R^T]]
        Jk = np.zeros((6, n))
        for c in range(m):
            v0, v1, v2 = J[0, c], J[1, c], J[2, c]
            w0, w1, w2 = J[3, c], J[4, c], J[5, c]
            u0 = v0 + w1 * p[2] - w2 * p[1]     # v + omega x p
            u1 = v1 + w2 * p[0] - w0 * p[2]
            u2 = v2 + w0 * p[1] - w1 * p[0]
            for a in range(3):
                Jk[a, c] = R[0, a] * u0 + R[1, a] * u1 + R[2, a] * u2
                Jk[3 + a, c] = R[0, a] * w0 + R[1, a] * w1 + R[2, a] * w2
        if k > 0:                               # + L q'_parent, L = [R^T Psi; Lw Theta]
            op, Dp = off[k - 1], D[k - 1]
            Lw = Lw_all[k]
            for i in range(Dp):
                for a in range(3):
                    sv, sw = 0.0, 0.0
                    for b in range(3):
                        sv += R[b, a] * V[6 + b, op + i]
                        sw += Lw[a, b] * V[9 + b, op + i]
                    Jk[a, 4 + op + i] += sv
                    Jk[3 + a, 4 + op + i] += sw
        Jk[3, k] += 1.0
        # body matrices at q: M_X = M6 + sum q_i M1_i, B = [P; H + sum_j q_j G_j]
        Mx = M6[k].copy()
        Bk = V[0:6, o:o + Dk].copy()
        if Dk > 0:
            q = y[4 + o:4 + o + Dk].copy()
            modal.add_inertia(Mx, M1, o, Dk, q)
            hq = q @ G[k]
            for a in range(3):
                Bk[3 + a] += hq[a * Dk:(a + 1) * Dk]
        Pk = Mx @ Jk
        for i in range(Dk):
            for a in range(6):
                Pk[a, 4 + o + i] += Bk[a, i]
        if BtJ.shape[0]:                        # (size 0: only the factors are asked for)
            BtJ[o:o + Dk] = Bk.T @ Jk
        Ball[:, o:o + Dk] = Bk
        Jall[6 * k:6 * k + 6] = Jk
        Pall[6 * k:6 * k + 6] = Pk
        J = Jk


class Workspace:
    """Buffers of the composite assembly for n coordinates, reused from call to call:
    Jall, Pall (24, n), BtJ (n - 4, n), B (6, n - 4), M (n, n).  Reuse matters beyond the copy: a fresh
    n x n array is fresh memory, and its first touch costs a page fault per 4 kB page
    (measured: ~5 ms of a 7 ms assembly at n = 804 on the benchmark VM)."""

    def __init__(self, n):
        self.Jall = np.zeros((24, n))
        self.Pall = np.zeros((24, n))
        self.BtJ = np.zeros((n - 4, n))
        self.B = np.zeros((6, n - 4))
        self.M = np.zeros((n, n))


def mass_matrix_composite(data, y, work=None):
    """M(y) (n, n) by the Jacobian (composite) assembly; data = ``pack(chain)``: one
    (n x 24)(24 x n) product, O(48 n^2) flops (0.6 ms at n = 404 against 24-33 ms for the
    n + 1 inverse-dynamics columns, which it matches to 3e-16).  With a ``Workspace`` the
    result is written into (and returned as) work.M; without one, into a new array."""
    y = np.ascontiguousarray(y, dtype=float)
    work = Workspace(y.size) if work is None else work
    _mass_factors(y, work.Jall, work.Pall, work.BtJ, work.B, *data)
    M = np.dot(work.Jall.T, work.Pall, out=work.M)     # the one O(n^2) product: BLAS dgemm
    M[4:] += work.BtJ
    idx = np.arange(4, y.size)
    M[idx, idx] += 1.0
    return M


class MassFactors(NamedTuple):
    """M(y) in the factored form of the composite assembly (``mass_factors``): J, P (24, n) the
    four bodies' twist Jacobians J_k (rows 6k..6k+5) and P_k = M_X J_k + B_k E_k, B (6, S) the
    bodies' B_k in their own modes' columns (off[k]..off[k] + D[k]); off, D (4,) int.  Then
    M = J^T P + [0; B_k^T J_k rows] + I on the modal block: every block of M minus the
    identity has rank <= 30, which a quadratic form x^T M x uses (``ModalBasis.
    rayleigh_frequencies``)."""
    J: np.ndarray
    P: np.ndarray
    B: np.ndarray
    off: np.ndarray
    D: np.ndarray


def mass_factors(data, y):
    """The ``MassFactors`` of M(y) (new arrays); data = ``pack(chain)``."""
    y = np.ascontiguousarray(y, dtype=float)
    n = y.size
    J, P, B = np.zeros((24, n)), np.zeros((24, n)), np.zeros((6, n - 4))
    _mass_factors(y, J, P, np.zeros((0, n)), B, *data)
    return MassFactors(J, P, B, data.off, data.D)


# ------------------------------------------------------------------ wrappers
class FastChain:
    """The chain packed for the kernels, with the same functions as ``multibody``.

    data: the ``PackedChain``."""

    def __init__(self, chain):
        self.chain = chain
        self.data = pack(chain)
        self._work = None           # the composite assembly's buffers (``Workspace``), made on first use

    def inverse_dynamics(self, y, yd, ydd, w1, dw1):
        return _inverse_dynamics(np.asarray(y, float), np.asarray(yd, float), np.asarray(ydd, float),
                                 w1, dw1, *self.data)

    def solve_mass(self, y, r, modal_diagonal=None):
        y = np.asarray(y, float)
        n = y.size
        unit = modal_diagonal is None
        dg = np.ones(n - 4) if unit else np.asarray(modal_diagonal, float)
        return _solve_mass(y, np.asarray(r, float), dg, unit, *self.data)

    def mass_matrix(self, y):
        """M(y) (n, n), symmetrised, by the composite assembly (``mass_matrix_composite``) in
        buffers kept from call to call: only the result is fresh memory (measured 0.5 against
        3.2 ms at n = 404 between the eigenproblems of an exponential run, where fresh (n, n)
        buffers page-fault on first touch, ``Workspace``)."""
        if self._work is None or self._work.M.shape[0] != np.size(y):
            self._work = Workspace(np.size(y))
        M = mass_matrix_composite(self.data, y, self._work)
        out = np.add(M, M.T)
        out *= 0.5
        return out

    def mass_factors(self, y):
        """M(y) factored (``MassFactors``), the composite assembly's own factors."""
        return mass_factors(self.data, y)

    def mass_matrix_by_columns(self, y):
        """M(y) (n, n), symmetrised, column by column from the inverse dynamics at unit
        accelerations (Walker-Orin method 1; the reference of the composite assembly).  The modal stiffness and damping are left out of these calls: they do
        not enter M, and subtracting K q (up to ~1e5 |M| on the truth model at q ~ 1e-7)
        from every column would cost ~5 digits of M."""
        y = np.asarray(y, float)
        n = y.size
        data = self.data._replace(om2=np.zeros_like(self.data.om2), cd=np.zeros_like(self.data.cd))
        zero, z6 = np.zeros(n), np.zeros(6)
        base = _inverse_dynamics(y, zero, zero, z6, z6, *data)
        M = np.empty((n, n))
        e = np.zeros(n)
        for i in range(n):
            e[i] = 1.0
            M[:, i] = _inverse_dynamics(y, zero, e, z6, z6, *data) - base
            e[i] = 0.0
        return 0.5 * (M + M.T)

    def accelerations(self, y, yd, w1, dw1, tau):
        return _accelerations(y, yd, w1, dw1, tau, *self.data)

    def kinetic_energy(self, y, yd, w1):
        """T [in lbf] with the case twist w1 (6,)."""
        return _kinetic_energy(np.asarray(y, float), np.asarray(yd, float), w1, *self.data)

    def energy_samples(self, t, Y, Yd, tau, twist, at_rest):
        """(kinetic (T,), case power (T,)) at the samples t (T,) of Y, Yd (T, n) C-contiguous,
        with the motor torques tau (T, 4) and the case twist function twist(t) -> (w1, dw1):
        ``kinetic_energy`` and (unless the case is at rest: zero) ``case_power_at`` per sample,
        the kernels called directly."""
        data = self.data
        unused = np.zeros(3)
        T, P = np.empty(t.size), np.zeros(t.size)
        for k in range(t.size):
            w1, dw1 = twist(t[k])
            y, yd = Y[k], Yd[k]
            T[k] = _kinetic_energy(y, yd, w1, *data)
            if not at_rest:
                ydd = _rhs(0.0, y, yd, True, unused, unused, unused, unused, w1, dw1, tau[k], *data)
                P[k] = _case_power_at_acc(y, yd, ydd, w1, dw1, *data)
        return T, P

    def case_power_at(self, y, yd, w1, dw1, tau):
        """case_power at the accelerations of the equations: y'' by ``_rhs`` (w1, dw1 given: at
        rest, so the case arrays are not read), then the power by the inverse dynamics."""
        y, yd = np.asarray(y, float), np.asarray(yd, float)
        unused = np.zeros(3)
        ydd = _rhs(0.0, y, yd, True, unused, unused, unused, unused, w1, dw1,
                   np.asarray(tau, float), *self.data)
        return float(_case_power_at_acc(y, yd, ydd, w1, dw1, *self.data))


class CompiledRhs:
    """The compiled right-hand side of a chain in a case motion with motor torques.

    Calling it, rhs(t, y, y') -> y'' (``rhs`` is the same as a plain function, a little
    cheaper per call).  ``case_twist(t)``; with constant torques (``has_rk4``) also the
    compiled RK4 loops ``rk4_steps`` and ``rk4_integrate``.  ``fast_chain``: the
    ``FastChain`` (inverse dynamics, solve, energies)."""

    def __init__(self, chain, case=None, torque=None):
        self.fast_chain = FastChain(chain)
        self.case = case or multibody.CaseMotion()
        self.torque = multibody.torque_function(torque)
        self.at_rest = self.case.at_rest
        self._case = case_arrays(self.case)
        const_tau = None if callable(torque) else np.asarray(self.torque(0.0), float)
        self.has_rk4 = const_tau is not None
        self._tau = None if const_tau is None else np.ascontiguousarray(const_tau, dtype=float)
        data, case_data, at_rest, tau_f = self.fast_chain.data, self._case, self.at_rest, self.torque
        w1 = np.zeros(6)
        dw1 = np.zeros(6)

        def rhs(t, y, yd):
            tau = const_tau if const_tau is not None else np.asarray(tau_f(t), float)
            return _rhs(float(t), y, yd, at_rest, *case_data, w1, dw1, tau, *data)
        self.rhs = rhs

    def __call__(self, t, y, yd):
        return self.rhs(t, y, yd)

    def case_twist(self, t):
        """(w1, dw1) (6,) each, compiled (multibody.CaseMotion.twist)."""
        w, dw = np.zeros(6), np.zeros(6)
        recursion.case_twist(float(t), self._case, w, dw)
        return w, dw

    def _constant_torque(self, what):
        if not self.has_rk4:
            raise ValueError(f"{what} needs constant motor torques (a callable was given)")

    def rk4_steps(self, y, yd, t0, h, n):
        """n compiled RK4 steps from (t0, y, y'); returns (y, y') (non-finite if the state
        became so).  The whole-run kernel over one output interval of n steps, its energy
        watch off (growth inf) and the case's power skipped (at_rest): one compiled RK4 loop,
        one entry of the same argument types as the RK4 runs', serves both."""
        self._constant_torque("the compiled RK4 loop")
        t0, h, n = float(t0), float(h), int(n)
        Y, Yd, _, _ = _rk4_integrate(np.asarray(y, float), np.asarray(yd, float),
                                     np.array([t0, t0 + n * h]), h, n, math.inf, bool(True),
                                     *self._case, self._tau, *self.fast_chain.data)
        return Y[1], Yd[1]

    def rk4_integrate(self, y0, yd0, t_out, h, n_sub, growth):
        """A whole RK4 run with outputs and energy watch (``kernels.rk4.rk4_integrate``):
        returns (Y, Yd, energy, info)."""
        self._constant_torque("the compiled RK4 run")
        return _rk4_integrate(np.asarray(y0, float), np.asarray(yd0, float),
                              np.asarray(t_out, float), float(h), int(n_sub), float(growth),
                              bool(self.at_rest), *self._case, self._tau, *self.fast_chain.data)


def make_rhs(chain, case=None, torque=None):
    """The compiled right-hand side (``CompiledRhs``) of a chain in a case motion."""
    return CompiledRhs(chain, case, torque)


# this module's entries compiled ahead of time, when built and current (kernels.extension)
extension.attach(__name__)
