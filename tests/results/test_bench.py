"""Benchmarks of issue 6: the dense baseline, the growth-law fit, the Pareto front, the CLIs.

Timings are never asserted (they are the benchmarks' output, machine-dependent);
what is checked is that the baseline computes the same accelerations as the
structured solver, that the helpers compute what they claim on hand-made
input, and that the CLIs write well-formed files.
"""
import csv
import json
import os

import numpy as np
import pytest

from gimbal_reduction.results.bench import pareto, scaling
from gimbal_reduction.solver.dynamics import compiled, dense_baseline, integrators, multibody
from gimbal_reduction.results.bench.oracle import synthetic_chain

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
REAL = {"truth": os.path.join(ROOT, "results", "sim", "thesis", "truth.h5"),
        "modes": os.path.join(ROOT, "results", "modes", "body5.h5"),
        "reduction": os.path.join(ROOT, "results", "reduction", "body5.h5")}
REAL_FILES = ["--bodies", *[os.path.join(ROOT, "results", "modes", f"body{b}.h5") for b in (2, 3, 4, 5)],
              "--reductions", *[os.path.join(ROOT, "results", "reduction", f"body{b}.h5") for b in (2, 3, 4, 5)]]
needs_real = pytest.mark.skipif(not all(os.path.exists(p) for p in REAL.values()),
                                reason="real body, reduction and truth files absent (snakemake dynamics)")

CASE = multibody.CaseMotion(amplitude=(1.0, 0.3, -0.2), frequency=(2.0, 1.0, 0.0), omega0=(0.1, 0.0, 0.2))
TORQUE = np.array([0.1, 0.0, -0.2, 0.05])


def rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def random_state(chain, rng, q_scale):
    n = chain.n_coordinates
    return (np.concatenate([rng.uniform(-3, 3, 4), q_scale * rng.normal(size=n - 4)]),
            rng.normal(size=n))


# ------------------------------------------------------------------ dense baseline
@pytest.mark.parametrize("seed", [0, 3, 7])
def test_dense_baseline_matches_structured_rhs(seed):
    """Same accelerations as compiled.make_rhs to 1e-10 relative, case motion, torques and
    damping on; physical (small) modal amplitudes, so the Cholesky path runs."""
    chain, _ = synthetic_chain(seed=seed, n_modes=(4, 3, 3, 2), damping_ratio=0.02)
    structured = compiled.make_rhs(chain, CASE, TORQUE)
    dense = dense_baseline.make_dense_rhs(chain, CASE, TORQUE)
    rng = np.random.default_rng(seed + 10)
    for t in (0.0, 0.37):
        y, yd = random_state(chain, rng, 1e-4)
        assert rel(dense(t, y, yd), structured(t, y, yd)) < 1e-10
    assert dense.stats["lu_fallbacks"] == 0


def test_dense_mass_matrix_is_the_reference_one():
    """The composite assembly equals multibody.mass_matrix (NumPy, column by column) and the
    column assembly; both symmetric."""
    chain, _ = synthetic_chain(seed=2)
    y, _ = random_state(chain, np.random.default_rng(0), 0.01)
    ref = multibody.mass_matrix(chain, y)
    M = dense_baseline.make_dense_rhs(chain).mass_matrix(y)
    Mc = dense_baseline.make_dense_rhs(chain, assembly="columns").mass_matrix(y)
    assert rel(M, ref) < 1e-12 and rel(M, M.T) < 1e-14
    assert rel(Mc, ref) < 1e-9


def test_dense_baseline_falls_back_to_lu_when_not_positive_definite():
    """At unphysically large q the first-order M(y) is indefinite: LU takes over, and the
    answer is still the structured one."""
    chain, _ = synthetic_chain(seed=4, damping_ratio=0.01)
    rng = np.random.default_rng(1)
    structured = compiled.make_rhs(chain, CASE, TORQUE)
    dense = dense_baseline.make_dense_rhs(chain, CASE, TORQUE)
    indefinite = 0
    for _ in range(4):
        y, yd = random_state(chain, rng, 0.02)
        indefinite += np.linalg.eigvalsh(multibody.mass_matrix(chain, y))[0] < 0
        assert rel(dense(0.3, y, yd), structured(0.3, y, yd)) < 1e-10
    assert indefinite > 0 and dense.stats["lu_fallbacks"] == indefinite


