"""Load-aware and global mode selection against the measured errors: table and figure.

    python -m gimbal_reduction.results.bench.selection --truth results/sim/thesis/truth.h5 \\
        --cases results/sim/thesis/*.h5 --ranking results/reduction/load/thesis.h5 \\
        --reductions results/reduction/body{2,3,4,5}.h5 \\
        --table results/tables/selection.csv --figure results/figures/bench/global_ranking.png

For every simulated case: the measured eq. 3.53 error E_n of each gimbal rate
against the truth (``gimbal_reduction.results.study.tables``), and, for models without static modes,
the a-priori estimate of the same four numbers from the frozen linear chain
stored in the ranking file (``gimbal_reduction.reduction.load_aware.estimate_error``), and the
additive estimate (sum of the dropped modes' participation scores).  The scalar
is E = max over the four rates (the outer-gimbal rate in every case here,
thesis finding 5).

``selection.csv`` (one row per case, sorted by family and size): ``TABLE_COLUMNS``.
``global_ranking.png`` (and ``.pdf``): left, E against the total number of
elastic coordinates for freq-N, xmx-N, xmgmx-N, load-N (4N coordinates) and
global-N (N), measured (markers) and a-priori (lines, from the ranking file),
with the rigid model's a-priori E; right, a-priori against measured E_n for
every rate and case.  Missing or mismatched files end with one line
``gimbal_reduction.results.bench.selection: error: ...`` (exit 2), nothing written.
"""
from __future__ import annotations

import argparse
import os
import sys

import h5py
import numpy as np

from gimbal_reduction.reduction import load_aware, models, names
from gimbal_reduction.solver import bodyconfig
from gimbal_reduction.results.study.cases import BODY_NAMES
from gimbal_reduction.solver.bodydata import BODIES
from gimbal_reduction.solver.dynamics.error_measure import check_same_grid, error_measure
from gimbal_reduction.solver.dynamics.simfile import read_sim
from gimbal_reduction.workflow.provenance import csv_text, provenance, savefig, write_text

FAMILIES = tuple(names.FAMILIES)
RATES = tuple(BODY_NAMES[b] for b in BODIES)
TABLE_COLUMNS = ("model", "family", "count", "n_elastic",
                 *(f"E_{r}" for r in RATES), "E_max",
                 *(f"apriori_{r}" for r in RATES), "apriori_max", "apriori_over_measured",
                 "additive_max", "wall_time_s", "file")
POOLED_XMX_STYLE = ("tab:gray", "x")     # the pooled XMX ranking's a-priori curve (not a model)


class SelectionInputError(ValueError):
    """A missing or mismatched input file (one-line message)."""


def classify(name: str) -> tuple[str, int | None]:
    """(family, count) of a model name: family in FAMILIES, 'rigid', 'truth' or 'other';
    count = N of freq-N ... (per body) or global-N (total); None otherwise."""
    if name in ("rigid", "truth"):
        return name, 0 if name == "rigid" else None
    parsed = names.parse_or_none(name)
    plain = None if parsed is None else parsed.plain
    return plain if plain is not None else ("other", None)


def kept_indices(spec, offsets) -> np.ndarray | None:
    """Pooled indices of a ModelSpec's kept vibration modes (None if it has static modes)."""
    if any(spec.static[b] for b in BODIES):
        return None
    return np.concatenate([offsets[k] + np.asarray(spec.kept[b], int)
                           for k, b in enumerate(BODIES)]).astype(int)


