"""Load-aware mode selection (gimbal_reduction.reduction.load_aware), the load-N / global-N grammar, the
simulate --load-ranking path and the selection table (gimbal_reduction.results.bench.selection).

Synthetic chains only (gimbal_reduction/results/bench/oracle.py), except the last test, which checks
the stored a-priori estimate against a measured error on the real data when present."""

import json
import re
import os

import h5py
import numpy as np
import pytest

from gimbal_reduction.reduction import frozen_chain as fc
from gimbal_reduction.reduction import load_aware as la
from gimbal_reduction.results.bench import selection
from gimbal_reduction.reduction import models
from gimbal_reduction.reduction import names
from gimbal_reduction.solver.dynamics import scenes, simulate
from gimbal_reduction.results.bench.oracle import synthetic_body
from tests.dynamics_fixtures import run_model
from tests.reduction.test_models import project_body_hash, write_body

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


# ------------------------------------------------------------ linear response
def test_velocity_response_closed_forms():
    """Exact for piecewise-linear loads at any omega h (here up to 30): step and ramp."""
    t = np.linspace(0.0, 0.01, 101)
    w = np.array([0.0, 50.0, 3e5])
    step = fc.velocity_response(w, np.ones((t.size, 3)), t)
    assert np.allclose(step[:, 0], t, rtol=0, atol=1e-15)
    assert np.allclose(step[:, 1:], np.sin(np.outer(t, w[1:])) / w[1:], rtol=0, atol=1e-13)
    ramp = fc.velocity_response(w, np.tile(t[:, None], 3), t)
    assert np.allclose(ramp[:, 0], t ** 2 / 2, rtol=0, atol=1e-15)
    assert np.allclose(ramp[:, 1:], (1 - np.cos(np.outer(t, w[1:]))) / w[1:] ** 2, rtol=0,
                       atol=1e-15)


def test_velocity_response_smooth_load_and_nonuniform_grid():
    """cos(nu t) load on a fine, non-uniform grid: the closed form within O(h^2)."""
    rng = np.random.default_rng(1)
    t = np.sort(np.concatenate([[0.0, 0.02], rng.uniform(0, 0.02, 3000)]))
    w, nu = np.array([2e3, 4e4]), 4 * np.pi
    g = np.cos(nu * t)[:, None] * np.ones(2)
    exact = (-nu * np.sin(nu * t)[:, None] + w * np.sin(np.outer(t, w))) / (w ** 2 - nu ** 2)
    got = fc.velocity_response(w, g, t)
    assert np.max(np.abs(got - exact)) < 1e-6 * np.max(np.abs(exact))


def test_fused_joint_rates_match_the_numpy_duhamel_sums_and_closed_form():
    """The fused kernel (uniform grids) against the NumPy form projected on the joints, and a
    step load's closed form sin(w t)/w, up to omega t ~ 6e3 (rotation rounding stays ~1e-12)."""
    rng = np.random.default_rng(7)
    t = 0.003 + np.arange(1501) * 1e-5
    w = np.concatenate([[0.0], rng.uniform(1e2, 4e5, 40)])
    g = rng.normal(size=(t.size, w.size)).cumsum(axis=0)
    V4 = rng.normal(size=(4, w.size))
    ref = fc.velocity_response(w, g, t) @ V4.T
    got = fc.joint_rate_response(w, V4, g, t)
    assert np.max(np.abs(got - ref)) < 1e-11 * np.max(np.abs(ref))
    step = fc.joint_rate_response(w[1:4], np.eye(4, 3), np.ones((t.size, 3)), t - t[0])
    assert np.allclose(step[:, :3], np.sin(np.outer(t - t[0], w[1:4])) / w[1:4], rtol=0, atol=1e-12)
    assert np.all(step[:, 3] == 0.0)
    # a non-uniform grid takes the NumPy form, the same numbers
    tn = np.sort(np.concatenate([[0.0, 0.01], rng.uniform(0, 0.01, 200)]))
    gn = rng.normal(size=(tn.size, 5))
    ref = fc.velocity_response(w[:5], gn, tn) @ V4[:, :5].T
    got = fc.joint_rate_response(w[:5], V4[:, :5], gn, tn)
    assert np.max(np.abs(got - ref)) <= 1e-13 * np.max(np.abs(ref))   # BLAS may round per alignment


