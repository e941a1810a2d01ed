"""Eigenpairs of a symmetric matrix with one row and column deleted, from the matrix's own.

For A = P diag(mu) P^T (n x n, mu ascending) and the principal submatrix A_-i (row and column
i deleted), with z = P^T e_i (row i of P):

* the eigenvalues of A_-i are the n - 1 roots of the secular function
  f(x) = e_i^T (A - x)^-1 e_i = sum_j z_j^2 / (mu_j - x), one between each pair of poles
  (Cauchy interlacing), because f(x) = det(A_-i - x) / det(A - x);
* the eigenvector for a root x is y = (A - x)^-1 e_i = P (z / (mu - x)): its component i is
  f(x) = 0, and (A - x) y = e_i vanishes on the other rows.

So an eigenvector of A_-i is P u with u_j proportional to z_j / (mu_j - x): every product
v^T y with fixed vectors v costs O(n) per root once P^T v is known, and the whole
decomposition O(n^2) instead of the O(n^3) of a new eigensolver call.  This module computes the
roots and the coefficient matrix U (n - 1, n) with rows u; ``gimbal_reduction.reduction.frozen_chain`` uses it
for the backward eliminations of the load-aware ranking, which delete one mode after another
from a kept set.

Numerics (the standard ones of divide-and-conquer eigensolvers, written for this case; the
method is Bunch, Nielsen and Sorensen's, with Gu and Eisenstat's recomputed z):

* deflation: a pole with |z_j| <= DEFLATE_Z (it hardly touches row i) stays an eigenvalue
  of A_-i with eigenvector p_j; the change to A is ~|z_j| |mu_j|, the backward error of any
  symmetric eigensolver;
* each root is found in coordinates shifted to its nearer pole, x = d_K + tau, so that the
  differences d_j - x that make the eigenvector are accurate to a few units of rounding
  relative to themselves, also for a root 1e-30 away from its pole;
* the iteration is the "middle way" of LAPACK's dlaed4 (f modelled by two poles, the
  neighbours of the root, and a constant), safeguarded by bisection inside a bracket kept from
  the sign of f (f increases between poles); 4-5 passes per root on the real chains;
* z is recomputed from the roots (Loewner's formula, z_j^2 = prod_m (x_m - d_j) /
  prod_{l != j} (d_l - d_j), in pairs of factors near 1), which makes the computed vectors
  exact eigenvectors of a nearby matrix and so orthogonal to working precision.

Two close poles that both touch row i (a near-multiple eigenvalue: gap <= CLOSE_POLES times
the largest |mu|), a nonpositive pole spacing, or an iteration that does not converge make
``delete_index`` report failure (ok = False); the caller then calls an eigensolver on A_-i.
"""
import numba
import numpy as np

EPS = np.finfo(float).eps
DEFLATE_Z = 8 * EPS         # |z_j| below this: pole j is an eigenvalue of A_-i (z normalised)
CLOSE_POLES = 8 * EPS       # poles closer than this times max |mu| (both undeflated): not handled
MAX_ITER = 60


