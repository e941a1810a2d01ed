"""The recursion of the chain, compiled: kinematics (forward pass), the Newton-Euler
backward pass, the articulated-body solve, the energies and the case twist.

The same equations as ``gimbal_reduction.solver.dynamics.multibody`` (docs/dynamics.md Section 3); every
kernel takes the packed chain ``ch`` (``compiled.PackedChain``) and, for the passes, the
``Frames`` of one state.
"""

import math
from typing import NamedTuple

import numba
import numpy as np

from gimbal_reduction.solver.dynamics.kernels import FAST, JIT, extension

# Thin wrappers (a few allocations around one or three calls) are inlined by Numba into their
# callers (inline="always", on Numba's IR): a compiled function of their own would put one level
# more into the call tree, and Numba optimises a callee's whole code again in every caller's
# module (docs/dynamics.md Section 8).  Their arithmetic stays in the functions they call, under
# those functions' flags.
from gimbal_reduction.solver.dynamics.kernels.linalg import (add, adinv, adinv_matrix, cr, inv6, mm6, mtv3, mv3,
                                            mv6, scale, sub)
from gimbal_reduction.solver.dynamics.kernels.modal import (add_inertia_rows, axpy, coriolis_pass,
                                           coriolis_rate_pass, dot, gram_blocks, hb_products,
                                           inertia_weights, linear_data, project_all,
                                           projections, rows_combine)


class Frames(NamedTuple):
    """What the passes compute for one state and the solve reuses, per joint / body:
    R (4, 3, 3), p (4, 3) the joint poses; Lw (4, 3, 3) the rotation part of each joint
    map L = [R^T Psi; Lw Theta] of the parent's modes; W, DW (4, 6) the body twists and
    their rates; Mx (4, 6, 6) M_X(q) per body; HB (3, S) = H + sum_j q_j G_j, the angular
    rows of B(q)."""
    R: np.ndarray
    p: np.ndarray
    Lw: np.ndarray
    W: np.ndarray
    DW: np.ndarray
    Mx: np.ndarray
    HB: np.ndarray


@numba.njit(**JIT)
def new_frames(S):
    """Frames for S modal coordinates, the small arrays in one allocation (HB zero)."""
    small = np.empty(276)
    return Frames(small[0:36].reshape((4, 3, 3)), small[36:48].reshape((4, 3)),
                  small[48:84].reshape((4, 3, 3)), small[84:108].reshape((4, 6)),
                  small[108:132].reshape((4, 6)), small[132:276].reshape((4, 6, 6)),
                  np.zeros((3, S)))


# ------------------------------------------------------------------ kinematics
@numba.njit(**FAST)
def joint(j, g, has_acc, wp, dwp, pq, pqd, pqdd, ch, fr, scratch):
    """Joint j (0: case -> body 2) of the forward pass, in place: its pose (R, p) =
    (fr.R[j], fr.p[j]), the rotation part Lw = fr.Lw[j] of the joint map L = [R^T Psi;
    Lw Theta] of the parent's modes, and the child's twist w = fr.W[j] and its rate
    dw = fr.DW[j] (6,) from the parent's wp, dwp.  g = (angle, rate, acceleration) of the
    joint; scratch (12,).

    The joint rotates by gam about its fixed axis frame Cj (ch.C1 for joint 0, else ch.C):
    R = E Cj Rx(gam), where E is the parent's elastic rotation at the output bearings
    (x-y-z angles th = Theta q) and the joint sits at the elastic translation p = Psi q
    (pq, pqd, pqdd (12,): the parent's rows V q, V q', V q''; used only if the parent is
    elastic).  Otherwise p = base_p (ch.rho for joint 0, else 0) and E = I."""
    gam, gd, gdd = g
    elastic = j > 0 and ch.D[j - 1] > 0
    Cj = ch.C1 if j == 0 else ch.C
    CR = scratch[0:9].reshape((3, 3))
    base_p = ch.rho if j == 0 else scratch[9:12]
    R, p, Lw, w, dw = fr.R[j], fr.p[j], fr.Lw[j], fr.W[j], fr.DW[j]
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
        e1 = sub(scale(c0, a1), scale(s0, a2))
        e2 = add(scale(s0, a1), scale(c0, a2))
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
        t1 = scale(thd[0], cx)
        t2 = scale(thd[1], cy)
        t3 = (0.0, 0.0, thd[2])
        omE = add(add(t1, t2), t3)
        domE = add(cr(t1, add(t2, t3)), cr(t2, t3))    # Te' th'
        xv = mtv3(R, pd)
        t = mtv3(CR, omE)
        xw = (t[0] + gd, t[1], t[2])
        bv = scale(-1.0, cr(xw, xv))
        u = mtv3(CR, domE)                   # - (gd ex) x xw + (Cj Rx)^T domE
        bw = (u[0], u[1] + gd * xw[2], u[2] - gd * xw[1])
    pp = (p[0], p[1], p[2])
    # w = Ad^-1 wp + xi;  dw = Ad^-1 dwp + [w, xi] + bias (+ gdd ex + L q''_parent)
    wpw = (wp[3], wp[4], wp[5])
    wv = add(mtv3(R, add((wp[0], wp[1], wp[2]), cr(wpw, pp))), xv)
    ww = add(mtv3(R, wpw), xw)
    dpw = (dwp[3], dwp[4], dwp[5])
    dv = mtv3(R, add((dwp[0], dwp[1], dwp[2]), cr(dpw, pp)))
    dv = add(add(dv, bv), sub(cr(ww, xv), cr(xw, wv)))
    dww = add(add(mtv3(R, dpw), bw), cr(ww, xw))
    if elastic and has_acc:
        dv = add(dv, mtv3(R, (pqdd[6], pqdd[7], pqdd[8])))
        dww = add(dww, mv3(Lw, (pqdd[9], pqdd[10], pqdd[11])))
    for i in range(3):
        w[i] = wv[i]
        w[3 + i] = ww[i]
        dw[i] = dv[i]
        dw[3 + i] = dww[i]
    dw[3] += gdd