def test_phi_series_and_direct_formula_agree():
    a = 1j * np.array([0.5, 0.99, 1.01, 2.0]) * fc.SERIES_LIMIT
    for order in (1, 2):
        series = fc._phi(a, order)                    # the first two by the series
        direct = (1 - np.exp(-a)) / a if order == 1 else (1 - np.exp(-a) * (1 + a)) / a ** 2
        assert np.allclose(series, direct, rtol=1e-12, atol=0)


def hand_model(decoupled=2, T=400):
    """A small frozen chain: 4 joints + 4 modes, mode ``decoupled`` neither loaded nor
    coupled to anything (an identity row of M, a zero load)."""
    rng = np.random.default_rng(5)
    n = 8
    A = rng.normal(size=(n, n))
    M = A @ A.T / n + np.eye(n)
    q = 4 + decoupled
    M[q, :] = M[:, q] = 0.0
    M[q, q] = 1.0
    K = np.array([0, 0, 0, 0, 4e6, 9e6, 2.5e7, 6.4e7], float)
    t = np.linspace(0, 0.01, T)
    loads = np.outer(np.cos(4 * np.pi * t), rng.normal(size=4))
    loads[:, decoupled] = 0.0
    rigid = np.outer(np.sin(4 * np.pi * t), [1.0, 0.5, -0.3, 0.2]) * 1e-2
    model = {"M": M, "K": K, "t": t, "rigid_rates": rigid, "loads": loads,
             "offsets": np.array([0, 1, 2, 3, 4])}
    la.check_model(model)
    model["full"] = fc.rate_response(model, np.arange(4))
    return model


def test_mode_orthogonal_to_every_load_scores_zero_and_is_dropped():
    model = hand_model(decoupled=2)
    part = la.participation_scores(model)
    s = part["score"]
    assert np.all(s[:, 2] == 0.0) and np.all(s[:, [0, 1, 3]].max(axis=0) > 0)
    assert list(la.excited_modes(s)) == [True, True, False, True]
    order, info = la.pooled_ranking(model, s, pool_size=4, stride=1, drop_fraction=0.0)
    assert order[-1] == 2 and sorted(order) == [0, 1, 2, 3] and info["pool"] == 3
    # dropping it changes nothing: the a-priori error of the other three is zero
    assert np.max(la.estimate_error(model, [0, 1, 3])) < 1e-24
    assert np.all(la.estimate_error(model, [0, 1]) > 0)
    # the participation scores add up to about the rigid model's error
    assert np.allclose(s.sum(axis=1), la.estimate_error(model, []), rtol=0.3)


def coupled_model(Q=14, T=301, rank=3, seed=8, t=None):
    """A frozen chain of 4 joints and Q modes with strong joint coupling (M far from diagonal),
    frequencies over a decade and loads of the given rank (sums of a few time functions,
    as the real modal loads are)."""
    rng = np.random.default_rng(seed)
    n = Q + 4
    A = rng.normal(size=(n, n))
    M = A @ A.T / n + np.eye(n)
    K = np.concatenate([np.zeros(4), np.geomspace(2e3, 3e4, Q) ** 2])
    t = np.linspace(0, 0.02, T) if t is None else t
    basis = np.stack([np.cos(2 * np.pi * (k + 1) * 30 * t + k) for k in range(rank)], axis=1)
    loads = basis @ rng.normal(size=(rank, Q))
    rigid = np.outer(np.sin(4 * np.pi * t), [1.0, 0.5, -0.3, 0.2]) * 1e-2
    model = {"M": M, "K": K, "t": t, "rigid_rates": rigid, "loads": loads,
             "offsets": np.array([0, 4, 7, 11, Q])}
    model["full"] = fc.rate_response(model, np.arange(Q))
    return model


