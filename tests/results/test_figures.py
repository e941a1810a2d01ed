"""gimbal_reduction.results.study.figures (rate figures with the rigid baseline and zoom windows, envelopes of long
runs, the manifest) and gimbal_reduction.results.study.mode_shapes (print figures of a small synthetic body)."""
from __future__ import annotations

import json
import os

import h5py
import meshio
import numpy as np
import pytest

from gimbal_reduction.results.study import figures, mode_shapes, tables
from gimbal_reduction.solver.dynamics.simfile import read_sim
from tests.synthetic_bodies import project_body_hash
from tests.results.synthetic_study import DT, T_END, truth_rates, write_sim, write_study

CASES = ("freq-5", "static-4")                      # rate figures drawn
TABLED = CASES + ("freq-10", "static-10@2:output_motor_fz")   # in the tables only


@pytest.fixture(scope="module")
def sims(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("figs")
    truth, tabled = write_study(tmp / "sim", cases=[c for c in tables.study_cases() if c["model"] in TABLED])
    cases = [p for p in tabled if p.endswith(tuple(f"/{m}.h5" for m in CASES))]
    t = np.linspace(0.0, T_END, int(round(T_END / DT)) + 1)
    rigid = write_sim(tmp / "sim" / "thesis" / "rigid.h5", "rigid", t, 1.2 * truth_rates(t), n_modes=[0] * 4)
    rt, st = tmp / "errors_ranking.csv", tmp / "errors_static.csv"
    assert tables.main(["--truth", truth, "--cases", *tabled, rigid, "--ranking-table", str(rt),
                        "--static-table", str(st)]) == 0
    return {"tmp": tmp, "truth": truth, "cases": cases, "rigid": rigid, "ranking": str(rt), "static": str(st)}


def _manifest(d):
    return json.loads((d / "figures.json").read_text())


def test_rate_figures_have_rigid_baseline_and_zoom(sims):
    d = sims["tmp"] / "with_rigid"
    assert figures.main(["--truth", sims["truth"], "--cases", *sims["cases"], "--rigid", sims["rigid"],
                         "--ranking-table", sims["ranking"], "--static-table", sims["static"],
                         "--out-dir", str(d)]) == 0
    m = _manifest(d)
    assert m["scene"] == "thesis" and m["rigid"].endswith("rigid.h5") and m["notes"] == []
    rates = [f for f in m["figures"] if f["kind"] == "rates"]
    assert sorted(f["model"] for f in rates) == sorted(CASES)
    for f in m["figures"]:
        assert (d / f["pdf"]).read_bytes()[:5] == b"%PDF-" and "png" not in f and f["caption"]
    for f in rates:
        assert f["baseline"] == "rigid" and "rigid model" in f["caption"]
        # synthetic rates: E = a^2 exactly; the rigid case has a = 0.2 on every rate
        assert np.allclose(list(f["E_rigid"].values()), 0.04, rtol=1e-9)
        assert f["zoom_windows_ms"][0] == pytest.approx([0.0, 2.0])
        assert f["zoom_windows_ms"][1] == pytest.approx([1e3 * T_END - 2.0, 1e3 * T_END])
        assert f["envelope"] is False and "first 2 ms" in f["caption"]
    err = {f["id"]: f for f in m["figures"] if f["kind"] == "error"}
    assert err["error_ranking"]["baseline"] == "rigid" and err["error_static"]["baseline"] == "rigid"
    assert err["error_load_cases"]["controls"] == ["rigid", "no static"]
    assert "without a static mode (freq-10)" in err["error_load_cases"]["caption"]


def test_rigid_among_cases_is_the_baseline(sims, tmp_path):
    assert figures.main(["--truth", sims["truth"], "--cases", sims["cases"][0], sims["rigid"],
                         "--out-dir", str(tmp_path)]) == 0
    rates = {f["model"]: f for f in _manifest(tmp_path)["figures"]}
    assert rates[CASES[0]]["baseline"] == "rigid"
    assert rates["rigid"]["baseline"] is None and "rigid model itself" in rates["rigid"]["caption"]


def test_missing_rigid_is_skipped_and_stated(sims, tmp_path):
    assert figures.main(["--truth", sims["truth"], "--cases", sims["cases"][0], "--rigid",
                         str(tmp_path / "absent.h5"), "--out-dir", str(tmp_path)]) == 0
    m = _manifest(tmp_path)
    assert m["rigid"] is None and any("missing" in n for n in m["notes"])
    (f,) = m["figures"]
    assert f["baseline"] is None and f["E_rigid"] is None and "not available" in f["caption"]


def _pixels(fig):
    """fig drawn on its Agg canvas: (H, W, 4) uint8."""
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba()).copy()


