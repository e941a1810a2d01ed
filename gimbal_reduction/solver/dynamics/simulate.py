"""Simulate one scene with one reduced-model file: results/sim/{scene}/{model}.h5.

    python -m gimbal_reduction.solver.dynamics.simulate --scene config/scenes/thesis.yaml \
        --model-file results/models/thesis/truth.h5 --out results/sim/thesis/truth.h5
    python -m gimbal_reduction.solver.dynamics.simulate --scene thesis --model static-8 --integrator generalized-alpha --step 1e-5

The reduced-model file (``gimbal_reduction.solver.dynamics.chainfile``, made by ``python -m
gimbal_reduction.reduction.models`` or ``snakemake results/models/{scene}/{model}.h5``) holds the
chain; the scene adds the case motion, torques, initial state and modal damping.
``--model NAME`` alone finds the file at results/models/{scene}/{NAME}.h5 and
writes results/sim/{scene}/{NAME}.h5, {scene} being the scene file's name (never
a field inside it); the workflow passes every path explicitly.

Everything is validated (scene file, model file, step, output folder) before the
integration.  The output is the simulation file of ``gimbal_reduction.solver.dynamics.simfile``
(datasets t, gamma, gamma_dot, energies; attributes scene, model, integrator,
step, steps, config_hash, omega_max (the coupled chain's highest
frequency at the initial state, which sets the RK4 limit), modal_omega_max,
stability_limit, n_modes, provenance; the exponential integrator's options as
stat_exponential_<option> among its statistics stat_*), written atomically.  Timings: see
``simfile``.
"""

import argparse
import hashlib
import json
import os
import sys
import time

import numba
import numpy as np
from numba.core import event

from gimbal_reduction.solver.bodydata import BODIES
from gimbal_reduction.solver.dynamics import chainfile, exponential, integrators, multibody, scenes, simfile
from gimbal_reduction.solver.dynamics.kernels import extension
from gimbal_reduction.solver.dynamics.problem import Problem
from gimbal_reduction.workflow import cli
from gimbal_reduction.workflow import config as cfgmod
from gimbal_reduction.workflow.provenance import versions

ROOT = str(cfgmod.ROOT)   # the project folder (workflow.config.project_dir)


# The default integrator of every simulation (truth and reduced models alike): the modal
# exponential integrator at its default tolerance (gimbal_reduction.solver.dynamics.exponential,
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
    own (``integrators.METHOD_OPTIONS``: tol, fraction, rtol, rho_inf, ...).  The exponential
    integrator without a tolerance or a fixed step takes the scene's ``exponential_tolerance``
    if it states one (``scenes``), else its default."""
    prob = scene_problem(chain, scene) if problem is None else problem
    options = scene_options(scene, integrator, step, options)
    run = integrators.integrate(prob, scene.duration, scene.output_interval, method=integrator,
                                step=step, model=model_name, **options)
    return run, prob


def scene_options(scene, integrator, step, options):
    """The integrator options with the scene's exponential tolerance added where it applies
    (exponential, neither tol nor a fixed step given; ``run_scene``)."""
    if (integrator == "exponential" and step is None and options.get("tol") is None
            and scene.exponential_tolerance is not None):
        return {**options, "tol": scene.exponential_tolerance}
    return options


def integrator_options(args):
    """The integrator options given on the command line (those left at None dropped)."""
    given = {key: getattr(args, key) for key in integrators.METHOD_OPTIONS if hasattr(args, key)}
    return {k: v for k, v in given.items() if v is not None}


def energy_history(prob, run):
    """(kinetic, potential, input_work) at the output samples (recorded by the
    integrator's monitor when available, else recomputed)."""
    if run.energy and np.all(np.isfinite(run.energy["kinetic"])):
        return run.energy["kinetic"], run.energy["potential"], run.energy["input_work"]
    T, U, P = prob.energy_history(run.t, run.y, run.yd)
    W = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(run.t))])
    return T, U, W


