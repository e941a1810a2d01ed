"""The modal stage: assemble one body, attach bearings and eccentric mass, solve its modes.

``gimbal modes --body 2 --mesh results/mesh/body2.msh --mesh-meta results/mesh/body2.json --out results/modes/body2.h5``

The stage reads the config only through ``gimbal_reduction.workflow.config.body_inputs`` (whose hash
is the rule's rerun trigger and the body file's ``config_hash``), and the mesh size
from the mesh's metadata (``gimbal_reduction.geometry.mesh --meta``).

Steps (each one function):

1. assemble K and the structural M on the body's mesh (shell or solid, ``gimbal_reduction.solver.fe.forms``);
2. build the rigid-fit operator of every bearing region and of the mass region
   (``gimbal_reduction.solver.fe.bearings``), from integration weights gathered over all ranks;
3. add the eccentric point mass ``m R_t^T R_t`` (10 % of the structural mass);
4. eliminate the six support constraints with a basis T (masters chosen by
   pivoted QR) and solve ``(T^T K T) x = lambda (T^T M T) x`` with SLEPc;
5. gather to rank 0, polish by Rayleigh-Ritz, check residuals and
   M-orthonormality, and write ``body{n}.h5`` (layout: docs/body-data.md).

All heavy algebra (assembly, T^T K T, the factorisation and the eigensolve)
runs on distributed PETSc objects, so the stage runs unchanged under
``mpirun -n 2``; only the final write gathers the data on rank 0.
"""
from __future__ import annotations

import json
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI  # isort: skip - first: the bindings below find libmpi through it

import numpy as np
import scipy.sparse as sp
from petsc4py import PETSc

from gimbal_reduction.geometry.gimbal import GeometryError, bearing_points, eccentric_mass_point
from gimbal_reduction.geometry.mesh import MAX_DOFS, check_size
from gimbal_reduction.solver.fe import bearings, eigen, forms as fe
from gimbal_reduction.solver.bodydata import BEARING_NAMES, BODY_KEYS, CSR_KEYS, read_body_file, rigid_modes, write_csr
from gimbal_reduction.workflow import cli
from gimbal_reduction.workflow import config as cfgmod
from gimbal_reduction.workflow.provenance import atomic_h5, versions


@dataclass
class BodyModel:
    """A body's assembled FE model (PETSc, distributed) and its connection operators (scipy, global)."""

    params: dict
    K: PETSc.Mat
    M: PETSc.Mat
    block_size: int
    ndof: int
    operators: dict          # region name -> (6, ndof) rigid-fit operator (scipy CSR)
    points: np.ndarray       # (4, 3) bearing points
    structural_mass: float   # lbf s^2/in
    point_mass: float        # lbf s^2/in
    point_mass_position: np.ndarray
    mesh_size: float
    dof_coords: np.ndarray | None = None   # (ndof, 3), rank 0 only
    n_cells: int = 0
    space: object = None                   # the DOLFINx function space (for studies of the connection)
    regions: dict | None = None            # region name -> (nodes, coords, weights) of the rigid fits


def _gather_region(V, facet_tags, tag: int, comm):
    """Global node indices, coordinates and weights of a region, identical on every rank."""
    weights = fe.region_weights(V, facet_tags, tag)
    nodes, coords = fe.owned_nodes(V)
    keep = weights > 1e-14 * max(weights.max(initial=0.0), 1e-300)
    parts = comm.allgather((nodes[keep], coords[keep], weights[keep]))
    nodes = np.concatenate([p[0] for p in parts])
    order = np.argsort(nodes)
    return (nodes[order], np.concatenate([p[1] for p in parts])[order],
            np.concatenate([p[2] for p in parts])[order])


def _rigid_translation_vector(K: PETSc.Mat, block_size: int, component: int) -> PETSc.Vec:
    vec = K.createVecRight()
    r0, r1 = vec.getOwnershipRange()
    vec.array[:] = (np.arange(r0, r1) % block_size == component).astype(float)
    return vec


