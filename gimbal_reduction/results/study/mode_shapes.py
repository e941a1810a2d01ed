"""Mode shapes for print: the lowest and the top XMX-ranked vibration modes of a body, its
static correction modes, and a VTU file of all modes for ParaView, each point-data array
named with its mode number and frequency (``mode_007_1234.5Hz``), the frequencies also as the
FieldData array ``frequencies_hz`` (thesis Figs 2-9, 2-10).

    python -m gimbal_reduction.results.study.mode_shapes --body-file results/modes/body2.h5 \\
        --mesh results/mesh/body2.msh --png results/figures/mode_shapes_body2.png \\
        --vtu results/modes/shapes/body2.vtu \\
        [--reduction results/reduction/body2.h5 \\
         --static-png results/figures/static_modes_body2.png] \\
        [--lowest 4] [--ranked 2] [--manifest results/figures/mode_shapes_body2.json]

``--png``: the ``--lowest`` lowest modes and, with ``--reduction``, the ``--ranked``
best XMX-ranked modes not among them; 3 panels per row, 7.0 in wide (A4 text
width; text >= 7 pt when printed at 6.3 in), 300 dpi.  Each panel: the deformed
surface coloured by |u| / max |u| (one colour bar), the undeformed outline in
grey, the bearings as labelled dots, mode number, frequency and why it was
chosen in the title.  ``--static-png`` (needs ``--reduction``): the static
correction modes (``static_modes/<load case>/mode`` of the reduction file), one
panel per load case, the loaded bearing in red.  ``--manifest``: JSON
``{"figures": [{id, kind, png, caption, body, modes}]}`` (paths relative to it).
"""
from __future__ import annotations

import argparse
import json
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import meshio  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

from gimbal_reduction.reduction.static_modes import DEFAULT_LOAD_CASE  # noqa: E402
from gimbal_reduction.results import vtk  # noqa: E402
from gimbal_reduction.solver import bodyconfig  # noqa: E402
from gimbal_reduction.solver.bodydata import BEARING_NAMES  # noqa: E402
from gimbal_reduction.workflow import cli  # noqa: E402
from gimbal_reduction.workflow.provenance import (provenance, read_h5_checked, savefig, write_json,  # noqa: E402
                                 write_sidecar)

FONT = 8                  # pt at 7.0 in; >= 7 pt when the figure is printed at 6.3 in
FIG_WIDTH_IN = 7.0
PANEL_IN = 2.45           # height of a row of 3-D panels (3 per row)
PANEL_STATIC_IN = 1.95    # 4 per row
PNG_DPI = 300
SCALE_TO = 0.10           # largest displacement drawn as 10 % of the body's largest extent
CMAP = plt.cm.viridis
RC = {"font.size": FONT, "pdf.fonttype": 42}
BEARING_ABBREV = {"input_motor": "IM", "input_resolver": "IR", "output_motor": "OM",
                  "output_resolver": "OR"}


def linear_mesh(mesh: meshio.Mesh) -> meshio.Mesh:
    """The mesh's vertices and straight cells (second-order nodes dropped), renumbered.

    Vertices are DOF points of every Lagrange space, midside nodes need not be.
    """
    kinds = {"tetra10": ("tetra", 4), "tetra": ("tetra", 4), "triangle6": ("triangle", 3),
             "triangle": ("triangle", 3)}
    top = "tetra" if any(c.type.startswith("tetra") for c in mesh.cells) else "triangle"
    blocks = [c.data[:, : kinds[c.type][1]] for c in mesh.cells if c.type in kinds and kinds[c.type][0] == top]
    cells = np.vstack(blocks)
    used, inverse = np.unique(cells, return_inverse=True)
    return meshio.Mesh(mesh.points[used], [(top, inverse.reshape(cells.shape))])


def surface_triangles(mesh: meshio.Mesh) -> np.ndarray:
    """(n, 3) vertex indices of the visible triangles: shell cells, or a solid's boundary faces."""
    tets = [c.data for c in mesh.cells if c.type == "tetra"]
    if not tets:
        return np.vstack([c.data for c in mesh.cells if c.type == "triangle"])
    tets = np.vstack(tets)
    faces = np.vstack([tets[:, [0, 1, 2]], tets[:, [0, 1, 3]], tets[:, [0, 2, 3]], tets[:, [1, 2, 3]]])
    key = np.sort(faces, axis=1)
    _, index, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    return faces[index[counts == 1]]


