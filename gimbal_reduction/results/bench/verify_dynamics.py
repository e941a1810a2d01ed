"""Verification and benchmark of the dynamics stage on the real bodies.

    python -m gimbal_reduction.results.bench.verify_dynamics --bodies results/modes/body{2,3,4,5}.h5 \\
        --reductions results/reduction/body{2,3,4,5}.h5 \\
        --verification results/verification/dynamics.json --benchmark results/benchmarks/dynamics.json

dynamics.json: every check as {name, value, tolerance, passed, details}:

* oracle agreement: M(y), f(y, y', t) and y'' of small synthetic chains against
  the JAX oracle (results/bench/oracle.Oracle: the Lagrangian from nodal
  masses, differentiated by JAX, no modal integral); without JAX a reduced
  version (compiled vs NumPy reference path, articulated-body vs dense solve)
  runs and the details say so.  On the real bodies: compiled right-hand side vs
  the NumPy reference, articulated-body solve vs dense solve.
* scene ``free`` on the real bodies (small mode count, ``CONSERVATION_MODEL``):
  energy and axial angular momentum drift over 1e5 RK4 steps at a tenth of the
  stability limit.
* RK4 observed order on the real bodies (``thesis`` scene, small model).
* truth convergence on ``thesis``: the truth model at its default step and at
  half of it, E (thesis eq. 3.53) of every gimbal rate < 1e-10; with
  ``--convergence-reference`` the default (the converged DOP853 file) against
  the exponential integrator at a tight tolerance instead, a second method
  whose own error is independent of DOP853's (same bound).
* rigid-limit closed forms: case spin about the outer drive axis (real
  elastic bodies), motor spin-up (real mass properties, principal-axis
  idealisation).
* generalised-alpha accuracy against the converged truth (measured E, and its
  ratio on halving the step).
* bad input: one-line errors before integration, on the real data.

benchmarks/dynamics.json: wall times (median of ``--repeats`` runs) of the
truth model on ``thesis`` with each integrator, with step, steps taken and E
against the converged truth, and the software versions; with ``--runs-from`` the untimed RK4 and
generalised-alpha rows are the Pareto benchmark's runs of the same setting (``pareto_truth_rows``).
"""

import argparse
import contextlib
import io
import os
import sys
import time
from types import SimpleNamespace

import numpy as np

from gimbal_reduction.solver.dynamics.error_measure import error_measure
from gimbal_reduction.solver.dynamics import checks as dc
from gimbal_reduction.solver.dynamics import exponential, integrators, linearized, multibody, scenes, simulate
from gimbal_reduction.solver.dynamics.problem import Problem, make_rhs
from gimbal_reduction.reduction import models
from gimbal_reduction.solver import bodyconfig
from gimbal_reduction.results.bench.oracle import Oracle, jax_available, synthetic_chain
from gimbal_reduction.results.bench.pareto import run_budget
from gimbal_reduction.results.study.tables import RATE_COLUMNS
from gimbal_reduction.solver.dynamics.simfile import mismatches, read_sim
from gimbal_reduction.workflow.progress import Progress
from gimbal_reduction.workflow.provenance import check_record, provenance, versions, write_json

CONSERVATION_MODEL = "freq-2"     # real bodies, 2 modes each: 1e5 RK4 steps in seconds
ORDER_MODEL = "freq-2"
GA_STEP = 1.0e-5                  # generalised-alpha step for the truth benchmark [s]
DOP853_RTOL = 1.0e-10


def _check(name, value, tolerance, passed=None, **details):
    return check_record(str(name), value, tolerance, passed, details=details)


def _from_tuple(res, **details):
    """A record of gimbal_reduction.solver.dynamics.checks with this run's details nested under 'details'."""
    return {**res, "details": details}


def rate_error(run, ref):
    """Largest E (thesis eq. 3.53) over the four gimbal rates of run against ref (same outputs)."""
    return float(np.max(error_measure(ref.t, ref.yd[:, :4], run.yd[:, :4])))