@pytest.mark.parametrize("grid", ["uniform", "decimated", "non-uniform"])
def test_estimator_equals_the_straightforward_estimate(grid):
    """FrozenChainEstimator (principal submatrices of the whole chain's Schur complement, the
    standard-form eigenproblem, loads factored) gives estimate_error's numbers to rounding, on
    any kept set, also on a decimated copy of the model and a non-uniform grid."""
    t = None
    if grid == "non-uniform":
        t = np.sort(np.concatenate([[0.0, 0.02], np.random.default_rng(2).uniform(0, 0.02, 299)]))
    model = coupled_model(t=t)
    est = fc.FrozenChainEstimator(model)
    m = fc.decimated(model, 3) if grid == "decimated" else model
    rng = np.random.default_rng(4)
    sets = [[], [5], [0, 13], list(range(14))] + [rng.choice(14, k, replace=False) for k in range(1, 14)]
    for keep in sets:
        ref = fc.estimate_error(m, keep)
        got = est.estimate_error(m, keep)
        assert np.allclose(got, ref, rtol=1e-9, atol=1e-16), (keep, got, ref)
        assert np.allclose(est.rate_response(m, keep), fc.rate_response(m, keep), rtol=0,
                           atol=1e-11 * np.abs(model["full"]).max())
    with pytest.raises(la.LoadAwareError, match="not the estimator's chain"):
        est.estimate_error(coupled_model(), [1, 2])
    with pytest.raises(la.LoadAwareError, match="distinct indices"):
        est.estimate_error(m, [1, 1])


@pytest.mark.parametrize("grid", ["uniform", "non-uniform"])
def test_removals_and_chains_equal_the_estimate_of_each_set(grid):
    """removal_errors (deletions from one eigendecomposition) and chain_errors (successive
    deletions) give estimate_error's numbers for every set they stand for."""
    t = None
    if grid == "non-uniform":
        t = np.sort(np.concatenate([[0.0, 0.02], np.random.default_rng(2).uniform(0, 0.02, 299)]))
    model = coupled_model(t=t)
    est = fc.FrozenChainEstimator(model)
    m = fc.decimated(model, 2)

    def same(got, keep):
        ref = fc.estimate_error(m, keep)
        assert np.allclose(got, ref, rtol=1e-9, atol=1e-16), (keep, got, ref)
    for keep in ([3, 9], [0, 4, 7, 11], list(range(14)), [13, 2, 8, 5, 6, 1, 10]):
        for m_out, got in zip(keep, est.removal_errors(m, keep, keep)):
            same(got, [i for i in keep if i != m_out])
    order = [6, 2, 13, 0, 9, 4, 11, 7, 1, 12, 3, 8, 5, 10]
    steps = [[10], [5, 8], [3], [12, 1, 7], [11], [4, 9, 0, 13], [2], [6]]
    got = est.chain_errors(m, order, steps)
    assert len(got) == len(steps) + 1
    keep = list(order)
    same(got[0], keep)
    for st, e in zip(steps, got[1:]):
        keep = [i for i in keep if i not in st]
        same(e, keep)
    with pytest.raises(la.LoadAwareError, match="kept modes"):
        est.removal_errors(m, [1, 2], [3])
    with pytest.raises(la.LoadAwareError, match="distinct kept modes"):
        est.chain_errors(m, [1, 2], [[2], [2]])


def test_curves_by_chains_equal_the_curves_by_single_estimates():
    model = coupled_model()
    est = fc.FrozenChainEstimator(model)
    orders = [np.array([2, 0, 3, 1]), np.array([1, 2, 0]), np.array([3, 0, 2, 1]), np.array([2, 0, 1])]
    for fn in (la.estimate_curves, la.body_curves):
        a = fn(model, orders, 5, est.estimate_error)
        b = fn(model, orders, 5, est.estimate_error, est.chain_errors)
        for x, y in (zip(a.values(), b.values()) if isinstance(a, dict) else [(a, b)]):
            assert np.array_equal(np.isnan(x), np.isnan(y))
            assert np.allclose(x[~np.isnan(x)], y[~np.isnan(y)], rtol=1e-9, atol=1e-16)
    layers = [[5], [0], [13, 2], [7]]
    assert np.allclose(la.nested_errors(model, [1], layers, est.estimate_error),
                       la.nested_errors(model, [1], layers, est.estimate_error, est.chain_errors),
                       rtol=1e-9, atol=1e-16)
    assert la.nested_errors(model, [1], [], est.estimate_error).shape == (0, 4)