def vertex_displacements(points: np.ndarray, dof_coords: np.ndarray, dof_component: np.ndarray,
                         modes: np.ndarray) -> np.ndarray:
    """(n_modes, n_points, 3) translations of the mode shapes at the mesh vertices."""
    rows = {}
    for c in range(3):
        sel = np.flatnonzero(dof_component == c)
        tree = cKDTree(dof_coords[sel])
        dist, idx = tree.query(points)
        if dist.max() > 1e-8:
            raise ValueError("mesh vertices do not match the body file's DOF coordinates (stale mesh?)")
        rows[c] = sel[idx]
    return np.stack([modes[rows[c]].T for c in range(3)], axis=-1)


def feature_edges(points: np.ndarray, triangles: np.ndarray, angle_deg: float = 35.0) -> np.ndarray:
    """(m, 2) vertex pairs of the outline: free edges (shell rims) and edges whose two faces meet
    at more than ``angle_deg`` (a solid's corners)."""
    edges = np.vstack([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    face = np.tile(np.arange(len(triangles)), 3)
    key = np.sort(edges, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))
    key, face = key[order], face[order]
    new = np.r_[True, np.any(key[1:] != key[:-1], axis=1)]
    start = np.flatnonzero(new)
    counts = np.diff(np.r_[start, len(key)])
    n = np.cross(points[triangles[:, 1]] - points[triangles[:, 0]],
                 points[triangles[:, 2]] - points[triangles[:, 0]])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    keep = counts == 1
    two = counts == 2
    cosang = np.abs(np.einsum("ij,ij->i", n[face[start[two]]], n[face[start[two] + 1]]))
    keep[np.flatnonzero(two)[cosang < np.cos(np.radians(angle_deg))]] = True
    return key[start[keep]]


def select_modes(n_modes: int, rank_xmx=None, first: int = 4, ranked: int = 2) -> list[tuple[int, str]]:
    """(mode index, why chosen) of the plotted modes: the ``first`` lowest, then the
    ``ranked`` highest XMX-ranked modes not already among them (``rank_xmx``: mode
    indices, best first; None: only the lowest)."""
    chosen = [(i, "lowest") for i in range(min(first, n_modes))]
    if rank_xmx is not None:
        rank = [int(i) for i in rank_xmx]
        for i in rank:
            if sum(r != "lowest" for _, r in chosen) >= ranked:
                break
            if all(i != c for c, _ in chosen):
                chosen.append((i, f"XMX rank {rank.index(i) + 1}"))
    return chosen


def _draw_shape(ax, points, triangles, outline, d, bearings, size, loaded=None, scale_to=SCALE_TO):
    """One deformed shape on a 3-D axes: faces coloured by |u| / max|u| (viridis), the undeformed
    outline in grey, bearing locations as black markers (the loaded one red)."""
    amp = np.linalg.norm(d, axis=1)
    peak = amp.max() if amp.max() > 0 else 1.0
    deformed = points + (scale_to * size / peak) * d
    tri_mag = amp[triangles].mean(axis=1) / peak
    centre = 0.5 * (points.max(axis=0) + points.min(axis=0))
    ax.computed_zorder = False
    ax.add_collection3d(Line3DCollection(points[outline], colors="0.55", linewidths=0.5, zorder=1))
    ax.add_collection3d(Poly3DCollection(deformed[triangles], facecolors=CMAP(tri_mag),
                                         edgecolors=CMAP(tri_mag), linewidths=0.15, zorder=2))
    for k, name in enumerate(BEARING_NAMES):
        p = bearings[k]
        if not np.all(np.isfinite(p)):
            continue
        red = loaded is not None and name == loaded
        ax.scatter(*p, marker="o", s=22, color="tab:red" if red else "black", edgecolors="white",
                   linewidths=0.6, depthshade=False, zorder=5)
        off = p - centre
        off = off / max(np.linalg.norm(off), 1e-12)
        ax.text(*(p + 0.085 * size * off), BEARING_ABBREV[name], fontsize=FONT, zorder=6,
                color="tab:red" if red else "black", ha="center", va="center")
    lim = 0.5 * size
    ax.set(xlim=(centre[0] - lim, centre[0] + lim), ylim=(centre[1] - lim, centre[1] + lim),
           zlim=(centre[2] - lim, centre[2] + lim))
    ax.set_box_aspect((1, 1, 1), zoom=1.45)
    ax.view_init(elev=22, azim=-55)
    ax.set_axis_off()
    _triad(ax, centre + lim * np.array([-1.05, 0.0, -1.05]), 0.18 * lim)


def _triad(ax, origin, length):
    for k, name in enumerate("xyz"):
        e = np.eye(3)[k] * length
        ax.plot(*np.c_[origin, origin + e], color="0.3", lw=0.8, zorder=4)
        ax.text(*(origin + 1.35 * e), name, fontsize=FONT, color="0.3", ha="center", va="center",
                zorder=4)


def _grid_figure(n_panels, ncols, panel_in):
    nrows = int(np.ceil(n_panels / ncols))
    height = nrows * panel_in + 1.2
    fig = plt.figure(figsize=(FIG_WIDTH_IN, height))
    gs = fig.add_gridspec(nrows + 1, ncols, height_ratios=[panel_in] * nrows + [0.6],
                          left=0.01, right=0.99, top=1 - 0.55 / height,
                          bottom=0.01, hspace=0.18, wspace=0.02)
    axes = [fig.add_subplot(gs[i // ncols, i % ncols], projection="3d") for i in range(n_panels)]
    return fig, gs, nrows, axes


def _footer(fig, gs, nrows, bearings, loaded_note=False):
    """Colour bar and the bearing key in the figure's last row (outside every panel)."""
    sub = gs[nrows, :].subgridspec(1, 2, width_ratios=[1, 1.25], wspace=0.15)
    cax = fig.add_subplot(sub[0, 0])
    pos = cax.get_position()
    cax.set_position([pos.x0 + 0.03, pos.y0 + 0.62 * pos.height, pos.width - 0.03, 0.25 * pos.height])
    sm = plt.cm.ScalarMappable(norm=matplotlib.colors.Normalize(0, 1), cmap=CMAP)
    cb = fig.colorbar(sm, cax=cax, orientation="horizontal")
    cb.set_label("displacement magnitude |u| / max |u| (per panel)", fontsize=FONT)
    cb.ax.tick_params(labelsize=FONT)
    kax = fig.add_subplot(sub[0, 1])
    kax.set_axis_off()
    present = [BEARING_ABBREV[n] + " " + n.replace("_", " ") for k, n in enumerate(BEARING_NAMES)
               if np.all(np.isfinite(bearings[k]))]
    text = "Bearings (black dots): " + ", ".join(present) + ".\nGrey: undeformed outline."
    if loaded_note:
        text += " Red dot: the loaded bearing."
    kax.text(0.0, 0.5, text, fontsize=FONT, va="center", ha="left", transform=kax.transAxes, wrap=True)


def plot_modes(points, triangles, displacements, frequencies, title, path, selection, bearings, record=None):
    """PNG (PNG_DPI) of the selected mode shapes (``select_modes``), 3 per row at A4 text width;
    record: its provenance (``gimbal_reduction.workflow.provenance.savefig``)."""
    size = np.ptp(points, axis=0).max()
    outline = feature_edges(points, triangles)
    with plt.rc_context(RC):
        fig, gs, nrows, axes = _grid_figure(len(selection), 3, PANEL_IN)
        for ax, (i, why) in zip(axes, selection):
            _draw_shape(ax, points, triangles, outline, displacements[i], bearings, size)
            ax.set_title(f"mode {i + 1}: {frequencies[i]:,.0f} Hz ({why})", fontsize=FONT + 1, pad=0)
        fig.suptitle(f"{title}: vibration mode shapes (displacement scaled to "
                     f"{SCALE_TO:.0%} of the body size)", fontsize=FONT + 1)
        _footer(fig, gs, nrows, bearings)
        savefig(fig, path, record, format="png", dpi=PNG_DPI)
        plt.close(fig)


def plot_static_modes(points, triangles, statics, title, path, bearings, default=None, record=None):
    """PNG of the static correction modes, one panel per load case (record: its provenance).

    statics: list of dicts (``load_case``, ``disp`` (n_points, 3), ``frequency_hz``,
    ``residual_fraction``)."""
    size = np.ptp(points, axis=0).max()
    outline = feature_edges(points, triangles)
    with plt.rc_context(RC):
        fig, gs, nrows, axes = _grid_figure(len(statics), 4 if len(statics) > 3 else 3,
                                            PANEL_STATIC_IN if len(statics) > 3 else PANEL_IN)
        for ax, s in zip(axes, statics):
            bearing = s["load_case"].rsplit("_", 1)[0]
            _draw_shape(ax, points, triangles, outline, s["disp"], bearings, size, loaded=bearing)
            star = " (default)" if s["load_case"] == default else ""
            ax.set_title(f"{_load_label(s['load_case'])}{star}\n"
                         f"{s['frequency_hz'] / 1e3:.1f} kHz, residual {s['residual_fraction']:.2g}",
                         fontsize=FONT, pad=0)
        fig.suptitle(f"{title}: static correction modes, one per load case (displacement scaled to "
                     f"{SCALE_TO:.0%} of the body size)", fontsize=FONT + 1)
        _footer(fig, gs, nrows, bearings, loaded_note=True)
        savefig(fig, path, record, format="png", dpi=PNG_DPI)
        plt.close(fig)


def _load_label(case):
    bearing, comp = case.rsplit("_", 1)
    kind = {"f": "force", "m": "moment"}[comp[0]]
    return f"{BEARING_ABBREV[bearing]}: {comp[1]}-{kind}"


def mode_array_name(index, frequency_hz):
    """Point-data name of mode ``index`` (0-based): ``mode_007_1234.5Hz`` (number and frequency,
    so ParaView's array menus list the frequencies)."""
    return f"mode_{index + 1:03d}_{frequency_hz:.1f}Hz"


def write_vtu(points, cells, displacements, frequencies, path, record=None):
    """All mode shapes as point vectors in one VTU file (ParaView: Warp By Vector), each named with
    its number and frequency (``mode_array_name``); the exact frequencies [Hz] as the FieldData
    array ``frequencies_hz`` (ParaView: Information panel, spreadsheet view "Field Data"), units
    in an XML comment (``gimbal_reduction.results.vtk.write_vtu``); its provenance (record, default
    ``provenance()``) in a sidecar ``{path}.provenance.json``."""
    frequencies = np.asarray(frequencies, float)
    data = {mode_array_name(i, f): displacements[i] for i, f in enumerate(frequencies)}
    mesh = meshio.Mesh(points, cells, point_data=data)
    vtk.write_vtu(path, mesh, {"frequencies_hz": frequencies,
                               "mode_number": np.arange(1, frequencies.size + 1)},
                  comment=f"Mode shapes: {frequencies.size} mass-normalised supported modes of the body "
                          f"(point vectors mode_NNN_<frequency>Hz, in per sqrt(lbf s^2/in)); points in "
                          f"inches (in), body axes; FieldData frequencies_hz [Hz], mode_number.")
    write_sidecar(path, record)


def read_statics(path):
    """Static correction modes of a reduction file: [{load_case, mode (ndof,), frequency_hz,
    residual_fraction}] in the file's load-case order."""
    with h5py.File(path, "r") as f:
        g = f["static_modes"]
        order = json.loads(g.attrs.get("load_cases", "[]")) or sorted(g)
        return [{"load_case": c, "mode": g[c]["mode"][()],
                 "frequency_hz": float(g[c].attrs["frequency_hz"]),
                 "residual_fraction": float(g[c].attrs["residual_fraction"]),
                 "n_kept": int(g[c].attrs.get("n_kept", g.attrs.get("n_kept", 0))),
                 "kept_ranking": str(g.attrs.get("kept_ranking", ""))} for c in order if c in g]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gimbal_reduction.results.study.mode_shapes",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("--body-file", required=True, help="results/modes/body{n}.h5")
    parser.add_argument("--mesh", required=True, help="results/mesh/body{n}.msh")
    parser.add_argument("--png", required=True, help="vibration mode shapes (PNG)")
    parser.add_argument("--vtu", required=True, help="every mode as point vectors (ParaView)")
    parser.add_argument("--reduction", help="results/reduction/body{n}.h5: XMX ranking and static modes")
    parser.add_argument("--static-png", help="static correction modes (PNG; needs --reduction)")
    parser.add_argument("--lowest", type=int, default=4, help="lowest modes shown (default 4)")
    parser.add_argument("--ranked", type=int, default=2,
                        help="best XMX-ranked modes shown besides the lowest (default 2; needs --reduction)")
    parser.add_argument("--manifest", help="JSON list of the figures with captions")
    cli.add_config_option(parser, "a body or reduction file of another configuration is refused")
    args = parser.parse_args(argv)
    if args.static_png and not args.reduction:
        parser.error("--static-png needs --reduction")
    try:
        bodyconfig.check_files([args.body_file] + ([args.reduction] if args.reduction else []), args.config)
        with read_h5_checked(args.body_file, ("modes", "dof_coords", "dof_component", "frequencies_hz",
                                              "bearing_points")) as h5:
            modes, coords = h5["modes"][()], h5["dof_coords"][()]
            component, freqs, name = h5["dof_component"][()], h5["frequencies_hz"][()], h5.attrs["name"]
            bearings, body = h5["bearing_points"][()], int(h5.attrs.get("body", 0))
        rank_xmx, statics = None, []
        if args.reduction:
            with read_h5_checked(args.reduction, ("rank_xmx", "static_modes")) as h5:
                rank_xmx = h5["rank_xmx"][()]
            statics = read_statics(args.reduction) if args.static_png else []
        mesh = linear_mesh(meshio.read(args.mesh))
        disp = vertex_displacements(mesh.points, coords, component, modes)
        if statics:
            sdisp = vertex_displacements(mesh.points, coords, component,
                                         np.stack([s["mode"] for s in statics], axis=1))
            for s, d in zip(statics, sdisp):
                s["disp"] = d
    except (ValueError, FileNotFoundError, KeyError, OSError) as exc:
        print(f"gimbal_reduction.results.study.mode_shapes: error: {exc}", file=sys.stderr)
        return 1
    triangles = surface_triangles(mesh)
    record = provenance(sources=[args.body_file] + ([args.reduction] if args.reduction else []))
    label = str(name).replace("_", " ")
    selection = select_modes(len(freqs), rank_xmx, args.lowest, args.ranked if rank_xmx is not None else 0)
    plot_modes(mesh.points, triangles, disp, freqs, label.capitalize(), args.png, selection, bearings, record)
    shown = ", ".join(f"{i + 1}" for i, _ in selection)
    entries = [{"id": f"mode_shapes_body{body}", "kind": "mode_shapes", "png": args.png, "body": body,
                "modes": [i + 1 for i, _ in selection],
                "caption": f"Vibration mode shapes of the {label} (body {body}), modes {shown}: the "
                           f"{min(args.lowest, len(freqs))} lowest"
                           + (f" and the {args.ranked} best XMX-ranked modes not among them"
                              if rank_xmx is not None and args.ranked else "")
                           + f". Deformed surface coloured by the displacement magnitude relative to the "
                             f"mode's largest, largest displacement drawn as {SCALE_TO:.0%} of the body "
                             f"size; grey: undeformed outline; dots: bearings (IM/IR input motor/"
                             f"resolver, OM/OR output motor/resolver)."}]
    if args.static_png and statics:
        n_kept, ranking = statics[0]["n_kept"], statics[0]["kept_ranking"]
        kept = (f", mass-orthogonal to the {n_kept} kept vibration modes"
                + (f" ({ranking} ranking)" if ranking else "") if n_kept else "")
        plot_static_modes(mesh.points, triangles, statics, label.capitalize(), args.static_png, bearings,
                          DEFAULT_LOAD_CASE, record)
        entries.append({"id": f"static_modes_body{body}", "kind": "static_modes", "png": args.static_png,
                        "body": body, "modes": [s["load_case"] for s in statics],
                        "caption": f"Static correction modes of the {label} (body {body}): the residual "
                                   f"attachment mode of each load case (unit force or moment at the red "
                                   f"bearing{kept}), with its Rayleigh frequency and residual fraction"
                                   + (f"; {DEFAULT_LOAD_CASE} (marked default) is the load case of the "
                                      f"static-N models" if any(s["load_case"] == DEFAULT_LOAD_CASE
                                                                for s in statics) else "")
                                   + ". Colours and scaling as in the vibration mode shapes."})
    write_vtu(mesh.points, mesh.cells, disp, freqs, args.vtu, record)
    if args.manifest:
        base = os.path.dirname(os.path.abspath(args.manifest))
        for e in entries:
            e["png"] = os.path.relpath(os.path.abspath(e["png"]), base)
        write_json(args.manifest, {"description": "Mode-shape figures (gimbal_reduction/results/study/mode_shapes.py); "
                                                  "paths relative to this file.", "figures": entries}, record)
    return 0


if __name__ == "__main__":
    sys.exit(main())
