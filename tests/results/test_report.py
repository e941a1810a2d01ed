"""gimbal_reduction.results.study.figures and gimbal_reduction.results.study.report: files written, manifest, the Typst PDF rendered and inspected.

The PDF checks use Debian's poppler-utils (pdftotext, pdfinfo, pdftoppm)."""
from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pytest

from gimbal_reduction.results.study import decision, figures, report
from gimbal_reduction.reduction.names import STYLES
from gimbal_reduction.results.study.cases import GROUPS
from tests.results.synthetic_study import write_tables

pytest.importorskip("typst")
POPPLER = all(shutil.which(t) for t in ("pdftotext", "pdfinfo", "pdftoppm"))
needs_poppler = pytest.mark.skipif(not POPPLER, reason="poppler-utils (pdftotext, pdftoppm) missing")
RATE_CASES = ("freq-5", "xmx-10", "static-4", "static-10@2:input_motor_my")


@pytest.fixture(scope="module")
def study_outputs(tmp_path_factory):
    """Synthetic study -> tables, findings, figures (rate figures for RATE_CASES only)."""
    tmp = tmp_path_factory.mktemp("results")
    truth, cases, rt, st, fj = write_tables(str(tmp), str(tmp / "tables"))
    rate_files = [p for p in cases if any(p.endswith(f"/{m}.h5") for m in RATE_CASES)]
    fig_dir = tmp / "figures"
    assert figures.main(["--truth", truth, "--cases", *rate_files, "--ranking-table", str(rt),
                         "--static-table", str(st), "--out-dir", str(fig_dir)]) == 0
    return {"tmp": tmp, "truth": truth, "ranking": rt, "static": st, "findings": fj, "figures": fig_dir}


def test_figures_written_with_manifest(study_outputs):
    d = study_outputs["figures"]
    manifest = json.loads((d / "figures.json").read_text())["figures"]
    ids = [f["id"] for f in manifest]
    assert {"error_ranking", "error_static", "error_load_cases", "runtime_error"} <= set(ids)
    assert sum(f["kind"] == "rates" for f in manifest) == len(RATE_CASES)
    assert "rates_static-10_at2_input_motor_my" in ids
    for f in manifest:
        assert (d / f["pdf"]).read_bytes()[:5] == b"%PDF-" and "png" not in f   # the reports read PDFs only
        assert f["caption"]
    assert not list(d.glob("*.png"))
    assert [f["thesis_figure"] for f in manifest if f["id"] == "error_ranking"] == ["4-28"]


@needs_poppler
def test_figure_pdfs_are_vector_with_labels(study_outputs):
    d = study_outputs["figures"]
    text = subprocess.run(["pdftotext", str(d / "error_ranking.pdf"), "-"], capture_output=True,
                          text=True, check=True).stdout
    assert "vibration modes per body" in text and "XMGMX-ranked" in text
    text = subprocess.run(["pdftotext", str(d / "rates_freq-5.pdf"), "-"], capture_output=True,
                          text=True, check=True).stdout
    assert "time t [ms]" in text and "rad/s" in text and "E = " in text


def test_pareto_front():
    cost = np.array([1.0, 2.0, 3.0, 0.5, 4.0])
    err = np.array([1.0, 0.5, 0.7, 2.0, 0.1])
    assert figures.pareto_front(cost, err) == [3, 0, 1, 4]
    assert figures.safe_name("static-10@2:output_motor_fz+output_motor_my") == \
        "static-10_at2_output_motor_fz_plus_output_motor_my"


def test_typst_escaping():
    assert report.s('a "b" \\ #c $d$') == '#"a \\"b\\" \\\\ #c $d$"'
    assert report.sci(1.234e-5) == "$1.23 times 10^(-5)$"
    assert report.sci(0.5) == "$0.5$" and report.sci(float("nan")) == "--"


def _pdf_text(pdf):
    return subprocess.run(["pdftotext", "-layout", str(pdf), "-"], capture_output=True, text=True,
                          check=True).stdout


def _pages(pdf):
    info = subprocess.run(["pdfinfo", str(pdf)], capture_output=True, text=True).stdout
    return int(next(l.split()[-1] for l in info.splitlines() if l.startswith("Pages:")))


