"""The study report: every finding on every scene, the discussion and the recommendation.

    python -m gimbal_reduction.results.study.study_report --scenes config/scenes/{thesis,damped,smooth,long}.yaml \\
        --ranking-tables results/tables/{scene}/errors_ranking.csv ... \\
        --static-tables results/tables/{scene}/errors_static.csv ... \\
        --findings results/tables/{scene}/findings.json ... \\
        --figures results/figures/study/{scene}/figures.json ... \\
        --fe results/verification/fe_fast.json --reduction results/verification/reduction.json \\
        [--dynamics ... --exponential ... --exponential-bench ... --fe-full ... (read if present)] \\
        --out results/report/report.pdf

The per-scene PDFs (``gimbal_reduction.results.study.report``) hold every table and figure of one scene; this
one answers the study's questions across the scenes: which thesis findings hold where, what
the rigid baseline says about every reduced model, how far the truth itself can be trusted,
what the platform's attitude error is, and which model to use for which need.

Every number in the text comes from ``analyse`` (a pure function of the tables and findings),
which the tests compare with the tables, so the text cannot drift from the data.  A missing
input is not an error: the report says which file is missing and which target makes it.
"""
from __future__ import annotations

import argparse
import csv
import os
import sys
import time

import numpy as np

from gimbal_reduction.reduction import names
from gimbal_reduction.results.bench.equal_error import FAMILIES, cheapest_within, max_error
from gimbal_reduction.results.study.cases import MODE_COUNTS, TRUTH, TRUTH_CHECK, TRUTH_INTERFACE
from gimbal_reduction.results.markup import (MARKS_LEGEND, compile_pdf, figure, ms, note, page_setup, read_json, read_yaml,
                                             report_versions, s, sci, table, verdict_marks)
from gimbal_reduction.results.study import decision
from gimbal_reduction.results.study.cases import study_cases
from gimbal_reduction.results.study.figures import STYLE, pyplot, save
from gimbal_reduction.results.study.findings import THESIS, THESIS_SUSPECTED_TYPOS, THESIS_TABLE_4_1
from gimbal_reduction.results.study.report import ROOT, note_revision, stale_list, version_of
from gimbal_reduction.results.study.tables import RATE_COLUMNS, read_table
from gimbal_reduction.solver.dynamics.error_measure import SAMPLING_MARGIN, SAMPLING_SHARE
from gimbal_reduction.workflow import units

RATES = ("outer", "middle", "inner", "platform")
RATE_NAMES = {"outer": "outer gimbal", "middle": "middle gimbal", "inner": "inner gimbal",
              "platform": "stable platform"}
# accuracy needs of the recommendation: E (eq. 3.53) on every gimbal rate at most this
TARGETS = (1e-1, 1e-2, 1e-3, 1e-4)
OPTIONAL = {"dynamics": "snakemake verify", "exponential": "snakemake verify",
            "exponential_bench": "snakemake bench", "fe_full": "snakemake verify",
            "integrators": "snakemake verify", "stability": "snakemake bench",
            "truth_basis": "snakemake results/verification/truth_basis.json",
            "pareto": "snakemake bench", "scaling": "snakemake bench", "selection": "snakemake bench",
            "tolerance": "snakemake bench", "decision": "snakemake results/tables/decision.json"}


# ---------------------------------------------------------------- reading
def _load(path, reader, ctx, key, makes):
    if not path or not os.path.exists(path):
        ctx["missing"][key] = f"{path} missing (made by {makes})"
        return None
    try:
        out = reader(path)
    except Exception as exc:  # noqa: BLE001 - a broken input is reported, not fatal
        ctx["missing"][key] = f"{path} unreadable ({exc.__class__.__name__})"
        return None
    ctx["dates"][key] = time.strftime("%Y-%m-%d %H:%M", time.localtime(os.path.getmtime(path)))
    if key in OPTIONAL:
        ctx["dates"][key] += f", {version_of(path)}" + note_revision(ctx.setdefault("stale", {}), key, path, path, makes)
    return out


def gather(scene_files, rankings, statics, findings, figures, fe, reduction, optional,
           mode_ranking=None) -> dict:
    """Everything the report shows.  The four lists are per scene, in the order of scene_files."""
    n = len(scene_files)
    for name, lst in (("ranking tables", rankings), ("static tables", statics),
                      ("findings", findings), ("figures", figures)):
        if len(lst) != n:
            raise ValueError(f"{len(lst)} {name} for {n} scenes: give one per scene, in the same order")
    ctx = {"missing": {}, "dates": {}, "scenes": []}
    for k in range(n):
        name = os.path.splitext(os.path.basename(scene_files[k]))[0]
        sc = {"name": name}
        sc["scene"] = _load(scene_files[k], read_yaml, ctx, f"{name}: scene", "config/scenes") or {}
        rows = (_load(rankings[k], read_table, ctx, f"{name}: ranking table", "snakemake report") or []) + \
               (_load(statics[k], read_table, ctx, f"{name}: static table", "snakemake report") or [])
        sc["rows"] = rows
        fj = _load(findings[k], read_json, ctx, f"{name}: findings", "snakemake report") or {}
        sc["findings"] = fj.get("findings", [])
        man = _load(figures[k], read_json, ctx, f"{name}: figures", "snakemake report") or {}
        base = os.path.dirname(os.path.abspath(figures[k]))
        sc["figures"] = [{**e, "pdf": os.path.join(base, e["pdf"])} for e in man.get("figures", [])
                         if os.path.exists(os.path.join(base, e["pdf"]))]
        ctx["scenes"].append(sc)
    ctx["fe"] = _load(fe, read_json, ctx, "fe", "snakemake all")
    ctx["reduction"] = _load(reduction, read_json, ctx, "reduction", "snakemake reduction_report")
    ctx["mode_ranking"] = _load(mode_ranking, read_mode_ranking, ctx, "mode ranking",
                                "snakemake reduction_report") if mode_ranking else None
    for key, path in optional.items():
        ctx[key] = _load(path, read_json, ctx, key, OPTIONAL.get(key, "snakemake verify")) \
            if path and path.endswith(".json") else None
    # the truth's resolution of each scene, and the findings judged only where it resolves them
    by_scene = {d["scene"]: d for d in (ctx.get("decision") or {}).get("scenes", [])}
    for sc in ctx["scenes"]:
        sc["decision"] = by_scene.get(sc["name"])
        if sc["decision"]:
            sc["findings"] = decision.resolve_findings(sc["findings"], sc["rows"], sc["decision"]["resolution"])
    ctx["versions"] = report_versions()
    ctx["date"] = time.strftime("%Y-%m-%d %H:%M:%S %Z")
    return ctx


def read_mode_ranking(path) -> dict:
    """results/tables/ranking.csv (gimbal_reduction.reduction.report, the Table 4.1 analogue) as
    {body name: {"xmx": (mode, ...), "xmgmx": (mode, ...)}}, 1-based mode numbers, most important
    first."""
    out = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(line for line in f if not line.startswith("#")):
            body = out.setdefault(row["name"], {"xmx": [], "xmgmx": []})
            for key in ("xmx", "xmgmx"):
                body[key].append(int(row[f"{key}_mode_1based"]))
    return {name: {k: tuple(v) for k, v in body.items()} for name, body in out.items()}


# ---------------------------------------------------------------- analysis (pure)
def _E(row):
    return np.array([row[c] for c in RATE_COLUMNS], float)


def analyse_scene(rows) -> dict:
    """The numbers the text quotes for one scene, from its table rows (both tables).

    rigid (4,) E of the rigid model; beat_rigid {rate: [models]} reduced cases (not rigid,
    not the truth check) with E below the rigid model's; n_reduced; best {rate: (model, E,
    n_elastic)}; truth_error (4,) E of static-100 against the truth and its attitude error
    [arcsec]; cheapest {target: (model, max E, n_elastic) or None} the fewest elastic
    coordinates with E <= target on every rate."""
    by = {r["model"]: r for r in rows}
    reduced = [r for r in rows if r["model"] not in (TRUTH, "rigid", TRUTH_CHECK, TRUTH_INTERFACE)
               and np.all(np.isfinite(_E(r)))]
    out = {"n_reduced": len(reduced), "rigid": None, "beat_rigid": {}, "best": {},
           "truth_error": None, "truth_attitude": None, "cheapest": {}}
    if "rigid" in by:
        rigid = _E(by["rigid"])
        out["rigid"] = rigid
        out["rigid_attitude"] = by["rigid"].get("attitude_max_arcsec")
        for k, rate in enumerate(RATES):
            out["beat_rigid"][rate] = [r["model"] for r in reduced if _E(r)[k] < rigid[k]]
    candidates = reduced + ([by["rigid"]] if "rigid" in by else [])
    for k, rate in enumerate(RATES):
        if candidates:
            b = min(candidates, key=lambda r: _E(r)[k])
            out["best"][rate] = (b["model"], float(_E(b)[k]), b["n_elastic"])
    freq = [by[f"freq-{n}"][RATE_COLUMNS[0]] for n in MODE_COUNTS if f"freq-{n}" in by]
    out["freq_monotone"] = len(freq) == len(MODE_COUNTS) and all(b < a for a, b in zip(freq, freq[1:]))
    if TRUTH_CHECK in by:
        out["truth_error"] = _E(by[TRUTH_CHECK])
        out["truth_attitude"] = by[TRUTH_CHECK].get("attitude_max_arcsec")
    for target in TARGETS:
        ok = [r for r in candidates if float(np.max(_E(r))) <= target]
        if ok:
            c = min(ok, key=lambda r: (r["n_elastic"] if r["n_elastic"] is not None else 1e9,
                                       float(np.max(_E(r)))))
            out["cheapest"][target] = (c["model"], float(np.max(_E(c))), c["n_elastic"])
        else:
            out["cheapest"][target] = None
    return out


