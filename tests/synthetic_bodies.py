"""Small FE-like elastic bodies in the body-file layout, for tests of any stage.

Everything here is independent of the project's packages (numpy, scipy, h5py
only), so tests that use it check the code under test against an independent
construction.  Units: in, lbf, s (mass lbf s^2/in).

Building blocks
---------------
* ``beam_element(p1, p2, section, ...)``: 3D Euler-Bernoulli beam, 12 DOFs
  (u_x, u_y, u_z, th_x, th_y, th_z at each end, global axes), stiffness and
  consistent mass.
* ``assemble(n_nodes, elements)``: global CSR (6 n_nodes, 6 n_nodes) from a
  list of (node_i, node_j, Ke, Me).
* ``node_dofs(nodes)``: ``dof_coords`` (ndof, 3) and ``dof_component``
  (ndof,) in the node-major layout 6 k + c.
* ``rigid_basis(dof_coords, dof_component)``: X (ndof, 6).
* ``selection_basis(ndof, constrained)``: T for constrained-DOF supports.
* ``constraint_basis(C, preferred)``: sparse T spanning null(C) for linear
  multi-point constraints C u = 0 (rigid links, skew supports), by
  Gauss-Jordan elimination of one slave DOF per constraint.
* ``supported_modes(K, M, T, n_modes)``: dense generalised eigenproblem
  (T^T K T) x = lambda (T^T M T) x, mass-normalised modes phi = T x, ascending;
  uses the K-inner product so that a singular T^T M T (massless rotations)
  works: only the finite-frequency modes are returned.

Bodies
------
* ``ring_body(...)``: a gimbal-like ring of beam elements in the local x-z
  plane (axis y) with four bearing nodes on the local axes (input motor,
  input resolver on x; output motor, output resolver on z), joined to the
  ring by stiff rods (``connection="rods"``: bearing nodes, supports on
  their DOFs, a selection T), by rigid links eliminated in T
  (``connection="rigid_links"``: a multi-point T), or -- like the FE stage --
  with no bearing nodes, each bearing a rigid-fit ("RBE3-like") average of the
  three ring nodes at its angle, supports holding rows of that fit
  (``connection="rigid_fit"``: a multi-point T).  The eccentric point mass
  (10 % at 45 degrees) sits on one node (``eccentric="node"``) or moves with
  the rigid-fit translation of three nodes (``eccentric="rigid_fit"``, which
  ties their massless rotations together); supports as in the thesis (motor
  side u_y = u_z = th_x = 0, resolver side u_x = u_y = u_z = 0).  Mass models:
  ``"consistent"`` (beam consistent mass with polar inertia), ``"lumped"``
  (translational masses only: every rotation massless), ``"shell_like"``
  (lumped translations plus rotary inertia about the tangent and the ring
  axis but none about the radial direction -- the drilling rotation of a
  band-shaped shell, massless in an oblique direction), ``"consistent_no_polar"``
  (consistent mass without the torsional inertia: at a node the two elements'
  axes differ, so the rotation about the tangent is *nearly* massless -- like
  the drilling rotation of a faceted shell).
  ``output_bearings=False`` gives a platform-like body (bearing rows 2, 3 NaN).
* ``band_body(n_circ, n_width, ...)``: a large shell-like band (a beam grid
  on the ring's mid-surface, rigid-fit bearings, 100 modes from sparse
  Lanczos) at the real bodies' size (20k-60k DOFs), for timing.
* ``rigid_fit_operator(nodes, positions, point, ndof)``: the (6, ndof)
  least-squares rigid motion of a region (bearing connection, eccentric mass).
* ``permute_dofs(body, perm)``, ``scale_density(body, factor)``: the same
  body renumbered / with scaled density (invariance tests).
* ``grounded_masses(masses, positions, stiffnesses)``: point masses with
  3 translational DOFs each, tied to ground by isotropic springs (T = I): the
  hand-checkable model (modes e_d / sqrt(m_n), Omega^2 = k_n / m_n).
* ``body_dict(...)`` and ``write_body_file(path, body)``: a body dict in the
  layout of docs/body-data.md and its HDF5 file.
"""

import json

import h5py
import numpy as np
import scipy.linalg
import scipy.sparse as sp

from gimbal_reduction.solver.bodydata import write_csr

E_STEEL_LIKE = 3.0e8  # lbf/in^2 (the project's material)
NU = 0.3
RHO = 0.0026 / 12.0  # lbf s^2/in^4


