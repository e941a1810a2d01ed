"""Dense baseline right-hand side: assemble M(y), factorise it, solve -- at every evaluation.

The textbook way to get the accelerations of ``M(y) y'' = tau - c(y, y', t)``
(thesis eq 2.1) is the one the structured solver (``gimbal_reduction.solver.dynamics.compiled``: the
articulated-body recursion with every modal block eliminated by Woodbury,
docs/dynamics.md Section 3) is benchmarked against:

1. the bias ``c`` by the recursive Newton-Euler inverse dynamics at y'' = 0
   (the project's compiled one, ``compiled.FastChain.inverse_dynamics``);
2. the full dense mass matrix ``M(y)`` (n x n, n = 4 + sum D);
3. a dense Cholesky factorisation of M and two triangular solves (LAPACK
   ``dpotrf`` / ``dpotrs``).  M(y), the kinetic energy's Hessian, is positive
   definite at physical states; the first-order energy (docs/dynamics.md
   Section 2) is not at unphysically large modal amplitudes (q ~ 1e-2 on the
   small synthetic test bodies), and there LU with partial pivoting takes over
   (counted in ``rhs.stats["lu_fallbacks"]``).

It is meant to be a *fair* baseline, not a slow one: everything is compiled
or LAPACK, and M is assembled the efficient way, from the kinetic energy
``T = 1/2 sum_k v_k^T N_k v_k`` with ``v_k = [w_k; q'_k] = [J_k; E_k] y'``
(``J_k`` (6, n) the twist Jacobian of body k, ``E_k`` the selector of its
modal rates, ``N_k = [[M_X(q), B(q)], [B(q)^T, I]]``)::

    M = sum_k J_k^T (M_X J_k + B E_k)  +  sum_k E_k^T B^T J_k  +  I_modal

The first sum is ONE matrix product (n x 24)(24 x n) with the four bodies'
J_k and P_k = M_X J_k + B E_k stacked -- the composite-rigid-body idea
written for floating-frame bodies: O(48 n^2) flops, while the Cholesky
factorisation costs n^3 / 3.  ``assembly="columns"`` instead builds M column
by column from n + 1 inverse-dynamics calls with unit accelerations
(Walker & Orin's method 1, what ``linearized.mass_matrix_fast`` does):
O(n sum D^2), the naive textbook route, kept for comparison.

Public API (same call signature as ``compiled.make_rhs``)::

    rhs = make_dense_rhs(chain, case, torque)     # rhs(t, y, y') -> y''  (n,)
    rhs.rk4_steps(y, y', t0, h, n_steps)          # -> (y, y'), Python loop of rk4_step
    rhs.mass_matrix(y)                            # M(y) (n, n)

Units: y [rad; modal], y' per second, y'' per second squared, t [s],
torque [in lbf].
"""

import copy

import numpy as np
from scipy.linalg import lapack

from gimbal_reduction.solver.dynamics import compiled, multibody
from gimbal_reduction.solver.dynamics.integrators import rk4_step

ASSEMBLIES = ("composite", "columns")


class DenseSolveError(ArithmeticError):
    """M(y) is not positive definite (dense Cholesky failed)."""


def pack_dense(chain):
    """The chain's flat arrays for the mass-matrix kernel: the same as the structured
    solver's (``compiled.pack``: modal counts and offsets, rigid masses, modal rows
    V = [P; H; Psi; Theta], inertia-gradient rows, Coriolis tensors, joint axes)."""
    return compiled.pack(chain)


# The composite assembly (``_mass_factors``, ``Workspace``, ``mass_matrix_composite``) lives
# in ``gimbal_reduction.solver.dynamics.compiled``: the exponential integrator's linearisation and the RK4
# bound's coupled frequencies use it too.
mass_matrix_composite = compiled.mass_matrix_composite
Workspace = compiled.Workspace


def mass_matrix_columns(fast_chain, y, out=None):
    """M(y) (n, n) column by column, n + 1 compiled inverse-dynamics calls with unit
    accelerations (Walker-Orin method 1: ``compiled.FastChain.mass_matrix_by_columns``);
    copied into ``out`` if given."""
    M = fast_chain.mass_matrix_by_columns(y)
    if out is None:
        return M
    out[...] = M
    return out


