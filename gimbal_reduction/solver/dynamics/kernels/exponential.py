"""Compiled core of the exponential integrator's step (``gimbal_reduction.solver.dynamics.exponential``).

``advance_diagonal``: the variation-of-constants update of every mode over a length H with
the forcing polynomial sum_r c_r (s / h)^r, for the undamped (diagonal) oscillator bank, in
one loop over the modes (``modal_xi`` its complex coordinates at the start); ``phi_table``:
the phi-functions its weights are made of; ``dense_diagonal``, ``dense_coupled``: the
outputs inside a step, of the undamped and the damped bank.  Used by the compiled step loop
(``kernels.pece``) and by ``exponential.advance``.
"""

import numba
import numpy as np

from gimbal_reduction.solver.dynamics.kernels import JIT, extension

N_JOINTS = 4


@numba.njit(**JIT)
def modal_xi(eta, etad, mu, delta, xi_re, xi_im):
    """The undamped bank's complex coordinates xi = (eta' - conj(mu) eta) / delta of the elastic
    modes (index 4 + i of eta, etad (n,)) into their real and imaginary parts xi_re, xi_im (m,);
    mu, delta (m,) complex.  Once per step: every advance of the step starts from them."""
    for i in range(mu.shape[0]):
        k = N_JOINTS + i
        xi = (etad[k] - np.conj(mu[i]) * eta[k]) / delta[i]
        xi_re[i] = xi.real
        xi_im[i] = xi.imag


@numba.njit(**JIT)
def advance_diagonal(eta, etad, xi_re, xi_im, coef, theta_pow, E_re, E_im, F_re, F_im, wpos, wvel, mu, H,
                     out_eta, out_etad):
    """Fill out_eta, out_etad (n,) with the modal state after a length H [s] from (eta, eta') (n,):
    elastic mode i (index 4 + i), from its xi = xi_re + i xi_im (``modal_xi``),
    acc = E_i xi + sum_r F[r, i] theta^r c_r with F = W / delta (the forcing weights of the
    undamped bank, ``pece.fill_weights``), eta = 2 Re acc, eta' = 2 Re(mu acc); joint a:
    eta <- eta + H eta' + sum_r wpos_r theta^r c_r, eta' <- eta' + sum_r wvel_r theta^r c_r.
    coef (kk, n) real, theta_pow (kk,) = theta^r, E_re, E_im (m,), F_re, F_im (>= kk, m),
    mu (m,) complex, wpos, wvel (>= kk,); out_eta must not be eta, etad or coef.  Real and
    imaginary parts in separate arrays, no division, and every loop over the modes with
    contiguous rows (acc is summed over r in the same order, for each mode, as a loop over the
    modes outside would): the loops vectorise (measured 5.4 -> 0.9 us for 400 modes, kk = 5)."""
    kk = coef.shape[0]
    m = mu.shape[0]
    j = N_JOINTS
    a_re = out_eta[j:]                  # Re acc, accumulated in place
    a_im = np.empty(m)
    for i in range(m):
        a_re[i] = E_re[i] * xi_re[i] - E_im[i] * xi_im[i]
        a_im[i] = E_re[i] * xi_im[i] + E_im[i] * xi_re[i]
    for r in range(kk):
        tp = theta_pow[r]
        c_r, f_re, f_im = coef[r, j:], F_re[r], F_im[r]
        for i in range(m):
            c = tp * c_r[i]
            a_re[i] += f_re[i] * c
            a_im[i] += f_im[i] * c
    for i in range(m):
        out_etad[j + i] = 2.0 * (mu[i].real * a_re[i] - mu[i].imag * a_im[i])
        a_re[i] = 2.0 * a_re[i]
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
    """Fill out (order + 1, n) complex with phi_0 .. phi_order at z (n,) complex
    (``exponential.phi_functions``): the recurrence phi_{j+1} = (phi_j - 1/j!) / z for
    |z| >= radius, below it the Taylor series phi_order(z) = sum_m z^m / (m + order)! with
    `terms` terms and the same recurrence downwards; one loop over the points instead of NumPy
    passes over masked arrays.  inv_fact (>= terms + order + 1,) = 1 / k!."""
    for i in range(z.shape[0]):
        zi = z[i]
        e = np.exp(zi)
        out[0, i] = e
        if abs(zi) >= radius:
            prev = e
            inv = 1.0 / zi                  # one division, then products (6x cheaper than divisions)
            for j in range(order):
                prev = (prev - inv_fact[j]) * inv
                out[j + 1, i] = prev
        elif order > 0:
            # the Taylor series of the highest one only, then down by phi_j = z phi_{j+1} + 1/j!
            # (stable here: an error in phi_{j+1} enters phi_j relatively smaller by |z| / (j + 1)
            # < 1 for |z| < radius = 2; one series instead of `order`, 5x fewer operations)
            acc = inv_fact[terms + order] + 0.0j
            for m in range(terms - 1, -1, -1):
                acc = acc * zi + inv_fact[m + order]
            out[order, i] = acc
            for j in range(order - 1, 0, -1):
                acc = zi * acc + inv_fact[j]
                out[j, i] = acc


