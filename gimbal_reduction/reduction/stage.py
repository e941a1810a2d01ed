"""Reduction stage: modal integrals, rankings and static modes of one body.

    /usr/bin/python3 -m gimbal_reduction.reduction.stage --body-file results/modes/body2.h5 \\
        --out results/reduction/body2.h5 [--static-kept 10] [--load-cases ...]

Reads a body file (docs/body-data.md), writes ``results/reduction/body{n}.h5``
atomically (docs/reduction.md lists every dataset).  Errors in the input (a
stale or corrupt body file, an unknown load case, a mode count above what was
computed, missing supports) end the run with a one-line message naming the
culprit and exit status 2, before the expensive work.

Static modes: one per load case, each orthogonalised against the kept set of
the ``--static-kept`` lowest-frequency modes (default 10, thesis Section 4.4:
"one static mode ... and ten normal modes"; the thesis builds its static
mode against the kept modes of the run, Appendix A.2).  Other kept sets:
``gimbal_reduction.reduction.static_modes.static_correction_modes``.  Platform rule: the
output-bearing load cases are skipped (and listed in the attribute
``skipped_load_cases``) when the body has no output bearings and the cases
were not named explicitly; naming one explicitly is an error.
"""

import json
import os
import sys
import time

import numpy as np

from gimbal_reduction.reduction import modal_integrals as mi
from gimbal_reduction.reduction import ranking as rk
from gimbal_reduction.reduction import static_modes as st
from gimbal_reduction.reduction import verification as vf
from gimbal_reduction.solver import bodyconfig
from gimbal_reduction.solver.bodydata import BEARING_NAMES, read_body_file
from gimbal_reduction.reduction.errors import BodyFileError, MissingBearingError, ReductionError
from gimbal_reduction.workflow import cli
from gimbal_reduction.workflow.provenance import atomic_h5, check_record, versions

FORMAT_VERSION = 1