def test_dense_rk4_loop_matches_compiled_loop():
    chain, _ = synthetic_chain(seed=1)
    y0, yd0 = random_state(chain, np.random.default_rng(5), 1e-4)
    h = 0.2 * integrators.rk4_stability_limit(400.0 * 3)
    a = dense_baseline.make_dense_rhs(chain, CASE, TORQUE).rk4_steps(y0, yd0, 0.1, h, 20)
    b = compiled.make_rhs(chain, CASE, TORQUE).rk4_steps(y0, yd0, 0.1, h, 20)
    assert rel(a[1], b[1]) < 1e-10 and rel(a[0], b[0]) < 1e-12


def test_dense_baseline_rejects_unknown_assembly():
    chain, _ = synthetic_chain(seed=0)
    with pytest.raises(ValueError, match="unknown assembly"):
        dense_baseline.make_dense_rhs(chain, assembly="sparse")


def test_synthetic_modal_bodies_are_valid_and_agree():
    """scaling's random modal integrals: Hughes bound, antisymmetric G, SPD M(y) at the
    timing state, and dense = structured there."""
    chain = scaling.synthetic_modal_chain(12, seed=3)
    for b in chain.bodies:
        B = b.momentum
        assert np.linalg.eigvalsh(b.rigid_mass - B @ B.T).min() > 0
        assert np.allclose(b.coriolis, -b.coriolis.transpose(2, 1, 0))
    y, yd = scaling.timing_state(chain)
    dense = dense_baseline.make_dense_rhs(chain, scaling.CASE)
    assert np.linalg.eigvalsh(dense.mass_matrix(y)).min() > 0
    structured = compiled.make_rhs(chain, scaling.CASE)
    assert rel(dense(0.01, y, yd), structured(0.01, y, yd)) < 1e-10


# ------------------------------------------------------------------ pure helpers
def test_fit_power_law_recovers_known_exponent():
    x = np.array([100.0, 200.0, 400.0, 800.0, 1600.0])
    p, a = scaling.fit_power_law(x, 3e-9 * x ** 2.7)
    assert p == pytest.approx(2.7, abs=1e-12) and a == pytest.approx(3e-9, rel=1e-9)
    noisy = 3e-9 * x ** 1.5 * np.exp(np.random.default_rng(0).normal(scale=0.02, size=x.size))
    assert scaling.fit_power_law(x, noisy)[0] == pytest.approx(1.5, abs=0.05)
    with pytest.raises(ValueError, match=">= 2 positive points"):
        scaling.fit_power_law([100.0, 200.0], [1.0, -1.0])


def test_growth_laws_use_the_large_n_range_only():
    rows = [{"n_elastic": s, "structured_eval_s": 1e-6 * s ** 2, "dense_eval_s": 1e-8 * s ** 3}
            for s in (20, 100, 200, 400, 800)]
    rows[0]["structured_eval_s"] = 1.0          # a small-size outlier outside the fit range
    fits = scaling.growth_laws(rows, min_elastic=200)
    assert fits["structured"]["exponent"] == pytest.approx(2.0)
    assert fits["dense"]["exponent"] == pytest.approx(3.0)
    assert fits["structured"]["n_elastic"] == [200, 400, 800]
    assert "columns" not in fits


def test_pareto_mask_on_hand_made_points():
    #            a     b     c     d     e     f      g
    cost = [1.0, 2.0, 3.0, 2.5, 5.0, 0.5, np.nan]
    err = [1e-1, 1e-3, 1e-3, 1e-2, 1e-6, 1.0, 1e-9]
    # a, b, e, f are optimal; c ties b's error at a higher cost; d is beaten by b; g has no time
    assert pareto.pareto_mask(cost, err).tolist() == [True, True, False, False, True, True, False]