# ----------------------------------------------------------------- the checks
def oracle_checks(real_chain, real_chains=()):
    out = []
    chain, datas = synthetic_chain(seed=3, n_modes=(3, 2, 2, 2), damping_ratio=0.02)
    rng = np.random.default_rng(11)
    torque = np.array([0.3, -0.2, 0.1, 0.05])
    if jax_available():
        oracle = Oracle(datas, axis=(0.3, -0.5, 0.8), amp=1.3, freq=2.0, phase=0.4, omega0=0.7,
                        damping_ratio=0.02)
        case = oracle.case_motion()
        worst = {"M": 0.0, "f": 0.0, "a": 0.0}
        for _ in range(3):
            n = chain.n_coordinates
            y = np.concatenate([rng.uniform(-np.pi, np.pi, 4), 0.02 * rng.normal(size=n - 4)])
            yd = np.concatenate([rng.normal(size=4), 0.4 * rng.normal(size=n - 4)])
            t = rng.uniform(0, 1)
            Mo, fo = oracle.equations(y, yd, t, torque)
            worst["M"] = max(worst["M"], dc.relative_difference(multibody.mass_matrix(chain, y), Mo))
            worst["f"] = max(worst["f"], dc.relative_difference(
                multibody.generalized_force(chain, y, yd, t, case, torque), fo))
            fast = make_rhs(chain, case, torque)
            worst["a"] = max(worst["a"], dc.relative_difference(fast(t, y, yd), np.linalg.solve(Mo, fo)))
        what = ("synthetic chain (shells with rotation DOFs, consistent and lumped mass, damping 2%, "
                "case about a skew axis, torques), 3 random states; JAX oracle")
        out += [_check("oracle: mass matrix M(y)", worst["M"], 1e-10, data=what),
                _check("oracle: generalised force f(y, y', t)", worst["f"], 1e-10, data=what),
                _check("oracle: accelerations of the compiled right-hand side", worst["a"], 1e-10,
                       data=what)]
    else:
        case = multibody.CaseMotion(amplitude=(1.0, 0.3, -0.2), frequency=(2.0, 1.0, 0.0))
        fast = make_rhs(chain, case, torque, fast=True)
        ref = make_rhs(chain, case, torque, fast=False)
        n = chain.n_coordinates
        y = np.concatenate([rng.uniform(-3, 3, 4), 0.02 * rng.normal(size=n - 4)])
        yd = rng.normal(size=n)
        out.append(_check("oracle (REDUCED: JAX not installed): compiled vs reference right-hand side",
                          dc.relative_difference(fast(0.3, y, yd), ref(0.3, y, yd)), 1e-10,
                          data="synthetic chain; the JAX oracle did not run (JAX missing)"))
    # real bodies: compiled path vs NumPy reference path, articulated-body vs dense solve
    rng = np.random.default_rng(5)
    n = real_chain.n_coordinates
    case = multibody.CaseMotion(amplitude=(1.0, 0.3, -0.2), frequency=(2.0, 1.0, 0.0), omega0=(0.1, 0, 0))
    y = np.concatenate([rng.uniform(-3, 3, 4), 1e-4 * rng.normal(size=n - 4)])
    yd = np.concatenate([rng.normal(size=4), 1e-1 * rng.normal(size=n - 4)])
    fast = make_rhs(real_chain, case, torque, fast=True)
    ref = make_rhs(real_chain, case, torque, fast=False)
    out.append(_check("real bodies: compiled vs NumPy reference accelerations",
                      dc.relative_difference(fast(0.2, y, yd), ref(0.2, y, yd)), 1e-10,
                      data=f"model {real_chain.name!r}, random state"))
    # M(y) of the real chain is ill-conditioned (modes nearly spanning the rigid rotation about
    # the drive axes: the articulated inertia about a joint is J_xx (1 - sum H_x^2 / J_xx), with
    # sum H_x^2 / J_xx up to 0.9999): any solve has a forward error ~ cond(M) eps.  Compare the
    # articulated-body accelerations with a dense LU solve at a thesis-like state, tolerance
    # 10 cond(M) eps (the forward-error bound of a backward-stable solve).
    for chain in real_chains:
        sc = scenes.load_scene("thesis")
        n = chain.n_coordinates
        y = np.zeros(n)
        y[:4] = sc.initial_angles
        y[4:] = 1e-7 * rng.normal(size=n - 4)
        yd = np.zeros(n)
        yd[:4] = [1e-4, 1e-3, 1e-2, 1e-3]
        yd[4:] = 1e-4 * rng.normal(size=n - 4)
        f = multibody.generalized_force(chain, y, yd, 3e-3, sc.case)
        M = linearized.mass_matrix_fast(chain, y)
        a_dense = np.linalg.solve(M, f)
        a_fast = make_rhs(chain, sc.case)(3e-3, y, yd)
        cond = float(np.linalg.cond(M))
        out.append(_check(f"real bodies ({chain.name}): articulated-body accelerations vs dense LU solve",
                          dc.relative_difference(a_fast, a_dense), 10 * cond * np.finfo(float).eps,
                          condition_number=cond,
                          gimbal_accelerations_difference=dc.relative_difference(a_fast[:4], a_dense[:4]),
                          note="tolerance 10 cond(M) eps: both solves carry ~cond eps forward error"))
    return out