def reduce_body(body, n_modes=None, static_kept=10, static_ranking="frequency",
                load_cases=None, table_rows=40, log=None):
    """All reduction results of one body dict (``bodyfile.read_body_file``) as a dict.

    n_modes: use the first n computed modes (default all); static_kept: size
    of the kept set the static modes are orthogonal to, taken from the
    ``static_ranking`` ("frequency", "xmx" or "xmgmx"); load_cases: names
    (default ``THESIS_LOAD_CASES``; see the module docstring for the platform).
    """
    log = log or (lambda *_: None)
    where = body.get("path", "body")
    D_all = body["modes"].shape[1]
    D = mi.check_mode_count(D_all if n_modes is None else n_modes, D_all, f"{where}: modes")
    if D == 0:
        raise ReductionError(f"{where}: at least one mode is needed")
    mi.check_mode_count(static_kept, D, f"{where}: --static-kept")
    if static_ranking not in ("frequency", "xmx", "xmgmx"):
        raise ReductionError(f"unknown static ranking {static_ranking!r} (frequency, xmx, xmgmx)")
    explicit = load_cases is not None
    cases = list(st.THESIS_LOAD_CASES if load_cases is None else load_cases)
    points = np.asarray(body["bearing_points"], float)
    has_inside = bool(np.all(np.isfinite(points[2:4])))
    skipped = []
    for name in cases:  # validate names and bearings before the expensive work
        bearing, _ = st.parse_load_case(name)
        if not np.all(np.isfinite(points[bearing])):
            if explicit:
                raise MissingBearingError(
                    f"{where}: load case {name!r} needs bearing {BEARING_NAMES[bearing]}, "
                    f"which this body does not have")
            skipped.append(name)
    cases = [c for c in cases if c not in skipped]

    modes = np.asarray(body["modes"][:, :D], float)
    lam = np.asarray(body["eigenvalues"][:D], float)
    M, K, T, X = body["M"], body["K"], body["T"], np.asarray(body["rigid_modes"], float)
    mi.check_supports(K, T, X)  # missing supports: fail before any factorisation
    t0 = time.perf_counter()
    P, H = mi.momentum_coefficients(M, X, modes)
    M_rigid = mi.rigid_mass(M, X)
    dof_node = mi.node_index(body["dof_coords"])
    M_inf, mass_details = mi.supported_rigid_mass(M, T, X, dof_node, return_details=True)
    t1 = time.perf_counter()
    apply_G = mi.supported_flexibility(K, T, X)
    MGM_inf = mi.flexibility_matrix(M, X, apply_G)
    t2 = time.perf_counter()
    log(f"modal integrals {t1 - t0:.2f} s, stiffness factorisation + MGM {t2 - t1:.2f} s")

    rho_xmx = rk.xmx_radii(P, H, M_inf)
    rho_xmgmx = rk.xmgmx_radii(P, H, lam, MGM_inf)
    rank_frequency = rk.rank_by_frequency(lam)
    rank_xmx = rk.rank_by_radius(rho_xmx)
    rank_xmgmx = rk.rank_by_radius(rho_xmgmx)
    table = rk.ranking_table(rank_xmx, rank_xmgmx, n_rows=table_rows)
    shares = {}
    for label, order in (("frequency", rank_frequency), ("xmx", rank_xmx), ("xmgmx", rank_xmgmx)):
        shares[f"{label}/mass_trace"], shares[f"{label}/mass_min"] = rk.cumulative_share(
            P, H, order, M_inf)
        shares[f"{label}/flexibility_trace"], shares[f"{label}/flexibility_min"] = \
            rk.cumulative_share(P, H, order, MGM_inf, lam)

    bearing_modes = np.asarray(body["bearing_modes"][:D], float)
    joints = mi.inside_frame_motion(bearing_modes, points) if has_inside else None

    ranking_for_static = {"frequency": rank_frequency, "xmx": rank_xmx,
                          "xmgmx": rank_xmgmx}[static_ranking]
    kept = rk.kept_modes(ranking_for_static, static_kept)
    Phi, lam_kept = st.check_kept_set(modes, lam, kept)
    B = body["bearing_operator"]
    # static checks: 1e-10, or what the FE modes' own accuracy allows (their eigen-residual)
    mode_residual = float(body.get("attrs", {}).get("max_relative_residual", 0.0) or 0.0)
    static_tol = max(1e-10, 10.0 * mode_residual)
    statics = {}
    checks = [
        check_record("mass_identity_share_of_computed_modes",
                     rk.captured_share(P, H, np.arange(D), M_inf)["trace_share"], None),
        check_record("flexibility_identity_share_of_computed_modes",
                     rk.captured_share(P, H, np.arange(D), MGM_inf, lam)["trace_share"], None),
    ]
    loads = {}
    for name in cases:
        F = st.load_case_vector(B, name, points)
        loads[name] = F
        res = st.static_correction_modes(M, K, apply_G, F, Phi, lam_kept, [name])
        phi = res["modes"][:, 0]
        Ps, Hs = mi.momentum_coefficients(M, X, phi)
        motion = np.asarray(B @ phi).reshape(4, 6)
        motion[~np.all(np.isfinite(points), axis=1)] = np.nan
        entry = {"mode": phi, "modal_mass": res["modal_mass"][0],
                 "modal_stiffness": res["modal_stiffness"][0],
                 "frequency_hz": res["frequencies_hz"][0], "P": Ps, "H": Hs,
                 "bearing_motion": motion, "kept_modes": kept,
                 "residual_fraction": res["residual_fraction"][0],
                 "mass_coupling": res["mass_coupling"],
                 "stiffness_coupling": res["stiffness_coupling"],
                 "mass_coupling_vector": res["mass_coupling_vector"][:, 0],
                 "stiffness_coupling_vector": res["stiffness_coupling_vector"][:, 0],
                 "load": F}
        if has_inside:
            jm = mi.inside_frame_motion(motion, points)
            entry.update({k: jm[k] for k in ("psi", "theta", "psi_midpoint", "stretch")})
        statics[name] = entry
        checks.append(vf.check_static_orthogonality(res, tol=static_tol,
                                                    name=f"static_orthogonality/{name}"))
        checks.append(vf.check_static_completeness(
            apply_G, F, Phi, lam_kept, phi, res["modal_stiffness"][0], tol=static_tol,
            name=f"static_completeness/{name}"))
        checks.append(vf.check_truncation_shortfall(
            apply_G, F, Phi, lam_kept, name=f"kept_modes_static_shortfall/{name}"))
    set_condition = np.nan
    if len(cases) > 1:
        together = st.static_correction_modes(
            M, K, apply_G, np.column_stack([loads[c] for c in cases]), Phi, lam_kept, cases,
            gram_condition_limit=np.inf)
        set_condition = together["gram_condition"]
    t3 = time.perf_counter()
    log(f"rankings and {len(cases)} static modes {t3 - t2:.2f} s")
    return {
        "n_modes": D, "P": P, "H": H, "M_inf": M_inf, "M_rigid": M_rigid, "MGM_inf": MGM_inf,
        "eigenvalues": lam, "frequencies_hz": np.sqrt(lam) / (2 * np.pi),
        "rho_xmx": rho_xmx, "rho_xmgmx": rho_xmgmx, "rank_frequency": rank_frequency,
        "rank_xmx": rank_xmx, "rank_xmgmx": rank_xmgmx, "table": table, "shares": shares,
        "joints": joints, "bearing_modes": bearing_modes, "statics": statics,
        "static_kept": kept, "static_ranking": static_ranking, "load_cases": cases,
        "skipped_load_cases": skipped, "static_set_gram_condition": set_condition,
        "mass_details": mass_details, "checks": checks,
        "timings": {"modal_integrals_s": t1 - t0, "flexibility_s": t2 - t1,
                    "rankings_static_s": t3 - t2},
    }