@numba.njit(**JIT)
def dense_diagonal(eta, etad, xi_re, xi_im, coef, mu, delta, h, dt, count, Ed_re, Ed_im, radius, terms,
                   inv_fact, fact, out_eta, out_etad):
    """The undamped bank's dense outputs at s = k dt, k = 1..count, inside a step of h [s] from
    (eta, eta') (n,) (xi_re, xi_im: its ``modal_xi``) with the forcing polynomial
    p(s) = sum_r coef[r] (s / h)^r (coef (kk, n)), into out_eta, out_etad (count, n): the same
    exact solution as ``advance_diagonal`` with the weights of each length, written as the
    polynomial particular solution plus the free oscillation, so that no weights per output
    time are needed.  Mode i (eta'' - 2 Re(mu_i) eta' + |mu_i|^2 eta = p): in u = s / h the
    particular solution P(u) = sum_k d_k u^k solves W^2 d_k + b (k + 1) d_{k+1}
    + (k + 2)(k + 1) d_{k+2} = h^2 c_k (W^2 = |mu_i|^2 h^2, b = -2 Re(mu_i) h; backwards from
    the top degree); the free part xi_h = xi - (P'(0) / h - conj(mu) P(0)) / delta turns by
    Ed = e^{mu dt} (Ed_re, Ed_im (m,): the weights of one output interval) from output to
    output; eta = 2 Re xi_h + P(u), eta' = 2 Re(mu xi_h) + P'(u) / h.  The recursion divides
    by W^2 and its terms grow by (k + 2)(k + 1) / W^2: modes with W < radius (slow against
    the step) take the phi-function formula of ``advance_diagonal`` instead, per output
    (``phi_table`` of those modes only).  Joints: eta + H eta' + sum_r H^2 r!/(r+2)! theta^r
    c_r, eta' + sum_r H r!/(r+1)! theta^r c_r, H = k dt, theta = H / h.  inv_fact, fact
    (>= terms + kk + 2,) 1/k!, k!."""
    kk = coef.shape[0]
    m = mu.shape[0]
    j = N_JOINTS
    d = np.zeros((kk + 2, m))
    h2 = h * h
    slow = np.zeros(m, dtype=np.int64)
    n_slow = 0
    for i in range(m):
        W2 = (mu[i].real ** 2 + mu[i].imag ** 2) * h2
        if W2 < radius * radius:
            slow[n_slow] = i
            n_slow += 1
    for k in range(kk - 1, -1, -1):
        for i in range(m):
            W2 = (mu[i].real ** 2 + mu[i].imag ** 2) * h2
            if W2 < radius * radius:
                continue                    # a slow mode: the phi formula below
            bb = -2.0 * mu[i].real * h
            d[k, i] = (h2 * coef[k, j + i] - bb * (k + 1) * d[k + 1, i]
                       - (k + 2) * (k + 1) * d[k + 2, i]) / W2
    h_re = np.empty(m)
    h_im = np.empty(m)
    for i in range(m):
        # xi_P(0) = (P'(0) / h - conj(mu) P(0)) / delta
        p0 = d[0, i]
        p1 = d[1, i] / h if kk > 1 else 0.0
        xp = (p1 - np.conj(mu[i]) * p0) / delta[i]
        h_re[i] = xi_re[i] - xp.real
        h_im[i] = xi_im[i] - xp.imag
    mu_re = mu.real.copy()
    mu_im = mu.imag.copy()
    if n_slow:
        zs = np.empty(n_slow, dtype=np.complex128)
        phis = np.empty((kk + 1, n_slow), dtype=np.complex128)
    for k in range(count):
        H = (k + 1) * dt
        u = H / h
        for i in range(m):
            t = Ed_re[i] * h_re[i] - Ed_im[i] * h_im[i]
            h_im[i] = Ed_re[i] * h_im[i] + Ed_im[i] * h_re[i]
            h_re[i] = t
        oe = out_eta[k, j:]
        od = out_etad[k, j:]
        for i in range(m):
            oe[i] = d[kk - 1, i]
            od[i] = 0.0
        for r in range(kk - 2, -1, -1):
            for i in range(m):
                od[i] = od[i] * u + oe[i]
                oe[i] = oe[i] * u + d[r, i]
        for i in range(m):
            oe[i] += 2.0 * h_re[i]
            od[i] = od[i] / h + 2.0 * (mu_re[i] * h_re[i] - mu_im[i] * h_im[i])
        if n_slow:
            # the slow modes by the phi-function formula (advance_diagonal's, theta^r unfolded)
            for s in range(n_slow):
                zs[s] = H * mu[slow[s]]
            phi_table(zs, kk, radius, terms, inv_fact, phis)
            for s in range(n_slow):
                i = slow[s]
                acc = phis[0, s] * (xi_re[i] + 1j * xi_im[i])
                tp = 1.0
                for r in range(kk):
                    acc += H * fact[r] * phis[r + 1, s] * (tp * coef[r, j + i]) / delta[i]
                    tp *= u
                oe[i] = 2.0 * acc.real
                od[i] = 2.0 * (mu[i] * acc).real
        joints_dense(eta, etad, coef, H, u, fact, out_eta[k], out_etad[k])


