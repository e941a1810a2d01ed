"""Small synthetic bodies and the independent oracle, for the dynamics verification and its tests.

A synthetic body is a handful of nodes with a random but valid finite-element
structure: nodal DOFs in 3-blocks (translations, optionally rotations), a
symmetric positive-definite mass matrix (lumped, or "consistent": fully
coupled between nodes and between translations and rotations), a free
stiffness whose null space is exactly the six rigid motions, bearing points
on the local axes (motor/resolver sides as in the thesis's Table 2.2) whose
rigid-fit operator is a least-squares fit over nearby nodes, the thesis's
supports (motor u_y = u_z = th_x = 0, resolver u = 0, on the bearing fit),
and supported modes from the generalised eigenproblem in the null space of
the supports -- the same contract as ``docs/body-data.md``.

The oracle (``Oracle``) writes the chain's Lagrangian directly from nodal
masses and nodal kinematics -- node positions x_k = o_n + A_n (r_k + u_k)
differentiated by JAX, frame poses built by composing rotation matrices, the
inside frame found by solving the bearing conditions, the elastic energy
1/2 u^T K u from the nodal stiffness -- with no modal integral anywhere,
and gets M(y) and f(y, y', t) by automatic differentiation of L.
"""

import numpy as np
import scipy.linalg

from gimbal_reduction.reduction import modal_integrals
from gimbal_reduction.solver.bodydata import rigid_modes, skew
from gimbal_reduction.solver.dynamics import multibody

MOTOR_SIGN = {2: 1.0, 3: 1.0, 4: -1.0, 5: 1.0}           # thesis Table 2.2
HALF_OUTER = {2: 3.625, 3: 3.125, 4: 2.625, 5: 1.935}    # half bearing distances [in]
HALF_INNER = {2: 3.125, 3: 2.625, 4: 1.935}
RADIUS = {2: 3.375, 3: 2.875, 4: 2.375, 5: 1.2}
# XLA compiler options of the oracle's compiled functions: compile quickly rather than run quickly
XLA_QUICK_COMPILE = {"xla_backend_optimization_level": 0, "xla_llvm_disable_expensive_passes": True}


def bearing_points(number):
    """(4, 3): input motor, input resolver, output motor, output resolver (platform: NaN rows)."""
    a = HALF_OUTER[number]
    s = MOTOR_SIGN[number]
    pts = np.full((4, 3), np.nan)
    pts[0] = [s * a, 0.0, 0.0]
    pts[1] = [-s * a, 0.0, 0.0]
    if number < 5:
        b = HALF_INNER[number]
        child_sign = MOTOR_SIGN[number + 1]   # child's motor on +-x_child = +-z_parent
        pts[2] = [0.0, 0.0, child_sign * b]
        pts[3] = [0.0, 0.0, -child_sign * b]
    return pts


def rigid_fit_operator(node_pos, center):
    """(6, 3k): least-squares rigid motion (u at center, theta) of k nodes' translations."""
    rows = []
    for p in node_pos:
        d = p - center
        rows.append(np.hstack([np.eye(3), -skew(d)]))   # u + theta x d
    A = np.vstack(rows)
    return np.linalg.pinv(A)


