"""Equations of motion of the elastic gimbal chain case -> 2 -> 3 -> 4 -> 5.

The derivation is ``docs/dynamics.md``; this module is its executable form.

Generalised coordinates (``n_y = 4 + sum_n D_n``), all SI-free in-lbf-s:

    y = [gamma_1, gamma_2, gamma_3, gamma_4, q_2, q_3, q_4, q_5]

gamma_j [rad] is the joint angle between body j and body j+1 about body
j+1's local x; q_n [in sqrt(lbf s^2/in)] are body n's modal coordinates.

Every body n has an outside frame (origin o_n, axes A_n) and a twist
``w_n = [v_n; omega_n]`` (6,) in its own axes [in/s, rad/s].  The child's
frame sits on the parent's inside frame, moved by the parent's elastic
translation ``Psi q`` and small rotation ``E(Theta q)`` and turned by the joint:

    child pose in parent axes:   p = Psi q_parent,   R = E(Theta q) C Rx(gamma)

(case -> outer gimbal: p = rho, R = C_1 Rx(gamma_1)).  Lagrange's equations of
L = sum_n T_n(w_n, q_n, dq_n) - 1/2 sum q^T Omega^2 q are written in the
Newton-Euler (Euler-Poincare) form per body and assembled through the joint
Jacobians, so that

    M(y) y'' = f(y, y', t)     [thesis eq 2.1]

is available three ways, all O(sum D) or O(sum D^2) per evaluation:

* ``inverse_dynamics``: M(y) a + c(y, y', t) for any a (recursive Newton-Euler);
* ``solve_mass``: x = (M(y) + diag(0, d - 1))^-1 r, the articulated-body
  recursion with every modal block eliminated analytically (Woodbury, 6x6
  solves); no dense factorisation of the (4 + sum D) matrix;
* ``accelerations``: y'' = solve_mass(y, tau - c), the fast right-hand side.

``mass_matrix`` assembles M(y) column by column (tests and small models only).
"""

from dataclasses import dataclass, field, replace

import numpy as np

E_X = np.array([1.0, 0.0, 0.0])

# Fixed axes at zero angles (spec "Joints and orientation at all angles zero"):
# columns are the child's local axes written in the parent's axes.
CASE_TO_OUTER = np.array([[0.0, 1.0, 0.0],     # x_2 = Z, y_2 = X, z_2 = Y
                          [0.0, 0.0, 1.0],
                          [1.0, 0.0, 0.0]])
PARENT_TO_CHILD = np.array([[0.0, 0.0, -1.0],  # x_{n+1} = z_n, y_{n+1} = y_n, z_{n+1} = -x_n
                            [0.0, 1.0, 0.0],
                            [1.0, 0.0, 0.0]])
GIMBAL_OFFSET = np.array([0.0, 0.0, -3.375])   # rho, gimbal point in the case frame [in]