def rect_section(width, thickness):
    """Section of a rectangular band: area, I about local y, I about local z, J, polar.

    Local axes of ``beam_element``: y along ``width``, z along ``thickness``.
    """
    b, t = max(width, thickness), min(width, thickness)
    J = b * t ** 3 * (1.0 / 3.0 - 0.21 * t / b * (1.0 - t ** 4 / (12.0 * b ** 4)))
    A = width * thickness
    Iy = width * thickness ** 3 / 12.0  # bending with deflection along local z
    Iz = thickness * width ** 3 / 12.0  # bending with deflection along local y
    return {"A": A, "Iy": Iy, "Iz": Iz, "J": J, "Ip": Iy + Iz}


def beam_element(p1, p2, section, E=E_STEEL_LIKE, nu=NU, rho=RHO, up=(0.0, 1.0, 0.0),
                 polar_inertia=True, mass=True):
    """Global stiffness and consistent mass (12, 12) of a 3D Euler-Bernoulli beam.

    Local x from p1 to p2, local y = ``up`` made orthogonal to x, z = x cross y.
    """
    p1, p2 = np.asarray(p1, float), np.asarray(p2, float)
    L = np.linalg.norm(p2 - p1)
    ex = (p2 - p1) / L
    ey = np.asarray(up, float) - np.dot(up, ex) * ex
    if np.linalg.norm(ey) < 1e-8:
        ey = np.cross(ex, [1.0, 0.0, 0.0])
        if np.linalg.norm(ey) < 1e-8:
            ey = np.cross(ex, [0.0, 0.0, 1.0])
    ey /= np.linalg.norm(ey)
    ez = np.cross(ex, ey)
    R = np.vstack([ex, ey, ez])
    G = E / (2.0 * (1.0 + nu))
    A, Iy, Iz, J, Ip = (section[k] for k in ("A", "Iy", "Iz", "J", "Ip"))

    k = np.zeros((12, 12))
    k[0, 0] = k[6, 6] = E * A / L
    k[0, 6] = -E * A / L
    k[3, 3] = k[9, 9] = G * J / L
    k[3, 9] = -G * J / L
    # deflection v (local y) with rotation th_z, inertia Iz
    a = E * Iz / L ** 3
    k[1, 1] = k[7, 7] = 12 * a
    k[1, 7] = -12 * a
    k[1, 5] = k[1, 11] = 6 * a * L
    k[5, 7] = k[7, 11] = -6 * a * L
    k[5, 5] = k[11, 11] = 4 * a * L ** 2
    k[5, 11] = 2 * a * L ** 2
    # deflection w (local z) with rotation th_y, inertia Iy
    a = E * Iy / L ** 3
    k[2, 2] = k[8, 8] = 12 * a
    k[2, 8] = -12 * a
    k[2, 4] = k[2, 10] = -6 * a * L
    k[4, 8] = k[8, 10] = 6 * a * L
    k[4, 4] = k[10, 10] = 4 * a * L ** 2
    k[4, 10] = 2 * a * L ** 2
    k = np.triu(k) + np.triu(k, 1).T

    m = np.zeros((12, 12))
    if mass:
        c = rho * A * L / 420.0
        m[0, 0] = m[6, 6] = 140 * c
        m[0, 6] = 70 * c
        if polar_inertia:
            m[3, 3] = m[9, 9] = rho * Ip * L / 3.0
            m[3, 9] = rho * Ip * L / 6.0
        m[1, 1] = m[7, 7] = 156 * c
        m[1, 7] = 54 * c
        m[1, 5] = 22 * L * c
        m[1, 11] = -13 * L * c
        m[5, 7] = 13 * L * c
        m[7, 11] = -22 * L * c
        m[5, 5] = m[11, 11] = 4 * L ** 2 * c
        m[5, 11] = -3 * L ** 2 * c
        m[2, 2] = m[8, 8] = 156 * c
        m[2, 8] = 54 * c
        m[2, 4] = -22 * L * c
        m[2, 10] = 13 * L * c
        m[4, 8] = -13 * L * c
        m[8, 10] = 22 * L * c
        m[4, 4] = m[10, 10] = 4 * L ** 2 * c
        m[4, 10] = -3 * L ** 2 * c
        m = np.triu(m) + np.triu(m, 1).T

    Lam = scipy.linalg.block_diag(R, R, R, R)
    return Lam.T @ k @ Lam, Lam.T @ m @ Lam


