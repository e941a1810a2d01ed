"""Cost of one right-hand-side evaluation against model size: structured solver vs dense baseline.

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python -m gimbal_reduction.results.bench.scaling \\
        --out-csv results/benchmarks/scaling.csv --out-json results/benchmarks/scaling.json \\
        --figure results/figures/bench/scaling.png [--quick]

What is timed, per size (D modes on each of the four bodies, S = 4 D elastic
coordinates, n = 4 + S):

* ``structured``: ``compiled.make_rhs`` -- the articulated-body recursion with
  Woodbury-eliminated modal blocks (docs/dynamics.md Section 3), called as
  rhs(t, y, y') from Python; ``structured_loop``: the same inside its compiled
  RK4 loop (``rhs.rk4_steps``, no Python per evaluation), what a simulation runs;
* ``dense``: ``gimbal_reduction.solver.dynamics.dense_baseline`` -- bias by inverse dynamics, M(y) by the
  Jacobian (composite) assembly, LAPACK Cholesky, at every evaluation; its
  three parts are also timed alone;
* ``columns``: the dense baseline with M from n + 1 inverse-dynamics calls
  (Walker-Orin method 1, ``linearized.mass_matrix_fast``'s route), small sizes only.

Each cost is the median over ``repeats`` (default 9) of a timed batch of calls
divided by the batch size; a batch lasts at least ``batch_seconds``, and the
methods' batches are interleaved round by round (``time_interleaved``) so that
the load of a shared machine hits them alike.  The
bodies are synthetic (``synthetic_modal_chain``): random but physically valid
modal integrals of the shapes the real ones have.  Timing does not depend on
their values, only on D; the dense-vs-structured accelerations are compared at
every size as a sanity check (``agreement``).

Per simulated second: cost per evaluation x 4 / h, h = 0.5 x 2.785 / omega_max
(RK4 at its default fraction), with omega_max the *assumed* coupled highest
frequency of a chain with D modes per body: each body's spectrum is the power
law f_k = c k^beta fitted to the real bodies' 100 modes (``SPECTRUM``),
extrapolated beyond 100, times the truth model's coupled / kept ratio
``COUPLED_RATIO`` (docs/dynamics.md Section 6).

Growth law: cost = a S^p fitted by least squares on log-log over S >= ``FIT_MIN_ELASTIC``
(``fit_power_law``), per method.  Outputs: CSV (one row per size), JSON (rows,
fits, assumptions, environment), PNG (three panels: cost per evaluation, speed-up,
cost per simulated second).
"""
from __future__ import annotations

import os

# One BLAS thread, like the simulation rules: the structured solver is single-threaded,
# so the dense baseline's LAPACK gets one core too (set before numpy is imported).
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from gimbal_reduction.results.study.figures import STYLE  # noqa: E402
from gimbal_reduction.solver.dynamics import compiled, dense_baseline, integrators, multibody  # noqa: E402
from gimbal_reduction.solver.dynamics.synthetic import (HUGHES_FRACTION, SPECTRUM, modal_frequencies,  # noqa: E402
                                       synthetic_modal_chain)
from gimbal_reduction.workflow.provenance import csv_text, provenance, savefig, versions, write_json, write_text  # noqa: E402

# Coupled chain's highest frequency / largest kept modal frequency, truth model on scene
# thesis: 6.09e6 / 3.66e6 rad/s (docs/dynamics.md Section 6).
COUPLED_RATIO = 1.663
SIZES = (5, 10, 20, 50, 100, 200, 500, 1000, 2000)   # modes per body
QUICK_SIZES = (5, 25, 50, 75)
DENSE_MAX = 1000             # modes per body: the dense baseline up to S = 4000
COLUMNS_MAX = 200            # modes per body: the column assembly up to S = 800
FIT_MIN_ELASTIC = 200        # fit the growth law over S >= 200 (the large-n range)
METHODS = ("structured", "structured_loop", "dense", "columns")
CASE = multibody.CaseMotion(amplitude=(1.0, 0.0, 0.0), frequency=(2.0, 0.0, 0.0))  # scene thesis
CSV_COLUMNS = ("modes_per_body", "n_elastic", "n_coordinates", "omega_max_rad_s", "rk4_step_s",
               "evals_per_sim_second", "structured_eval_s", "structured_loop_eval_s", "dense_eval_s",
               "columns_eval_s", "structured_eval_min_s", "dense_eval_min_s",
               "dense_assembly_s", "dense_factor_s", "dense_bias_s",
               "speedup_eval", "speedup_eval_min", "speedup_sim_second", "speedup_columns_eval",
               "structured_per_sim_second_s", "dense_per_sim_second_s", "columns_per_sim_second_s",
               "structured_spread", "dense_spread", "agreement", "repeats")


