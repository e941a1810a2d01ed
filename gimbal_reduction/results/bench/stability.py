"""Numerical stability stress tests of the gimbal-chain integrators.

    MPLBACKEND=Agg .venv/bin/python -m gimbal_reduction.results.bench.stability --bodies results/modes/body{2,3,4,5}.h5 \\
        --reductions results/reduction/body{2,3,4,5}.h5 --out-dir results/stability \\
        --figures-dir results/figures/stability [--quick]

Three parts (method and measured numbers: docs/stability.md):

a. **RK4 step sweep.**  For several reduced models the actual stability limit h*
   of RK4 is found by bisection on the step: every coupled mode of the chain
   (linearised at the thesis configuration) gets the same small kinetic energy,
   RK4 runs ``n_steps`` steps, and a step is unstable when the energy grows by
   ``growth``.  h* is compared with the project's bound 2.785/omega_max
   (``integrators.RK4_STABILITY``, the negative-real-axis bound) and with the
   exact bound for undamped modes, 2 sqrt 2 / omega (the imaginary-axis bound).
b. **Energy drift** |E(t) - E(0)| / |E(0)| of every integrator over the 10 s
   scene ``free_10s`` (case at rest: E = T + U is conserved).
c. **Hard cases**: large gimbal rates, the case driven at the first coupled
   elastic resonance, gimbal lock, several static modes on one body, and steps
   beyond the limit.  Each must either run and agree with a tighter run
   (thesis eq. 3.53 error measure E of the four gimbal rates) or stop with a
   one-line diagnosis; a run that finishes but disagrees is ``garbage``.

The experiments live in ``gimbal_reduction.results.bench.rk4_theory`` (RK4's amplification factor, its
bounds, the bisection), ``gimbal_reduction.results.bench.chain_stability`` (coupled modes, the measured
limit of a chain, energy drift, gimbal-lock geometry) and ``gimbal_reduction.results.bench.hard_cases``
(part c); this module is the study's CLI, its CSV files and its figures.

Outputs (atomic: temporary name, then rename): ``{out}/stability.json`` (every
number, a boolean ``pass`` per check, provenance), ``{out}/rk4_limit.csv``,
``{out}/energy_drift.csv``, ``{out}/hard_cases.csv``, ``{out}/gimbal_lock.csv``, and the figures
``{figures}/rk4_limit.png``, ``{figures}/energy_drift.png``.

Units: inch, lbf, second, rad; energies in in lbf; frequencies in rad/s.
"""
from __future__ import annotations

import argparse
import csv
import io
import os
import sys
import time

import numba
import numpy as np

from gimbal_reduction.results.bench.chain_stability import (
    DRIFT_MODEL,
    THESIS_ANGLES,
    build,
    drift_run,
    log,
    measure_chain_rk4_limit,
    omega_top_over_angles,
)
from gimbal_reduction.results.bench.hard_cases import HARD_CASE_TOLERANCE, HARD_MODEL, run_hard_cases, scene_variant
from gimbal_reduction.results.bench.rk4_theory import (
    RK4_BOUND,
    oscillator_rk4_limit,
    rk4_imaginary_axis_limit,
    rk4_real_axis_limit,
)
from gimbal_reduction.reduction import models
from gimbal_reduction.solver import bodyconfig
from gimbal_reduction.solver.dynamics import integrators, scenes
from gimbal_reduction.workflow.provenance import provenance, savefig, versions, write_json, write_text
from gimbal_reduction.workflow import config as cfgmod

ROOT = str(cfgmod.ROOT)   # the project folder (workflow.config.project_dir)

LIMIT_TOLERANCE = 0.05                     # |h* / (2.785 / omega_max) - 1| must stay below this
DRIFT_TOLERANCE = 1e-6                     # relative energy drift over the 10 s free run

# Models of the step sweep: vibration modes only (two rankings), one static mode per
# body, one static mode on one body, and three static modes on one body (their Rayleigh
# frequencies lie far above the kept modes: they set omega_max).
SWEEP_MODELS = ("freq-5", "xmx-10", "static-8", "static-10@2:output_motor_fz",
                "freq-6@2:output_motor_fz+output_motor_my+output_motor_mz")
