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

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from petsc4py import PETSc
from slepc4py import SLEPc

from workflow.progress import Progress


class EigenSolveError(RuntimeError):
    """The eigen solve did not deliver the requested pairs; one-line message."""


def lowest_eigenpairs(K: PETSc.Mat, M: PETSc.Mat, count: int, shift: float = 0.0,
                      tolerance: float = 1e-12, max_iterations: int = 500, label: str = "body"):
    """The ``count`` eigenpairs nearest above ``shift`` of the pencil (K, M).

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


def all_supported_modes(K: sp.spmatrix, M: sp.spmatrix, T: sp.spmatrix):
    """Every finite supported eigenpair by a dense solve (coarse meshes only).

    M may be singular (massless drilling rotations). With Y, Z the eigenvectors
    of T^T M T with positive and zero eigenvalues, the massless part is
    condensed statically: c = -(Z^T K Z)^-1 Z^T K Y a, and the finite modes
    solve (Y^T K Y - Y^T K Z (Z^T K Z)^-1 Z^T K Y) a = lambda (Y^T M Y) a.
    Returns (eigenvalues ascending, modes (ndof, rank M) with unit modal mass).
    """
    k_red = (T.T @ K @ T).toarray()
    m_red = (T.T @ M @ T).toarray()
    m_values, basis = scipy.linalg.eigh(m_red)
    massive = m_values > 1e-10 * m_values.max()
    Y, Z = basis[:, massive], basis[:, ~massive]
    k_yy, k_yz, k_zz = Y.T @ k_red @ Y, Y.T @ k_red @ Z, Z.T @ k_red @ Z
    condense = -np.linalg.solve(k_zz, k_yz.T) if Z.shape[1] else np.zeros((0, Y.shape[1]))
    values, a = scipy.linalg.eigh(k_yy + k_yz @ condense, np.diag(m_values[massive]))
    x = Y @ a + Z @ (condense @ a)
    return values, T @ x