def case_rows(truth: dict, cases: list[dict], linear: dict | None, rankings: dict | None,
              scores: np.ndarray | None) -> list[dict]:
    """Rows of the table (measured and a-priori E per rate) for the simulated cases."""
    rows = []
    for case in cases:
        label = case.get("path", case["model"])
        check_same_grid(truth["t"], case["t"], label)
        E = error_measure(truth["t"], truth["gamma_dot"], case["gamma_dot"])
        family, count = classify(case["model"])
        n_modes = case["attrs"].get("n_modes")
        row = {"model": case["model"], "family": family, "count": count,
               "n_elastic": int(np.sum(n_modes)) if n_modes is not None else None,
               **{f"E_{r}": float(e) for r, e in zip(RATES, E)}, "E_max": float(np.max(E)),
               "wall_time_s": case["attrs"].get("wall_time_s"), "file": label}
        est = add = None
        if linear is not None and rankings is not None:
            try:
                spec = models.model_spec(case["model"], rankings)
            except models.ModelError:
                spec = None
            keep = None if spec is None else kept_indices(spec, linear["offsets"])
            if keep is not None:
                est = load_aware.estimate_error(linear, keep)
                add = load_aware.additive_estimate(scores, keep) if scores is not None else None
        for k, r in enumerate(RATES):
            row[f"apriori_{r}"] = None if est is None else float(est[k])
        row["apriori_max"] = None if est is None else float(np.max(est))
        row["apriori_over_measured"] = None if est is None else float(np.max(est) / np.max(E))
        row["additive_max"] = None if add is None else float(np.max(add))
        rows.append(row)
    order = {f: i for i, f in enumerate(("rigid",) + FAMILIES + ("other",))}
    rows.sort(key=lambda r: (order.get(r["family"], 99), r["count"] or 0, r["model"]))
    return rows


def format_csv(rows: list[dict]) -> str:
    """CSV text (TABLE_COLUMNS; floats with 6 significant digits, missing = empty)."""
    return csv_text(rows, TABLE_COLUMNS, 6)


def read_ranking(path) -> dict:
    """Curves, scores and the linear model of a ranking file (gimbal_reduction.reduction.load_aware)."""
    if not os.path.exists(path):
        raise SelectionInputError(f"{path}: ranking file missing (run python -m gimbal_reduction.reduction.load_aware)")
    try:
        with h5py.File(path, "r") as f:
            out = {"curves": {k: f["estimate"][k][()] for k in f["estimate"]},
                   "linear": {k: f["linear"][k][()] for k in f["linear"]},
                   "scores": np.hstack([f[f"body{b}/score"][()] for b in BODIES]),
                   "scene": str(f.attrs.get("scene", ""))}
    except (OSError, KeyError) as exc:
        raise SelectionInputError(f"{path}: not a complete ranking file ({exc.__class__.__name__})") from None
    return out


def plot(rows: list[dict], curves: dict, path: str, record: dict | None = None) -> list[str]:
    """The two-panel figure (PNG at ``path`` and a PDF beside it, each with its provenance record,
    default ``gimbal_reduction.workflow.provenance.provenance()``); returns the paths."""
    import matplotlib  # optional heavy dependency: imported only when the figure is drawn
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.3), gridspec_kw={"width_ratios": [1.5, 1]})
    for fam in ("freq", "xmx", "xmgmx", "load"):
        c = curves.get(fam)
        if c is not None:
            n = np.arange(1, c.shape[0] + 1)
            ax.plot(4 * n, np.nanmax(c, axis=1), "-", color=names.style(fam).colour, lw=1, alpha=0.8,
                    label=f"{fam}-N a priori (4N coords)")
    for fam, label in (("global", "global-N a priori"), ("global_xmx", "pooled XMX a priori")):
        c = curves.get(fam)
        if c is not None:
            ax.plot(np.arange(1, c.shape[0] + 1), np.nanmax(c, axis=1), "-" if fam == "global"
                    else ":", color=names.style(fam).colour if fam == "global" else POOLED_XMX_STYLE[0],
                    lw=1.4 if fam == "global" else 1, label=label)
    if "rigid" in curves:
        ax.axhline(float(np.max(curves["rigid"])), color="k", ls="--", lw=0.8,
                   label="rigid model a priori")
    for fam in FAMILIES:
        pts = [(r["n_elastic"], r["E_max"]) for r in rows if r["family"] == fam]
        if pts:
            x, y = np.array(pts, float).T
            look = names.style(fam)
            ax.plot(x, y, look.marker, color=look.colour, ms=6, mfc="none" if fam != "global"
                    else look.colour, ls="", label=f"{fam}-N simulated")
    ax.set_yscale("log")
    ax.set_xlabel("elastic coordinates in the model (all bodies)")
    ax.set_ylabel("E = max over the 4 gimbal rates (eq. 3.53)")
    ax.set_xlim(0, None)
    ax.legend(fontsize=7, ncol=2)
    ax.set_title("error against model size: measured (markers), a priori (lines)", fontsize=9)
    pairs = [(r[f"E_{rt}"], r[f"apriori_{rt}"], k) for r in rows for k, rt in enumerate(RATES)
             if r.get(f"apriori_{rt}") is not None]
    if pairs:
        m, a, k = (np.array(v) for v in zip(*pairs))
        for kk, rt in enumerate(RATES):
            sel = k == kk
            bx.loglog(m[sel], a[sel], "o", ms=4, mfc="none", label=rt.replace("_", " "))
        lo, hi = min(m.min(), a.min()) / 2, max(m.max(), a.max()) * 2
        bx.plot([lo, hi], [lo, hi], "k-", lw=0.8)
        ratio = a / m
        bx.set_title(f"a priori vs measured E_n: ratio {ratio.min():.3f} .. {ratio.max():.3f}",
                     fontsize=9)
        bx.legend(fontsize=7)
    bx.set_xlabel("measured E_n")
    bx.set_ylabel("a-priori E_n (frozen linear chain)")
    fig.tight_layout()
    out = []
    for p in (path, os.path.splitext(path)[0] + ".pdf"):
        savefig(fig, p, record, dpi=150)                # provenance in the file's metadata
        out.append(p)
    plt.close(fig)
    return out


