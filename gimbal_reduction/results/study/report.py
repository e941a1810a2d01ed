"""The study's PDF report, typeset with Typst (PyPI package ``typst``): results/report/report.pdf.

    python -m gimbal_reduction.results.study.report \\
        --ranking-table results/tables/errors_ranking.csv \\
        --static-table results/tables/errors_static.csv \\
        --findings results/tables/findings.json \\
        --figures-dir results/figures/study \\
        --fe results/verification/fe.json --modes-benchmark results/benchmarks/modes.json \\
        --reduction results/verification/reduction.json \\
        --truth results/sim/thesis/truth.h5 \\
        --config config/config.yaml --scene config/scenes/thesis.yaml \\
        --out results/report/report.pdf

Every option has the default shown, so ``python -m gimbal_reduction.results.study.report`` builds the
report from whatever exists.  A missing input is not an error: the section
that needs it says which file is missing and how it is made.  The Typst
source is written beside the PDF (``report.typ``).  Figures are the vector
PDFs listed in ``<figures-dir>/figures.json`` (``gimbal_reduction.results.study.figures``), tables
are typeset from the CSV/JSON data, no text is an image.

Pure parts: ``gather`` (reads the inputs into one dict, recording what is
missing), ``typst_source`` (dict -> Typst markup), ``compile_pdf``.
"""
from __future__ import annotations

import argparse
import csv
import os
import sys
import time

import numpy as np

from gimbal_reduction.reduction import names
from gimbal_reduction.results.study import decision, findings
from gimbal_reduction.results.study.cases import (
    BODY_LABELS,
    LOAD_CASES,
    MODE_COUNTS,
    RANKING_TABLE_GROUPS,
    REFEREES,
    STATIC_COUNTS,
    study_cases,
)
from gimbal_reduction.results.study.tables import RATE_COLUMNS, read_table
from gimbal_reduction.solver.bodies import BODIES
from gimbal_reduction.solver.dynamics.error_measure import SAMPLING_MARGIN, SAMPLING_SHARE
from gimbal_reduction.solver.dynamics.simfile import read_sim
from gimbal_reduction.workflow import units
from gimbal_reduction.workflow import config as cfgmod
from gimbal_reduction.workflow.config import BODY_NAMES, load_config
from gimbal_reduction.results.markup import (MARKS_LEGEND, compile_pdf, figure, ms, note, page_setup, read_json,
                                             read_yaml, report_versions, s, sci, table, verdict_marks)
from gimbal_reduction.workflow.provenance import git_revision, other_revision, provenance

ROOT = str(cfgmod.ROOT)   # the project folder (workflow.config.project_dir)
DEFAULTS = {
    "ranking_table": "results/tables/errors_ranking.csv",
    "static_table": "results/tables/errors_static.csv",
    "findings": "results/tables/findings.json",
    "figures": "results/figures/study/figures.json",
    "fe": "results/verification/fe.json",
    "modes_benchmark": "results/benchmarks/modes.json",
    "reduction": "results/verification/reduction.json",
    "truth": "results/sim/thesis/truth.h5",
    "config": "config/config.yaml",
    "scene": "config/scenes/thesis.yaml",
    "stability": "results/stability/stability.json",
    "pareto": "results/benchmarks/pareto.csv",
    "scaling": "results/benchmarks/scaling.json",
    "selection": "results/tables/selection.csv",
    "integrators": "results/benchmarks/integrator_tables.json",
    "dynamics": "results/verification/dynamics.json",
    "exponential": "results/verification/exponential.json",
    "exponential_bench": "results/benchmarks/exponential.json",
    "fe_full": "results/verification/fe.json",
    "coupled_modes": "results/study/thesis/coupled_modes.json",
    "decision": "results/tables/decision.json",
    "out": "results/report/report.pdf",
}
MAKES = {"ranking_table": "python -m gimbal_reduction.results.study.tables", "static_table": "python -m gimbal_reduction.results.study.tables",
         "findings": "python -m gimbal_reduction.results.study.findings", "figures": "python -m gimbal_reduction.results.study.figures",
         "fe": "snakemake verify_fe", "modes_benchmark": "snakemake modes",
         "reduction": "python -m gimbal_reduction.reduction.report", "truth": "python -m gimbal_reduction.solver.dynamics.simulate --model truth",
         "config": "the project's config", "scene": "the scene file",
         "stability": "snakemake stability", "pareto": "snakemake pareto",
         "scaling": "snakemake scaling", "selection": "snakemake selection",
         "integrators": "snakemake results/benchmarks/integrator_tables.json",
         "dynamics": "snakemake verify", "exponential": "snakemake verify",
         "exponential_bench": "snakemake bench", "fe_full": "snakemake verify",
         "coupled_modes": "snakemake study (gimbal_reduction.results.study.run_scene --coupled-modes)",
         "decision": "snakemake results/tables/decision.json"}
# The inputs made by other targets than the report's (bench, verify): the report names their revision
OPTIONAL_KEYS = ("stability", "pareto", "scaling", "selection", "integrators", "dynamics", "exponential",
                 "exponential_bench", "fe_full")
# Lists of files (the rule hands over each file, never a folder)
LIST_DEFAULTS = {
    "mode_shapes": [f"results/figures/mode_shapes_body{b}.json" for b in (2, 3, 4, 5)],
    "bench_figures": ["results/figures/bench/pareto.png", "results/figures/bench/scaling.png",
                      "results/figures/bench/global_ranking.png", "results/figures/stability/rk4_limit.png",
                      "results/figures/stability/energy_drift.png"],
}
# Figures of the performance section: (key, the end of its path, caption)
BENCH_FIGURES = (
    ("pareto", "bench/pareto.png", "Wall time (median of repeated runs) against the error E of eq. 3.53 "
     "with respect to the converged truth, for every reduced model and integrator; the line is the "
     "Pareto front (gimbal_reduction.results.bench.pareto)."),
    ("scaling", "bench/scaling.png", "Cost per right-hand-side evaluation and per simulated second "
     "against the number of elastic coordinates, structured recursion vs the dense-mass-matrix "
     "baseline timed in the same run (gimbal_reduction.results.bench.scaling)."),
    ("global", "bench/global_ranking.png", "Error against total elastic coordinates: the pooled "
     "(global) load-aware ranking, the per-body load-aware ranking, XMX and frequency cutoff, with "
     "the a-priori estimate (gimbal_reduction.reduction.load_aware, gimbal_reduction.results.bench.selection)."),
    ("rk4_limit", "stability/rk4_limit.png", "Measured RK4 stability limit against 2.785/omega_max "
     "for several reduced models (gimbal_reduction.results.bench.stability)."),
    ("drift", "stability/energy_drift.png", "Energy drift on scene free_10s (10 s; its first second in "
     "the main job's version), per integrator (gimbal_reduction.results.bench.stability)."),
)
N_FREQ_ROWS = 10


# ---------------------------------------------------------------- reading inputs
def _abs(p):
    return p if os.path.isabs(p) else os.path.join(ROOT, p)


def _csv_rows(path):
    """Rows of a CSV file as dicts of strings."""
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _num(text, default=np.nan):
    try:
        return float(text)
    except (TypeError, ValueError):
        return default


def note_revision(stale: dict, key: str, path: str, shown: str, makes: str) -> str:
    """If ``path`` (named ``shown`` in the text) was made at another git revision than this report
    (``other_revision``), record why it may be stale in ``stale[key]`` and return ", revision X" for
    its date; else return ""."""
    made = other_revision(path)
    if not made:
        return ""
    stale[key] = f"{shown} was made at revision {made}, this report at {git_revision()}: rerun {makes} if " \
                 "the code changed since"
    return f", revision {made}"


def version_of(path: str) -> str:
    """Which version of a check ``path`` holds: the main job's (`snakemake all` writes its cheap
    versions below results/all/) or the extended one (`snakemake verify`, `bench`)."""
    parts = os.path.abspath(path).split(os.sep)
    return "main job's version" if any(a == "results" and b == "all" for a, b in zip(parts, parts[1:])) \
        else "extended version"


