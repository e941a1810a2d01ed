"""The frozen linear chain of a scene and its a-priori error estimate (eq. 3.53 without a simulation).

The chain is linearised about the scene's rigid motion (``gimbal_reduction.reduction.load_aware`` builds it and
stores it in the ranking file, ``read_linear_model``); the modal loads drive every coupled mode
of a kept set, whose rate response is solved in closed form (``velocity_response``), so
``estimate_error(model, keep)`` is the eq. 3.53 error of keeping ``keep`` against the full set.
This module holds what both the ranking (``gimbal_reduction.reduction.load_aware``) and the model grammar's
``tol-EPS`` (``gimbal_reduction.reduction.models``) use; it imports neither.  ``FrozenChainEstimator`` gives the
rankings' many evaluations of one chain the same numbers at a fraction of the cost (its
docstring; docs/selection.md, Section 2).
"""

import cmath
import math

import numba
import numpy as np
import scipy.linalg

from gimbal_reduction.reduction import submatrix_eig
from gimbal_reduction.reduction.errors import ReductionError
from gimbal_reduction.solver.dynamics import linearized
from gimbal_reduction.solver.dynamics.error_measure import error_measure
from gimbal_reduction.workflow.provenance import read_h5_checked

N_JOINTS = 4
FROZEN_ANGLE = 1e-2         # rad: larger gimbal excursions in a scene earn a warning
FROZEN_RATE = 1e-3          # rate / lowest modal frequency above which the same warning is given
SERIES_LIMIT = 0.1          # |omega h| below which velocity_response uses its Taylor series

# The a-priori curves (the estimates the file records for every count) on at most this many
# samples: the thesis scene's whole grid; the 1 s scene's every 5th sample (its curves took 87 s).
CURVE_SAMPLES = 2001

# Singular values of the modal loads below this fraction of the largest are dropped
# (``load_factors``): 5 units of rounding, the loads' own accuracy.
LOAD_RANK_RTOL = 1e-15


class LoadAwareError(ReductionError):
    """Bad input to the load-aware selection (one-line message)."""


# ------------------------------------------------------------ linear response
def coupled_modes(M, K):
    """Modes of the frozen chain with mass matrix M (n, n) and stiffness K (n,) (0 on the
    joints): ``gimbal_reduction.solver.dynamics.linearized.free_joint_modes`` (the joints eliminated by
    their Schur complement), with the n_free = 4 joint columns put in front as zeros (omega
    0, no motion), so that omega (n,) [rad/s] and V (n, n) keep the shapes of the full
    pencil; the elastic columns satisfy V^T M V = I, V^T diag(K) V = diag(omega^2)."""
    M = np.asarray(M, float)
    K = np.asarray(K, float)
    omega, shapes = linearized.free_joint_modes(M, K[N_JOINTS:])
    if omega.size and omega[0] ** 2 <= 1e-9 * omega[-1] ** 2:
        raise LoadAwareError(f"linear model: more than {N_JOINTS} zero frequencies "
                             f"(mass matrix not positive definite?)")
    n = M.shape[0]
    return np.concatenate([np.zeros(N_JOINTS), omega]), np.hstack([np.zeros((n, N_JOINTS)), shapes])


def _phi(a, order):
    """phi_1(a) = (1 - e^-a)/a (order 1) or phi_2(a) = (1 - e^-a (1 + a))/a^2 (order 2),
    complex a, by a Taylor series where |a| < SERIES_LIMIT (no cancellation)."""
    a = np.asarray(a, complex)
    small = np.abs(a) < SERIES_LIMIT
    safe = np.where(small, 1.0, a)
    e = np.exp(-safe)
    out = (1 - e) / safe if order == 1 else (1 - e * (1 + safe)) / safe ** 2
    if np.any(small):
        s = a[small]
        term = np.ones_like(s)
        acc = np.zeros_like(s)
        for k in range(12):             # sum_k (-a)^k / (k+1)!  or  (-a)^k / (k! (k+2))
            acc += term / ((k + 1) if order == 1 else (k + 2))
            term = term * (-s) / (k + 1)
        out = np.where(small, 0, out)
        out[small] = acc
    return out