def platform_attitude(chain, run):
    """The platform's frame in case axes (T, 3, 3) at the outputs of a run
    (``multibody.platform_attitude``): from the 13 linear functionals of the state it reads
    (``multibody.attitude_functionals``), taken from a modal run's coordinates per basis
    (``exponential.ModalStates.functionals``) without forming its (T, n) states."""
    L = multibody.attitude_functionals(chain)
    y = run.y
    f = y.functionals(L) if hasattr(y, "functionals") else np.asarray(y, float) @ L.T
    return multibody.attitude_of_functionals(chain, f)


positive_number = cli.positive_number        # (argparse type; kept for callers of this module)


class CompileNotice(event.Listener):
    """Says once, on stdout, that a kernel is being compiled, when Numba starts compiling one that
    its on-disk cache does not hold (the event ``numba:compile`` fires on a cache miss only): the
    first use of an integrator path (the damped RK4 loop, DOP853's right-hand side) compiles for
    minutes without another word otherwise.  Measured cold compiles, 2 cores: the workflow's
    kernel set 85 CPU-s (rule kernels), the damped RK4 kernel 6 min 55 s."""

    def __init__(self, what):
        self.what, self.said = what, False

    def on_start(self, ev):
        if not self.said:
            self.said = True
            print(f"simulate: compiling {self.what} (first use: not in Numba's cache; 1-7 min, "
                  f"once per machine and code version)", flush=True)

    def on_end(self, ev):
        pass


def kernel_path(integrator, scene):
    """The words for the kernels a run uses: its integrator, damped or not."""
    return f"the {'damped ' if scene.damping_ratio > 0 else ''}{integrator} kernels"

# Guards before the work (an explicit option lifts each): integration steps, output samples and
# the memory the outputs take.  The 15 ms thesis scene takes ~60 exponential steps or ~1e5 RK4
# steps and 6,001 samples; the long scene (1 s) 40,001 samples.
MAX_STEPS = 20_000_000
MAX_SAMPLES = 1_000_000
MAX_OUTPUT_GIB = 4.0


def estimated_steps(scene, integrator, step, options, prob):
    """(steps, step [s]) a fixed-step run will take, or (None, None) when the step is chosen by
    error control (exponential without --step, dop853).  RK4 without --step: its fraction of
    the stability limit (``integrators.rk4_limit``, computed here: ~7 small eigenproblems)."""
    if scene.duration <= 0:
        return 0, step
    if integrator == "rk4":
        h = step if step is not None else \
            options.get("fraction", integrators.RK4_DEFAULT_FRACTION) * integrators.rk4_limit(prob)
    elif integrator == "generalized-alpha":
        h = step if step is not None else scene.output_interval
    elif integrator == "exponential" and step is not None:
        h = step
    else:
        return None, None
    if not (np.isfinite(h) and h > 0):
        return None, None
    # the fixed-step methods take whole steps per output interval
    per_interval = max(int(np.ceil(scene.output_interval / h - 1e-9)), 1)
    return per_interval * max(int(round(scene.duration / scene.output_interval)), 1), h


