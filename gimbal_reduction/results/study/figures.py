"""Figures of the study: gimbal rates against the truth, error against mode count, cost.

    python -m gimbal_reduction.results.study.figures --truth results/sim/thesis/truth.h5 \\
        --cases results/sim/thesis/freq-5.h5 ... \\
        --ranking-table results/tables/errors_ranking.csv \\
        --static-table results/tables/errors_static.csv \\
        --out-dir results/figures/study

Every figure is written once, ``<stem>.pdf`` (vector, what the reports include), and
listed in ``<out-dir>/figures.json`` (``id, kind, pdf, caption, thesis_figure, model,
group``; paths relative to the manifest), which the reports read:

* ``rates_<model>``: truth (solid) and reduced (dashed) gimbal rates
  gamma_dot_1..4 [rad/s] against time [ms], one panel per rate, with E (eq 3.53)
  per panel (analogues of Figs 4-2..4-27);
* ``error_ranking``: E against vibration modes per body for the freq, XMX and
  XMGMX cases (Fig 4-28), thesis Table 4.2 values drawn in grey;
* ``error_static``: E against vibration modes per body with one static mode
  (Fig 4-29), thesis Table 4.3 in grey;
* ``error_load_cases``: E per gimbal rate for the seven static-mode load cases
  (Figs 4-21..4-27 in one chart);
* ``error_coordinates``: E against elastic coordinates per body (n_elastic / 4) for every mode
  family (``tables.COORDINATE_GROUPS``: the thesis's, ours, the field's defaults), so families
  that keep more than their count (cb: 6 constraint modes per ring; static: 1 per body) are
  compared at equal size;
* ``runtime_error``: model size (elastic coordinates) against the outer-gimbal E for every
  case, with the Pareto front and the truth's size (run times: the benchmark's medians).

Missing inputs (no table, no simulation file) skip the figures that need them;
the manifest lists what was made.
"""
from __future__ import annotations

import argparse
import contextlib
import functools
import io
import os
import re
import sys
import textwrap

import numpy as np

from gimbal_reduction.reduction import names
from gimbal_reduction.results.study import findings
from gimbal_reduction.results.study.cases import (
    LOAD_CASE_COUNT,
    LOAD_CASES,
    RANKING_TABLE_GROUPS,
    RATE_LABELS,
    describe_model,
    study_cases,
)
from gimbal_reduction.results.study.tables import COORDINATE_GROUPS, RATE_COLUMNS, read_table
from gimbal_reduction.solver.bodies import BODIES
from gimbal_reduction.solver.dynamics.error_measure import ErrorsInputError, check_same_grid, error_measure
from gimbal_reduction.solver.dynamics.simfile import read_sim
from gimbal_reduction.workflow.provenance import provenance, savefig, write_json

STYLE = {"pdf.fonttype": 42, "ps.fonttype": 42, "font.size": 9, "axes.grid": True,
         "grid.alpha": 0.3, "legend.fontsize": 8, "figure.dpi": 100}
# Groups drawn as lines against modes per body: the rigid model is the dashed baseline and the
# truth check a single point at 100, so neither is a line; cb at equal coordinates is a count of
# coordinates, drawn in error_coordinates only
LINE_GROUPS = tuple(g for g in RANKING_TABLE_GROUPS if g not in ("rigid", "truth-check", "truth-interface",
                                                                   "cb-equal"))
PER_BODY_DIVISOR = {"global": 4}
PNG_DPI = 150           # ``save``'s PNG (figures of other modules; the study's are PDF only)
RIGID = "rigid"        # the baseline model: no elastic modes
ZOOM_S = 2e-3           # zoom windows: the first and the last 2 ms of a run
ENVELOPE_BINS = 1000    # columns of a min/max envelope (~ pixels of a panel at 600 dpi)


def pyplot():
    """matplotlib.pyplot on the Agg backend (every figure of the project is drawn through it, with
    ``STYLE``)."""
    import matplotlib  # optional heavy dependency: imported only when a figure is drawn
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def safe_name(model: str) -> str:
    """File-name stem of a model name (``static-10@2:output_motor_fz`` -> ``static-10_at2_output_motor_fz``)."""
    s = model.replace("@", "_at").replace(":", "_").replace("+", "_plus_").replace(",", "-")
    return re.sub(r"[^A-Za-z0-9_.-]", "_", s)


@functools.lru_cache(maxsize=1)
def run_provenance() -> dict:
    """The provenance record of this run's figures (``gimbal_reduction.workflow.provenance.provenance``: config
    hash of the run's configuration file, git revision, versions), made once per process (it
    runs git)."""
    return provenance()


# Characters every embedded font subset holds whether a figure uses them or not: all of printable
# ASCII (titles, legends, tick labels) and the few others the figures write (minus sign, micro,
# mu, gamma, times, mathtext's dot accent, the ff/fi/fl/ffi/ffl ligatures of the text), so that one subset per font file serves a whole run of figures
# (``glyph_subsets_cached``); a glyph outside it grows the subset once.  (A DejaVu Sans subset
# of these is ~27 kB before the PDF's compression, one of a typical figure's own glyphs ~15 kB.)
SUBSET_BASE = ("".join(map(chr, range(0x20, 0x7F))) + "\u2212\u00b5\u03bc\u03b3\u00d7\u0307"
               + "".join(map(chr, range(0xFB00, 0xFB05))))
# (font file, face index) -> (glyph indices, subset font file bytes, glyph index map of the subset)
_SUBSETS: dict[tuple[str, int], tuple[frozenset, bytes, dict]] = {}


def base_glyphs(fontfile) -> frozenset:
    """The glyph indices of ``SUBSET_BASE``'s characters in ``fontfile`` (a matplotlib FontPath:
    a path with a face index), those the font has."""
    return _base_glyphs(str(fontfile), getattr(fontfile, "face_index", 0))


@functools.lru_cache(maxsize=None)
def _base_glyphs(path: str, face_index: int) -> frozenset:
    from fontTools.ttLib import TTFont     # matplotlib's own dependency for PDF font subsetting
    with TTFont(path, fontNumber=face_index, lazy=True) as font:
        cmap = font.getBestCmap() or {}
        return frozenset(font.getGlyphID(cmap[ord(c)]) for c in SUBSET_BASE if ord(c) in cmap)


