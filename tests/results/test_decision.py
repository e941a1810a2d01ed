"""The decision table and the truth's resolution (gimbal_reduction.results.study.decision).

Synthetic tables: E per rate and attitude per model are chosen, so every expected answer is
worked out by hand here (RMS error = sqrt(E) x RMS rate; bounds by the triangle inequality)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from gimbal_reduction.results.study import decision
from gimbal_reduction.results.study.tables import RATE_COLUMNS

RMS = np.array([2.0, 1.0, 0.5, 0.5])          # rad/s, the truth's RMS rates


def row(model, n_elastic, E, attitude):
    E = np.broadcast_to(np.asarray(E, float), (4,))
    return {"model": model, "n_elastic": n_elastic, "attitude_max_arcsec": attitude,
            **{c: float(e) for c, e in zip(RATE_COLUMNS, E)}}


def scene_rows(rigid_E=1e-1, check_E=1e-6):
    """truth, its check, rigid and three reduced models of increasing size and accuracy."""
    return [row("truth", 400, 0.0, 0.0), row("static-100", 404, check_E, 0.01),
            row("rigid", 0, rigid_E, 500.0), row("freq-5", 20, 1e-2, 50.0),
            row("xmx-10", 40, 1e-4, 5.0), row("global-100", 100, 1e-5, 0.5)]


def test_resolution_is_the_larger_check_per_rate():
    rows = scene_rows(check_E=[1e-6, 1e-3, 1e-6, 1e-6])
    res = decision.resolution(rows, {"E": [1e-4, 1e-5, 1e-5, 1e-5], "attitude_max_arcsec": 0.2}, RMS)
    assert res["E_per_rate"] == pytest.approx([1e-4, 1e-3, 1e-5, 1e-5])
    assert res["E"] == pytest.approx(1e-3)
    assert res["attitude"] == pytest.approx(0.2)
    assert res["rate_per_rate"][1] == pytest.approx(math.sqrt(1e-3) * 1.0)
    assert res["sources"] == ["static-100", "freq-200"]


def test_rate_rms_of_a_sine():
    t = np.linspace(0.0, 1.0, 20001)
    gd = np.stack([3.0 * np.sin(2 * np.pi * 5 * t)] * 4, axis=1)
    assert decision.rate_rms(t, gd) == pytest.approx(np.full(4, 3.0 / math.sqrt(2)), rel=1e-6)


def test_must_say_not_resolvable_when_the_truth_error_exceeds_the_difference():
    """The long scene's case: the truth's own error (2.29e-3) above the rigid model's E (1.11e-3)."""
    assert not decision.resolvable(1.11e-3, 0.0, 2.29e-3)
    rows = scene_rows(rigid_E=1.11e-3)
    res = decision.resolution(rows, {"E": [2.29e-3] * 4, "attitude_max_arcsec": 1.0}, RMS)
    assert not decision.rate_resolved(rows, 0, res["E_per_rate"][0])
    b = decision.best(rows, 0, res["E_per_rate"][0])
    assert b["status"] == decision.NOT_RESOLVABLE and "rigid" in b["ties"]
    findings = [{"finding": 8, "verdict": "reproduced", "reason": "",
                 "verdict_per_rate": dict.fromkeys(("outer", "middle", "inner", "platform"), "reproduced")}]
    out = decision.resolve_findings(findings, rows, res)[0]
    assert out["verdict"] == decision.NOT_RESOLVABLE
    assert set(out["verdict_per_rate"].values()) == {decision.NOT_RESOLVABLE}
    # a requirement below the resolution: no model, "not resolvable"
    c = decision.choose("E", 1e-4, rows, RMS, res)
    assert c["status"] == decision.NOT_RESOLVABLE and c["model"] is None
    assert decision.cell(1e-3, 2.29e-3) == decision.NOT_RESOLVABLE


def test_must_not_say_not_resolvable_when_the_difference_exceeds_the_truth_error():
    """The thesis scene's case: rigid E ~ 0.1 against a resolution of 6.9e-4."""
    assert decision.resolvable(1e-1, 0.0, 6.9e-4)
    rows = scene_rows(rigid_E=1e-1)
    res = decision.resolution(rows, {"E": [6.9e-4] * 4, "attitude_max_arcsec": 0.3}, RMS)
    assert decision.rate_resolved(rows, 0, res["E_per_rate"][0])
    findings = [{"finding": 8, "verdict": "reproduced", "reason": "",
                 "verdict_per_rate": dict.fromkeys(("outer", "middle", "inner", "platform"), "reproduced")}]
    assert decision.resolve_findings(findings, rows, res)[0]["verdict"] == "reproduced"
    assert decision.cell(1e-1, 6.9e-4) == pytest.approx(1e-1)
    c = decision.choose("E", 1e-1, rows, RMS, res)
    assert c["status"] == "met"