QUICK_SWEEP_MODELS = ("freq-5", "freq-6@2:output_motor_fz+output_motor_my+output_motor_mz")
# Integrator settings of the drift runs: the defaults (rk4 at RK4_DEFAULT_FRACTION of its
# limit, dop853 at rtol 1e-10 / atol 1e-14), except generalized-alpha, whose default step is
# the output interval (10 ms here): it gets 1 ms (h omega_max = 12: every elastic mode is
# filtered, the gimbal motion resolved), rho_inf 0.9.
# The exponential integrator is not symplectic: its local errors (tol per step) accumulate
# into the energy.  Measured on this model and scene (10 s): tol 5e-6 drift
# 1.3e-5 (438 steps, 1.1 s), 1e-7 1.3e-6 (9,974 steps), 1e-8 5.5e-8 (30,645 steps, 12.5 s);
# 1e-8 is the setting that holds DRIFT_TOLERANCE (docs/exponential.md Section 9).
DRIFT_OPTIONS = {"rk4": {}, "dop853": {}, "generalized-alpha": {"step": 1e-3},
                 "exponential": {"tol": 1e-8}}


# ============================================================== the study (CLI)
def load_inputs(body_files, reduction_files):
    """(rankings, body data, provenance of the inputs) with one-line errors for missing files;
    body_files, reduction_files: {body: path}."""
    for files, what in ((body_files, "modes"), (reduction_files, "reduction")):
        for b in models.BODIES:
            if not os.path.exists(files[b]):
                raise FileNotFoundError(f"{files[b]} missing (run the {what} stage first)")
    rankings = models.read_rankings(reduction_files)
    data = {b: models.load_body_file(body_files[b]) for b in models.BODIES}
    prov = {f"body{b}": {"path": body_files[b],
                         "config_hash": str(data[b]["attrs"].get("config_hash", ""))}
            for b in models.BODIES}
    return rankings, data, prov


def run_rk4_sweep(model_names, rankings, data, n_steps, rtol=2e-4):
    """Part a: ``measure_chain_rk4_limit`` per model at the thesis configuration, plus the
    top coupled frequency over a grid of angles.  {model: dict with ``pass``}."""
    out = {}
    for name in model_names:
        log(f"rk4 limit: {name} ...")
        chain = build(name, rankings, data)
        res = measure_chain_rk4_limit(chain, n_steps=n_steps, rtol=rtol)
        grid_max, where = omega_top_over_angles(chain)
        res.update(omega_grid_max=grid_max, omega_grid_argmax=where.tolist(),
                   grid_over_omega_max=grid_max / res["omega_max"])
        res["pass"] = bool(abs(res["ratio_bound"] - 1.0) < LIMIT_TOLERANCE)
        log(f"rk4 limit: {name}: h* = {res['h_measured']:.4e} s, 2.785/omega_max = "
            f"{res['h_bound']:.4e} s (ratio {res['ratio_bound']:.4f}), h* omega_top = "
            f"{res['h_omega_top']:.4f} (2 sqrt 2 = 2.8284), {res['wall_s']:.1f} s")
        out[name] = res
    return out


def run_energy_drift(scene, rankings, data, model=DRIFT_MODEL):
    """Part b: every integrator of ``integrators.METHODS`` on ``scene`` with the settings
    ``DRIFT_OPTIONS``.  {method: dict with ``pass``}."""
    chain = build(model, rankings, data)
    out = {}
    for method in integrators.METHODS:
        log(f"energy drift: {method} on {scene.name} ({scene.duration:g} s), model {model} ...")
        res = drift_run(chain, scene, method, model_name=model, **DRIFT_OPTIONS.get(method, {}))
        res["pass"] = bool(res["drift_max"] < DRIFT_TOLERANCE)
        log(f"energy drift: {method}: max {res['drift_max']:.3e}, final {res['drift_final']:.3e}, "
            f"{res['steps']} steps, {res['wall_s']:.1f} s")
        out[method] = res
    return out


