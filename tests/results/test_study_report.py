"""gimbal_reduction.results.study.study_report: the numbers of the text from the tables, the sections, the PDF."""
from __future__ import annotations

import numpy as np
import pytest

from gimbal_reduction.results.study import findings, study_report, tables
from gimbal_reduction.results.markup import sci
from gimbal_reduction.results.study.tables import RATE_COLUMNS
from tests.results.synthetic_study import write_study


def row(model, E, n, group="other", attitude=1.0):
    r = {"model": model, "group": group, "n_elastic": n, "attitude_max_arcsec": attitude}
    r.update(dict(zip(RATE_COLUMNS, E)))
    return r


ROWS = [row("truth", (0, 0, 0, 0), 400, "truth", 0.0),
        row("rigid", (0.04, 1e-3, 2e-5, 1e-2), 0, "rigid"),
        row("freq-10", (0.07, 1e-3, 8e-6, 3e-3), 40, "freq"),       # worse than rigid on outer
        row("load-25", (0.009, 3e-4, 3e-6, 7e-5), 100, "load"),      # better everywhere
        row("global-100", (0.003, 1e-4, 3e-6, 4e-5), 100, "global"),
        row("static-100", (2e-8, 2e-9, 2e-10, 3e-10), 404, "truth-check", 1e-7)]


def test_analyse_scene_counts_what_beats_the_rigid_model_and_the_cheapest_per_target():
    a = study_report.analyse_scene(ROWS)
    assert a["n_reduced"] == 3                          # truth, rigid and static-100 are not cases
    assert a["beat_rigid"]["outer"] == ["load-25", "global-100"]
    assert a["beat_rigid"]["inner"] == ["freq-10", "load-25", "global-100"]
    assert a["best"]["outer"] == ("global-100", 0.003, 100)
    assert np.allclose(a["truth_error"], (2e-8, 2e-9, 2e-10, 3e-10))
    # E <= 1e-1 on every rate: the rigid model (0 coordinates) is the cheapest
    assert a["cheapest"][1e-1][0] == "rigid"
    # E <= 1e-2: load-25 and global-100 both have 100 coordinates; the smaller max E wins
    assert a["cheapest"][1e-2][0] == "global-100"
    assert a["cheapest"][1e-4] is None
    assert a["freq_monotone"] is False                 # freq-5..25 are not all in ROWS


def test_freq_monotone_needs_every_count_falling():
    rows = [row(f"freq-{n}", (1.0 / n, 0, 0, 0), 4 * n, "freq") for n in (5, 10, 15, 20, 25)]
    assert study_report.analyse_scene(rows)["freq_monotone"] is True
    rows[2] = row("freq-15", (0.5, 0, 0, 0), 60, "freq")
    assert study_report.analyse_scene(rows)["freq_monotone"] is False


def test_analyse_scene_without_rigid_model_leaves_the_baseline_empty():
    a = study_report.analyse_scene([r for r in ROWS if r["model"] != "rigid"])
    assert a["rigid"] is None and a["beat_rigid"] == {}


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """Two synthetic scenes with tables and findings (the files the workflow hands the report)."""
    tmp = tmp_path_factory.mktemp("study")
    out = {"scenes": [], "rank": [], "static": [], "findings": [], "figures": []}
    for scene in ("thesis", "smooth"):
        truth, cases = write_study(tmp / "sim", good=(scene == "thesis"), scene=scene)
        rt, st = tmp / scene / "errors_ranking.csv", tmp / scene / "errors_static.csv"
        assert tables.main(["--truth", truth, "--cases", *cases, "--ranking-table", str(rt),
                            "--static-table", str(st)]) == 0
        fj = tmp / scene / "findings.json"
        assert findings.main(["--ranking-table", str(rt), "--static-table", str(st), "--scene", scene,
                              "--csv", str(tmp / scene / "findings.csv"), "--json", str(fj)]) == 0
        scene_file = tmp / f"{scene}.yaml"
        scene_file.write_text(f"name: {scene}\ndescription: synthetic {scene}\n"
                              "duration: {value: 0.015, unit: s}\ndamping_ratio: {value: 0.0, unit: '1'}\n")
        out["scenes"].append(str(scene_file))
        out["rank"].append(str(rt))
        out["static"].append(str(st))
        out["findings"].append(str(fj))
        out["figures"].append(str(tmp / scene / "figures.json"))     # missing: reported, not fatal
    out["tmp"] = tmp
    return out


