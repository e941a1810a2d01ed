"""Hard cases of the gimbal-chain integrators (part c of ``gimbal_reduction.results.bench.stability``).

Large gimbal rates, the case driven at the first coupled elastic resonance, gimbal
lock, several static modes on one body, and steps beyond the limit.  Each must
either run and agree with a tighter run (thesis eq. 3.53 error measure E of the
four gimbal rates, ``checked_run``) or stop with a one-line diagnosis; a run that
finishes but disagrees is ``garbage`` (``case_passes``).

Units: inch, lbf, second, rad; energies in in lbf; frequencies in rad/s.
"""
from __future__ import annotations

import time

import numpy as np

from gimbal_reduction.reduction import models
from gimbal_reduction.results.bench.chain_stability import (
    DRIFT_MODEL,
    THESIS_ANGLES,
    axis_alignment,
    build,
    drive_axes,
    lock_distance,
    log,
    mass_conditioning,
    omega_top_over_angles,
)
from gimbal_reduction.solver.dynamics import integrators, linearized, multibody, scenes, simulate
from gimbal_reduction.solver.dynamics.problem import Problem
from gimbal_reduction.solver.dynamics.error_measure import error_measure

HARD_CASE_TOLERANCE = 1e-6                 # E (eq. 3.53) of a run against its tighter run
HARD_MODEL = "freq-5"
# The twelve load cases of the output bearings: the most static modes one body can carry
# (input-bearing loads partly act on the supports).
OUTPUT_LOADS = tuple(f"output_{b}_{c}" for b in ("motor", "resolver")
                     for c in ("fx", "fy", "fz", "mx", "my", "mz"))
ALL_LOADS = tuple(f"{b}_{c}" for b in models.BEARINGS for c in ("fx", "fy", "fz", "mx", "my", "mz"))


# ============================================================== static-mode conditioning
def static_mode_conditioning(body, kept, load_cases):
    """Conditioning of several static correction modes on one body (a dict).

    body: a body-file dict (``models.load_body_file``); kept (k,) kept mode indices;
    load_cases: names.  The modes are those of the chain's model (``models.static_modes_for``).
    gram_condition: condition number of the mass Gram matrix of the
    unit-mass residual attachment modes before they are made M-orthogonal (the modal
    mass the thesis's eq. 3.52 would carry; large = nearly dependent loads);
    frequencies_hz (p,) their Rayleigh frequencies; mass_coupling, stiffness_coupling
    (largest normalised coupling to the kept modes).  Raises the reduction's one-line
    StaticModeError for loads that act only on the supports.
    """
    kept = np.asarray(kept, dtype=int)
    res = models.static_modes_for(body, load_cases, np.asarray(body["modes"])[:, kept],
                                  np.asarray(body["eigenvalues"])[kept])
    return {"gram_condition": float(res["gram_condition"]),
            "frequencies_hz": [float(f) for f in res["frequencies_hz"]],
            "mass_coupling": float(res["mass_coupling"]),
            "stiffness_coupling": float(res["stiffness_coupling"])}


# ============================================================== hard cases
def scene_variant(scene, name, **changes):
    """A copy of ``scene`` (scenes.Scene) with top-level or case_motion numbers replaced.

    changes: key=value with key a scene key (duration, initial_rates, ...) or
    ``case_<key>`` for a case_motion key; values in the scene file's units.  The result
    is validated by ``scenes.parse_scene`` like a file (one-line SceneError).
    """
    raw = {k: (dict(v) if isinstance(v, dict) else v) for k, v in scene.raw.items()}
    raw["case_motion"] = {k: dict(v) for k, v in scene.raw["case_motion"].items()}
    raw["name"] = name
    raw.pop("needs", None)          # what the base scene's results need is not the variant's
    for key, value in changes.items():
        value = np.asarray(value, float).tolist()
        if key.startswith("case_"):
            raw["case_motion"][key[5:]] = dict(raw["case_motion"][key[5:]], value=value,
                                               source="gimbal_reduction.results.bench.stability (hard case)")
        else:
            raw[key] = dict(raw[key], value=value, source="gimbal_reduction.results.bench.stability (hard case)")
    return scenes.parse_scene(raw, origin=name)


def rate_error(reference, candidate, t):
    """Eq. 3.53 E (4,) of the four gimbal rates of ``candidate`` against ``reference``.

    reference, candidate (T, 4) [rad/s]; t (T,) [s].  A rate identically zero in both
    counts as E = 0 (error_measure gives NaN for a zero reference)."""
    E = np.asarray(error_measure(t, reference, candidate), float)
    both_zero = np.all(reference == 0, axis=0) & np.all(candidate == 0, axis=0)
    return np.where(np.isnan(E) & both_zero, 0.0, np.where(np.isnan(E), np.inf, E))


