"""Compiled right-hand side of the chain: the same equations as ``solver.dynamics.multibody``.

Why compiled: the recursion of ``multibody.accelerations`` is a few hundred
tiny array operations (3-vectors, 6x6 matrices) per evaluation; in NumPy each
costs ~1-5 us of call overhead, so one evaluation takes milliseconds, while
the truth model needs ~1e5 evaluations.  The profile shows the time goes to
call overhead (``np.cross``, small ``inv``, ``tensordot``), not arithmetic,
which is exactly what Numba removes.  The arithmetic that remains is the
O(D^2) contraction of the modal Coriolis tensor G (D, 3, D) with q, q' and
omega, done here in one fused pass over G per body.

``make_rhs(chain, case, torque)`` returns rhs(t, y, y') -> y''; it raises
ImportError when Numba is missing (``integrators.make_rhs`` then falls back
to the NumPy reference path).  The kernels take the chain as flat arrays
(``pack``), bodies' modes concatenated; tests compare them with
``multibody`` to round-off.
"""

import math

import llvmlite.binding
import numpy as np
import numba

from solver.dynamics import multibody

_JIT = dict(cache=True, fastmath=False, error_model="numpy")


def _allow_runtime_alias_checks(limit=16):
    """Let LLVM vectorise loops over many row views.  Numba cannot tell LLVM that two
    array views do not overlap, so a loop that writes one and reads several is
    vectorised only behind runtime overlap checks, at most 8 by default: the Coriolis
    pass with four rows of G needs more and ran 3x slower, unvectorised.  An LLVM
    option may be given only once per process, hence the guard."""
    if not getattr(llvmlite.binding, "_gimbal_alias_checks", False):
        llvmlite.binding.set_option("", f"--runtime-memory-check-threshold={limit}")
        llvmlite.binding._gimbal_alias_checks = True


_allow_runtime_alias_checks()


# Rows of a body's constant modal matrix V (12, D): the modal integrals the right-hand
# side contracts with modal vectors.  Together with hq = sum_j q_j G_j (3, D), computed
# per evaluation, they span every O(D) product of the recursion (docs/dynamics.md §3):
#   B(q) = [P; H + hq],   L = [R^T Psi; Lw Theta]   (joint map of the child joint).



# dM_X/dq_i = [[0, Yv^T], [Yv, Ys]] (Yv 3x3, Ys = Y_w + Y_w^T symmetric): 9 + 6 numbers.
_YS_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def inertia_gradient_rows(inertia_gradient, number=0):
    """(15, D): per mode the entries Yv[a, b] (rows 3a + b) and Ys[a, b], a <= b (rows
    9.. in the order of _YS_PAIRS) of dM_X/dq_i (D, 6, 6), whose structure (zero
    translational block, symmetry) is checked: the kernels rely on it."""
    M1 = np.asarray(inertia_gradient, float)
    scale = max(np.abs(M1).max(), 1e-300)
    if np.abs(M1[:, :3, :3]).max() > 1e-12 * scale or \
            np.abs(M1 - M1.transpose(0, 2, 1)).max() > 1e-12 * scale:
        raise ValueError(f"body {number}: inertia_gradient is not [[0, Yv^T], [Yv, Ys]] "
                         f"with Ys symmetric (reduction.modal_integrals.inertia_gradient)")
    rows = np.empty((15, M1.shape[0]))
    for a in range(3):
        for b in range(3):
            rows[3 * a + b] = M1[:, 3 + a, b]
    for c, (a, b) in enumerate(_YS_PAIRS):
        rows[9 + c] = M1[:, 3 + a, 3 + b]
    return rows


def pack(chain):
    """Flat arrays of the chain for the kernels.

    D (4,) modes per body; off (4,) offsets of each body's modes in q (S = sum D);
    M6 (4, 6, 6) rigid mass X^T M X; V (12, S) rows [P; H; Psi; Theta] per body
    (Psi = Theta = 0 for the platform); gram (4, 12, 12) V_k V_k^T; M1 (15, S)
    the 15 independent entries of dM_X/dq_i (``inertia_gradient_rows``); G: 4-tuple of (D_k, 3 D_k) Coriolis tensors G[j, a D + i]
    = (G_j)_{a i}; om2 (S,) Omega^2 [(rad/s)^2]; cd (S,) 2 zeta Omega [1/s]; C1, C
    (3, 3) fixed joint axes; rho (3,) gimbal offset [in]."""
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
    return (D, off, M6, V, gram, M1, tuple(G), om2, cd,
            np.ascontiguousarray(chain.case_to_outer, dtype=float),
            np.ascontiguousarray(chain.parent_to_child, dtype=float),
            np.ascontiguousarray(chain.gimbal_offset, dtype=float))


# ------------------------------------------------------------------ small vectors
# Why no small arrays: an evaluation used to allocate ~600 of them (3-vectors, 6x6
# temporaries), ~17 ns each to allocate and free, plus the cache traffic; that was half
# of the fixed cost of an evaluation.  Now 3-vectors are tuples, which Numba keeps in
# registers, and 6x6 temporaries live in scratch arrays allocated once per evaluation.
# Reassociation only (no "no-NaN/no-Inf" assumptions: a diverging state must stay visible).
_FAST = dict(cache=True, fastmath={"reassoc", "contract", "nsz"}, error_model="numpy")


