"""Reduction report: Table 4.1 analogue, verification record and benchmark of all bodies.

    python -m gimbal_reduction.reduction.report --bodies results/modes/body{2..5}.h5 \\
        --reductions results/reduction/body{2..5}.h5 \\
        --coarse-body results/verification/coarse/body4.h5 \\
        --table results/tables/ranking.csv \\
        --verification results/verification/reduction.json \\
        --benchmark results/benchmarks/reduction.json

Inputs: the body files (docs/body-data.md), the reduction files that
``gimbal_reduction.reduction.stage`` made from them, and a coarse body file holding *every*
finite supported mode (``gimbal_reduction.solver.fe.modes --all-modes``) for the discrete Hughes
identities.

Outputs (all written atomically):

* ``--table`` (CSV): thesis Table 4.1 for our bodies -- the first 40 ranked
  modes of every body under XMX and XMGMX, as 1-based mode numbers in
  frequency order (the thesis's convention; column names say ``_1based``),
  with their frequencies and radii, whether both rankings put the same mode
  at that rank, and the size of the intersection of the two top-k sets.
* ``--verification`` (JSON): ``checks``, a list of ``{name, value,
  tolerance, passed, details}`` (``gimbal_reduction.workflow.provenance.check_record``;
  tolerance None: a measured report that passes when finite), and per body the top-10 ranked modes, the shares of
  M_inf and MGM_inf captured by the first 5/10/25 ranked modes, the
  agreement of the two rankings, and the static modes' conditioning.
* ``--benchmark`` (JSON): per body the median of three runs of the stage's
  pure functions (``stage.reduce_body``: modal integrals, rankings and the
  static modes of every default load case), file reading excluded, with
  software versions and input provenance.

Bad input (a missing, corrupt or stale body, reduction or coarse file; a
reduction file of another body or of other modes; unequal lists) ends the run
with a one-line ``gimbal_reduction.reduction.report: error: ...`` naming the culprit, exit
status 2, before any output is written.  Failed checks do not stop the run
(exit 0, like the stage): they are recorded with ``passed: false`` and
listed on stderr.
"""

import argparse
import os
import sys
import time

import h5py
import numpy as np
import scipy.sparse as sp
from scipy.stats import kendalltau, spearmanr

from gimbal_reduction.reduction import modal_integrals as mi
from gimbal_reduction.reduction import ranking as rk
from gimbal_reduction.reduction import stage
from gimbal_reduction.reduction import static_modes as st
from gimbal_reduction.reduction import verification as vf
from gimbal_reduction.solver import bodyconfig
from gimbal_reduction.solver.bodydata import RIGID_MOTION_NAMES, read_body_file, rigid_modes
from gimbal_reduction.reduction.errors import BodyFileError, ReductionError
from gimbal_reduction.workflow.provenance import check_record, provenance as provenance_record, versions, write_csv, write_json

TABLE_ROWS = 40
SHARE_COUNTS = (5, 10, 25)
TOP_LISTED = 10
IDENTITY_TOL = 1e-8
STATIC_TOL = 1e-10
INVARIANCE_TOL = 1e-10
N_RUNS = 3
TARGET_TOTAL_S = 30.0
REDUCTION_DATASETS = ("P", "H", "M_inf", "MGM_inf", "eigenvalues", "frequencies_hz",
                      "rho_xmx", "rho_xmgmx", "rank_xmx", "rank_xmgmx", "rank_frequency",
                      "static_modes")
REDUCTION_ATTRS = ("format_version", "body", "n_modes")


class ReportInputError(ReductionError):
    """A missing, corrupt or stale input of the report."""


# ----------------------------------------------------------------------------- inputs

def read_reduction_file(path):
    """The datasets and attributes of a reduction file that the report uses (dict)."""
    where = str(path)
    if not os.path.isfile(where):
        raise ReportInputError(f"{where}: reduction file not found (run python -m gimbal_reduction.reduction.stage)")
    try:
        with h5py.File(where, "r") as f:
            missing = [k for k in REDUCTION_DATASETS if k not in f]
            missing += [f"attribute {k}" for k in REDUCTION_ATTRS if k not in f.attrs]
            if missing:
                raise ReportInputError(f"{where}: missing {', '.join(missing)} "
                                       f"(stale or truncated reduction file; rerun gimbal_reduction.reduction.stage)")
            out = {k: f[k][...] for k in REDUCTION_DATASETS if k != "static_modes"}
            out["attrs"] = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
            s = f["static_modes"]
            out["static_attrs"] = {k: (v.decode() if isinstance(v, bytes) else v)
                                   for k, v in s.attrs.items()}
            out["static_cases"] = {name: dict(s[name].attrs) for name in s}
    except ReportInputError:
        raise
    except (OSError, KeyError, ValueError, TypeError) as exc:
        raise ReportInputError(f"{where}: cannot read reduction file ({' '.join(str(exc).split())})") from None
    if int(out["attrs"]["format_version"]) != stage.FORMAT_VERSION:
        raise ReportInputError(f"{where}: format_version {out['attrs']['format_version']}, expected "
                               f"{stage.FORMAT_VERSION} (stale reduction file; rerun gimbal_reduction.reduction.stage)")
    out["path"] = where
    return out


