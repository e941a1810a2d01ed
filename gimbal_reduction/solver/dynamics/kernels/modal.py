"""O(D) passes over a body's modal rows and the O(D^2) Coriolis passes (docs/dynamics.md §3, §8).

A body's constant modal matrix V (12, D) holds the rows [P; H; Psi; Theta] (momentum,
inside-frame translation and rotation), M1 (15, D) the independent entries of dM_X/dq_i
(``compiled.inertia_gradient_rows``).  Together with hq = sum_j q_j G_j (3, D), computed per
evaluation from the Coriolis tensor G, they span every O(D) product of the recursion:
B(q) = [P; H + hq],  L = [R^T Psi; Lw Theta]  (joint map of the child joint).
"""

import numba
import numpy as np

from gimbal_reduction.solver.dynamics.kernels import FAST, JIT, extension

# dM_X/dq_i = [[0, Yv^T], [Yv, Ys]] (Yv 3x3, Ys = Y_w + Y_w^T symmetric): 9 + 6 numbers.
YS_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


# ------------------------------------------------------------------ O(D) passes
# Long loops over a body's modes are written on 1-D row views (V[a, o:o + D]):
# indexing a 2-D array inside the loop defeats vectorisation (measured 4-5x slower).
@numba.njit(**FAST)
def dot(a, b):
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i] * b[i]
    return s


@numba.njit(**FAST)
def dotw(a, b, w):
    """sum_i a_i b_i w_i."""
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i] * b[i] * w[i]
    return s


@numba.njit(**FAST)
def axpy(alpha, x, y):
    """y += alpha x, in place."""
    for i in range(x.shape[0]):
        y[i] += alpha * x[i]


@numba.njit(**FAST)
def rows_dot(V, o, D, x, out, r0, nrows):
    """out[r] = V[r0 + r, o:o+D] . x for r < nrows."""
    for r in range(nrows):
        out[r] = dot(V[r0 + r, o:o + D], x)


@numba.njit(**FAST)
def rows_dot2(A, o, D, x, xd, out, outd):
    """out[r] = A[r, o:o+D] . x and outd[r] = A[r, o:o+D] . xd for every row r of A:
    four rows per pass, so x and xd are read once per four rows."""
    nr = A.shape[0]
    r = 0
    while r + 4 <= nr:
        a0, a1, a2, a3 = A[r, o:o + D], A[r + 1, o:o + D], A[r + 2, o:o + D], A[r + 3, o:o + D]
        s0 = s1 = s2 = s3 = t0 = t1 = t2 = t3 = 0.0
        for i in range(D):
            xi = x[i]
            di = xd[i]
            s0 += a0[i] * xi
            s1 += a1[i] * xi
            s2 += a2[i] * xi
            s3 += a3[i] * xi
            t0 += a0[i] * di
            t1 += a1[i] * di
            t2 += a2[i] * di
            t3 += a3[i] * di
        out[r], out[r + 1], out[r + 2], out[r + 3] = s0, s1, s2, s3
        outd[r], outd[r + 1], outd[r + 2], outd[r + 3] = t0, t1, t2, t3
        r += 4
    while r < nr:
        a = A[r, o:o + D]
        s = 0.0
        sd = 0.0
        for i in range(D):
            s += a[i] * x[i]
            sd += a[i] * xd[i]
        out[r] = s
        outd[r] = sd
        r += 1


@numba.njit(**FAST)
def rows_dot4(A, o, D, x, out):
    """out[r] = A[r, o:o+D] . x for every row r of A, four rows per pass over x."""
    nr = A.shape[0]
    r = 0
    while r + 4 <= nr:
        a0, a1, a2, a3 = A[r, o:o + D], A[r + 1, o:o + D], A[r + 2, o:o + D], A[r + 3, o:o + D]
        s0 = s1 = s2 = s3 = 0.0
        for i in range(D):
            xi = x[i]
            s0 += a0[i] * xi
            s1 += a1[i] * xi
            s2 += a2[i] * xi
            s3 += a3[i] * xi
        out[r], out[r + 1], out[r + 2], out[r + 3] = s0, s1, s2, s3
        r += 4
    while r < nr:
        out[r] = dot(A[r, o:o + D], x)
        r += 1


@numba.njit(**FAST)
def rows_combine(A, o, D, coef, nrows, y):
    """y += sum_{r < nrows} coef[r] A[r, o:o+D], four rows per pass over y."""
    r = 0
    while r + 4 <= nrows:
        a0, a1, a2, a3 = A[r, o:o + D], A[r + 1, o:o + D], A[r + 2, o:o + D], A[r + 3, o:o + D]
        c0, c1, c2, c3 = coef[r], coef[r + 1], coef[r + 2], coef[r + 3]
        for i in range(D):
            y[i] += c0 * a0[i] + c1 * a1[i] + c2 * a2[i] + c3 * a3[i]
        r += 4
    while r < nrows:
        axpy(coef[r], A[r, o:o + D], y)
        r += 1


