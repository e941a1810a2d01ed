"""Benchmark summaries written by the workflow.

``/usr/bin/python3 -m gimbal_reduction.results.bench.summary modes results/modes/body*.h5 --out results/benchmarks/modes.json``
``/usr/bin/python3 -m gimbal_reduction.results.bench.summary workflow results/benchmarks/rules --out results/benchmarks/workflow.json``
(the share of each stage in a run, from every rule's ``benchmark:`` record)
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from gimbal_reduction.workflow.provenance import provenance, read_h5_checked, versions, write_json


def modes_benchmark(body_files: list[str]) -> dict:
    """Per-body DOFs, cells, assembly and eigen-solve times (s) read from the body files."""
    bodies = {}
    for path in body_files:
        with read_h5_checked(path, ("modes",)) as h5:
            timings = json.loads(h5.attrs["timings"])
            bodies[str(h5.attrs["name"])] = {
                "body": int(h5.attrs["body"]), "model": str(h5.attrs["model"]), "dofs": int(h5["modes"].shape[0]),
                "modes": int(h5["modes"].shape[1]), "cells": int(h5.attrs["cells"]),
                "mesh_size_in": float(h5.attrs["mesh_size"]), **timings,
                "wall_time_s": float(h5.attrs["wall_time_s"]), "mpi_ranks": int(h5.attrs["mpi_ranks"])}
    total = sum(b["wall_time_s"] for b in bodies.values())
    return {"bodies": bodies, "total_wall_time_s": total, "versions": versions()}


STAGES = (("geometry", ("mesh_body", "coarse_mesh")), ("modes", ("modes_body", "mode_shapes", "modes_benchmark")),
          ("fe verification", ("verify_",)), ("reduction", ("reduction", "coarse_body")),
          ("simulation", ("simulate", "sim/")), ("dynamics verification", ("dynamics_verification",)),
          ("results", ("error_tables", "findings", "study_figures", "report")))


def stage_of(rule_file: str) -> str:
    """Stage of a benchmark record, from its rule name (the file name under results/benchmarks/rules)."""
    for stage, prefixes in STAGES:
        if any(rule_file.startswith(p) for p in prefixes):
            return stage
    return "other"


def workflow_benchmark(rule_dir: str) -> dict:
    """Wall time (s) per stage summed over the rules' ``benchmark:`` records, and each stage's share."""
    totals: dict[str, float] = {}
    for tsv in Path(rule_dir).rglob("*.tsv"):
        lines = tsv.read_text().splitlines()
        if len(lines) < 2:
            continue
        seconds = float(lines[1].split("\t")[0])
        relative = tsv.relative_to(rule_dir).as_posix()
        totals[stage_of(relative)] = totals.get(stage_of(relative), 0.0) + seconds
    busy = sum(totals.values())
    return {"stage_seconds": totals, "stage_share": {k: v / busy for k, v in totals.items()},
            "job_seconds_total": busy, "versions": versions()}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("kind", choices=["modes", "workflow"])
    parser.add_argument("files", nargs="+", help="modes: body files; workflow: the rules' benchmark folder")
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    try:
        data = modes_benchmark(args.files) if args.kind == "modes" else workflow_benchmark(args.files[0])
    except (ValueError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    write_json(args.out, data, provenance(sources=args.files if args.kind == "modes" else ()))
    print(json.dumps(data.get("stage_share") or {k: v["wall_time_s"] for k, v in data["bodies"].items()}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
