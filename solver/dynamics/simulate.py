"""Simulate one scene with one reduced-model file: results/sim/{scene}/{model}.h5.

    python -m solver.dynamics.simulate --scene config/scenes/thesis.yaml \
        --model-file results/models/thesis/truth.h5 --out results/sim/thesis/truth.h5
    python -m solver.dynamics.simulate --scene thesis --model static-8 --integrator generalized-alpha --step 1e-5

The reduced-model file (``solver.dynamics.chainfile``, made by ``python -m
reduction.models`` or ``snakemake results/models/{scene}/{model}.h5``) holds the
chain; the scene adds the case motion, torques, initial state and modal damping.
``--model NAME`` alone finds the file at results/models/{scene}/{NAME}.h5 and
writes results/sim/{scene}/{NAME}.h5, {scene} being the scene file's name (never
a field inside it); the workflow passes every path explicitly.

Everything is validated (scene file, model file, step, output folder) before the
integration.  The output is the simulation file of ``solver.dynamics.simfile``
(datasets t, gamma, gamma_dot, energies; attributes scene, model, integrator,
step, steps, wall_time_s, config_hash, omega_max (the coupled chain's highest
frequency at the initial state, which sets the RK4 limit), modal_omega_max,
stability_limit, n_modes, provenance), written atomically.
"""

import argparse
import hashlib
import json
import os
import sys
import time

import numpy as np

from solver.dynamics import chainfile, integrators, multibody, scenes, simfile
from solver.dynamics.problem import Problem
from workflow.provenance import versions

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


# The truth model's default integration (simulate --model truth without --integrator/--step/
# --fraction): chosen so that halving the step changes every gimbal rate on scene thesis by
# E < 1e-10 (results.bench.verify_dynamics; docs/dynamics.md Section 8).
# Measured on the real bodies (thesis, 15 ms): RK4 needs 1/8 of its stability limit (264k steps,
# ~100 s; E(h, h/2) ~ 1e-11, E(h/4, h/2) = 2e-7 at half the limit: the top coupled modes,
# excited by the case's sudden acceleration, are stable but their phase is not resolved), while
# DOP853 at rtol 1e-10 runs near its larger stability limit (21k steps, 12 evaluations each) and
# agrees with that RK4 run to E = 4e-12: the cheaper converged choice.
TRUTH_DEFAULT = {"integrator": "dop853", "rtol": 1e-10, "atol": 1e-14}


def config_hash(scene, model_hash, options):
    """Hash of what a simulation depends on: the scene's physics, the reduced-model file's
    own hash (bodies, kept modes, rankings) and the integrator options (16 hex digits)."""
    payload = {"scene": scene.physics, "model": model_hash, "options": options}
    return hashlib.sha256(json.dumps(payload, sort_keys=True, default=str).encode()).hexdigest()[:16]


def scene_problem(chain, scene):
    """problem.Problem of a chain in a scene (its omega_max: the coupled chain's highest
    frequency at the scene's initial state)."""
    y0, yd0 = scenes.initial_state(scene, chain.n_coordinates)
    return Problem(chain, case=scene.case, torque=scene.motor_torques, y0=y0, yd0=yd0)


def run_scene(chain, scene, method="rk4", step=None, fraction=None, rho_inf=0.9, rtol=1e-10,
              atol=1e-14, model_name="", problem=None):
    """Integrate a chain through a scene; returns (Run, Problem)."""
    prob = scene_problem(chain, scene) if problem is None else problem
    run = integrators.integrate(prob, scene.duration, scene.output_interval, method=method,
                                step=step, fraction=fraction, rho_inf=rho_inf, rtol=rtol, atol=atol,
                                model=model_name)
    return run, prob


def energy_history(prob, run):
    """(kinetic, potential, input_work) at the output samples (recorded by the
    integrator's monitor when available, else recomputed)."""
    if run.energy and np.all(np.isfinite(run.energy["kinetic"])):
        return run.energy["kinetic"], run.energy["potential"], run.energy["input_work"]
    chain = prob.chain
    T = np.array([multibody.kinetic_energy(chain, y, v, t, prob.case)
                  for t, y, v in zip(run.t, run.y, run.yd)])
    U = np.array([multibody.potential_energy(chain, y) for y in run.y])
    P = np.array([prob.input_power(t, y, v) for t, y, v in zip(run.t, run.y, run.yd)])
    W = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(run.t))])
    return T, U, W


def _positive(name):
    """argparse type: a positive finite float; a negative value is read as a value, then refused."""
    def parse(text):
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
        if not (np.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"{name} must be a positive number, got {text!r}")
        return value
    return parse


class _Parser(argparse.ArgumentParser):
    """Argument errors as one line (no usage block), exit status 2."""

    def error(self, message):
        self.exit(2, f"simulate: {message} (see --help)\n")


def _scene_stem(arg):
    return os.path.splitext(os.path.basename(str(arg)))[0]