def rot_x(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class Body:
    """Modal data of one elastic body (``gimbal_reduction.reduction.modal_integrals.chain_integrals``).

    rigid_mass (6, 6); momentum (6, D) = [P; H]; inertia_gradient (D, 6, 6);
    coriolis (D, 3, D); omega2 (D,) modal stiffness [(rad/s)^2]; damping (D,)
    modal damping 2 zeta Omega [1/s]; inside_translation / inside_rotation
    (3, D) Psi, Theta of the inside frame (None for the terminal body);
    labels (D,) mode names for output.
    """
    number: int
    rigid_mass: np.ndarray
    momentum: np.ndarray
    inertia_gradient: np.ndarray
    coriolis: np.ndarray
    omega2: np.ndarray
    damping: np.ndarray
    inside_translation: np.ndarray = None
    inside_rotation: np.ndarray = None
    labels: tuple = ()

    @property
    def n_modes(self):
        return int(self.omega2.size)


def modal_damping(omega2, damping_ratio):
    """Modal damping coefficients 2 zeta Omega (D,) [1/s] of modal stiffnesses omega2 (D,)
    [rad^2/s^2] at ratio(s) zeta (scalar or (D,), dimensionless)."""
    omega2 = np.asarray(omega2, float)
    zeta = np.broadcast_to(np.asarray(damping_ratio, float), omega2.shape)
    return 2.0 * zeta * np.sqrt(np.maximum(omega2, 0.0))


def with_damping(chain, damping_ratio):
    """The chain with every body's modal damping at ratio ``damping_ratio`` (what a model file
    read with the scene's damping gives, ``chainfile.read_chain``)."""
    return replace(chain, bodies=tuple(replace(b, damping=modal_damping(b.omega2, damping_ratio))
                                       for b in chain.bodies))


def make_body(number, integrals, omega2, damping_ratio=0.0, labels=()):
    """Body from a ``modal_integrals`` dict, modal stiffness omega2 (D,) and a damping ratio."""
    omega2 = np.asarray(omega2, float)
    D = omega2.size
    psi = integrals.get("inside_translation")
    theta = integrals.get("inside_rotation")
    return Body(
        number=int(number),
        rigid_mass=np.array(integrals["rigid_mass"], float).reshape(6, 6),
        momentum=np.array(integrals["momentum"], float).reshape(6, D),
        inertia_gradient=np.array(integrals["inertia_gradient"], float).reshape(D, 6, 6),
        coriolis=np.array(integrals["coriolis"], float).reshape(D, 3, D),
        omega2=omega2.copy(),
        damping=modal_damping(omega2, damping_ratio),
        inside_translation=None if psi is None else np.array(psi, float).reshape(3, D),
        inside_rotation=None if theta is None else np.array(theta, float).reshape(3, D),
        labels=tuple(labels))


@dataclass(frozen=True)
class Chain:
    """The gimbal chain: four bodies (2..5), the gimbal offset and the fixed axes."""
    bodies: tuple
    gimbal_offset: np.ndarray = field(default_factory=lambda: GIMBAL_OFFSET.copy())
    case_to_outer: np.ndarray = field(default_factory=lambda: CASE_TO_OUTER.copy())
    parent_to_child: np.ndarray = field(default_factory=lambda: PARENT_TO_CHILD.copy())
    name: str = ""

    def __post_init__(self):
        if len(self.bodies) != 4:
            raise ValueError(f"the chain has 4 elastic bodies (2..5), got {len(self.bodies)}")
        for k, b in enumerate(self.bodies[:-1]):
            if b.n_modes and (b.inside_translation is None or b.inside_rotation is None):
                raise ValueError(f"body {b.number} has modes but no inside-frame data")

    @property
    def n_modes(self):
        return tuple(b.n_modes for b in self.bodies)

    @property
    def n_coordinates(self):
        return 4 + sum(self.n_modes)

    @property
    def slices(self):
        """Slices of q_2..q_5 in y."""
        out, start = [], 4
        for D in self.n_modes:
            out.append(slice(start, start + D))
            start += D
        return out

    @property
    def omega_max(self):
        """Largest kept modal frequency [rad/s] (0 for a rigid chain).

        NOT the stability bound of an explicit integrator: the coupled chain's
        highest frequency is higher (``linearized.coupled_omega_max``)."""
        w2 = [b.omega2.max() for b in self.bodies if b.n_modes]
        return float(np.sqrt(max(w2))) if w2 else 0.0

    def stiffness_diagonal(self):
        return np.concatenate([np.zeros(4)] + [b.omega2 for b in self.bodies])

    def damping_diagonal(self):
        return np.concatenate([np.zeros(4)] + [b.damping for b in self.bodies])


# ----------------------------------------------------------------- case motion
@dataclass(frozen=True)
class CaseMotion:
    """Prescribed rotation of the case about its origin (fixed in inertial space).

    Angular acceleration in case axes, per axis k: amplitude[k] *
    cos(2 pi frequency[k] t + phase[k]) [rad/s^2]; initial angular velocity
    omega0 (3,) [rad/s].  Components in case axes integrate to the angular
    velocity in case axes (d/dt of body components = body components of the
    inertial derivative, because omega x omega = 0).
    """
    amplitude: tuple = (0.0, 0.0, 0.0)
    frequency: tuple = (0.0, 0.0, 0.0)
    phase: tuple = (0.0, 0.0, 0.0)
    omega0: tuple = (0.0, 0.0, 0.0)

    def angular_acceleration(self, t):
        a, f, ph = map(np.asarray, (self.amplitude, self.frequency, self.phase))
        return a * np.cos(2 * np.pi * f * t + ph)

    def angular_velocity(self, t):
        a, f, ph = map(np.asarray, (self.amplitude, self.frequency, self.phase))
        w = 2 * np.pi * f
        safe = np.where(w > 0, w, 1.0)
        integral = np.where(w > 0, (np.sin(w * t + ph) - np.sin(ph)) / safe, np.cos(ph) * t)
        return np.asarray(self.omega0, float) + a * integral

    def twist(self, t):
        """(w_1, dw_1/dt) (6,) each: the case twist [0; omega] in case axes and its rate."""
        w = np.zeros(6)
        dw = np.zeros(6)
        w[3:] = self.angular_velocity(t)
        dw[3:] = self.angular_acceleration(t)
        return w, dw

    @property
    def at_rest(self):
        return not (np.any(np.asarray(self.amplitude)) or np.any(np.asarray(self.omega0)))


# -------------------------------------------------------------- joint geometry
def adjoint_inverse(R, p, w):
    """Ad_{g^-1} w: twist w (6,) of a frame, written in a frame posed at (R, p) relative to it."""
    return np.concatenate([R.T @ (w[:3] + np.cross(w[3:], p)), R.T @ w[3:]])


def adjoint_inverse_transpose(R, p, F):
    """(Ad_{g^-1})^T F: wrench F = [force; moment] (6,) in the child frame, as a wrench
    in the parent frame about the parent origin."""
    f = R @ F[:3]
    return np.concatenate([f, np.cross(p, f) + R @ F[3:]])


def adjoint_inverse_matrix(R, p):
    """Ad_{g^-1} (6, 6) = [[R^T, -R^T skew(p)], [0, R^T]]."""
    A = np.zeros((6, 6))
    A[:3, :3] = R.T
    A[3:, 3:] = R.T
    A[:3, 3:] = -R.T @ np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])
    return A