def rhs_cost(prob, calls=20):
    """Seconds per right-hand-side evaluation of a problem (median of ``calls``)."""
    times = []
    for _ in range(calls):
        t0 = time.perf_counter()
        prob.rhs(0.0, prob.y0, prob.yd0)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def check_size(scene, chain, integrator, step, options, prob, max_steps, max_samples, model_file):
    """ValueError (one line, naming the scene, the limit and the option that lifts it) before
    the work if the run would take more than ``max_steps`` steps, write more than
    ``max_samples`` output samples or hold more than MAX_OUTPUT_GIB of outputs."""
    samples = int(round(scene.duration / scene.output_interval)) + 1 if scene.duration > 0 else 1
    gib = samples * (2 * chain.n_coordinates + 16) * 8 / 2 ** 30
    if samples > max_samples:
        raise ValueError(f"scene {scene.name}: {samples:.3g} output samples ({scene.duration:g} s every "
                         f"{scene.output_interval:g} s, ~{gib:.3g} GiB) exceed the limit {max_samples:.3g} "
                         f"(--max-samples N lifts it; or a longer output_interval)")
    if gib > MAX_OUTPUT_GIB and samples <= max_samples and max_samples == MAX_SAMPLES:
        raise ValueError(f"scene {scene.name}: the outputs would take ~{gib:.3g} GiB (limit "
                         f"{MAX_OUTPUT_GIB:g} GiB; --max-samples N lifts it)")
    steps, h = estimated_steps(scene, integrator, step, options, prob)
    if steps is not None and steps > max_steps:
        evaluations = {"rk4": 4, "generalized-alpha": 3, "exponential": 2}.get(integrator, 4)
        seconds = steps * evaluations * rhs_cost(prob)
        raise ValueError(f"{integrator} at step {h:.3g} s on scene {scene.name} ({scene.duration:g} s) "
                         f"takes ~{steps:.3g} steps (~{_duration_text(seconds)} for model file "
                         f"{model_file}), above the limit {max_steps:.3g} steps (--max-steps N lifts it; "
                         f"or a longer --step)")
    return steps, h


def _duration_text(seconds):
    for unit, size in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


def _scene_stem(arg):
    return os.path.splitext(os.path.basename(str(arg)))[0]


def build_parser():
    ap = cli.OneLineParser(
        prog="simulate",
        description="Simulate the elastic gimbal chain: one scene, one reduced-model file "
                    "(docs/dynamics.md; the file is made by python -m gimbal_reduction.reduction.models or by "
                    "snakemake results/models/SCENE/MODEL.h5).")
    ap.add_argument("--scene", required=True, help="scene name (config/scenes/NAME.yaml) or path")
    ap.add_argument("--model-file", help="reduced-model file (default results/models/SCENE/MODEL.h5)")
    ap.add_argument("--model", help="model name, to find the default model file and output")
    ap.add_argument("--out", help="simulation file to write (default results/sim/SCENE/MODEL.h5)")
    cli.add_config_option(ap, "the reduced model's body files must have been made from it "
                              "(their config hashes)")
    ap.add_argument("--no-config-check", action="store_true",
                    help="a model file made from no body files (a synthetic chain: the kernels' "
                         "warm-up): skip the check against --config")
    ap.add_argument("--integrator", default=None, choices=integrators.METHODS,
                    help=f"default {DEFAULT_INTEGRATOR} (docs/exponential.md); dop853 at rtol "
                         f"1e-10 is the converged reference, rk4 the thesis's method")
    ap.add_argument("--step", type=positive_number("--step"), default=None,
                    help="fixed step [s] (rk4, generalized-alpha, exponential without --tol)")
    ap.add_argument("--tol", type=positive_number("--tol"), default=None,
                    help=f"exponential: local error tolerance (default {exponential.DEFAULTS.tol:g})")
    ap.add_argument("--relinearise-every", type=positive_number("--relinearise-every"), default=None,
                    help="exponential with --step: re-linearisation interval [s]")
    ap.add_argument("--drift", type=positive_number("--drift"), default=None,
                    help=f"exponential: gimbal-angle drift [rad] that triggers a new basis "
                         f"(default {exponential.DEFAULTS.drift:g})")
    ap.add_argument("--order", type=cli.positive_int("--order"), default=None,
                    help=f"exponential: Adams order (default {exponential.DEFAULTS.order})")
    ap.add_argument("--fraction", type=positive_number("--fraction"), default=None,
                    help=f"rk4 step as a fraction of its stability limit (default "
                         f"{integrators.RK4_DEFAULT_FRACTION}; at most 1)")
    ap.add_argument("--rho-inf", type=_unit_interval, default=None,
                    help="generalized-alpha spectral radius in [0, 1] (default 0.9)")
    ap.add_argument("--rtol", type=positive_number("--rtol"), default=None,
                    help="dop853 relative tolerance (default 1e-10)")
    ap.add_argument("--atol", type=positive_number("--atol"), default=None,
                    help="dop853 absolute tolerance (default 1e-14)")
    ap.add_argument("--max-steps", type=cli.positive_int("--max-steps"), default=MAX_STEPS,
                    help=f"refuse a fixed-step run estimated above this many steps (default {MAX_STEPS:g})")
    ap.add_argument("--max-samples", type=cli.positive_int("--max-samples"), default=MAX_SAMPLES,
                    help=f"refuse a scene with more output samples (default {MAX_SAMPLES:g}, and "
                         f"{MAX_OUTPUT_GIB:g} GiB of outputs)")
    ap.add_argument("--store-modal", action="store_true", help="also store q(t), q'(t)")
    ap.add_argument("--no-energy", action="store_true",
                    help="leave the energy history out of the file (one right-hand side and the case "
                         "power per output sample: as long as the run itself on a reduced model of "
                         "the 1 s scene long)")
    return ap