def stale_list(stale: dict, keyed=False) -> str:
    """The report's paragraph on the inputs made at another revision (``note_revision``), each named
    by its key too if ``keyed``."""
    return ("*Made at another revision.* These inputs come from another version of the code than this "
            "report, so they may be stale:\n"
            + "".join(f"- {s(k) + ': ' if keyed else ''}{s(why)}\n" for k, why in stale.items()))


def gather(paths: dict) -> dict:
    """Everything the report shows, from the input files (keys of DEFAULTS); each input that
    is missing or unreadable is recorded in ``missing`` ({key: reason}) and left None."""
    p = {k: _abs(paths.get(k) or v) for k, v in DEFAULTS.items()}
    p.update({k: [_abs(f) for f in (paths.get(k) or v)] for k, v in LIST_DEFAULTS.items()})
    ctx = {"paths": p, "missing": {}, "status": {}, "stale": {}}

    def load(key, reader):
        path = p[key]
        if not os.path.exists(path):
            ctx["missing"][key] = f"{os.path.relpath(path, ROOT)} missing (made by {MAKES[key]})"
            ctx["status"][key] = "missing"
            return None
        try:
            out = reader(path)
        except Exception as exc:  # noqa: BLE001 - a broken input is reported, not fatal
            ctx["missing"][key] = f"{os.path.relpath(path, ROOT)} unreadable ({exc.__class__.__name__}: " \
                                  f"{str(exc).splitlines()[0][:120] if str(exc) else ''})"
            ctx["status"][key] = "unreadable"
            return None
        ctx["status"][key] = time.strftime("%Y-%m-%d %H:%M", time.localtime(os.path.getmtime(path)))
        if key in OPTIONAL_KEYS:
            ctx["status"][key] += f", {version_of(path)}" + note_revision(
                ctx["stale"], key, path, os.path.relpath(path, ROOT), MAKES[key])
        return out

    ctx["ranking_rows"] = load("ranking_table", read_table) or []
    ctx["static_rows"] = load("static_table", read_table) or []
    ctx["fe"] = load("fe", read_json)
    ctx["modes_benchmark"] = load("modes_benchmark", read_json)
    ctx["reduction"] = load("reduction", read_json)
    ctx["config"] = load("config", load_config)    # values in the units the report prints (inch, lbf, s)
    ctx["scene"] = load("scene", read_yaml)
    ctx["truth"] = load("truth", lambda q: read_sim(q)["attrs"])
    fj = load("findings", read_json)
    if fj and "findings" in fj:
        ctx["findings"], ctx["findings_source"] = fj["findings"], "file"
    else:
        ctx["findings"] = findings.evaluate(ctx["ranking_rows"], ctx["static_rows"], ctx["reduction"])
        ctx["findings_source"] = "computed"
    manifest = load("figures", read_json)
    figs = []
    for e in (manifest or {}).get("figures", []):
        pdf = os.path.join(os.path.dirname(p["figures"]), e["pdf"])
        if os.path.exists(pdf):
            figs.append({**e, "pdf": pdf})
    ctx["figures"] = figs
    ctx["mode_shapes"] = _mode_shape_figures(p["mode_shapes"])
    ctx["stability"] = load("stability", read_json)
    ctx["pareto_rows"] = load("pareto", _csv_rows) or []
    ctx["scaling"] = load("scaling", read_json)
    ctx["selection_rows"] = load("selection", _csv_rows) or []
    ctx["integrators"] = load("integrators", read_json)
    for key in ("dynamics", "exponential", "exponential_bench", "fe_full", "coupled_modes"):
        ctx[key] = load(key, read_json)
    # this scene's decision: the truth's resolution, the decision rows, the sampling check
    name = (ctx["scene"] or {}).get("name")
    ctx["decision"] = next((d for d in (load("decision", read_json) or {}).get("scenes", [])
                            if d["scene"] == name), None)
    if ctx["decision"]:
        ctx["findings"] = decision.resolve_findings(ctx["findings"], ctx["ranking_rows"] + ctx["static_rows"],
                                                    ctx["decision"]["resolution"])
    ctx["bench_figures"] = [(key, path, cap) for key, rel, cap in BENCH_FIGURES
                            for path in p["bench_figures"]
                            if path.endswith(os.sep + rel) and os.path.exists(path)]
    ctx["versions"] = report_versions()
    ctx["date"] = time.strftime("%Y-%m-%d %H:%M:%S %Z")
    return ctx


def _mode_shape_figures(files):
    """[(png, caption)] of the mode-shape manifests (gimbal_reduction.results.study.mode_shapes --manifest: the
    lowest and best-ranked modes, and the static modes, of one body each); a plain PNG is taken
    with a generic caption."""
    out = []
    for f in files:
        if not os.path.exists(f):
            continue
        if f.endswith(".json"):
            base = os.path.dirname(os.path.abspath(f))
            for e in read_json(f).get("figures", []):
                png = os.path.join(base, e["png"])
                if os.path.exists(png):
                    out.append((png, e.get("caption", "")))
        else:
            out.append((f, "Supported mode shapes of one body."))
    return out


def _cv(cfg, *keys, default=None):
    cur = cfg
    for k in keys:
        if not isinstance(cur, dict) or k not in cur:
            return default
        cur = cur[k]
    return cur.get("value", default) if isinstance(cur, dict) else cur


# ---------------------------------------------------------------- sections
def _summary(ctx):
    rows = [r for r in ctx["ranking_rows"] + ctx["static_rows"] if r["group"] != "truth"]
    thesis = study_cases(extended=False)
    added = [c for c in study_cases() if c["model"] not in {x["model"] for x in thesis}]
    have = {r["model"] for r in rows}
    dec = ctx.get("decision")
    name = (ctx["scene"] or {}).get("name", "")
    out = ["= Summary\n\n",
           f"This report holds the results of one scene, {s(name)}, of the reproduction of P. J. "
           "Balucan, _Model Reduction of a Set of Elastic, Nested Gimbals by Component Mode Selection "
           "Criteria and Static Correction Modes_ (S.M. thesis, MIT, 2001). The bodies, their modes and "
           "the mode selection are in the model report (results/report/model.pdf); the decision which "
           "model to use, on every scene, is page 1 of the study report (results/report/report.pdf).\n\n"]
    out.append(f"- Cases with results: {s(sum(c['model'] in have for c in thesis))} of the thesis's "
               f"{s(len(thesis))} cases (its 25 figures and table columns, with its one \"ranked\" "
               f"selection run as both XMX and XMGMX), and {s(sum(c['model'] in have for c in added))} of "
               f"the project's {s(len(added))} additions (the rigid baseline, the no-static controls "
               f"freq-2..8, load-N, global-N, the field's defaults dom-N, cb-N, ritz-N and Craig-Bampton at "
               f"equal coordinates, and the truth checks static-100 and cb-100)"
               f"{'' if ctx['truth'] else ' (truth model missing)'}.\n")
    counts = {}
    for f in ctx["findings"]:
        key = "thesis" if f["finding"] <= 6 else "ours"
        counts.setdefault(key, {}).setdefault(f["verdict"], 0)
        counts[key][f["verdict"]] += 1
    for key, what in (("thesis", "The thesis's findings 1-6"), ("ours", "The project's findings 7-10")):
        if key in counts:
            out.append(f"- {what}: " + ", ".join(f"{s(v)} {s(k)}" for k, v in counts[key].items())
                       + " (@findings).\n")
    # the truth check (the truth + residual flexibility) referees the truth: not a reduced model
    reduced = [r for r in rows if r["group"] not in ("rigid", "truth-check", "truth-interface")]
    rigid = next((r for r in rows if r["group"] == "rigid"), None)
    if rigid is not None and np.isfinite(rigid["E_outer_gimbal"]):
        beat = [r for r in reduced if r["E_outer_gimbal"] < rigid["E_outer_gimbal"]]
        unresolved = dec is not None and not dec["rate_resolved"][0]
        out.append(f"- Baseline: the rigid model (no elastic modes) has outer-gimbal E = "
                   f"{sci(rigid['E_outer_gimbal'])}; "
                   + ("not resolvable: the truth's own error on that rate is as large, so no reduced "
                      "model can be shown better than the rigid one.\n" if unresolved else
                      f"{s(len(beat))} of {s(len(reduced))} reduced models beat it on that rate.\n"))
    if not dec:
        best = _best_case(reduced)
        if best:
            out.append(f"- Most accurate reduced model on the outer gimbal rate: {s(best['model'])} "
                       f"(E = {sci(best['E_outer_gimbal'])}; not checked against the truth's own error: "
                       "the decision file is missing).\n")
    if dec:
        res = dec["resolution"]
        out.append(f"- The truth's own error on this scene (the larger of its two checks, "
                   f"{s(', '.join(res['sources']))}): E = {sci(res['E'])} on the worst rate, "
                   f"{sci(res['rate'])} rad/s RMS, {sci(res['attitude'])} arcsec of platform attitude. "
                   "Errors and differences below it are marked not resolvable (n.r.) throughout.\n")
        items = []
        for label, b in zip(("outer", "middle", "inner", "platform"), dec["best"]):
            if b["status"] == decision.NOT_RESOLVABLE:
                items.append(f"{label}: not resolvable ({s(b['model'])} and {s(len(b['ties']))} other "
                             "models within the truth's own error of it)")
            elif b["model"]:
                items.append(f"{label}: {s(b['model'])} (E = {sci(b['E'])})")
        out.append("- Most accurate reduced model per rate: " + "; ".join(items) + ".\n")
        met = [r for r in dec["rows"] if r["status"] == "met" and r["measure"] == "attitude"]
        if met:
            items = [f"{s(format(r['requirement'], 'g'))} arcsec: {s(r['model'])} "
                     f"({s(r['coordinates'])} coordinates)" for r in met]
            out.append("- Cheapest model for a platform attitude error of at most: " + "; ".join(items)
                       + ".\n")
    if ctx["missing"]:
        out.append("\n*Incomplete report.* These inputs are missing, so the sections that need them "
                   "say so:\n")
        for k, why in ctx["missing"].items():
            out.append(f"- {s(why)}\n")
    if ctx.get("stale"):
        out.append("\n" + stale_list(ctx["stale"]))
    return "".join(out) + "\n"