def match_reduction(reduction, body):
    """Raise ReportInputError unless the reduction file was made from this body file."""
    rpath, bpath = reduction["path"], body["path"]
    battrs, rattrs = body["attrs"], reduction["attrs"]
    if int(rattrs["body"]) != int(battrs.get("body", -1)):
        raise ReportInputError(f"{rpath}: reduction of body {rattrs['body']}, but {bpath} is body "
                               f"{battrs.get('body')}")
    if "config_hash" in battrs and str(rattrs.get("config_hash")) != str(battrs["config_hash"]):
        raise ReportInputError(f"{rpath}: stale (config_hash {rattrs.get('config_hash')!r}, body file "
                               f"{bpath} has {battrs['config_hash']!r}); rerun gimbal_reduction.reduction.stage")
    n = int(rattrs["n_modes"])
    lam = np.asarray(body["eigenvalues"], float)
    if n > lam.size or reduction["eigenvalues"].shape != (n,) or not np.allclose(
            reduction["eigenvalues"], lam[:n], rtol=1e-12, atol=0.0):
        raise ReportInputError(f"{rpath}: stale (its eigenvalues differ from those of {bpath}); "
                               f"rerun gimbal_reduction.reduction.stage")


def load_inputs(body_paths, reduction_paths):
    """Read and pair the body and reduction files (by body number); returns a sorted list."""
    if len(body_paths) != len(reduction_paths):
        raise ReportInputError(f"--bodies has {len(body_paths)} files, --reductions "
                               f"{len(reduction_paths)}: one reduction file per body file is needed")
    bodies = []
    for path in body_paths:
        t0 = time.perf_counter()
        body = read_body_file(path)
        body["read_s"] = time.perf_counter() - t0
        if "body" not in body["attrs"]:
            raise ReportInputError(f"{path}: missing attribute body (stale body file?)")
        bodies.append(body)
    reductions = [read_reduction_file(p) for p in reduction_paths]
    numbers = [int(b["attrs"]["body"]) for b in bodies]
    if len(set(numbers)) != len(numbers):
        raise ReportInputError(f"--bodies: body numbers {numbers} repeat")
    by_number = {}
    for red in reductions:
        n = int(red["attrs"]["body"])
        if n in by_number:
            raise ReportInputError(f"{red['path']}: a second reduction of body {n} "
                                   f"(also {by_number[n]['path']})")
        by_number[n] = red
    pairs = []
    for body, n in zip(bodies, numbers):
        if n not in by_number:
            raise ReportInputError(f"{body['path']}: no reduction file of body {n} among --reductions")
        match_reduction(by_number[n], body)
        pairs.append((body, by_number[n]))
    return sorted(pairs, key=lambda p: int(p[0]["attrs"]["body"]))


# ----------------------------------------------------------------------------- checks

def coarse_identity_checks(coarse):
    """Discrete Hughes identities on a body file that holds every finite supported mode."""
    where = coarse["path"]
    M, K, T, X = coarse["M"], coarse["K"], coarse["T"], np.asarray(coarse["rigid_modes"], float)
    lam = np.asarray(coarse["eigenvalues"], float)
    P, H = mi.momentum_coefficients(M, X, coarse["modes"])
    M_inf, details = mi.supported_rigid_mass(M, T, X, mi.node_index(coarse["dof_coords"]),
                                             return_details=True)
    D, m = coarse["modes"].shape[1], T.shape[1]
    finite = m - details["n_massless_local"]  # upper bound on the finite supported modes
    if D < 0.5 * finite:
        raise ReportInputError(f"{where}: coarse body holds {D} modes of up to {finite} finite "
                               f"supported modes; make it with gimbal_reduction.solver.fe.modes --all-modes")
    apply_G = mi.supported_flexibility(K, T, X)
    MGM_inf = mi.flexibility_matrix(M, X, apply_G)
    common = {"file": where, "n_modes": int(D), "n_supported_coordinates": int(m),
              "n_massless_local": details["n_massless_local"],
              "modes_missing": int(m - details["n_massless_local"] - D),
              "mode_eigen_residual": float(coarse["attrs"].get("max_relative_residual", np.nan)),
              "measure": "max |A^-1/2 (sum_i C_i) A^-1/2 - I|"}
    mass = vf.check_hughes_mass_identity(P, H, M_inf, tol=IDENTITY_TOL,
                                         name="coarse_hughes_mass_identity")
    flex = vf.check_hughes_flexibility_identity(P, H, lam, MGM_inf, tol=IDENTITY_TOL,
                                                name="coarse_hughes_flexibility_identity")
    sums = {"xmx_radii_sum_minus_6": float(rk.xmx_radii(P, H, M_inf).sum() - 6.0),
            "xmgmx_radii_sum_minus_6": float(rk.xmgmx_radii(P, H, lam, MGM_inf).sum() - 6.0)}
    mass["details"] = {**common, "equation": "sum_i Mbar_i = M_inf (eq 3.32)", **sums}
    flex["details"] = {**common, "equation": "sum_i Mbar_i / Omega_i^2 = MGM_inf (eq 3.46)", **sums}
    return [mass, flex]