# ============================================================== outputs
def _write_csv(path, header, rows, record=None):
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    w.writerows(rows)
    write_text(path, buf.getvalue(), record)         # provenance in a sidecar
    return path


def write_csvs(out_dir, sweep, drift, cases, record=None):
    """rk4_limit.csv, energy_drift.csv, hard_cases.csv, gimbal_lock.csv in out_dir, each with its
    provenance sidecar (record, default ``provenance()``); list of paths."""
    record = record or provenance()
    paths = []
    cols = ("n_modes", "modal_omega_max", "omega_top", "omega_max", "omega_grid_max", "h_measured",
            "h_lo", "h_hi", "h_bound", "h_imaginary", "ratio_bound", "ratio_imaginary", "pass")
    paths.append(_write_csv(os.path.join(out_dir, "rk4_limit.csv"), ("model",) + cols,
                            [[m] + [("+".join(map(str, r[c])) if c == "n_modes" else r[c]) for c in cols]
                             for m, r in sweep.items()], record))
    if drift:
        methods = list(drift)
        t = drift[methods[0]]["t"]
        rows = [[f"{t[i]:.6g}"] + [f"{drift[m]['drift'][i]:.6e}" for m in methods] for i in range(t.size)]
        paths.append(_write_csv(os.path.join(out_dir, "energy_drift.csv"),
                                ["t_s"] + [f"drift_{m}" for m in methods], rows, record))
    paths.append(_write_csv(os.path.join(out_dir, "hard_cases.csv"),
                            ("case", "model", "scene", "outcome", "E_max", "message", "wall_s", "pass"),
                            [[k, r.get("model", ""), r.get("scene", ""), r["outcome"], r.get("E_max", ""),
                              r.get("message", ""), r.get("wall_s", ""), r["pass"]]
                             for k, r in cases.items()], record))
    lock = cases.get("gimbal_lock", {}).get("conditioning")
    if lock:
        keys = ("lock_distance", "axis_alignment", "omega_top", "cond_M", "cond_joints", "cond_schur",
                "min_eig_schur")
        paths.append(_write_csv(os.path.join(out_dir, "gimbal_lock.csv"), ("configuration",) + keys,
                                [[r["configuration"]] + [r[k] for k in keys] for r in lock], record))
    return paths


def _save(fig, path, record=None):
    savefig(fig, path, record, format="png", dpi=150)       # provenance in the PNG's metadata
    return path


def plot_rk4_limit(sweep, path, record=None):
    """Measured h* against 2.785/omega_max (left), and h*/(2.785/omega_max) per model (right)."""
    import matplotlib  # optional heavy dependency: imported only when a figure is drawn
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(sweep)
    hb = np.array([sweep[m]["h_bound"] for m in names])
    hm = np.array([sweep[m]["h_measured"] for m in names])
    ratio = hm / hb
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
    lo, hi = hb.min() / 1.3, hb.max() * 1.3
    a1.loglog([lo, hi], [lo, hi], "k-", lw=0.8, label="h* = 2.785 / omega_max")
    undamped = 2 * np.sqrt(2) / RK4_BOUND
    a1.loglog([lo, hi], [lo * undamped, hi * undamped], "k--", lw=0.8,
              label="h* = 2 sqrt 2 / omega_max")
    for m, x, y in zip(names, hb, hm):
        a1.loglog(x, y, "o", label=m if len(m) < 30 else m[:28] + "...")
    a1.set_xlabel("theory 2.785 / omega_max [s]")
    a1.set_ylabel("measured RK4 limit h* [s]")
    a1.legend(fontsize=7, loc="upper left")
    x = np.arange(len(names))
    a2.axhspan(1 - LIMIT_TOLERANCE, 1 + LIMIT_TOLERANCE, color="0.9", label="check: +-5 %")
    a2.axhline(1.0, color="k", lw=0.8)
    a2.axhline(2 * np.sqrt(2) / RK4_BOUND, color="k", ls="--", lw=0.8,
               label="2 sqrt 2 / 2.785 = 1.0156 (undamped)")
    a2.plot(x, ratio, "o", label="vs 2.785 / omega_max (Problem: max over 4 configurations)")
    top = np.array([sweep[m]["h_measured"] * sweep[m]["omega_top"] / RK4_BOUND for m in names])
    a2.plot(x, top, "o", mfc="none", label="vs 2.785 / omega_top (thesis configuration)")
    a2.set_xticks(x)
    a2.set_xticklabels([m if len(m) < 16 else m[:14] + "..." for m in names], rotation=20, fontsize=7)
    a2.set_ylabel("h* / (2.785 / omega_max)")
    a2.set_ylim(0.93, 1.07)
    a2.legend(fontsize=7, loc="lower right")
    fig.suptitle("RK4 stability limit: measured (bisection) vs theory, thesis configuration")
    fig.tight_layout()
    _save(fig, path, record)
    plt.close(fig)
    return path


