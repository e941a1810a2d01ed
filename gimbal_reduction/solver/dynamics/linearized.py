"""The chain linearised at a configuration: its mass matrix, coupled modes and frequencies,
and the highest coupled frequency that bounds an explicit integrator's step.

The joint angles have no stiffness, so the pencil (K, M(y)), K = diag(0_4, Omega^2),
is reduced to the modal coordinates by the Schur complement
S = M_qq - M_qg M_gg^-1 M_gq (the modal inertia with the joints free): K_q x = lambda S x.
Because the modes carry momentum about the drive axes (X^T M Phi != 0: the supports hold
each body at its bearing regions only), S is *smaller* than the modal mass and the
coupled frequencies lie above the kept ones -- on the real bodies by up to 3x
(docs/dynamics.md, Section 6).  This, not the largest kept modal frequency, bounds an
explicit integrator's step.
"""

import numpy as np
import scipy.linalg

# Numba is required (workflow/envs/requirements.txt): no silent NumPy fallback
from gimbal_reduction.solver.dynamics import compiled


def mass_matrix_fast(chain, y):
    """M(y) (n_y, n_y) from n_y calls of the compiled inverse dynamics without the modal
    stiffness (``compiled.FastChain.mass_matrix``; ``multibody.mass_matrix`` is the NumPy reference)."""
    y = np.asarray(y, float)
    return compiled.FastChain(chain).mass_matrix(y)


def free_joints(M):
    """(joint_of_mode (4, m), S (m, m)): the joint motion g = joint_of_mode x that makes a
    modal motion x carry no joint momentum (M_gg g + M_gq x = 0), and the symmetrised
    Schur complement S = M_qq - M_qg M_gg^-1 M_gq of M (n, n), m = n - 4."""
    Mgg, Mgq, Mqq = M[:4, :4], M[:4, 4:], M[4:, 4:]
    joint_of_mode = -np.linalg.solve(Mgg, Mgq)
    S = Mqq + Mgq.T @ joint_of_mode
    return joint_of_mode, 0.5 * (S + S.T)


def _pencil(M, stiffness, who):
    """(M (n, n), stiffness (n - 4,)) as float arrays; ValueError (one line naming ``who``)
    unless the shapes fit with n > 4."""
    M = np.asarray(M, dtype=float)
    k = np.asarray(stiffness, dtype=float)
    n = M.shape[0]
    if M.shape != (n, n) or k.shape != (n - 4,) or n < 5:
        raise ValueError(f"{who}: M {M.shape} and stiffness {k.shape} do not match "
                         f"(need (n, n) and (n - 4,), n > 4)")
    return M, k


def free_joint_modes(M, stiffness):
    """Natural modes of the linearised chain with mass matrix M (n, n) and modal stiffness
    (n - 4,) Omega^2 [(rad/s)^2] (the four joint angles have none): the joints are
    eliminated (module docstring) and Omega^2 x = lambda S x solved.  Each mode moves the
    joints by g = -M_gg^-1 M_gq x, which makes its joint momenta M_gg g + M_gq x vanish,
    so phi = [g; x] satisfies K phi = lambda M phi and phi_i^T M phi_j = x_i^T S x_j =
    delta_ij: M-orthonormal in the full coordinates.

    Returns (omega (m,) [rad/s] ascending, shapes (n, m)), m = n - 4.  Raises ValueError
    unless M is (n, n) and stiffness (n - 4,) with n > 4."""
    M, k = _pencil(M, stiffness, "coupled_modes")
    joint_of_mode, S = free_joints(M)
    lam, X = scipy.linalg.eigh(np.diag(k), S)              # X^T S X = I
    return np.sqrt(np.maximum(lam, 0.0)), np.vstack([joint_of_mode @ X, X])


