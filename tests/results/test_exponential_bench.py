"""The exponential integrator's speed benchmark (issue 13): its pure helpers and its command line.

Timings are never asserted (they are the benchmark's output).  Checked here: the
medians and ratios on hand-made numbers, the issue's table built from hand-made
cases (met / not met / no reference / failed / a DOP853 ratio not at equal E),
the profile split, the cProfile attribution, the report formats, the one-line
errors of bad input before any work, and one smoke run of the CLI on a small
synthetic chain (no real body files needed).
"""
import csv
import io
import json

import numpy as np
import pytest

from gimbal_reduction.results.bench import exponential as bench
from gimbal_reduction.results.bench.oracle import synthetic_chain
from gimbal_reduction.results.study.tables import RATE_COLUMNS
from gimbal_reduction.solver.dynamics import chainfile, integrators, scenes, simfile, simulate


# ------------------------------------------------------------------ pure helpers
def test_parse_reference_and_references():
    assert bench.parse_reference("thesis=a/b=c.h5") == ("thesis", "a/b=c.h5")
    for bad in ("thesis", "=x.h5", "thesis=", ""):
        with pytest.raises(bench.BenchInputError, match="SCENE=FILE"):
            bench.parse_reference(bad)
    refs = bench.parse_references(["thesis=t.h5", "long=l.h5"], ["thesis", "long"])
    assert refs == {"thesis": "t.h5", "long": "l.h5"}
    with pytest.raises(bench.BenchInputError, match="twice"):
        bench.parse_references(["thesis=a", "thesis=b"], ["thesis"])
    with pytest.raises(bench.BenchInputError, match="not benchmarked"):
        bench.parse_references(["thesis=a", "long=b"], ["thesis"])
    with pytest.raises(bench.BenchInputError, match="thesis=FILE is required"):
        bench.parse_references(["long=b"], ["thesis", "long"])


def test_timing_summary_medians_and_minima():
    samples = [{"read_s": r, "problem_s": 0.1 * r, "integration_s": 2 * r, "end_to_end_s": 3 * r}
               for r in (0.5, 0.1, 0.3, 0.9, 0.2)]
    s = bench.timing_summary(samples)
    assert s["runs"] == 5
    assert s["read_median_s"] == pytest.approx(0.3) and s["read_min_s"] == pytest.approx(0.1)
    assert s["integration_median_s"] == pytest.approx(0.6)
    assert s["end_to_end_median_s"] == pytest.approx(0.9) and s["end_to_end_min_s"] == pytest.approx(0.3)
    with pytest.raises(ValueError, match="no runs"):
        bench.timing_summary([])


def test_speed_ratio_is_the_ratio_of_medians():
    # medians 12 and 0.02 (even count: mean of the middle two); an outlier does not move it
    assert bench.speed_ratio([10.0, 12.0, 14.0, 500.0, 11.0], [0.02, 0.019, 0.021, 3.0, 0.018]) \
        == pytest.approx(12.0 / 0.02)
    assert bench.speed_ratio([4.0, 6.0], [1.0, 3.0]) == pytest.approx(2.5)
    with pytest.raises(ValueError):
        bench.speed_ratio([], [1.0])
    with pytest.raises(ValueError, match="> 0"):
        bench.speed_ratio([1.0], [0.0])


def test_judge_and_reference_prefix_and_duration():
    assert bench.judge(1e-9, "<=", 1e-8) is True and bench.judge(2e-8, "<=", 1e-8) is False
    assert bench.judge(600, ">=", 500) is True and bench.judge(499, ">=", 500) is False
    assert bench.judge(None, "<=", 1.0) is None and bench.judge(float("nan"), "<=", 1.0) is False
    with pytest.raises(ValueError):
        bench.judge(1.0, "<", 2.0)
    ref = {"t": np.linspace(0, 1e-3, 11), "gamma_dot": np.arange(44.0).reshape(11, 4)}
    t, g = bench.reference_prefix(ref, 3e-4)
    assert t.size == 4 and g.shape == (4, 4) and t[-1] == pytest.approx(3e-4)
    thesis = scenes.load_scene("thesis")
    assert bench.bench_duration(thesis, None) == pytest.approx(thesis.duration)
    dt = thesis.output_interval                                            # whole output intervals
    assert bench.bench_duration(thesis, 2.4 * dt) == pytest.approx(2 * dt, rel=1e-9)
    assert bench.bench_duration(thesis, 1.0) == pytest.approx(thesis.duration)