@needs_poppler
def test_report_pdf_has_sections_tables_and_figures(study_outputs, tmp_path):
    out = tmp_path / "report" / "report.pdf"
    so = study_outputs
    code = report.main(["--ranking-table", str(so["ranking"]), "--static-table", str(so["static"]),
                        "--findings", str(so["findings"]), "--figures", str(so["figures"] / "figures.json"),
                        "--truth", so["truth"], "--out", str(out),
                        # no benchmark, whatever the project's results/ holds
                        "--exponential-bench", str(tmp_path / "no_benchmark.json")])
    assert code == 0 and out.read_bytes()[:5] == b"%PDF-"
    assert (tmp_path / "report" / "report.typ").exists()
    text = _pdf_text(out)
    for heading in ("Summary", "Methods", "Equations of motion", "Integrator", "Error measure",
                    "Results", "Error tables", "Findings", "Cost against error", "Provenance"):
        assert heading in text, heading
    for heading in ("Geometry and material", "Natural frequencies", "Mode ranking criteria"):
        assert heading not in text, heading                     # the model report's, once
    # tables typeset as text, with numbered captions
    assert "Table 1:" in text and "analogue of thesis Table 4.2" in text
    assert "analogue of thesis Table 4.3" in text and "The findings on this scene: rule, control and verdict" in text
    # run times are not quoted from single runs: the benchmark is named as missing
    assert "no run time is quoted from single runs" in (tmp_path / "report" / "report.typ").read_text()
    assert "output_motor_my" in text and "reproduced" in text
    # figures: numbered captions, and the vector figures' own labels are text in the PDF
    n_captions = text.count("Figure ")
    assert n_captions >= 4 + len(RATE_CASES)
    assert "vibration modes per body" in text and "elastic coordinates of the model" in text
    pages = _pages(out)
    assert pages >= 6
    # render every page to PNG; the figure pages carry ink (not blank)
    subprocess.run(["pdftoppm", "-r", "40", "-png", str(out), str(tmp_path / "page")], check=True)
    pngs = sorted(tmp_path.glob("page-*.png"))
    assert len(pngs) == pages
    import matplotlib.image as mpimg
    ink = [float(np.mean(mpimg.imread(p)[..., :3] < 0.5)) for p in pngs]
    # a sparse 7-pt table page at 40 dpi inks ~7e-4; a blank page ~0
    assert max(ink) > 0.02 and all(i > 3e-4 for i in ink), [(k, i) for k, i in enumerate(ink) if i <= 3e-4]


@needs_poppler
def test_model_report_holds_what_does_not_depend_on_the_scene(tmp_path):
    out = tmp_path / "model.pdf"
    assert report.main(["--part", "model", "--out", str(out),
                        "--ranking-table", str(tmp_path / "none.csv")]) == 0
    text = _pdf_text(out)
    for heading in ("Geometry and material", "Natural frequencies", "Mode ranking criteria",
                    "Static correction modes", "coupled chain"):
        assert heading in text, heading
    assert "Error tables" not in text and "Findings" not in text


@needs_poppler
def test_report_builds_without_inputs(tmp_path):
    out = tmp_path / "report.pdf"
    missing = {k: str(tmp_path / f"missing_{k}") for k in report.DEFAULTS if k != "out"}
    args = [a for k, v in missing.items() for a in ("--" + k.replace("_", "-"), v)]
    assert report.main([*args, "--out", str(out)]) == 0
    text = _pdf_text(out)
    assert "Incomplete report" in text and "Not available" in text
    assert "missing" in text and "not evaluated" in text
    assert "Provenance" in text and _pages(out) >= 2


def test_study_groups_have_labels():
    assert set(GROUPS) <= set(STYLES) and all(STYLES[g].label and STYLES[g].colour for g in GROUPS)


