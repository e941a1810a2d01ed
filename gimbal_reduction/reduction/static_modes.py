"""Static correction (residual attachment) modes, thesis Section 3.3 and 4.4.

A unit load F_a at a joint, applied to the supported body, gives the
residual attachment mode (eq 3.48, S = I for a supported body)

    phi = [G - Phi Lambda^-1 Phi^T] F_a,      G = T (T^T K T)^-1 T^T,

where Phi (ndof, k) and Lambda (k,) are the *kept* vibration modes and their
eigenvalues: the static response minus the part the kept modes already
represent.  It is M- and K-orthogonal to every kept mode (exactly, for exact
modes: Phi^T K G F = Phi^T F and Phi^T M G F = Lambda^-1 Phi^T F), so the
modal mass and stiffness matrices stay block diagonal (eq 3.52).

Which vibration modes? The thesis builds the static mode against the kept
modes of the run (Appendix A.2 truncates ``eigvect(:, 1:nModes)`` before
forming it; Section 4.3.3 keeps 2 to 8 modes, Section 4.4 ten), not against
all computed modes.  Against all 100 it would only carry the response of the
uncomputed modes and differ from the thesis's mode.  A static mode therefore
belongs to a kept set; ``static_correction_modes`` builds it for any kept set
and the stage stores it for one documented kept set (``--static-kept``).

Loads act through the bearing connection: a force/moment f (6,) at bearing b
is the nodal load ``bearing_operator[6b:6b+6].T @ f`` (virtual work).  Load
cases are named ``{bearing}_{f|m}{x|y|z}`` with bearing one of input_motor,
input_resolver, output_motor, output_resolver, in the body's local axes; the
thesis's seven (Section 4.4, Figures 4-21 to 4-27) are ``THESIS_LOAD_CASES``,
``output_motor_fz`` (Figure 4-12, Section 4.3.3) first.  Units: 1 lbf or
1 in lbf; the mode is normalised anyway.

Normalisation: unit modal mass, phi^T M phi = 1 [lbf s^2/in]; the modal
stiffness phi^T K phi is then the square of a Rayleigh-quotient frequency
[(rad/s)^2].  Several static modes are made M- and K-orthogonal among
themselves by the small generalised eigenproblem in their span (after unit
mass normalisation of each), which gives a diagonal modal mass (identity)
and stiffness; the condition number of their Gram (mass) matrix before that
step is reported -- a large value means nearly dependent load cases.
"""

import numpy as np
import scipy.linalg

from gimbal_reduction.reduction.errors import (
    BearingIndexError,
    MissingBearingError,
    ModeCountError,
    StaticModeError,
    UnknownLoadCaseError,
)
from gimbal_reduction.solver.bodydata import BEARING_NAMES

THESIS_LOAD_CASES = (
    "output_motor_fz",  # Figure 4-12 / 4-24, the default
    "output_motor_fx",  # Figure 4-23
    "output_motor_my",  # Figure 4-21
    "output_motor_mz",  # Figure 4-22
    "input_motor_fx",   # Figure 4-27 (force along the drive axis)
    "input_motor_my",   # Figure 4-25
    "input_motor_mz",   # Figure 4-26
)
DEFAULT_LOAD_CASE = THESIS_LOAD_CASES[0]
LOAD_COMPONENTS = ("fx", "fy", "fz", "mx", "my", "mz")


def parse_load_case(name):
    """``'output_motor_fz'`` -> (bearing index 2, component index 2); UnknownLoadCaseError otherwise."""
    text = str(name)
    bearing, _, component = text.rpartition("_")
    if bearing not in BEARING_NAMES or component not in LOAD_COMPONENTS:
        raise UnknownLoadCaseError(
            f"unknown load case {text!r}: expected {{bearing}}_{{f|m}}{{x|y|z}} with bearing in "
            f"{', '.join(BEARING_NAMES)} (e.g. {DEFAULT_LOAD_CASE})")
    return BEARING_NAMES.index(bearing), LOAD_COMPONENTS.index(component)


def bearing_load(bearing_operator, bearing, f):
    """Nodal load (ndof,) of a force/moment f (6,) [lbf, in lbf] at bearing 0..3."""
    n_bearings = bearing_operator.shape[0] // 6
    if int(bearing) != bearing or not 0 <= bearing < n_bearings:
        raise BearingIndexError(f"bearing index {bearing} outside 0..{n_bearings - 1}")
    f = np.asarray(f, float)
    if f.shape != (6,):
        raise StaticModeError(f"bearing load must have shape (6,), got {f.shape}")
    rows = bearing_operator[6 * int(bearing):6 * int(bearing) + 6]
    return np.asarray(rows.T @ f).ravel()