def synthetic_body(rng, number, n_nodes=6, rotations=False, consistent=False, n_modes=3,
                   omega_max=400.0, point_mass=True):
    """A small random body with the contract's data (dict like a body file)."""
    pts = bearing_points(number)
    has_output = number < 5
    bearing_nodes = pts if has_output else pts[:2]
    R = RADIUS[number]
    ang = rng.uniform(0, 2 * np.pi, n_nodes)
    extra = np.column_stack([R * np.cos(ang), rng.uniform(-0.25, 0.25, n_nodes), R * np.sin(ang)])
    nodes = np.vstack([bearing_nodes, extra])
    nn = nodes.shape[0]
    per = 6 if rotations else 3
    ndof = nn * per
    dof_coords = np.repeat(nodes, per, axis=0)
    dof_component = np.tile(np.arange(per), nn)
    trans = np.flatnonzero(dof_component < 3)
    # mass
    m = rng.uniform(0.002, 0.01, nn)
    if point_mass:
        m[-1] *= 3.0
    M = np.zeros((ndof, ndof))
    for k in range(nn):
        M[k * per:k * per + 3, k * per:k * per + 3] = m[k] * np.eye(3)
        if rotations:
            Jr = rng.uniform(1e-5, 4e-5) * np.diag(rng.uniform(0.3, 1.0, 3))
            M[k * per + 3:k * per + 6, k * per + 3:k * per + 6] = Jr
    if consistent:
        A = rng.normal(size=(ndof, ndof)) * 0.002 / np.sqrt(ndof)
        M = M + A @ A.T
        # plus node-to-node isotropic translation coupling (bar-like elements)
        for k in range(nn - 1):
            c = 0.3 * min(m[k], m[k + 1])
            for a in range(3):
                i, j = k * per + a, (k + 1) * per + a
                M[i, i] += c
                M[j, j] += c
                M[i, j] += c / 2
                M[j, i] += c / 2
    M = 0.5 * (M + M.T)
    X = rigid_modes(dof_coords, dof_component)
    # free stiffness with null space = rigid motions
    P = np.eye(ndof) - X @ np.linalg.pinv(X)
    B = rng.normal(size=(ndof, ndof))
    K = P @ (B @ B.T + ndof * np.eye(ndof)) @ P
    K = 0.5 * (K + K.T)
    # bearing operator: rigid fit over the bearing node and its 3 nearest nodes
    Bop = np.zeros((24, ndof))
    for b in range(4):
        if not np.all(np.isfinite(pts[b])):
            continue
        d = np.linalg.norm(nodes - pts[b], axis=1)
        near = np.argsort(d)[:4]
        fit = rigid_fit_operator(nodes[near], pts[b])
        for col, k in enumerate(near):
            Bop[6 * b:6 * b + 6, k * per:k * per + 3] = fit[:, 3 * col:3 * col + 3]
    # supports: input motor u_y, u_z, th_x; input resolver u_x, u_y, u_z
    C = Bop[[1, 2, 3, 6, 7, 8]]
    if abs(np.linalg.det(C @ X)) < 1e-8:
        raise RuntimeError("supports do not remove the rigid motions")
    T = scipy.linalg.null_space(C)
    Kt, Mt = T.T @ K @ T, T.T @ M @ T
    lam, V = scipy.linalg.eigh(0.5 * (Kt + Kt.T), 0.5 * (Mt + Mt.T))
    scale = (omega_max ** 2) / lam[n_modes - 1] if n_modes else 1.0
    K *= scale
    lam *= scale
    modes = T @ V[:, :n_modes]
    modes /= np.sqrt(np.einsum("ij,ij->j", modes, M @ modes))
    return {
        "number": number, "M": M, "K": K, "T": T, "modes": modes, "eigenvalues": lam[:n_modes],
        "rigid_modes": X, "dof_coords": dof_coords, "dof_component": dof_component,
        "bearing_points": pts, "bearing_operator": Bop,
        "bearing_modes": (Bop @ modes).T.reshape(n_modes, 4, 6),
        "nodes": nodes, "dofs_per_node": per, "translation_dofs": trans,
    }


def chain_body(data, damping_ratio=0.0, rotate_rotation_blocks=True):
    """multibody.Body from a synthetic body dict (the production path)."""
    integ = modal_integrals.chain_integrals(
        data["M"], data["modes"], data["rigid_modes"], data["dof_coords"], data["dof_component"],
        data["bearing_modes"], data["bearing_points"], rotate_rotation_blocks=rotate_rotation_blocks)
    return multibody.make_body(data["number"], integ, data["eigenvalues"], damping_ratio)


def synthetic_chain(seed=0, n_modes=(3, 2, 2, 2), rotations=(True, False, True, False),
                    consistent=(True, False, False, True), damping_ratio=0.0, omega_max=400.0):
    """(Chain, list of body dicts) of four random synthetic bodies."""
    rng = np.random.default_rng(seed)
    datas = [synthetic_body(rng, n, n_modes=D, rotations=rot, consistent=con, omega_max=omega_max)
             for n, D, rot, con in zip((2, 3, 4, 5), n_modes, rotations, consistent)]
    chain = multibody.Chain(tuple(chain_body(d, damping_ratio) for d in datas))
    return chain, datas


def rigid_body(number, mass, inertia_diag, com=(0.0, 0.0, 0.0)):
    """A rigid body (no modes): mass, principal inertia about the origin, centre of mass."""
    c = np.asarray(com, float)
    Mr = np.zeros((6, 6))
    Mr[:3, :3] = mass * np.eye(3)
    Mr[3:, :3] = mass * skew(c)
    Mr[:3, 3:] = -mass * skew(c)
    Mr[3:, 3:] = np.diag(inertia_diag)
    integ = {"rigid_mass": Mr, "momentum": np.zeros((6, 0)),
             "inertia_gradient": np.zeros((0, 6, 6)), "coriolis": np.zeros((0, 3, 0)),
             "inside_translation": np.zeros((3, 0)), "inside_rotation": np.zeros((3, 0))}
    return multibody.make_body(number, integ, np.zeros(0))