def twist_bracket(w, xi):
    """ad_w xi for twists [v; omega]: [omega x v' - omega' x v; omega x omega']."""
    return np.concatenate([np.cross(w[3:], xi[:3]) - np.cross(xi[3:], w[:3]),
                           np.cross(w[3:], xi[3:])])


@dataclass
class Joint:
    """Joint j between parent and child, evaluated at (y, y').

    R (3, 3), p (3,): child pose in parent axes; xi (6,): relative twist in
    child axes; L (6, D_parent): d(child twist)/d(dq_parent); bias (6,):
    d(xi)/dt at zero accelerations; Rj (3, 3) = C Rx(gamma) (the part after
    the elastic rotation) and Te (3, 3): d(omega_E)/d(dtheta)."""
    R: np.ndarray
    p: np.ndarray
    xi: np.ndarray
    L: np.ndarray
    bias: np.ndarray


def joint_state(chain, j, y, yd):
    """Joint j = 1..4 (between body j and j+1) at (y, y')."""
    gamma, gdot = y[j - 1], yd[j - 1]
    Rx = rot_x(gamma)
    if j == 1:
        R = chain.case_to_outer @ Rx
        p = chain.gimbal_offset
        xi = np.zeros(6)
        xi[3] = gdot
        return Joint(R=R, p=p, xi=xi, L=np.zeros((6, 0)), bias=np.zeros(6))
    parent = chain.bodies[j - 2]
    sl = chain.slices[j - 2]
    q, qd = y[sl], yd[sl]
    D = parent.n_modes
    C = chain.parent_to_child
    RjT = Rx.T @ C.T                                   # (C Rx)^T
    if D == 0:
        R = C @ Rx
        xi = np.zeros(6)
        xi[3] = gdot
        return Joint(R=R, p=np.zeros(3), xi=xi, L=np.zeros((6, 0)), bias=np.zeros(6))
    Psi, Theta = parent.inside_translation, parent.inside_rotation
    p = Psi @ q
    pd = Psi @ qd
    th = Theta @ q
    thd = Theta @ qd
    # elastic rotation E = Rx(th1) Ry(th2) Rz(th3); its angular velocity in its own axes
    # omega_E = a1 + a2 + a3 (Rz^T Ry^T e_x th1', Rz^T e_y th2', e_z th3')
    Rz, Ry = rot_z(th[2]), rot_y(th[1])
    cx = Rz.T @ (Ry.T @ E_X)
    cy = Rz.T @ np.array([0.0, 1.0, 0.0])
    Te = np.column_stack([cx, cy, [0.0, 0.0, 1.0]])
    E = rot_x(th[0]) @ Ry @ Rz
    R = E @ C @ Rx
    a1, a2, a3 = cx * thd[0], cy * thd[1], np.array([0.0, 0.0, thd[2]])
    omega_E = a1 + a2 + a3
    domega_E = np.cross(a1, a2 + a3) + np.cross(a2, a3)   # d(omega_E)/dt at th'' = 0
    v_rel = R.T @ pd
    w_rel = RjT @ omega_E + E_X * gdot
    xi = np.concatenate([v_rel, w_rel])
    L = np.vstack([R.T @ Psi, RjT @ (Te @ Theta)])
    bias = np.concatenate([-np.cross(w_rel, v_rel),
                           -np.cross(E_X * gdot, RjT @ omega_E) + RjT @ domega_E])
    return Joint(R=R, p=p, xi=xi, L=L, bias=bias)