def test_rate_errors_zero_for_identical_rates_and_max_over_rates():
    t = np.linspace(0, 0.015, 31)
    ref = np.column_stack([np.sin(100 * t), np.cos(50 * t), t, 1 + t])
    E, per = bench.rate_errors(t, ref, ref)
    assert E == 0.0 and per.shape == (4,)
    bad = ref.copy()
    bad[:, 2] *= 1.01
    E, per = bench.rate_errors(t, ref, bad)
    assert E == per[2] and E > 0 and per[0] == per[1] == per[3] == 0.0


def _case(scene, status="ok", E=1e-9, integ=0.01, e2e=0.05, model="truth"):
    out = {"scene": scene, "model": model, "status": status}
    if status == "ok":
        out.update(E_max=E, runs=5, steps=37, evaluations=75, relinearisations=0,
                   integration_median_s=integ, end_to_end_median_s=e2e, n_coordinates=404,
                   **{c: (None if E is None else E / (k + 1)) for k, c in enumerate(RATE_COLUMNS)})
    return out


def _comparison(speedup=800.0, e_dop=2e-10, e_exp=1e-9):
    return {"status": "ok", "rtol": 1e-6, "runs": 5, "speedup": speedup, "speedup_end_to_end": speedup / 3,
            "dop853_integration_median_s": 12.0, "exponential_integration_median_s": 12.0 / speedup,
            "dop853_end_to_end_median_s": 12.1, "exponential_end_to_end_median_s": 12.1 * 3 / speedup,
            "E_dop853": e_dop, "E_exponential": e_exp,
            "equal_or_better": e_dop is not None and e_exp is not None and e_dop <= e_exp}


def test_issue_table_judges_every_check():
    cases = {"thesis": _case("thesis", E=2e-9, integ=0.012, e2e=0.2),
             "stress_rates_10": _case("stress_rates_10", status="failed: exponential: t = 0.01 s: lock"),
             "long": _case("long", E=None, e2e=0.8)}
    reduced = [_case("thesis", model="freq-10", e2e=0.03, E=0.2),
               _case("thesis", model="global-100", e2e=0.07, E=0.01)]
    rows = bench.issue_table(cases, _comparison(), reduced)
    met = {r["check"]: r["met"] for r in rows}
    assert [r["check"] for r in rows] == ["thesis_error", "thesis_integration", "thesis_end_to_end",
                                          "dop853_speedup", "fastest_integration", "fastest_speedup",
                                          "stress_error", "stress_end_to_end",
                                          "long_error", "long_end_to_end", "reduced_end_to_end"]
    assert met["thesis_error"] == "yes" and met["thesis_integration"] == "yes"
    assert met["thesis_end_to_end"] == "no"                       # 0.2 s > 0.1 s
    assert met["dop853_speedup"] == "yes"
    assert met["fastest_integration"] == "not run" and met["fastest_speedup"] == "not run"  # no sweep
    assert met["stress_error"].startswith("failed: exponential") and met["stress_end_to_end"].startswith("failed")
    assert met["long_error"] == "no reference" and met["long_end_to_end"] == "goal met"
    assert met["reduced_end_to_end"] == "no"                      # global-100 over 50 ms
    red = rows[-1]
    assert red["value"] == pytest.approx(0.07) and "global-100" in red["measured"]
    assert all(r["source"] == "issue 13, Speed" for r in rows)
    assert {r["target"] for r in rows} == {t["text"] for t in bench.TARGETS.values()}


def test_a_case_at_the_scene_tolerance_says_so():
    """The truth on long runs at the scene's exponential_tolerance (as the workflow runs it); the
    table names that tolerance, and a case at the default does not."""
    at_scene = dict(_case("long", E=1e-8, e2e=6.8), tol=1e-6, scene_tol=True)
    text = bench._measured(at_scene, "long_end_to_end")
    assert "tol 1e-06, the scene's exponential_tolerance" in text
    assert "exponential_tolerance" not in bench._measured(_case("thesis"), "thesis_integration")


