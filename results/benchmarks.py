"""Benchmark summaries written by the workflow.

``/usr/bin/python3 -m results.benchmarks modes results/modes/body*.h5 --out results/benchmarks/modes.json``
"""
from __future__ import annotations

import argparse
import json
import sys

from workflow.provenance import read_h5_checked, versions, write_json


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


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("kind", choices=["modes"])
    parser.add_argument("files", nargs="+")
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    try:
        data = modes_benchmark(args.files)
    except (ValueError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    write_json(args.out, data)
    print(json.dumps({k: v["wall_time_s"] for k, v in data["bodies"].items()}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
