"""Finite-element models of one body in DOLFINx 0.11: shell and solid.

Shell (gimbal rings)
--------------------
A linear Reissner-Mindlin (Naghdi) shell on the mid-surface manifold,
discretised with flat (affine) triangles and continuous P2 fields for both the
displacement ``u`` (3 components) and the rotation vector ``theta`` (3 global
components): 6 DOFs per node, node-interleaved as (u_x, u_y, u_z, th_x, th_y,
th_z). With the unit normal ``n`` of a facet and the tangential projector
``P = I - n n^T``, the strains are

* membrane   ``e = sym(P grad(u) P)``
* bending    ``k = sym(P grad(beta) P)`` with the director increment
  ``beta = theta x n`` (so ``grad(beta) = -[n]x grad(theta)`` on a flat facet)
* shear      ``g = P (beta + grad(u)^T n)``
* drilling   ``d = theta.n - 1/2 [n]x : grad(u)`` (normal rotation minus the
  in-plane rotation of the displacement field, Hughes-Brezzi)

and every one of them vanishes exactly for a rigid motion ``u = a + w x x``,
``theta = w`` (checked by the tests), whatever the facet orientation: flipping
``n`` flips ``k``, ``g`` and ``d`` together, so the energy is invariant.

Locking: P2/P2 with full integration shear-locks on thin plates. We use the
consistent stabilisation of Lyly-Stenberg-Vihinen (Stenberg 1995): the shear
modulus is scaled by ``t^2 / (t^2 + alpha h^2)``; it tends to 1 as the mesh is
refined (so the method converges to the Reissner-Mindlin solution), it removes
locking for t << h without reduced integration and without spurious
zero-energy modes. For the thick rings (t >= h) it is essentially inactive.
The drilling rotation has a penalty stiffness ``c E t^3 / h^2`` and no inertia.

Mass: ``rho t u.u + rho t^3/12 beta.beta`` (translation and rotary inertia of
the director; no drilling inertia).

Solid (platform, and the outer gimbal for verification)
-------------------------------------------------------
Isotropic linear elasticity on tetrahedra, 3 DOFs per node, of the polynomial
degree the caller gives (config ``solid.degree``: 3, on the platform's curved
second-order tetrahedra).
"""
from __future__ import annotations

from pathlib import Path

# mpi4py first: the wheel's bindings (dolfinx, petsc4py) resolve libmpi through the copy that
# mpi4py.MPI loads (importing dolfinx_solver does the same ordering and checks the stack)
from mpi4py import MPI  # isort: skip

import dolfinx_solver  # noqa: F401  # isort: skip

# h5py (the body files) before dolfinx.fem.petsc: imported after it, h5py resolves its HDF5 calls
# to the wheel's HDF5 1.14 instead of its own 2.0 and fails on import ("Not a datatype")
import h5py  # noqa: F401  # isort: skip

import basix
import basix.ufl
import meshio
import numpy as np
import ufl
from dolfinx import fem
from dolfinx import graph as dgraph
from dolfinx import mesh as dmesh
from dolfinx.fem import petsc as fem_petsc
from dolfinx.io import utils as io_utils
from petsc4py import PETSc

NODES_PER_CELL = {"line": 2, "triangle": 3, "triangle6": 6, "tetra": 4, "tetra10": 10}
CELL_TYPES = {"line": dmesh.CellType.interval, "triangle": dmesh.CellType.triangle,
              "triangle6": dmesh.CellType.triangle, "tetra": dmesh.CellType.tetrahedron,
              "tetra10": dmesh.CellType.tetrahedron}

JIT = {"cffi_extra_compile_args": ["-O2"], "cache_dir": str(Path.home() / ".cache" / "fenics")}