def ranking_comparison(ours, thesis=THESIS_TABLE_4_1, top=20, lowest=25) -> dict:
    """Our XMX and XMGMX rankings beside the thesis's Table 4.1, per body (pure).

    Mode numbers are in order of frequency on each model's own mesh, so the same number is not
    necessarily the same shape; what compares across models is where the ranked modes sit in
    the spectrum.  Per body and ranking ("thesis", "xmx", "xmgmx"): ``low``, how many of the
    ``top`` most important modes are among the ``lowest`` lowest-frequency modes; ``highest``,
    the highest mode number among them; ``shared``, how many of them the thesis's top also
    holds (as mode numbers)."""
    out = {}
    for body, modes in thesis.items():
        if body not in ours:
            continue
        lists = {"thesis": tuple(modes[:top]), "xmx": tuple(ours[body]["xmx"][:top]),
                 "xmgmx": tuple(ours[body]["xmgmx"][:top])}
        ref = set(lists["thesis"])
        out[body] = {k: {"modes": v, "low": sum(m <= lowest for m in v), "highest": max(v),
                         "shared": len(ref & set(v))} for k, v in lists.items()}
    return out


def analyse(ctx) -> dict:
    """{scene name: analyse_scene(rows)} of every scene with a table."""
    return {sc["name"]: analyse_scene(sc["rows"]) for sc in ctx["scenes"] if sc["rows"]}


# ---------------------------------------------------------------- text
def _frac(models, total):
    return f"{len(models)} of {total}"


def _scene_desc(sc):
    d = sc["scene"].get("description", "") if isinstance(sc["scene"], dict) else ""
    return d or sc["name"]


def summary_section(ctx, an) -> str:
    out = ["= Summary\n\n",
           "This report reproduces and extends the results chapter of P. J. Balucan, _Model "
           "Reduction of a Set of Elastic, Nested Gimbals by Component Mode Selection Criteria and "
           "Static Correction Modes_ (S.M. thesis, MIT, 2001): our own finite-element bodies, the "
           "flexible multibody chain, the truth model (100 modes per body) and every reduced model "
           "of the thesis, plus the rigid baseline, no-static controls, scene-aware selections and the field's defaults, "
           f"each simulated on {len(ctx['scenes'])} scenes. The error is eq. 3.53 of the thesis per "
           "gimbal rate ($E = integral e^2 dif t \\/ integral r^2 dif t$).\n\n"]
    thesis_cases = study_cases(extended=False)
    added = [c for c in study_cases() if c["model"] not in {x["model"] for x in thesis_cases}]
    out.append(f"Cases: the thesis's {s(len(thesis_cases))} (its 25 figure cases, with its one \"ranked\" "
               f"selection run as both XMX and XMGMX) and the project's {s(len(added))} additions (the rigid "
               "baseline, the no-static controls freq-2..8, load-N, global-N, the field's defaults dom-N, "
               "cb-N, ritz-N and Craig-Bampton at equal coordinates, and the truth checks static-100 and "
               "cb-100), on every scene.\n\n")
    for sc in ctx["scenes"]:
        a = an.get(sc["name"])
        if not a or a["rigid"] is None:
            continue
        beat = a["beat_rigid"]["outer"]
        b = (sc.get("decision") or {}).get("best", [None])[0]
        if b and b["status"] == decision.NOT_RESOLVABLE:
            best = (f"Best on the outer rate: not resolvable ({s(b['model'])} and {s(len(b['ties']))} other "
                    "models lie within the truth's own error of it).")
        elif b and b["model"]:
            best = f"Best on the outer rate: {s(b['model'])} (E = {sci(b['E'])}), resolved by the truth."
        else:
            best = "Best on the outer rate: not judged (no truth resolution for this scene)."
        unresolved = sc.get("decision") and not sc["decision"]["rate_resolved"][0]
        out.append(f"- *{s(sc['name'])}*: the rigid model's outer-gimbal error is "
                   f"{sci(a['rigid'][0])}; "
                   + (s("not resolvable: the truth's own error exceeds it, so no reduced model can be "
                        "shown better than the rigid one") if unresolved else
                      f"{s(_frac(beat, a['n_reduced']))} reduced models beat it on that rate")
                   + f". {best}\n")
    out.append("\n")
    # the findings, each named with its verdict and number per scene
    verdict_rows = _verdict_matrix(ctx)
    if verdict_rows:
        out.append("*The findings* (thesis 1-6, the project's 7-10), verdict per scene, judged only where "
                   "the truth resolves the rate (" + s(MARKS_LEGEND) + "); each finding's rule stands "
                   "under it (\"better\" = smaller by more than the 10 % tie band):\n\n")
        out.append(table(["finding and rule"] + [s(sc["name"]) for sc in ctx["scenes"]], verdict_rows,
                         "Verdict of every finding on every scene (results/tables/SCENE/findings.json, "
                         "with the truth's resolution of results/tables/decision.json); each cell: "
                         "overall verdict, then per rate.", "tab-verdicts",
                         columns="(2.4fr" + ", 1fr" * len(ctx["scenes"]) + ")", size="7pt"))
    if ctx["missing"]:
        out.append("*Incomplete report.* These inputs are missing, so the sections that need "
                   "them say so:\n")
        for k, why in ctx["missing"].items():
            out.append(f"- {s(k)}: {s(why)}\n")
        out.append("\n")
    if ctx.get("stale"):
        out.append(stale_list(ctx["stale"], keyed=True) + "\n")
    return "".join(out)


MEASURE_HEADS = {"attitude": "platform attitude error ≤ [arcsec]", "rate": "gimbal-rate error ≤ [rad/s RMS]",
                 "E": "E (eq. 3.53) ≤"}


def _decision_cell(r) -> str:
    """One answer of the decision table: the model, its coordinates, run and set-up times (medians),
    or why none."""
    if r["status"] == decision.NOT_RESOLVABLE:
        return s("not resolvable")
    if r["status"] != "met":
        return s(r["status"])
    return f"*{s(r['model'])}* ({s(r['coordinates'])}) {ms(r['run_ms'])} + {ms(r['setup_ms'])}"


def decision_tables(dec) -> str:
    """Per measure, one table: rows the requirement levels, columns the scenes (decision.json)."""
    scenes = dec["scenes"]
    out = []
    for measure in dec["measures"]:
        levels = []
        for sc in scenes:
            for r in sc["rows"]:
                if r["measure"] == measure and r["requirement"] not in levels:
                    levels.append(r["requirement"])
        rows = []
        for level in levels:
            cells = [s(format(level, "g"))]
            for sc in scenes:
                r = next((r for r in sc["rows"] if r["measure"] == measure and r["requirement"] == level), None)
                cells.append(_decision_cell(r) if r else "--")
            rows.append(cells)
        res = [s("truth's own error")] + [sci(sc["resolution"][measure]) for sc in scenes]
        what = s(dec["measures"][measure]["label"])
        caption = (f"The cheapest model whose {what} plus the truth's own error is within the "
                   "requirement: name (kept coordinates: 4 joint angles + elastic) run + set-up time, "
                   "medians of 5 runs in one process (run: the whole scene; set-up: building the model "
                   "and its problem)." + first_call_note(scenes)
                   if not out else f"As @tab-decision-{next(iter(dec['measures']))}, for the {what}.")
        out.append(table([MEASURE_HEADS.get(measure, measure)] + [s(sc["scene"]) for sc in scenes],
                         rows + [res], caption,
                         f"tab-decision-{measure}", columns=f"(auto,) + (1fr,) * {len(scenes)}", size="6.5pt"))
    return "".join(out)


def first_call_note(scenes) -> str:
    """What a user running one simulation in a fresh process sees beyond the medians: the timing
    jobs' first simulations (bench.runtime.first_call), the largest excess over the scenes."""
    calls = [(sc["scene"], sc["runtime"]["first_call"]) for sc in scenes
             if (sc.get("runtime") or {}).get("first_call")]
    if not calls:
        return ""
    name, c = max(calls, key=lambda x: x[1]["extra_ms"])
    return (f" A fresh process's first simulation takes longer than these medians by at most "
            f"{ms(max(c['extra_ms'], 0.0))} (measured in each timing job; largest on {s(name)}: "
            f"{s(c['model'])} {ms(c['first_run_ms'])} against {ms(c['run_ms'])}).")


CAMP_HEADS = {"thesis": "the thesis's selections (freq, XMX, XMGMX, static)",
              "project": "the project's (load-N, global-N)",
              "field": "the field's defaults (Craig-Bampton, Ritz, dominance)"}


def needs_elastic(r) -> bool:
    """Whether a decision row asks for a reduced model: met, and by neither the rigid model (then
    no mode selection is needed at all) nor the truth (then none of the study's reduced models
    meets it)."""
    return r["status"] == "met" and r.get("model") not in (None, "rigid", "truth")


def camp_wins(dec, measures=("E", "attitude")) -> dict:
    """{camp: number of requirements (of ``measures``, every scene) that need a reduced model
    (``needs_elastic``) at which its cheapest model has the fewest coordinates of the three camps
    (ties count for each)}, and {"judged": how many such requirements some camp meets}."""
    wins = dict.fromkeys(CAMP_HEADS, 0)
    judged = 0
    for sc in dec["scenes"]:
        for r in sc["rows"]:
            if r["measure"] in measures and needs_elastic(r) and r.get("cheapest_camps"):
                judged += 1
                for c in r["cheapest_camps"]:
                    wins[c] += 1
    return {**wins, "judged": judged}


