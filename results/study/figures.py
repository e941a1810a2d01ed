"""Figures of the study: gimbal rates against the truth, error against mode count, cost.

    python -m results.study.figures --truth results/sim/thesis/truth.h5 \\
        --cases results/sim/thesis/freq-5.h5 ... \\
        --ranking-table results/tables/errors_ranking.csv \\
        --static-table results/tables/errors_static.csv \\
        --out-dir results/figures/study

Every figure is written twice, ``<stem>.pdf`` (vector, for the report) and
``<stem>.png`` (150 dpi, for viewing), and listed in ``<out-dir>/figures.json``
(``id, kind, pdf, png, caption, thesis_figure, model, group``; paths relative to
the manifest), which the report reads:

* ``rates_<model>``: truth (solid) and reduced (dashed) gimbal rates
  gamma_dot_1..4 [rad/s] against time [ms], one panel per rate, with E (eq 3.53)
  per panel (analogues of Figs 4-2..4-27);
* ``error_ranking``: E against vibration modes per body for the freq, XMX and
  XMGMX cases (Fig 4-28), thesis Table 4.2 values drawn in grey;
* ``error_static``: E against vibration modes per body with one static mode
  (Fig 4-29), thesis Table 4.3 in grey;
* ``error_load_cases``: E per gimbal rate for the seven static-mode load cases
  (Figs 4-21..4-27 in one chart);
* ``runtime_error``: wall time [s] against the outer-gimbal E for every case,
  with the Pareto front and the truth's wall time.

Missing inputs (no table, no simulation file) skip the figures that need them;
the manifest lists what was made.
"""
from __future__ import annotations

import argparse
import os
import re
import sys
import textwrap

import numpy as np

from results.study import findings
from results.study.cases import (
    GROUP_LABELS,
    LOAD_CASES,
    RANKING_TABLE_GROUPS,
    RATE_LABELS,
    describe_model,
    study_cases,
)
from results.study.tables import RATE_COLUMNS, read_table
from solver.bodydata import BODIES
from solver.dynamics.error_measure import ErrorsInputError, check_same_grid, error_measure
from solver.dynamics.simfile import read_sim
from workflow.provenance import write_json

STYLE = {"pdf.fonttype": 42, "ps.fonttype": 42, "font.size": 9, "axes.grid": True,
         "grid.alpha": 0.3, "legend.fontsize": 8, "figure.dpi": 100}
GROUP_STYLE = {"freq": ("tab:blue", "o", "-"), "xmx": ("tab:orange", "s", "-"),
               "xmgmx": ("tab:green", "^", "--"), "static-freq": ("tab:purple", "D", "-"),
               "static-xmx": ("tab:red", "v", "-"), "static-xmgmx": ("tab:brown", "P", "--"),
               "load-case": ("tab:pink", "X", ""), "other": ("tab:gray", ".", ""),
               "truth": ("black", "*", "")}
PNG_DPI = 150


def _plt():
    import matplotlib  # optional heavy dependency: imported only when a figure is drawn
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def safe_name(model: str) -> str:
    """File-name stem of a model name (``static-10@2:output_motor_fz`` -> ``static-10_at2_output_motor_fz``)."""
    s = model.replace("@", "_at").replace(":", "_").replace("+", "_plus_").replace(",", "-")
    return re.sub(r"[^A-Za-z0-9_.-]", "_", s)


def save(fig, stem) -> dict:
    """Write fig to stem.pdf and stem.png; returns {"pdf": path, "png": path}."""
    plt = _plt()
    os.makedirs(os.path.dirname(os.path.abspath(stem)), exist_ok=True)
    paths = {"pdf": f"{stem}.pdf", "png": f"{stem}.png"}
    fig.savefig(paths["pdf"])
    fig.savefig(paths["png"], dpi=PNG_DPI)
    plt.close(fig)
    return paths