def plot_energy_drift(drift, path, title="", record=None):
    """|E(t) - E(0)| / |E(0)| against t for every integrator (log scale)."""
    import matplotlib  # optional heavy dependency: imported only when a figure is drawn
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    floor = 1e-17
    for m, r in drift.items():
        label = f"{m} ({r['steps']} steps, {r['wall_s']:.1f} s)"
        ax.semilogy(r["t"][1:], np.maximum(r["drift"][1:], floor), lw=0.8, label=label)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("|E(t) - E(0)| / |E(0)|")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    _save(fig, path, record)
    plt.close(fig)
    return path


def _summary(obj):
    """JSON-ready copy: arrays to lists, long time series dropped (they go to the CSVs)."""
    if isinstance(obj, dict):
        return {k: _summary(v) for k, v in obj.items() if k not in ("t", "drift")}
    if isinstance(obj, (list, tuple)):
        return [_summary(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer, np.bool_)):
        return obj.item()
    if isinstance(obj, float) and not np.isfinite(obj):
        return str(obj)
    return obj


def _versions(versions):
    """gimbal_reduction.workflow.provenance.versions() plus numba (the compiled right-hand side)."""
    out = versions()
    out["numba"] = numba.__version__     # required: the compiled right-hand side (no NumPy fallback)
    return out


class _Parser(argparse.ArgumentParser):
    """Argument errors as one line, exit status 2."""

    def error(self, message):
        self.exit(2, f"stability: {message} (see --help)\n")


