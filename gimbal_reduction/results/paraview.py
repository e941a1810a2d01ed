"""The deformed gimbal bodies over time, for ParaView: a PVD collection of VTU files.

    python -m gimbal_reduction.results.paraview --sim results/sim_modal/thesis/freq-10.h5 \\
        --model-file results/models/thesis/freq-10.h5 \\
        --bodies results/modes/body{2,3,4,5}.h5 --meshes results/mesh/body{2,3,4,5}.msh \\
        --out results/paraview/thesis/freq-10.pvd [--frames 100 | --every K] [--scale 1] \\
        [--png results/paraview/thesis/freq-10.png [--png-frame -1]]

The simulation must hold the modal coordinates (``simulate --store-modal``; the workflow's
``results/sim_modal/{scene}/{model}.h5``).  Every file is checked before any work (a
simulation without modal coordinates, a simulation of another model file, a body file of
another configuration, a mesh that does not match its body file): one line naming the file.

Each written frame is one VTU file, ``{out without .pvd}_frames/frame_NNNN.vtu``, holding the four
bodies' surfaces (shell triangles; the platform's boundary faces; linear cells), all in the
case's axes [in] (the case is drawn at rest: the prescribed case rotation is the same in every
model).  A body n's material point X (body axes, the mesh's coordinates) is drawn at

    x = o_n + A_n (X + s u_n(X)),    u_n = Phi_n q_n  (the kept modes, and static correction
                                                       modes, at the mesh vertices),

with (o_n, A_n) the body frame from the joint kinematics (``multibody.joint_state``: the
gimbal angles gamma_1..4, and the elastic translation Psi q and rotation E(Theta q) of the
parent's bearings) at the elastic coordinates s q: with a scale s != 1 the whole elastic
motion is exaggerated alike, so every child stays on its parent's bearings.  Point data:
``displacement [in]`` = A_n u_n (true scale, case axes), ``displacement_magnitude [in]``,
``body_id`` (2..5; also cell data).  FieldData: ``TimeValue`` [s], ``displacement_scale`` s,
``gamma [rad]`` (4), ``sample_index``.  The PVD lists the frames with their times; an XML
comment in every file states the units (in, s, rad), the model, the scene and the scale.

``--frames N`` (default 100) takes N output samples evenly spread over the run, first and last
included; ``--every K`` every K-th sample (and the last).  ``--png`` renders one frame
(``--png-frame``, an index into the written frames, default the last) with ``gimbal_reduction.results.render``.

ParaView: File > Open the .pvd, Apply; colour by ``body_id`` or ``displacement_magnitude [in]``;
the time controls step through the frames.

Why a PVD of VTU files and not XDMF: every point moves in every frame (the bodies turn with the
gimbals), so an XDMF series would store the geometry per step as well, and gain nothing; a PVD
is ParaView's own collection, read the same way by every version (no choice among XDMF readers),
each frame is a self-contained file that opens alone (its time as FieldData ``TimeValue``), and
meshio reads every file back (the tests do).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import sys

import h5py
import meshio
import numpy as np

from gimbal_reduction.reduction import models
from gimbal_reduction.results import render, vtk
from gimbal_reduction.results.study.mode_shapes import linear_mesh, surface_triangles, vertex_displacements
from gimbal_reduction.solver.bodydata import BODIES
from gimbal_reduction.solver.dynamics import chainfile, multibody
from gimbal_reduction.solver.dynamics.simfile import read_sim
from gimbal_reduction.workflow.provenance import provenance, write_sidecar

DEFAULT_FRAMES = 100
UNITS = "lengths and displacements in inches (in), time in seconds (s), angles in radians (rad)"


class ParaviewInputError(ValueError):
    """Bad input (one line naming the file)."""

    def __init__(self, message):
        super().__init__(" ".join(str(message).split()))


# ------------------------------------------------------------------ inputs
def read_modal_sim(path):
    """The simulation file with its modal coordinates: read_sim's dict plus ``q`` (T, sum D),
    checked (present, finite, one row per output sample)."""
    try:
        sim = read_sim(path)
    except ValueError as exc:
        raise ParaviewInputError(exc) from None
    with h5py.File(path, "r") as f:
        if "q" not in f:
            raise ParaviewInputError(f"{path}: no modal coordinates (dataset 'q'): rerun the simulation "
                                     f"with simulate --store-modal (the workflow's results/sim_modal/"
                                     f"{{scene}}/{{model}}.h5)")
        q = f["q"][()]
    if sim["gamma"] is None:
        raise ParaviewInputError(f"{path}: dataset 'gamma' missing (not a simulation file)")
    if q.ndim != 2 or q.shape[0] != sim["t"].size:
        raise ParaviewInputError(f"{path}: dataset 'q' has shape {q.shape}, expected ({sim['t'].size}, n)")
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(sim["gamma"]))):
        raise ParaviewInputError(f"{path}: non-finite gamma or q (diverged run)")
    sim["q"] = np.asarray(q, float)
    sim["gamma"] = np.asarray(sim["gamma"], float)
    return sim


def check_sim_matches_model(sim, chain, info, sim_path, model_path):
    """The simulation was run on this reduced-model file: its model name, mode counts and the model
    file's config hash (which the simulation records as model_config_hash) agree; one line naming
    both files otherwise.  The scene is not compared: a model may be simulated on another scene."""
    attrs = sim["attrs"]
    what = []
    if str(attrs.get("model", "")) != str(info.get("model", "")):
        what.append(f"model {attrs.get('model')!r} vs {info.get('model')!r}")
    n_modes = attrs.get("n_modes")
    counts = None if n_modes is None else tuple(int(n) for n in np.atleast_1d(n_modes))
    if counts is not None and counts != chain.n_modes:
        what.append(f"mode counts {counts} vs {chain.n_modes}")
    mine, theirs = attrs.get("model_config_hash"), info.get("config_hash")
    if mine is not None and theirs is not None and str(mine) != str(theirs):
        what.append(f"model config_hash {mine!r} vs {theirs!r}")
    if sim["q"].shape[1] != sum(chain.n_modes):
        what.append(f"{sim['q'].shape[1]} modal coordinates vs {sum(chain.n_modes)}")
    if what:
        raise ParaviewInputError(f"{sim_path} was not simulated from {model_path} ({'; '.join(what)}): "
                                 f"rerun the simulation of that model file")


def _body_hashes(info, model_path):
    stored = info.get("body_config_hashes")
    if stored is None:
        return None
    try:
        return dict(zip(BODIES, json.loads(stored)))
    except (TypeError, ValueError):
        raise ParaviewInputError(f"{model_path}: attribute body_config_hashes unreadable ({stored!r})") from None


def check_body_files(paths, info, model_path):
    """Each body file exists, is body n's, was made from the configuration the model file was made
    from (its config_hash) and has every kept mode; cheap (attributes and shapes only)."""
    hashes = _body_hashes(info, model_path)
    for b, path in zip(BODIES, paths):
        if not os.path.isfile(path):
            raise ParaviewInputError(f"{path}: body file not found (make it: snakemake --cores 2 {path})")
        try:
            with h5py.File(path, "r") as f:
                missing = [k for k in ("modes", "dof_coords", "dof_component") if k not in f]
                if missing:
                    raise ParaviewInputError(f"{path}: dataset(s) {', '.join(missing)} missing (not a body "
                                             f"file, or stale)")
                number, D = int(f.attrs.get("body", b)), f["modes"].shape[1]
                found = f.attrs.get("config_hash")
        except OSError:
            raise ParaviewInputError(f"{path}: not a readable HDF5 file (corrupt or truncated)") from None
        if number != b:
            raise ParaviewInputError(f"{path}: holds body {number}, expected body {b} (give the body "
                                     f"files in the order {', '.join(map(str, BODIES))})")
        found = found.decode() if isinstance(found, bytes) else found
        if hashes is not None and found is not None and str(found) != str(hashes[b]):
            raise ParaviewInputError(f"{path}: made from another configuration than {model_path} (config_hash "
                                     f"{found!r}, the model's body {b} has {hashes[b]!r})")
        kept = np.asarray(info["kept"][b], int)
        if kept.size and kept.max() >= D:
            raise ParaviewInputError(f"{path}: has {D} modes, {model_path} keeps mode {kept.max()} of body {b}")


def body_basis(path, kept, static_cases):
    """(Phi (ndof, D), dof_coords, dof_component) of the reduced model's coordinates of one body:
    its kept vibration modes, then its static correction modes made the way the reduction makes
    them (``gimbal_reduction.reduction.models.static_modes_for``, from the full body file)."""
    kept = np.asarray(kept, int)
    if static_cases:
        data = models.load_body_file(path)
        Phi = np.asarray(data["modes"])[:, kept]
        lam = np.asarray(data["eigenvalues"])[kept]
        S = models.static_modes_for(data, list(static_cases), Phi, lam)["modes"]
        return np.hstack([Phi, S]), np.asarray(data["dof_coords"]), np.asarray(data["dof_component"])
    with h5py.File(path, "r") as f:
        Phi = f["modes"][:, np.sort(kept)] if kept.size else np.zeros((f["modes"].shape[0], 0))
        if kept.size:
            Phi = Phi[:, np.argsort(np.argsort(kept))]
        return Phi, f["dof_coords"][()], f["dof_component"][()]


def body_surface(mesh_path):
    """(points (n, 3), triangles (m, 3)) of a body mesh's visible surface, linear, with only the
    vertices the surface uses."""
    if not os.path.isfile(mesh_path):
        raise ParaviewInputError(f"{mesh_path}: mesh file not found (make it: snakemake --cores 2 {mesh_path})")
    try:
        mesh = linear_mesh(meshio.read(mesh_path))
    except Exception as exc:  # meshio raises its own ReadError and others on a bad file
        raise ParaviewInputError(f"{mesh_path}: unreadable mesh ({exc.__class__.__name__}: {exc})") from None
    tri = surface_triangles(mesh)
    used, inverse = np.unique(tri, return_inverse=True)
    return np.asarray(mesh.points[used], float), inverse.reshape(tri.shape)


# ------------------------------------------------------------------ kinematics
def body_frames(chain, y):
    """[(o_n (3,), A_n (3, 3))] of bodies 2..5 in case axes at state y (n_y,): the joint poses
    (``multibody.joint_state``) composed from the case: A_c = A_p R_j, o_c = o_p + A_p p_j."""
    o, A = np.zeros(3), np.eye(3)
    zero = np.zeros_like(y)
    frames = []
    for j in range(1, 5):
        J = multibody.joint_state(chain, j, y, zero)
        o, A = o + A @ J.p, A @ J.R
        frames.append((o, A))
    return frames


def frame_indices(n_samples, frames=None, every=None):
    """Output-sample indices to write: ``every`` K-th (and the last), or ``frames`` evenly spread
    (first and last included; all samples if there are fewer)."""
    if every is not None:
        if every < 1:
            raise ParaviewInputError(f"--every must be >= 1, got {every}")
        idx = np.arange(0, n_samples, every)
        return idx if idx[-1] == n_samples - 1 else np.append(idx, n_samples - 1)
    frames = DEFAULT_FRAMES if frames is None else frames
    if frames < 1:
        raise ParaviewInputError(f"--frames must be >= 1, got {frames}")
    if frames == 1:
        return np.array([n_samples - 1])
    return np.unique(np.round(np.linspace(0, n_samples - 1, min(frames, n_samples))).astype(int))


class Scene3D:
    """The four bodies' surfaces and their mode shapes at the surface vertices."""

    def __init__(self, chain, surfaces, shapes):
        self.chain = chain
        self.surfaces = surfaces          # [(points (n, 3), triangles (m, 3))] bodies 2..5
        self.shapes = shapes              # [(D, n, 3)] bodies 2..5

    def frame(self, gamma, q, scale=1.0):
        """(points (N, 3), triangles (M, 3), displacement (N, 3), body_id (N,), cell_body (M,)) of
        all bodies at gimbal angles gamma (4,) and modal coordinates q (sum D,)."""
        y = np.concatenate([np.asarray(gamma, float), scale * np.asarray(q, float)])
        frames = body_frames(self.chain, y)
        pts, tris, disp, ids, cell_ids, offset = [], [], [], [], [], 0
        for k, (b, (X, tri), Phi_v, (o, A)) in enumerate(zip(BODIES, self.surfaces, self.shapes, frames)):
            qb = np.asarray(q, float)[self.chain.slices[k].start - 4:self.chain.slices[k].stop - 4]
            u = np.tensordot(qb, Phi_v, axes=(0, 0)) if qb.size else np.zeros_like(X)
            pts.append(o + (X + scale * u) @ A.T)
            disp.append(u @ A.T)
            tris.append(tri + offset)
            ids.append(np.full(len(X), b))
            cell_ids.append(np.full(len(tri), b))
            offset += len(X)
        return (np.vstack(pts), np.vstack(tris), np.vstack(disp), np.concatenate(ids),
                np.concatenate(cell_ids))