def default_case(result):
    """The default static load case of a body (the platform lacks output_motor_fz)."""
    cases = result["load_cases"]
    if not cases:
        raise ReportInputError("no static load case")
    return st.DEFAULT_LOAD_CASE if st.DEFAULT_LOAD_CASE in cases else cases[0]


def static_checks(label, body, result, apply_G):
    """Completeness, orthogonality and conditioning of the static modes of one body."""
    M = body["M"]
    kept = result["static_kept"]
    Phi = np.asarray(body["modes"][:, kept], float)
    lam = np.asarray(result["eigenvalues"], float)[kept]
    residual = float(body["attrs"].get("max_relative_residual", np.nan))
    case = default_case(result)
    entry = result["statics"][case]
    F = entry["load"]
    full = vf.static_response_error(apply_G, F, np.column_stack([Phi, entry["mode"]]),
                                    np.r_[lam, entry["modal_stiffness"]])
    without = vf.static_response_error(apply_G, F, Phi, lam)
    energy = vf.static_energy_shortfall(apply_G, F, Phi, lam)
    checks = [check_record(
        f"static_completeness/{label}/{case}", full, STATIC_TOL,
        details={"measure": "||[Phi, phi_s] K_r^-1 [Phi, phi_s]^T F - G F|| / ||G F||",
         "kept_modes_0based": [int(k) for k in kept], "load_case": case,
         "limit": ("K-coupling left by the FE modes' eigen-residual: after the M-orthogonal "
                   "Gram-Schmidt pass the static mode is K-coupled to mode i by about "
                   "c_i Omega_i / Omega_s, c_i ~ eigen-residual, which the diagonal reduced "
                   "stiffness neglects"),
         "mode_eigen_residual": residual,
         "shortfall_without_static_mode": without,
         "energy_shortfall_without_static_mode": energy}),
        check_record(f"static_shortfall_without_static_mode/{label}/{case}", without, None,
                     details={"measure": "||Phi Lambda^-1 Phi^T F - G F|| / ||G F|| (10 kept modes only)",
                              "energy_norm_share": energy})]
    mass = {c: float(e["mass_coupling"]) for c, e in result["statics"].items()}
    stiff = {c: float(e["stiffness_coupling"]) for c, e in result["statics"].items()}
    checks.append(check_record(f"static_mass_orthogonality/{label}", max(mass.values()), STATIC_TOL,
                               details={"measure": "max_i |phi_i^T M phi_s| / sqrt(m_s) over kept modes i",
                                        "per_case": mass, "mode_eigen_residual": residual}))
    checks.append(check_record(f"static_stiffness_orthogonality/{label}", max(stiff.values()), STATIC_TOL,
                               details={"measure": "max_i |phi_i^T K phi_s| / sqrt(Omega_i^2 k_s)",
                                        "per_case": stiff, "mode_eigen_residual": residual}))
    completeness_all = {c: vf.static_response_error(
        apply_G, e["load"], np.column_stack([Phi, e["mode"]]), np.r_[lam, e["modal_stiffness"]])
        for c, e in result["statics"].items()}
    Psi = np.column_stack([Phi, entry["mode"]])
    modal_mass = Psi.T @ (M @ Psi)
    w = np.linalg.eigvalsh(0.5 * (modal_mass + modal_mass.T))
    conditioning = {
        "load_cases": list(result["load_cases"]),
        "skipped_load_cases": list(result["skipped_load_cases"]),
        "static_set_mass_gram_condition": float(result["static_set_gram_condition"]),
        "static_set_meaning": ("condition number of the mass Gram matrix of the unit-mass static "
                               "modes of all load cases together, before their diagonalisation "
                               "(large: nearly dependent load cases)"),
        "kept_plus_default_static_modal_mass_condition": float(w[-1] / w[0]),
        "max_abs_static_modal_mass_minus_1": float(max(abs(e["modal_mass"] - 1.0)
                                                       for e in result["statics"].values())),
        "static_frequencies_hz": {c: float(e["frequency_hz"]) for c, e in result["statics"].items()},
        "residual_fraction": {c: float(e["residual_fraction"]) for c, e in result["statics"].items()},
        "completeness_per_case": completeness_all,
    }
    checks.append(check_record(f"static_modal_mass_conditioning/{label}",
                               conditioning["static_set_mass_gram_condition"], None, details=conditioning))
    return checks, {"default_load_case": case, "completeness": full,
                    "shortfall_without_static_mode": without,
                    "energy_shortfall_without_static_mode": energy, **conditioning}