def camps_section(dec, measures=("E", "attitude")) -> str:
    """Whose methods to use: per scene and requirement that needs a reduced model
    (``needs_elastic``), the cheapest model of each camp (decision.json's ``by_camp``), the
    cheapest in bold, then the count of wins."""
    rows = []
    units = {"E": "E ≤", "attitude": "attitude ≤ [arcsec]"}
    for sc in dec["scenes"]:
        for r in sc["rows"]:
            camps = r.get("by_camp")
            if r["measure"] not in measures or not needs_elastic(r) or not camps:
                continue
            cells = [s(sc["scene"]), s(f"{units.get(r['measure'], r['measure'])} {r['requirement']:g}")]
            for c in CAMP_HEADS:
                v = camps.get(c, {})
                text = (s(f"{v['model']} ({v['coordinates']})") if v.get("status") == "met"
                        else s("none of the study's counts"))
                cells.append(f"*{text}*" if c in r.get("cheapest_camps", ()) else text)
            rows.append(cells)
    if not rows:
        return ""
    wins = camp_wins(dec)
    out = [table(["scene", "requirement", *(s(h) for h in CAMP_HEADS.values())], rows,
                 "Whose methods: for every requirement of Tables 1 and 3 that needs a reduced model (the "
                 "rigid model does not meet it, a study model does), the cheapest model of each camp "
                 "meeting it (kept coordinates; bold: the fewest).", "tab-camps", size="6.5pt")]
    order = sorted(CAMP_HEADS, key=lambda c: -wins[c])
    out.append(f"*Whose methods to use.* Over the {wins['judged']} requirements on E and the platform "
               "attitude that need a reduced model, the fewest coordinates came from "
               + s(", ".join(f"{CAMP_HEADS[c].split(' (')[0]} {wins[c]}" for c in order))
               + " (ties count for each; rules: study_report.camp_wins, decision.choose_by_camp). Where "
               "the rigid model meets a requirement no mode selection is needed; below the truth's own "
               "error nothing can be judged.\n\n")
    return "".join(out)


PAYS_RUN_MS = 1000.0     # a truth run of a second or more is one a designer waits for: reduction pays


def pays_section(dec) -> str:
    """Where reduction pays and where it does not, in measured numbers (decision.json): one row per
    scene, then the verdicts."""
    rows, pays, not_pays = [], [], []
    for sc in dec["scenes"]:
        tr, rg = sc["runtime"]["truth"], sc["runtime"].get("rigid", {})
        met = [r for r in sc["rows"] if r["status"] == "met" and r["model"] != "truth" and r["run_ms"]]
        if not tr.get("run_ms"):
            continue
        sp = [r["speedup"] for r in met if r.get("speedup")]
        dims = sorted({r["state_dimension"] for r in met}) or [None]
        batch = (tr.get("setup_ms") or 0.0) + 1000 * tr["run_ms"]
        rows.append([s(sc["scene"]), s(format(sc["runtime"].get("duration_s") or float("nan"), "g") + " s"),
                     f"{ms(tr['run_ms'])} + {ms(tr.get('setup_ms'))}", ms(rg.get("run_ms")),
                     (s(f"{min(sp):.3g}" if f"{min(sp):.3g}" == f"{max(sp):.3g}" else
                        f"{min(sp):.3g} to {max(sp):.3g}") if sp else "--"),
                     s(f"{2 * (sc['truth_coordinates'] or 0)} / {dims[0]} to {dims[-1]}"), ms(batch)])
        (pays if tr["run_ms"] >= PAYS_RUN_MS else not_pays).append(
            f"{sc['scene']} ({tr['run_ms'] / 1e3:.3g} s)" if tr["run_ms"] >= PAYS_RUN_MS else
            f"{sc['scene']} ({tr['run_ms']:.3g} ms)")
    if not rows:
        return note("no timing job results (results/benchmarks/runtime/SCENE.json)")
    load = sorted({x for sc in dec["scenes"] for x in (sc["runtime"].get("load_average") or [])})
    out = [table(["scene", "simulated", "truth: run + set-up", "rigid: run", "speed-up of the answers",
                  "state dimension: truth / answers", "1,000 truth runs"], rows,
                 "Measured cost (timing job, medians of 5 runs in one process"
                 + (f"; machine load average {load[0]:.3g} to {load[-1]:.3g} on {dec['scenes'][0]['runtime'].get('cpu_count') or '?'} "
                    "cores during the runs, so absolute times are inflated; the models of a scene were "
                    "timed interleaved, so their ratios are fair" if load else "") + ").",
                 "tab-pays", size="6.5pt")]
    out.append("*Where reduction pays.* ")
    if pays:
        out.append(f"Simulation time, where the truth runs for a second or more: {s(', '.join(pays))}: "
                   "the answers above are faster by the factors in the table. ")
    if not_pays:
        out.append(f"Not in simulation time where the truth is fast already: {s(', '.join(not_pays))}: "
                   "the exponential integrator's step is not set by the highest frequency, so the truth "
                   "costs milliseconds per run and a reduced model saves little. ")
    out.append("Batches multiply the run time (last column), so they pay where single runs do. The state "
               "dimension pays everywhere: a control design (the linearised state space, "
               "docs/examples/control_export.py) works with twice the kept coordinates.\n\n")
    return "".join(out)


def decision_section(ctx) -> str:
    """Page 1: which model, for what accuracy, at what cost (decision.json)."""
    dec = ctx.get("decision")
    out = ["= The decision <decision>\n\n"]
    if not dec:
        return out[0] + note(s(ctx["missing"].get("decision", "results/tables/decision.json missing")))
    out.append(
        "For an accuracy in the designer's units, the cheapest model of the study meeting it on each "
        "scene, its error bounded by the error against the truth plus the truth's own error (the largest "
        "of its checks: static-100, cb-100, the 200-mode truth). At or below the truth's own error a requirement is *not resolvable*: no "
        "model can be shown to meet it. $sqrt(E)$ is the RMS rate error as a fraction of the RMS rate "
        "($E = 0.04$: 20 %). Rules: gimbal_reduction/results/study/decision.py; numbers: "
        "results/tables/decision.csv.\n\n")
    out.append(decision_tables(dec))
    out.append(pays_section(dec))
    out.append(camps_section(dec))
    return "".join(out)


def _verdict_matrix(ctx):
    ids = []
    for sc in ctx["scenes"]:
        for f in sc["findings"]:
            if f["finding"] not in ids:
                ids.append(f["finding"])
    rows = []
    for i in sorted(ids):
        first = next(f for sc in ctx["scenes"] for f in sc["findings"] if f["finding"] == i)
        row = [f"{s(f'{i}. ' + first['statement'])} \\ #text(size: 6pt)[rule: {s(first.get('rule', ''))}]"]
        for sc in ctx["scenes"]:
            f = next((f for f in sc["findings"] if f["finding"] == i), None)
            if f is None:
                row.append("--")
                continue
            row.append(f"{s(f['verdict'])} \\ {s(verdict_marks(f['verdict_per_rate']))}")
        rows.append(row)
    return rows


def methods_section(ctx) -> str:
    out = ["= Methods\n\n",
           "*Bodies and modes.* The three gimbal rings are Reissner-Mindlin shells (P2, DOLFINx "
           "0.5), the stable platform a solid of curved P3 tetrahedra; 100 supported modes per "
           "body from SLEPc (the model report, results/report/model.pdf, lists the frequencies and the FE checks). "
           "*Reduction.* Frequency cutoff, XMX and XMGMX rankings (Hughes identities), "
           "residual-attachment static correction modes, and two scene-aware selections: "
           "load-N (each body's modes ranked by what the scene's joint loads make them contribute "
           "to the gimbal rates) and global-N (N modes pooled over the bodies). *Dynamics.* "
           "Floating frames with exact large rotations, integrated by the modal exponential "
           "integrator (exact harmonic solution of the linearised chain's modes; E below 1e-8 against a "
           "converged reference on every verified scene: DOP853 at rtol 1e-10, or the exponential "
           "integrator 100 times tighter, itself checked against DOP853; Verification). *Errors.* E of eq. 3.53 "
           "per gimbal rate against the truth on the same scene, and the stable platform's attitude "
           "error: the angle between the model's and the truth's platform frame (case motion "
           "prescribed, so it is the inertial attitude error), largest over the window, in arcsec. "
           "*Sampling.* Every model is sampled on its scene's output grid (@tab-scenes), and "
           "E is the trapezoid rule over those samples: a mean square, exact while the sampling rate "
           "exceeds twice the highest frequency the rates hold. The rule "
           "(gimbal_reduction.solver.dynamics.error_measure): the grid's Nyquist frequency is at "
           f"least {SAMPLING_MARGIN:g} times the highest coupled mode of the truth that holds "
           f"{sci(SAMPLING_SHARE)} or more of a gimbal rate's mean square under the scene's drive; "
           "the study checks it before it simulates the truth, and each scene report states the "
           "mode.\n\n"]
    rows = []
    for sc in ctx["scenes"]:
        d = sc["scene"] if isinstance(sc["scene"], dict) else {}
        dur = (d.get("duration") or {}).get("value", "--")
        damp = (d.get("damping_ratio") or {}).get("value", "--")
        try:
            dt = units.convert(d["output_interval"], "s", "output_interval")
            every = s(f"{dt * 1e6:.4g} µs ({0.5 / dt / 1e3:.4g} kHz)")
        except (KeyError, TypeError, ValueError, ZeroDivisionError):
            every = s("--")
        rows.append([s(sc["name"]), s(_scene_desc(sc)), s(f"{dur} s"), every, s(damp), s(len(sc["rows"]) - 1)])
    out.append(table(["scene", "what", "duration", "output every (Nyquist)", "damping ratio", "cases"], rows,
                     "The study's scenes (config/scenes/NAME.yaml; every number there carries its "
                     "unit and source).", "tab-scenes", columns="(auto, 3fr, auto, auto, auto, auto)"))
    groups = sorted({r["group"] for sc in ctx["scenes"] for r in sc["rows"] if r["group"] != "truth"})
    out.append("The cases, by group: " + "; ".join(f"{s(g)}: {s(names.label(g))}"
                                                   for g in groups) + ".\n\n")
    return "".join(out)