def conservation_checks(body_data, rankings):
    chain = models.build_chain(models.model_spec(CONSERVATION_MODEL, rankings), body_data)
    scene = scenes.load_scene("free")
    y0, yd0 = scenes.initial_state(scene, chain.n_coordinates)
    t0 = time.perf_counter()
    res = dc.conservation("free (real bodies)", chain, y0, yd0, n_steps=100_000, fraction=0.1, tol=1e-9)
    wall = time.perf_counter() - t0
    w = linearized.coupled_omega_max(chain, y0)
    det = dict(data=f"real bodies, model {CONSERVATION_MODEL!r} (modes per body {chain.n_modes}), "
                    f"scene 'free' initial state", coupled_omega_max=w,
               step=0.1 * integrators.rk4_stability_limit(w), wall_time_s=wall)
    return [_from_tuple(r, **det) for r in res]


def order_check(body_data, rankings):
    chain = models.build_chain(models.model_spec(ORDER_MODEL, rankings), body_data)
    scene = scenes.load_scene("thesis")
    prob = simulate.scene_problem(chain, scene)
    limit = integrators.rk4_stability_limit(prob.omega_max)
    t_end = 2e-3
    steps = tuple(t_end / np.ceil(t_end / (f * limit)) for f in (0.2, 0.1, 0.05))
    res = dc.rk4_order("thesis (real bodies)", prob, t_end, steps=steps)
    return _from_tuple(res, data=f"real bodies, model {ORDER_MODEL!r}, scene 'thesis' over {t_end} s, "
                                 f"final-state errors against a run at steps[-1]/8", steps=list(steps),
                       lower=3.9, upper=4.1)


def rigid_checks(body_data, rankings):
    chain = models.build_chain(models.model_spec(CONSERVATION_MODEL, rankings), body_data)
    out = [_from_tuple(dc.rigid_spin_about_outer_axis("real bodies", chain, t_end=5e-3),
                       data=f"real elastic bodies, model {CONSERVATION_MODEL!r}, 5 ms")]
    inertias = []
    for b in models.BODIES:
        m = models.build_chain(models.model_spec("rigid", rankings), body_data).bodies[b - 2].rigid_mass
        inertias.append((m[0, 0], m[3, 3], m[4, 4], m[5, 5]))
    out.append(_from_tuple(dc.rigid_motor_spin_up("real mass properties", inertias),
                           data="real bodies' mass and diagonal inertia about the gimbal point, "
                                "principal-axis idealisation (off-diagonal inertia and first "
                                "moment dropped for the closed form)", inertias=inertias))
    return out


def reduce_and_simulate(model, scene, body_files, reduction_files, model_out, sim_out, options=(),
                        load_ranking=None):
    """The workflow's two jobs of one simulation, in process (tests, verification): reduce
    (``gimbal_reduction.reduction.models.main``: body files {body: path}, reduction files {body: path} -> model_out), then
    simulate (``gimbal_reduction.solver.dynamics.simulate.main``: model_out -> sim_out, with ``options``).
    Returns the exit status of the first job that fails, or 0."""
    args = ["--model", model, "--scene", str(scene),
            "--bodies", *[str(body_files[b]) for b in models.BODIES],
            "--reductions", *[str(reduction_files[b]) for b in models.BODIES], "--out", str(model_out)]
    if load_ranking is not None:
        args += ["--load-ranking", str(load_ranking)]
    rc = models.main(args)
    if rc:
        return rc
    return simulate.main(["--scene", str(scene), "--model-file", str(model_out), "--out", str(sim_out),
                          *options])


def _reduce_and_simulate(args, body_files, reduction_files, out_dir):
    """The workflow's two jobs of one simulation (reduce, then simulate), in process:
    args = ["--scene", S, "--model", M, *simulate options]; the first non-zero status."""
    scene, model, options = args[1], args[3], args[4:]
    return reduce_and_simulate(model, scene, body_files, reduction_files,
                               os.path.join(out_dir, "models", f"{model}.h5"),
                               os.path.join(out_dir, f"{model}.h5"), options)


