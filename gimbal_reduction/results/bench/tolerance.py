"""Accuracy on request, checked: tol-EPS models against the truth, scene by scene.

    OMP_NUM_THREADS=1 python -m gimbal_reduction.results.bench.tolerance \\
        --scenes config/scenes/{thesis,damped,smooth,long,spin}.yaml --eps 1e-2 1e-3 ... 1e-8 \\
        [--modes-dir results/modes --reduction-dir results/reduction --tables-dir results/tables] \\
        [--repeats 5 --budget 60] --out-csv results/benchmarks/tolerance.csv \\
        --out-json results/benchmarks/tolerance.json --figure results/figures/bench/tolerance.png

Per scene (one process, so the runs share the compiled kernels and the verified search's
simulations; ``gimbal_reduction.results.study.run_scene`` does the same):

1. the truth (100 modes per body) is reduced and integrated through the scene with the default
   integrator (``gimbal_reduction.solver.dynamics.simulate.run_scene``: the modal exponential integrator at its
   default tolerance); its gimbal rates are the reference;
2. for every EPS the model ``tol-EPS`` is reduced through the stage the workflow runs
   (``gimbal_reduction.reduction.models.main``, in process): the a-priori choice of the frozen linear chain, or,
   where that chain does not hold (``long``, ``spin``), the verified search
   (``gimbal_reduction.reduction.verified_search``, its truth the run of step 1); then integrated the
   same way, and its error measured:

       E_n = int (x_n - r_n)^2 dt / int r_n^2 dt   (eq. 3.53, n = the four gimbal rates),
       within the request  <=>  max_n E_n <= EPS ;

3. with the scene's study error table (``--tables-dir``/{scene}/errors_ranking.csv, if present),
   the cheapest freq-, xmx- and global-N of the study meeting each EPS
   (``gimbal_reduction.results.bench.equal_error``) are reduced, timed and measured in the same run, so their run
   times and tol-EPS's compare at equal error.

Times: ``run_time_s`` is the integration's wall time (``integrators.Run.wall_time``), the median of
``--repeats`` runs (a model whose runs would not fit in ``--budget`` seconds timed over a prefix of
the scene and scaled by its steps, ``gimbal_reduction.results.bench.timing``: ``time_basis``); with
``--untimed`` one run (beside other jobs), which ``--times-from`` times alone (the truth of a
scene of ``--truth-times SCENE=JSON`` not again: its time is the median of the runtime benchmark's
whole runs of it, timed alone); after one untimed run of the rigid model per scene that loads the compiled kernels;
with ``--truths SCENE=FILE`` (``--untimed`` only) the truth's rates and time are read from the
study's run of the scene (``file_run``: the same model, integrator and tolerance), not integrated;
``selection_time_s`` is the reduction stage's wall time of one run (for a verified search it
includes the candidates' simulations, which the later EPS of a scene partly reuse:
``search_cost_s`` is the search's cost on its own, the truth's run plus every probe's).  One row
per (scene, EPS): the kept coordinates, how they were chosen, the a-priori estimate (flagged
where the frozen chain does not hold), the verified search's measured E, the measured E of this
run, what the frozen chain alone would have chosen (``apriori_N``) with that set's measured E
(where the search simulated it: its first probe), and the times.  A refused request is a row with its one-line reason and no numbers.
"""
from __future__ import annotations

import os

# One BLAS thread, as in the simulation rules (set before numpy is imported).
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import functools  # noqa: E402
import io  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402

import h5py  # noqa: E402
import numpy as np  # noqa: E402

from gimbal_reduction.reduction import models as reduction_models  # noqa: E402
from gimbal_reduction.reduction import verified_search  # noqa: E402
from gimbal_reduction.results.bench.equal_error import FAMILIES, cheapest_within, max_error  # noqa: E402
from gimbal_reduction.results.bench import timing  # noqa: E402
from gimbal_reduction.results.study.figures import STYLE, pyplot, save  # noqa: E402
from gimbal_reduction.results.study.tables import read_table  # noqa: E402
from gimbal_reduction.solver.dynamics import chainfile, exponential, integrators, scenes, simfile, simulate  # noqa: E402
from gimbal_reduction.solver.dynamics.error_measure import error_measure  # noqa: E402
from gimbal_reduction.workflow.provenance import csv_text, provenance, write_json, write_text  # noqa: E402