TABLE_MODELS = ("rigid", "freq-10", "freq-25", "xmx-10", "xmgmx-10", "static-6", "static-8",
              "load-10", "load-25", "global-40", "global-100")


def results_section(ctx, an, root) -> str:
    out = ["= Results\n\n== Key models on every scene\n\n"]
    for sc in ctx["scenes"]:
        by = {r["model"]: r for r in sc["rows"]}
        res = (sc.get("decision") or {}).get("resolution")

        def cell(x, k):
            v = x if res is None else decision.cell(x, res["E_per_rate"][k])
            return s("n.r.") if v == decision.NOT_RESOLVABLE else sci(v)
        rows = [[s(m), s(by[m]["n_elastic"])] + [cell(by[m][c], k) for k, c in enumerate(RATE_COLUMNS)] +
                [sci(by[m].get("attitude_max_arcsec"))] for m in TABLE_MODELS if m in by]
        if rows:
            out.append(table(["model", "elastic coord.", "E outer", "E middle", "E inner",
                              "E platform", "attitude [arcsec]"], rows,
                             f"Scene {s(sc['name'])}: E (eq. 3.53) per gimbal rate and the largest "
                             f"platform attitude error, for the baseline and one model per family "
                             f"(every case: the scene's PDF); n.r. = not resolvable, within the truth's "
                             f"own error on that rate.", f"tab-key-{sc['name']}", size="7.5pt"))
        else:
            out.append(note(f"scene {s(sc['name'])}: no error table"))
    out.append(thesis_tables(ctx))
    out.append(thesis_ranking_table(ctx))
    out.append(truth_error_section(ctx, an))
    out.append("== Error against the number of modes\n\n")
    for sc in ctx["scenes"]:
        err = [f for f in sc["figures"] if f.get("kind") == "error"]
        for f in err[:1]:
            out.append(figure(f["pdf"], f"Scene {s(sc['name'])}: " + s(f["caption"]), root, width="66%"))
        if not err:
            out.append(note(f"scene {s(sc['name'])}: no error figure"))
    out.append(tolerance_section(ctx, root))
    return "".join(out)


def truth_referee(an, basis) -> dict:
    """{scene: the error the truth can referee}: the larger of the truth's distance to the
    larger basis (truth_basis.json, max over rates) and to the truth with residual flexibility
    (static-100), where known."""
    out = {}
    for name, a in an.items():
        vals = []
        if a["truth_error"] is not None:
            vals.append(float(np.max(a["truth_error"])))
        b = (basis or {}).get("scenes", {}).get(name)
        if b:
            vals.append(float(b["E_max"]))
        if vals:
            out[name] = max(vals)
    return out


def unrefereed_scenes(an, basis) -> list[tuple[str, float, float]]:
    """[(scene, the truth's E against the larger basis, the rigid model's E)] on the outer gimbal rate,
    for the scenes where the truth's own error is at least the rigid model's: there the truth cannot
    separate the reduced models (every one of them lies within the truth's error of the rigid one or
    beyond it)."""
    out = []
    for name, b in ((basis or {}).get("scenes") or {}).items():
        a = an.get(name)
        if a and a["rigid"] is not None and b["E"][0] >= a["rigid"][0]:
            out.append((name, float(b["E"][0]), float(a["rigid"][0])))
    return out


def truth_error_section(ctx, an) -> str:
    out = ["== The truth's own error\n\n"]
    basis = ctx.get("truth_basis")
    rows = []
    for sc in ctx["scenes"]:
        a, name = an.get(sc["name"]), sc["name"]
        if a and a["truth_error"] is not None:
            rows.append([s(name), s("static-100")] + [sci(x) for x in a["truth_error"]] +
                        [sci(a["truth_attitude"])])
        b = (basis or {}).get("scenes", {}).get(name)
        if b:
            rows.append([s(name), s(basis.get("larger_basis", "200 modes per body"))] +
                        [sci(x) for x in b["E"]] + [sci(b.get("attitude_max_arcsec"))])
        d = sc.get("decision")
        if d:
            res = d["resolution"]
            rows.append([s(name), f"*{s('resolution (the larger, used everywhere)')}*"] +
                        [sci(x) for x in res["E_per_rate"]] + [sci(res["attitude"])])
    if not rows:
        return out[0] + note("no static-100 case in the tables and no larger-basis check")
    ref = truth_referee(an, basis)
    out.append("The truth keeps the 100 lowest modes per body. Two checks bound what it leaves out: "
               "one static correction mode per body added (static-100: the quasi-static residual "
               "flexibility of the truncated modes under the bearing loads), and a basis of 200 modes "
               "per body on the same meshes (freq-200; "
               + (f"results/verification/truth_basis.json, {s(ctx['dates'].get('truth_basis', ''))}"
                  if basis else s(ctx["missing"].get("truth_basis", "not run"))) + "). "
               "The truth can referee errors down to about: "
               + "; ".join(f"{s(k)} {sci(v)}" + ("" if k in (basis or {}).get("scenes", {})
                                                   else s(" (residual flexibility only: a lower bound)"))
                           for k, v in ref.items()) + ". ")
    th_b = (basis or {}).get("scenes", {}).get("thesis")
    th_a = an.get("thesis")
    if th_b and th_a and th_a["truth_error"] is not None and th_b["E_max"] > 10 * np.max(th_a["truth_error"]):
        out.append(f"On the thesis scene the larger basis moves the rates by E = {sci(th_b['E_max'])}, "
                   "far more than the residual flexibility does: the step at t = 0 also rings the modes "
                   "above the 100th, which a static correction cannot represent"
                   + (f" (without the step, on the smooth scene, the two truths differ by E = "
                      f"{sci(basis['scenes']['smooth']['E_max'])})" if "smooth" in basis.get("scenes", {})
                      else "") + ". Reduced-model errors near that level are not resolved by this truth.")
    unresolved = unrefereed_scenes(an, basis)
    if unresolved:
        out.append(" " + " ".join(
            f"On the {s(name)} scene the truth's own error on the outer gimbal rate "
            f"(E = {sci(own)} against {s(basis.get('larger_basis', 'the larger basis'))}) is larger than "
            f"the rigid model's error ({sci(rigid)}): the differences between that scene's reduced models "
            "are below what this truth resolves, so its rankings and verdicts compare models with a "
            "truncated truth, not with the chain."
            for name, own, rigid in unresolved))
    out.append("\n\n")
    out.append(table(["scene", "compared with", "E outer", "E middle", "E inner", "E platform",
                      "attitude [arcsec]"], rows,
                     "The truth (100 modes per body) against the truth with residual flexibility "
                     "(static-100) and against a 200-modes-per-body truth (freq-200).",
                     "tab-truth-error", size="7.5pt"))
    return "".join(out)


# thesis Tables 4.2 / 4.3 (findings.THESIS) against our cases on the thesis scene: (label, key, model
# of our case at count n); "ranked" is the thesis's one ranking, shown against our XMX and XMGMX
THESIS_ROWS = (("freq", "freq", "freq-{n}"), ("ranked (ours: XMX)", "ranked", "xmx-{n}"),
               ("ranked (ours: XMGMX)", "ranked", "xmgmx-{n}"),
               ("1 static + lowest", "static-freq", "static-{n}"),
               ("1 static + ranked (ours: XMX)", "static-ranked", "static-xmx-{n}"))


def thesis_tables(ctx) -> str:
    """The thesis's Tables 4.2 and 4.3 beside ours (outer and middle rates, thesis scene)."""
    sc = next((sc for sc in ctx["scenes"] if sc["name"] == "thesis"), None)
    if sc is None or not sc["rows"]:
        return note("no thesis-scene table: the thesis's Tables 4.2 and 4.3 are not compared")
    by = {r["model"]: r for r in sc["rows"]}
    rows, ratios = [], []
    for label, key, pattern in THESIS_ROWS:
        for n, E in sorted(THESIS[key].items()):
            ours = by.get(pattern.format(n=n))
            if ours and ours[RATE_COLUMNS[0]] > 0:
                ratios.append(E[0] / ours[RATE_COLUMNS[0]])
            rows.append([s(label), s(n), sci(E[0]), sci(ours[RATE_COLUMNS[0]]) if ours else "--",
                         sci(E[1]), sci(ours[RATE_COLUMNS[1]]) if ours else "--"])
    rigid = by.get("rigid")
    if rigid:
        rows.append([s("rigid (not in the thesis)"), s(0), "--", sci(rigid[RATE_COLUMNS[0]]), "--",
                     sci(rigid[RATE_COLUMNS[1]])])
    return ("== The thesis's Tables 4.2 and 4.3 beside ours\n\n" +
            table(["case", "modes per body", "E outer (thesis)", "E outer (ours)", "E middle (thesis)",
                   "E middle (ours)"], rows,
                  "Thesis Tables 4.2 (frequency and ranked modes) and 4.3 (one static mode per body) "
                  "against our thesis scene, outer and middle gimbal rates. "
                  + (f"On the outer rate the thesis's E is {min(ratios):.3g} to {max(ratios):.3g} "
                     "times ours: its bodies and bearing model differ from ours (docs/reduction.md), "
                     "and it reports a low-frequency response of its reduced models that varies "
                     "strongly with the mode count (its Section 4.3)." if ratios else ""),
                  "tab-thesis-side", size="7pt")
            + typo_list())