def load_scene3d(model_file, body_files, mesh_files, info=None, chain=None):
    """Scene3D of a reduced-model file, its body files and meshes (checked first)."""
    if chain is None:
        chain, info = chainfile.read_chain(model_file)
    check_body_files(body_files, info, model_file)
    for path in mesh_files:
        if not os.path.isfile(path):
            raise ParaviewInputError(f"{path}: mesh file not found (make it: snakemake --cores 2 {path})")
    surfaces, shapes = [], []
    for k, (b, body, mesh) in enumerate(zip(BODIES, body_files, mesh_files)):
        Phi, coords, comp = body_basis(body, info["kept"][b], info["static_cases"][b])
        if Phi.shape[1] != chain.n_modes[k]:
            raise ParaviewInputError(f"{body}: gives {Phi.shape[1]} coordinates of body {b}, {model_file} "
                                     f"has {chain.n_modes[k]}")
        X, tri = body_surface(mesh)
        try:
            shapes.append(vertex_displacements(X, coords, comp, Phi))
        except ValueError as exc:
            raise ParaviewInputError(f"{mesh}: {exc} ({body})") from None
        surfaces.append((X, tri))
    return Scene3D(chain, surfaces, shapes)


# ------------------------------------------------------------------ output
def frame_mesh(scene3d, gamma, q, scale):
    pts, tri, disp, ids, cell_ids = scene3d.frame(gamma, q, scale)
    return meshio.Mesh(pts, [("triangle", tri)],
                       point_data={"displacement [in]": disp,
                                   "displacement_magnitude [in]": np.linalg.norm(disp, axis=1),
                                   "body_id": ids.astype(np.int32)},
                       cell_data={"body_id": [cell_ids.astype(np.int32)]})