def free_joint_basis(M, stiffness):
    """The coupled modes of ``free_joint_modes`` in factored form, for the exponential
    integrator: (omega (m,) [rad/s] ascending, joint_of_mode (4, m), X (m, m), Y (m, m)),
    the modal part of the shapes X (X^T S X = I, Omega^2 X = S X diag(omega^2)) and its
    inverse transposed Y = S X = X^-T, so that a modal vector's coordinates in the modes
    are Y^T v without a product with S.

    With every stiffness positive the pencil is turned into a standard symmetric problem
    by the stiffness alone: x = Omega^-1 p gives (Omega^-1 S Omega^-1) p = p / omega^2,
    one symmetric eigenproblem (LAPACK syevd) without the Cholesky factor of S and the
    two-sided reduction of the generalised solver (measured 1.4-1.7x faster at m = 400,
    frequencies within 1e-10 relative of it, Y^T X = I to 1e-13; docs/exponential.md
    Sec. 8).  The eigenvectors P (orthogonal) give X = Omega^-1 P diag(omega) and
    Y = Omega P diag(1 / omega), both diagonal scalings of P.  A zero stiffness (no
    scaling possible) falls back to the generalised solver."""
    M, k = _pencil(M, stiffness, "free_joint_basis")
    joint_of_mode, S = free_joints(M)
    if np.all(k > 0):
        Om = np.sqrt(k)
        A = S / np.outer(Om, Om)
        mu, P = scipy.linalg.eigh(A, driver="evd", overwrite_a=True, check_finite=False)
        mu, P = mu[::-1], P[:, ::-1]                   # 1 / omega^2 descending: omega ascending
        omega = 1.0 / np.sqrt(mu)
        X = P * (omega[None, :] / Om[:, None])
        Y = P * (Om[:, None] / omega[None, :])
        return omega, joint_of_mode, X, Y
    lam, X = scipy.linalg.eigh(np.diag(k), S)
    return np.sqrt(np.maximum(lam, 0.0)), joint_of_mode, X, S @ X


def free_joint_frequencies(M, stiffness):
    """The elastic coupled frequencies [rad/s] (ascending) of ``free_joint_basis``,
    eigenvalues only (the same scaled standard problem; generalised if a stiffness is 0)."""
    k = np.asarray(stiffness, dtype=float)
    _, S = free_joints(np.asarray(M, dtype=float))
    if np.all(k > 0):
        Om = np.sqrt(k)
        mu = scipy.linalg.eigh(S / np.outer(Om, Om), eigvals_only=True, driver="evd",
                               overwrite_a=True, check_finite=False)
        return np.sort(1.0 / np.sqrt(mu))
    lam = scipy.linalg.eigh(np.diag(k), S, eigvals_only=True)
    return np.sqrt(np.maximum(lam, 0.0))


def coupled_modes(chain, y):
    """(omega (m,) [rad/s] ascending, shapes (n, m)): the natural modes of the chain
    linearised at configuration y (``free_joint_modes`` of M(y), ``mass_matrix_fast``)."""
    return free_joint_modes(mass_matrix_fast(chain, y), chain.stiffness_diagonal()[4:])


def coupled_frequencies(chain, y):
    """Natural frequencies [rad/s] (ascending, the elastic ones) of the chain linearised
    at configuration y: sqrt of the generalised eigenvalues of the pencil (K, M(y)),
    K = diag(0_4, Omega^2), by the Schur complement on the joints (module docstring).
    Eigenvalues only (``coupled_modes`` for the shapes): the RK4 bound's omega_max."""
    n_q = sum(chain.n_modes)
    if n_q == 0:
        return np.zeros(0)
    _, S = free_joints(mass_matrix_fast(chain, y))
    lam = scipy.linalg.eigh(np.diag(chain.stiffness_diagonal()[4:]), S, eigvals_only=True)
    return np.sqrt(np.maximum(lam, 0.0))


