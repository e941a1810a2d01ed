"""gimbal_reduction.results.study.findings: every rule on a synthetic table where it must pass and one where it
must fail, per rate; the thesis's own tables; missing inputs; the CLI and its one-scene check."""
from __future__ import annotations

import json

import pytest

from gimbal_reduction.results.study import findings, tables
from gimbal_reduction.results.study.cases import BODY_NAMES, LOAD_CASES
from gimbal_reduction.results.study.tables import RATE_COLUMNS
from gimbal_reduction.solver.bodydata import BODIES
from tests.results.synthetic_study import write_study

RATE_FACTORS = (1.0, 0.3, 1e-3, 1e-3)     # outer > middle >> inner, platform (finding 5 holds)


def _good_outer() -> dict:
    """E_outer per model of a study on which all ten findings hold."""
    E = {"truth": 0.0, "rigid": 1.0}
    E.update({f"freq-{n}": 0.5 for n in (2, 4, 5, 6, 8, 10, 15, 20)})
    E["freq-25"] = 0.05
    for rank in ("xmx", "xmgmx"):
        E.update({f"{rank}-{n}": 0.2 for n in (5, 10, 15, 20)})
        E[f"{rank}-25"] = 0.05
        E.update({f"static-{rank}-{n}": v for n, v in ((2, 0.35), (4, 0.35), (6, 0.12), (8, 0.12))})
    E.update({"static-2": 0.3, "static-4": 0.3, "static-6": 0.08, "static-8": 0.085})
    E.update({f"static-10@2:{c}": 0.1 * (1 + 0.05 * k) for k, (c, _) in enumerate(LOAD_CASES)})
    E.update({f"load-{n}": 0.3 for n in (5, 10, 15, 20)})
    E["load-25"] = 0.044
    E.update({f"global-{n}": 0.3 for n in (20, 40, 60, 80)})
    E["global-100"] = 0.044
    # Craig-Bampton at the coordinates of freq-10..25 and static-6, static-8: no better than them
    E.update({"cb-4,4,4,10": 0.5, "cb-9,9,9,15": 0.5, "cb-14,14,14,20": 0.5, "cb-19,19,19,25": 0.05,
              "cb-1,1,1,7": 0.1, "cb-3,3,3,9": 0.1})
    E["static-100"] = 1e-4          # the truth's own error: every pair above it
    E["cb-100"] = 5e-5              # ... and at the interfaces
    return E


def _rows(outer: dict, scene="thesis") -> list[dict]:
    """Table rows; a value is E_outer (the other rates by RATE_FACTORS) or a 4-tuple."""
    rows = []
    for model, e in outer.items():
        E = tuple(e) if isinstance(e, tuple) else tuple(e * f for f in RATE_FACTORS)
        rows.append({"model": model, "n_elastic": None, "scene": scene, **dict(zip(RATE_COLUMNS, E))})
    return rows


def _study(**changes):
    E = _good_outer()
    for k, v in changes.items():
        model, _, case = k.partition("__")          # static_10__output_motor_my
        k = model.replace("_", "-") + (f"@2:{case}" if case else "")
        if v is None:
            E.pop(k)
        else:
            E[k] = v
    return findings.Study(_rows(E))


def _reduction(prefix):
    return {"bodies": {f"body{b}": {"name": BODY_NAMES[b], "ranking_agreement": {
        "common_prefix": prefix, "top_k": [5, 10, 40], "top_k_overlap": [5, 10, min(prefix, 40)],
        "spearman_rho_all_modes": 0.95}} for b in BODIES}}


def _per_rate(res):
    return [res["verdict_per_rate"][r] for r in findings.RATES]


ALL = ["reproduced"] * 4
NONE = ["not reproduced"] * 4


# ---------------------------------------------------------------- every rule passes on the good study
def test_good_study_reproduces_all_ten():
    rows = _rows(_good_outer())
    items = findings.evaluate(rows[:30], rows[30:], _reduction(45), scene="thesis")
    assert [i["finding"] for i in items] == list(range(1, 11))
    assert [i["id"] for i in items] == [f"F{k}" for k in range(1, 11)]
    for i in items:
        assert i["verdict"] == "reproduced", (i["finding"], i["reason"])
        assert list(i["verdict_per_rate"].values()) == ALL
        assert i["scene"] == "thesis" and i["control"] and i["rule"] and i["statement"]
    assert [i["source"] for i in items] == ["thesis"] * 6 + ["new"] * 4