def test_eliminations_with_a_removals_callback_are_the_same():
    w = {0: 5.0, 1: 1.0, 2: 3.0, 3: 0.5, 4: 4.0, 10: 0.5, 11: 4.0, 12: 2.0, 13: 1.5, 14: 0.2}
    calls = []

    def cost(keep):
        return sum(v for k, v in w.items() if k not in keep)

    def removals(keep, members):
        calls.append(len(members))
        return [cost([k for k in keep if k != m]) for m in members]
    for frac in (0.0, 0.25):
        a = la.backward_elimination(cost, list(w), protected=[3], drop_fraction=frac, tie_rtol=1e-6)
        b = la.backward_elimination(cost, list(w), protected=[3], drop_fraction=frac, tie_rtol=1e-6,
                                    removals=removals)
        assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1], equal_nan=True)
    a = la.lockstep_elimination(cost, [[0, 1, 2, 3, 4], [10, 11, 12, 13, 14]])
    b = la.lockstep_elimination(cost, [[0, 1, 2, 3, 4], [10, 11, 12, 13, 14]], removals=removals)
    assert all(np.array_equal(x, y) for x, y in zip(a[0], b[0])) and np.array_equal(a[1], b[1])
    assert calls


def test_modal_loads_are_minus_the_modal_rows_of_the_inverse_dynamics():
    """The compiled inverse dynamics of modal_loads against multibody's NumPy reference, with a
    moving case (its twist at every sample), and the compiled M(y0) of linear_model."""
    from gimbal_reduction.solver.dynamics import multibody
    from gimbal_reduction.solver.dynamics.synthetic import synthetic_modal_chain
    chain = synthetic_modal_chain(3, seed=2)
    rng = np.random.default_rng(6)
    t = np.linspace(0.0, 0.01, 7)
    y, yd, ydd = (rng.normal(size=(t.size, 4)) * s for s in (0.3, 0.05, 0.5))
    case = multibody.CaseMotion(amplitude=(0.2, -0.1, 0.3), frequency=(5.0, 0.0, 12.0),
                                phase=(0.1, 0.2, 0.3), omega0=(0.01, 0.0, -0.02))
    got = la.modal_loads(chain, t, y, yd, ydd, case)
    n = chain.n_coordinates
    ref = np.zeros_like(got)
    for k in range(t.size):
        Y, V, A = (np.concatenate([v[k], np.zeros(n - 4)]) for v in (y, yd, ydd))
        ref[k] = -multibody.inverse_dynamics(chain, Y, V, A, t[k], case)[4:]
    assert np.allclose(got, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    y0 = np.concatenate([y[0], np.zeros(n - 4)])
    lin = la.linear_model(chain, y0, t, yd, got)
    assert np.allclose(lin["M"], multibody.mass_matrix(chain, y0), rtol=0,
                       atol=1e-13 * np.abs(lin["M"]).max())


def test_load_factors_are_the_loads_to_rounding():
    """loads = F W: the rank of a sum of r time functions is r, a full-rank matrix keeps all."""
    model = coupled_model(rank=3)
    F, W = fc.load_factors(model["loads"])
    assert F.shape == (301, 3) and W.shape == (3, 14)
    assert np.allclose(F @ W, model["loads"], rtol=0, atol=1e-14 * np.abs(model["loads"]).max())
    full = np.random.default_rng(0).normal(size=(40, 9))
    F, W = fc.load_factors(full)
    assert F.shape == (40, 9) and np.allclose(F @ W, full, rtol=0, atol=1e-13)
    F, W = fc.load_factors(np.zeros((5, 3)))
    assert F.shape == (5, 0) and W.shape == (0, 3)


def test_backward_elimination_recovers_an_additive_order():
    w = {0: 5.0, 1: 1.0, 2: 3.0, 3: 0.5, 4: 4.0}

    def cost(keep):
        return sum(v for k, v in w.items() if k not in keep)
    order, c = la.backward_elimination(cost, list(w))
    assert list(order) == [0, 4, 2, 1, 3]
    assert c[len(w)] == 0 and c[0] == sum(w.values()) and c[2] == 4.5
    order, _ = la.backward_elimination(cost, list(w), protected=[3])
    assert order[0] == 3 and list(order[1:]) == [0, 4, 2, 1]
    order, c = la.backward_elimination(cost, list(w), drop_fraction=0.5)
    assert list(order) == [0, 4, 2, 1, 3] and np.isnan(c[4]) and c[3] == 1.5
    with pytest.raises(la.LoadAwareError, match="distinct"):
        la.backward_elimination(cost, [0, 0, 1])
    with pytest.raises(la.LoadAwareError, match="drop_fraction"):
        la.backward_elimination(cost, [0, 1], drop_fraction=1.0)


def test_lockstep_elimination_keeps_equal_counts():
    w = {0: 5.0, 1: 1.0, 2: 3.0, 10: 0.5, 11: 4.0, 12: 2.0}

    def cost(keep):
        return sum(v for k, v in w.items() if k not in keep)
    orders, c = la.lockstep_elimination(cost, [[0, 1, 2], [10, 11, 12]])
    assert [list(o) for o in orders] == [[0, 2, 1], [11, 12, 10]]
    assert c[3] == 0 and c[1] == 1.0 + 3.0 + 0.5 + 2.0 and c[0] == sum(w.values())
    with pytest.raises(la.LoadAwareError, match="equal size"):
        la.lockstep_elimination(cost, [[0, 1], [10]])


def test_forward_selection_keeps_the_best_prefix_even_after_a_bad_first_step():
    # mode 1 alone hurts (ringing), 1 and 2 together help: a cost a plain greedy stop misses
    def cost(keep):
        k = set(keep)
        return 1.0 + 0.5 * (1 in k) - 0.9 * ({1, 2} <= k) + 0.01 * (0 in k)
    prefix, c = la.forward_selection(cost, [0, 1, 2], max_size=3)
    assert c[0] == 1.0 and set(prefix) == {1, 2} and np.isclose(c[len(prefix)], 0.6)


def test_split_by_body_and_counts():
    off = np.array([0, 3, 5, 6, 8])
    order = np.array([5, 0, 7, 3, 1, 2, 4, 6])
    parts = la.split_by_body(order, off)
    assert [list(p) for p in parts] == [[0, 1, 2], [0, 1], [0], [1, 0]]
    assert list(la.kept_from_counts(off, parts, [2, 1, 0, 1])) == [0, 1, 3, 7]


def test_bad_linear_model_is_one_line_error():
    model = hand_model()
    model["loads"] = model["loads"][:, :3]
    with pytest.raises(la.LoadAwareError, match="do not fit"):
        la.check_model(model)
    with pytest.raises(la.LoadAwareError, match="distinct indices"):
        fc.rate_response(hand_model(), [0, 0])


# ------------------------------------------------------------------ grammar
def rankings(D=6):
    r = {b: {"rank_frequency": np.arange(D), "rank_xmx": np.arange(D)[::-1],
             "rank_xmgmx": np.arange(D), "rank_load": np.roll(np.arange(D), 2)}
         for b in models.BODIES}
    r["pooled"] = {"body": np.repeat([3, 2, 5, 4], D), "mode": np.tile(np.arange(D)[::-1], 4)}
    return r


def test_grammar_load_and_global():
    r = rankings()
    s = models.model_spec("load-2", r)
    assert all(list(s.kept[b]) == [4, 5] for b in models.BODIES) and s.ranking == "load"
    s = models.model_spec("load-1,2,0,3", r)
    assert [len(s.kept[b]) for b in models.BODIES] == [1, 2, 0, 3]
    s = models.model_spec("global-8", r)
    assert [list(s.kept[b]) for b in models.BODIES] == [[4, 5], list(range(6)), [], []]
    s = models.model_spec("static-global-8", r)
    assert s.static[2] == ("output_motor_fz",) and s.n_modes(3) == 7
    s = models.model_spec("load-3@2:output_motor_my", r)
    assert s.static[2] == ("output_motor_my",) and s.static[3] == ()
    assert names.needs_load_ranking("global-4") and names.needs_load_ranking("static-load-2")
    assert not names.needs_load_ranking("xmx-4") and not names.needs_load_ranking("truth")


@pytest.mark.parametrize("name, change, message", [
    ("global-1,2,3,4", None, "global-N takes one total count"),
    ("global-25", None, "only 24 computed"),
    ("load-7", None, "only 6 computed"),
    ("load-2", "no_load", "no load-aware ranking loaded"),
    ("global-2", "no_pooled", "no pooled load-aware ranking"),
    ("global-2", "bad_pooled", "not a permutation"),
    ("loads-2", None, "unknown model"),
])
def test_grammar_errors(name, change, message):
    r = rankings()
    if change == "no_load":
        for b in models.BODIES:
            del r[b]["rank_load"]
    elif change == "no_pooled":
        del r["pooled"]
    elif change == "bad_pooled":
        r["pooled"]["mode"][1] = r["pooled"]["mode"][0]
    with pytest.raises(models.ModelError, match=message):
        models.model_spec(name, r)


# ------------------------------------------------- the stage on synthetic files
def write_synthetic_bodies(root, seed=11):
    """root/modes/body{2..5}.h5 (synthetic bodies, 6 modes each) and root/reduction/body{n}.h5
    (fixed rankings): the inputs of the load-aware stage."""
    rng = np.random.default_rng(seed)
    (root / "modes").mkdir()
    (root / "reduction").mkdir()
    for b in models.BODIES:
        d = synthetic_body(rng, b, n_nodes=8, rotations=(b % 2 == 0), n_modes=6, omega_max=3e3)
        write_body(root / "modes" / f"body{b}.h5", d)
        with h5py.File(root / "reduction" / f"body{b}.h5", "w") as f:
            f["rank_frequency"] = np.arange(6)
            f["rank_xmx"] = np.array([3, 1, 0, 2, 5, 4])
            f["rank_xmgmx"] = np.array([3, 1, 0, 2, 4, 5])
            f.attrs["body"], f.attrs["config_hash"] = b, project_body_hash(b)   # as the reduction stage copies
            f["rho_xmx"] = np.array([0.3, 0.5, 0.2, 0.9, 0.01, 0.05])


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    """Synthetic body and reduction files, and the load-aware ranking made by the CLI."""
    root = tmp_path_factory.mktemp("load_aware")
    write_synthetic_bodies(root)
    out = root / "load" / "thesis.h5"
    rc = la.main(["--scene", "thesis", "--bodies", *[str(root / "modes" / f"body{b}.h5") for b in models.BODIES],
                  "--reductions", *[str(root / "reduction" / f"body{b}.h5") for b in models.BODIES],
                  "--out", str(out), "--pool", "24", "--curve", "6", "--drop-fraction", "0", "--quiet"])
    assert rc == 0
    return root, out


def test_ranking_file_contents(synthetic):
    root, out = synthetic
    with h5py.File(out, "r") as f:
        for b in models.BODIES:
            assert sorted(f[f"body{b}/rank_load"][()]) == list(range(6))
            assert f[f"body{b}/score"].shape == (4, 6)
        body, mode = f["pooled/body"][()], f["pooled/mode"][()]
        assert len(set(zip(body, mode))) == 24
        for b in models.BODIES:      # equal-count ranking: the pooled order's first 6 per body
            assert sorted(mode[body == b][:6]) == sorted(f[f"body{b}/rank_load"][:6])
        assert f["estimate/load"].shape == (6, 4) and f["estimate/global"].shape == (24, 4)
        # all modes: no error, to the rounding of two eigendecompositions (E 2.4e-19 on the
        # thesis grid, 12 orders below the smallest kept set's 1.7e-7)
        assert np.allclose(f["estimate/global"][-1], 0.0, atol=1e-16)
        assert np.allclose(f["estimate/load"][-1], 0.0, atol=1e-16)
        assert f["estimate/global_xmx"].shape == (24, 4)
        assert f.attrs["scene"] == "thesis" and len(f.attrs["config_hash"]) == 16
        assert "numpy" in json.loads(f.attrs["versions"]) and f.attrs["wall_time_s"] > 0
    assert not [p for p in os.listdir(out.parent) if ".part" in p]


def test_estimate_predicts_simulated_error_on_synthetic_chain(synthetic, tmp_path):
    """Simulate load-2, global-5 and freq-2 (RK4, nonlinear); the a-priori eq. 3.53 errors
    of the frozen linear chain agree with the measured ones to within 2 % (rates > 1e-3
    rad/s: within 0.2 % measured) and the truth (all modes) too."""
    root, out = synthetic
    for name in ("freq-6", "load-2", "global-5", "freq-2"):
        assert run_model("thesis", name, str(root / "modes"), str(root / "reduction"), str(tmp_path),
                         ["--integrator", "rk4", "--fraction", "0.25"], load_ranking=out) == 0
    with h5py.File(tmp_path / "thesis" / "load-2.h5", "r") as f:
        assert f.attrs["load_ranking"] == str(out) and list(f.attrs["n_modes"]) == [2, 2, 2, 2]
    rc = selection.main(["--truth", str(tmp_path / "thesis" / "freq-6.h5"), "--cases"] +
                        [str(tmp_path / "thesis" / f"{m}.h5") for m in ("load-2", "global-5", "freq-2")] +
                        ["--ranking", str(out), "--reductions",
                         *[str(root / "reduction" / f"body{b}.h5") for b in models.BODIES],
                         "--table", str(tmp_path / "sel.csv"), "--figure",
                         str(tmp_path / "fig" / "global_ranking.png")])
    assert rc == 0 and (tmp_path / "fig" / "global_ranking.png").stat().st_size > 1000
    import csv
    rows = list(csv.DictReader(open(tmp_path / "sel.csv")))
    assert [r["model"] for r in rows] == ["freq-2", "load-2", "global-5"]
    for r in rows:
        ratio = float(r["apriori_over_measured"])
        assert 0.98 < ratio < 1.02, (r["model"], ratio)
        assert float(r["E_max"]) > 1e-8


def test_simulate_missing_ranking_is_one_line_error(synthetic, tmp_path, capsys):
    root, out = synthetic
    common = (str(root / "modes"), str(root / "reduction"), str(tmp_path))
    missing = tmp_path / "nope" / "thesis.h5"
    assert run_model("thesis", "load-2", *common, load_ranking=missing) == 2
    assert run_model("thesis", "global-99", *common, load_ranking=out) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and str(missing) in err[0] and "missing" in err[0]
    assert "only 24 computed" in err[1]


def test_simulate_refuses_ranking_of_other_bodies(synthetic, tmp_path, capsys):
    root, out = synthetic
    stale = tmp_path / "stale.h5"
    stale.write_bytes(out.read_bytes())
    with h5py.File(stale, "a") as f:
        f.attrs["body_config_hashes"] = json.dumps(["a", "b", "c", "d"])
    rc = run_model("thesis", "load-1", str(root / "modes"), str(root / "reduction"), str(tmp_path),
                   load_ranking=stale)
    assert rc == 2 and "other body files" in capsys.readouterr().err


def test_cli_bad_input_is_one_line(tmp_path, capsys):
    files = ["--bodies", *[str(tmp_path / f"body{b}.h5") for b in models.BODIES],
             "--reductions", *[str(tmp_path / f"red{b}.h5") for b in models.BODIES]]
    rc = la.main(["--scene", "nope", "--out", str(tmp_path / "x.h5"), "--quiet", *files])
    assert rc == 2 and not (tmp_path / "x.h5").exists()
    rc = la.main(["--scene", "thesis", "--out", str(tmp_path / "x.h5"), "--quiet", *files])
    assert rc == 2
    rc = la.main(["--scene", "thesis", "--pool", "0", "--out", str(tmp_path / "x.h5"), "--quiet", *files])
    assert rc == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and "unknown scene" in err[0] and "body file" in err[1]
    assert "--pool" in err[2]


# -------------------------------------------------------------------- real data
REAL_RANKING = os.path.join(ROOT, "results", "reduction", "load", "thesis.h5")
REAL_SIM = os.path.join(ROOT, "results", "sim", "thesis")


@pytest.mark.skipif(not (os.path.exists(REAL_RANKING) and
                         os.path.exists(os.path.join(REAL_SIM, "freq-10.h5")) and
                         os.path.exists(os.path.join(REAL_SIM, "truth.h5"))),
                    reason="real ranking file or simulations absent")
def test_real_apriori_estimate_matches_measured_freq_10():
    from gimbal_reduction.solver.dynamics.error_measure import error_measure
    from gimbal_reduction.results.study.tables import read_sim
    lin = fc.read_linear_model(REAL_RANKING)
    rk = models.load_rankings(os.path.join(ROOT, "results", "reduction"))
    spec = models.model_spec("freq-10", rk)
    keep = selection.kept_indices(spec, lin["offsets"])
    est = la.estimate_error(lin, keep)
    truth, case = read_sim(os.path.join(REAL_SIM, "truth.h5")), read_sim(os.path.join(REAL_SIM, "freq-10.h5"))
    meas = error_measure(truth["t"], truth["gamma_dot"], case["gamma_dot"])
    assert np.allclose(est, meas, rtol=0.01)
    scene = scenes.load_scene("thesis")
    assert lin["t"].size == round(scene.duration / scene.output_interval) + 1


def test_ties_are_broken_by_priority():
    def cost(keep):                         # modes 1, 2, 3 do not matter at all
        return 0.0 if 0 in keep else 1.0
    order, _ = la.backward_elimination(cost, [0, 1, 2, 3], priority={0: 0, 1: 5, 2: 1, 3: 9},
                                       tie_rtol=1e-6)
    assert list(order) == [0, 3, 1, 2]
    orders, _ = la.lockstep_elimination(cost, [[0, 1], [2, 3]], priority={0: 0, 1: 5, 2: 1, 3: 9},
                                        tie_rtol=1e-6)
    assert [list(o) for o in orders] == [[0, 1], [3, 2]]


@pytest.mark.parametrize("search", [{"stride": 1, "drop_fraction": 0.0},
                                    {"stride": 3, "drop_fraction": 1 / 16, "greedy_prefix": 3},
                                    {"stride": 2, "drop_fraction": 0.25}])
def test_ranking_progress_counts_the_work_it_planned(synthetic, monkeypatch, capsys, search):
    """Issue 16: rank_scene prints progress lines whose share of the work is exact: the work it
    plans (ranking_work) is the work its a-priori evaluations add up to (an upper bound with a
    greedy prefix, whose length the plan cannot know: it protects modes from the elimination)."""
    from gimbal_reduction.workflow import progress
    monkeypatch.setattr(progress, "EVERY", 0.0)
    root, out = synthetic
    model = fc.read_linear_model(out)
    reductions = {b: str(root / "reduction" / f"body{b}.h5") for b in models.BODIES}
    rankings = models.read_rankings(reductions)
    for b in models.BODIES:
        with h5py.File(reductions[b], "r") as f:
            rankings[b]["rho_xmx"] = f["rho_xmx"][()]
    result = la.rank_scene(model, rankings, pool_size=20, n_curve=5, search=search)
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("progress: load_aware: ranking: ")]
    if search.get("greedy_prefix"):
        assert 0.8 * result["work"]["planned"] <= result["work"]["done"] <= result["work"]["planned"]
    else:
        assert result["work"]["done"] == pytest.approx(result["work"]["planned"], rel=1e-12)
        assert lines[-1].startswith("progress: load_aware: ranking: 100 % of the work")
    assert len(lines) > 10
    assert {ln.rsplit("; ", 1)[1] for ln in lines} == {"pooled ranking", "per-body ranking", "a-priori curves"}
    assert all(re.search(r"\d+ % of the work, \d+ s elapsed, ~\d+ s left; ", ln) for ln in lines)