# Gimbal-angle offsets at which coupled_omega_max samples the configuration (besides y0).
# M(y) depends on the angles; the highest coupled frequency varies with them by up to ~1 %
# on the real reduced models, and it peaks where two gimbal axes align (gamma_2 = 0: outer
# and inner gimbal axes; gamma_3 = 0: middle gimbal and platform axes), measured by
# gimbal_reduction.results.bench.stability (docs/stability.md): +5.4 % over the offsets alone for freq-1,1,0,0.
# So the lock configurations are sampled too (LOCK_ANGLES: gamma_2, gamma_3 set to 0).
COUPLED_SAMPLE_OFFSETS = ((0.0, 0.0, 0.0, 0.0), (0.7, -0.4, 1.1, 0.3), (-1.3, 0.9, -0.6, 2.1),
                          (2.4, 1.7, 0.5, -1.9))
LOCK_ANGLES = ((1,), (2,), (1, 2))


def coupled_omega_max(chain, y0=None, offsets=COUPLED_SAMPLE_OFFSETS, lock_angles=LOCK_ANGLES):
    """Highest frequency [rad/s] of the chain linearised at y0, at the gimbal angles
    y0 + offsets, and at y0 with the angles of lock_angles (0-based indices into gamma)
    set to zero (elastic coordinates as in y0): the RK4 stability bound's omega_max."""
    if sum(chain.n_modes) == 0:
        return 0.0
    y0 = np.zeros(chain.n_coordinates) if y0 is None else y0
    return max(float(coupled_frequencies(chain, y)[-1])
               for y in sample_configurations(y0, offsets, lock_angles))


def coupled_damped_eigenvalues(chain, y):
    """Eigenvalues (2m,) complex [1/s] of the chain linearised at configuration y with its
    modal damping: S x'' + C x' + K x = 0 on the elastic coordinates (the joints eliminated
    as in ``free_joints``: they carry neither stiffness nor damping, so their equations only
    shed inertia), C = diag(2 zeta Omega) (``chain.damping_diagonal``), from the companion
    matrix [[0, I], [-S^-1 K, -S^-1 C]].  A mode of frequency omega and effective damping
    ratio zeta_e gives lambda = omega (-zeta_e +- i sqrt(1 - zeta_e^2)); zeta_e exceeds the
    scene's zeta when the joints shed inertia (S smaller than the modal mass)."""
    m = sum(chain.n_modes)
    if m == 0:
        return np.zeros(0, complex)
    _, S = free_joints(mass_matrix_fast(chain, y))
    k = chain.stiffness_diagonal()[4:]
    c = chain.damping_diagonal()[4:]
    A = np.zeros((2 * m, 2 * m))
    A[:m, m:] = np.eye(m)
    A[m:, :m] = -np.linalg.solve(S, np.diag(k))
    A[m:, m:] = -np.linalg.solve(S, np.diag(c))
    return scipy.linalg.eigvals(A, check_finite=False)


def sample_configurations(y0, offsets=COUPLED_SAMPLE_OFFSETS, lock_angles=LOCK_ANGLES):
    """The configurations ``coupled_omega_max`` samples: y0 with its gimbal angles offset by
    each of ``offsets``, and y0 with the angles of each of ``lock_angles`` set to zero."""
    y0 = np.asarray(y0, float)
    samples = []
    for off in offsets:
        y = y0.copy()
        y[:4] += np.asarray(off, float)
        samples.append(y)
    for idx in lock_angles:
        y = y0.copy()
        y[list(idx)] = 0.0
        samples.append(y)
    return samples


def coupled_damped_spectrum(chain, y0=None):
    """``coupled_damped_eigenvalues`` at every configuration ``coupled_omega_max`` samples,
    concatenated: what bounds an explicit integrator's step on a damped chain."""
    if sum(chain.n_modes) == 0:
        return np.zeros(0, complex)
    y0 = np.zeros(chain.n_coordinates) if y0 is None else np.asarray(y0, float)
    return np.concatenate([coupled_damped_eigenvalues(chain, y) for y in sample_configurations(y0)])
