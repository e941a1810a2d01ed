"""The field's default bases of one body: Craig-Bampton, load-dependent Ritz vectors, dominance.

Three ways the structural-dynamics tools reduce a component, here in the terms of a body file
(docs/body-data.md: M, K, T the admissible displacements with the input bearings supported, the
rigid-fit ``bearing_operator`` whose rows 6b..6b+5 give the motion (u_x, u_y, u_z, th_x, th_y,
th_z) [in, rad] of bearing b):

* **Orthonormalised Craig-Bampton** (``craig_bampton_stage`` then ``craig_bampton_basis``), the
  basis of an Adams MNF, a Simpack FEMBS or an Abaqus substructure.  The *output interface* of a
  ring is the six DOFs through which the next body is supported (``output_interface``):
  with e the bearing axis (output motor minus output resolver point) and p1, p2 two unit vectors
  across it,

      C = [p1.u_m; p2.u_m; p1.u_r; p2.u_r; e.u_r; e.th_m]          (6, ndof)

  (u_m, th_m of the output motor b = 2, u_r of the output resolver b = 3): both bearings across
  the axis, the resolver along it, the motor's rotation about it -- statically determinate, as
  the input support is, and the six motions from which the inside frame is built
  (``modal_integrals.inside_frame_motion``).  With G = T (T^T K T)^-1 T^T the supported body's
  flexibility:

  - *constraint modes* Psi = G C^T (C G C^T)^-1 (ndof, 6): the least-energy admissible shape
    with C Psi = I (a unit motion of one interface DOF, the others held; the Lagrange condition
    K Psi = C^T mu gives Psi in the range of G C^T);
  - *fixed-interface modes*: K phi = lambda M phi on range(T) with C phi = 0, by shift-invert
    Lanczos at 0 whose operator is the held body's flexibility
    G_c = G - G C^T (C G C^T)^-1 C G (every iterate is admissible and held);
  - *orthonormalised*: Rayleigh-Ritz on V = [Psi, Phi_N] (``rayleigh_ritz``): solve
    (V^T K V) N = (V^T M V) N D and use Y = V N, so Y^T M Y = I, Y^T K Y = D, diagonal -- the
    reduced-model file's contract for modes.  The Ritz values bound the supported eigenvalues
    from above, entry by entry (Courant-Fischer: range(V) lies in range(T)), and the constraint
    modes reproduce exactly the static response to loads through the interface (C^T f lies in
    K range(Psi)).
  The platform has no output interface: its Craig-Bampton basis is its lowest supported modes.

* **Load-dependent Ritz vectors** (Wilson, Yuan & Dickens 1982; ``load_dependent_ritz``): the
  block Krylov sequence G F, (G M) G F, (G M)^2 G F, ... of the body's load vectors F
  (``load_vectors``: on a ring first the unit loads C^T e_j the next body puts on it through the
  six DOFs of its output interface -- the bearing loads the statically determinate support
  transmits -- then the other six unit forces and moments at the output bearings; on the
  platform, which has none, the unit forces and moments at its input bearings; then the
  rigid-body inertia loads M X), M-orthonormalised by classical Gram-Schmidt twice, a column
  dropped when less than ``DEFLATION`` of it is new, then Rayleigh-Ritz.  The first block is the
  static response to the loads: on a ring its first six vectors span the constraint modes (the
  Craig-Bampton basis without fixed-interface modes), and the block holds the static correction
  mode of every output-bearing load case made without kept modes.

* **Dominance** of a supported mode (``dominance_scores``): its share of the static transfer
  from the loads B to the bearing motions C,

      d_i = ||phi_i^T B^||_2 ||C^ phi_i||_2 / Omega_i^2,

  with B^ (ndof, p) the transmitted loads and the inertia loads (``load_vectors`` with
  ``transmitted_only``) each scaled to unit static compliance (b^T G b = 1) and C^ (q, ndof) the
  motions the loads work on (``load_motions``: a ring's output interface, the platform's input
  bearing rows) each scaled to c G c^T = 1, so
  the score is dimensionless and independent of the units of forces, moments, translations and
  rotations.  Summed over every supported mode, phi_i phi_i^T / Omega_i^2 = G, so a column of
  B^ and a row of C^ give sum_i (c^ phi_i)(phi_i^T b^)/Omega_i^2 = c^ G b^ <= 1: each mode's
  score is its part of a transfer of order one.  Loads or motions on supported directions (zero
  compliance) are left out.

Arrays: ndof DOFs of the free FE model, m admissible coordinates; modes (ndof, k) [in per unit
modal mass], eigenvalues (k,) [(rad/s)^2]; loads [lbf, in lbf].
"""

