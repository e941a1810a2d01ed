"""Compiled right-hand side of the chain: the same equations as ``solver.multibody``.

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

import numpy as np
import numba

from solver import multibody

_JIT = dict(cache=True, fastmath=False, error_model="numpy")


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


# ------------------------------------------------------------------ helpers
# Small fixed-size products written out: numba's ``@`` calls BLAS, whose call
# overhead dwarfs a 3x3 or 6x6 product.
@numba.njit(**_JIT)
def _mm(A, B):
    n, m, p = A.shape[0], A.shape[1], B.shape[1]
    out = np.zeros((n, p))
    for i in range(n):
        for k in range(m):
            a = A[i, k]
            for j in range(p):
                out[i, j] += a * B[k, j]
    return out


@numba.njit(**_JIT)
def _mv(A, x):
    n, m = A.shape
    out = np.zeros(n)
    for i in range(n):
        s = 0.0
        for k in range(m):
            s += A[i, k] * x[k]
        out[i] = s
    return out


@numba.njit(**_JIT)
def _mtv(A, x):
    n, m = A.shape
    out = np.zeros(m)
    for k in range(n):
        xk = x[k]
        for i in range(m):
            out[i] += A[k, i] * xk
    return out


@numba.njit(fastmath={"reassoc", "contract", "nsz"}, error_model="numpy", cache=True)
def _mm6(A, B):
    """A B for 6x6 A, B."""
    out = np.empty((6, 6))
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
    return out


@numba.njit(fastmath={"reassoc", "contract", "nsz"}, error_model="numpy", cache=True)
def _mm6t(A, B):
    """A B^T for 6x6 A, B."""
    out = np.empty((6, 6))
    for i in range(6):
        for j in range(6):
            s = 0.0
            for k in range(6):
                s += A[i, k] * B[j, k]
            out[i, j] = s
    return out


@numba.njit(**_JIT)
def _inv(A):
    """Inverse of a small matrix by Gauss-Jordan elimination with partial pivoting."""
    n = A.shape[0]
    M = A.copy()
    X = np.eye(n)
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
    return X


@numba.njit(**_JIT)
def _cross(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@numba.njit(**_JIT)
def _rot(axis, ang):
    c, s = np.cos(ang), np.sin(ang)
    R = np.eye(3)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    R[i, i] = c
    R[j, j] = c
    R[i, j] = -s
    R[j, i] = s
    return R


@numba.njit(**_JIT)
def _adinv(R, p, w):
    """Ad_{g^-1} w = [R^T (v + omega x p); R^T omega]."""
    out = np.empty(6)
    vp = w[:3] + _cross(w[3:], p)
    out[:3] = _mtv(R, vp)
    out[3:] = _mtv(R, w[3:])
    return out


@numba.njit(**_JIT)
def _adinv_matrix(R, p):
    A = np.zeros((6, 6))
    RT = R.T.copy()
    A[:3, :3] = RT
    A[3:, 3:] = RT
    S = np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])
    A[:3, 3:] = -_mm(RT, S)
    return A


@numba.njit(**_JIT)
def _adinv_T(R, p, F):
    out = np.empty(6)
    f = _mv(R, F[:3])
    out[:3] = f
    out[3:] = _cross(p, f) + _mv(R, F[3:])
    return out


@numba.njit(**_JIT)
def _bracket(w, xi):
    out = np.empty(6)
    out[:3] = _cross(w[3:], xi[:3]) - _cross(xi[3:], w[:3])
    out[3:] = _cross(w[3:], xi[3:])
    return out


# ------------------------------------------------------------------ kernels
# Reassociation only (no "no-NaN/no-Inf" assumptions: a diverging state must stay visible).
_FAST = dict(cache=True, fastmath={"reassoc", "contract", "nsz"}, error_model="numpy")


@numba.njit(**_FAST)
def _coriolis_pass(G2, q, qd, om):
    """The only O(D^2) work of an evaluation: body k's Coriolis tensor G (D, 3D) read once.

    Returns hq (3D,) = sum_j q_j G_j, hqd (3D,) = sum_j q'_j G_j and gq (D,),
    gq_j = omega . G_j q' (the Coriolis part of dT/dq): 9 D^2 multiply-adds.
    Rows are taken two at a time, so hq and hqd are loaded and stored once per
    two rows (measured 1.4x faster than one row at a time; four rows at a time
    spill registers and are slower).  The outputs are allocated here so that
    the compiler knows they alias nothing and vectorises the inner loop."""
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
    while j + 2 <= D:
        q0, q1 = q[j], q[j + 1]
        d0, d1 = qd[j], qd[j + 1]
        r0 = G2[j]
        r1 = G2[j + 1]
        s0 = 0.0
        s1 = 0.0
        for c in range(D3):
            g0 = r0[c]
            g1 = r1[c]
            hq[c] += q0 * g0 + q1 * g1
            hqd[c] += d0 * g0 + d1 * g1
            w = wq[c]
            s0 += g0 * w
            s1 += g1 * w
        gq[j] = s0
        gq[j + 1] = s1
        j += 2
    if j < D:
        qj, dj = q[j], qd[j]
        r0 = G2[j]
        s = 0.0
        for c in range(D3):
            g = r0[c]
            hq[c] += qj * g
            hqd[c] += dj * g
            s += g * wq[c]
        gq[j] = s
    return hq, hqd, gq


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
def _add_inertia(Mx, M1, o, Dk, x):
    """Mx (6, 6) += sum_i x_i dM_X/dq_i, from the 15 rows of M1 (inertia_gradient_rows)."""
    for a in range(3):
        for b in range(3):
            s = _dot(M1[3 * a + b, o:o + Dk], x)
            Mx[3 + a, b] += s
            Mx[b, 3 + a] += s
    for c in range(6):
        a, b = _YS_PAIRS[c]
        s = _dot(M1[9 + c, o:o + Dk], x)
        Mx[3 + a, 3 + b] += s
        if a != b:
            Mx[3 + b, 3 + a] += s


@numba.njit(**_JIT)
def _inertia_weights(w, ww):
    """ww (15,) with 1/2 w^T M1_i w = sum_c ww_c M1[c, i]."""
    for a in range(3):
        for b in range(3):
            ww[3 * a + b] = w[3 + a] * w[b]
    for c in range(6):
        a, b = _YS_PAIRS[c]
        ww[9 + c] = (0.5 if a == b else 1.0) * w[3 + a] * w[3 + b]


@numba.njit(**_JIT)
def _kinematics(y, yd, ydd, w1, dw1, D, off, V, C1, C, rho, R_all, p_all, Lw_all, W, DW):
    """Forward pass, in place: joint poses R_all (4,3,3), p_all (4,3), the rotation part
    Lw_all (4,3,3) of each joint map L = [R^T Psi; Lw Theta] of the parent's modes,
    body twists W (4,6) and their rates DW (4,6) at accelerations ydd."""
    w_par = w1.copy()
    dw_par = dw1.copy()
    ex = np.array([1.0, 0.0, 0.0])
    ey = np.array([0.0, 1.0, 0.0])
    v4 = np.empty(4)
    for j in range(4):
        gd = yd[j]
        Rx = _rot(0, y[j])
        xi = np.zeros(6)
        bias = np.zeros(6)
        Lw = np.zeros((3, 3))
        k = j - 1
        if j == 0:
            R = _mm(C1, Rx)
            p = rho.copy()
            xi[3] = gd
        elif D[k] == 0:
            R = _mm(C, Rx)
            p = np.zeros(3)
            xi[3] = gd
        else:
            Dk = D[k]
            o = off[k]
            RjT = _mm(C, Rx).T.copy()
            # inside-frame translation t = Psi q and rotation th = Theta q, and their rates
            qk = y[4 + o:4 + o + Dk]
            qdk = yd[4 + o:4 + o + Dk]
            p = np.empty(3)
            pd = np.empty(3)
            th = np.empty(3)
            thd = np.empty(3)
            _rows_dot(V, o, Dk, qk, p, 6, 3)
            _rows_dot(V, o, Dk, qdk, pd, 6, 3)
            _rows_dot(V, o, Dk, qk, th, 9, 3)
            _rows_dot(V, o, Dk, qdk, thd, 9, 3)
            Rz = _rot(2, th[2])
            Ry = _rot(1, th[1])
            cx = _mtv(Rz, _mtv(Ry, ex))
            cy = _mtv(Rz, ey)
            Te = np.zeros((3, 3))
            Te[:, 0] = cx
            Te[:, 1] = cy
            Te[2, 2] = 1.0
            E = _mm(_mm(_rot(0, th[0]), Ry), Rz)
            R = _mm(_mm(E, C), Rx)
            a1 = cx * thd[0]
            a2 = cy * thd[1]
            a3 = np.array([0.0, 0.0, thd[2]])
            omE = a1 + a2 + a3
            domE = _cross(a1, a2 + a3) + _cross(a2, a3)
            v_rel = _mtv(R, pd)
            w_rel = _mv(RjT, omE)
            w_rel[0] += gd
            xi[:3] = v_rel
            xi[3:] = w_rel
            Lw = _mm(RjT, Te)
            bias[:3] = -_cross(w_rel, v_rel)
            bias[3:] = -_cross(ex * gd, w_rel - ex * gd) + _mv(RjT, domE)
        w = _adinv(R, p, w_par) + xi
        dw = _adinv(R, p, dw_par) + _bracket(w, xi) + bias
        dw[3] += ydd[j]
        if j > 0 and D[k] > 0:            # + L q''_parent
            Dk = D[k]
            o = off[k]
            qdd = ydd[4 + o:4 + o + Dk]
            pdd = np.empty(3)
            thdd = np.empty(3)
            _rows_dot(V, o, Dk, qdd, pdd, 6, 3)
            _rows_dot(V, o, Dk, qdd, thdd, 9, 3)
            dw[:3] += _mtv(R, pdd)
            dw[3:] += _mv(Lw, thdd)
        R_all[j] = R
        p_all[j] = p
        Lw_all[j] = Lw
        W[j] = w
        DW[j] = dw
        w_par = w
        dw_par = dw


@numba.njit(**_FAST)
def _inverse_dynamics(y, yd, ydd, w1, dw1, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """out (n,) = M(y) ydd + c(y, y', t) by the recursive Newton-Euler passes, and what
    the solve reuses: Mx_all (4,6,6) = M_X(q) per body, HB (3, S) = H + sum_j q_j G_j (the angular rows of B(q)),
    the joint data (R_all, p_all, Lw_all) and F0, the composite wrench on body 2."""
    S = V.shape[1]
    n = 4 + S
    R_all = np.empty((4, 3, 3))
    p_all = np.empty((4, 3))
    Lw_all = np.empty((4, 3, 3))
    W = np.empty((4, 6))
    DW = np.empty((4, 6))
    _kinematics(y, yd, ydd, w1, dw1, D, off, V, C1, C, rho, R_all, p_all, Lw_all, W, DW)
    out = np.zeros(n)
    Mx_all = np.empty((4, 6, 6))
    HB = np.zeros((3, S))
    F_child = np.zeros(6)
    ww = np.empty(15)
    for k in range(3, -1, -1):
        Dk = D[k]
        o = off[k]
        w = W[k]
        dw = DW[k]
        om = w[3:]
        Mx = M6[k].copy()
        dMx = np.zeros((6, 6))
        mu = np.zeros(6)
        dmu = np.zeros(6)
        if Dk > 0:
            qk = y[4 + o:4 + o + Dk]
            qdk = yd[4 + o:4 + o + Dk]
            qddk = ydd[4 + o:4 + o + Dk]
            # dM_X/dq_i through its 15 independent rows: M_X(q) = M6 + sum q_i M1_i,
            # its rate sum q'_i M1_i, and half_i = 1/2 w^T M1_i w = w_a Yv_ab v_b + 1/2 w^T Ys w
            _add_inertia(Mx, M1, o, Dk, qk)
            _add_inertia(dMx, M1, o, Dk, qdk)
            _inertia_weights(w, ww)
            half = np.zeros(Dk)
            for c in range(15):
                _axpy(ww[c], M1[c, o:o + Dk], half)
            hq, hqd, gq = _coriolis_pass(G[k], qk, qdk, om)
            # B(q) q' and B(q) q'' with B = [P; H + hq]; u = (sum q'_j G_j) q'
            Bqd = np.empty(6)
            Bqdd = np.empty(6)
            _rows_dot(V, o, Dk, qdk, Bqd, 0, 6)
            _rows_dot(V, o, Dk, qddk, Bqdd, 0, 6)
            for a in range(3):
                h = hq[a * Dk:(a + 1) * Dk]
                HB[a, o:o + Dk] = V[3 + a, o:o + Dk] + h
                Bqd[3 + a] += _dot(h, qdk)
                Bqdd[3 + a] += _dot(h, qddk)
                dmu[3 + a] += _dot(hqd[a * Dk:(a + 1) * Dk], qdk)
            mu += Bqd
            dmu += Bqdd
        mu += _mv(Mx, w)
        dmu += _mv(Mx, dw) + _mv(dMx, w)
        F = dmu.copy()
        F[:3] += _cross(om, mu[:3])
        F[3:] += _cross(om, mu[3:]) + _cross(w[:3], mu[:3])
        if k < 3:
            Rc = R_all[k + 1]
            F += _adinv_T(Rc, p_all[k + 1], F_child)
        if Dk > 0:
            # modal forces Q = B^T dw + (sum q'_j G_j)^T omega + q'' - dT/dq + Omega^2 q + C q'
            # (+ L^T F_child): one pass over the rows [P; H; Psi; Theta] and hq
            cv = np.zeros(12)
            cv[0:6] = dw
            if k < 3:
                cv[6:9] = _mv(R_all[k + 1], F_child[:3])
                cv[9:12] = _mtv(Lw_all[k + 1], F_child[3:])
            Q = out[4 + o:4 + o + Dk]
            for i in range(Dk):
                ii = o + i
                Q[i] = ydd[4 + ii] + om2[ii] * y[4 + ii] + cd[ii] * yd[4 + ii] - half[i] - gq[i]
            for a in range(12):
                _axpy(cv[a], V[a, o:o + Dk], Q)
            for a in range(3):
                _axpy(dw[3 + a], hq[a * Dk:(a + 1) * Dk], Q)
                _axpy(om[a], hqd[a * Dk:(a + 1) * Dk], Q)
        out[k] = F[3]
        F_child = F
        Mx_all[k] = Mx
    return out, Mx_all, HB, R_all, p_all, Lw_all, F_child


@numba.njit(**_FAST)
def _gram_blocks(V, HB, o, Dk, dinv, gram_k, unit, BB, BY, YY):
    """Weighted Gram blocks (6, 6) of a body's modal rows, W = diag(dinv):
    BB = B W B^T, BY = B W Y^T, YY = Y W Y^T, with B = [P; H + hq] and
    Y = [Psi; Theta].  With W = I only the rows of H + hq are new (gram_k holds
    the constant Gram of [P; H; Psi; Theta])."""
    w = dinv[o:o + Dk]
    for a in range(6):
        ra = V[a, o:o + Dk] if a < 3 else HB[a - 3, o:o + Dk]
        for b in range(a + 1):
            if unit and a < 3:
                s = gram_k[a, b]
            else:
                rb = V[b, o:o + Dk] if b < 3 else HB[b - 3, o:o + Dk]
                s = _dot(ra, rb) if unit else _dotw(ra, rb, w)
            BB[a, b] = s
            BB[b, a] = s
        for b in range(6):
            if unit and a < 3:
                s = gram_k[a, 6 + b]
            else:
                s = _dot(ra, V[6 + b, o:o + Dk]) if unit else _dotw(ra, V[6 + b, o:o + Dk], w)
            BY[a, b] = s
        for b in range(6):
            if a < 6 and b <= a:
                if unit:
                    s = gram_k[6 + a, 6 + b]
                else:
                    s = _dotw(V[6 + a, o:o + Dk], V[6 + b, o:o + Dk], w)
                YY[a, b] = s
                YY[b, a] = s


@numba.njit(**_JIT)
def _solve(r, dg, unit, D, off, V, gram, Mx_all, HB, R_all, p_all, Lw_all):
    """x with (M + diag(0, dg - 1)) x = r: the articulated-body recursion of
    multibody.solve_mass (docs/dynamics.md, Section 3).

    A body's modes enter only through its modal rows B = [P; H + hq] (6, D) and
    Y = [Psi; Theta] (6, D): the joint map of its child is L = Lam Y with
    Lam = diag(R^T, Lw) (6, 6), and K = B + Ad^-T Itil L = B + Mk Y.  So every
    product over the modes that the Woodbury elimination needs (K N^-1 K^T,
    K N^-1 L^T, L N^-1 L^T, K N^-1 r, ...) is a 6x6 expression in the Gram blocks
    BB, BY, YY of _gram_blocks and the projections B r/dg, Y r/dg: per body
    three passes over the modes remain (Gram rows of H + hq, projections,
    back-substitution), everything else is 6x6 algebra."""
    S = V.shape[1]
    n = 4 + S
    dinv = 1.0 / dg
    IA = np.zeros((4, 6, 6))
    bA = np.zeros((4, 6))
    BB = np.zeros((4, 6, 6))
    BY = np.zeros((4, 6, 6))
    YY = np.zeros((4, 6, 6))
    Br = np.zeros((4, 6))
    Yr = np.zeros((4, 6))
    Lam = np.zeros((4, 6, 6))
    Mk = np.zeros((4, 6, 6))
    pa_all = np.zeros((4, 6))
    Itils = np.zeros((4, 6, 6))
    Zinvs = np.zeros((4, 6, 6))
    for k in range(3, -1, -1):
        Dk = D[k]
        o = off[k]
        I_art = Mx_all[k].copy()
        b_art = np.zeros(6)
        child = k < 3
        if child:
            Ic = IA[k + 1]
            bc = bA[k + 1]
            d = Ic[3, 3]
            Is = Ic[:, 3].copy()
            u = r[k + 1] - bc[3]
            Itil = Itils[k]
            for a in range(6):
                for b in range(6):
                    Itil[a, b] = Ic[a, b] - Is[a] * Is[b] / d
            pa = bc + Is * (u / d)
            pa_all[k] = pa
            A = _adinv_matrix(R_all[k + 1], p_all[k + 1])
            AtI = _mm6(A.T.copy(), Itil)
            I_art += _mm6(AtI, A)
            b_art += _mtv(A, pa)
            Lm = Lam[k]
            Lm[:3, :3] = R_all[k + 1].T
            Lm[3:, 3:] = Lw_all[k + 1]
            Mk[k] = _mm6(AtI, Lm)
        if Dk > 0:
            _gram_blocks(V, HB, o, Dk, dinv, gram[k], unit, BB[k], BY[k], YY[k])
            rd = r[4 + o:4 + o + Dk] * dinv[o:o + Dk]
            for a in range(6):
                Br[k, a] = _dot(V[a, o:o + Dk] if a < 3 else HB[a - 3, o:o + Dk], rd)
                Yr[k, a] = _dot(V[6 + a, o:o + Dk], rd)
            if child:
                M = Mk[k]
                Lm = Lam[k]
                yh = _mtv(Lm, pa_all[k])                 # L^T pa = Y^T yh
                Bz = Br[k] - _mv(BY[k], yh)              # B zd, zd = (r_q - L^T pa)/dg
                Yz = Yr[k] - _mv(YY[k], yh)              # Y zd
                MBYt = _mm6t(M, BY[k])
                KNK = BB[k] + MBYt + MBYt.T + _mm6t(_mm6(M, YY[k]), M)
                KNr = Bz + _mv(M, Yz)
                KdL = _mm6t(BY[k] + _mm6(M, YY[k]), Lm)
                LdL = _mm6t(_mm6(Lm, YY[k]), Lm)
                Lz = _mv(Lm, Yz)
                Zinv = _inv(np.eye(6) + _mm6(LdL, Itils[k]))
                Zinvs[k] = Zinv
                KIZ = _mm6(_mm6(KdL, Itils[k]), Zinv)
                KNK = KNK - _mm6t(KIZ, KdL)
                KNr = KNr - _mv(KIZ, Lz)
            else:
                KNK = BB[k]
                KNr = Br[k].copy()
            I_art -= KNK
            b_art += KNr
        IA[k] = 0.5 * (I_art + I_art.T)
        bA[k] = b_art
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
        acc = a_base.copy()
        acc[3] += xg
        Dk = D[k]
        o = off[k]
        child = k < 3
        Lz = np.zeros(6)
        if Dk > 0:
            # z = (r_q - B^T acc - Y^T eY)/dg with eY = Lam^T (pa + corr) + Mk^T acc;
            # corr = Itil Zinv L z0 (Woodbury), z0 the same without corr
            eY = np.zeros(6)
            if child:
                Lm = Lam[k]
                eY = _mtv(Lm, pa_all[k]) + _mtv(Mk[k], acc)
                Yz0 = Yr[k] - _mtv(BY[k], acc) - _mv(YY[k], eY)
                corr = _mv(Itils[k], _mv(Zinvs[k], _mv(Lm, Yz0)))
                eY += _mtv(Lm, corr)
            z = r[4 + o:4 + o + Dk].copy()
            for a in range(3):
                _axpy(-acc[a], V[a, o:o + Dk], z)
                _axpy(-acc[3 + a], HB[a, o:o + Dk], z)
            if child:
                for a in range(6):
                    _axpy(-eY[a], V[6 + a, o:o + Dk], z)
                Lz = _mv(Lam[k], Yr[k] - _mtv(BY[k], acc) - _mv(YY[k], eY))   # L z = Lam Y z
            x[4 + o:4 + o + Dk] = z * dinv[o:o + Dk]
        if child:
            a_base = _adinv(R_all[k + 1], p_all[k + 1], acc) + Lz
    return x


@numba.njit(**_JIT)
def _accelerations(y, yd, w1, dw1, tau, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """y'' = M(y)^-1 (tau - c(y, y', t))."""
    n = y.shape[0]
    c, Mx_all, HB, R_all, p_all, Lw_all, _ = _inverse_dynamics(
        y, yd, np.zeros(n), w1, dw1, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
    r = -c
    for j in range(4):
        r[j] += tau[j]
    return _solve(r, np.ones(n - 4), True, D, off, V, gram, Mx_all, HB, R_all, p_all, Lw_all)


@numba.njit(**_JIT)
def _kinetic_energy(y, yd, w1, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """T = sum_n 1/2 w^T M_X(q) w + w^T B(q) q' + 1/2 q'^T q' (multibody.kinetic_energy)."""
    n = y.shape[0]
    R_all = np.empty((4, 3, 3))
    p_all = np.empty((4, 3))
    Lw_all = np.empty((4, 3, 3))
    W = np.empty((4, 6))
    DW = np.empty((4, 6))
    _kinematics(y, yd, np.zeros(n), w1, np.zeros(6), D, off, V, C1, C, rho, R_all, p_all, Lw_all, W, DW)
    T = 0.0
    for k in range(4):
        Dk = D[k]
        o = off[k]
        w = W[k]
        Mx = M6[k].copy()
        if Dk > 0:
            qk = y[4 + o:4 + o + Dk]
            qdk = yd[4 + o:4 + o + Dk]
            _add_inertia(Mx, M1, o, Dk, qk)
            hq, _, _ = _coriolis_pass(G[k], qk, qdk, w[3:])
            Bqd = np.empty(6)
            _rows_dot(V, o, Dk, qdk, Bqd, 0, 6)
            for a in range(3):
                for i in range(Dk):
                    Bqd[3 + a] += hq[a * Dk + i] * qdk[i]
            for i in range(Dk):
                T += 0.5 * qdk[i] * qdk[i]
            T += np.dot(w, Bqd)
        T += 0.5 * np.dot(w, _mv(Mx, w))
    return T


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
def _rk4_run(y, yd, t0, h, n_steps, amp, omf, phase, om0, tau,
             D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho):
    """n_steps classical RK4 steps of (y, y')' = (y', y'') from t0 with constant torques
    (integrators.rk4_step, compiled: no Python call per stage)."""
    y = y.copy()
    yd = yd.copy()
    w1 = np.zeros(6)
    dw1 = np.zeros(6)
    for i in range(n_steps):
        t = t0 + i * h
        _case_twist(t, amp, omf, phase, om0, w1, dw1)
        k1 = _accelerations(y, yd, w1, dw1, tau, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
        y2 = y + 0.5 * h * yd
        v2 = yd + 0.5 * h * k1
        _case_twist(t + 0.5 * h, amp, omf, phase, om0, w1, dw1)
        k2 = _accelerations(y2, v2, w1, dw1, tau, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
        y3 = y + 0.5 * h * v2
        v3 = yd + 0.5 * h * k2
        k3 = _accelerations(y3, v3, w1, dw1, tau, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
        y4 = y + h * v3
        v4 = yd + h * k3
        _case_twist(t + h, amp, omf, phase, om0, w1, dw1)
        k4 = _accelerations(y4, v4, w1, dw1, tau, D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho)
        y = y + (h / 6.0) * (yd + 2.0 * v2 + 2.0 * v3 + v4)
        yd = yd + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return y, yd


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

    def case_power(self, y, yd, ydd, w1, dw1):
        """Power the case motion feeds into bodies 2-5 (multibody.case_power)."""
        out = _inverse_dynamics(np.asarray(y, float), np.asarray(yd, float), np.asarray(ydd, float),
                                w1, dw1, *self.data)
        R, p, F = out[3][0], out[4][0], out[6]
        return float(_adinv(R, p, w1) @ F)


def make_rhs(chain, case=None, torque=None):
    """rhs(t, y, y') -> y'' (compiled)."""
    fc = FastChain(chain)
    data = fc.data
    case = case or multibody.CaseMotion()
    from solver.integrators import _torque_function
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
    if const_tau is not None:
        tau_c = np.ascontiguousarray(const_tau, dtype=float)

        def rk4_steps(y, yd, t0, h, n):
            """n compiled RK4 steps from (t0, y, y'); returns (y, y')."""
            return _rk4_run(np.asarray(y, float), np.asarray(yd, float), float(t0), float(h), int(n),
                            c_amp, c_omf, c_ph, c_om0, tau_c, *data)
        rhs.rk4_steps = rk4_steps
    return rhs
