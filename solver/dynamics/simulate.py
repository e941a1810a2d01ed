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

import numba
import numpy as np

from solver.dynamics import chainfile, exponential, integrators, multibody, scenes, simfile
from solver.dynamics.problem import Problem
from workflow.provenance import versions

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


# The default integrator of every simulation (truth and reduced models alike): the modal
# exponential integrator at its default tolerance (solver.dynamics.exponential,
# docs/exponential.md: E <= 1e-8 against the converged DOP853 on every verified scene).
# The converged reference that referees every error is REFERENCE (dop853 at rtol 1e-10).
DEFAULT_INTEGRATOR = "exponential"
REFERENCE = {"integrator": "dop853", "rtol": 1e-10, "atol": 1e-14}


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


def run_scene(chain, scene, integrator=DEFAULT_INTEGRATOR, step=None, model_name="", problem=None,
              **options):
    """Integrate a chain through a scene; returns (Run, Problem).  options: the integrator's
    own (``integrators.METHOD_OPTIONS``: tol, fraction, rtol, rho_inf, ...)."""
    prob = scene_problem(chain, scene) if problem is None else problem
    run = integrators.integrate(prob, scene.duration, scene.output_interval, method=integrator,
                                step=step, model=model_name, **options)
    return run, prob


def integrator_options(args):
    """The integrator options given on the command line (those left at None dropped)."""
    given = {key: getattr(args, key) for key in integrators.METHOD_OPTIONS if hasattr(args, key)}
    return {k: v for k, v in given.items() if v is not None}


def energy_history(prob, run):
    """(kinetic, potential, input_work) at the output samples (recorded by the
    integrator's monitor when available, else recomputed)."""
    if run.energy and np.all(np.isfinite(run.energy["kinetic"])):
        return run.energy["kinetic"], run.energy["potential"], run.energy["input_work"]
    T = np.array([prob.kinetic_energy(t, y, v) for t, y, v in zip(run.t, run.y, run.yd)])
    U = np.array([prob.potential_energy(y) for y in run.y])
    P = np.array([prob.input_power(t, y, v) for t, y, v in zip(run.t, run.y, run.yd)])
    W = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(run.t))])
    return T, U, W


def platform_attitude(chain, run):
    """The platform's frame in case axes (T, 3, 3) at the outputs of a run
    (``multibody.platform_attitude``; only the columns it reads are built from a modal run)."""
    cols = multibody.attitude_coordinates(chain)
    y = np.zeros((len(run.t), chain.n_coordinates))
    y[:, cols] = run.y[:, cols]
    return multibody.platform_attitude(chain, y)


def positive_number(name):
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
                    help=f"default {DEFAULT_INTEGRATOR} (docs/exponential.md); dop853 at rtol "
                         f"1e-10 is the converged reference, rk4 the thesis's method")
    ap.add_argument("--step", type=positive_number("--step"), default=None,
                    help="fixed step [s] (rk4, generalized-alpha, exponential without --tol)")
    ap.add_argument("--tol", type=positive_number("--tol"), default=None,
                    help=f"exponential: local error tolerance (default {exponential.DEFAULT_TOL:g})")
    ap.add_argument("--relinearise-every", type=positive_number("--relinearise-every"), default=None,
                    help="exponential with --step: re-linearisation interval [s]")
    ap.add_argument("--drift", type=positive_number("--drift"), default=None,
                    help=f"exponential: gimbal-angle drift [rad] that triggers a new basis "
                         f"(default {exponential.DEFAULT_DRIFT:g})")
    ap.add_argument("--order", type=int, default=None,
                    help=f"exponential: Adams order (default {exponential.DEFAULT_ORDER})")
    ap.add_argument("--fraction", type=positive_number("--fraction"), default=None,
                    help=f"rk4 step as a fraction of 2.785/omega_max (default "
                         f"{integrators.RK4_DEFAULT_FRACTION})")
    ap.add_argument("--rho-inf", type=float, default=None,
                    help="generalized-alpha spectral radius (default 0.9)")
    ap.add_argument("--rtol", type=positive_number("--rtol"), default=None,
                    help="dop853 relative tolerance (default 1e-10)")
    ap.add_argument("--atol", type=positive_number("--atol"), default=None,
                    help="dop853 absolute tolerance (default 1e-14)")
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
            args.integrator = DEFAULT_INTEGRATOR
        options = integrator_options(args)
        integrators.check_options(args.integrator, args.step, options)
        prob = scene_problem(chain, scene)
        if args.integrator == "rk4" and args.step is not None:
            limit = integrators.rk4_stability_limit(prob.omega_max)
            if args.step > limit:
                raise integrators.StepTooLargeError(
                    f"rk4 step {args.step:.3e} s exceeds the stability limit {limit:.3e} s "
                    f"(coupled omega_max = {prob.omega_max:.4g} rad/s) of model {model!r}")
        options = {"integrator": args.integrator, "step": args.step, **options}
        chash = config_hash(scene, str(info.get("config_hash", "")), options)
        out = args.out or os.path.join(ROOT, "results", "sim", stem, f"{model}.h5")
        _check_writable(out)
        t0 = time.perf_counter()
        run, prob = run_scene(chain, scene, model_name=model, problem=prob, **options)
        wall = time.perf_counter() - t0
    except (ValueError, FileNotFoundError, integrators.DivergenceError) as exc:
        print(f"simulate: {exc}", file=sys.stderr)
        return 2
    # the coupled chain's highest frequency at the initial state: the exponential integrator's
    # first basis has it; the others computed it for the RK4 bound (Problem.omega_max)
    omega_max = run.stats["coupled_omega_max"] if run.method == "exponential" else prob.omega_max
    attrs = {"scene": scene.name, "model": model, "integrator": run.method, "step": run.step,
             "steps": run.steps, "wall_time_s": wall, "integration_time_s": run.wall_time,
             "config_hash": chash, "model_config_hash": str(info.get("config_hash", "")),
             "omega_max": omega_max, "modal_omega_max": chain.omega_max,
             "stability_limit": integrators.rk4_stability_limit(omega_max),
             "n_modes": np.array(chain.n_modes), "units": "in, lbf, s, rad",
             "created": time.strftime("%Y-%m-%dT%H:%M:%S")}
    for key in ("load_ranking", "load_ranking_scene"):
        if key in info:
            attrs[key] = info[key]
    attrs.update({f"version_{k}": str(v) for k, v in versions().items()})
    attrs["version_numba"] = numba.__version__      # the compiled right-hand side
    simfile.write_sim(out, run, energy_history(prob, run), attrs, args.store_modal,
                      platform_attitude(chain, run))
    what = (f"(mean step {scene.duration / max(run.steps, 1):.3e} s)" if run.method == "dop853"
            else f"of {run.step:.3e} s")
    print(f"simulate: {out}: {run.steps} {run.method} steps {what} in {wall:.2f} s "
          f"(coupled omega_max {omega_max:.4g} rad/s, RK4 limit "
          f"{integrators.rk4_stability_limit(omega_max):.3e} s)")
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