import json
import os
import sys
import time

import h5py
import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg

from gimbal_reduction.reduction import modal_integrals
from gimbal_reduction.reduction.errors import MissingBearingError, ReductionError
from gimbal_reduction.reduction.names import CB_FIXED_MODES
from gimbal_reduction.solver import bodyconfig
from gimbal_reduction.solver.bodydata import BEARING_NAMES, read_body_file
from gimbal_reduction.workflow import cli
from gimbal_reduction.workflow.provenance import atomic_h5, versions

OUTPUT_MOTOR, OUTPUT_RESOLVER = 2, 3
INTERFACE_NAMES = ("output_motor_across_1", "output_motor_across_2", "output_resolver_across_1",
                   "output_resolver_across_2", "output_resolver_along", "output_motor_about")
LOAD_COMPONENTS = ("fx", "fy", "fz", "mx", "my", "mz")
# a Krylov column is dropped when its part not yet spanned is below this fraction of its
# M-norm: 1e-8 is ~1e8 x machine precision, well above round-off of the solves (iteratively
# refined), well below any load a body resists
DEFLATION = 1e-8
# a load or motion whose admissible part is below this fraction of its size acts on supported
# directions only (``static_modes`` uses the same test for its load cases)
SUPPORTED_COMPLIANCE = 1e-10


def has_output_bearings(data):
    """True if the body has output bearings (rings), False for the platform."""
    points = np.asarray(data["bearing_points"], float)
    return bool(np.all(np.isfinite(points[[OUTPUT_MOTOR, OUTPUT_RESOLVER]])))


def _interface_axes(data):
    """(e, p1, p2): the unit bearing axis (output motor minus output resolver point) and two unit
    vectors across it (the coordinate axis nearest perpendicular, made orthogonal, and e x p1)."""
    points = np.asarray(data["bearing_points"], float)
    axis = points[OUTPUT_MOTOR] - points[OUTPUT_RESOLVER]
    d = float(np.linalg.norm(axis))
    if d == 0.0:
        raise ReductionError("the output motor and resolver points coincide")
    e = axis / d
    p1 = np.eye(3)[int(np.argmin(np.abs(e)))]
    p1 = p1 - e * (p1 @ e)
    p1 /= np.linalg.norm(p1)
    return e, p1, np.cross(e, p1)


def output_interface(data):
    """The output interface C (6, ndof) CSR of a ring (module docstring; rows INTERFACE_NAMES):
    combinations of the rigid-fit rows of the output motor and resolver, across and along the
    bearing axis.  MissingBearingError for the platform."""
    if not has_output_bearings(data):
        raise MissingBearingError(f"{data.get('path', 'body')}: no output bearings (the platform has "
                                  f"no output interface)")
    e, p1, p2 = _interface_axes(data)
    B = sp.csr_matrix(data["bearing_operator"])
    u_m, th_m = B[6 * OUTPUT_MOTOR:6 * OUTPUT_MOTOR + 3], B[6 * OUTPUT_MOTOR + 3:6 * OUTPUT_MOTOR + 6]
    u_r = B[6 * OUTPUT_RESOLVER:6 * OUTPUT_RESOLVER + 3]
    rows = [sp.csr_matrix(p1) @ u_m, sp.csr_matrix(p2) @ u_m, sp.csr_matrix(p1) @ u_r,
            sp.csr_matrix(p2) @ u_r, sp.csr_matrix(e) @ u_r, sp.csr_matrix(e) @ th_m]
    return sp.vstack(rows).tocsr()