def _best_case(rows):
    ok = [r for r in rows if np.isfinite(r["E_outer_gimbal"])]
    return min(ok, key=lambda r: r["E_outer_gimbal"]) if ok else None


def _model_section(ctx, root):
    cfg, fe, mb = ctx["config"], ctx["fe"], ctx["modes_benchmark"]
    out = ["= The model\n\n",
           "Units are inch, pound-force and second (mass in lbf s#super[2]/in) throughout. Five bodies "
           "form the chain: the case (rigid, prescribed motion), the outer, middle and inner gimbals "
           "(cylindrical bands) and the stable platform (annular plate). Each elastic body is modelled "
           "separately; its modes are computed with the outer bearings supported.\n\n",
           "== Geometry and material\n\n"]
    if cfg:
        rows = []
        for key in BODY_NAMES:
            b = cfg.get("bodies", {}).get(key, {})
            rows.append([s(key.replace("_", " ")), s(_cv(b, "number")), s(_cv(b, "shape")),
                         s(_cv(b, "diameter")), s(_cv(b, "hole_diameter", default="--")),
                         s(_cv(b, "thickness")), s(_cv(b, "width", default="--")),
                         s(_cv(b, "outer_bearing_distance")),
                         s(_cv(b, "inner_bearing_distance", default="--"))])
        out.append(table(["body", "n", "shape", "diameter [in]", "hole [in]", "thickness [in]",
                          "width [in]", "outer bearings [in]", "inner bearings [in]"], rows,
                         "Geometry of the elastic bodies (thesis Table 2.1; ring diameters are "
                         "mid-surface diameters, band width chosen).", "tab-geometry"))
        E, nu, rho = (_cv(cfg, "material", k) for k in ("youngs_modulus", "poissons_ratio", "density"))
        frac = _cv(cfg, "eccentric_mass", "mass_fraction")
        out.append(f"Material (thesis Table 2.3, all bodies): $E = {sci(E)[1:-1]}$ lbf/in#super[2], "
                   f"$nu = {nu}$, $rho = {sci(rho)[1:-1]}$ lbf s#super[2]/in#super[4] (0.0026 slug/in"
                   f"#super[3]). Each body carries an eccentric point mass of {s(frac)} of its "
                   "structural mass at 45° between +x and +z, moving with the mean translation of "
                   "the band's cross-section (rings) or of a rim patch (platform).\n\n")
    else:
        out.append(note(ctx["missing"].get("config", "config")))
    out.append("== Supports and connection\n\n"
               "The modes of each body are computed with its two outer bearings supported: at the "
               "motor side $u_y = u_z = 0$ and $theta_x = 0$, at the resolver side $u_x = u_y = u_z = 0$, "
               "which removes exactly the six rigid-body motions (thesis Table 2.2). A bearing point "
               "is joined to the body by a rigid-fit average (RBE3-like) over the band's "
               "cross-section line (rings) or a ±11.25° rim face patch (platform), standing for the "
               "thesis's high-stiffness rods. The same operator applies loads and carries the "
               "eccentric mass.\n\n== Mesh\n\n")
    if mb:
        rows = []
        for key in BODY_NAMES:
            b = mb.get("bodies", {}).get(key)
            if b:
                rows.append([s(key.replace("_", " ")), s(b.get("model")), s(b.get("mesh_size_in")),
                             s(b.get("cells")), s(b.get("dofs")), s(b.get("modes")),
                             s(f"{b.get('eigensolve_s', float('nan')):.3g}")])
        out.append("Rings: Reissner-Mindlin (Naghdi) shell, P2 displacement and rotation on flat "
                   "triangles; platform: 3D solid, curved P3 tetrahedra. Eigen-solve: SLEPc "
                   "Krylov-Schur with shift-and-invert.\n\n")
        out.append(table(["body", "model", "mesh size [in]", "cells", "DOFs", "modes",
                          "eigen-solve [s]"], rows, "Meshes and modal solves (results/benchmarks/"
                         "modes.json).", "tab-mesh"))
    else:
        out.append(note(ctx["missing"].get("modes_benchmark", "modes benchmark")))
    out.append("== Natural frequencies\n\n")
    if fe:
        bodies = fe.get("bodies", {})
        n = min([N_FREQ_ROWS] + [len(bodies[k]["supported_hz"]) for k in BODY_NAMES if k in bodies])
        rows = [[s(i + 1)] + [s(f"{bodies[k]['supported_hz'][i]:.1f}") if k in bodies else "--"
                              for k in BODY_NAMES] for i in range(n)]
        out.append(table(["mode", "outer gimbal [Hz]", "middle gimbal [Hz]", "inner gimbal [Hz]",
                          "stable platform [Hz]"], rows,
                         f"The {n} lowest natural frequencies of every body with the outer bearings "
                         f"supported (results/verification/fe.json; 100 modes are kept per body).",
                         "tab-frequencies"))
        masses = ", ".join(f"{k.replace('_', ' ')} {bodies[k]['structural_mass']:.4g}"
                           for k in BODY_NAMES if k in bodies)
        out.append(f"Structural masses [lbf s#super[2]/in]: {s(masses)}. FE verification: "
                   f"{s(sum(c.get('passed', False) for c in fe.get('checks', [])))} of "
                   f"{s(len(fe.get('checks', [])))} checks passed"
                   + (" (@tab-fe-checks).\n\n" if fe.get("checks") else ".\n\n"))
        rows = [[s(c.get("name")), sci(c.get("value")), sci(c.get("tolerance")),
                 s("pass" if c.get("passed") else "FAIL")] for c in fe.get("checks", [])]
        if rows:
            out.append("== Finite-element checks\n\n")
            out.append(table(["check", "value", "tolerance", "verdict"], rows,
                             "Finite-element checks against independent references (results/verification/"
                             "fe_fast.json; fine meshes and MPI: `snakemake verify`).", "tab-fe-checks",
                             columns="(3fr, auto, auto, auto)", size="7.5pt"))
    else:
        out.append(note(ctx["missing"].get("fe", "fe.json")))
    if ctx["mode_shapes"]:
        out.append("== Mode shapes and static modes\n\n")
        # two figures per page: 62 % of the text width (drawn for the full width at 8 pt)
        for png, caption in ctx["mode_shapes"]:
            out.append(figure(png, s(caption), root, width="62%"))
    else:
        out.append(note(f"mode-shape plots {s(', '.join(os.path.relpath(f, ROOT) for f in ctx['paths']['mode_shapes']))} "
                        f"missing (made by python -m gimbal_reduction.results.study.mode_shapes)"))
    return "".join(out)