def assemble(n_nodes, elements):
    """Global K, M (CSR, 6 n_nodes square) from [(i, j, Ke (12,12), Me (12,12)), ...]."""
    rows, cols, kv, mv = [], [], [], []
    for i, j, Ke, Me in elements:
        dofs = np.r_[6 * i:6 * i + 6, 6 * j:6 * j + 6]
        rr, cc = np.meshgrid(dofs, dofs, indexing="ij")
        rows.append(rr.ravel())
        cols.append(cc.ravel())
        kv.append(np.asarray(Ke).ravel())
        mv.append(np.asarray(Me).ravel())
    n = 6 * n_nodes
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    K = sp.csr_matrix((np.concatenate(kv), (rows, cols)), shape=(n, n))
    M = sp.csr_matrix((np.concatenate(mv), (rows, cols)), shape=(n, n))
    K.sum_duplicates()
    M.sum_duplicates()
    return K, M


def node_dofs(nodes):
    """dof_coords (6N, 3) and dof_component (6N,) for 6 DOFs per node, node-major."""
    nodes = np.asarray(nodes, float)
    return np.repeat(nodes, 6, axis=0), np.tile(np.arange(6), nodes.shape[0])


def rigid_basis(dof_coords, dof_component):
    """X (ndof, 6): unit translations x, y, z; unit rotations about x, y, z at the origin."""
    X = np.zeros((len(dof_component), 6))
    for d, (r, c) in enumerate(zip(np.asarray(dof_coords, float), dof_component)):
        if c < 3:
            X[d, c] = 1.0
            for a in range(3):
                X[d, 3 + a] = np.cross(np.eye(3)[a], r)[c]
        else:
            X[d, c] = 1.0
    return X


def selection_basis(ndof, constrained):
    """T (ndof, ndof - len(constrained)) CSR: unit columns of the free DOFs."""
    free = np.setdiff1d(np.arange(ndof), np.asarray(constrained, int))
    return sp.csr_matrix((np.ones(free.size), (free, np.arange(free.size))),
                         shape=(ndof, free.size))


def rigid_fit_operator(nodes, positions, point, ndof, rotation_length=0.25, weights=None):
    """(6, ndof) CSR: least-squares rigid motion (u, th) at ``point`` fitted to nodes' motion.

    Minimises sum_k w_k |u_k - u - th x r_k|^2 + L^2 sum_k w_k |th_k - th|^2 with
    r_k = x_k - point (nodes with 6 DOFs each, node-major layout): an
    "RBE3-like" connection that reproduces rigid motions exactly.
    """
    nodes = np.asarray(nodes)
    w = np.ones(nodes.size) if weights is None else np.asarray(weights, float)
    r = np.asarray(positions, float)[nodes] - np.asarray(point, float)
    A = np.zeros((nodes.size, 3, 6))
    A[:, :, :3] = np.eye(3)
    for k in range(nodes.size):
        A[k, :, 3:] = -np.array([[0, -r[k, 2], r[k, 1]], [r[k, 2], 0, -r[k, 0]],
                                 [-r[k, 1], r[k, 0], 0]])
    N = np.einsum("k,kia,kib->ab", w, A, A)
    N[3:, 3:] += rotation_length ** 2 * w.sum() * np.eye(3)
    Ninv = np.linalg.inv(N)
    R = sp.lil_matrix((6, ndof))
    for k, node in enumerate(nodes):
        R[:, 6 * node:6 * node + 3] = w[k] * Ninv @ A[k].T
        R[:, 6 * node + 3:6 * node + 6] = w[k] * rotation_length ** 2 * Ninv[:, 3:]
    return R.tocsr()