def velocity_response(omega, g, t):
    """eta' (T, n) of eta'' + omega^2 eta = g(t) from rest, g linear between samples.

    omega (n,) [rad/s] (0 allowed: eta' = integral of g); g (T, n) sampled loads;
    t (T,) [s].  Exact for the piecewise-linear load (Duhamel integral in closed
    form), so omega h may be far above 1:

        eta'(t) = int_0^t cos(omega (t - s)) g(s) ds = Re[e^{i omega t} I(t)],
        I(t) = int_0^t e^{-i omega s} g(s) ds,

    summed interval by interval with
    int_0^h e^{-i w u} (g_a + g' u) du = h phi_1(i w h) g_a + h^2 phi_2(i w h) g'
    (``_phi``).  Real arithmetic (cosines and sines of omega t), ~5 ms for
    1500 samples and 160 modes."""
    t = np.asarray(t, float)
    g = np.asarray(g, float)
    w = np.asarray(omega, float)
    if g.ndim != 2 or g.shape != (t.size, w.size):
        raise LoadAwareError(f"velocity_response: g must be (T, n) = ({t.size}, {w.size}), "
                             f"got {g.shape}")
    h = np.diff(t)
    uniform = np.allclose(h, h[0], rtol=1e-9, atol=0.0)
    hh = np.array([[h[0]]]) if uniform else h[:, None]
    a = 1j * hh * w[None, :]
    A1, A2 = hh * _phi(a, 1), hh * hh * _phi(a, 2)
    slope = np.diff(g, axis=0) / h[:, None]
    wt = np.outer(t, w)
    c, s = np.cos(wt), np.sin(wt)
    Br = g[:-1] * A1.real + slope * A2.real          # B = g_a A1 + g' A2 on every interval
    Bi = g[:-1] * A1.imag + slope * A2.imag
    re = np.zeros_like(c)                             # I = sum of e^{-i w t_a} B
    im = np.zeros_like(c)
    np.cumsum(c[:-1] * Br + s[:-1] * Bi, axis=0, out=re[1:])
    np.cumsum(c[:-1] * Bi - s[:-1] * Br, axis=0, out=im[1:])
    return c * re - s * im


@numba.njit(cache=True, error_model="numpy")
def _modal_rates_uniform(omega, h, g):
    """eta'_j(t_a) (T, n) of every mode on a uniform grid of step h (``velocity_response``'s
    Duhamel sums).

    With J_a = e^{i omega t_a} I(t_a), the running integral times the phase, the sum of
    ``velocity_response`` over the interval [t_a, t_a + h] becomes one complex step

        J_{a+1} = e^{i omega h} (J_a + g_a P + g_{a+1} Q),   eta'(t_a) = Re J_a,  J_0 = 0,

    P = h (phi_1 - phi_2)(i omega h), Q = h phi_2(i omega h) (the load g_a + (g_{a+1} - g_a) u / h
    integrated against e^{-i omega u}; phi as ``_phi``, by its series where |omega h| <
    SERIES_LIMIT): no cosine or sine per sample, no division, and the modes of one sample side
    by side (contiguous rows of g).  The rotation's rounding grows like a eps per sample
    (~1e-13 relative on the real chain, 1501 samples).  omega (n,) [rad/s]; g (T, n)
    C-contiguous."""
    T, n = g.shape
    rc = np.empty(n)
    rs = np.empty(n)
    Pr = np.empty(n)
    Pi = np.empty(n)
    Qr = np.empty(n)
    Qi = np.empty(n)
    for j in range(n):
        a = 1j * (omega[j] * h)
        if abs(a) < SERIES_LIMIT:       # sum_k (-a)^k / (k+1)!  and  (-a)^k / (k! (k+2))
            term = 1.0 + 0.0j
            p1 = 0.0j
            p2 = 0.0j
            for k in range(12):
                p1 += term / (k + 1)
                p2 += term / (k + 2)
                term = term * (-a) / (k + 1)
        else:
            e = cmath.exp(-a)
            p1 = (1 - e) / a
            p2 = (1 - e * (1 + a)) / (a * a)
        P = h * (p1 - p2)
        Q = h * p2
        rc[j], rs[j] = math.cos(omega[j] * h), math.sin(omega[j] * h)
        Pr[j], Pi[j], Qr[j], Qi[j] = P.real, P.imag, Q.real, Q.imag
    R = np.empty((T, n))
    Jr = np.zeros(n)
    Ji = np.zeros(n)
    for j in range(n):
        R[0, j] = 0.0
    for a in range(T - 1):
        ga = g[a]
        gb = g[a + 1]
        Ra = R[a + 1]
        for j in range(n):
            xr = Jr[j] + ga[j] * Pr[j] + gb[j] * Qr[j]
            xi = Ji[j] + ga[j] * Pi[j] + gb[j] * Qi[j]
            yr = rc[j] * xr - rs[j] * xi
            Ji[j] = rs[j] * xr + rc[j] * xi
            Jr[j] = yr
            Ra[j] = yr
    return R