@numba.njit(**_JIT)
def _cr(a, b):
    """a x b for 3-vectors (tuples or arrays) -> tuple."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@numba.njit(**_JIT)
def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@numba.njit(**_JIT)
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@numba.njit(**_JIT)
def _scale(s, a):
    return (s * a[0], s * a[1], s * a[2])


@numba.njit(**_JIT)
def _mv3(R, x):
    """R x for a (3, 3) array R -> tuple."""
    return (R[0, 0] * x[0] + R[0, 1] * x[1] + R[0, 2] * x[2],
            R[1, 0] * x[0] + R[1, 1] * x[1] + R[1, 2] * x[2],
            R[2, 0] * x[0] + R[2, 1] * x[1] + R[2, 2] * x[2])


@numba.njit(**_JIT)
def _mtv3(R, x):
    """R^T x for a (3, 3) array R -> tuple."""
    return (R[0, 0] * x[0] + R[1, 0] * x[1] + R[2, 0] * x[2],
            R[0, 1] * x[0] + R[1, 1] * x[1] + R[2, 1] * x[2],
            R[0, 2] * x[0] + R[1, 2] * x[1] + R[2, 2] * x[2])


@numba.njit(**_JIT)
def _adinv(R, p, w):
    """Ad_{g^-1} w = [R^T (v + omega x p); R^T omega] (6,) for the pose g = (R, p)."""
    om = (w[3], w[4], w[5])
    v = _mtv3(R, _add((w[0], w[1], w[2]), _cr(om, p)))
    o = _mtv3(R, om)
    return np.array([v[0], v[1], v[2], o[0], o[1], o[2]])


# 6x6 algebra into preallocated outputs (out must not alias an input); transposes are
# passed as views (A.T).  A row of the result is accumulated in six scalars: 1.5x
# faster than the plain triple loop.
@numba.njit(**_FAST)
def _mm6(A, B, out):
    """out = A B."""
    for i in range(6):
        r0 = r1 = r2 = r3 = r4 = r5 = 0.0
        for k in range(6):
            a = A[i, k]
            r0 += a * B[k, 0]
            r1 += a * B[k, 1]
            r2 += a * B[k, 2]
            r3 += a * B[k, 3]
            r4 += a * B[k, 4]
            r5 += a * B[k, 5]
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4], out[i, 5] = r0, r1, r2, r3, r4, r5


@numba.njit(**_FAST)
def _mv6(A, x, out):
    """out = A x."""
    for i in range(6):
        s = 0.0
        for k in range(6):
            s += A[i, k] * x[k]
        out[i] = s


@numba.njit(**_JIT)
def _inv6(A, X, M):
    """X = A^-1 (6x6) by Gauss-Jordan elimination with partial pivoting; M is scratch."""
    n = 6
    for i in range(n):
        for j in range(n):
            M[i, j] = A[i, j]
            X[i, j] = 1.0 if i == j else 0.0
    for c in range(n):
        piv = c
        big = abs(M[c, c])
        for r in range(c + 1, n):
            if abs(M[r, c]) > big:
                big = abs(M[r, c])
                piv = r
        if piv != c:
            for j in range(n):
                M[c, j], M[piv, j] = M[piv, j], M[c, j]
                X[c, j], X[piv, j] = X[piv, j], X[c, j]
        inv = 1.0 / M[c, c]
        for j in range(n):
            M[c, j] *= inv
            X[c, j] *= inv
        for r in range(n):
            if r != c:
                f = M[r, c]
                if f != 0.0:
                    for j in range(n):
                        M[r, j] -= f * M[c, j]
                        X[r, j] -= f * X[c, j]


@numba.njit(**_JIT)
def _adinv_matrix(R, p, A):
    """A (6, 6) = Ad_{g^-1} = [[R^T, -R^T p~], [0, R^T]], in place."""
    for i in range(3):
        for j in range(3):
            A[i, j] = R[j, i]
            A[3 + i, 3 + j] = R[j, i]
            A[3 + i, j] = 0.0
        # row i of -R^T p~:  -(R^T p~)[i, :] = (p x R[:, i])^T ... written out
        c0, c1, c2 = R[0, i], R[1, i], R[2, i]      # column i of R = row i of R^T
        # (R^T p~)[i, j] = sum_m R[m, i] p~[m, j],  p~ = [[0, -p2, p1], [p2, 0, -p0], [-p1, p0, 0]]
        A[i, 3] = -(c1 * p[2] - c2 * p[1])
        A[i, 4] = -(-c0 * p[2] + c2 * p[0])
        A[i, 5] = -(c0 * p[1] - c1 * p[0])


# ------------------------------------------------------------------ O(D) passes
# Long loops over a body's modes are written on 1-D row views (V[a, o:o + D]):
# indexing a 2-D array inside the loop defeats vectorisation (measured 4-5x slower).
@numba.njit(**_FAST)
def _dot(a, b):
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i] * b[i]
    return s


@numba.njit(**_FAST)
def _dotw(a, b, w):
    """sum_i a_i b_i w_i."""
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i] * b[i] * w[i]
    return s


@numba.njit(**_FAST)
def _axpy(alpha, x, y):
    """y += alpha x, in place."""
    for i in range(x.shape[0]):
        y[i] += alpha * x[i]


@numba.njit(**_FAST)
def _rows_dot(V, o, D, x, out, r0, nrows):
    """out[r] = V[r0 + r, o:o+D] . x for r < nrows."""
    for r in range(nrows):
        out[r] = _dot(V[r0 + r, o:o + D], x)


@numba.njit(**_FAST)
def _rows_dot2(A, o, D, x, xd, out, outd):
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


@numba.njit(**_FAST)
def _rows_dot4(A, o, D, x, out):
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
        out[r] = _dot(A[r, o:o + D], x)
        r += 1


@numba.njit(**_FAST)
def _rows_combine(A, o, D, coef, nrows, y):
    """y += sum_{r < nrows} coef[r] A[r, o:o+D], four rows per pass over y."""
    r = 0
    while r + 4 <= nrows:
        a0, a1, a2, a3 = A[r, o:o + D], A[r + 1, o:o + D], A[r + 2, o:o + D], A[r + 3, o:o + D]
        c0, c1, c2, c3 = coef[r], coef[r + 1], coef[r + 2], coef[r + 3]
        for i in range(D):
            y[i] += c0 * a0[i] + c1 * a1[i] + c2 * a2[i] + c3 * a3[i]
        r += 4
    while r < nrows:
        _axpy(coef[r], A[r, o:o + D], y)
        r += 1


@numba.njit(**_FAST)
def _project(V, M1, o, Dk, q, qd, qdd, has_acc, pq_given, pq, pqd, pqdd):
    """A body's modal rows applied to its modal state, in one read of the rows:
    pq (27,) = [V; M1] q (taken as given if pq_given), pqd (27,) = [V; M1] q',
    pqdd (12,) = V q'' (0 if not has_acc).  V rows: [P; H; Psi; Theta] (momentum,
    inside-frame translation and rotation); M1 rows: the 15 entries of dM_X/dq_i
    (inertia_gradient_rows)."""
    if pq_given:
        _rows_dot4(V, o, Dk, qd, pqd[0:12])
        _rows_dot4(M1, o, Dk, qd, pqd[12:27])
    else:
        _rows_dot2(V, o, Dk, q, qd, pq[0:12], pqd[0:12])
        _rows_dot2(M1, o, Dk, q, qd, pq[12:27], pqd[12:27])
    if has_acc:
        _rows_dot(V, o, Dk, qdd, pqdd, 0, 12)
    else:
        pqdd[:] = 0.0


@numba.njit(**_FAST)
def _hb_products(V, HB, o, Dk, x, out):
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


@numba.njit(**_FAST)
def _coriolis_pass(G2, q, qd, om):
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


@numba.njit(**_FAST)
def _coriolis_rate_pass(G2, qd, om):
    """hqd (3D,) = sum_j q'_j G_j and gq (D,) as in ``_coriolis_pass``, without hq:
    6 D^2 multiply-adds, for when hq = sum_j q_j G_j is already known (``_rk4_run``).
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


@numba.njit(**_FAST)
def _add_inertia_rows(Mx, m):
    """Mx (6, 6) += sum_i x_i dM_X/dq_i given m (15,) = M1 x (inertia_gradient_rows)."""
    for a in range(3):
        for b in range(3):
            s = m[3 * a + b]
            Mx[3 + a, b] += s
            Mx[b, 3 + a] += s
    for c in range(6):
        a, b = _YS_PAIRS[c]
        s = m[9 + c]
        Mx[3 + a, 3 + b] += s
        if a != b:
            Mx[3 + b, 3 + a] += s


@numba.njit(**_FAST)
def _add_inertia(Mx, M1, o, Dk, x):
    """Mx (6, 6) += sum_i x_i dM_X/dq_i, from the 15 rows of M1 (inertia_gradient_rows)."""
    m = np.empty(15)
    _rows_dot(M1, o, Dk, x, m, 0, 15)
    _add_inertia_rows(Mx, m)


@numba.njit(**_JIT)
def _inertia_weights(w, ww):
    """ww (15,) with 1/2 w^T M1_i w = sum_c ww_c M1[c, i]."""
    for a in range(3):
        for b in range(3):
            ww[3 * a + b] = w[3 + a] * w[b]
    for c in range(6):
        a, b = _YS_PAIRS[c]
        ww[9 + c] = (0.5 if a == b else 1.0) * w[3 + a] * w[3 + b]