INPUT_BEARINGS = (0, 1)


def load_motions(data):
    """(C (q, ndof) CSR, names): the motions the body's joint loads work on -- a ring's output
    interface (``output_interface``, q = 6); the platform's input motor and resolver rows
    (u_x .. th_z of each, q = 12: it has no output bearings, its joint loads act there)."""
    if has_output_bearings(data):
        return output_interface(data), list(INTERFACE_NAMES)
    B = sp.csr_matrix(data["bearing_operator"])
    rows = sp.vstack([B[6 * b:6 * b + 6] for b in INPUT_BEARINGS]).tocsr()
    return rows, [f"{BEARING_NAMES[b]}_{c}" for b in INPUT_BEARINGS for c in LOAD_COMPONENTS]


def load_vectors(data, transmitted_only=False):
    """(F (ndof, p), names): the unit loads C^T e_j on the motions of ``load_motions`` [lbf,
    in lbf]; on a ring then (unless ``transmitted_only``) the unit loads on the six output-bearing
    motions the interface leaves free (``free_interface_rows``); then the inertia loads M X of
    unit rigid accelerations (x, y, z translations [in/s^2], rotations [rad/s^2])."""
    C, names = load_motions(data)
    cols = [np.asarray(C.T.todense())]
    if has_output_bearings(data) and not transmitted_only:
        cols.append(np.asarray(free_interface_rows(data).T.todense()))
        names = names + list(FREE_NAMES)
    cols.append(np.asarray(data["M"] @ np.asarray(data["rigid_modes"], float)))
    names = names + [f"inertia_{a}" for a in ("ux", "uy", "uz", "rx", "ry", "rz")]
    return np.hstack(cols), names


def bearing_motion_rows(data):
    """The outputs C of the dominance score: the motions of ``load_motions``."""
    return load_motions(data)[0]


FREE_NAMES = ("output_motor_along", "output_motor_rot_across_1", "output_motor_rot_across_2",
              "output_resolver_rot_across_1", "output_resolver_rot_across_2", "output_resolver_rot_about")


def free_interface_rows(data):
    """The six output-bearing motions (6, ndof) CSR the output interface leaves free (rows
    FREE_NAMES; axes of ``_interface_axes``): e.u_m, p1.th_m, p2.th_m, p1.th_r, p2.th_r, e.th_r.
    With the interface's six they span all twelve rigid-fit rows of the two output bearings."""
    e, p1, p2 = _interface_axes(data)
    B = sp.csr_matrix(data["bearing_operator"])
    u_m, th_m = B[6 * OUTPUT_MOTOR:6 * OUTPUT_MOTOR + 3], B[6 * OUTPUT_MOTOR + 3:6 * OUTPUT_MOTOR + 6]
    th_r = B[6 * OUTPUT_RESOLVER + 3:6 * OUTPUT_RESOLVER + 6]
    rows = [sp.csr_matrix(e) @ u_m, sp.csr_matrix(p1) @ th_m, sp.csr_matrix(p2) @ th_m,
            sp.csr_matrix(p1) @ th_r, sp.csr_matrix(p2) @ th_r, sp.csr_matrix(e) @ th_r]
    return sp.vstack(rows).tocsr()


def flexibility(data):
    """apply_G of the body (``modal_integrals.supported_flexibility``), factorised once and kept
    in the body's dict (``_apply_G``, shared with the static modes of ``models``)."""
    apply_G = data.get("_apply_G")
    if apply_G is None:
        apply_G = modal_integrals.supported_flexibility(data["K"], data["T"], data["rigid_modes"])
        data["_apply_G"] = apply_G
    return apply_G