def plot_rates(truth: dict, case: dict, stem: str, title: str | None = None) -> dict:
    """Truth vs reduced gimbal rates: 2x2 panels, t [ms] vs gamma_dot_n [rad/s], E per panel.

    truth, case: dicts of ``read_sim`` (t (T,) s, gamma_dot (T, 4) rad/s) on one grid."""
    check_same_grid(truth["t"], case["t"], case.get("path", case.get("model", "case")))
    E = error_measure(truth["t"], truth["gamma_dot"], case["gamma_dot"])
    plt = _plt()
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(2, 2, figsize=(7.0, 4.8), sharex=True, constrained_layout=True)
        t_ms = 1e3 * truth["t"]
        for k, (ax, b) in enumerate(zip(axes.flat, BODIES)):
            ax.plot(t_ms, truth["gamma_dot"][:, k], color="black", lw=1.0, label="truth (100 modes/body)")
            ax.plot(1e3 * case["t"], case["gamma_dot"][:, k], color="tab:red", lw=1.0, ls="--",
                    label=f"reduced: {case['model']}")
            ax.set_ylabel(f"{RATE_LABELS[b]} [rad/s]")
            ax.text(0.02, 0.95, f"E = {E[k]:.3g}", transform=ax.transAxes, va="top", fontsize=8,
                    bbox={"boxstyle": "round", "fc": "white", "ec": "0.7", "alpha": 0.9})
            if k >= 2:
                ax.set_xlabel("time t [ms]")
        axes.flat[0].legend(loc="best", fontsize=7)
        fig.suptitle(textwrap.fill(title or f"Gimbal rates: truth vs {case['model']}", 90), fontsize=9)
        return save(fig, stem)


def _series(rows, group, col):
    pts = sorted((r["count"], r[col]) for r in rows if r["group"] == group and r["count"] is not None)
    return np.array([p[0] for p in pts], float), np.array([p[1] for p in pts], float)


def plot_error_vs_modes(rows: list[dict], groups, stem: str, title: str, thesis=None) -> dict:
    """E (log) against vibration modes per body, one panel per gimbal rate, one line per group.

    rows: table rows (``read_table``); thesis: optional {label: {count: (4,) E}} in grey."""
    plt = _plt()
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(2, 2, figsize=(7.0, 5.0), sharex=True, constrained_layout=True)
        for k, (ax, b) in enumerate(zip(axes.flat, BODIES)):
            col = RATE_COLUMNS[k]
            for g in groups:
                x, y = _series(rows, g, col)
                if x.size:
                    c, m, ls = GROUP_STYLE.get(g, GROUP_STYLE["other"])
                    ax.plot(x, np.where(y > 0, y, np.nan), color=c, marker=m, ls=ls or "-",
                            label=f"ours: {GROUP_LABELS.get(g, g)}")
            for j, (label, data) in enumerate((thesis or {}).items()):
                xs = sorted(data)
                ax.plot(xs, [data[n][k] for n in xs], color="0.55", marker="os"[j % 2], ms=3,
                        ls=":", lw=0.8, label=f"thesis: {label}")
            ax.set_yscale("log")
            ax.set_ylabel(f"E of {RATE_LABELS[b]} [-]")
            if k >= 2:
                ax.set_xlabel("vibration modes per body")
        if axes.flat[0].get_legend_handles_labels()[0]:
            axes.flat[0].legend(fontsize=6, loc="best")
        fig.suptitle(title)
        return save(fig, stem)


def plot_load_cases(rows: list[dict], stem: str) -> dict:
    """Grouped bars: E (log) of each gimbal rate for the seven static-mode load cases."""
    plt = _plt()
    lc = [r for r in rows if r["group"] == "load-case"]
    order = [c for c, _ in LOAD_CASES]
    lc.sort(key=lambda r: order.index(r["load_case"]) if r["load_case"] in order else len(order))
    with plt.rc_context(STYLE):
        fig, ax = plt.subplots(figsize=(7.0, 3.6), constrained_layout=True)
        x = np.arange(len(lc))
        w = 0.2
        for k, b in enumerate(BODIES):
            ax.bar(x + (k - 1.5) * w, [r[RATE_COLUMNS[k]] for r in lc], w,
                   label=RATE_LABELS[b])
        ax.set_xticks(x, [f"{r['load_case']}\n(Fig {r['thesis_figure']})" for r in lc], fontsize=7)
        ax.set_yscale("log")
        ax.set_ylabel("E [-]")
        ax.set_xlabel("load case of the outer gimbal's static mode (10 lowest modes per body)")
        ax.legend(ncol=2)
        ax.set_title("Error for the seven static-mode load cases")
        return save(fig, stem)