def load_case_vector(bearing_operator, name, bearing_points=None):
    """Nodal load (ndof,) of a named unit load case.

    Raises UnknownLoadCaseError for a bad name and MissingBearingError if the
    body lacks the bearing (its point is NaN or its operator rows are zero:
    the platform has no output bearings).
    """
    bearing, component = parse_load_case(name)
    if bearing_points is not None and not np.all(np.isfinite(np.asarray(bearing_points)[bearing])):
        raise MissingBearingError(
            f"load case {name!r}: the body has no {BEARING_NAMES[bearing]} bearing")
    rows = bearing_operator[6 * bearing:6 * bearing + 6]
    if rows.nnz == 0 or not np.any(rows.data):
        raise MissingBearingError(
            f"load case {name!r}: the body has no {BEARING_NAMES[bearing]} bearing")
    f = np.zeros(6)
    f[component] = 1.0
    return bearing_load(bearing_operator, bearing, f)


def check_kept_set(modes, eigenvalues, kept):
    """Kept modes (ndof, k) and eigenvalues (k,) from mode indices; ModeCountError if invalid."""
    modes = np.asarray(modes)
    D = modes.shape[1]
    kept = np.asarray(kept, dtype=int).ravel()
    if kept.size > D:
        raise ModeCountError(f"kept modes: asked for {kept.size}, only {D} computed")
    if kept.size and (kept.min() < 0 or kept.max() >= D):
        raise ModeCountError(f"kept mode index {int(kept.max() if kept.max() >= D else kept.min())} "
                             f"outside 0..{D - 1}")
    if np.unique(kept).size != kept.size:
        raise ModeCountError("kept modes contain a repeated index")
    return modes[:, kept], np.asarray(eigenvalues, float)[kept]


def residual_attachment(apply_G, loads, kept_modes, kept_eigenvalues):
    """[G - Phi Lambda^-1 Phi^T] F (eq 3.48): loads (ndof,) or (ndof, p) -> same shape.

    apply_G from ``modal_integrals.supported_flexibility``; kept_modes (ndof, k)
    mass-normalised, kept_eigenvalues (k,) [(rad/s)^2].
    """
    F = np.asarray(loads, float)
    Phi = np.asarray(kept_modes, float)
    lam = np.asarray(kept_eigenvalues, float)
    U = apply_G(F)
    if Phi.shape[1] == 0:
        return U
    coeff = (Phi.T @ F) / (lam if F.ndim == 1 else lam[:, None])
    return U - Phi @ coeff


