"""tol-EPS: grammar, the choice on a synthetic ranking file, and the refusal (fast, no FE)."""
import os
import shutil

import h5py
import numpy as np
import pytest

from gimbal_reduction.reduction import models as m
from gimbal_reduction.reduction import frozen_chain as fc
from gimbal_reduction.reduction import verified_search as vs
from gimbal_reduction.reduction import names
from gimbal_reduction.solver.bodydata import BODIES

D = 5   # modes per body in the synthetic ranking
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


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
    assert names.parse(name).eps == eps
    assert names.needs_load_ranking(name) and names.needs_reduction_rankings(name)


@pytest.mark.parametrize("parse, name, message", [
    ("parse", "tol-", "positive number"), ("parse", "tol-abc", "positive number"),
    ("parse", "tol--1e-3", "positive number"), ("parse", "tol-0", "positive"),
    ("parse", "tol-1e-4@2:output_motor_fz", "no static modes"),
    ("request", "tol-1e-4-att-", "positive number"), ("request", "tol-1e-4-att-0", "attitude"),
    ("request", "tol-1e-4-att-x", "positive number"),
    ("request", "tol-1e-4-att-2-att-3", "positive number")])
def test_grammar_errors(parse, name, message):
    """A bad accuracy request (tol-EPS, and tol-EPS-att-ARCSEC) is refused in one line naming why."""
    with pytest.raises(m.ModelError, match=message):
        getattr(names, parse)(name)


def test_choice_on_synthetic_ranking(tmp_path):
    path = tmp_path / "rank.h5"
    body, mode = _ranking_file(path)
    r = _rankings(path)
    spec = m.model_spec("tol-1e-4", r)             # estimate max: 1e-1, 1e-2, ... at N = 1, 2, ...
    a = spec.choice
    assert a["tol_N"] == 4 and a["tol_eps"] == 1e-4
    assert a["tol_estimate_max"] == pytest.approx(1e-4)
    assert a["tol_equivalent_model"] == "global-4"
    for b in BODIES:                                # the pooled top 4, as global-4
        assert sorted(spec.kept[b].tolist()) == sorted(mode[:4][body[:4] == b].tolist())
    # a looser tolerance keeps fewer modes; the rigid estimate (N = 0) counts too
    assert m.model_spec("tol-1e-4", r).choice["tol_N"] == 4
    assert m.model_spec("tol-0.05", r).choice["tol_N"] == 2
    assert m.model_spec("tol-1", r).choice["tol_N"] == 0


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
        m.model_spec("tol-1e-12", r)
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize("excursion, rate, why", [(0.05, 1e-6, "gimbals move 5.00e-02 rad"),
                                                  (1e-4, 0.1, "rate / lowest modal frequency")])
def test_refusal_when_frozen_chain_invalid(tmp_path, excursion, rate, why):
    path = tmp_path / "rank.h5"
    _ranking_file(path, excursion=excursion, rate=rate)
    with pytest.raises(m.ModelError, match=f"refused on scene .synthetic.: .*{why}") as exc:
        m.model_spec("tol-1e-4", _rankings(path))
    assert "cannot promise" in str(exc.value) and "\n" not in str(exc.value)


# ------------------------------------------------------------ verified search (pure)
def _curve(values):
    """measure(N) -> E (4,) from a list of max-E values, counting the calls."""
    calls = []

    def measure(N):
        calls.append(N)
        return np.array([values[N], 0.5 * values[N], 0.0, 0.0])
    return measure, calls


@pytest.mark.parametrize("guess", [None, 0, 3, 17, 29, 40])
def test_search_finds_the_threshold_of_a_monotone_curve(guess):
    values = [10.0 ** -(0.25 * n) for n in range(41)]              # 1, 0.56, ... 1e-10
    measure, calls = _curve(values)
    r = vs.smallest_verified(1e-4, measure, 40, guess=guess)
    assert r.N == 16 and np.max(r.E) == pytest.approx(1e-4)       # 10^-4 at N = 16, 10^-3.75 at 15
    assert 15 in calls and 16 in calls                             # both sides were simulated
    assert len(set(calls)) == len(calls)                           # no N measured twice
    assert len(calls) <= (6 if guess is None else 2 * int(np.log2(abs(guess - 16) + 1)) + 4)


