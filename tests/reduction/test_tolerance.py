"""tol-EPS: grammar, the choice on a synthetic ranking file, and the refusal (fast, no FE)."""
import h5py
import numpy as np
import pytest

from reduction import models as m
from solver.bodydata import BODIES

D = 5   # modes per body in the synthetic ranking


def _ranking_file(path, excursion=1e-4, rate=1e-6):
    """A load-aware ranking file with the datasets tol-EPS reads: pooled order over 4 x D
    modes and a decreasing a-priori curve for N = 1..8 (the 'pool')."""
    Q = 4 * D
    body = np.repeat(np.array(BODIES), D)
    mode = np.tile(np.arange(D), 4)
    perm = np.random.default_rng(0).permutation(Q)
    est = np.array([[10.0 ** -(k + 1), 0.5 * 10.0 ** -(k + 1), 1e-9, 0.0] for k in range(8)])
    with h5py.File(path, "w") as f:
        for b in BODIES:
            f[f"body{b}/rank_load"] = np.arange(D)
        f["pooled/body"], f["pooled/mode"] = body[perm], mode[perm]
        f["estimate/global"] = est
        f["estimate/rigid"] = np.array([1.0, 0.1, 0.0, 0.0])
        f.attrs["scene"] = "synthetic"
        f.attrs["angle_excursion_rad"] = np.array([0.0, 0.0, excursion, 0.0])
        f.attrs["rate_over_lowest_frequency"] = rate
    return body[perm], mode[perm]


def _rankings(path):
    r = {b: {"rank_frequency": np.arange(D)} for b in BODIES}
    return m.load_load_ranking(str(path), r)


@pytest.mark.parametrize("name, eps", [("tol-1e-4", 1e-4), ("tol-0.01", 0.01), ("tol-2.5E-6", 2.5e-6),
                                       ("tol-3", 3.0)])
def test_grammar(name, eps):
    assert m.parse_tolerance(name) == eps
    assert m.needs_load_ranking(name) and m.needs_reduction_rankings(name)


@pytest.mark.parametrize("name, message", [("tol-", "positive number"), ("tol-abc", "positive number"),
                                           ("tol--1e-3", "positive number"), ("tol-0", "positive"),
                                           ("tol-1e-4@2:output_motor_fz", "no static modes")])
def test_grammar_errors(name, message):
    with pytest.raises(m.ModelError, match=message):
        m.parse_tolerance(name)


def test_choice_on_synthetic_ranking(tmp_path):
    path = tmp_path / "rank.h5"
    body, mode = _ranking_file(path)
    r = _rankings(path)
    spec = m.parse_model("tol-1e-4", r)             # estimate max: 1e-1, 1e-2, ... at N = 1, 2, ...
    a = m.tolerance_attrs("tol-1e-4")
    assert a["tol_N"] == 4 and a["tol_eps"] == 1e-4
    assert a["tol_estimate_max"] == pytest.approx(1e-4)
    assert a["tol_equivalent_model"] == "global-4"
    for b in BODIES:                                # the pooled top 4, as global-4
        assert sorted(spec.kept[b].tolist()) == sorted(mode[:4][body[:4] == b].tolist())
    # a looser tolerance keeps fewer modes; the rigid estimate (N = 0) counts too
    assert m.tolerance_attrs("tol-1e-4")["tol_N"] == 4
    m.parse_model("tol-0.05", r)
    assert m.tolerance_attrs("tol-0.05")["tol_N"] == 2
    m.parse_model("tol-1", r)
    assert m.tolerance_attrs("tol-1")["tol_N"] == 0


def test_choice_extends_beyond_stored_curve():
    pooled = {"estimate": np.array([[1e-1] * 4, [1e-2] * 4]), "rigid_estimate": np.ones(4)}
    calls = []

    def extend(N):
        calls.append(N)
        return np.full(4, 10.0 ** -N)
    N, E, source = m.tolerance_choice(1e-5, pooled, total=30, extend=extend)
    assert N == 5 and np.max(E) <= 1e-5 and "linear" in source
    with pytest.raises(m.ModelError, match="smallest estimate reached 1.000e-02"):
        m.tolerance_choice(1e-5, pooled, total=30)          # no extension: stops at the pool


def test_unreachable_tolerance_one_line(tmp_path):
    path = tmp_path / "rank.h5"
    _ranking_file(path)
    r = _rankings(path)
    r[m.POOLED_KEY].pop("path")                            # no frozen chain to extend with
    with pytest.raises(m.ModelError, match=r"no pooled set of up to 8 modes meets E <= 1e-12 .*"
                                           r"smallest estimate reached 1\.000e-08") as exc:
        m.parse_model("tol-1e-12", r)
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize("excursion, rate, why", [(0.05, 1e-6, "gimbals move 5.00e-02 rad"),
                                                  (1e-4, 0.1, "rate / lowest modal frequency")])
def test_refusal_when_frozen_chain_invalid(tmp_path, excursion, rate, why):
    path = tmp_path / "rank.h5"
    _ranking_file(path, excursion=excursion, rate=rate)
    with pytest.raises(m.ModelError, match=f"refused on scene .synthetic.: .*{why}") as exc:
        m.parse_model("tol-1e-4", _rankings(path))
    assert "cannot promise" in str(exc.value) and "\n" not in str(exc.value)
