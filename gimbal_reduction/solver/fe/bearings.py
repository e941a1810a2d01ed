"""The bearing connection: a rigid-fit ("RBE3-like") average of a region's motion.

The thesis joins each bearing point to its body by "high stiffness rods". We
model the rods as rigid and the joint to the body as a *rigid-fit average*:
the bearing point's motion ``z = (u_b, th_b)`` is the rigid-body motion that
best fits, in the weighted least-squares sense, the motion of a small region
of the body (a ring's cross-section line across the band width, or a face
patch of the solid platform's rim):

    min_z  sum_k w_k |u_k - u_b - th_b x r_k|^2  +  L^2 sum_k w_k |P_k (th_k - th_b)|^2

with ``r_k = x_k - x_b``, ``w_k`` the integration weight of node k on the
region (so the fit is an integral, independent of the mesh), and the second
sum only where nodes carry rotations (shells; ``L`` is a length that weighs
rotations against translations). ``P_k = I - n_k n_k^T`` keeps only the
shell's bending rotations: the rotation about the normal (the drilling
rotation) is a penalty quantity whose value depends on the mesh, so it must
not enter the fit; the rotation about the normal comes from the translations
along the region instead (a line across the band determines it). Setting the
gradient to zero gives the linear operator ``z = R u``: a (6, ndof) matrix
that reproduces any rigid motion exactly and adds no stiffness.

Because it constrains (or loads) an *integral* of the field over a line or a
face, not a single node, it is well posed under mesh refinement, unlike a
single-node support whose frequency falls without limit. The same operator
serves three purposes:

* supports: rows of ``R`` held at zero, ``C u = 0`` (see :func:`admissible_basis`);
* loads: a force/moment f at the bearing acts as nodal loads ``R^T f``;
* the eccentric point mass: it moves with the translation rows ``R_t`` of the
  fit at its own position, kinetic energy ``1/2 m |R_t u_dot|^2``.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.sparse as sp

from gimbal_reduction.solver.bodydata import skew


def rigid_fit_operator(nodes: np.ndarray, coords: np.ndarray, weights: np.ndarray,
                       point: np.ndarray, block_size: int, ndof: int,
                       rotation_length: float, normals: np.ndarray | None = None) -> sp.csr_matrix:
    """(6, ndof) operator R mapping the DOF vector to the rigid-fit motion at ``point``.

    nodes: (k,) global node indices of the region (DOF = node * block_size + component);
    coords: (k, 3) node positions, in; weights: (k,) integration weights (>= 0);
    block_size: 3 (translations) or 6 (translations + rotations);
    normals: (k, 3) unit shell normals at the nodes (block_size 6; None: use all
    three rotation components).
    Rows of R: u_x, u_y, u_z (in), th_x, th_y, th_z (rad) of the bearing point.
    """
    nodes, weights = np.asarray(nodes), np.asarray(weights, dtype=float)
    if len(nodes) == 0 or not np.all(weights >= 0) or weights.sum() <= 0:
        raise ValueError("bearing region is empty or has no positive weight (is it meshed?)")
    r = np.asarray(coords, dtype=float) - np.asarray(point, dtype=float)
    # A_k = [I, -[r_k]x]: rigid motion (u_b, th_b) evaluated at node k
    A = np.zeros((len(nodes), 3, 6))
    A[:, :, :3] = np.eye(3)
    A[:, :, 3:] = -skew(r)
    normal = np.einsum("k,kia,kib->ab", weights, A, A)
    rotational = block_size == 6
    if rotational:
        if normals is None:
            tangential = np.broadcast_to(np.eye(3), (len(nodes), 3, 3))
        else:
            normals = np.asarray(normals, dtype=float)
            tangential = np.eye(3) - np.einsum("ki,kj->kij", normals, normals)
        normal[3:, 3:] += rotation_length**2 * np.einsum("k,kij->ij", weights, tangential)
    if np.linalg.cond(normal) > 1e12:
        raise ValueError("bearing region cannot determine a rigid motion (degenerate region)")
    normal_inv = np.linalg.inv(normal)
    # coefficient blocks: translations N^-1 w_k A_k^T, rotations N^-1 w_k L^2 B_k^T
    blocks = [np.einsum("ab,k,kib->kai", normal_inv, weights, A)]  # (k, 6, 3)
    if rotational:
        blocks.append(rotation_length**2 * np.einsum("ab,k,kbc->kac", normal_inv[:, 3:], weights, tangential))
    coeff = np.concatenate(blocks, axis=2)  # (k, 6, block_size)
    cols = nodes[:, None] * block_size + np.arange(block_size)[None, :]  # (k, bs)
    rows = np.broadcast_to(np.arange(6)[None, :, None], coeff.shape)
    cols = np.broadcast_to(cols[:, None, :], coeff.shape)
    return sp.csr_matrix((coeff.ravel(), (rows.ravel(), cols.ravel())), shape=(6, ndof))


def support_constraints(operators: dict[str, sp.csr_matrix], motor: str = "input_motor",
                        resolver: str = "input_resolver") -> sp.csr_matrix:
    """(6, ndof) constraint matrix C of the thesis's supports, C u = 0.

    Motor side: u_y = u_z = th_x = 0 (u_x, th_y, th_z free);
    resolver side: u_x = u_y = u_z = 0 (rotations free).
    Together they remove exactly the six rigid-body motions.
    """
    return sp.vstack([operators[motor][[1, 2, 3]], operators[resolver][[0, 1, 2]]]).tocsr()


def admissible_basis(constraints: sp.csr_matrix) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eliminate one master DOF per constraint row: u_master = S u_slaves.

    Masters are chosen by QR with column pivoting on the (dense, small) block of
    C over the DOFs it touches. Returns ``(masters (c,), slaves (s,), S (c, s))``.
    The admissible displacements are then spanned by T with identity on every
    non-master DOF and rows S for the masters (:func:`admissible_basis_matrix`).
    """
    C = constraints.tocsr()
    touched = np.unique(C.tocoo().col)
    dense = C[:, touched].toarray()
    _, r, pivots = scipy.linalg.qr(dense, pivoting=True, mode="economic")
    rank = int(np.sum(np.abs(np.diag(r)) > 1e-12 * np.abs(r[0, 0])))
    if rank < dense.shape[0]:
        raise ValueError(f"support constraints are dependent (rank {rank} < {dense.shape[0]})")
    m = dense.shape[0]
    master_local, slave_local = pivots[:m], np.sort(pivots[m:])
    S = -np.linalg.solve(dense[:, master_local], dense[:, slave_local])
    return touched[master_local], touched[slave_local], S


def admissible_basis_matrix(masters, slaves, S, ndof: int) -> sp.csr_matrix:
    """(ndof, ndof - c) CSR matrix T: columns are the non-master DOFs in ascending order."""
    is_master = np.zeros(ndof, dtype=bool)
    is_master[masters] = True
    column = np.cumsum(~is_master) - 1  # column index of each non-master DOF
    free = np.flatnonzero(~is_master)
    rows = [free, np.repeat(masters, len(slaves))]
    cols = [column[free], np.tile(column[slaves], len(masters))]
    vals = [np.ones(len(free)), S.ravel()]
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(ndof, ndof - len(masters)))