def _methods_section(ctx):
    out = ["= Mode selection\n\n== Mode ranking criteria\n\n",
           "Each body's modes are ranked by how much of the body's rigid-body inertia they carry "
           "through its bearings. With $P_i$ and $H_i$ the momentum coefficients of mode $i$ (the "
           "rigid translations and rotations it excites), its contribution is "
           "$macron(M)_i = v_i v_i^T$ with $v_i = [P_i; H_i]$, and the modes satisfy "
           "$sum_i macron(M)_i = M_infinity$ (eq 3.32) and "
           "$sum_i macron(M)_i \\/ Omega_i^2 = M G M_infinity$ (eq 3.46). The XMX criterion ranks by "
           "the spectral radius of $M_infinity^(-1\\/2) macron(M)_i M_infinity^(-1\\/2)$, XMGMX by "
           "that of $(M G M_infinity)^(-1\\/2) macron(M)_i (M G M_infinity)^(-1\\/2) \\/ Omega_i^2$. "
           "The lowest-frequency criterion keeps modes in frequency order.\n\n"]
    red = ctx["reduction"]
    if red and "bodies" in red:
        rows = []
        for label, b in sorted(red["bodies"].items()):
            top = b.get("top10", {})
            ag = b.get("ranking_agreement", {})
            topk = dict(zip(ag.get("top_k", []), ag.get("top_k_overlap", [])))
            rows.append([s(f"{label} ({b.get('name', '')})"),
                         s(", ".join(str(m["mode_1based"]) for m in top.get("xmx", [])[:8])),
                         s(", ".join(str(m["mode_1based"]) for m in top.get("xmgmx", [])[:8])),
                         s(ag.get("common_prefix")), s(f"{topk.get(40, '--')}/40")])
        out.append(table(["body", "XMX top 8 (mode no.)", "XMGMX top 8 (mode no.)",
                          "equal leading ranks", "top-40 overlap"], rows,
                         "First ranked modes (1-based numbers in frequency order) and the agreement "
                         "of the two rankings (results/verification/reduction.json; full list: "
                         "results/tables/ranking.csv, the Table 4.1 analogue).", "tab-ranking"))
    else:
        out.append(note(ctx["missing"].get("reduction", "reduction.json")))
    out.append("== Static correction modes\n\n"
               "A static correction mode is the part of the body's static deflection under a unit "
               "load at a bearing that the kept vibration modes miss (eq 3.48): "
               "$phi_s = (G - Phi Lambda^(-1) Phi^T) F$, with $G$ the flexibility of the supported "
               "body, $Phi$ and $Lambda$ the kept modes and eigenvalues, and $F$ the unit load applied "
               "through the bearing operator; it is made exactly mass-orthogonal to the kept modes "
               "and normalised to unit modal mass (docs/reduction.md). It represents the "
               "quasi-static response of the truncated modes. The default "
               "load case is a z-force at the output motor bearing (thesis Figure 4-12); the seven "
               "load cases of Figs 4-21 to 4-27 are " +
               ", ".join(s(c) for c, _ in LOAD_CASES) + ".\n\n")
    return "".join(out)


def _scene_methods_section(ctx):
    out = ["= Methods\n\n",
           "The bodies, their modes, the ranking criteria and the static correction modes do not "
           "depend on the scene: the model report (results/report/model.pdf) holds them.\n\n"]
    out.append("== Equations of motion\n\n"
               "The chain case - outer gimbal - middle gimbal - inner gimbal - platform is a tree of "
               "floating-frame bodies: each body's motion is the rigid rotation of its joint angle "
               "$gamma_n$ about its drive axis plus small elastic displacements "
               "$u = Phi q$ in its outside frame, and the next body hangs from the elastic "
               "translation and rotation of its inner bearings. The kinetic energy with the modal "
               "integrals of each body gives Lagrange's equations "
               "$M(y) dot.double(y) = f(t, y, dot(y))$ for $y = (gamma_1..gamma_4, q)$, solved by an "
               "articulated-body recursion (docs/dynamics.md). " + _scene_sentence(ctx.get("scene")) +
               "\n\n== Integrator\n\n")
    integ = _integrators(ctx)
    if integ:
        out.append(f"Integrators used: {s(integ)}. The exponential integrator (the workflow's "
                   "default, docs/exponential.md) solves the linearised chain's coupled modes exactly "
                   "and steps the slow remainder with error control, so its step is not bounded by "
                   "the highest frequency; RK4 (config simulation.integrator: rk4, the thesis's "
                   "method) runs with a fixed step below its stability limit $2.785 \\/ omega_max$. "
                   "Outputs are sampled on one common grid, so all errors compare equal time "
                   "points.\n\n")
    else:
        out.append(note("no simulation results (" + ctx["missing"].get("ranking_table", "") + ")"))
    out.append("== Error measure\n\nFor each gimbal rate $dot(gamma)_n$ (thesis eq 3.53), with $r(t)$ "
               "the truth model's rate and $e(t)$ the reduced model's rate minus $r(t)$:\n\n"
               "$ E_n = (integral_0^T e_n (t)^2 dif t) / (integral_0^T r_n (t)^2 dif t) $\n\n"
               "Both integrals use the trapezoid rule on the common output grid. $E = 1$ is an "
               "error as large as the signal itself; $sqrt(E)$ is the RMS error as a fraction of the "
               "RMS rate, so $E = 0.04$ is an error of 20 % RMS of the rate and $E = 10^(-4)$ one of "
               "1 %. The decision (study report) also states it in rad/s: "
               "$\"RMS\"(e_n) = sqrt(E_n) \"RMS\"(r_n)$.\n\n")
    out.append(_sampling_paragraph(ctx))
    return "".join(out)


def _sampling_paragraph(ctx):
    """What the output grid resolves: its interval and Nyquist frequency against E's sampling rule
    (``error_measure``: Nyquist >= margin x f_max, f_max the truth's highest coupled mode holding at
    least a share of a rate's mean square; found by run_scene, coupled_modes.json's "sampling"),
    and the measured effect of a grid twice as coarse."""
    sc, cm = ctx.get("scene") or {}, ctx.get("coupled_modes") or {}
    try:
        dt = units.convert(sc["output_interval"], "s", "output_interval")
        duration = units.convert(sc["duration"], "s", "duration")
    except (KeyError, TypeError, ValueError):
        return ""
    nyquist = 0.5 / dt
    rule = cm.get("sampling") or {}
    text = (f"*Sampling.* Every model is sampled on the scene's output grid: every {dt * 1e6:.4g} µs "
            f"({int(round(duration / dt)) + 1} samples over {duration_text(duration)}, Nyquist frequency "
            f"{nyquist / 1e3:.4g} kHz); each sample is the integrator's solution at that instant (the "
            "exponential integrator evaluates its modal solution there, whatever its own step). "
            "E is a mean square over the samples: the square of a rate that holds frequencies up to "
            "$f_max$ holds them up to $2 f_max$, which the trapezoid rule integrates exactly while "
            "$2 f_max$ stays below the sampling rate; beyond it two modes whose frequencies add up to "
            "the sampling rate beat at a low frequency, and E moves. The rule "
            "(gimbal_reduction.solver.dynamics.error_measure): Nyquist frequency "
            f"$>= {rule.get('margin', SAMPLING_MARGIN):g} f_max$, $f_max$ the highest coupled mode of the "
            "truth (every model is compared with it) that holds at least "
            f"{sci(rule.get('share', SAMPLING_SHARE))} of a gimbal rate's mean square under the scene's "
            "drive; the study checks it before it simulates the truth. ")
    if rule and rule.get("f_max_hz"):
        verdict = "met" if rule.get("resolved") else "NOT met"
        text += (f"Here $f_max$ = {rule['f_max_hz'] / 1e3:.4g} kHz (coupled mode {rule['mode']}), so the "
                 f"interval may be at most {rule['longest_interval_s'] * 1e6:.3g} µs: {verdict}. ")
    elif rule and rule.get("note"):
        text += f"Not evaluated here: {rule['note']}. "
    chk = (ctx.get("decision") or {}).get("sampling")
    if chk:
        text += (f"Measured: E of every case computed on every second sample (Nyquist "
                 f"{nyquist / 2e3:.4g} kHz) differs from E on the full grid by at most "
                 f"{100 * chk['max_relative_change']:.2g} % ({s(chk['model'])}, {s(chk['rate'])} rate).")
    return text + "\n\n"