def _rankings(M, K, T, X, modes, lam, dof_coords):
    P, H = mi.momentum_coefficients(M, X, modes)
    M_inf = mi.supported_rigid_mass(M, T, X, mi.node_index(dof_coords))
    MGM_inf = mi.flexibility_matrix(M, X, mi.supported_flexibility(K, T, X))
    rx, rg = rk.xmx_radii(P, H, M_inf), rk.xmgmx_radii(P, H, lam, MGM_inf)
    return rx, rg, rk.rank_by_radius(rx), rk.rank_by_radius(rg)


def invariance_checks(label, body, result, seed=3):
    """Rankings of a real body unchanged by mode sign flips, DOF renumbering, density scaling."""
    M, K, T = body["M"], body["K"], body["T"]
    X = np.asarray(body["rigid_modes"], float)
    D = result["n_modes"]
    modes = np.asarray(body["modes"][:, :D], float)
    lam = np.asarray(result["eigenvalues"], float)
    coords = np.asarray(body["dof_coords"], float)
    rng = np.random.default_rng(seed)
    ref = (result["rho_xmx"], result["rho_xmgmx"], result["rank_xmx"], result["rank_xmgmx"])
    variants = {}
    signs = rng.choice([-1.0, 1.0], size=D)
    variants["sign_flips"] = (_rankings(M, K, T, X, modes * signs, lam, coords),
                              f"{int((signs < 0).sum())} of {D} modes negated")
    perm = rng.permutation(M.shape[0])
    cols = rng.permutation(T.shape[1])
    variants["dof_renumbering"] = (_rankings(
        M[perm][:, perm].tocsr(), K[perm][:, perm].tocsr(), T[perm][:, cols].tocsr(), X[perm],
        modes[perm], lam, coords[perm]), "random permutation of DOFs and supported coordinates")
    c = 7.3
    variants["density_scaling"] = (_rankings((M * c).tocsr(), K, T, X, modes / np.sqrt(c), lam / c,
                                             coords), f"M -> {c} M, phi -> phi/sqrt({c}), "
                                                      f"Omega^2 -> Omega^2/{c}")
    checks = []
    for kind, (new, what) in variants.items():
        rx = vf.check_ranking_invariance(ref[0], new[0], ref[2], new[2], tol=INVARIANCE_TOL)
        rg = vf.check_ranking_invariance(ref[1], new[1], ref[3], new[3], tol=INVARIANCE_TOL)
        # both checks pass only within INVARIANCE_TOL, so their verdict implies the record's bound
        checks.append(check_record(
            f"ranking_invariance/{label}/{kind}", max(rx["value"], rg["value"]), INVARIANCE_TOL,
            passed=rx["passed"] and rg["passed"],
            details={"what": what,
                     "measure": "max |rho - rho'| / max rho (XMX and XMGMX); orders must be equal",
                     "xmx_relative_change": rx["value"], "xmgmx_relative_change": rg["value"],
                     "xmx_order_equal": bool(np.array_equal(ref[2], new[2])),
                     "xmgmx_order_equal": bool(np.array_equal(ref[3], new[3]))}))
    return checks


