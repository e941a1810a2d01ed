"""The study on one scene, in one process: every model reduced, then simulated.

    python -m gimbal_reduction.results.study.run_scene --scene config/scenes/thesis.yaml \\
        --bodies results/modes/body{2,3,4,5}.h5 --reductions results/reduction/body{2,3,4,5}.h5 \\
        --load-ranking results/reduction/load/thesis.h5 --models truth rigid freq-10 ... \\
        --out-dir results/study/thesis/sim [--integrator exponential --tol 1e-5]

Why one process: a study scene holds ~50 models whose simulations take milliseconds to a
second each with the exponential integrator, while a workflow job costs ~1 s of interpreter
start and compiled-kernel loading.  Each model goes through exactly the two stages the
per-model rules run (``gimbal_reduction.reduction.models`` writes the reduced-model file, here into a
temporary folder; ``gimbal_reduction.solver.dynamics.simulate`` integrates it and writes
``{out-dir}/{model}.h5``, the simulation-file contract of ``gimbal_reduction.solver.dynamics.simfile``; with
``--coupled-modes`` also the truth's coupled natural modes, ``coupled_mode_table``; with
``--frequency-error`` every model's H-infinity and H2 error against the truth,
``gimbal_reduction.reduction.frequency_error``: each model file is linearised as it is made, the
norms computed once all are), called in process with the same arguments, so a study file equals the file
``snakemake results/sim/{scene}/{model}.h5`` makes, but for one thing the study does not need: no
file has an energy history (``simulate --no-energy``; no stage of the study reads it, and it costs a
right-hand side, the case power and every coordinate per output sample: on the 1 s scene ``long``
as much as the run, 16 of the truth's 39 s).

Progress (``gimbal_reduction.workflow.progress``, stderr): at most one line every ``progress.EVERY`` seconds with
the models done of the total, the time elapsed and the estimated time left.  The first model
that fails stops the run with its one-line message and exit status 2 (nothing is left under
its name; the others' files are removed by Snakemake as the outputs of a failed job).
"""
from __future__ import annotations

import os
import sys
import tempfile
import time

import numpy as np

from gimbal_reduction.reduction import frequency_error
from gimbal_reduction.reduction import models as reduction_models
from gimbal_reduction.solver import bodyconfig
from gimbal_reduction.solver.dynamics import chainfile, integrators, linearized, scenes, simulate
from gimbal_reduction.workflow import cli
from gimbal_reduction.workflow.progress import Progress
from gimbal_reduction.workflow.provenance import provenance, write_json

BODY_LABELS = ("outer gimbal", "middle gimbal", "inner gimbal", "stable platform")


def coupled_mode_table(model_file, scene_file, sampling=None) -> dict:
    """The coupled chain's natural modes at the scene's initial state (``linearized.coupled_modes``:
    joints free), with the body each mode lives in: frequencies_hz (m,) ascending, body (m,) the
    label of the body holding the largest share of the mode's modal mass (the elastic mass block
    of a body is its modal mass matrix, identity for mass-normalised modes), share (m,) that share;
    sampling: what E's sampling rule found for the scene's output grid
    (``frequency_error.sampling_band``), if given."""
    scene = scenes.load_scene(scene_file)
    chain, _ = chainfile.read_chain(model_file, scene.damping_ratio)
    y0, _ = scenes.initial_state(scene, chain.n_coordinates)
    omega, shapes = linearized.coupled_modes(chain, y0)
    weights = np.array([np.sum(shapes[sl] ** 2, axis=0) for sl in chain.slices])      # (4, m)
    share = weights / np.maximum(weights.sum(axis=0), 1e-300)
    dominant = np.argmax(share, axis=0)
    return {"scene": scene.name, "model": "truth", "units": "Hz",
            "frequencies_hz": (omega / (2 * np.pi)).tolist(),
            "body": [BODY_LABELS[k] for k in dominant],
            "share": share[dominant, np.arange(dominant.size)].tolist(),
            **({"sampling": sampling} if sampling is not None else {})}


