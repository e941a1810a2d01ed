"""Synthetic gimbal chains: random but physically valid modal integrals of the real bodies' shapes.

For what needs a chain of a given size but not the real bodies: the cost-against-size
benchmark (``gimbal_reduction.results.bench.scaling``) and the compilation of the kernels before the workflow's
first simulation (``gimbal_reduction.solver.dynamics.warmup``).  Timing and compiled code depend on the shapes
and types of the arrays only, never on their values.
"""
from __future__ import annotations

import numpy as np

from gimbal_reduction.solver.dynamics import multibody

# Modal spectrum of each real body, f_k = c k^beta [Hz] (least squares on log-log over modes
# k = 10..100 of results/modes/body{n}.h5): the rings bend like plates
# (beta ~ 1.25), the solid platform's count grows faster (beta ~ 0.65).
SPECTRUM = {2: (843.1, 1.284), 3: (1178.9, 1.256), 4: (1721.3, 1.226), 5: (32903.0, 0.648)}
RIGID = {2: (6.0e-4, 3.375), 3: (5.0e-4, 2.875), 4: (4.0e-4, 2.375), 5: (1.8e-3, 1.2)}  # mass, radius
HUGHES_FRACTION = 0.95       # share of the rigid mass the kept modes' momentum spans (real: 0.95-0.9999)


def modal_frequencies(number, n_modes):
    """Omega (n_modes,) [rad/s] of body ``number`` (2..5): 2 pi c k^beta, k = 1..n_modes."""
    c, beta = SPECTRUM[number]
    return 2 * np.pi * c * np.arange(1, n_modes + 1, dtype=float) ** beta


def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def synthetic_modal_body(rng, number, n_modes, terminal=False):
    """multibody.Body with random, physically valid modal integrals (docs/dynamics.md Section 2).

    Rigid mass (6, 6) of a ring (mass m, radius R about local y) with its centre
    of mass off the origin; momentum [P; H] (6, D) = sqrt(f) L V, L L^T the
    rigid mass, V (6, D) with orthonormal rows (columns if D < 6), so that
    sum_i [P;H]_i [P;H]_i^T = f x rigid mass <= rigid mass (Hughes identity,
    f = HUGHES_FRACTION); inertia gradient M1_i = [[0, Yv^T], [Yv, Yw + Yw^T]]
    with Yv = skew(P_i) (lumped translational mass); Coriolis G (D, 3, D)
    antisymmetric in the two mode indices; inside-frame Psi, Theta (3, D)
    (None for the terminal body); omega2 from ``modal_frequencies``.
    """
    D = int(n_modes)
    m, R = RIGID[number]
    com = rng.normal(scale=0.05 * R, size=3)
    J = m * R * R * np.diag([0.5, 1.0, 0.5]) - m * _skew(com) @ _skew(com)
    Mr = np.block([[m * np.eye(3), -m * _skew(com)], [m * _skew(com), J]])
    # momentum: decaying participation (low modes carry most), then orthonormalised
    Z = rng.normal(size=(6, D)) / np.sqrt(np.arange(1, D + 1))
    U, _, Vt = np.linalg.svd(Z, full_matrices=False)
    B0 = np.sqrt(HUGHES_FRACTION) * np.linalg.cholesky(Mr) @ (U @ Vt)
    M1 = np.zeros((D, 6, 6))
    scale = np.linalg.norm(B0, axis=0) * R
    for i in range(D):
        Yv = _skew(B0[:3, i])
        Yw = rng.normal(scale=scale[i], size=(3, 3))
        M1[i, 3:, :3] = Yv
        M1[i, :3, 3:] = Yv.T
        M1[i, 3:, 3:] = Yw + Yw.T
    A = rng.normal(scale=0.1, size=(D, 3, D))
    G = A - A.transpose(2, 1, 0)                # G[j, :, i] = -G[i, :, j]
    del A
    integrals = {"rigid_mass": Mr, "momentum": B0, "inertia_gradient": M1, "coriolis": G}
    if not terminal:
        integrals["inside_translation"] = rng.normal(scale=10.0, size=(3, D))
        integrals["inside_rotation"] = rng.normal(scale=10.0, size=(3, D))
    return multibody.make_body(number, integrals, modal_frequencies(number, D) ** 2)


def synthetic_modal_chain(n_modes, seed=0):
    """multibody.Chain of four synthetic bodies (2..5) with n_modes modes each."""
    rng = np.random.default_rng(seed)
    return multibody.Chain(tuple(synthetic_modal_body(rng, b, n_modes, terminal=(b == 5))
                                 for b in (2, 3, 4, 5)), name=f"synthetic-{n_modes}")