def test_reused_rate_panels_draw_as_a_fresh_figure(sims, tmp_path):
    """A case drawn on panels that showed other cases first (the rate figures of a run after the
    first) looks pixel for pixel as on panels of its own: no data, limit, unit, baseline, title
    height or layout is left over."""
    truth, rigid = read_sim(sims["truth"]), read_sim(sims["rigid"])
    first, second = (read_sim(p) for p in sims["cases"])
    assert not np.allclose(first["gamma_dot"], second["gamma_dot"])
    long_title = "Truth vs " + "a title long enough to take two lines " * 4
    draws = [(first, rigid, "Truth vs x"), (second, None, long_title), (first, rigid, "Truth vs x")]
    reused = {}
    try:
        for n, (case, base, title) in enumerate(draws):
            out = figures.plot_rates(truth, case, str(tmp_path / f"r{n}"), title, rigid=base, panels=reused)
            assert os.path.exists(out["pdf"]) and (out["E_rigid"] is None) == (base is None)
            (panels,) = reused.values()
            shown = [t.get_text() for leg in panels.top.legends if leg.get_visible() for t in leg.get_texts()]
            assert ("rigid model" in shown) == (base is not None) and len(shown) == 3 + (base is not None)
            lines = 2 if title == long_title else 1                  # the heading row fits the title
            assert panels.grid.get_height_ratios()[0] == pytest.approx(0.15 + 0.11 * lines)
            if n == 0:
                continue
            fresh = {}
            figures.plot_rates(truth, case, str(tmp_path / f"f{n}"), title, rigid=base, panels=fresh)
            (r,), (f,) = reused.values(), fresh.values()
            with figures.pyplot().rc_context(figures.RATE_RC):
                assert np.array_equal(_pixels(r.fig), _pixels(f.fig)), n
            f.close()
            for ax in r.fig.get_axes():                      # every curve inside its panel
                lo, hi = ax.get_ylim()
                for line in ax.get_lines():
                    y = np.asarray(line.get_ydata(), float)
                    assert y.size == 0 or lo < y.min() <= y.max() < hi
    finally:
        for p in reused.values():
            p.close()


def test_rate_panels_layout_ignores_no_frame(sims, tmp_path):
    """The rate panels' layout leaves their frames (spines) out: it places every panel where the
    layout with the frames measured does (to rounding)."""
    truth, rigid = read_sim(sims["truth"]), read_sim(sims["rigid"])
    panels = {}
    figures.plot_rates(truth, read_sim(sims["cases"][0]), str(tmp_path / "r"), "Truth vs x", rigid=rigid,
                       panels=panels)
    (p,) = panels.values()
    try:
        without = [ax.get_position().bounds for ax in p.fig.get_axes()]
        assert not any(s.get_in_layout() for ax in p.fig.get_axes() for s in ax.spines.values())
        for ax in p.fig.get_axes():
            for spine in ax.spines.values():
                spine.set_in_layout(True)
        with figures.pyplot().rc_context(figures.RATE_RC):
            for ax, start in p.start:                       # from the same start, frames measured
                ax.set_position(start)
                ax.set_in_layout(True)
            figures.solve_layout(p.fig, p.engine)
        measured = [ax.get_position().bounds for ax in p.fig.get_axes()]
        assert np.allclose(measured, without, rtol=0.0, atol=1e-12)     # up to rounding
    finally:
        p.close()


def _panels_figure():
    plt = figures.pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(7.0, 5.6), constrained_layout=True)
    for k, ax in enumerate(axes.flat):
        ax.plot([0.0, 10.0 ** k], [0.0, 3e-4 * 10.0 ** k])
    axes[0, 0].set_title("a title")
    axes[0, 0].set_ylabel("a y label")
    axes[1, 1].set_xlabel("an x label")
    return fig