def duration_text(seconds) -> str:
    """A duration for the text: 15 ms, 1 s."""
    return f"{seconds * 1e3:.4g} ms" if seconds < 1.0 else f"{seconds:.4g} s"


def _scene_sentence(scene) -> str:
    """What drives the chain on this scene, from its file (values read in their units): the case's
    angular acceleration a cos(2 pi f t + phase) per axis, the initial angles, the motor torques,
    the modal damping and the duration; the thesis scene's sources (Tables 2.4, 2.5, Section 3.1)."""
    if not scene:
        return "The scene file was not given."
    motion = scene.get("case_motion", {})
    amp = units.convert(motion["angular_acceleration_amplitude"], "rad/s^2", "angular_acceleration_amplitude")
    freq = units.convert(motion["angular_acceleration_frequency"], "Hz", "angular_acceleration_frequency")
    phase = units.convert(motion["angular_acceleration_phase"], "rad", "angular_acceleration_phase")
    terms = []
    for axis, a, f, ph in zip("XYZ", amp, freq, phase):
        if a:
            shift = "" if ph == 0 else f" {'+' if ph > 0 else '-'} {abs(ph):.4g}"
            scale = "" if a == 1 else f"{a:g} "
            terms.append(f"${scale}cos(2 pi dot {f:g} t{shift})$ rad/s#super[2] about {axis}")
    drive = " and ".join(terms) if terms else "no angular acceleration (the case at rest)"
    # the acceleration at t = 0 (rad/s^2): a step there sets off the ringing of the coupled modes
    at_start = max((abs(a * np.cos(ph)) for a, ph in zip(amp, phase)), default=0.0)
    steps = at_start > 1e-9 * max((abs(a) for a in amp), default=0.0)
    angles = units.convert(scene["initial_angles"], "rad", "initial_angles")
    torques = units.convert(scene["motor_torques"], "in*lbf", "motor_torques")
    damping = units.convert(scene["damping_ratio"], "1", "damping_ratio")
    duration = units.convert(scene["duration"], "s", "duration")
    gimbal_angles = ", ".join(f"{a:.4g}" for a in angles)
    return (f"On this scene ({s(scene.get('name', ''))}: {s(scene.get('description', ''))}) the case is "
            f"driven by the angular acceleration {drive}, "
            + (f"which steps from zero to {at_start:.3g} rad/s#super[2] at $t = 0$" if steps
               else "which rises from zero at $t = 0$ (no step)")
            + f"; the joint angles start at ({gimbal_angles}) rad; the motor torques are "
            + ("zero" if not any(torques) else ", ".join(f"{t:g}" for t in torques) + " in lbf")
            + f"; modal damping ratio {damping:g}; the scene lasts {duration_text(duration)} "
            "(the thesis's scene: its Tables 2.4, 2.5 and Section 3.1).")


def _integrators(ctx):
    seen = {}
    truth = ctx["truth"]
    rows = ctx["ranking_rows"] + ctx["static_rows"]
    if truth:
        # an adaptive run's step attribute is one of its steps: the mean (duration / steps) says more
        steps = truth.get("steps") or 0
        duration = (ctx["scene"] or {}).get("duration", {}).get("value") if ctx.get("scene") else None
        mean = f", mean step {float(duration) / steps:.3g} s" if steps and duration else ""
        tol = truth.get("stat_tol")
        tol = f", tolerance {float(tol):g}" if tol is not None and np.isfinite(float(tol)) else ""
        seen[f"truth: {truth.get('integrator')} ({steps} steps{mean}{tol})"] = 1
    for r in rows:
        if r["group"] != "truth" and r["integrator"]:
            seen[f"{r['integrator']}"] = seen.get(r["integrator"], 0) + 1
    return ", ".join(k if k.startswith("truth") else f"{k} ({v} cases)" for k, v in seen.items())


def _cell(ctx, row, k):
    """An E cell: the number, or "n.r." where it is within the truth's own error of zero on that
    rate (``decision.cell``; the number itself without the decision file)."""
    res = (ctx.get("decision") or {}).get("resolution")
    x = row[RATE_COLUMNS[k]]
    if res is None or row["group"] in ("truth", *REFEREES):
        return sci(x)
    v = decision.cell(x, res["E_per_rate"][k])
    return s("n.r.") if v == decision.NOT_RESOLVABLE else sci(v)


# a load case "changes nothing" when every rate's E is within this of freq-10's: the third digit of
# the tables; on the thesis scene the two z-moment cases differ from freq-10 by 6.5e-4 and 1.9e-3,
# the other five by 1.2e-2 to 1.1e-1
INERT_RTOL = 5e-3


def inert_load_cases(control, load_rows, rtol=INERT_RTOL) -> list[str]:
    """The load cases whose static mode leaves every rate's E within ``rtol`` (relative) of the
    no-static control's (freq-10)."""
    if control is None:
        return []
    out = []
    for r in load_rows:
        pairs = [(r[c], control[c]) for c in RATE_COLUMNS]
        if all(np.isfinite(a) and np.isfinite(b) and abs(a - b) <= rtol * abs(b) for a, b in pairs):
            out.append(r["load_case"])
    return out


def _inert_caption(ranking_rows, load_rows) -> str:
    control = next((r for r in ranking_rows if r["model"] == "freq-10"), None)
    inert = inert_load_cases(control, load_rows)
    if not inert:
        return ""
    text = (f" The static modes of {', '.join(s(c) for c in inert)} change no rate's E by more than "
            f"{INERT_RTOL:g} relative from freq-10's (the tables' third digit).")
    if all(c.endswith("_mz") for c in inert):
        text += (" They are moments about the ring's z axis, whose static modes deform the outer gimbal out "
                 "of the plane of the scene's motion (momentum coefficients P_y, H_x and H_z only, bearing "
                 "motions u_y, theta_x and theta_z only: results/reduction/body2.h5), while the case rocks "
                 "about the outer gimbal's own axis and the loads on the ring lie in that plane: the scene "
                 "gives them almost no generalised force, so they stay nearly at rest. A property of the "
                 "scene, not a defect: a static mode helps only where the scene loads the body as the mode "
                 "was built.")
    return text


def _nr_caption(ctx) -> str:
    res = (ctx.get("decision") or {}).get("resolution")
    return "" if res is None else (" n.r. = not resolvable: within the truth's own error on that rate (E "
                                   + ", ".join(sci(x) for x in res["E_per_rate"]) + ").")


def _pivot(ctx, rows, group, counts):
    sel = {r["count"]: r for r in rows if r["group"] == group}
    out = []
    for k, b in enumerate(BODIES):
        out.append([s(BODY_LABELS[b])] + [_cell(ctx, sel[n], k) if n in sel else "--" for n in counts])
    return out, bool(sel)


def _group_counts(rows, group):
    """The counts a group has in the table (freq also has the no-static controls 2..8)."""
    return sorted({r["count"] for r in rows if r["group"] == group and r["count"] is not None})


