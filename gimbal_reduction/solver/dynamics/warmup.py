"""Compile the dynamics kernels once, before the workflow's first simulation.

    python -m gimbal_reduction.solver.dynamics.warmup --scenes config/scenes/thesis.yaml config/scenes/damped.yaml \\
        [--integrator exponential --tol 1e-6] --out results/verification/kernels.json

The chain's equations run as Numba kernels (``gimbal_reduction.solver.dynamics.kernels``) compiled on first
use and cached on disk (``cache=True``: ``__pycache__`` beside the sources, or
``NUMBA_CACHE_DIR``).  In a fresh clone nothing is cached, and every job that reaches a
kernel before the cache exists compiles the whole set itself: on this 2-core machine one
compilation is ~1-1.5 CPU-minutes, and the workflow's first dynamics jobs (the load-aware
rankings, the study scenes, the truth-basis check) start together, so that it was paid
several times over.  This stage pays it once, at the start of the workflow, while the FE
jobs run beside it: it needs no body file, because compiled code depends on the types and
layouts of the arrays, not on their values.

What it runs is exactly what the jobs run: a synthetic chain
(``gimbal_reduction.solver.dynamics.synthetic``: two modes per body, and the rigid chain) written to a
reduced-model file and simulated through ``gimbal_reduction.solver.dynamics.simulate``'s command line on
every given scene with the configured integrator (so damped scenes compile the damped
paths), on the first scene's first output intervals with RK4 and generalised-alpha
(``OTHER_INTEGRATORS``: the checks'; ``SHORT_WINDOW``),
and the rigid chain with DOP853 (the load-aware ranking's rigid motion).  A kernel
the jobs reach with other array types would still compile there, only later; nothing is
assumed about the cache's contents, and a missing or stale cache costs time, never a result.

Output: a JSON record (per run: scene, integrator, wall time; the first run's wall time is
the compilation; versions, git revision), the file the dynamics rules take as an input so
that they start after it.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

import numba
import numpy as np
import yaml

from gimbal_reduction.solver.dynamics import chainfile, kernels, multibody, scenes, simulate
from gimbal_reduction.solver.dynamics.kernels import extension
from gimbal_reduction.solver.dynamics.synthetic import synthetic_modal_chain
from gimbal_reduction.workflow.provenance import git_revision, versions, write_json

MODES_PER_BODY = 2


def rigid_chain(chain):
    """The chain with every body's modes removed (D = 0): the load-aware ranking's rigid motion."""
    bodies = tuple(multibody.make_body(b.number, {"rigid_mass": b.rigid_mass,
                                                  "momentum": np.zeros((6, 0)),
                                                  "inertia_gradient": np.zeros((0, 6, 6)),
                                                  "coriolis": np.zeros((0, 3, 0)),
                                                  **({} if b.inside_translation is None else
                                                     {"inside_translation": np.zeros((3, 0)),
                                                      "inside_rotation": np.zeros((3, 0))})},
                                       np.zeros(0)) for b in chain.bodies)
    return multibody.Chain(bodies, name="synthetic-rigid")


def write_model(path, chain, name):
    """``chain`` as a reduced-model file (the contract the simulations read)."""
    kept = {b.number: np.arange(b.n_modes) for b in chain.bodies}
    static = {b.number: () for b in chain.bodies}
    chainfile.write_chain(path, chain, kept, static, {"model": name, "scene": "synthetic",
                                                       "config_hash": "synthetic"})


# The integrators the workflow's checks run besides the configured one, each once on the first
# scene: RK4 and generalised-alpha have kernels of their own (the step loop, the mass solve) that
# the study never reaches, but `all`'s checks do (the dynamics verification, the Pareto front, the
# stability tests); left out, the first of those jobs compiled them (~76 CPU-s, measured).
OTHER_INTEGRATORS = ("rk4", "generalized-alpha")

# The other integrators run over the first scene's first SHORT_WINDOW output intervals only: their
# steps are fixed and their Python side does the same at every step, so a short window calls the
# same entry points with the same types as the whole one (checked: tests/dynamics/test_extension.py,
# a whole-window run of each in a fresh process compiles nothing).  Over the thesis scene's 6000
# intervals they ran 12000 and 6000 steps, ~4 CPU-s of the extension's build (its JIT code is
# unoptimised machine code there: kernels.recording_jit).
SHORT_WINDOW = 40


def runs(scene_paths, integrator, options):
    """The (scene file, model, simulate options, output intervals: None for the whole window) of
    the warm-up, in order."""
    first = scene_paths[0]
    out = [(scene, "elastic", ["--integrator", integrator, *options], None) for scene in scene_paths]
    out += [(first, "elastic", ["--integrator", other], SHORT_WINDOW) for other in OTHER_INTEGRATORS
            if other != integrator]
    out.append((first, "rigid", ["--integrator", "dop853"], None))
    return out


def shortened(scene_path, intervals, directory):
    """A copy of the scene file ``scene_path`` in ``directory`` (the same file name, so the same
    scene name) whose duration is its first ``intervals`` output intervals (its whole duration if
    shorter); returns its path."""
    scene = scenes.load_scene(scene_path)
    raw = dict(scene.raw)
    raw["duration"] = {"value": min(scene.duration, intervals * scene.output_interval), "unit": "s",
                       "source": f"the first {intervals} output intervals of {scene_path} (the warm-up)"}
    path = os.path.join(directory, os.path.basename(scene_path))
    with open(path, "w") as f:
        yaml.safe_dump(raw, f)
    return path


def warm(scene_paths, integrator, options, record):
    """Simulate the synthetic chains of ``runs``; append each run to record["runs"]; returns the
    exit code (2: a run failed, named on stderr)."""
    elastic = synthetic_modal_chain(MODES_PER_BODY, seed=0)
    with tempfile.TemporaryDirectory(prefix="warmup_") as tmp:
        models = {"elastic": os.path.join(tmp, "elastic.h5"), "rigid": os.path.join(tmp, "rigid.h5")}
        write_model(models["elastic"], elastic, f"synthetic-{MODES_PER_BODY}")
        write_model(models["rigid"], rigid_chain(elastic), "synthetic-rigid")
        short = {}                          # (scene file, intervals) -> its shortened copy
        for k, (scene, model, opts, window) in enumerate(runs(scene_paths, integrator, options)):
            t0 = time.perf_counter()
            try:
                if window is not None and (scene, window) not in short:
                    short[scene, window] = shortened(scene, window, tmp)
                run_scene = scene if window is None else short[scene, window]
            except scenes.SceneError as exc:
                print(f"warmup: the synthetic {model} chain failed on {scene} ({exc})", file=sys.stderr)
                return 2
            rc = simulate.main(["--scene", run_scene, "--model-file", models[model],
                                "--out", os.path.join(tmp, f"sim{k}.h5"), "--no-config-check", *opts])
            if rc:
                print(f"warmup: the synthetic {model} chain failed on {scene} (simulate exit {rc})",
                      file=sys.stderr)
                return 2
            wall = time.perf_counter() - t0
            record["runs"].append({"scene": scene, "model": model, "options": opts,
                                   "output_intervals": window, "wall_time_s": wall})
            what = "" if window is None else f", its first {window} output intervals"
            print(f"warmup: [{k + 1}] {model} chain on {scene} ({' '.join(opts)}{what}): {wall:.1f} s",
                  flush=True)
    return 0


def build_extension(scene_paths, integrator, options, argv) -> int:
    """The kernels' extension module (``kernels.extension``): the warm-up's entry points, recorded
    while it runs with the JIT, compiled ahead of time.  Nothing to do when it is current.  The
    build runs in a process of its own, started here with GIMBAL_KERNELS=build (``argv``: this
    command's arguments), whose JIT only serves the recording (``kernels.recording_jit``)."""
    if extension.up_to_date():
        print("warmup: the kernels' extension is up to date", flush=True)
        return 0
    if not kernels.BUILDING:
        return subprocess.run([sys.executable, "-m", __spec__.name, *argv],
                              env={**os.environ, "GIMBAL_KERNELS": "build"}).returncode
    print("warmup: compiling the dynamics kernels ahead of time (kernels.extension; ~1 "
          "CPU-minute): the warm-up with the JIT first, then the extension", flush=True)
    start = time.process_time()
    with extension.recording() as seen:
        rc = warm(scene_paths, integrator, options, {"runs": []})
    if rc:
        return rc
    print(f"warmup: the warm-up compiled with the JIT ({time.process_time() - start:.0f} CPU-s); "
          f"now the extension", flush=True)
    numba.config.OPT = numba.core.config._process_opt_level(str(kernels.OPT_LEVEL))
    entries = extension.exportable(seen)
    path = extension.build(entries, log=lambda line: print(f"warmup: {line}", flush=True))
    print(f"warmup: {path} holds {len(entries)} entries ({time.process_time() - start:.0f} CPU-s "
          f"in this process)", flush=True)
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m gimbal_reduction.solver.dynamics.warmup",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", required=True, help="scene files the study simulates")
    ap.add_argument("--integrator", default=simulate.DEFAULT_INTEGRATOR,
                    help="the workflow's integrator (config simulation.integrator)")
    ap.add_argument("--tol", default=None, help="its tolerance (config simulation.tolerance)")
    ap.add_argument("--out", help="JSON record of the warm-up (required without --extension)")
    ap.add_argument("--extension", action="store_true",
                    help="build the kernels' extension module instead (kernels.extension; make install)")
    args = ap.parse_args(argv)
    options = [] if args.tol is None else ["--tol", str(args.tol)]
    if args.extension:
        return build_extension(args.scenes, args.integrator, options,
                               sys.argv[1:] if argv is None else argv)
    if args.out is None:
        ap.error("--out is required without --extension")
    record = {"integrator": args.integrator, "options": options, "runs": [],
              "numba": numba.__version__, "numba_cache_dir": os.environ.get("NUMBA_CACHE_DIR", ""),
              "extension": extension.attached(),
              "versions": versions(), "git_revision": git_revision()}
    start = time.perf_counter()
    rc = warm(args.scenes, args.integrator, options, record)
    if rc:
        return rc
    record["wall_time_s"] = time.perf_counter() - start
    write_json(args.out, record)
    what = "loaded from the extension" if record["extension"] else "compiled and cached"
    print(f"warmup: kernels {what} in {record['wall_time_s']:.1f} s -> {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