# ------------------------------------------------------------------ kinematics
@numba.njit(**_FAST)
def _joint(gam, gd, gdd, Cj, base_p, elastic, has_acc, pq, pqd, pqdd, wp, dwp,
           R, p, Lw, w, dw, CR):
    """One joint of the forward pass, in place: its pose (R, p), the rotation part Lw of
    the joint map L = [R^T Psi; Lw Theta] of the parent's modes, and the child's twist w
    and its rate dw (6,) from the parent's wp, dwp.

    The joint rotates by gam about its fixed axis frame Cj: R = E Cj Rx(gam), where E is
    the parent's elastic rotation at the output bearings (x-y-z angles th = Theta q) and
    the joint sits at the elastic translation p = Psi q (pq, pqd, pqdd (12,): the parent's
    rows V q, V q', V q''; used only if elastic).  Otherwise p = base_p and E = I."""
    c, s = math.cos(gam), math.sin(gam)
    for i in range(3):                        # CR = Cj Rx(gam)
        CR[i, 0] = Cj[i, 0]
        CR[i, 1] = Cj[i, 1] * c + Cj[i, 2] * s
        CR[i, 2] = Cj[i, 2] * c - Cj[i, 1] * s
    xv = (0.0, 0.0, 0.0)                      # joint twist xi = [xv; xw] and bias [bv; bw]
    xw = (gd, 0.0, 0.0)
    bv = (0.0, 0.0, 0.0)
    bw = (0.0, 0.0, 0.0)
    if not elastic:
        for i in range(3):
            for m in range(3):
                R[i, m] = CR[i, m]
                Lw[i, m] = 0.0
            p[i] = base_p[i]
    else:
        pd = (pqd[6], pqd[7], pqd[8])
        thd = (pqd[9], pqd[10], pqd[11])
        c0, s0 = math.cos(pq[9]), math.sin(pq[9])
        c1, s1 = math.cos(pq[10]), math.sin(pq[10])
        c2, s2 = math.cos(pq[11]), math.sin(pq[11])
        # E = Rx(th0) Ry(th1) Rz(th2), rows e0, e1, e2 (Ry Rz has rows a0, a1, a2)
        a0 = (c1 * c2, -c1 * s2, s1)
        a1 = (s2, c2, 0.0)
        a2 = (-s1 * c2, s1 * s2, c1)
        e0 = a0
        e1 = _sub(_scale(c0, a1), _scale(s0, a2))
        e2 = _add(_scale(s0, a1), _scale(c0, a2))
        for m in range(3):
            R[0, m] = e0[0] * CR[0, m] + e0[1] * CR[1, m] + e0[2] * CR[2, m]
            R[1, m] = e1[0] * CR[0, m] + e1[1] * CR[1, m] + e1[2] * CR[2, m]
            R[2, m] = e2[0] * CR[0, m] + e2[1] * CR[1, m] + e2[2] * CR[2, m]
            p[m] = pq[6 + m]
        # angular velocity of E: omE = Te th', Te = [cx, cy, ez] (columns)
        cx = (c1 * c2, -c1 * s2, s1)
        cy = (s2, c2, 0.0)
        for i in range(3):                    # Lw = (Cj Rx)^T Te
            Lw[i, 0] = CR[0, i] * cx[0] + CR[1, i] * cx[1] + CR[2, i] * cx[2]
            Lw[i, 1] = CR[0, i] * cy[0] + CR[1, i] * cy[1]
            Lw[i, 2] = CR[2, i]
        t1 = _scale(thd[0], cx)
        t2 = _scale(thd[1], cy)
        t3 = (0.0, 0.0, thd[2])
        omE = _add(_add(t1, t2), t3)
        domE = _add(_cr(t1, _add(t2, t3)), _cr(t2, t3))    # Te' th'
        xv = _mtv3(R, pd)
        t = _mtv3(CR, omE)
        xw = (t[0] + gd, t[1], t[2])
        bv = _scale(-1.0, _cr(xw, xv))
        u = _mtv3(CR, domE)                   # - (gd ex) x xw + (Cj Rx)^T domE
        bw = (u[0], u[1] + gd * xw[2], u[2] - gd * xw[1])
    pp = (p[0], p[1], p[2])
    # w = Ad^-1 wp + xi;  dw = Ad^-1 dwp + [w, xi] + bias (+ gdd ex + L q''_parent)
    wpw = (wp[3], wp[4], wp[5])
    wv = _add(_mtv3(R, _add((wp[0], wp[1], wp[2]), _cr(wpw, pp))), xv)
    ww = _add(_mtv3(R, wpw), xw)
    dpw = (dwp[3], dwp[4], dwp[5])
    dv = _mtv3(R, _add((dwp[0], dwp[1], dwp[2]), _cr(dpw, pp)))
    dv = _add(_add(dv, bv), _sub(_cr(ww, xv), _cr(xw, wv)))
    dww = _add(_add(_mtv3(R, dpw), bw), _cr(ww, xw))
    if elastic and has_acc:
        dv = _add(dv, _mtv3(R, (pqdd[6], pqdd[7], pqdd[8])))
        dww = _add(dww, _mv3(Lw, (pqdd[9], pqdd[10], pqdd[11])))
    for i in range(3):
        w[i] = wv[i]
        w[3 + i] = ww[i]
        dw[i] = dv[i]
        dw[3 + i] = dww[i]
    dw[3] += gdd


@numba.njit(**_FAST)
def _forward(y, yd, ydd, has_acc, w1, dw1, D, C1, C, rho, Pq, Pqd, Pqdd,
             R_all, p_all, Lw_all, W, DW):
    """Forward pass over the four joints, in place: R_all (4,3,3), p_all (4,3), Lw_all
    (4,3,3), body twists W (4,6) and their rates DW (4,6) at accelerations ydd, from the
    bodies' projected modal rows Pq, Pqd (4, 27) and Pqdd (4, 12) (``_project``)."""
    small = np.zeros(12)
    CR = small[0:9].reshape((3, 3))
    zero3 = small[9:12]
    for j in range(4):
        k = j - 1
        elastic = j > 0 and D[k] > 0
        kk = k if j > 0 else 0
        wp = w1 if j == 0 else W[k]
        dwp = dw1 if j == 0 else DW[k]
        _joint(y[j], yd[j], ydd[j] if has_acc else 0.0, C1 if j == 0 else C,
               rho if j == 0 else zero3, elastic, has_acc, Pq[kk], Pqd[kk], Pqdd[kk],
               wp, dwp, R_all[j], p_all[j], Lw_all[j], W[j], DW[j], CR)


@numba.njit(**_FAST)
def _project_all(y, yd, ydd, has_acc, D, off, V, M1, pq_given, Pq, Pqd, Pqdd):
    """Pq, Pqd (4, 27), Pqdd (4, 12) in place: every body's ``_project`` (rows of bodies
    without modes are left alone: zero)."""
    for k in range(4):
        Dk = D[k]
        if Dk > 0:
            s = 4 + off[k]
            _project(V, M1, off[k], Dk, y[s:s + Dk], yd[s:s + Dk], ydd[s:s + Dk], has_acc,
                     pq_given, Pq[k], Pqd[k], Pqdd[k])
    return Pq, Pqd, Pqdd


@numba.njit(**_FAST)
def _projections(y, yd, ydd, has_acc, D, off, V, M1):
    """Pq, Pqd (4, 27), Pqdd (4, 12): every body's ``_project``, in new arrays."""
    return _project_all(y, yd, ydd, has_acc, D, off, V, M1, False, np.zeros((4, 27)),
                        np.zeros((4, 27)), np.zeros((4, 12)))


@numba.njit(**_JIT)
def _kinematics(y, yd, ydd, w1, dw1, D, off, V, M1, C1, C, rho, R_all, p_all, Lw_all, W, DW):
    """Forward pass, in place: joint poses R_all (4,3,3), p_all (4,3), the rotation part
    Lw_all (4,3,3) of each joint map L = [R^T Psi; Lw Theta] of the parent's modes,
    body twists W (4,6) and their rates DW (4,6) at accelerations ydd."""
    Pq, Pqd, Pqdd = _projections(y, yd, ydd, True, D, off, V, M1)
    _forward(y, yd, ydd, True, w1, dw1, D, C1, C, rho, Pq, Pqd, Pqdd, R_all, p_all, Lw_all, W, DW)