class _Parser(argparse.ArgumentParser):
    """Argument errors as one line, exit status 2."""

    def error(self, message):
        self.exit(2, f"gimbal_reduction.results.bench.selection: error: {message} (see --help)\n")


def main(argv=None) -> int:
    ap = _Parser(prog="python -m gimbal_reduction.results.bench.selection",
                                 description="Measured vs a-priori eq. 3.53 errors of load-aware, "
                                             "global and ranked models (docs/selection.md).")
    ap.add_argument("--truth", required=True, help="truth simulation file")
    ap.add_argument("--cases", nargs="+", required=True, help="simulation files of reduced models")
    ap.add_argument("--ranking", required=True, help="ranking file of gimbal_reduction.reduction.load_aware")
    ap.add_argument("--reductions", nargs=4, required=True, metavar="REDUCTION_FILE",
                    help="the reduction stage's files of bodies 2..5 (frequency/XMX/XMGMX rankings)")
    ap.add_argument("--table", required=True, help="CSV output, e.g. results/tables/selection.csv")
    ap.add_argument("--config", help="the current configuration file: input files of another "
                                     "configuration are refused before the work (gimbal_reduction.solver.bodyconfig)")
    ap.add_argument("--figure", required=True,
                    help="PNG output (a PDF is written beside it), e.g. "
                         "results/figures/bench/global_ranking.png")
    args = ap.parse_args(argv)
    try:
        bodyconfig.check_files(args.reductions + [args.ranking], args.config)
        ranking = read_ranking(args.ranking)
        rankings = models.read_rankings(dict(zip(models.BODIES, args.reductions)))
        models.load_load_ranking(args.ranking, rankings)
        truth = read_sim(args.truth)
        if ranking["scene"] and truth["attrs"].get("scene") not in (None, ranking["scene"]):
            raise SelectionInputError(f"{args.truth}: scene {truth['attrs'].get('scene')!r}, the "
                                      f"ranking's is {ranking['scene']!r}")
        cases = [read_sim(p) for p in args.cases
                 if os.path.abspath(p) != os.path.abspath(args.truth)]
        rows = case_rows(truth, cases, ranking["linear"], rankings, ranking["scores"])
    except (ValueError, FileNotFoundError) as exc:
        print(f"gimbal_reduction.results.bench.selection: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    record = provenance(sources=[args.truth, *args.cases, args.ranking])
    write_text(args.table, format_csv(rows), record)
    made = plot(rows, ranking["curves"], args.figure, record)
    est = [r for r in rows if r["apriori_max"] is not None]
    if est:
        ratio = np.array([r["apriori_over_measured"] for r in est])
        print(f"gimbal_reduction.results.bench.selection: {len(rows)} cases -> {args.table}, {', '.join(made)}; a priori / "
              f"measured E (max over rates) {ratio.min():.4f} .. {ratio.max():.4f} over {len(est)} "
              f"cases")
    else:
        print(f"gimbal_reduction.results.bench.selection: {len(rows)} cases -> {args.table}, {', '.join(made)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