def model_file_name(model: str) -> str:
    """The file name of a model's output: the model name itself (as the per-model rules)."""
    return f"{model}.h5"


def linearised_model(model_file, scene):
    """The reduced model's chain linearised at the scene's initial configuration
    (``frequency_error.linear_chain``)."""
    chain, _ = chainfile.read_chain(model_file, scene.damping_ratio)
    y0, _ = scenes.initial_state(scene, chain.n_coordinates)
    return frequency_error.linear_chain(chain, y0)


def run_scene(scene, models, bodies, reductions, load_ranking, out_dir, integrator_args=(),
              coupled_modes=None, config=None, frequency_errors=None, cb_bases=None):
    """Reduce and simulate every model of ``models`` on ``scene`` (a scene file); writes
    {out_dir}/{model}.h5, the truth's coupled-mode table to ``coupled_modes`` (JSON) and every
    model's frequency-domain error to ``frequency_errors`` (JSON; the models must hold the truth)
    if given; cb_bases: the rings' Craig-Bampton stage files (cb- models).  Before the truth is
    simulated, its model file is checked against E's sampling rule (``frequency_error.sampling_band``,
    the rule in ``error_measure``): a grid that does not resolve the truth's excited modes stops the
    run with a one-line message; the finding goes into the coupled-mode table.  Returns (status,
    failed model or None)."""
    scene_obj = scenes.load_scene(scene)
    linear, sampling = {}, None
    progress = Progress(f"run_scene {os.path.splitext(os.path.basename(str(scene)))[0]}", len(models),
                        "models")
    with tempfile.TemporaryDirectory(prefix="run_scene_") as tmp:
        for k, model in enumerate(models, 1):
            t0 = time.perf_counter()
            model_file = os.path.join(tmp, f"model{k}.h5")
            args = ["--model", model, "--scene", str(scene), "--bodies", *map(str, bodies),
                    "--out", model_file]
            if reductions:
                args += ["--reductions", *map(str, reductions)]
            if load_ranking:
                args += ["--load-ranking", str(load_ranking)]
            if cb_bases:
                args += ["--cb-bases", *map(str, cb_bases)]
            checked = ["--config", str(config)] if config else []   # body files vs the config
            rc = reduction_models.main(args + checked)
            if rc == 0 and model == "truth":
                linear[model] = linearised_model(model_file, scene_obj)
                sampling = frequency_error.sampling_band(linear[model], scene_obj)
                if sampling["resolved"] is False:
                    print(f"run_scene: {sampling['problem']}", file=sys.stderr)
                    return 2, model
            if rc == 0:
                rc = simulate.main(["--scene", str(scene), "--model-file", model_file, "--out",
                                    os.path.join(out_dir, model_file_name(model)),
                                    *checked, *integrator_args, "--no-energy"])
            if rc:
                return rc, model
            if model == "truth" and coupled_modes:
                truth_sim = os.path.join(out_dir, model_file_name(model))
                write_json(coupled_modes, coupled_mode_table(model_file, scene, sampling),
                           record=provenance(sources=[truth_sim]))
            if frequency_errors and model not in linear:
                linear[model] = linearised_model(model_file, scene_obj)
            os.remove(model_file)
            progress.update(k, note=f"{model} took {time.perf_counter() - t0:.2f} s")
    if frequency_errors:
        t0, c0 = time.perf_counter(), time.process_time()
        table = frequency_error.frequency_errors(scene_obj, linear)
        table["cost_s"] = time.perf_counter() - t0              # wall, and CPU (less load-dependent)
        table["cost_cpu_s"] = time.process_time() - c0
        write_json(frequency_errors, table, record=provenance(
            sources=[os.path.join(out_dir, model_file_name(m)) for m in models]))
        print(f"run_scene: frequency-domain errors of {len(models)} models in {table['cost_s']:.1f} s "
              f"(band to {table['band']['edge_hz']:.4g} Hz) -> {frequency_errors}")
    return 0, None


