"""Command line of the FE verification: one check per call, and the combined report.

``gimbal fe-verify CHECK [--body N] [--body-file F] [--mesh F] --out part.json``
``gimbal fe-verify body --body-file F --out modes.json --spectra-out spectra.json``
``gimbal fe-verify combine part1.json ... --out fe.json --summary fe.md``

CHECK is one of: ring, plate, solid-ring, platform, convergence, body-file,
hughes, mpi, connection, spectra (see ``gimbal_reduction.solver.fe.checks``); body-file, spectra, mpi and
hughes read ``--body-file`` (hughes: the coarse body with every mode, ``--all-modes``).
``body`` runs body-file and spectra on one read of the file (``--out``, ``--spectra-out``).
"""
from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from gimbal_reduction.solver.fe import checks as v
from gimbal_reduction.workflow import config as cfgmod
from gimbal_reduction.workflow.provenance import provenance, versions, write_json, write_text

CHECKS = cfgmod.CHECKS


def run_check(name: str, config: dict, args) -> dict:
    if name == "ring":
        return v.check_ring_formula(config)
    if name == "plate":
        return v.check_plate_fv12(config, size=0.25)
    if name == "solid-ring":
        return v.check_solid_ring(config, solid_size=args.solid_size)
    if name == "platform":
        return v.check_platform_model(config)
    if name == "convergence":
        # the verdict on the first verification.convergence_modes, all modes.count reported
        return v.check_convergence(config, int(args.body), levels=args.levels,
                                   report_count=int(cfgmod.value(config, "modes.count")),
                                   level0=args.body_file)
    if name == "body-file":
        return v.check_body_file(args.body_file)
    if name == "hughes":
        if not args.body_file:
            raise ValueError("hughes checks a body file with every supported mode: give --body-file "
                             "(gimbal_reduction.solver.fe.modes --all-modes; rule coarse_body_all_modes)")
        return v.check_hughes_identity(args.body_file)
    if name == "mpi":
        return v.check_mpi(args.body_file, args.mesh, args.config)
    if name == "connection":
        return v.connection_study(config)
    if name == "spectra":
        return v.body_spectra(args.body_file, int(cfgmod.value(config, "verification.free_modes")),
                              int(cfgmod.value(config, "verification.supported_modes")))
    raise ValueError(f"unknown check '{name}': choose from {', '.join(CHECKS)}")


def combine(parts: list[dict], config: dict) -> dict:
    """fe.json: per-body spectra, then every check with name, value, tolerance and verdict."""
    bodies = {p["name"]: p for p in parts if "free_free_hz" in p}
    checks = [p for p in parts if "passed" in p]
    return {"all_passed": all(c["passed"] for c in checks), "bodies": bodies, "checks": checks,
            "config_hash": cfgmod.section_hash(config), "versions": versions()}


def summary_markdown(report: dict) -> str:
    """A readable summary of fe.json."""
    lines = ["# Finite-element verification", "",
             f"All checks passed: **{report['all_passed']}** (config {report['config_hash']}, "
             f"git {report['versions'].get('git')})", "", "| check | value | tolerance | verdict |", "|---|---|---|---|"]
    for c in report["checks"]:
        lines.append(f"| {c['name']} | {c['value']:.3g} | {c['tolerance']:.3g} | {'pass' if c['passed'] else 'FAIL'} |")
    lines += ["", "## Frequencies (Hz)", ""]
    for name, b in report["bodies"].items():
        free = ", ".join(f"{f:.0f}" for f in np.asarray(b["free_free_hz"])[6:12])
        sup = ", ".join(f"{f:.0f}" for f in np.asarray(b["supported_hz"])[:6])
        lines.append(f"- **{name}** ({b['model']}, {b['dofs']} DOFs, {b['rigid_modes_found']} rigid modes found "
                     f"free-free): free-free elastic {free} ...; supported {sup} ...")
    return "\n".join(lines) + "\n"


def body_checks(args, config: dict, record, started: float) -> int:
    """The body-file check (--out) and the spectra (--spectra-out) of one body file, read once."""
    if not (args.body_file and args.spectra_out):
        raise ValueError("body needs --body-file and --spectra-out")
    one_read = argparse.Namespace(**{**vars(args), "body_file": v._body_and_attrs(args.body_file)})
    read = time.perf_counter() - started
    for out, name in ((args.out, "body-file"), (args.spectra_out, "spectra")):
        t0 = time.perf_counter()
        result = run_check(name, config, one_read)
        result["wall_time_s"] = time.perf_counter() - t0 + read   # each part with the read
        write_json(out, result, record)
        print(json.dumps({k: result[k] for k in ("name", "value", "tolerance", "passed") if k in result}))
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("check", choices=CHECKS + ("body", "combine"))
    parser.add_argument("parts", nargs="*", help="with combine: the part files")
    parser.add_argument("--body")
    parser.add_argument("--body-file")
    parser.add_argument("--mesh")
    parser.add_argument("--config", default=str(cfgmod.DEFAULT_CONFIG))
    parser.add_argument("--out", required=True)
    parser.add_argument("--summary")
    parser.add_argument("--spectra-out", help="with body: the spectra part")
    parser.add_argument("--levels", type=int, nargs="+", default=None,
                        help="with convergence: the mesh levels, sizes h * mesh.refinement_ratio^level "
                             "(default: rings -1 0 1, the platform 0 1 2), ascending; level 0 (the "
                             "study's mesh) must be one of them; with --body-file (the study's "
                             "body file) level 0's frequencies are read from it, not solved again")
    parser.add_argument("--solid-size", type=float, default=None,
                        help="with solid-ring: the solid's element size [in] (default: a third of the wall)")
    args = parser.parse_args(argv)
    if args.levels is not None and (0 not in args.levels or len(args.levels) < 2
                                    or sorted(set(args.levels)) != args.levels):
        parser.error(f"--levels {' '.join(map(str, args.levels))}: give two or more levels, coarse to "
                     "fine (ascending), 0 among them")
    if args.solid_size is not None and not args.solid_size > 0:
        parser.error(f"--solid-size {args.solid_size:g}: an element size [in] must be positive")
    started = time.perf_counter()
    try:
        config = cfgmod.load_config(args.config)
        record = provenance(cfgmod.section_hash(config))
        if args.check == "combine":
            report = combine([json.load(open(p)) for p in args.parts], config)
            write_json(args.out, report, record)
            if args.summary:
                write_text(args.summary, summary_markdown(report), record)
            print(summary_markdown(report))
            return 0
        if args.check == "body":
            return body_checks(args, config, record, started)
        result = run_check(args.check, config, args)
    except (ValueError, FileNotFoundError, cfgmod.ConfigError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    result["wall_time_s"] = time.perf_counter() - started
    write_json(args.out, result, record)
    print(json.dumps({k: result[k] for k in ("name", "value", "tolerance", "passed") if k in result}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