# ---------------------------------------------------------------- body physics
def body_matrices(body, q):
    """M_X(q) (6, 6) and B(q) (6, D): the body's kinetic energy is
    1/2 w^T M_X w + w^T B dq + 1/2 dq^T dq (first order in q, docs/dynamics.md)."""
    D = body.n_modes
    if D == 0:
        return body.rigid_mass, np.zeros((6, 0)), np.zeros((3, 0))
    Mx = body.rigid_mass + np.tensordot(q, body.inertia_gradient, axes=(0, 0))
    hq = np.tensordot(q, body.coriolis, axes=(0, 0))       # (3, D)
    B = body.momentum.copy()
    B[3:] += hq
    return Mx, B, hq


def body_forces(body, w, dw, q, qd, qdd):
    """Generalised inertial + elastic forces of one body.

    w, dw (6,): frame twist and its rate (own axes); q, qd, qdd (D,).
    Returns F (6,) = d(mu)/dt + [omega x p; omega x h + v x p] (the wrench the
    frame needs), Q (D,) = d(pi)/dt - dT/dq + Omega^2 q + C dq (the modal
    force needed), mu (6,) = dT/dw (linear and angular momentum about the
    frame origin, own axes), pi (D,) = dT/d(dq)."""
    Mx, B, _ = body_matrices(body, q)
    mu = Mx @ w + B @ qd
    v, om = w[:3], w[3:]
    D = body.n_modes
    if D:
        hqd = np.tensordot(qd, body.coriolis, axes=(0, 0))  # sum_j dq_j G_j (3, D)
        dMx = np.tensordot(qd, body.inertia_gradient, axes=(0, 0))
        dmu = Mx @ dw + dMx @ w + B @ qdd
        dmu[3:] += hqd @ qd
        dpi = B.T @ dw + hqd.T @ om + qdd
        dTdq = 0.5 * np.einsum("iab,a,b->i", body.inertia_gradient, w, w) \
            + (body.coriolis @ qd) @ om
        Q = dpi - dTdq + body.omega2 * q + body.damping * qd
        pi = B.T @ w + qd
    else:
        dmu = Mx @ dw
        Q = np.zeros(0)
        pi = np.zeros(0)
    p, h = mu[:3], mu[3:]
    F = dmu + np.concatenate([np.cross(om, p), np.cross(om, h) + np.cross(v, p)])
    return F, Q, mu, pi