# ------------------------------------------------------------------ Rayleigh-Ritz
def rayleigh_ritz(M, K, V):
    """(Y (ndof, n), eigenvalues (n,) ascending) of the basis V (ndof, n): Y = V N with
    (V^T K V) N = (V^T M V) N D, so Y^T M Y = I and Y^T K Y = D.  Each column's sign makes its
    largest entry positive (reproducible files).  ReductionError if V^T M V is singular."""
    V = np.asarray(V, float)
    if V.shape[1] == 0:
        return V.copy(), np.zeros(0)
    Mh, Kh = V.T @ (M @ V), V.T @ (K @ V)
    Mh, Kh = 0.5 * (Mh + Mh.T), 0.5 * (Kh + Kh.T)
    try:
        lam, N = scipy.linalg.eigh(Kh, Mh)
    except np.linalg.LinAlgError as exc:
        raise ReductionError(f"Rayleigh-Ritz: the basis's mass matrix is singular ({exc})") from None
    Y = V @ N
    big = np.argmax(np.abs(Y), axis=0)
    return Y * np.sign(Y[big, np.arange(Y.shape[1])]), lam


# ------------------------------------------------------------------ Craig-Bampton
def craig_bampton_stage(data, n_fixed, tol=1e-10):
    """What a ring's Craig-Bampton bases are made of, for every count up to ``n_fixed``: a dict
    with ``constraint_modes`` (ndof, 6) (C Psi = I), ``fixed_modes`` (ndof, n_fixed) unit modal
    mass, ``fixed_eigenvalues`` (n_fixed,) ascending [(rad/s)^2], ``interface`` C (6, ndof) and
    ``held_residual`` (the largest |C phi| of the fixed modes relative to the bearings' motion
    in the supported modes: 0 up to round-off).  ``tol``: ARPACK's relative accuracy."""
    C = output_interface(data)
    M, K = data["M"], data["K"]
    apply_G = flexibility(data)
    Z = apply_G(np.asarray(C.T.todense()))                     # G C^T (ndof, 6)
    S = np.asarray(C @ Z)                                      # C G C^T (6, 6)
    S = 0.5 * (S + S.T)
    w = np.linalg.eigvalsh(S)
    if not w[0] > 1e-12 * w[-1]:
        raise ReductionError(f"{data.get('path', 'body')}: the output interface is not independent of "
                             f"the supports (C G C^T eigenvalues {w[0]:.2e} .. {w[-1]:.2e})")
    S_lu = scipy.linalg.cho_factor(S)
    Psi = scipy.linalg.cho_solve(S_lu, Z.T).T                  # G C^T (C G C^T)^-1

    def held_flexibility(F):
        # G_c F = G F - G C^T (C G C^T)^-1 C G F: the static response with the interface held
        F = np.asarray(F, float)
        U = apply_G(F)
        return U - Psi @ np.asarray(C @ U)

    ndof = M.shape[0]
    op = scipy.sparse.linalg.LinearOperator((ndof, ndof), matvec=held_flexibility, dtype=float)
    rng = np.random.default_rng(0)
    v0 = held_flexibility(M @ rng.standard_normal(ndof))        # in range(T), held
    n_fixed = int(n_fixed)
    if n_fixed > 0:
        lam, Phi = scipy.sparse.linalg.eigsh(K, k=n_fixed, M=M, sigma=0.0, OPinv=op, which="LM",
                                             v0=v0, tol=tol, ncv=min(ndof - 1, max(2 * n_fixed + 1, 20)))
        order = np.argsort(lam)
        lam, Phi = lam[order], Phi[:, order]
        Phi = Phi / np.sqrt(np.einsum("ij,ij->j", Phi, M @ Phi))
        big = np.argmax(np.abs(Phi), axis=0)
        Phi = Phi * np.sign(Phi[big, np.arange(n_fixed)])
    else:
        lam, Phi = np.zeros(0), np.zeros((ndof, 0))
    modes = np.asarray(data["modes"])
    scale = float(np.max(np.abs(C @ modes))) if modes.size else 1.0
    held = float(np.max(np.abs(C @ Phi)) / scale) if n_fixed else 0.0
    return {"constraint_modes": Psi, "fixed_modes": Phi, "fixed_eigenvalues": lam,
            "interface": C, "held_residual": held}


