"""One frame of the deformed gimbal bodies (a VTU of ``gimbal_reduction.results.paraview``) as a PNG, headless.

    python -m gimbal_reduction.results.render --vtu results/paraview/thesis/freq-10/frame_0099.vtu --png frame.png \\
        [--color body|magnitude] [--elev 22] [--azim -55] [--title TEXT]
    python -m gimbal_reduction.results.render --pvd results/paraview/thesis/freq-10.pvd --frame -1 --png frame.png

Matplotlib's 3-D axes on the Agg backend (no display): the surface triangles, flat-shaded
by their facing to a light, coloured by body (outer, middle, inner gimbal, platform) or by the
displacement magnitude, on equal axes in the file's case axes [in].  Matplotlib sorts whole
triangles by depth (no z-buffer), so where surfaces interpenetrate the drawing can show small
artefacts; ParaView is the tool for inspection, this is a quick look and a check.
"""
from __future__ import annotations

import argparse
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import meshio  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

from gimbal_reduction.results import vtk  # noqa: E402
from gimbal_reduction.workflow.provenance import provenance, savefig  # noqa: E402

BODY_NAMES = {2: "outer gimbal", 3: "middle gimbal", 4: "inner gimbal", 5: "stable platform"}
BODY_COLORS = {2: "tab:blue", 3: "tab:orange", 4: "tab:green", 5: "tab:red"}
LIGHT = np.array([0.4, -0.5, 0.75]) / np.linalg.norm([0.4, -0.5, 0.75])
DPI = 150


def shade(points, triangles, light=LIGHT):
    """(m,) brightness 0.45..1 of each triangle: |cos| of the angle between its normal and the
    light (two-sided: shells have no outside)."""
    n = np.cross(points[triangles[:, 1]] - points[triangles[:, 0]],
                 points[triangles[:, 2]] - points[triangles[:, 0]])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    return 0.45 + 0.55 * np.abs(n @ light)


def face_colors(points, triangles, cell_body, magnitude=None):
    """(m, 4) RGBA per triangle: the body's colour (or viridis of the mean vertex magnitude
    relative to its largest), times the shading."""
    if magnitude is None:
        base = np.array([matplotlib.colors.to_rgba(BODY_COLORS.get(int(b), "0.5")) for b in cell_body])
    else:
        m = magnitude[triangles].mean(axis=1)
        base = plt.cm.viridis(m / m.max() if m.max() > 0 else m)
    rgb = base[:, :3] * shade(points, triangles)[:, None]
    return np.column_stack([rgb, base[:, 3]])


def render(points, triangles, cell_body, png, title="", magnitude=None, elev=22.0, azim=-55.0,
           record=None, size_in=6.0):
    """Draw the triangles and write the PNG (atomically, with its provenance ``record``)."""
    fig = plt.figure(figsize=(size_in, size_in))
    ax = fig.add_subplot(projection="3d")
    colors = face_colors(points, triangles, cell_body, magnitude)
    ax.add_collection3d(Poly3DCollection(points[triangles], facecolors=colors, edgecolors=colors,
                                         linewidths=0.05))
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre, half = 0.5 * (lo + hi), 0.5 * np.max(hi - lo)
    ax.set(xlim=(centre[0] - half, centre[0] + half), ylim=(centre[1] - half, centre[1] + half),
           zlim=(centre[2] - half, centre[2] + half), xlabel="X [in]", ylabel="Y [in]", zlabel="Z [in]")
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=elev, azim=azim)
    if magnitude is None:
        present = sorted({int(b) for b in cell_body})
        handles = [matplotlib.patches.Patch(color=BODY_COLORS.get(b, "0.5"), label=f"{b}: {BODY_NAMES.get(b, '')}")
                   for b in present]
        ax.legend(handles=handles, loc="upper left", fontsize=8, frameon=False)
    else:
        sm = plt.cm.ScalarMappable(norm=matplotlib.colors.Normalize(0, float(np.max(magnitude))),
                                   cmap=plt.cm.viridis)
        fig.colorbar(sm, ax=ax, shrink=0.6, pad=0.12, label="|displacement| [in] (true scale)")
    if title:
        ax.set_title(title, fontsize=9)
    savefig(fig, png, record, format="png", dpi=DPI)
    plt.close(fig)
    return png


def render_vtu(vtu, png, title="", color="body", elev=22.0, azim=-55.0):
    """Render a frame file of ``gimbal_reduction.results.paraview`` (its triangles, cell ``body_id``, point
    ``displacement_magnitude [in]``)."""
    mesh = meshio.read(str(vtu), file_format="vtu")
    tri = np.vstack([c.data for c in mesh.cells if c.type == "triangle"])
    cell_body = np.concatenate([d for c, d in zip(mesh.cells, mesh.cell_data["body_id"]) if c.type == "triangle"])
    magnitude = mesh.point_data["displacement_magnitude [in]"] if color == "magnitude" else None
    return render(np.asarray(mesh.points, float), tri, cell_body, png, title, magnitude, elev, azim,
                  record=provenance(sources=[str(vtu)]))


def main(argv=None):
    ap = argparse.ArgumentParser(prog="gimbal render", description=__doc__.split("\n")[0])
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--vtu", help="one frame file")
    src.add_argument("--pvd", help="a collection; with --frame")
    ap.add_argument("--frame", type=int, default=-1, help="frame index into the collection (default -1, the last)")
    ap.add_argument("--png", required=True)
    ap.add_argument("--color", choices=("body", "magnitude"), default="body")
    ap.add_argument("--elev", type=float, default=22.0)
    ap.add_argument("--azim", type=float, default=-55.0)
    ap.add_argument("--title", default="")
    args = ap.parse_args(argv)
    try:
        vtu = args.vtu
        if args.pvd:
            frames = vtk.read_pvd(args.pvd)
            if not -len(frames) <= args.frame < len(frames):
                raise ValueError(f"{args.pvd}: --frame {args.frame}, the collection has {len(frames)} frames")
            vtu = frames[args.frame][1]
        render_vtu(vtu, args.png, args.title, args.color, args.elev, args.azim)
    except (ValueError, OSError, KeyError) as exc:
        print(f"gimbal_reduction.results.render: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    print(f"gimbal_reduction.results.render: {args.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