# ------------------------------------------------------------ chain recursions
def _check_state(chain, y, yd):
    y = np.asarray(y, float)
    yd = np.asarray(yd, float)
    n = chain.n_coordinates
    if y.shape != (n,) or yd.shape != (n,):
        raise ValueError(f"state must have shape ({n},), got {y.shape} and {yd.shape}")
    return y, yd


def kinematics(chain, y, yd, t, case=None, ydd=None):
    """Joints and body twists: (joints[4], w[4], dw[4]) with dw at accelerations ydd (0 if None)."""
    case = case or CaseMotion()
    w_case, dw_case = case.twist(t)
    ydd = np.zeros_like(y) if ydd is None else ydd
    joints, ws, dws = [], [], []
    w_par, dw_par = w_case, dw_case
    for j in range(1, 5):
        J = joint_state(chain, j, y, yd)
        w = adjoint_inverse(J.R, J.p, w_par) + J.xi
        dw = adjoint_inverse(J.R, J.p, dw_par) + twist_bracket(w, J.xi) + J.bias
        dw[3] += ydd[j - 1]
        if J.L.shape[1]:
            dw += J.L @ ydd[chain.slices[j - 2]]
        joints.append(J)
        ws.append(w)
        dws.append(dw)
        w_par, dw_par = w, dw
    return joints, ws, dws