RATE_WORDS = ("outer gimbal", "middle gimbal", "inner gimbal", "stable platform")
TABLE_NAMES = {"freq": "Table 4.2, lowest modes", "ranked": "Table 4.2, ranked modes",
               "static-freq": "Table 4.3, 1 static + lowest", "static-ranked": "Table 4.3, 1 static + ranked"}


def typo_list() -> str:
    """The entries of the thesis's tables that are probably misprints, with the reason
    (findings.THESIS_SUSPECTED_TYPOS; the figures draw them apart, not joined)."""
    items = [f"- {s(f'{TABLE_NAMES.get(key, key)}, {n} modes, {RATE_WORDS[k]} rate: {why}.')}\n"
             for (key, n, k), why in THESIS_SUSPECTED_TYPOS.items()]
    return ("*Suspected misprints in the thesis's tables* (drawn as red crosses, not joined, in the "
            "error figures; the findings' thesis checks use the values as printed):\n" + "".join(items) + "\n")


def thesis_ranking_table(ctx, top=20, lowest=25) -> str:
    """Thesis Table 4.1 (its first 20 rows) beside our XMX and XMGMX rankings of the same bodies."""
    ours = ctx.get("mode_ranking")
    if not ours:
        return note("no mode ranking (results/tables/ranking.csv): Table 4.1 is not compared")
    cmp_ = ranking_comparison(ours, top=top, lowest=lowest)
    bodies = list(cmp_)
    short = {"outer_gimbal": "outer", "middle_gimbal": "middle", "inner_gimbal": "inner",
             "stable_platform": "platform"}
    header = ["rank"] + [f"{short.get(b, b)} {k}" for b in bodies for k in ("thesis", "XMX", "XMGMX")]
    rows = [[s(i + 1)] + [s(cmp_[b][k]["modes"][i]) for b in bodies for k in ("thesis", "xmx", "xmgmx")]
            for i in range(top)]
    for key, label in (("low", f"in the {lowest} lowest"), ("highest", "highest mode"),
                       ("shared", "shared with thesis")):
        rows.append([s(label)] + [s(cmp_[b][k][key]) for b in bodies for k in ("thesis", "xmx", "xmgmx")])
    low = {k: sum(cmp_[b][k]["low"] for b in bodies) for k in ("thesis", "xmx", "xmgmx")}
    shared = {k: sum(cmp_[b][k]["shared"] for b in bodies) for k in ("xmx", "xmgmx")}
    n = top * len(bodies)
    return ("== The thesis's Table 4.1 beside ours\n\n" +
            table(header, rows,
                  f"Thesis Table 4.1 (one ranking for XMX and XMGMX, its first {top} of 40 rows) beside "
                  f"our XMX and XMGMX rankings (results/tables/ranking.csv), 1-based mode numbers in "
                  f"order of frequency, most important first. Of the {n} top-{top} modes, "
                  f"{low['thesis']} (thesis), {low['xmx']} (XMX) and {low['xmgmx']} (XMGMX) are among "
                  f"each body's {lowest} lowest; {shared['xmx']} (XMX) and {shared['xmgmx']} (XMGMX) "
                  f"mode numbers are also in the thesis's top {top}. Mode numbers on different meshes "
                  f"and bearing models need not be the same shapes: the comparison is where in the "
                  f"spectrum the important modes sit.", "tab-thesis-ranking",
                  columns=f"(auto,) + (1fr,) * {len(header) - 1}", size="6.5pt"))


def _best_outer(ctx, name) -> str:
    """The most accurate model on a scene's outer rate as text, or "not resolvable" (decision.best)."""
    sc = next((sc for sc in ctx["scenes"] if sc["name"] == name), None)
    b = ((sc or {}).get("decision") or {}).get("best", [None])[0]
    if not b or not b["model"]:
        return "not judged (no truth resolution)"
    if b["status"] == decision.NOT_RESOLVABLE:
        return f"not resolvable ({s(b['model'])} and {s(len(b['ties']))} others within the truth's own error)"
    return f"{s(b['model'])} ({sci(b['E'])})"


def discussion_section(ctx, an) -> str:
    out = ["= Discussion\n\n"]
    th, sm, dm, lg = (an.get(k) for k in ("thesis", "smooth", "damped", "long"))
    has = lambda a: a is not None and a["rigid"] is not None        # noqa: E731
    if has(th):
        beat = th["beat_rigid"]["outer"]
        out.append(
            f"*The rigid baseline.* On the thesis scene the rigid model, which keeps no elastic mode, "
            f"has E = {sci(th['rigid'][0])} on the outer-gimbal rate, and only "
            f"{s(_frac(beat, th['n_reduced']))} reduced models do better "
            f"({s(', '.join(beat[:12]) + (' ...' if len(beat) > 12 else '') if beat else 'none')}). "
            "The thesis scene starts the case's angular acceleration with a step at t = 0 (cos(2 pi 2 t) "
            "from rest), which sets the chain's coupled modes ringing, undamped (the model report lists "
            "them). ")
        if has(sm) and sm["rigid"][0] > 0:
            ratio = th["rigid"][0] / sm["rigid"][0]
            out.append(
                f"Without the step (scene smooth) the rigid model's outer error is {sci(sm['rigid'][0])}, "
                f"{s(f'{ratio:.0f}' if ratio >= 100 else f'{ratio:.3g}')} times smaller: on the thesis scene the "
                "rigid model's error is almost entirely the start-up ringing it cannot have. A reduced "
                "model rings too, but at shifted coupled frequencies and with another participation, "
                "so its error holds the part of the truth's ringing it misses and its own. That is "
                "consistent with which models beat the rigid one: those that keep the modes the joint "
                "loads excite (load-N, global-N) or many modes.")
        out.append("\n\n")
    if has(sm) and has(th):
        out.append(f"*Smooth start (scene smooth).* {s(_frac(sm['beat_rigid']['outer'], sm['n_reduced']))} "
                   f"reduced models beat the rigid model on the outer rate (thesis scene: "
                   f"{s(len(th['beat_rigid']['outer']))}); best: {_best_outer(ctx, 'smooth')}."
                   + (" With no ringing to get wrong, modal truncation does what the thesis expected "
                      "of it: the outer error of the lowest-frequency cutoff falls with every 5 modes "
                      "added (freq-5 to freq-25)." if sm["freq_monotone"] else "") + "\n\n")
    if has(dm) and has(th):
        out.append(f"*1 % damping (scene damped).* The ringing decays; the rigid model's outer error "
                   f"is {sci(dm['rigid'][0])} and {s(_frac(dm['beat_rigid']['outer'], dm['n_reduced']))} "
                   f"reduced models beat it; best: {_best_outer(ctx, 'damped')}.\n\n")
    if has(lg) and has(th):
        n_lg = len(lg["beat_rigid"]["outer"])
        out.append(f"*1 s window (scene long).* The rigid model's outer error is {sci(lg['rigid'][0])} "
                   f"(the slow motion of 1 s carries more signal than the 15 ms window) and "
                   f"{s(_frac(lg['beat_rigid']['outer'], lg['n_reduced']))} reduced models beat it; best "
                   f"on the outer rate: {_best_outer(ctx, 'long')}. ")
        if n_lg * 2 < lg["n_reduced"]:
            out.append("Undamped ringing that a reduced model gets slightly wrong in frequency drifts out "
                       "of phase with the truth's as the window lengthens, so its error keeps growing, "
                       "while the rigid model's stays the amplitude of the truth's ringing.")
        own = next((e for name, e, _ in unrefereed_scenes(an, ctx.get("truth_basis")) if name == "long"), None)
        if own is not None:
            out.append(f" The truth itself is E = {sci(own)} from the 200-mode truth on this scene, more "
                       "than the rigid model's error: on long no reduced model can be judged better than "
                       "another at this truth's resolution (@tab-truth-error).")
        out.append("\n\n")
    # findings that change with the scene
    changing = []
    ids = sorted({f["finding"] for sc in ctx["scenes"] for f in sc["findings"]})
    for i in ids:
        v = {sc["name"]: next((f["verdict"] for f in sc["findings"] if f["finding"] == i), None)
             for sc in ctx["scenes"]}
        if len({x for x in v.values() if x}) > 1:
            changing.append((i, v))
    if changing:
        out.append("*Verdicts that change with the scene.* " + " ".join(
            f"Finding {s(i)}: " + ", ".join(f"{s(k)} {s(x)}" for k, x in v.items() if x) + "."
            for i, v in changing) + " A verdict that holds on one scene and not on another is a "
            "property of the scene's excitation, not of the reduction method; the thesis judged "
            "its methods on one scene only.\n\n")
    elif ids:
        out.append("*Verdicts across scenes.* Every finding has the same overall verdict on every "
                   "scene.\n\n")
    return "".join(out)