def assemble_body(inputs: dict, mesh_path: str | Path, comm=MPI.COMM_WORLD) -> BodyModel:
    """Assemble K, M (with the eccentric mass) and the bearing operators of one body.

    ``inputs``: the body's resolved inputs, ``gimbal_reduction.workflow.config.body_inputs(config, n, mesh_size)``.
    """
    params = inputs["body"]
    mesh, _, facet_tags, regions = fe.load_mesh(mesh_path, comm)
    if params["model"] == "shell":
        V, a_k, a_m = fe.shell_forms(mesh, params, inputs["shell"])
    else:
        V, a_k, a_m = fe.solid_forms(mesh, params, inputs["solid_degree"])
    K, M = fe.assemble_matrix(a_k), fe.assemble_matrix(a_m)
    bs = V.dofmap.index_map_bs
    ndof = V.dofmap.index_map.size_global * bs
    points = bearing_points(params)
    mass_position = eccentric_mass_point(params, inputs["mass_angle"])
    length = inputs["rotation_weight_length"]
    operators, region_data = {}, {}
    for name, point in [*zip(BEARING_NAMES, points), ("eccentric_mass", mass_position)]:
        if name not in regions:
            continue
        if np.any(np.isnan(point)):
            continue
        nodes, coords, weights = region_data[name] = _gather_region(V, facet_tags, regions[name], comm)
        operators[name] = bearings.rigid_fit_operator(nodes, coords, weights, point, bs, ndof, length,
                                                      shell_normals(coords) if bs == 6 else None)
    missing = [n for n in ("input_motor", "input_resolver", "eccentric_mass") if n not in operators]
    if missing:
        raise ValueError(f"mesh '{mesh_path}' lacks the region(s) {', '.join(missing)}")
    # structural mass = X_x^T M X_x (unit translation along x)
    ex = _rigid_translation_vector(K, bs, 0)
    structural_mass = M.createVecLeft()
    M.mult(ex, structural_mass)
    structural_mass = structural_mass.dot(ex)
    point_mass = inputs["mass_fraction"] * structural_mass
    _add_point_mass(M, operators["eccentric_mass"][:3], point_mass, comm)
    nodes, coords = fe.owned_nodes(V)
    parts = comm.gather((nodes, coords), root=0)
    dof_coords = None
    if comm.rank == 0:
        node_coords = np.zeros((ndof // bs, 3))
        for n_, c_ in parts:
            node_coords[n_] = c_
        dof_coords = np.repeat(node_coords, bs, axis=0)
    mesh_size = inputs["mesh"]["size"]
    n_cells = comm.allreduce(mesh.topology.index_map(mesh.topology.dim).size_local)
    return BodyModel(params, K, M, bs, ndof, operators, points, structural_mass, point_mass,
                     mass_position, mesh_size, dof_coords, n_cells, V, region_data)


def shell_normals(coords: np.ndarray) -> np.ndarray:
    """(k, 3) unit normals of the ring mid-surface (radial in the x-z plane) at the given points."""
    radial = np.asarray(coords, dtype=float) * [1.0, 0.0, 1.0]
    return radial / np.linalg.norm(radial, axis=1, keepdims=True)


def _add_point_mass(M: PETSc.Mat, translation_rows: sp.csr_matrix, mass: float, comm) -> None:
    """M += mass R_t^T R_t (dense over the region's DOFs).

    The block is assembled as its own preallocated matrix (each rank its own
    rows) and added with AXPY: inserting it entry by entry into M, whose
    pattern lacks it, made PETSc reallocate and took minutes on fine meshes.
    """
    R = sp.csr_matrix(translation_rows)
    block = (mass * (R.T @ R)).tocsr()
    r0, r1 = M.getOwnershipRange()
    local = block[r0:r1]
    local.sort_indices()
    point_mass = PETSc.Mat().createAIJ(size=M.getSizes(), comm=M.getComm(),
                                       csr=(local.indptr.astype(PETSc.IntType),
                                            local.indices.astype(PETSc.IntType), local.data))
    point_mass.assemble()
    M.axpy(1.0, point_mass, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
    point_mass.destroy()


def admissible_basis_petsc(K: PETSc.Mat, constraints: sp.csr_matrix) -> tuple[PETSc.Mat, sp.csr_matrix]:
    """The basis T of admissible displacements as a distributed PETSc matrix (and scipy on all ranks).

    T has identity columns for every non-master DOF and, in the master rows,
    the elimination coefficients S (``gimbal_reduction.solver.fe.bearings.admissible_basis``).
    """
    ndof = K.getSize()[0]
    masters, slaves, S = bearings.admissible_basis(constraints)
    T = bearings.admissible_basis_matrix(masters, slaves, S, ndof)
    r0, r1 = K.getOwnershipRange()
    is_master = np.zeros(ndof, dtype=bool)
    is_master[masters] = True
    c0 = r0 - int(is_master[:r0].sum())
    c1 = r1 - int(is_master[:r1].sum())
    local = T[r0:r1].tocsr()
    local.sort_indices()
    T_petsc = PETSc.Mat().createAIJ(size=((r1 - r0, ndof), (c1 - c0, T.shape[1])), comm=K.getComm(),
                                    csr=(local.indptr.astype(PETSc.IntType),
                                         local.indices.astype(PETSc.IntType), local.data))
    T_petsc.assemble()
    return T_petsc, T


def without_zeros(A: PETSc.Mat) -> PETSc.Mat:
    """A copy of a distributed AIJ matrix without its stored zeros (each rank its own rows).

    The assembled matrices store the forms' full pattern: a solid's mass couples only equal
    components, so two thirds of its stored entries are zeros. They change no product, but
    every one costs time in PtAP and in each M-inner product of the eigen solve.
    """
    indptr, indices, data = A.getValuesCSR()
    local = sp.csr_matrix((data, indices, indptr), shape=(len(indptr) - 1, A.getSize()[1]))
    local.eliminate_zeros()
    local.sort_indices()
    out = PETSc.Mat().createAIJ(size=A.getSizes(), comm=A.getComm(),
                                csr=(local.indptr.astype(PETSc.IntType), local.indices.astype(PETSc.IntType),
                                     local.data))
    out.assemble()
    return out


def gather_matrix(A: PETSc.Mat, comm) -> sp.csr_matrix | None:
    """The whole matrix as scipy CSR on rank 0 (None elsewhere), without stored zeros (the body
    file's K and M: every product downstream skips them, ``without_zeros``)."""
    r0, r1 = A.getOwnershipRange()
    indptr, indices, data = A.getValuesCSR()
    parts = comm.gather((r0, indptr.copy(), indices.copy(), data.copy()), root=0)
    if comm.rank != 0:
        return None
    shape = A.getSize()
    blocks = []
    for r0_, ip, ix, d in sorted(parts, key=lambda p: p[0]):
        blocks.append(sp.csr_matrix((d, ix, ip), shape=(len(ip) - 1, shape[1])))
    out = sp.vstack(blocks).tocsr()
    out.eliminate_zeros()
    return out


def gather_vectors(vectors: list[PETSc.Vec], comm) -> np.ndarray | None:
    """(n, len(vectors)) array on rank 0."""
    columns = []
    for vec in vectors:
        scatter, full = PETSc.Scatter.toZero(vec)
        scatter.scatter(vec, full, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        if comm.rank == 0:
            columns.append(full.getArray().copy())
        scatter.destroy()
        full.destroy()
    return np.column_stack(columns) if comm.rank == 0 else None


def supported_modes(body: BodyModel, count: int, tolerance: float, max_iterations: int, comm,
                    known: tuple[np.ndarray, np.ndarray] | None = None):
    """Lowest ``count`` supported modes: returns (eigenvalues, T scipy, vectors gathered on rank 0).

    ``known``: (eigenvalues (k,), modes (ndof, k)) of the lowest k < count supported modes of
    this very model (an earlier solve, on every rank): only the count - k further ones are
    solved for, in their M-orthogonal complement (``eigen.lowest_eigenpairs`` deflation), and
    the known ones come first in the result.
    """
    constraints = bearings.support_constraints(body.operators)
    T_petsc, T = admissible_basis_petsc(body.K, constraints)
    k_reduced = without_zeros(body.K).PtAP(T_petsc)
    m_reduced = without_zeros(body.M).PtAP(T_petsc)
    deflation, known_values, known_modes = [], np.zeros(0), np.zeros((body.ndof, 0))
    if known is not None:
        known_values, known_modes = np.asarray(known[0], float), np.asarray(known[1], float)
        deflation = _reduced_vectors(k_reduced, T, constraints, known_modes, body.params["name"])
    values, vecs = eigen.lowest_eigenpairs(k_reduced, m_reduced, count - len(deflation), 0.0, tolerance,
                                           max_iterations, label=body.params["name"], deflation=deflation)
    full = []
    for x in vecs:
        phi = body.K.createVecRight()
        T_petsc.mult(x, phi)
        full.append(phi)
    vectors = gather_vectors(full, comm)
    if comm.rank == 0 and len(deflation):
        vectors = np.hstack([known_modes, vectors])
    return np.concatenate([known_values, values]), T, vectors


def _reduced_vectors(k_reduced: PETSc.Mat, T: sp.csr_matrix, constraints: sp.csr_matrix,
                     modes: np.ndarray, name: str) -> list[PETSc.Vec]:
    """Modes (ndof, k) as PETSc Vecs of the admissible coordinates (T's columns: the non-master
    DOFs, ``bearings.admissible_basis_matrix``); ValueError if they are not T x (another mesh or
    connection)."""
    masters = bearings.admissible_basis(constraints)[0]
    coordinates = modes[np.setdiff1d(np.arange(T.shape[0]), masters)]
    mismatch = float(np.max(np.abs(T @ coordinates - modes))) if modes.size else 0.0
    if mismatch > 1e-8 * float(np.max(np.abs(modes))):
        raise ValueError(f"{name}: the known modes are not admissible displacements of this model "
                         f"(mismatch {mismatch:.2e}): another mesh, connection or configuration?")
    out = []
    for column in coordinates.T:
        vec = k_reduced.createVecRight()
        c0, c1 = vec.getOwnershipRange()
        vec.array[:] = column[c0:c1]
        out.append(vec)
    return out


def free_modes(body: BodyModel, count: int, shift: float, tolerance: float, max_iterations: int, comm):
    """Lowest ``count`` free-free modes (six rigid ones first); shift < 0 scaled to the stiffness."""
    values, vecs = eigen.lowest_eigenpairs(body.K, body.M, count, shift, tolerance, max_iterations,
                                           label=f"{body.params['name']} (free-free)")
    return values, gather_vectors(vecs, comm)


def bearing_operator_matrix(body: BodyModel) -> sp.csr_matrix:
    """(24, ndof) stacked operators of the four bearings (zero rows where absent)."""
    blocks = [body.operators.get(name, sp.csr_matrix((6, body.ndof))) for name in BEARING_NAMES]
    return sp.vstack(blocks).tocsr()


def compute_body(body_number: int, config: dict, mesh_path: str | Path, count: int | None = None,
                 comm=MPI.COMM_WORLD, log=print, all_modes: bool = False, mesh_size: float | None = None,
                 known: dict | None = None) -> dict | None:
    """Assemble and solve one body; return the body-file payload on rank 0 (None elsewhere).

    ``all_modes``: every finite supported mode by a dense solve (coarse meshes,
    serial only), for the discrete Hughes identities. ``mesh_size``: the size the
    mesh was made with (default: the config's), recorded in the body file.
    ``known``: a body file's dict (``gimbal_reduction.solver.bodydata.read_body_file``) of the same body, mesh
    and inputs with fewer modes (e.g. results/modes/body{n}.h5 for the 200-mode basis): its
    modes are kept and only the further ones solved for (``supported_modes``); every mode is
    then polished together by Rayleigh-Ritz and checked as usual.
    """
    started = time.perf_counter()
    inputs = cfgmod.body_inputs(config, body_number, mesh_size)
    params = inputs["body"]
    count = int(count or inputs["modes"]["count"])
    tolerance = inputs["modes"]["tolerance"]
    max_iterations = int(inputs["modes"]["max_iterations"])
    body = assemble_body(inputs, mesh_path, comm)
    t_assembled = time.perf_counter()
    if all_modes:
        if comm.size > 1 or body.ndof > 20000:
            raise ValueError(f"{params['name']}: --all-modes is a dense solve for coarse serial meshes "
                             f"({body.ndof} DOFs on {comm.size} ranks)")
        K, M = gather_matrix(body.K, comm), gather_matrix(body.M, comm)
        T = admissible_basis_petsc(body.K, bearings.support_constraints(body.operators))[1]
        values, vectors = eigen.all_supported_modes(K, M, T)
        count = len(values)
        log(f"[{params['name']}] {body.ndof} DOFs: all {count} finite supported modes (dense)")
        return _payload(body_number, params, body, values, vectors, K, M, T, comm.size,
                        {"assembly_s": t_assembled - started, "eigensolve_s": time.perf_counter() - t_assembled}, log)
    if count > body.ndof - 6:
        raise ValueError(f"{params['name']}: modes.count = {count} exceeds the {body.ndof - 6} "
                         "admissible DOFs of the mesh")
    start = None
    if known is not None:
        start = _known_modes(known, inputs, body, count)
    log(f"[{params['name']}] {body.ndof} DOFs ({params['model']}), assembled in {t_assembled - started:.2f} s; "
        f"solving {count} modes" + (f" ({count - len(start[0])} after the {len(start[0])} of {known['path']})"
                                    if start is not None else ""))
    values, T, vectors = supported_modes(body, count, tolerance, max_iterations, comm, start)
    t_solved = time.perf_counter()
    K, M = gather_matrix(body.K, comm), gather_matrix(body.M, comm)
    if comm.rank != 0:
        return None
    values, vectors = eigen.rayleigh_ritz(K, M, vectors)
    timings = {"assembly_s": t_assembled - started, "eigensolve_s": t_solved - t_assembled}
    if start is not None:
        timings["known_modes"] = len(start[0])
    return _payload(body_number, params, body, values, vectors, K, M, T, comm.size, timings, log)


def _known_modes(known: dict, inputs: dict, body: BodyModel, count: int) -> tuple[np.ndarray, np.ndarray]:
    """(eigenvalues, modes) of a body file of the same inputs with fewer than ``count`` modes;
    ValueError (one line naming the file) otherwise."""
    where = known.get("path", "the known modes' file")
    if str(known["attrs"].get("config_hash")) != cfgmod.inputs_hash(inputs):
        raise ValueError(f"{where}: made from other inputs than this body's (config_hash "
                         f"{known['attrs'].get('config_hash')!r}): remake it first")
    if float(known["attrs"].get("mesh_size", math.nan)) != float(inputs["mesh"]["size"]) or \
            known["modes"].shape[0] != body.ndof:
        raise ValueError(f"{where}: another mesh ({known['modes'].shape[0]} DOFs, size "
                         f"{known['attrs'].get('mesh_size')} in) than this one ({body.ndof} DOFs, "
                         f"{inputs['mesh']['size']} in)")
    k = len(known["eigenvalues"])
    if k >= count:
        raise ValueError(f"{where}: holds {k} modes, not fewer than the {count} requested")
    return np.asarray(known["eigenvalues"]), np.asarray(known["modes"])


def _payload(body_number, params, body, values, vectors, K, M, T, ranks, timings, log) -> dict:
    """Checks and the body-file payload of solved modes."""
    count = len(values)
    residuals = eigen.relative_residuals(K, M, values, vectors, T)
    orthonormality = eigen.orthonormality_error(M, vectors)
    if np.any(values <= 0):
        raise eigen.EigenSolveError(f"{params['name']}: non-positive supported eigenvalue {values.min():.3e} "
                                    "(supports do not remove all rigid motions)")
    operator = bearing_operator_matrix(body)
    bearing_modes = (operator @ vectors).T.reshape(count, 4, 6)
    bearing_modes[:, [name not in body.operators for name in BEARING_NAMES], :] = np.nan
    log(f"[{params['name']}] f1..f4 = {np.sqrt(values[:4]) / (2 * math.pi)} Hz, f{count} = "
        f"{np.sqrt(values[-1]) / (2 * math.pi):.1f} Hz; max residual {residuals.max():.1e}, "
        f"orthonormality {orthonormality:.1e}; solved in {timings['eigensolve_s']:.2f} s")
    return {
        "frequencies_hz": np.sqrt(values) / (2 * math.pi), "eigenvalues": values, "modes": vectors,
        "M": M, "K": K, "T": T, "bearing_operator": operator,
        "rigid_modes": rigid_modes(body.dof_coords, np.arange(body.ndof) % body.block_size),
        "dof_coords": body.dof_coords,
        "dof_component": (np.arange(body.ndof) % body.block_size).astype(np.int8),
        "bearing_points": body.points, "bearing_modes": bearing_modes,
        "residuals": residuals,
        "attrs": {"body": body_number, "name": params["name"], "model": params["model"],
                  "structural_mass": body.structural_mass, "point_mass": body.point_mass,
                  "point_mass_position": body.point_mass_position, "mesh_size": body.mesh_size,
                  "cells": body.n_cells, "units": "in, lbf, s (mass lbf s^2/in, eigenvalues (rad/s)^2)",
                  "max_relative_residual": float(residuals.max()), "orthonormality_error": orthonormality,
                  "mpi_ranks": ranks},
        "timings": timings,
    }


def write_body_file(path: str | Path, payload: dict, config_hash: str, wall_time: float) -> None:
    """Write the body file atomically (layout: docs/body-data.md)."""
    with atomic_h5(path) as h5:
        for key in BODY_KEYS + ("residuals",):
            if key in CSR_KEYS:
                write_csr(h5, key, payload[key])
            else:
                h5.create_dataset(key, data=payload[key])
        for key, val in payload["attrs"].items():
            h5.attrs[key] = val
        h5.attrs["config_hash"] = config_hash
        h5.attrs["versions"] = json.dumps(versions())
        h5.attrs["wall_time_s"] = wall_time
        h5.attrs["timings"] = json.dumps(payload["timings"])


def read_mesh_size(path: str | Path) -> float:
    """The mesh size recorded in a mesh's metadata file, with a one-line error if it is unusable."""
    try:
        return float(json.loads(Path(path).read_text())["mesh_size"])
    except FileNotFoundError:
        raise FileNotFoundError(f"mesh metadata '{path}' not found (run gimbal_reduction.geometry.mesh --meta)") from None
    except (ValueError, KeyError, TypeError):
        raise ValueError(f"mesh metadata '{path}' holds no mesh_size: delete it and rerun gimbal_reduction.geometry.mesh") from None


def main(argv=None) -> int:
    parser = cli.OneLineParser(prog="gimbal_reduction.solver.fe.modes", description=__doc__.split("\n")[0])
    parser.add_argument("--body", required=True, help="body number 2..5")
    parser.add_argument("--mesh", required=True, help="gmsh .msh file of the body")
    parser.add_argument("--mesh-meta", default=None,
                        help="the mesh's metadata (gimbal_reduction.geometry.mesh --meta): the mesh size recorded (default: config)")
    parser.add_argument("--out", required=True, help="output body file (.h5)")
    parser.add_argument("--config", default=str(cfgmod.DEFAULT_CONFIG))
    parser.add_argument("--count", type=cli.positive_int("--count"), default=None,
                        help="number of modes (default: config)")
    parser.add_argument("--max-dofs", type=cli.positive_int("--max-dofs"), default=MAX_DOFS,
                        help=f"refuse a mesh whose model is estimated above this many DOFs "
                             f"(default {MAX_DOFS:,}; gimbal_reduction.geometry.mesh)")
    parser.add_argument("--all-modes", action="store_true",
                        help="every finite supported mode by a dense solve (coarse meshes only)")
    parser.add_argument("--known-modes", default=None,
                        help="a body file of the same body, mesh and config with fewer modes (e.g. "
                             "results/modes/body2.h5): its modes are kept, only the further ones solved for")
    try:
        args = parser.parse_args(cli.values_joined(sys.argv[1:] if argv is None else argv, parser))
    except SystemExit as exc:
        return exc.code
    comm = MPI.COMM_WORLD
    started = time.perf_counter()
    try:
        config = cfgmod.load_config(args.config)
        body_number = cfgmod.BODY_NUMBERS[cfgmod.body_name(args.body)]
        mesh_size = read_mesh_size(args.mesh_meta) if args.mesh_meta else None
        if not os.path.isfile(args.mesh):
            raise FileNotFoundError(f"mesh '{args.mesh}' not found (make it: snakemake --cores 2 {args.mesh})")
        check_size(cfgmod.body_inputs(config, body_number, mesh_size)["mesh"], args.max_dofs,
                   f"mesh size of {args.mesh_meta or 'the config'}")
        cli.check_writable(args.out)
        known = read_body_file(args.known_modes) if args.known_modes else None
        payload = compute_body(body_number, config, args.mesh, args.count, comm,
                               log=print if comm.rank == 0 else (lambda *a, **k: None), all_modes=args.all_modes,
                               mesh_size=mesh_size, known=known)
    except (ValueError, FileNotFoundError, eigen.EigenSolveError, GeometryError) as exc:
        if comm.rank == 0:
            print(f"error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 1
    if comm.rank == 0:
        inputs = cfgmod.body_inputs(config, body_number, mesh_size)
        try:
            write_body_file(args.out, payload, cfgmod.inputs_hash(inputs), time.perf_counter() - started)
        except OSError as exc:
            print(f"error: {cli.write_failure(args.out, exc)}", file=sys.stderr)
            return 1
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