def constraint_basis(C, preferred=(), tol=1e-12):
    """Sparse T (ndof, ndof - rank C) with C T = 0, by eliminating one slave per row.

    C (c, ndof) dense.  Gauss-Jordan: each row picks as slave a not-yet-used DOF
    with a nonzero coefficient, ``preferred`` DOFs first, then the largest
    coefficient.  Returns T whose columns are the master DOFs (unit entry on the
    master, -coefficients on the slaves): a multi-point T.
    """
    C = np.array(C, dtype=float)
    ndof = C.shape[1]
    pref = np.zeros(ndof, bool)
    pref[list(preferred)] = True
    slaves, slave_rows = [], []
    for i in range(C.shape[0]):
        row = C[i]
        scale = np.max(np.abs(row))
        if scale <= tol:
            continue
        cand = np.flatnonzero(np.abs(row) > 1e-9 * scale)
        cand = cand[~np.isin(cand, slaves)]
        if cand.size == 0:
            continue
        key = pref[cand] * 1e6 + np.abs(row[cand]) / scale
        j = cand[np.argmax(key)]
        C[i] /= C[i, j]
        for k in range(C.shape[0]):
            if k != i and C[k, j] != 0.0:
                C[k] -= C[k, j] * C[i]
        slaves.append(j)
        slave_rows.append(i)
    masters = np.setdiff1d(np.arange(ndof), slaves)
    col_of = {dof: n for n, dof in enumerate(masters)}
    r, c, v = list(masters), list(range(masters.size)), [1.0] * masters.size
    for s, i in zip(slaves, slave_rows):
        for dof in np.flatnonzero(np.abs(C[i]) > tol):
            if dof != s:
                r.append(s)
                c.append(col_of[dof])
                v.append(-C[i, dof])
    T = sp.csr_matrix((v, (r, c)), shape=(ndof, masters.size))
    return T


def supported_modes(K, M, T, n_modes=None, rtol=1e-13):
    """Mass-normalised supported modes, dense: eigenvalues (D,), modes (ndof, D).

    Solves (T^T K T) x = lambda (T^T M T) x through the K-inner product
    (T^T K T = L L^T, A = L^-1 (T^T M T) L^-T, mu = 1 / lambda), so a singular
    T^T M T is allowed; only finite modes (mu > rtol * max mu) are kept.  When
    T^T M T is definite, scipy.linalg.eigh(Kt, Mt) is used directly.
    """
    T = sp.csr_matrix(T)
    Kt = (T.T @ K @ T).toarray()
    Mt = (T.T @ M @ T).toarray()
    Kt, Mt = 0.5 * (Kt + Kt.T), 0.5 * (Mt + Mt.T)
    w_m = np.linalg.eigvalsh(Mt)
    if w_m[0] > 1e-10 * w_m[-1]:
        lam, x = scipy.linalg.eigh(Kt, Mt)
    else:
        L = np.linalg.cholesky(Kt)
        Li = scipy.linalg.solve_triangular(L, np.eye(L.shape[0]), lower=True)
        A = Li @ Mt @ Li.T
        mu, W = np.linalg.eigh(0.5 * (A + A.T))
        keep = mu > rtol * mu[-1]
        mu, W = mu[keep], W[:, keep]
        x = Li.T @ W / np.sqrt(mu)
        lam = 1.0 / mu
        order = np.argsort(lam)
        lam, x = lam[order], x[:, order]
    if n_modes is not None:
        lam, x = lam[:n_modes], x[:, :n_modes]
    modes = np.asarray(T @ x)
    # deterministic signs: largest entry positive
    idx = np.argmax(np.abs(modes), axis=0)
    modes *= np.sign(modes[idx, np.arange(modes.shape[1])])
    return lam, modes


