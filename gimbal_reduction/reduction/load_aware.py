"""Load-aware mode selection: rank the modes by what the scene's loads make them do.

    python -m gimbal_reduction.reduction.load_aware --scene thesis --bodies results/modes/body{2,3,4,5}.h5 \\
        --reductions results/reduction/body{2,3,4,5}.h5 --out results/reduction/load/thesis.h5

The thesis closes with "it is advantageous to take into account the given
conditions applied to the system when reducing the model" and proposes (Section
5.1) to rank the modes of all bodies in one pool.  This module does both.  The
method, its maths and the measured results are in ``docs/selection.md``; in short:

1. **Loads of the scene on every mode** (``rigid_run``, ``modal_loads``).  The
   rigid chain (no modes) is integrated through the scene.  Along that motion
   the elastic chain's modal equations, at q = 0, are driven by

       Gamma_i(t) = -[P; H]_i^T dw_n/dt  +  1/2 w_n^T M_1,i w_n  -  L_i^T F_child(t)

   the inertial load of the body's frame acceleration (momentum coefficients
   P, H), the centrifugal load, and the bearing load: the wrench F_child that
   the inner subtree needs, applied through the inside-frame motion of the
   mode (L_i = [R^T Psi_i; R_j^T Theta_i], from the bearings' rigid-fit data).
   That is minus the modal rows of the inverse dynamics at q = 0.

2. **Frozen linear chain** (``linear_model``).  Over the scene the gimbal angles
   change little (thesis scene: < 2e-4 rad) and the rates are ~1e-2 rad/s
   against modal frequencies above 1e4 rad/s, so the deviation d = y - y_rigid
   obeys  M(y0) d'' + K d = [0; Gamma(t)],  d(0) = d'(0) = 0  with
   K = diag(0_4, Omega^2).  M(y0) holds the whole joint coupling: the modes'
   momentum about the drive axes (P, H) and the inner bodies' inertia carried
   by the inside-frame motion (Psi, Theta), which on the real bodies makes the
   modal mass matrix far from diagonal (entries up to 93).

3. **A-priori error of any kept set** (``estimate_error``).  The kept set's
   pencil (K_S, M_S) is solved exactly, every coupled mode's velocity response
   to its load is integrated in closed form (``velocity_response``), and
   eq. 3.53 (``gimbal_reduction.solver.dynamics.error_measure.error_measure``) compares the rates
   gamma_dot_rigid + d_S with the full set's gamma_dot_rigid + d_full.  No
   nonlinear simulation is involved; one evaluation costs 1-20 ms.  The rankings
   make ~7000 of them per scene, by ``frozen_chain.FrozenChainEstimator``: the
   same numbers from what the kept sets share (the whole chain's Schur
   complement, the loads' few time functions), a round's trials and a curve's
   counts as deletions from one eigendecomposition
   (``gimbal_reduction.reduction.submatrix_eig``): 0.1-0.5 ms each.

4. **Scores and rankings.**  ``participation_scores``: the share of eq. 3.53 that
   each coupled mode k of the full chain carries in rate n (e_nk), handed to
   the body modes by their strain-energy share in it,
   eps_ik = Omega_i^2 V_ik^2 / lambda_k: s_ni = sum_k e_nk eps_ik.  A mode that no
   load reaches has s = 0 ("not excited").  The pooled ranking
   (``pooled_ranking``) is the backward elimination of the a-priori error: from
   a pool of the best-scored modes of all four bodies, repeatedly drop the
   mode whose removal raises max_n E_n least.  Everything is in the same unit
   (E of the gimbal rates), so modes of different bodies compare directly.
   Each body's ``rank_load`` is the pooled order restricted to that body.

Pure functions on numpy arrays; file reading and writing only in the CLI.
Units: in, lbf, s, rad; mass lbf s^2/in.
"""

import argparse
import hashlib
import json
import math
import sys
import time

import h5py
import numpy as np
from scipy.integrate import solve_ivp

from gimbal_reduction.reduction import models
from gimbal_reduction.reduction.frozen_chain import (CURVE_SAMPLES, FROZEN_ANGLE, FROZEN_RATE, N_JOINTS,
                                    FrozenChainEstimator, LoadAwareError, check_model, coupled_modes,
                                    decimated, estimate_error, modal_rates, rate_response)
from gimbal_reduction.solver import bodyconfig
from gimbal_reduction.solver.bodydata import BODIES
from gimbal_reduction.solver.dynamics import compiled, linearized, multibody, scenes, simulate
from gimbal_reduction.workflow import cli
from gimbal_reduction.workflow.progress import Progress
from gimbal_reduction.workflow.provenance import atomic_h5, versions
FORMAT_VERSION = 1
DEFAULT_POOL = 160          # pooled modes ranked by backward elimination (40 per body on average)
GREEDY_STEPS = 0            # forward-selection steps that seed the pooled ranking (0: none; see docs)
N_CURVE = 40                # a-priori estimates for N = 1..40 modes per body
EXCITED_RTOL = 1e-12        # a mode carrying less than this share of the scores is "not excited"
TIE_RTOL = 1e-6             # removals changing the a-priori J by less are ties (decided by score)