# ------------------------------------------------------------------ inverse dynamics
@numba.njit(**_FAST)
def _backward(y, yd, ydd, has_acc, D, off, M6, V, M1, G, om2, cd, Pq, Pqd, Pqdd,
              R_all, p_all, Lw_all, W, DW, out, Mx_all, HB, HQ, hq_given, HQD):
    """Backward (Newton-Euler) pass, in place: out (n,) = M(y) ydd + c(y, y', t), Mx_all
    (4,6,6) = M_X(q) per body, HB (3, S) = H + sum_j q_j G_j; returns F0 (6,), the
    composite wrench on body 2.  HQ, HQD (3S,): every body's hq = sum_j q_j G_j and
    hqd = sum_j q'_j G_j (body k at 3 off[k], layout a D_k + i); HQ is taken as given
    if hq_given (else computed and stored), HQD is always stored."""
    scratch = np.zeros(87)                  # one allocation for the small vectors
    F, Fc, mu, dmu = scratch[0:6], scratch[6:12], scratch[12:18], scratch[18:24]
    cv, ww = scratch[24:36], scratch[36:51]
    dMx = scratch[51:87].reshape((6, 6))
    for k in range(3, -1, -1):
        Dk = D[k]
        o = off[k]
        w = W[k]
        dw = DW[k]
        om = (w[3], w[4], w[5])
        Mx = Mx_all[k]
        Mx[:, :] = M6[k]
        dMx[:, :] = 0.0
        for a in range(6):
            mu[a] = 0.0
            dmu[a] = 0.0
        if Dk > 0:
            s = 4 + o
            qk = y[s:s + Dk]
            qdk = yd[s:s + Dk]
            qddk = ydd[s:s + Dk]
            # M_X(q) = M6 + sum q_i M1_i and its rate sum q'_i M1_i (15 rows, projected)
            _add_inertia_rows(Mx, Pq[k, 12:27])
            _add_inertia_rows(dMx, Pqd[k, 12:27])
            b3 = 3 * o
            if hq_given:
                hqd, gq = _coriolis_rate_pass(G[k], qdk, om)
            else:
                hq_new, hqd, gq = _coriolis_pass(G[k], qk, qdk, om)
                HQ[b3:b3 + 3 * Dk] = hq_new
            hq = HQ[b3:b3 + 3 * Dk]
            HQD[b3:b3 + 3 * Dk] = hqd
            # HB = H + hq (the angular rows of B(q)); (hq q', hq q'', hqd q') per axis
            for a in range(3):
                h = hq[a * Dk:(a + 1) * Dk]
                hd = hqd[a * Dk:(a + 1) * Dk]
                Ha = V[3 + a, o:o + Dk]
                HBa = HB[a, o:o + Dk]
                s1 = 0.0
                s2 = 0.0
                s3 = 0.0
                for i in range(Dk):
                    HBa[i] = Ha[i] + h[i]
                    s1 += h[i] * qdk[i]
                    s3 += hd[i] * qdk[i]
                if has_acc:
                    for i in range(Dk):
                        s2 += h[i] * qddk[i]
                mu[3 + a] += s1                       # B(q) q'
                dmu[3 + a] += s2 + s3                 # B(q) q'' + (sum q'_j G_j) q'
            for a in range(6):
                mu[a] += Pqd[k, a]
                dmu[a] += Pqdd[k, a]
        for a in range(6):
            s1 = 0.0
            s2 = 0.0
            for b in range(6):
                s1 += Mx[a, b] * w[b]
                s2 += Mx[a, b] * dw[b] + dMx[a, b] * w[b]
            mu[a] += s1
            dmu[a] += s2
        # F = d/dt mu + [om x mu_v; om x mu_w + v x mu_v] + Ad^-T F_child
        t1 = _cr(om, (mu[0], mu[1], mu[2]))
        t2 = _add(_cr(om, (mu[3], mu[4], mu[5])), _cr((w[0], w[1], w[2]), (mu[0], mu[1], mu[2])))
        for a in range(3):
            F[a] = dmu[a] + t1[a]
            F[3 + a] = dmu[3 + a] + t2[a]
        if k < 3:
            Rc = R_all[k + 1]
            f = _mv3(Rc, (Fc[0], Fc[1], Fc[2]))
            m = _add(_cr(p_all[k + 1], f), _mv3(Rc, (Fc[3], Fc[4], Fc[5])))
            for a in range(3):
                F[a] += f[a]
                F[3 + a] += m[a]
        if Dk > 0:
            # modal forces Q = B^T dw + (sum q'_j G_j)^T omega + q'' - dT/dq + Omega^2 q + C q'
            # (+ L^T F_child), dT/dq = 1/2 w^T M1_i w + gq: row by row over [P; H; Psi; Theta]
            s = 4 + o
            for a in range(6):
                cv[a] = dw[a]
            if k < 3:
                f = _mv3(R_all[k + 1], (Fc[0], Fc[1], Fc[2]))
                m = _mtv3(Lw_all[k + 1], (Fc[3], Fc[4], Fc[5]))
                for a in range(3):
                    cv[6 + a] = f[a]
                    cv[9 + a] = m[a]
            nrows = 12 if k < 3 else 6
            Q = out[s:s + Dk]
            yk = y[s:s + Dk]
            ydk = yd[s:s + Dk]
            o2 = om2[o:o + Dk]
            c2 = cd[o:o + Dk]
            for i in range(Dk):
                Q[i] = o2[i] * yk[i] + c2[i] * ydk[i] - gq[i]
            if has_acc:
                _axpy(1.0, ydd[s:s + Dk], Q)
            _rows_combine(V, o, Dk, cv, nrows, Q)
            _inertia_weights(w, ww)
            for c in range(15):
                ww[c] = -ww[c]
            _rows_combine(M1, o, Dk, ww, 15, Q)
            h0, h1, h2 = hq[0:Dk], hq[Dk:2 * Dk], hq[2 * Dk:3 * Dk]
            e0, e1, e2 = hqd[0:Dk], hqd[Dk:2 * Dk], hqd[2 * Dk:3 * Dk]
            for i in range(Dk):
                Q[i] += (dw[3] * h0[i] + dw[4] * h1[i] + dw[5] * h2[i]
                         + om[0] * e0[i] + om[1] * e1[i] + om[2] * e2[i])
        out[k] = F[3]
        for a in range(6):
            Fc[a] = F[a]
    return Fc


@numba.njit(**_FAST)
def _inverse_dynamics_into(y, yd, ydd, has_acc, w1, dw1, D, off, M6, V, M1, G, om2, cd,
                           C1, C, rho, out, Mx_all, HB, R_all, p_all, Lw_all, LIN, lin_given, LIND):
    """out (n,) = M(y) ydd + c(y, y', t) (ydd taken as 0 if not has_acc), and the data the
    solve reuses, in place; returns F0 (6,), the composite wrench on body 2.

    LIN (3S + 108,) holds what is linear in q: [hq (3S); Pq (4, 27) row by row], every
    body's sum_j q_j G_j and projected rows [V; M1] q; it is taken as given if lin_given
    (``_rk4_run`` carries it from stage to stage), else computed and stored.  LIND gets
    the same of q': [hqd; Pqd]."""
    S3 = LIN.shape[0] - 108
    HQ = LIN[:S3]
    HQD = LIND[:S3]
    Pq = LIN[S3:].reshape((4, 27))
    Pqd = LIND[S3:].reshape((4, 27))
    small = np.zeros(96)
    Pqdd = small[0:48].reshape((4, 12))
    W = small[48:72].reshape((4, 6))
    DW = small[72:96].reshape((4, 6))
    _project_all(y, yd, ydd, has_acc, D, off, V, M1, lin_given, Pq, Pqd, Pqdd)
    _forward(y, yd, ydd, has_acc, w1, dw1, D, C1, C, rho, Pq, Pqd, Pqdd, R_all, p_all, Lw_all, W, DW)
    return _backward(y, yd, ydd, has_acc, D, off, M6, V, M1, G, om2, cd, Pq, Pqd, Pqdd,
                     R_all, p_all, Lw_all, W, DW, out, Mx_all, HB, HQ, lin_given, HQD)