def ring_body(radius=3.375, n_elements=24, width=0.5, thickness=0.25,
              outer_bearing_distance=7.25, inner_bearing_distance=6.25,
              motor_side=1, output_motor_side=1, mass_model="consistent",
              connection="rods", rod_factor=20.0, eccentric_fraction=0.10,
              output_bearings=True, n_modes=None, density=RHO, body=2, eccentric="node"):
    """A ring-gimbal-like body dict in the body-file layout (see module docstring).

    Node order: ring nodes 0..n_elements-1 at angle 2 pi k / n (from +x towards
    +z), then the bearing nodes (input motor, input resolver, output motor,
    output resolver; the platform-like body has only the first two).
    """
    if n_elements % 8:
        raise ValueError("n_elements must be a multiple of 8")
    ang = 2 * np.pi * np.arange(n_elements) / n_elements
    ring = np.c_[radius * np.cos(ang), np.zeros_like(ang), radius * np.sin(ang)]
    a_out, a_in = outer_bearing_distance / 2, inner_bearing_distance / 2
    bearing_points = np.array([
        [motor_side * a_out, 0, 0], [-motor_side * a_out, 0, 0],
        [0, 0, output_motor_side * a_in], [0, 0, -output_motor_side * a_in]], float)
    q = n_elements // 4
    attach = [0 if motor_side > 0 else 2 * q, 2 * q if motor_side > 0 else 0,
              q if output_motor_side > 0 else 3 * q, 3 * q if output_motor_side > 0 else q]
    n_b = 4 if output_bearings else 2
    has_bearing_nodes = connection in ("rods", "rigid_links")
    nodes = np.vstack([ring, bearing_points[:n_b]]) if has_bearing_nodes else ring
    n_nodes = nodes.shape[0]
    sec = rect_section(width, thickness)
    # band: local y of each element along the ring axis (global y)
    elements = []
    consistent = mass_model in ("consistent", "consistent_no_polar")
    for k in range(n_elements):
        i, j = k, (k + 1) % n_elements
        Ke, Me = beam_element(nodes[i], nodes[j], sec, rho=density, up=(0, 1, 0),
                              polar_inertia=mass_model == "consistent", mass=consistent)
        elements.append((i, j, Ke, Me))
    rod = {key: val * rod_factor for key, val in sec.items()}
    if connection == "rods":
        for b in range(n_b):
            Ke, Me = beam_element(nodes[attach[b]], nodes[n_elements + b], rod, rho=density,
                                  up=(0, 1, 0), mass=False)
            elements.append((attach[b], n_elements + b, Ke, Me))
    K, M = assemble(n_nodes, elements)
    dof_coords, dof_component = node_dofs(nodes)
    ndof = 6 * n_nodes

    # structural mass of the band, lumped variants
    structural_mass = density * sec["A"] * 2 * np.pi * radius * np.sin(np.pi / n_elements) / (
        np.pi / n_elements)
    extra = sp.lil_matrix((ndof, ndof))
    if not consistent:
        m_node = structural_mass / n_elements
        for k in range(n_elements):
            for c in range(3):
                extra[6 * k + c, 6 * k + c] += m_node
            if mass_model == "shell_like":
                radial = np.array([np.cos(ang[k]), 0.0, np.sin(ang[k])])
                # rotary inertia per node about tangent and axis, none about the radial
                j_rot = m_node * (thickness ** 2 + width ** 2) / 12.0
                I_rot = j_rot * (np.eye(3) - np.outer(radial, radial))
                extra[6 * k + 3:6 * k + 6, 6 * k + 3:6 * k + 6] = I_rot
            elif mass_model != "lumped":
                raise ValueError(f"unknown mass_model {mass_model!r}")
    # eccentric mass at 45 degrees: on one ring node (translations only), or
    # moving with the rigid-fit translation of three ring nodes (as the FE stage)
    k45 = n_elements // 8
    point_mass = eccentric_fraction * structural_mass
    if eccentric == "node":
        for c in range(3):
            extra[6 * k45 + c, 6 * k45 + c] += point_mass
        M = (M + extra.tocsr()).tocsr()
    elif eccentric == "rigid_fit":
        Rt = rigid_fit_operator([k45 - 1, k45, k45 + 1], nodes, nodes[k45], ndof)[:3]
        M = (M + extra.tocsr() + point_mass * (Rt.T @ Rt)).tocsr()
    else:
        raise ValueError(f"unknown eccentric {eccentric!r}")

    if connection == "rigid_fit":
        fits = [rigid_fit_operator([(attach[b] - 1) % n_elements, attach[b],
                                    (attach[b] + 1) % n_elements], nodes,
                                   bearing_points[b], ndof) for b in range(n_b)]
        C = sp.vstack([fits[0][[1, 2, 3]], fits[1][[0, 1, 2]]]).toarray()
        T = constraint_basis(C)
        B = sp.vstack(fits + [sp.csr_matrix((6, ndof))] * (4 - n_b)).tocsr()
        lam, modes = supported_modes(K, M, T, n_modes)
        points = bearing_points.copy()
        if not output_bearings:
            points[2:] = np.nan
        return body_dict(
            M=M, K=K, T=T, modes=modes, eigenvalues=lam, dof_coords=dof_coords,
            dof_component=dof_component, bearing_points=points, bearing_operator=B,
            body=body, name=f"synthetic ring ({mass_model}, {connection})",
            model="shell" if mass_model == "shell_like" else "solid",
            structural_mass=structural_mass, point_mass=point_mass,
            point_mass_position=nodes[k45], mesh_size=2 * np.pi * radius / n_elements)
    motor_node, resolver_node = n_elements, n_elements + 1
    support_dofs = [6 * motor_node + 1, 6 * motor_node + 2, 6 * motor_node + 3,
                    6 * resolver_node + 0, 6 * resolver_node + 1, 6 * resolver_node + 2]
    if connection == "rods":
        T = selection_basis(ndof, support_dofs)
    elif connection == "rigid_links":
        rows = []
        for b in range(n_b):
            s, r = n_elements + b, attach[b]
            d = nodes[s] - nodes[r]
            for c in range(3):
                row = np.zeros(ndof)
                row[6 * s + c] = 1.0
                row[6 * r + c] = -1.0
                # u_s = u_r + th_r x d = u_r - skew(d) th_r
                sk = np.array([[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]])
                row[6 * r + 3:6 * r + 6] = sk[c]
                rows.append(row)
            for c in range(3):
                row = np.zeros(ndof)
                row[6 * s + 3 + c] = 1.0
                row[6 * r + 3 + c] = -1.0
                rows.append(row)
        for dof in support_dofs:
            row = np.zeros(ndof)
            row[dof] = 1.0
            rows.append(row)
        bearing_dofs = np.arange(6 * n_elements, ndof)
        T = constraint_basis(np.array(rows), preferred=bearing_dofs)
    else:
        raise ValueError(f"unknown connection {connection!r}")

    lam, modes = supported_modes(K, M, T, n_modes)
    B = sp.lil_matrix((24, ndof))
    for b in range(n_b):
        for c in range(6):
            B[6 * b + c, 6 * (n_elements + b) + c] = 1.0
    points = bearing_points.copy()
    if not output_bearings:
        points[2:] = np.nan
    return body_dict(
        M=M, K=K, T=T, modes=modes, eigenvalues=lam, dof_coords=dof_coords,
        dof_component=dof_component, bearing_points=points, bearing_operator=B.tocsr(),
        body=body, name=f"synthetic ring ({mass_model}, {connection})",
        model="shell" if mass_model == "shell_like" else "solid",
        structural_mass=structural_mass, point_mass=point_mass,
        point_mass_position=nodes[k45], mesh_size=2 * np.pi * radius / n_elements)