def test_layout_solved_as_the_pdf_draws_it(tmp_path):
    """fix_layout places the axes exactly where savefig's own layout pass for the PDF would, and
    leaves the figure without a layout engine (so savefig draws it once)."""
    plt = figures.pyplot()
    own, fixed = _panels_figure(), _panels_figure()
    own.savefig(tmp_path / "own.pdf")
    figures.fix_layout(fixed)
    assert own.get_layout_engine() is not None and fixed.get_layout_engine() is None
    for a, b in zip(own.get_axes(), fixed.get_axes()):
        assert np.allclose(a.get_position().bounds, b.get_position().bounds, rtol=0.0, atol=1e-12)
    plt.close(own)
    plt.close(fixed)


def test_pinning_empty_decorations_changes_no_pixel():
    """Empty titles and axis labels pinned in place: the figure draws the same (the non-empty
    ones still move clear of the tick labels)."""
    plt = figures.pyplot()
    free, pinned = _panels_figure(), _panels_figure()
    figures.pin_empty_decorations(pinned)
    for fig in (free, pinned):
        figures.solve_layout(fig, fig.get_layout_engine())
        fig.set_layout_engine(None)
    assert pinned.get_axes()[3].get_title() == "" and pinned.get_axes()[0].get_title() == "a title"
    assert np.array_equal(_pixels(free), _pixels(pinned))
    plt.close(free)
    plt.close(pinned)


def test_font_subsets_made_once_per_font_and_grown(monkeypatch, tmp_path):
    """Within glyph_subsets_cached the PDF backend subsets a font file again only for a glyph
    no earlier subset holds, and then keeps every earlier one; matplotlib's own function is back
    after it.  (matplotlib >= 3.11 subsets by glyph index: the characters of the text are mapped to
    the font's glyphs here with fontTools.)"""
    from fontTools.ttLib import TTFont
    from matplotlib import font_manager
    from matplotlib.backends import _backend_pdf_ps as pdf_ps
    real, calls = pdf_ps.get_glyphs_subset, []

    def spy(fontfile, glyphs):
        calls.append(set(glyphs))
        return real(fontfile, glyphs)

    monkeypatch.setattr(pdf_ps, "get_glyphs_subset", spy)
    monkeypatch.setattr(figures, "_SUBSETS", {})
    plt = figures.pyplot()
    with plt.rc_context(figures.STYLE):
        path = font_manager.findfont(font_manager.FontProperties())
    with TTFont(path, lazy=True) as font:
        cmap = font.getBestCmap()
        gids = {c: font.getGlyphID(cmap[ord(c)]) for c in "\u0436\u0449" + figures.SUBSET_BASE if ord(c) in cmap}

    def glyphs(chars):
        return {gids[c] for c in chars if c in gids}

    def pdf(text):
        with plt.rc_context(figures.STYLE), figures.glyph_subsets_cached():
            fig = plt.figure(figsize=(2, 1))
            fig.text(0.1, 0.5, text)
            fig.savefig(tmp_path / "t.pdf")
            plt.close(fig)
        return (tmp_path / "t.pdf").read_bytes()

    assert pdf("abc 12")[:5] == b"%PDF-" and len(calls) == 1
    assert len(glyphs(figures.SUBSET_BASE)) >= 95 and glyphs(figures.SUBSET_BASE) <= calls[0]
    pdf("cab 21.5")
    pdf("Xyz \u2212\u00b5")
    assert len(calls) == 1                                   # hits: every ASCII glyph is in the base
    pdf("\u0436\u0449")                                    # Cyrillic: outside the base
    assert len(calls) == 2 and glyphs("\u0436\u0449" + figures.SUBSET_BASE) <= calls[1]  # grown, kept
    assert pdf_ps.get_glyphs_subset is spy


def _column_extremes(t, y, bins):
    """(min (bins,), max (bins,)) of y over each of ``bins`` equal columns of [t[0], t[-1]], by a
    plain loop over the samples (the envelope's definition, written independently of it)."""
    lo, hi = np.full(bins, np.inf), np.full(bins, -np.inf)
    for ti, yi in zip(t, y):
        c = min(int((ti - t[0]) / (t[-1] - t[0]) * bins), bins - 1)
        lo[c], hi[c] = min(lo[c], yi), max(hi[c], yi)
    return lo, hi