def main(argv=None) -> int:
    ap = cli.OneLineParser(prog="python -m gimbal_reduction.results.study.run_scene", description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", required=True, help="scene file (config/scenes/NAME.yaml)")
    ap.add_argument("--models", nargs="+", required=True, help="model names (gimbal_reduction/reduction/models.py)")
    ap.add_argument("--bodies", nargs=4, required=True, metavar="BODY_FILE", help="body files 2..5")
    ap.add_argument("--reductions", nargs=4, metavar="REDUCTION_FILE", help="reduction files 2..5")
    ap.add_argument("--load-ranking", help="the scene's load-aware ranking (load-, global- models)")
    ap.add_argument("--cb-bases", nargs=3, metavar="CB_FILE",
                    help="the Craig-Bampton stage files of rings 2, 3, 4 (cb- models)")
    ap.add_argument("--out-dir", required=True, help="folder of the simulation files")
    ap.add_argument("--coupled-modes", help="JSON: the truth's coupled modes at the initial state")
    ap.add_argument("--frequency-error", help="JSON: every model's H-infinity and H2 error against the "
                                              "truth (the models must hold the truth)")
    cli.add_config_option(ap, "body files from another one are refused")
    ap.add_argument("--integrator", default=None, choices=integrators.METHODS,
                    help="simulate's --integrator (default its own)")
    ap.add_argument("--tol", default=None, type=cli.positive_number("--tol"),
                    help="simulate's --tol (exponential)")
    try:        # a negative value is read as the option's value (and refused by its type)
        args = ap.parse_args(cli.values_joined(sys.argv[1:] if argv is None else argv, ap))
        if args.tol is not None and (args.integrator or simulate.DEFAULT_INTEGRATOR) != "exponential":
            ap.error(f"--tol is the exponential integrator's tolerance, not {args.integrator}'s")
    except SystemExit as exc:       # the one-line message is printed; in process, return the status
        return exc.code
    if args.frequency_error and "truth" not in args.models:
        print("run_scene: --frequency-error compares every model with the truth: add truth to --models",
              file=sys.stderr)
        return 2
    if len(set(args.models)) != len(args.models):
        dup = sorted({m for m in args.models if args.models.count(m) > 1})
        print(f"run_scene: model(s) given twice: {', '.join(dup)}", file=sys.stderr)
        return 2
    # every name is checked before any work (a typo in the last model must not cost the others)
    try:
        # and every input file against the configuration, before any work (gimbal_reduction.solver.bodyconfig)
        bodyconfig.check_slots(args.bodies)
        bodyconfig.check_slots(args.reductions or [])
        bodyconfig.check_files([*args.bodies, *(args.reductions or []),
                                *([args.load_ranking] if args.load_ranking else [])], args.config)
        if args.reductions:
            rankings = reduction_models.read_rankings(dict(zip(reduction_models.BODIES, args.reductions)))
            if args.load_ranking:
                reduction_models.load_load_ranking(args.load_ranking, rankings)
            for m in args.models:
                reduction_models.model_spec(m, rankings)
    except (ValueError, FileNotFoundError) as exc:
        print(f"run_scene: {exc}", file=sys.stderr)
        return 2
    integrator_args = []
    if args.integrator:
        integrator_args += ["--integrator", args.integrator]
    if args.tol:
        integrator_args += ["--tol", repr(args.tol)]
    t0 = time.perf_counter()
    try:
        rc, failed = run_scene(args.scene, args.models, args.bodies, args.reductions, args.load_ranking,
                               args.out_dir, integrator_args, coupled_modes=args.coupled_modes,
                               config=args.config, frequency_errors=args.frequency_error,
                               cb_bases=args.cb_bases)
    except frequency_error.FrequencyError as exc:
        print(f"run_scene: frequency-domain error: {exc}", file=sys.stderr)
        return 2
    if rc:
        print(f"run_scene: model {failed!r} failed (status {rc}); see the message above", file=sys.stderr)
        return rc
    print(f"run_scene: {len(args.models)} models on {args.scene} in {time.perf_counter() - t0:.1f} s "
          f"-> {args.out_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