def bad_input_checks(body_files, reduction_files, out_dir):
    cases = {
        "unknown model": ["--scene", "thesis", "--model", "fraq-10"],
        "mode count above computed": ["--scene", "thesis", "--model", "freq-101"],
        "unknown scene": ["--scene", "nope", "--model", "freq-10"],
        "rk4 step beyond the limit": ["--scene", "thesis", "--model", "freq-10", "--integrator", "rk4",
                                      "--step", "1e-5"],
        "negative step": ["--scene", "thesis", "--model", "freq-10", "--step=-1e-7"],
        "bad integrator": ["--scene", "thesis", "--model", "freq-10", "--integrator", "euler"],
        "zero tolerance": ["--scene", "thesis", "--model", "freq-10", "--tol", "0"],
        "tolerance with a step": ["--scene", "thesis", "--model", "freq-10", "--tol", "1e-6",
                                  "--step", "1e-4"],
        "option of another integrator": ["--scene", "thesis", "--model", "freq-10", "--rho-inf", "0.5"],
    }
    import tempfile
    import yaml
    tmp = tempfile.mkdtemp()
    base = scenes.load_scene("thesis").raw        # read strictly (a duplicate key is refused)
    for label, change in (("negative duration", ("duration", -0.01)),
                          ("non-finite initial value", ("initial_rates", [0.0, float("nan"), 0.0, 0.0])),
                          ("unknown scene key", ("gravity", 1.0))):
        raw = dict(base)
        key, val = change
        raw[key] = dict(raw[key], value=val) if key in raw else {"value": val, "unit": "1"}
        path = os.path.join(tmp, f"bad_{key}.yaml")
        with open(path, "w") as fh:
            yaml.safe_dump(raw, fh)
        cases[label] = ["--scene", path, "--model", "freq-10"]
    failures, messages = [], {}
    t0 = time.perf_counter()
    for label, args in cases.items():
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                rc = _reduce_and_simulate(args, body_files, reduction_files, out_dir)
            except SystemExit as exc:          # argparse errors
                rc = exc.code
        lines = err.getvalue().strip().splitlines()
        messages[label] = lines
        if rc != 2 or len(lines) != 1:
            failures.append(label)
    return [_check("bad input: one-line errors before integration (real data)", len(failures), 0,
                   failures=failures, messages=messages, wall_time_s=time.perf_counter() - t0)]


# ------------------------------------------------ truth: convergence, benchmark
def reference_run(path, scene):
    """The converged DOP853 reference of ``scene`` on the truth model (rule reference_simulation:
    ``simulate.REFERENCE``) as a run: t (T,) [s], yd (T, 4) gimbal rates [rad/s], steps, step [s]
    (the mean), its integration time [s]; a file of another scene, model or integrator setting
    is refused."""
    f = read_sim(path)
    a = f["attrs"]
    want = {"scene": scene.name, "model": "truth", "integrator": simulate.REFERENCE["integrator"],
            "stat_rtol": simulate.REFERENCE["rtol"], "stat_atol": simulate.REFERENCE["atol"]}
    wrong = mismatches(a, want)
    if wrong:
        raise ValueError(f"{path}: not the converged reference of {scene.name} ({want}): {wrong}")
    steps = int(a["steps"])
    return SimpleNamespace(t=f["t"], yd=f["gamma_dot"], steps=steps, step=scene.duration / steps,
                           stats={}), float(a["integration_time_s"])


def second_method_run(path, scene):
    """The truth on ``scene`` by the exponential integrator at a tight tolerance (rule
    reference_exponential) as a run: t (T,) [s], yd (T, 4) gimbal rates [rad/s], steps, and its
    tolerance; a file of another scene, model or integrator is refused."""
    f = read_sim(path)
    a = f["attrs"]
    wrong = mismatches(a, {"scene": scene.name, "model": "truth", "integrator": "exponential"})
    if wrong:
        raise ValueError(f"{path}: not the exponential integrator's truth on {scene.name}: {wrong}")
    return SimpleNamespace(t=f["t"], yd=f["gamma_dot"], steps=int(a["steps"]),
                           tol=float(a["stat_exponential_tol"]))


def second_method_check(default_run, second, method, bound=1e-10, /, **details):
    """The truth's convergence as the agreement of two methods: E (eq. 3.53) of ``default_run`` (the
    converged DOP853 run) against ``second`` (``second_method_run``) per gimbal rate, passed when
    max E <= ``bound``; both runs on the same output grid, else ValueError."""
    if second.yd.shape[0] != default_run.yd.shape[0]:
        raise ValueError(f"the second method's run has {second.yd.shape[0]} outputs, the default "
                         f"{default_run.yd.shape[0]}")
    E = error_measure(default_run.t, default_run.yd[:, :4], second.yd[:, :4])
    return _check(f"truth convergence on thesis: the default ({method}) against the exponential "
                  f"integrator at tol {second.tol:g}, max E over the 4 gimbal rates", float(np.max(E)),
                  bound, E_per_rate=np.asarray(E).tolist(), steps_second=second.steps, **details)


def pareto_truth_rows(path):
    """The truth's rows of a Pareto benchmark's CSV (``gimbal pareto --errors-only``, judged against
    the same converged reference): [(method, step [s], row)], each row with its E per rate; a
    missing file, no truth row or a row without E refused in one line (ValueError)."""
    import csv
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r.get("model") == "truth" and r.get("status", "ok") == "ok"]
    if not rows:
        raise ValueError(f"{path}: no row of the truth")
    bad = [r.get("integrator") for r in rows
           if not all(r.get(c) not in (None, "") for c in ("step_s", "steps", "E", *RATE_COLUMNS))]
    if bad:
        raise ValueError(f"{path}: truth rows without step, steps or E: {', '.join(map(str, bad))}")
    return [(r["method"], float(r["step_s"]), r) for r in rows]


