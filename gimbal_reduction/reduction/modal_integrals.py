"""Modal integrals of one elastic body, from its finite-element matrices.

Notation (thesis Chapter 3; units in, lbf, s; mass lbf s^2/in):

* ``ndof`` DOFs of the free (unsupported) FE model, ``m`` supported
  coordinates, ``D`` computed (kept) vibration modes.
* ``M``, ``K``: free mass and stiffness, scipy CSR ``(ndof, ndof)``.
* ``T``: CSR ``(ndof, m)`` spanning the admissible displacements; every
  supported mode is ``phi = T x`` with ``(T^T K T) x = lambda (T^T M T) x``.
  Supports given as constrained DOFs are the special case where every column
  of ``T`` is a unit vector.
* ``X``: ``(ndof, 6)`` rigid modes: unit translations along x, y, z, then unit
  rotations about x, y, z through the body origin (``rigid_modes``).
* ``modes``: ``(ndof, D)`` mass-normalised supported modes,
  ``modes^T M modes = I``; ``eigenvalues``: ``(D,)`` Omega^2 in (rad/s)^2.

Quantities:

* momentum coefficients ``[P_i; H_i] = X^T M phi_i`` (eqs 2.7-2.10, 3.4-3.11),
  ``P`` in sqrt(mass), ``H`` in sqrt(mass) in -- from the consistent FE mass
  matrix, not from lumped nodal masses;
* mode contribution ``Mbar_i = [P_i; H_i][P_i; H_i]^T`` (eq 3.32);
* ``M_rigid = X^T M X``: mass, first moment and inertia of the whole body
  (eq 3.25), what the multibody equations need as M_rr;
* ``M_inf``: the rigid mass "seen by the supported modes", chosen so that the
  discrete Hughes identity ``sum_i Mbar_i = M_inf`` holds exactly over all
  finite-frequency supported modes (see ``supported_rigid_mass``);
* ``MGM_inf = X^T M G M X`` with ``G = T (T^T K T)^-1 T^T`` the flexibility of
  the supported body (eqs 3.45, 3.49); ``sum_i Mbar_i / Omega_i^2 = MGM_inf``.

Why ``M_inf`` is not ``X^T M X``: with all finite modes ``Phi = T V``,
``V V^T = (T^T M T)^+`` and so ``sum_i Mbar_i = X^T M T (T^T M T)^+ T^T M X``,
the mass matrix of the M-orthogonal projection of X onto range(T).  It equals
``X_f^T M_ff X_f`` (the rigid mass of the free DOFs only) when T selects DOFs
*and* the mass does not couple free and constrained DOFs (lumped mass, or
constrained nodes without mass); with a consistent mass at a constrained node
the coupling terms ``M_fc X_c`` also enter.  ``M_rigid - M_inf`` (positive
semidefinite) is the mass that the supports hold.

Massless directions: for shells the drilling rotation has no inertia, so
``T^T M T`` is singular (infinite-frequency "modes") or, for faceted shells,
nearly so.  Massless directions carry no momentum (``M T x = 0`` implies
``X^T M T x = 0``), the sum runs over the finite modes only, and
``(T^T M T)^+`` is applied as follows: block-local null vectors are found
exactly from small diagonal blocks (a vector supported on one block with zero
block energy is a null vector of a positive semidefinite matrix) and made
definite by adding ``s N N^T``; the rest (non-local or nearly massless
directions) by a tiny shift and iterative refinement until M_inf settles.
The solve is exact on range(T^T M T) because ``b = T^T M X`` lies in it,
orthogonal to every null vector (``supported_rigid_mass``).
"""

import numpy as np
import scipy.sparse as sp
import scipy.sparse.csgraph
import scipy.sparse.linalg

from gimbal_reduction.solver.bodydata import BEARING_NAMES, RIGID_MOTION_NAMES
from gimbal_reduction.reduction.errors import (
    BearingIndexError,
    ModeCountError,
    MissingBearingError,
    ReductionError,
    SingularMassError,
    SingularStiffnessError,
)

