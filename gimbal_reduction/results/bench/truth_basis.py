"""The truth's own error from a larger basis: 100 modes per body against 200.

    python -m gimbal_reduction.results.bench.truth_basis --bodies results/verification/truth_basis/body{2,3,4,5}.h5 \\
        --scenes config/scenes/{thesis,damped,smooth,long}.yaml --tol 1e-5 \\
        --truths thesis=results/study/thesis/sim/truth.h5 ... --out results/verification/truth_basis.json

The body files here are the modal stage's with ``--count 200`` on the same meshes
(rule ``modes_body_large``: the study's 100 modes and the next 100).  Two models are reduced
from the same files and simulated on each scene with the workflow's integrator
(``gimbal_reduction.reduction.models`` + ``gimbal_reduction.solver.dynamics.simulate``, in process, as ``gimbal_reduction.results.study.run_scene``):
``truth`` (the 100 lowest modes per body) and ``freq-200`` (all 200).  A reduced-model file
depends on the scene only through its elastic bodies (the damping is applied when a
simulation reads it), so each model is reduced once per set of elastic bodies and simulated
on every scene that has it.  E of eq. 3.53 per gimbal rate of the truth against the larger basis,
and the platform attitude difference [arcsec], say down to what error the truth can referee;
the study's ``static-100`` (residual flexibility of the truncated modes) is the other estimate.

Both runs of a scene use the exponential integrator at the tolerance the workflow runs the scene
at (``--tol``, or the scene's own where tighter: ``Scene.tighter_tolerance``).  The truth is the
study's model (the large body files' 100 lowest modes are the study's, rule ``modes_body_large``),
so ``--truths SCENE=FILE`` gives the study's run of it (results/study/{scene}/sim/truth.h5), read
instead of integrated again; it must be the run this job would make, judged by its simulation
hash (``simulate.config_hash``: the scene's physics, the truth model's hash, integrator and
tolerance), else a one-line error before any simulation.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import h5py
import numpy as np

from gimbal_reduction.reduction import models as reduction_models
from gimbal_reduction.solver import bodyconfig
from gimbal_reduction.solver.dynamics import exponential, simulate
from gimbal_reduction.solver.dynamics.error_measure import ARCSEC_PER_RAD, attitude_error, error_measure
from gimbal_reduction.solver.dynamics.scenes import load_scene
from gimbal_reduction.solver.dynamics.simfile import mismatches, read_sim
from gimbal_reduction.workflow import cli
from gimbal_reduction.workflow.progress import Progress
from gimbal_reduction.workflow.provenance import provenance, versions, write_json

LARGE = "freq-200"


def compare(truth: dict, large: dict) -> dict:
    """E (4,) of the truth's rates against the larger basis's, and the attitude difference."""
    E = error_measure(large["t"], large["gamma_dot"], truth["gamma_dot"])
    out = {"E": [float(x) for x in E], "E_max": float(np.max(E))}
    if truth.get("platform_attitude") is not None and large.get("platform_attitude") is not None:
        a = attitude_error(large["platform_attitude"], truth["platform_attitude"]) * ARCSEC_PER_RAD
        out["attitude_max_arcsec"] = float(a.max())
    return out


def parse_truths(items, scene_names):
    """{scene: path} of ``--truths`` SCENE=FILE arguments; ValueError (one line) on a malformed or
    repeated item, a scene not among ``scene_names`` or a missing file."""
    out = {}
    for item in items or ():
        name, sep, path = item.partition("=")
        if not sep or not name or not path:
            raise ValueError(f"--truths {item!r}: not SCENE=FILE")
        if name in out:
            raise ValueError(f"--truths: scene {name!r} given twice")
        if name not in scene_names:
            raise ValueError(f"--truths {item!r}: scene {name!r} is not among --scenes")
        if not os.path.exists(path):
            raise ValueError(f"--truths {item!r}: {path} does not exist")
        out[name] = path
    return out


def model_hash(path):
    """The ``config_hash`` attribute of a reduced-model file (what it is made from)."""
    with h5py.File(path, "r") as f:
        return str(f.attrs.get("config_hash", ""))


def check_truth_run(path, scene, truth_hash, tol):
    """ValueError (one line) unless the simulation file ``path`` is the truth's run this job would
    make on ``scene``: the truth model of hash ``truth_hash``, the default integrator at ``tol``
    (exponential), the scene's physics (the file's ``config_hash``, ``simulate.config_hash``)."""
    attrs = read_sim(path)["attrs"]
    want = {"scene": scene.name, "model": "truth", "integrator": simulate.DEFAULT_INTEGRATOR,
            "model_config_hash": truth_hash}
    wrong = mismatches(attrs, want)
    wrong.update(mismatches(attrs, {"stat_exponential_tol": tol}, {"stat_exponential_tol": 1e-9}))
    options = {"integrator": simulate.DEFAULT_INTEGRATOR, "step": None, "tol": tol}
    wrong.update(mismatches(attrs, {"config_hash": simulate.config_hash(scene, truth_hash, options)}))
    if wrong:
        raise ValueError(f"--truths {path} is not the truth's run of scene {scene.name} at tol {tol:g} "
                         f"(scene physics, model {truth_hash}): it has {wrong}")


def run(bodies, scenes, log=print, config=None, tol=exponential.DEFAULTS.tol, truths=None) -> dict:
    """{scene name: ``compare`` of the truth against the larger basis, wall_time_s}; progress
    (``gimbal_reduction.workflow.progress``): the simulations done.  config: the configuration
    file the body files must come from (their config_hash), if given; tol: the exponential
    integrator's tolerance (each scene runs at ``Scene.tighter_tolerance(tol)``); truths: {scene
    name: the study's simulation file of its truth}, each checked (``check_truth_run``) before any
    simulation and read instead of integrated."""
    results = {}
    truths = dict(truths or {})
    progress = Progress("truth_basis", 2 * len(scenes) - len(truths), "simulations")
    checked = ["--config", str(config)] if config else []     # the body files vs the configuration
    model_files = {}        # (model, elastic bodies) -> reduced-model file
    with tempfile.TemporaryDirectory(prefix="truth_basis_") as tmp:
        loaded = []
        for scene in scenes:
            name = os.path.splitext(os.path.basename(scene))[0]
            sc = load_scene(scene)
            elastic = tuple(sc.elastic_bodies)
            scene_tol = sc.tighter_tolerance(tol)
            # the truth's model is reduced even where its run is read: its hash identifies the run
            mfile = model_files.get(("truth", elastic))
            if mfile is None:
                mfile = os.path.join(tmp, f"{name}_truth_model.h5")
                rc = reduction_models.main(["--model", "truth", "--scene", scene, "--bodies", *bodies,
                                            "--out", mfile, *checked])
                if rc:
                    raise RuntimeError(f"scene {name}, model truth: reduction failed (status {rc}), see above")
                model_files["truth", elastic] = mfile
            if name in truths:
                check_truth_run(truths[name], sc, model_hash(mfile), scene_tol)
            loaded.append((scene, name, elastic, scene_tol))
        for scene, name, elastic, scene_tol in loaded:
            sims = {}
            t0 = time.perf_counter()
            if name in truths:
                sims["truth"] = read_sim(truths[name])
            for model in [m for m in ("truth", LARGE) if m not in sims]:
                mfile = model_files.get((model, elastic))
                rc = 0
                if mfile is None:
                    mfile = os.path.join(tmp, f"{name}_{model}_model.h5")
                    rc = reduction_models.main(["--model", model, "--scene", scene, "--bodies", *bodies,
                                                "--out", mfile, *checked])
                    if rc == 0:
                        model_files[model, elastic] = mfile
                sfile = os.path.join(tmp, f"{name}_{model}.h5")
                if rc == 0:
                    # the energy history is not compared: left out (~6 s of the 1 s scene's two runs)
                    rc = simulate.main(["--scene", scene, "--model-file", mfile, "--out", sfile, *checked,
                                        "--tol", repr(scene_tol), "--no-energy"])
                if rc:
                    raise RuntimeError(f"scene {name}, model {model}: failed (status {rc}), see above")
                sims[model] = read_sim(sfile)
                progress.advance(note=f"{name} {model}")
            results[name] = {**compare(sims["truth"], sims[LARGE]), "tol": scene_tol,
                             "truth_run": truths.get(name, "simulated here"),
                             "wall_time_s": time.perf_counter() - t0}
            log(f"truth_basis: {name}: E of the truth against {LARGE}: "
                + ", ".join(f"{x:.3g}" for x in results[name]["E"]))
    return results


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m gimbal_reduction.results.bench.truth_basis", description=__doc__.split("\n\n")[0])
    ap.add_argument("--bodies", nargs=4, required=True, help="body files 2..5 with >= 200 modes")
    ap.add_argument("--scenes", nargs="+", required=True, help="scene files")
    ap.add_argument("--tol", type=float, default=exponential.DEFAULTS.tol,
                    help="the exponential integrator's tolerance (config simulation.tolerance; a scene's "
                         "own where tighter)")
    ap.add_argument("--truths", nargs="*", default=[], metavar="SCENE=FILE",
                    help="the study's run of a scene's truth, read instead of integrated (checked)")
    ap.add_argument("--out", required=True, help="JSON")
    cli.add_config_option(ap, "body files of another configuration are refused before the work")
    args = ap.parse_args(argv)
    try:
        bodyconfig.check_slots(args.bodies)
        bodyconfig.check_files(args.bodies, args.config)
        exponential.ExponentialOptions(tol=args.tol)
        names = [os.path.splitext(os.path.basename(s))[0] for s in args.scenes]
        truths = parse_truths(args.truths, names)
        results = run(args.bodies, args.scenes, config=args.config, tol=args.tol, truths=truths)
    except (RuntimeError, ValueError, FileNotFoundError) as exc:
        print(f"truth_basis: error: {exc}", file=sys.stderr)
        return 2
    write_json(args.out, {"description": "E (eq. 3.53) per gimbal rate (outer, middle, inner, "
                                         "platform) of the truth (100 modes per body) against "
                                         f"{LARGE} (200 per body), same meshes and integrator; the truth's "
                                         "run read from the study where given (truth_run)",
                          "larger_basis": LARGE, "scenes": results, "versions": versions()},
               provenance(sources=args.bodies))
    print(f"truth_basis: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