def modal_rates_uniform(omega, g, h):
    """eta' (T, n) of eta'' + omega^2 eta = g(t) from rest on a uniform grid of step h [s]
    (``velocity_response``; by the compiled ``_modal_rates_uniform``).  omega (n,) [rad/s]."""
    return _modal_rates_uniform(np.ascontiguousarray(omega, dtype=float), float(h),
                                np.ascontiguousarray(g, dtype=float))


def modal_rates(omega, g, t):
    """eta' (T, n) of eta'' + omega^2 eta = g(t) from rest (``velocity_response``): on a uniform
    grid by ``modal_rates_uniform``, else by the NumPy form.  omega (n,) [rad/s], g (T, n),
    t (T,) [s]."""
    t = np.asarray(t, float)
    h = np.diff(t)
    if t.size < 2 or not np.allclose(h, h[0], rtol=1e-9, atol=0.0):
        return velocity_response(omega, g, t)
    if np.shape(g) != (t.size, np.size(omega)):
        raise LoadAwareError(f"modal_rates: g must be (T, n) = ({t.size}, {np.size(omega)}), "
                             f"got {np.shape(g)}")
    return modal_rates_uniform(omega, g, float(h[0]))


def joint_rate_response(omega, V4, g, t):
    """sum_j V4[:, j] eta'_j(t) (T, 4): the joint rates of the coupled modes driven by g
    (``velocity_response``); on a uniform grid by ``modal_rates_uniform``, else by the NumPy
    form.  omega (n,) [rad/s], V4 (4, n), g (T, n), t (T,) [s]."""
    t = np.asarray(t, float)
    h = np.diff(t)
    if t.size < 2 or not np.allclose(h, h[0], rtol=1e-9, atol=0.0):
        return velocity_response(omega, g, t) @ np.asarray(V4, float).T
    w = np.asarray(omega, float)
    if np.shape(g) != (t.size, w.size):
        raise LoadAwareError(f"joint_rate_response: g must be (T, n) = ({t.size}, {w.size}), "
                             f"got {np.shape(g)}")
    return modal_rates_uniform(w, g, float(h[0])) @ np.asarray(V4, float).T


def check_model(model):
    """Raise LoadAwareError unless the linear model's arrays fit together."""
    M, K, t, g, L = (np.asarray(model[k]) for k in ("M", "K", "t", "rigid_rates", "loads"))
    n = K.size
    if M.shape != (n, n) or L.shape != (t.size, n - N_JOINTS) or g.shape != (t.size, N_JOINTS):
        raise LoadAwareError(f"linear model: shapes M {M.shape}, K {K.shape}, t {t.shape}, "
                             f"rigid_rates {g.shape}, loads {L.shape} do not fit")
    if np.any(K[:N_JOINTS] != 0) or np.any(K[N_JOINTS:] <= 0):
        raise LoadAwareError("linear model: K must be 0 on the 4 joints and > 0 on every mode")
    if t.size < 2 or np.any(np.diff(t) <= 0):
        raise LoadAwareError("linear model: t must hold at least 2 strictly increasing samples")


def _kept_index(model, keep):
    keep = np.asarray(keep, dtype=int).ravel()
    Q = model["loads"].shape[1]
    if keep.size and (keep.min() < 0 or keep.max() >= Q or np.unique(keep).size != keep.size):
        raise LoadAwareError(f"kept modes must be distinct indices in 0..{Q - 1}")
    return np.sort(keep)


def rate_response(model, keep):
    """d gamma_dot (T, 4) [rad/s]: what the kept modes (indices into the pooled
    modal coordinates, 0..sum D - 1) add to the rigid rates in the frozen chain."""
    keep = _kept_index(model, keep)
    t = model["t"]
    if keep.size == 0:
        return np.zeros((t.size, N_JOINTS))
    idx = np.concatenate([np.arange(N_JOINTS), N_JOINTS + keep])
    omega, V = coupled_modes(model["M"][np.ix_(idx, idx)], model["K"][idx])
    g = model["loads"][:, keep] @ V[N_JOINTS:]               # load on every coupled mode
    return joint_rate_response(omega, V[:N_JOINTS], g, t)


