"""Lowest eigenpairs of K x = lambda M x with SLEPc shift-and-invert, and their checks.

Shift-and-invert turns the lowest eigenvalues near the shift sigma into the
largest of (K - sigma M)^-1 M, which Krylov-Schur finds quickly; the shifted
matrix is factorised once (Cholesky, MUMPS). M may be singular (the shell's
drilling rotation has no inertia): its infinite eigenvalues map to zero and
are never returned. For a free-free body K is singular and sigma must be
negative and scaled to the stiffness (a tiny shift gives garbage without any
error from MUMPS), so callers pass a shift proportional to a known eigenvalue.
"""
from __future__ import annotations

from mpi4py import MPI  # noqa: F401  # isort: skip - first: petsc4py finds libmpi through it

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from petsc4py import PETSc
from slepc4py import SLEPc

from gimbal_reduction.workflow.progress import Progress


class EigenSolveError(RuntimeError):
    """The eigen solve did not deliver the requested pairs; one-line message."""


def lowest_eigenpairs(K: PETSc.Mat, M: PETSc.Mat, count: int, shift: float = 0.0,
                      tolerance: float = 1e-12, max_iterations: int = 500, label: str = "body",
                      deflation: list | None = None):
    """The ``count`` eigenpairs nearest above ``shift`` of the pencil (K, M).

    ``deflation``: PETSc Vecs (laid out like K's columns) spanning known eigenvectors, e.g.
    the lowest modes of an earlier solve: the solve works in their M-orthogonal complement
    and returns the ``count`` pairs after them.
    Returns ``(eigenvalues (count,), vectors)`` with eigenvalues ascending in
    (rad/s)^2 and vectors a list of PETSc Vecs (distributed like K's columns).
    """
    n = K.getSize()[0]
    if count >= n:
        raise EigenSolveError(f"{label}: {count} modes requested but the model has only {n} DOFs")
    eps = SLEPc.EPS().create(K.getComm())
    eps.setOperators(K, M)
    eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
    eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
    eps.setDimensions(nev=count)
    eps.setTolerances(tol=tolerance, max_it=max_iterations)
    eps.setTarget(shift)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_REAL)
    st = eps.getST()
    st.setType(SLEPc.ST.Type.SINVERT)
    st.setShift(shift)
    ksp = st.getKSP()
    ksp.setType(PETSc.KSP.Type.PREONLY)
    pc = ksp.getPC()
    pc.setType(PETSc.PC.Type.CHOLESKY)
    pc.setFactorSolverType("mumps")
    if deflation:
        eps.setDeflationSpace(deflation)
    eps.setFromOptions()
    # progress on rank 0 (the job's log): converged pairs of the requested, at each restart
    progress = Progress(f"eigen solve {label}", count, "eigenpairs", quiet=K.getComm().getRank() != 0)
    eps.setMonitor(lambda _eps, its, nconv, _eig, _err:
                   progress.update(min(nconv, count), note=f"Krylov-Schur restart {its}"))
    eps.solve()
    converged = eps.getConverged()
    if converged < count:
        raise EigenSolveError(
            f"{label}: eigen solve converged {converged} of {count} modes in {eps.getIterationNumber()} "
            f"iterations (tolerance {tolerance:g}); raise modes.max_iterations or check the supports")
    values, vectors = [], []
    for i in range(converged):
        vec = K.createVecRight()
        lam = eps.getEigenpair(i, vec)
        values.append(lam.real)
        vectors.append(vec)
    order = np.argsort(values)[:count]
    eps.destroy()
    return np.asarray(values)[order], [vectors[i] for i in order]


def constrained_eigenvalues(K: sp.spmatrix, M: sp.spmatrix, C: sp.spmatrix, count: int,
                            tolerance: float = 1e-10, max_iterations: int = 500, label: str = "body"):
    """The ``count`` lowest eigenvalues of K x = lambda M x on C x = 0, by Lagrange multipliers (serial).

    The pencil ([[K, s C^T], [s C, 0]], [[M, 0], [0, 0]]) has the constrained eigenvalues as its
    finite ones (its multiplier block is massless); shift-and-invert at 0 factorises the
    symmetric indefinite saddle-point matrix (LDL^T, MUMPS). s = mean |diag K| scales the
    constraint rows to the stiffness. Unlike the elimination with master DOFs
    (``bearings.admissible_basis``), whose master rows couple every DOF of a constraint's
    region with every other (a dense block of the region's size squared in T^T K T), the
    constraints only add their own rows: a support spread over a wide patch costs no more
    than a line.
    """
    C = sp.csr_matrix(C)
    scale = float(np.mean(np.abs(K.diagonal())))
    A = sp.bmat([[K, scale * C.T], [scale * C, None]], format="csr")
    B = sp.bmat([[M, None], [None, sp.csr_matrix((C.shape[0], C.shape[0]))]], format="csr")
    values, vectors = lowest_eigenpairs(scipy_to_petsc(A), scipy_to_petsc(B), count, 0.0, tolerance,
                                        max_iterations, label=label)
    for vec in vectors:
        vec.destroy()
    return values


