"""Eigenpairs of a principal submatrix from the matrix's own (gimbal_reduction.reduction.submatrix_eig), against
an eigensolver called on the submatrix."""
import numpy as np
import pytest
import scipy.linalg

from gimbal_reduction.reduction import submatrix_eig as se


def deleted(A, i):
    """(mu, P) of A, the result of delete_index, and the submatrix A_-i."""
    mu, P = scipy.linalg.eigh(A)
    keep = np.delete(np.arange(A.shape[0]), i)
    return mu, P, se.delete_index(mu, P, i), A[np.ix_(keep, keep)], keep


def check(A, i, tol=1e-13):
    mu, P, (ok, x, U), Ai, keep = deleted(A, i)
    assert ok
    scale = np.abs(mu).max()
    assert np.all(np.diff(x) >= 0)
    assert np.allclose(x, scipy.linalg.eigvalsh(Ai), rtol=0, atol=tol * scale)
    Y = P @ U.T
    assert np.max(np.abs(Y[i])) < tol                          # no component on the deleted row
    Y = Y[keep]
    assert np.allclose(Y.T @ Y, np.eye(len(x)), rtol=0, atol=tol)
    assert np.max(np.abs(Ai @ Y - Y * x)) < tol * scale
    return x, Y


def spd(n, seed, spread=1.0):
    rng = np.random.default_rng(seed)
    B = rng.normal(size=(n, n))
    D = np.diag(np.geomspace(1.0, spread, n) ** -0.5)
    return D @ (B @ B.T / n + np.eye(n)) @ D


@pytest.mark.parametrize("n, i", [(2, 0), (3, 2), (12, 5), (60, 0), (60, 59), (150, 71)])
def test_random_matrices(n, i):
    check(spd(n, n + i), i)


def test_graded_spectrum_like_the_frozen_chain():
    """Eigenvalues over 6 decades (1/omega^2 of the real chains spans 6.5): accurate to the
    largest eigenvalue's rounding, as an eigensolver."""
    A = spd(80, 3, spread=1e6)
    for i in (0, 17, 79):
        check(A, i)


def test_deflation_exact_and_near():
    """A block-diagonal matrix: the other block's poles do not touch row i (z = 0) and stay
    eigenvalues; a coupling of 1e-14 or 1e-9 between the blocks is resolved, not dropped."""
    A = scipy.linalg.block_diag(spd(20, 1), 3.0 * spd(25, 2))
    _, Y = check(A, 4)
    second = np.linalg.norm(Y[19:], axis=0) > 0.5                 # eigenvectors of the other block
    assert second.sum() == 25 and np.abs(Y[:19, second]).max() < 1e-14
    for c in (1e-14, 1e-9):
        B = A.copy()
        B[4, 30] = B[30, 4] = c
        check(B, 4)
        check(B, 30)


def test_multiple_eigenvalue_is_left_to_the_eigensolver():
    Q, _ = np.linalg.qr(np.random.default_rng(0).normal(size=(10, 10)))
    A = Q @ np.diag([1.0, 2.0, 2.0, 3.0, 4.0, 5.0, 6.0, 6.0, 7.0, 8.0]) @ Q.T
    mu, P = scipy.linalg.eigh(A)
    ok, _, _ = se.delete_index(mu, P, 3)
    assert not ok


def test_one_by_one_and_scaled_rows():
    ok, x, U = se.delete_index(np.array([2.0]), np.ones((1, 1)), 0)
    assert ok and x.shape == (0,) and U.shape == (0, 1)
    A = spd(7, 9)
    mu, P = scipy.linalg.eigh(A)
    ok, x, _ = se.delete_index(mu, 3.0 * P, 2)                 # the row is normalised
    assert ok and np.allclose(x, scipy.linalg.eigvalsh(np.delete(np.delete(A, 2, 0), 2, 1)), rtol=1e-13)
