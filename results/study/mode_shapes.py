"""Mode shapes: a VTU file for ParaView and a PNG of the first four modes (thesis Figs 2-9, 2-10).

``/usr/bin/python3 -m results.study.mode_shapes --body-file results/modes/body2.h5 --mesh results/mesh/body2.msh
--png results/figures/mode_shapes_body2.png --vtu results/modes/shapes/body2.vtu``
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
from scipy.spatial import cKDTree  # noqa: E402

from workflow.provenance import atomic_path, read_h5_checked  # noqa: E402


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


def plot_modes(points, triangles, displacements, frequencies, title, path, count=4):
    """PNG of the first ``count`` mode shapes, deformed over the undeformed outline."""
    size = np.ptp(points, axis=0).max()
    fig = plt.figure(figsize=(10, 9))
    for i in range(count):
        ax = fig.add_subplot(2, 2, i + 1, projection="3d")
        d = displacements[i]
        scale = 0.12 * size / np.abs(d).max()
        deformed = points + scale * d
        magnitude = np.linalg.norm(d, axis=1)[triangles].mean(axis=1)
        ax.add_collection3d(Poly3DCollection(points[triangles], facecolors=(1, 1, 1, 0), edgecolors=(0.7, 0.7, 0.7, 0.3),
                                             linewidths=0.2))
        colors = plt.cm.viridis(magnitude / magnitude.max())
        ax.add_collection3d(Poly3DCollection(deformed[triangles], facecolors=colors, edgecolors="none"))
        lim = 0.6 * size
        ax.set(xlim=(-lim, lim), ylim=(-lim, lim), zlim=(-lim, lim), xlabel="x (in)", ylabel="y (in)",
               zlabel="z (in)")
        ax.view_init(elev=25, azim=-60)
        ax.set_title(f"mode {i + 1}: {frequencies[i]:.0f} Hz")
    fig.suptitle(f"{title}: first {count} supported modes (displacement exaggerated)")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)


def write_vtu(points, cells, displacements, frequencies, path):
    """All mode shapes as point vectors ``mode_001`` ... in one VTU file (ParaView: Warp By Vector)."""
    data = {f"mode_{i + 1:03d}": displacements[i] for i in range(len(frequencies))}
    mesh = meshio.Mesh(points, cells, point_data=data,
                       field_data={"frequencies_hz": np.asarray(frequencies)})
    with atomic_path(path) as tmp:
        meshio.write(tmp, mesh, file_format="vtu")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--body-file", required=True)
    parser.add_argument("--mesh", required=True)
    parser.add_argument("--png", required=True)
    parser.add_argument("--vtu", required=True)
    args = parser.parse_args(argv)
    try:
        with read_h5_checked(args.body_file, ("modes", "dof_coords", "dof_component", "frequencies_hz")) as h5:
            modes, coords = h5["modes"][()], h5["dof_coords"][()]
            component, freqs, name = h5["dof_component"][()], h5["frequencies_hz"][()], h5.attrs["name"]
        mesh = linear_mesh(meshio.read(args.mesh))
        disp = vertex_displacements(mesh.points, coords, component, modes)
    except (ValueError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    triangles = surface_triangles(mesh)
    plot_modes(mesh.points, triangles, disp, freqs, str(name).replace("_", " "), args.png)
    write_vtu(mesh.points, mesh.cells, disp, freqs, args.vtu)
    return 0


if __name__ == "__main__":
    sys.exit(main())