def _shared_record(label, method, step, shared, source):
    """The benchmark record of an integrator setting taken from a Pareto truth row of the same
    method and step (``pareto_truth_rows``; the step to the CSV's 6 digits), or None."""
    for m, h, row in shared or ():
        if m == method and np.isclose(h, step, rtol=1e-5):
            E = [float(row[c]) for c in RATE_COLUMNS]
            return {"integrator": method, "label": label, "wall_times_s": [float(row["wall_time_s"])],
                    "median_wall_time_s": float(row["wall_time_s"]), "step_s": h,
                    "steps_taken": int(row["steps"]), "E_vs_converged_truth": float(row["E"]),
                    "E_per_rate": E, "stats": {}, "run_from": f"{source} ({row['integrator']})"}
    return None


def _bench_record(label, method, walls, run, ref):
    """The benchmark record of one integrator: its runs' wall times [s], E of ``run`` against
    ``ref`` (the converged truth), step and steps."""
    return {"integrator": method, "label": label, "wall_times_s": walls,
            "median_wall_time_s": float(np.median(walls)), "step_s": run.step,
            "steps_taken": run.steps, "E_vs_converged_truth": rate_error(run, ref),
            "E_per_rate": np.asarray(error_measure(ref.t, ref.yd[:, :4], run.yd[:, :4])).tolist(),
            "stats": {k: float(v) for k, v in run.stats.items()}}


def truth_setup(body_data, rankings):
    """(chain, problem, scene thesis, seconds of the coupled omega_max, the RK4 step at the
    stability limit dividing the output interval [s])."""
    chain = models.build_chain(models.model_spec("truth", rankings), body_data)
    scene = scenes.load_scene("thesis")
    t0 = time.perf_counter()
    prob = simulate.scene_problem(chain, scene)
    t_omega = time.perf_counter() - t0
    limit = integrators.rk4_stability_limit(prob.omega_max)
    n_sub = int(np.ceil(scene.output_interval / limit - 1e-9))
    return chain, prob, scene, t_omega, scene.output_interval / n_sub


def bench_settings(rk4_step):
    """(label, integrate keywords) of every integrator the benchmark times on the truth."""
    return [("rk4 at its stability-limited step (largest step <= 2.785/omega_max dividing the "
             "output interval)", dict(method="rk4", step=rk4_step)),
            (f"dop853 rtol {DOP853_RTOL:g} (truth default)",
             dict(method="dop853", rtol=DOP853_RTOL, atol=1e-14)),
            (f"generalized-alpha h = {GA_STEP:g} s, rho_inf 0.9",
             dict(method="generalized-alpha", step=GA_STEP))]