def rayleigh_ritz(K: sp.spmatrix, M: sp.spmatrix, basis: np.ndarray):
    """Re-solve the pencil in span(basis): M-orthonormal vectors, ascending values.

    Cheap (count x count) and exact within the subspace: it restores
    M-orthonormality inside clusters of (near-)repeated eigenvalues, which the
    symmetric rings have in pairs.
    """
    k_small = basis.T @ (K @ basis)
    m_small = basis.T @ (M @ basis)
    k_small, m_small = (k_small + k_small.T) / 2, (m_small + m_small.T) / 2
    values, rotation = scipy.linalg.eigh(k_small, m_small)
    vectors = basis @ rotation
    # deterministic signs: largest-magnitude entry positive
    idx = np.argmax(np.abs(vectors), axis=0)
    vectors *= np.sign(vectors[idx, np.arange(vectors.shape[1])])
    return values, vectors


def relative_residuals(K: sp.spmatrix, M: sp.spmatrix, values: np.ndarray, vectors: np.ndarray,
                       admissible: sp.spmatrix | None = None) -> np.ndarray:
    """(count,) relative residuals ||T^T (K phi - lambda M phi)|| / ||T^T K phi||.

    With supports (T given), K phi - lambda M phi is the reaction at the
    constrained DOFs, so only its projection on the admissible space must vanish.
    """
    residual = K @ vectors - (M @ vectors) * values
    force = K @ vectors
    if admissible is not None:
        residual, force = admissible.T @ residual, admissible.T @ force
    return np.linalg.norm(residual, axis=0) / np.linalg.norm(force, axis=0)


def orthonormality_error(M: sp.spmatrix, vectors: np.ndarray) -> float:
    """max |Phi^T M Phi - I|."""
    gram = vectors.T @ (M @ vectors)
    return float(np.max(np.abs(gram - np.eye(gram.shape[0]))))


def scipy_to_petsc(A: sp.spmatrix, comm=PETSc.COMM_SELF) -> PETSc.Mat:
    """A serial PETSc AIJ copy of a scipy sparse matrix."""
    A = sp.csr_matrix(A)
    A.sort_indices()
    mat = PETSc.Mat().createAIJ(size=A.shape, csr=(A.indptr.astype(PETSc.IntType),
                                                    A.indices.astype(PETSc.IntType), A.data), comm=comm)
    mat.assemble()
    return mat


MASSLESS_RTOL = 1e-10   # a pivot of T^T M T below this fraction of its largest diagonal entry: massless


def massless_split(m_red: np.ndarray, rtol: float = MASSLESS_RTOL):
    """Split the coordinates of a dense PSD mass matrix into massive ones and a null basis.

    Cholesky with complete pivoting (LAPACK ``dpstrf``) stops at the first pivot below
    ``rtol`` times the largest diagonal entry: P^T m_red P = [L11; L21] [L11; L21]^T up to a
    remainder whose entries are below that. Returns ``(S, Z)``: S (r,) the pivoted (massive)
    coordinates, m_red[S][:, S] = L11 L11^T definite, and Z (n, n - r) the null basis
    (Z[R] = I on the other coordinates R, Z[S] = -L11^-T L21^T, so m_red Z vanishes to the
    remainder). On the coarse bodies of the Hughes identities (0.5 and 0.75 in) the kept pivots
    end at 1e-6 and the remainder is 2e-19 of the largest diagonal entry: the cut is clear.
    """
    n = m_red.shape[0]
    scale = float(np.max(np.diag(m_red))) if n else 0.0
    if n == 0 or scale <= 0:
        raise EigenSolveError("the supported mass matrix is zero or empty")
    factor, piv, rank, info = scipy.linalg.lapack.dpstrf(m_red, tol=rtol * scale, lower=1)
    if info < 0:
        raise EigenSolveError(f"pivoted Cholesky of the supported mass matrix failed (info {info})")
    piv = piv[:n] - 1
    S, R = piv[:rank], piv[rank:]
    L11 = np.tril(factor[:rank, :rank])
    L21 = factor[rank:, :rank]
    Z = np.zeros((n, n - rank))
    Z[R, np.arange(n - rank)] = 1.0
    if rank < n:
        Z[S] = -scipy.linalg.solve_triangular(L11, L21.T, lower=True, trans="T")
    return S, Z


def all_supported_modes(K: sp.spmatrix, M: sp.spmatrix, T: sp.spmatrix):
    """Every finite supported eigenpair by a dense solve (coarse meshes only).

    M may be singular (massless drilling rotations). With the massive coordinates S
    and the null basis Z of T^T M T from a pivoted Cholesky factorisation
    (:func:`massless_split`), a displacement is x = E_S a + Z c (E_S the coordinate
    columns S); the massless part is condensed statically, c = -(Z^T K Z)^-1 Z^T K E_S a,
    and the finite modes solve
    (K_SS - K_SZ (Z^T K Z)^-1 K_ZS) a = lambda M_SS a, M_SS = L11 L11^T definite
    (one dense generalised eigenproblem of the massive size; no eigen-decomposition of
    the mass matrix and no dense changes of basis).
    Returns (eigenvalues ascending, modes (ndof, rank M) with unit modal mass).
    """
    k_red = (T.T @ K @ T).toarray()
    m_red = (T.T @ M @ T).toarray()
    S, Z = massless_split(m_red)
    k_sz = k_red[S] @ Z                                   # (r, n - r)
    condense = -np.linalg.solve(Z.T @ k_red @ Z, k_sz.T) if Z.shape[1] else np.zeros((0, len(S)))
    k_c = k_red[np.ix_(S, S)] + k_sz @ condense
    values, a = scipy.linalg.eigh((k_c + k_c.T) / 2, m_red[np.ix_(S, S)], driver="gvd",
                                  overwrite_a=True, overwrite_b=True)
    x = Z @ (condense @ a)
    x[S] += a
    return values, T @ x
