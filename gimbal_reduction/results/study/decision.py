"""The decision: for an accuracy a designer states, the cheapest model that meets it, and at what cost.

    python -m gimbal_reduction.results.study.decision --scenes thesis damped smooth long \\
        --ranking-tables results/tables/{thesis,...}/errors_ranking.csv \\
        --static-tables results/tables/{thesis,...}/errors_static.csv \\
        --truths results/study/{thesis,...}/sim/truth.h5 \\
        --truth-basis results/verification/truth_basis.json \\
        --runtimes results/benchmarks/runtime/{thesis,...}.json \\
        --out-json results/tables/decision.json --out-csv results/tables/decision.csv

Three accuracy measures, in the units a designer states them:

* ``attitude``: the stable platform's attitude error, the largest angle over the scene between the
  model's and the truth's platform frame [arcsec] (``tables.attitude_errors``);
* ``rate``: the RMS error of every gimbal rate [rad/s], the worst of the four; from eq. 3.53,
  E_n = int e_n^2 dt / int r_n^2 dt on the same grid, so RMS(e_n) = sqrt(E_n) RMS(r_n) with
  RMS(r_n) = sqrt(int r_n^2 dt / T) of the truth's rate;
* ``E``: eq. 3.53 itself, the worst of the four rates (dimensionless; sqrt(E) is the RMS error as a
  fraction of the RMS rate: E = 0.04 is an error of 20 % RMS of the rate).

The truth's resolution.  The truth (100 modes per body) is itself an approximation of the chain;
three checks bound its own error per scene and rate: the truth with one static correction mode per
body (``static-100``, the residual flexibility of the truncated modes), the truth's band with each
ring's output-interface flexibility (``cb-100``, Craig-Bampton with 100 fixed-interface modes) and
a 200-modes-per-body truth (``truth_basis.json``).  The resolution is one number per scene and
measure, the largest of the checks (per rate for E and rate; the attitude's largest angle), and it
is used everywhere:

* a requirement at or below the resolution is ``not resolvable``: no model can be shown to meet it
  by this truth (not even the truth);
* a model meets a requirement when its error *plus* the resolution is within it.  Errors against the
  chain obey the triangle inequality in RMS (rates) and in angle (attitude: the geodesic distance
  on SO(3)), so error-to-truth + truth-to-chain bounds the error to the chain:
  sqrt(E_chain) <= sqrt(E) + sqrt(E_res), RMS(e_chain) <= RMS(e) + RMS_res, angle likewise;
* two errors on one rate differ resolvably only when their RMS values differ by more than the
  truth's RMS error (``resolvable``); otherwise every verdict, "best" or table cell built on that
  difference says ``not resolvable``.

Cheapest = fewest kept coordinates (4 joint angles + the elastic coordinates: half the state
dimension of the model's first-order form, the size a control design works with), ties broken by
the smaller error.  The truth is always a candidate (its error bound is the resolution), so a
resolvable requirement always has an answer.  Run and set-up times come from the timing job
(``gimbal_reduction.results.bench.runtime``: medians of repeated runs in one process), never from
the study's single runs.

Outputs: ``decision.json`` (per scene: resolution, requirement rows with the chosen model, its
error, coordinates and times, the truth's times; the pure functions below) and a CSV of the same
rows (``CSV_COLUMNS``).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
from dataclasses import dataclass

import numpy as np

from gimbal_reduction.results.study.cases import CAMPS, TRUTH, TRUTH_CHECK, TRUTH_INTERFACE

# the rows that judge the truth (its own error), never candidates: the truth + residual
# flexibility, and the truth's band + each ring's interface flexibility (Craig-Bampton)
REFEREE_MODELS = (TRUTH_CHECK, TRUTH_INTERFACE)
from gimbal_reduction.results.study.tables import RATE_COLUMNS, read_table
from gimbal_reduction.solver.dynamics.error_measure import ErrorsInputError, error_measure
from gimbal_reduction.solver.dynamics.simfile import read_sim
from gimbal_reduction.workflow import cli
from gimbal_reduction.workflow.provenance import csv_text, provenance, write_json, write_text

RATES = ("outer", "middle", "inner", "platform")     # the order of RATE_COLUMNS
N_JOINTS = 4                      # the four joint angles every model keeps (gamma_1..gamma_4)
NOT_RESOLVABLE = "not resolvable"
MEASURES = ("attitude", "rate", "E")
MEASURE_UNITS = {"attitude": "arcsec", "rate": "rad/s RMS", "E": "1"}
MEASURE_LABELS = {"attitude": "platform attitude error (largest angle)",
                  "rate": "gimbal-rate error (RMS, worst rate)",
                  "E": "E of eq. 3.53 (worst rate)"}
CSV_COLUMNS = ("scene", "measure", "unit", "requirement", "status", "model", "coordinates",
               "state_dimension", "error", "error_bound", "resolution", "run_ms", "run_ms_spread",
               "setup_ms", "truth_run_ms", "truth_setup_ms", "speedup")


@dataclass(frozen=True)
class Requirements:
    """The accuracy levels the decision table answers, per measure (each a tuple, ascending or
    not): attitude [arcsec], rate [rad/s RMS], E [1].  Decades from what a platform IMU designer
    quotes (attitude: 10 arcsec, a coarse pointing budget, to 0.1 arcsec, a navigation-grade
    platform's stability) down to where the truth stops resolving (1e-3 arcsec on the study's
    scenes); rates from 1e-2 rad/s to 1e-6 rad/s RMS (0.2 arcsec/s); E across the thesis's tables
    (1e-1 to 1e-4)."""
    attitude: tuple = (10.0, 1.0, 0.1, 1e-2, 1e-3)
    rate: tuple = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6)
    E: tuple = (1e-1, 1e-2, 1e-3, 1e-4)

    def levels(self, measure):
        return tuple(getattr(self, measure))


# ---------------------------------------------------------------- the truth's resolution (pure)
def rate_rms(t, gamma_dot) -> np.ndarray:
    """(4,) RMS over the scene of each gimbal rate [rad/s]: sqrt(int r^2 dt / T), trapezoid rule
    on the output grid (the integral of eq. 3.53's denominator).  t (T,) [s], gamma_dot (T, 4)."""
    t = np.asarray(t, float)
    r = np.asarray(gamma_dot, float)
    return np.sqrt(np.trapezoid(r ** 2, t, axis=0) / (t[-1] - t[0]))


def resolution(rows, basis_scene, truth_rms) -> dict:
    """The truth's own error on one scene, the largest of its checks, per measure.

    rows: the scene's table rows (``tables.read_table``; the ``static-100`` and ``cb-100`` rows are
    checks);
    basis_scene: ``truth_basis.json``'s entry of the scene ({E (4,), attitude_max_arcsec}) or None;
    truth_rms (4,) [rad/s].  Returns {E_per_rate (4,), rate_per_rate (4,) [rad/s], attitude
    [arcsec], E, rate (worst rate), sources: the checks used}.  A measure no check gives is NaN
    (then nothing on that measure is judged: ``resolvable`` is False)."""
    E = np.full(4, np.nan)
    att = float("nan")
    sources = []
    checks = [(r["model"], [r[c] for c in RATE_COLUMNS], r.get("attitude_max_arcsec"))
              for model in REFEREE_MODELS for r in rows if r["model"] == model]
    if basis_scene:
        checks.append(("freq-200", basis_scene.get("E"), basis_scene.get("attitude_max_arcsec")))
    for name, e, a in checks:
        if e is None:
            continue
        sources.append(name)
        E = np.fmax(E, np.asarray(e, float))
        if a is not None and np.isfinite(a):
            att = a if not np.isfinite(att) else max(att, float(a))
    rate = np.sqrt(E) * np.asarray(truth_rms, float)
    return {"E_per_rate": E.tolist(), "rate_per_rate": rate.tolist(), "attitude": att,
            "E": float(np.max(E)), "rate": float(np.max(rate)), "sources": sources}


def resolvable(E_a, E_b, E_res) -> bool:
    """Whether two errors E_a, E_b of one rate differ by more than the truth can tell: their RMS
    values (sqrt(E), as a fraction of the RMS rate) differ by more than the truth's own
    (sqrt(E_res)).  False when E_res is unknown (NaN) or any value is not finite."""
    vals = (E_a, E_b, E_res)
    if not all(v is not None and np.isfinite(v) for v in vals):
        return False
    return abs(math.sqrt(E_a) - math.sqrt(E_b)) > math.sqrt(E_res)


def cell(E, E_res) -> str | float:
    """An error table cell: E itself, or ``NOT_RESOLVABLE`` when E is within the truth's own
    error of zero (the model cannot be told from the truth on that rate)."""
    return E if resolvable(E, 0.0, E_res) else NOT_RESOLVABLE


# ---------------------------------------------------------------- model errors (pure)
def model_errors(row, truth_rms) -> dict:
    """{attitude [arcsec], rate (worst) [rad/s RMS], E (worst), rate_per_rate (4,), E_per_rate
    (4,)} of one table row; RMS(e_n) = sqrt(E_n) RMS(r_n) (module doc)."""
    E = np.array([row[c] for c in RATE_COLUMNS], float)
    rate = np.sqrt(E) * np.asarray(truth_rms, float)
    return {"attitude": float(row.get("attitude_max_arcsec", np.nan)), "rate": float(np.max(rate)),
            "E": float(np.max(E)), "rate_per_rate": rate.tolist(), "E_per_rate": E.tolist()}


def error_bound(measure, err: dict, res: dict) -> float:
    """The model's error against the chain, bounded by the triangle inequality (module doc):
    per rate for E and rate (the worst rate's bound), on the angle for the attitude."""
    if measure == "attitude":
        return err["attitude"] + res["attitude"]
    if measure == "rate":
        return float(np.max(np.asarray(err["rate_per_rate"]) + np.asarray(res["rate_per_rate"])))
    return float(np.max((np.sqrt(err["E_per_rate"]) + np.sqrt(res["E_per_rate"])) ** 2))


def coordinates(row) -> int | None:
    """Kept coordinates of a model: the 4 joint angles and its elastic coordinates."""
    return None if row.get("n_elastic") is None else N_JOINTS + int(row["n_elastic"])


def candidates(rows) -> list[dict]:
    """The rows a decision chooses from: every model with finite errors but the truth's checks
    (``REFEREE_MODELS``, larger than the truth), the truth last."""
    out = [r for r in rows if r["model"] not in REFEREE_MODELS and coordinates(r) is not None
           and all(np.isfinite(r[c]) for c in RATE_COLUMNS)]
    return sorted(out, key=lambda r: (r["model"] == TRUTH, coordinates(r), r["model"]))


def choose(measure, requirement, rows, truth_rms, res) -> dict:
    """The cheapest model meeting one requirement on one scene.

    Returns {status, model, coordinates, error, error_bound}: status ``NOT_RESOLVABLE`` when the
    requirement is at or below the truth's resolution of the measure (then no model), else
    ``met`` with the fewest coordinates whose error bound is within the requirement (ties: the
    smaller error; the truth's bound is the resolution, so it is the last resort)."""
    r_res = res[measure]
    out = {"measure": measure, "requirement": requirement, "resolution": r_res}
    if not (np.isfinite(r_res) and requirement > r_res):
        return {**out, "status": NOT_RESOLVABLE, "model": None, "coordinates": None,
                "error": None, "error_bound": None}
    ok = []
    for r in candidates(rows):
        err = model_errors(r, truth_rms)
        bound = error_bound(measure, err, res) if r["model"] != TRUTH else r_res
        if np.isfinite(bound) and bound <= requirement:
            ok.append((coordinates(r), bound, r, err))
    if not ok:      # the truth's bound is the resolution: only without a truth row
        return {**out, "status": "no model", "model": None, "coordinates": None, "error": None,
                "error_bound": None}
    n, bound, r, err = min(ok, key=lambda x: (x[0], x[1]))
    return {**out, "status": "met", "model": r["model"], "coordinates": n,
            "error": err[measure] if r["model"] != TRUTH else 0.0, "error_bound": bound}


def choose_by_camp(measure, requirement, rows, truth_rms, res) -> dict:
    """{camp: the cheapest model of that camp's groups meeting the requirement} (``cases.CAMPS``:
    the thesis's selections, the project's, the field's defaults), each as ``choose`` gives it
    over that camp's rows alone: ``met`` with its model and coordinates, ``no model`` when none of
    the camp's study counts meets it, ``NOT_RESOLVABLE`` at or below the truth's own error."""
    return {camp: choose(measure, requirement, [r for r in rows if r.get("group") in groups],
                         truth_rms, res)
            for camp, groups in CAMPS.items()}


def cheapest_camps(by_camp) -> list[str]:
    """The camps whose answer has the fewest coordinates among those met (all that tie), or []."""
    met = {c: v["coordinates"] for c, v in by_camp.items() if v["status"] == "met"}
    if not met:
        return []
    n = min(met.values())
    return [c for c, k in met.items() if k == n]


def best(rows, rate_index, E_res) -> dict:
    """The most accurate model on one rate (not the truth nor its check), and whether that is
    resolvable: it is when no other model's error is within the truth's resolution of it
    (``resolvable``).  Returns {model, E, status: ``resolved`` or ``NOT_RESOLVABLE``, ties: the
    models it cannot be told from}."""
    col = RATE_COLUMNS[rate_index]
    pool = [r for r in candidates(rows) if r["model"] != TRUTH]
    if not pool:
        return {"model": None, "E": None, "status": "no model", "ties": []}
    pool.sort(key=lambda r: r[col])
    b = pool[0]
    ties = [r["model"] for r in pool[1:] if not resolvable(b[col], r[col], E_res)]
    return {"model": b["model"], "E": float(b[col]),
            "status": NOT_RESOLVABLE if ties else "resolved", "ties": ties}


def rate_resolved(rows, rate_index, E_res) -> bool:
    """Whether the truth resolves the models of a scene on one rate at all: the rigid model (no
    elastic coordinate, the largest error a study case has by construction of the question) is
    resolvably worse than a perfect model (E = 0).  When it is not, every model of the scene is
    within the truth's error of every other on that rate, and every finding's verdict there is
    ``NOT_RESOLVABLE``."""
    rigid = next((r for r in rows if r["model"] == "rigid"), None)
    if rigid is None:
        return False
    return resolvable(rigid[RATE_COLUMNS[rate_index]], 0.0, E_res)


def resolve_findings(findings, rows, res) -> list[dict]:
    """The findings of one scene with each per-rate verdict replaced by ``NOT_RESOLVABLE`` on
    the rates the truth does not resolve (``rate_resolved``), and the overall verdict recomputed
    over the rates left (all resolvable rates reproduced -> reproduced, none -> not reproduced,
    else partly; no resolvable rate -> ``NOT_RESOLVABLE``).  A finding about the rankings alone
    (no per-rate errors: finding 2) is kept as is.  "inconclusive" verdicts read "not evaluated"
    (the findings stage's own word for a test whose premise fails)."""
    ok = {rate: rate_resolved(rows, k, res["E_per_rate"][k]) for k, rate in enumerate(RATES)}
    out = []
    for f in findings:
        per = dict(f.get("verdict_per_rate") or {})
        why = f.get("reason_per_rate") or dict.fromkeys(per, f.get("reason", ""))
        per = {r: ("not evaluated" if "inconclusive" in str(why.get(r, "")) else v) for r, v in per.items()}
        if f.get("uses_errors", True) and f.get("finding") != 2:
            per = {r: (v if ok.get(r, True) or v == "not evaluated" else NOT_RESOLVABLE)
                   for r, v in per.items()}
        judged = [v for v in per.values() if v not in ("not evaluated", NOT_RESOLVABLE)]
        if not judged:
            verdict = NOT_RESOLVABLE if NOT_RESOLVABLE in per.values() else "not evaluated"
        elif all(v == "reproduced" for v in judged):
            verdict = "reproduced"
        elif all(v == "not reproduced" for v in judged):
            verdict = "not reproduced"
        else:
            verdict = "partly reproduced"
        out.append({**f, "verdict_per_rate": per, "verdict": verdict,
                    "verdict_before": f.get("verdict")})
    return out


# ---------------------------------------------------------------- the decision (pure)
def decide_scene(name, rows, truth_rms, basis_scene, runtime, requirements=Requirements()) -> dict:
    """The decision of one scene: resolution, one row per measure x requirement (``choose``)
    with its run and set-up times from ``runtime`` (the timing job's JSON: {models: {name:
    {run_ms, run_ms_spread, setup_ms, runs, n_modes}}}), the truth's times, and the best model per
    rate (``best``)."""
    res = resolution(rows, basis_scene, truth_rms)
    timed = (runtime or {}).get("models", {})
    truth_t = timed.get(TRUTH, {})
    out_rows = []
    for measure in MEASURES:
        for level in requirements.levels(measure):
            c = choose(measure, level, rows, truth_rms, res)
            camps = choose_by_camp(measure, level, rows, truth_rms, res)
            t = timed.get(c["model"], {}) if c["model"] else {}
            run, truth_run = t.get("run_ms"), truth_t.get("run_ms")
            out_rows.append({"scene": name, **c, "unit": MEASURE_UNITS[measure],
                             "state_dimension": None if c["coordinates"] is None else 2 * c["coordinates"],
                             "run_ms": run, "run_ms_spread": t.get("run_ms_spread"),
                             "setup_ms": t.get("setup_ms"), "n_modes": t.get("n_modes"),
                             "truth_run_ms": truth_run, "truth_setup_ms": truth_t.get("setup_ms"),
                             "speedup": (truth_run / run) if run and truth_run else None,
                             "by_camp": {k: {"status": v["status"], "model": v["model"],
                                             "coordinates": v["coordinates"]} for k, v in camps.items()},
                             "cheapest_camps": cheapest_camps(camps)})
    truth_row = next((r for r in rows if r["model"] == TRUTH), None)
    return {"scene": name, "resolution": res, "truth_rate_rms": [float(x) for x in truth_rms],
            "truth_coordinates": coordinates(truth_row) if truth_row else None,
            "rows": out_rows,
            "best": [best(rows, k, res["E_per_rate"][k]) for k in range(4)],
            "rate_resolved": [rate_resolved(rows, k, res["E_per_rate"][k]) for k in range(4)],
            "runtime": {"truth": truth_t, "rigid": timed.get("rigid", {}), "runs": (runtime or {}).get("repeats"),
                        "duration_s": (runtime or {}).get("duration_s"),
                        "samples": (runtime or {}).get("samples"),
                        "load_average": (runtime or {}).get("load_average"),
                        "cpu_count": (runtime or {}).get("cpu_count"),
                        # a fresh process's first simulation against its median (bench.runtime.first_call)
                        "first_call": next((dict(t["first_call"], model=m) for m, t in
                                            ((runtime or {}).get("models") or {}).items()
                                            if isinstance(t, dict) and t.get("first_call")), None)}}


def chosen_models(rows, truth_rms, basis_scene, requirements=Requirements()) -> list[str]:
    """The models a scene's decision names (the timing job times these, the rigid model and the
    truth)."""
    res = resolution(rows, basis_scene, truth_rms)
    names = {choose(m, lv, rows, truth_rms, res)["model"] for m in MEASURES
             for lv in requirements.levels(m)}
    return sorted(n for n in names | {"rigid", TRUTH} if n)


def sampling_check(truth, cases) -> dict:
    """How much E depends on the output grid: E of every case on every second sample against E on
    the full grid (``error_measure``), the largest relative change over cases and rates where E
    is resolvable at all (E > 1e-12).  truth, cases: simulation files (``simfile.read_sim``).
    Returns {max_relative_change, model, rate, samples, half_samples}."""
    t, r = truth["t"], truth["gamma_dot"]
    worst = (0.0, None, None)
    for c in cases:
        full = error_measure(t, r, c["gamma_dot"])
        half = error_measure(t[::2], r[::2], c["gamma_dot"][::2])
        for k, (a, b) in enumerate(zip(full, half)):
            if np.isfinite(a) and np.isfinite(b) and a > 1e-12:
                change = abs(b - a) / a
                if change > worst[0]:
                    worst = (float(change), c["model"], RATES[k])
    return {"max_relative_change": worst[0], "model": worst[1], "rate": worst[2],
            "samples": int(t.size), "half_samples": int(t[::2].size)}


# ---------------------------------------------------------------- files
def read_scene(ranking, static, truth):
    """(rows of both tables, truth RMS rates (4,) [rad/s]) of one scene."""
    rows = read_table(ranking) + read_table(static)
    sim = read_sim(truth)
    return rows, rate_rms(sim["t"], sim["gamma_dot"])


def read_basis(path) -> dict:
    """truth_basis.json's {scene: {E, attitude_max_arcsec, ...}}, {} without the file."""
    if not path or not os.path.exists(path):
        return {}
    with open(path) as f:
        return json.load(f).get("scenes", {})


def main(argv=None) -> int:
    ap = cli.OneLineParser(prog="python -m gimbal_reduction.results.study.decision",
                           description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", required=True, help="scene names, in order")
    ap.add_argument("--ranking-tables", nargs="+", required=True)
    ap.add_argument("--static-tables", nargs="+", required=True)
    ap.add_argument("--truths", nargs="+", required=True, help="the truth's simulation file per scene")
    ap.add_argument("--truth-basis", help="results/verification/truth_basis.json")
    ap.add_argument("--runtimes", nargs="+", required=True, help="the timing job's JSON per scene")
    ap.add_argument("--sims", nargs="*", default=[],
                    help="the study's simulation files (any scenes): E's dependence on the output grid")
    ap.add_argument("--out-json", required=True)
    ap.add_argument("--out-csv", required=True)
    args = ap.parse_args(argv)
    n = len(args.scenes)
    for what in ("ranking_tables", "static_tables", "truths", "runtimes"):
        if len(getattr(args, what)) != n:
            print(f"decision: {len(getattr(args, what))} --{what.replace('_', '-')} for {n} scenes",
                  file=sys.stderr)
            return 2
    basis = read_basis(args.truth_basis)
    scenes = []
    try:
        for k, name in enumerate(args.scenes):
            rows, rms = read_scene(args.ranking_tables[k], args.static_tables[k], args.truths[k])
            with open(args.runtimes[k]) as f:
                runtime = json.load(f)
            scenes.append(decide_scene(name, rows, rms, basis.get(name), runtime))
        sims = [read_sim(p) for p in args.sims]
        for sc in scenes:
            mine = [x for x in sims if x["attrs"].get("scene") == sc["scene"]]
            truth = next((x for x in mine if x["model"] == TRUTH), None)
            if truth is not None:
                sc["sampling"] = sampling_check(truth, [x for x in mine if x["model"] != TRUTH])
    except (ErrorsInputError, OSError, ValueError) as exc:
        print(f"decision: {exc}", file=sys.stderr)
        return 2
    record = provenance(sources=[*args.ranking_tables, *args.static_tables, *args.truths])
    write_json(args.out_json, {"measures": {m: {"unit": MEASURE_UNITS[m], "label": MEASURE_LABELS[m]}
                                            for m in MEASURES},
                               "n_joints": N_JOINTS, "scenes": scenes}, record)
    write_text(args.out_csv, csv_text([r for sc in scenes for r in sc["rows"]], CSV_COLUMNS, 6), record)
    print(f"decision: {n} scenes -> {args.out_json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