def test_dop853_ratio_counts_only_at_equal_or_better_error():
    """A large ratio against a DOP853 run less accurate than the exponential one is not met."""
    cases = {"thesis": _case("thesis")}
    ok = bench.issue_table(cases, _comparison(800.0, 2e-10, 1e-9), [])[3]
    worse = bench.issue_table(cases, _comparison(800.0, 5e-9, 1e-9), [])[3]
    slow = bench.issue_table(cases, _comparison(100.0, 2e-10, 1e-9), [])[3]
    assert (ok["met"], worse["met"], slow["met"]) == ("yes", "no", "no")
    assert "not at equal E" in worse["measured"]
    missing = bench.issue_table(cases, None, [])
    assert missing[3]["met"] == "not run" and missing[6]["met"] == "not run"   # stress case not run
    assert missing[-1]["met"] == "not run"


def test_profile_split_adds_up():
    p = bench.profile_split(0.1, 0.02, 0.025, 0.005, 75, 4e-5)
    assert p["rhs_evaluations_s"] == pytest.approx(0.003)
    assert p["rest_s"] == pytest.approx(0.1 - 0.02 - 0.025 - 0.005 - 0.003)
    parts = ("problem_setup_s", "first_basis_s", "later_bases_s", "rhs_evaluations_s", "rest_s")
    assert sum(p[k] for k in parts) == pytest.approx(p["end_to_end_s"])
    assert sum(p[k.replace("_s", "_share")] for k in parts) == pytest.approx(1.0)
    noisy = bench.profile_split(0.05, 0.02, 0.03, 0.0, 100, 1e-4)     # parts exceed the total
    assert noisy["rest_s"] == pytest.approx(-0.01)
    limits = bench.profile_limits({**p, "read_s": 0.015, "problem_s": 0.005}, 404, 2, 37, 1501,
                                  [{"function": "exponential.py:1(run)", "tottime_s": 0.01, "calls": 1}], 4)
    assert set(limits) == set(parts)
    assert "400" in limits["first_basis_s"] and "75 evaluations" in limits["rhs_evaluations_s"]
    assert "4 frequency updates" in limits["later_bases_s"] and "1 new basis" in limits["later_bases_s"]
    assert "exponential.py:1(run)" in limits["rest_s"]


def test_rest_functions_leave_out_what_only_the_parts_call():
    callers = {"main": {}, "integrate": {"main": 1}, "linearise": {"integrate": 1},
               "eigh": {"linearise": 1}, "lapack": {"eigh": 1}, "rhs": {"integrate": 1},
               "kernel": {"rhs": 1}, "dot": {"rhs": 1, "integrate": 1}, "advance": {"integrate": 1}}
    rest = set(bench.rest_functions(callers, {"linearise", "rhs"}))
    assert rest == {"main", "integrate", "dot", "advance"}


def test_tolerance_sweep_fastest_and_pareto_front():
    """The fastest swept tolerance meeting E <= 1e-8 (not the fastest overall), its own rows beside
    the default's, and the Pareto front of (integration, E)."""
    sweep = [dict(_case("thesis", E=3e-9, integ=0.011), tol=1e-3),
             dict(_case("thesis", E=2e-8, integ=0.009), tol=3e-3),       # fastest, misses E
             dict(_case("thesis", E=2e-9, integ=0.014), tol=1e-4),
             dict(_case("thesis", E=2.5e-9, integ=0.02), tol=3e-5),      # dominated by 1e-4
             dict(_case("thesis", status="failed: boom"), tol=1e-6)]
    fastest = bench.fastest_meeting(sweep)
    assert fastest["tol"] == 1e-3
    assert bench.pareto_front(sweep) == [1e-3, 3e-3, 1e-4]
    assert bench.fastest_meeting([dict(_case("thesis", E=None), tol=1e-3)]) is None
    comp = dict(_comparison(300.0, 2e-10, 3e-9), tol=1e-3)
    rows = bench.issue_table({"thesis": _case("thesis")}, _comparison(), [], fastest, comp)
    met = {r["check"]: r for r in rows}
    assert met["fastest_integration"]["met"] == "yes" and "tol 0.001" in met["fastest_integration"]["measured"]
    assert met["fastest_speedup"]["met"] == "no" and "exponential tol 0.001" in met["fastest_speedup"]["measured"]
    md = bench.format_markdown(rows, {}, None, [], None, {}, {"title": "T"}, sweep)
    assert "| 0.001 (*fastest*) | 11 ms |" in md and "| 1e-06 | failed: boom |" in md