def write_reduction_file(path, result, body):
    """Write ``reduce_body``'s result atomically (layout in docs/reduction.md)."""
    attrs = body.get("attrs", {})

    def write(f):
        f.attrs["format_version"] = FORMAT_VERSION
        for key in ("body", "name", "model", "config_hash"):
            if key in attrs:
                f.attrs[key] = attrs[key]
        f.attrs["body_file"] = str(body.get("path", ""))
        f.attrs["n_modes"] = result["n_modes"]
        f.attrs["units"] = ("in, lbf, s; P sqrt(lbf s^2/in), H sqrt(lbf s^2/in) in, "
                            "M_inf like X^T M X, MGM_inf like X^T M G M X, rho dimensionless")
        f.attrs["mode_index_base"] = 0
        f.attrs["n_massless_local"] = result["mass_details"]["n_massless_local"]
        f.attrs["mass_solve_relative_residual"] = result["mass_details"]["relative_residual"]
        f.attrs["timings"] = json.dumps(result["timings"])
        f.attrs["checks"] = json.dumps(result["checks"])
        # provenance as in a body file: this stage's versions and git revision (JSON), and the body
        # file's own (its config_hash is copied above)
        f.attrs["versions"] = json.dumps(versions())
        if "versions" in attrs:
            f.attrs["body_versions"] = attrs["versions"]
        f.attrs["created"] = time.strftime("%Y-%m-%dT%H:%M:%S")
        for key in ("P", "H", "M_inf", "M_rigid", "MGM_inf", "eigenvalues", "frequencies_hz",
                    "rho_xmx", "rho_xmgmx", "rank_frequency", "rank_xmx", "rank_xmgmx"):
            f.create_dataset(key, data=result[key])
        g = f.create_group("ranking_table")
        for key, value in result["table"].items():
            if np.ndim(value):
                g.create_dataset(key, data=value)
            else:
                g.attrs[key] = value
        g = f.create_group("captured_share")
        g.attrs["meaning"] = ("k-th entry: trace/6 and smallest eigenvalue of "
                              "A^-1/2 (sum of the first k+1 modes of the ranking) A^-1/2")
        for key, value in result["shares"].items():
            g.create_dataset(key, data=value)
        g = f.create_group("joint")
        g.create_dataset("bearing_modes", data=result["bearing_modes"])
        g.attrs["has_inside_frame"] = result["joints"] is not None
        if result["joints"] is not None:
            for key in ("psi", "theta", "psi_midpoint"):
                g.create_dataset(key, data=np.asarray(result["joints"][key]).T)  # (3, D)
            g.create_dataset("stretch", data=result["joints"]["stretch"])
            g.attrs["axis"] = result["joints"]["axis"]
            g.attrs["distance"] = result["joints"]["distance"]
        s = f.create_group("static_modes")
        s.attrs["n_kept"] = len(result["static_kept"])
        s.attrs["kept_ranking"] = result["static_ranking"]
        s.attrs["load_cases"] = json.dumps(result["load_cases"])
        s.attrs["skipped_load_cases"] = json.dumps(result["skipped_load_cases"])
        s.attrs["set_gram_condition"] = result["static_set_gram_condition"]
        s.attrs["normalisation"] = "unit modal mass"
        for name, entry in result["statics"].items():
            c = s.create_group(name)
            c.attrs["n_kept"] = len(entry["kept_modes"])
            c.create_dataset("kept_modes", data=entry["kept_modes"])
            for key in ("mode", "P", "H", "bearing_motion", "load", "mass_coupling_vector",
                        "stiffness_coupling_vector"):
                c.create_dataset(key, data=entry[key])
            for key in ("psi", "theta", "psi_midpoint"):
                if key in entry:
                    c.create_dataset(key, data=entry[key])
            for key in ("modal_mass", "modal_stiffness", "frequency_hz", "residual_fraction",
                        "mass_coupling", "stiffness_coupling", "stretch"):
                if key in entry:
                    c.attrs[key] = float(entry[key])

    with atomic_h5(path) as f:
        write(f)
    return os.fspath(path)