def craig_bampton_basis(M, K, constraint_modes, fixed_modes, n):
    """(Y (ndof, 6 + n), eigenvalues (6 + n,)): the orthonormalised Craig-Bampton basis of the
    six constraint modes and the ``n`` lowest fixed-interface modes (``rayleigh_ritz``)."""
    if n > fixed_modes.shape[1]:
        raise ReductionError(f"Craig-Bampton: {n} fixed-interface modes asked, {fixed_modes.shape[1]} "
                             f"computed")
    return rayleigh_ritz(M, K, np.hstack([constraint_modes, fixed_modes[:, :n]]))


# ------------------------------------------------------------------ load-dependent Ritz vectors
def load_dependent_ritz(M, apply_G, F, n, deflation=DEFLATION):
    """The first ``n`` M-orthonormal vectors (ndof, n) of the block Krylov sequence
    G F, (G M) G F, ... (module docstring), in the order generated: block by block, within a
    block in the order of F's columns.  Each candidate is orthogonalised against every vector
    kept so far by classical Gram-Schmidt in the M inner product, twice (one pass loses
    orthogonality when most of the candidate is already spanned); it is dropped (deflated) when
    its M-norm after that is at most ``deflation`` times its M-norm before.  ReductionError if
    the sequence spans fewer than n vectors."""
    n = int(n)
    ndof = M.shape[0]
    basis = np.zeros((ndof, 0))
    sources = np.asarray(F, float)          # the block whose images G s are the next candidates
    while basis.shape[1] < n:
        new, j = [], 0
        # only as many solves as vectors still wanted (more where some are deflated)
        while j < sources.shape[1] and basis.shape[1] + len(new) < n:
            need = n - basis.shape[1] - len(new)
            for v in apply_G(sources[:, j:j + need]).T:
                before = np.sqrt(max(float(v @ (M @ v)), 0.0))
                if before == 0.0:
                    continue
                Q = np.hstack([basis] + [q[:, None] for q in new])
                for _ in range(2):
                    v = v - Q @ (Q.T @ (M @ v))
                after = np.sqrt(max(float(v @ (M @ v)), 0.0))
                if after > deflation * before:
                    new.append(v / after)
            j += need
        if not new:
            raise ReductionError(f"load-dependent Ritz: the loads' Krylov sequence spans only "
                                 f"{basis.shape[1]} vectors, {n} asked")
        new = np.column_stack(new)
        basis = np.hstack([basis, new])
        sources = np.asarray(M @ new)
    return basis


def ritz_basis(data, n):
    """(Y (ndof, n), eigenvalues (n,)): the orthonormalised load-dependent Ritz basis of one body
    (``load_vectors``, ``load_dependent_ritz``, ``rayleigh_ritz``)."""
    if n == 0:
        return np.zeros((data["M"].shape[0], 0)), np.zeros(0)
    F, _ = load_vectors(data)
    V = load_dependent_ritz(data["M"], flexibility(data), F, n)
    return rayleigh_ritz(data["M"], data["K"], V)


# ------------------------------------------------------------------ dominance
def unit_compliance(G_cols, cols, T, what):
    """The columns ``cols`` (ndof, p) scaled to unit static compliance c^T G c = 1 (G_cols =
    G cols), those on supported directions left out: a column whose admissible part T^T c is at
    most SUPPORTED_COMPLIANCE of |T|^T |c| (each column judged on its own, so the choice does not
    depend on the units of the others).  Returns (scaled (ndof, p'), kept (p',) indices)."""
    T = sp.csr_matrix(T)
    reach = np.linalg.norm(np.asarray(T.T @ cols), axis=0)
    bound = np.linalg.norm(np.asarray(abs(T).T @ np.abs(cols)), axis=0)
    compliance = np.einsum("ij,ij->j", cols, G_cols)
    kept = np.flatnonzero((reach > SUPPORTED_COMPLIANCE * bound) & (compliance > 0))
    if kept.size == 0:
        raise ReductionError(f"dominance: every {what} acts on supported directions only")
    return cols[:, kept] / np.sqrt(compliance[kept]), kept