def _rotations(axis, a):
    """Rotations (T, 3, 3) about the body axis 0/1/2 (x/y/z) by angles a (T,) [rad]."""
    a = np.asarray(a, float)
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(a.shape + (3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R[..., axis, axis] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


def platform_attitude(chain, y):
    """The stable platform's frame in case axes, R (T, 3, 3), at states y (T, n_y).

    The product of the four joint rotations (``joint_state``: R_1 = case_to_outer Rx(gamma_1),
    R_j = E_j C Rx(gamma_j) with E_j = Rx(th_1) Ry(th_2) Rz(th_3) the elastic rotation of the
    parent's inside bearing, th = Theta q of the parent), vectorised over the rows.  The case
    motion is prescribed, the same in every model, so two models' platform attitude in
    inertial axes differ exactly as their R here do (R_case cancels in R_a^T R_b)."""
    y = np.atleast_2d(np.asarray(y, float))
    bearings = [y[:, chain.slices[k]] @ np.asarray(chain.bodies[k].inside_rotation, float).T
                if chain.bodies[k].n_modes else None for k in range(3)]
    return attitude_of(chain, y[:, :4], bearings)


def attitude_of(chain, gamma, bearings):
    """``platform_attitude`` (T, 3, 3) from what it reads: the gimbal angles gamma (T, 4) [rad]
    and, per parent body k = 0, 1, 2 (bodies 2-4), its inside bearing's elastic rotations
    th = Theta q (T, 3) [rad], or None for a body without modes (E = I)."""
    R = chain.case_to_outer @ _rotations(0, gamma[:, 0])
    C = chain.parent_to_child
    for j in range(2, 5):
        Rj = C @ _rotations(0, gamma[:, j - 1])
        th = bearings[j - 2]
        if th is not None:
            E = _rotations(0, th[:, 0]) @ _rotations(1, th[:, 1]) @ _rotations(2, th[:, 2])
            Rj = E @ Rj
        R = R @ Rj
    return R


def attitude_functionals(chain):
    """L (13, n_y): the linear functionals of y that ``platform_attitude`` reads, rows 0-3 the
    gimbal angles, rows 4 + 3k .. 6 + 3k the inside-bearing rotations Theta q of parent body k
    (zero rows for a body without modes).  L y gives ``attitude_of``'s arguments: a trajectory
    known as y = y_r + Phi eta (the exponential integrator's outputs) needs only L Phi (13, n),
    not its (T, n) states (``simulate.platform_attitude``)."""
    L = np.zeros((13, chain.n_coordinates))
    L[np.arange(4), np.arange(4)] = 1.0
    for k in range(3):
        if chain.bodies[k].n_modes:
            L[4 + 3 * k:7 + 3 * k, chain.slices[k]] = np.asarray(chain.bodies[k].inside_rotation, float)
    return L


def attitude_of_functionals(chain, f):
    """``platform_attitude`` (T, 3, 3) from f = y L^T (T, 13) (``attitude_functionals``)."""
    return attitude_of(chain, f[:, :4], [f[:, 4 + 3 * k:7 + 3 * k] if chain.bodies[k].n_modes else None
                                         for k in range(3)])


def attitude_coordinates(chain):
    """Column indices into y of what ``platform_attitude`` reads: the four gimbal angles and
    the elastic coordinates of bodies 2-4 (the platform's own modes do not move its frame)."""
    cols = list(range(4))
    for k in range(3):
        sl = chain.slices[k]
        cols.extend(range(sl.start, sl.stop))
    return np.array(cols, dtype=int)


def inverse_dynamics(chain, y, yd, ydd, t=0.0, case=None, with_case=True):
    """M(y) ydd + c(y, y', t) (n_y,): the generalised forces the motion needs.

    c holds every velocity, case-motion, stiffness and damping term, so that
    the equations of motion are inverse_dynamics(y, y', y'') = tau (motor
    torques on gamma, zero on q).  with_case=False drops the case motion."""
    y, yd = _check_state(chain, y, yd)
    ydd = np.asarray(ydd, float)
    case = case if (with_case and case is not None) else CaseMotion()
    joints, ws, dws = kinematics(chain, y, yd, t, case, ydd)
    out = np.zeros(chain.n_coordinates)
    slices = chain.slices
    F_child = None
    for k in range(3, -1, -1):                  # bodies 5, 4, 3, 2
        body = chain.bodies[k]
        sl = slices[k]
        F, Q, _, _ = body_forces(body, ws[k], dws[k], y[sl], yd[sl], ydd[sl])
        if F_child is not None:                 # the child subtree hangs on the inside frame
            Jc = joints[k + 1]
            F = F + adjoint_inverse_transpose(Jc.R, Jc.p, F_child)
            if Jc.L.shape[1]:
                Q = Q + Jc.L.T @ F_child
        out[sl] = Q
        out[k] = F[3]                           # joint k+1 (gamma_{k+1}) drives this subtree about x
        F_child = F
    return out


def joint_wrench(chain, y, yd, ydd, t=0.0, case=None):
    """Wrench (6,) the case exerts on the subtree (bodies 2-5) through joint 1, in body-2 axes."""
    y, yd = _check_state(chain, y, yd)
    case = case or CaseMotion()
    joints, ws, dws = kinematics(chain, y, yd, t, case, np.asarray(ydd, float))
    F_child = None
    for k in range(3, -1, -1):
        body = chain.bodies[k]
        sl = chain.slices[k]
        F, _, _, _ = body_forces(body, ws[k], dws[k], y[sl], yd[sl], np.asarray(ydd)[sl])
        if F_child is not None:
            Jc = joints[k + 1]
            F = F + adjoint_inverse_transpose(Jc.R, Jc.p, F_child)
        F_child = F
    return F_child, joints, ws


def mass_matrix(chain, y):
    """M(y) (n_y, n_y), assembled column by column (O(n_y^2 D); tests and small models)."""
    y = np.asarray(y, float)
    n = chain.n_coordinates
    zero = np.zeros(n)
    base = inverse_dynamics(chain, y, zero, zero, with_case=False)
    cols = []
    for i in range(n):
        e = np.zeros(n)
        e[i] = 1.0
        cols.append(inverse_dynamics(chain, y, zero, e, with_case=False) - base)
    M = np.array(cols).T
    return 0.5 * (M + M.T)


def solve_mass(chain, y, r, modal_diagonal=None):
    """x with (M(y) + diag(0_4, d - 1)) x = r, by the articulated-body recursion.

    r (n_y,) generalised forces; modal_diagonal d (sum D,) replaces the
    identity modal mass blocks by diag(d) (an implicit integrator adds
    beta h^2 Omega^2 + gamma h c there); default ones.  Every modal block is
    eliminated with a Woodbury identity through a 6x6 solve, so the cost is
    O(sum 36 D) and nothing of size n_y is factorised."""
    y = np.asarray(y, float)
    r = np.asarray(r, float)
    zero = np.zeros_like(y)
    slices = chain.slices
    dg_all = np.ones(sum(chain.n_modes)) if modal_diagonal is None else np.asarray(modal_diagonal, float)
    joints = [joint_state(chain, j, y, zero) for j in range(1, 5)]
    # backward pass: articulated inertia IA (6, 6) and bias bA (6,) of each subtree
    IA = [None] * 4
    bA = [None] * 4
    store = [None] * 4
    for k in range(3, -1, -1):
        body = chain.bodies[k]
        sl = slices[k]
        Mx, B, _ = body_matrices(body, y[sl])
        dg = dg_all[sl.start - 4:sl.stop - 4]
        rq = r[sl].copy()
        I_art = Mx.copy()
        b_art = np.zeros(6)
        K = B.copy()
        Ltil = None
        if k < 3:
            Jc = joints[k + 1]
            Ic, bc = IA[k + 1], bA[k + 1]
            d = Ic[3, 3]
            Is = Ic[:, 3]
            u = r[k + 1] - bc[3]
            Itil = Ic - np.outer(Is, Is) / d
            pa = bc + Is * (u / d)
            A = adjoint_inverse_matrix(Jc.R, Jc.p)
            I_art += A.T @ Itil @ A
            b_art += A.T @ pa
            if Jc.L.shape[1]:
                K = K + A.T @ (Itil @ Jc.L)
                rq = rq - Jc.L.T @ pa
                Ltil = (Jc.L, Itil)
        # N = diag(dg) + L^T Itil L; N^-1 z = z/dg - (L/dg)^T Itil Z^-1 L (z/dg), Z = I + L (L/dg)^T Itil
        if body.n_modes:
            Kd = K / dg
            if Ltil is not None:
                L, Itil = Ltil
                Ld = L / dg
                Zinv = np.linalg.inv(np.eye(6) + (L @ Ld.T) @ Itil)
                KLd = K @ Ld.T                      # K D^-1 L^T (6, 6)
                KNK = Kd @ K.T - KLd @ Itil @ Zinv @ KLd.T
            else:
                L = Ld = Zinv = Itil = None
                KNK = Kd @ K.T
            def n_inv(z, dg=dg, L=L, Ld=Ld, Zinv=Zinv, Itil=Itil):
                zd = z / dg
                if L is None:
                    return zd
                return zd - Ld.T @ (Itil @ (Zinv @ (L @ zd)))
            I_art -= KNK
            b_art += K @ n_inv(rq)
            store[k] = (K, rq, n_inv)
        IA[k] = 0.5 * (I_art + I_art.T)
        bA[k] = b_art
    # forward pass
    x = np.zeros_like(r)
    a_base = np.zeros(6)                        # case acceleration is not part of M
    for k in range(4):
        Ic, bc = IA[k], bA[k]
        x[k] = (r[k] - bc[3] - Ic[3] @ a_base) / Ic[3, 3]
        a = a_base.copy()
        a[3] += x[k]
        sl = slices[k]
        if store[k] is not None:
            K, rq, n_inv = store[k]
            x[sl] = n_inv(rq - K.T @ a)
        if k < 3:
            Jc = joints[k + 1]
            a_base = adjoint_inverse(Jc.R, Jc.p, a)
            if Jc.L.shape[1]:
                a_base = a_base + Jc.L @ x[sl]
    return x


def accelerations(chain, y, yd, t=0.0, case=None, torque=None):
    """y'' = M(y)^-1 f(y, y', t), f = tau - c: the fast right-hand side."""
    y, yd = _check_state(chain, y, yd)
    tau = np.zeros(chain.n_coordinates)
    if torque is not None:
        tau[:4] = torque(t) if callable(torque) else torque
    c = inverse_dynamics(chain, y, yd, np.zeros_like(y), t, case)
    return solve_mass(chain, y, tau - c)


def generalized_force(chain, y, yd, t=0.0, case=None, torque=None):
    """f(y, y', t) = tau - c(y, y', t) of M y'' = f (thesis eq 2.1)."""
    y, yd = _check_state(chain, y, yd)
    tau = np.zeros(chain.n_coordinates)
    if torque is not None:
        tau[:4] = torque(t) if callable(torque) else torque
    return tau - inverse_dynamics(chain, y, yd, np.zeros_like(y), t, case)


# ------------------------------------------------------------ energy, momentum
def kinetic_energy(chain, y, yd, t=0.0, case=None):
    """T = sum_n 1/2 w^T M_X w + w^T B dq + 1/2 dq^T dq [in lbf]."""
    y, yd = _check_state(chain, y, yd)
    _, ws, _ = kinematics(chain, y, yd, t, case)
    T = 0.0
    for k, body in enumerate(chain.bodies):
        sl = chain.slices[k]
        Mx, B, _ = body_matrices(body, y[sl])
        w, qd = ws[k], yd[sl]
        T += 0.5 * w @ Mx @ w + w @ (B @ qd) + 0.5 * qd @ qd
    return float(T)


def potential_energy(chain, y):
    """U = 1/2 sum Omega^2 q^2 [in lbf]."""
    y = np.asarray(y, float)
    return float(0.5 * np.sum(chain.stiffness_diagonal() * y * y))


def generalized_momentum(chain, y, yd, t=0.0, case=None):
    """dT/dy' (n_y,): the momenta conjugate to y.  Component 0 (conjugate to
    gamma_1) is the angular momentum of bodies 2-5 about the outer drive axis
    (the line through rho along x_2 = Z), exactly, elastic parts included."""
    y, yd = _check_state(chain, y, yd)
    joints, ws, _ = kinematics(chain, y, yd, t, case)
    out = np.zeros(chain.n_coordinates)
    mu_child = None
    for k in range(3, -1, -1):
        body = chain.bodies[k]
        sl = chain.slices[k]
        _, _, mu, pi = body_forces(body, ws[k], np.zeros(6), y[sl], yd[sl], np.zeros(body.n_modes))
        if mu_child is not None:
            Jc = joints[k + 1]
            mu = mu + adjoint_inverse_transpose(Jc.R, Jc.p, mu_child)
            if Jc.L.shape[1]:
                pi = pi + Jc.L.T @ mu_child
        out[sl] = pi
        out[k] = mu[3]
        mu_child = mu
    return out


def case_power(chain, y, yd, ydd, t=0.0, case=None):
    """Power [in lbf/s] the prescribed case motion feeds into bodies 2-5:
    (Ad^-1 w_1) . F, with F the joint-1 wrench on body 2 (motor power excluded)."""
    case = case or CaseMotion()
    F, joints, _ = joint_wrench(chain, y, yd, ydd, t, case)
    w_case, _ = case.twist(t)
    J = joints[0]
    return float(adjoint_inverse(J.R, J.p, w_case) @ F)


def torque_function(torque):
    """Motor torques as a function t -> (4,) [in lbf]: None (zero), a constant (4,) or a
    callable t -> (4,) (returned as it is)."""
    if torque is None:
        return lambda t: np.zeros(4)
    if callable(torque):
        return torque
    arr = np.asarray(torque, float).reshape(4)
    return lambda t: arr