def main(argv=None):
    parser = cli.OneLineParser(prog="gimbal_reduction.reduction.stage", description="Reduce one body: modal integrals, "
                                                                  "rankings, static correction modes.")
    parser.add_argument("--body-file", required=True, help="results/modes/body{n}.h5")
    parser.add_argument("--out", required=True, help="results/reduction/body{n}.h5")
    parser.add_argument("--n-modes", type=int, default=None,
                        help="use the first n computed modes (default: all)")
    parser.add_argument("--static-kept", type=int, default=10,
                        help="kept vibration modes the static modes are orthogonal to (default 10)")
    parser.add_argument("--static-ranking", default="frequency",
                        choices=("frequency", "xmx", "xmgmx"),
                        help="ranking the kept set is taken from (default frequency)")
    parser.add_argument("--load-cases", nargs="+", default=None,
                        help="static load cases (default: the thesis's seven)")
    parser.add_argument("--table-rows", type=int, default=40)
    parser.add_argument("--expect-config-hash", default=None,
                        help="refuse a body file with a different config_hash (stale)")
    cli.add_config_option(parser, "a body file of another configuration is refused")
    parser.add_argument("--quiet", action="store_true")
    try:        # a negative value is read as the option's value (and refused by the stage's checks)
        args = parser.parse_args(cli.values_joined(sys.argv[1:] if argv is None else argv, parser))
    except SystemExit as exc:       # the one-line message is printed; in process, return the status
        return exc.code
    log = (lambda *_: None) if args.quiet else (lambda msg: print(f"[reduction] {msg}"))
    started = time.perf_counter()
    try:
        bodyconfig.check_files([args.body_file], args.config)
        body = read_body_file(args.body_file, args.expect_config_hash)
        result = reduce_body(body, args.n_modes, args.static_kept, args.static_ranking,
                             args.load_cases, args.table_rows, log)
        result["timings"]["wall_time_s"] = time.perf_counter() - started
    except (ReductionError, BodyFileError) as exc:
        print(f"gimbal_reduction.reduction.stage: error: {exc}", file=sys.stderr)
        return 2
    try:
        write_reduction_file(args.out, result, body)
    except OSError as exc:          # a full disk: the atomic writer left nothing
        print(f"gimbal_reduction.reduction.stage: error: {cli.write_failure(args.out, exc)}", file=sys.stderr)
        return 2
    failed = [c["name"] for c in result["checks"] if not c["passed"]]
    log(f"{args.body_file} -> {args.out}: {result['n_modes']} modes, "
        f"top XMX {list(result['rank_xmx'][:5])}, {len(result['statics'])} static modes, "
        f"{time.perf_counter() - started:.2f} s" + (f"; FAILED checks {failed}" if failed else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