def truth_runs(body_data, rankings, repeats, budget_s=None, reference=None, second=None,
               shared=None, shared_source=""):
    """Truth on thesis: default-step convergence, and every integrator's cost and accuracy: the
    median of ``repeats`` runs each, fewer (at least one) where they would not fit in ``budget_s``
    seconds at the first run's pace (a run that slow decides no comparison by its median).
    repeats 1: one run each (``--untimed``: their E and steps, beside other jobs).
    reference: the converged DOP853 reference of thesis (``reference_run``), taken as the
    default's run (the same integrator and setting) instead of integrating it again.
    second: with ``reference``, the exponential integrator's tight run (``second_method_run``):
    the convergence check compares the default with it instead of integrating the default at half
    its step, and the default is the converged truth the benchmark's E are measured against.
    shared: with ``second``, ``pareto_truth_rows`` of a Pareto run against the same converged
    truth (``shared_source`` its file): an untimed setting of the same method and step is taken
    from its row, not integrated again."""
    chain, prob, scene, t_omega, rk4_limit_step = truth_setup(body_data, rankings)
    limit = integrators.rk4_stability_limit(prob.omega_max)
    cfg = dict(simulate.REFERENCE)
    go = lambda **kw: integrators.integrate(prob, scene.duration, scene.output_interval, **kw)
    # convergence of the default: its run, and the same integrator with every step at most
    # half the default's mean step (DOP853 is stability-limited here, its steps nearly uniform)
    kw = {"method": cfg["integrator"]}
    if cfg["integrator"] == "dop853":
        kw.update(rtol=cfg["rtol"], atol=cfg["atol"])
    elif "fraction" in cfg:
        kw.update(fraction=cfg["fraction"])
    if reference is not None:
        run_h, t_default = reference
    else:
        t0 = time.perf_counter()
        run_h = go(**kw)
        t_default = time.perf_counter() - t0
    h_mean = scene.duration / run_h.steps
    common = dict(default=cfg, mean_step=h_mean, steps=run_h.steps, wall_time_default_s=t_default,
                  coupled_omega_max=prob.omega_max, modal_omega_max=prob.modal_omega_max,
                  rk4_stability_limit=limit,
                  default_run="the converged reference file" if reference else "integrated here")
    if second is not None and reference is not None:
        # two methods whose errors are independent (an explicit Runge-Kutta pair at rtol 1e-10,
        # the modal exponential integrator at a tolerance 100x under the scene's): their
        # difference bounds the default's error as well as its step halving does
        conv = second_method_check(run_h, second, cfg["integrator"], **common)
        ref, converged = run_h, f"{cfg['integrator']} at rtol {cfg.get('rtol')} (the converged reference)"
    else:
        half = dict(kw, max_step=h_mean / 2) if cfg["integrator"] == "dop853" else dict(kw, step=run_h.step / 2)
        half.pop("fraction", None)
        t0 = time.perf_counter()
        run_h2 = go(**half)
        t_half = time.perf_counter() - t0
        E = error_measure(run_h2.t, run_h2.yd[:, :4], run_h.yd[:, :4])
        conv = _check(f"truth convergence on thesis: step halving of the default ({cfg['integrator']}), "
                      f"max E over the 4 gimbal rates", float(np.max(E)), 1e-10,
                      E_per_rate=np.asarray(E).tolist(), steps_half=run_h2.steps,
                      wall_time_half_s=t_half, **common)
        ref, converged = run_h2, (f"{cfg['integrator']} with max step {h_mean / 2:.4e} s (half the "
                                  f"truth default's mean step)")
    default_is_dop = cfg["integrator"] == "dop853" and cfg["rtol"] == DOP853_RTOL

    # the default's own E: against the second method where the default is the converged truth
    default_referee = second if ref is run_h else ref

    def bench(label, repeats, referee=ref, **kw):
        walls, run = [], None
        while len(walls) < (repeats if budget_s is None or not walls
                            else run_budget(walls[0], repeats, budget_s)):
            t0 = time.perf_counter()
            run = go(**kw)
            walls.append(time.perf_counter() - t0)
        return _bench_record(label, kw["method"], walls, run, referee), run

    def effective_step(method, kw):
        """The step a fixed-step setting runs at: RK4's given one; generalised-alpha's the largest
        dividing the output interval, not above the given one (integrators._generalized_alpha)."""
        n = max(int(np.ceil(scene.output_interval / kw["step"] - 1e-9)), 1)
        return kw["step"] if method == "rk4" else scene.output_interval / n

    # rows of another job's untimed runs apply only against the same referee: the converged file
    shared = shared if (repeats == 1 and ref is run_h) else None
    records, ga = [], None
    for label, kw in bench_settings(rk4_step=rk4_limit_step):
        if kw["method"] == "dop853" and default_is_dop:        # the default run counts
            rec, _ = (bench(label, repeats - 1, referee=default_referee, **kw) if repeats > 1
                      else (_bench_record(label, "dop853", [], run_h, default_referee), None))
            if default_referee is not ref:
                rec["E_against"] = f"the exponential integrator at tol {second.tol:g}"
            rec["wall_times_s"].append(t_default)
            rec["median_wall_time_s"] = float(np.median(rec["wall_times_s"]))
        else:
            rec = (_shared_record(label, kw["method"], effective_step(kw["method"], kw), shared,
                                  shared_source) if kw["method"] in ("rk4", "generalized-alpha") else None)
            if rec is None:
                rec, run = bench(label, repeats, **kw)
                rec["run_from"] = "integrated here"
            if kw["method"] == "generalized-alpha":
                ga = (rec["step_s"], rec["E_vs_converged_truth"])
        records.append(rec)
    # a step never exceeds the output interval (it divides it), so where both GA_STEP and its half
    # are capped there, the half-step run is the same run
    half = dict(method="generalized-alpha", step=GA_STEP / 2)
    if np.isclose(effective_step("generalized-alpha", half), ga[0], rtol=1e-9):
        ga2 = ga
    else:
        run2 = go(**half)
        ga2 = (run2.step, rate_error(run2, ref))
    (h_ga, Ega), (h_ga2, Ega2) = ga, ga2
    ga_check = _check(f"generalized-alpha accuracy on thesis (truth, h = {GA_STEP:g} s) vs the converged truth",
                      Ega, 1e-1, E_half_step=Ega2, ratio_on_halving=Ega / Ega2 if Ega2 > 0 else None,
                      steps_used_s=[float(h_ga), float(h_ga2)],
                      note="measured, not a convergence claim: rho_inf 0.9 filters the top modes, "
                           "so E stalls at their share of the rates (outer gimbal rate, tiny, has the "
                           "largest E); the tolerance 0.1 only flags a gross failure")
    info = {"model": "truth", "scene": "thesis", "n_modes": list(chain.n_modes),
            "coupled_omega_max_rad_s": prob.omega_max, "modal_omega_max_rad_s": prob.modal_omega_max,
            "rk4_stability_limit_s": limit, "coupled_omega_time_s": t_omega,
            "converged_truth": converged}
    return [conv, ga_check], records, info, (chain, prob, ref)