def momentum_coefficients(M, X, modes):
    """Linear and angular momentum coefficients of every mode (eq 3.11).

    M (ndof, ndof) sparse; X (ndof, 6); modes (ndof, D) or (ndof,).
    Returns P (3, D) and H (3, D) (or (3,), (3,) for one mode vector):
    ``[P; H] = X^T M modes``.
    """
    modes = np.asarray(modes, dtype=float)
    PH = np.asarray(X).T @ np.asarray(M @ modes)
    return PH[:3], PH[3:]


def mode_contributions(P, H):
    """Mbar_i = [P_i; H_i][P_i; H_i]^T for every mode: P, H (3, D) -> (D, 6, 6)."""
    v = np.vstack([np.atleast_2d(np.asarray(P).T).T, np.atleast_2d(np.asarray(H).T).T]).T  # (D, 6)
    return v[:, :, None] * v[:, None, :]


def rigid_mass(M, X):
    """M_rigid = X^T M X (6, 6): [[m I, -c~], [c~, J]] of the whole free body (eq 3.25)."""
    A = np.asarray(X).T @ np.asarray(M @ X)
    return 0.5 * (A + A.T)


def node_index(dof_coords, decimals=9):
    """Node number of every DOF (ndof,) int: DOFs at the same point share a node."""
    coords = np.round(np.asarray(dof_coords, dtype=float), decimals)
    _, inverse = np.unique(coords, axis=0, return_inverse=True)
    return inverse.ravel()


def supported_column_groups(T, dof_node=None):
    """Group the columns of T (m,) int: columns that move a common node are connected.

    For constrained-DOF supports a group is the free DOFs of one node; for
    multi-point supports (rigid links, rigid-fit connections) a group joins
    the nodes that the constraint ties together.  ``dof_node`` (ndof,) int
    (``node_index``); None treats every DOF as its own node.
    """
    T = sp.csr_matrix(T)
    ndof, m = T.shape
    if dof_node is None:
        dof_node = np.arange(ndof)
    dof_node = np.asarray(dof_node)
    n_nodes = int(dof_node.max()) + 1 if ndof else 0
    incidence = sp.csr_matrix(
        (np.ones(ndof), (dof_node, np.arange(ndof))), shape=(n_nodes, ndof))
    touches = (incidence @ abs(T)).tocsc()
    touches.data[:] = 1.0
    adjacency = (touches.T @ touches).tocsr()
    _, labels = scipy.sparse.csgraph.connected_components(adjacency, directed=False)
    return labels