def test_best_is_resolved_only_when_no_other_model_is_within_the_resolution():
    rows = scene_rows()
    # global-100 (1e-5) against xmx-10 (1e-4): sqrt differ by 6.8e-3; with E_res 1e-6 (1e-3) resolved
    assert decision.best(rows, 0, 1e-6)["status"] == "resolved"
    assert decision.best(rows, 0, 1e-6)["model"] == "global-100"
    # with E_res 1e-4 (sqrt 1e-2 > 6.8e-3): xmx-10 ties
    b = decision.best(rows, 0, 1e-4)
    assert b["status"] == decision.NOT_RESOLVABLE and b["ties"] == ["xmx-10"]


def test_choose_the_cheapest_model_whose_bound_meets_the_requirement():
    rows = scene_rows(check_E=1e-8)
    res = decision.resolution(rows, None, RMS)           # E_res 1e-8, attitude 0.01 arcsec
    # E <= 1e-2: freq-5's bound (sqrt(1e-2) + 1e-4)^2 > 1e-2, so the next, xmx-10
    c = decision.choose("E", 1e-2, rows, RMS, res)
    assert c["model"] == "xmx-10" and c["coordinates"] == 44
    assert c["error_bound"] == pytest.approx((1e-2 + 1e-4) ** 2)
    # attitude <= 100 arcsec: freq-5 (50 + 0.01)
    c = decision.choose("attitude", 100.0, rows, RMS, res)
    assert c["model"] == "freq-5" and c["error"] == 50.0
    # rate <= 0.25 rad/s RMS: freq-5's worst rate sqrt(1e-2) x 2 = 0.2 (+ 2e-4) meets it; rigid 0.63 not
    c = decision.choose("rate", 0.25, rows, RMS, res)
    assert c["model"] == "freq-5" and c["error"] == pytest.approx(0.2)
    # tighter than every reduced model's bound but above the resolution: the truth
    c = decision.choose("attitude", 0.1, rows, RMS, res)
    assert c["model"] == "truth" and c["error_bound"] == pytest.approx(0.01)


def test_inconclusive_reads_not_evaluated():
    rows = scene_rows()
    res = decision.resolution(rows, None, RMS)
    f = [{"finding": 6, "verdict": "not reproduced", "reason": "inconclusive: effect 1.02",
          "verdict_per_rate": dict.fromkeys(("outer", "middle", "inner", "platform"), "not reproduced")}]
    out = decision.resolve_findings(f, rows, res)[0]
    assert out["verdict"] == "not evaluated"


def test_decision_rows_carry_the_benchmark_times(tmp_path):
    rows = scene_rows()
    runtime = {"models": {"truth": {"run_ms": 12.0, "setup_ms": 300.0},
                          "xmx-10": {"run_ms": 3.0, "setup_ms": 40.0, "run_ms_spread": 0.5}}}
    d = decision.decide_scene("thesis", rows, RMS, None, runtime)
    r = next(r for r in d["rows"] if r["model"] == "xmx-10")
    assert (r["run_ms"], r["setup_ms"], r["truth_run_ms"], r["truth_setup_ms"]) == (3.0, 40.0, 12.0, 300.0)
    assert r["speedup"] == pytest.approx(4.0) and r["state_dimension"] == 88
    assert set(decision.chosen_models(rows, RMS, None)) >= {"truth", "rigid", "xmx-10"}
    json.dumps(d)          # the file the report reads


def test_sampling_check_sees_a_grid_that_misweights_a_mode():
    """A mode at exactly the half grid's Nyquist frequency: on every second sample its samples are
    all at one phase, so E moves by ~100 %; away from it, hardly at all."""
    t = np.arange(0.0, 0.1 + 1e-12, 1e-4)
    base = np.stack([np.sin(2 * np.pi * 10 * t)] * 4, axis=1)
    truth = {"t": t, "gamma_dot": base, "model": "truth"}

    def case(f):
        return {"t": t, "gamma_dot": base + 1e-2 * np.cos(2 * np.pi * f * t)[:, None], "model": f"m{f}"}
    assert decision.sampling_check(truth, [case(2500.0)])["max_relative_change"] > 0.5
    assert decision.sampling_check(truth, [case(1234.5)])["max_relative_change"] < 0.02


