"""results.study.findings: the six rules on synthetic tables, on the thesis's own tables, missing inputs."""
from __future__ import annotations

import json

import pytest

from results.study import findings, tables
from results.study.cases import BODY_NAMES
from results.study.tables import build_tables
from solver.bodydata import BODIES
from solver.dynamics.simfile import read_sim
from tests.results.synthetic_study import write_study


def _rows(tmp_path, good):
    truth, cases = write_study(tmp_path / "sim", good=good)
    t = read_sim(truth)
    return build_tables(t, [read_sim(p) for p in cases])


def _reduction(prefix):
    return {"bodies": {f"body{b}": {"name": BODY_NAMES[b], "ranking_agreement": {
        "common_prefix": prefix, "top_k": [5, 10, 40], "top_k_overlap": [5, 10, min(prefix, 40)],
        "spearman_rho_all_modes": 0.95}} for b in BODIES}}


def test_rules_pass_on_the_thesis_tables():
    th = findings.thesis_table()
    assert findings.finding1(th, ("xmx",))["verdict"] == "reproduced"
    assert findings.finding3(th)["verdict"] == "reproduced"
    assert findings.finding3(th)["values"] == pytest.approx(0.6264 / 0.2935)
    assert findings.finding4(th, ("static-xmx",))["verdict"] == "reproduced"
    assert findings.finding5(th)["verdict"] == "reproduced"


def test_good_synthetic_study_reproduces_everything(tmp_path):
    rank, stat = _rows(tmp_path, good=True)
    items = findings.evaluate(rank, stat, _reduction(45))
    assert [i["finding"] for i in items] == [1, 2, 3, 4, 5, 6]
    assert [i["verdict"] for i in items] == ["reproduced"] * 6
    assert "ratio E_outer ranked/freq" in items[0]["ours"]
    assert "rule gives: reproduced" in items[0]["thesis"]


def test_bad_synthetic_study_is_not_reproduced(tmp_path):
    rank, stat = _rows(tmp_path, good=False)
    items = {i["finding"]: i for i in findings.evaluate(rank, stat, _reduction(0))}
    assert items[1]["verdict"] == "not reproduced"       # ranked worse than freq below 25
    assert items[2]["verdict"] == "not reproduced"       # rankings differ at rank 1
    assert items[4]["verdict"] == "not reproduced"       # static+ranked always better
    assert items[6]["verdict"] == "not reproduced"       # load cases differ by a factor 5
    assert "factor" in items[6]["reason"]
    assert items[3]["verdict"] == items[5]["verdict"] == "reproduced"


def test_partly_reproduced_when_one_ranking_fails():
    tab = {"freq": {5: (1.0, .1, 1e-4, 1e-4)}, "xmx": {5: (0.5, .1, 1e-4, 1e-4)},
           "xmgmx": {5: (2.0, .1, 1e-4, 1e-4)}}
    f = findings.finding1(tab)
    assert f["verdict"] == "partly reproduced" and "XMGMX" in f["reason"]


def test_finding5_detects_a_dominant_middle_gimbal():
    tab = {"freq": {n: (0.1, 1.0, 1e-5, 1e-5) for n in (5, 10)}}
    f = findings.finding5(tab)
    assert f["verdict"] == "not reproduced" and "exceeds the outer" in f["reason"]


def test_missing_inputs_are_not_evaluated(tmp_path):
    items = findings.evaluate([], [], None)
    assert all(i["verdict"] == "not evaluated" for i in items)
    assert all(i["reason"].startswith("missing input") for i in items)
    code = findings.main(["--ranking-table", str(tmp_path / "none.csv"), "--csv",
                          str(tmp_path / "f.csv"), "--json", str(tmp_path / "f.json")])
    assert code == 0
    data = json.loads((tmp_path / "f.json").read_text())
    assert data["missing_inputs"] and len(data["findings"]) == 6


def test_cli_writes_csv_and_json(tmp_path):
    truth, cases = write_study(tmp_path / "sim")
    rt, st = tmp_path / "r.csv", tmp_path / "s.csv"
    assert tables.main(["--truth", truth, "--cases", *cases, "--ranking-table", str(rt),
                        "--static-table", str(st)]) == 0
    red = tmp_path / "reduction.json"
    red.write_text(json.dumps(_reduction(0)))
    assert findings.main(["--ranking-table", str(rt), "--static-table", str(st), "--reduction",
                          str(red), "--csv", str(tmp_path / "f.csv"), "--json",
                          str(tmp_path / "f.json")]) == 0
    lines = (tmp_path / "f.csv").read_text().splitlines()
    assert lines[0] == ",".join(findings.FIELDS)
    data = json.loads((tmp_path / "f.json").read_text())
    assert {i["finding"]: i["verdict"] for i in data["findings"]}[2] == "not reproduced"