@numba.njit(**FAST)
def project(V, M1, o, Dk, q, qd, qdd, has_acc, pq_given, pq, pqd, pqdd):
    """A body's modal rows applied to its modal state, in one read of the rows:
    pq (27,) = [V; M1] q (taken as given if pq_given), pqd (27,) = [V; M1] q',
    pqdd (12,) = V q'' (0 if not has_acc).  V rows: [P; H; Psi; Theta] (momentum,
    inside-frame translation and rotation); M1 rows: the 15 entries of dM_X/dq_i
    (inertia_gradient_rows)."""
    if pq_given:
        rows_dot4(V, o, Dk, qd, pqd[0:12])
        rows_dot4(M1, o, Dk, qd, pqd[12:27])
    else:
        rows_dot2(V, o, Dk, q, qd, pq[0:12], pqd[0:12])
        rows_dot2(M1, o, Dk, q, qd, pq[12:27], pqd[12:27])
    if has_acc:
        rows_dot(V, o, Dk, qdd, pqdd, int(0), int(12))
    else:
        pqdd[:] = 0.0


@numba.njit(**FAST)
def hb_products(V, HB, o, Dk, x, out):
    """out (12,) = [P; H + hq; Psi; Theta] x for one body: the rows B(q) and Y of the
    solve (H + hq = HB), twelve dot products in one pass over the modes."""
    r0, r1, r2 = V[0, o:o + Dk], V[1, o:o + Dk], V[2, o:o + Dk]
    r3, r4, r5 = HB[0, o:o + Dk], HB[1, o:o + Dk], HB[2, o:o + Dk]
    r6, r7, r8 = V[6, o:o + Dk], V[7, o:o + Dk], V[8, o:o + Dk]
    r9, r10, r11 = V[9, o:o + Dk], V[10, o:o + Dk], V[11, o:o + Dk]
    s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = s8 = s9 = s10 = s11 = 0.0
    for i in range(Dk):
        xi = x[i]
        s0 += r0[i] * xi
        s1 += r1[i] * xi
        s2 += r2[i] * xi
        s3 += r3[i] * xi
        s4 += r4[i] * xi
        s5 += r5[i] * xi
        s6 += r6[i] * xi
        s7 += r7[i] * xi
        s8 += r8[i] * xi
        s9 += r9[i] * xi
        s10 += r10[i] * xi
        s11 += r11[i] * xi
    out[0], out[1], out[2], out[3], out[4], out[5] = s0, s1, s2, s3, s4, s5
    out[6], out[7], out[8], out[9], out[10], out[11] = s6, s7, s8, s9, s10, s11


@numba.njit(**FAST)
def coriolis_pass(G2, q, qd, om):
    """The only O(D^2) work of an evaluation: body k's Coriolis tensor G (D, 3D) read once.

    Returns hq (3D,) = sum_j q_j G_j, hqd (3D,) = sum_j q'_j G_j and gq (D,),
    gq_j = omega . G_j q' (the Coriolis part of dT/dq): 9 D^2 multiply-adds.
    Rows are taken four at a time, so hq and hqd are loaded and stored once per
    four rows (1.25x faster than two at a time, measured; it needs the raised
    alias-check threshold set at import, else the loop is not vectorised).  The
    outputs are allocated here so that the compiler knows they alias nothing."""
    D = q.shape[0]
    D3 = 3 * D
    hq = np.zeros(D3)
    hqd = np.zeros(D3)
    gq = np.empty(D)
    wq = np.empty(D3)
    for a in range(3):
        for i in range(D):
            wq[a * D + i] = om[a] * qd[i]
    j = 0
    while j + 4 <= D:
        q0, q1, q2, q3 = q[j], q[j + 1], q[j + 2], q[j + 3]
        d0, d1, d2, d3 = qd[j], qd[j + 1], qd[j + 2], qd[j + 3]
        r0, r1, r2, r3 = G2[j], G2[j + 1], G2[j + 2], G2[j + 3]
        s0 = s1 = s2 = s3 = 0.0
        for c in range(D3):
            g0 = r0[c]
            g1 = r1[c]
            g2 = r2[c]
            g3 = r3[c]
            hq[c] += q0 * g0 + q1 * g1 + q2 * g2 + q3 * g3
            hqd[c] += d0 * g0 + d1 * g1 + d2 * g2 + d3 * g3
            w = wq[c]
            s0 += g0 * w
            s1 += g1 * w
            s2 += g2 * w
            s3 += g3 * w
        gq[j], gq[j + 1], gq[j + 2], gq[j + 3] = s0, s1, s2, s3
        j += 4
    while j < D:
        qj, dj = q[j], qd[j]
        r0 = G2[j]
        s = 0.0
        for c in range(D3):
            g = r0[c]
            hq[c] += qj * g
            hqd[c] += dj * g
            s += g * wq[c]
        gq[j] = s
        j += 1
    return hq, hqd, gq