def grounded_masses(masses, positions, stiffnesses):
    """Point masses (3 translational DOFs each) on isotropic springs to ground.

    Returns dict(M, K, T, X, modes, eigenvalues, dof_coords, dof_component):
    modes are e_d / sqrt(m_n) in node-major order, Omega^2 = k_n / m_n (not sorted).
    """
    masses = np.asarray(masses, float)
    positions = np.asarray(positions, float)
    k = np.asarray(stiffnesses, float)
    n = masses.size
    M = sp.diags(np.repeat(masses, 3)).tocsr()
    K = sp.diags(np.repeat(k, 3)).tocsr()
    T = sp.identity(3 * n, format="csr")
    dof_coords = np.repeat(positions, 3, axis=0)
    dof_component = np.tile(np.arange(3), n)
    modes = np.diag(1.0 / np.sqrt(np.repeat(masses, 3)))
    eigenvalues = np.repeat(k / masses, 3)
    return {"M": M, "K": K, "T": T, "X": rigid_basis(dof_coords, dof_component),
            "modes": modes, "eigenvalues": eigenvalues, "dof_coords": dof_coords,
            "dof_component": dof_component}


def project_body_hash(body):
    """The config_hash the project's configuration gives body ``body``'s file ("synthetic" for a
    number outside 2..5): the stages check a body file against the configuration in use by
    default, and a synthetic body made with it passes."""
    from gimbal_reduction.solver import bodyconfig
    from gimbal_reduction.workflow.config import DEFAULT_CONFIG
    return bodyconfig.expected_hashes(str(DEFAULT_CONFIG)).get(int(body), "synthetic")


def body_dict(M, K, T, modes, eigenvalues, dof_coords, dof_component, bearing_points,
              bearing_operator, body=2, name="synthetic", model="solid", structural_mass=0.0,
              point_mass=0.0, point_mass_position=(0.0, 0.0, 0.0), mesh_size=0.0):
    """Assemble a body dict with every dataset and attribute of docs/body-data.md."""
    B = sp.csr_matrix(bearing_operator)
    modes = np.asarray(modes, float)
    bearing_modes = np.asarray(B @ modes).T.reshape(-1, 4, 6)
    points = np.asarray(bearing_points, float)
    for b in range(4):
        if not np.all(np.isfinite(points[b])):
            bearing_modes[:, b, :] = np.nan
    lam = np.asarray(eigenvalues, float)
    return {
        "frequencies_hz": np.sqrt(lam) / (2 * np.pi), "eigenvalues": lam, "modes": modes,
        "M": sp.csr_matrix(M), "K": sp.csr_matrix(K), "T": sp.csr_matrix(T),
        "rigid_modes": rigid_basis(dof_coords, dof_component),
        "dof_coords": np.asarray(dof_coords, float),
        "dof_component": np.asarray(dof_component, np.int64),
        "bearing_points": points, "bearing_operator": B, "bearing_modes": bearing_modes,
        "attrs": {"body": body, "name": name, "model": model,
                  "structural_mass": float(structural_mass), "point_mass": float(point_mass),
                  "point_mass_position": np.asarray(point_mass_position, float),
                  "mesh_size": float(mesh_size), "units": "in, lbf, s",
                  "config_hash": project_body_hash(body), "versions": json.dumps({"numpy": np.__version__}),
                  "wall_time_s": 0.0},
    }