EXP_TIGHT_TOL = 1e-7      # the tight tolerance of the exponential integrator's check


def exponential_checks(body_data, rankings, truth, conservation_s=None):
    """The modal exponential integrator on the real bodies: the truth on thesis
    against the converged DOP853 truth at the default and a tight tolerance; a reduced model
    against RK4 at a tenth of its stability limit; energy
    and axial momentum over the 10 s scene free_10s (case at rest), or its first
    ``conservation_s`` seconds."""
    chain, prob, ref = truth
    scene = scenes.load_scene("thesis")
    out = []
    for tol in (exponential.DEFAULTS.tol, EXP_TIGHT_TOL):
        t0 = time.perf_counter()
        run = integrators.integrate(prob, scene.duration, scene.output_interval,
                                    method="exponential", tol=tol)
        wall = time.perf_counter() - t0
        E = error_measure(ref.t, ref.yd[:, :4], run.yd[:, :4])
        out.append(_check(f"exponential (tol {tol:g}) vs the converged truth on thesis (truth model), "
                          f"max E over the 4 gimbal rates", float(np.max(E)),
                          1e-8 if tol == exponential.DEFAULTS.tol else 1e-9,
                          E_per_rate=np.asarray(E).tolist(), steps=run.steps, wall_time_s=wall,
                          stats={k: float(v) for k, v in run.stats.items()}))
    small = models.build_chain(models.model_spec("freq-10", rankings), body_data)
    sp = simulate.scene_problem(small, scene)
    rk = integrators.integrate(sp, scene.duration, scene.output_interval, method="rk4", fraction=0.1)
    ex = integrators.integrate(sp, scene.duration, scene.output_interval, method="exponential")
    E = error_measure(rk.t, rk.yd[:, :4], ex.yd[:, :4])
    out.append(_check("exponential (default tol) vs RK4 at 0.1 x its stability limit, freq-10 on thesis, "
                      "max E", float(np.max(E)), 1e-8, E_per_rate=np.asarray(E).tolist(),
                      rk4_steps=rk.steps, exponential_steps=ex.steps))
    free = scenes.load_scene("free_10s")
    y0, yd0 = scenes.initial_state(free, chain.n_coordinates)
    fp = Problem(chain, case=free.case, torque=free.motor_torques, y0=y0, yd0=yd0)
    t0 = time.perf_counter()
    # not conservation to round-off: the method is not symplectic and its local errors (tol
    # per step) accumulate (docs/exponential.md Section 9; the measured drifts are in
    # results/verification/dynamics.json)
    t_end = free.duration if conservation_s is None else conservation_s
    recs, run = dc.exponential_conservation("free_10s (truth model)", fp, t_end,
                                            free.output_interval, limit=1e-3, tol=1e-6)
    for r in recs:
        r.update(wall_time_s=time.perf_counter() - t0, steps=run.steps,
                 relinearisations=run.stats["relinearisations"])
    out += recs
    return out