def pareto_front(cost, err):
    """Indices of the Pareto-optimal points (no other point is both cheaper and more
    accurate), sorted by cost.  cost, err: (N,) arrays."""
    cost, err = np.asarray(cost, float), np.asarray(err, float)
    ok = np.flatnonzero(np.isfinite(cost) & np.isfinite(err))
    idx = ok[np.lexsort((err[ok], cost[ok]))]
    front, best = [], np.inf
    for i in idx:
        if err[i] < best:
            front.append(int(i))
            best = err[i]
    return front


def plot_runtime_error(rows: list[dict], stem: str, col: str = "E_outer_gimbal") -> dict:
    """Scatter of wall time [s] (log) against E (log) of one rate for every case, Pareto front,
    and the truth's wall time as a vertical line."""
    plt = _plt()
    cases = [r for r in rows if r["group"] != "truth"]
    truth = [r for r in rows if r["group"] == "truth"]
    with plt.rc_context(STYLE):
        fig, ax = plt.subplots(figsize=(7.0, 4.4), constrained_layout=True)
        for g in dict.fromkeys(r["group"] for r in cases):
            sel = [r for r in cases if r["group"] == g]
            c, m, _ = GROUP_STYLE.get(g, GROUP_STYLE["other"])
            ax.scatter([r["wall_time_s"] for r in sel], [r[col] for r in sel], color=c, marker=m,
                       label=GROUP_LABELS.get(g, g), zorder=3)
        cost = np.array([r["wall_time_s"] for r in cases])
        err = np.array([r[col] for r in cases])
        front = pareto_front(cost, err)
        if front:
            ax.step(cost[front], err[front], where="post", color="0.3", lw=1, ls="--",
                    label="Pareto front", zorder=2)
            for i in front:
                ax.annotate(cases[i]["model"], (cost[i], err[i]), fontsize=6, xytext=(3, 3),
                            textcoords="offset points")
        if truth and np.isfinite(truth[0]["wall_time_s"]):
            ax.axvline(truth[0]["wall_time_s"], color="black", lw=1,
                       label=f"truth: {truth[0]['wall_time_s']:.3g} s")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time of the simulation [s]")
        ax.set_ylabel(f"E of {RATE_LABELS[2]} [-]")
        ax.legend(fontsize=6, loc="best", framealpha=0.8)
        ax.set_title("Run time against error (eq 3.53)")
        return save(fig, stem)