def estimate_error(model, keep):
    """A-priori eq. 3.53 error (4,) of keeping ``keep``: rates of the kept set against the
    full set, both in the frozen linear chain (``gimbal_reduction.solver.dynamics.error_measure.error_measure``)."""
    t, g0, full = model["t"], model["rigid_rates"], model["full"]
    return np.asarray(error_measure(t, g0 + full, g0 + rate_response(model, keep)), float)


def load_factors(loads, rtol=LOAD_RANK_RTOL):
    """(F (T, r), W (r, Q)) with loads (T, Q) = F W to rounding: the truncated singular value
    decomposition, F = U_r Sigma_r, W = V_r^T, keeping the singular values above ``rtol`` times
    the largest.

    The modal loads of a scene are linear combinations of a few functions of time (the frames'
    accelerations, products of their rates, the bearing wrenches: ``gimbal_reduction.reduction.load_aware.
    modal_loads``), so r is small: 4 on the thesis, damped and smooth scenes, 17 on long (400
    modes); the singular values beyond them are rounding (3e-16 of the largest and less).  The
    coupled modes' loads L_S X then cost (T + k) r k instead of T k^2."""
    U, sv, Wt = np.linalg.svd(np.asarray(loads, float), full_matrices=False)
    r = int(np.sum(sv > rtol * sv[0])) if sv.size and sv[0] > 0 else 0
    return np.ascontiguousarray(U[:, :r] * sv[:r]), np.ascontiguousarray(Wt[:r])