def dominance_scores(modes, eigenvalues, loads, outputs, apply_G):
    """d_i (D,) dimensionless of the modes (ndof, D), eigenvalues (D,) [(rad/s)^2], loads B
    (ndof, p) [lbf, in lbf], outputs C (q, ndof) [motions per DOF] (module docstring); apply_G
    from ``modal_integrals.supported_flexibility`` (its ``admissible_basis`` T)."""
    B = np.asarray(loads, float)
    Ct = np.asarray(outputs.T.todense() if sp.issparse(outputs) else np.asarray(outputs).T, float)
    T = apply_G.admissible_basis
    B_hat, _ = unit_compliance(apply_G(B), B, T, "load")
    C_hat, _ = unit_compliance(apply_G(Ct), Ct, T, "output motion")
    Phi = np.asarray(modes, float)
    lam = np.asarray(eigenvalues, float)
    if np.any(lam <= 0):
        raise ReductionError(f"dominance: eigenvalues must be positive (smallest {lam.min():.3e})")
    inputs = np.linalg.norm(Phi.T @ B_hat, axis=1)
    outputs_ = np.linalg.norm(Phi.T @ C_hat, axis=1)
    return inputs * outputs_ / lam


def body_dominance(data, modes=None, eigenvalues=None):
    """``dominance_scores`` of a body file's modes (or of the given ones) with its load vectors
    and bearing motions (``load_vectors``, ``bearing_motion_rows``)."""
    F, _ = load_vectors(data, transmitted_only=True)
    return dominance_scores(data["modes"] if modes is None else modes,
                            data["eigenvalues"] if eigenvalues is None else eigenvalues,
                            F, bearing_motion_rows(data), flexibility(data))


# ------------------------------------------------------------------ the Craig-Bampton stage file
CB_FORMAT = "gimbal-cb-stage-1"


def write_cb_stage(path, stage, body, wall_time_s=0.0):
    """Write a ring's Craig-Bampton stage (``craig_bampton_stage``) atomically: datasets
    ``constraint_modes`` (ndof, 6), ``fixed_modes`` (ndof, n), ``fixed_eigenvalues`` (n,)
    [(rad/s)^2], ``fixed_frequencies_hz`` (n,); attributes ``format``, ``body``, ``config_hash``
    (the body file's), ``interface`` (INTERFACE_NAMES, JSON), ``held_residual``, ``wall_time_s``."""
    attrs = body.get("attrs", {})
    with atomic_h5(path) as f:
        f.attrs["format"] = CB_FORMAT
        f.attrs["body"] = int(body["number"])
        f.attrs["config_hash"] = str(attrs.get("config_hash", ""))
        f.attrs["body_file"] = str(body.get("path", ""))
        f.attrs["interface"] = json.dumps(INTERFACE_NAMES)
        f.attrs["held_residual"] = float(stage["held_residual"])
        f.attrs["wall_time_s"] = float(wall_time_s)
        f.attrs["units"] = "in, lbf, s; modes in per sqrt(lbf s^2/in), eigenvalues (rad/s)^2"
        f.attrs["versions"] = json.dumps(versions())
        f.create_dataset("constraint_modes", data=stage["constraint_modes"])
        f.create_dataset("fixed_modes", data=stage["fixed_modes"])
        f.create_dataset("fixed_eigenvalues", data=stage["fixed_eigenvalues"])
        f.create_dataset("fixed_frequencies_hz", data=np.sqrt(stage["fixed_eigenvalues"]) / (2 * np.pi))