@pytest.mark.parametrize("kind", ["noise", "walk", "ties", "uneven"])
def test_envelope_keeps_each_columns_min_and_max_exactly(kind):
    """Every column's smallest and largest sample are drawn, exactly, and nothing else: the
    envelope's points are samples of y (same t, same y), in time order, and per column their
    min and max are the column's."""
    rng = np.random.default_rng(1)
    t = np.linspace(0.0, 1.0, 20_001)
    if kind == "uneven":
        t = np.sort(rng.uniform(0.0, 1.0, 20_001))
    y = {"walk": np.cumsum(rng.normal(size=t.size)),
         "ties": np.round(rng.normal(size=t.size), 0)}.get(kind, rng.normal(size=t.size))
    y[[17, 10_000, 20_000]] = [40.0, -55.0, 30.0]          # isolated spikes
    bins = 500
    te, ye = figures.envelope(t, y, bins=bins)
    assert te.size <= 2 * bins and np.all(np.diff(te) > 0)
    at = np.searchsorted(t, te)
    assert np.array_equal(t[at], te) and np.array_equal(y[at], ye)   # drawn points are samples
    lo, hi = _column_extremes(t, y, bins)
    col = np.minimum(((te - t[0]) / (t[-1] - t[0]) * bins).astype(int), bins - 1)
    drawn_lo, drawn_hi = np.full(bins, np.inf), np.full(bins, -np.inf)
    np.minimum.at(drawn_lo, col, ye)
    np.maximum.at(drawn_hi, col, ye)
    assert np.array_equal(drawn_lo, lo) and np.array_equal(drawn_hi, hi)
    assert {40.0, -55.0, 30.0} <= set(ye.tolist())


def test_envelope_short_or_windowed_or_not_finite():
    t = np.linspace(0.0, 1.0, 100_001)
    y = np.sin(40 * t)
    ts, ys = figures.envelope(t[:100], y[:100], bins=500)    # short: unchanged
    assert np.array_equal(ys, y[:100]) and np.array_equal(ts, t[:100])
    tw, _ = figures.envelope(t, y, 0.25, 0.5, bins=100)
    assert tw[0] >= 0.25 and tw[-1] <= 0.5 and tw.size <= 200
    y[5] = np.nan                                            # not finite: every sample drawn
    tn, yn = figures.envelope(t, y, bins=100)
    assert tn.size == t.size and np.isnan(yn[5])


def test_long_run_is_drawn_as_envelope(tmp_path):
    t = np.linspace(0.0, 1.0, 100_001)
    r = truth_rates(t)
    truth = write_sim(tmp_path / "truth.h5", "truth", t, r, scene="long", n_modes=[100] * 4)
    case = write_sim(tmp_path / "freq-10.h5", "freq-10", t, 1.1 * r, scene="long")
    assert figures.main(["--truth", truth, "--cases", case, "--out-dir", str(tmp_path / "f")]) == 0
    (f,) = _manifest(tmp_path / "f")["figures"]
    assert f["envelope"] is True and f["scene"] == "long" and "envelopes" in f["caption"]
    assert f["zoom_windows_ms"][1] == pytest.approx([998.0, 1000.0])


def test_select_modes():
    assert mode_shapes.select_modes(100) == [(0, "lowest"), (1, "lowest"), (2, "lowest"), (3, "lowest")]
    sel = mode_shapes.select_modes(100, [1, 2, 0, 15, 7, 20], first=4, ranked=2)
    assert sel[4:] == [(15, "XMX rank 4"), (7, "XMX rank 5")]