class SubsetFontFile:
    """A font subset already written as a font file (``data``, bytes): what the PDF backend does
    with a subset font is save it to a file (``font_as_file``: ``font.save(file)``), so handing
    it the bytes skips parsing the subset and compiling it back for every figure.  A context
    manager like fontTools' TTFont, which ``SubsetResults`` opens."""

    def __init__(self, data: bytes):
        self.data = data

    def save(self, file, reorderTables=True) -> None:
        file.write(self.data)

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        return None


@contextlib.contextmanager
def glyph_subsets_cached():
    """Within: matplotlib's PDF backend takes the TrueType font subsets it embeds from a cache
    instead of subsetting the font file again for every figure (fontTools, ~0.07-0.7 s per font
    and file).  One subset per font file, of every glyph of ``SUBSET_BASE`` and every other glyph
    a figure of this process has used so far; a figure needing a glyph outside it makes it
    again, grown.  The PDF's glyph widths and text map come from the characters it uses, as
    before, so its pages are the same and its font files a few kB larger.  Without matplotlib's
    hook (``_backend_pdf_ps.get_glyphs_subset``) nothing changes.

    The hook is matplotlib >= 3.11's: ``get_glyphs_subset(fontfile, glyph indices)`` returns a
    context manager of ``SubsetResults(font, glyph_index_map)`` (the subset as a fontTools TTFont
    and the map from the font's glyph indices to the subset's); the PDF backend writes the font
    with ``font_as_file`` (``font.save``) and maps its glyphs through the map.  The cache hands
    out the cached subset's file bytes (``SubsetFontFile``) with the map of that subset."""
    from matplotlib.backends import _backend_pdf_ps as pdf_ps   # heavy, optional: figures only
    original = getattr(pdf_ps, "get_glyphs_subset", None)
    if original is None or getattr(original, "study_cache", False):
        yield
        return

    def cached(fontfile, glyphs):
        key = (str(fontfile), getattr(fontfile, "face_index", 0))
        have, data, index_map = _SUBSETS.get(key, (frozenset(), b"", {}))
        need = set(glyphs) | base_glyphs(fontfile)
        if not need <= have:
            have = frozenset(need | have)
            with original(fontfile, set(have)) as subset:
                data = pdf_ps.font_as_file(subset.font).getvalue()
                index_map = dict(subset.glyph_index_map)
            _SUBSETS[key] = (have, data, index_map)
        return pdf_ps.SubsetResults(SubsetFontFile(data), dict(index_map))._as_cm()

    cached.study_cache = True
    pdf_ps.get_glyphs_subset = cached
    try:
        yield
    finally:
        pdf_ps.get_glyphs_subset = original


def save(fig, stem, record=None) -> dict:
    """Write fig to stem.pdf and stem.png (``PNG_DPI``), each with the provenance ``record``
    (default ``run_provenance()``) in its metadata, the layout solved once for both
    (``save_pdf``); returns {"pdf": path, "png": path}.  (The study's own figures are PDF only,
    ``save_pdf``; this is for the figures whose PNG is read: gimbal_reduction.results.study.study_report,
    gimbal_reduction.results.bench.tolerance.)"""
    paths = save_pdf(fig, stem, record, close=False)
    paths["png"] = f"{stem}.png"
    savefig(fig, paths["png"], record or run_provenance(), dpi=PNG_DPI)
    pyplot().close(fig)
    return paths


def save_pdf(fig, stem, record=None, close=True) -> dict:
    """Write fig to stem.pdf (the reports' vector figure) with the provenance ``record`` (default
    ``run_provenance()``) in its metadata, its layout solved once first (``fix_layout``); returns
    {"pdf": path}.  The study's figures are written this way only: the reports include the PDFs,
    nothing reads a PNG of them, and one cost a fifth of the figures' time."""
    record = record or run_provenance()
    os.makedirs(os.path.dirname(os.path.abspath(stem)), exist_ok=True)
    paths = {"pdf": f"{stem}.pdf"}
    fix_layout(fig)
    with glyph_subsets_cached():
        savefig(fig, paths["pdf"], record)
    if close:
        pyplot().close(fig)
    return paths


def fix_layout(fig) -> None:
    """Solve fig's layout (constrained) once, here, and drop its layout engine: the positions are
    figure-relative, so every later draw at any dpi reuses them.  Without an engine ``savefig``
    draws once; with one (even matplotlib's 'none' placeholder) it walks the whole figure an extra
    time before drawing it."""
    engine = fig.get_layout_engine()
    if engine is None:
        return
    pin_empty_decorations(fig)
    solve_layout(fig, engine)
    plt = pyplot()
    with plt.rc_context({"figure.autolayout": False, "figure.constrained_layout.use": False}):
        fig.set_layout_engine(None)


def pin_empty_decorations(fig) -> None:
    """Pin the place of every empty title and axis label of fig's axes: matplotlib otherwise
    moves each clear of the tick labels at every layout pass and draw (an axis label's move
    solves the axis's ticks again), ~12 % of a rate figure's time, for text that draws nothing
    and, being empty, takes no room in the layout either.  Call it once the texts are set."""
    for ax in fig.get_axes():
        if not any(ax.get_title(loc) for loc in ("left", "center", "right")):
            ax.set_title("", y=1.0)          # an explicit y turns the automatic placement off
        if not ax.get_xlabel():
            ax.xaxis.set_label_coords(0.5, 0.0)
        if not ax.get_ylabel():
            ax.yaxis.set_label_coords(0.0, 0.5)


def solve_layout(fig, engine) -> None:
    """Run the layout ``engine`` on fig with text measured as the PDF draws it (unhinted glyphs
    at 72 dpi): on a PDF canvas, as ``savefig`` itself would lay the figure out before the PDF's
    draw.  (Measured on the figure's own Agg canvas, hinted glyphs come out a little larger and
    every panel ~2 % smaller, which can change a tick count.)"""
    from matplotlib.backends.backend_pdf import FigureCanvasPdf  # heavy, optional: figures only
    canvas, dpi = fig.canvas, fig.dpi
    FigureCanvasPdf(fig)
    try:
        engine.execute(fig)
    finally:
        fig.set_canvas(canvas)
        fig.dpi = dpi