def test_search_on_a_non_monotone_curve_returns_a_verified_pass_and_fail():
    rng = np.random.default_rng(5)
    values = list(np.exp(-0.2 * np.arange(101)) * rng.uniform(0.3, 3.0, 101))
    for eps in (1e-1, 1e-3, 1e-6):
        measure, calls = _curve(values)
        r = vs.smallest_verified(eps, measure, 100, guess=30)
        assert values[r.N] <= eps and (r.N == 0 or values[r.N - 1] > eps)
        assert r.N in calls and (r.N == 0 or r.N - 1 in calls)     # both measured, not assumed
        assert list(r.probe_N) == calls                            # every probe recorded, in order


def test_search_uses_known_values_and_fails_inf_and_nan():
    values = [np.inf, np.nan, 1e-2, 1e-5, 0.0]

    def measure(N):
        if N == 4:
            raise AssertionError("the known largest set was measured")
        return np.full(4, values[N])
    r = vs.smallest_verified(1e-4, measure, 4, known={4: np.zeros(4)})
    assert r.N == 3 and r.probe_N[0] == 4                          # the known value comes first
    r = vs.smallest_verified(1e-9, measure, 4, known={4: np.zeros(4)})
    assert r.N == 4                                                # only the largest (the truth) passes
    with pytest.raises(vs.SearchError, match="positive"):
        vs.smallest_verified(0.0, measure, 4)


# ------------------------------------------------ verified search, end to end (synthetic bodies)
def synthetic_inputs(root):
    """In folder ``root``: synthetic bodies (6 modes each: modes/, gimbal_reduction/reduction/) and their load-aware
    ranking on the thesis scene (load/valid.h5), and a copy flagged as outside the frozen chain,
    gimbals moving 0.05 rad (load/invalid.h5).  Returns (valid, invalid, the a-priori max-E curve
    of global-1..24)."""
    from gimbal_reduction.reduction import load_aware as la
    from tests.reduction.test_load_aware import write_synthetic_bodies
    write_synthetic_bodies(root)
    valid = root / "load" / "valid.h5"
    assert la.main(["--scene", "thesis", "--bodies", *[str(root / "modes" / f"body{b}.h5") for b in BODIES],
                    "--reductions", *[str(root / "reduction" / f"body{b}.h5") for b in BODIES],
                    "--out", str(valid), "--pool", "24", "--curve", "6", "--drop-fraction", "0",
                    "--quiet"]) == 0
    invalid = root / "load" / "invalid.h5"
    shutil.copy(valid, invalid)
    with h5py.File(invalid, "a") as f:
        f.attrs["angle_excursion_rad"] = np.array([0.05, 0.0, 0.0, 0.0])
    with h5py.File(valid, "r") as f:
        curve = np.max(f["estimate/global"][()], axis=1)
    return valid, invalid, curve


@pytest.fixture(scope="module")
def invalid_scene(tmp_path_factory):
    root = tmp_path_factory.mktemp("tol_verified")
    return (root, *synthetic_inputs(root))


def _tol_args(root, ranking, model, out, *extra):
    return ["--model", model, "--scene", "thesis",
            "--bodies", *[str(root / "modes" / f"body{b}.h5") for b in BODIES],
            "--reductions", *[str(root / "reduction" / f"body{b}.h5") for b in BODIES],
            "--load-ranking", str(ranking), "--out", str(out), *extra]


def _measured(root, ranking, model, tmp_path):
    """Max E (eq. 3.53, 4 rates) of ``model`` against the truth (global-24: every synthetic mode),
    each reduced and simulated by the workflow's two stages (not the search's own simulations)."""
    from gimbal_reduction.solver.dynamics.error_measure import error_measure
    from gimbal_reduction.solver.dynamics.simfile import read_sim
    from tests.dynamics_fixtures import run_model
    out = {}
    for name in ("global-24", model):
        assert run_model("thesis", name, str(root / "modes"), str(root / "reduction"), str(tmp_path),
                         load_ranking=str(ranking)) == 0
        out[name] = read_sim(str(tmp_path / "thesis" / f"{name}.h5"))
    truth = out["global-24"]
    return float(np.max(error_measure(truth["t"], truth["gamma_dot"], out[model]["gamma_dot"])))


def _measured_attitude(tmp_path, model):
    """Largest platform attitude error [arcsec] of a model simulated by ``_measured`` in tmp_path."""
    from gimbal_reduction.solver.dynamics.error_measure import ARCSEC_PER_RAD, attitude_error
    from gimbal_reduction.solver.dynamics.simfile import read_sim
    truth, case = (read_sim(str(tmp_path / "thesis" / f"{m}.h5")) for m in ("global-24", model))
    return float(np.max(attitude_error(truth["platform_attitude"], case["platform_attitude"]))) * ARCSEC_PER_RAD


