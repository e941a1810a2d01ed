"""Run and set-up times of the models a scene's decision names: a timing job.

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python -m gimbal_reduction.results.bench.runtime \\
        --scene config/scenes/thesis.yaml --bodies results/modes/body{2,3,4,5}.h5 \\
        --reductions results/reduction/body{2,3,4,5}.h5 --load-ranking results/reduction/load/thesis.h5 \\
        --ranking-table results/tables/thesis/errors_ranking.csv \\
        --static-table results/tables/thesis/errors_static.csv --truth results/study/thesis/sim/truth.h5 \\
        [--truth-basis results/verification/truth_basis.json] --repeats 5 --out results/benchmarks/runtime/thesis.json

The models timed are those the decision table names (``gimbal_reduction.results.study.decision.
chosen_models``: the cheapest model meeting each requirement), the rigid model and the truth.  For
each model, in this one process, after every model's one warm-up run (which loads or compiles the
Numba kernels, a one-off cost of a fresh process):

* set-up [ms]: building the chain from the body data already in memory (``reduction.models.
  build_chain``: the kept modes' modal integrals) and the scene's problem (``simulate.
  scene_problem``: the initial state and the coupled chain's highest frequency), median of
  ``--repeats``; reading the body files (shared by every model) is not in it;
* first call [ms]: the first model's warm-up run, the process's first simulation, against that
  model's median (``first_call``): what a user running one simulation in a fresh process pays
  beyond the medians (the kernels come from their extension: milliseconds);
* run [ms]: the integration of the whole scene with the workflow's integrator and options
  (``integrators.Run.wall_time``: the stepping and the output monitor), median of ``--repeats``
  runs, and the spread (largest minus smallest) beside it; a model whose runs would take longer
  than ``--budget`` runs as often as fits, at least once (``run_ms_all``).

The rounds interleave the models (round k runs every model once), so a slow spell of a shared
machine falls on every model alike rather than on one.  This is a timing job: the workflow gives it
both cores so that no other job runs beside it.  Output JSON: {scene, repeats, duration_s, samples,
integrator, models: {name: {run_ms, run_ms_spread, run_ms_all, setup_ms, setup_ms_all, n_modes
(4,), coordinates}}, environment, cpu_count, load_average (before, after)}.
"""
from __future__ import annotations

import os

# One BLAS thread, as in the simulation rules (set before numpy is imported).
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from gimbal_reduction.reduction import models  # noqa: E402
from gimbal_reduction.reduction import names as names_mod  # noqa: E402
from gimbal_reduction.reduction.names import needs_load_ranking  # noqa: E402
from gimbal_reduction.results.study import decision  # noqa: E402
from gimbal_reduction.solver import bodyconfig  # noqa: E402
from gimbal_reduction.solver.dynamics import integrators, scenes, simulate  # noqa: E402
from gimbal_reduction.solver.dynamics.simfile import read_sim  # noqa: E402
from gimbal_reduction.workflow import cli  # noqa: E402
from gimbal_reduction.workflow.provenance import provenance, versions, write_json  # noqa: E402

MIN_REPEATS = 5