def conclusions_section(ctx, an) -> str:
    out = ["= Conclusions and recommendation\n\n",
           "Which model for which accuracy, at what cost: @decision (page 1), with every answer "
           "bounded by the truth's own error and its measured run and set-up times. "]
    dec = ctx.get("decision")
    th = next((d for d in (dec or {}).get("scenes", []) if d["scene"] == "thesis"), None)
    if th:
        r2 = next((r for r in th["rows"] if r["measure"] == "E" and r["requirement"] == 1e-2), None)
        if r2 and r2["status"] == "met":
            out.append(f"For E ≤ $10^(-2)$ on every rate of the thesis scene use {s(r2['model'])} "
                       f"({s(r2['coordinates'])} coordinates). ")
        low = [r for r in th["rows"] if r["status"] == decision.NOT_RESOLVABLE]
        if low:
            out.append(f"Tighter requirements ({s(len(low))} of the table's) are not resolvable by this "
                       "truth: they need a larger truth before any model can be recommended for them. ")
    out.append("Modes chosen by the scene's loads (load-N, pooled global-N) reach a given error "
               "with fewer coordinates than frequency cutoff or the Hughes-identity rankings "
               "wherever finding 9 holds; the thesis's closing advice (take the applied loads into "
               "account when reducing) is the one our results support. A model should always be "
               "checked against the rigid baseline on the scene it is used for.\n\n")
    return "".join(out)


# ---------------------------------------------------------------- accuracy on request
def _float_or_none(x):
    try:
        x = float(x)
    except (TypeError, ValueError):
        return None
    return x if np.isfinite(x) else None


def _int_or_none(x):
    x = _float_or_none(x)
    return None if x is None else int(x)


def tolerance_chart_data(tol, scene_rows) -> dict:
    """Chart and table data of "cost against requested tolerance" (pure).

    tol: results/benchmarks/tolerance.json (gimbal_reduction.results.bench.tolerance); scene_rows: {scene: rows of
    its study error table}.  Per bench scene, in the bench's order:
    ``points`` [{eps, n_kept, run_time_s, estimated, measured, within, apriori_N,
    apriori_measured, method, status}] (EPS descending; a refused request has n_kept None;
    apriori_*: the frozen chain's own choice and its measured E, None where not measured); ``families`` {family: [{eps, model, n_elastic,
    E_max, run_time_s}]}: for every EPS the cheapest model of the family in the study table meeting
    EPS on every rate (``gimbal_reduction.results.bench.equal_error.cheapest_within``; model None where no study
    model does), with its run time from the bench's comparisons timed in the same run (None if
    the bench did not time it); ``has_table``: the scene has a study table."""
    rows = tol.get("rows", []) if tol else []
    timed = {(c["scene"], float(c["eps"]), c["family"], c.get("model")): c
             for c in (tol or {}).get("comparisons", []) if c.get("model")}
    out = {}
    for scene in dict.fromkeys(r["scene"] for r in rows):
        pts = []
        for r in sorted((r for r in rows if r["scene"] == scene), key=lambda r: -float(r["eps"])):
            ok = r.get("status") == "ok"
            pts.append({"eps": float(r["eps"]), "n_kept": int(r["n_kept"]) if ok else None,
                        "run_time_s": float(r["run_time_s"]) if ok else None,
                        "estimated": float(r["estimated_E_max"]) if ok else None,
                        "measured": float(r["measured_E_max"]) if ok else None,
                        "within": bool(r["within_request"]) if ok else None,
                        "apriori_N": _int_or_none(r.get("apriori_N")) if ok else None,
                        "apriori_measured": _float_or_none(r.get("apriori_measured_E_max")) if ok else None,
                        "method": r.get("method", ""), "status": r.get("status", "")})
        table_rows = scene_rows.get(scene) or []
        fams = {}
        for family in FAMILIES:
            fams[family] = []
            for p in pts:
                c = cheapest_within(table_rows, family, p["eps"])
                t = timed.get((scene, p["eps"], family, c["model"])) if c else None
                fams[family].append({"eps": p["eps"], "model": c["model"] if c else None,
                                     "n_elastic": int(c["n_elastic"]) if c else None,
                                     "E_max": max_error(c) if c else None,
                                     "run_time_s": float(t["run_time_s"]) if t and t.get("run_time_s") != ""
                                     else None})
        out[scene] = {"points": pts, "families": fams, "has_table": bool(table_rows)}
    return out


def tolerance_summary(data) -> dict:
    """The numbers the section's text quotes (pure, from ``tolerance_chart_data``): requests,
    built, within the request, per method; where the a-priori estimate chose, measured /
    estimated E per scene (min, max) and over all (max: the side that breaks a promise); where
    the search ran, how often the frozen chain's own choice would have missed the request (its
    set's measured E > EPS); the equal-error comparisons with the cheapest study model of each
    family (tol-EPS keeps fewer, as many or more coordinates), and the requests no study model
    meets."""
    pts = [(scene, p) for scene, d in data.items() for p in d["points"]]
    built = [(scene, p) for scene, p in pts if p["n_kept"] is not None]
    out = {"requests": len(pts), "built": len(built), "within": sum(p["within"] for _, p in built),
           "methods": {}, "apriori_ratio": {}, "apriori_max_ratio": None, "comparisons": [],
           "fewer": 0, "equal": 0, "more": 0, "more_scenes": [], "beyond_study": 0,
           "promise_checked": 0, "promise_broken": []}
    for method in dict.fromkeys(p["method"] for _, p in built):
        mine = [p for _, p in built if p["method"] == method]
        out["methods"][method] = {"built": len(mine), "within": sum(p["within"] for p in mine),
                                  "scenes": sorted({sc for sc, p in built if p["method"] == method})}
    for scene, d in data.items():
        r = [p["measured"] / p["estimated"] for p in d["points"]
             if p["n_kept"] is not None and p["method"] == "a-priori estimate" and p["estimated"]]
        if r:
            out["apriori_ratio"][scene] = (min(r), max(r))
    if out["apriori_ratio"]:
        out["apriori_max_ratio"] = max(hi for _, hi in out["apriori_ratio"].values())
    for scene, p in built:              # where the search ran: would the frozen chain's choice have held?
        if p["method"] == "verified search" and p["apriori_measured"] is not None:
            out["promise_checked"] += 1
            if p["apriori_measured"] > p["eps"]:
                out["promise_broken"].append((scene, p["eps"], p["apriori_N"], p["apriori_measured"]))
    for scene, d in data.items():
        for k, p in enumerate(d["points"]):
            if p["n_kept"] is None or not d["has_table"]:
                continue
            fam = [d["families"][f][k] | {"family": f} for f in FAMILIES if d["families"][f][k]["model"]]
            if not fam:
                out["beyond_study"] += 1
            for f in fam:
                out["comparisons"].append((scene, p["eps"], f["family"], f["model"], p["n_kept"], f["n_elastic"]))
                key = "fewer" if p["n_kept"] < f["n_elastic"] else "equal" if p["n_kept"] == f["n_elastic"] \
                    else "more"
                out[key] += 1
                if key == "more" and scene not in out["more_scenes"]:
                    out["more_scenes"].append(scene)
    return out


def _eps_label(eps) -> str:
    """EPS as Typst math: 10^(-k) for a power of ten, else ``sci``."""
    k = np.log10(eps)
    return f"$10^({int(round(k))})$" if abs(k - round(k)) < 1e-9 else sci(eps, 2)


TOL_MARK = {True: "(within)", False: "(beyond)", None: ""}    # words of the body font, no symbol glyphs


def _damping(sc) -> float:
    """The modal damping ratio of a report scene (its scene file), 0 if not given."""
    d = sc["scene"] if isinstance(sc.get("scene"), dict) else {}
    return float((d.get("damping_ratio") or {}).get("value", 0.0) or 0.0)


def tolerance_table(data) -> str:
    """Estimated against measured E: per scene the kept coordinates, the a-priori estimate and the
    measured E ("within" the request or "beyond" it) of tol-EPS, one column per EPS."""
    eps = sorted({p["eps"] for d in data.values() for p in d["points"]}, reverse=True)
    rows, own_choice = [], False
    for scene, d in data.items():
        by = {p["eps"]: p for p in d["points"]}
        verified = any(p["method"] == "verified search" for p in d["points"])
        label = f"{scene} (verified search)" if verified else scene
        rows.append([s(label), s("N kept")] + [s(by[e]["n_kept"]) if e in by and by[e]["n_kept"] is not None
                                               else s("refused") for e in eps])
        rows.append(["", s("estimated" + (" (not valid)" if verified else ""))] +
                    [sci(by[e]["estimated"]) if e in by else "--" for e in eps])
        rows.append(["", s("measured")] + [(sci(by[e]["measured"]) + " " + s(TOL_MARK[by[e]["within"]]))
                                           if e in by and by[e]["measured"] is not None else "--" for e in eps])
        if verified and any(by[e].get("apriori_measured") is not None for e in eps if e in by):
            own_choice = True
            rows.append(["", s("frozen chain's own choice N")] +
                        [s(by[e]["apriori_N"]) if e in by and by[e]["apriori_N"] is not None else "--" for e in eps])
            rows.append(["", s("its measured E")] +
                        [(sci(by[e]["apriori_measured"]) + " " + s(TOL_MARK[by[e]["apriori_measured"] <= e]))
                         if e in by and by[e]["apriori_measured"] is not None else "--" for e in eps])
    return table(["scene", ""] + [f"EPS {_eps_label(e)}" for e in eps], rows,
                 "tol-EPS on every bench scene: elastic coordinates kept, the frozen chain's a-priori E "
                 "(max over the four gimbal rates) and the E measured against the truth (within: the E is within the "
                 "request). Where the frozen chain does not hold, the model was chosen by verified "
                 "search and its estimate is shown only for comparison"
                 + (", with the set the frozen chain would have chosen and its measured E (the search's "
                    "first probe)" if own_choice else "") + ".", "tab-tolerance",
                 columns=f"(auto, auto) + (1fr,) * {len(eps)}", size="6.5pt")