def test_markdown_and_csv_formats():
    cases = {"thesis": _case("thesis"), "stress_rates_10": None, "long": None}
    reduced = [_case("thesis", model="rigid", e2e=0.02, E=2.4), _case("thesis", model="xmx-10",
                                                                      status="failed: boom")]
    for r in reduced:
        r["n_coordinates"] = 4
        r.setdefault("integration_median_s", 0.01)
    table = bench.issue_table(cases, _comparison(), reduced)
    profile = bench.profile_split(0.05, 0.01, 0.015, 0.005, 75, 4e-5)
    limits = {k: f"limit of {k}" for k in ("problem_setup_s", "first_basis_s", "later_bases_s",
                                           "rhs_evaluations_s", "rest_s")}
    md = bench.format_markdown(table, cases, _comparison(), reduced, profile, limits,
                               {"title": "T", "note": "N", "provenance": "P"})
    lines = md.splitlines()
    start = lines.index("| case | target | measured | met? |")
    assert len([ln for ln in lines[start + 2:start + 2 + len(table)] if ln.startswith("| ")]) == len(table)
    assert "| rigid | 4 | 20 ms |" in md and "| xmx-10 | 4 | failed: boom |" in md
    assert "limit of rest_s" in md and md.rstrip().endswith("P")
    rows = [dict(_case("thesis"), case="thesis: truth", method="exponential", reference="r.h5")]
    parsed = list(csv.DictReader(io.StringIO(bench.format_csv(rows))))
    assert tuple(parsed[0]) == bench.CSV_COLUMNS
    assert float(parsed[0]["E_max"]) == pytest.approx(1e-9) and parsed[0]["rtol"] == ""


# ------------------------------------------------------------------ command line
def _args(tmp_path, *extra, truth=None):
    return ["--truth-model", str(truth or tmp_path / "missing.h5"),
            "--out-json", str(tmp_path / "e.json"), "--out-md", str(tmp_path / "e.md"),
            "--out-csv", str(tmp_path / "e.csv"), *extra]


@pytest.mark.parametrize("extra, message", [
    (["--reference", "thesis=x.h5", "--repeats", "0"], "--repeats must be >= 1"),
    (["--reference", "thesis"], "SCENE=FILE"),
    (["--reference", "thesis=x.h5", "long=y.h5", "--scenes", "thesis"], "not benchmarked"),
    (["--reference", "long=y.h5"], "thesis=FILE is required"),
    (["--reference", "thesis=x.h5", "--tol", "-1"], "--tol must be a positive finite number"),
    (["--reference", "thesis=x.h5", "--tol", "nan"], "--tol must be a positive finite number"),
    (["--reference", "thesis=x.h5", "--scenes", "nowhere"], "invalid choice"),
    (["--reference", "thesis=x.h5"], "missing.h5: reduced-model file not found"),
])
def test_bad_input_is_one_line_before_any_work(tmp_path, capsys, extra, message):
    assert bench.main(_args(tmp_path, *extra)) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not any(tmp_path.glob("e.*"))


@pytest.fixture(scope="module")
def synthetic_files(tmp_path_factory):
    """A small synthetic chain as a 'truth' reduced-model file, and its converged DOP853 run of
    the first 0.2 ms of scene thesis as the reference."""
    folder = tmp_path_factory.mktemp("exponential_bench")
    chain, _ = synthetic_chain(seed=1)
    model = folder / "truth.h5"
    chainfile.write_chain(model, chain, {b.number: np.arange(b.n_modes) for b in chain.bodies},
                          {b.number: () for b in chain.bodies},
                          {"model": "truth", "scene": "thesis", "config_hash": "synthetic"})
    scene = scenes.load_scene("thesis")
    chain, _ = chainfile.read_chain(model, scene.damping_ratio)
    prob = simulate.scene_problem(chain, scene)
    run = integrators.integrate(prob, 2e-4, scene.output_interval, method="dop853", rtol=1e-10, atol=1e-14)
    ref = folder / "reference.h5"
    simfile.write_sim(ref, run, simulate.energy_history(prob, run),
                      {"scene": "thesis", "model": "truth", "integrator": "dop853",
                       "model_config_hash": "synthetic"})
    return model, ref