@numba.njit(**FAST)
def coriolis_rate_pass(G2, qd, om):
    """hqd (3D,) = sum_j q'_j G_j and gq (D,) as in ``coriolis_pass``, without hq:
    6 D^2 multiply-adds, for when hq = sum_j q_j G_j is already known (``rk4.rk4_core``).
    Eight rows of G per sweep, then four, then one: the sweep's loads of hqd and
    omega (x) q' are shared by more rows (eight measured ~8 % faster than four)."""
    D = qd.shape[0]
    D3 = 3 * D
    out = np.zeros(7 * D)                   # one allocation: [hqd; omega (x) q'; gq]
    hqd = out[0:D3]
    wq = out[D3:2 * D3]
    gq = out[2 * D3:]
    for a in range(3):
        for i in range(D):
            wq[a * D + i] = om[a] * qd[i]
    j = 0
    while j + 8 <= D:
        d0, d1, d2, d3 = qd[j], qd[j + 1], qd[j + 2], qd[j + 3]
        d4, d5, d6, d7 = qd[j + 4], qd[j + 5], qd[j + 6], qd[j + 7]
        r0, r1, r2, r3 = G2[j], G2[j + 1], G2[j + 2], G2[j + 3]
        r4, r5, r6, r7 = G2[j + 4], G2[j + 5], G2[j + 6], G2[j + 7]
        s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = 0.0
        for c in range(D3):
            g0 = r0[c]
            g1 = r1[c]
            g2 = r2[c]
            g3 = r3[c]
            g4 = r4[c]
            g5 = r5[c]
            g6 = r6[c]
            g7 = r7[c]
            hqd[c] += (d0 * g0 + d1 * g1 + d2 * g2 + d3 * g3
                       + d4 * g4 + d5 * g5 + d6 * g6 + d7 * g7)
            w = wq[c]
            s0 += g0 * w
            s1 += g1 * w
            s2 += g2 * w
            s3 += g3 * w
            s4 += g4 * w
            s5 += g5 * w
            s6 += g6 * w
            s7 += g7 * w
        gq[j], gq[j + 1], gq[j + 2], gq[j + 3] = s0, s1, s2, s3
        gq[j + 4], gq[j + 5], gq[j + 6], gq[j + 7] = s4, s5, s6, s7
        j += 8
    while j + 4 <= D:
        d0, d1, d2, d3 = qd[j], qd[j + 1], qd[j + 2], qd[j + 3]
        r0, r1, r2, r3 = G2[j], G2[j + 1], G2[j + 2], G2[j + 3]
        s0 = s1 = s2 = s3 = 0.0
        for c in range(D3):
            g0 = r0[c]
            g1 = r1[c]
            g2 = r2[c]
            g3 = r3[c]
            hqd[c] += d0 * g0 + d1 * g1 + d2 * g2 + d3 * g3
            w = wq[c]
            s0 += g0 * w
            s1 += g1 * w
            s2 += g2 * w
            s3 += g3 * w
        gq[j], gq[j + 1], gq[j + 2], gq[j + 3] = s0, s1, s2, s3
        j += 4
    while j < D:
        dj = qd[j]
        r0 = G2[j]
        s = 0.0
        for c in range(D3):
            g = r0[c]
            hqd[c] += dj * g
            s += g * wq[c]
        gq[j] = s
        j += 1
    return hqd, gq


@numba.njit(**FAST)
def add_inertia_rows(Mx, m):
    """Mx (6, 6) += sum_i x_i dM_X/dq_i given m (15,) = M1 x (inertia_gradient_rows)."""
    for a in range(3):
        for b in range(3):
            s = m[3 * a + b]
            Mx[3 + a, b] += s
            Mx[b, 3 + a] += s
    for c in range(6):
        a, b = YS_PAIRS[c]
        s = m[9 + c]
        Mx[3 + a, 3 + b] += s
        if a != b:
            Mx[3 + b, 3 + a] += s