# ----------------------------------------------------------------- scene loads
def rigid_run(rigid_chain, scene, rtol=1e-12, atol=1e-14):
    """The rigid chain (no modes) through a scene: dict t (T,), y, yd, ydd (T, 4).

    DOP853 at rtol 1e-12 in one solve over the whole scene, read at the output samples by its
    dense output (the method's own interpolant, of the order of its steps): 4 coordinates, 0.7 s
    on the 40,001 samples of ``long``; restarted at every sample it took 29 s there for the same
    motion (rates within 4.3e-13, angles within 7e-14 rad, accelerations within 3.6e-14 of their
    largest; thesis, spin, long).  It agrees with ``integrators``' DOP853, the references' route
    (``test_rigid_run_matches_the_integrators_dop853``).  Accelerations from the equations of
    motion at the output samples."""
    if sum(rigid_chain.n_modes):
        raise LoadAwareError(f"rigid_run needs a chain without modes, got {rigid_chain.n_modes}")
    prob = simulate.scene_problem(rigid_chain, scene)
    n_out = max(int(round(scene.duration / scene.output_interval)), 1)
    t = np.linspace(0.0, scene.duration, n_out + 1)

    def f(tk, z):
        return np.concatenate([z[N_JOINTS:], prob.rhs(tk, z[:N_JOINTS], z[N_JOINTS:])])
    sol = solve_ivp(f, (0.0, scene.duration), np.concatenate([prob.y0, prob.yd0]), method="DOP853",
                    rtol=rtol, atol=np.full(2 * N_JOINTS, atol), t_eval=t)
    if not sol.success:
        raise LoadAwareError(f"rigid_run: DOP853 failed on scene {scene.name!r}: {sol.message}")
    y, yd = np.ascontiguousarray(sol.y[:N_JOINTS].T), np.ascontiguousarray(sol.y[N_JOINTS:].T)
    ydd = np.array([prob.rhs(tk, a, b) for tk, a, b in zip(t, y, yd)])
    return {"t": t, "y": y, "yd": yd, "ydd": ydd}


def modal_loads(chain, t, y, yd, ydd, case, progress=None):
    """Gamma (T, sum D): the load of the scene on every mode along a rigid motion.

    chain: the elastic chain (all modes to be ranked); t (T,) [s]; y, yd, ydd
    (T, 4): gimbal angles, rates, accelerations of the rigid run.  With the
    elastic coordinates at rest (q = q' = q'' = 0) the modal rows of the
    inverse dynamics (``gimbal_reduction.solver.dynamics.multibody.inverse_dynamics``) are, per body n and
    mode i (docs/dynamics.md, Section 3),

        ID_q,i = [P; H]_i^T dw_n/dt - 1/2 w_n^T M_1,i w_n + L_i^T F_child,

    so Gamma = -ID_q is the generalised force that the rigid motion leaves on the
    modes: inertial (frame acceleration through P, H), centrifugal (M_1,i), and
    the bearing wrench F_child of the inner subtree through the inside-frame
    motion L_i (Psi, Theta).  Unit: lbf / sqrt(lbf s^2/in) = sqrt(mass) in/s^2,
    the generalised force of a mass-normalised modal coordinate.  progress: a
    ``gimbal_reduction.workflow.progress.Progress`` advanced by one per sample (optional).

    The inverse dynamics is the compiled one (``gimbal_reduction.solver.dynamics.compiled.FastChain``, the case
    twist of ``case`` at each sample): the same numbers as ``multibody.inverse_dynamics`` to
    rounding (9e-16 of the largest load on the thesis scene), ~10 ms instead of ~2 s per 1000
    samples at 400 modes."""
    t = np.asarray(t, float)
    y, yd, ydd = (np.asarray(a, float) for a in (y, yd, ydd))
    if y.shape != (t.size, N_JOINTS) or yd.shape != y.shape or ydd.shape != y.shape:
        raise LoadAwareError(f"rigid motion must be (T, 4) arrays for T = {t.size} samples, got "
                             f"{y.shape}, {yd.shape}, {ydd.shape}")
    n = chain.n_coordinates
    fast = compiled.FastChain(chain)
    case = multibody.CaseMotion() if case is None else case
    out = np.zeros((t.size, n - N_JOINTS))
    Y, V, A = np.zeros(n), np.zeros(n), np.zeros(n)
    for k in range(t.size):
        Y[:N_JOINTS], V[:N_JOINTS], A[:N_JOINTS] = y[k], yd[k], ydd[k]
        w1, dw1 = case.twist(t[k])
        out[k] = -fast.inverse_dynamics(Y, V, A, w1, dw1)[N_JOINTS:]
        if progress is not None:
            progress.advance()
    return out


def linear_model(chain, y0, t, gamma_rigid, loads):
    """The frozen linear chain of a scene, as a dict of arrays (the a-priori estimator).

    M (n, n) = M(y0) of the elastic chain, K (n,) = [0_4, Omega^2], t (T,) [s],
    rigid_rates (T, 4) [rad/s] (gamma_dot of the rigid run), loads (T, n - 4)
    (``modal_loads``), offsets (5,): body b's modes are columns offsets[k]:offsets[k+1]
    of loads (k = b - 2), and the full set's response ``full`` (T, 4) [rad/s]."""
    M = linearized.mass_matrix_fast(chain, np.asarray(y0, float))
    K = chain.stiffness_diagonal()
    model = {"M": M, "K": K, "t": np.asarray(t, float),
             "rigid_rates": np.asarray(gamma_rigid, float), "loads": np.asarray(loads, float),
             "offsets": np.concatenate([[0], np.cumsum(chain.n_modes)]).astype(int)}
    check_model(model)
    model["full"] = rate_response(model, np.arange(model["loads"].shape[1]))
    return model


def kept_from_counts(offsets, orders, counts):
    """Pooled indices (k,) of the first counts[b] modes of orders[b] of every body."""
    return np.concatenate([offsets[k] + np.asarray(orders[k], int)[:int(c)]
                           for k, c in enumerate(counts)]).astype(int)