@numba.njit(**FAST)
def forward(y, yd, ydd, has_acc, w1, dw1, ch, Pq, Pqd, Pqdd, fr):
    """Forward pass over the four joints, in place: fr.R (4,3,3), fr.p (4,3), fr.Lw
    (4,3,3), body twists fr.W (4,6) and their rates fr.DW (4,6) at accelerations ydd, from
    the bodies' projected modal rows Pq, Pqd (4, 27) and Pqdd (4, 12) (``modal.project``)."""
    small = np.zeros(12)                      # scratch of ``joint``
    W, DW = fr.W, fr.DW
    for j in range(4):
        k = j - 1
        kk = k if j > 0 else 0
        wp = w1 if j == 0 else W[k]
        dwp = dw1 if j == 0 else DW[k]
        joint(j, (y[j], yd[j], ydd[j] if has_acc else 0.0), has_acc, wp, dwp,
              Pq[kk], Pqd[kk], Pqdd[kk], ch, fr, small)


@numba.njit(**JIT, inline="always")
def kinematics(y, yd, ydd, w1, dw1, ch, fr):
    """Forward pass, in place: joint poses fr.R (4,3,3), fr.p (4,3), the rotation part
    fr.Lw (4,3,3) of each joint map L = [R^T Psi; Lw Theta] of the parent's modes,
    body twists fr.W (4,6) and their rates fr.DW (4,6) at accelerations ydd."""
    Pq, Pqd, Pqdd = projections(y, yd, ydd, bool(True), ch)
    forward(y, yd, ydd, bool(True), w1, dw1, ch, Pq, Pqd, Pqdd, fr)