def _ring_body(tmp_path):
    """A shell ring (x-z plane) of 48 x 2 quads split into triangles, 6 DOF per node."""
    a = np.linspace(0, 2 * np.pi, 48, endpoint=False)
    pts = np.array([[np.cos(q), y, np.sin(q)] for y in (-0.2, 0.2) for q in a])
    n = len(a)
    tris = [c for i in range(n) for c in ([i, (i + 1) % n, n + i], [(i + 1) % n, n + (i + 1) % n, n + i])]
    meshio.write(tmp_path / "ring.msh", meshio.Mesh(pts, [("triangle", np.array(tris))]), file_format="gmsh22")
    coords = np.repeat(pts, 6, axis=0)
    comp = np.tile(np.arange(6), len(pts))
    rng = np.random.default_rng(0)
    k = np.arange(1, 9)
    q = np.arctan2(coords[:, 2], coords[:, 0])
    modes = np.cos(np.outer(q, k)) * (comp < 3)[:, None] + 1e-3 * rng.normal(size=(len(q), 8))
    body = tmp_path / "body2.h5"
    with h5py.File(body, "w") as f:
        f["modes"], f["dof_coords"], f["dof_component"] = modes, coords, comp
        f["frequencies_hz"] = 1000.0 * k
        f["bearing_points"] = [[1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1]]
        f.attrs["name"], f.attrs["body"] = "outer_gimbal", 2
        f.attrs["config_hash"] = project_body_hash(2)       # made from the configuration in use
    red = tmp_path / "red2.h5"
    with h5py.File(red, "w") as f:
        f.attrs["body"], f.attrs["config_hash"] = 2, project_body_hash(2)
        f["rank_xmx"] = [1, 2, 0, 6, 5, 3, 4, 7]
        s = f.create_group("static_modes")
        s.attrs["load_cases"] = json.dumps(["output_motor_fz", "input_motor_my"])
        for j, case in enumerate(("output_motor_fz", "input_motor_my")):
            c = s.create_group(case)
            c["mode"] = modes[:, 5 + j]
            c.attrs["frequency_hz"], c.attrs["residual_fraction"] = 3e4, 0.01
    return body, red


def test_mode_shape_figures_and_captions(tmp_path):
    body, red = _ring_body(tmp_path)
    out = tmp_path / "fig"
    assert mode_shapes.main(["--body-file", str(body), "--mesh", str(tmp_path / "ring.msh"),
                             "--png", str(out / "m.png"), "--vtu", str(tmp_path / "m.vtu"),
                             "--reduction", str(red), "--static-png", str(out / "s.png"),
                             "--manifest", str(out / "m.json")]) == 0
    m = json.loads((out / "m.json").read_text())["figures"]
    assert [f["kind"] for f in m] == ["mode_shapes", "static_modes"]
    assert m[0]["modes"] == [1, 2, 3, 4, 7, 6] and m[1]["modes"] == ["output_motor_fz", "input_motor_my"]
    for f in m:
        assert (out / f["png"]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and "bearing" in f["caption"]
    import matplotlib.image as mpimg
    h, w = mpimg.imread(out / "m.png").shape[:2]
    assert w == 7 * mode_shapes.PNG_DPI                        # A4 text width at print resolution


def _tick_value(text):
    """A tick label's number: "0.005", "$10^{-5}$" or "$2\\times10^{-5}$"."""
    if not text.startswith("$"):
        return float(text)
    body = text.strip("$")
    mantissa, _, power = body.rpartition("10^")
    return float(mantissa.replace("\\times", "") or 1.0) * 10.0 ** int(power.strip("{}"))


@pytest.mark.parametrize("low, high, at_least", [(3.5e-3, 0.08, 4), (1.1e-3, 2.9e-3, 4), (1.7e-7, 2.5e-5, 6)])
def test_log_axis_labels_several_values_over_a_short_span(low, high, at_least):
    """Errors spanning 1.4 decades (thesis) or under one (long) get several labelled y ticks, not a
    lone "10^-2"; the labels are the tick values to three digits (no 0.00125 shown as 0.0013)."""
    plt = figures.pyplot()
    fig, ax = plt.subplots()
    ax.semilogy([0, 1], [low, high])
    figures.log_ticks_for(ax, [low, high], plt)
    fig.canvas.draw()
    ymin, ymax = ax.get_ylim()
    shown = [(tick, label.get_text()) for tick, label in zip(ax.get_yticks(), ax.get_yticklabels())
             if ymin <= tick <= ymax and label.get_text()]
    plt.close(fig)
    assert len(shown) >= at_least, shown
    assert all(_tick_value(text) == pytest.approx(tick, rel=5e-3) for tick, text in shown), shown