def test_run_budget():
    assert pareto.run_budget(1.0, 5, 20.0) == 5
    assert pareto.run_budget(6.0, 5, 20.0) == 3
    assert pareto.run_budget(50.0, 5, 20.0) == 1


def test_max_rate_error_is_eq_353_maximum():
    t = np.linspace(0.0, 1.0, 201)
    ref = np.column_stack([np.sin(2 * np.pi * t) + k for k in range(1, 5)])
    red = ref * np.array([1.0, 1.01, 1.1, 1.0])
    E, per = pareto.max_rate_error(t, ref, red)
    assert per[0] == 0.0 and per[3] == 0.0
    assert per[1] == pytest.approx(1e-4, rel=1e-9) and E == pytest.approx(1e-2, rel=1e-9)


def test_model_family():
    assert pareto.model_family("freq-10") == "freq"
    assert pareto.model_family("static-xmx-8") == "static-xmx"
    assert pareto.model_family("truth") == "truth"
    assert pareto.model_family("load-10") == "load"
    assert pareto.model_family("global-8") == "global"


# ------------------------------------------------------------------ CLIs
def test_scaling_cli_quick(tmp_path):
    out = {k: tmp_path / f"scaling.{k}" for k in ("csv", "json", "png")}
    rc = scaling.main(["--quick", "--repeats", "2", "--out-csv", str(out["csv"]),
                       "--out-json", str(out["json"]), "--figure", str(out["png"])])
    assert rc == 0 and all(p.stat().st_size > 0 for p in out.values())
    rows = list(csv.DictReader(out["csv"].open()))
    assert [int(r["n_elastic"]) for r in rows] == [4 * d for d in scaling.QUICK_SIZES]
    for r in rows:
        assert float(r["structured_eval_s"]) > 0 and float(r["dense_eval_s"]) > 0
        assert float(r["agreement"]) < 1e-10
        assert float(r["speedup_eval"]) == pytest.approx(
            float(r["dense_eval_s"]) / float(r["structured_eval_s"]), rel=1e-4)
    data = json.loads(out["json"].read_text())
    assert {"structured", "dense"} <= set(data["growth_laws"])
    assert data["assumptions"]["coupled_ratio"] == scaling.COUPLED_RATIO


def test_scaling_cli_bad_argument(capsys):
    with pytest.raises(SystemExit) as exc:
        scaling.main(["--out-csv", "a", "--out-json", "b", "--figure", "c", "--sizes", "0"])
    assert exc.value.code == 2
    assert capsys.readouterr().err.count("\n") == 1


@needs_real
def test_pareto_cli_quick(tmp_path):
    csv_path, png = tmp_path / "pareto.csv", tmp_path / "pareto.png"
    rc = pareto.main(["--quick", "--truth", REAL["truth"], "--models", "freq-2", "--repeats", "2",
                      "--rk4-fractions", "1", "--rtols", "1e-6", "--galpha-steps", "1e-5",
                      "--exp-tols", "5e-6",
                      "--out-csv", str(csv_path), "--figure", str(png), *REAL_FILES])
    assert rc == 0 and png.stat().st_size > 0
    rows = list(csv.DictReader(csv_path.open()))
    assert {(r["model"], r["integrator"], r["solver"]) for r in rows} == {
        (m, i, "structured") for m in ("freq-2", "truth")
        for i in ("exp-5e-06", "rk4-1", "dop853-1e-06", "galpha-1e-05")
    } | {("truth", "rk4-1", "dense-composite")}
    ok = [r for r in rows if r["status"] == "ok"]
    assert len(ok) == len(rows) and any(r["pareto"] == "1" for r in rows)
    dense = next(r for r in rows if r["solver"] == "dense-composite")
    truth_rk4 = next(r for r in rows if r["model"] == "truth" and r["integrator"] == "rk4-1"
                     and r["solver"] == "structured")
    assert float(dense["deviation"]) < 1e-8 and float(dense["speedup"]) > 1
    assert float(dense["E"]) == pytest.approx(float(truth_rk4["E"]), rel=1e-6)
    # the front is exactly the non-dominated rows
    t = np.array([float(r["wall_time_s"]) for r in ok])
    E = np.array([float(r["E"]) for r in ok])
    for r, ti, ei in zip(ok, t, E):
        dominated = np.any((t <= ti) & (E <= ei) & ((t < ti) | (E < ei)))
        assert (r["pareto"] == "1") == (not dominated)
    assert json.loads((tmp_path / "pareto.json").read_text())["dense_comparison"][0]["steps"] > 0