# ------------------------------------------------------------------ the oracle
def jax_available():
    """Whether JAX (optional: only the oracle needs it) can be imported."""
    try:
        import jax  # noqa: F401  (optional heavy dependency, imported only when asked for)
        return True
    except Exception:
        return False


class Oracle:
    """Lagrangian of the chain from nodal data, differentiated by JAX.

    datas: four synthetic body dicts; case: fixed case axis (3,) with
    phi'' = amp cos(2 pi freq t + phase), phi'(0) = omega0; damping (4,) ratios.
    """

    def __init__(self, datas, axis=(1.0, 0.0, 0.0), amp=0.0, freq=0.0, phase=0.0, omega0=0.0,
                 damping_ratio=0.0, rho=multibody.GIMBAL_OFFSET,
                 rotate_rotation_blocks=True):
        import jax  # optional heavy dependency: imported only when an oracle is built
        jax.config.update("jax_enable_x64", True)
        import jax.numpy as jnp
        self.jax, self.jnp = jax, jnp
        self.datas = datas
        a = np.asarray(axis, float)
        self.axis = a / np.linalg.norm(a)
        self.amp, self.freq, self.phase, self.omega0 = amp, freq, phase, omega0
        self.rho = np.asarray(rho, float)
        self.rot_blocks = rotate_rotation_blocks
        self.n_modes = [d["modes"].shape[1] for d in datas]
        self.damping = np.concatenate(
            [2 * damping_ratio * np.sqrt(d["eigenvalues"]) for d in datas])
        # XLA's CPU compilation of the differentiated Lagrangian (~10^4 HLO lines) is what a
        # first call costs (~12 CPU s with XLA's defaults); without the backend's optimisation
        # passes it takes half that, and the few evaluations the checks make do not notice the
        # slower code.  The arithmetic is the same up to rounding (1e-16 relative, measured).
        self._equations = jax.jit(self._raw_equations, compiler_options=XLA_QUICK_COMPILE)
        self._momentum = jax.jit(jax.grad(self.lagrangian, argnums=1), compiler_options=XLA_QUICK_COMPILE)

    def case_motion(self):
        a = np.array(self.amp) * self.axis
        return multibody.CaseMotion(amplitude=tuple(a), frequency=(self.freq,) * 3,
                                    phase=(self.phase,) * 3, omega0=tuple(self.omega0 * self.axis))

    # --- rotations
    def _rx(self, a):
        jnp = self.jnp
        c, s = jnp.cos(a), jnp.sin(a)
        return jnp.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])

    def _ry(self, a):
        jnp = self.jnp
        c, s = jnp.cos(a), jnp.sin(a)
        return jnp.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])

    def _rz(self, a):
        jnp = self.jnp
        c, s = jnp.cos(a), jnp.sin(a)
        return jnp.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def _case_angle(self, t):
        jnp = self.jnp
        w0 = self.omega0
        if self.freq == 0.0:
            return w0 * t + 0.5 * self.amp * np.cos(self.phase) * t * t
        W = 2 * np.pi * self.freq
        return (w0 * t + self.amp / W * ((np.cos(self.phase) - jnp.cos(W * t + self.phase)) / W
                                         - t * np.sin(self.phase)))

    def _axis_rotation(self, phi):
        jnp = self.jnp
        k = jnp.asarray(self.axis)
        Kx = jnp.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
        return jnp.eye(3) + jnp.sin(phi) * Kx + (1 - jnp.cos(phi)) * Kx @ Kx

    def _inside_frame(self, data, u):
        """Solve the bearing conditions for the inside frame's (t, theta)."""
        jnp = self.jnp
        bm = (jnp.asarray(data["bearing_operator"]) @ u).reshape(4, 6)
        pm, pr = data["bearing_points"][2], data["bearing_points"][3]
        e = (pm - pr) / np.linalg.norm(pm - pr)
        n1 = np.cross(e, [1.0, 0.0, 0.0]) if abs(e[0]) < 0.9 else np.cross(e, [0.0, 1.0, 0.0])
        n1 /= np.linalg.norm(n1)
        n2 = np.cross(e, n1)
        rows, rhs = [], []

        def disp_row(p, n):     # n . (t + theta x p) = [n, p x n] . [t, theta]
            return np.concatenate([n, np.cross(p, n)])
        for p, ub in ((pm, bm[2, :3]), (pr, bm[3, :3])):
            for n in (n1, n2):
                rows.append(disp_row(p, n))
                rhs.append(jnp.dot(n, ub))
        rows.append(disp_row(pr, e))
        rhs.append(jnp.dot(e, bm[3, :3]))
        rows.append(np.concatenate([np.zeros(3), e]))
        rhs.append(jnp.dot(e, bm[2, 3:]))
        sol = jnp.linalg.solve(jnp.asarray(np.array(rows)), jnp.stack(rhs))
        return sol[:3], sol[3:]

    def poses(self, y, t):
        """Per body: (A, o, u): axes, origin (inertial) and nodal displacement vector."""
        jnp = self.jnp
        A1 = self._axis_rotation(self._case_angle(t))
        A = A1 @ jnp.asarray(multibody.CASE_TO_OUTER) @ self._rx(y[0])
        o = A1 @ jnp.asarray(self.rho)
        out = []
        start = 4
        for k, data in enumerate(self.datas):
            D = self.n_modes[k]
            q = y[start:start + D]
            start += D
            u = jnp.asarray(data["modes"]) @ q
            out.append((A, o, u))
            if k < 3:
                t_in, th = self._inside_frame(data, u)
                E = self._rx(th[0]) @ self._ry(th[1]) @ self._rz(th[2])
                o = o + A @ t_in
                A = A @ E @ jnp.asarray(multibody.PARENT_TO_CHILD) @ self._rx(y[k + 1])
        return out

    def lagrangian(self, y, yd, t):
        jax, jnp = self.jax, self.jnp
        P, Pd = jax.jvp(lambda yy, tt: self.poses(yy, tt), (y, t), (yd, jnp.ones_like(t)))
        L = 0.0
        for data, (A, o, u), (Ad, od, ud) in zip(self.datas, P, Pd):
            W = A.T @ Ad
            om = jnp.array([W[2, 1], W[0, 2], W[1, 0]])
            per = data["dofs_per_node"]
            nn = data["nodes"].shape[0]
            r = jnp.asarray(data["nodes"])
            ub = u.reshape(nn, per)
            udb = ud.reshape(nn, per)
            # translations: exact velocity of x_k = o + A (r_k + u_k) in body axes
            x_dot_body = (A.T @ od)[None, :] + (W @ (r + ub[:, :3]).T).T + udb[:, :3]
            delta_t = jnp.cross(om[None, :], ub[:, :3])
            blocks_v = [x_dot_body]
            blocks_d = [delta_t]
            if per == 6:
                th = ub[:, 3:]
                rot_turn = jnp.cross(om[None, :], th) if self.rot_blocks else 0.0 * th
                blocks_v.append(om[None, :] + udb[:, 3:] + rot_turn)
                blocks_d.append(rot_turn)
            V = jnp.concatenate(blocks_v, axis=1).reshape(-1)
            Dl = jnp.concatenate(blocks_d, axis=1).reshape(-1)
            Mn = jnp.asarray(data["M"])
            L = L + 0.5 * V @ Mn @ V - 0.5 * Dl @ Mn @ Dl - 0.5 * u @ jnp.asarray(data["K"]) @ u
        return L

    def _raw_equations(self, y, yd, t):
        jax, jnp = self.jax, self.jnp
        L = self.lagrangian
        M = jax.hessian(L, argnums=1)(y, yd, t)
        dLdy = jax.grad(L, argnums=0)(y, yd, t)
        p = jax.grad(L, argnums=1)
        _, dp = jax.jvp(lambda yy, tt: p(yy, yd, tt), (y, t), (yd, jnp.ones_like(t)))
        return M, dLdy - dp

    def equations(self, y, yd, t, torque=(0.0, 0.0, 0.0, 0.0)):
        """(M (n, n), f (n,)) of M y'' = f: Lagrange's equations by automatic differentiation
        (f = dL/dy - d/dt(dL/dy') + y'' terms removed, minus modal damping, plus motor torque)."""
        jnp = self.jnp
        M, f = self._equations(jnp.asarray(y, dtype=jnp.float64), jnp.asarray(yd, dtype=jnp.float64),
                               jnp.asarray(float(t), dtype=jnp.float64))
        f = np.array(f)
        f[4:] -= self.damping * np.asarray(yd)[4:]
        f[:4] += np.asarray(torque, float)
        return np.array(M), f

    def momentum(self, y, yd, t):
        """dL/dy' (n,): generalised momenta."""
        jnp = self.jnp
        return np.array(self._momentum(jnp.asarray(y, dtype=jnp.float64),
                                       jnp.asarray(yd, dtype=jnp.float64),
                                       jnp.asarray(float(t), dtype=jnp.float64)))
