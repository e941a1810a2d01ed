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

_JIT = dict(cache=True, fastmath=False)


def pack(chain):
    """Flat arrays of the chain for the kernels (see ``_inverse_dynamics``)."""
    D = np.array(chain.n_modes, dtype=np.int64)
    off = np.zeros(4, dtype=np.int64)
    off[1:] = np.cumsum(D)[:3]
    S = int(D.sum())
    M6 = np.zeros((4, 6, 6))
    B0 = np.zeros((6, S))
    M1 = np.zeros((S, 6, 6))
    om2 = np.zeros(S)
    cd = np.zeros(S)
    Psi = np.zeros((3, S))
    Th = np.zeros((3, S))
    goff = np.zeros(5, dtype=np.int64)   # kept for the signature; G is per body
    G = []
    M1s = []   # per body (D, 36): dM_X/dq_i flattened, for BLAS contractions
    for k, b in enumerate(chain.bodies):
        s = slice(off[k], off[k] + D[k])
        G.append(np.ascontiguousarray(np.asarray(b.coriolis, float).reshape(D[k], 3 * D[k])))
        M1s.append(np.ascontiguousarray(np.asarray(b.inertia_gradient, float).reshape(D[k], 36)))
        M6[k] = b.rigid_mass
        if D[k]:
            B0[:, s] = b.momentum
            M1[s] = b.inertia_gradient
            om2[s] = b.omega2
            cd[s] = b.damping
            if b.inside_translation is not None and k < 3:
                Psi[:, s] = b.inside_translation
                Th[:, s] = b.inside_rotation
    return (D, off, M6, B0, tuple(M1s), tuple(G), goff, om2, cd, Psi, Th,
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


@numba.njit(**_JIT)
def _mtm(A, B):
    """A^T B."""
    n, m, p = A.shape[0], A.shape[1], B.shape[1]
    out = np.zeros((m, p))
    for k in range(n):
        for i in range(m):
            a = A[k, i]
            for j in range(p):
                out[i, j] += a * B[k, j]
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
@numba.njit(cache=True, fastmath={"reassoc", "contract", "nsz"})
def _coriolis_pass(G2, q, qd, om):
    """Contractions of body k's G (D, 3, D), stored flat as (D, 3D) rows, in ONE pass:
    hq = q^T G (3D,), hqd = q'^T G (3D,) and gq = G wq (D,) with wq = omega (x) q'.
    G is the only O(D^2) data of the right-hand side (240 kB per 100-mode body), so
    reading it once instead of twice (two BLAS calls) is what counts; fastmath lets
    the row dot product vectorise (summation order differs from BLAS at round-off)."""
    D = q.shape[0]
    D3 = G2.shape[1]
    hq = np.zeros(D3)
    hqd = np.zeros(D3)
    gq = np.empty(D)
    wq = np.empty(D3)
    for a in range(3):
        for i in range(D):
            wq[a * D + i] = om[a] * qd[i]
    for j in range(D):
        qj = q[j]
        qdj = qd[j]
        s = 0.0
        for c in range(D3):
            g = G2[j, c]
            hq[c] += qj * g
            hqd[c] += qdj * g
            s += g * wq[c]
        gq[j] = s
    return hq, hqd, gq


@numba.njit(**_JIT)
def _kinematics(y, yd, ydd, w1, dw1, D, off, Psi, Th, C1, C, rho):
    """Joint poses R (4,3,3), p (4,3), joint maps L (6, S) (columns of the parent's
    modes), body twists W (4,6) and accelerations DW (4,6) at accelerations ydd."""
    S = Psi.shape[1]
    R_all = np.zeros((4, 3, 3))
    p_all = np.zeros((4, 3))
    L = np.zeros((6, S))
    W = np.zeros((4, 6))
    DW = np.zeros((4, 6))
    w_par = w1.copy()
    dw_par = dw1.copy()
    ex = np.array([1.0, 0.0, 0.0])
    for j in range(4):
        gd = yd[j]
        Rx = _rot(0, y[j])
        xi = np.zeros(6)
        bias = np.zeros(6)
        if j == 0:
            R = _mm(C1, Rx)
            p = rho.copy()
            xi[3] = gd
        else:
            k = j - 1
            Dk = D[k]
            o = off[k]
            RjT = _mm(C, Rx).T.copy()
            if Dk == 0:
                R = _mm(C, Rx)
                p = np.zeros(3)
                xi[3] = gd
            else:
                p = np.zeros(3)
                pd = np.zeros(3)
                th = np.zeros(3)
                thd = np.zeros(3)
                for i in range(Dk):
                    qi = y[4 + o + i]
                    qdi = yd[4 + o + i]
                    for a in range(3):
                        p[a] += Psi[a, o + i] * qi
                        pd[a] += Psi[a, o + i] * qdi
                        th[a] += Th[a, o + i] * qi
                        thd[a] += Th[a, o + i] * qdi
                Rz = _rot(2, th[2])
                Ry = _rot(1, th[1])
                cx = _mtv(Rz, _mtv(Ry, ex))
                cy = _mtv(Rz, np.array([0.0, 1.0, 0.0]))
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
                RT = R.T.copy()
                RjTTe = _mm(RjT, Te)
                for i in range(Dk):
                    for a in range(3):
                        sv = 0.0
                        sw = 0.0
                        for b in range(3):
                            sv += RT[a, b] * Psi[b, o + i]
                            sw += RjTTe[a, b] * Th[b, o + i]
                        L[a, o + i] = sv
                        L[3 + a, o + i] = sw
                bias[:3] = -_cross(w_rel, v_rel)
                bias[3:] = -_cross(ex * gd, w_rel - ex * gd) + _mv(RjT, domE)
        w = _adinv(R, p, w_par) + xi
        dw = _adinv(R, p, dw_par) + _bracket(w, xi) + bias
        dw[3] += ydd[j]
        if j > 0:
            k = j - 1
            o = off[k]
            for i in range(D[k]):
                a_i = ydd[4 + o + i]
                for a in range(6):
                    dw[a] += L[a, o + i] * a_i
        R_all[j] = R
        p_all[j] = p
        W[j] = w
        DW[j] = dw
        w_par = w
        dw_par = dw
    return R_all, p_all, L, W, DW


@numba.njit(**_JIT)
def _inverse_dynamics(y, yd, ydd, w1, dw1, D, off, M6, B0, M1, G, goff, om2, cd, Psi, Th, C1, C, rho):
    """c_total (n,) = M(y) ydd + c(y, y', t), plus what the solve reuses:
    Mx (4,6,6), B (6,S) at q, joint poses and maps."""
    S = B0.shape[1]
    n = 4 + S
    R_all, p_all, L, W, DW = _kinematics(y, yd, ydd, w1, dw1, D, off, Psi, Th, C1, C, rho)
    out = np.zeros(n)
    Mx_all = np.zeros((4, 6, 6))
    B = B0.copy()
    F_child = np.zeros(6)
    for k in range(3, -1, -1):
        Dk = D[k]
        o = off[k]
        w = W[k]
        dw = DW[k]
        om = w[3:]
        M1k = M1[k]
        Mx = M6[k].copy()
        dMx = np.zeros((6, 6))
        ww = np.empty(36)
        for a in range(6):
            for b in range(6):
                ww[6 * a + b] = w[a] * w[b]
        half_all = np.zeros(Dk)
        if Dk > 0:
            QQ = np.empty((2, Dk))
            QQ[0] = y[4 + o:4 + o + Dk]
            QQ[1] = yd[4 + o:4 + o + Dk]
            MM = np.dot(QQ, M1k)           # (2, 36): sum q_i M1_i, sum q'_i M1_i
            half_all = np.dot(M1k, ww)     # w^T M1_i w
            for a in range(6):
                for b in range(6):
                    Mx[a, b] += MM[0, 6 * a + b]
                    dMx[a, b] += MM[1, 6 * a + b]
        # fused pass over G[j, a, i]: hq = sum_j q_j G_j, hqd = sum_j q'_j G_j,
        # gq_j = omega . G_j q'; then t = hqd^T omega, u = hqd q'
        qk = y[4 + o:4 + o + Dk].copy()
        qdk = yd[4 + o:4 + o + Dk].copy()
        hq_f, hqd_f, gq = _coriolis_pass(G[k], qk, qdk, om)
        hq = hq_f.reshape((3, Dk))
        tvec = np.zeros(Dk)
        u = np.zeros(3)
        for a in range(3):
            for i in range(Dk):
                h_ai = hqd_f[a * Dk + i]
                tvec[i] += om[a] * h_ai
                u[a] += h_ai * qdk[i]
        for a in range(3):
            for i in range(Dk):
                B[3 + a, o + i] += hq[a, i]
        # momentum and its rate
        mu = _mv(Mx, w)
        dmu = _mv(Mx, dw) + _mv(dMx, w)
        for i in range(Dk):
            qdi = yd[4 + o + i]
            qddi = ydd[4 + o + i]
            for a in range(6):
                mu[a] += B[a, o + i] * qdi
                dmu[a] += B[a, o + i] * qddi
        dmu[3:] += u
        pv = mu[:3]
        h = mu[3:]
        v = w[:3]
        F = dmu.copy()
        F[:3] += _cross(om, pv)
        F[3:] += _cross(om, h) + _cross(v, pv)
        # modal forces
        Mw = np.zeros(6)
        for i in range(Dk):
            ii = o + i
            dpi = tvec[i] + ydd[4 + ii]
            for a in range(6):
                dpi += B[a, ii] * dw[a]
            half = half_all[i]
            Q = dpi - 0.5 * half - gq[i] + om2[ii] * y[4 + ii] + cd[ii] * yd[4 + ii]
            out[4 + ii] = Q
        if k < 3:
            Rc = R_all[k + 1]
            pc = p_all[k + 1]
            F += _adinv_T(Rc, pc, F_child)
            for i in range(Dk):
                s = 0.0
                for a in range(6):
                    s += L[a, o + i] * F_child[a]
                out[4 + o + i] += s
        out[k] = F[3]
        F_child = F
        Mx_all[k] = Mx
    return out, Mx_all, B, R_all, p_all, L, F_child


@numba.njit(**_JIT)
def _solve(r, dg, D, off, Mx_all, B, R_all, p_all, L):
    """x with (M + diag(0, dg - 1)) x = r: articulated-body recursion (see multibody.solve_mass)."""
    S = B.shape[1]
    n = 4 + S
    IA = np.zeros((4, 6, 6))
    bA = np.zeros((4, 6))
    Ks = np.zeros((6, S))
    rqs = np.zeros(S)
    Itils = np.zeros((4, 6, 6))
    Zinvs = np.zeros((4, 6, 6))
    for k in range(3, -1, -1):
        Dk = D[k]
        o = off[k]
        I_art = Mx_all[k].copy()
        b_art = np.zeros(6)
        for i in range(Dk):
            rqs[o + i] = r[4 + o + i]
            for a in range(6):
                Ks[a, o + i] = B[a, o + i]
        has_child_L = False
        Itil = np.zeros((6, 6))
        if k < 3:
            Ic = IA[k + 1]
            bc = bA[k + 1]
            d = Ic[3, 3]
            Is = Ic[:, 3].copy()
            u = r[k + 1] - bc[3]
            for a in range(6):
                for b in range(6):
                    Itil[a, b] = Ic[a, b] - Is[a] * Is[b] / d
            pa = bc + Is * (u / d)
            A = _adinv_matrix(R_all[k + 1], p_all[k + 1])
            AtI = _mtm(A, Itil)
            I_art += _mm(AtI, A)
            b_art += _mtv(A, pa)
            if Dk > 0:
                has_child_L = True
                for i in range(Dk):        # K += Ad^-T Itil L, rq -= L^T pa (no temporaries)
                    s = 0.0
                    for a in range(6):
                        ka = 0.0
                        for b in range(6):
                            ka += AtI[a, b] * L[b, o + i]
                        Ks[a, o + i] += ka
                        s += L[a, o + i] * pa[a]
                    rqs[o + i] -= s
        if Dk > 0:
            # K N^-1 K^T and K N^-1 rq with N = diag(dg) + L^T Itil L (Woodbury)
            KdK = np.zeros((6, 6))
            KdL = np.zeros((6, 6))
            LdL = np.zeros((6, 6))
            zd = np.zeros(Dk)
            for i in range(Dk):
                zd[i] = rqs[o + i] / dg[o + i]
            Kz = np.zeros(6)
            Lz = np.zeros(6)
            for i in range(Dk):
                inv = 1.0 / dg[o + i]
                for a in range(6):
                    ka = Ks[a, o + i] * inv
                    Kz[a] += Ks[a, o + i] * zd[i]
                    for b in range(6):
                        KdK[a, b] += ka * Ks[b, o + i]
                if has_child_L:
                    for a in range(6):
                        la = L[a, o + i]
                        Lz[a] += la * zd[i]
                        ka = Ks[a, o + i] * inv
                        for b in range(6):
                            KdL[a, b] += ka * L[b, o + i]
                            LdL[a, b] += la * inv * L[b, o + i]
            KNK = KdK
            KNr = Kz
            if has_child_L:
                Z = np.eye(6) + _mm(LdL, Itil)
                Zinv = _inv(Z)
                Zinvs[k] = Zinv
                Itils[k] = Itil
                KIZ = _mm(_mm(KdL, Itil), Zinv)
                KNK = KdK - _mm(KIZ, KdL.T.copy())
                KNr = Kz - _mv(KIZ, Lz)
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
        a = a_base.copy()
        a[3] += xg
        Dk = D[k]
        o = off[k]
        if Dk > 0:
            z = np.zeros(Dk)
            for i in range(Dk):
                s = rqs[o + i]
                for b in range(6):
                    s -= Ks[b, o + i] * a[b]
                z[i] = s / dg[o + i]
            if k < 3:
                Lz = np.zeros(6)
                for i in range(Dk):
                    for b in range(6):
                        Lz[b] += L[b, o + i] * z[i]
                corr = _mv(Itils[k], _mv(Zinvs[k], Lz))
                for i in range(Dk):
                    s = 0.0
                    for b in range(6):
                        s += L[b, o + i] * corr[b]
                    z[i] -= s / dg[o + i]
            for i in range(Dk):
                x[4 + o + i] = z[i]
        if k < 3:
            a_base = _adinv(R_all[k + 1], p_all[k + 1], a)
            for i in range(Dk):
                xi_ = x[4 + o + i]
                for b in range(6):
                    a_base[b] += L[b, o + i] * xi_
    return x


@numba.njit(**_JIT)
def _accelerations(y, yd, w1, dw1, tau, D, off, M6, B0, M1, G, goff, om2, cd, Psi, Th, C1, C, rho):
    n = y.shape[0]
    c, Mx_all, B, R_all, p_all, L, _ = _inverse_dynamics(
        y, yd, np.zeros(n), w1, dw1, D, off, M6, B0, M1, G, goff, om2, cd, Psi, Th, C1, C, rho)
    r = -c
    for j in range(4):
        r[j] += tau[j]
    return _solve(r, np.ones(n - 4), D, off, Mx_all, B, R_all, p_all, L)


@numba.njit(**_JIT)
def _kinetic_energy(y, yd, w1, D, off, M6, B0, M1, G, goff, om2, cd, Psi, Th, C1, C, rho):
    """T = sum_n 1/2 w^T M_X(q) w + w^T B(q) q' + 1/2 q'^T q' (multibody.kinetic_energy)."""
    n = y.shape[0]
    _, _, _, W, _ = _kinematics(y, yd, np.zeros(n), w1, np.zeros(6), D, off, Psi, Th, C1, C, rho)
    T = 0.0
    for k in range(4):
        Dk = D[k]
        o = off[k]
        w = W[k]
        Mx = M6[k].copy()
        Bw = np.zeros(Dk)            # B(q)^T w
        if Dk > 0:
            qk = y[4 + o:4 + o + Dk].copy()
            MM = np.dot(qk, M1[k])
            for a in range(6):
                for b in range(6):
                    Mx[a, b] += MM[6 * a + b]
            hq = np.dot(qk, G[k])    # (3 Dk,): sum_j q_j G_j
            for i in range(Dk):
                s = 0.0
                for a in range(6):
                    s += B0[a, o + i] * w[a]
                for a in range(3):
                    s += hq[a * Dk + i] * w[3 + a]
                Bw[i] = s
        T += 0.5 * np.dot(w, _mv(Mx, w))
        for i in range(Dk):
            qdi = yd[4 + o + i]
            T += Bw[i] * qdi + 0.5 * qdi * qdi
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
             D, off, M6, B0, M1, G, goff, om2, cd, Psi, Th, C1, C, rho):
    """n_steps classical RK4 steps of (y, y')' = (y', y'') from t0 with constant torques
    (integrators.rk4_step, compiled: no Python call per stage)."""
    y = y.copy()
    yd = yd.copy()
    w1 = np.zeros(6)
    dw1 = np.zeros(6)
    for i in range(n_steps):
        t = t0 + i * h
        _case_twist(t, amp, omf, phase, om0, w1, dw1)
        k1 = _accelerations(y, yd, w1, dw1, tau, D, off, M6, B0, M1, G, goff, om2, cd, Psi, Th, C1, C, rho)
        y2 = y + 0.5 * h * yd
        v2 = yd + 0.5 * h * k1
        _case_twist(t + 0.5 * h, amp, omf, phase, om0, w1, dw1)
        k2 = _accelerations(y2, v2, w1, dw1, tau, D, off, M6, B0, M1, G, goff, om2, cd, Psi, Th, C1, C, rho)
        y3 = y + 0.5 * h * v2
        v3 = yd + 0.5 * h * k2
        k3 = _accelerations(y3, v3, w1, dw1, tau, D, off, M6, B0, M1, G, goff, om2, cd, Psi, Th, C1, C, rho)
        y4 = y + h * v3
        v4 = yd + h * k3
        _case_twist(t + h, amp, omf, phase, om0, w1, dw1)
        k4 = _accelerations(y4, v4, w1, dw1, tau, D, off, M6, B0, M1, G, goff, om2, cd, Psi, Th, C1, C, rho)
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
        dg = np.ones(n - 4) if modal_diagonal is None else np.asarray(modal_diagonal, float)
        _, Mx_all, B, R_all, p_all, L, _ = _inverse_dynamics(y, zero, zero, np.zeros(6), np.zeros(6),
                                                          *self.data)
        D, off = self.data[0], self.data[1]
        return _solve(np.asarray(r, float), dg, D, off, Mx_all, B, R_all, p_all, L)

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
    zero6 = np.zeros(6)
    const_tau = None if callable(torque) else np.asarray(tau_f(0.0), float)
    amp = [float(a) for a in case.amplitude]
    om_f = [2 * math.pi * float(f) for f in case.frequency]
    phase = [float(p) for p in case.phase]
    om0 = [float(w) for w in case.omega0]
    w1 = np.zeros(6)
    dw1 = np.zeros(6)

    def rhs(t, y, yd):
        if not at_rest:        # case.twist(t), written out (it is called 4x per RK4 step)
            for k in range(3):
                arg = om_f[k] * t + phase[k]
                dw1[3 + k] = amp[k] * math.cos(arg)
                if om_f[k] > 0.0:
                    integ = (math.sin(arg) - math.sin(phase[k])) / om_f[k]
                else:
                    integ = math.cos(phase[k]) * t
                w1[3 + k] = om0[k] + amp[k] * integ
        tau = const_tau if const_tau is not None else np.asarray(tau_f(t), float)
        return _accelerations(y, yd, w1, dw1, tau, *data)
    rhs.fast_chain = fc
    if const_tau is not None:
        c_amp, c_omf = np.array(amp, float), np.array(om_f, float)
        c_ph, c_om0 = np.array(phase, float), np.array(om0, float)
        tau_c = np.ascontiguousarray(const_tau, dtype=float)

        def rk4_steps(y, yd, t0, h, n):
            """n compiled RK4 steps from (t0, y, y'); returns (y, y')."""
            return _rk4_run(np.asarray(y, float), np.asarray(yd, float), float(t0), float(h), int(n),
                            c_amp, c_omf, c_ph, c_om0, tau_c, *data)
        rhs.rk4_steps = rk4_steps
    return rhs