# ---------------------------------------------------------------- finding 10
def test_f10_fails_where_craig_bampton_is_better_and_is_partly_for_some_pairs():
    f = findings.finding10(_study())
    assert f["verdict"] == "reproduced" and "14/14 resolved pairs" in f["reason"]
    better = {"cb-4,4,4,10": 0.1, "cb-9,9,9,15": 0.1, "cb-14,14,14,20": 0.1, "cb-19,19,19,25": 0.01,
              "cb-1,1,1,7": 0.01, "cb-3,3,3,9": 0.01}
    E = _good_outer()
    E.update(better)
    f = findings.finding10(findings.Study(_rows(E)))
    assert f["verdict"] == "not reproduced" and "cb better at freq-10" in f["reason"]
    E = _good_outer()
    E["cb-1,1,1,7"] = 0.01                        # beats static-6 only
    f = findings.finding10(findings.Study(_rows(E)))
    assert f["verdict"] == "partly reproduced" and f["cases"]["outer"] == ["static-6"]


def test_f10_is_masked_by_the_truths_resolution():
    E = _good_outer()
    E.update({"cb-1,1,1,7": 0.01, "cb-3,3,3,9": 0.01})     # cb better than static-6, static-8 ...
    E["static-100"] = 0.2                                 # ... but the truth cannot tell below 0.2
    f = findings.finding10(findings.Study(_rows(E)))
    assert f["verdict"] == "reproduced" and "5 unresolved" in f["reason"]
    E["static-100"] = 1.0                                 # nothing resolved: no verdict
    f = findings.finding10(findings.Study(_rows(E)))
    assert f["verdict"] == "not evaluated" and "within the truth's resolution" in f["reason"]
    E["static-100"], E["cb-100"] = 1e-4, 0.2              # the interface referee sets R alike
    f = findings.finding10(findings.Study(_rows(E)))
    assert f["verdict"] == "reproduced" and f["numbers"]["outer"]["truth_resolution"] == 0.2
    # a Craig-Bampton model below R and a thesis one above it by less than TIE: a tie, not a win
    E["cb-1,1,1,7"], E["static-6"] = 1e-6, 0.21
    f = findings.finding10(findings.Study(_rows(E)))
    assert "static-6" not in f["cases"]["outer"]
    E["static-6"] = 0.3                                    # above R by more than TIE: cb better
    assert "static-6" in findings.finding10(findings.Study(_rows(E)))["cases"]["outer"]
    E.pop("cb-4,4,4,10"), E.pop("cb-9,9,9,15"), E.pop("cb-14,14,14,20"), E.pop("cb-19,19,19,25")
    E.pop("cb-1,1,1,7"), E.pop("cb-3,3,3,9")
    assert findings.finding10(findings.Study(_rows(E)))["verdict"] == "not evaluated"


# ---------------------------------------------------------------- finding 1
def test_f1_fails_when_ranked_is_worse_and_is_partly_with_one_ranking():
    bad = {f"xmx_{n}": 0.6 for n in (5, 10, 15, 20)}
    f = findings.finding1(_study(**bad))
    assert _per_rate(f) == ["partly reproduced"] * 4 and f["verdict"] == "partly reproduced"
    bad.update({f"xmgmx_{n}": 0.6 for n in (5, 10, 15, 20)})
    f = findings.finding1(_study(**bad))
    assert f["verdict"] == "not reproduced" and "XMX better at 0/4" in f["reason"]


def test_f1_is_judged_per_rate():
    # ranked better on the outer rate only: the inner rate fails (as on our thesis scene)
    changes = {f"{r}_{n}": (0.2, 0.06, 5e-3, 1e-4) for r in ("xmx", "xmgmx") for n in (5, 10, 15, 20)}
    f = findings.finding1(_study(**changes))
    assert _per_rate(f) == ["reproduced", "reproduced", "not reproduced", "reproduced"]
    assert f["verdict"] == "partly reproduced"
    assert f["numbers"]["inner"]["xmx-5"] == pytest.approx(5e-3)
    assert f["numbers"]["inner"]["freq-5"] == pytest.approx(5e-4)


def test_f1_tie_is_not_better():
    f = findings.finding1(_study(**{f"{r}_{n}": 0.47 for r in ("xmx", "xmgmx") for n in (5, 10, 15, 20)}))
    assert f["verdict"] == "not reproduced"       # 6 % better: within TIE


