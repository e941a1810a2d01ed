"""Compiled core of the exponential integrator's step (``solver.dynamics.exponential``).

One function, ``advance_diagonal``: the variation-of-constants update of every mode
over a length H with the forcing polynomial sum_r c_r (s / h)^r, for the undamped
(diagonal) oscillator bank.  The same arithmetic as ``exponential.advance`` with a
``DiagonalBank``, in one loop over the modes instead of a dozen NumPy passes over
(K + 1, m) complex arrays (measured 150 us per call in NumPy on the truth model, on a
loaded machine; the loop does ~5 (K + 1) m flops).
"""

import numba
import numpy as np

from solver.dynamics.kernels import JIT

N_JOINTS = 4


@numba.njit(**JIT)
def advance_diagonal(eta, etad, coef, theta_pow, E, W, wpos, wvel, mu, delta, H, out_eta, out_etad):
    """Fill out_eta, out_etad (n,) with the modal state after a length H [s] from (eta, eta')
    (n,): elastic mode i (index 4 + i), xi = (eta' - conj(mu) eta) / delta,
    xi <- E_i xi + sum_r W[r, i] theta^r c_r / delta_i, eta = 2 Re xi, eta' = 2 Re(mu xi);
    joint a: eta <- eta + H eta' + sum_r wpos_r theta^r c_r, eta' <- eta' + sum_r wvel_r
    theta^r c_r.  coef (kk, n) real, theta_pow (kk,) = theta^r, E (m,), W (>= kk, m),
    mu, delta (m,) complex, wpos, wvel (>= kk,)."""
    kk = coef.shape[0]
    m = mu.shape[0]
    for i in range(m):
        k = N_JOINTS + i
        xi = (etad[k] - np.conj(mu[i]) * eta[k]) / delta[i]
        acc = E[i] * xi
        f = 0.0j
        for r in range(kk):
            f += W[r, i] * (theta_pow[r] * coef[r, k])
        acc += f / delta[i]
        out_eta[k] = 2.0 * acc.real
        out_etad[k] = 2.0 * (mu[i] * acc).real
    for a in range(N_JOINTS):
        p = eta[a] + H * etad[a]
        v = etad[a]
        for r in range(kk):
            p += wpos[r] * theta_pow[r] * coef[r, a]
            v += wvel[r] * theta_pow[r] * coef[r, a]
        out_eta[a] = p
        out_etad[a] = v


@numba.njit(**JIT)
def phi_table(z, order, radius, terms, inv_fact, out):
    """Fill out (order + 1, n) complex with phi_0 .. phi_order at z (n,) complex: the same
    arithmetic as ``exponential.phi_functions`` (the recurrence phi_{j+1} = (phi_j - 1/j!) / z
    for |z| >= radius, the Taylor series sum_m z^m / (m + j)! with `terms` terms below), one
    loop over the points instead of NumPy passes over masked arrays.  inv_fact (>= terms +
    order + 1,) = 1 / k!."""
    for i in range(z.shape[0]):
        zi = z[i]
        e = np.exp(zi)
        out[0, i] = e
        if abs(zi) >= radius:
            prev = e
            for j in range(order):
                prev = (prev - inv_fact[j]) / zi
                out[j + 1, i] = prev
        else:
            for j in range(1, order + 1):
                acc = inv_fact[terms + j] + 0.0j
                for m in range(terms - 1, -1, -1):
                    acc = acc * zi + inv_fact[m + j]
                out[j, i] = acc


@numba.njit(**JIT)
def dense_diagonal(eta, etad, coef, E, W, wpos, wvel, H, mu, delta, out_eta, out_etad):
    """``advance_diagonal`` to k points inside one step at once (the dense outputs): fill
    out_eta, out_etad (k, n).  E (k, m), W (k, >= kk, m) with the powers theta^r already
    folded in, wpos, wvel (k, >= kk) likewise, H (k,) [s]; coef (kk, n) real."""
    kk = coef.shape[0]
    m = mu.shape[0]
    k = E.shape[0]
    xi = np.empty(m, dtype=np.complex128)
    for i in range(m):
        c = N_JOINTS + i
        xi[i] = (etad[c] - np.conj(mu[i]) * eta[c]) / delta[i]
    for o in range(k):                  # row by row: W[o], E[o] and the outputs read in order
        for i in range(m):
            c = N_JOINTS + i
            f = 0.0j
            for r in range(kk):
                f += W[o, r, i] * coef[r, c]
            acc = E[o, i] * xi[i] + f / delta[i]
            out_eta[o, c] = 2.0 * acc.real
            out_etad[o, c] = 2.0 * (mu[i] * acc).real
        for a in range(N_JOINTS):
            p = eta[a] + H[o] * etad[a]
            v = etad[a]
            for r in range(kk):
                p += wpos[o, r] * coef[r, a]
                v += wvel[o, r] * coef[r, a]
            out_eta[o, a] = p
            out_etad[o, a] = v