def frequency_rows(rows) -> list[list[str]]:
    """The frequency-domain error table's rows: one per family (the ranking table's groups, the
    rigid model first), each cell "N: H-inf / H2" of one of its counts (relative to the truth's
    norms, ``reduction.frequency_error``); a family without the columns is left out."""
    out = []
    for g in [g for g in RANKING_TABLE_GROUPS if g not in REFEREES]:
        have = sorted((r for r in rows if r["group"] == g and np.isfinite(r.get("hinf_error", np.nan))),
                      key=lambda r: (r["count"] is None, r["count"] or 0, r["model"]))
        if have:
            out.append([s(names.label(g))] + [
                s(f"{r['count'] if r['count'] is not None else r['model']}: "
                  f"{r['hinf_error']:.3g} / {r['h2_error']:.3g}") for r in have])
    return out


def _frequency_section(rr) -> str:
    rows = frequency_rows(rr)
    if not rows:
        return ""
    width = max(len(r) for r in rows)
    rows = [r + [""] * (width - len(r)) for r in rows]
    return table(["family"] + [f"{k}" for k in range(1, width)], rows,
                 "Frequency-domain error beside E: each model's relative H∞ / H2 error of the linearised "
                 "chain's transfer from case acceleration and motor torques to the gimbal rates and the "
                 "platform's angular velocity, over the band the scene excites (cell: count per body, or "
                 "in total for global-N: H∞ / H2; the rigid model's error is 1; "
                 "results/study/SCENE/frequency_error.json, gimbal_reduction/reduction/frequency_error.py).",
                 "tab-frequency-error", size="6.5pt")


N_COUPLED_ROWS = 16


def _coupled_section(ctx):
    """The truth chain's coupled modes at the scene's initial state (joints free): what rings."""
    cm = ctx.get("coupled_modes")
    out = ["== The coupled chain's modes\n\n"]
    if not cm:
        return out[0] + note(ctx["missing"].get("coupled_modes", "coupled_modes.json"))
    f, body, share = cm["frequencies_hz"], cm["body"], cm["share"]
    rows = [[s(k + 1), s(f"{f[k]:.1f}"), s(body[k]), s(f"{100 * share[k]:.0f} %")]
            for k in range(min(N_COUPLED_ROWS, len(f)))]
    out.append(f"The truth model linearised at the scene's initial state, joints free "
               f"({s(len(f))} coupled elastic modes, {s(f'{f[0]:.0f}')} to {s(f'{f[-1]:.4g}')} Hz). "
               "A step in the case acceleration sets these modes ringing; every reduced model must "
               "reproduce the ones the gimbal rates see.\n\n")
    out.append(table(["mode", "frequency [Hz]", "body with the largest share", "share of modal mass"],
                     rows, f"The {s(len(rows))} lowest coupled modes of the truth chain.",
                     "tab-coupled", size="7.5pt"))
    return "".join(out)


def _results_section(ctx, root):
    out = ["= Results\n\n== Error tables\n\n"]
    rr, sr = ctx["ranking_rows"], ctx["static_rows"]
    if rr:
        base = [r for r in rr if r["group"] in ("rigid", *REFEREES)]
        if base:
            out.append(table(["model", "what"] + [s(BODY_LABELS[b]) for b in BODIES],
                             [[s(r["model"]), s(names.label(r["group"]))] +
                              [sci(r[c]) for c in RATE_COLUMNS] for r in base],
                             "The baseline every reduced model must beat (rigid: no elastic mode) "
                             "and the truth's own error (static-100: the truth with residual "
                             "flexibility; cb-100: the truth's band with each ring's output-interface "
                             "flexibility).", "tab-baseline", size="7.5pt"))
        for g in [g for g in RANKING_TABLE_GROUPS if g not in ("rigid", *REFEREES)]:
            counts = _group_counts(rr, g)
            rows, ok = _pivot(ctx, rr, g, counts)
            if ok:
                unit = "in total" if g == "global" else "per body"
                out.append(table(["rate"] + [f"{n}" for n in counts], rows,
                                 f"Error E (eq 3.53) using {s(names.label(g))}, by the number of modes "
                                 f"{unit}" + (" (analogue of thesis Table 4.2)." if g in ("freq", "xmx", "xmgmx")
                                              else ".") + _nr_caption(ctx), f"tab-err-{g}", size="7.5pt"))
        out.append(_frequency_section(rr))
    else:
        out.append(note(ctx["missing"].get("ranking_table", "ranking table")))
    if sr:
        for g in ("static-freq", "static-xmx", "static-xmgmx"):
            rows, ok = _pivot(ctx, sr, g, STATIC_COUNTS)
            if ok:
                out.append(table(["rate"] + [f"{n} modes" for n in STATIC_COUNTS], rows,
                                 f"Error E using {s(names.label(g))} per body "
                                 f"(analogue of thesis Table 4.3)." + _nr_caption(ctx), f"tab-err-{g}"))
        lc = [r for r in sr if r["group"] == "load-case"]
        if lc:
            rows = [[s(r["load_case"]), s(r["thesis_figure"])] +
                    [_cell(ctx, r, k) for k in range(len(RATE_COLUMNS))] for r in lc]
            out.append(table(["load case", "thesis fig.", "outer", "middle", "inner", "platform"],
                             rows, "Error E with the 10 lowest modes per body and one static mode on "
                                   "the outer gimbal, per load case (Figs 4-21 to 4-27)." + _nr_caption(ctx)
                             + _inert_caption(rr, lc),
                             "tab-err-load"))
    else:
        out.append(note(ctx["missing"].get("static_table", "static table")))
    figs = ctx["figures"]
    err_figs = [f for f in figs if f["kind"] == "error"]
    out.append("== Error against the number of modes\n\n")
    if err_figs:
        for f in err_figs:
            out.append(figure(f["pdf"], s(f["caption"]), root, label=f"fig-{f['id']}"))
    else:
        out.append(note(ctx["missing"].get("figures", "no error figures in the figure manifest")))
    rate_figs = [f for f in figs if f["kind"] == "rates"]
    out.append("== Gimbal rates of every case\n\n")
    if rate_figs:
        thesis_figs = sum(1 for f in rate_figs if f.get("thesis_figure"))
        out.append(f"Each of the {len(rate_figs)} figures compares the truth model's four gimbal rates "
                   "with one reduced model's"
                   + (", in the order of the thesis's Figures 4-2 to 4-27." if thesis_figs > 20 else
                      ": the rigid baseline and one model per family (every case is in the error "
                      "tables; the thesis scene's report has a figure for each of the thesis's cases).")
                   + "\n\n")
        for f in rate_figs:
            out.append(figure(f["pdf"], s(f["caption"]), root, width="92%"))
    else:
        out.append(note(ctx["missing"].get("figures", "no rate figures in the figure manifest "
                                                          "(simulation files missing)")))
    return "".join(out)


def _findings_section(ctx):
    res = (ctx.get("decision") or {}).get("resolution")
    out = ["= Findings <findings>\n\n",
           "Each finding (1-6: the thesis's, Sections 4.3-4.5; 7-10: the project's) is decided by the "
           "rule printed beside its verdict, on this scene's error tables, on every gimbal rate, "
           "against the control named. \"Better\" means smaller by more than 10 % (a tie band). The "
           "thesis column applies the same rule to the thesis's own Tables 4.2 and 4.3 where they "
           "hold the data. A rate on which even the rigid model lies within the truth's own error of "
           "a perfect model is not resolvable: no verdict is given there"
           + (f" (the truth's E per rate: {', '.join(sci(x) for x in res['E_per_rate'])})" if res else
              " (the decision file is missing, so no rate is marked)")
           + ". A finding whose premise fails on a rate (\"inconclusive\") is not evaluated there. "
           + s(MARKS_LEGEND) + ".\n\n"]
    rows = []
    for f in ctx["findings"]:
        th = (f.get("thesis_check") or {}).get("verdict") or "--"
        before = f.get("verdict_before")
        changed = (f" (without the truth's resolution: {before})"
                   if before and before != f["verdict"] and decision.NOT_RESOLVABLE in
                   (f.get("verdict_per_rate") or {}).values() else "")
        rows.append([s(f["finding"]), s(f["statement"]), s(f.get("rule", "")), s(f.get("control", "")),
                     f"*{s(f['verdict'])}*{s(changed)} \\ {s(verdict_marks(f.get('verdict_per_rate')))}",
                     s(th), s(f["reason"])])
    out.append(table(["no.", "finding", "rule and thresholds", "control", "verdict", "thesis", "reason"],
                     rows, "The findings on this scene: rule, control and verdict.", "tab-findings",
                     columns="(auto, 1.1fr, 1.3fr, 0.9fr, 0.8fr, 0.6fr, 1.6fr)", size="6.5pt"))
    return "".join(out)


