"""The frozen linear chain of a scene and its a-priori error estimate (eq. 3.53 without a simulation).

The chain is linearised about the scene's rigid motion (``reduction.load_aware`` builds it and
stores it in the ranking file, ``read_linear_model``); the modal loads drive every coupled mode
of a kept set, whose rate response is solved in closed form (``velocity_response``), so
``estimate_error(model, keep)`` is the eq. 3.53 error of keeping ``keep`` against the full set.
This module holds what both the ranking (``reduction.load_aware``) and the model grammar's
``tol-EPS`` (``reduction.models``) use; it imports neither.
"""
import numpy as np

from reduction.errors import ReductionError
from solver.dynamics import linearized
from solver.dynamics.error_measure import error_measure
from workflow.provenance import read_h5_checked

N_JOINTS = 4
FROZEN_ANGLE = 1e-2         # rad: larger gimbal excursions in a scene earn a warning
FROZEN_RATE = 1e-3          # rate / lowest modal frequency above which the same warning is given
SERIES_LIMIT = 0.1          # |omega h| below which velocity_response uses its Taylor series

# The a-priori curves (the estimates the file records for every count) on at most this many
# samples: the thesis scene's whole grid; the 1 s scene's every 5th sample (its curves took 87 s).
CURVE_SAMPLES = 2001


class LoadAwareError(ReductionError):
    """Bad input to the load-aware selection (one-line message)."""


# ------------------------------------------------------------ linear response
def coupled_modes(M, K):
    """Modes of the frozen chain with mass matrix M (n, n) and stiffness K (n,) (0 on the
    joints): ``solver.dynamics.linearized.free_joint_modes`` (the joints eliminated by
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
    return velocity_response(omega, g, t) @ V[:N_JOINTS].T


def estimate_error(model, keep):
    """A-priori eq. 3.53 error (4,) of keeping ``keep``: rates of the kept set against the
    full set, both in the frozen linear chain (``solver.dynamics.error_measure.error_measure``)."""
    t, g0, full = model["t"], model["rigid_rates"], model["full"]
    return np.asarray(error_measure(t, g0 + full, g0 + rate_response(model, keep)), float)


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