def hand_check():
    """The hand-checkable case of tests/reduction/test_hand.py, rebuilt here independently.

    Three point masses m = 1/2 at (2, 0, 0), (-1, 1, 0), (-1, -1, 0) on equal
    springs k = 100 to ground (T = I): M_inf = diag(3/2, 3/2, 3/2, 1, 3, 4),
    MGM_inf = (m/k) M_inf, XMX radii 1/3, 5/6, 1, 11/24, 11/24, 1, 11/24,
    11/24, 1 (by hand), equal XMGMX radii, both summing to 6.
    """
    m, k = 0.5, 100.0
    pos = np.array([[2.0, 0, 0], [-1.0, 1.0, 0], [-1.0, -1.0, 0]])
    M = sp.identity(9, format="csr") * m
    K = sp.identity(9, format="csr") * k
    T = sp.identity(9, format="csr")
    X = rigid_modes(np.repeat(pos, 3, axis=0), np.tile(np.arange(3), 3))
    modes = np.eye(9) / np.sqrt(m)
    lam = np.full(9, k / m)
    P, H = mi.momentum_coefficients(M, X, modes)
    M_inf = mi.supported_rigid_mass(M, T, X)
    MGM_inf = mi.flexibility_matrix(M, X, mi.supported_flexibility(K, T, X))
    expected_rho = np.array([1 / 3, 5 / 6, 1, 11 / 24, 11 / 24, 1, 11 / 24, 11 / 24, 1])
    expected_M = np.diag([1.5, 1.5, 1.5, 1.0, 3.0, 4.0])
    rx, rg = rk.xmx_radii(P, H, M_inf), rk.xmgmx_radii(P, H, lam, MGM_inf)
    errors = {"rho_xmx": float(np.max(np.abs(rx - expected_rho))),
              "rho_xmgmx": float(np.max(np.abs(rg - expected_rho))),
              "M_inf": float(np.max(np.abs(M_inf - expected_M)) / 4.0),
              "MGM_inf": float(np.max(np.abs(MGM_inf - expected_M * m / k)) / (4.0 * m / k)),
              "xmx_sum_minus_6": float(abs(rx.sum() - 6.0))}
    order = [int(i) for i in rk.rank_by_radius(rx)]
    worst = max(errors.values())
    return check_record("hand_checkable_three_masses", worst, 1e-12,
                        passed=bool(np.isfinite(worst) and worst <= 1e-12
                                    and order == [2, 5, 8, 1, 3, 4, 6, 7, 0]),
                        details={"errors": errors, "rank_xmx_0based": order,
                                 "expected_rank_0based": [2, 5, 8, 1, 3, 4, 6, 7, 0]})


# ----------------------------------------------------------------------------- summaries

def ranking_agreement(rho_xmx, rho_xmgmx, rank_xmx, rank_xmgmx, frequencies_hz, n_rows=TABLE_ROWS):
    """How far the XMX and XMGMX rankings agree (dict of plain numbers)."""
    a, b = np.asarray(rank_xmx, int), np.asarray(rank_xmgmx, int)
    table = rk.ranking_table(a, b, n_rows=n_rows)
    D = a.size
    pos_a, pos_b = np.empty(D, int), np.empty(D, int)
    pos_a[a], pos_b[b] = np.arange(D), np.arange(D)
    top = np.union1d(a[:n_rows], b[:n_rows])
    # The thesis code (Appendix A.1) reuses the XMX array rho for XMGMX and its XMGMX loop
    # ``for iiii = depth`` overwrites only the last entry: emulate its "XMGMX" ranking.
    thesis_rho = np.asarray(rho_xmx, float).copy()
    thesis_rho[-1] = rho_xmgmx[-1]
    thesis_rank = rk.rank_by_radius(thesis_rho)
    differ = np.flatnonzero(thesis_rank != a)
    f = np.asarray(frequencies_hz, float)
    ratio = f[1:] / f[:-1] - 1.0
    close = [[int(i), int(i + 1)] for i in np.flatnonzero(ratio < 0.02)
             if i in top or i + 1 in top]
    return {
        "common_prefix": int(table["common_prefix"]),
        "first_mode_equal": bool(a[0] == b[0]),
        "top_k": [int(k) for k in table["top_k"]],
        "top_k_overlap": [int(o) for o in table["overlap"]],
        "spearman_rho_all_modes": float(spearmanr(rho_xmx, rho_xmgmx)[0]),
        "kendall_tau_all_modes": float(kendalltau(rho_xmx, rho_xmgmx)[0]),
        "spearman_positions_top40_union": float(spearmanr(pos_a[top], pos_b[top])[0]),
        "thesis_code_emulation_first_difference": int(differ[0]) if differ.size else D,
        "thesis_code_emulation_note": ("rank of the first position where the thesis code's "
                                       "'XMGMX' ranking (XMX radii with only the last mode's entry "
                                       "overwritten) differs from XMX, 0-based"),
        "near_degenerate_pairs_in_top40_within_2pct_0based": close,
    }