# ------------------------------------------------------------------ inverse dynamics
@numba.njit(**FAST)
def backward(y, yd, ydd, has_acc, ch, fr, Pqdd, out, LIN, hq_given, LIND):
    """Backward (Newton-Euler) pass, in place: out (n,) = M(y) ydd + c(y, y', t), fr.Mx
    (4,6,6) = M_X(q) per body, fr.HB (3, S) = H + sum_j q_j G_j; returns F0 (6,), the
    composite wrench on body 2.  LIN = [HQ; Pq], LIND = [HQD; Pqd] (``inverse_dynamics_into``):
    HQ, HQD (3S,) every body's hq = sum_j q_j G_j and hqd = sum_j q'_j G_j (body k at
    3 off[k], layout a D_k + i); HQ is taken as given if hq_given (else computed and
    stored), HQD is always stored; Pq, Pqd (4, 27) and Pqdd (4, 12) the projected rows."""
    D, off, M6, V, M1, G, om2, cd = ch.D, ch.off, ch.M6, ch.V, ch.M1, ch.G, ch.om2, ch.cd
    R_all, p_all, Lw_all, W, DW, Mx_all, HB = fr
    S3 = LIN.shape[0] - 108
    HQ = LIN[:S3]
    HQD = LIND[:S3]
    Pq = LIN[S3:].reshape((4, 27))
    Pqd = LIND[S3:].reshape((4, 27))
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
            add_inertia_rows(Mx, Pq[k, 12:27])
            add_inertia_rows(dMx, Pqd[k, 12:27])
            b3 = 3 * o
            if hq_given:
                hqd, gq = coriolis_rate_pass(G[k], qdk, om)
            else:
                hq_new, hqd, gq = coriolis_pass(G[k], qk, qdk, om)
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
        t1 = cr(om, (mu[0], mu[1], mu[2]))
        t2 = add(cr(om, (mu[3], mu[4], mu[5])), cr((w[0], w[1], w[2]), (mu[0], mu[1], mu[2])))
        for a in range(3):
            F[a] = dmu[a] + t1[a]
            F[3 + a] = dmu[3 + a] + t2[a]
        if k < 3:
            Rc = R_all[k + 1]
            f = mv3(Rc, (Fc[0], Fc[1], Fc[2]))
            m = add(cr(p_all[k + 1], f), mv3(Rc, (Fc[3], Fc[4], Fc[5])))
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
                f = mv3(R_all[k + 1], (Fc[0], Fc[1], Fc[2]))
                m = mtv3(Lw_all[k + 1], (Fc[3], Fc[4], Fc[5]))
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
                axpy(1.0, ydd[s:s + Dk], Q)
            rows_combine(V, o, Dk, cv, nrows, Q)
            inertia_weights(w, ww)
            for c in range(15):
                ww[c] = -ww[c]
            rows_combine(M1, o, Dk, ww, int(15), Q)
            h0, h1, h2 = hq[0:Dk], hq[Dk:2 * Dk], hq[2 * Dk:3 * Dk]
            e0, e1, e2 = hqd[0:Dk], hqd[Dk:2 * Dk], hqd[2 * Dk:3 * Dk]
            for i in range(Dk):
                Q[i] += (dw[3] * h0[i] + dw[4] * h1[i] + dw[5] * h2[i]
                         + om[0] * e0[i] + om[1] * e1[i] + om[2] * e2[i])
        out[k] = F[3]
        for a in range(6):
            Fc[a] = F[a]
    return Fc


@numba.njit(**FAST, inline="always")
def inverse_dynamics_into(y, yd, ydd, has_acc, w1, dw1, ch, out, fr, LIN, lin_given, LIND):
    """out (n,) = M(y) ydd + c(y, y', t) (ydd taken as 0 if not has_acc), and the data the
    solve reuses (the Frames fr), in place; returns F0 (6,), the composite wrench on body 2.

    LIN (3S + 108,) holds what is linear in q: [hq (3S); Pq (4, 27) row by row], every
    body's sum_j q_j G_j and projected rows [V; M1] q; it is taken as given if lin_given
    (``rk4.rk4_core`` carries it from stage to stage), else computed and stored.  LIND
    gets the same of q': [hqd; Pqd]."""
    S3 = LIN.shape[0] - 108
    Pq = LIN[S3:].reshape((4, 27))
    Pqd = LIND[S3:].reshape((4, 27))
    Pqdd = np.zeros((4, 12))
    project_all(y, yd, ydd, has_acc, ch, lin_given, Pq, Pqd, Pqdd)
    forward(y, yd, ydd, has_acc, w1, dw1, ch, Pq, Pqd, Pqdd, fr)
    return backward(y, yd, ydd, has_acc, ch, fr, Pqdd, out, LIN, lin_given, LIND)


@numba.njit(**JIT, inline="always")
def inverse_dynamics(y, yd, ydd, w1, dw1, ch):
    """(out, fr, F0): out (n,) = M(y) ydd + c(y, y', t) by the recursive Newton-Euler
    passes, the Frames fr the solve reuses (joint data, M_X(q) per body, HB (3, S) =
    H + sum_j q_j G_j, the angular rows of B(q)) and F0, the composite wrench on body 2."""
    S = ch.V.shape[1]
    out = np.zeros(4 + S)
    fr = new_frames(S)
    F0 = inverse_dynamics_into(y, yd, ydd, bool(True), w1, dw1, ch, out, fr,
                               np.zeros(3 * S + 108), bool(False), np.zeros(3 * S + 108))
    return out, fr, F0