@pytest.mark.parametrize("method, options, attrs, message", [
    ("dop853", {"rtol": 1e-10, "atol": 1e-14}, {"model_config_hash": "elsewhere"},
     "made from another truth model"),
    ("exponential", {}, {"integrator": "exponential"},
     "ran the exponential integrator at tol 1e-05, looser than the scene's 1e-05 / 100"),
    ("rk4", {}, {"integrator": "rk4"}, "is a rk4 run, not the converged dop853"),
    ("dop853", {"rtol": 1e-8, "atol": 1e-14}, {"integrator": "dop853"}, "ran at rtol 1e-08, looser"),
    ("dop853", {"rtol": 1e-10, "atol": 1e-14}, {"scene": "free"}, "is a run of scene 'free'"),
])
def test_a_reference_that_cannot_referee_is_refused(tmp_path, capsys, synthetic_files, method, options,
                                                     attrs, message):
    """Another model, another integrator, a loose rtol or tolerance (the exponential integrator is a
    reference 100 times tighter than the scene only), another scene: one line, nothing written."""
    model, _ = synthetic_files
    scene = scenes.load_scene("thesis")
    chain, _ = chainfile.read_chain(model, scene.damping_ratio)
    prob = simulate.scene_problem(chain, scene)
    run = integrators.integrate(prob, 2e-5, scene.output_interval, method=method, **options)
    other = tmp_path / "other.h5"
    simfile.write_sim(other, run, simulate.energy_history(prob, run),
                      {"scene": "thesis", "model": "truth", "model_config_hash": "synthetic", **attrs})
    assert bench.main(_args(tmp_path, "--reference", f"thesis={other}", "--scenes", "thesis",
                            truth=model)) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not any(tmp_path.glob("e.*"))


def test_cli_smoke_on_a_synthetic_chain(tmp_path, synthetic_files):
    """--duration 0.2 ms, one run per case: the three files are written and consistent."""
    model, ref = synthetic_files
    assert bench.main(_args(tmp_path, "--reference", f"thesis={ref}", "--scenes", "thesis",
                            "--models", str(model), "--repeats", "1", "--duration", "2e-4",
                            "--sweep-tols", "1e-4", truth=model)) == 0
    data = json.loads((tmp_path / "e.json").read_text())
    assert len(data["table"]) == len(bench.TARGETS) and data["targets"] == bench.TARGETS
    thesis = data["truth_cases"]["thesis"]
    assert thesis["status"] == "ok" and thesis["runs"] == 1 and thesis["E_max"] < 1e-6
    # set-up (read, problem, initial basis) + integration (the rest of the run) = end to end, up to
    # the little between the timers (the Run's assembly)
    assert 0 < thesis["setup_median_s"] and 0 < thesis["integration_median_s"]
    assert thesis["setup_median_s"] + thesis["integration_median_s"] \
        <= thesis["end_to_end_median_s"] * (1 + 1e-9)
    assert thesis["integration_median_s"] == \
        pytest.approx(thesis["run_median_s"] - thesis["first_basis_median_s"])
    comp = data["dop853_comparison"]
    assert comp["status"] == "ok" and comp["speedup"] > 0 and comp["E_dop853"] is not None
    assert comp["speedup_end_to_end"] > 0
    assert data["profile"]["evaluations"] == thesis["evaluations"] and data["profile"]["cprofile_top"]
    assert data["config_hash"] and data["versions"]["git"]
    md = (tmp_path / "e.md").read_text()
    assert "| truth on `stress_rates_10` | E ≤ 1e-8 | not run | not run |" in md
    assert "--duration" in md
    rows = list(csv.DictReader(io.StringIO((tmp_path / "e.csv").read_text())))
    swept = data["tolerance_sweep"]
    assert [c["tol"] for c in swept["cases"]] == [1e-4] and swept["cases"][0]["status"] == "ok"
    compared = ["dop853", "exponential"] if swept["fastest_meeting_E_1e-8"] == 1e-4 else []
    assert [r["method"] for r in rows] == ["exponential", "dop853", "exponential", "exponential",
                                           *compared, "exponential"]