def test_summary_names_the_rigid_baseline_and_the_best_reduced_model():
    """The scene summary counts the reduced models that beat the rigid one on the outer rate and
    names the most accurate reduced model; the truth check (truth + residual flexibility, here the
    smallest E) referees the truth and is neither."""
    def row(group, model, e, n):
        return {"group": group, "model": model, "E_outer_gimbal": e, "n_elastic": n}
    rows = [row("rigid", "rigid", 0.04, 0), row("freq", "freq-5", 0.05, 20), row("freq", "freq-25", 0.03, 100),
            row("global", "global-40", 0.02, 40), row("truth-check", "static-100", 2e-12, 404)]
    ctx = {"ranking_rows": rows, "static_rows": [], "findings": [], "truth": True, "missing": {},
           "scene": {"name": "thesis"}}
    text = "".join(report._summary(ctx))
    assert '#"2" of #"3" reduced models beat it' in text           # Typst source: #"..." is text
    assert 'Most accurate reduced model on the outer gimbal rate: #"global-40"' in text
    assert "static-100" not in text.split("Baseline")[1]      # named only as the truth check
    # with the truth's resolution: resolvable (a small truth error) and not (one above rigid's E)
    res = {"E_per_rate": [1e-8] * 4, "rate_per_rate": [1e-6] * 4, "attitude": 0.1, "E": 1e-8,
           "rate": 1e-6, "sources": ["static-100"]}
    for E_res, resolved in ((1e-8, True), (0.05, False)):
        res = {**res, "E_per_rate": [E_res] * 4, "E": E_res}
        full = [{**r, **{c: r["E_outer_gimbal"] for c in ("E_middle_gimbal", "E_inner_gimbal",
                                                          "E_stable_platform")}} for r in rows]
        d = {"resolution": res, "rows": [], "rate_resolved": [decision.rate_resolved(full, 0, E_res)] * 4,
             "best": [decision.best(full, k, E_res) for k in range(4)]}
        text = "".join(report._summary({**ctx, "ranking_rows": full, "decision": d}))
        assert ("reduced models beat it" in text) == resolved
        assert ("no reduced model can be shown better" in text) != resolved


@pytest.mark.parametrize("name, duration, start", [("thesis", "lasts 15 ms", "steps from zero to 1 rad"),
                                                   ("smooth", "lasts 15 ms", "rises from zero"),
                                                   ("long", "lasts 1 s", "steps from zero to 1 rad"),
                                                   ("damped", "damping ratio 0.01", "steps from zero")])
def test_methods_describe_the_scene_from_its_file(name, duration, start):
    """The scene report's methods say what drives the chain on its own scene, read from the scene file
    (the text said "the scene lasts 15 ms" on the 1 s scene long)."""
    import os
    from gimbal_reduction.solver.dynamics.scenes import SCENES_DIR
    from gimbal_reduction.workflow import yamlfile
    text = report._scene_sentence(yamlfile.load_file(os.path.join(SCENES_DIR, f"{name}.yaml")))
    assert duration in text and start in text


def test_report_names_inputs_made_at_another_revision(study_outputs, tmp_path):
    """A bench result made by other code (another git revision) is listed as possibly stale, with its
    revision, in the summary and in the inputs table."""
    old = tmp_path / "exponential.json"
    old.write_text(json.dumps({"rows": [], "provenance": {"git": "0000000"}}))
    so = study_outputs
    ctx = report.gather({"ranking_table": str(so["ranking"]), "static_table": str(so["static"]),
                         "findings": str(so["findings"]), "exponential_bench": str(old)})
    if report.git_revision() == "unknown":
        pytest.skip("no git revision here to compare with")
    assert "0000000" in ctx["stale"]["exponential_bench"] and "revision 0000000" in ctx["status"]["exponential_bench"]
    text = "".join(report._summary(ctx))
    assert "Made at another revision" in text and "0000000" in text


def test_the_methods_name_the_truth_integrators_tolerance():
    """The truth's tolerance (its simulation file's stat_tol: the scene's own on long) is in the
    methods' list of integrators; a fixed-step run (NaN) has none."""
    ctx = {"truth": {"integrator": "exponential", "steps": 12301, "stat_tol": 1e-6},
           "scene": {"duration": {"value": 1.0}}, "ranking_rows": [], "static_rows": []}
    assert "tolerance 1e-06" in report._integrators(ctx)
    ctx["truth"]["stat_tol"] = float("nan")
    assert "tolerance" not in report._integrators(ctx)


def test_inert_load_cases_are_those_within_the_tolerance_of_the_control():
    cols = ("E_outer_gimbal", "E_middle_gimbal", "E_inner_gimbal", "E_stable_platform")
    control = dict(zip(cols, (0.5, 0.1, 1e-3, 1e-4)))
    same = {"load_case": "output_motor_mz", **{c: v * (1 + 1e-5) for c, v in control.items()}}
    moved = {"load_case": "output_motor_fz", **{c: v * (1 + 1e-5) for c, v in control.items()},
             "E_stable_platform": 2e-4}
    assert report.inert_load_cases(control, [same, moved]) == ["output_motor_mz"]
    assert report.inert_load_cases(None, [same]) == []