@numba.njit(**_JIT)
def _inverse_dynamics(y, yd, ydd, w1, dw1, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """out (n,) = M(y) ydd + c(y, y', t) by the recursive Newton-Euler passes, and what
    the solve reuses: Mx_all (4,6,6) = M_X(q) per body, HB (3, S) = H + sum_j q_j G_j (the
    angular rows of B(q)), the joint data (R_all, p_all, Lw_all) and F0, the composite
    wrench on body 2."""
    S = V.shape[1]
    out = np.zeros(4 + S)
    Mx_all = np.empty((4, 6, 6))
    HB = np.zeros((3, S))
    R_all = np.empty((4, 3, 3))
    p_all = np.empty((4, 3))
    Lw_all = np.empty((4, 3, 3))
    F0 = _inverse_dynamics_into(y, yd, ydd, True, w1, dw1, D, off, M6, V, M1, G, om2, cd,
                                C1, C, rho, out, Mx_all, HB, R_all, p_all, Lw_all,
                                np.zeros(3 * S + 108), False, np.zeros(3 * S + 108))
    return out, Mx_all, HB, R_all, p_all, Lw_all, F0


# ------------------------------------------------------------------ articulated-body solve
@numba.njit(**_FAST)
def _gram_blocks(V, HB, o, Dk, dinv, gram_k, unit, BB, BY, YY):
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
            _hb_products(V, HB, o, Dk, HB[a, o:o + Dk], prod)
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
            s = _dotw(ra, rb, w)
            BB[a, b] = s
            BB[b, a] = s
        for b in range(6):
            BY[a, b] = _dotw(ra, V[6 + b, o:o + Dk], w)
        for b in range(a + 1):
            s = _dotw(V[6 + a, o:o + Dk], V[6 + b, o:o + Dk], w)
            YY[a, b] = s
            YY[b, a] = s


@numba.njit(**_FAST)
def _solve(r, dg, unit, D, off, V, gram, Mx_all, HB, R_all, p_all, Lw_all):
    """x with (M + diag(0, dg - 1)) x = r: the articulated-body recursion of
    multibody.solve_mass (docs/dynamics.md, Section 3).

    A body's modes enter only through its modal rows B = [P; H + hq] (6, D) and
    Y = [Psi; Theta] (6, D): the joint map of its child is L = Lam Y with
    Lam = diag(R^T, Lw) (6, 6), and K = B + Ad^-T Itil L = B + Mk Y.  So every
    product over the modes that the Woodbury elimination needs (K N^-1 K^T,
    K N^-1 L^T, L N^-1 L^T, K N^-1 r, ...) is a 6x6 expression in the Gram blocks
    BB, BY, YY of _gram_blocks and the projections B r/dg, Y r/dg: per body
    three kinds of passes over the modes remain (Gram rows of H + hq, projections,
    back-substitution), everything else is 6x6 algebra in scratch arrays."""
    S = V.shape[1]
    n = 4 + S
    dinv = dg if unit else 1.0 / dg         # (not read when unit)
    # the 6x6 blocks and 6-vectors of the recursion, in two allocations (each costs
    # ~30 ns; the evaluation used to make 55 of them)
    mats = np.zeros((10, 4, 6, 6))
    IA, BB, BY, YY, Lam = mats[0], mats[1], mats[2], mats[3], mats[4]
    Mk, Itils, Zinvs = mats[5], mats[6], mats[7]
    T = mats[8:10].reshape((8, 6, 6))        # 6x6 scratch
    vecs = np.zeros((24, 6))
    bA, Br, Yr, pa_all = vecs[0:4], vecs[4:8], vecs[8:12], vecs[12:16]
    v = vecs[16:22]                          # 6-vector scratch
    prod = vecs[22:24].reshape(12)
    A, AtI, T2, T3, KNK, KdL, T6, T7 = T[0], T[1], T[2], T[3], T[4], T[5], T[6], T[7]
    yh, KNr, t6, Lz, eY, acc = v[0], v[1], v[2], v[3], v[4], v[5]
    for k in range(3, -1, -1):
        Dk = D[k]
        o = off[k]
        I_art = IA[k]
        I_art[:, :] = Mx_all[k]
        b_art = bA[k]
        child = k < 3
        if child:
            # the child's articulated inertia with its joint axis eliminated, moved here
            Ic = IA[k + 1]
            bc = bA[k + 1]
            d = Ic[3, 3]
            u = r[k + 1] - bc[3]
            Itil = Itils[k]
            pa = pa_all[k]
            for a in range(6):
                pa[a] = bc[a] + Ic[a, 3] * (u / d)
                for b in range(6):
                    Itil[a, b] = Ic[a, b] - Ic[a, 3] * Ic[b, 3] / d
            _adinv_matrix(R_all[k + 1], p_all[k + 1], A)
            _mm6(A.T, Itil, AtI)
            _mm6(AtI, A, T2)
            _mv6(A.T, pa, t6)
            for a in range(6):
                b_art[a] += t6[a]
                for b in range(6):
                    I_art[a, b] += T2[a, b]
            Lm = Lam[k]
            Rc = R_all[k + 1]
            Lwc = Lw_all[k + 1]
            for a in range(3):
                for b in range(3):
                    Lm[a, b] = Rc[b, a]
                    Lm[3 + a, 3 + b] = Lwc[a, b]
            _mm6(AtI, Lm, Mk[k])
        if Dk > 0:
            _gram_blocks(V, HB, o, Dk, dinv, gram[k], unit, BB[k], BY[k], YY[k])
            s = 4 + o
            if unit:
                _hb_products(V, HB, o, Dk, r[s:s + Dk], prod)
            else:
                _hb_products(V, HB, o, Dk, r[s:s + Dk] * dinv[o:o + Dk], prod)
            for a in range(6):
                Br[k, a] = prod[a]
                Yr[k, a] = prod[6 + a]
            if child:
                M = Mk[k]
                Lm = Lam[k]
                Itil = Itils[k]
                _mv6(Lm.T, pa_all[k], yh)                 # L^T pa = Y^T yh
                # KNr = B zd + M Y zd, zd = (r_q - L^T pa)/dg
                _mv6(BY[k], yh, t6)
                for a in range(6):
                    KNr[a] = Br[k, a] - t6[a]
                _mv6(YY[k], yh, t6)
                for a in range(6):
                    t6[a] = Yr[k, a] - t6[a]             # Y zd
                _mv6(Lm, t6, Lz)
                _mv6(M, t6, yh)
                for a in range(6):
                    KNr[a] += yh[a]
                # KNK = BB + M BY^T + BY M^T + M YY M^T
                _mm6(M, BY[k].T, T2)
                _mm6(M, YY[k], T3)
                _mm6(T3, M.T, KNK)
                for a in range(6):
                    for b in range(6):
                        KNK[a, b] += BB[k, a, b] + T2[a, b] + T2[b, a]
                        T3[a, b] += BY[k, a, b]          # BY + M YY
                _mm6(T3, Lm.T, KdL)                       # K N^-1 L^T
                _mm6(Lm, YY[k], T6)
                _mm6(T6, Lm.T, T7)                        # L N^-1 L^T
                _mm6(T7, Itil, T6)                       # Z = I + L N^-1 L^T Itil
                for a in range(6):
                    T6[a, a] += 1.0
                _inv6(T6, Zinvs[k], T7)
                _mm6(KdL, Itil, T2)
                _mm6(T2, Zinvs[k], T3)                   # KIZ
                _mm6(T3, KdL.T, T2)
                _mv6(T3, Lz, t6)
                for a in range(6):
                    KNr[a] -= t6[a]
                    for b in range(6):
                        KNK[a, b] -= T2[a, b]
                for a in range(6):
                    b_art[a] += KNr[a]
                    for b in range(6):
                        I_art[a, b] -= KNK[a, b]
            else:
                for a in range(6):
                    b_art[a] += Br[k, a]
                    for b in range(6):
                        I_art[a, b] -= BB[k, a, b]
        for a in range(6):                       # symmetrise
            for b in range(a):
                m = 0.5 * (I_art[a, b] + I_art[b, a])
                I_art[a, b] = m
                I_art[b, a] = m
    x = np.zeros(n)
    a_base = np.zeros(6)
    for k in range(4):
        Ic = IA[k]
        bc = bA[k]
        xg = r[k] - bc[3]
        for a in range(6):
            xg -= Ic[3, a] * a_base[a]
        xg /= Ic[3, 3]
        x[k] = xg
        for a in range(6):
            acc[a] = a_base[a]
            Lz[a] = 0.0
        acc[3] += xg
        Dk = D[k]
        o = off[k]
        child = k < 3
        if Dk > 0:
            # z = (r_q - B^T acc - Y^T eY)/dg with eY = Lam^T (pa + corr) + Mk^T acc;
            # corr = Itil Zinv L z0 (Woodbury), z0 the same without corr
            s = 4 + o
            z = x[s:s + Dk]
            z[:] = r[s:s + Dk]
            for a in range(6):
                t6[a] = -acc[a]
            _rows_combine(V, o, Dk, t6, 3, z)
            _rows_combine(HB[:, o:o + Dk], 0, Dk, t6[3:6], 3, z)
            if child:
                Lm = Lam[k]
                _mv6(Lm.T, pa_all[k], eY)
                _mv6(Mk[k].T, acc, t6)
                for a in range(6):
                    eY[a] += t6[a]
                _mv6(BY[k].T, acc, yh)
                _mv6(YY[k], eY, t6)
                for a in range(6):
                    t6[a] = Yr[k, a] - yh[a] - t6[a]     # Y z0
                _mv6(Lm, t6, KNr)
                _mv6(Zinvs[k], KNr, t6)
                _mv6(Itils[k], t6, KNr)                  # corr
                _mv6(Lm.T, KNr, t6)
                for a in range(6):
                    eY[a] += t6[a]
                for a in range(6):
                    t6[a] = -eY[a]
                _rows_combine(V[6:12], o, Dk, t6, 6, z)
                _mv6(YY[k], eY, t6)
                for a in range(6):
                    t6[a] = Yr[k, a] - yh[a] - t6[a]     # Y z
                _mv6(Lm, t6, Lz)                         # L z = Lam Y z
            if not unit:
                for i in range(Dk):
                    z[i] *= dinv[o + i]
        if child:
            a_base = _adinv(R_all[k + 1], p_all[k + 1], acc)
            for a in range(6):
                a_base[a] += Lz[a]
    return x


@numba.njit(**_FAST)
def _accelerations_lin(y, yd, w1, dw1, tau, LIN, lin_given, LIND,
                       D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """y'' = M(y)^-1 (tau - c(y, y', t)), with what is linear in q taken from LIN
    (3S + 108,) if lin_given (else computed into it) and the same of q' stored in LIND
    (``_inverse_dynamics_into``)."""
    n = y.shape[0]
    S = n - 4
    c = np.zeros(n)
    HB = np.zeros((3, S))
    small = np.empty(228)
    Mx_all = small[0:144].reshape((4, 6, 6))
    R_all = small[144:180].reshape((4, 3, 3))
    p_all = small[180:192].reshape((4, 3))
    Lw_all = small[192:228].reshape((4, 3, 3))
    _inverse_dynamics_into(y, yd, y, False, w1, dw1, D, off, M6, V, M1, G, om2, cd,
                           C1, C, rho, c, Mx_all, HB, R_all, p_all, Lw_all, LIN, lin_given, LIND)
    for i in range(n):
        c[i] = -c[i]
    for j in range(4):
        c[j] += tau[j]
    return _solve(c, c, True, D, off, V, gram, Mx_all, HB, R_all, p_all, Lw_all)


@numba.njit(**_FAST)
def _accelerations(y, yd, w1, dw1, tau, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """y'' = M(y)^-1 (tau - c(y, y', t))."""
    S = y.shape[0] - 4
    return _accelerations_lin(y, yd, w1, dw1, tau, np.zeros(3 * S + 108), False,
                              np.zeros(3 * S + 108), D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)


@numba.njit(**_JIT)
def _kinetic_energy_lin(y, yd, w1, LIN, Pqd, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """T = sum_n 1/2 w^T M_X(q) w + w^T B(q) q' + 1/2 q'^T q' (multibody.kinetic_energy),
    with LIN = [hq; Pq] (``_inverse_dynamics_into``) and Pqd (4, 27) = [V; M1] q' given."""
    S3 = LIN.shape[0] - 108
    Pq = LIN[S3:].reshape((4, 27))
    R_all = np.empty((4, 3, 3))
    p_all = np.empty((4, 3))
    Lw_all = np.empty((4, 3, 3))
    W = np.empty((4, 6))
    DW = np.empty((4, 6))
    _forward(y, yd, y, False, w1, np.zeros(6), D, C1, C, rho, Pq, Pqd, np.zeros((4, 12)),
             R_all, p_all, Lw_all, W, DW)
    T = 0.0
    Mx = np.empty((6, 6))
    for k in range(4):
        Dk = D[k]
        o = off[k]
        w = W[k]
        Mx[:, :] = M6[k]
        if Dk > 0:
            s = 4 + o
            qdk = yd[s:s + Dk]
            _add_inertia_rows(Mx, Pq[k, 12:27])
            Bqd = Pqd[k, 0:6].copy()                   # B(q) q' = [P; H + hq] q'
            for a in range(3):
                b0 = 3 * o + a * Dk
                Bqd[3 + a] += _dot(LIN[b0:b0 + Dk], qdk)
            for i in range(Dk):
                T += 0.5 * qdk[i] * qdk[i]
            for a in range(6):
                T += w[a] * Bqd[a]
        for a in range(6):
            for b in range(6):
                T += 0.5 * w[a] * Mx[a, b] * w[b]
    return T


@numba.njit(**_JIT)
def _linear_data(y, yd, D, off, V, M1, G):
    """LIN (3S + 108,) = [hq; Pq] of a state (``_inverse_dynamics_into``) and Pqd (4, 27),
    directly: hq = sum_j q_j G_j by row combination (3 D^2), Pq and Pqd by projection."""
    S = y.shape[0] - 4
    LIN = np.zeros(3 * S + 108)
    Pqd = np.zeros((4, 27))
    for k in range(4):
        Dk = D[k]
        if Dk > 0:
            s = 4 + off[k]
            b0 = 3 * off[k]
            _rows_combine(G[k], 0, 3 * Dk, y[s:s + Dk], Dk, LIN[b0:b0 + 3 * Dk])
    _project_all(y, yd, y, False, D, off, V, M1, False, LIN[3 * S:].reshape((4, 27)),
                 Pqd, np.zeros((4, 12)))
    return LIN, Pqd


@numba.njit(**_JIT)
def _kinetic_energy(y, yd, w1, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """T = sum_n 1/2 w^T M_X(q) w + w^T B(q) q' + 1/2 q'^T q' (multibody.kinetic_energy)."""
    LIN, Pqd = _linear_data(y, yd, D, off, V, M1, G)
    return _kinetic_energy_lin(y, yd, w1, LIN, Pqd, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)


@numba.njit(**_JIT)
def _case_power(y, yd, w1, dw1, tau, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """Power the case motion feeds into bodies 2-5, (Ad_{g1^-1} w1) . F0, with F0 the
    composite wrench on body 2 at the accelerations the equations give."""
    S = y.shape[0] - 4
    LIN = np.zeros(3 * S + 108)                      # [hq; Pq], reused by the second pass
    LIND = np.zeros(3 * S + 108)
    ydd = _accelerations_lin(y, yd, w1, dw1, tau, LIN, False, LIND,
                             D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
    return _case_power_lin(y, yd, ydd, w1, dw1, LIN, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)


@numba.njit(**_JIT)
def _case_power_lin(y, yd, ydd, w1, dw1, LIN, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """``_case_power`` at accelerations ydd, with LIN = [hq; Pq] of the state given."""
    n = y.shape[0]
    S = n - 4
    out = np.zeros(n)
    Mx_all = np.empty((4, 6, 6))
    HB = np.zeros((3, S))
    R_all = np.empty((4, 3, 3))
    p_all = np.empty((4, 3))
    Lw_all = np.empty((4, 3, 3))
    F0 = _inverse_dynamics_into(y, yd, ydd, True, w1, dw1, D, off, M6, V, M1, G, om2, cd,
                                C1, C, rho, out, Mx_all, HB, R_all, p_all, Lw_all, LIN, True,
                                np.zeros(3 * S + 108))
    return np.dot(_adinv(R_all[0], p_all[0], w1), F0)


@numba.njit(**_JIT)
def _case_twist(t, amp, omf, phase, om0, w1, dw1):
    """Case twist [0; omega(t)] and its rate, in place (multibody.CaseMotion.twist)."""
    for k in range(3):
        arg = omf[k] * t + phase[k]
        dw1[3 + k] = amp[k] * math.cos(arg)
        if omf[k] > 0.0:
            integ = (math.sin(arg) - math.sin(phase[k])) / omf[k]
        else:
            integ = math.cos(phase[k]) * t
        w1[3 + k] = om0[k] + amp[k] * integ


@numba.njit(**_JIT)
def _rk4_core(y, yd, t0, h, n_steps, first_given, K0, LIN0, LIND0, amp, omf, phase, om0, tau,
              D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """n_steps classical RK4 steps of (y, y')' = (y', y'') from t0 with constant torques
    (integrators.rk4_step, compiled: no Python call per stage).  If first_given, the first
    stage's evaluation (accelerations K0 (n,), LIN0 and LIND0 at (t0, y, y')) is given.

    What an evaluation needs that is linear in q, LIN = [hq; Pq] (the modal Coriolis
    sums hq = sum_j q_j G_j and the projected rows Pq = [V; M1] q, see
    ``_inverse_dynamics_into``), is carried from stage to stage instead of recomputed:
    every RK4 stage position is q plus a multiple of the previous stage's velocity
    (q2 = q + h/2 v1, q3 = q + h/2 v2, q4 = q + h v3, q_next = q + h/6 (v1 + 2 v2 +
    2 v3 + v4)), and each evaluation computes the same quantities of its velocity,
    LIND = [sum_j v_j G_j; [V; M1] v], anyway.  So the Coriolis pass of an evaluation
    drops from 9 D^2 to 6 D^2 multiply-adds per body and the projections from 54 to 27
    rows.  LIN is computed directly at the first stage of each call (every output
    sample), so round-off cannot accumulate."""
    n = y.shape[0]
    L = 3 * (n - 4) + 108
    y = y.copy()
    yd = yd.copy()
    w1 = np.zeros(6)
    dw1 = np.zeros(6)
    LINS = np.zeros((4, L))          # LIN of each stage; LINS[0] is the step's own
    LIN = LINS[0]
    LINDS = np.zeros((4, L))         # LIND of each stage
    K = np.empty((4, n))             # accelerations of each stage
    Vs = np.empty((4, n))            # velocities of each stage
    ys = np.empty(n)
    c_stage = (0.0, 0.5, 0.5, 1.0)
    for i in range(n_steps):
        t = t0 + i * h
        for st in range(4):          # one call site: the compiler inlines the RHS once
            c = c_stage[st] * h
            if st == 0:
                Vs[0, :] = yd
                ys[:] = y
            else:
                for m in range(n):
                    ys[m] = y[m] + c * Vs[st - 1, m]
                    Vs[st, m] = yd[m] + c * K[st - 1, m]
                for m in range(L):
                    LINS[st, m] = LIN[m] + c * LINDS[st - 1, m]
            if i == 0 and st == 0 and first_given:
                K[0, :] = K0
                LIN[:] = LIN0
                LINDS[0, :] = LIND0
                continue
            if st != 2:
                _case_twist(t + c, amp, omf, phase, om0, w1, dw1)
            K[st, :] = _accelerations_lin(ys, Vs[st], w1, dw1, tau, LINS[st],
                                          st > 0 or i > 0, LINDS[st],
                                          D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
        for m in range(n):
            y[m] += (h / 6.0) * (Vs[0, m] + 2.0 * Vs[1, m] + 2.0 * Vs[2, m] + Vs[3, m])
            yd[m] += (h / 6.0) * (K[0, m] + 2.0 * K[1, m] + 2.0 * K[2, m] + K[3, m])
        for m in range(L):
            LIN[m] += (h / 6.0) * (LINDS[0, m] + 2.0 * LINDS[1, m] + 2.0 * LINDS[2, m] + LINDS[3, m])
    return y, yd


@numba.njit(**_JIT)
def _rk4_run(y, yd, t0, h, n_steps, amp, omf, phase, om0, tau,
             D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """n_steps classical RK4 steps from (t0, y, y') (``_rk4_core``)."""
    dummy = np.zeros(0)
    return _rk4_core(y, yd, t0, h, n_steps, False, dummy, dummy, dummy, amp, omf, phase, om0,
                     tau, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)


@numba.njit(**_JIT)
def _rk4_integrate(y0, yd0, t_out, h, n_sub, growth, at_rest, amp, omf, phase, om0, tau,
                   D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """A whole RK4 run with outputs and the energy watch, compiled (integrators.integrate
    with integrators.Monitor, without a Python call per output sample).

    From (y0, y0') at t_out[0], n_sub steps of h per output interval.  At every output
    time t_out[k] it stores the state Y, Yd (T, n) and energy (T, 4) = kinetic T,
    potential U, input power P [in lbf/s] and the input work so far (trapezoidal), and
    applies Monitor's test: the state must be finite and |T + U| must stay within
    growth x scale, scale = max(|E0|, |work|) so far.  The accelerations the power
    needs are those of the sample's own state: the first stage of the next interval,
    so they are computed once for both.  Returns (Y, Yd, energy, info), info (4,) =
    (status, k, E, scale): status 0 (done, k = T), 1 (non-finite state at sample k) or
    2 (energy growth at sample k); rows from k on are not filled (NaN)."""
    n = y0.shape[0]
    S = n - 4
    nt = t_out.shape[0]
    Y = np.full((nt, n), np.nan)
    Yd = np.full((nt, n), np.nan)
    energy = np.full((nt, 4), np.nan)
    info = np.zeros(4)
    info[1] = nt
    y = y0.copy()
    yd = yd0.copy()
    w1 = np.zeros(6)
    dw1 = np.zeros(6)
    LIN = np.zeros(3 * S + 108)
    LIND = np.zeros(3 * S + 108)
    E0 = 0.0
    scale = 0.0
    work = 0.0
    P0 = 0.0
    for k in range(nt):
        t = t_out[k]
        if not math.isfinite(_dot(y, y) + _dot(yd, yd)):
            info[0], info[1] = 1.0, k
            return Y, Yd, energy, info
        Y[k, :] = y
        Yd[k, :] = yd
        _case_twist(t, amp, omf, phase, om0, w1, dw1)
        acc = _accelerations_lin(y, yd, w1, dw1, tau, LIN, False, LIND,
                                 D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
        T = _kinetic_energy_lin(y, yd, w1, LIN, LIND[3 * S:].reshape((4, 27)), D, off, M6, V,
                                gram, M1, G, om2, cd, C1, C, rho)
        U = 0.0
        P = 0.0
        for j in range(4):
            P += tau[j] * yd[j]
        for i in range(S):
            U += 0.5 * om2[i] * y[4 + i] * y[4 + i]
            P -= cd[i] * yd[4 + i] * yd[4 + i]
        if not at_rest:
            P += _case_power_lin(y, yd, acc, w1, dw1, LIN, D, off, M6, V, gram, M1, G, om2, cd,
                                 C1, C, rho)
        E = T + U
        if k == 0:
            E0 = E
            scale = abs(E)
        else:
            work += 0.5 * (P + P0) * (t - t_out[k - 1])
        P0 = P
        scale = max(scale, abs(E0), abs(work))
        energy[k, 0], energy[k, 1], energy[k, 2], energy[k, 3] = T, U, P, work
        if not math.isfinite(E) or (scale > 0 and abs(E) > growth * scale) or \
                (scale == 0 and abs(E) > 0):
            info[0], info[1], info[2], info[3] = 2.0, k, E, scale
            return Y, Yd, energy, info
        if k + 1 < nt:
            y, yd = _rk4_core(y, yd, t, h, n_sub, True, acc, LIN, LIND, amp, omf, phase, om0,
                              tau, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
    return Y, Yd, energy, info


# ------------------------------------------------------------------ wrappers
class FastChain:
    """The chain packed for the kernels, with the same functions as ``multibody``."""

    def __init__(self, chain):
        self.chain = chain
        self.data = pack(chain)

    def inverse_dynamics(self, y, yd, ydd, w1, dw1):
        return _inverse_dynamics(np.asarray(y, float), np.asarray(yd, float), np.asarray(ydd, float),
                                 w1, dw1, *self.data)[0]

    def solve_mass(self, y, r, modal_diagonal=None):
        y = np.asarray(y, float)
        n = y.size
        zero = np.zeros(n)
        unit = modal_diagonal is None
        dg = np.ones(n - 4) if unit else np.asarray(modal_diagonal, float)
        _, Mx_all, HB, R_all, p_all, Lw_all, _ = _inverse_dynamics(
            y, zero, zero, np.zeros(6), np.zeros(6), *self.data)
        D, off, _, V, gram = self.data[:5]
        return _solve(np.asarray(r, float), dg, unit, D, off, V, gram, Mx_all, HB, R_all, p_all, Lw_all)

    def mass_matrix(self, y):
        """M(y) (n, n), symmetrised, column by column from the inverse dynamics at unit
        accelerations.  The modal stiffness and damping are left out of these calls: they do
        not enter M, and subtracting K q (up to ~1e5 |M| on the truth model at q ~ 1e-7)
        from every column would cost ~5 digits of M."""
        y = np.asarray(y, float)
        n = y.size
        D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho = self.data
        data = (D, off, M6, V, gram, M1, G, np.zeros_like(om2), np.zeros_like(cd), C1, C, rho)
        zero, z6 = np.zeros(n), np.zeros(6)
        base = _inverse_dynamics(y, zero, zero, z6, z6, *data)[0]
        M = np.empty((n, n))
        e = np.zeros(n)
        for i in range(n):
            e[i] = 1.0
            M[:, i] = _inverse_dynamics(y, zero, e, z6, z6, *data)[0] - base
            e[i] = 0.0
        return 0.5 * (M + M.T)

    def accelerations(self, y, yd, w1, dw1, tau):
        return _accelerations(y, yd, w1, dw1, tau, *self.data)

    def kinetic_energy(self, y, yd, w1):
        """T [in lbf] with the case twist w1 (6,)."""
        return _kinetic_energy(np.asarray(y, float), np.asarray(yd, float), w1, *self.data)

    def case_power_at(self, y, yd, w1, dw1, tau):
        """case_power at the accelerations of the equations (one compiled call)."""
        return float(_case_power(np.asarray(y, float), np.asarray(yd, float), w1, dw1,
                                 np.asarray(tau, float), *self.data))


def make_rhs(chain, case=None, torque=None):
    """rhs(t, y, y') -> y'' (compiled)."""
    fc = FastChain(chain)
    data = fc.data
    case = case or multibody.CaseMotion()
    from solver.dynamics.integrators import _torque_function
    tau_f = _torque_function(torque)
    at_rest = case.at_rest
    const_tau = None if callable(torque) else np.asarray(tau_f(0.0), float)
    # the case motion as arrays for the compiled twist (multibody.CaseMotion.twist)
    c_amp = np.array(case.amplitude, float)
    c_omf = 2 * math.pi * np.array(case.frequency, float)
    c_ph = np.array(case.phase, float)
    c_om0 = np.array(case.omega0, float)
    w1 = np.zeros(6)
    dw1 = np.zeros(6)

    def rhs(t, y, yd):
        if not at_rest:        # case.twist(t), compiled (it is called 4x per RK4 step)
            _case_twist(float(t), c_amp, c_omf, c_ph, c_om0, w1, dw1)
        tau = const_tau if const_tau is not None else np.asarray(tau_f(t), float)
        return _accelerations(y, yd, w1, dw1, tau, *data)
    rhs.fast_chain = fc

    def case_twist(t):
        """(w1, dw1) (6,) each, compiled (multibody.CaseMotion.twist)."""
        w, dw = np.zeros(6), np.zeros(6)
        _case_twist(float(t), c_amp, c_omf, c_ph, c_om0, w, dw)
        return w, dw
    rhs.case_twist = case_twist
    if const_tau is not None:
        tau_c = np.ascontiguousarray(const_tau, dtype=float)

        def rk4_steps(y, yd, t0, h, n):
            """n compiled RK4 steps from (t0, y, y'); returns (y, y')."""
            return _rk4_run(np.asarray(y, float), np.asarray(yd, float), float(t0), float(h), int(n),
                            c_amp, c_omf, c_ph, c_om0, tau_c, *data)
        rhs.rk4_steps = rk4_steps

        def rk4_integrate(y0, yd0, t_out, h, n_sub, growth):
            """A whole RK4 run with outputs and energy watch (``_rk4_integrate``)."""
            return _rk4_integrate(np.asarray(y0, float), np.asarray(yd0, float),
                                  np.asarray(t_out, float), float(h), int(n_sub), float(growth),
                                  bool(at_rest), c_amp, c_omf, c_ph, c_om0, tau_c, *data)
        rhs.rk4_integrate = rk4_integrate
    return rhs
