"""The truth's own error from a larger basis: 100 modes per body against 200.

    python -m gimbal_reduction.results.bench.truth_basis --bodies results/verification/truth_basis/body{2,3,4,5}.h5 \\
        --scenes config/scenes/{thesis,damped,smooth,long}.yaml --out results/verification/truth_basis.json

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
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np

from gimbal_reduction.reduction import models as reduction_models
from gimbal_reduction.solver import bodyconfig
from gimbal_reduction.solver.dynamics import simulate
from gimbal_reduction.solver.dynamics.error_measure import ARCSEC_PER_RAD, attitude_error, error_measure
from gimbal_reduction.solver.dynamics.scenes import load_scene
from gimbal_reduction.solver.dynamics.simfile import read_sim
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


def run(bodies, scenes, log=print, config=None) -> dict:
    """{scene name: ``compare`` of the truth against the larger basis, wall_time_s}; progress
    (``gimbal_reduction.workflow.progress``): the simulations done of 2 per scene.  config: the configuration
    file the body files must come from (their config_hash), if given."""
    results = {}
    progress = Progress("truth_basis", 2 * len(scenes), "simulations")
    checked = ["--config", str(config)] if config else []     # the body files vs the configuration
    model_files = {}        # (model, elastic bodies) -> reduced-model file
    with tempfile.TemporaryDirectory(prefix="truth_basis_") as tmp:
        for scene in scenes:
            name = os.path.splitext(os.path.basename(scene))[0]
            elastic = tuple(load_scene(scene).elastic_bodies)
            sims = {}
            t0 = time.perf_counter()
            for model in ("truth", LARGE):
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
                                        "--no-energy"])
                if rc:
                    raise RuntimeError(f"scene {name}, model {model}: failed (status {rc}), see above")
                sims[model] = read_sim(sfile)
                progress.advance(note=f"{name} {model}")
            results[name] = {**compare(sims["truth"], sims[LARGE]),
                             "wall_time_s": time.perf_counter() - t0}
            log(f"truth_basis: {name}: E of the truth against {LARGE}: "
                + ", ".join(f"{x:.3g}" for x in results[name]["E"]))
    return results


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m gimbal_reduction.results.bench.truth_basis", description=__doc__.split("\n\n")[0])
    ap.add_argument("--bodies", nargs=4, required=True, help="body files 2..5 with >= 200 modes")
    ap.add_argument("--scenes", nargs="+", required=True, help="scene files")
    ap.add_argument("--out", required=True, help="JSON")
    cli.add_config_option(ap, "body files of another configuration are refused before the work")
    args = ap.parse_args(argv)
    try:
        bodyconfig.check_slots(args.bodies)
        bodyconfig.check_files(args.bodies, args.config)
        results = run(args.bodies, args.scenes, config=args.config)
    except (RuntimeError, ValueError, FileNotFoundError) as exc:
        print(f"truth_basis: error: {exc}", file=sys.stderr)
        return 2
    write_json(args.out, {"description": "E (eq. 3.53) per gimbal rate (outer, middle, inner, "
                                         "platform) of the truth (100 modes per body) against "
                                         f"{LARGE} (200 per body), same meshes and integrator",
                          "larger_basis": LARGE, "scenes": results, "versions": versions()},
               provenance(sources=args.bodies))
    print(f"truth_basis: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