def read_cb_stage(path, body=None):
    """The dict of a Craig-Bampton stage file (``write_cb_stage``); with ``body`` (its body file's
    dict) checked to be that body's and made from that file (config_hash).  ReductionError (one
    line naming the file and the target to rerun) otherwise."""
    path = str(path)
    remedy = f"rerun its target: snakemake --cores 2 --forcerun {path}"
    if not os.path.isfile(path):
        raise ReductionError(f"Craig-Bampton stage file {path} missing (make it: snakemake --cores 2 {path})")
    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("format") != CB_FORMAT:
                raise ReductionError(f"{path}: not a Craig-Bampton stage file of format {CB_FORMAT}: {remedy}")
            out = {k: f[k][()] for k in ("constraint_modes", "fixed_modes", "fixed_eigenvalues")}
            out.update(body=int(f.attrs["body"]), config_hash=str(f.attrs["config_hash"]))
    except ReductionError:
        raise
    except (OSError, KeyError) as exc:
        raise ReductionError(f"{path}: unreadable or incomplete ({exc.__class__.__name__}): {remedy}") from None
    if body is not None:
        if out["body"] != int(body["number"]):
            raise ReductionError(f"{path}: holds body {out['body']}'s Craig-Bampton modes, given for body "
                                 f"{body['number']}")
        theirs = str(body.get("attrs", {}).get("config_hash", ""))
        if out["config_hash"] != theirs:
            raise ReductionError(f"{path}: made from another body file (config_hash {out['config_hash']!r}, "
                                 f"body file {body.get('path', '')} has {theirs!r}; stale): {remedy}")
        if out["constraint_modes"].shape != (body["M"].shape[0], len(INTERFACE_NAMES)):
            raise ReductionError(f"{path}: constraint modes of shape {out['constraint_modes'].shape}, "
                                 f"the body has {body['M'].shape[0]} DOFs: {remedy}")
    return out


def main(argv=None):
    """The Craig-Bampton stage of one ring: its constraint and fixed-interface modes."""
    ap = cli.OneLineParser(prog="gimbal_reduction.reduction.bases",
                           description="Craig-Bampton stage of one ring: the constraint modes of its "
                                       "output interface and its fixed-interface modes.")
    ap.add_argument("--body-file", required=True, help="results/modes/body{n}.h5 (a ring: 2, 3, 4)")
    ap.add_argument("--fixed-modes", type=int, default=CB_FIXED_MODES,
                    help=f"fixed-interface modes to compute (default {CB_FIXED_MODES}, as many as the "
                         f"truth's supported modes)")
    ap.add_argument("--config", help="the current configuration file: a body file of another "
                                     "configuration is refused")
    ap.add_argument("--out", required=True, help="results/reduction/cb/body{n}.h5")
    try:
        args = ap.parse_args(cli.values_joined(sys.argv[1:] if argv is None else argv, ap))
    except SystemExit as exc:
        return exc.code
    t0 = time.perf_counter()
    try:
        if args.fixed_modes < 1:
            raise ReductionError(f"--fixed-modes must be at least 1, got {args.fixed_modes}")
        cli.check_writable(args.out)
        bodyconfig.check_files([args.body_file], args.config)
        body = read_body_file(args.body_file)
        if not has_output_bearings(body):
            raise ReductionError(f"{args.body_file}: body {body['number']} has no output interface (the "
                                 f"platform's Craig-Bampton basis is its lowest supported modes)")
        stage = craig_bampton_stage(body, args.fixed_modes)
    except (ValueError, FileNotFoundError) as exc:
        print(f"gimbal_reduction.reduction.bases: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    wall = time.perf_counter() - t0
    try:
        write_cb_stage(args.out, stage, body, wall)
    except OSError as exc:
        print(f"gimbal_reduction.reduction.bases: {cli.write_failure(args.out, exc)}", file=sys.stderr)
        return 2
    lam = stage["fixed_eigenvalues"]
    print(f"gimbal_reduction.reduction.bases: {args.out}: body {body['number']}, 6 constraint modes, "
          f"{lam.size} fixed-interface modes {np.sqrt(lam[0]) / 2 / np.pi:.1f}..{np.sqrt(lam[-1]) / 2 / np.pi:.1f} Hz, "
          f"held residual {stage['held_residual']:.1e}, {wall:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