@numba.njit(**JIT)
def joints_dense(eta, etad, coef, H, u, fact, out_eta, out_etad):
    """The joints' part of a dense output at length H [s], u = H / h inside a step of h [s]: the
    forcing polynomial sum_r coef[r] u^r integrated twice from (eta, eta') (n,),
    eta + H eta' + sum_r H^2 r!/(r+2)! u^r c_r and eta' + sum_r H r!/(r+1)! u^r c_r, into the
    first N_JOINTS entries of out_eta, out_etad (n,).  fact (>= kk + 2,) k!."""
    for a in range(N_JOINTS):
        p = eta[a] + H * etad[a]
        v = etad[a]
        tp = 1.0
        for r in range(coef.shape[0]):
            p += H * H * (fact[r] / fact[r + 2]) * tp * coef[r, a]
            v += H * (fact[r] / fact[r + 1]) * tp * coef[r, a]
            tp *= u
        out_eta[a] = p
        out_etad[a] = v


@numba.njit(**JIT)
def dense_coupled(eta, etad, coef, mu, P_eta, P_vel, V_real, h, tick, offset, spacing, count, radius,
                  terms, inv_fact, fact, out_eta, out_etad):
    """The damped bank's dense outputs (``exponential.CoupledBank``) at the lengths
    H_k = (offset + k spacing) tick [s] (offset, spacing in grid ticks of tick [s]),
    k = 0..count-1, inside a step of h [s] from (eta, eta') (n,) with the
    forcing polynomial p(s) = sum_r coef[r] (s / h)^r (coef (kk, n)), into out_eta, out_etad
    (count, n): the exact solution of ``pece.coupled_advance`` at each length, arranged so that
    the O(p m) products are paid once per step and not once per output.

    In the bank's coordinates xi = P [eta; eta'] (p,) complex, with xi' = mu xi + P_vel p(s),
    the variation of constants over H = theta h reads

        xi(H) = e^{H mu} xi_0 + sum_r H r! phi_{r+1}(H mu) theta^r b_r,   b_r = P_vel c_r,

    so the start xi_0 = P_eta eta_0 + P_vel eta'_0 and the forcing's coordinates b_r are mapped
    once (one complex product P_vel [eta'_0, c_0, .., c_{kk-1}], (p, kk + 1)); each output then
    costs its phi-functions (``phi_table`` at H mu) and O(p kk) products.  The outputs return to
    (eta, eta') together: with Xi (count, 2p) the rows [Re xi(H_k), Im xi(H_k)] and V_real
    (2p, 2m) = [[Re V_eta^T, Re V_vel^T], [-Im V_eta^T, -Im V_vel^T]] (P_eta, P_vel (p, m) and
    V_eta, V_vel (m, p) complex as in ``pece.Basis``), Re(V xi) = Re V Re xi - Im V Im xi makes
    [eta_e, eta'_e] (count, 2m) = Xi V_real one real matrix product.  Joints: ``joints_dense``.
    inv_fact, fact
    (>= terms + kk + 2,) 1/k!, k!."""
    kk = coef.shape[0]
    p = mu.shape[0]
    j = N_JOINTS
    m = eta.shape[0] - j
    rhs = np.empty((m, kk + 1), dtype=np.complex128)      # [eta'_0, c_0, .., c_{kk-1}] (elastic)
    for i in range(m):
        rhs[i, 0] = etad[j + i]
        for r in range(kk):
            rhs[i, r + 1] = coef[r, j + i]
    B = np.dot(P_vel, rhs)                                 # (p, kk + 1): P_vel eta'_0, b_r
    xi0 = np.dot(P_eta, eta[j:].astype(np.complex128)) + B[:, 0]
    Bt = np.ascontiguousarray(B.T)                        # (kk + 1, p): rows contiguous
    Xi = np.empty((count, 2 * p))
    z = np.empty(p, dtype=np.complex128)
    phis = np.empty((kk + 1, p), dtype=np.complex128)
    acc = np.empty(p, dtype=np.complex128)
    for k in range(count):
        H = (offset + k * spacing) * tick
        u = H / h
        for i in range(p):
            z[i] = H * mu[i]
        phi_table(z, kk, radius, terms, inv_fact, phis)
        for i in range(p):
            acc[i] = phis[0, i] * xi0[i]
        tp = 1.0
        for r in range(kk):
            wr = H * fact[r] * tp
            b_r, ph = Bt[r + 1], phis[r + 1]
            for i in range(p):
                acc[i] += wr * ph[i] * b_r[i]
            tp *= u
        for i in range(p):
            Xi[k, i] = acc[i].real
            Xi[k, p + i] = acc[i].imag
    Z = np.dot(Xi, V_real)                                 # (count, 2m): [eta_e, eta'_e]
    for k in range(count):
        out_eta[k, j:] = Z[k, :m]
        out_etad[k, j:] = Z[k, m:]
        H = (offset + k * spacing) * tick
        joints_dense(eta, etad, coef, H, H / h, fact, out_eta[k], out_etad[k])

# this module's entries compiled ahead of time, when built and current (kernels.extension)
extension.attach(__name__)