def time_models(names, scene, body_files, reduction_files, load_ranking=None, repeats=MIN_REPEATS,
                integrator=simulate.DEFAULT_INTEGRATOR, options=None, log=print, cb_files=None,
                budget_s=None, truth_whole=None) -> dict:
    """{name: {run_ms, run_ms_spread, run_ms_all, setup_ms, setup_ms_all, n_modes, coordinates}}
    of every model of ``names`` on ``scene`` (a loaded scene); see the module doc.
    cb_files: {ring: path} of the Craig-Bampton stage files (read once, like the body files, when
    a cb- model is timed).  budget_s: seconds of timed runs per model (None: no limit); a model
    whose ``repeats`` runs would take longer runs as often as fits, at least once.  truth_whole: (wall time [s], steps) of the truth's whole run with
    this integrator (its simulation file), so that its warm-up is a short run."""
    options = dict(options or {})
    rankings = models.read_rankings(reduction_files)
    if any(needs_load_ranking(n) for n in names):
        models.load_load_ranking(load_ranking, rankings)
    specs = {n: models.model_spec(n, rankings) for n in names}        # every name before any work
    body_data = {b: models.load_body_file(body_files[b]) for b in models.BODIES}
    cb_stages = models.cb_stages_for(specs.values(), body_data, cb_files)
    dt = scene.output_interval
    run_options = simulate.scene_options(scene, integrator, None, options)
    built, out, first = {}, {}, None
    for name, spec in specs.items():
        chain = models.build_chain(spec, body_data, scene.damping_ratio, cb_stages)
        prob = simulate.scene_problem(chain, scene)
        go = (lambda d, prob=prob, name=name: integrators.integrate(prob, d, dt, method=integrator,
                                                                     model=name, **run_options))
        if name == "truth" and truth_whole is not None:
            go(2 * dt)                                                   # warm-up
            whole_s = truth_whole[0]
        else:
            warm = go(scene.duration)                                    # warm-up, and its pace
            whole_s = warm.wall_time
            if first is None and not built:          # this process's first simulation: a whole run
                first = (name, 1e3 * whole_s)
        # runs of this model: a slow one as many as fit in the budget, at least one (the
        # exponential integrator's cost per step varies along a scene: no prefix, timing module)
        count = (repeats if budget_s is None or whole_s * repeats <= budget_s
                 else max(1, min(repeats, int(budget_s // max(whole_s, 1e-12)))))
        built[name] = (spec, chain, go, count)
        out[name] = {"run_ms_all": [], "setup_ms_all": [], "n_modes": list(chain.n_modes),
                     "coordinates": int(chain.n_coordinates)}
    for k in range(repeats):
        for name, (spec, chain, go, count) in built.items():
            if k >= count:
                continue
            t0 = time.perf_counter()
            c = models.build_chain(spec, body_data, scene.damping_ratio, cb_stages)
            simulate.scene_problem(c, scene)
            out[name]["setup_ms_all"].append(1e3 * (time.perf_counter() - t0))
            out[name]["run_ms_all"].append(1e3 * go(scene.duration).wall_time)
        log(f"runtime: round {k + 1} of {repeats} done")
    for name, rec in out.items():
        runs = np.asarray(rec["run_ms_all"])
        rec.update(run_ms=float(np.median(runs)), run_ms_spread=float(runs.max() - runs.min()),
                   setup_ms=float(np.median(rec["setup_ms_all"])))
        log(f"runtime: {name}: run {rec['run_ms']:.3g} ms (median of {len(runs)}), "
            f"set-up {rec['setup_ms']:.3g} ms")
    if first is not None:
        out[first[0]]["first_call"] = first_call(first[1], out[first[0]]["run_ms_all"])
        log(f"runtime: this process's first simulation ({first[0]}): "
            f"{out[first[0]]['first_call']['extra_ms']:+.3g} ms against its median")
    return out


def first_call(first_run_ms: float, run_ms_all) -> dict:
    """What a fresh process's first simulation costs beyond the same run later in the process:
    {first_run_ms, run_ms (the median of the later runs ``run_ms_all``), extra_ms = the first's
    excess (loading the kernels, first-use set-up of the libraries; can be slightly negative
    on a noisy machine)} [ms]."""
    later = float(np.median(np.asarray(run_ms_all, float)))
    return {"first_run_ms": float(first_run_ms), "run_ms": later, "extra_ms": float(first_run_ms) - later}


def truth_whole_run(path, scene, integrator, options):
    """(integration time [s], steps) of the truth's simulation file if it ran ``integrator`` with
    the tolerance of ``options`` (as ``simulate.scene_options`` completes them), else None."""
    a = read_sim(path)["attrs"]
    tol = simulate.scene_options(scene, integrator, None, options).get("tol")
    if (a.get("model") != "truth" or a.get("integrator") != integrator or "steps" not in a
            or (tol is not None and a.get("stat_tol") != tol)):
        return None
    return float(a["integration_time_s"]), int(a["steps"])


def main(argv=None) -> int:
    ap = cli.OneLineParser(prog="python -m gimbal_reduction.results.bench.runtime",
                           description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", required=True, help="scene file")
    ap.add_argument("--bodies", nargs=4, required=True, metavar="BODY_FILE")
    ap.add_argument("--reductions", nargs=4, required=True, metavar="REDUCTION_FILE")
    ap.add_argument("--load-ranking", help="the scene's load-aware ranking")
    ap.add_argument("--cb-bases", nargs=3, metavar="CB_FILE",
                    help="the Craig-Bampton stage files of rings 2, 3, 4 (cb- models)")
    ap.add_argument("--ranking-table", required=True)
    ap.add_argument("--static-table", required=True)
    ap.add_argument("--truth", required=True, help="the truth's simulation file of the scene")
    ap.add_argument("--truth-basis", help="results/verification/truth_basis.json")
    ap.add_argument("--repeats", type=int, default=MIN_REPEATS)
    ap.add_argument("--budget", type=cli.positive_number("--budget"), default=None,
                    help="seconds of timed runs per model: a slower one runs as often as fits, at "
                         "least once (default: --repeats runs)")
    ap.add_argument("--integrator", default=simulate.DEFAULT_INTEGRATOR, choices=integrators.METHODS)
    ap.add_argument("--tol", type=cli.positive_number("--tol"), default=None)
    ap.add_argument("--config", help="the configuration file: body files from another one are refused")
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    if args.repeats < MIN_REPEATS:
        ap.error(f"--repeats {args.repeats}: at least {MIN_REPEATS} (a median of fewer is noise)")
    try:
        bodyconfig.check_files([*args.bodies, *args.reductions,
                                *([args.load_ranking] if args.load_ranking else [])], args.config)
        scene = scenes.load_scene(args.scene)
        rows, rms = decision.read_scene(args.ranking_table, args.static_table, args.truth)
        basis = decision.read_basis(args.truth_basis).get(scene.name)
        names = decision.chosen_models(rows, rms, basis)
        options = {"tol": args.tol} if args.tol else {}
        load_before = os.getloadavg()[0]
        timed = time_models(names, scene, dict(zip(models.BODIES, args.bodies)),
                            dict(zip(models.BODIES, args.reductions)), args.load_ranking,
                            args.repeats, args.integrator, options,
                            cb_files=dict(zip(names_mod.INTERFACE_BODIES, args.cb_bases)) if args.cb_bases
                            else None, budget_s=args.budget,
                            truth_whole=truth_whole_run(args.truth, scene, args.integrator, options))
    except (ValueError, FileNotFoundError) as exc:
        print(f"runtime: {exc}", file=sys.stderr)
        return 2
    samples = int(round(scene.duration / scene.output_interval)) + 1
    write_json(args.out, {"scene": scene.name, "repeats": args.repeats, "budget_s": args.budget,
                          "integrator": args.integrator,
                          "duration_s": scene.duration, "output_interval_s": scene.output_interval,
                          "samples": samples, "models": timed, "environment": versions(),
                          "cpu_count": os.cpu_count(),
                          # the machine's 1-minute load average before and after the runs: on a shared
                          # machine the absolute times are inflated by about load / cores
                          "load_average": [load_before, os.getloadavg()[0]]},
               provenance(sources=[args.ranking_table, args.static_table, args.truth]))
    print(f"runtime: {len(timed)} models on {scene.name} x {args.repeats} -> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