def is_one_line_diagnosis(message, *must_name):
    """A diagnosis is usable when it is one non-empty line naming what it must
    (e.g. the model and the step): bool."""
    text = str(message)
    return bool(text) and "\n" not in text.strip() and all(str(m) in text for m in must_name)


def checked_run(chain, scene, model_name, method="rk4", tol=HARD_CASE_TOLERANCE, problem=None,
                observe=None, **options):
    """Run ``scene`` and judge the result against a tighter run (one dict).

    The tighter run halves the step (rk4, generalized-alpha) or divides rtol by 100
    (dop853).  outcome: ``verified`` (finite, E <= tol for every gimbal rate),
    ``diagnosed`` (the run stopped with a DivergenceError / StepTooLargeError /
    ValueError: message, and ``one_line`` whether it is one line naming the model),
    or ``garbage`` (finished, but disagrees with the tighter run or is not finite).
    Also: E (4,), energy_balance max |E(t) - E(0) - W(t)| / max(|E|, |W|) (W by the
    trapezoid rule at the output samples, so only as good as their spacing), steps,
    step [s], wall_s, omega_max.  observe: optional callable (run, problem) -> dict of
    extra numbers about the (finished) run, merged into the result.
    """
    out = {"model": model_name, "scene": scene.name, "method": method,
           "options": {k: v for k, v in options.items() if v is not None}}
    start = time.perf_counter()
    try:
        prob = simulate.scene_problem(chain, scene) if problem is None else problem
        out["omega_max"] = float(prob.omega_max)
        run, _ = simulate.run_scene(chain, scene, method, model_name=model_name, problem=prob,
                                    **options)
    except (integrators.DivergenceError, integrators.StepTooLargeError, ValueError) as exc:
        msg = str(exc)
        out.update(outcome="diagnosed", error=type(exc).__name__, message=msg,
                   one_line=is_one_line_diagnosis(msg, repr(model_name)),
                   wall_s=time.perf_counter() - start)
        return out
    tight = dict(options)
    if method == "dop853":
        tight["rtol"] = options.get("rtol", 1e-10) / 100.0
    else:
        tight.pop("fraction", None)
        tight["step"] = run.step / 2.0
    out.update(steps=int(run.steps), step=float(run.step))
    try:
        ref, _ = simulate.run_scene(chain, scene, method, model_name=model_name, problem=prob,
                                    **tight)
    except (integrators.DivergenceError, ValueError) as exc:
        out.update(outcome="garbage", message=f"the run finished but its tighter run failed: {exc}",
                   wall_s=time.perf_counter() - start)
        return out
    finite = bool(np.all(np.isfinite(run.yd)) and np.all(np.isfinite(run.y)))
    E = rate_error(ref.yd[:, :4], run.yd[:, :4], run.t) if finite else np.full(4, np.inf)
    T, U, W = simulate.energy_history(prob, run)
    Etot = T + U
    scale = max(float(np.abs(Etot).max()), float(np.abs(W).max()), 1e-300)
    balance = float(np.abs(Etot - Etot[0] - W).max() / scale)
    ok = finite and bool(np.all(E <= tol))
    out.update(outcome="verified" if ok else "garbage", E=[float(e) for e in E], E_max=float(E.max()),
               tolerance=tol, energy_balance=balance, tighter=tight,
               max_rate=float(np.abs(run.yd[:, :4]).max()),
               max_modal=float(np.abs(run.y[:, 4:]).max(initial=0.0)),
               wall_s=time.perf_counter() - start)
    if observe is not None:
        out.update(observe(run, prob))
    if not ok:
        out["message"] = (f"finished but E = {E.max():.3e} against the tighter run "
                          f"(tolerance {tol:.0e})" if finite else "non-finite state")
    return out


def case_passes(result, expect=None):
    """A hard case passes unless it is garbage; a diagnosis must be one line naming the
    model.  expect: 'verified' or 'diagnosed' to demand that outcome.  bool."""
    outcome = result.get("outcome")
    if outcome == "garbage" or outcome is None:
        return False
    if expect is not None and outcome != expect:
        return False
    if outcome == "diagnosed":
        return bool(result.get("one_line", False))
    return True