# ------------------------------------------------------------------ articulated-body solve
@numba.njit(**FAST)
def solve(r, dg, unit, ch, fr):
    """x with (M + diag(0, dg - 1)) x = r: the articulated-body recursion of
    multibody.solve_mass (docs/dynamics.md, Section 3), at the state whose passes
    filled the Frames fr (``inverse_dynamics_into``).

    A body's modes enter only through its modal rows B = [P; H + hq] (6, D) and
    Y = [Psi; Theta] (6, D): the joint map of its child is L = Lam Y with
    Lam = diag(R^T, Lw) (6, 6), and K = B + Ad^-T Itil L = B + Mk Y.  So every
    product over the modes that the Woodbury elimination needs (K N^-1 K^T,
    K N^-1 L^T, L N^-1 L^T, K N^-1 r, ...) is a 6x6 expression in the Gram blocks
    BB, BY, YY of gram_blocks and the projections B r/dg, Y r/dg: per body
    three kinds of passes over the modes remain (Gram rows of H + hq, projections,
    back-substitution), everything else is 6x6 algebra in scratch arrays."""
    D, off, V, gram = ch.D, ch.off, ch.V, ch.gram
    R_all, p_all, Lw_all, Mx_all, HB = fr.R, fr.p, fr.Lw, fr.Mx, fr.HB
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
            adinv_matrix(R_all[k + 1], p_all[k + 1], A)
            mm6(A.T, Itil, AtI)
            mm6(AtI, A, T2)
            mv6(A.T, pa, t6)
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
            mm6(AtI, Lm, Mk[k])
        if Dk > 0:
            gram_blocks(V, HB, o, Dk, dinv, gram[k], unit, BB[k], BY[k], YY[k])
            s = 4 + o
            if unit:
                hb_products(V, HB, o, Dk, r[s:s + Dk], prod)
            else:
                hb_products(V, HB, o, Dk, r[s:s + Dk] * dinv[o:o + Dk], prod)
            for a in range(6):
                Br[k, a] = prod[a]
                Yr[k, a] = prod[6 + a]
            if child:
                M = Mk[k]
                Lm = Lam[k]
                Itil = Itils[k]
                mv6(Lm.T, pa_all[k], yh)                 # L^T pa = Y^T yh
                # KNr = B zd + M Y zd, zd = (r_q - L^T pa)/dg
                mv6(BY[k], yh, t6)
                for a in range(6):
                    KNr[a] = Br[k, a] - t6[a]
                mv6(YY[k], yh, t6)
                for a in range(6):
                    t6[a] = Yr[k, a] - t6[a]             # Y zd
                mv6(Lm, t6, Lz)
                mv6(M, t6, yh)
                for a in range(6):
                    KNr[a] += yh[a]
                # KNK = BB + M BY^T + BY M^T + M YY M^T
                mm6(M, BY[k].T, T2)
                mm6(M, YY[k], T3)
                mm6(T3, M.T, KNK)
                for a in range(6):
                    for b in range(6):
                        KNK[a, b] += BB[k, a, b] + T2[a, b] + T2[b, a]
                        T3[a, b] += BY[k, a, b]          # BY + M YY
                mm6(T3, Lm.T, KdL)                       # K N^-1 L^T
                mm6(Lm, YY[k], T6)
                mm6(T6, Lm.T, T7)                        # L N^-1 L^T
                mm6(T7, Itil, T6)                       # Z = I + L N^-1 L^T Itil
                for a in range(6):
                    T6[a, a] += 1.0
                inv6(T6, Zinvs[k], T7)
                mm6(KdL, Itil, T2)
                mm6(T2, Zinvs[k], T3)                   # KIZ
                mm6(T3, KdL.T, T2)
                mv6(T3, Lz, t6)
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
            rows_combine(V, o, Dk, t6, int(3), z)
            rows_combine(HB, o, Dk, t6[3:6], int(3), z)
            if child:
                Lm = Lam[k]
                mv6(Lm.T, pa_all[k], eY)
                mv6(Mk[k].T, acc, t6)
                for a in range(6):
                    eY[a] += t6[a]
                mv6(BY[k].T, acc, yh)
                mv6(YY[k], eY, t6)
                for a in range(6):
                    t6[a] = Yr[k, a] - yh[a] - t6[a]     # Y z0
                mv6(Lm, t6, KNr)
                mv6(Zinvs[k], KNr, t6)
                mv6(Itils[k], t6, KNr)                  # corr
                mv6(Lm.T, KNr, t6)
                for a in range(6):
                    eY[a] += t6[a]
                for a in range(6):
                    t6[a] = -eY[a]
                rows_combine(V[6:12], o, Dk, t6, int(6), z)
                mv6(YY[k], eY, t6)
                for a in range(6):
                    t6[a] = Yr[k, a] - yh[a] - t6[a]     # Y z
                mv6(Lm, t6, Lz)                         # L z = Lam Y z
            if not unit:
                for i in range(Dk):
                    z[i] *= dinv[o + i]
        if child:
            a_base = adinv(R_all[k + 1], p_all[k + 1], acc)
            for a in range(6):
                a_base[a] += Lz[a]
    return x