# ---------------------------------------------------------------- finding 2
def test_f2_pass_fail_and_per_body():
    assert findings.finding2(_reduction(45))["verdict"] == "reproduced"
    f = findings.finding2(_reduction(3))
    assert f["verdict"] == "not reproduced" and "first 3 ranks equal" in f["reason"]
    red = _reduction(45)
    red["bodies"]["body4"]["ranking_agreement"]["common_prefix"] = 7
    f = findings.finding2(red)
    assert _per_rate(f) == ["reproduced", "reproduced", "not reproduced", "reproduced"]


# ---------------------------------------------------------------- finding 3
def test_f3_passes_only_with_its_controls():
    f = findings.finding3(_study())
    assert f["verdict"] == "reproduced"
    assert f["numbers"]["outer"]["static-6"] == pytest.approx(0.08)
    assert f["numbers"]["outer"]["freq-6"] == pytest.approx(0.5)
    assert f["numbers"]["outer"]["rigid"] == pytest.approx(1.0)


def test_f3_rigid_like_study_fails():
    # every model is about as good as freq-25: the static mode adds nothing over its control
    f = findings.finding3(_study(freq_6=0.085, freq_8=0.085, static_6=0.085, static_8=0.085))
    assert f["verdict"] == "not reproduced" and "not better than freq-6" in f["reason"]
    # the rigid model itself is as good as the static cases
    f = findings.finding3(_study(rigid=0.08))
    assert f["verdict"] == "not reproduced" and "not better than rigid" in f["reason"]


def test_f3_fails_when_far_from_25_modes():
    f = findings.finding3(_study(static_6=0.2, static_8=0.2))
    assert f["verdict"] == "not reproduced" and "4x freq-25 0.05 (> 3x)" in f["reason"]


# ---------------------------------------------------------------- finding 4
def test_f4_fails_when_static_ranked_is_better():
    changes = {f"static_{r}_{n}": 0.05 for r in ("xmx", "xmgmx") for n in (2, 4, 6, 8)}
    f = findings.finding4(_study(**changes))
    assert f["verdict"] == "not reproduced" and "incl. the largest" in f["reason"]
    changes = {f"static_xmgmx_{n}": 0.05 for n in (2, 4, 6, 8)}
    assert findings.finding4(_study(**changes))["verdict"] == "partly reproduced"


# ---------------------------------------------------------------- finding 5
def test_f5_fails_per_rate():
    f = findings.finding5(_study(freq_5=(0.1, 1.0, 1e-5, 1e-5)))
    assert _per_rate(f) == ["not reproduced", "not reproduced", "reproduced", "reproduced"]
    assert f["cases"]["outer"] == ["freq-5"]
    E = {k: (v, 0.3 * v, 0.1 * v, 1e-3 * v) for k, v in _good_outer().items() if k != "truth"}
    f = findings.finding5(findings.Study(_rows(E)))
    assert _per_rate(f) == ["reproduced", "reproduced", "not reproduced", "reproduced"]
    assert f["numbers"]["inner"]["median_E_outer_over_E_inner"] == pytest.approx(10)


# ---------------------------------------------------------------- finding 6
def test_f6_passes_only_when_the_static_mode_matters():
    f = findings.finding6(_study())
    assert f["verdict"] == "reproduced"
    assert f["numbers"]["outer"]["static_mode_factor"] > 4
    # the static mode changes E by 1-2 %: the load case cannot matter, so nothing is shown
    flat = {f"static_10__{c}": 0.5 * (1 + 0.003 * k) for k, (c, _) in enumerate(LOAD_CASES)}
    f = findings.finding6(_study(**flat))
    assert f["verdict"] == "not reproduced" and "inconclusive" in f["reason"]


def test_f6_fails_on_a_large_load_case_spread():
    spread = {f"static_10__{c}": 0.05 * (1 + k) for k, (c, _) in enumerate(LOAD_CASES)}
    f = findings.finding6(_study(**spread))
    assert f["verdict"] == "not reproduced"
    assert f["numbers"]["outer"]["load_case_spread"] == pytest.approx(7)
    # spread 1.6 < 2 but as large as the static mode's own effect (1.6x): fails too
    close = {f"static_10__{c}": 0.3 * (1 + 0.1 * k) for k, (c, _) in enumerate(LOAD_CASES)}
    assert findings.finding6(_study(**close))["verdict"] == "not reproduced"