def draw_tolerance_chart(data, stem) -> dict:
    """The chart "cost against requested tolerance": one row per scene, kept elastic coordinates
    (left) and the median integration time (right) against EPS, tol-EPS as a line, the cheapest
    freq-, xmx- and global-N of the study meeting EPS as markers; stem.pdf and stem.png."""
    plt = pyplot()
    scenes = list(data)
    eps = [p["eps"] for d in data.values() for p in d["points"]] or [1e-2]
    with plt.rc_context({**STYLE, "font.size": 7, "legend.fontsize": 7}):
        fig = plt.figure(figsize=(6.7, 1.3 * len(scenes) + 0.8), constrained_layout=True)
        grid = fig.add_gridspec(len(scenes) + 1, 2, height_ratios=[0.22] + [1.0] * len(scenes))
        key = fig.add_subplot(grid[0, :])
        key.axis("off")
        axes = [(fig.add_subplot(grid[k + 1, 0]), fig.add_subplot(grid[k + 1, 1])) for k in range(len(scenes))]
        handles = {}
        for (ax, bx), scene in zip(axes, scenes):
            d = data[scene]
            pts = [p for p in d["points"] if p["n_kept"] is not None]
            x = [p["eps"] for p in pts]
            h, = ax.plot(x, [p["n_kept"] for p in pts], color="black", marker="o", ms=3, lw=1.2)
            bx.plot(x, [p["run_time_s"] for p in pts], color="black", marker="o", ms=3, lw=1.2)
            handles["tol-EPS"] = h
            for k, family in enumerate(FAMILIES):
                color, marker = names.style(family).colour, names.style(family).marker
                fs = [f for f in d["families"][family] if f["model"]]
                shift = 1.0 + 0.12 * (k - 1)              # side by side at one EPS
                handles[f"cheapest {family}-N of the study"] = ax.scatter(
                    [f["eps"] * shift for f in fs], [f["n_elastic"] for f in fs], color=color,
                    marker=marker, s=16, zorder=3)
                timed = [f for f in fs if f["run_time_s"]]
                bx.scatter([f["eps"] * shift for f in timed], [f["run_time_s"] for f in timed], color=color,
                           marker=marker, s=16, zorder=3)
            ax.set_ylabel(f"{scene}\nelastic coord.")
            ax.set_ylim(-15, 420)
            bx.set_yscale("log")
            bx.set_ylabel("run time [s]")
            if not d["has_table"]:
                ax.text(0.02, 0.9, "no study table: tol-EPS only", transform=ax.transAxes, fontsize=6,
                        va="top", color="0.35")
            for a in (ax, bx):
                a.set_xscale("log")
                a.set_xlim(2 * max(eps), min(eps) / 2)          # tighter tolerance to the right
                if scene != scenes[-1]:
                    a.tick_params(labelbottom=False)
                else:
                    a.set_xlabel("requested tolerance EPS")
        key.legend(list(handles.values()), list(handles), loc="center", ncol=4, fontsize=7, frameon=False,
                   handletextpad=0.3, columnspacing=1.2)
        return save(fig, stem)


def mesh_convergence(fe_full) -> list:
    """The mesh-convergence checks of ``fe.json`` (``gimbal_reduction.solver.fe.checks.check_convergence``), one
    per body: [{name, mesh_sizes (levels,) [in], deviation (levels, n) |f/f_finest - 1| per mode,
    default (index of the default mesh), count (modes of the verdict), passed}], those holding
    per-mode deviations only."""
    out = []
    for c in (fe_full or {}).get("checks", []):
        dev = c.get("deviation_per_mode")
        if "mesh convergence" not in c.get("name", "") or not dev:
            continue
        sizes = [float(h) for h in c["mesh_sizes"]]
        # the default mesh is the coarsest level within 1 % when the check passes; the levels are
        # (2h, h, h/2) for the rings and (h, h/2, h/4) for the platform (check_convergence)
        default = 1 if "gimbal" in c["name"] else 0
        out.append({"name": c["name"].split(" mesh convergence")[0], "mesh_sizes": sizes,
                    "deviation": [[float(v) for v in row] for row in dev], "default": default,
                    "count": len(c.get("frequencies_hz", [[]])[0]), "passed": bool(c.get("passed"))})
    return out