def massless_directions(Mt, groups, rtol=1e-10, atol_factor=1e-13, max_group_size=2000):
    """Orthonormal null vectors of the positive semidefinite Mt (m, m), block by block.

    ``groups`` (m,) int labels (``supported_column_groups``).  For each group
    the dense diagonal block is decomposed; eigenvalues below
    ``max(rtol * largest eigenvalue of the block, atol_factor * max diag(Mt))``
    are taken as massless.  Every vector returned is an exact null vector of
    Mt up to that tolerance.  Groups larger than ``max_group_size`` are not
    analysed.  Returns CSR (m, n_null).
    """
    Mt = sp.coo_matrix(Mt)
    m = Mt.shape[0]
    groups = np.asarray(groups)
    order = np.argsort(groups, kind="stable")
    sorted_groups = groups[order]
    starts = np.flatnonzero(np.r_[True, sorted_groups[1:] != sorted_groups[:-1]])
    sizes = np.diff(np.r_[starts, m])
    local = np.empty(m, dtype=int)
    local[order] = np.arange(m) - np.repeat(starts, sizes)
    group_of_label = np.empty(int(groups.max()) + 1 if m else 0, dtype=int)
    group_of_label[sorted_groups[starts]] = np.arange(starts.size)
    gid = group_of_label[groups]  # dense group number 0..G-1 of each column

    diag = Mt.diagonal()
    atol = atol_factor * (np.max(np.abs(diag)) if m else 0.0)
    same = gid[Mt.row] == gid[Mt.col]
    r, c, v = Mt.row[same], Mt.col[same], Mt.data[same]

    null_rows, null_cols, null_vals = [], [], []
    n_null = 0
    for size in np.unique(sizes):
        if size > max_group_size:
            continue
        gids = np.flatnonzero(sizes == size)
        slot = np.full(starts.size, -1)
        slot[gids] = np.arange(gids.size)
        blocks = np.zeros((gids.size, size, size))
        pick = slot[gid[r]] >= 0
        np.add.at(blocks, (slot[gid[r[pick]]], local[r[pick]], local[c[pick]]), v[pick])
        blocks = 0.5 * (blocks + blocks.transpose(0, 2, 1))
        w, vec = np.linalg.eigh(blocks)
        threshold = np.maximum(rtol * np.max(np.abs(w), axis=1), atol)
        b_idx, k_idx = np.nonzero(w <= threshold[:, None])
        for b, k in zip(b_idx, k_idx):
            cols = order[starts[gids[b]]:starts[gids[b]] + size]
            null_rows.append(cols)
            null_cols.append(np.full(size, n_null))
            null_vals.append(vec[b, :, k])
            n_null += 1
    if n_null == 0:
        return sp.csr_matrix((m, 0))
    N = sp.csr_matrix(
        (np.concatenate(null_vals), (np.concatenate(null_rows), np.concatenate(null_cols))),
        shape=(m, n_null))
    N.eliminate_zeros()
    return N


def _sparse_solver(A, what):
    """LU of the sparse square A (symmetric ordering); raises on exact singularity."""
    try:
        lu = scipy.sparse.linalg.splu(
            sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
            options={"SymmetricMode": True})
    except RuntimeError as exc:
        raise SingularStiffnessError(f"{what} is singular ({exc})") from None
    return lu