# the sections of main, in order (progress: sections done of these)
SECTIONS = ("oracle", "conservation", "rk4 order", "rigid limits", "bad input", "truth", "exponential")


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m gimbal_reduction.results.bench.verify_dynamics",
                                 description="Verify the dynamics on the real bodies; benchmark the truth model.")
    ap.add_argument("--bodies", nargs=4, required=True, metavar="BODY_FILE",
                    help="the modal stage's body files of bodies 2, 3, 4, 5")
    ap.add_argument("--reductions", nargs=4, required=True, metavar="REDUCTION_FILE",
                    help="the reduction stage's files of bodies 2..5")
    ap.add_argument("--verification", required=True, help="output JSON of the checks")
    ap.add_argument("--benchmark", required=True, help="output JSON of the truth-model timings")
    ap.add_argument("--repeats", type=int, default=5, help="runs per integrator (median)")
    ap.add_argument("--budget", type=float, default=None,
                    help="seconds per integrator: fewer runs (at least one) where --repeats would not fit "
                         "at the first run's pace (default: no limit)")
    ap.add_argument("--config", help="the current configuration file: input files of another "
                                     "configuration are refused before the work (gimbal_reduction.solver.bodyconfig)")
    ap.add_argument("--untimed", action="store_true",
                    help="the benchmark's integrators run once each (E, steps, that run's wall time): a "
                         "job beside others; the truth's times alone are the Pareto benchmark's rows")
    ap.add_argument("--reference", help="the converged DOP853 reference of thesis on the truth model "
                                        "(results/reference/thesis/truth.h5): the default's run is "
                                        "taken from it rather than integrated again")
    ap.add_argument("--convergence-reference", metavar="FILE",
                    help="with --reference: the truth on thesis by the exponential integrator at a "
                         "tight tolerance (results/all/reference/thesis/truth.h5); the truth's "
                         "convergence is the default against it, not a run at half its step")
    ap.add_argument("--runs-from", metavar="CSV",
                    help="with --untimed and --convergence-reference: a Pareto benchmark's untimed "
                         "errors (gimbal pareto --errors-only) against the same reference; the truth's "
                         "RK4 and generalised-alpha settings are taken from its rows of the same step")
    ap.add_argument("--conservation-duration", type=float, metavar="SECONDS",
                    help="the exponential integrator's energy and momentum drift over the first "
                         "SECONDS of free_10s (default: all 10 s)")
    args = ap.parse_args(argv)
    start = time.perf_counter()
    try:
        if args.convergence_reference and not args.reference:
            raise ValueError("--convergence-reference needs --reference (the default it checks)")
        if args.runs_from and not (args.untimed and args.convergence_reference):
            raise ValueError("--runs-from needs --untimed and --convergence-reference (the rows are "
                             "untimed runs against the converged reference)")
        if args.conservation_duration is not None and not (
                0 < args.conservation_duration <= scenes.load_scene("free_10s").duration):
            raise ValueError(f"--conservation-duration {args.conservation_duration:g}: not within "
                             "(0, the duration of free_10s]")
        bodyconfig.check_files(args.bodies + args.reductions + [p for p in (args.reference,
                               args.convergence_reference) if p], args.config)
        body_files = dict(zip(models.BODIES, args.bodies))
        reduction_files = dict(zip(models.BODIES, args.reductions))
        rankings = models.read_rankings(reduction_files)
        body_data = {b: models.load_body_file(body_files[b]) for b in models.BODIES}
        reference = reference_run(args.reference, scenes.load_scene("thesis")) if args.reference else None
        second = (second_method_run(args.convergence_reference, scenes.load_scene("thesis"))
                  if args.convergence_reference else None)
        shared = pareto_truth_rows(args.runs_from) if args.runs_from else None
    except (OSError, ValueError) as exc:
        print(f"verify_dynamics: {exc}", file=sys.stderr)
        return 2
    checks, timing_s = [], {}
    progress = Progress("verify_dynamics", len(SECTIONS), "sections")

    def section(name, fn, *a):
        t0 = time.perf_counter()
        res = fn(*a)
        timing_s[name] = time.perf_counter() - t0
        print(f"verify_dynamics: {name}: {timing_s[name]:.1f} s", flush=True)
        progress.advance(note=f"{name} took {timing_s[name]:.0f} s")
        return res

    real_small = models.build_chain(models.model_spec("freq-10", rankings), body_data)
    truth_chain = models.build_chain(models.model_spec("truth", rankings), body_data)
    checks += section("oracle", oracle_checks, real_small, (real_small, truth_chain))
    checks += section("conservation", conservation_checks, body_data, rankings)
    checks.append(section("rk4 order", order_check, body_data, rankings))
    checks += section("rigid limits", rigid_checks, body_data, rankings)
    import tempfile
    checks += section("bad input", bad_input_checks, body_files, reduction_files, tempfile.mkdtemp())
    truth_checks, bench, info, truth = section("truth", truth_runs, body_data, rankings,
                                               1 if args.untimed else args.repeats,
                                               args.budget, reference, second, shared,
                                               args.runs_from or "")
    checks += truth_checks
    checks += section("exponential", exponential_checks, body_data, rankings, truth,
                      args.conservation_duration)
    total = time.perf_counter() - start
    vers = versions()
    for mod in ("numba", "jax"):
        try:
            vers[mod] = __import__(mod).__version__
        except Exception:  # noqa: BLE001 - optional
            pass
    record = provenance(sources=[*args.bodies, *args.reductions])
    write_json(args.verification, {"stage": "dynamics", "checks": checks,
                                   "passed": all(c["passed"] for c in checks),
                                   "wall_time_s": total, "section_times_s": timing_s, "versions": vers},
               record)
    write_json(args.benchmark, {"stage": "dynamics", **info, "runs": bench,
                                "repeats": 1 if args.untimed else args.repeats,
                                "budget_s": args.budget, "timed_alone": not args.untimed,
                                "versions": vers}, record)
    failed = [c["name"] for c in checks if not c["passed"]]
    print(f"verify_dynamics: {len(checks) - len(failed)}/{len(checks)} checks passed in {total:.0f} s"
          + (f"; FAILED: {'; '.join(failed)}" if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