# ---------------------------------------------------------------- finding 7
def test_f7_rigid_baseline():
    f = findings.finding7(_study())
    assert f["verdict"] == "reproduced"
    assert f["numbers"]["outer"]["cases_better_than_rigid"] == f["numbers"]["outer"]["cases"] == 54
    f = findings.finding7(_study(rigid=0.04))
    assert f["verdict"] == "not reproduced"
    assert f["numbers"]["outer"]["cases_better_than_rigid"] == 0 and "0/54" in f["reason"]
    f = findings.finding7(_study(rigid=0.15))      # beaten by 21 of 54 only
    assert f["verdict"] == "not reproduced" and f["numbers"]["outer"]["cases_better_than_rigid"] == 21
    assert "static-6" in f["cases"]["outer"] and "freq-5" not in f["cases"]["outer"]


# ---------------------------------------------------------------- finding 8
def test_f8_best_and_cheapest():
    f = findings.finding8(_study())
    assert f["verdict"] == "reproduced"
    n = f["numbers"]["outer"]
    assert n["best"] == pytest.approx(0.044) and n["cheapest_n_elastic"] == 28
    assert f["cases"]["outer"][1] == "static-6"
    f = findings.finding8(_study(global_100=0.01))
    assert f["verdict"] == "not reproduced" and f["cases"]["outer"][0] == "global-100"
    assert "8x best" in f["reason"]


def test_f8_includes_the_rigid_model_among_the_candidates():
    f = findings.finding8(_study(rigid=0.001))
    assert f["cases"]["outer"] == ["rigid", "rigid"]
    assert f["numbers"]["outer"]["cheapest_n_elastic"] == 0


# ---------------------------------------------------------------- finding 9
def test_f9_scene_aware_against_frequency_cutoff():
    f = findings.finding9(_study())
    assert f["verdict"] == "reproduced"
    assert f["numbers"]["outer"]["global-40"] == pytest.approx(0.3)
    assert f["numbers"]["outer"]["freq-10"] == pytest.approx(0.5)
    worse = {f"load_{n}": 0.6 for n in (5, 10, 15, 20, 25)}
    worse.update({f"global_{n}": 0.6 for n in (20, 40, 60, 80, 100)})
    assert findings.finding9(_study(**worse))["verdict"] == "not reproduced"
    f = findings.finding9(_study(**{f"global_{n}": 0.6 for n in (20, 40, 60, 80, 100)}))
    assert _per_rate(f) == ["partly reproduced"] * 4 and "global better at 0/5" in f["reason"]


# ---------------------------------------------------------------- missing inputs
def test_missing_inputs_are_not_evaluated_with_the_reason():
    items = findings.evaluate([], [], None)
    assert all(i["verdict"] == "not evaluated" for i in items)
    assert all(i["reason"].startswith("missing input") for i in items)
    assert all(set(i["verdict_per_rate"].values()) == {"not evaluated"} for i in items)


@pytest.mark.parametrize("finding, drop, word", [
    (3, "rigid", "rigid"), (3, "freq-6,freq-8", "freq-6"), (3, "freq-25", "freq-25"),
    (6, "freq-10", "freq-10"), (7, "rigid", "rigid"),
    (9, ",".join([f"load-{n}" for n in (5, 10, 15, 20, 25)] +
                 [f"global-{n}" for n in (20, 40, 60, 80, 100)]), "load-N"),
    (1, ",".join(f"{r}-{n}" for r in ("xmx", "xmgmx") for n in (5, 10, 15, 20, 25)), "XMX-N"),
    (8, "static-6,static-8", "static-6")])
def test_a_missing_control_is_not_evaluated(finding, drop, word):
    E = _good_outer()
    for m in drop.split(","):
        E.pop(m)
    f = getattr(findings, f"finding{finding}")(findings.Study(_rows(E)))
    assert f["verdict"] == "not evaluated"
    assert f["reason"].startswith("missing input") and word in f["reason"]


def test_a_nan_rate_is_not_evaluated_on_that_rate_only():
    E = {k: (v, 0.3 * v, float("nan"), 1e-3 * v) for k, v in _good_outer().items()}
    f = findings.finding3(findings.Study(_rows(E)))
    assert _per_rate(f) == ["reproduced", "reproduced", "not evaluated", "reproduced"]
    assert f["verdict"] == "reproduced"