def frames_folder(out):
    """The folder of a collection's frames: ``{out without .pvd}_frames``."""
    return os.path.splitext(out)[0] + "_frames"


def write_series(scene3d, sim, indices, out, scale=1.0, describe=""):
    """Write the frames ``indices`` of ``sim`` and the PVD ``out``; returns the frame paths.

    The frames go to a temporary folder renamed into place when all are written, then the PVD
    is written (atomically): an interrupted run leaves neither a partial folder nor a PVD."""
    out = os.path.abspath(out)
    folder = frames_folder(out)
    parent, name = os.path.split(folder)
    os.makedirs(parent, exist_ok=True)
    tmp = os.path.join(parent, f".{name}.part{os.getpid()}")
    shutil.rmtree(tmp, ignore_errors=True)
    os.makedirs(tmp)
    files = []
    try:
        for n, i in enumerate(indices):
            t, gamma = float(sim["t"][i]), sim["gamma"][i]
            comment = (f"Deformed gimbal bodies 2-5 at t = {t!r} s (output sample {int(i)}); {describe}; "
                       f"{UNITS}; points in case axes, x = o_n + A_n (X + s u), s = displacement_scale "
                       f"= {scale!r}; displacement [in] = A_n u at true scale.")
            vtk.write_vtu(os.path.join(tmp, f"frame_{n:04d}.vtu"), frame_mesh(scene3d, gamma, sim["q"][i], scale),
                          {"TimeValue": [t], "displacement_scale": [scale], "gamma [rad]": gamma,
                           "sample_index": [int(i)]}, comment)
            files.append((t, os.path.join(folder, f"frame_{n:04d}.vtu")))
        if os.path.isdir(folder):
            shutil.rmtree(folder)
        os.replace(tmp, folder)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    vtk.write_pvd(out, files, comment=f"Deformed gimbal bodies over time: {describe}; {UNITS}; "
                                      f"displacement_scale = {scale!r}; {len(files)} frames")
    return [f for _, f in files]