def test_rigid_run_matches_the_integrators_dop853():
    """``rigid_run`` (scipy's solve_ivp read at the samples) against the references' route,
    ``integrators``' DOP853 (its own step loop, outputs and divergence watch): the same motion
    to the tolerance's scale (rtol 1e-12), on the spin scene (the gimbals turn by radians)."""
    from gimbal_reduction.solver.dynamics import integrators
    rng = np.random.default_rng(5)
    bodies = {b: synthetic_body(rng, b, n_nodes=8, rotations=(b % 2 == 0), n_modes=2, omega_max=3e3)
              for b in models.BODIES}
    rigid = models.build_chain(models.ModelSpec("rigid", {b: np.zeros(0, int) for b in models.BODIES},
                                                dict.fromkeys(models.BODIES, ()), "freq"), bodies)
    scene = scenes.load_scene("spin")
    run = la.rigid_run(rigid, scene)
    prob = simulate.scene_problem(rigid, scene)
    ref = integrators.integrate(prob, scene.duration, scene.output_interval, method="dop853",
                                rtol=1e-12, atol=1e-14)
    assert run["t"] == pytest.approx(ref.t, abs=1e-15)
    assert np.ptp(ref.y, axis=0).max() > 1.0                 # a motion of radians, not a still chain
    assert np.abs(run["y"] - ref.y).max() <= 1e-9 * np.abs(ref.y).max()
    assert np.abs(run["yd"] - ref.yd).max() <= 1e-9 * np.abs(ref.yd).max()
    ydd = np.array([prob.rhs(t, y, v) for t, y, v in zip(ref.t, ref.y, ref.yd)])
    assert np.abs(run["ydd"] - ydd).max() <= 1e-9 * np.abs(ydd).max()