def _runtime_section(ctx, root):
    """Cost and accuracy of every case.  Run times are quoted only from the benchmark's medians
    (results/benchmarks/exponential.json or the main job's version), never from the study's single
    runs (compilation and a shared machine make those noise)."""
    out = ["= Cost against error <runtime>\n\n"]
    rows = sorted((r for r in ctx["ranking_rows"] + ctx["static_rows"] if r["group"] != "truth"),
                  key=lambda r: (r["n_elastic"] if r["n_elastic"] is not None else 1e9, r["model"]))
    rt = [f for f in ctx["figures"] if f["kind"] == "cost"]
    for f in rt:
        out.append(figure(f["pdf"], s(f["caption"]), root, width="85%", label="fig-runtime"))
    d = ctx.get("decision")
    if d and d["runtime"]["truth"].get("run_ms"):
        tr, rg = d["runtime"]["truth"], d["runtime"].get("rigid", {})
        out.append(f"Measured run times on this scene (the timing job: medians of 5 runs in one process; "
                   f"the decision on page 1 of the study report quotes them per answer): the truth "
                   f"{ms(tr['run_ms'])} (set-up {ms(tr.get('setup_ms'))}), the rigid model "
                   f"{ms(rg.get('run_ms'))}.\n\n")
    eb = ctx.get("exponential_bench")
    if eb:
        out.append(f"Run times (medians of repeated runs) are those of the exponential integrator's "
                   f"benchmark of {s(ctx['status'].get('exponential_bench', ''))}: "
                   f"{s(os.path.relpath(ctx['paths']['exponential_bench'], ROOT)[:-len('json')] + 'md')}.\n\n")
    else:
        out.append(note(s(ctx["missing"].get("exponential_bench", "no benchmark") + ";") +
                        " no run time is quoted from single runs."))
    if rows:
        body = [[s(r["model"] + (" (truth check)" if r["group"] == "truth-check" else "")),
                 s(r["n_elastic"]), *(_cell(ctx, r, k) for k in range(len(RATE_COLUMNS))),
                 sci(r.get("attitude_max_arcsec", float("nan"))), s(r["steps"])] for r in rows]
        out.append(table(["model", "elastic coord.", "E outer", "E middle", "E inner", "E platform",
                          "attitude [arcsec]", "steps"], body,
                         "Every case by its size (elastic coordinates): E per rate, the largest "
                         "platform attitude error against the truth, and the integrator's steps. "
                         "The truth check (the truth + 1 static mode per body) measures the truth's "
                         "truncation, not a reduced model." + _nr_caption(ctx),
                         "tab-runtime", size="6.5pt"))
    elif not rt:
        out.append(note(ctx["missing"].get("ranking_table", "error tables")))
    return "".join(out)


def _bench_figure(ctx, key, root, width="85%"):
    for k, path, cap in ctx["bench_figures"]:
        if k == key:
            return figure(path, s(cap), root, width=width, label=f"fig-bench-{key}")
    return ""


def _integrators_section(ctx):
    """Issue 13: how far the error table moves between the exponential integrator (the
    workflow's) and RK4 (the thesis's), from gimbal_reduction.results.bench.integrator_tables."""
    out = ["== The exponential integrator against RK4\n\n"]
    it = ctx.get("integrators")
    if not it:
        out.append(note(ctx["missing"].get("integrators", "no integrator comparison")))
        return "".join(out)
    sm = it["summary"]
    truth_E = max(sm["truth_E_rk4_vs_exponential"])
    out.append(
        f"Every simulation of this study ran the modal exponential integrator (tolerance "
        f"{sm['exponential_tol']:g}); config simulation.integrator: rk4 runs it with RK4 at "
        f"{sm['rk4_fraction_of_limit']:g} of its stability limit, as the thesis did. Computed both "
        f"ways for {sm['models']} models (each against its own integrator's truth), the error "
        f"table (eq. 3.53) differs by at most {sm['max_relative_difference']:.2g} relative "
        f"(median {sm['median_relative_difference']:.2g}), and the order of the models by their "
        f"largest E is {'the same' if sm['same_order'] else 'not the same'}"
        + ("" if sm["same_order"] else f" ({len(sm['rank_changes'])} models change rank)")
        + f". The two truths differ by E = {truth_E:.2g} (RK4 at its default step is the less "
        f"accurate of the two). Wall time of all these runs: {sm['wall_s_exponential']:.3g} s "
        f"exponential, {sm['wall_s_rk4']:.3g} s RK4.\n\n")
    rows = sorted(it["rows"], key=lambda r: -float(r["relative_difference"]))[:8]
    body = [[s(r["model"]), sci(r["E_max_exponential"]), sci(r["E_max_rk4"]),
             sci(r["relative_difference"])] for r in rows]
    out.append(table(["model", "E (exponential)", "E (RK4)", "relative difference"], body,
                     "The models whose error moves most between the two integrators.",
                     "tab-integrators", size="7pt"))
    return "".join(out)