def agreement_diagnostics(result, M_rigid, cluster_gap=0.02, n=TABLE_ROWS):
    """Why XMX and XMGMX disagree (docs/reduction.md, "Finding 2 on our model").

    * ``same_set_k``: the k <= 10 for which both rankings pick the same top-k set;
    * ``xmx_top40_unchanged_with_M_rigid``: the thesis's M_inf = X^T M X instead of the
      supported M_inf leaves the XMX top 40 unchanged (the M_inf definition is not the cause);
    * merged near-degenerate clusters (neighbouring frequencies within ``cluster_gap``) as one
      entry each (sum of their Mbar_i): ``clusters_common_prefix``, ``clusters_top10_overlap``
      (if split degenerate pairs caused the disagreement, merging would restore it);
    * ``dominant_direction``: per top-10 mode (1-based) the rigid direction (ux..rz) that
      A^-1/2 v_i points along most, with its share, for XMX and XMGMX.
    """
    P, H, lam = result["P"], result["H"], np.asarray(result["eigenvalues"], float)
    a, b = np.asarray(result["rank_xmx"], int), np.asarray(result["rank_xmgmx"], int)
    same = [k for k in range(1, min(10, a.size) + 1) if set(a[:k]) == set(b[:k])]
    rigid_rank = rk.rank_by_radius(rk.xmx_radii(P, H, M_rigid))
    f = np.asarray(result["frequencies_hz"], float)
    cluster = np.r_[0, np.cumsum(f[1:] / f[:-1] - 1.0 > cluster_gap)]
    C = mi.mode_contributions(P, H)
    nc = int(cluster.max()) + 1
    Cx = np.array([C[cluster == c].sum(axis=0) for c in range(nc)])
    Cg = np.array([(C[cluster == c] / lam[cluster == c][:, None, None]).sum(axis=0)
                   for c in range(nc)])
    ca = rk.rank_by_radius(rk.spectral_radii(Cx, result["M_inf"]))
    cb = rk.rank_by_radius(rk.spectral_radii(Cg, result["MGM_inf"]))
    differ = np.flatnonzero(ca != cb)
    V = np.vstack([P, H])
    directions = {}
    for label, A, scale in (("xmx", result["M_inf"], np.ones_like(lam)),
                            ("xmgmx", result["MGM_inf"], 1.0 / np.sqrt(lam))):
        W = rk.symmetric_inverse_sqrt(A) @ (V * scale)
        share = W ** 2 / np.maximum((W ** 2).sum(axis=0), np.finfo(float).tiny)
        directions[label] = {
            str(int(i) + 1): [RIGID_MOTION_NAMES[int(np.argmax(share[:, i]))],
                              float(np.max(share[:, i]))]
            for i in np.union1d(a[:TOP_LISTED], b[:TOP_LISTED])}
    return {
        "same_set_k": same,
        "xmx_top40_unchanged_with_M_rigid": bool(np.array_equal(rigid_rank[:n], a[:n])),
        "cluster_gap": cluster_gap, "n_clusters": nc,
        "clusters_common_prefix": int(differ[0]) if differ.size else nc,
        "clusters_top10_overlap": int(np.intersect1d(ca[:10], cb[:10]).size),
        "dominant_direction": directions,
    }


def top_modes(order, result, n=TOP_LISTED):
    f = result["frequencies_hz"]
    return [{"rank_1based": r + 1, "mode_1based": int(i) + 1, "frequency_hz": float(f[i]),
             "rho_xmx": float(result["rho_xmx"][i]), "rho_xmgmx": float(result["rho_xmgmx"][i])}
            for r, i in enumerate(np.asarray(order)[:n])]


def shares(result, body):
    """Share of M_inf and MGM_inf captured by the first 5/10/25 modes of every ranking."""
    P, H = result["P"], result["H"]
    out = {}
    for label in ("frequency", "xmx", "xmgmx"):
        order = result[f"rank_{label}"]
        out[label] = {}
        for k in SHARE_COUNTS:
            if k > order.size:
                continue
            mass = rk.captured_share(P, H, order[:k], result["M_inf"])
            flex = rk.captured_share(P, H, order[:k], result["MGM_inf"], result["eigenvalues"])
            out[label][str(k)] = {"mass_trace": mass["trace_share"], "mass_min": mass["min_eigenvalue"],
                                  "flexibility_trace": flex["trace_share"],
                                  "flexibility_min": flex["min_eigenvalue"]}
    return out