# -------------------------------------------------------------------- scores
def participation_scores(model):
    """Share of the error that every mode would carry: dict of arrays.

    ``score`` (4, Q): s_ni = sum_k e_nk eps_ik, where, for the full frozen chain's
    coupled modes k (``coupled_modes``), e_nk = int (V_nk eta'_k)^2 dt / int r_n^2 dt
    is the part of eq. 3.53 that coupled mode k's response makes in rate n (r the
    reference rate), and eps_ik = Omega_i^2 V_ik^2 / omega_k^2 the strain-energy
    share of body mode i in coupled mode k (sum_i eps_ik = 1).  So s_ni is the share
    of rate n's elastic signal that mode i builds; sum_i s_ni ~ E_n of the rigid
    model (exact up to cross terms between coupled modes, which average out over
    the scene when their frequencies differ by more than 1/duration).  A mode that
    no load reaches and that is not coupled to one that is, has s = 0.
    ``rate_share`` (4, n): e_nk; ``omega`` (n,) [rad/s]; ``strain_share`` (Q, n)."""
    t, K, g0 = model["t"], model["K"], model["rigid_rates"]
    omega, V = coupled_modes(model["M"], K)
    g = model["loads"] @ V[N_JOINTS:]
    eta = modal_rates(omega, g, t)
    ref = np.trapezoid((g0 + model["full"]) ** 2, t, axis=0)               # (4,)
    e = V[:N_JOINTS] ** 2 * np.trapezoid(eta ** 2, t, axis=0)               # int (V_nk eta'_k)^2 dt
    e = e / np.where(ref > 0, ref, 1.0)[:, None]
    elastic = omega > 0
    eps = np.zeros((K.size - N_JOINTS, K.size))
    eps[:, elastic] = K[N_JOINTS:, None] * V[N_JOINTS:, elastic] ** 2 / omega[elastic] ** 2
    e[:, ~elastic] = 0.0
    return {"score": e @ eps.T, "rate_share": e, "omega": omega, "strain_share": eps}


def additive_estimate(score, keep):
    """Sum of the dropped modes' scores (4,): the additive a-priori estimate (it ignores
    the ringing that kept modes add at frequencies the full chain does not have)."""
    score = np.asarray(score, float)
    dropped = np.ones(score.shape[1], bool)
    dropped[np.asarray(keep, int)] = False
    return score[:, dropped].sum(axis=1)


def excited_modes(score, rtol=EXCITED_RTOL):
    """(Q,) bool: modes whose score (max over rates) exceeds rtol times the largest
    rate's total; the others the scene does not excite (dropped, ranked last)."""
    s = np.max(np.asarray(score, float), axis=0)
    total = float(np.max(np.sum(score, axis=1))) if s.size else 0.0
    return s > rtol * total if total > 0 else np.zeros(s.size, bool)


# ------------------------------------------------------------------ rankings
def _removals(trials, tie_rtol):
    """Candidate removals sorted best first.  trials: (cost, priority, member) tuples;
    costs within ``tie_rtol`` (relative) of the smallest count as equal to it, and
    equal costs go by priority (the lower priority is removed first)."""
    if not trials:
        return []
    c_min = min(c for c, _, _ in trials)
    tied = c_min + tie_rtol * abs(c_min)
    return sorted(trials, key=lambda x: (c_min if x[0] <= tied else x[0], x[1]))