SCENES = ("thesis", "damped", "smooth", "long", "spin")
EPS = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)
COLUMNS = ("scene", "eps", "model", "method", "n_kept", "equivalent_model", "estimated_E_max",
           "frozen_chain_valid", "verified_E_max", "measured_E_max", "within_request",
           "measured_over_estimated", "apriori_N", "apriori_measured_E_max", "apriori_within",
           "selection_time_s", "search_probes", "search_cost_s", "run_time_s", "runs",
           "truth_run_time_s", "status")
COMPARISON_COLUMNS = ("scene", "eps", "family", "model", "n_elastic", "table_E_max", "measured_E_max",
                      "run_time_s", "runs", "tol_n_kept", "tol_run_time_s", "time_ratio")


def _stage(fn, args):
    """Run one stage in process: (status, its stderr lines)."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = fn(args)
    return rc, [line.strip() for line in err.getvalue().splitlines() if line.strip()]


def reduce(model, scene_file, bodies, reductions, load_ranking, tmp, runs=None):
    """(status, stderr lines, model file, its attributes, wall time [s]) of the reduction stage;
    runs: the verified search's ``verified_search.Runs`` shared by the scene's requests."""
    path = os.path.join(tmp, f"{model}.h5")
    t0 = time.perf_counter()
    rc, lines = _stage(functools.partial(reduction_models.main, runs=runs),
                       ["--model", model, "--scene", scene_file, "--bodies", *bodies,
                        "--reductions", *reductions, "--load-ranking", load_ranking, "--out", path])
    wall = time.perf_counter() - t0
    if rc:
        return rc, lines, None, {}, wall
    with h5py.File(path, "r") as f:
        attrs = dict(f.attrs)
    return 0, lines, path, attrs, wall


def timed_run(model_file, scene, repeats, budget_s, frames=False):
    """One model file through the scene: {t (T,) [s], rates (T, 4) [rad/s], run_time_s (median
    integration wall time), runs, steps, time_basis}: ``timing.median_timing`` after one run that
    gives the rates (whole runs within ``budget_s`` seconds, else a prefix scaled by the steps);
    repeats 0: that one run's time (``--untimed``); frames: also the platform's frames (T, 3, 3)."""
    chain, _ = chainfile.read_chain(model_file, scene.damping_ratio)
    prob = simulate.scene_problem(chain, scene)
    first, _ = simulate.run_scene(chain, scene, problem=prob)
    out = {"t": np.asarray(first.t, float), "rates": np.asarray(first.yd[:, :4], float),
           "run_time_s": first.wall_time, "runs": 1, "steps": int(first.steps),
           "time_basis": "one run, not timed alone"}
    if frames:
        out["frames"] = simulate.platform_attitude(chain, first)
    if repeats > 0:
        out.update(_median(prob, scene, first.wall_time, first.steps, repeats, budget_s))
    return out


def file_run(path, scene, model_file, reference="truth"):
    """``timed_run``'s record of the reference from a simulation file the workflow made of it on
    ``scene`` (``--truths``: the study's results/study/{scene}/sim/truth.h5), its time the file's
    integration time (one run, not timed alone); ValueError (one line) unless the file is the same
    scene and model (``model_file``'s config hash) run with the default integrator at the scene's
    tolerance."""
    with h5py.File(model_file, "r") as f:
        model_hash = str(f.attrs.get("config_hash"))
    with h5py.File(path, "r") as f:
        a = dict(f.attrs)
        t, rates = np.asarray(f["t"][()], float), np.asarray(f["gamma_dot"][()][:, :4], float)
        frames = np.asarray(f["platform_attitude"][()], float) if "platform_attitude" in f else None
    options = simulate.scene_options(scene, simulate.DEFAULT_INTEGRATOR, None, {})
    want = {"scene": scene.name, "model": reference, "model_config_hash": model_hash,
            "integrator": simulate.DEFAULT_INTEGRATOR}
    wrong = simfile.mismatches(a, want)
    if simulate.DEFAULT_INTEGRATOR == "exponential":
        tol = float(options.get("tol", exponential.DEFAULTS.tol))
        wrong.update(simfile.mismatches(a, {"stat_exponential_tol": tol}, {"stat_exponential_tol": 1e-9}))
    if len(t) != int(round(scene.duration / scene.output_interval)) + 1:
        wrong["outputs"] = len(t)
    if wrong:
        raise ValueError(f"--truths {path} is not the {reference} of scene {scene.name} as this bench "
                         f"runs it ({want}): {wrong}")
    return {"t": t, "rates": rates, "frames": frames, "run_time_s": float(a["integration_time_s"]), "runs": 1,
            "steps": int(a["steps"]), "time_basis": "one run, not timed alone (the study's file)",
            "run_file": path}


def _median(prob, scene, whole_s, whole_steps, repeats, budget_s):
    """{run_time_s, runs, time_basis} of a problem on ``scene`` (``timing.median_timing``)."""
    options = simulate.scene_options(scene, simulate.DEFAULT_INTEGRATOR, None, {})
    run = lambda d: integrators.integrate(prob, d, scene.output_interval,
                                          method=simulate.DEFAULT_INTEGRATOR, **options)
    t = timing.median_timing(run, scene.duration, scene.output_interval, whole_s, whole_steps,
                             repeats, budget_s, scalable=simulate.DEFAULT_INTEGRATOR != "exponential")
    return {"run_time_s": t["wall_time_s"], "runs": t["runs"], "time_basis": t["time_basis"]}


def runtime_truth_time(path, scene, model_file):
    """{run_time_s, runs, time_basis} of the reference model (the truth) on ``scene`` from the
    runtime benchmark's JSON at ``path`` (``gimbal_reduction.results.bench.runtime``: the median
    of its whole runs of the truth, timed alone, Run.wall_time as here).  ValueError (one line)
    unless that JSON timed this scene with the default integrator and a truth of the same modes
    as ``model_file``."""
    import json
    with open(path) as fh:
        data = json.load(fh)
    chain, _ = chainfile.read_chain(model_file, scene.damping_ratio)
    truth = (data.get("models") or {}).get("truth") or {}
    got = {"scene": data.get("scene"), "integrator": data.get("integrator"),
           "n_modes": [int(n) for n in truth.get("n_modes") or ()]}
    want = {"scene": scene.name, "integrator": simulate.DEFAULT_INTEGRATOR, "n_modes": [int(n) for n in chain.n_modes]}
    if got != want or not truth.get("run_ms_all"):
        raise ValueError(f"--truth-times {path} did not time the truth of {model_file} on {scene.name} "
                         f"with {simulate.DEFAULT_INTEGRATOR} ({got}, wanted {want})")
    runs = np.asarray(truth["run_ms_all"], float) / 1e3
    return {"run_time_s": float(np.median(runs)), "runs": int(runs.size),
            "time_basis": f"measured: the runtime benchmark's whole runs ({path})"}


def retime(summary, scene_files, models_dir, repeats, budget_s, log=print, truth_times=None):
    """``--times-from``: the rows and comparisons of an ``--untimed`` run (its JSON, changed in
    place), each model timed in this process from its file in ``models_dir``/{scene}/{model}.h5
    (the untimed run's ``--keep-models``); E, choices and searches are the untimed run's.
    truth_times: {scene: runtime benchmark JSON}: that scene's truth is not timed again, its time
    is the runtime benchmark's median (``runtime_truth_time``)."""
    for scene_file in scene_files:
        scene = scenes.load_scene(scene_file)
        folder = os.path.join(models_dir, scene.name)
        timed = {}

        def time_model(model, whole_s, steps):
            if model not in timed:
                chain, _ = chainfile.read_chain(os.path.join(folder, f"{model}.h5"), scene.damping_ratio)
                prob = simulate.scene_problem(chain, scene)
                integrators.integrate(prob, 2 * scene.output_interval, scene.output_interval,
                                      method=simulate.DEFAULT_INTEGRATOR)          # warm-up
                timed[model] = _median(prob, scene, whole_s, steps, repeats, budget_s)
                log(f"tolerance: {scene.name}: {model}: {timed[model]['run_time_s']:.3g} s "
                    f"({timed[model]['time_basis']})")
            return timed[model]
        truth = summary["truths"][scene.name]
        if scene.name in (truth_times or {}) and truth["model"] == "truth":
            truth.update(runtime_truth_time(truth_times[scene.name], scene,
                                            os.path.join(folder, f"{truth['model']}.h5")))
            log(f"tolerance: {scene.name}: truth: {truth['run_time_s']:.3g} s ({truth['time_basis']})")
        else:
            truth.update(time_model(truth["model"], truth["run_time_s"], truth["steps"]))
        tol = {}
        for r in summary["rows"]:
            if r["scene"] == scene.name:
                r["truth_run_time_s"] = truth["run_time_s"]
                if r.get("status") == "ok":
                    r.update(time_model(r["model"], r["run_time_s"], r["steps"]))
                    tol[r["eps"]] = r
        for c in summary["comparisons"]:
            if c["scene"] == scene.name and c.get("model"):
                c.update(time_model(c["model"], c["run_time_s"], c["steps"]))
                if c["eps"] in tol:
                    c["tol_run_time_s"] = tol[c["eps"]]["run_time_s"]
                    c["time_ratio"] = tol[c["eps"]]["run_time_s"] / c["run_time_s"]
    return summary


def _float(attrs, key):
    return float(attrs[key]) if key in attrs else float("nan")


def tol_row(scene, eps, attrs, run, truth, selection_time):
    """The bench row of one tol-EPS request that was built (the model file's ``tol_*``
    attributes, this run's measurement)."""
    E = np.asarray(error_measure(truth["t"], truth["rates"], run["rates"]), float)
    meas, est = float(np.max(E)), _float(attrs, "tol_estimate_max")
    probe_s = np.asarray(attrs.get("tol_search_probe_s", []), float)
    verified = attrs.get("tol_method") == reduction_models.TOL_VERIFIED
    # what the frozen chain alone would have promised: its own choice (the search's first guess)
    # and that set's measured E (the search simulated it first), or this model where it chose
    probes = dict(zip(np.asarray(attrs.get("tol_search_N", []), int).tolist(),
                      np.asarray(attrs.get("tol_search_E_max", []), float).tolist()))
    guess = int(attrs.get("tol_search_guess", -1)) if verified else int(attrs["tol_N"])
    guess_E = probes.get(guess, float("nan")) if verified else meas
    return {"scene": scene, "eps": eps, "model": f"tol-{eps:g}", "method": str(attrs.get("tol_method", "")),
            "n_kept": int(attrs["tol_coordinates"]), "equivalent_model": str(attrs["tol_equivalent_model"]),
            "estimated_E_max": est, "frozen_chain_valid": bool(int(attrs.get("tol_frozen_chain_valid", 1))),
            "verified_E_max": _float(attrs, "tol_measured_max"), "measured_E_max": meas,
            "within_request": bool(meas <= eps),
            "measured_over_estimated": meas / est if est > 0 else float("nan"),
            "apriori_N": guess if guess >= 0 else "", "apriori_measured_E_max": guess_E,
            "apriori_within": bool(guess_E <= eps) if np.isfinite(guess_E) else "",
            "selection_time_s": selection_time,
            "search_probes": int(len(attrs.get("tol_search_N", [])) - 1) if verified else 0,
            "search_cost_s": float(_float(attrs, "tol_search_truth_time_s") + np.nansum(probe_s))
            if verified else float("nan"),
            "run_time_s": run["run_time_s"], "runs": run["runs"], "truth_run_time_s": truth["run_time_s"],
            "steps": run["steps"], "time_basis": run["time_basis"],
            "measured_E_per_rate": E.tolist(),
            "estimated_E_per_rate": np.asarray(attrs.get("tol_estimate", np.full(4, np.nan)), float).tolist(),
            "frozen_chain_reason": str(attrs.get("tol_frozen_chain_reason", "")), "status": "ok"}


def bench_scene(scene_file, eps_list, bodies, reductions, load_ranking, table=None, repeats=5,
                budget_s=60.0, reference="truth", log=print, keep_dir=None, truth_file=None):
    """(tol rows, comparison rows, the reference's {model, run_time_s, runs, steps}) of one
    scene (module docstring); reference: the model every error is measured against (the truth;
    a test's synthetic bodies: global-Q); keep_dir: the model files are kept there (else in a
    temporary folder); truth_file: the reference's run is read from it (``file_run``), not integrated."""
    scene = scenes.load_scene(scene_file)
    name = scene.name
    rows, comparisons = [], []
    with (contextlib.nullcontext(keep_dir) if keep_dir
          else tempfile.TemporaryDirectory(prefix="tolerance_")) as tmp:
        os.makedirs(tmp, exist_ok=True)
        rc, lines, path, _, _ = reduce("rigid", scene_file, bodies, reductions, load_ranking, tmp)
        if rc:
            raise RuntimeError(f"rigid on {name} failed: {lines[-1] if lines else rc}")
        simulate.run_scene(chainfile.read_chain(path, scene.damping_ratio)[0], scene)   # warm-up
        rc, lines, path, _, _ = reduce(reference, scene_file, bodies, reductions, load_ranking, tmp)
        if rc:
            raise RuntimeError(f"{reference} on {name} failed: {lines[-1] if lines else rc}")
        truth = (file_run(truth_file, scene, path, reference) if truth_file
                 else timed_run(path, scene, repeats, budget_s, frames=reference == "truth"))
        # the verified searches of this scene's requests share runs, the truth's this one
        runs = verified_search.Runs(truth=(truth["t"], truth["rates"], truth["frames"], truth["run_time_s"])
                                    if reference == "truth" and truth.get("frames") is not None else None)
        log(f"tolerance: {name}: {reference} {truth['run_time_s']:.2f} s (median of {truth['runs']})")
        for eps in eps_list:
            model = f"tol-{eps:g}"
            rc, lines, path, attrs, selection = reduce(model, scene_file, bodies, reductions,
                                                       load_ranking, tmp, runs)
            for line in lines:
                log(f"tolerance: {name}: {line}")
            if rc:
                row = dict.fromkeys(COLUMNS, "")
                reason = lines[-1] if lines else f"status {rc}"
                row.update({"scene": name, "eps": eps, "model": model,
                            "status": "refused: " + reason.replace("gimbal_reduction.reduction.models: ", ""),
                            "truth_run_time_s": truth["run_time_s"]})
                log(f"tolerance: {name} {model}: {row['status']}")
                rows.append(row)
                continue
            row = tol_row(name, eps, attrs, timed_run(path, scene, repeats, budget_s), truth, selection)
            log(f"tolerance: {name} {model}: N = {row['n_kept']} ({row['method']}), estimated "
                f"{row['estimated_E_max']:.3e}, measured {row['measured_E_max']:.3e} "
                f"({'within' if row['within_request'] else 'OUTSIDE'} the request), "
                f"{row['run_time_s']:.3g} s")
            rows.append(row)
        if table is not None:
            comparisons = compare_families(name, scene, scene_file, eps_list, table, rows, truth, bodies,
                                           reductions, load_ranking, tmp, repeats, budget_s, log)
    return rows, comparisons, {"model": reference, **{k: truth[k] for k in ("run_time_s", "runs", "steps",
                                                                           "time_basis")}}


def compare_families(name, scene, scene_file, eps_list, table, rows, truth, bodies, reductions,
                     load_ranking, tmp, repeats, budget_s, log=print):
    """Comparison rows: for every family and EPS the cheapest study model meeting EPS (from the
    scene's error table), timed and measured in this run beside tol-EPS (one row per pair; a
    family with no model meeting EPS gets a row with model ''). Each distinct model runs once."""
    done = {}
    out = []
    tol = {r["eps"]: r for r in rows if r.get("status") == "ok"}
    for eps in eps_list:
        for family in FAMILIES:
            choice = cheapest_within(table, family, eps)
            row = dict.fromkeys(COMPARISON_COLUMNS, "")
            row.update({"scene": name, "eps": eps, "family": family})
            if eps in tol:
                row.update({"tol_n_kept": tol[eps]["n_kept"], "tol_run_time_s": tol[eps]["run_time_s"]})
            if choice is None:
                out.append(row)
                continue
            model = choice["model"]
            if model not in done:
                rc, lines, path, _, _ = reduce(model, scene_file, bodies, reductions, load_ranking, tmp)
                if rc:
                    raise RuntimeError(f"{model} on {name} failed: {lines[-1] if lines else rc}")
                run = timed_run(path, scene, repeats, budget_s)
                E = np.asarray(error_measure(truth["t"], truth["rates"], run["rates"]), float)
                done[model] = {"measured_E_max": float(np.max(E)), "run_time_s": run["run_time_s"],
                               "runs": run["runs"], "steps": run["steps"], "time_basis": run["time_basis"]}
                log(f"tolerance: {name}: {model}: measured {np.max(E):.3e} (table {max_error(choice):.3e}), "
                    f"{run['run_time_s']:.3g} s")
            row.update({"model": model, "n_elastic": int(choice["n_elastic"]),
                        "table_E_max": max_error(choice), **done[model]})
            if eps in tol and done[model]["run_time_s"] > 0:
                row["time_ratio"] = tol[eps]["run_time_s"] / done[model]["run_time_s"]
            out.append(row)
    return out


def summarise(rows, eps_list):
    """Counts per scene and over all: requests, built, within the request, by method."""
    def count(rs):
        ok = [r for r in rs if r.get("status") == "ok"]
        return {"requests": len(rs), "built": len(ok), "refused": len(rs) - len(ok),
                "within_request": sum(bool(r["within_request"]) for r in ok),
                "a_priori": sum(r["method"] == reduction_models.TOL_APRIORI for r in ok),
                "verified": sum(r["method"] == reduction_models.TOL_VERIFIED for r in ok)}
    scenes_ = list(dict.fromkeys(r["scene"] for r in rows))
    return {"all": count(rows), "per_scene": {s: count([r for r in rows if r["scene"] == s]) for s in scenes_},
            "a_priori_only": count([r for r in rows if r.get("method") == reduction_models.TOL_APRIORI])}


SCENE_MARKERS = {"thesis": ("tab:blue", "o"), "damped": ("tab:green", "s"), "smooth": ("tab:orange", "^"),
                 "long": ("tab:red", "D"), "spin": ("tab:purple", "v")}


def plot(rows, stem, record=None):
    """Measured max E against the requested EPS per scene (filled markers; the a-priori estimate
    of the same model open), the line E = EPS, and the measured / estimated ratio; writes
    stem.pdf and stem.png."""
    plt = pyplot()
    ok = [r for r in rows if r.get("status") == "ok"]
    with plt.rc_context(STYLE):
        fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4.2), constrained_layout=True)
        eps_all = sorted({r["eps"] for r in rows}) or [1e-8, 1e-2]
        lo, hi = min(eps_all) / 3, max(eps_all) * 3
        ax.plot([lo, hi], [lo, hi], color="0.4", lw=1, ls="--", label="E = EPS")
        for k, scene in enumerate(dict.fromkeys(r["scene"] for r in ok)):
            color, marker = SCENE_MARKERS.get(scene, ("0.3", "o"))
            rs = [r for r in ok if r["scene"] == scene]
            shift = 1.0 + 0.06 * (k - 2)            # side by side at one EPS
            x = np.array([r["eps"] for r in rs]) * shift
            meas = np.array([max(r["measured_E_max"], 1e-16) for r in rs])
            est = np.array([r["estimated_E_max"] for r in rs], float)
            ax.scatter(x, meas, color=color, marker=marker, s=28, zorder=3,
                       label=f"{scene} ({'verified search' if not rs[0]['frozen_chain_valid'] else 'a-priori'})")
            ax.scatter(x, est, facecolors="none", edgecolors=color, marker=marker, s=44, zorder=2)
            bx.plot(x, meas / est, color=color, marker=marker, ms=5, lw=1, label=scene)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(lo, hi)
        ax.set_xlabel("requested tolerance EPS")
        ax.set_ylabel("max E over the four gimbal rates (eq. 3.53)")
        ax.set_title("tol-EPS: measured (filled), estimated a priori (open)", fontsize=9)
        ax.legend(fontsize=7, loc="upper left")
        bx.axhline(1.0, color="0.4", lw=1, ls="--")
        bx.set_xscale("log")
        bx.set_yscale("log")            # damped: the estimate is 1e-7 .. 3e-2 of the measurement
        bx.set_xlabel("requested tolerance EPS")
        bx.set_ylabel("measured / a-priori estimated E")
        bx.set_title("the frozen chain's estimate, checked", fontsize=9)
        bx.legend(fontsize=7)
        return save(fig, stem, record)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m gimbal_reduction.results.bench.tolerance", description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", default=list(SCENES), help="scene files or names")
    ap.add_argument("--eps", nargs="+", type=float, default=list(EPS))
    ap.add_argument("--modes-dir", default="results/modes")
    ap.add_argument("--reduction-dir", default="results/reduction",
                    help="body reduction files and load/{scene}.h5 rankings")
    ap.add_argument("--tables-dir", default="results/tables",
                    help="study error tables {dir}/{scene}/errors_ranking.csv (read where present)")
    ap.add_argument("--repeats", type=int, default=5, help="timed runs per model (median)")
    ap.add_argument("--budget", type=float, default=60.0,
                    help="seconds of timed runs per model; a slower one is timed over a prefix of the "
                         "scene and scaled by its steps (gimbal_reduction.results.bench.timing)")
    ap.add_argument("--untimed", action="store_true",
                    help="every model run once (E, the choices, the searches; no timing): a job beside "
                         "others; with --keep-models, --times-from then times them alone")
    ap.add_argument("--keep-models", metavar="DIR", help="keep the model files in DIR/{scene}/")
    ap.add_argument("--times-from", metavar="JSON",
                    help="the --out-json of an --untimed run with --keep-models DIR (--models-from DIR): "
                         "only its models are timed, its CSV and JSON rewritten with the times")
    ap.add_argument("--models-from", metavar="DIR", help="the --keep-models folder of --times-from")
    ap.add_argument("--truth-times", nargs="*", default=[], metavar="SCENE=JSON",
                    help="with --times-from: the truth's time on SCENE from the runtime benchmark's JSON "
                         "(the median of its whole runs, timed alone) instead of timed again")
    ap.add_argument("--reference", default="truth", help="the model errors are measured against")
    ap.add_argument("--truths", nargs="*", default=[], metavar="SCENE=FILE",
                    help="with --untimed: the reference's run on SCENE read from FILE (the study's "
                         "results/study/{scene}/sim/truth.h5) instead of integrated again")
    ap.add_argument("--out-csv", default="results/benchmarks/tolerance.csv")
    ap.add_argument("--out-json", default="results/benchmarks/tolerance.json")
    ap.add_argument("--figure", default="results/figures/bench/tolerance.png",
                    help="PNG path; the PDF is written beside it (not with --times-from: no time in it)")
    args = ap.parse_args(argv)
    if args.repeats < 1 or args.budget <= 0 or any(not np.isfinite(e) or e <= 0 for e in args.eps):
        print("tolerance: --repeats must be >= 1, --budget and every --eps > 0", file=sys.stderr)
        return 2
    if bool(args.times_from) != bool(args.models_from) or (args.times_from and args.untimed):
        print("tolerance: --times-from needs --models-from (and no --untimed)", file=sys.stderr)
        return 2
    scene_files = [a if a.endswith((".yaml", ".yml")) else os.path.join("config", "scenes", f"{a}.yaml")
                   for a in args.scenes]
    names = {os.path.splitext(os.path.basename(f))[0] for f in scene_files}

    def scene_map(items, needs, what):
        """{scene: path} of SCENE=PATH items, once per scene of --scenes, only with ``needs``;
        None (after one line on stderr) otherwise."""
        out = dict(item.partition("=")[::2] for item in items)
        bad = [item for item in items if "=" not in item or item.partition("=")[0] not in names
               or not item.partition("=")[2]]
        if (items and not needs) or bad or len(out) != len(items):
            print(f"tolerance: {what}" + (f" (got {' '.join(bad)})" if bad else ""), file=sys.stderr)
            return None
        return out
    truth_files = scene_map(args.truths, args.untimed,
                            "--truths takes SCENE=FILE, once per scene of --scenes, with --untimed")
    if truth_files is None:
        return 2
    truth_times = scene_map(args.truth_times, args.times_from,
                            "--truth-times takes SCENE=JSON, once per scene of --scenes, with --times-from")
    if truth_times is None:
        return 2
    if args.times_from:
        import json
        with open(args.times_from) as fh:
            summary = json.load(fh)
        summary.pop("provenance", None)
        t0 = time.perf_counter()
        try:
            retime(summary, scene_files, args.models_from, args.repeats, args.budget, truth_times=truth_times)
        except (OSError, ValueError, KeyError) as exc:
            print(f"tolerance: {' '.join(str(exc).split())}", file=sys.stderr)
            return 2
        summary.update(repeats=args.repeats, budget_s=args.budget, timing_wall_time_s=time.perf_counter() - t0,
                       timed_alone=True)
        record = provenance(sources=[args.times_from])
        write_json(args.out_json, summary, record)
        write_text(args.out_csv, csv_text([{k: r.get(k, "") for k in COLUMNS} for r in summary["rows"]],
                                          COLUMNS), record)
        print(f"tolerance: {len(summary['rows'])} requests timed -> {args.out_csv}, {args.out_json}")
        return 0
    bodies = [os.path.join(args.modes_dir, f"body{b}.h5") for b in reduction_models.BODIES]
    reductions = [os.path.join(args.reduction_dir, f"body{b}.h5") for b in reduction_models.BODIES]
    rows, comparisons, truths = [], [], {}
    t0 = time.perf_counter()
    for scene_file in scene_files:
        name = os.path.splitext(os.path.basename(scene_file))[0]
        load_ranking = os.path.join(args.reduction_dir, "load", f"{name}.h5")
        table_path = os.path.join(args.tables_dir, name, "errors_ranking.csv")
        table = read_table(table_path) if os.path.exists(table_path) else None
        try:
            r, c, truths[name] = bench_scene(
                scene_file, args.eps, bodies, reductions, load_ranking, table,
                0 if args.untimed else args.repeats, args.budget, args.reference,
                keep_dir=os.path.join(args.keep_models, name) if args.keep_models else None,
                truth_file=truth_files.get(name))
        except (RuntimeError, OSError, ValueError) as exc:
            print(f"tolerance: {name}: {' '.join(str(exc).split())}", file=sys.stderr)
            return 2
        rows += r
        comparisons += c
    summary = {"rows": rows, "comparisons": comparisons, "truths": truths,
               "counts": summarise(rows, args.eps), "timed_alone": not args.untimed,
               "scenes": [os.path.splitext(os.path.basename(s))[0] for s in args.scenes],
               "eps": args.eps, "repeats": args.repeats, "budget_s": args.budget,
               "wall_time_s": time.perf_counter() - t0, "created": time.strftime("%Y-%m-%dT%H:%M:%S"),
               "integrator": verified_search.INTEGRATOR,
               "note": "measured E of eq. 3.53 against the truth (100 modes per body) integrated the "
                       "same way; within_request: measured max E <= EPS; run_time_s: median "
                       "integration wall time of up to `repeats` runs"}
    record = provenance(sources=[*bodies, *reductions])
    write_json(args.out_json, summary, record)
    write_text(args.out_csv, csv_text([{k: r.get(k, "") for k in COLUMNS} for r in rows], COLUMNS), record)
    figure = save_figure(rows, args.figure, record)
    counts = summary["counts"]["all"]
    print(f"tolerance: {counts['built']} of {counts['requests']} requests built "
          f"({counts['a_priori']} a priori, {counts['verified']} by verified search), "
          f"{counts['within_request']} within the request -> {args.out_csv}, {args.out_json}, {figure}")
    return 0


def save_figure(rows, png_path, record=None):
    """The figure at png_path (and its PDF beside it)."""
    return plot(rows, os.path.splitext(png_path)[0], record)["png"]


if __name__ == "__main__":
    sys.exit(main())