def _performance_section(ctx, root):
    """Issue 6: run time against error, cost against size, stability stress tests, selection."""
    out = ["= Fast and stable <performance>\n\n"]
    rows = [r for r in ctx["pareto_rows"] if r.get("status", "ok") == "ok"]
    out.append("== Run time against error\n\n")
    out.append(_bench_figure(ctx, "pareto", root))
    front = sorted((r for r in rows if r.get("pareto") == "1"), key=lambda r: _num(r["wall_time_s"]))
    if front:
        body = [[s(r["model"]), s(r["integrator"]), s(r.get("solver", "")), s(r["n_elastic"]),
                 sci(_num(r["E"])), s(f"{_num(r['wall_time_s']):.3g}")] for r in front]
        scaled = sum(str(r.get("time_basis", "measured")).startswith("extrapolated") for r in front)
        out.append(table(["model", "integrator", "solver", "elastic coord.", "E", "wall time [s]"], body,
                         "The Pareto front of wall time against error (medians of repeated runs"
                         + (f"; {scaled} of them of a prefix of the scene, scaled by the steps" if scaled
                            else "") + ").", "tab-pareto", size="7pt"))
    for d in (r for r in ctx["pareto_rows"] if str(r.get("solver", "")).startswith("dense")):
        # the same-run ratio of gimbal_reduction.results.bench.pareto (dense segment against the structured runs)
        out.append(f"Dense-mass-matrix baseline ({s(d['solver'])}), {s(d['model'])} with "
                   f"{s(d['integrator'])}: {_num(d['speedup']):.1f}x slower than the structured "
                   f"recursion, timed in the same run.\n\n")
    if not rows:
        out.append(note(ctx["missing"].get("pareto", "no Pareto benchmark")))
    out.append("== Cost against model size\n\n")
    out.append(_bench_figure(ctx, "scaling", root))
    sc = ctx["scaling"]
    if sc:
        laws = sc.get("growth_laws", {})
        items = [[s(m), s(f"{v['exponent']:.2f}"), s(f"{min(v['n_elastic'])}-{max(v['n_elastic'])}")]
                 for m, v in laws.items() if isinstance(v, dict) and "exponent" in v]
        if items:
            out.append(table(["method", "exponent p (cost ~ S^p)", "fitted over S"], items,
                             "Growth laws of the cost per evaluation with the number of elastic "
                             "coordinates S, least squares on log-log.", "tab-growth"))
    else:
        out.append(note(ctx["missing"].get("scaling", "no scaling benchmark")))
    out.append("== Stability stress tests\n\n")
    st = ctx["stability"]
    if st:
        lim = st.get("rk4_limit", {}).get("models", {})
        body = [[s(m), sci(v["h_measured"]), s(f"{v['ratio_bound']:.4f}"), s(f"{v['h_omega_top']:.4f}"),
                 s("yes" if v.get("pass") else "no")] for m, v in lim.items()]
        if body:
            out.append(table(["model", "measured limit [s]", "ratio to 2.785/omega_max", "limit x omega_top", "within 5 %"],
                             body, "Measured RK4 stability limit (bisection) against theory; the exact "
                             "bound of an undamped mode is 2 sqrt 2 = 2.8284.", "tab-rk4-limit"))
        out.append(_bench_figure(ctx, "rk4_limit", root, width="70%"))
        drift = st.get("energy_drift", {}).get("methods", {})
        body = [[s(m + "".join(f", {k} {val:g}" for k, val in v.get("options", {}).items())),
                 s(v["steps"]), sci(v["drift_max"]), sci(v["drift_final"]), s(f"{v['wall_s']:.3g}")]
                for m, v in drift.items()]
        if body:
            out.append(table(["integrator", "steps", "max drift", "final drift", "wall time [s]"], body,
                             f"Relative energy drift over {st['energy_drift'].get('duration_s', 10.0):g} s of "
                             f"scene free_10s "
                             f"(model {s(st['energy_drift'].get('model', ''))}).", "tab-drift"))
        out.append(_bench_figure(ctx, "drift", root, width="70%"))
        cases = st.get("hard_cases", {}).get("cases", {})
        body = [[s(k), s(v.get("outcome", "")), sci(v["E_max"]) if v.get("E_max") is not None else
                 s((v.get("message") or "")[:70])] for k, v in cases.items()]
        if body:
            out.append(table(["hard case", "outcome", "E against a tighter run, or the diagnosis"], body,
                             "Hard cases: each runs correctly (checked against a half-step run) or "
                             "stops with a diagnosis.", "tab-hard", size="7pt"))
    else:
        out.append(note(ctx["missing"].get("stability", "no stability tests")))
    out.append(_integrators_section(ctx))
    out.append("== Load-aware and global mode selection\n\n")
    out.append(_bench_figure(ctx, "global", root))
    sel = ctx["selection_rows"]
    if sel:
        body = [[s(r["model"]), s(r["n_elastic"]), sci(_num(r["E_max"])), sci(_num(r["apriori_max"]))]
                for r in sel]
        out.append(table(["model", "elastic coord.", "E (max over gimbals)", "a-priori estimate"], body,
                         "Measured error and its a-priori estimate per selection.", "tab-selection",
                         size="7pt"))
    else:
        out.append(note(ctx["missing"].get("selection", "no selection table")))
    return "".join(out)


def _provenance_section(ctx):
    v = ctx["versions"]
    out = ["= Provenance\n\n"]
    hashes = sorted({r["config_hash"] for r in ctx["ranking_rows"] + ctx["static_rows"]
                     if r.get("config_hash")})
    fe_hash = (ctx["fe"] or {}).get("config_hash")
    items = [("report built", ctx["date"]), ("git revision", v.get("git", "unknown")),
             ("FE stage config hash", fe_hash or "--"),
             ("simulation config hashes", f"{len(hashes)} distinct" +
              (f" (truth: {ctx['truth'].get('config_hash')})" if ctx["truth"] else "")),
             ("scene", (ctx["scene"] or {}).get("name", "--"))]
    items += [(k, val) for k, val in v.items() if k != "git"]
    out.append(table(["item", "value"], [[s(a), s(b)] for a, b in items],
                     "Software versions and configuration.", "tab-provenance"))
    rows = [[s(k), s(os.path.relpath(ctx["paths"][k], ROOT)), s(ctx["status"].get(k, "--"))]
            for k in DEFAULTS if k != "out" and (k in (ctx.get("part_inputs") or DEFAULTS))]
    out.append(table(["input", "path", "modified / status"], rows,
                     "Inputs of this report.", "tab-inputs"))
    return "".join(out)


PARTS = ("scene", "model")
# the inputs the model report reads (its provenance table lists these only)
MODEL_INPUTS = ("fe", "modes_benchmark", "reduction", "config", "scene", "coupled_modes", *OPTIONAL_KEYS)
# the checks only the model report shows: a scene report does not miss them
MODEL_ONLY = tuple(k for k in OPTIONAL_KEYS if k != "exponential_bench")


def typst_source(ctx: dict, root: str, part: str = "scene") -> str:
    """The report's Typst markup (figures addressed relative to ``root``): ``part`` "model" is what
    does not depend on the scene (bodies, FE checks, mode shapes and static modes, mode selection,
    the coupled modes, the benchmarks), "scene" one scene's results only."""
    sub = (f"after P. J. Balucan, S.M. thesis, MIT (2001). Built {s(ctx['date'])}, revision "
           f"{s(ctx['versions'].get('git', 'unknown'))}")
    if part == "model":
        ctx = {**ctx, "part_inputs": MODEL_INPUTS}
        return (page_setup("Model reduction of elastic nested gimbals: the model", sub)
                + _model_section(ctx, root) + _methods_section(ctx) + "= The coupled chain\n\n"
                + _coupled_section(ctx) + _performance_section(ctx, root) + _provenance_section(ctx))
    name = (ctx["scene"] or {}).get("name", "?")
    ctx = {**ctx, "missing": {k: v for k, v in ctx["missing"].items() if k not in MODEL_ONLY},
           "part_inputs": tuple(k for k in DEFAULTS if k not in MODEL_ONLY)}
    return (page_setup(f"Model reduction of elastic nested gimbals: scene {name}", sub)
            + _summary(ctx) + _scene_methods_section(ctx) + _results_section(ctx, root)
            + _findings_section(ctx) + _runtime_section(ctx, root) + _provenance_section(ctx))


def report_root(ctx, out_pdf):
    """Common folder of the report and every figure (Typst's project root)."""
    paths = [os.path.dirname(os.path.abspath(out_pdf))] + [f["pdf"] for f in ctx["figures"]] + \
        [png for png, _ in ctx["mode_shapes"]] + [path for _, path, _ in ctx.get("bench_figures", [])]
    return os.path.commonpath([os.path.abspath(p) for p in paths])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gimbal_reduction.results.study.report",
                                     description="Typeset the study's PDF report with Typst.")
    for key, default in DEFAULTS.items():
        parser.add_argument("--" + key.replace("_", "-"), default=default, help=f"(default {default})")
    for key, default in LIST_DEFAULTS.items():
        parser.add_argument("--" + key.replace("_", "-"), nargs="*", default=default,
                            help=f"files (default {' '.join(default)})")
    parser.add_argument("--part", choices=PARTS, default="scene",
                        help="scene: one scene's results; model: what does not depend on the scene")
    args = parser.parse_args(argv)
    paths = {k: getattr(args, k) for k in (*DEFAULTS, *LIST_DEFAULTS)}
    ctx = gather(paths)
    out = _abs(args.out)
    root = report_root(ctx, out)
    # config hash: the truth's and the error tables' (the simulations' config hashes)
    record = provenance(sources=[ctx["paths"][k] for k in ("truth", "ranking_table", "static_table")
                                 if os.path.exists(ctx["paths"][k])])
    try:
        compile_pdf(typst_source(ctx, root, args.part), out, root, record)
    except Exception as exc:  # noqa: BLE001 - typst raises RuntimeError with the diagnostics
        msg = " ".join(str(exc).split())[:400]
        print(f"gimbal_reduction.results.study.report: error: typst failed: {msg}", file=sys.stderr)
        return 2
    missing = [k for k in ctx["missing"] if args.part == "model" or k not in MODEL_ONLY]
    print(f"gimbal_reduction.results.study.report: {out} ({len(ctx['figures'])} figures, missing inputs: "
          f"{', '.join(missing) or 'none'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
