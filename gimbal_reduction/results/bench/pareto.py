"""Wall time against accuracy for every reduced model x integrator: the Pareto front.

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python -m gimbal_reduction.results.bench.pareto --scene thesis \\
        --truth results/reference/thesis/truth.h5 --models freq-5 freq-10 xmx-10 static-8 \\
        --repeats 5 --bodies results/modes/body{2,3,4,5}.h5 --reductions results/reduction/body{2,3,4,5}.h5 \\
        --load-ranking results/reduction/load/thesis.h5 \\
        --out-csv results/benchmarks/pareto.csv --figure results/figures/bench/pareto.png [--quick]

For every model (``gimbal_reduction.reduction.models`` grammar, load-aware ``load-N`` / ``global-N``
included; the truth model is always added)
and every integrator setting (``SETTINGS``: RK4 at the stability-limited step
and at the default half of it; DOP853 at rtol 1e-6, 1e-8, 1e-10; generalised-alpha
at three steps), the scene is integrated and two numbers are recorded:

* time: the wall time of the integration (``integrators.Run.wall_time``: the
  stepping and the output monitor; the model's assembly and its coupled
  omega_max are setup, reported apart), median of ``--repeats`` runs after one
  short warm-up run that compiles the JIT kernels.  A setting whose run takes
  longer than ``--budget / --repeats`` seconds is timed over a prefix of the
  scene and scaled by its step count (``gimbal_reduction.results.bench.timing``);
  the CSV's ``time_basis`` says which.  ``--errors-only`` makes the untimed
  runs (E, steps) as a job beside others; ``--errors-from`` then times alone.
* E: thesis eq 3.53 per gimbal rate (``gimbal_reduction.solver.dynamics.error_measure.error_measure``) against
  the converged truth file, and E = the maximum over the four rates (the
  convention of docs/dynamics.md's convergence and integrator tables; the study
  tables list the four separately, so does the CSV).  For the truth model E is
  the integration error alone; the truth file is converged to E ~ 7e-12, so
  smaller values mean "as converged as the reference" (drawn at ``E_FLOOR``).

The dense baseline (``gimbal_reduction.solver.dynamics.dense_baseline``) runs RK4 on the truth model at
the stability-limited step over the first ``--dense-duration`` seconds of the
scene, and the structured solver runs the same segment in the same process:
their ratio is the speed-up; the dense full-run time is extrapolated from its
segment (its trajectory equals the structured one to round-off: the CSV's
``deviation``), and its E is the structured run's.  The column-assembly
variant runs a shorter segment (``--columns-duration``).

``--truth-runs SETTING=FILE`` (with ``--errors-only``) gives a run of the truth at one setting
that another job already made (the integrator table's RK4 run of the truth at half the limit,
``rk4-0.5``): its E and steps are taken from the file instead of integrating again, once the file
is checked to be that run (``truth_file_row``: the scene, the truth model's hash, the integrator
and its option, the simulation hash ``simulate.config_hash``, the output grid).

Pareto front: the non-dominated points (no other point is both faster and
more accurate), over all rows that ran (``pareto`` = 1 in the CSV).  Outputs: the CSV
(``CSV_COLUMNS``), a JSON beside it (settings, environment, dense comparison),
and the chart (time log-scale vs E log-scale, one marker per integrator
setting, one colour per model family, the front as a staircase).
"""
from __future__ import annotations

import os

# One BLAS thread, as in the simulation rules (set before numpy is imported).
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from dataclasses import dataclass  # noqa: E402

import numpy as np  # noqa: E402

from gimbal_reduction.reduction import models  # noqa: E402
from gimbal_reduction.reduction.names import STYLES, needs_load_ranking, parse_or_none  # noqa: E402
from gimbal_reduction.solver import bodyconfig  # noqa: E402
from gimbal_reduction.results.bench import timing  # noqa: E402
from gimbal_reduction.results.study.cases import describe_model  # noqa: E402
from gimbal_reduction.results.study.figures import STYLE, pareto_front  # noqa: E402
from gimbal_reduction.results.study.tables import RATE_COLUMNS  # noqa: E402
from gimbal_reduction.solver.dynamics import dense_baseline, integrators, scenes, simulate  # noqa: E402
from gimbal_reduction.solver.dynamics.error_measure import ErrorsInputError, check_same_grid, error_measure  # noqa: E402
from gimbal_reduction.solver.dynamics.simfile import mismatches as simfile_mismatches, read_sim  # noqa: E402
from gimbal_reduction.workflow.provenance import csv_text, provenance, savefig, versions, write_json, write_text  # noqa: E402
from gimbal_reduction.workflow import config as cfgmod

