"""Mode rankings of one body: frequency, XMX and XMGMX (thesis Section 3.2, Table 3.1).

Inputs are the modal integrals of ``gimbal_reduction.reduction.modal_integrals``: P, H (3, D),
eigenvalues Omega^2 (D,) [(rad/s)^2], M_inf and MGM_inf (6, 6).

* XMX:   rho_i = spectral radius of M_inf^-1/2 Mbar_i M_inf^-1/2
* XMGMX: rho_i = spectral radius of MGM_inf^-1/2 (Mbar_i / Omega_i^2) MGM_inf^-1/2

with Mbar_i = [P_i; H_i][P_i; H_i]^T.  Both are dimensionless, invariant to
the mode's sign, to the DOF numbering and to a uniform scaling of the density
(M -> c M gives phi -> phi / sqrt(c), Omega^2 -> Omega^2 / c).  Because Mbar_i
has rank one, rho_i also equals v_i^T A^-1 v_i (v_i = [P_i; H_i], A the
reference matrix): over all finite supported modes the XMX radii sum to 6
(the trace of the identity, Hughes's identity), and so do the XMGMX radii.
Modes are ranked by decreasing rho; ties (relative 1e-12) go to the lower
mode index, i.e. the lower frequency, so degenerate pairs keep their order.

Deviations from the thesis (Appendix A.1 code and text), and why
------------------------------------------------------------------
1. XMGMX radii over *every* mode: the thesis code loops ``for iiii = depth``,
   which visits only the last mode; the equations (Table 3.1) mean all modes.
2. M_inf^-1/2 is the symmetric inverse square root from ``eigh``: the code's
   ``MInfinity(-1/2)`` lost its power operator (it indexes the matrix).
3. M_inf and MGM_inf are consistent with the supports (see
   ``modal_integrals``) so that the identities hold exactly; the code used
   X^T M X over all DOFs for M_inf and the first 576 DOFs for MGM_inf (its
   ``mod((i+1),6)`` and 1:576 index juggling of the constrained DOFs), which
   mixes a free and a supported quantity.
4. XMGMX uses Mbar_i / Omega_i^2 (eq 3.46); the code's
   ``1/eigvals(iiii)2`` lost an operator (and would square the eigenvalue).
5. The thesis sorts ascending (``sort(rho)``) and reads the list from the
   end; here rankings are returned most important first, 0-based.
6. The table is produced per ranking; the thesis's Table 4.1 lists one
   column per body "XMX/XMGMX" because its two rankings agreed over the first
   40 modes -- here the agreement is measured (``ranking_table``), not assumed.
"""

import numpy as np

from gimbal_reduction.reduction.errors import ModeCountError, ReductionError
from gimbal_reduction.reduction.modal_integrals import mode_contributions


def symmetric_inverse_sqrt(A, rtol=1e-12):
    """A^-1/2 (n, n) of a symmetric positive definite A, via eigh.

    Raises ReductionError if A is not positive definite (smallest eigenvalue
    below ``rtol`` times the largest): a rigid mass or flexibility that misses
    a direction (e.g. a body without inertia about an axis).
    """
    A = 0.5 * (np.asarray(A, float) + np.asarray(A, float).T)
    w, V = np.linalg.eigh(A)
    if not np.all(np.isfinite(w)) or w[-1] <= 0 or w[0] <= rtol * w[-1]:
        raise ReductionError(
            f"reference matrix is not positive definite (eigenvalues {w[0]:.3e} .. {w[-1]:.3e})")
    return (V / np.sqrt(w)) @ V.T


def spectral_radii(contributions, reference):
    """rho_i = largest eigenvalue of A^-1/2 C_i A^-1/2: C (D, 6, 6), A (6, 6) -> (D,)."""
    S = symmetric_inverse_sqrt(reference)
    scaled = S @ np.asarray(contributions) @ S
    return np.linalg.eigvalsh(0.5 * (scaled + scaled.transpose(0, 2, 1)))[:, -1]


def xmx_radii(P, H, M_inf):
    """XMX spectral radii (D,) of Table 3.1 (dimensionless)."""
    return spectral_radii(mode_contributions(P, H), M_inf)