def main(argv=None):
    ap = _Parser(
        prog="python -m solver.dynamics.simulate",
        description="Simulate the elastic gimbal chain: one scene, one reduced-model file "
                    "(docs/dynamics.md; the file is made by python -m reduction.models or by "
                    "snakemake results/models/SCENE/MODEL.h5).")
    ap.add_argument("--scene", required=True, help="scene name (config/scenes/NAME.yaml) or path")
    ap.add_argument("--model-file", help="reduced-model file (default results/models/SCENE/MODEL.h5)")
    ap.add_argument("--model", help="model name, to find the default model file and output")
    ap.add_argument("--out", help="simulation file to write (default results/sim/SCENE/MODEL.h5)")
    ap.add_argument("--integrator", default=None, choices=integrators.METHODS,
                    help="default rk4 (truth: TRUTH_DEFAULT, the converged setting)")
    ap.add_argument("--step", type=_positive("--step"), default=None,
                    help="fixed step [s] (rk4, generalized-alpha)")
    ap.add_argument("--fraction", type=_positive("--fraction"), default=None,
                    help=f"rk4 step as a fraction of 2.785/omega_max (default "
                         f"{integrators.RK4_DEFAULT_FRACTION})")
    ap.add_argument("--rho-inf", type=float, default=0.9, help="generalized-alpha spectral radius")
    ap.add_argument("--rtol", type=float, default=1e-10, help="dop853 relative tolerance")
    ap.add_argument("--atol", type=float, default=1e-14, help="dop853 absolute tolerance")
    ap.add_argument("--store-modal", action="store_true", help="also store q(t), q'(t)")
    try:
        args = ap.parse_args(argv)
        if args.model_file is None and args.model is None:
            ap.error("give --model-file FILE or --model NAME")
    except SystemExit as exc:       # the one-line message is printed; in process, return the status
        return exc.code
    stem = _scene_stem(args.scene)
    model_file = args.model_file or os.path.join(ROOT, "results", "models", stem, f"{args.model}.h5")
    try:
        scene = scenes.load_scene(args.scene)
        chain, info = chainfile.read_chain(model_file, scene.damping_ratio)
        model = str(info.get("model", ""))
        if args.model is not None and args.model != model:
            raise ValueError(f"{model_file} holds model {model!r}, not {args.model!r}")
        if args.integrator is None:
            args.integrator = "rk4"
            if model == "truth" and args.step is None and args.fraction is None:
                cfg = dict(TRUTH_DEFAULT)
                args.integrator, args.fraction = cfg["integrator"], cfg.get("fraction")
                args.rtol, args.atol = cfg.get("rtol", args.rtol), cfg.get("atol", args.atol)
        prob = scene_problem(chain, scene)
        if args.integrator == "rk4" and args.step is not None:
            limit = integrators.rk4_stability_limit(prob.omega_max)
            if args.step > limit:
                raise integrators.StepTooLargeError(
                    f"rk4 step {args.step:.3e} s exceeds the stability limit {limit:.3e} s "
                    f"(coupled omega_max = {prob.omega_max:.4g} rad/s) of model {model!r}")
        options = {"integrator": args.integrator, "step": args.step, "fraction": args.fraction,
                   "rho_inf": args.rho_inf, "rtol": args.rtol, "atol": args.atol}
        chash = config_hash(scene, str(info.get("config_hash", "")), options)
        out = args.out or os.path.join(ROOT, "results", "sim", stem, f"{model}.h5")
        _check_writable(out)
        t0 = time.perf_counter()
        run, prob = run_scene(chain, scene, args.integrator, args.step, args.fraction, args.rho_inf,
                              args.rtol, args.atol, model, problem=prob)
        wall = time.perf_counter() - t0
    except (ValueError, FileNotFoundError, integrators.DivergenceError) as exc:
        print(f"simulate: {exc}", file=sys.stderr)
        return 2
    attrs = {"scene": scene.name, "model": model, "integrator": run.method, "step": run.step,
             "steps": run.steps, "wall_time_s": wall, "integration_time_s": run.wall_time,
             "config_hash": chash, "model_config_hash": str(info.get("config_hash", "")),
             "omega_max": prob.omega_max, "modal_omega_max": chain.omega_max,
             "stability_limit": integrators.rk4_stability_limit(prob.omega_max),
             "n_modes": np.array(chain.n_modes), "units": "in, lbf, s, rad",
             "created": time.strftime("%Y-%m-%dT%H:%M:%S")}
    for key in ("load_ranking", "load_ranking_scene"):
        if key in info:
            attrs[key] = info[key]
    attrs.update({f"version_{k}": str(v) for k, v in versions().items()})
    simfile.write_sim(out, run, energy_history(prob, run), attrs, args.store_modal)
    what = (f"(mean step {scene.duration / max(run.steps, 1):.3e} s)" if run.method == "dop853"
            else f"of {run.step:.3e} s")
    print(f"simulate: {out}: {run.steps} {run.method} steps {what} in {wall:.2f} s "
          f"(coupled omega_max {prob.omega_max:.4g} rad/s, RK4 limit "
          f"{integrators.rk4_stability_limit(prob.omega_max):.3e} s)")
    return 0


def _check_writable(path):
    """ValueError (one line) before the integration if ``path`` could not be written: its
    folder, or the nearest existing folder above it, must be writable.  Nothing is created
    here (the folder appears only with the file, so a failed run leaves nothing behind)."""
    folder = os.path.dirname(os.path.abspath(path))
    existing = folder
    while not os.path.isdir(existing):
        if os.path.exists(existing):
            raise ValueError(f"cannot create the output folder {folder}: {existing} is a file")
        existing = os.path.dirname(existing)
    if not os.access(existing, os.W_OK):
        raise ValueError(f"output folder {existing} is not writable")


if __name__ == "__main__":
    sys.exit(main())