def load_mesh(path: str | Path, comm: MPI.Comm = MPI.COMM_WORLD):
    """Read a gmsh ``.msh`` file (triangles, or first/second-order tetrahedra) into DOLFINx.

    Read with meshio on rank 0 and distributed by DOLFINx. (``dolfinx.io.gmsh`` reads a
    live gmsh model or a file through gmsh; reading the file with meshio keeps the mesh's
    nodes and cells exactly as written, whatever gmsh version is installed.)
    Returns ``(mesh, cell_tags, facet_tags, region_tags)`` where region_tags
    maps the physical-group names of dimension tdim-1 to their tag values.
    """
    path = Path(path)
    payload = None
    if comm.rank == 0:
        if not path.exists():
            raise FileNotFoundError(f"mesh file '{path}' not found (run the 'mesh' rule first)")
        try:
            msh = meshio.read(path)
        except Exception:  # noqa: BLE001 - meshio raises many types
            raise ValueError(f"mesh file '{path}' is not a readable gmsh file") from None
        types = {c.type for c in msh.cells}
        if "tetra10" in types:
            tdim, cell_type, facet_type = 3, "tetra10", "triangle6"
        elif "tetra" in types:
            tdim, cell_type, facet_type = 3, "tetra", "triangle"
        else:
            tdim, cell_type, facet_type = 2, "triangle", "line"
        tags = msh.cell_data.get("gmsh:physical")
        if tags is None or not any(c.type == cell_type for c in msh.cells):
            raise ValueError(f"mesh file '{path}' has no tagged {cell_type} cells")

        def stack(kind):
            blocks = [(c.data, t) for c, t in zip(msh.cells, tags) if c.type == kind]
            if not blocks:
                return np.zeros((0, NODES_PER_CELL[kind]), np.int64), np.zeros(0, np.int32)
            return (np.vstack([b[0] for b in blocks]).astype(np.int64),
                    np.concatenate([b[1] for b in blocks]).astype(np.int32))

        regions = {name: int(tag) for name, (tag, dim) in msh.field_data.items() if dim == tdim - 1}
        (cells, cell_values), (facets, facet_values) = stack(cell_type), stack(facet_type)
        # drop nodes that no cell uses (the mesh's geometry is the cells' nodes; the point group's
        # node lies on the mid-surface and is kept)
        used = np.unique(cells)
        renumber = np.full(len(msh.points), -1, dtype=np.int64)
        renumber[used] = np.arange(len(used))
        if np.any(renumber[facets] < 0):
            raise ValueError(f"mesh file '{path}' has tagged facets off the cells")
        # meshio hands cells over in VTK node order; DOLFINx numbers them differently
        cells = renumber[cells][:, io_utils.cell_perm_vtk(CELL_TYPES[cell_type], cells.shape[1])]
        facets = renumber[facets][:, io_utils.cell_perm_vtk(CELL_TYPES[facet_type], facets.shape[1])]
        payload = (tdim, cell_type, facet_type, msh.points[used], (cells, cell_values), (facets, facet_values),
                   regions)
    tdim, cell_type, facet_type, regions = comm.bcast(
        (payload[0], payload[1], payload[2], payload[6]) if comm.rank == 0 else None, root=0)
    if comm.rank == 0:
        x, (cells, cell_values), (facets, facet_values) = payload[3:6]
    else:
        x = np.zeros((0, 3))
        cells, cell_values = np.zeros((0, NODES_PER_CELL[cell_type]), np.int64), np.zeros(0, np.int32)
        facets, facet_values = np.zeros((0, NODES_PER_CELL[facet_type]), np.int64), np.zeros(0, np.int32)
    # the coordinate field: vector Lagrange of degree 1 (flat triangles, affine tetrahedra) or 2
    # (curved tetrahedra) with three components, also on the shell's 2D manifold in 3D
    degree = 2 if cell_type == "tetra10" else 1
    coordinate_element = basix.ufl.element("Lagrange", "tetrahedron" if tdim == 3 else "triangle", degree,
                                           lagrange_variant=basix.LagrangeVariant.equispaced, shape=(3,))
    # Cells sharing a facet across ranks are ghosted ("shared facet"): the region weights of a
    # ring are interior-facet integrals (dS) over the bearing lines, which DOLFINx can only
    # evaluate on a facet whose two cells a rank holds. (DOLFINx 0.5 ghosted so by default;
    # in 0.11 the default ghosts nothing, and dS on a facet between ranks is an error.)
    partitioner = dmesh.create_cell_partitioner(dmesh.GhostMode.shared_facet, 2)
    mesh = dmesh.create_mesh(comm, cells, ufl.Mesh(coordinate_element), x, partitioner)
    if comm.allreduce(mesh.topology.index_map(tdim).size_local) == 0:
        raise ValueError(f"mesh file '{path}' holds an empty mesh")

    def tags_of(dim, entities, values):
        # entities are given by their input (file) node numbers; each goes to the rank owning it
        mesh.topology.create_connectivity(dim, tdim)
        local, local_values = io_utils.distribute_entity_data(mesh, dim, entities, values)
        return dmesh.meshtags_from_entities(mesh, dim, dgraph.adjacencylist(local), local_values)

    return mesh, tags_of(tdim, cells, cell_values), tags_of(tdim - 1, facets, facet_values), regions


def lagrange_element(mesh, degree: int, components: int):
    """Continuous vector Lagrange element of ``degree`` with ``components`` node-interleaved values.

    The nodes are Basix's GLL-warped points (the variant DOLFINx 0.5.2 chose for every Lagrange
    space, and 0.11's default, stated here as part of the model); they coincide with the equispaced ones up to degree 2 and only the P3 solid's edge
    and face nodes depend on it. The nodes matter beyond the space itself: the bearing
    connection is a weighted fit of *nodal* values (``gimbal_reduction.solver.fe.bearings``).
    """
    return basix.ufl.element("Lagrange", mesh.basix_cell(), degree,
                             lagrange_variant=basix.LagrangeVariant.gll_warped, shape=(components,))


def skew(a):
    """UFL 3x3 matrix [a]x with [a]x b = a x b."""
    return ufl.as_matrix([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])


def facet_normal(mesh):
    """Unit normal of each flat triangle of a manifold mesh (sign arbitrary)."""
    jac = ufl.Jacobian(mesh)
    t1, t2 = jac[:, 0], jac[:, 1]
    n = ufl.cross(t1, t2)
    return n / ufl.sqrt(ufl.dot(n, n))