# ------------------------------------------------------------- synthetic bodies
def assumed_omega_max(n_modes):
    """Coupled highest frequency [rad/s] assumed for D = n_modes on every body:
    COUPLED_RATIO x the largest kept modal frequency of the four spectra."""
    return COUPLED_RATIO * max(modal_frequencies(b, n_modes)[-1] for b in SPECTRUM)


def timing_state(chain, seed=1):
    """(y, y') (n,) each: thesis-like angles, physically small modal amplitudes (~1e-8)
    and rates, so that M(y) is positive definite as on a real run."""
    rng = np.random.default_rng(seed)
    n = chain.n_coordinates
    y = np.concatenate([[0.1, -np.pi / 2 + 0.2, -0.3, 0.4], 1e-8 * rng.normal(size=n - 4)])
    yd = np.concatenate([[0.01, -0.02, 0.015, 0.005], 1e-3 * rng.normal(size=n - 4)])
    return y, yd


# ------------------------------------------------------------------ timing
def time_interleaved(fns, repeats=7, batch_seconds=0.05):
    """{name: (median, min, spread)} [s] per call of each fns[name] = (fn, calls_per_invocation).

    Each function's batch size is calibrated by one untimed call so that a batch
    lasts about batch_seconds; then ``repeats`` rounds each time one batch of
    every function in turn, so that a load change on a shared machine hits all
    of them alike and their ratios stay fair.  spread = (max - min) / median of
    a function's batch times (noise indicator)."""
    batch = {}
    for name, (fn, _) in fns.items():
        t0 = time.perf_counter()
        fn()
        batch[name] = max(1, int(math.ceil(batch_seconds / max(time.perf_counter() - t0, 1e-9))))
    times = {name: [] for name in fns}
    for _ in range(int(repeats)):
        for name, (fn, calls) in fns.items():
            t0 = time.perf_counter()
            for _ in range(batch[name]):
                fn()
            times[name].append((time.perf_counter() - t0) / (batch[name] * calls))
    out = {}
    for name, ts in times.items():
        ts = np.array(ts)
        med = float(np.median(ts))
        out[name] = (med, float(ts.min()), float((ts.max() - ts.min()) / med))
    return out