# ------------------------------------------------------------------ DOP853 over a prefix
def test_prefix_summary_puts_the_whole_run_on_the_line_through_the_two_medians():
    """First interval 0.1 s for 8 steps, prefix 1.0 s for 100 steps: a run of 1000 steps takes
    0.1 + 0.9 * 992 / 92 s (the fixed cost once); read, problem and set-up stay as measured."""
    def sample(integration, read=0.01):
        return {"read_s": read, "problem_s": 0.02, "first_basis_s": 0.0, "later_bases_s": 0.0,
                "run_s": integration, "setup_s": read + 0.02, "integration_s": integration,
                "end_to_end_s": read + 0.02 + integration}
    firsts = [sample(0.1), sample(0.3), sample(0.1)]
    prefixes = [sample(1.0), sample(1.2), sample(0.9, read=0.03)]
    out = bench.prefix_summary(firsts, 8, prefixes, 100, 1000)
    assert out["integration_median_s"] == pytest.approx(0.1 + 0.9 * 992 / 92, rel=1e-12)
    assert out["integration_min_s"] == pytest.approx(0.1 + 0.8 * 992 / 92, rel=1e-12)
    assert out["end_to_end_median_s"] == pytest.approx(0.13 + 0.9 * 992 / 92, rel=1e-12)
    assert out["read_median_s"] == pytest.approx(0.01) and out["runs"] == 3
    assert out["time_basis"] == "extrapolated from 100 and 8 of 1000 steps"


def _untimed_csv(path, E, steps, wall, status="ok", integrator="dop853-1e-06"):
    cols = ["model", "integrator", "steps", "wall_time_s", "E", *RATE_COLUMNS, "status"]
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        w.writerow(["load-10", integrator, 9, 0.5, 0.04, 0.04, 0.0, 0.0, 0.0, "ok"])
        w.writerow(["truth", integrator, steps, wall, E, E, E / 2, E / 3, E / 4, status])
    return path


def test_an_untimed_dop853_run_that_cannot_serve_is_one_line(tmp_path):
    ref = {"path": "r.h5", "attrs": {}}
    with pytest.raises(bench.BenchInputError, match="no row of the truth with dop853-1e-08"):
        bench.read_untimed_dop853(_untimed_csv(tmp_path / "a.csv", 1e-11, 100, 2.0), 1e-8, ref)
    with pytest.raises(bench.BenchInputError, match="status 'failed: diverged'"):
        bench.read_untimed_dop853(_untimed_csv(tmp_path / "b.csv", 1e-11, 100, 2.0, "failed: diverged"),
                                  1e-6, ref)
    with pytest.raises(bench.BenchInputError, match="file not found"):
        bench.read_untimed_dop853(str(tmp_path / "none.csv"), 1e-6, ref)
    got = bench.read_untimed_dop853(_untimed_csv(tmp_path / "c.csv", 1e-11, 100, 2.0), 1e-6, ref)
    assert (got["E_max"], got["steps"], got["wall_time_s"], got["reference"]) == (1e-11, 100, 2.0, ref)


@pytest.mark.parametrize("E_untimed, better", [(0.0, True), (1.0, False)])
def test_cli_times_dop853_over_a_prefix_and_takes_the_untimed_runs_error(tmp_path, synthetic_files,
                                                                       E_untimed, better):
    """A budget no whole DOP853 run fits: DOP853 is timed over a prefix (two output intervals)
    and scaled to the untimed run's steps; its E is the untimed run's, so an untimed E worse
    than the exponential run's fails the ratio check whatever the speed-up."""
    model, ref = synthetic_files
    untimed = _untimed_csv(tmp_path / "u.csv", E_untimed, 400, 5.0)
    assert bench.main(_args(tmp_path, "--reference", f"thesis={ref}", "--scenes", "thesis",
                            "--repeats", "1", "--duration", "2e-4", "--sweep-tols", "--budget", "1e-6",
                            "--dop853-untimed", str(untimed), str(ref), truth=model)) == 0
    data = json.loads((tmp_path / "e.json").read_text())
    comp = data["dop853_comparison"]
    assert comp["dop853_time_basis"].startswith("extrapolated from ") and comp["dop853_time_basis"].endswith(
        " of 400 steps")
    assert comp["E_dop853"] == E_untimed and comp["dop853_steps"] == 400
    assert comp["E_reference"].endswith(f"({ref})")
    assert comp["equal_or_better"] is better
    row = next(r for r in data["table"] if r["check"] == "dop853_speedup")
    assert row["met"] == ("yes" if better and comp["speedup"] >= 500 else "no")
    assert "extrapolated from" in row["measured"]
    assert ("not at equal E" in row["measured"]) is not better
    rows = list(csv.DictReader(io.StringIO((tmp_path / "e.csv").read_text())))
    dop = next(r for r in rows if r["method"] == "dop853")
    assert dop["time_basis"].startswith("extrapolated") and int(dop["steps"]) == 400