ROOT = str(cfgmod.ROOT)   # the project folder (workflow.config.project_dir)
E_FLOOR = 1e-12                  # below the truth file's own convergence (E ~ 7e-12)
DEFAULT_MODELS = ("freq-5", "xmx-10", "static-8")   # ~2.5 min each, the truth ~4 min
QUICK_DURATION = 2e-4            # s: 20 output samples of scene thesis
DENSE_DURATION = 2e-4            # s of the scene the dense baseline runs (then extrapolated)
COLUMNS_DURATION = 1e-5          # s for the column-assembly variant (one output interval)
QUICK_DENSE_DURATION = 1e-4
CSV_COLUMNS = ("model", "family", "n_elastic", "solver", "integrator", "method", "fraction", "rtol",
               "step_s", "steps", "wall_time_s", "wall_time_min_s", "runs", "time_basis", "E",
               *RATE_COLUMNS, "pareto", "status", "omega_max_rad_s", "setup_s", "deviation",
               "speedup")


@dataclass(frozen=True)
class Setting:
    """One integrator configuration (arguments of ``integrators.integrate``)."""
    name: str
    method: str
    fraction: float | None = None    # rk4: step as a fraction of 2.785 / omega_max
    rtol: float | None = None        # dop853 (atol 1e-14, as the truth default)
    step: float | None = None        # generalized-alpha step [s] (rho_inf 0.9)
    tol: float | None = None         # exponential: local error tolerance

    def kwargs(self):
        out = {"method": self.method}
        if self.tol is not None:
            out["tol"] = self.tol
        if self.fraction is not None:
            out["fraction"] = self.fraction
        if self.rtol is not None:
            out.update(rtol=self.rtol, atol=1e-14)
        if self.step is not None:
            out.update(step=self.step, rho_inf=0.9)
        return out


def default_settings(rk4_fractions=(1.0, 0.5), rtols=(1e-6, 1e-8, 1e-10),
                     galpha_steps=(1e-5, 5e-6, 2.5e-6), exp_tols=(1e-5, 5e-8)):
    """The integrator settings: the modal exponential integrator at each tolerance (1e-5:
    the workflow's default), RK4 at each fraction of its stability limit (1.0 = the
    largest stable step dividing the output interval; 0.5 = the thesis's setting),
    DOP853 at each rtol, generalised-alpha at each step [s]."""
    return ([Setting(f"exp-{t:.0e}", "exponential", tol=float(t)) for t in exp_tols]
            + [Setting(f"rk4-{f:g}", "rk4", fraction=float(f)) for f in rk4_fractions]
            + [Setting(f"dop853-{r:.0e}", "dop853", rtol=float(r)) for r in rtols]
            + [Setting(f"galpha-{h:.2g}", "generalized-alpha", step=float(h)) for h in galpha_steps])


def model_family(name):
    """Colour group of a model: the study group (freq, xmx, static-freq, load-case, truth ...)
    or, for names outside the study (load-10, global-8, per-body counts), the name's prefix."""
    group = describe_model(name)["group"]
    if group != "other":
        return group
    parsed = parse_or_none(name)
    if parsed is None:
        return "other"
    return parsed.group if parsed.group != "other" else parsed.family


# ------------------------------------------------------------------ pure helpers
def pareto_mask(cost, err):
    """(N,) bool: True for the non-dominated points of (cost, err), both minimised; points
    with a non-finite coordinate are never on the front (``gimbal_reduction.results.study.figures.pareto_front``)."""
    mask = np.zeros(len(cost), dtype=bool)
    mask[pareto_front(cost, err)] = True
    return mask


def max_rate_error(t, reference, rates):
    """(E, E per rate (4,)): eq 3.53 per gimbal rate (columns of (T, 4) arrays [rad/s]) and
    its maximum, the accuracy of one run."""
    per = np.atleast_1d(error_measure(t, reference, rates))
    return float(np.nanmax(per)), per