# ---------------------------------------------------------------- the thesis's own tables
def test_rules_on_the_thesis_tables():
    th = findings.thesis_checks()
    assert th[1]["verdict_per_rate"]["outer"] == "reproduced"           # where the thesis claims it
    assert th[1]["verdict_per_rate"]["inner"] == "not reproduced"       # its own Table 4.2
    assert th[3]["verdict_per_rate"]["outer"] == "reproduced"
    assert th[3]["numbers"]["outer"]["static-6"] == pytest.approx(0.6264)
    assert th[3]["numbers"]["outer"]["freq-10"] == pytest.approx(8.4256)  # nearest control
    assert th[4]["verdict"] == "reproduced"
    assert th[5]["verdict"] == "reproduced"
    assert th[8]["numbers"]["outer"]["recommended_over_best"] == pytest.approx(0.6264 / 0.2935)
    items = {i["finding"]: i for i in findings.evaluate([], [], None)}
    assert "rule gives: partly reproduced" in items[1]["thesis"]
    assert items[1]["thesis_check"]["verdict_per_rate"]["outer"] == "reproduced"
    assert items[7]["thesis_check"]["verdict"] == "not evaluated"


# ---------------------------------------------------------------- CLI
def test_cli_writes_csv_and_json_of_one_scene(tmp_path):
    truth, cases = write_study(tmp_path / "sim")
    rt, st = tmp_path / "r.csv", tmp_path / "s.csv"
    assert tables.main(["--truth", truth, "--cases", *cases, "--ranking-table", str(rt),
                        "--static-table", str(st)]) == 0
    red = tmp_path / "reduction.json"
    red.write_text(json.dumps(_reduction(0)))
    args = ["--ranking-table", str(rt), "--static-table", str(st), "--reduction", str(red),
            "--csv", str(tmp_path / "f.csv"), "--json", str(tmp_path / "f.json")]
    assert findings.main(args + ["--scene", "thesis"]) == 0
    lines = (tmp_path / "f.csv").read_text().splitlines()
    assert lines[0] == ",".join(findings.FIELDS) and len(lines) == 11
    data = json.loads((tmp_path / "f.json").read_text())
    assert data["scene"] == "thesis" and data["rates"] == list(findings.RATES)
    items = {i["finding"]: i for i in data["findings"]}
    assert items[2]["verdict"] == "not reproduced"
    assert items[1]["verdict"] == "reproduced"            # synthetic_study: ranked better (good=True)
    # synthetic_study gives the rigid case E = 0 on every rate: no case beats it
    assert items[7]["verdict"] == "not reproduced" and "rigid" in items[7]["reason"]
    assert set(items[1]["numbers"]) == set(findings.RATES)
    for k in ("finding", "statement", "rule", "ours", "thesis", "verdict", "reason"):  # report.py reads
        assert all(k in i for i in data["findings"])
    # tables of another scene than --scene: refused
    assert findings.main(args + ["--scene", "long"]) == 2


def test_tables_of_two_scenes_are_refused():
    rows = _rows({"freq-5": 1.0}) + _rows({"freq-10": 1.0}, scene="damped")
    with pytest.raises(findings.FindingsInputError):
        findings.table_scene(rows)
    assert findings.table_scene(_rows({"freq-5": 1.0})) == "thesis"
    assert findings.table_scene([], "smooth") == "smooth"


def test_classify_model_names():
    assert findings.classify("rigid") == ("rigid", 0)
    assert findings.classify("global-40") == ("global", 40)
    assert findings.classify("static-xmgmx-6") == ("static-xmgmx", 6)
    assert findings.classify("static-10@2:input_motor_fx") == ("load-case", "input_motor_fx")
    assert findings.classify("freq-10,10,5,5")[0] == "other"
    st = findings.Study(_rows({"global-40": 1.0, "static-10@2:input_motor_fx": 1.0, "load-5": 1.0}))
    assert [c["n_elastic"] for c in st.rows] == [40, 41, 20]


def test_the_truth_check_is_no_case():
    """static-100 (the truth with residual flexibility) referees the truth: it must not count as
    a reduced case beating the rigid model (7) nor be the best case (8)."""
    rows = _rows({"rigid": 0.04, "freq-10": 0.07, "global-100": 0.003, "static-100": 2e-8,
                  "static-6": 0.08, "static-8": 0.075})
    out = {f["finding"]: f for f in findings.evaluate(rows, [], None, "thesis")}
    assert "static-100" not in out[7]["reason"] and "1/4 cases" in out[7]["reason"]
    assert out[8]["cases"]["outer"][0] == "global-100"