# ------------------------------------------------------------------ a truth case from the workflow's runs
@pytest.fixture(scope="module")
def study_run(synthetic_files, tmp_path_factory):
    """The synthetic truth's exponential run over the first 0.2 ms of thesis, as a study file."""
    model, _ = synthetic_files
    scene = scenes.load_scene("thesis")
    chain, _ = chainfile.read_chain(model, scene.damping_ratio)
    prob = simulate.scene_problem(chain, scene)
    run = integrators.integrate(prob, 2e-4, scene.output_interval, method="exponential", tol=1e-5)
    path = tmp_path_factory.mktemp("study_run") / "truth.h5"
    simfile.write_sim(path, run, simulate.energy_history(prob, run),
                      {"scene": "thesis", "model": "truth", "integrator": "exponential",
                       "model_config_hash": "synthetic", "steps": run.steps})
    return simfile.read_sim(path), chain.n_coordinates, scene


def _runtime(n, scene="thesis", integrator="exponential"):
    return {"scene": scene, "integrator": integrator, "path": "runtime.json",
            "models": {"truth": {"coordinates": n, "run_ms_all": [90.0, 80.0, 100.0, 85.0, 95.0],
                                 "setup_ms_all": [2.0, 1.0, 3.0, 1.0, 2.0]}}}


def test_a_truth_case_from_the_runtime_benchmark_and_the_study_run(synthetic_files, study_run):
    """Times: the runtime benchmark's medians (end to end = set-up + run); E: the study file's rates
    against the reference (the exponential run at tol 1e-5 on 0.2 ms: far below 1e-6)."""
    _, ref = synthetic_files
    sim, n, scene = study_run
    case = bench.case_from_runs("thesis", scene, _runtime(n), sim, {"config_hash": "synthetic"}, n,
                                {"tol": 1e-5}, simfile.read_sim(ref), 2e-4)
    assert case["status"] == "ok" and case["runs"] == 5 and case["steps"] == int(sim["attrs"]["steps"])
    assert case["end_to_end_median_s"] == pytest.approx(0.092)          # median of (run + set-up)
    assert case["setup_median_s"] + case["integration_median_s"] == pytest.approx(case["end_to_end_median_s"])
    assert 0 <= case["E_max"] < 1e-6 and "runtime benchmark's 5 whole runs" in case["time_basis"]
    table = bench.issue_table({"thesis": case}, None, [])
    assert all("not run here: the runtime benchmark's 5 whole runs" in r["measured"] for r in table[:3])


@pytest.mark.parametrize("runtime, truth_hash, tol, message", [
    ({"scene": "long"}, "synthetic", 1e-5, "has no timed truth of thesis"),
    ({"integrator": "rk4"}, "synthetic", 1e-5, "has no timed truth of thesis"),
    ({}, "elsewhere", 1e-5, "model_config_hash"),
    ({}, "synthetic", 5e-7, "stat_exponential_tol"),
])
def test_a_truth_case_from_runs_of_another_setting_is_refused(study_run, runtime, truth_hash, tol, message):
    sim, n, scene = study_run
    with pytest.raises(bench.BenchInputError, match=message):
        bench.case_from_runs("thesis", scene, {**_runtime(n), **runtime}, sim, {"config_hash": truth_hash}, n,
                             {"tol": tol}, None, 2e-4)