def make_figures(out_dir, ranking_rows=None, static_rows=None, truth=None, cases=(),
                 thesis=None) -> list[dict]:
    """Every figure whose inputs are given; returns the manifest entries (paths relative to out_dir)."""
    thesis = findings.THESIS if thesis is None else thesis
    entries = []

    def add(paths, **meta):
        entries.append({**meta, **{k: os.path.relpath(v, out_dir) for k, v in paths.items()}})

    ranking_rows, static_rows = ranking_rows or [], static_rows or []
    if truth is not None:
        order = {c["model"]: i for i, c in enumerate(study_cases())}
        for case in sorted(cases, key=lambda c: order.get(c["model"], len(order))):
            d = describe_model(case["model"])
            fig = f" (thesis Fig {d['thesis_figure']})" if d["thesis_figure"] else ""
            paths = plot_rates(truth, case, os.path.join(out_dir, f"rates_{safe_name(case['model'])}"),
                               f"Truth vs {d['title']}")
            add(paths, id=f"rates_{safe_name(case['model'])}", kind="rates", model=case["model"],
                group=d["group"], thesis_figure=d["thesis_figure"],
                caption=f"Gimbal rates of the truth model (solid) and of model {case['model']}, "
                        f"{d['title']} (dashed){fig}; E per rate from eq 3.53.")
    if any(r["group"] in RANKING_TABLE_GROUPS for r in ranking_rows):
        th = {"freq (Table 4.2)": thesis["freq"], "XMX/XMGMX (Table 4.2)": thesis["ranked"]}
        add(plot_error_vs_modes(ranking_rows, RANKING_TABLE_GROUPS,
                                os.path.join(out_dir, "error_ranking"),
                                "Error against mode count: lowest-frequency vs ranked modes", th),
            id="error_ranking", kind="error", model="", group="", thesis_figure="4-28",
            caption="Error E (eq 3.53) of each gimbal rate against the number of vibration modes "
                    "per body, lowest-frequency, XMX- and XMGMX-ranked modes (analogue of Fig 4-28); "
                    "grey: the thesis's Table 4.2.")
    if any(r["group"].startswith("static-") for r in static_rows):
        th = {"1 static + lowest (Table 4.3)": thesis["static-freq"],
              "1 static + ranked (Table 4.3)": thesis["static-ranked"]}
        add(plot_error_vs_modes(static_rows, ("static-freq", "static-xmx", "static-xmgmx"),
                                os.path.join(out_dir, "error_static"),
                                "Error against mode count with one static mode per body", th),
            id="error_static", kind="error", model="", group="", thesis_figure="4-29",
            caption="Error E (eq 3.53) of each gimbal rate against the number of vibration modes "
                    "per body with one static correction mode per body, lowest-frequency and ranked "
                    "modes (analogue of Fig 4-29); grey: the thesis's Table 4.3.")
    if any(r["group"] == "load-case" for r in static_rows):
        add(plot_load_cases(static_rows, os.path.join(out_dir, "error_load_cases")),
            id="error_load_cases", kind="error", model="", group="load-case",
            thesis_figure="4-21..4-27",
            caption="Error E of each gimbal rate with the 10 lowest modes per body and one static "
                    "mode on the outer gimbal, for the seven load cases (Figs 4-21 to 4-27).")
    rows = ranking_rows + static_rows
    if any(r["group"] != "truth" and np.isfinite(r["wall_time_s"]) for r in rows):
        add(plot_runtime_error(rows, os.path.join(out_dir, "runtime_error")),
            id="runtime_error", kind="cost", model="", group="", thesis_figure="",
            caption="Wall time of each simulation against the error E of the outer gimbal rate; "
                    "dashed: the Pareto front (no case is both faster and more accurate); "
                    "vertical line: the truth model's wall time.")
    return entries


def write_manifest(out_dir, entries):
    path = os.path.join(out_dir, "figures.json")
    write_json(path, {"description": "Figures of the results stage (results/study/figures.py); paths "
                                     "relative to this file.", "figures": entries})
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m results.study.figures",
                                     description="Figures of the study (PDF + PNG) and their manifest.")
    parser.add_argument("--truth", help="truth simulation file (for the rate figures)")
    parser.add_argument("--cases", nargs="*", default=[], help="reduced-model simulation files")
    parser.add_argument("--ranking-table", help="results/tables/errors_ranking.csv")
    parser.add_argument("--static-table", help="results/tables/errors_static.csv")
    parser.add_argument("--out-dir", required=True, help="folder of the figures and figures.json")
    args = parser.parse_args(argv)
    try:
        truth = read_sim(args.truth) if args.truth else None
        cases = [read_sim(p) for p in args.cases
                 if not args.truth or os.path.abspath(p) != os.path.abspath(args.truth)]
        if cases and truth is None:
            raise ErrorsInputError("--cases needs --truth")
        rank = read_table(args.ranking_table) if args.ranking_table else []
        stat = read_table(args.static_table) if args.static_table else []
    except (ErrorsInputError, OSError) as exc:
        print(f"results.study.figures: error: {exc}", file=sys.stderr)
        return 2
    entries = make_figures(args.out_dir, rank, stat, truth, cases)
    path = write_manifest(args.out_dir, entries)
    print(f"results.study.figures: {len(entries)} figures -> {args.out_dir} ({path})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
