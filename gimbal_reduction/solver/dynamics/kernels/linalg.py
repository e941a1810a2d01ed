"""Small linear algebra of the recursion: 3-vectors as tuples, 6x6 matrices in scratch arrays.

Why no small arrays: an evaluation used to allocate ~600 of them (3-vectors, 6x6
temporaries), ~17 ns each to allocate and free, plus the cache traffic; that was half
of the fixed cost of an evaluation.  Now 3-vectors are tuples, which Numba keeps in
registers, and 6x6 temporaries live in scratch arrays allocated once per evaluation.
"""

import numba
import numpy as np

from gimbal_reduction.solver.dynamics.kernels import FAST, JIT, extension


@numba.njit(**JIT)
def cr(a, b):
    """a x b for 3-vectors (tuples or arrays) -> tuple."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@numba.njit(**JIT)
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@numba.njit(**JIT)
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@numba.njit(**JIT)
def scale(s, a):
    return (s * a[0], s * a[1], s * a[2])


@numba.njit(**JIT)
def mv3(R, x):
    """R x for a (3, 3) array R -> tuple."""
    return (R[0, 0] * x[0] + R[0, 1] * x[1] + R[0, 2] * x[2],
            R[1, 0] * x[0] + R[1, 1] * x[1] + R[1, 2] * x[2],
            R[2, 0] * x[0] + R[2, 1] * x[1] + R[2, 2] * x[2])


@numba.njit(**JIT)
def mtv3(R, x):
    """R^T x for a (3, 3) array R -> tuple."""
    return (R[0, 0] * x[0] + R[1, 0] * x[1] + R[2, 0] * x[2],
            R[0, 1] * x[0] + R[1, 1] * x[1] + R[2, 1] * x[2],
            R[0, 2] * x[0] + R[1, 2] * x[1] + R[2, 2] * x[2])


@numba.njit(**JIT)
def adinv(R, p, w):
    """Ad_{g^-1} w = [R^T (v + omega x p); R^T omega] (6,) for the pose g = (R, p)."""
    om = (w[3], w[4], w[5])
    v = mtv3(R, add((w[0], w[1], w[2]), cr(om, p)))
    o = mtv3(R, om)
    return np.array([v[0], v[1], v[2], o[0], o[1], o[2]])


# 6x6 algebra into preallocated outputs (out must not alias an input); transposes are
# passed as views (A.T).  A row of the result is accumulated in six scalars: 1.5x
# faster than the plain triple loop.
@numba.njit(**FAST)
def mm6(A, B, out):
    """out = A B."""
    for i in range(6):
        r0 = r1 = r2 = r3 = r4 = r5 = 0.0
        for k in range(6):
            a = A[i, k]
            r0 += a * B[k, 0]
            r1 += a * B[k, 1]
            r2 += a * B[k, 2]
            r3 += a * B[k, 3]
            r4 += a * B[k, 4]
            r5 += a * B[k, 5]
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4], out[i, 5] = r0, r1, r2, r3, r4, r5


@numba.njit(**FAST)
def mv6(A, x, out):
    """out = A x."""
    for i in range(6):
        s = 0.0
        for k in range(6):
            s += A[i, k] * x[k]
        out[i] = s


@numba.njit(**JIT)
def inv6(A, X, M):
    """X = A^-1 (6x6) by Gauss-Jordan elimination with partial pivoting; M is scratch."""
    n = 6
    for i in range(n):
        for j in range(n):
            M[i, j] = A[i, j]
            X[i, j] = 1.0 if i == j else 0.0
    for c in range(n):
        piv = c
        big = abs(M[c, c])
        for r in range(c + 1, n):
            if abs(M[r, c]) > big:
                big = abs(M[r, c])
                piv = r
        if piv != c:
            for j in range(n):
                M[c, j], M[piv, j] = M[piv, j], M[c, j]
                X[c, j], X[piv, j] = X[piv, j], X[c, j]
        inv = 1.0 / M[c, c]
        for j in range(n):
            M[c, j] *= inv
            X[c, j] *= inv
        for r in range(n):
            if r != c:
                f = M[r, c]
                if f != 0.0:
                    for j in range(n):
                        M[r, j] -= f * M[c, j]
                        X[r, j] -= f * X[c, j]


@numba.njit(**JIT)
def adinv_matrix(R, p, A):
    """A (6, 6) = Ad_{g^-1} = [[R^T, -R^T p~], [0, R^T]], in place."""
    for i in range(3):
        for j in range(3):
            A[i, j] = R[j, i]
            A[3 + i, 3 + j] = R[j, i]
            A[3 + i, j] = 0.0
        # row i of -R^T p~:  -(R^T p~)[i, :] = (p x R[:, i])^T ... written out
        c0, c1, c2 = R[0, i], R[1, i], R[2, i]      # column i of R = row i of R^T
        # (R^T p~)[i, j] = sum_m R[m, i] p~[m, j],  p~ = [[0, -p2, p1], [p2, 0, -p0], [-p1, p0, 0]]
        A[i, 3] = -(c1 * p[2] - c2 * p[1])
        A[i, 4] = -(-c0 * p[2] + c2 * p[0])
        A[i, 5] = -(c0 * p[1] - c1 * p[0])


# this module's entries compiled ahead of time, when built and current (kernels.extension)
extension.attach(__name__)