def test_invalid_frozen_chain_falls_back_to_a_verified_search(invalid_scene, tmp_path, capsys):
    root, valid, invalid, curve = invalid_scene
    eps = float(np.sqrt(curve[2] * curve[8]))                     # somewhere inside the curve
    out = tmp_path / "tol.h5"
    assert m.main(_tol_args(root, invalid, f"tol-{eps:.4g}", out)) == 0
    err = capsys.readouterr().err
    assert "the frozen-chain estimate is no promise" in err and "gimbals move 5.00e-02 rad" in err
    with h5py.File(out, "r") as f:
        a = dict(f.attrs)
    assert a["tol_method"] == m.TOL_VERIFIED and a["tol_frozen_chain_valid"] == 0
    assert "gimbals move" in a["tol_frozen_chain_reason"]
    N = int(a["tol_N"])
    assert 0 < N < 24 and a["tol_measured_max"] <= float(f"{eps:.4g}")
    probes = dict(zip(a["tol_search_N"].tolist(), a["tol_search_E_max"].tolist()))
    assert probes[24] == 0.0 and N in probes and N - 1 in probes and probes[N - 1] > float(f"{eps:.4g}")
    assert a["tol_search_probe_s"].shape == a["tol_search_N"].shape and a["tol_search_truth_time_s"] > 0
    # the claim, checked by the workflow's own stages: global-N meets the request, global-(N-1) not
    eps = float(f"{eps:.4g}")
    assert _measured(root, valid, f"global-{N}", tmp_path / "a") <= eps
    assert _measured(root, valid, f"global-{N - 1}", tmp_path / "b") > eps


def test_invalid_frozen_chain_refused_without_search_and_when_only_the_truth_passes(invalid_scene, tmp_path,
                                                                                   capsys):
    root, valid, invalid, curve = invalid_scene
    assert m.main(_tol_args(root, invalid, "tol-1e-3", tmp_path / "a.h5", "--no-verified-search")) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "refused on scene 'thesis'" in err and "cannot promise" in err
    assert not (tmp_path / "a.h5").exists()
    assert m.main(_tol_args(root, invalid, "tol-1e-8", tmp_path / "b.h5")) == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert "no pooled set smaller than the truth (24 modes) meets E <= 1e-08 by simulation" in last
    assert not (tmp_path / "b.h5").exists()
    assert m.main(_tol_args(root, invalid, "tol-1e-40", tmp_path / "c.h5")) == 2     # below the floor
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "below 1e-08, the truth's own error" in err and "tol-1e-08" in err


def test_valid_frozen_chain_keeps_the_a_priori_choice(invalid_scene, tmp_path):
    root, valid, invalid, curve = invalid_scene
    eps = float(f"{np.sqrt(curve[2] * curve[8]):.4g}")
    out = tmp_path / "tol.h5"
    assert m.main(_tol_args(root, valid, f"tol-{eps:g}", out)) == 0
    with h5py.File(out, "r") as f:
        a = dict(f.attrs)
    assert a["tol_method"] == m.TOL_APRIORI and a["tol_frozen_chain_valid"] == 1
    assert "tol_search_N" not in a and a["tol_estimate_max"] <= eps


# ------------------------------------------------ the fast-spinning scene (config/scenes/spin.yaml)
def test_spin_scene_spins_at_a_constant_10_rev_per_s_about_x():
    from gimbal_reduction.solver.dynamics import scenes
    s = scenes.load_scene("spin")
    for t in np.linspace(0.0, s.duration, 7):
        assert np.allclose(s.case.angular_velocity(t), [20 * np.pi, 0.0, 0.0], rtol=0, atol=1e-12)
        assert not np.any(s.case.angular_acceleration(t))
    assert s.initial_rates == (0.0, 0.0, 0.0, 0.0) and s.duration == 0.015


REAL_BODIES = [os.path.join(ROOT, "results", "modes", f"body{b}.h5") for b in BODIES]


@pytest.mark.skipif(not all(os.path.exists(p) for p in REAL_BODIES), reason="no real body files (snakemake modes)")
def test_spin_scene_is_outside_the_frozen_chain_on_the_real_bodies():
    """The rigid chain through `spin` (what gimbal_reduction.reduction.load_aware records as the validity): the
    gimbals swing far beyond FROZEN_ANGLE, so tol-EPS there is a verified search, not a promise."""
    from gimbal_reduction.reduction import load_aware as la
    from gimbal_reduction.solver.dynamics import scenes
    body_data = {b: m.load_body_file(p) for b, p in zip(BODIES, REAL_BODIES)}
    rigid = m.build_chain(m.ModelSpec("rigid", {b: np.zeros(0, int) for b in BODIES}, dict.fromkeys(BODIES, ()),
                                      "freq"), body_data)
    run = la.rigid_run(rigid, scenes.load_scene("spin"))
    excursion = np.max(np.abs(run["y"] - run["y"][0]), axis=0)
    assert np.max(excursion) > 10 * fc.FROZEN_ANGLE
    ok, why = m.frozen_chain_valid({"angle_excursion": excursion, "rate_over_lowest_frequency": 0.0})
    assert not ok and "gimbals move" in why