def draw_convergence(entries, stem) -> dict:
    """Relative frequency change of every computed mode against the finest mesh, one panel per
    body, each coarser level a line; the 1 % and 0.5 % limits of the verdict dashed."""
    plt = pyplot()
    with plt.rc_context({**STYLE, "font.size": 7, "legend.fontsize": 6.5}):
        cols = min(2, len(entries))
        rows = -(-len(entries) // cols)
        fig, axes = plt.subplots(rows, cols, figsize=(6.7, 1.9 * rows + 0.2), sharey=True, squeeze=False,
                                 constrained_layout=True)
        for ax in axes.ravel()[len(entries):]:
            ax.axis("off")
        axes = axes.ravel()
        for ax, e in zip(axes, entries):
            finest = e["mesh_sizes"][-1]
            for k, (h, dev) in enumerate(zip(e["mesh_sizes"][:-1], e["deviation"][:-1])):
                label = f"h = {h:g} in" + (" (default)" if k == e["default"] else "")
                ax.semilogy(np.arange(1, len(dev) + 1), np.maximum(dev, 1e-7), lw=1.0 if k == e["default"] else 0.8,
                            color="black" if k == e["default"] else "0.6", label=label)
            ax.axhline(0.01, color="tab:red", ls="--", lw=0.7)
            ax.axhline(0.005, color="tab:orange", ls=":", lw=0.7)
            ax.axvline(e["count"] + 0.5, color="0.75", lw=0.6)
            ax.set_title(f"{e['name'].replace('_', ' ')} (finest h = {finest:g} in)", fontsize=7)
            ax.set_xlabel("mode number")
            ax.legend(loc="lower right", frameon=False, handlelength=1.5)
        for ax in axes[::cols]:
            ax.set_ylabel("|f / f_finest - 1|")
        return save(fig, stem)


def convergence_paragraph(ctx, root) -> str:
    """Mesh convergence of all the modes the study uses, from the last `snakemake verify`."""
    entries = mesh_convergence(ctx.get("fe_full"))
    if not entries:
        return ""
    rows = []
    for e in entries:
        d = e["deviation"][e["default"]]
        n = len(d)
        rows.append([s(e["name"].replace("_", " ")), s(f"{e['mesh_sizes'][e['default']]:g}"),
                     s(f"{e['mesh_sizes'][-1]:g}"), s(n), sci(max(d[:e["count"]])), sci(max(d)),
                     s(int(np.argmax(d)) + 1), s(sum(v > 0.01 for v in d))])
    out = [table(["body", "default h [in]", "finest h [in]", "modes", f"max dev., first {entries[0]['count']}",
                  "max dev., all", "worst mode", "modes > 1 %"], rows,
                 f"Mesh convergence of every mode the study uses ("
                 f"{s(ctx['dates'].get('fe_full', ''))}): the relative change |f/f_finest - 1| of each "
                 f"supported frequency from the default mesh to the finest level; the verdict "
                 f"of the check is on the first {entries[0]['count']}.", "tab-convergence", size="7pt")]
    fig = ctx.get("convergence_figure")
    if fig:
        out.append(figure(fig["pdf"], "Mesh convergence of all computed modes per body: |f/f_finest - 1| "
                          "of each mode on the coarser meshes (black: the default mesh the study uses); "
                          "dashed: 1 %, dotted: 0.5 %; the grey vertical line ends the modes of the "
                          "check's verdict.", root, label="fig-convergence"))
    return "".join(out)


def tolerance_section(ctx, root) -> str:
    """== Accuracy on request: the chart, the table and the numbers, from the tolerance bench."""
    out = ["== Accuracy on request: cost against requested tolerance\n\n"]
    tol = ctx.get("tolerance")
    if not tol:
        return out[0] + note(s(ctx["missing"].get("tolerance", "results/benchmarks/tolerance.json missing "
                                                               "(made by snakemake bench)")))
    data = tolerance_chart_data(tol, {sc["name"]: sc["rows"] for sc in ctx["scenes"]})
    sm = tolerance_summary(data)
    out.append(f"`tol-EPS` asks for the smallest pooled load-aware set whose error is at most EPS on every "
               f"gimbal rate (docs/models.md). The tolerance bench (results/benchmarks/tolerance.json, "
               f"{s(ctx['dates'].get('tolerance', ''))}) built {s(sm['built'])} of {s(sm['requests'])} "
               f"requests and measured each against the truth: {s(sm['within'])} of {s(sm['built'])} are "
               f"within the request. ")
    for method, m in sm["methods"].items():
        out.append(f"By {s(method)} ({s(', '.join(m['scenes']))}): {s(m['within'])} of {s(m['built'])}. ")
    if sm["apriori_max_ratio"] is not None:
        # one string: Typst drops a ';' that follows an expression
        per = s("; ".join(f"{k} {lo:.5g} to {hi:.5g}" for k, (lo, hi) in sm["apriori_ratio"].items()))
        worst = f"{sm['apriori_max_ratio']:.5g}"
        out.append(f"Where the frozen chain holds and chose, the measured E is at most {s(worst)} times the "
                   f"a-priori estimate (measured / estimated per scene: {per}). ")
        damped = [sc["name"] for sc in ctx["scenes"] if sc["name"] in sm["apriori_ratio"]
                  and _damping(sc) > 0 and sm["apriori_ratio"][sc["name"]][1] < 1]
        if damped:
            out.append(f"On {s(', '.join(damped))} the estimate is pessimistic: the frozen chain ignores the "
                       f"modal damping, so tol-EPS is safe there but keeps more modes than it needs. ")
    if sm["promise_checked"]:
        broken = sm["promise_broken"]
        out.append(f"Where the search ran, the frozen chain's own choice (its first probe) would have missed the "
                   f"request in {s(len(broken))} of {s(sm['promise_checked'])} cases"
                   + (" (" + s("; ").join(f"{s(sc)} EPS {_eps_label(e)}: global-{s(n)} measured {sci(E)}"
                                          for sc, e, n, E in broken[:4])
                      + (s("; ...") if len(broken) > 4 else "") + ")" if broken else "") + ". ")
    n = len(sm["comparisons"])
    if n:
        out.append(f"At equal error (both meet EPS on the scene), tol-EPS keeps fewer elastic coordinates than "
                   f"the cheapest freq-, XMX- or global-N of the study in {s(sm['fewer'])} of {s(n)} "
                   f"comparisons, as many in {s(sm['equal'])} and more in {s(sm['more'])}"
                   + (f" ({s(', '.join(sm['more_scenes']))})" if sm["more_scenes"] else "") + ". ")
    if sm["beyond_study"]:
        out.append(f"For {s(sm['beyond_study'])} requests no freq-, XMX- or global-N of the study (at most "
                   f"100 elastic coordinates) meets EPS at all; tol-EPS does, with more coordinates. ")
    out.append("Run times are medians of repeated integrations timed in the same bench run.\n\n")
    out.append(tolerance_table(data))
    fig = ctx.get("tolerance_figure")
    if fig:
        out.append(figure(fig["pdf"], "Cost against requested tolerance, per scene: elastic coordinates "
                          "kept (left) and the integration's median wall time (right) of tol-EPS (line) "
                          "against the requested EPS, beside the cheapest freq-, XMX- and global-N of the "
                          "study meeting the same EPS on every rate (markers; none where no study model "
                          "does). Scenes without a study table show tol-EPS alone.", root,
                          label="fig-tolerance"))
    return "".join(out)


def verification_section(ctx, root=None) -> str:
    out = ["= Verification and run time\n\n"]
    fe = ctx.get("fe")
    if fe:
        rows = [[s(c["name"]), sci(c["value"]), sci(c["tolerance"]), s("pass" if c["passed"] else "FAIL")]
                for c in fe.get("checks", [])]
        out.append(table(["check", "value", "tolerance", "verdict"], rows,
                         f"Finite-element checks of the main job (results/verification/fe_fast.json, "
                         f"{s(ctx['dates'].get('fe', ''))}); the convergence, solid and MPI checks "
                         f"follow.", "tab-fe", size="7.5pt"))
    else:
        out.append(note(s(ctx["missing"].get("fe", "fe_fast.json"))))
    for key, what in (("fe_full", "FE verification on fine meshes and under MPI"),
                      ("dynamics", "dynamics against the JAX oracle and the second code"),
                      ("exponential", "exponential integrator against converged references")):
        data = ctx.get(key)
        if data is None:
            out.append(f"- {s(what)}: {s(ctx['missing'].get(key, 'missing'))}.\n")
            continue
        checks = data.get("checks", [])
        n_ok = sum(1 for c in checks if c.get("passed"))
        out.append(f"- {s(what)}: {s(n_ok)} of {s(len(checks))} checks pass "
                   f"(last run {s(ctx['dates'].get(key, ''))}).\n")
        if key == "exponential":
            out.append(reference_lines(data))
        if key == "fe_full":
            out.append("\n" + convergence_paragraph(ctx, root) + "\n")
    eb = ctx.get("exponential_bench")
    if eb is None:
        out.append(f"- Run times: {s(ctx['missing'].get('exponential_bench', 'missing') + ';')} this "
                   "report quotes no single-run timing.\n")
    else:
        out.append(f"- Run times: the exponential integrator's benchmark (medians of repeated runs, "
                   f"{s(ctx['dates'].get('exponential_bench', ''))}) is in exponential.md beside "
                   f"its exponential.json.\n")
    out.append("\n")
    return "".join(out)


def reference_lines(accuracy: dict) -> str:
    """How the exponential accuracy check's references were made, and the check of the faster ones
    against DOP853 (its ``rows`` and ``anchors``), as list lines."""
    out = []
    kinds = sorted({r.get("reference_kind", "dop853 rtol 1e-10") for r in accuracy.get("rows", [])})
    worst = max((r["default"]["E_max"] for r in accuracy.get("rows", [])), default=float("nan"))
    out.append(f"  - Largest E at the default tolerance {sci(worst)} over "
               f"{s(len(accuracy.get('rows', [])))} scenes; references: {s('; '.join(kinds))}.\n")
    for a in accuracy.get("anchors", []):
        what = (f"truth by the references' order-{a['route_order']} route" if a.get("route_order")
                else "reference")
        out.append(f"  - The {s(a['scene'])} {what} ({s(a['reference'])}) against DOP853 "
                   f"({s(a['anchor'])}): E {sci(a['E_max'])}.\n")
    return "".join(out)


def provenance_section(ctx) -> str:
    v = ctx["versions"]
    rows = [[s(k), s(v[k])] for k in sorted(v)]
    return "= Provenance\n\n" + table(["package", "version"], rows, f"Built {s(ctx['date'])}.",
                                      "tab-versions", size="7.5pt")


def typst_source(ctx, root) -> str:
    """Page 1 is the decision (title, the decision tables, where reduction pays); the outline and
    the study follow from page 2."""
    an = analyse(ctx)
    head = page_setup("Elastic nested gimbals: which reduced model, at what cost",
                      f"after P. J. Balucan, S.M. thesis, MIT (2001). Built {s(ctx['date'])}, revision "
                      f"{s(ctx['versions'].get('git', 'unknown'))}", outline_depth=None)
    return (head + decision_section(ctx) + "#pagebreak()\n#outline(depth: 1)\n\n"
            + summary_section(ctx, an) + methods_section(ctx) + results_section(ctx, an, root)
            + discussion_section(ctx, an) + conclusions_section(ctx, an) + verification_section(ctx, root)
            + provenance_section(ctx))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m gimbal_reduction.results.study.study_report", description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", required=True, help="scene files, one per study scene")
    ap.add_argument("--ranking-tables", nargs="+", required=True)
    ap.add_argument("--static-tables", nargs="+", required=True)
    ap.add_argument("--findings", nargs="+", required=True)
    ap.add_argument("--figures", nargs="+", required=True, help="figure manifests (figures.json)")
    ap.add_argument("--fe", required=True, help="results/verification/fe_fast.json")
    ap.add_argument("--reduction", required=True)
    ap.add_argument("--mode-ranking", default=None,
                    help="results/tables/ranking.csv (the Table 4.1 analogue, reduction_report)")
    for key in OPTIONAL:
        ap.add_argument("--" + key.replace("_", "-"), default=None, help=f"read if present ({OPTIONAL[key]})")
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    try:
        ctx = gather(args.scenes, args.ranking_tables, args.static_tables, args.findings, args.figures,
                     args.fe, args.reduction, {k: getattr(args, k) for k in OPTIONAL},
                     mode_ranking=args.mode_ranking)
    except ValueError as exc:
        print(f"gimbal_reduction.results.study.study_report: error: {exc}", file=sys.stderr)
        return 2
    out = os.path.abspath(args.out)
    if ctx.get("tolerance"):        # the chart is drawn beside the report (as its .typ)
        try:
            ctx["tolerance_figure"] = draw_tolerance_chart(
                tolerance_chart_data(ctx["tolerance"], {sc["name"]: sc["rows"] for sc in ctx["scenes"]}),
                os.path.splitext(out)[0] + "_tolerance_cost")
        except (KeyError, TypeError, ValueError) as exc:
            ctx["missing"]["tolerance chart"] = f"not drawn ({exc.__class__.__name__}: {exc})"
    entries = mesh_convergence(ctx.get("fe_full"))
    if entries:
        try:
            ctx["convergence_figure"] = draw_convergence(entries, os.path.splitext(out)[0] + "_mesh_convergence")
        except (KeyError, TypeError, ValueError) as exc:
            ctx["missing"]["convergence chart"] = f"not drawn ({exc.__class__.__name__}: {exc})"
    paths = [os.path.dirname(out)] + [f["pdf"] for sc in ctx["scenes"] for f in sc["figures"]]
    root = os.path.commonpath(paths + [ROOT]) if paths else ROOT
    try:
        compile_pdf(typst_source(ctx, root), out, root)
    except Exception as exc:  # noqa: BLE001 - typst raises RuntimeError with the diagnostics
        print(f"gimbal_reduction.results.study.study_report: error: typst failed: {' '.join(str(exc).split())[:400]}",
              file=sys.stderr)
        return 2
    print(f"gimbal_reduction.results.study.study_report: {out} ({len(ctx['scenes'])} scenes; missing: "
          f"{', '.join(ctx['missing']) or 'none'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