@needs_real
def test_pareto_split_takes_the_untimed_errors_and_times_alone(tmp_path, capsys):
    """--errors-only (one untimed run per setting) then --errors-from (the timing): the rows keep the
    untimed run's E and steps; 5 runs each, a slow setting over a prefix scaled by its steps; a
    setting missing from the untimed CSV is a one-line error."""
    common = ["--duration", "2e-4", "--dense-duration", "1e-4", "--columns-duration", "0",
              "--truth", REAL["truth"], "--models", "freq-2", "--rk4-fractions", "1",
              "--rtols", "1e-6", "--galpha-steps", "1e-5", "--exp-tols", "5e-6", *REAL_FILES]
    errors = tmp_path / "errors.csv"
    assert pareto.main([*common, "--errors-only", "--out-csv", str(errors)]) == 0
    untimed = {(r["model"], r["integrator"]): r for r in csv.DictReader(errors.open())}
    assert {r["time_basis"] for r in untimed.values()} == {"one run, not timed alone"}
    out = tmp_path / "pareto.csv"
    assert pareto.main([*common, "--repeats", "5", "--budget", "0.05", "--errors-from", str(errors),
                        "--out-csv", str(out), "--figure", str(tmp_path / "p.png")]) == 0
    rows = [r for r in csv.DictReader(out.open()) if r["solver"] == "structured"]
    assert {(r["model"], r["integrator"]) for r in rows} == set(untimed)
    for r in rows:
        u = untimed[(r["model"], r["integrator"])]
        assert r["E"] == u["E"] and r["steps"] == u["steps"] and r["runs"] == "5"
        assert r["time_basis"] == "measured" or r["time_basis"].startswith("extrapolated from ")
    assert any(r["time_basis"] != "measured" for r in rows)       # the truth's DOP853 at least
    capsys.readouterr()
    short = tmp_path / "short.csv"
    short.write_text("".join(line for line in errors.open() if "dop853" not in line))
    assert pareto.main([*common, "--errors-from", str(short), "--out-csv", str(tmp_path / "x.csv"),
                        "--figure", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert "dop853-1e-06" in err and err.count("\n") == 1


@needs_real
def test_pareto_cli_bad_model(tmp_path, capsys):
    rc = pareto.main(["--quick", "--truth", REAL["truth"], "--models", "freq-x",
                      "--out-csv", str(tmp_path / "p.csv"), "--figure", str(tmp_path / "p.png"), *REAL_FILES])
    assert rc == 2 and "freq-x" in capsys.readouterr().err
    assert not (tmp_path / "p.csv").exists()


def test_pareto_cli_missing_truth(tmp_path, capsys):
    rc = pareto.main(["--truth", str(tmp_path / "none.h5"), "--out-csv", str(tmp_path / "p.csv"),
                      "--figure", str(tmp_path / "p.png"), *REAL_FILES])
    err = capsys.readouterr().err
    assert rc == 2 and "none.h5" in err and err.count("\n") == 1


def test_time_interleaved_runs_every_function_in_batches():
    calls = {"a": 0, "b": 0}

    def bump(k):
        calls[k] += 1
    res = scaling.time_interleaved({"a": (lambda: bump("a"), 1), "b": (lambda: bump("b"), 4)},
                                   repeats=3, batch_seconds=1e-4)
    assert set(res) == {"a", "b"}
    for k in ("a", "b"):
        med, low, spread = res[k]
        assert 0 < low <= med and spread >= 0
        assert (calls[k] - 1) % 3 == 0 and calls[k] >= 4      # calibration call + 3 equal batches