def test_the_decision_file_quotes_the_benchmark_and_the_error_tables(tmp_path):
    """End to end on a synthetic study: every decision row's run and set-up times are the timing
    job's medians of that model, its error is the error table's (attitude, E; rate from E and the
    truth's RMS rate), and a requirement below the truth's resolution names no model."""
    from gimbal_reduction.results.study.tables import read_table
    from tests.results.synthetic_study import write_tables
    truth, cases, rt, st, _ = write_tables(tmp_path, tmp_path / "tables")
    rows = read_table(rt) + read_table(st)
    models = {r["model"]: {"run_ms": 1.0 + k, "setup_ms": 10.0 + k, "run_ms_spread": 0.1}
              for k, r in enumerate(rows)}
    runtime = tmp_path / "runtime.json"
    runtime.write_text(json.dumps({"models": models, "runs": 5}))
    basis = tmp_path / "basis.json"
    basis.write_text(json.dumps({"scenes": {"thesis": {"E": [1e-3] * 4, "attitude_max_arcsec": 1.0}}}))
    out = tmp_path / "decision.json"
    assert decision.main(["--scenes", "thesis", "--ranking-tables", rt, "--static-tables", st,
                          "--truths", truth, "--runtimes", str(runtime), "--truth-basis", str(basis),
                          "--sims", truth, *cases[:3],
                          "--out-json", str(out), "--out-csv", str(tmp_path / "decision.csv")]) == 0
    d = json.loads(out.read_text())["scenes"][0]
    by = {r["model"]: r for r in rows}
    rms = decision.rate_rms(*(lambda s: (s["t"], s["gamma_dot"]))(decision.read_sim(truth)))
    assert d["resolution"]["E"] == pytest.approx(max(1e-3, max(by["static-100"][c] for c in RATE_COLUMNS)))
    met = [r for r in d["rows"] if r["status"] == "met"]
    assert met and any(r["model"] != "truth" for r in met)
    for r in met:
        assert r["run_ms"] == models[r["model"]]["run_ms"] and r["setup_ms"] == models[r["model"]]["setup_ms"]
        assert r["truth_run_ms"] == models["truth"]["run_ms"]
        if r["model"] == "truth":
            continue
        E = np.array([by[r["model"]][c] for c in RATE_COLUMNS])
        expected = {"E": E.max(), "attitude": by[r["model"]]["attitude_max_arcsec"],
                    "rate": float(np.max(np.sqrt(E) * rms))}[r["measure"]]
        assert r["error"] == pytest.approx(expected, rel=1e-12) and r["error_bound"] <= r["requirement"]
    for r in d["rows"]:
        assert (r["status"] == decision.NOT_RESOLVABLE) == (r["requirement"] <= r["resolution"])
    assert "max_relative_change" in d["sampling"]


def camp_rows():
    """Rows with their groups: the thesis's freq/xmx, the project's global, the field's cb."""
    def g(model, group, n, E):
        return {**row(model, n, E, 1.0), "group": group}
    return [g("truth", "truth", 400, 0.0), g("static-100", "truth-check", 404, 1e-7),
            g("cb-100", "truth-interface", 418, 2e-7), g("rigid", "rigid", 0, 1e-1),
            g("freq-10", "freq", 40, 1e-2), g("xmx-25", "xmx", 100, 1e-3),
            g("global-60", "global", 60, 1e-3), g("cb-10", "cb", 58, 1e-3)]


def test_cb_100_is_one_of_the_truths_checks_and_never_an_answer():
    rows = camp_rows()
    res = decision.resolution(rows, None, RMS)
    assert res["E"] == pytest.approx(2e-7) and res["sources"] == ["static-100", "cb-100"]
    assert "cb-100" not in [r["model"] for r in decision.candidates(rows)]


def test_each_camp_gives_its_cheapest_answer_and_the_fewest_coordinates_win():
    rows = camp_rows()
    res = decision.resolution(rows, None, RMS)
    camps = decision.choose_by_camp("E", 2e-3, rows, RMS, res)
    assert {c: v["model"] for c, v in camps.items()} == {"thesis": "xmx-25", "project": "global-60",
                                                         "field": "cb-10"}
    assert decision.cheapest_camps(camps) == ["field"]          # 58 < 60 < 100 coordinates
    # must fail: at 5e-4 no camp's model is within the requirement (bounds above 1e-3)
    none = decision.choose_by_camp("E", 5e-4, rows, RMS, res)
    assert all(v["status"] == "no model" for v in none.values())
    assert decision.cheapest_camps(none) == []
    # below the truth's own error, every camp says not resolvable
    low = decision.choose_by_camp("E", 1e-7, rows, RMS, res)
    assert all(v["status"] == decision.NOT_RESOLVABLE for v in low.values())