# ------------------------------------------------ tol-EPS-att-A: the platform attitude too
@pytest.mark.parametrize("name, request_", [("tol-1e-4-att-2", (1e-4, 2.0)), ("tol-0.01-att-0.5", (0.01, 0.5)),
                                            ("tol-1e-6-att-2.5e-1", (1e-6, 0.25)), ("tol-1e-4", (1e-4, None))])
def test_attitude_grammar(name, request_):
    assert names.request(name) == request_
    assert names.parse(name).eps == request_[0] and names.parse(name).attitude == request_[1]
    assert names.needs_load_ranking(name) and names.request("global-40") is None


def test_attitude_request_has_no_a_priori_answer(tmp_path):
    path = tmp_path / "rank.h5"
    _ranking_file(path)
    with pytest.raises(m.AttitudeRequested, match="attitude has no a-priori estimate") as exc:
        m.model_spec("tol-1e-4-att-2", _rankings(path))
    assert "\n" not in str(exc.value) and isinstance(exc.value, m.NeedsSimulation)


def test_attitude_request_is_answered_by_a_verified_search(invalid_scene, tmp_path, capsys):
    """tol-EPS-att-A on a scene where the frozen chain holds: the rates' a-priori choice is only the
    first guess; the answer meets both limits when simulated again, and N - 1 misses one of them."""
    root, valid, invalid, curve = invalid_scene
    eps = float(f"{np.sqrt(curve[2] * curve[8]):.4g}")
    rates = tmp_path / "rates.h5"
    assert m.main(_tol_args(root, valid, f"tol-{eps:g}", rates)) == 0
    with h5py.File(rates, "r") as f:
        n_rates = int(f.attrs["tol_N"])
    _measured(root, valid, f"global-{n_rates}", tmp_path / "r")
    A = float(f"{0.5 * _measured_attitude(tmp_path / 'r', f'global-{n_rates}'):.3g}")     # binds
    out = tmp_path / "tol.h5"
    assert m.main(_tol_args(root, valid, f"tol-{eps:g}-att-{A:g}", out)) == 0
    assert "attitude has no a-priori estimate" in capsys.readouterr().err
    with h5py.File(out, "r") as f:
        a = dict(f.attrs)
    assert a["tol_method"] == m.TOL_VERIFIED and a["tol_frozen_chain_valid"] == 1
    assert a["tol_attitude_arcsec"] == A and a["tol_search_guess"] == n_rates
    N = int(a["tol_N"])
    assert a["tol_measured_attitude_arcsec"] <= A and a["tol_measured_max"] <= eps and N != n_rates
    assert a["tol_search_attitude_arcsec"].shape == a["tol_search_N"].shape
    # the claim, re-simulated by the workflow's stages
    assert _measured(root, valid, f"global-{N}", tmp_path / "a") <= eps
    assert _measured_attitude(tmp_path / "a", f"global-{N}") <= A
    below = _measured(root, valid, f"global-{N - 1}", tmp_path / "b")
    assert below > eps or _measured_attitude(tmp_path / "b", f"global-{N - 1}") > A


def test_a_judge_takes_the_truth_run_its_caller_made():
    """Runs(truth=...): the truth the caller integrated is each judge's truth, global-Q is not
    simulated again (chain_for is never asked for it); without it the judge has no truth yet."""
    from gimbal_reduction.reduction.verified_search import Runs, SimulationJudge
    t = np.linspace(0.0, 1e-3, 11)
    seeded = (t, np.ones((11, 4)), np.tile(np.eye(3), (11, 1, 1)), 1.5)
    asked, lines = [], []
    judge = SimulationJudge("scene", asked.append, 400, key=("tol", "k"), runs=Runs(truth=seeded),
                            log=lines.append)
    assert judge.truth() is seeded and asked == []
    assert "not simulated again" in lines[0]
    assert "truth" not in SimulationJudge("scene", asked.append, 400, key=("tol", "k"), runs=Runs()).runs