def build_parser():
    ap = argparse.ArgumentParser(prog="gimbal paraview", description=__doc__.split("\n")[0])
    ap.add_argument("--sim", required=True, help="simulation file with modal coordinates (--store-modal)")
    ap.add_argument("--model-file", required=True, help="the reduced-model file it was simulated from")
    ap.add_argument("--bodies", nargs=4, required=True, help="body files of bodies 2, 3, 4, 5")
    ap.add_argument("--meshes", nargs=4, required=True, help="meshes of bodies 2, 3, 4, 5")
    ap.add_argument("--out", required=True, help="the PVD collection (.pvd); frames in the folder beside it")
    which = ap.add_mutually_exclusive_group()
    which.add_argument("--frames", type=int, help=f"frames evenly spread over the run (default {DEFAULT_FRAMES})")
    which.add_argument("--every", type=int, help="every K-th output sample (and the last)")
    ap.add_argument("--scale", type=float, default=1.0,
                    help="scale of the elastic displacement (default 1, true scale); recorded in the files")
    ap.add_argument("--png", help="also render one frame to this PNG (gimbal_reduction.results.render)")
    ap.add_argument("--png-frame", type=int, default=-1, help="the written frame --png shows (default -1, the last)")
    return ap


def main(argv=None):
    args = build_parser().parse_args(argv)
    try:
        if not args.out.endswith(".pvd"):
            raise ParaviewInputError(f"--out {args.out}: a .pvd file is expected")
        if not (np.isfinite(args.scale) and args.scale > 0):
            raise ParaviewInputError(f"--scale must be a positive number, got {args.scale}")
        sim = read_modal_sim(args.sim)
        chain, info = chainfile.read_chain(args.model_file)
        check_sim_matches_model(sim, chain, info, args.sim, args.model_file)
        indices = frame_indices(sim["t"].size, args.frames, args.every)
        if args.png and not -len(indices) <= args.png_frame < len(indices):
            raise ParaviewInputError(f"--png-frame {args.png_frame}: only {len(indices)} frames are written")
        scene3d = load_scene3d(args.model_file, args.bodies, args.meshes, info, chain)
    except (ValueError, FileNotFoundError, OSError) as exc:
        print(f"gimbal_reduction.results.paraview: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    describe = f"model {info.get('model', '')} on scene {sim['attrs'].get('scene', '')} ({args.sim})"
    files = write_series(scene3d, sim, indices, args.out, args.scale, describe)
    write_sidecar(args.out, provenance(sources=[args.sim, args.model_file, *args.bodies, *args.meshes]))
    print(f"gimbal_reduction.results.paraview: {args.out}: {len(files)} frames of {sim['t'].size} samples, "
          f"t = {sim['t'][indices[0]]:.6g} .. {sim['t'][indices[-1]]:.6g} s, scale {args.scale:g}")
    if args.png:
        render.render_vtu(files[args.png_frame], args.png,
                          title=f"{info.get('model', '')} on {sim['attrs'].get('scene', '')}, "
                                f"t = {sim['t'][indices[args.png_frame]] * 1e3:.3f} ms, "
                                f"displacement x{args.scale:g}")
        print(f"gimbal_reduction.results.paraview: {args.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