def test_the_camp_count_counts_ties_and_only_requirements_that_need_a_reduced_model():
    from gimbal_reduction.results.study.study_report import camp_wins, camps_section
    dec = {"scenes": [{"scene": "a", "rows": [
        {"measure": "E", "requirement": 1e-2, "status": "met", "model": "cb-4,4,4,10",
         "cheapest_camps": ["field"],
         "by_camp": {"thesis": {"status": "met", "model": "freq-10", "coordinates": 44},
                     "project": {"status": "no model", "model": None, "coordinates": None},
                     "field": {"status": "met", "model": "cb-4,4,4,10", "coordinates": 40}}},
        {"measure": "attitude", "requirement": 1e-3, "status": "met", "model": "freq-5",
         "cheapest_camps": ["thesis", "field"]},
        # must not count: the rigid model meets it (no selection needed), the truth only, unresolvable
        {"measure": "E", "requirement": 1e-1, "status": "met", "model": "rigid", "cheapest_camps": ["thesis"]},
        {"measure": "E", "requirement": 1e-3, "status": "met", "model": "truth", "cheapest_camps": []},
        {"measure": "E", "requirement": 1e-4, "status": decision.NOT_RESOLVABLE, "model": None,
         "cheapest_camps": []},
        {"measure": "rate", "requirement": 1e-3, "status": "met", "model": "load-5", "cheapest_camps": ["project"]}]}]}
    assert camp_wins(dec) == {"thesis": 1, "project": 0, "field": 2, "judged": 2}
    text = camps_section(dec)
    assert '*#"cb-4,4,4,10 (40)"*' in text and "none of the study" in text and "0.1" not in text


def test_the_frequency_error_table_has_a_cell_per_model_of_a_family_and_skips_missing_columns():
    from gimbal_reduction.results.study.report import frequency_rows
    rows = [{"group": "rigid", "model": "rigid", "count": None, "hinf_error": 1.0, "h2_error": 1.0},
            {"group": "freq", "model": "freq-10", "count": 10, "hinf_error": 1.41, "h2_error": 1.16},
            {"group": "freq", "model": "freq-5", "count": 5, "hinf_error": 2.0, "h2_error": 1.5},
            {"group": "xmx", "model": "xmx-5", "count": 5, "hinf_error": float("nan"), "h2_error": float("nan")}]
    out = frequency_rows(rows)
    assert len(out) == 2                                   # xmx has no frequency-domain error
    assert out[1][1:] == ['#"5: 2 / 1.5"', '#"10: 1.41 / 1.16"']


def test_the_first_call_of_a_fresh_process_is_reported_against_the_median():
    """runtime.first_call: the process's first run against the median of the later ones; the
    decision keeps it per scene and the report quotes the largest excess (never below 0)."""
    from gimbal_reduction.results.bench import runtime as runtime_bench
    from gimbal_reduction.results.study import study_report
    c = runtime_bench.first_call(57.5, [43.0, 44.5, 42.5, 45.0, 43.5])
    assert c == {"first_run_ms": 57.5, "run_ms": 43.5, "extra_ms": 14.0}
    noisy = runtime_bench.first_call(40.0, [43.0, 44.5, 42.5])          # the first ran faster
    assert noisy["extra_ms"] == -3.0
    runtime = {"models": {"rigid": {"run_ms": 1.5, "setup_ms": 0.3, "first_call": c},
                          "truth": {"run_ms": 43.5, "setup_ms": 1.0}}}
    kept = decision.decide_scene("thesis", scene_rows(), RMS, None, runtime)["runtime"]["first_call"]
    assert kept == dict(c, model="rigid")
    assert decision.decide_scene("thesis", scene_rows(), RMS, None, {"models": {}})["runtime"]["first_call"] is None
    scene = {"scene": "thesis", "runtime": {"first_call": dict(c, model="rigid")}}
    other = {"scene": "long", "runtime": {"first_call": dict(noisy, model="rigid")}}
    note = study_report.first_call_note([other, scene])
    assert 'at most #"14 ms"' in note and 'largest on #"thesis"' in note and '#"rigid"' in note
    assert 'at most #"0 ms"' in study_report.first_call_note([other])
    assert study_report.first_call_note([{"scene": "smooth", "runtime": {}}]) == ""