def case_axis_loading(chain, y, shape):
    """Generalised force (3,) [lbf in-ish, per rad/s^2] that a unit case angular acceleration
    about case X, Y, Z puts on one mode: -shape . c_a, c_a = inverse dynamics at rest with
    only the case accelerating (the inertia load of the case motion).

    chain, y (n,) configuration, shape (n,) a coupled mode (``linearized.coupled_modes``).  The case
    axis with the largest |value| drives the mode hardest."""
    n = chain.n_coordinates
    out = np.zeros(3)
    for a in range(3):
        amp = np.zeros(3)
        amp[a] = 1.0
        c = multibody.inverse_dynamics(chain, np.asarray(y, float), np.zeros(n), np.zeros(n), 0.0,
                                       multibody.CaseMotion(amplitude=tuple(amp)))
        out[a] = -float(np.asarray(shape, float) @ c)
    return out


def potential_growth(run, fraction=0.2):
    """max U over the last ``fraction`` of a run / max U over its first ``fraction`` [1]
    (U = elastic energy at the output samples): ~ (1/f)^2 = 25 for f = 0.2 when an
    undamped mode is driven at resonance (amplitude, so the envelope of U^(1/2), growing
    linearly in time); ~1 for a bounded response."""
    U = np.asarray(run.energy.get("potential", []), float)
    k = max(int(round(fraction * U.size)), 1)
    early = float(U[1:k + 1].max()) if U.size > 1 else 0.0
    late = float(U[-k:].max()) if U.size else 0.0
    return {"potential_growth": late / early if early > 0 else np.inf,
            "potential_max": float(U.max()) if U.size else 0.0}


def _diagnosed_build(name, exc, *must_name):
    """Result dict of a model that could not be built (a one-line ValueError naming must_name)."""
    msg = str(exc)
    return {"model": name, "outcome": "diagnosed", "error": type(exc).__name__, "message": msg,
            "one_line": is_one_line_diagnosis(msg, *must_name)}


def lock_table(chain, base_angles=(0.0, 0.0, 0.0, 0.0), distances=(1e-1, 1e-2, 1e-3, 0.0)):
    """Conditioning of M(y) against the distance from the double gimbal lock gamma_2 =
    gamma_3 = 0 (list of dicts), plus the thesis and free configurations for reference."""
    rows = []
    configs = [("thesis", THESIS_ANGLES), ("free", (0.1, -1.3707963267948966, -0.3, 0.4))]
    configs += [(f"lock+{d:g}", (base_angles[0], d, d, base_angles[3])) for d in distances]
    for label, ang in configs:
        y = np.zeros(chain.n_coordinates)
        y[:4] = ang
        axes = drive_axes(ang)
        row = {"configuration": label, "angles": [float(a) for a in ang],
               "lock_distance": lock_distance(axes), "axis_alignment": axis_alignment(axes),
               "omega_top": float(linearized.coupled_frequencies(chain, y)[-1])}
        row.update(mass_conditioning(linearized.mass_matrix_fast(chain, y)))
        rows.append(row)
    return rows