def static_correction_modes(M, K, apply_G, loads, kept_modes, kept_eigenvalues, names=None,
                            vanish_tol=1e-8, gram_condition_limit=1e10, mass_orthogonalise=True):
    """Static correction modes for any kept set (eqs 3.48, 3.51, 3.52).

    M, K (ndof, ndof) sparse; apply_G as in ``residual_attachment``; loads
    (ndof, p) unit loads (``load_case_vector``); kept_modes (ndof, k),
    kept_eigenvalues (k,); names (p,) for messages.

    Returns a dict:
    ``modes`` (ndof, p): unit modal mass, M- and K-orthogonal to the kept
    modes and among themselves; ``modal_mass`` (p,) [lbf s^2/in] (= 1);
    ``modal_stiffness`` (p,) [lbf/in per unit mass, i.e. (rad/s)^2];
    ``frequencies_hz`` (p,): sqrt(stiffness / mass) / 2 pi (Rayleigh-like);
    ``mass_coupling_vector`` (k, p) = Phi^T M phi and ``stiffness_coupling_vector``
    (k, p) = Phi^T K phi, so a model can keep the (small) couplings;
    ``combination`` (p, p): modes = residuals_unit_mass @ combination (identity
    up to sign for p = 1, so the mode stays tied to its load case);
    ``gram_condition``: condition number of the mass Gram matrix of the
    unit-mass residuals (1 for p = 1); ``residual_fraction`` (p,):
    ||phi_raw||_M / ||G F||_M, the share of each static response the kept
    modes miss; ``mass_coupling``, ``stiffness_coupling``: the largest
    |Phi^T M phi| and |Phi^T K phi| / sqrt(Omega_i^2 k_s) (both relative;
    ~1e-12 or less for accurate modes).

    Orthogonality with inexact vibration modes: eq 3.48 as written is
    K-orthogonal to the kept modes whenever Phi^T K Phi = Lambda (true for
    Rayleigh-Ritz-refined modes, whatever their accuracy), and M-orthogonal
    only as far as the modes are exact eigenvectors: a mass coupling c_i =
    phi_i^T M phi of the size of the modes' eigen-residual.  By default
    (``mass_orthogonalise=True``) one M-orthogonal Gram-Schmidt pass removes
    it; that moves a coupling Omega_i^2 c_i into the stiffness, i.e. a
    normalised K-coupling c_i Omega_i / Omega_s, smaller than c_i because the
    static mode is stiffer than every kept mode.  So the largest normalised
    coupling only shrinks.  ``mass_orthogonalise=False`` keeps eq 3.48 as
    written.  Both couplings are returned (scalars and vectors).
    """
    F = np.asarray(loads, float)
    if F.ndim == 1:
        F = F[:, None]
    p = F.shape[1]
    names = list(names) if names is not None else [f"load {j}" for j in range(p)]
    Phi = np.asarray(kept_modes, float)
    lam = np.asarray(kept_eigenvalues, float)
    if Phi.shape[0] != F.shape[0]:
        raise StaticModeError(f"loads have {F.shape[0]} DOFs, modes {Phi.shape[0]}")

    T = getattr(apply_G, "admissible_basis", None)
    if T is not None:  # a load that only pushes on the supports has no static response
        reach = np.linalg.norm(np.asarray(T.T @ F), axis=0)
        bound = np.linalg.norm(np.asarray(abs(T).T @ np.abs(F)), axis=0)
        for j in np.flatnonzero(reach <= 1e-10 * bound):
            raise StaticModeError(
                f"static mode {names[j]!r} vanishes: the load acts only on supported directions")
    U = apply_G(F)
    R = U - Phi @ ((Phi.T @ F) / lam[:, None]) if Phi.shape[1] else U.copy()
    if mass_orthogonalise and Phi.shape[1]:
        R = R - Phi @ (Phi.T @ (M @ R))
    u_mass = np.sqrt(np.maximum(np.einsum("ij,ij->j", U, M @ U), 0.0))
    r_mass = np.sqrt(np.maximum(np.einsum("ij,ij->j", R, M @ R), 0.0))
    for j in range(p):
        if not u_mass[j] > 0.0:
            raise StaticModeError(
                f"static mode {names[j]!r} vanishes: the load acts only on supported directions")
        if r_mass[j] <= vanish_tol * u_mass[j]:
            raise StaticModeError(
                f"static mode {names[j]!r} vanishes: its static response lies in the "
                f"{Phi.shape[1]} kept modes (residual {r_mass[j] / u_mass[j]:.1e})")
    S = R / r_mass
    gram = S.T @ (M @ S)
    gram = 0.5 * (gram + gram.T)
    w_gram = np.linalg.eigvalsh(gram)
    condition = float(w_gram[-1] / w_gram[0]) if w_gram[0] > 0 else np.inf
    if condition > gram_condition_limit:
        raise StaticModeError(
            f"static modes {', '.join(map(repr, names))} are nearly linearly dependent "
            f"(mass Gram condition {condition:.1e} > {gram_condition_limit:.0e})")
    stiff = S.T @ (K @ S)
    stiff = 0.5 * (stiff + stiff.T)
    k_s, V = scipy.linalg.eigh(stiff, gram)
    big = np.argmax(np.abs(V), axis=0)
    V = V * np.sign(V[big, np.arange(p)])
    modes = S @ V
    MS, KS = M @ modes, K @ modes
    modal_mass = np.einsum("ij,ij->j", modes, MS)
    modal_stiffness = np.einsum("ij,ij->j", modes, KS)
    mass_vector, stiffness_vector = Phi.T @ MS, Phi.T @ KS
    if Phi.shape[1]:
        mass_coupling = float(np.max(np.abs(mass_vector) / np.sqrt(modal_mass)))
        stiffness_coupling = float(np.max(
            np.abs(stiffness_vector) / np.sqrt(np.outer(lam, modal_stiffness))))
    else:
        mass_coupling = stiffness_coupling = 0.0
    return {
        "modes": modes, "modal_mass": modal_mass, "modal_stiffness": modal_stiffness,
        "frequencies_hz": np.sqrt(np.maximum(modal_stiffness, 0.0) / modal_mass) / (2 * np.pi),
        "combination": V, "gram_condition": condition, "residual_fraction": r_mass / u_mass,
        "mass_coupling": mass_coupling, "stiffness_coupling": stiffness_coupling,
        "mass_coupling_vector": mass_vector, "stiffness_coupling_vector": stiffness_vector,
        "names": names,
    }


def reduced_static_response(loads, modes, modal_stiffness):
    """Static response of a modal model: Psi diag(k)^-1 Psi^T F (ndof,) or (ndof, p).

    modes (ndof, n) with a diagonal modal stiffness ``modal_stiffness`` (n,)
    (vibration modes: their eigenvalues; static modes: their modal stiffness).
    """
    Psi = np.asarray(modes, float)
    k = np.asarray(modal_stiffness, float)
    F = np.asarray(loads, float)
    coeff = (Psi.T @ F) / (k if F.ndim == 1 else k[:, None])
    return Psi @ coeff