def test_study_report_builds_every_section_and_quotes_the_tables(study):
    pdf = study["tmp"] / "report.pdf"
    rc = study_report.main(["--scenes", *study["scenes"], "--ranking-tables", *study["rank"],
                            "--static-tables", *study["static"], "--findings", *study["findings"],
                            "--figures", *study["figures"], "--fe", str(study["tmp"] / "nope.json"),
                            "--reduction", str(study["tmp"] / "nope2.json"), "--out", str(pdf)])
    assert rc == 0 and pdf.stat().st_size > 10_000
    src = (study["tmp"] / "report.typ").read_text()
    for head in ("= Summary", "= Methods", "= Results", "== The truth's own error", "= Discussion",
                 "= Conclusions and recommendation", "= Verification and run time", "= Provenance"):
        assert head in src, head
    # the rigid model's outer error in the summary is the table's
    rows = tables.read_table(study["rank"][0])
    rigid = next(r for r in rows if r["model"] == "rigid")
    assert f"the rigid model's outer-gimbal error is {sci(rigid['E_outer_gimbal'])}" in src
    # every finding of every scene is in the verdict table; missing inputs are named
    assert src.count('#"9. ') == 1 and "Incomplete report" in src and "nope.json missing" in src


def test_study_report_refuses_lists_of_different_lengths(study, capsys):
    rc = study_report.main(["--scenes", *study["scenes"], "--ranking-tables", study["rank"][0],
                            "--static-tables", *study["static"], "--findings", *study["findings"],
                            "--figures", *study["figures"], "--fe", "x", "--reduction", "y",
                            "--out", str(study["tmp"] / "r.pdf")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "1 ranking tables for 2 scenes" in err


def test_truth_error_takes_the_larger_of_residual_flexibility_and_the_larger_basis():
    an = {"thesis": study_report.analyse_scene(ROWS)}
    basis = {"larger_basis": "freq-200",
             "scenes": {"thesis": {"E": [7e-4, 2e-5, 3e-6, 2e-5], "E_max": 7e-4},
                        "smooth": {"E": [1e-8, 0, 0, 0], "E_max": 1e-8}}}
    assert study_report.truth_referee(an, basis) == {"thesis": 7e-4}
    assert study_report.truth_referee(an, None) == {"thesis": 2e-8}
    ctx = {"scenes": [{"name": "thesis"}], "truth_basis": basis, "dates": {}, "missing": {}}
    text = study_report.truth_error_section(ctx, an)
    assert "far more than the residual flexibility" in text and sci(1e-8) in text
    # a larger basis that agrees with the residual flexibility: no such sentence
    basis["scenes"]["thesis"]["E_max"] = 5e-8
    assert "far more" not in study_report.truth_error_section(ctx, an)


def test_thesis_table_4_1_is_40_distinct_modes_per_body_as_printed():
    # the transcription: 40 rows, no repeated mode, every number a mode of the 100 computed
    for body, modes in findings.THESIS_TABLE_4_1.items():
        assert len(modes) == 40 and len(set(modes)) == 40 and all(1 <= m <= 100 for m in modes), body
    # first and last rows of the printed table (outer, middle, inner, platform)
    assert [m[0] for m in findings.THESIS_TABLE_4_1.values()] == [4, 4, 4, 1]
    assert [m[-1] for m in findings.THESIS_TABLE_4_1.values()] == [42, 83, 30, 48]


def test_ranking_comparison_counts_low_modes_highest_and_shared():
    thesis = {"outer_gimbal": (1, 2, 30, 4)}
    ours = {"outer_gimbal": {"xmx": (2, 1, 5, 40), "xmgmx": (1, 2, 30, 4)}}
    c = study_report.ranking_comparison(ours, thesis, top=3, lowest=25)["outer_gimbal"]
    assert c["thesis"] == {"modes": (1, 2, 30), "low": 2, "highest": 30, "shared": 3}
    assert c["xmx"] == {"modes": (2, 1, 5), "low": 3, "highest": 5, "shared": 2}
    assert c["xmgmx"]["shared"] == 3
    # a body the thesis does not list is left out, not invented
    assert study_report.ranking_comparison({"other": ours["outer_gimbal"]}, thesis) == {}


def test_mode_ranking_table_is_read_and_shown_beside_the_thesis(study):
    csv = study["tmp"] / "ranking.csv"
    lines = ["body,name,rank_1based,xmx_mode_1based,xmgmx_mode_1based"]
    for b, name in enumerate(findings.THESIS_TABLE_4_1, start=2):
        lines += [f"body{b},{name},{k + 1},{k + 1},{40 - k}" for k in range(40)]
    csv.write_text("\n".join(lines) + "\n")
    ours = study_report.read_mode_ranking(str(csv))
    assert ours["stable_platform"]["xmx"][:3] == (1, 2, 3) and ours["outer_gimbal"]["xmgmx"][0] == 40
    pdf = study["tmp"] / "ranked.pdf"
    assert study_report.main(["--scenes", *study["scenes"], "--ranking-tables", *study["rank"],
                              "--static-tables", *study["static"], "--findings", *study["findings"],
                              "--figures", *study["figures"], "--fe", "x", "--reduction", "y",
                              "--mode-ranking", str(csv), "--out", str(pdf)]) == 0
    src = (study["tmp"] / "ranked.typ").read_text()
    # XMX keeps modes 1..20: all 80 among the 25 lowest; the thesis's top 20: 71 of 80
    assert "== The thesis's Table 4.1 beside ours" in src
    assert "Of the 80 top-20 modes, 71 (thesis), 80 (XMX) and" in src


# ------------------------------------------------ accuracy on request (issue 17)
def tol_row(scene, eps, n, est, meas, method="a-priori estimate", run=0.1):
    return {"scene": scene, "eps": eps, "status": "ok", "n_kept": n, "estimated_E_max": est,
            "measured_E_max": meas, "within_request": meas <= eps, "method": method, "run_time_s": run}


TOLERANCE = {
    "rows": [tol_row("thesis", 1e-2, 73, 9.6e-3, 9.7e-3, run=0.05),
             tol_row("thesis", 1e-3, 150, 9.9e-4, 1.1e-3, run=0.08),
             {**tol_row("spin", 1e-2, 0, 9.5e-4, 9.6e-4, "verified search", 0.2), "apriori_N": 40,
              "apriori_measured_E_max": 1.5e-2},                  # the frozen chain's own choice missed
             {"scene": "spin", "eps": 1e-3, "status": "refused: only the truth", "n_kept": "",
              "method": "", "estimated_E_max": "", "measured_E_max": "", "within_request": "",
              "run_time_s": ""}],
    "comparisons": [{"scene": "thesis", "eps": 1e-2, "family": "global", "model": "global-100",
                     "run_time_s": 0.06, "n_elastic": 100}],
    "scenes": ["thesis", "spin"], "eps": [1e-2, 1e-3]}


def test_tolerance_chart_data_pairs_tol_eps_with_the_cheapest_study_models():
    data = study_report.tolerance_chart_data(TOLERANCE, {"thesis": ROWS})
    assert list(data) == ["thesis", "spin"]
    th = data["thesis"]
    assert [p["eps"] for p in th["points"]] == [1e-2, 1e-3] and th["has_table"]
    assert [p["n_kept"] for p in th["points"]] == [73, 150]
    assert th["points"][0]["within"] is True and th["points"][1]["within"] is False   # 1.1e-3 > 1e-3
    g = th["families"]["global"]
    assert g[0]["model"] == "global-100" and g[0]["n_elastic"] == 100 and g[0]["run_time_s"] == 0.06
    assert g[1]["model"] is None                                  # global-100's 3e-3 misses 1e-3
    assert th["families"]["freq"][0]["model"] is None             # freq-10's 7e-2 misses 1e-2
    sp = data["spin"]
    assert not sp["has_table"] and sp["points"][1]["n_kept"] is None and sp["points"][1]["within"] is None


def test_tolerance_summary_counts_methods_deviation_and_equal_error_ratios():
    sm = study_report.tolerance_summary(study_report.tolerance_chart_data(TOLERANCE, {"thesis": ROWS}))
    assert sm["requests"] == 4 and sm["built"] == 3 and sm["within"] == 2
    assert sm["methods"]["verified search"] == {"built": 1, "within": 1, "scenes": ["spin"]}
    assert sm["apriori_ratio"]["thesis"] == (pytest.approx(9.7e-3 / 9.6e-3), pytest.approx(1.1e-3 / 9.9e-4))
    assert sm["apriori_max_ratio"] == pytest.approx(1.1e-3 / 9.9e-4) and "spin" not in sm["apriori_ratio"]
    assert sm["comparisons"] == [("thesis", 1e-2, "global", "global-100", 73, 100)]
    assert (sm["fewer"], sm["equal"], sm["more"]) == (1, 0, 0)
    assert sm["beyond_study"] == 1                                # EPS 1e-3: no study model meets it
    assert sm["promise_checked"] == 1 and sm["promise_broken"] == [("spin", 1e-2, 40, 1.5e-2)]


def test_study_report_shows_the_tolerance_section_with_the_bench_numbers(study, tmp_path):
    import json
    path = tmp_path / "tolerance.json"
    path.write_text(json.dumps(TOLERANCE))
    pdf = tmp_path / "report.pdf"
    rc = study_report.main(["--scenes", *study["scenes"], "--ranking-tables", *study["rank"],
                            "--static-tables", *study["static"], "--findings", *study["findings"],
                            "--figures", *study["figures"], "--fe", str(study["tmp"] / "nope.json"),
                            "--reduction", str(study["tmp"] / "nope2.json"), "--tolerance", str(path),
                            "--out", str(pdf)])
    assert rc == 0
    src = (tmp_path / "report.typ").read_text()
    assert "== Accuracy on request: cost against requested tolerance" in src
    assert "<fig-tolerance>" in src and "<tab-tolerance>" in src
    assert (tmp_path / "report_tolerance_cost.png").stat().st_size > 5000
    for x in (9.6e-3, 9.7e-3, 9.9e-4, 1.1e-3, 9.5e-4):           # estimated and measured, from the file
        assert sci(x) in src, x
    assert '#"spin (verified search)"' in src and '#"refused"' in src
    assert "frozen chain's own choice N" in src and sci(1.5e-2) + ' #"(beyond)"' in src
    assert 'would have missed the request in #"1" of #"1" cases' in src
    tables_by_scene = {"thesis": tables.read_table(study["rank"][0]), "smooth": tables.read_table(study["rank"][1])}
    sm = study_report.tolerance_summary(study_report.tolerance_chart_data(TOLERANCE, tables_by_scene))
    assert len(sm["comparisons"]) > 0 and "$10^(-3)$" in src
    assert (f'in #"{sm["fewer"]}" of #"{len(sm["comparisons"])}" comparisons, as many in #"{sm["equal"]}" '
            f'and more in #"{sm["more"]}"') in src
    assert 'built #"3" of #"4" requests' in src and '#"2" of #"3" are within the request' in src
    assert sci(1.1e-3) + ' #"(beyond)"' in src and sci(9.7e-3) + ' #"(within)"' in src
    # without the bench's file the section says what makes it
    pdf2 = tmp_path / "b" / "report.pdf"
    assert study_report.main(["--scenes", *study["scenes"], "--ranking-tables", *study["rank"],
                              "--static-tables", *study["static"], "--findings", *study["findings"],
                              "--figures", *study["figures"], "--fe", str(study["tmp"] / "nope.json"),
                              "--reduction", str(study["tmp"] / "nope2.json"), "--out", str(pdf2)]) == 0
    src = (tmp_path / "b" / "report.typ").read_text()
    assert "== Accuracy on request" in src and "made by snakemake bench" in src


def _convergence_check(name, sizes, deviation, count=20):
    return {"name": f"{name} mesh convergence, first {count} supported modes", "value": 0.004,
            "tolerance": 0.005, "passed": True, "mesh_sizes": sizes,
            "frequencies_hz": [[1.0] * count for _ in sizes], "deviation_per_mode": deviation}


def test_study_report_shows_the_mesh_convergence_of_every_mode_from_the_last_verify(study, tmp_path):
    """fe.json's convergence checks (snakemake verify) become a table and a figure of all modes: the
    default mesh's largest deviation over the verdict's modes and over all, the worst mode and the
    count above 1 %, per body (rings: default = the middle level; platform: the coarsest)."""
    import json
    rng = np.random.default_rng(0)
    ring = [list(rng.uniform(1e-3, 2e-2, 100)), list(rng.uniform(1e-4, 4e-3, 100)), [0.0] * 100]
    ring[1][57] = 0.0123                                    # mode 58, beyond the verdict's 20
    plate = [list(rng.uniform(1e-4, 9e-3, 100)), list(rng.uniform(1e-5, 1e-3, 100)), [0.0] * 100]
    fe = {"checks": [_convergence_check("outer_gimbal", [0.5, 0.25, 0.125], ring),
                     _convergence_check("stable_platform", [0.5, 0.25, 0.125], plate),
                     {"name": "ring in-plane modes", "value": 1e-3, "tolerance": 3e-3, "passed": True}]}
    path = tmp_path / "fe.json"
    path.write_text(json.dumps(fe))
    pdf = tmp_path / "report.pdf"
    assert study_report.main(["--scenes", *study["scenes"], "--ranking-tables", *study["rank"],
                              "--static-tables", *study["static"], "--findings", *study["findings"],
                              "--figures", *study["figures"], "--fe", str(study["tmp"] / "nope.json"),
                              "--reduction", str(study["tmp"] / "nope2.json"), "--fe-full", str(path),
                              "--out", str(pdf)]) == 0
    src = (tmp_path / "report.typ").read_text()
    assert "<tab-convergence>" in src and "<fig-convergence>" in src
    assert (tmp_path / "report_mesh_convergence.png").stat().st_size > 5000
    outer = src[src.index('#"outer gimbal"'):].split("\n")[0]
    assert sci(max(ring[1][:20])) in outer and sci(0.0123) in outer and '#"58"' in outer
    assert f'#"{sum(v > 0.01 for v in ring[1])}"' in outer
    platform = src[src.index('#"stable platform"'):].split("\n")[0]
    assert sci(max(plate[0])) in platform              # the platform's default is its coarsest level
    # without per-mode deviations (an fe.json of before) there is no convergence table
    fe["checks"][0].pop("deviation_per_mode")
    fe["checks"][1].pop("deviation_per_mode")
    path.write_text(json.dumps(fe))
    assert study_report.main(["--scenes", *study["scenes"], "--ranking-tables", *study["rank"],
                              "--static-tables", *study["static"], "--findings", *study["findings"],
                              "--figures", *study["figures"], "--fe", str(study["tmp"] / "nope.json"),
                              "--reduction", str(study["tmp"] / "nope2.json"), "--fe-full", str(path),
                              "--out", str(tmp_path / "b" / "report.pdf")]) == 0
    assert "<tab-convergence>" not in (tmp_path / "b" / "report.typ").read_text()


def test_a_truth_whose_own_error_exceeds_the_rigid_models_is_said_not_to_referee():
    """On a scene where the truth against the larger basis is farther (outer rate) than the rigid
    model is from the truth (long: 2.3e-3 against 1.1e-3), the report says the truth cannot separate
    that scene's reduced models; below the rigid model's error it says nothing."""
    an = {"long": study_report.analyse_scene(ROWS)}
    rigid = an["long"]["rigid"][0]
    basis = {"larger_basis": "freq-200", "scenes": {"long": {"E": [2 * rigid, 0, 0, 0], "E_max": 2 * rigid}}}
    assert study_report.unrefereed_scenes(an, basis) == [("long", 2 * rigid, rigid)]
    ctx = {"scenes": [{"name": "long"}], "truth_basis": basis, "dates": {}, "missing": {}}
    assert "below what this truth resolves" in study_report.truth_error_section(ctx, an)
    basis["scenes"]["long"]["E"][0] = 0.5 * rigid
    assert study_report.unrefereed_scenes(an, basis) == []
    assert "below what this truth resolves" not in study_report.truth_error_section(ctx, an)


def test_page_one_is_the_decision_with_the_measured_times(study, tmp_path):
    """With a decision file, the study report opens with the decision tables (before the outline),
    every answer quoting the decision's model, coordinates and timing-job medians; a requirement
    below the truth's resolution reads "not resolvable"; the findings on an unresolved rate too."""
    import json
    from gimbal_reduction.results.study import decision
    scenes = []
    for name, rt, st in zip(("thesis", "smooth"), study["rank"], study["static"]):
        rows = tables.read_table(rt) + tables.read_table(st)
        runtime = {"models": {r["model"]: {"run_ms": 2.5, "setup_ms": 30.0} for r in rows}}
        basis = {"E": [1e-3 if name == "thesis" else 10.0] * 4, "attitude_max_arcsec": 1.0}
        scenes.append(decision.decide_scene(name, rows, np.ones(4), basis, runtime))
    dec = tmp_path / "decision.json"
    dec.write_text(json.dumps({"measures": {m: {"unit": decision.MEASURE_UNITS[m],
                                                "label": decision.MEASURE_LABELS[m]} for m in decision.MEASURES},
                               "scenes": scenes}))
    pdf = tmp_path / "report.pdf"
    assert study_report.main(["--scenes", *study["scenes"], "--ranking-tables", *study["rank"],
                              "--static-tables", *study["static"], "--findings", *study["findings"],
                              "--figures", *study["figures"], "--fe", "x", "--reduction", "y",
                              "--decision", str(dec), "--out", str(pdf)]) == 0
    src = (tmp_path / "report.typ").read_text()
    assert src.index("= The decision") < src.index("#outline") < src.index("= Summary")
    met = next(r for r in scenes[0]["rows"] if r["status"] == "met" and r["model"] != "truth")
    assert f'*#"{met["model"]}"* (#"{met["coordinates"]}") #"2.5 ms" + #"30 ms"' in src
    assert '#"not resolvable"' in src
    # smooth: the truth's error (E = 10) exceeds every model's: no finding is judged there
    assert "not resolvable: the truth's own error exceeds it" in src


def test_reference_lines_name_the_route_an_anchor_row_checked():
    """An anchor row of the references' other Adams order (exponential_accuracy --anchor-orders) is
    the truth by that route, not the scene's reference; kinds with commas are kept apart."""
    from gimbal_reduction.results.study.study_report import reference_lines
    case = {"E_max": 3.8e-9}
    accuracy = {"rows": [{"reference_kind": "exponential tol 1e-07, order 4", "default": case},
                         {"reference_kind": "exponential tol 5e-09, order 2", "default": case}],
                "anchors": [{"scene": "thesis", "reference": "exponential tol 1e-07, order 4",
                             "anchor": "dop853 rtol 1e-10", "E_max": 1.6e-11},
                            {"scene": "thesis", "reference": "exponential tol 1e-07, order 2",
                             "anchor": "dop853 rtol 1e-10", "E_max": 1.2e-10, "route_order": 2}]}
    text = reference_lines(accuracy).replace('#"', "").replace('"', "")     # Typst strings unquoted
    assert "order 4; exponential tol 5e-09, order 2" in text
    assert "thesis reference (exponential tol 1e-07, order 4)" in text
    assert "thesis truth by the references' order-2 route (exponential tol 1e-07, order 2)" in text
