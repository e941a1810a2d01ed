"""How far the study's error table moves when the integrator changes.

The workflow runs every simulation with the modal exponential integrator; config
``simulation.integrator: rk4`` runs the whole study with RK4 at half its stability
limit, as the thesis did.  This stage answers, in one process, the question the report
must state: would the thesis table (eq. 3.53, every model against the truth, both run by
the same integrator) read differently?

    python -m gimbal_reduction.results.bench.integrator_tables --scene config/scenes/thesis.yaml \\
        --truth-model results/models/thesis/truth.h5 --models results/models/thesis/freq-5.h5 ... \\
        --tol 1e-5 --out-json results/benchmarks/integrator_tables.json \\
        --out-csv results/benchmarks/integrator_tables.csv

For every model m and gimbal rate n, E_n(m) is computed twice: E^exp with the truth and
m integrated by the exponential integrator, E^rk4 with both by RK4.  The table differs by

    d(m) = max_n |E^exp_n(m) - E^rk4_n(m)| / E^rk4_n(m)      (relative, dimensionless),

and the study's order of the models (by E_max) is compared too.  Both integrators'
truths are also compared with each other (E of one against the other): RK4 at half its
limit is itself only accurate to E ~ 2e-7 on the truth (8.8e-6 at the limit; docs/exponential.md
Section 1).
Outputs: the JSON (rows, summary, provenance) and a CSV of the rows; with ``--truth-rk4-out``
also the truth's RK4 run as a simulation file (``simfile.write_sim``, no energy history), the run
another check of the same setting reads instead of integrating it again (the Pareto benchmark's
``rk4-0.5`` of the truth: ``gimbal_reduction.results.bench.pareto --truth-runs``).
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

from gimbal_reduction.solver import bodyconfig
from gimbal_reduction.solver.dynamics import chainfile, exponential, integrators, scenes, simfile, simulate
from gimbal_reduction.solver.dynamics.error_measure import error_measure
from gimbal_reduction.solver.dynamics.simulate import scene_problem
from gimbal_reduction.workflow.provenance import provenance, versions, write_csv, write_json

RK4_FRACTION = integrators.RK4_DEFAULT_FRACTION     # the workflow's rk4 setting (thesis method)
CSV_COLUMNS = ("model", "n_elastic", "E_max_exponential", "E_max_rk4", "relative_difference",
               "wall_s_exponential", "wall_s_rk4")


def relative_difference(E_a, E_b):
    """max over rates of |E_a - E_b| / E_b (rates with E_b = 0 or NaN left out; NaN if none).
    E_a, E_b (4,) dimensionless."""
    a, b = np.asarray(E_a, float), np.asarray(E_b, float)
    ok = np.isfinite(a) & np.isfinite(b) & (b > 0)
    return float(np.max(np.abs(a[ok] - b[ok]) / b[ok])) if ok.any() else float("nan")


def same_order(names, E_a, E_b):
    """(bool, list of (model, rank a, rank b)): whether sorting the models by E_a and by E_b
    gives the same order, and the models whose rank differs."""
    ra = {m: i for i, m in enumerate(sorted(names, key=lambda m: E_a[m]))}
    rb = {m: i for i, m in enumerate(sorted(names, key=lambda m: E_b[m]))}
    moved = [(m, ra[m], rb[m]) for m in names if ra[m] != rb[m]]
    return not moved, moved


def method_options(method, tol):
    """The integrator options of ``method`` here: the exponential integrator at ``tol``, RK4 at
    ``RK4_FRACTION`` of its stability limit."""
    return {"tol": tol} if method == "exponential" else {"fraction": RK4_FRACTION}


def run_chain(chain, scene, method, tol):
    """(``integrators.Run``, wall time [s] with the problem's setup) of a chain in a scene."""
    t0 = time.perf_counter()
    prob = scene_problem(chain, scene)
    run = integrators.integrate(prob, scene.duration, scene.output_interval, method=method,
                                model=chain_name(chain), **method_options(method, tol))
    return run, time.perf_counter() - t0


def run_rates(chain, scene, method, tol):
    """(gimbal rates (T, 4) [rad/s], wall time [s]) of a chain in a scene."""
    run, wall = run_chain(chain, scene, method, tol)
    return np.asarray(run.yd[:, :4]), wall


def write_truth_run(path, run, scene, model_hash, method, tol):
    """The truth's run as a simulation file, with the attributes ``simulate`` gives one (scene,
    model, its hash, integrator, the simulation hash ``simulate.config_hash`` of these options)
    and the options themselves (``option_*``), for a reader to check it is the run it needs."""
    options = {"integrator": method, "step": None, **method_options(method, tol)}
    attrs = {"scene": scene.name, "model": "truth", "model_config_hash": model_hash,
             "integrator": run.method, "step": run.step, "steps": run.steps,
             "integration_time_s": run.wall_time,
             "config_hash": simulate.config_hash(scene, model_hash, options),
             **{f"option_{k}": v for k, v in method_options(method, tol).items()},
             "units": "in, lbf, s, rad", **{f"version_{k}": str(v) for k, v in versions().items()}}
    simfile.write_sim(path, run, None, attrs)


def chain_name(chain):
    return getattr(chain, "name", "")


def compare(scene, truth_chain, chains, tol, log=print, truth_rk4_out=None, truth_hash=""):
    """The rows and summary (module docstring); chains: {model name: chain}; truth_rk4_out: the
    path the truth's RK4 run is written to (``write_truth_run``; truth_hash: the truth model
    file's config_hash), if given."""
    truth = {}
    for method in ("exponential", "rk4"):
        run, wall = run_chain(truth_chain, scene, method, tol)
        truth[method] = (np.asarray(run.yd[:, :4]), wall)
        log(f"integrator_tables: truth, {method}: {wall:.2f} s")
        if method == "rk4" and truth_rk4_out:
            write_truth_run(truth_rk4_out, run, scene, truth_hash, method, tol)
    t = np.linspace(0.0, scene.duration, truth["rk4"][0].shape[0])
    rows, Ee, Er = [], {}, {}
    for name, chain in chains.items():
        rates = {m: run_rates(chain, scene, m, tol) for m in ("exponential", "rk4")}
        e_exp = error_measure(t, truth["exponential"][0], rates["exponential"][0])
        e_rk4 = error_measure(t, truth["rk4"][0], rates["rk4"][0])
        Ee[name], Er[name] = float(np.nanmax(e_exp)), float(np.nanmax(e_rk4))
        rows.append({"model": name, "n_elastic": int(sum(chain.n_modes)),
                     "E_max_exponential": Ee[name], "E_max_rk4": Er[name],
                     "E_exponential": np.asarray(e_exp).tolist(), "E_rk4": np.asarray(e_rk4).tolist(),
                     "relative_difference": relative_difference(e_exp, e_rk4),
                     "wall_s_exponential": rates["exponential"][1], "wall_s_rk4": rates["rk4"][1]})
        log(f"integrator_tables: {name}: E {Ee[name]:.3e} (exponential) {Er[name]:.3e} (rk4), "
            f"difference {rows[-1]['relative_difference']:.2e}")
    order_same, moved = same_order(list(chains), Ee, Er)
    diffs = np.array([r["relative_difference"] for r in rows], float)
    summary = {
        "models": len(rows),
        "max_relative_difference": float(np.nanmax(diffs)) if rows else float("nan"),
        "median_relative_difference": float(np.nanmedian(diffs)) if rows else float("nan"),
        "same_order": order_same, "rank_changes": moved,
        "truth_E_rk4_vs_exponential": np.asarray(
            error_measure(t, truth["exponential"][0], truth["rk4"][0])).tolist(),
        "wall_s_exponential": truth["exponential"][1] + sum(r["wall_s_exponential"] for r in rows),
        "wall_s_rk4": truth["rk4"][1] + sum(r["wall_s_rk4"] for r in rows),
        "rk4_fraction_of_limit": RK4_FRACTION, "exponential_tol": tol}
    return rows, summary


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m gimbal_reduction.results.bench.integrator_tables",
                                 description="The study's error table with the exponential "
                                             "integrator against RK4 (the thesis's method).")
    ap.add_argument("--scene", required=True, help="scene name or file (the study: thesis)")
    ap.add_argument("--truth-model", required=True, help="the truth's reduced-model file")
    ap.add_argument("--models", nargs="+", required=True, help="reduced-model files of the study")
    ap.add_argument("--tol", type=float, default=exponential.DEFAULTS.tol,
                    help="the exponential integrator's tolerance (config simulation.tolerance)")
    ap.add_argument("--out-json", required=True)
    ap.add_argument("--out-csv", required=True)
    ap.add_argument("--truth-rk4-out", help="also write the truth's RK4 run here (a simulation file)")
    ap.add_argument("--config", help="the current configuration file: input files of another "
                                     "configuration are refused before the work (gimbal_reduction.solver.bodyconfig)")
    args = ap.parse_args(argv)
    start = time.perf_counter()
    try:
        bodyconfig.check_files([args.truth_model, *args.models], args.config)
        exponential.ExponentialOptions(tol=args.tol)
        scene = scenes.load_scene(args.scene)
        truth_chain, truth_info = chainfile.read_chain(args.truth_model, scene.damping_ratio)
        chains = {}
        for path in args.models:
            chain, info = chainfile.read_chain(path, scene.damping_ratio)
            chains[str(info.get("model", os.path.splitext(os.path.basename(path))[0]))] = chain
    except (OSError, ValueError) as exc:
        print(f"integrator_tables: {exc}", file=sys.stderr)
        return 2
    rows, summary = compare(scene, truth_chain, chains, args.tol, truth_rk4_out=args.truth_rk4_out,
                            truth_hash=str(truth_info.get("config_hash", "")))
    record = provenance(sources=[args.truth_model, *args.models])      # the model files' config hashes
    write_csv(args.out_csv, [{k: r[k] for k in CSV_COLUMNS} for r in rows], CSV_COLUMNS, record=record)
    write_json(args.out_json, {"stage": "integrator_tables", "scene": scene.name, "rows": rows,
                               "summary": summary, "inputs": [args.truth_model, *args.models],
                               "wall_time_s": time.perf_counter() - start, "versions": versions()}, record)
    print(f"integrator_tables: {len(rows)} models; the tables differ by at most "
          f"{summary['max_relative_difference']:.2e} (relative); same order: {summary['same_order']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