def backward_elimination(evaluate, pool, protected=(), drop_fraction=0.0, priority=None,
                         tie_rtol=0.0, log=None, removals=None):
    """Nested ranking of ``pool`` by backward elimination of a cost.

    evaluate: callable(list of kept indices) -> float (smaller is better);
    pool: indices to rank; protected: indices never dropped (ranked first, in the
    given order).  Each round evaluates the removal of every unprotected member and
    drops the one whose removal gives the smallest cost -- or, with
    ``drop_fraction`` f > 0, the k = max(1, floor(f n)) cheapest removals at once (n
    kept; fewer rounds, a slightly coarser order).  Costs within ``tie_rtol`` of
    the smallest are ties, resolved by ``priority`` (dict member -> number, the
    lower removed first; default: the later member of the pool first).
    removals: optional callable(kept list, members list) -> their costs, the cost of the kept
    set without each member in turn (what ``evaluate`` would give, in one call: a round's
    trials share work).
    Returns (order, cost): order (len(pool),) most important first (the last
    dropped first), cost (len(pool) + 1,) with cost[N] the cost of order[:N]
    (NaN for sizes a multi-drop round skipped)."""
    pool = [int(i) for i in pool]
    protected = [int(i) for i in protected]
    if len(set(pool)) != len(pool) or not set(protected) <= set(pool):
        raise LoadAwareError("backward elimination: pool must be distinct and hold the protected set")
    if not 0.0 <= drop_fraction < 1.0:
        raise LoadAwareError(f"backward elimination: drop_fraction must lie in [0, 1), got {drop_fraction}")
    keep_set = set(protected)
    current = list(pool)
    cost = np.full(len(pool) + 1, np.nan)
    cost[len(current)] = float(evaluate(current))
    dropped = []
    while len(current) > len(protected):
        cands = [pos for pos in range(len(current) - 1, -1, -1) if current[pos] not in keep_set]
        costs = ([evaluate(current[:pos] + current[pos + 1:]) for pos in cands] if removals is None
                 else removals(current, [current[pos] for pos in cands]))
        trials = [(float(c), -pos if priority is None else (priority[current[pos]], -pos), current[pos])
                  for c, pos in zip(costs, cands)]
        trials = _removals(trials, tie_rtol)
        k = max(1, int(drop_fraction * len(current)))
        chosen = [m for _, _, m in trials[:k]]
        current = [i for i in current if i not in set(chosen)]
        dropped.extend(chosen)
        cost[len(current)] = trials[0][0] if k == 1 else float(evaluate(current))
        if log and (len(current) // 20) != ((len(current) + k) // 20):
            log(f"backward elimination: {len(current)} kept, cost {cost[len(current)]:.3e}")
    order = protected + dropped[::-1]
    return np.array(order, int), cost


def lockstep_elimination(evaluate, pools, priority=None, tie_rtol=0.0, log=None, removals=None):
    """Nested rankings of several groups kept at equal counts (the ``load-N`` models).

    evaluate: callable(list of kept indices) -> float; pools: one list of indices
    per group (body), all of the same length n.  Round by round (n -> n - 1 per
    group), each group in turn drops the member whose removal, with the other
    groups as they stand, gives the smallest cost (ties within ``tie_rtol`` by
    ``priority``, as in ``backward_elimination``; removals: as there).  Returns (orders,
    cost): orders a list of (n,) arrays, most important first; cost (n + 1,) with cost[N]
    the cost of keeping the first N of every group's order."""
    current = [[int(i) for i in p] for p in pools]
    n = len(current[0]) if current else 0
    if any(len(p) != n for p in current) or len({i for p in current for i in p}) != n * len(current):
        raise LoadAwareError("lockstep elimination: the pools must be distinct and of equal size")
    dropped = [[] for _ in current]
    cost = np.full(n + 1, np.nan)
    cost[n] = float(evaluate([i for p in current for i in p]))
    for size in range(n, 0, -1):
        for g in range(len(current)):
            others = [i for h, p in enumerate(current) if h != g for i in p]
            costs = ([evaluate(others + current[g][:k] + current[g][k + 1:])
                      for k in range(len(current[g]))] if removals is None
                     else removals(others + current[g], current[g]))
            trials = [(float(c), -k if priority is None else (priority[m], -k), m)
                      for k, (c, m) in enumerate(zip(costs, current[g]))]
            best = _removals(trials, tie_rtol)[0]
            current[g].remove(best[2])
            dropped[g].append(best[2])
        cost[size - 1] = best[0]
        if log and (size - 1) % 10 == 0:
            log(f"lockstep elimination: {size - 1} per body, cost {best[0]:.3e}")
    return [np.array(d[::-1], int) for d in dropped], cost


def forward_selection(evaluate, candidates, max_size, min_gain=0.005):
    """Greedy forward selection: from the empty set, add the candidate that gives the
    lowest cost, ``max_size`` times (also when no addition lowers the cost: a single
    mode may add ringing that a later one cancels), and keep the prefix with the
    lowest cost if it beats the empty set by more than ``min_gain`` (relative).
    Returns (prefix (k,) in order of selection, cost (max_size + 1,) of every prefix)."""
    candidates = [int(i) for i in candidates]
    selected = []
    cost = [float(evaluate([]))]
    for _ in range(min(int(max_size), len(candidates))):
        best = min((float(evaluate(selected + [m])), m) for m in candidates if m not in selected)
        selected.append(best[1])
        cost.append(best[0])
    cost = np.array(cost)
    k = int(np.argmin(cost))
    if cost[k] >= cost[0] * (1.0 - min_gain):
        k = 0
    return np.array(selected[:k], int), cost


# The search grid of the ranking: at most this many output samples (the thesis scene's 1501 / 3).
# A 1 s scene at 1e-4 s has 10001 samples: its search at stride 3 took minutes; the a-priori
# error on every 20th sample is its mean square over the same window (the rankings are checked
# by the simulations of the study, not trusted).
SEARCH_SAMPLES = 501




def search_stride(duration, output_interval, samples=SEARCH_SAMPLES):
    """The default search stride: >= 3, and at most ``samples`` search samples."""
    n = int(round(duration / output_interval)) + 1
    return max(3, int(math.ceil(n / samples)))


def pooled_ranking(model, score, pool_size=DEFAULT_POOL, drop_fraction=1 / 16, stride=3,
                   greedy_prefix=GREEDY_STEPS, log=None, estimate=estimate_error, removals=None):
    """Pooled load-aware ranking of every mode of every body.

    score (4, Q) from ``participation_scores``.  The cost is J = max_n E_n, the
    a-priori eq. 3.53 error (``estimate_error``) evaluated on every ``stride``-th
    output sample (within 0.5 % of the full grid on the real bodies).  First a
    forward selection (``greedy_prefix`` steps over the pool; 0 skips it) finds the
    small set with the lowest J (``forward_selection``); then the ``pool_size``
    best-scored excited modes (they include that prefix) are ordered by backward
    elimination with the prefix protected.  The other excited
    modes follow by score, the modes the scene does not excite come last.
    Returns (order (Q,) pooled indices most important first, info dict:
    ``prefix`` (k,), ``search_cost`` (pool + 1,) J on the search grid).  estimate: the
    a-priori error function (``rank_scene`` passes it counted, for its progress); removals:
    optional callable(model, keep, members) -> [estimate(model, keep without m) for m in
    members] (``frozen_chain.FrozenChainEstimator.removal_errors``), the elimination's trials."""
    s = np.max(np.asarray(score, float), axis=0)
    excited = excited_modes(score)
    by_score = np.lexsort((np.arange(s.size), -s))
    by_score = by_score[excited[by_score]]
    search = decimated(model, stride)

    def J(keep):
        return float(np.max(estimate(search, keep)))
    top = [int(i) for i in by_score[:max(0, min(int(pool_size), by_score.size))]]
    prefix = np.zeros(0, int)
    if greedy_prefix:
        prefix, fcost = forward_selection(J, top, greedy_prefix)
        if log:
            log(f"forward selection: prefix of {prefix.size} modes, J {fcost[0]:.3e} -> "
                f"{fcost[prefix.size]:.3e}")
    pool = list(prefix) + [i for i in top if i not in set(prefix.tolist())]
    order, cost = backward_elimination(J, pool, protected=prefix, drop_fraction=drop_fraction,
                                       priority={int(i): s[i] for i in pool}, tie_rtol=TIE_RTOL,
                                       log=log, removals=_max_removals(removals, search))
    ranked = set(order.tolist())
    rest = [i for i in by_score if i not in ranked]
    silent = np.flatnonzero(~excited)
    return (np.concatenate([order, rest, silent]).astype(int),
            {"prefix": prefix, "search_cost": cost, "pool": len(pool)})


def body_rankings(model, pooled_order, score=None, n_lockstep=N_CURVE, stride=3, log=None,
                  estimate=estimate_error, removals=None):
    """Per-body load-aware rankings for equal counts per body (``load-N``).

    The first ``n_lockstep`` modes of every body are ordered by ``lockstep_elimination``
    of J = max_n E_n (a-priori, every ``stride``-th sample), starting from each
    body's first n_lockstep modes in the pooled order; the others follow in the
    pooled order.  Removals that change J by less than TIE_RTOL (relative) are
    ties, resolved by the participation score (score (4, Q), max over rates):
    the platform's modes, for one, hardly move J = E of the outer-gimbal rate.  (The pooled order restricted to a body is a good set only
    together with the other bodies' pooled picks: at equal counts its first 5 per
    body ring at frequencies the full chain does not have, J = 0.31 on the thesis
    scene, against 0.04 for the rigid model.)  Returns 4 arrays (D_b,) of local
    mode indices.  estimate, removals: the a-priori error functions (as ``pooled_ranking``)."""
    off = model["offsets"]
    split = split_by_body(pooled_order, off)
    n = min([int(n_lockstep)] + [len(p) for p in split])
    if n == 0:
        return split
    search = decimated(model, stride)

    def J(keep):
        return float(np.max(estimate(search, keep)))
    pools = [off[k] + p[:n] for k, p in enumerate(split)]
    prio = None if score is None else dict(enumerate(np.max(np.asarray(score), axis=0)))
    orders, _ = lockstep_elimination(J, pools, priority=prio, tie_rtol=TIE_RTOL, log=log,
                                     removals=_max_removals(removals, search))
    return [np.concatenate([o - off[k], p[n:]]).astype(int)
            for k, (o, p) in enumerate(zip(orders, split))]


def _max_removals(removals, model):
    """The eliminations' removals callback (J = max_n E_n of each trial) from an a-priori
    removals function (model, keep, members) -> E arrays; None stays None."""
    if removals is None:
        return None
    return lambda keep, members: [float(np.max(e)) for e in removals(model, keep, members)]


def split_by_body(order, offsets):
    """Per-body rankings [(D_b,) local mode indices] from a pooled order and offsets (5,)."""
    order = np.asarray(order, int)
    out = []
    for k in range(len(offsets) - 1):
        mine = order[(order >= offsets[k]) & (order < offsets[k + 1])]
        out.append(mine - offsets[k])
    return out


def pooled_xmx_order(radii, offsets):
    """A load-blind pooled ranking for comparison: every body's XMX radius (D_b,) in one
    list, largest first.  The radii are shares of each body's own rigid mass M_inf, so
    they do not weigh the bodies by what they do to the gimbal rates."""
    r = np.concatenate([np.asarray(x, float) for x in radii])
    if r.size != offsets[-1]:
        raise LoadAwareError(f"pooled XMX: {r.size} radii for {offsets[-1]} modes")
    return np.lexsort((np.arange(r.size), -r))


def nested_errors(model, base, layers, estimate=estimate_error, chain=None):
    """A-priori errors (L, 4) of the nested kept sets base + layers[0] + ... + layers[N - 1],
    N = 1..L (each count of a curve adds a layer: one mode, or one mode per body).  chain:
    optional callable(model, keep, steps) -> the errors of keep and of keep without each step in
    turn (``frozen_chain.FrozenChainEstimator.chain_errors``: the whole curve from one
    eigendecomposition); without it, ``estimate`` of every set."""
    base = [int(i) for i in np.ravel(base)]
    layers = [[int(i) for i in np.ravel(layer)] for layer in layers]
    if not layers:
        return np.zeros((0, N_JOINTS))
    if chain is None:
        return np.array([estimate(model, base + [i for layer in layers[:N] for i in layer])
                         for N in range(1, len(layers) + 1)])
    keep = base + [i for layer in layers for i in layer]
    return np.array(chain(model, keep, layers[:0:-1])[::-1])


def estimate_curves(model, orders, n_max=N_CURVE, estimate=estimate_error, chain=None):
    """A-priori errors (n_max, 4) of keeping the first N = 1..n_max modes of every body's
    order (orders: 4 arrays of local indices); estimate, chain: as ``nested_errors``."""
    off = model["offsets"]
    D = np.diff(off)
    out = np.full((n_max, N_JOINTS), np.nan)
    n = min(int(n_max), int(D.min()))
    layers = [[off[k] + int(np.asarray(o, int)[N]) for k, o in enumerate(orders)] for N in range(n)]
    out[:n] = nested_errors(model, [], layers, estimate, chain)
    return out


def body_curves(model, orders, n_max=N_CURVE, estimate=estimate_error, chain=None):
    """{body: (n_max, 4)}: a-priori errors of truncating one body to its first N modes
    (N = 1..n_max), the other bodies keeping every mode; estimate, chain: as ``nested_errors``."""
    off = model["offsets"]
    out = {}
    for k, b in enumerate(BODIES):
        curve = np.full((n_max, N_JOINTS), np.nan)
        others = np.concatenate([np.arange(off[j], off[j + 1])
                                 for j in range(len(BODIES)) if j != k])
        n = min(int(n_max), int(off[k + 1] - off[k]))
        layers = [[off[k] + int(i)] for i in np.asarray(orders[k], int)[:n]]
        curve[:n] = nested_errors(model, others, layers, estimate, chain)
        out[b] = curve
    return out


# ----------------------------------------------------------------- the stage
def build_linear_model(scene, body_data, log=None):
    """(model, info) of a scene and the body files {b: body dict}: every computed mode."""
    log = log or (lambda *_: None)
    D = {b: int(np.asarray(body_data[b]["eigenvalues"]).size) for b in BODIES}
    rigid = models.build_chain(models.ModelSpec("rigid", {b: np.zeros(0, int) for b in BODIES},
                                                dict.fromkeys(BODIES, ()), "freq"), body_data)
    full = models.build_chain(models.ModelSpec("all", {b: np.arange(D[b]) for b in BODIES},
                                               dict.fromkeys(BODIES, ()), "freq"), body_data,
                              scene.damping_ratio)
    t0 = time.perf_counter()
    run = rigid_run(rigid, scene)
    log(f"rigid run: {run['t'].size} samples in {time.perf_counter() - t0:.1f} s")
    t0 = time.perf_counter()
    loads = modal_loads(full, run["t"], run["y"], run["yd"], run["ydd"], scene.case,
                        Progress("load_aware: modal loads", run["t"].size, "samples"))
    log(f"modal loads of {loads.shape[1]} modes in {time.perf_counter() - t0:.1f} s")
    y0 = np.zeros(full.n_coordinates)
    y0[:N_JOINTS] = scene.initial_angles
    t0 = time.perf_counter()
    model = linear_model(full, y0, run["t"], run["yd"], loads)
    log(f"frozen linear chain ({full.n_coordinates} coordinates) in {time.perf_counter() - t0:.1f} s")
    excursion = np.max(np.abs(run["y"] - run["y"][0]), axis=0)
    info = {"angle_excursion": excursion,
            "rate_over_lowest_frequency": float(np.max(np.abs(run["yd"])) /
                                                np.sqrt(np.min(full.stiffness_diagonal()[4:]))),
            "rigid_motion": run}
    return model, info


# ------------------------------------------------------------- progress of rank_scene
def evaluation_work(samples, kept):
    """The relative cost of one a-priori evaluation (``estimate_error``): its samples times its
    coordinates (the kept modes and the joints; the closed-form response is linear in both)."""
    return samples * (kept + N_JOINTS)


def elimination_work(n, protected=0, drop_fraction=0.0):
    """Sum of (kept + joints) over ``backward_elimination``'s evaluations of a pool of n."""
    work, size = n + N_JOINTS, n
    while size > protected:
        work += (size - protected) * (size - 1 + N_JOINTS)
        k = max(1, int(drop_fraction * size))
        size -= min(k, size - protected)
        if k != 1:
            work += size + N_JOINTS
    return work


def selection_work(candidates, steps):
    """Sum of (kept + joints) over ``forward_selection``'s evaluations."""
    return N_JOINTS + sum((candidates - s) * (s + 1 + N_JOINTS) for s in range(min(steps, candidates)))


def lockstep_work(groups, n):
    """Sum of (kept + joints) over ``lockstep_elimination``'s evaluations (groups of n)."""
    work, sizes = groups * n + N_JOINTS, [n] * groups
    for size in range(n, 0, -1):
        for g in range(groups):
            work += size * (sum(sizes) - 1 + N_JOINTS)
            sizes[g] -= 1
    return work


def ranking_work(model, n_pool, n_curve=N_CURVE, stride=3, drop_fraction=1 / 16, greedy_prefix=GREEDY_STEPS,
                 global_xmx=True):
    """The work of ``rank_scene`` (``evaluation_work`` summed over every a-priori evaluation it
    makes), for its progress line: the pooled ranking and the per-body ranking on the search
    grid, the curves on the curve grid.  Exact without a greedy prefix (the default); with one,
    an upper bound (the prefix, of a length known only after the search, is never eliminated)."""
    off = np.asarray(model["offsets"])
    D = np.diff(off)
    T = len(model["t"])
    search = len(range(0, T, stride))
    curve = len(range(0, T, max(1, int(math.ceil(T / CURVE_SAMPLES)))))
    pooled = elimination_work(n_pool, 0, drop_fraction) + (
        selection_work(n_pool, greedy_prefix) if greedy_prefix else 0)
    per_body = lockstep_work(len(D), min([int(n_curve)] + D.tolist()))
    prefixes = sum(N + N_JOINTS for N in range(1, n_pool + 1))               # order[:N], N = 1..pool
    nc = min(int(n_curve), int(D.min()))
    curves = (N_JOINTS + prefixes * (3 if global_xmx else 2)
              + 4 * sum(4 * N + N_JOINTS for N in range(1, nc + 1))            # load, freq, xmx, xmgmx
              + sum(off[-1] - d + N + N_JOINTS for d in D for N in range(1, min(int(n_curve), d) + 1)))
    return search * (pooled + per_body) + curve * curves + T * N_JOINTS         # + the rigid estimate


def rank_scene(model, rankings, pool_size=DEFAULT_POOL, n_curve=N_CURVE, search=None, log=None):
    """Everything the ranking file holds, as a dict of arrays (see ``write_ranking``).  Progress
    (``gimbal_reduction.workflow.progress``): the a-priori evaluations done, weighted by ``evaluation_work``,
    of the whole (``ranking_work``)."""
    log = log or (lambda *_: None)
    off = model["offsets"]
    t0 = time.perf_counter()
    part = participation_scores(model)
    log(f"participation scores in {time.perf_counter() - t0:.1f} s")
    search = dict(search or {})
    global_xmx = all("rho_xmx" in rankings[b] for b in BODIES)
    n_excited = int(np.sum(excited_modes(part["score"])))
    progress = Progress("load_aware: ranking", ranking_work(
        model, min(int(pool_size), n_excited), n_curve, search.get("stride", 3),
        search.get("drop_fraction", 1 / 16), search.get("greedy_prefix", GREEDY_STEPS), global_xmx), None)
    step = "pooled ranking"
    engine = FrozenChainEstimator(model)
    estimate = progress.counted(
        engine.estimate_error, lambda m, keep: evaluation_work(len(m["t"]), np.size(keep)),
        note=lambda: step)
    removals = progress.counted(
        engine.removal_errors,
        lambda m, keep, members: len(members) * evaluation_work(len(m["t"]), np.size(keep) - 1),
        note=lambda: step)
    chain = progress.counted(
        engine.chain_errors,
        lambda m, keep, steps: sum(evaluation_work(len(m["t"]), size) for size in
                                   np.size(keep) - np.cumsum([0] + [len(st) for st in steps])),
        note=lambda: step)
    t0 = time.perf_counter()
    order, info = pooled_ranking(model, part["score"], pool_size, log=log, estimate=estimate,
                                 removals=removals, **search)
    n_pool = info["pool"]
    log(f"pooled ranking (pool {n_pool}) in {time.perf_counter() - t0:.1f} s")
    step = "per-body ranking"
    t0 = time.perf_counter()
    per_body = body_rankings(model, order, part["score"], n_curve, search.get("stride", 3), log,
                             estimate=estimate, removals=removals)
    log(f"per-body (equal counts) ranking in {time.perf_counter() - t0:.1f} s")
    step = "a-priori curves"
    t0 = time.perf_counter()
    # the a-priori curves on the full output grid up to CURVE_SAMPLES samples, decimated beyond
    full = model
    model = decimated(model, max(1, int(math.ceil(len(model["t"]) / CURVE_SAMPLES))))
    pooled_E = nested_errors(model, [], [[i] for i in order[:n_pool]], estimate, chain)
    J = np.concatenate([[np.max(estimate(model, []))], pooled_E.max(axis=1)])
    curves = {"load": estimate_curves(model, per_body, n_curve, estimate, chain)}
    for fam, key in (("freq", "rank_frequency"), ("xmx", "rank_xmx"), ("xmgmx", "rank_xmgmx")):
        curves[fam] = estimate_curves(model, [rankings[b][key] for b in BODIES], n_curve, estimate,
                                      chain)
    xmx_pool = None
    if global_xmx:
        xmx_pool = pooled_xmx_order([rankings[b]["rho_xmx"] for b in BODIES], off)
        curves["global_xmx"] = nested_errors(model, [], [[i] for i in xmx_pool[:len(J) - 1]],
                                             estimate, chain)
    by_score = np.lexsort((np.arange(off[-1]), -part["score"].max(axis=0)))
    curves["global_score"] = nested_errors(model, [], [[i] for i in by_score[:len(J) - 1]],
                                           estimate, chain)
    bodies = body_curves(model, per_body, n_curve, estimate, chain)
    model = full
    rigid_estimate = estimate(model, [])
    log(f"a-priori curves in {time.perf_counter() - t0:.1f} s")
    additive_load = np.array([additive_estimate(
        part["score"], kept_from_counts(off, per_body, [N] * 4)) for N in range(1, n_curve + 1)])
    additive_global = np.array([additive_estimate(part["score"], order[:N])
                                for N in range(1, len(J))])
    return {"order": order, "J": J, "prefix": info["prefix"], "per_body": per_body, "score": part["score"],
            "excited": excited_modes(part["score"]), "coupled_omega": part["omega"],
            "rate_share": part["rate_share"], "pooled_estimate": pooled_E, "curves": curves,
            "body_curves": bodies, "additive_load": additive_load,
            "additive_global": additive_global, "rigid_estimate": rigid_estimate,
            "work": {"planned": progress.total, "done": progress.done}}


def write_ranking(path, result, model, attrs):
    """Write the ranking file atomically (``gimbal_reduction.workflow.provenance.atomic_h5``).

    Layout (mode indices 0-based into the body file's modes; pooled indices run over
    bodies 2..5 in turn, body b's block at offsets[b-2]:offsets[b-1]):
    ``body{b}/rank_load`` (D,), ``body{b}/score`` (4, D), ``body{b}/excited`` (D,);
    ``pooled/body``, ``pooled/mode`` (Q,) the pooled ranking; ``pooled/J`` (P+1,);
    ``estimate/{load,freq,xmx,xmgmx}`` (40, 4) a-priori E of N = 1..40 per body;
    ``estimate/{global,global_xmx,global_score}`` (P, 4) of the pooled top N = 1..P;
    ``estimate/body{b}`` (40, 4) body b truncated alone; ``estimate/additive_load``,
    ``estimate/additive_global``; ``estimate/rigid`` (4,); ``linear/{M,K,t,
    rigid_rates,loads,offsets,full}`` the frozen linear chain (the a-priori estimator);
    ``coupled/omega`` (n,) [rad/s], ``coupled/rate_share`` (4, n)."""
    off = model["offsets"]
    order = result["order"]
    body_of = np.searchsorted(off, order, side="right") + 1          # 2..5
    with atomic_h5(path) as f:
        for k, b in enumerate(BODIES):
            g = f.create_group(f"body{b}")
            g["rank_load"] = np.asarray(result["per_body"][k], np.int64)
            g["score"] = result["score"][:, off[k]:off[k + 1]]
            g["excited"] = result["excited"][off[k]:off[k + 1]]
        p = f.create_group("pooled")
        p["body"] = body_of.astype(np.int64)
        p["mode"] = (order - off[body_of - 2]).astype(np.int64)
        p["J"] = result["J"]
        p["prefix"] = np.asarray(result["prefix"], np.int64)
        e = f.create_group("estimate")
        e["global"] = result["pooled_estimate"]
        for name, curve in result["curves"].items():
            e[name] = curve
        for b, curve in result["body_curves"].items():
            e[f"body{b}"] = curve
        e["additive_load"] = result["additive_load"]
        e["additive_global"] = result["additive_global"]
        e["rigid"] = result["rigid_estimate"]
        lin = f.create_group("linear")
        for key in ("M", "K", "t", "rigid_rates", "loads", "offsets", "full"):
            lin[key] = model[key]
        c = f.create_group("coupled")
        c["omega"] = result["coupled_omega"]
        c["rate_share"] = result["rate_share"]
        for k, v in attrs.items():
            f.attrs[k] = v


def ranking_config_hash(scene, body_hashes, options):
    """16 hex digits of the scene, the body files' config hashes and the options (dict)."""
    payload = {"scene": scene.config_hash(), "bodies": list(body_hashes), "options": options,
               "format": FORMAT_VERSION}
    return hashlib.sha256(json.dumps(payload, sort_keys=True, default=str).encode()).hexdigest()[:16]


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def main(argv=None):
    ap = _Parser(prog="python -m gimbal_reduction.reduction.load_aware",
                 description="Load-aware ranking of every body's modes for one scene, pooled and "
                             "per body, with a-priori eq. 3.53 error estimates (docs/selection.md).")
    ap.add_argument("--scene", required=True, help="scene name (config/scenes/NAME.yaml) or path")
    ap.add_argument("--bodies", nargs=4, required=True, metavar="BODY_FILE",
                    help="the modal stage's body files of bodies 2, 3, 4, 5")
    ap.add_argument("--reductions", nargs=4, required=True, metavar="REDUCTION_FILE",
                    help="the reduction stage's files of bodies 2..5 (frequency/XMX/XMGMX rankings)")
    ap.add_argument("--out", required=True, help="ranking file, e.g. results/reduction/load/thesis.h5")
    cli.add_config_option(ap, "body and reduction files of another configuration are refused before the work")
    ap.add_argument("--pool", type=int, default=DEFAULT_POOL,
                    help=f"modes ranked by backward elimination (default {DEFAULT_POOL})")
    ap.add_argument("--curve", type=int, default=N_CURVE,
                    help=f"a-priori curves for N = 1..CURVE modes per body (default {N_CURVE})")
    ap.add_argument("--search-stride", type=int, default=None,
                    help=f"the ranking search evaluates E on every STRIDE-th output sample (default: "
                         f"the smallest >= 3 that leaves at most {SEARCH_SAMPLES} samples)")
    ap.add_argument("--drop-fraction", type=float, default=1 / 16,
                    help="backward elimination drops this fraction of the kept modes per round "
                         "(0: one at a time; default 1/16)")
    ap.add_argument("--greedy-steps", type=int, default=GREEDY_STEPS,
                    help=f"forward-selection steps that seed the ranking (0: none; default "
                         f"{GREEDY_STEPS})")
    ap.add_argument("--quiet", action="store_true")
    try:        # a negative value is read as the option's value (and refused below)
        args = ap.parse_args(cli.values_joined(sys.argv[1:] if argv is None else argv, ap))
    except SystemExit as exc:       # the one-line message is printed; in process, return the status
        return exc.code
    log = (lambda *_: None) if args.quiet else (lambda m: print(f"load_aware: {m}", flush=True))
    start = time.perf_counter()
    try:
        bodyconfig.check_slots(args.bodies)
        bodyconfig.check_slots(args.reductions)
        bodyconfig.check_files(args.bodies + args.reductions, args.config)
        if args.search_stride is None:
            scene0 = scenes.load_scene(args.scene)
            args.search_stride = search_stride(scene0.duration, scene0.output_interval)
        if args.pool < 1 or args.curve < 1 or args.search_stride < 1:
            raise LoadAwareError(f"--pool, --curve and --search-stride must be >= 1, got "
                                 f"{args.pool}, {args.curve}, {args.search_stride}")
        if not 0.0 <= args.drop_fraction < 1.0:
            raise LoadAwareError(f"--drop-fraction must lie in [0, 1), got {args.drop_fraction}")
        scene = scenes.load_scene(args.scene)
        body_data = {b: models.load_body_file(path) for b, path in zip(BODIES, args.bodies)}
        reductions = dict(zip(BODIES, args.reductions))
        rankings = models.read_rankings(reductions)
        for b in BODIES:
            path = reductions[b]
            with h5py.File(path, "r") as f:
                if "rho_xmx" in f:
                    rankings[b]["rho_xmx"] = f["rho_xmx"][()]
            D = np.asarray(body_data[b]["eigenvalues"]).size
            if np.asarray(rankings[b]["rank_frequency"]).size != D:
                raise LoadAwareError(f"{path}: ranks {np.asarray(rankings[b]['rank_frequency']).size} "
                                     f"modes, the body file has {D} (stale reduction file)")
        model, info = build_linear_model(scene, body_data, log)
        if np.max(info["angle_excursion"]) > FROZEN_ANGLE or \
                info["rate_over_lowest_frequency"] > FROZEN_RATE:
            print(f"load_aware: warning: the gimbals move {np.max(info['angle_excursion']):.2e} rad "
                  f"(rate / lowest modal frequency {info['rate_over_lowest_frequency']:.1e}) in "
                  f"scene {scene.name!r}: the frozen linear chain may not hold; check the a-priori "
                  f"errors against a simulation", file=sys.stderr)
        result = rank_scene(model, rankings, args.pool, args.curve,
                            {"stride": args.search_stride, "drop_fraction": args.drop_fraction,
                             "greedy_prefix": args.greedy_steps}, log)
    except (ValueError, FileNotFoundError, OSError) as exc:
        print(f"load_aware: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    body_hashes = [str(body_data[b]["attrs"].get("config_hash", "")) for b in BODIES]
    options = {"pool": args.pool, "curve": args.curve, "search_stride": args.search_stride,
               "drop_fraction": args.drop_fraction, "greedy_steps": args.greedy_steps}
    attrs = {"options": json.dumps(options, sort_keys=True), "format_version": FORMAT_VERSION, "scene": scene.name,
             "config_hash": ranking_config_hash(scene, body_hashes, options),
             "scene_hash": scene.config_hash(), "scene_loads_hash": scene.loads_hash(),
             "body_config_hashes": json.dumps(body_hashes),
             "pool": int(min(args.pool, result["order"].size)), "curve": int(args.curve),
             "criterion": "J = max over the 4 gimbal rates of eq. 3.53, frozen linear chain",
             "n_modes": np.diff(model["offsets"]),
             "angle_excursion_rad": info["angle_excursion"],
             "rate_over_lowest_frequency": info["rate_over_lowest_frequency"],
             "mode_index_base": 0, "units": "in, lbf, s, rad",
             "versions": json.dumps(versions()), "wall_time_s": time.perf_counter() - start,
             "created": time.strftime("%Y-%m-%dT%H:%M:%S")}
    try:
        write_ranking(args.out, result, model, attrs)
    except OSError as exc:          # a full disk: the atomic writer left nothing
        print(f"load_aware: error: {cli.write_failure(args.out, exc)}", file=sys.stderr)
        return 2
    J = result["J"]
    log(f"{args.out}: rigid J = {J[0]:.3e}; pooled top 40/80/160: " +
        ", ".join(f"{J[n]:.3e}" for n in (40, 80, 160) if n < len(J)) +
        f" ({attrs['wall_time_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