def cholesky_solve(M, f):
    """x (n,) with M x = f by Cholesky (LAPACK dpotrf / dpotrs, n^3 / 3 flops), M (n, n)
    symmetric, overwritten; None when M is not positive definite."""
    # M is symmetric, so its C-order buffer is also its Fortran-order transpose: no copy
    chol, info = lapack.dpotrf(M.T, lower=1, clean=0, overwrite_a=1)
    if info != 0:
        return None
    x, info = lapack.dpotrs(chol, f, lower=1)
    return x if info == 0 else None


def lu_solve(M, f):
    """x (n,) with M x = f by LU with partial pivoting (LAPACK dgetrf / dgetrs), M (n, n)
    overwritten.  Raises DenseSolveError if M is singular."""
    lu, piv, info = lapack.dgetrf(M, overwrite_a=1)
    if info != 0:
        raise DenseSolveError(f"dense LU of M(y) failed (LAPACK dgetrf info {info}): M is singular")
    x, info = lapack.dgetrs(lu, piv, f)
    if info != 0:
        raise DenseSolveError(f"dense LU solve failed (LAPACK dgetrs info {info})")
    return x


def case_twist_function(case):
    """twist(t) -> (w1 (6,), dw1 (6,)): the case twist [0; omega] [rad/s] and its rate
    [rad/s^2] in case axes (``multibody.CaseMotion.twist``)."""
    return case.twist


def make_dense_rhs(chain, case=None, torque=None, assembly="composite"):
    """rhs(t, y, y') -> y'' (n,) by dense assembly and Cholesky at every call.

    chain: ``multibody.Chain``; case: ``multibody.CaseMotion`` (default at rest);
    torque: (4,) motor torques [in lbf] or a callable t -> (4,); assembly:
    "composite" (default, the fair baseline) or "columns" (n + 1 inverse
    dynamics).  The returned function carries ``rk4_steps``, ``mass_matrix``,
    ``fast_chain``, ``assembly`` and ``stats``.
    """
    if assembly not in ASSEMBLIES:
        raise ValueError(f"unknown assembly {assembly!r}; known: {', '.join(ASSEMBLIES)}")
    case = case or multibody.CaseMotion()
    fc = compiled.FastChain(chain)
    data = pack_dense(chain)
    tau_f = multibody.torque_function(torque)
    const_tau = None if callable(torque) else np.asarray(tau_f(0.0), float)
    twist = case_twist_function(case)
    n = chain.n_coordinates
    zero = np.zeros(n)
    stats = {"lu_fallbacks": 0}

    work = Workspace(n)

    def assemble(y):            # into the reused buffer (the Cholesky overwrites it)
        if assembly == "composite":
            return mass_matrix_composite(data, y, work)
        return mass_matrix_columns(fc, y, work.M)

    def mass_matrix(y):
        """M(y) (n, n), a new array."""
        return assemble(y).copy()

    def rhs(t, y, yd):
        w1, dw1 = twist(t)
        f = -fc.inverse_dynamics(y, yd, zero, w1, dw1)           # -c(y, y', t)
        f[:4] += const_tau if const_tau is not None else np.asarray(tau_f(t), float)
        x = cholesky_solve(assemble(y), f)
        if x is None:       # not positive definite: only at unphysically large q (module doc)
            stats["lu_fallbacks"] += 1
            x = lu_solve(assemble(y), f)
        return x

    def rk4_steps(y, yd, t0, h, n_steps):
        """n_steps classical RK4 steps from (t0, y, y'); returns (y, y')."""
        y, yd = np.array(y, float), np.array(yd, float)
        for i in range(int(n_steps)):
            y, yd = rk4_step(rhs, t0 + i * h, y, yd, h)
        return y, yd

    rhs.rk4_steps = rk4_steps
    rhs.mass_matrix = mass_matrix
    rhs.fast_chain = fc
    rhs.assembly = assembly
    rhs.stats = stats
    return rhs


def dense_problem(problem, assembly="composite"):
    """A copy of a ``problem.Problem`` whose rhs (and so RK4 and DOP853) is the dense
    baseline, without the compiled RK4 paths; its omega_max (stability bound), energy
    monitor and implicit-solver hooks are the original's."""
    out = copy.copy(problem)
    out.rhs = make_dense_rhs(problem.chain, problem.case, problem.torque, assembly)
    out.rk4_steps = None
    out.rk4_run = None
    return out