def permute_dofs(body, perm):
    """The same body with DOFs renumbered: new DOF i is old DOF perm[i]."""
    perm = np.asarray(perm)
    out = dict(body)
    for key in ("M", "K"):
        out[key] = body[key][perm][:, perm].tocsr()
    out["T"] = body["T"][perm].tocsr()
    out["bearing_operator"] = body["bearing_operator"][:, perm].tocsr()
    for key in ("modes", "rigid_modes", "dof_coords", "dof_component"):
        out[key] = body[key][perm]
    return out


def scale_density(body, factor):
    """The same body with every mass multiplied by ``factor`` (modes re-normalised)."""
    out = dict(body)
    out["M"] = (body["M"] * factor).tocsr()
    out["modes"] = body["modes"] / np.sqrt(factor)
    out["eigenvalues"] = body["eigenvalues"] / factor
    out["frequencies_hz"] = np.sqrt(out["eigenvalues"]) / (2 * np.pi)
    out["bearing_modes"] = body["bearing_modes"] / np.sqrt(factor)
    return out


def write_body_file(path, body):
    """Write a body dict (``body_dict``) as an HDF5 file in the contract's layout."""
    with h5py.File(path, "w") as f:
        for key in ("frequencies_hz", "eigenvalues", "modes", "rigid_modes", "dof_coords",
                    "dof_component", "bearing_points", "bearing_modes"):
            f.create_dataset(key, data=body[key])
        for key in ("M", "K", "T", "bearing_operator"):
            write_csr(f, key, body[key])
        for key, value in body["attrs"].items():
            f.attrs[key] = value
    return path