def envelope(t, y, t0=None, t1=None, bins=ENVELOPE_BINS):
    """Min/max envelope of y(t) on [t0, t1] for plotting: at most ``bins`` columns, each drawn
    by its smallest and largest sample in time order, so no peak is lost; windows with at
    most 2*bins samples, or with a non-finite sample, are returned unchanged.  t (T,)
    ascending, y (T,); returns (t, y).

    Sample i of the window [t_a, t_b] falls in column c_i = min(floor(bins (t_i - t_a) /
    (t_b - t_a)), bins - 1); t is ascending, so c is too and every column is one run of
    samples [s_c, s_{c+1}).  Its extremes m_c = min y, M_c = max y over the run are two
    ``reduceat``s, and the first sample of the run equal to each is found by a search in the
    sorted positions of the samples that equal their column's extreme: no sort, O(T)."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    t0 = t[0] if t0 is None else t0
    t1 = t[-1] if t1 is None else t1
    lo, hi = np.searchsorted(t, t0, "left"), np.searchsorted(t, t1, "right")
    t, y = t[lo:hi], y[lo:hi]
    if t.size <= 2 * bins or not np.all(np.isfinite(y)):
        return t, y
    col = np.minimum(((t - t[0]) / (t[-1] - t[0]) * bins).astype(int), bins - 1)
    start = np.r_[0, np.flatnonzero(np.diff(col)) + 1]           # first sample of each column
    runs = np.diff(np.r_[start, t.size])                          # samples per column
    keep = []
    for extreme in (np.minimum, np.maximum):
        at = np.flatnonzero(y == np.repeat(extreme.reduceat(y, start), runs))   # ascending
        keep.append(at[np.searchsorted(at, start)])               # the first in each column
    keep = np.unique(np.concatenate(keep))                        # each column's min and max, time order
    return t[keep], y[keep]


def zoom_windows(t, zoom_s=ZOOM_S):
    """((t0, t1) early, (t0, t1) late) [s]: the first and the last ``zoom_s`` of the run
    (a fifth of the run each if it is shorter than 5 zoom_s)."""
    t0, t1 = float(t[0]), float(t[-1])
    w = min(zoom_s, (t1 - t0) / 5.0)
    return (t0, t0 + w), (t1 - w, t1)


def _fmt_e(e):
    return f"{e:.3g}" if e >= 1e-3 else f"{e:.2e}"


def _ms_label(w):
    ms = 1e3 * (w[1] - w[0])
    return f"{ms:.3g} ms"


RATE_RC = {**STYLE, "font.size": 8, "axes.titlesize": 8, "axes.labelsize": 8, "xtick.labelsize": 8,
           "ytick.labelsize": 8, "axes.grid": True}
RED, GREY = "tab:red", "0.6"
CASE_DASH = (0, (4, 2))


class RatePanels:
    """The 4 x 4 panels of the rate figures (``plot_rates``), built once and drawn again for every
    case of a run: axes, lines, headings, zoom shading and legends stay; data, units, limits,
    texts, the heading row's height and whether the rigid baseline shows change.  A fresh figure
    per case cost its construction and the first layout of hundreds of new tick artists each
    time (a third of a rate figure's time).  One per pair of zoom windows; draw and save inside
    ``RATE_RC``."""

    def __init__(self, early, late):
        plt = pyplot()
        self.fig = fig = plt.figure(figsize=(7.0, 8.8), constrained_layout=True)
        # as fig.subfigures(5, 1, hspace=0, height_ratios=...), keeping the grid to resize its rows
        self.grid = plt.GridSpec(5, 1, figure=fig, hspace=0.0, height_ratios=_row_ratios(1))
        self.top, *rows = [fig.add_subfigure(self.grid[j, 0]) for j in range(5)]
        self.rows = []
        for k, sub in enumerate(rows):
            axes = sub.subplots(1, 4, gridspec_kw={"width_ratios": [1.25, 1.25, 1, 1]})
            ax = axes[0]
            row = {"sub": sub, "axes": axes, "err_rigid": [], "err": []}
            row["rigid"], = ax.plot([], [], color=GREY, lw=1.6, label="rigid model")
            row["truth"], = ax.plot([], [], color="black", lw=0.9, label="truth")
            row["case"], = ax.plot([], [], color=RED, lw=0.9, ls=CASE_DASH)
            for j, (ax, win) in enumerate(zip(axes[1:], (None, early, late))):
                row["err_rigid"].append(ax.plot([], [], color=GREY, lw=0.9)[0])
                row["err"].append(ax.plot([], [], color=RED, lw=0.8)[0])
                ax.axhline(0.0, color="black", lw=0.5)
                ax.margins(y=0.08)
                if j:
                    ax.set_xlim(1e3 * win[0], 1e3 * win[1])
                    ax.set_xticks(np.linspace(1e3 * win[0], 1e3 * win[1], 3))
            axes[0].set_ylabel("rate")           # units: per case (``draw``)
            axes[1].set_ylabel("error")
            for w in (early, late):
                axes[1].axvspan(1e3 * w[0], 1e3 * w[1], color="tab:blue", alpha=0.12, lw=0)
            for j, ax in enumerate(axes):
                if j < 2:
                    ax.xaxis.set_major_locator(plt.MaxNLocator(nbins=4))
                ax.xaxis.set_major_formatter(plt.FormatStrFormatter("%.4g"))
                ax.yaxis.get_offset_text().set_fontsize(8)
            if k == 0:
                for ax, name in zip(axes, ("rate, whole run", "error, whole run",
                                           f"error, first {_ms_label(early)}",
                                           f"error, last {_ms_label(late)}")):
                    ax.set_title(name, fontsize=8)
            if k == 3:
                for ax in axes:
                    ax.set_xlabel("time t [ms]")
            self.rows.append(row)
        self.legends = {}                        # with the rigid baseline or without
        for with_rigid in (True, False):
            handles = [plt.Line2D([], [], color="black", lw=0.9, label="truth (100 modes/body)"),
                       plt.Line2D([], [], color=RED, lw=0.9, ls=CASE_DASH,
                                  label="reduced model; error = reduced - truth")]
            if with_rigid:
                handles.append(plt.Line2D([], [], color=GREY, lw=1.6, label="rigid model"))
            handles.append(plt.matplotlib.patches.Patch(color="tab:blue", alpha=0.12, label="zoom windows"))
            self.legends[with_rigid] = self.top.legend(
                handles=handles, loc="lower center", ncol=len(handles), fontsize=8, frameon=False,
                handlelength=2.2, columnspacing=1.2)
        # the layout is solved again for every case (tick labels change), each time from the
        # positions of a fresh figure, so it comes out as on a figure of its own
        self.start = [(ax, ax.get_position(original=True).frozen()) for ax in fig.get_axes()]
        pin_empty_decorations(fig)
        # every panel has tick labels left and below, beyond its frame's tick marks: the frame
        # (spines) never widens a panel's margins, so the layout need not measure it (~7 % of a
        # rate figure's time); ``test_rate_panels_layout_ignores_no_frame`` checks it
        for ax in fig.get_axes():
            for spine in ax.spines.values():
                spine.set_in_layout(False)
        self.engine = fig.get_layout_engine()
        with plt.rc_context({"figure.autolayout": False, "figure.constrained_layout.use": False}):
            fig.set_layout_engine(None)          # no engine: savefig draws once (``fix_layout``)

    def draw(self, t, truth, case, rigid, heading, E, E_r, early, late) -> None:
        """Put one case's rates and errors into the panels.  t (T,); truth, case, rigid (T, 4)
        gimbal rates (rigid None: no baseline drawn); heading: the title (its lines set the
        heading row's height); E, E_r (4,)."""
        self.grid.set_height_ratios(_row_ratios(heading.count("\n") + 1))
        self.top.suptitle(heading, fontsize=9)
        for with_rigid, legend in self.legends.items():
            legend.set_visible(with_rigid == (rigid is not None))
        for k, (row, b) in enumerate(zip(self.rows, BODIES)):
            head = f"{RATE_LABELS[b]}:   E = {_fmt_e(E[k])}"
            if E_r is not None:
                head += f"   (rigid model: E = {_fmt_e(E_r[k])})"
            row["sub"].suptitle(head, x=0.01, ha="left", fontsize=8.5, fontweight="bold")
            tr, cs = truth[:, k], case[:, k]
            err = cs - tr
            err_r = rigid[:, k] - tr if rigid is not None else None
            fr, ur = rate_unit(max(np.abs(tr).max(), np.abs(cs).max()))
            fe, ue = rate_unit(max(np.abs(err).max(), 0.0 if err_r is None else np.abs(err_r).max()))
            row["truth"].set_data(*_ms(envelope(t, tr), fr))
            row["case"].set_data(*_ms(envelope(t, cs), fr))
            for j, win in enumerate(((t[0], t[-1]), early, late)):
                row["err"][j].set_data(*_ms(envelope(t, err, *win), fe))
                base = row["err_rigid"][j]
                base.set_data(*(([], []) if err_r is None else _ms(envelope(t, err_r, *win), fe)))
            row["rigid"].set_data(*(([], []) if rigid is None else _ms(envelope(t, rigid[:, k]), fr)))
            for line in (row["rigid"], *row["err_rigid"]):
                line.set_visible(rigid is not None)
            axes = row["axes"]
            axes[1].set_xlim(1e3 * t[0], 1e3 * t[-1])
            axes[0].set_ylabel(f"rate [{ur}]")
            axes[1].set_ylabel(f"error [{ue}]")
            for ax in axes:
                ax.relim()
                ax.autoscale_view()
        for sub, box in zip(self.fig.subfigs, _grid_boxes(self.grid)):
            sub.bbox_relative.set_points(box)
        for ax, start in self.start:
            ax.set_position(start)
            ax.set_in_layout(True)
        solve_layout(self.fig, self.engine)

    def close(self) -> None:
        pyplot().close(self.fig)


def _row_ratios(heading_lines: int) -> list[float]:
    """Heights of the rate figure's rows: the heading (title and legend), then the four rates."""
    return [0.15 + 0.11 * heading_lines, 1, 1, 1, 1.08]


def _grid_boxes(grid) -> list[np.ndarray]:
    """[[x0, y0], [x1, y1]] (figure fractions) of each row of a one-column grid, as a new subfigure
    in it starts (matplotlib's SubFigure places itself by the ratios alone, before any layout)."""
    hr = np.asarray(grid.get_height_ratios())
    out = []
    for j in range(len(hr)):
        dy = hr[j:j + 1].sum() / hr.sum()
        y0 = 1 - hr[:j + 1].sum() / hr.sum()
        out.append(np.array([[0.0, y0], [1.0, y0 + dy]]))
    return out


def plot_rates(truth: dict, case: dict, stem: str, title: str | None = None, rigid: dict | None = None,
               zoom_s: float = ZOOM_S, panels: dict | None = None) -> dict:
    """Truth vs reduced (vs rigid) gimbal rates and their errors against time, 4 rows x 4 columns.

    Row n: gamma_dot_n over the run (truth, reduced, rigid baseline), the error e_n = reduced -
    truth [rad/s] over the run (rigid - truth in grey behind), and e_n zoomed on the first and the
    last ``zoom_s`` (shaded in the second panel).  E (eq 3.53) of the model and of the rigid model
    are in each row's heading, outside the axes.  Long runs are drawn as min/max envelopes
    (``envelope``).  truth, case, rigid: dicts of ``read_sim`` on one grid; panels: a dict of
    ``RatePanels`` kept between calls (the caller closes them; None: a figure of its own);
    returns {"pdf", "E", "E_rigid", "windows_s"}."""
    check_same_grid(truth["t"], case["t"], case.get("path", case.get("model", "case")))
    if rigid is not None:
        check_same_grid(truth["t"], rigid["t"], rigid.get("path", "rigid"))
    t = truth["t"]
    E = error_measure(t, truth["gamma_dot"], case["gamma_dot"])
    E_r = error_measure(t, truth["gamma_dot"], rigid["gamma_dot"]) if rigid is not None else None
    early, late = zoom_windows(t, zoom_s)
    heading = textwrap.fill(title or f"Gimbal rates: truth vs {case['model']}", 105)
    key = (early, late)
    own = panels is None
    panels = {} if own else panels
    with pyplot().rc_context(RATE_RC):
        if key not in panels:
            panels[key] = RatePanels(early, late)
        fig = panels[key]
        fig.draw(t, truth["gamma_dot"], case["gamma_dot"], None if rigid is None else rigid["gamma_dot"],
                 heading, E, E_r, early, late)
        paths = save_pdf(fig.fig, stem, close=own)
    return {**paths, "E": [float(e) for e in E],
            "E_rigid": None if E_r is None else [float(e) for e in E_r],
            "windows_s": [list(early), list(late)]}


def _ms(ty, scale=1.0):
    return 1e3 * ty[0], scale * ty[1]


def rate_unit(peak):
    """(factor, unit) that puts a rate of magnitude ``peak`` [rad/s] in [1, 1000) units
    (rad/s, mrad/s or urad/s, nrad/s below), so no axis needs an offset or exponent label."""
    for factor, unit in ((1.0, "rad/s"), (1e3, "mrad/s"), (1e6, r"$\mu$rad/s"), (1e9, "nrad/s")):
        if peak * factor >= 1.0:
            return factor, unit
    return 1e9, "nrad/s"


def _series(rows, group, col, coordinates=False):
    """(modes per body (k,), E (k,)) of a group; global-N counts N in total, drawn at N/4;
    ``coordinates``: against elastic coordinates per body (n_elastic / 4) instead."""
    if coordinates:
        pts = sorted((r["n_elastic"] / len(BODIES), r[col]) for r in rows
                     if r["group"] == group and r.get("n_elastic") is not None)
        return np.array([p[0] for p in pts], float), np.array([p[1] for p in pts], float)
    d = PER_BODY_DIVISOR.get(group, 1)
    pts = sorted((r["count"] / d, r[col]) for r in rows if r["group"] == group and r["count"] is not None)
    return np.array([p[0] for p in pts], float), np.array([p[1] for p in pts], float)


def _has_typo(thesis_keys) -> bool:
    """Whether any table of ``thesis_keys`` ({label: THESIS key}) has a suspected typo."""
    keys = set((thesis_keys or {}).values())
    return any(key in keys for key, _, _ in findings.THESIS_SUSPECTED_TYPOS)


def plot_error_vs_modes(rows: list[dict], groups, stem: str, title: str, thesis=None,
                        rigid_E=None, thesis_keys=None, coordinates=False) -> dict:
    """E (log) against vibration modes per body, one panel per gimbal rate, one line per group.

    rows: table rows (``read_table``); thesis: optional {label: {count: (4,) E}} in grey, with
    thesis_keys {label: key of findings.THESIS}: the entries of findings.THESIS_SUSPECTED_TYPOS are
    drawn apart (red x, not joined: the legend's entry is drawn on the first panel);
    rigid_E: optional (4,) E of the rigid model, a horizontal dashed line; ``coordinates``:
    against elastic coordinates per body (``_series``).  The legend sits below the panels."""
    plt = pyplot()
    with plt.rc_context(STYLE):
        fig, axes = plt.subplots(2, 2, figsize=(7.0, 5.6), sharex=True, constrained_layout=True)
        for k, (ax, b) in enumerate(zip(axes.flat, BODIES)):
            col = RATE_COLUMNS[k]
            for g in groups:
                x, y = _series(rows, g, col, coordinates)
                if x.size:
                    look = names.style(g)
                    c, m, ls = look.colour, look.marker, look.line
                    ax.plot(x, np.where(y > 0, y, np.nan), color=c, marker=m, ls=ls or "-",
                            label=f"ours: {names.label(g)}")
            for j, (label, data) in enumerate((thesis or {}).items()):
                xs = sorted(data)
                key = (thesis_keys or {}).get(label)
                bad = [n for n in xs if (key, n, k) in findings.THESIS_SUSPECTED_TYPOS]
                ax.plot(xs, [np.nan if n in bad else data[n][k] for n in xs], color="0.55",
                        marker="os"[j % 2], ms=3, ls=":", lw=0.8, label=f"thesis: {label}")
                ax.plot(bad, [data[n][k] for n in bad], ls="none", marker="x", ms=6, mew=1.2,
                        color="tab:red", label="_nolegend_")
            if k == 0 and _has_typo(thesis_keys):      # the legend is the first panel's
                ax.plot([], [], ls="none", marker="x", ms=6, mew=1.2, color="tab:red",
                        label="thesis: suspected misprint (not joined)")
            if rigid_E is not None and np.isfinite(rigid_E[k]) and rigid_E[k] > 0:
                ax.axhline(rigid_E[k], color="black", ls="--", lw=1.0,
                           label="ours: rigid model (no elastic modes)")
            ax.set_yscale("log")
            ax.set_ylabel(f"E of {RATE_LABELS[b]} [-]")
            if k >= 2:
                ax.set_xlabel("elastic coordinates per body" if coordinates else "vibration modes per body")
        handles, labels = axes.flat[0].get_legend_handles_labels()
        if handles:
            fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=8, frameon=False,
                       bbox_to_anchor=(0.5, 0.0))
            low = 0.025 + 0.032 * ((len(handles) + 1) // 2)      # legend rows at 8 pt in 5.6 in
            fig.get_layout_engine().set(rect=(0, low, 1, 1 - low))
        fig.suptitle(title)
        return save_pdf(fig, stem)


def _short_load_case(case):
    bearing, comp = case.rsplit("_", 1)
    abbrev = {"input_motor": "IM", "output_motor": "OM", "input_resolver": "IR", "output_resolver": "OR"}
    return f"{abbrev.get(bearing, bearing)} {comp[0]}$_{comp[1]}$"


def plot_load_cases(rows: list[dict], stem: str, controls=()) -> dict:
    """Grouped bars: E (log) of each gimbal rate for the seven static-mode load cases, after the
    controls (``controls``: [(label, (4,) E)], e.g. the rigid model and the same vibration modes
    without a static mode), separated by a vertical line.  Legend above the axes."""
    plt = pyplot()
    lc = [r for r in rows if r["group"] == "load-case"]
    order = [c for c, _ in LOAD_CASES]
    lc.sort(key=lambda r: order.index(r["load_case"]) if r["load_case"] in order else len(order))
    groups = [(label, list(E)) for label, E in controls] + \
             [(f"{_short_load_case(r['load_case'])}\n(Fig {r['thesis_figure']})",
               [r[c] for c in RATE_COLUMNS]) for r in lc]
    with plt.rc_context(STYLE):
        fig, ax = plt.subplots(figsize=(7.0, 3.9), constrained_layout=True)
        x = np.arange(len(groups))
        w = 0.2
        for k, b in enumerate(BODIES):
            ax.bar(x + (k - 1.5) * w, [g[1][k] for g in groups], w, label=RATE_LABELS[b])
        if controls:
            ax.axvline(len(controls) - 0.5, color="black", lw=0.8)
        ax.set_xticks(x, [g[0] for g in groups], fontsize=8)
        ax.set_yscale("log")
        ax.set_ylabel("E [-]")
        ax.set_xlabel("controls | load case of the outer gimbal's static mode (10 lowest modes per body;"
                      " IM/OM input/output motor)", fontsize=8)
        fig.legend(*ax.get_legend_handles_labels(), loc="upper center", ncol=4, fontsize=8,
                   frameon=False, bbox_to_anchor=(0.5, 0.935))
        fig.get_layout_engine().set(rect=(0, 0, 1, 0.88))
        fig.suptitle("Error for the seven static-mode load cases and their controls", fontsize=9)
        return save_pdf(fig, stem)


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


def _size(r):
    """A case's size: its elastic coordinates (NaN if unknown)."""
    return float(r["n_elastic"]) if r.get("n_elastic") not in (None, "") else float("nan")


def tick_number(v) -> str:
    """A tick value to three digits: plain between 1e-3 and 1e3 (0.005), else m x 10^e in mathtext."""
    if v == 0 or 1e-3 <= abs(v) < 1e3:
        return f"{v:.3g}"
    exponent = int(np.floor(np.log10(abs(v))))
    mantissa = float(f"{v / 10.0 ** exponent:.3g}")
    if mantissa == 10.0:
        mantissa, exponent = 1.0, exponent + 1
    return f"$10^{{{exponent}}}$" if mantissa == 1.0 else f"${mantissa:g}\\times10^{{{exponent}}}$"


def log_ticks_for(ax, values, plt) -> None:
    """Readable log-axis ticks on y for data ``values`` (positive ones used): a span under three
    decades gets labels at 1, 2 and 5 of each decade (a single "10^-2" otherwise), plain numbers."""
    pos = np.asarray(values, float)
    pos = pos[np.isfinite(pos) & (pos > 0)]
    if pos.size and pos.max() < 1e3 * pos.min():
        ax.yaxis.set_major_locator(plt.LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        # (a span under a decade falls back to linear ticks such as 0.00125: three digits)
        ax.yaxis.set_major_formatter(plt.FuncFormatter(lambda v, _: tick_number(v)))
        ax.yaxis.set_minor_formatter(plt.NullFormatter())


# where a point's label may go, tried in this order: (dx, dy) in points and the text's alignment
LABEL_SPOTS = ((-5, -12, "right"), (5, -12, "left"), (5, 4, "left"), (-5, 4, "right"),
               (-5, -22, "right"), (5, -22, "left"), (5, 14, "left"), (-5, 14, "right"))


def label_points(ax, points, fontsize=9) -> None:
    """Label each point (text, x, y) in data coordinates at the first of ``LABEL_SPOTS`` where the
    text neither overlaps a label already placed nor leaves the axes; a point with no free spot
    keeps no label (the legend names its group).  Measured after the axes' limits are final."""
    fig = ax.figure
    fig.canvas.draw()                            # the limits and the transforms are set
    renderer = fig.canvas.get_renderer()
    frame = ax.get_window_extent(renderer)
    placed = []
    for text, x, y in points:
        for dx, dy, ha in LABEL_SPOTS:
            label = ax.annotate(text, (x, y), fontsize=fontsize, xytext=(dx, dy),
                                textcoords="offset points", ha=ha)
            box = label.get_window_extent(renderer)
            inside = (box.x0 >= frame.x0 and box.x1 <= frame.x1 and box.y0 >= frame.y0
                      and box.y1 <= frame.y1)
            if inside and not any(box.overlaps(other) for other in placed):
                placed.append(box)
                break
            label.remove()


def plot_runtime_error(rows: list[dict], stem: str, col: str = "E_outer_gimbal", rigid_E=None) -> dict:
    """Scatter of each case's size (elastic coordinates) against E (log) of one rate, the Pareto
    front and the rigid model's E (``rigid_E``, optional) as a horizontal line; the truth's size is
    named in the legend (it is far right of the cases: 400 against at most 100 coordinates, so a line
    there would squeeze them into a quarter of the axes); legend below the axes.  The front's points
    are labelled with their model, except the rigid one (at size 0, its line is labelled).  (Sizes,
    not the study's single-run wall times: run times come from the benchmark's medians,
    ``snakemake bench``.)"""
    plt = pyplot()
    # the truth check (the truth + residual flexibility) referees the truth: not a case
    cases = [r for r in rows if r["group"] not in ("truth", "truth-check") and np.isfinite(_size(r))]
    truth = [r for r in rows if r["group"] == "truth"]
    with plt.rc_context(STYLE):
        fig, ax = plt.subplots(figsize=(7.0, 5.2), constrained_layout=True)
        for g in dict.fromkeys(r["group"] for r in cases):
            sel = [r for r in cases if r["group"] == g]
            c, m = names.style(g).colour, names.style(g).marker
            ax.scatter([_size(r) for r in sel], [r[col] for r in sel], color=c, marker=m,
                       label=names.label(g), zorder=3)
        cost = np.array([_size(r) for r in cases])
        err = np.array([r[col] for r in cases])
        front = pareto_front(cost, err)
        if front:       # ringed points and a staircase: drawn even when the front is one point
            ax.plot(cost[front], err[front], drawstyle="steps-post", color="0.3", lw=1, ls="--",
                    marker="o", ms=10, mfc="none", mec="0.3",
                    label="Pareto front (ringed)" if len(front) > 1 else
                    f"Pareto front: one point ({cases[front[0]]['model']}, ringed)", zorder=2)
        if truth and np.isfinite(_size(truth[0])):
            ax.plot([], [], ls="none", label=f"truth (off the axis): {_size(truth[0]):.0f} coordinates")
        if rigid_E is not None and np.isfinite(rigid_E) and rigid_E > 0:
            ax.axhline(rigid_E, color="black", lw=1, ls=":", label=f"rigid model: E = {rigid_E:.3g}")
        ax.set_yscale("log")
        log_ticks_for(ax, err, plt)
        finite = cost[np.isfinite(cost)]
        if finite.size:
            ax.set_xlim(-0.04 * finite.max() - 1, 1.12 * finite.max() + 1)
        pos = err[np.isfinite(err) & (err > 0)]
        if pos.size:                             # room below the lowest point for its label
            ax.set_ylim(pos.min() / 1.6, pos.max() * 1.3)
        ax.set_xlabel("elastic coordinates of the model")
        ax.set_ylabel(f"E of {RATE_LABELS[2]} [-]")
        handles, labels = ax.get_legend_handles_labels()
        fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=8, frameon=False,
                   columnspacing=1.0, handlelength=1.6)
        low = 0.02 + ((len(handles) + 1) // 2) * 8 * 1.55 / 72 / fig.get_figheight()
        fig.get_layout_engine().set(rect=(0, low, 1, 1 - low))
        ax.set_title("Model size against error (eq 3.53)")
        # last: the labels are placed in the final axes
        label_points(ax, [(cases[i]["model"], cost[i], err[i]) for i in front if cases[i]["model"] != RIGID])
        return save_pdf(fig, stem)


def _rigid_E(rows, rigid, truth):
    """(4,) E of the rigid model: from a table row of model ``rigid``, else from its simulation."""
    for r in rows:
        if r["model"] == RIGID:
            return [r[c] for c in RATE_COLUMNS]
    if rigid is not None and truth is not None:
        return [float(e) for e in error_measure(truth["t"], truth["gamma_dot"], rigid["gamma_dot"])]
    return None


def make_figures(out_dir, ranking_rows=None, static_rows=None, truth=None, cases=(),
                 thesis=None, rigid=None, scene=None, zoom_s=ZOOM_S) -> list[dict]:
    """Every figure whose inputs are given; returns the manifest entries (paths relative to out_dir).

    rigid: the rigid model's simulation (``read_sim``), drawn as a baseline in every rate figure
    (None: taken from ``cases`` if one is model ``rigid``; absent: no baseline, said in the
    captions).  scene: the scene's name for the titles (default: the truth's ``scene`` attribute)."""
    thesis = findings.THESIS if thesis is None else thesis
    entries = []

    def add(paths, **meta):
        entries.append({**meta, **{k: os.path.relpath(v, out_dir) for k, v in paths.items()}})

    ranking_rows, static_rows = ranking_rows or [], static_rows or []
    if rigid is None:
        rigid = next((c for c in cases if c["model"] == RIGID), None)
    if scene is None and truth is not None:
        scene = truth["attrs"].get("scene") or None
    on = f" ({scene} scene)" if scene else ""
    E_rigid = _rigid_E(ranking_rows + static_rows, rigid, truth)
    if truth is not None:
        order = {c["model"]: i for i, c in enumerate(study_cases())}
        t = truth["t"]
        dt = float(np.median(np.diff(t))) if t.size > 1 else float("nan")
        thinned = t.size > 2 * ENVELOPE_BINS
        panels = {}      # rate-figure skeletons, drawn again for each case (RatePanels)
        try:
            for case in sorted(cases, key=lambda c: order.get(c["model"], len(order))):
                d = describe_model(case["model"])
                fig = f" (thesis Fig {d['thesis_figure']})" if d["thesis_figure"] else ""
                base = rigid if rigid is not None and case["model"] != RIGID else None
                stem = f"rates_{safe_name(case['model'])}"
                out = plot_rates(truth, case, os.path.join(out_dir, stem),
                                 f"Truth vs {d['title']}{on}", rigid=base, zoom_s=zoom_s,
                                 panels=panels)
                early, late = out["windows_s"]
                if case["model"] == RIGID:
                    baseline = "This is the rigid model itself."
                elif base is not None:
                    baseline = ("Grey: the rigid model (no elastic modes) as a baseline, its E in the row "
                                "headings.")
                else:
                    baseline = "Rigid-model baseline not available (no simulation of model rigid given)."
                add({"pdf": out["pdf"]}, id=stem, kind="rates", model=case["model"],
                    group=d["group"], thesis_figure=d["thesis_figure"], scene=scene or "",
                    E=dict(zip(RATE_COLUMNS, out["E"])),
                    E_rigid=None if out["E_rigid"] is None else dict(zip(RATE_COLUMNS, out["E_rigid"])),
                    baseline=RIGID if base is not None else None,
                    zoom_windows_ms=[[1e3 * a for a in early], [1e3 * a for a in late]],
                    envelope=thinned,
                    caption=f"Gimbal rates{on} of the truth model (black) and of model {case['model']}, "
                            f"{d['title']} (red dashed){fig}, and the error model - truth against time: "
                            f"whole run, first {_ms_label(early)} and last {_ms_label(late)} (shaded in the "
                            f"whole-run panel). {baseline} E per rate from eq 3.53 in the row headings."
                            + (f" {t.size} samples ({dt:.2g} s apart) drawn as min/max envelopes of "
                               f"{ENVELOPE_BINS} columns per panel (no peak dropped)." if thinned else ""))
        finally:
            for p in panels.values():
                p.close()
    rigid_note = ("black dashed: the rigid model (no elastic modes)." if E_rigid is not None else
                  "rigid-model baseline not available (no rigid simulation or table row).")
    if any(r["group"] in RANKING_TABLE_GROUPS for r in ranking_rows):
        th = {"freq (Table 4.2)": thesis["freq"], "XMX/XMGMX (Table 4.2)": thesis["ranked"]}
        add(plot_error_vs_modes(ranking_rows, LINE_GROUPS,
                                os.path.join(out_dir, "error_ranking"),
                                f"Error against mode count{on}: lowest-frequency vs ranked modes", th,
                                E_rigid, {"freq (Table 4.2)": "freq", "XMX/XMGMX (Table 4.2)": "ranked"}),
            id="error_ranking", kind="error", model="", group="", thesis_figure="4-28",
            scene=scene or "", baseline=RIGID if E_rigid is not None else None,
            caption="Error E (eq 3.53) of each gimbal rate against the number of vibration modes "
                    "per body, lowest-frequency, XMX- and XMGMX-ranked modes (analogue of Fig 4-28), "
                    "the scene-aware selections (load-N per body; global-N pooled, drawn at N/4) and "
                    "the field's defaults (dominance ranking, Craig-Bampton against its fixed-interface "
                    "modes, Ritz vectors); "
                    "grey: the thesis's Table 4.2 (red x: an entry that is probably a misprint, "
                    "study report); " + rigid_note)
    if any(r["group"].startswith("static-") for r in static_rows):
        th = {"1 static + lowest (Table 4.3)": thesis["static-freq"],
              "1 static + ranked (Table 4.3)": thesis["static-ranked"]}
        add(plot_error_vs_modes(static_rows, ("static-freq", "static-xmx", "static-xmgmx"),
                                os.path.join(out_dir, "error_static"),
                                f"Error against mode count with one static mode per body{on}", th,
                                E_rigid, {"1 static + lowest (Table 4.3)": "static-freq",
                                          "1 static + ranked (Table 4.3)": "static-ranked"}),
            id="error_static", kind="error", model="", group="", thesis_figure="4-29",
            scene=scene or "", baseline=RIGID if E_rigid is not None else None,
            caption="Error E (eq 3.53) of each gimbal rate against the number of vibration modes "
                    "per body with one static correction mode per body, lowest-frequency and ranked "
                    "modes (analogue of Fig 4-29); grey: the thesis's Table 4.3 (red x: an entry that is probably a misprint, "
                    "study report); " + rigid_note)
    if any(r["group"] == "load-case" for r in static_rows):
        controls = []
        if E_rigid is not None:
            controls.append(("rigid\n(control)", E_rigid))
        ctrl = next((r for r in ranking_rows if r["model"] == f"freq-{LOAD_CASE_COUNT}"), None)
        if ctrl is not None:
            controls.append((f"no static\n(freq-{LOAD_CASE_COUNT})", [ctrl[c] for c in RATE_COLUMNS]))
        titles = [c[0].split(chr(10))[0] for c in controls]
        add(plot_load_cases(static_rows, os.path.join(out_dir, "error_load_cases"), controls),
            id="error_load_cases", kind="error", model="", group="load-case",
            thesis_figure="4-21..4-27", scene=scene or "", controls=titles,
            baseline=RIGID if E_rigid is not None else None,
            caption=f"Error E of each gimbal rate{on} with the 10 lowest modes per body and one static "
                    "mode on the outer gimbal, for the seven load cases (Figs 4-21 to 4-27)"
                    + (", after the controls left of the line: " + (
                        "the rigid model and " if E_rigid is not None else "")
                       + (f"the same {LOAD_CASE_COUNT} modes without a static mode (freq-{LOAD_CASE_COUNT})"
                          if ctrl is not None else "") if controls else "")
                    + "." + ("" if E_rigid is not None else " Rigid-model control not available.")
                    + ("" if ctrl is not None else f" No-static control freq-{LOAD_CASE_COUNT} not "
                                                    "in the ranking table."))
    rows = ranking_rows + static_rows
    present = [g for g in COORDINATE_GROUPS if any(r["group"] == g for r in rows)]
    if present:
        add(plot_error_vs_modes(rows, present, os.path.join(out_dir, "error_coordinates"),
                                f"Error against elastic coordinates per body{on}: every family", None,
                                E_rigid, coordinates=True),
            id="error_coordinates", kind="error", model="", group="", thesis_figure="",
            scene=scene or "", baseline=RIGID if E_rigid is not None else None,
            caption="Error E (eq 3.53) of each gimbal rate against the elastic coordinates kept per "
                    "body (all coordinates over the four bodies / 4) for every mode family: the "
                    "thesis's (lowest-frequency, XMX, XMGMX, 1 static + modes), ours (load-N, "
                    "global-N) and the field's defaults (dominance ranking, orthonormalised "
                    "Craig-Bampton with its 6 constraint modes per ring counted, load-dependent Ritz "
                    "vectors); the numbers: the scene's table coordinates.csv; " + rigid_note)
    if any(r["group"] != "truth" and np.isfinite(_size(r)) for r in rows):
        add(plot_runtime_error(rows, os.path.join(out_dir, "runtime_error"),
                               rigid_E=None if E_rigid is None else E_rigid[0]),
            id="runtime_error", kind="cost", model="", group="", thesis_figure="", scene=scene or "",
            baseline=RIGID if E_rigid is not None else None,
            caption=f"Size of each case (elastic coordinates){on} against the error E of the outer "
                    "gimbal rate; dashed: the Pareto front (no case is both smaller and more "
                    "accurate), each of its points labelled with its model; the truth's size is named "
                    "in the legend. Run times: the benchmark's medians, not single runs"
                    + ("; dotted: the rigid model's E." if E_rigid is not None else
                       "; rigid-model baseline not available."))
    return entries


def write_manifest(out_dir, entries, scene=None, rigid=None, notes=()):
    """``<out_dir>/figures.json``: {description, scene, rigid (path or null), notes, figures}."""
    path = os.path.join(out_dir, "figures.json")
    write_json(path, {"description": "Figures of the results stage (gimbal_reduction/results/study/figures.py); paths "
                                     "relative to this file.", "scene": scene or "",
                      "rigid": rigid, "notes": list(notes), "figures": entries})
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gimbal_reduction.results.study.figures",
                                     description="Figures of the study (PDF + PNG) and their manifest.")
    parser.add_argument("--truth", help="truth simulation file (for the rate figures)")
    parser.add_argument("--cases", nargs="*", default=[],
                        help="reduced-model simulation files (one rate figure each; a file of model "
                             "'rigid' among them is also the baseline)")
    parser.add_argument("--rigid", help="simulation file of model 'rigid', the baseline of every rate "
                                        "figure (default: the case of model 'rigid', if any; a "
                                        "missing file is skipped and noted in the manifest)")
    parser.add_argument("--ranking-table", help="results/tables/errors_ranking.csv")
    parser.add_argument("--static-table", help="results/tables/errors_static.csv")
    parser.add_argument("--scene", help="scene name for titles and captions (default: the truth's)")
    parser.add_argument("--zoom-ms", type=float, default=1e3 * ZOOM_S,
                        help=f"width of the early and late zoom windows [ms] (default {1e3 * ZOOM_S:g})")
    parser.add_argument("--out-dir", required=True, help="folder of the figures and figures.json")
    args = parser.parse_args(argv)
    notes = []
    try:
        truth = read_sim(args.truth) if args.truth else None
        cases = [read_sim(p) for p in args.cases
                 if not args.truth or os.path.abspath(p) != os.path.abspath(args.truth)]
        if cases and truth is None:
            raise ErrorsInputError("--cases needs --truth")
        rigid = None
        if args.rigid and os.path.exists(args.rigid):
            rigid = next((c for c in cases if os.path.abspath(c["path"]) == os.path.abspath(args.rigid)),
                         None) or read_sim(args.rigid)
        elif args.rigid:
            notes.append(f"rigid baseline {args.rigid} missing: figures drawn without it")
        rank = read_table(args.ranking_table) if args.ranking_table else []
        stat = read_table(args.static_table) if args.static_table else []
        if args.zoom_ms <= 0:
            raise ErrorsInputError(f"--zoom-ms must be positive, got {args.zoom_ms}")
    except (ErrorsInputError, OSError) as exc:
        print(f"gimbal_reduction.results.study.figures: error: {exc}", file=sys.stderr)
        return 2
    if rigid is None:
        rigid = next((c for c in cases if c["model"] == RIGID), None)
    if rigid is None and truth is not None:
        notes.append("no simulation of model rigid: rate figures without the rigid baseline")
    entries = make_figures(args.out_dir, rank, stat, truth, cases, rigid=rigid, scene=args.scene,
                           zoom_s=1e-3 * args.zoom_ms)
    scene = args.scene or (truth["attrs"].get("scene") if truth is not None else None)
    path = write_manifest(args.out_dir, entries, scene,
                          os.path.relpath(rigid["path"], args.out_dir) if rigid is not None else None, notes)
    print(f"gimbal_reduction.results.study.figures: {len(entries)} figures -> {args.out_dir} ({path})"
          + "".join(f"; {n}" for n in notes))
    return 0


if __name__ == "__main__":
    sys.exit(main())