@numba.njit(**FAST, inline="always")
def accelerations_lin(y, yd, w1, dw1, tau, LIN, lin_given, LIND, ch):
    """y'' = M(y)^-1 (tau - c(y, y', t)), with what is linear in q taken from LIN
    (3S + 108,) if lin_given (else computed into it) and the same of q' stored in LIND
    (``inverse_dynamics_into``)."""
    n = y.shape[0]
    S = n - 4
    c = np.zeros(n)
    fr = new_frames(S)
    inverse_dynamics_into(y, yd, y, bool(False), w1, dw1, ch, c, fr, LIN, lin_given, LIND)
    for i in range(n):
        c[i] = -c[i]
    for j in range(4):
        c[j] += tau[j]
    return solve(c, c, bool(True), ch, fr)


@numba.njit(**FAST, inline="always")
def accelerations(y, yd, w1, dw1, tau, ch):
    """y'' = M(y)^-1 (tau - c(y, y', t))."""
    S = y.shape[0] - 4
    return accelerations_lin(y, yd, w1, dw1, tau, np.zeros(3 * S + 108), bool(False),
                             np.zeros(3 * S + 108), ch)


@numba.njit(**JIT)
def kinetic_energy_lin(y, yd, w1, LIN, Pqd, ch):
    """T = sum_n 1/2 w^T M_X(q) w + w^T B(q) q' + 1/2 q'^T q' (multibody.kinetic_energy),
    with LIN = [hq; Pq] (``inverse_dynamics_into``) and Pqd (4, 27) = [V; M1] q' given."""
    D, off, M6 = ch.D, ch.off, ch.M6
    S3 = LIN.shape[0] - 108
    Pq = LIN[S3:].reshape((4, 27))
    fr = new_frames(int(0))                   # (twists only; no HB needed)
    forward(y, yd, y, bool(False), w1, np.zeros(6), ch, Pq, Pqd, np.zeros((4, 12)), fr)
    W = fr.W
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
            add_inertia_rows(Mx, Pq[k, 12:27])
            Bqd = Pqd[k, 0:6].copy()                   # B(q) q' = [P; H + hq] q'
            for a in range(3):
                b0 = 3 * o + a * Dk
                Bqd[3 + a] += dot(LIN[b0:b0 + Dk], qdk)
            for i in range(Dk):
                T += 0.5 * qdk[i] * qdk[i]
            for a in range(6):
                T += w[a] * Bqd[a]
        for a in range(6):
            for b in range(6):
                T += 0.5 * w[a] * Mx[a, b] * w[b]
    return T


@numba.njit(**JIT, inline="always")
def kinetic_energy(y, yd, w1, ch):
    """T = sum_n 1/2 w^T M_X(q) w + w^T B(q) q' + 1/2 q'^T q' (multibody.kinetic_energy)."""
    LIN, Pqd = linear_data(y, yd, ch)
    return kinetic_energy_lin(y, yd, w1, LIN, Pqd, ch)


@numba.njit(**JIT)
def case_power_lin(y, yd, ydd, w1, dw1, LIN, ch):
    """Power the case motion feeds into bodies 2-5, (Ad_{g1^-1} w1) . F0, with F0 the composite
    wrench on body 2, at accelerations ydd, with LIN = [hq; Pq] of the state given."""
    n = y.shape[0]
    S = n - 4
    out = np.zeros(n)
    fr = new_frames(S)
    F0 = inverse_dynamics_into(y, yd, ydd, bool(True), w1, dw1, ch, out, fr, LIN, bool(True),
                               np.zeros(3 * S + 108))
    return np.dot(adinv(fr.R[0], fr.p[0], w1), F0)


@numba.njit(**JIT)
def case_twist(t, case, w1, dw1):
    """Case twist [0; omega(t)] and its rate, in place (multibody.CaseMotion.twist);
    case = (amplitude, 2 pi frequency, phase, omega0) (3,) each (``compiled.case_arrays``)."""
    amp, omf, phase, om0 = case
    for k in range(3):
        arg = omf[k] * t + phase[k]
        dw1[3 + k] = amp[k] * math.cos(arg)
        if omf[k] > 0.0:
            integ = (math.sin(arg) - math.sin(phase[k])) / omf[k]
        else:
            integ = math.cos(phase[k]) * t
        w1[3 + k] = om0[k] + amp[k] * integ


# this module's entries compiled ahead of time, when built and current (kernels.extension)
extension.attach(__name__)