@numba.njit(**FAST)
def add_inertia(Mx, M1, o, Dk, x):
    """Mx (6, 6) += sum_i x_i dM_X/dq_i, from the 15 rows of M1 (inertia_gradient_rows)."""
    m = np.empty(15)
    rows_dot(M1, o, Dk, x, m, int(0), int(15))
    add_inertia_rows(Mx, m)


@numba.njit(**JIT)
def inertia_weights(w, ww):
    """ww (15,) with 1/2 w^T M1_i w = sum_c ww_c M1[c, i]."""
    for a in range(3):
        for b in range(3):
            ww[3 * a + b] = w[3 + a] * w[b]
    for c in range(6):
        a, b = YS_PAIRS[c]
        ww[9 + c] = (0.5 if a == b else 1.0) * w[3 + a] * w[3 + b]


@numba.njit(**FAST)
def project_all(y, yd, ydd, has_acc, ch, pq_given, Pq, Pqd, Pqdd):
    """Pq, Pqd (4, 27), Pqdd (4, 12) in place: every body's ``project`` (rows of bodies
    without modes are left alone: zero)."""
    D, off, V, M1 = ch.D, ch.off, ch.V, ch.M1
    for k in range(4):
        Dk = D[k]
        if Dk > 0:
            s = 4 + off[k]
            project(V, M1, off[k], Dk, y[s:s + Dk], yd[s:s + Dk], ydd[s:s + Dk], has_acc,
                    pq_given, Pq[k], Pqd[k], Pqdd[k])
    return Pq, Pqd, Pqdd


@numba.njit(**FAST, inline="always")
def projections(y, yd, ydd, has_acc, ch):
    """Pq, Pqd (4, 27), Pqdd (4, 12): every body's ``project``, in new arrays."""
    return project_all(y, yd, ydd, has_acc, ch, bool(False), np.zeros((4, 27)),
                       np.zeros((4, 27)), np.zeros((4, 12)))


@numba.njit(**FAST)
def gram_blocks(V, HB, o, Dk, dinv, gram_k, unit, BB, BY, YY):
    """Weighted Gram blocks (6, 6) of a body's modal rows, W = diag(dinv):
    BB = B W B^T, BY = B W Y^T, YY = Y W Y^T, with B = [P; H + hq] and
    Y = [Psi; Theta].  With W = I only the rows of H + hq are new (gram_k holds
    the constant Gram of [P; H; Psi; Theta]): three fused passes."""
    if unit:
        prod = np.empty(12)
        for a in range(6):
            for b in range(6):
                YY[a, b] = gram_k[6 + a, 6 + b]
        for a in range(3):
            for b in range(3):
                BB[a, b] = gram_k[a, b]
            for b in range(6):
                BY[a, b] = gram_k[a, 6 + b]
        for a in range(3):
            hb_products(V, HB, o, Dk, HB[a, o:o + Dk], prod)
            for b in range(6):
                BB[3 + a, b] = prod[b]
                BB[b, 3 + a] = prod[b]
                BY[3 + a, b] = prod[6 + b]
        return
    w = dinv[o:o + Dk]
    for a in range(6):
        ra = V[a, o:o + Dk] if a < 3 else HB[a - 3, o:o + Dk]
        for b in range(a + 1):
            rb = V[b, o:o + Dk] if b < 3 else HB[b - 3, o:o + Dk]
            s = dotw(ra, rb, w)
            BB[a, b] = s
            BB[b, a] = s
        for b in range(6):
            BY[a, b] = dotw(ra, V[6 + b, o:o + Dk], w)
        for b in range(a + 1):
            s = dotw(V[6 + a, o:o + Dk], V[6 + b, o:o + Dk], w)
            YY[a, b] = s
            YY[b, a] = s


@numba.njit(**JIT)
def linear_data(y, yd, ch):
    """LIN (3S + 108,) = [hq; Pq] of a state (``recursion.inverse_dynamics_into``) and Pqd
    (4, 27), directly: hq = sum_j q_j G_j by row combination (3 D^2), Pq and Pqd by projection."""
    D, off, G = ch.D, ch.off, ch.G
    S = y.shape[0] - 4
    LIN = np.zeros(3 * S + 108)
    Pqd = np.zeros((4, 27))
    for k in range(4):
        Dk = D[k]
        if Dk > 0:
            s = 4 + off[k]
            b0 = 3 * off[k]
            rows_combine(G[k], int(0), 3 * Dk, y[s:s + Dk], Dk, LIN[b0:b0 + 3 * Dk])
    project_all(y, yd, y, bool(False), ch, bool(False), LIN[3 * S:].reshape((4, 27)), Pqd, np.zeros((4, 12)))
    return LIN, Pqd


# this module's entries compiled ahead of time, when built and current (kernels.extension)
extension.attach(__name__)