def table_rows(label, name, reduction):
    """Rows of the ranking CSV for one body (from its reduction file)."""
    a, b = reduction["rank_xmx"].astype(int), reduction["rank_xmgmx"].astype(int)
    f, rx, rg = reduction["frequencies_hz"], reduction["rho_xmx"], reduction["rho_xmgmx"]
    n = min(TABLE_ROWS, a.size)
    rows = []
    for r in range(n):
        i, j = a[r], b[r]
        rows.append({
            "body": label, "name": name, "rank_1based": r + 1,
            "xmx_mode_1based": i + 1, "xmx_frequency_hz": f"{f[i]:.6g}", "xmx_rho": f"{rx[i]:.6g}",
            "xmgmx_mode_1based": j + 1, "xmgmx_frequency_hz": f"{f[j]:.6g}",
            "xmgmx_rho": f"{rg[j]:.6g}", "same_mode": int(i == j),
            "top_k_overlap": int(np.intersect1d(a[:r + 1], b[:r + 1]).size),
            "xmx_mode_in_xmgmx_top40": int(i in b[:n]), "xmgmx_mode_in_xmx_top40": int(j in a[:n]),
        })
    return rows


def write_table(path, rows, record=None):
    """The ranking CSV (``table_rows``: numbers already formatted as text or ints), its provenance
    record (default ``gimbal_reduction.workflow.provenance.provenance()``) in a sidecar."""
    write_csv(path, rows, list(rows[0].keys()), record=record)


# ----------------------------------------------------------------------------- main

def build_report(pairs, coarse, log=None, runs=N_RUNS):
    """All checks, summaries, table rows and timings (dicts/lists of plain values); the stage is
    timed over ``runs`` runs per body (1 in the main job: its timing repeats are the bench's)."""
    log = log or (lambda *_: None)
    checks, bodies, rows, bench = [hand_check()], {}, [], {}
    checks += coarse_identity_checks(coarse)
    log(f"coarse identities: {[c['value'] for c in checks[1:3]]}")
    numbers = [int(b["attrs"]["body"]) for b, _ in pairs]
    invariance_body = 4 if 4 in numbers else numbers[0]
    for body, reduction in pairs:
        n = int(body["attrs"]["body"])
        label = f"body{n}"
        times, result = [], None
        for _ in range(runs):
            t0 = time.perf_counter()
            result = stage.reduce_body(body, n_modes=int(reduction["attrs"]["n_modes"]),
                                       static_kept=int(reduction["static_attrs"].get("n_kept", 10)),
                                       static_ranking=str(reduction["static_attrs"].get(
                                           "kept_ranking", "frequency")))
            times.append(time.perf_counter() - t0)
        bench[label] = {"name": body["attrs"].get("name"), "runs_s": times,
                        "median_s": float(np.median(times)), "read_body_file_s": body["read_s"],
                        "n_dofs": int(body["modes"].shape[0]), "n_modes": int(result["n_modes"]),
                        "n_load_cases": len(result["load_cases"]),
                        "skipped_load_cases": list(result["skipped_load_cases"]),
                        "stage_parts_s_last_run": result["timings"]}
        # the reduction file must hold what the pure functions give now
        for key in ("rho_xmx", "rho_xmgmx"):
            scale = np.max(np.abs(result[key]))
            if np.max(np.abs(result[key] - reduction[key])) > 1e-8 * scale:
                raise ReportInputError(f"{reduction['path']}: {key} differs from a fresh reduction of "
                                       f"{body['path']} (stale reduction file; rerun gimbal_reduction.reduction.stage)")
        for key in ("rank_xmx", "rank_xmgmx"):
            if not np.array_equal(result[key], reduction[key]):
                log(f"warning: {reduction['path']}: {key} differs from a fresh reduction in near-ties")
        apply_G = mi.supported_flexibility(body["K"], body["T"], body["rigid_modes"])
        static, static_summary = static_checks(label, body, result, apply_G)
        checks += static
        if n == invariance_body:
            checks += invariance_checks(label, body, result)
        agreement = ranking_agreement(reduction["rho_xmx"], reduction["rho_xmgmx"],
                                      reduction["rank_xmx"], reduction["rank_xmgmx"],
                                      reduction["frequencies_hz"])
        agreement.update(agreement_diagnostics(result, mi.rigid_mass(body["M"], body["rigid_modes"])))
        bodies[label] = {
            "name": body["attrs"].get("name"), "body_file": body["path"],
            "reduction_file": reduction["path"], "n_dofs": int(body["modes"].shape[0]),
            "n_modes": int(result["n_modes"]),
            "mode_eigen_residual": float(body["attrs"].get("max_relative_residual", np.nan)),
            "identity_share_of_computed_modes": {
                "mass_trace": float(rk.captured_share(result["P"], result["H"],
                                                      np.arange(result["n_modes"]),
                                                      result["M_inf"])["trace_share"]),
                "flexibility_trace": float(rk.captured_share(
                    result["P"], result["H"], np.arange(result["n_modes"]), result["MGM_inf"],
                    result["eigenvalues"])["trace_share"])},
            "top10": {"xmx": top_modes(reduction["rank_xmx"], result),
                      "xmgmx": top_modes(reduction["rank_xmgmx"], result)},
            "captured_share": shares(result, body),
            "ranking_agreement": agreement,
            "static_modes": static_summary,
        }
        rows += table_rows(label, body["attrs"].get("name", ""), reduction)
        log(f"{label}: median {np.median(times):.2f} s, top XMX "
            f"{[int(i) + 1 for i in reduction['rank_xmx'][:5]]}, top XMGMX "
            f"{[int(i) + 1 for i in reduction['rank_xmgmx'][:5]]} (1-based)")
    return checks, bodies, rows, bench