def xmgmx_radii(P, H, eigenvalues, MGM_inf):
    """XMGMX spectral radii (D,) of Table 3.1: Mbar_i / Omega_i^2 against MGM_inf."""
    lam = np.asarray(eigenvalues, float)
    if np.any(lam <= 0):
        raise ReductionError(f"eigenvalues must be positive (smallest {lam.min():.3e})")
    return spectral_radii(mode_contributions(P, H) / lam[:, None, None], MGM_inf)


def rank_by_radius(rho, rtol=1e-12):
    """Mode indices (D,) int, largest rho first; near-ties (rtol) by lower index."""
    rho = np.asarray(rho, float)
    scale = np.max(np.abs(rho)) if rho.size else 1.0
    key = np.round(rho / (scale or 1.0) / rtol)
    return np.lexsort((np.arange(rho.size), -key))


def rank_by_frequency(eigenvalues):
    """Mode indices (D,) int, lowest frequency first (stable)."""
    return np.argsort(np.asarray(eigenvalues, float), kind="stable")


def captured_share(P, H, kept, reference, eigenvalues=None):
    """How much of a reference matrix a kept set of modes reproduces.

    With C = sum_{i in kept} Mbar_i (or Mbar_i / Omega_i^2 when ``eigenvalues``
    are given, for MGM_inf) and S = reference^-1/2, returns a dict:
    ``trace_share`` = trace(S C S) / 6 (1 with all finite modes), and
    ``min_eigenvalue`` / ``max_eigenvalue`` of S C S (the worst/best captured
    rigid direction; the minimum is 0 when fewer than 6 modes are kept).
    """
    kept = np.asarray(kept, dtype=int)
    C = mode_contributions(P, H)
    if eigenvalues is not None:
        C = C / np.asarray(eigenvalues, float)[:, None, None]
    total = C[kept].sum(axis=0) if kept.size else np.zeros((6, 6))
    S = symmetric_inverse_sqrt(reference)
    w = np.linalg.eigvalsh(S @ total @ S)
    return {"trace_share": float(w.sum() / 6.0), "min_eigenvalue": float(w[0]),
            "max_eigenvalue": float(w[-1])}


def cumulative_share(P, H, order, reference, eigenvalues=None):
    """trace share and smallest eigenvalue (each (D,)) of the first k modes of ``order``, k = 1..D."""
    order = np.asarray(order, dtype=int)
    C = mode_contributions(P, H)
    if eigenvalues is not None:
        C = C / np.asarray(eigenvalues, float)[:, None, None]
    S = symmetric_inverse_sqrt(reference)
    partial = np.cumsum(S @ C[order] @ S, axis=0)
    w = np.linalg.eigvalsh(0.5 * (partial + partial.transpose(0, 2, 1)))
    return w.sum(axis=1) / 6.0, w[:, 0]


def kept_modes(ranking, n_kept):
    """The first ``n_kept`` mode indices of a ranking, as (n_kept,) int; checks the count."""
    ranking = np.asarray(ranking, dtype=int)
    if int(n_kept) != n_kept or n_kept < 0 or n_kept > ranking.size:
        raise ModeCountError(f"kept modes: asked for {n_kept}, only {ranking.size} computed")
    return ranking[:int(n_kept)]


def ranking_table(rank_xmx, rank_xmgmx, n_rows=40, top_k=(5, 10, 15, 20, 25, 30, 40)):
    """The analogue of thesis Table 4.1 for one body, and where the rankings agree.

    Returns a dict with
    ``xmx``, ``xmgmx``: (n_rows,) the first ranked modes as 1-based mode
    numbers in frequency order (the thesis's convention: 1 = lowest frequency);
    ``common_prefix``: how many leading entries the two rankings share in order;
    ``top_k``: (k,) and ``overlap``: (k,) the size of the intersection of the
    two top-k sets; ``same_set``: (k,) bool, whether the top-k sets are equal.
    """
    a, b = np.asarray(rank_xmx, int), np.asarray(rank_xmgmx, int)
    n = min(n_rows, a.size, b.size)
    differ = np.flatnonzero(a[:min(a.size, b.size)] != b[:min(a.size, b.size)])
    common = int(differ[0]) if differ.size else int(min(a.size, b.size))
    ks = np.array([k for k in top_k if k <= min(a.size, b.size)], dtype=int)
    overlap = np.array([np.intersect1d(a[:k], b[:k]).size for k in ks], dtype=int)
    return {"xmx": a[:n] + 1, "xmgmx": b[:n] + 1, "common_prefix": common,
            "top_k": ks, "overlap": overlap, "same_set": overlap == ks}