def run_hard_cases(rankings, data, quick=False, model=HARD_MODEL):
    """Part c: every hard case (dict name -> result with ``pass``, ``expect`` and ``what``)."""
    short = 0.005 if quick else 0.015
    chain = build(model, rankings, data)
    thesis = scenes.load_scene("thesis")
    cases = {}

    def record(name, what, result, expect=None):
        result.update(what=what, expect=expect, **{"pass": case_passes(result, expect)})
        cases[name] = result
        extra = f"E = {result['E_max']:.2e}" if "E_max" in result else result.get("message", "")
        log(f"hard case {name}: {result['outcome']} ({extra}), {result.get('wall_s', 0.0):.1f} s")

    # 1, 2: large initial gimbal rates (case at rest)
    for r in (10, 100):
        sc = scenes.load_scene(f"stress_rates_{r}")
        if quick:
            sc = scene_variant(sc, sc.name, duration=short)
        log(f"hard case rates_{r}: {model} on {sc.name} ...")
        record(f"rates_{r}", f"initial gimbal rates {r} rad/s (scene {sc.name}), rk4 default step",
               checked_run(chain, sc, model))

    # 3: case driven at the first coupled elastic resonance, about the case axis loading it most
    y0 = np.zeros(chain.n_coordinates)
    y0[:4] = thesis.initial_angles
    omega, shapes = linearized.coupled_modes(chain, y0)
    load = case_axis_loading(chain, y0, shapes[:, 0])
    axis = int(np.argmax(np.abs(load)))
    amp = np.zeros(3)
    amp[axis] = 1.0
    freq = np.zeros(3)
    freq[axis] = omega[0] / (2 * np.pi)
    sc = scene_variant(thesis, "stress_resonance", duration=0.01 if quick else 0.03,
                       case_angular_acceleration_amplitude=amp,
                       case_angular_acceleration_frequency=freq)
    log(f"hard case resonance: {model}, case axis {'XYZ'[axis]} at {freq[axis]:.2f} Hz ...")
    res = checked_run(chain, sc, model, observe=lambda run, prob: potential_growth(run))
    res.update(resonance_omega=float(omega[0]), resonance_hz=float(freq[axis]), case_axis="XYZ"[axis],
               case_axis_loading=load.tolist())
    record("resonance", f"case rocked at the first coupled elastic frequency "
                        f"({omega[0]:.1f} rad/s) about case {'XYZ'[axis]}, 1 rad/s^2", res)

    # 4: near gimbal lock (thesis case motion about X, the normal of the locked axes' plane)
    sc = scenes.load_scene("stress_lock")
    if quick:
        sc = scene_variant(sc, sc.name, duration=short)
    log(f"hard case gimbal_lock: {model} on {sc.name} ...")
    res = checked_run(chain, sc, model)
    res["conditioning"] = lock_table(chain)
    record("gimbal_lock", "gamma_2 = gamma_3 = 1e-3 rad from the double lock (all four drive axes "
                          "within 1e-3 of one plane), case rocked about its normal", res)

    # 5: twelve static modes on one body (every output-bearing load case of the outer gimbal)
    name12 = "freq-6@2:" + "+".join(OUTPUT_LOADS)
    log(f"hard case static_modes: {name12} ...")
    spec = models.model_spec(name12, rankings)
    cond = static_mode_conditioning(data[2], spec.kept[2], OUTPUT_LOADS)
    chain12 = models.build_chain(spec, data)
    y12 = np.zeros(chain12.n_coordinates)
    y12[:4] = thesis.initial_angles
    res = checked_run(chain12, scene_variant(thesis, "thesis", duration=short) if quick else thesis,
                      name12)
    chain6 = build("freq-6", rankings, data)
    y6 = np.zeros(chain6.n_coordinates)
    y6[:4] = thesis.initial_angles
    res.update(static=cond, chain=mass_conditioning(linearized.mass_matrix_fast(chain12, y12)),
               chain_without_static=mass_conditioning(linearized.mass_matrix_fast(chain6, y6)))
    record("static_modes", f"12 static modes on the outer gimbal ({len(OUTPUT_LOADS)} output-bearing "
                           f"load cases), thesis scene", res)

    # 6: all 24 bearing load cases on one body: some act only on the supports
    name24 = "freq-6@2:" + "+".join(ALL_LOADS)
    try:
        models.build_chain(models.model_spec(name24, rankings), data)
        res = {"model": name24, "outcome": "garbage", "message": "built a model with loads on supports"}
    except ValueError as exc:
        # the reduction's message names the load case, not the model (build_chain does not add it)
        res = _diagnosed_build(name24, exc, "static mode", "vanishes")
    record("static_modes_on_supports", "all 24 bearing load cases on the outer gimbal", res,
           expect="diagnosed")

    # 7: a requested step beyond the limit
    record("step_beyond_limit", "rk4 at 1.3 x 2.785/omega_max, thesis scene",
           checked_run(chain, thesis, model, fraction=1.3), expect="diagnosed")

    # 8: the old bound (largest kept modal frequency): the step is 3.5x too large
    prob = Problem(chain, case=thesis.case, y0=y0, omega_max=chain.omega_max)
    record("modal_frequency_bound", "rk4 at 0.5 x 2.785/(largest kept modal frequency), the bound "
                                    "before the coupled-frequency fix, thesis scene",
           checked_run(chain, thesis, model, problem=prob), expect="diagnosed")

    # 9: a permitted step (fraction 1.0 of the sampled limit) through the configuration where
    # the small model's top coupled frequency peaks (gamma_2 = 0), missed by the sampling
    small = build(DRIFT_MODEL, rankings, data)
    free = scenes.load_scene("free")
    sc = scene_variant(free, "stress_sampling", duration=0.2, output_interval=0.02,
                       initial_rates=(0.0, 10.0, 0.0, 0.0))
    log(f"hard case sampled_omega_max: {DRIFT_MODEL} ...")
    res = checked_run(small, sc, DRIFT_MODEL, fraction=1.0)
    grid_max, where = omega_top_over_angles(small)
    res.update(omega_grid_max=grid_max, omega_grid_argmax=where.tolist(),
               grid_over_omega_max=grid_max / res.get("omega_max", np.nan),
               h_omega_grid_max=integrators.RK4_STABILITY * grid_max / res.get("omega_max", np.nan))
    record("sampled_omega_max", f"{DRIFT_MODEL}, rk4 at 1.0 x the limit, gamma_2 from -1.37 rad "
                                f"through 0 at 10 rad/s", res)
    return cases
