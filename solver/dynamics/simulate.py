"""Simulate one scene with one reduced model: results/sim/{scene}/{model}.h5.

    /usr/bin/python3 -m solver.dynamics.simulate --scene thesis --model truth
    /usr/bin/python3 -m solver.dynamics.simulate --scene thesis --model static-8 --integrator generalized-alpha --step 1e-5

Everything is validated (scene file, model name, step) before integration.
Output datasets: t (T,) [s], gamma (T, 4) [rad], gamma_dot (T, 4) [rad/s],
q (T, sum D) modal coordinates (optional, --store-modal), energy/kinetic,
energy/potential, energy/total [in lbf], energy/input_work [in lbf] (work of
case motion and motors minus damping, trapezoid at output samples);
attributes: scene, model, integrator, step, steps, wall_time_s, config_hash,
omega_max (the coupled chain's highest frequency at the initial state, which
sets the RK4 limit), modal_omega_max (largest kept modal frequency),
stability_limit, n_modes (4,), created; for ``load-*`` / ``global-*`` models also
load_ranking (the ranking file used) and load_ranking_scene.  Written to a
temporary file and moved into place with os.replace (atomic).

``load-*`` and ``global-*`` models (reduction/models.py) read the scene's load-aware
ranking, ``--load-ranking PATH`` (default results/reduction/load/{scene}.h5, made by
``python -m reduction.load_aware``); a missing file is a one-line error naming it.
"""

import argparse
import hashlib
import json
import os
import sys
import tempfile
import time

import numpy as np

from solver.dynamics import integrators, multibody, scenes
from reduction import models

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def config_hash(scene, spec, options, body_hashes=()):
    payload = {"scene": scene.physics, "model": spec.name,
               "kept": {str(b): np.asarray(v).tolist() for b, v in spec.kept.items()},
               "static": {str(b): list(v) for b, v in spec.static.items()},
               "options": options, "bodies": list(body_hashes)}
    return hashlib.sha256(json.dumps(payload, sort_keys=True, default=str).encode()).hexdigest()[:16]


def scene_problem(chain, scene):
    """multibody.Problem of a chain in a scene (its omega_max: the coupled chain's highest
    frequency at the scene's initial state)."""
    y0, yd0 = scenes.initial_state(scene, chain.n_coordinates)
    return multibody.Problem(chain, case=scene.case, torque=scene.motor_torques, y0=y0, yd0=yd0)


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


def write_result(path, run, prob, attrs, store_modal=False):
    """Write the run atomically (temporary file in the same folder, then os.replace)."""
    import h5py
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    T, U, W = energy_history(prob, run)
    fd, tmp = tempfile.mkstemp(suffix=".h5.tmp", dir=os.path.dirname(os.path.abspath(path)))
    os.close(fd)
    try:
        with h5py.File(tmp, "w") as f:
            f["t"] = run.t
            f["gamma"] = run.y[:, :4]
            f["gamma_dot"] = run.yd[:, :4]
            if store_modal:
                f["q"] = run.y[:, 4:]
                f["q_dot"] = run.yd[:, 4:]
            g = f.create_group("energy")
            g["kinetic"], g["potential"], g["total"], g["input_work"] = T, U, T + U, W
            for k, v in attrs.items():
                f.attrs[k] = v
            for k, v in run.stats.items():
                f.attrs[f"stat_{k}"] = v
        os.chmod(tmp, 0o644)            # mkstemp creates 0600
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return path


def _check_load_ranking(path, rankings, body_data):
    """ValueError (one line) if a load-aware ranking was made from other body files."""
    import json
    stored = rankings[models.POOLED_KEY].get("body_config_hashes") or ""
    current = [str(body_data[b]["attrs"].get("config_hash", "")) for b in models.BODIES]
    if stored and json.loads(stored) != current:
        raise ValueError(f"load-aware ranking {path} was made from other body files (config "
                         f"hashes differ): rerun python -m reduction.load_aware")


class _Parser(argparse.ArgumentParser):
    """Argument errors as one line (no usage block), exit status 2."""

    def error(self, message):
        self.exit(2, f"simulate: {message} (see --help)\n")


