"""One elastic body as the multibody equations see it: its modal integrals.

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

import numpy as np
import scipy.sparse as sp

BEARING_NAMES = ("input_motor", "input_resolver", "output_motor", "output_resolver")
OUTPUT_MOTOR, OUTPUT_RESOLVER = 2, 3

# Levi-Civita symbol as the list of its non-zero entries (a, b, c, sign):
# (omega x phi)_a = sum_{b,c} eps_abc omega_b phi_c.
_EPSILON = ((0, 1, 2, 1.0), (0, 2, 1, -1.0), (1, 2, 0, 1.0),
            (1, 0, 2, -1.0), (2, 0, 1, 1.0), (2, 1, 0, -1.0))


def skew(r):
    """Cross-product matrix: ``skew(r) @ v == np.cross(r, v)``; r (..., 3) -> (..., 3, 3)."""
    r = np.asarray(r, dtype=float)
    s = np.zeros(r.shape[:-1] + (3, 3))
    s[..., 0, 1], s[..., 0, 2] = -r[..., 2], r[..., 1]
    s[..., 1, 0], s[..., 1, 2] = r[..., 2], -r[..., 0]
    s[..., 2, 0], s[..., 2, 1] = -r[..., 1], r[..., 0]
    return s


def rigid_modes(dof_coords, dof_component):
    """X (ndof, 6): nodal motion of unit translations x, y, z and unit rotations
    about x, y, z through the origin.  Translation DOF of axis a at r:
    X[:, b] = e_b[a], X[:, 3 + b] = (e_b x r)[a]; rotation DOF of axis a: X[:, 3 + a] = 1."""
    r = np.asarray(dof_coords, float)
    comp = np.asarray(dof_component, int)
    X = np.zeros((r.shape[0], 6))
    trans = comp < 3
    axis = comp % 3
    idx = np.arange(r.shape[0])
    X[idx[trans], axis[trans]] = 1.0
    for a, b, c, sign in _EPSILON:          # (e_b x r)_a = eps_abc r_c
        rows = idx[trans & (axis == a)]
        X[rows, 3 + b] += sign * r[rows, c]
    X[idx[~trans], 3 + axis[~trans]] = 1.0
    return X


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


def rigid_mass(M, X):
    """X^T M X (6, 6): [[m I, -skew(c)], [skew(c), J]] about the body origin, with the
    nodal rotary inertia of rotation DOFs included."""
    A = np.asarray(X.T @ (M @ X))
    return 0.5 * (A + A.T)


def momentum_coefficients(M, X, modes):
    """[P; H] = X^T M Phi (6, D) [sqrt(mass), sqrt(mass) in] (thesis eqs 2.7, 3.11)."""
    return np.asarray((M @ X).T @ modes)


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


def inside_frame_motion(bearing_modes, bearing_points, motor=OUTPUT_MOTOR, resolver=OUTPUT_RESOLVER):
    """Elastic translation Psi (3, D) and small rotation Theta (3, D) of the inside frame.

    bearing_modes (D, 4, 6): per mode, per bearing, the rigid-fit
    (u_x, u_y, u_z, th_x, th_y, th_z) in the body frame; bearing_points (4, 3).
    The inside frame carries the next body, which is held (its own supports)
    by: the two bearings across the bearing axis e (no relative translation
    across the axis), the resolver along the axis, the motor about the axis.
    So the frame's rigid motion u(p) = t + theta x p must match
    (I - e e^T) u at both output bearings, e . u at the resolver and e . th at
    the motor:  theta = e (e . th_m) + e x (u_m - u_r) / d,  t = u_r - theta x p_r.
    For bearings at +-d/2 on z this is the thesis's PSI/THT (Appendix A.2):
    t = ((u_m + u_r)/2 across z, u_rz along z), theta = ((u_ry - u_my)/d,
    (u_mx - u_rx)/d, th_mz) with d = z_m - z_r.
    """
    bm = np.asarray(bearing_modes, float)
    pts = np.asarray(bearing_points, float)
    p_m, p_r = pts[motor], pts[resolver]
    if not (np.all(np.isfinite(p_m)) and np.all(np.isfinite(p_r))):
        raise ValueError("the body has no output bearings (inside frame undefined)")
    delta = p_m - p_r
    d = float(np.linalg.norm(delta))
    e = delta / d
    u_m, th_m, u_r = bm[:, motor, :3], bm[:, motor, 3:], bm[:, resolver, :3]
    theta = np.outer(th_m @ e, e) + np.cross(e, u_m - u_r) / d      # (D, 3)
    t = u_r - np.cross(theta, p_r)
    return np.ascontiguousarray(t.T), np.ascontiguousarray(theta.T)


def modal_integrals(M, modes, rigid_modes, dof_coords, dof_component, bearing_modes=None,
                    bearing_points=None, rotate_rotation_blocks=True):
    """Every modal integral the multibody equations need, for one body.

    M (ndof, ndof) CSR consistent mass; modes (ndof, D) M-orthonormal;
    rigid_modes (ndof, 6); dof_coords (ndof, 3); dof_component (ndof,);
    bearing_modes (D, 4, 6) and bearing_points (4, 3) give the inside frame
    (omit them, or give NaN output bearings, for the terminal body).
    Returns a dict of arrays: rigid_mass (6, 6), momentum (6, D),
    inertia_gradient (D, 6, 6), coriolis (D, 3, D), and, if the body has
    output bearings, inside_translation (3, D) and inside_rotation (3, D).
    """
    M = sp.csr_matrix(M)
    Phi = np.asarray(modes, float)
    X = np.asarray(rigid_modes, float)
    Ut = rotation_action(Phi, dof_coords, dof_component, rotate_rotation_blocks)
    out = {
        "rigid_mass": rigid_mass(M, X),
        "momentum": momentum_coefficients(M, X, Phi),
        "inertia_gradient": inertia_gradient(M, X, Ut),
        "coriolis": coriolis_coefficients(M, Phi, Ut),
    }
    if bearing_points is not None and bearing_modes is not None:
        pts = np.asarray(bearing_points, float)
        if np.all(np.isfinite(pts[[OUTPUT_MOTOR, OUTPUT_RESOLVER]])):
            psi, theta = inside_frame_motion(bearing_modes, pts)
            out["inside_translation"], out["inside_rotation"] = psi, theta
    return out


def mass_orthonormalise(M, K, vibration_modes, extra_modes):
    """Basis [Phi_v, Phi_s'] with Phi_s' spanning the extra (static) modes, made
    M-orthogonal to the vibration modes and M-orthonormal, K-diagonal among
    themselves (Rayleigh-Ritz in their span).  Returns (basis, modal stiffness of
    the extra modes (s,) [(rad/s)^2], Gram condition number)."""
    Pv = np.asarray(vibration_modes, float)
    S = np.asarray(extra_modes, float)
    if S.ndim == 1:
        S = S[:, None]
    if S.shape[1] == 0:
        return Pv, np.zeros(0), 1.0
    MS = np.asarray(M @ S)
    S = S - Pv @ (Pv.T @ MS)                       # M-orthogonal to the kept modes
    Ms = S.T @ np.asarray(M @ S)
    Ks = S.T @ np.asarray(K @ S)
    Ms, Ks = 0.5 * (Ms + Ms.T), 0.5 * (Ks + Ks.T)
    cond = float(np.linalg.cond(Ms))
    import scipy.linalg
    lam, V = scipy.linalg.eigh(Ks, Ms)
    return np.hstack([Pv, S @ V]), lam, cond