def supported_rigid_mass(M, T, X, dof_node=None, return_details=False, residual_tol=1e-6,
                         converged_tol=1e-14, max_refinements=60):
    """M_inf (6, 6) consistent with the supports: X^T M T (T^T M T)^+ T^T M X.

    This is the matrix for which sum_i Mbar_i = M_inf holds exactly over all
    finite-frequency supported modes (module docstring), also when T^T M T is
    singular (massless drilling rotations of shells).

    Method: b = T^T M X lies in range(T^T M T) = null(T^T M T)^perp, so any z
    with (T^T M T) z = b gives M_inf = b^T z.  Block-local null vectors N
    (``massless_directions`` on the groups of ``supported_column_groups``;
    ``dof_node`` (ndof,) from ``node_index``) are made definite exactly by
    adding s N N^T; null vectors that are not block-local (e.g. drilling
    rotations tied together by a point mass that moves with a region's
    rigid-fit motion) and nearly massless directions (drilling rotations of a
    faceted shell, whose facets' normals differ at a node) are handled by a
    small shift delta I and iterative refinement on the residual
    b - (T^T M T) z, which converges to the exact solution on
    range(T^T M T); the shift's null-space components do not reach b^T z.
    Refinement stops when M_inf changes by less than ``converged_tol`` (relative
    to its largest entry).  The residual is reported; it need not vanish --
    roundoff leaves b a tiny component along directions with roundoff-level
    (even slightly negative) mass, which cannot be matched and carry no
    momentum -- but one above ``residual_tol`` raises SingularMassError.

    With ``return_details`` also returns a dict: ``n_massless_local`` (block-
    local null vectors), ``refinements``, ``last_change`` (relative change of
    M_inf in the last step) and ``relative_residual``.
    """
    T = sp.csr_matrix(T)
    Mt = (T.T @ M @ T).tocsr()
    Mt = 0.5 * (Mt + Mt.T)
    b = np.asarray(T.T @ (M @ X))
    b_norm = max(np.linalg.norm(b), np.finfo(float).tiny)
    groups = supported_column_groups(T, dof_node)
    N = massless_directions(Mt, groups)
    diag = np.abs(Mt.diagonal())
    shift = float(np.mean(diag)) if diag.size and np.mean(diag) > 0 else 1.0
    A = Mt + shift * (N @ N.T) if N.shape[1] else Mt
    delta = 1e-10 * shift
    try:
        lu = scipy.sparse.linalg.splu(
            sp.csc_matrix(A + delta * sp.identity(A.shape[0])), permc_spec="MMD_AT_PLUS_A",
            diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    except RuntimeError as exc:
        raise SingularMassError(f"cannot factorise T^T M T + shift ({exc})") from None
    z = lu.solve(b)
    M_inf = b.T @ z
    change, refinements = np.inf, 0
    while refinements < max_refinements and change > converged_tol:
        z = z + lu.solve(b - Mt @ z)
        updated = b.T @ z
        change = np.max(np.abs(updated - M_inf)) / max(np.max(np.abs(updated)), np.finfo(float).tiny)
        M_inf = updated
        refinements += 1
    residual = np.linalg.norm(b - Mt @ z) / b_norm
    if not np.all(np.isfinite(M_inf)) or change > 1e3 * converged_tol or residual > residual_tol:
        raise SingularMassError(
            f"T^T M T (with {N.shape[1]} block-local massless directions) could not be "
            f"inverted on its range: relative residual {residual:.2e}, last change of M_inf "
            f"{change:.1e} after {refinements} refinements")
    M_inf = 0.5 * (M_inf + M_inf.T)
    if return_details:
        return M_inf, {"n_massless_local": int(N.shape[1]), "refinements": int(refinements),
                       "last_change": float(change), "relative_residual": float(residual)}
    return M_inf


def check_supports(K, T, X, tol=1e-8):
    """Raise SingularStiffnessError if T^T K T is visibly singular (cheap checks).

    1. a zero diagonal entry of T^T K T (a supported coordinate without stiffness);
    2. a stress-free rigid motion X a (K X a = 0) that lies in range(T): the
       supports do not remove it.  Tested through the least-squares residual of
       X a in range(T), with X's columns scaled to unit length.
    """
    T = sp.csr_matrix(T)
    Kt_diag = np.asarray((T.multiply(K @ T)).sum(axis=0)).ravel()
    scale = np.max(np.abs(Kt_diag)) if Kt_diag.size else 0.0
    bad = np.flatnonzero(Kt_diag <= 1e-14 * scale)
    if scale <= 0.0 or bad.size:
        first = int(bad[0]) if bad.size else 0
        raise SingularStiffnessError(
            f"supported stiffness T^T K T has {bad.size if bad.size else T.shape[1]} zero or "
            f"negative diagonal entries (first: supported coordinate {first})")
    if X is None:
        return
    X = np.asarray(X, dtype=float)
    norms = np.linalg.norm(X, axis=0)
    Xs = X / np.where(norms > 0, norms, 1.0)
    TtT = (T.T @ T).tocsc()
    offdiag = TtT - sp.diags(TtT.diagonal())
    rhs = np.asarray(T.T @ Xs)
    if offdiag.nnz == 0 or abs(offdiag).max() == 0.0:
        y = rhs / TtT.diagonal()[:, None]
    else:
        y = scipy.sparse.linalg.splu(TtT, permc_spec="MMD_AT_PLUS_A").solve(rhs)
    R = Xs - T @ y
    w, V = np.linalg.eigh(R.T @ R)
    KXs = np.asarray(K @ Xs)
    k_scale = abs(K).max() if K.nnz else 1.0
    for j in range(6):
        if w[j] > tol ** 2:
            break
        a = V[:, j]
        if np.linalg.norm(KXs @ a) <= 1e-8 * k_scale * np.linalg.norm(Xs @ a):
            parts = " ".join(
                f"{a[i]:+.2f}*{RIGID_MOTION_NAMES[i]}" for i in np.argsort(-np.abs(a)) if abs(a[i]) > 0.1)
            raise SingularStiffnessError(
                f"supported stiffness T^T K T is singular: the supports leave the rigid motion "
                f"{parts} free (missing supports)")


def supported_flexibility(K, T, X=None, pivot_ratio_tol=1e-15, refinements=2):
    """Factorise T^T K T once; return apply_G(F) = T (T^T K T)^-1 T^T F.

    K (ndof, ndof) free stiffness, T (ndof, m), X (ndof, 6) optional rigid
    modes for the missing-support check (``check_supports``, done first).
    ``apply_G`` maps loads F (ndof,) or (ndof, k) [lbf, in lbf] to static
    displacements of the supported body (same shape) [in, rad]: the G of eq
    3.49 for multi-point supports.  Uses a sparse LU, never a dense inverse,
    and ``refinements`` steps of iterative refinement per solve.
    """
    T = sp.csr_matrix(T)
    check_supports(K, T, X)
    Kt = (T.T @ K @ T).tocsc()
    Kt = 0.5 * (Kt + Kt.T)
    lu = _sparse_solver(Kt, "supported stiffness T^T K T")
    pivots = np.abs(lu.U.diagonal())
    if pivots.size and pivots.min() <= pivot_ratio_tol * pivots.max():
        raise SingularStiffnessError(
            f"supported stiffness T^T K T is numerically singular (smallest/largest LU pivot "
            f"{pivots.min() / pivots.max():.1e}; missing supports?)")

    def apply_G(F):
        F = np.asarray(F, dtype=float)
        rhs = np.asarray(T.T @ F)
        z = lu.solve(rhs)
        for _ in range(refinements):  # iterative refinement: stiff bodies are ill-conditioned
            z += lu.solve(rhs - Kt @ z)
        return T @ z

    apply_G.admissible_basis = T  # for load checks (static_modes.static_correction_modes)
    return apply_G


def flexibility_matrix(M, X, apply_G):
    """MGM_inf = X^T M G M X (6, 6) [mass^2 / stiffness] (eqs 3.45, 3.46)."""
    MX = np.asarray(M @ X)
    A = MX.T @ apply_G(MX)
    return 0.5 * (A + A.T)


def inside_frame_motion(bearing_motion, bearing_points, motor=2, resolver=3):
    """Elastic motion of the inside frame from the output bearings (thesis PSI, THT).

    bearing_motion (..., 4, 6): per bearing the rigid-fit (u_x, u_y, u_z,
    th_x, th_y, th_z) [in, rad] (``bearing_modes`` of the body file, or
    ``bearing_operator @ phi`` reshaped); bearing_points (4, 3) [in].
    With p_m, p_r the output motor and resolver points, d = |p_m - p_r| and the
    bearing axis e = (p_m - p_r) / d:

    * ``theta`` (..., 3): rotation of the inside frame,
      ``e (e . th_m) + e x (u_m - u_r) / d`` -- about the axis from the motor's
      rotation (the motor holds the next body's drive angle), perpendicular to
      it from the relative translation of the two bearings.  For bearings on
      +z/-z this is the thesis's thetaX = (u_ry - u_my)/d,
      thetaY = (u_mx - u_rx)/d, thetaZ = th_mz (Appendix A.2).
    * ``psi_midpoint`` (..., 3): translation at the midpoint, (u_m + u_r) / 2.
    * ``psi`` (..., 3): translation of the inside frame: ``psi_midpoint`` with
      its axial component taken from the resolver alone (thesis A.2,
      PSI(3) = outResZTrans): the next body's motor bearing slides axially and
      its resolver holds it, so the next body follows the resolver along e.
    * ``stretch`` (...,): e . (u_m - u_r), the elastic change of the bearing
      distance (thesis outDiam minus the nominal distance).
    * ``origin_translation`` (..., 3): the frame's translation at the body
      origin, ``u_r - theta x p_r`` (the multibody equations' Psi).

    For a rigid motion u(p) = t + w x p, th = w: theta = w and
    psi = psi_midpoint = t + w x (p_m + p_r) / 2, stretch = 0.
    Raises MissingBearingError if a bearing point is not finite (platform).
    """
    points = np.asarray(bearing_points, dtype=float)
    for b in (motor, resolver):
        if not (0 <= b < points.shape[0]):
            raise BearingIndexError(f"bearing index {b} outside 0..{points.shape[0] - 1}")
        if not np.all(np.isfinite(points[b])):
            raise MissingBearingError(
                f"bearing {b} ({BEARING_NAMES[b]}) has no point (platform has no output bearings)")
    motion = np.asarray(bearing_motion, dtype=float)
    u_m, th_m = motion[..., motor, :3], motion[..., motor, 3:]
    u_r = motion[..., resolver, :3]
    delta = points[motor] - points[resolver]
    d = float(np.linalg.norm(delta))
    if d == 0.0:
        raise ReductionError(f"bearings {motor} and {resolver} coincide")
    e = delta / d
    theta = e * (th_m @ e)[..., None] + np.cross(e, u_m - u_r) / d
    psi_mid = 0.5 * (u_m + u_r)
    stretch = (u_m - u_r) @ e
    psi = psi_mid - 0.5 * stretch[..., None] * e
    # the frame's translation at the body origin: the rigid motion t + theta x p that
    # matches the resolver (equal to psi when the bearings' midpoint is the origin)
    origin = u_r - np.cross(theta, points[resolver])
    return {"psi": psi, "theta": theta, "psi_midpoint": psi_mid, "stretch": stretch,
            "origin_translation": origin, "axis": e, "distance": d}


def check_mode_count(n, available, what="modes"):
    """Raise ModeCountError unless 0 <= n <= available (int)."""
    if int(n) != n or n < 0 or n > available:
        raise ModeCountError(f"{what}: asked for {n}, only {available} computed")
    return int(n)


# ---------------------------------------------------------------------------
# The further modal integrals of the multibody equations (docs/dynamics.md)
# ---------------------------------------------------------------------------
"""The multibody equations' modal integrals (beyond P, H and X^T M X).

Everything here is a pure function of one body's finite-element data (the
contract of ``docs/body-data.md``) and serves every body alike (rings with
shell DOFs, the solid platform with translations only).  The derivation that
says *why* these integrals and no others is ``docs/dynamics.md``; the symbols
below are the ones used there.

Notation (units in, lbf, s; mass lbf s^2/in):

* ``ndof`` FE DOFs, grouped in 3-blocks: the translation (u_x, u_y, u_z) or the
  rotation (th_x, th_y, th_z) of one node (``dof_coords``, ``dof_component``).
* ``M`` (ndof, ndof): the consistent (not lumped) free mass matrix, CSR.
* ``X`` (ndof, 6): rigid modes, unit translations then unit rotations about
  the body origin (``rigid_modes``); ``X w`` is the nodal motion of the rigid
  twist ``w = [v; omega]``.
* ``Phi`` (ndof, D): the kept modes, M-orthonormal (``Phi^T M Phi = I``).
* ``Ut[:, b, i]`` (ndof, 3, D): the *rotation action* of mode i: the nodal
  vector ``Ut[:, :, i] @ omega`` holds, in every 3-block, ``omega x phi_i`` (the
  block of mode i turned by the frame rotation omega).  Whether rotation blocks
  take part is ``rotate_rotation_blocks`` (default True, see below).

Modal integrals of one body (all from M, X, Phi; nothing lumped):

=====================  ==========  ===========================================
name                   shape       definition
=====================  ==========  ===========================================
``rigid_mass``         (6, 6)      ``X^T M X`` = [[m I, -skew(c)], [skew(c), J]]
``momentum``           (6, D)      ``X^T M Phi`` = [P; H] (thesis eq 3.11)
``inertia_gradient``   (D, 6, 6)   ``dM_X/dq_i`` = [[0, Y_iv^T], [Y_iv, Y_iw + Y_iw^T]],
                                   ``Y_i = Ut_i^T M X`` (3, 6) = [Y_iv | Y_iw]
``coriolis``           (D, 3, D)   ``G_j = Ut_j^T M Phi``: ``coriolis[j, :, i]``
=====================  ==========  ===========================================

For a lumped, isotropic translational mass these reduce to the familiar
invariants: ``Y_iv = skew(P_i)``, ``Y_iw = -sum_k m_k skew(phi_ik) skew(r_k)``
and ``G_j[:, i] = sum_k m_k phi_jk x phi_ik``; with a consistent mass the
sums run over every pair of coupled nodes, which the matrix products do.

How the frame rotation acts on rotation blocks (``rotate_rotation_blocks``):
the body's kinetic energy is built from each 3-block's velocity seen in the
rotating body frame.  A translation block moves with the node: its velocity
is ``v + omega x (r + u) + du/dt``.  A rotation block carries the node's
rotary inertia (shells: rho t^3/12 about the two in-surface axes, none about
the drilling axis): the node's triad is turned by the small rotation theta,
so its angular velocity in the node's own axes is
``E(theta)^T (omega + dtheta/dt) = omega + dtheta/dt + omega x theta`` to first
order, and it is in the node's own axes that the FE rotary inertia (with its
massless drilling direction) is constant.  So the frame rotation acts on every
3-block alike: "each 3-block is a vector rotated with the body" (default).
``rotate_rotation_blocks=False`` keeps the rotary inertia fixed in the body
axes instead (omega acts on translation blocks only); the two differ by
terms of relative size (t^2/12)/r^2 * theta, ~1e-3 of an already first-order
term, and both give the same X^T M X, P and H.
"""

# Levi-Civita symbol as the list of its non-zero entries (a, b, c, sign):
# (omega x phi)_a = sum_{b,c} eps_abc omega_b phi_c.
_EPSILON = ((0, 1, 2, 1.0), (0, 2, 1, -1.0), (1, 2, 0, 1.0),
            (1, 0, 2, -1.0), (2, 0, 1, 1.0), (2, 1, 0, -1.0))


def dof_blocks(dof_coords, dof_component, decimals=9):
    """Sibling table of the 3-blocks: siblings (ndof, 3) int, siblings[d, c] is the
    DOF of the same node and kind (translation/rotation) as d with axis c
    (-1 if the FE model has no such DOF, which makes that component zero)."""
    coords = np.round(np.asarray(dof_coords, float), decimals)
    comp = np.asarray(dof_component, int)
    if comp.min(initial=0) < 0 or comp.max(initial=0) > 5:
        raise ValueError("dof_component must lie in 0..5")
    _, node = np.unique(coords, axis=0, return_inverse=True)
    node = node.ravel()
    block = 2 * node + comp // 3            # one id per (node, kind)
    table = -np.ones((2 * (node.max() + 1), 3), dtype=int)
    table[block, comp % 3] = np.arange(comp.size)
    if np.unique(block * 3 + comp % 3).size != comp.size:
        raise ValueError("two DOFs share the same node, kind and axis")
    return table[block]


def rotation_action(modes, dof_coords, dof_component, rotate_rotation_blocks=True):
    """Ut (ndof, 3, D): ``Ut[:, :, i] @ omega`` is ``omega x phi_i`` in every 3-block.

    modes (ndof, D) [in/sqrt(mass)]; rotation blocks take part unless
    ``rotate_rotation_blocks`` is False (module docstring)."""
    Phi = np.asarray(modes, float)
    if Phi.ndim == 1:
        Phi = Phi[:, None]
    comp = np.asarray(dof_component, int)
    siblings = dof_blocks(dof_coords, comp)
    axis = comp % 3
    active = np.ones(comp.size, bool) if rotate_rotation_blocks else comp < 3
    padded = np.vstack([Phi, np.zeros((1, Phi.shape[1]))])    # index -1 -> zero row
    Ut = np.zeros((comp.size, 3, Phi.shape[1]))
    for a, b, c, sign in _EPSILON:          # (omega x phi)_a = eps_abc omega_b phi_c
        rows = np.flatnonzero(active & (axis == a))
        Ut[rows, b, :] += sign * padded[siblings[rows, c]]
    return Ut


def inertia_gradient(M, X, Ut):
    """dM_X/dq_i (D, 6, 6) with M_X(q) = X^T M X + sum_i q_i dM_X/dq_i.

    From the energy term omega . (sum_i q_i Y_i) w, Y_i = Ut_i^T M X (3, 6):
    its symmetric 6x6 form is [[0, Y_iv^T], [Y_iv, Y_iw + Y_iw^T]]."""
    MX = np.asarray(M @ X)
    Y = np.einsum("dbi,dk->ibk", Ut, MX)                 # (D, 3, 6)
    D = Ut.shape[2]
    grad = np.zeros((D, 6, 6))
    grad[:, 3:, :3] = Y[:, :, :3]
    grad[:, :3, 3:] = np.transpose(Y[:, :, :3], (0, 2, 1))
    grad[:, 3:, 3:] = Y[:, :, 3:] + np.transpose(Y[:, :, 3:], (0, 2, 1))
    return grad


def coriolis_coefficients(M, modes, Ut):
    """G (D, 3, D), G[j, :, i] = (Ut_j^T M phi_i): the energy term
    omega . (sum_j q_j G_j) dq/dt couples the modes through the frame rotation
    (the modal gyroscopic coupling; antisymmetric in i, j for isotropic mass)."""
    ndof, _, D = Ut.shape
    MPhi = np.asarray(M @ modes)
    G = Ut.reshape(ndof, 3 * D).T @ MPhi                  # ((b, j), i)
    return np.ascontiguousarray(G.reshape(3, D, D).transpose(1, 0, 2))


def chain_integrals(M, modes, rigid_modes, dof_coords, dof_component, bearing_modes=None,
                    bearing_points=None, rotate_rotation_blocks=True):
    """Every modal integral the multibody equations need, for one body.

    M (ndof, ndof) CSR consistent mass; modes (ndof, D) M-orthonormal;
    rigid_modes (ndof, 6); dof_coords (ndof, 3); dof_component (ndof,);
    bearing_modes (D, 4, 6) and bearing_points (4, 3) give the inside frame
    (omit them, or give NaN output bearings, for the terminal body).
    Returns a dict of arrays: rigid_mass (6, 6), momentum (6, D) = [P; H],
    inertia_gradient (D, 6, 6), coriolis (D, 3, D), and, if the body has
    output bearings, inside_translation (3, D) (the inside frame's elastic
    translation at the body origin) and inside_rotation (3, D).
    """
    M = sp.csr_matrix(M)
    Phi = np.asarray(modes, float)
    X = np.asarray(rigid_modes, float)
    Ut = rotation_action(Phi, dof_coords, dof_component, rotate_rotation_blocks)
    out = {
        "rigid_mass": rigid_mass(M, X),
        "momentum": np.vstack(momentum_coefficients(M, X, Phi)),
        "inertia_gradient": inertia_gradient(M, X, Ut),
        "coriolis": coriolis_coefficients(M, Phi, Ut),
    }
    if bearing_points is not None and bearing_modes is not None:
        pts = np.asarray(bearing_points, float)
        if np.all(np.isfinite(pts[[2, 3]])):
            frame = inside_frame_motion(bearing_modes, pts)
            out["inside_translation"] = np.ascontiguousarray(frame["origin_translation"].T)
            out["inside_rotation"] = np.ascontiguousarray(frame["theta"].T)
    return out