def shell_strains(w, n):
    """Membrane, bending, shear and drilling strains of a 6-component field w = (u, theta)."""
    u = ufl.as_vector([w[0], w[1], w[2]])
    theta = ufl.as_vector([w[3], w[4], w[5]])
    proj = ufl.Identity(3) - ufl.outer(n, n)
    grad_u = ufl.grad(u)
    beta = ufl.cross(theta, n)
    grad_beta = -skew(n) * ufl.grad(theta)
    membrane = ufl.sym(proj * grad_u * proj)
    bending = ufl.sym(proj * grad_beta * proj)
    shear = proj * (beta + grad_u.T * n)
    drilling = ufl.dot(theta, n) - 0.5 * ufl.inner(skew(n), grad_u)
    return membrane, bending, shear, drilling, u, beta


def plane_stress(a, b, nu):
    """Isotropic plane-stress product (1-nu) a:b + nu tr(a) tr(b) of tangential tensors."""
    return (1 - nu) * ufl.inner(a, b) + nu * ufl.tr(a) * ufl.tr(b)


def shell_forms(mesh, params: dict, shell: dict):
    """Stiffness and mass bilinear forms of the shell on a 6-DOF P2 space.

    ``params``: youngs_modulus E, poissons_ratio nu, density rho, thickness t.
    ``shell``: shear_correction, drilling_factor, shear_stabilisation (alpha).
    Returns ``(V, a_stiffness, a_mass)``.
    """
    V = fem.functionspace(mesh, lagrange_element(mesh, 2, 6))
    E, nu, rho, t = (params[k] for k in ("youngs_modulus", "poissons_ratio", "density", "thickness"))
    G = E / (2 * (1 + nu))
    h = ufl.CellDiameter(mesh)
    n = facet_normal(mesh)
    w, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    ew, kw, gw, dw, uw, bw = shell_strains(w, n)
    ev, kv, gv, dv, uv, bv = shell_strains(v, n)
    membrane_stiffness = E * t / (1 - nu**2)
    bending_stiffness = E * t**3 / (12 * (1 - nu**2))
    shear_stiffness = shell["shear_correction"] * G * t * t**2 / (t**2 + shell["shear_stabilisation"] * h**2)
    drilling_stiffness = shell["drilling_factor"] * E * t**3 / h**2
    stiffness = (membrane_stiffness * plane_stress(ew, ev, nu)
                 + bending_stiffness * plane_stress(kw, kv, nu)
                 + shear_stiffness * ufl.dot(gw, gv)
                 + drilling_stiffness * dw * dv) * ufl.dx
    mass = (rho * t * ufl.dot(uw, uv) + rho * t**3 / 12 * ufl.dot(bw, bv)) * ufl.dx
    return V, stiffness, mass


def solid_forms(mesh, params: dict, degree: int = 2):
    """Stiffness and mass bilinear forms of 3D isotropic elasticity on Lagrange tetrahedra."""
    V = fem.functionspace(mesh, lagrange_element(mesh, degree, 3))
    E, nu, rho = (params[k] for k in ("youngs_modulus", "poissons_ratio", "density"))
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    eps = lambda a: ufl.sym(ufl.grad(a))  # noqa: E731
    stiffness = (2 * mu * ufl.inner(eps(u), eps(v)) + lam * ufl.div(u) * ufl.div(v)) * ufl.dx
    mass = rho * ufl.dot(u, v) * ufl.dx
    return V, stiffness, mass


def assemble_matrix(form) -> PETSc.Mat:
    """Assemble a bilinear form into a PETSc matrix (no boundary conditions)."""
    A = fem_petsc.assemble_matrix(fem.form(form, jit_options=JIT))
    A.assemble()
    return A


def region_weights(V, facet_tags, tag: int) -> np.ndarray:
    """Integration weight of every owned node on a tagged region, shape (n_owned_nodes,).

    The weight of node k is the integral of its (scalar) basis function over the
    region: a line inside a shell (interior facets, ``dS``) or a face patch of a
    solid (exterior facets, ``ds``). The weights sum to the region's measure.
    """
    mesh = V.mesh
    v = ufl.TestFunction(V)
    if mesh.topology.dim == 2:
        form = v("+")[0] * ufl.dS(domain=mesh, subdomain_data=facet_tags, subdomain_id=tag)
    else:
        form = v[0] * ufl.ds(domain=mesh, subdomain_data=facet_tags, subdomain_id=tag, degree=6)
    b = fem_petsc.assemble_vector(fem.form(form, jit_options=JIT))
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    bs = V.dofmap.index_map_bs
    return b.array[0::bs].copy()


def owned_nodes(V):
    """Global node (block) indices and coordinates of the owned nodes of V."""
    imap = V.dofmap.index_map
    n_owned = imap.size_local
    global_nodes = imap.local_to_global(np.arange(n_owned, dtype=np.int32))
    coords = V.tabulate_dof_coordinates()[:n_owned]
    return np.asarray(global_nodes, dtype=np.int64), np.asarray(coords)