@numba.njit(cache=True, error_model="numpy")
def _secular_delete(mu, z):
    """(ok, x (n - 1,) ascending, U (n - 1, n)): the eigenvalues of A_-i and the coefficients of
    its eigenvectors in the basis P, for A = P diag(mu) P^T, mu (n,) ascending, z = P[i] (n,)
    (normalised here; module docstring).  ok False: not handled (close poles, no convergence).

    All roots iterate together, pass by pass, so that the inner loops run over the roots
    (contiguous, no reduction: compiled to vector instructions)."""
    n = mu.size
    x = np.zeros(n - 1)
    U = np.zeros((n - 1, n))
    scale = max(abs(mu[0]), abs(mu[n - 1]))
    znorm = 0.0
    for j in range(n):
        znorm += z[j] * z[j]
    znorm = np.sqrt(znorm)
    # ---- deflation: undeflated poles idx[0..p-1], deflated ones dfl[0..nd-1]
    idx = np.empty(n, np.int64)
    dfl = np.empty(n, np.int64)
    p = 0
    nd = 0
    for j in range(n):
        if abs(z[j]) <= DEFLATE_Z * znorm:
            dfl[nd] = j
            nd += 1
        else:
            idx[p] = j
            p += 1
    if p == 0:                   # z = 0: not a row of an orthogonal matrix
        return False, x, U
    d = np.empty(p)
    w = np.empty(p)
    for k in range(p):
        d[k] = mu[idx[k]]
        w[k] = (z[idx[k]] / znorm) ** 2
    for k in range(p - 1):
        if not d[k + 1] - d[k] > CLOSE_POLES * scale:
            return False, x, U
    q = p - 1                    # roots: root k in (d[k], d[k+1])
    # ---- the nearer pole of each root: the sign of f at the midpoint (f increases)
    f = np.zeros(q)
    t = np.empty(q)
    for k in range(q):
        t[k] = 0.5 * (d[k + 1] - d[k])
    for j in range(p):
        wj, dj = w[j], d[j]
        dk, tk, fk = d[:q], t, f
        for k in range(q):
            fk[k] += wj / ((dj - dk[k]) - tk[k])
    dK = np.empty(q)             # the root is dK + t
    lo = np.empty(q)
    hi = np.empty(q)
    for k in range(q):
        gap = d[k + 1] - d[k]
        if f[k] >= 0.0:          # root in (d[k], mid]: t in (0, gap/2]; start at mid
            dK[k], lo[k], hi[k], t[k] = d[k], 0.0, 0.5 * gap, 0.5 * gap
        else:                    # root in (mid, d[k+1]): t in (-gap/2, 0)
            dK[k], lo[k], hi[k], t[k] = d[k + 1], -0.5 * gap, 0.0, -0.5 * gap
    # ---- the middle way (dlaed4), all roots per pass
    psi = np.empty(q)
    dpsi = np.empty(q)
    phi = np.empty(q)
    dphi = np.empty(q)
    done = np.zeros(q, np.bool_)
    for it in range(MAX_ITER):
        psi[:] = 0.0
        dpsi[:] = 0.0
        phi[:] = 0.0
        dphi[:] = 0.0
        for j in range(p):
            wj, dj = w[j], d[j]
            # roots k >= j have pole j on their left (psi), roots k < j on their right (phi)
            dKa, ta, pa, dpa = dK[j:], t[j:], psi[j:], dpsi[j:]
            for k in range(q - j if j < q else 0):
                inv = 1.0 / ((dj - dKa[k]) - ta[k])
                v = wj * inv
                pa[k] += v
                dpa[k] += v * inv
            m = j if j < q else q
            dKb, tb, pb, dpb = dK[:m], t[:m], phi[:m], dphi[:m]
            for k in range(m):
                inv = 1.0 / ((dj - dKb[k]) - tb[k])
                v = wj * inv
                pb[k] += v
                dpb[k] += v * inv
        active = 0
        for k in range(q):
            if done[k]:
                continue
            fk = psi[k] + phi[k]
            err = 8.0 * (phi[k] - psi[k]) + abs(t[k]) * (dpsi[k] + dphi[k])  # rounding of f
            if abs(fk) <= EPS * err:
                done[k] = True
                continue
            if fk < 0.0:
                lo[k] = t[k]
            else:
                hi[k] = t[k]
            # f(y) ~ c + s / (D0 - eta) + S / (D1 - eta): poles d[k], d[k+1] and a constant
            D0 = (d[k] - dK[k]) - t[k]          # < 0
            D1 = (d[k + 1] - dK[k]) - t[k]      # > 0
            s = D0 * D0 * dpsi[k]
            S = D1 * D1 * dphi[k]
            c = fk - D0 * dpsi[k] - D1 * dphi[k]
            a = c * (D0 + D1) + s + S
            b = c * D0 * D1 + s * D1 + S * D0
            if c == 0.0:
                eta = b / a if a != 0.0 else 0.0
            else:
                r = np.sqrt(max(a * a - 4.0 * b * c, 0.0))
                eta = (a - r) / (2.0 * c) if a <= 0.0 else 2.0 * b / (a + r)
            t_new = t[k] + eta
            if not (lo[k] < t_new < hi[k]):
                t_new = 0.5 * (lo[k] + hi[k])
            if t_new == t[k]:
                done[k] = True
                continue
            t[k] = t_new
            active += 1
        if active == 0:
            break
    for k in range(q):
        if not done[k]:
            return False, x, U
    # ---- Loewner: z recomputed from the roots, in pairs of factors near 1
    prod = np.ones(p)
    for k in range(q):
        xk, tk = dK[k], t[k]
        # poles j > k pair root k with pole k, poles j <= k with pole k + 1
        da, pa = d[k + 1:], prod[k + 1:]
        for j in range(p - k - 1):
            pa[j] *= ((xk - da[j]) + tk) / (d[k] - da[j])
        db, pb = d[:k + 1], prod[:k + 1]
        for j in range(k + 1):
            pb[j] *= ((xk - db[j]) + tk) / (d[k + 1] - db[j])
    zh = np.empty(p)
    for j in range(p):
        v = np.sqrt(max(prod[j], 0.0))
        zh[j] = v if z[idx[j]] >= 0.0 else -v
    # ---- rows in ascending order: the deflated poles merged with the roots (both ascending)
    u = np.empty(p)
    a = 0                        # next deflated pole
    for k in range(q + 1):
        xk = dK[k] + t[k] if k < q else np.inf
        while a < nd and mu[dfl[a]] <= xk:
            x[a + k] = mu[dfl[a]]
            U[a + k, dfl[a]] = 1.0
            a += 1
        if k == q:
            break
        # eigenvector of root k: u_j = zh_j / (d_j - x_k), normalised
        xK, tk = dK[k], t[k]
        nrm = 0.0
        for j in range(p):
            u[j] = zh[j] / ((d[j] - xK) - tk)
        for j in range(p):
            nrm += u[j] * u[j]
        nrm = 1.0 / np.sqrt(nrm)
        row = U[a + k]
        for j in range(p):
            row[idx[j]] = u[j] * nrm
        x[a + k] = xk
    return True, x, U


def delete_index(mu, P, i):
    """(ok, x (n - 1,), U (n - 1, n)): eigenvalues ascending and eigenvector coefficients of
    A_-i, A = P diag(mu) P^T with mu (n,) ascending (an eigensolver's output); the eigenvectors
    of A_-i are (P U^T) with row i dropped.  ok False: a case left to an eigensolver (module
    docstring); n = 1 gives empty arrays."""
    mu = np.ascontiguousarray(mu, dtype=float)
    n = mu.size
    if n == 1:
        return True, np.zeros(0), np.zeros((0, 1))
    return _secular_delete(mu, np.ascontiguousarray(P[i], dtype=float))