def _unit_interval(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--rho-inf must be a number, got {text!r}") from None
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"--rho-inf must lie in [0, 1], got {text!r}")
    return value


def _check_conflicts(args):
    """ValueError (one line) for options that contradict each other."""
    if args.step is not None and args.fraction is not None:
        raise ValueError("give --step or --fraction (the rk4 step as a fraction of its stability "
                         "limit), not both")
    if args.fraction is not None and args.fraction > 1:
        raise ValueError(f"--fraction {args.fraction:g} is beyond the rk4 stability limit (at most 1)")


def main(argv=None):
    ap = build_parser()
    try:
        args = ap.parse_args(cli.values_joined(sys.argv[1:] if argv is None else argv, ap))
        if args.model_file is None and args.model is None:
            ap.error("give --model-file FILE or --model NAME")
    except SystemExit as exc:       # the one-line message is printed; in process, return the status
        return exc.code
    stem = _scene_stem(args.scene)
    model_file = args.model_file or os.path.join(ROOT, "results", "models", stem, f"{args.model}.h5")
    try:
        _check_conflicts(args)
        scene = scenes.load_scene(args.scene)
        if args.out is not None:
            cli.check_writable(args.out)
        chain, info = chainfile.read_chain(model_file, scene.damping_ratio)
        model = str(info.get("model", ""))
        check_identity(model_file, info, args.model, args.out, scene)
        out = args.out or os.path.join(ROOT, "results", "sim", stem, f"{model}.h5")
        cli.check_writable(out)
        if not args.no_config_check:
            chainfile.check_body_hashes(model_file, info, expected_body_hashes(args.config))
        if args.integrator is None:
            args.integrator = DEFAULT_INTEGRATOR
        options = scene_options(scene, args.integrator, args.step, integrator_options(args))
        integrators.check_options(args.integrator, args.step, options)
        prob = scene_problem(chain, scene)
        check_size(scene, chain, args.integrator, args.step, options, prob, args.max_steps,
                   args.max_samples, model_file)
        if args.integrator == "rk4" and args.step is not None:
            limit = integrators.rk4_limit(prob)
            if args.step > limit:
                raise integrators.StepTooLargeError(
                    f"rk4 step {args.step:.3e} s exceeds the stability limit "
                    f"{integrators.rk4_limit_reason(prob)} of model {model!r}")
        options = {"integrator": args.integrator, "step": args.step, **options}
        chash = config_hash(scene, str(info.get("config_hash", "")), options)
        t0 = time.perf_counter()
        with event.install_listener("numba:compile", CompileNotice(kernel_path(args.integrator, scene))):
            run, prob = run_scene(chain, scene, model_name=model, problem=prob, **options)
        wall = time.perf_counter() - t0
    except (ValueError, FileNotFoundError, integrators.DivergenceError) as exc:
        print(f"simulate: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    except exponential.ExponentialError as exc:
        # the default integrator stops where it cannot go on (a damped bank it cannot diagonalise,
        # a step falling to nothing): one line, with the scene and the integrators that run any scene
        print(f"simulate: {' '.join(str(exc).split())} (scene {scene.name}, damping_ratio "
              f"{scene.damping_ratio:g}; --integrator dop853 or rk4 runs it)", file=sys.stderr)
        return 2
    # the coupled chain's highest frequency at the initial state: the exponential integrator's
    # first basis has it; the others computed it for the RK4 bound (Problem.omega_max)
    omega_max = run.stats["coupled_omega_max"] if run.method == "exponential" else prob.omega_max
    attrs = {"scene": scene.name, "model": model, "integrator": run.method, "step": run.step,
             "steps": run.steps, "wall_time_s": wall, "integration_time_s": run.wall_time,
             "kernel_load_s": run.kernel_load_time,
             "kernels": "extension" if extension.attached() else "jit",
             "config_hash": chash, "model_config_hash": str(info.get("config_hash", "")),
             "omega_max": omega_max, "modal_omega_max": chain.omega_max,
             "stability_limit": integrators.rk4_stability_limit(omega_max),
             "n_modes": np.array(chain.n_modes), "units": "in, lbf, s, rad",
             "created": time.strftime("%Y-%m-%dT%H:%M:%S")}
    for key in ("load_ranking", "load_ranking_scene", "body_config_hashes"):
        if key in info:
            attrs[key] = info[key]
    attrs.update({f"version_{k}": str(v) for k, v in versions().items()})
    attrs["version_numba"] = numba.__version__      # the compiled right-hand side
    try:
        energies = None if args.no_energy else energy_history(prob, run)
        simfile.write_sim(out, run, energies, attrs, args.store_modal,
                          platform_attitude(chain, run))
    except OSError as exc:
        print(f"simulate: {cli.write_failure(out, exc)}", file=sys.stderr)
        return 2
    what = (f"(mean step {scene.duration / max(run.steps, 1):.3e} s)" if run.method == "dop853"
            else f"of {run.step:.3e} s")
    print(f"simulate: {out}: {run.steps} {run.method} steps {what} in {wall:.2f} s "
          f"(coupled omega_max {omega_max:.4g} rad/s, RK4 limit "
          f"{integrators.rk4_stability_limit(omega_max):.3e} s)")
    return 0


def check_identity(model_file, info, model=None, out=None, scene=None):
    """ValueError (one line) unless the reduced-model file is the one its target expects: the
    model ``model`` (--model), or, in the workflow's layout where the model file and the output
    share their name (results/models/{scene}/{model}.h5 -> results/sim/{scene}/{model}.h5), the
    model that name says, made for ``scene`` when its folder is the scene's.  A freq-10 file copied
    over freq-2.h5 is refused, not simulated as freq-2."""
    held = str(info.get("model", ""))
    stem = _scene_stem(model_file)
    named = model if model is not None else (stem if out is not None and _scene_stem(out) == stem else None)
    if named is not None and named != held:
        raise ValueError(f"{model_file} holds model {held!r}, not {named!r}"
                         + (" (its target's name: a file copied over another model's?)" if model is None else "")
                         + f": remake it: snakemake --cores 2 --forcerun {model_file}")
    folder = os.path.basename(os.path.dirname(os.path.abspath(str(model_file))))
    made_for = str(info.get("scene", ""))
    if scene is not None and named is not None and folder == scene.name and made_for and made_for != scene.name:
        raise ValueError(f"{model_file} was made for scene {made_for!r}, not {scene.name!r} (its "
                         f"folder's): remake it: snakemake --cores 2 --forcerun {model_file}")


def expected_body_hashes(config_path):
    """{body: config_hash} the configuration file ``config_path`` gives the body files."""
    config = cfgmod.load_config(config_path)
    return {b: cfgmod.inputs_hash(cfgmod.body_inputs(config, b)) for b in BODIES}


def _check_writable(path):
    """ValueError (one line) before the integration if ``path`` could not be written
    (``gimbal_reduction.workflow.cli.check_writable``)."""
    cli.check_writable(path)


if __name__ == "__main__":
    sys.exit(main())