class FrozenChainEstimator:
    """``estimate_error`` for many kept sets of one frozen chain (the rankings make thousands of
    evaluations), with what every kept set shares computed once.

    Keeping the set S of modes, the joints are eliminated by the Schur complement of their
    block, which is the same 4 x 4 block M_gg for every S, so the kept set's Schur complement is
    the principal submatrix S_full[S, S] of the whole chain's and its joint motion
    -M_gg^-1 M_gq the columns S of the whole chain's (``linearized.free_joints``, done once).
    The pencil (Omega_S^2, S_S) is solved in the standard form of
    ``linearized.free_joint_basis``: A_S = Omega_S^-1 S_S Omega_S^-1 = P diag(mu) P^T (one
    symmetric eigenproblem, no Cholesky factor), omega = mu^-1/2 and the mass-normalised
    shapes X = Omega_S^-1 P diag(omega), so that the scaled loads L Omega^-1 and joint motion
    (also computed once, per time grid for the loads) give the coupled loads and joint rates
    by one product each with P diag(omega).  The response and eq. 3.53 are those of
    ``rate_response`` and ``estimate_error``, which it equals to rounding (the eigensolver
    differs: tests/reduction/test_load_aware.py).

    model: the linear model (``linear_model``); ``estimate_error(m, keep)`` takes it or any
    ``decimated`` copy of it (the same M: other chains are refused)."""

    def __init__(self, model):
        check_model(model)
        self._M = model["M"]
        M = np.asarray(model["M"], float)
        K = np.asarray(model["K"], float)
        joint_of_mode, S = linearized.free_joints(M)
        self._scale = np.sqrt(K[N_JOINTS:])                        # Omega (Q,)
        self._A = S / np.outer(self._scale, self._scale)           # Omega^-1 S Omega^-1
        self._joints = joint_of_mode / self._scale                  # (4, Q): joint motion, scaled
        self._grids = {}

    def _grid(self, model):
        """What a time grid shares: (t, uniform step or None, load factors (F (T, r), W (r, Q))
        of the scaled loads, Y (Q, 4 + r) = [joint motion, W]^T, the full set's rates (T, 4),
        the trapezoidal rule's weights (T,), and the reference rates' squares integrated (4,):
        eq. 3.53's denominator).  Kept per grid (decimated copies of one grid share it)."""
        t = model["t"]
        key = (t.__array_interface__["data"][0], t.strides, t.shape)
        grid = self._grids.get(key)
        if grid is None or grid[0] is not t and not np.array_equal(grid[0], t):
            if model["M"] is not self._M:
                raise LoadAwareError("FrozenChainEstimator: the model is not the estimator's chain "
                                     "(or a decimated copy of it)")
            tt = np.asarray(t, float)
            check_model(model)
            h = np.diff(tt)
            step = float(h[0]) if np.allclose(h, h[0], rtol=1e-9, atol=0.0) else None
            full = np.asarray(model["full"], float)
            ref = np.asarray(model["rigid_rates"], float) + full
            weights = np.zeros(tt.size)
            weights[:-1] += 0.5 * h
            weights[1:] += 0.5 * h
            F, W = load_factors(np.asarray(model["loads"], float) / self._scale)
            Y = np.ascontiguousarray(np.vstack([self._joints, W]).T)
            grid = (t, step, F, Y, full, weights, np.trapezoid(ref ** 2, tt, axis=0))
            self._grids[key] = grid
        elif model["M"] is not self._M:
            raise LoadAwareError("FrozenChainEstimator: the model is not the estimator's chain "
                                 "(or a decimated copy of it)")
        return grid

    def _eig(self, keep):
        """(mu (k,) ascending, P (k, k) C-contiguous) of A_S, S = keep (sorted)."""
        A = self._A[np.ix_(keep, keep)]
        if A.shape[0] == 1:                 # (LAPACK's workspace query of syevd fails at n = 1)
            return A[0].copy(), np.ones((1, 1))
        mu, P = scipy.linalg.eigh(A, driver="evd", overwrite_a=True, check_finite=False)
        return mu, np.ascontiguousarray(P)

    def modes(self, keep):
        """(omega (k,) [rad/s] ascending, B (k, k)) of the kept set (sorted pooled indices):
        the coupled modes' shapes are X = Omega_S^-1 B, B = P diag(omega)."""
        mu, P = self._eig(keep)
        _check_positive(mu)
        omega = 1.0 / np.sqrt(mu[::-1])                                # ascending
        return omega, P[:, ::-1] * omega

    def _rates(self, grid, mu, PY):
        """Joint rates (T, 4) of the coupled modes of eigenvalues mu (k,) ascending of A_S and
        eigenvectors P, given by PY = P^T Y_S (k, 4 + r): omega = mu^-1/2 and the shapes
        X = Omega_S^-1 P diag(omega) give the joint motion and load directions
        diag(omega) PY = X^T [J_S; W_S]^T."""
        t, step, F = grid[:3]
        if mu.size == 0:
            return np.zeros((len(t), N_JOINTS))
        _check_positive(mu)
        omega = 1.0 / np.sqrt(mu[::-1])                                # ascending
        proj = PY[::-1] * omega[:, None]
        g = F @ proj[:, N_JOINTS:].T                                   # load on every coupled mode
        if step is None:
            return velocity_response(omega, g, np.asarray(t, float)) @ proj[:, :N_JOINTS]
        return modal_rates_uniform(omega, g, step) @ proj[:, :N_JOINTS]

    @staticmethod
    def _error(grid, rates):
        """eq. 3.53 (4,) of the kept set's rates against the full set's: the numerator's
        difference (g0 + rates) - (g0 + full) taken as rates - full."""
        full, weights, den = grid[4:]
        num = weights @ (rates - full) ** 2
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)

    def rate_response(self, model, keep):
        """``rate_response(model, keep)`` (T, 4) [rad/s]."""
        keep = _kept_index(model, keep)
        grid = self._grid(model)
        if keep.size == 0:
            return self._rates(grid, np.zeros(0), None)
        mu, P = self._eig(keep)
        return self._rates(grid, mu, P.T @ grid[3][keep])

    def estimate_error(self, model, keep):
        """``estimate_error(model, keep)`` (4,): eq. 3.53 of the kept set against the full set."""
        return self._error(self._grid(model), self.rate_response(model, keep))

    def removal_errors(self, model, keep, remove):
        """[``estimate_error(model, keep without m)`` for m in remove]: the trials of a backward
        elimination step, from one eigendecomposition of the kept set's A_S = P diag(mu) P^T.

        Deleting mode m (row i of A_S) leaves the eigenvalues and eigenvectors P U^T of
        ``gimbal_reduction.reduction.submatrix_eig.delete_index`` (O(k^2) instead of an O(k^3) eigensolver call);
        the coupled modes' joint motion and load directions are their products with the scaled
        joint motion and load factors without mode m, U (P^T Y_S - P[i]^T Y_S[i]): one product
        with P for all m, then a rank-one correction each.  A deletion that ``delete_index``
        leaves to an eigensolver (a near-multiple eigenvalue) is evaluated by ``estimate_error``."""
        keep = _kept_index(model, keep)
        remove = [int(m) for m in remove]
        grid = self._grid(model)
        pos = np.searchsorted(keep, remove)
        if np.any(pos >= keep.size) or np.any(keep[np.minimum(pos, keep.size - 1)] != remove):
            raise LoadAwareError("removal_errors: the modes to remove must be kept modes")
        if keep.size <= 2:
            return [self.estimate_error(model, np.delete(keep, i)) for i in pos]
        mu, P = self._eig(keep)
        Y = grid[3][keep]
        PY = P.T @ Y
        out = []
        for i in pos:
            ok, x, U = submatrix_eig.delete_index(mu, P, i)
            if not ok:
                out.append(self.estimate_error(model, np.delete(keep, i)))
                continue
            out.append(self._error(grid, self._rates(grid, x, U @ (PY - np.outer(P[i], Y[i])))))
        return out

    def chain_errors(self, model, keep, steps):
        """[estimate_error of keep, of keep without steps[0], without steps[0] and steps[1], ...]
        (len(steps) + 1 arrays (4,)): the a-priori curves, which drop modes one after another
        (steps: lists of kept modes, removed before each further evaluation).

        One eigendecomposition of the kept set, then ``submatrix_eig.delete_index`` for every
        removal, carrying only what the later steps need: the projections P^T Y_S of the
        eigenvectors (the joint motion and load directions of the coupled modes) and the rows of
        P of the modes still to be removed, each updated by the deletion's coefficients U (O(k^2)
        per row instead of the O(k^3) of a new eigensolver call).  A deletion that
        ``delete_index`` leaves to an eigensolver restarts from an eigendecomposition."""
        keep = _kept_index(model, keep)
        steps = [[int(m) for m in st] for st in steps]
        gone = [m for st in steps for m in st]
        if len(set(gone)) != len(gone) or not set(gone) <= set(keep.tolist()):
            raise LoadAwareError("chain_errors: the removed modes must be distinct kept modes")
        grid = self._grid(model)
        Y = grid[3]

        def fresh(cur, pending):
            mu, P = self._eig(cur)
            return mu, P.T @ Y[cur], {m: P[i] for m, i in zip(pending, np.searchsorted(cur, pending))}

        cur = keep
        state = fresh(cur, gone) if cur.size else (np.zeros(0), None, {})
        out = [self._error(grid, self._rates(grid, *state[:2]))]
        done = 0
        for st in steps:
            for m in st:
                done += 1
                i = int(np.searchsorted(cur, m))
                nxt = np.delete(cur, i)
                pending = gone[done:]
                mu, PY, rows = state
                z = rows.pop(m)
                ok, x, U = submatrix_eig.delete_index(mu, z[None, :], 0)
                if not ok:
                    cur, state = nxt, fresh(nxt, pending)
                    continue
                PY = U @ (PY - np.outer(z, Y[m]))
                if rows:
                    R = np.array([rows[k] for k in pending]) @ U.T
                    rows = dict(zip(pending, R))
                cur, state = nxt, (x, PY, rows)
            out.append(self._error(grid, self._rates(grid, *state[:2])))
        return out


def _check_positive(mu):
    """Raise LoadAwareError unless the eigenvalues mu (ascending) of A_S = Omega^-1 S Omega^-1
    are positive and within 1e9 of each other (S positive definite)."""
    if mu[0] <= 0 or mu[0] <= 1e-9 * mu[-1]:
        raise LoadAwareError(f"linear model: more than {N_JOINTS} zero frequencies "
                             f"(mass matrix not positive definite?)")


def decimated(model, stride):
    """The linear model on every ``stride``-th output sample (a cheaper search grid)."""
    if stride == 1:
        return model
    out = dict(model)
    for key in ("t", "rigid_rates", "loads", "full"):
        out[key] = model[key][::stride]
    return out


def read_linear_model(path):
    """The frozen linear chain stored in a ranking file (``write_ranking``)."""
    with read_h5_checked(path, ("linear/M", "linear/loads")) as f:
        return {k: f["linear"][k][()] for k in f["linear"]}