def main(argv=None):
    ap = _Parser(prog="python -m gimbal_reduction.results.bench.stability",
                 description="Numerical stability stress tests of the integrators ("
                             "docs/stability.md).")
    ap.add_argument("--bodies", nargs=4, required=True, metavar="BODY_FILE",
                    help="the modal stage's body files of bodies 2, 3, 4, 5")
    ap.add_argument("--reductions", nargs=4, required=True, metavar="REDUCTION_FILE",
                    help="the reduction stage's files of bodies 2..5 (frequency/XMX/XMGMX rankings)")
    ap.add_argument("--out-dir", default=os.path.join(ROOT, "results", "stability"))
    ap.add_argument("--figures-dir", default=os.path.join(ROOT, "results", "figures", "stability"))
    ap.add_argument("--quick", action="store_true",
                    help="reduced version (2 models, 2000-step trials, 1 s drift, 5 ms hard cases)")
    ap.add_argument("--config", help="the current configuration file: input files of another "
                                     "configuration are refused before the work (gimbal_reduction.solver.bodyconfig)")
    args = ap.parse_args(argv)
    command_args = list(sys.argv[1:] if argv is None else argv)
    os.environ.setdefault("MPLBACKEND", "Agg")
    start = time.perf_counter()
    try:
        bodyconfig.check_files(args.bodies + args.reductions, args.config)
        rankings, data, inputs = load_inputs(dict(zip(models.BODIES, args.bodies)),
                                             dict(zip(models.BODIES, args.reductions)))
        drift_scene = scenes.load_scene("free_10s")
    except (FileNotFoundError, ValueError) as exc:
        print(f"stability: {exc}", file=sys.stderr)
        return 2
    if args.quick:
        drift_scene = scene_variant(drift_scene, "free_10s (quick: 1 s)", duration=1.0)
    log(f"{'quick' if args.quick else 'full'} run; inputs {' '.join(args.bodies)} {' '.join(args.reductions)}")

    omega = 1000.0
    osc = oscillator_rk4_limit(omega)
    x_imag = rk4_imaginary_axis_limit()
    oscillator = {"omega": omega, "h_measured": osc["step"], "h_omega": osc["step"] * omega,
                  "exact": x_imag, "relative_offset": osc["step"] * omega / x_imag - 1.0,
                  "pass": bool(abs(osc["step"] * omega / x_imag - 1.0) < 2e-4)}
    log(f"scalar oscillator: h* omega = {oscillator['h_omega']:.6f} (2 sqrt 2 = {x_imag:.6f})")

    sweep = run_rk4_sweep(QUICK_SWEEP_MODELS if args.quick else SWEEP_MODELS, rankings, data,
                          n_steps=2000 if args.quick else 4000)
    drift = run_energy_drift(drift_scene, rankings, data)
    cases = run_hard_cases(rankings, data, quick=args.quick)

    os.makedirs(args.out_dir, exist_ok=True)
    record = provenance(sources=[*args.bodies, *args.reductions])
    csvs = write_csvs(args.out_dir, sweep, drift, cases, record)
    figs = [plot_rk4_limit(sweep, os.path.join(args.figures_dir, "rk4_limit.png"), record),
            plot_energy_drift(drift, os.path.join(args.figures_dir, "energy_drift.png"),
                              f"scene {drift_scene.name}, model {DRIFT_MODEL}: relative energy drift", record)]
    parts = {"scalar_oscillator": oscillator["pass"],
             "rk4_limit": all(r["pass"] for r in sweep.values()),
             "energy_drift": all(r["pass"] for r in drift.values()),
             "hard_cases": all(r["pass"] for r in cases.values())}
    wall = time.perf_counter() - start
    report = {
        "title": "Numerical stability stress tests",
        "quick": bool(args.quick),
        "theory": {"rk4_imaginary_axis": x_imag, "rk4_real_axis": rk4_real_axis_limit(),
                   "project_bound": RK4_BOUND,
                   "imaginary_over_bound": x_imag / RK4_BOUND},
        "scalar_oscillator": oscillator,
        "rk4_limit": {"tolerance": LIMIT_TOLERANCE, "configuration": list(THESIS_ANGLES),
                      "check": "|h* / (2.785 / Problem.omega_max) - 1| < tolerance",
                      "models": sweep, "pass": parts["rk4_limit"]},
        "energy_drift": {"scene": drift_scene.name, "duration_s": drift_scene.duration,
                         "model": DRIFT_MODEL, "tolerance": DRIFT_TOLERANCE,
                         "model_choice": "first mode of the outer and middle gimbals only: omega_max "
                                         "1.2e4 rad/s, so 10 s cost 9e4 RK4 steps; the first modes of "
                                         "bodies 4 and 5 couple at 4.5e4 and 4.1e5 rad/s",
                         "methods": drift, "pass": parts["energy_drift"]},
        "hard_cases": {"model": HARD_MODEL, "tolerance": HARD_CASE_TOLERANCE, "cases": cases,
                       "pass": parts["hard_cases"]},
        "pass": all(parts.values()),
        "parts": parts,
        "outputs": {"csv": csvs, "figures": figs},
        "provenance": {"command": " ".join(["python -m gimbal_reduction.results.bench.stability"] + command_args),
                       "wall_time_s": wall, "created": time.strftime("%Y-%m-%dT%H:%M:%S"),
                       "versions": _versions(versions), "inputs": inputs},
    }
    path = os.path.join(args.out_dir, "stability.json")
    write_json(path, _summary(report), record)
    failed = [k for k, v in parts.items() if not v]
    log(f"{path}: {'FAILED: ' + ', '.join(failed) if failed else 'all checks pass'} ({wall:.0f} s)")
    return 0 if report["pass"] else 1


if __name__ == "__main__":
    sys.exit(main())