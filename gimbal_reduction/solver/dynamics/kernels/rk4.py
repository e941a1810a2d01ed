"""The compiled RK4 loop: steps without a Python call per stage, and a whole run with the
energy watch (docs/dynamics.md Section 8); steps without outputs are the whole run over one
output interval (``compiled.CompiledRhs.rk4_steps``).

Both are inlined on Numba's IR (``inline="always"``) into the entry that calls them from Python
(``compiled._rk4_integrate``): compiled functions of their own, each level's code
was optimised and generated again by LLVM in the level above, three times in all.  Measured
(cold cache, the warm-up's compilation, one profiled run each): the three levels 11.3 CPU-s,
inlined 6.1 and 6.5; the same run time (a 20-modes-per-body synthetic chain on the thesis
scene, median of 5 in each of 3 alternating processes: 2.70 s against 2.72 s)."""

import math

import numba
import numpy as np

from gimbal_reduction.solver.dynamics.kernels import JIT, extension
from gimbal_reduction.solver.dynamics.kernels.modal import dot
from gimbal_reduction.solver.dynamics.kernels.recursion import (accelerations_lin, case_power_lin, case_twist,
                                               kinetic_energy_lin)


@numba.njit(**JIT, inline="always")
def rk4_core(y, yd, t0, h, n_steps, K0, LIN0, LIND0, case, tau, ch):
    """n_steps classical RK4 steps of (y, y')' = (y', y'') from t0 with constant torques
    tau (4,) and the case motion ``case`` (``recursion.case_twist``) (integrators.rk4_step,
    compiled: no Python call per stage).  The first stage's evaluation is given: the
    accelerations K0 (n,), LIN0 and LIND0 at (t0, y, y').

    What an evaluation needs that is linear in q, LIN = [hq; Pq] (the modal Coriolis
    sums hq = sum_j q_j G_j and the projected rows Pq = [V; M1] q, see
    ``recursion.inverse_dynamics_into``), is carried from stage to stage instead of recomputed:
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
            if i == 0 and st == 0:
                K[0, :] = K0
                LIN[:] = LIN0
                LINDS[0, :] = LIND0
                continue
            if st != 2:
                case_twist(t + c, case, w1, dw1)
            K[st, :] = accelerations_lin(ys, Vs[st], w1, dw1, tau, LINS[st],
                                         st > 0 or i > 0, LINDS[st], ch)
        for m in range(n):
            y[m] += (h / 6.0) * (Vs[0, m] + 2.0 * Vs[1, m] + 2.0 * Vs[2, m] + Vs[3, m])
            yd[m] += (h / 6.0) * (K[0, m] + 2.0 * K[1, m] + 2.0 * K[2, m] + K[3, m])
        for m in range(L):
            LIN[m] += (h / 6.0) * (LINDS[0, m] + 2.0 * LINDS[1, m] + 2.0 * LINDS[2, m] + LINDS[3, m])
    return y, yd


@numba.njit(**JIT, inline="always")
def rk4_integrate(y0, yd0, t_out, h, n_sub, growth, at_rest, case, tau, ch):
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
    om2, cd = ch.om2, ch.cd
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
        if not math.isfinite(dot(y, y) + dot(yd, yd)):
            info[0], info[1] = 1.0, k
            return Y, Yd, energy, info
        Y[k, :] = y
        Yd[k, :] = yd
        case_twist(t, case, w1, dw1)
        acc = accelerations_lin(y, yd, w1, dw1, tau, LIN, bool(False), LIND, ch)
        T = kinetic_energy_lin(y, yd, w1, LIN, LIND[3 * S:].reshape((4, 27)), ch)
        U = 0.0
        P = 0.0
        for j in range(4):
            P += tau[j] * yd[j]
        for i in range(S):
            U += 0.5 * om2[i] * y[4 + i] * y[4 + i]
            P -= cd[i] * yd[4 + i] * yd[4 + i]
        if not at_rest:
            P += case_power_lin(y, yd, acc, w1, dw1, LIN, ch)
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
            y, yd = rk4_core(y, yd, t, h, n_sub, acc, LIN, LIND, case, tau, ch)
    return Y, Yd, energy, info


# this module's entries compiled ahead of time, when built and current (kernels.extension)
extension.attach(__name__)