def fit_power_law(x, y):
    """(p, a) of y = a x^p by least squares on log y = log a + p log x; x, y (N,) > 0, N >= 2."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y) & (x > 0) & (y > 0)
    if ok.sum() < 2:
        raise ValueError(f"a power-law fit needs >= 2 positive points, got {int(ok.sum())}")
    p, loga = np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)
    return float(p), float(np.exp(loga))


def relative_difference(a, b):
    """max |a - b| / max |b| (b the reference)."""
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


def measure_size(n_modes, repeats=7, batch_seconds=0.05, dense=True, columns=False, seed=0):
    """One CSV row: costs [s] per evaluation at D = n_modes per body (module docstring),
    all methods timed interleaved (``time_interleaved``)."""
    chain = synthetic_modal_chain(n_modes, seed)
    n = chain.n_coordinates
    y, yd = timing_state(chain)
    t = 0.01
    om = assumed_omega_max(n_modes)
    h = integrators.RK4_DEFAULT_FRACTION * integrators.rk4_stability_limit(om)
    row = {"modes_per_body": n_modes, "n_elastic": n - 4, "n_coordinates": n, "omega_max_rad_s": om,
           "rk4_step_s": h, "evals_per_sim_second": 4.0 / h, "repeats": repeats}
    s_rhs = compiled.make_rhs(chain, CASE, None)
    a_ref = s_rhs(t, y, yd).copy()             # also the JIT warm-up
    steps = 4                                   # compiled RK4 loop: 4 steps = 16 evaluations
    s_rhs.rk4_steps(y, yd, 0.0, 1e-9, steps)
    fns = {"structured": (lambda: s_rhs.rhs(t, y, yd), 1),
           "structured_loop": (lambda: s_rhs.rk4_steps(y, yd, 0.0, 1e-9, steps), 4 * steps)}
    if dense:
        d_rhs = dense_baseline.make_dense_rhs(chain, CASE, None)
        row["agreement"] = relative_difference(d_rhs(t, y, yd), a_ref)
        # the parts, each on reused buffers as in the rhs (fresh n x n arrays would add page faults)
        data = dense_baseline.pack_dense(chain)
        work = dense_baseline.Workspace(n)
        M = dense_baseline.mass_matrix_composite(data, y, work).copy()
        buf = np.empty_like(M)
        f = np.ones(n)
        w1, dw1 = dense_baseline.case_twist_function(CASE)(t)
        zero = np.zeros(n)
        fns.update({
            "dense": (lambda: d_rhs(t, y, yd), 1),
            "dense_assembly": (lambda: dense_baseline.mass_matrix_composite(data, y, work), 1),
            "dense_copy": (lambda: np.copyto(buf, M), 1),
            "dense_factor": (lambda: dense_baseline.cholesky_solve((np.copyto(buf, M), buf)[1], f), 1),
            "dense_bias": (lambda: d_rhs.fast_chain.inverse_dynamics(y, yd, zero, w1, dw1), 1)})
    if columns:
        c_rhs = dense_baseline.make_dense_rhs(chain, CASE, None, assembly="columns")
        c_rhs(t, y, yd)
        fns["columns"] = (lambda: c_rhs(t, y, yd), 1)
    res = time_interleaved(fns, repeats, batch_seconds)
    for m in METHODS:
        if m in res:
            row[f"{m}_eval_s"], row[f"{m}_eval_min_s"], row[f"{m}_spread"] = res[m]
    row["structured_per_sim_second_s"] = row["structured_loop_eval_s"] * row["evals_per_sim_second"]
    if dense:
        row["dense_assembly_s"] = res["dense_assembly"][0]
        row["dense_factor_s"] = max(res["dense_factor"][0] - res["dense_copy"][0], 0.0)
        row["dense_bias_s"] = res["dense_bias"][0]
        row["speedup_eval"] = row["dense_eval_s"] / row["structured_eval_s"]
        row["speedup_eval_min"] = row["dense_eval_min_s"] / row["structured_eval_min_s"]
        row["dense_per_sim_second_s"] = row["dense_eval_s"] * row["evals_per_sim_second"]
        row["speedup_sim_second"] = row["dense_per_sim_second_s"] / row["structured_per_sim_second_s"]
    if columns:
        row["speedup_columns_eval"] = row["columns_eval_s"] / row["structured_eval_s"]
        row["columns_per_sim_second_s"] = row["columns_eval_s"] * row["evals_per_sim_second"]
    return row


def local_exponents(rows, method):
    """[(S_a, S_b, p)]: slope of log cost between consecutive sizes that have the method
    (where the growth changes regime, e.g. when the Coriolis tensors leave the cache)."""
    pts = [(r["n_elastic"], r[f"{method}_eval_s"]) for r in rows if r.get(f"{method}_eval_s")]
    return [(a, b, float(np.log(cb / ca) / np.log(b / a))) for (a, ca), (b, cb) in zip(pts, pts[1:])]


def growth_laws(rows, min_elastic=FIT_MIN_ELASTIC):
    """{method: {exponent, prefactor_s, sizes}}: cost per evaluation = a S^p over S >= min_elastic."""
    out = {}
    for method in METHODS:
        key = f"{method}_eval_s"
        pts = [(r["n_elastic"], r[key]) for r in rows
               if r.get(key) is not None and r["n_elastic"] >= min_elastic]
        if len(pts) >= 2:
            p, a = fit_power_law(*zip(*pts))
            out[method] = {"exponent": p, "prefactor_s": a, "n_elastic": [x for x, _ in pts]}
    return out


# ------------------------------------------------------------------ output
def format_csv(rows):
    """CSV text, columns CSV_COLUMNS (floats with 6 significant digits, missing = empty)."""
    return csv_text(rows, CSV_COLUMNS, 6)


LABELS = {"structured": "structured (rhs call)", "structured_loop": "structured (compiled RK4 loop)",
          "dense": "dense: composite M + Cholesky", "columns": "dense: M by n+1 inverse dynamics"}
COLORS = {"structured": "tab:blue", "structured_loop": "tab:cyan", "dense": "tab:red",
          "columns": "tab:orange"}


def plot(rows, fits, path, record=None):
    """Three panels: cost per evaluation [s] (with the fitted growth laws), speed-up
    dense / structured, cost per simulated second [s]; written to path (PNG)."""
    import matplotlib  # optional heavy dependency: imported only when the figure is drawn
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    with plt.rc_context(STYLE):
        fig, axs = plt.subplots(1, 3, figsize=(12.0, 3.8), constrained_layout=True)
        for m in METHODS:
            pts = [(r["n_elastic"], r[f"{m}_eval_s"]) for r in rows if r.get(f"{m}_eval_s")]
            if not pts:
                continue
            x, y = map(np.array, zip(*pts))
            label = LABELS[m]
            if m in fits:
                label += f"  (~S^{fits[m]['exponent']:.2f})"
                xf = np.array([min(fits[m]["n_elastic"]), max(fits[m]["n_elastic"])], float)
                axs[0].plot(xf, fits[m]["prefactor_s"] * xf ** fits[m]["exponent"], ls=":",
                            color=COLORS[m], lw=1)
            axs[0].plot(x, y, marker="o", ms=3, color=COLORS[m], label=label)
        axs[0].set(xscale="log", yscale="log", xlabel="elastic coordinates S = 4 D",
                   ylabel="cost per evaluation [s]", title="right-hand side, one evaluation")
        axs[0].legend(fontsize=6)
        for key, label, color in (("speedup_eval", "dense / structured, per evaluation", "tab:red"),
                                  ("speedup_sim_second", "dense / structured loop, per simulated s",
                                   "tab:purple"),
                                  ("speedup_columns_eval", "columns / structured, per evaluation",
                                   "tab:orange")):
            pts = [(r["n_elastic"], r[key]) for r in rows if r.get(key)]
            if pts:
                x, y = map(np.array, zip(*pts))
                axs[1].plot(x, y, marker="o", ms=3, color=color, label=label)
        axs[1].set(xscale="log", yscale="log", xlabel="elastic coordinates S = 4 D",
                   ylabel="speed-up [-]", title="speed-up of the structured solver")
        axs[1].legend(fontsize=6)
        for m, key in (("structured_loop", "structured_per_sim_second_s"),
                       ("dense", "dense_per_sim_second_s"), ("columns", "columns_per_sim_second_s")):
            pts = [(r["n_elastic"], r[key]) for r in rows if r.get(key)]
            if pts:
                x, y = map(np.array, zip(*pts))
                axs[2].plot(x, y, marker="o", ms=3, color=COLORS[m], label=LABELS[m])
        axs[2].set(xscale="log", yscale="log", xlabel="elastic coordinates S = 4 D",
                   ylabel="wall time per simulated second [s]",
                   title="per simulated second (RK4, assumed spectrum)")
        axs[2].legend(fontsize=6)
        savefig(fig, path, record, dpi=150, format="png")       # provenance in the PNG's metadata
        plt.close(fig)


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        self.exit(2, f"gimbal_reduction.results.bench.scaling: {message} (see --help)\n")


def main(argv=None) -> int:
    ap = _Parser(prog="python -m gimbal_reduction.results.bench.scaling",
                 description="Cost per right-hand-side evaluation against model size: structured "
                             "solver vs dense baseline (synthetic bodies).")
    ap.add_argument("--out-csv", required=True)
    ap.add_argument("--out-json", required=True)
    ap.add_argument("--figure", required=True, help="PNG path")
    ap.add_argument("--quick", action="store_true", help=f"sizes {QUICK_SIZES} only (< 30 s)")
    ap.add_argument("--sizes", type=int, nargs="+", help=f"modes per body (default {SIZES})")
    ap.add_argument("--dense-max", type=int, default=DENSE_MAX,
                    help="largest modes per body for the dense baseline")
    ap.add_argument("--columns-max", type=int, default=COLUMNS_MAX,
                    help="largest modes per body for the column assembly")
    ap.add_argument("--repeats", type=int, default=9, help="timed batches per cost (median; >= 5)")
    ap.add_argument("--batch-seconds", type=float, default=None, help="least duration of a batch")
    args = ap.parse_args(argv)
    if args.repeats < 1:
        ap.error(f"--repeats must be >= 1, got {args.repeats}")
    sizes = args.sizes or (QUICK_SIZES if args.quick else SIZES)
    if min(sizes) < 1:
        ap.error(f"--sizes must be >= 1, got {min(sizes)}")
    batch = args.batch_seconds if args.batch_seconds is not None else (0.01 if args.quick else 0.03)
    start = time.perf_counter()
    load0 = os.getloadavg()
    rows = []
    for D in sorted(sizes):
        t0 = time.perf_counter()
        row = measure_size(D, args.repeats, batch, dense=D <= args.dense_max,
                           columns=D <= args.columns_max)
        rows.append(row)
        dense = f", dense {row['dense_eval_s'] * 1e6:.1f} us (x{row['speedup_eval']:.1f})" \
            if "dense_eval_s" in row else ""
        print(f"gimbal_reduction.results.bench.scaling: S = {row['n_elastic']}: structured {row['structured_eval_s'] * 1e6:.1f} us"
              f"{dense} [{time.perf_counter() - t0:.1f} s]", flush=True)
    fits = growth_laws(rows)
    record = provenance()          # synthetic bodies: the run's configuration file
    write_text(args.out_csv, format_csv(rows), record)
    plot(rows, fits, args.figure, record)
    write_json(args.out_json, {
        "description": "Cost per right-hand-side evaluation [s] against the number of elastic "
                       "coordinates S (synthetic bodies, D = S/4 modes each): structured solver "
                       "(gimbal_reduction.solver.dynamics.compiled) vs dense baseline (gimbal_reduction.solver.dynamics.dense_baseline). Medians of "
                       f"{args.repeats} timed batches.",
        "rows": rows, "growth_laws": fits, "fit_min_elastic": FIT_MIN_ELASTIC,
        "local_exponents": {m: local_exponents(rows, m) for m in METHODS},
        "assumptions": {"spectrum_hz": {str(b): {"c": c, "beta": be} for b, (c, be) in SPECTRUM.items()},
                        "coupled_ratio": COUPLED_RATIO,
                        "rk4_fraction": integrators.RK4_DEFAULT_FRACTION,
                        "rk4_stability": integrators.RK4_STABILITY,
                        "hughes_fraction": HUGHES_FRACTION},
        "environment": {k: os.environ.get(k) for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")}
        | {"cpu_count": os.cpu_count(), "loadavg_start": load0, "loadavg_end": os.getloadavg()},
        "quick": bool(args.quick), "total_seconds": time.perf_counter() - start,
        "versions": versions()}, record)
    summary = ", ".join(f"{m} ~S^{f['exponent']:.2f}" for m, f in fits.items())
    print(f"gimbal_reduction.results.bench.scaling: {len(rows)} sizes in {time.perf_counter() - start:.1f} s; {summary}; "
          f"-> {args.out_csv}, {args.out_json}, {args.figure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