def band_body(n_circ=400, n_width=5, radius=3.375, width=0.5, thickness=0.25,
              outer_bearing_distance=7.25, inner_bearing_distance=6.25, motor_side=1,
              output_motor_side=1, n_modes=100, mass_model="shell_like", body=2, seed=None):
    """A large shell-like band (beam grid on the ring's mid-surface) with 100 modes, sparse.

    n_circ x n_width nodes (6 DOFs each) on a cylinder of the ring's radius and
    width, beams along the circumference and across the width; the bearing
    connections are rigid fits over the cross-section line at the bearing
    angle (supports through a multi-point T), the eccentric mass moves with
    the rigid fit of the 45-degree line.  ``mass_model`` "shell_like" (no
    drilling inertia: singular T^T M T) or "consistent".  Modes by sparse
    shift-invert Lanczos (scipy eigsh), so a 60k-DOF body takes tens of seconds
    to build: meant for timing the downstream stages at the real bodies' size.
    """
    import scipy.sparse.linalg as spla

    if n_circ % 8:
        raise ValueError("n_circ must be a multiple of 8")
    ang = 2 * np.pi * np.arange(n_circ) / n_circ
    ys = np.linspace(-width / 2, width / 2, n_width)
    nodes = np.array([[radius * np.cos(a), y, radius * np.sin(a)] for a in ang for y in ys])
    idx = np.arange(n_circ * n_width).reshape(n_circ, n_width)
    ds, dw = 2 * np.pi * radius / n_circ, width / max(n_width - 1, 1)
    sec_c = rect_section(width / n_width, thickness)   # circumferential strips
    sec_w = rect_section(ds, thickness)                 # across the width
    consistent = mass_model == "consistent"
    elements = []
    for i in range(n_circ):
        for j in range(n_width):
            a, b = idx[i, j], idx[(i + 1) % n_circ, j]
            radial = np.array([np.cos(ang[i]), 0, np.sin(ang[i])])
            Ke, Me = beam_element(nodes[a], nodes[b], sec_c, up=(0, 1, 0), mass=consistent)
            elements.append((a, b, Ke, Me))
            if j + 1 < n_width:
                c = idx[i, j + 1]
                Ke, Me = beam_element(nodes[a], nodes[c], sec_w, up=radial, mass=False)
                elements.append((a, c, Ke, Me))
    n_nodes = nodes.shape[0]
    K, M = assemble(n_nodes, elements)
    ndof = 6 * n_nodes
    dof_coords, dof_component = node_dofs(nodes)
    structural_mass = RHO * width * thickness * 2 * np.pi * radius
    if not consistent:
        m_node = structural_mass / n_nodes
        rows, cols, vals = [], [], []
        for k in range(n_nodes):
            radial = np.array([nodes[k, 0], 0.0, nodes[k, 2]]) / radius
            I_rot = m_node * thickness ** 2 / 12.0 * (np.eye(3) - np.outer(radial, radial))
            for c in range(3):
                rows.append(6 * k + c)
                cols.append(6 * k + c)
                vals.append(m_node)
            rr, cc = np.meshgrid(np.arange(3), np.arange(3), indexing="ij")
            rows.extend(6 * k + 3 + rr.ravel())
            cols.extend(6 * k + 3 + cc.ravel())
            vals.extend(I_rot.ravel())
        M = sp.csr_matrix((vals, (rows, cols)), shape=(ndof, ndof))
    q = n_circ // 4
    k45 = n_circ // 8
    point_mass = 0.1 * structural_mass
    Rt = rigid_fit_operator(idx[k45], nodes, nodes[idx[k45]].mean(axis=0), ndof)[:3]
    M = (M + point_mass * (Rt.T @ Rt)).tocsr()
    a_out, a_in = outer_bearing_distance / 2, inner_bearing_distance / 2
    points = np.array([[motor_side * a_out, 0, 0], [-motor_side * a_out, 0, 0],
                       [0, 0, output_motor_side * a_in], [0, 0, -output_motor_side * a_in]], float)
    attach = [0 if motor_side > 0 else 2 * q, 2 * q if motor_side > 0 else 0,
              q if output_motor_side > 0 else 3 * q, 3 * q if output_motor_side > 0 else q]
    fits = [rigid_fit_operator(idx[attach[b]], nodes, points[b], ndof) for b in range(4)]
    C = sp.vstack([fits[0][[1, 2, 3]], fits[1][[0, 1, 2]]]).tocsr()
    # eliminate one DOF per constraint row (sparse variant of constraint_basis)
    touched = np.unique(C.tocoo().col)
    dense = C[:, touched].toarray()
    _, r, piv = scipy.linalg.qr(dense, pivoting=True, mode="economic")
    slaves_l, masters_l = piv[:6], np.sort(piv[6:])
    S = -np.linalg.solve(dense[:, slaves_l], dense[:, masters_l])
    slave, master_touched = touched[slaves_l], touched[masters_l]
    is_slave = np.zeros(ndof, bool)
    is_slave[slave] = True
    col = np.cumsum(~is_slave) - 1
    free = np.flatnonzero(~is_slave)
    T = sp.csr_matrix(
        (np.r_[np.ones(free.size), S.ravel()],
         (np.r_[free, np.repeat(slave, master_touched.size)],
          np.r_[col[free], np.tile(col[master_touched], slave.size)])),
        shape=(ndof, free.size))
    Kt = (T.T @ K @ T).tocsc()
    Mt = (T.T @ M @ T).tocsc()
    lam, x = spla.eigsh(Kt, k=n_modes, M=Mt, sigma=0.0, which="LM")
    order = np.argsort(lam)
    lam, x = lam[order], x[:, order]
    x /= np.sqrt(np.einsum("ij,ij->j", x, Mt @ x))
    modes = np.asarray(T @ x)
    residual = np.linalg.norm(Kt @ x - (Mt @ x) * lam, axis=0) / np.linalg.norm(Kt @ x, axis=0)
    out = body_dict(
        M=M, K=K, T=T, modes=modes, eigenvalues=lam, dof_coords=dof_coords,
        dof_component=dof_component, bearing_points=points,
        bearing_operator=sp.vstack(fits).tocsr(), body=body,
        name=f"synthetic band ({mass_model}, {n_circ}x{n_width})",
        model="shell" if not consistent else "solid", structural_mass=structural_mass,
        point_mass=point_mass, point_mass_position=nodes[idx[k45]].mean(axis=0),
        mesh_size=ds)
    out["attrs"]["max_relative_residual"] = float(residual.max())
    return out