def main(argv=None):
    ap = _Parser(
        prog="python -m solver.dynamics.simulate",
        description="Simulate the elastic gimbal chain: one scene, one reduced model "
                    "(docs/dynamics.md; model grammar in reduction/models.py).")
    ap.add_argument("--scene", required=True, help="scene name (config/scenes/NAME.yaml) or path")
    ap.add_argument("--model", required=True,
                    help="truth | rigid | freq-N | xmx-N | xmgmx-N | load-N | global-N | static-N | "
                         "static-xmx-N | ... with N or N,N,N,N and optional @body:loadcase")
    ap.add_argument("--integrator", default=None, choices=integrators.METHODS,
                    help="default rk4 (truth: models.TRUTH_DEFAULT, the converged setting)")
    ap.add_argument("--step", type=float, default=None, help="fixed step [s] (rk4, generalized-alpha)")
    ap.add_argument("--fraction", type=float, default=None,
                    help=f"rk4 step as a fraction of 2.785/omega_max (default "
                         f"{integrators.RK4_DEFAULT_FRACTION})")
    ap.add_argument("--rho-inf", type=float, default=0.9, help="generalized-alpha spectral radius")
    ap.add_argument("--rtol", type=float, default=1e-10, help="dop853 relative tolerance")
    ap.add_argument("--atol", type=float, default=1e-14, help="dop853 absolute tolerance")
    ap.add_argument("--modes-dir", default=os.path.join(ROOT, "results", "modes"))
    ap.add_argument("--reduction-dir", default=os.path.join(ROOT, "results", "reduction"))
    ap.add_argument("--out-dir", default=os.path.join(ROOT, "results", "sim"))
    ap.add_argument("--load-ranking", default=None,
                    help="load-aware ranking file for load-N / global-N models (default "
                         "results/reduction/load/{scene}.h5, python -m reduction.load_aware)")
    ap.add_argument("--store-modal", action="store_true", help="also store q(t), q'(t)")
    args = ap.parse_args(argv)
    try:
        scene = scenes.load_scene(args.scene)
        body_data = {b: models.load_body_file(os.path.join(args.modes_dir, f"body{b}.h5"))
                     for b in models.BODIES}
        if models.needs_reduction_rankings(args.model):
            rankings = models.load_rankings(args.reduction_dir)
        else:       # truth, rigid, freq-*, static-*: no reduction stage needed
            rankings = models.frequency_rankings(body_data)
        load_ranking = None
        if models.needs_load_ranking(args.model):
            load_ranking = args.load_ranking or os.path.join(
                ROOT, "results", "reduction", "load", f"{scene.name}.h5")
            models.load_load_ranking(load_ranking, rankings)
        spec = models.restrict_to_bodies(models.parse_model(args.model, rankings), scene.elastic_bodies)
        if args.integrator is None:
            args.integrator = "rk4"
            if spec.name == "truth" and args.step is None and args.fraction is None:
                cfg = models.truth_default()
                args.integrator, args.fraction = cfg["integrator"], cfg.get("fraction")
                args.rtol, args.atol = cfg.get("rtol", args.rtol), cfg.get("atol", args.atol)
        if args.fraction is not None and not (np.isfinite(args.fraction) and args.fraction > 0):
            raise ValueError(f"--fraction must be a positive number, got {args.fraction}")
        if args.step is not None and not (np.isfinite(args.step) and args.step > 0):
            raise ValueError(f"--step must be a positive number, got {args.step}")
        if load_ranking is not None:
            _check_load_ranking(load_ranking, rankings, body_data)
        chain = models.build_chain(spec, body_data, scene.damping_ratio)
        prob = scene_problem(chain, scene)
        if args.integrator == "rk4" and args.step is not None:
            limit = integrators.rk4_stability_limit(prob.omega_max)
            if args.step > limit:
                raise integrators.StepTooLargeError(
                    f"rk4 step {args.step:.3e} s exceeds the stability limit {limit:.3e} s "
                    f"(coupled omega_max = {prob.omega_max:.4g} rad/s) of model {spec.name!r}")
        options = {"integrator": args.integrator, "step": args.step, "fraction": args.fraction,
                   "rho_inf": args.rho_inf, "rtol": args.rtol, "atol": args.atol}
        chash = config_hash(scene, spec, options,
                            [body_data[b]["attrs"].get("config_hash", "") for b in models.BODIES])
        t0 = time.perf_counter()
        run, prob = run_scene(chain, scene, args.integrator, args.step, args.fraction, args.rho_inf,
                              args.rtol, args.atol, spec.name, problem=prob)
        wall = time.perf_counter() - t0
    except (ValueError, FileNotFoundError, integrators.DivergenceError) as exc:
        print(f"simulate: {exc}", file=sys.stderr)
        return 2
    path = os.path.join(args.out_dir, scene.name, f"{spec.name}.h5")
    attrs = {"scene": scene.name, "model": spec.name, "integrator": run.method, "step": run.step,
             "steps": run.steps, "wall_time_s": wall, "integration_time_s": run.wall_time,
             "config_hash": chash, "omega_max": prob.omega_max,
             "modal_omega_max": chain.omega_max,
             "stability_limit": integrators.rk4_stability_limit(prob.omega_max),
             "n_modes": np.array(chain.n_modes), "units": "in, lbf, s, rad",
             "created": time.strftime("%Y-%m-%dT%H:%M:%S")}
    if load_ranking is not None:
        attrs["load_ranking"] = os.path.abspath(load_ranking)
        attrs["load_ranking_scene"] = rankings[models.POOLED_KEY]["scene"]
    write_result(path, run, prob, attrs, args.store_modal)
    what = (f"(mean step {scene.duration / max(run.steps, 1):.3e} s)" if run.method == "dop853"
            else f"of {run.step:.3e} s")
    print(f"simulate: {path}: {run.steps} {run.method} steps {what} in {wall:.2f} s "
          f"(coupled omega_max {prob.omega_max:.4g} rad/s, RK4 limit "
          f"{integrators.rk4_stability_limit(prob.omega_max):.3e} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