def main(argv=None):
    parser = argparse.ArgumentParser(description="Ranking table, verification record and benchmark "
                                                 "of the reduction stage over all bodies.")
    parser.add_argument("--bodies", nargs="+", required=True, help="results/modes/body{n}.h5")
    parser.add_argument("--reductions", nargs="+", required=True, help="results/reduction/body{n}.h5")
    parser.add_argument("--coarse-body", required=True,
                        help="a body file holding every finite supported mode (--all-modes)")
    parser.add_argument("--table", required=True, help="ranking CSV (Table 4.1 analogue)")
    parser.add_argument("--verification", required=True, help="verification JSON")
    parser.add_argument("--benchmark", required=True, help="benchmark JSON")
    parser.add_argument("--runs", type=int, default=N_RUNS,
                        help=f"timed runs of the stage per body (default {N_RUNS}; the benchmark "
                             "gives their median; 1: the checks only, one timing)")
    parser.add_argument("--config", help="the current configuration file: body and reduction files of "
                                         "another configuration are refused (gimbal_reduction.solver.bodyconfig; the "
                                         "coarse body is checked by its own contract only)")
    args = parser.parse_args(argv)
    if args.runs < 1:
        parser.error(f"--runs must be at least 1, got {args.runs}")
    log = lambda msg: print(f"[gimbal_reduction.reduction.report] {msg}")  # noqa: E731
    started = time.perf_counter()
    try:
        bodyconfig.check_files(args.bodies + args.reductions, args.config)
        pairs = load_inputs(args.bodies, args.reductions)
        coarse = read_body_file(args.coarse_body)
        checks, bodies, rows, bench = build_report(pairs, coarse, log, runs=args.runs)
    except (ReductionError, BodyFileError) as exc:
        print(f"gimbal_reduction.reduction.report: error: {exc}", file=sys.stderr)
        return 2
    failed = [c["name"] for c in checks if not c["passed"]]
    provenance = {
        "command": "python -m gimbal_reduction.reduction.report " + " ".join(argv if argv is not None else sys.argv[1:]),
        "inputs": {p: {"config_hash": str(b["attrs"].get("config_hash")),
                       "mtime": os.path.getmtime(p)}
                   for p, b in [(b["path"], b) for b, _ in pairs] + [(coarse["path"], coarse)]},
        "reductions": [r["path"] for _, r in pairs],
    }
    # the body and reduction files' config hashes (the body files', copied into the reductions)
    record = provenance_record(sources=[*args.bodies, *args.reductions, args.coarse_body])
    write_table(args.table, rows, record)
    write_json(args.verification, {
        "description": ("Reduction stage verification (docs/reduction.md). Mode numbers in "
                        "'top10' are 1-based in frequency order (thesis convention); "
                        "kept_modes_0based and *_0based fields are 0-based indices."),
        "summary": {"n_checks": len(checks), "n_passed": len(checks) - len(failed),
                    "failed": failed},
        "checks": checks, "bodies": bodies, "provenance": provenance}, record)
    total = float(sum(b["median_s"] for b in bench.values()))
    write_json(args.benchmark, {
        "what": ("median of %d runs of gimbal_reduction.reduction.stage.reduce_body per body (modal integrals, "
                 "M_inf, stiffness factorisation and MGM_inf, rankings, static modes of every "
                 "default load case); body file reading excluded (read_body_file_s)" % args.runs),
        "runs": args.runs,
        "bodies": bench, "total_median_s": total, "target_total_s": TARGET_TOTAL_S,
        "passed": total < TARGET_TOTAL_S, "omp_num_threads": os.environ.get("OMP_NUM_THREADS"),
        "report_wall_time_s": time.perf_counter() - started,
        "versions": versions(), "provenance": provenance}, record)
    log(f"{len(checks) - len(failed)}/{len(checks)} checks passed; stage total {total:.2f} s "
        f"(median of {args.runs}); wrote {args.table}, {args.verification}, {args.benchmark}")
    if failed:
        print(f"gimbal_reduction.reduction.report: FAILED checks: {', '.join(failed)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