def run_budget(first_run_s, repeats, budget_s):
    """Number of timed runs: ``repeats``, fewer (>= 1) if they would not fit in budget_s."""
    if first_run_s * repeats <= budget_s:
        return int(repeats)
    return int(max(1, min(repeats, budget_s // max(first_run_s, 1e-9))))


# ------------------------------------------------------------------ running
def truth_prefix(truth, duration):
    """The truth file's t, gamma_dot restricted to t <= duration (+ half a sample)."""
    k = int(np.searchsorted(truth["t"], duration * (1 + 1e-9), side="right"))
    return truth["t"][:k], truth["gamma_dot"][:k]


def integrate(prob, setting, duration, dt, model):
    return integrators.integrate(prob, duration, dt, model=model, **setting.kwargs())


def time_setting(prob, setting, duration, dt, t_ref, g_ref, repeats, budget_s, model, known=None):
    """Row fields of one model x setting: E against (t_ref, g_ref) from a run of the whole scene,
    and the median wall time of ``repeats`` runs after a warm-up run over two output intervals
    (``timing.median_timing``: whole runs where they fit in ``budget_s``, else a prefix scaled by
    the step count).  known: this setting's row of an untimed run (``--errors-from``): its E and
    steps are taken and only the timing runs; repeats 0: no timing (``--errors-only``: the row's
    time is its one run's, ``time_basis`` says so)."""
    row = {"solver": "structured", "integrator": setting.name, "method": setting.method,
           "fraction": setting.fraction, "rtol": setting.rtol}
    try:
        integrate(prob, setting, min(2 * dt, duration), dt, model)           # JIT warm-up
        if known is None:
            first = integrate(prob, setting, duration, dt, model)
            check_same_grid(t_ref, first.t, f"{model} {setting.name}")
            E, per = max_rate_error(t_ref, g_ref, first.yd[:, :4])
            step = duration / max(first.steps, 1) if setting.method == "dop853" else first.step
            row.update(step_s=step, steps=first.steps, E=E, **dict(zip(RATE_COLUMNS, map(float, per))),
                       status="ok", _run=first, wall_time_s=first.wall_time,
                       wall_time_min_s=first.wall_time, runs=1,
                       time_basis="one run, not timed alone")
        elif known.get("status") != "ok":
            return {**row, "status": known.get("status") or "failed"}
        else:
            row.update({k: known[k] for k in ("step_s", "steps", "E", *RATE_COLUMNS)}, status="ok")
        if repeats > 0:
            row.update(timing.median_timing(lambda d: integrate(prob, setting, d, dt, model), duration,
                                            dt, known["wall_time_s"] if known else first.wall_time,
                                            int(row["steps"]), repeats, budget_s,
                                            scalable=setting.method != "exponential"))
            row.pop("wall_times_s")
            row.pop("duration_timed_s")
    except (integrators.DivergenceError, integrators.StepTooLargeError) as exc:
        return {**row, "status": f"failed: {exc}"}
    return row


def truth_model_hash(scene, body_files):
    """The config_hash a reduced-model file of the truth on ``scene`` has when made from
    ``body_files`` {body: path} (``models.model_config_hash``: the truth ranks by frequency)."""
    body_data = {b: models.load_body_file(body_files[b]) for b in models.BODIES}
    spec = models.restrict_to_bodies(models.model_spec("truth", models.frequency_rankings(body_data)),
                                     scene.elastic_bodies)
    return models.model_config_hash(spec, body_data, scene)


def truth_file_row(path, setting, scene, model_hash, t_ref, g_ref):
    """``time_setting``'s untimed row of the truth at ``setting`` from a simulation file of that run
    (``--truth-runs``), its time the file's integration time (one run, not timed alone);
    ValueError (one line) unless the file is the truth (``model_hash``) on ``scene`` with the
    setting's integrator and option (``option_fraction`` of RK4, ``option_tol`` of the exponential
    integrator), its simulation hash agreeing, on the reference's output grid."""
    f = read_sim(path)
    a = f["attrs"]
    options = {k: v for k, v in setting.kwargs().items() if k in ("tol", "fraction")}
    want = {"scene": scene.name, "model": "truth", "model_config_hash": model_hash,
            "integrator": setting.method,
            "config_hash": simulate.config_hash(scene, model_hash,
                                                {"integrator": setting.method, "step": None, **options}),
            **{f"option_{k}": v for k, v in options.items()}}
    wrong = simfile_mismatches(a, want)
    if wrong:
        raise ValueError(f"--truth-runs {setting.name}={path} is not the truth's {setting.name} run on scene "
                         f"{scene.name}: it has {wrong}")
    check_same_grid(t_ref, f["t"], f"--truth-runs {setting.name}={path}")
    E, per = max_rate_error(t_ref, g_ref, f["gamma_dot"][:, :4])
    return {"solver": "structured", "integrator": setting.name, "method": setting.method,
            "fraction": setting.fraction, "rtol": setting.rtol, "step_s": float(a["step"]),
            "steps": int(a["steps"]), "E": E, **dict(zip(RATE_COLUMNS, map(float, per))), "status": "ok",
            "wall_time_s": float(a["integration_time_s"]), "wall_time_min_s": float(a["integration_time_s"]),
            "runs": 1, "time_basis": "one run, not timed alone (read from another job's file)"}


def parse_truth_runs(items, settings, errors_only, scene, body_files, duration, truth):
    """{setting name: the truth's row (``truth_file_row``, E against ``truth`` over ``duration``)}
    of ``--truth-runs`` SETTING=FILE items, each file checked now, before any integration; ValueError (one line) on a
    malformed item, an unknown setting, use without --errors-only, or a file that is not the run."""
    if not items:
        return {}
    if not errors_only:
        raise ValueError("--truth-runs is for the untimed run (--errors-only)")
    by_name = {s.name: s for s in settings}
    model_hash = truth_model_hash(scene, body_files)
    t_ref, g_ref = truth_prefix(truth, duration)
    out = {}
    for item in items:
        name, sep, path = item.partition("=")
        if not sep or name not in by_name or name in out:
            raise ValueError(f"--truth-runs {item!r}: not SETTING=FILE of a setting run here, once "
                             f"({', '.join(by_name)})")
        out[name] = truth_file_row(path, by_name[name], scene, model_hash, t_ref, g_ref)
    return out


def read_errors(path):
    """{(model, integrator): row} of a CSV of this module (``--errors-only``): the numbers as floats."""
    import csv
    out = {}
    with open(path, newline="") as fh:
        for r in csv.DictReader(fh):
            row = {k: (float(v) if v not in ("", None) and k not in ("model", "family", "solver",
                   "integrator", "method", "time_basis", "status") else v) for k, v in r.items()}
            out[(r["model"], r["integrator"])] = row
    return out


def dense_comparison(prob, duration, dt, repeats, assembly="composite"):
    """The dense baseline against the structured solver, RK4 at the stability-limited step,
    over the first ``duration`` seconds: (dense wall time [s] of one run, structured median
    [s] of ``repeats`` runs, steps, deviation = max |rate difference| / max |rate|)."""
    setting = Setting("rk4-1", "rk4", fraction=1.0)
    dprob = dense_baseline.dense_problem(prob, assembly)
    integrate(dprob, setting, min(dt, duration), dt, "truth (dense)")             # warm-up
    integrate(prob, setting, min(dt, duration), dt, "truth")
    d = integrate(dprob, setting, duration, dt, "truth (dense)")
    s_times, s = [], None
    for _ in range(max(int(repeats), 1)):
        s = integrate(prob, setting, duration, dt, "truth")
        s_times.append(s.wall_time)
    dev = float(np.max(np.abs(d.yd[:, :4] - s.yd[:, :4])) / max(np.max(np.abs(s.yd[:, :4])), 1e-300))
    return {"assembly": assembly, "duration_s": duration, "steps": d.steps, "step_s": d.step,
            "dense_wall_time_s": d.wall_time, "structured_wall_time_s": float(np.median(s_times)),
            "structured_runs": len(s_times), "speedup": d.wall_time / float(np.median(s_times)),
            "deviation": dev, "lu_fallbacks": dprob.rhs.stats["lu_fallbacks"], "_run": d}


def load_models(names, scene, body_files, reduction_files, load_ranking=None):
    """{name: (chain, problem, setup seconds)}; every name is parsed before anything is built
    (one-line ModelError for a bad one).  load-N / global-N models read the scene's
    load-aware ranking (``gimbal_reduction.reduction.load_aware``).  body_files, reduction_files: {body: path}."""
    rankings = models.read_rankings(reduction_files)
    load_aware = any(needs_load_ranking(n) for n in names)
    if load_aware:
        if load_ranking is None:
            raise models.ModelError("load-N / global-N models need the scene's load-aware ranking "
                                    "(--load-ranking)")
        models.load_load_ranking(load_ranking, rankings)
    specs = [models.model_spec(n, rankings) for n in names]
    body_data = {b: models.load_body_file(body_files[b]) for b in models.BODIES}
    if load_aware:
        models.check_load_ranking(load_ranking, rankings, body_data, scene)   # same bodies, scene?
    out = {}
    for spec in specs:
        t0 = time.perf_counter()
        chain = models.build_chain(spec, body_data, scene.damping_ratio)
        prob = simulate.scene_problem(chain, scene)
        out[spec.name] = (chain, prob, time.perf_counter() - t0)
    return out


def evaluate(problems, settings, duration, dt, truth, repeats, budget_s, log=print, known=None,
             truth_rows=None):
    """Rows (dicts) of every model x setting, without the Pareto mark; known: {(model,
    integrator): row} of an untimed run (read_errors), whose E the rows take; truth_rows: {setting
    name: the truth's untimed row read from a file} (``parse_truth_runs``), taken as it is."""
    t_ref, g_ref = truth_prefix(truth, duration)
    truth_rows = truth_rows or {}
    rows = []
    for name, (chain, prob, setup) in problems.items():
        base = {"model": name, "family": model_family(name), "n_elastic": sum(chain.n_modes),
                "omega_max_rad_s": prob.omega_max, "setup_s": setup}
        for s in settings:
            t0 = time.perf_counter()
            k = None
            if known is not None:
                k = known.get((name, s.name))
                if k is None:
                    raise ValueError(f"{name} {s.name}: not in the untimed run's CSV (--errors-from)")
            if name == "truth" and s.name in truth_rows:
                row = {**base, **truth_rows[s.name]}
            else:
                row = {**base, **time_setting(prob, s, duration, dt, t_ref, g_ref, repeats, budget_s, name, k)}
            rows.append(row)
            what = (f"{row['wall_time_s']:.3g} s (x{row['runs']}, {row['time_basis']}), E {row['E']:.2e}"
                    if row["status"] == "ok" else row["status"])
            log(f"gimbal_reduction.results.bench.pareto: {name} {s.name}: {what} [{time.perf_counter() - t0:.0f} s]")
    return rows


def dense_row(truth_rows, comp, duration, t_ref, g_ref):
    """CSV row of the dense baseline: its own E if it ran the whole ``duration``, else the
    structured RK4 run's E (same trajectory to round-off: ``deviation``) and its wall time
    extrapolated from the segment (time per simulated second x duration)."""
    ref = next((r for r in truth_rows if r["integrator"] == "rk4-1" and r["status"] == "ok"), None)
    if ref is None:
        return None
    row = {**{k: ref[k] for k in ("model", "n_elastic", "integrator", "method", "fraction", "step_s",
                                  "steps", "E", *RATE_COLUMNS, "omega_max_rad_s", "setup_s")},
           "family": f"dense-{comp['assembly']}", "solver": f"dense-{comp['assembly']}", "runs": 1,
           "status": "ok", "deviation": comp["deviation"], "speedup": comp["speedup"]}
    if comp["duration_s"] >= duration * (1 - 1e-9):
        E, per = max_rate_error(t_ref, g_ref, comp["_run"].yd[:, :4])
        row.update(E=E, **dict(zip(RATE_COLUMNS, map(float, per))), time_basis="measured")
        wall = comp["dense_wall_time_s"]
    else:
        wall = comp["dense_wall_time_s"] * duration / comp["duration_s"]
        row["time_basis"] = f"extrapolated from {comp['steps']} of {ref['steps']} steps"
    return {**row, "wall_time_s": wall, "wall_time_min_s": wall}


# ------------------------------------------------------------------ output
def format_csv(rows):
    """CSV text (CSV_COLUMNS; floats with 6 significant digits, missing = empty)."""
    return csv_text(rows, CSV_COLUMNS, 6)


MARKERS = {"exponential": ("D", "d"), "rk4": ("o", "s", "h"), "dop853": ("^", "v", "<", ">"),
           "generalized-alpha": ("P", "X", "*", "p")}
FAMILY_COLORS = {"truth": "black", "dense-composite": "tab:red", "dense-columns": "darkred"}


def _styles(rows):
    """(marker per integrator, colour per family) for the chart."""
    markers, used = {}, {}
    for r in rows:
        if r["integrator"] not in markers:
            k = used.get(r["method"], 0)
            markers[r["integrator"]] = MARKERS[r["method"]][k % len(MARKERS[r["method"]])]
            used[r["method"]] = k + 1
    cycle = iter(["tab:cyan", "tab:olive", "tab:gray", "gold", "navy", "magenta", "teal"])
    colors = {}
    for r in rows:
        f = r["family"]
        if f not in colors:
            colors[f] = FAMILY_COLORS.get(f) or (STYLES[f].colour if f in STYLES else next(cycle, "0.5"))
    return markers, colors


def plot(rows, path, title, record=None):
    """Wall time [s] (log) against E (log): every row that ran, the Pareto front as a
    staircase with its points labelled; E below E_FLOOR drawn at the floor."""
    import matplotlib  # optional heavy dependency: imported only when the chart is drawn
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    ok = [r for r in rows if r["status"] == "ok"]
    markers, colors = _styles(ok)
    with plt.rc_context(STYLE):
        fig, ax = plt.subplots(figsize=(8.5, 5.6), constrained_layout=True)
        for r in ok:
            hollow = r["solver"] != "structured"
            ax.scatter(r["wall_time_s"], max(r["E"], E_FLOOR), marker=markers[r["integrator"]],
                       s=36 if hollow else 28, zorder=3, linewidths=1.2,
                       facecolors="none" if hollow else colors[r["family"]],
                       edgecolors=colors[r["family"]])
        front = sorted((r for r in ok if r.get("pareto")), key=lambda r: r["wall_time_s"])
        if front:
            ax.step([r["wall_time_s"] for r in front], [max(r["E"], E_FLOOR) for r in front],
                    where="post", color="0.3", lw=1, ls="--", zorder=2)
            lines = []                         # numbered labels: the cheap end is crowded
            for k, r in enumerate(front, 1):
                ax.annotate(str(k), (r["wall_time_s"], max(r["E"], E_FLOOR)), fontsize=6,
                            xytext=(3, 3 if k % 2 else -9), textcoords="offset points")
                lines.append(f"{k}  {r['model']} {r['integrator']}: {r['wall_time_s']:.3g} s, "
                             f"E {r['E']:.2g}")
            ax.text(0.52, 0.10, "Pareto front\n" + "\n".join(lines), transform=ax.transAxes,
                    fontsize=6, ha="left", va="bottom", family="monospace", multialignment="left",
                    bbox=dict(boxstyle="round", fc="white", ec="0.7", alpha=0.9))
        dense = [r for r in ok if r["solver"] != "structured"]
        for k, r in enumerate(dense):          # labels alternately below and above the marker
            note = (f"{r['solver']}, RK4 ({r['time_basis'].split(' from')[0]}):\n"
                    f"structured x{r['speedup']:.0f} faster")
            ax.annotate(note, (r["wall_time_s"], max(r["E"], E_FLOOR)), fontsize=6, ha="center",
                        va="top" if k % 2 == 0 else "bottom", xytext=(0, -8 if k % 2 == 0 else 8),
                        textcoords="offset points", color="tab:red")
        ax.axhline(E_FLOOR, color="0.6", lw=0.8, ls=":")
        ax.annotate(f"E < {E_FLOOR:g} drawn here (the truth file is converged to ~7e-12)",
                    (1.0, E_FLOOR), xycoords=("axes fraction", "data"), xytext=(-4, 3),
                    textcoords="offset points", ha="right", fontsize=6, color="0.4")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time of the integration [s] (median)")
        ax.set_ylabel("E, eq 3.53, max over the four gimbal rates [-]")
        ax.set_title(title)
        fam = [Line2D([], [], ls="", marker="o", color=c, label=f) for f, c in colors.items()]
        integ = [Line2D([], [], ls="", marker=m, color="0.3", label=i) for i, m in markers.items()]
        leg = ax.legend(handles=fam, title="model family", fontsize=6, title_fontsize=7,
                        loc="upper right")
        ax.add_artist(leg)
        ax.legend(handles=integ, title="integrator", fontsize=6, title_fontsize=7, loc="lower left")
        savefig(fig, path, record, dpi=150, format="png")       # provenance in the PNG's metadata
        plt.close(fig)


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        self.exit(2, f"gimbal_reduction.results.bench.pareto: {message} (see --help)\n")


def main(argv=None) -> int:
    ap = _Parser(prog="python -m gimbal_reduction.results.bench.pareto",
                 description="Wall time against eq 3.53 error for every model x integrator; "
                             "Pareto front; dense baseline on the truth model.")
    ap.add_argument("--scene", default="thesis")
    ap.add_argument("--truth", required=True, help="converged truth simulation (the DOP853 "
                    "reference, results/reference/<scene>/truth.h5)")
    ap.add_argument("--models", nargs="+", default=list(DEFAULT_MODELS),
                    help="model names (gimbal_reduction.reduction.models grammar); the truth model is always added")
    ap.add_argument("--repeats", type=int, default=5, help="timed runs per setting (median)")
    ap.add_argument("--budget", type=float, default=20.0,
                    help="seconds of timed runs per setting; slower settings get fewer repeats")
    ap.add_argument("--bodies", nargs=4, required=True, metavar="BODY_FILE",
                    help="the modal stage's body files of bodies 2, 3, 4, 5")
    ap.add_argument("--reductions", nargs=4, required=True, metavar="REDUCTION_FILE",
                    help="the reduction stage's files of bodies 2..5 (frequency/XMX/XMGMX rankings)")
    ap.add_argument("--load-ranking", default=None,
                    help="the scene's load-aware ranking, for load-N / global-N models")
    ap.add_argument("--out-csv", required=True)
    ap.add_argument("--figure", help="PNG path (required unless --errors-only)")
    ap.add_argument("--errors-only", action="store_true",
                    help="one untimed run per setting: E and steps, the CSV only (no timing, dense "
                         "baseline or chart); a job that may run beside others")
    ap.add_argument("--errors-from", metavar="CSV",
                    help="the CSV of an --errors-only run of the same settings: its E and steps are "
                         "taken, and only the timing runs (a job that runs alone)")
    ap.add_argument("--truth-runs", nargs="*", default=[], metavar="SETTING=FILE",
                    help="with --errors-only: the truth's run at a setting (e.g. rk4-0.5) made by another "
                         "job, read (checked) instead of integrated")
    ap.add_argument("--config", help="the current configuration file: input files of another "
                                     "configuration are refused before the work (gimbal_reduction.solver.bodyconfig)")
    ap.add_argument("--rk4-fractions", type=float, nargs="+", default=[1.0, 0.5])
    ap.add_argument("--rtols", type=float, nargs="+", default=[1e-6, 1e-8, 1e-10])
    ap.add_argument("--galpha-steps", type=float, nargs="+", default=[1e-5, 5e-6, 2.5e-6])
    ap.add_argument("--exp-tols", type=float, nargs="+", default=[1e-5, 5e-8])
    ap.add_argument("--dense-duration", type=float, default=None,
                    help=f"simulated seconds the dense baseline runs, then extrapolated "
                         f"(default {DENSE_DURATION:g}; --quick {QUICK_DENSE_DURATION:g})")
    ap.add_argument("--columns-duration", type=float, default=None,
                    help=f"simulated seconds of the column-assembly variant, 0 skips it "
                         f"(default {COLUMNS_DURATION:g}; --quick 0)")
    ap.add_argument("--duration", type=float, default=None,
                    help="simulated seconds (default: the scene's; E on the truth's prefix)")
    ap.add_argument("--quick", action="store_true",
                    help=f"first {QUICK_DURATION:g} s of the scene, 2 repeats: a smoke test")
    args = ap.parse_args(argv)
    start = time.perf_counter()
    try:
        bodyconfig.check_files(args.bodies + args.reductions + ([args.load_ranking] if args.load_ranking
                                                                else []), args.config)
        if args.repeats < 1:
            raise ValueError(f"--repeats must be >= 1, got {args.repeats}")
        if not args.errors_only and not args.figure:
            raise ValueError("--figure is required (unless --errors-only)")
        if args.errors_only and args.errors_from:
            raise ValueError("--errors-only and --errors-from exclude each other")
        known = read_errors(args.errors_from) if args.errors_from else None
        scene = scenes.load_scene(args.scene)
        truth = read_sim(args.truth)
        dt = scene.output_interval
        duration = args.duration if args.duration is not None else (
            QUICK_DURATION if args.quick else scene.duration)
        duration = dt * max(1, round(min(duration, scene.duration) / dt))
        repeats = min(args.repeats, 2) if args.quick else args.repeats
        dense_d = args.dense_duration if args.dense_duration is not None else (
            QUICK_DENSE_DURATION if args.quick else DENSE_DURATION)
        cols_d = args.columns_duration if args.columns_duration is not None else (
            0.0 if args.quick else COLUMNS_DURATION)
        dense_d = dt * max(1, round(min(dense_d, duration) / dt))
        cols_d = dt * round(min(cols_d, duration) / dt)
        ta = truth["attrs"]
        if ta.get("scene") and ta["scene"] != scene.name:
            raise ValueError(f"{args.truth} is a run of scene {ta['scene']!r}, not {scene.name!r}")
        names = list(dict.fromkeys(list(args.models) + ["truth"]))
        settings = default_settings(args.rk4_fractions, args.rtols, args.galpha_steps, args.exp_tols)
        problems = load_models(names, scene, dict(zip(models.BODIES, args.bodies)),
                               dict(zip(models.BODIES, args.reductions)), args.load_ranking)
        truth_rows = parse_truth_runs(args.truth_runs, settings, args.errors_only, scene,
                                      dict(zip(models.BODIES, args.bodies)), duration, truth)
    except (ValueError, FileNotFoundError, ErrorsInputError, models.ModelError) as exc:
        print(f"gimbal_reduction.results.bench.pareto: error: {exc}", file=sys.stderr)
        return 2
    try:
        rows = evaluate(problems, settings, duration, dt, truth, 0 if args.errors_only else repeats,
                        args.budget, known=known, truth_rows=truth_rows)
    except ValueError as exc:
        print(f"gimbal_reduction.results.bench.pareto: error: {exc}", file=sys.stderr)
        return 2
    if args.errors_only:
        for r in rows:
            r.pop("_run", None)
        write_text(args.out_csv, format_csv(rows), provenance(sources=[args.truth, *args.bodies,
                                                                       *args.reductions]))
        print(f"gimbal_reduction.results.bench.pareto: {len(rows)} rows, untimed; "
              f"{time.perf_counter() - start:.0f} s -> {args.out_csv}")
        return 0
    truth_prob = problems["truth"][1]
    comparisons = []
    for assembly, seg in (("composite", dense_d), ("columns", cols_d)):
        if seg <= 0:
            continue
        t0 = time.perf_counter()
        comp = dense_comparison(truth_prob, seg, dt, repeats, assembly)
        comparisons.append(comp)
        print(f"gimbal_reduction.results.bench.pareto: dense ({assembly}) RK4 on truth over {seg:g} s ({comp['steps']} steps): "
              f"{comp['dense_wall_time_s']:.3g} s vs structured {comp['structured_wall_time_s']:.3g} s "
              f"= x{comp['speedup']:.1f} [{time.perf_counter() - t0:.0f} s]", flush=True)
        row = dense_row([r for r in rows if r["model"] == "truth"], comp, duration,
                        *truth_prefix(truth, duration))
        if row is not None:
            rows.append(row)
    ok = [i for i, r in enumerate(rows) if r["status"] == "ok"]
    mask = pareto_mask([rows[i]["wall_time_s"] for i in ok], [rows[i]["E"] for i in ok])
    for r in rows:
        r["pareto"] = 0
    for i, m in zip(ok, mask):
        rows[i]["pareto"] = int(m)
    for r in rows:
        r.pop("_run", None)
    record = provenance(sources=[args.truth, *args.bodies, *args.reductions])
    write_text(args.out_csv, format_csv(rows), record)
    plot(rows, args.figure, f"Cost against accuracy, scene {scene.name} ({duration * 1e3:g} ms); "
                            f"dashed: Pareto front", record)
    for c in comparisons:
        c.pop("_run", None)
    json_path = os.path.splitext(args.out_csv)[0] + ".json"
    write_json(json_path, {
        "description": "Wall time [s] against eq 3.53 error E (max over the gimbal rates) per model x "
                       "integrator on scene " + scene.name + "; dense baseline comparison (gimbal_reduction.results.bench.pareto).",
        "scene": scene.name, "duration_s": duration, "truth": args.truth, "repeats": repeats,
        "budget_s": args.budget, "errors_from": args.errors_from,
        "settings": [s.__dict__ for s in settings],
        "dense_comparison": comparisons, "e_floor": E_FLOOR,
        "pareto_front": [{k: r.get(k) for k in ("model", "integrator", "solver", "wall_time_s", "E")}
                         for r in sorted((r for r in rows if r["pareto"]), key=lambda r: r["wall_time_s"])],
        "environment": {k: os.environ.get(k) for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")}
        | {"cpu_count": os.cpu_count(), "loadavg_end": os.getloadavg()},
        "quick": bool(args.quick), "total_seconds": time.perf_counter() - start, "versions": versions()},
        record)
    front = [f"{r['model']} {r['integrator']}" for r in rows if r["pareto"]]
    print(f"gimbal_reduction.results.bench.pareto: {len(rows)} rows, front: {', '.join(front)}; "
          f"{time.perf_counter() - start:.0f} s -> {args.out_csv}, {json_path}, {args.figure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
