"""Command line: mesh one body from the config.

``/usr/bin/python3 -m geometry.mesh --body 2 --out results/mesh/body2.msh [--size 0.125] [--meta body2.json]``

The stage reads the config only through ``workflow.config.body_inputs(...)["mesh"]``,
whose hash is the rule's rerun trigger. ``--meta`` writes the mesh's metadata (the
size used, node and cell counts, region angles) for the modal stage.
"""
from __future__ import annotations

import argparse
import json
import sys

from geometry.gimbal import GeometryError, mesh_body
from workflow import config as cfgmod
from workflow.provenance import write_json


def mesh_size(config: dict, params: dict, level: int = 0) -> float:
    """Default mesh size of a body (in), refined ``level`` times by the config's ratio."""
    key = "mesh.ring_size" if params["shape"] == "ring" else "mesh.platform_size"
    return cfgmod.value(config, key) * cfgmod.value(config, "mesh.refinement_ratio") ** level


def mesh_from_config(config: dict, body, path, size: float | None = None) -> dict:
    """Mesh a body with the config's geometry; ``size`` overrides the default mesh size."""
    return mesh_from_inputs(cfgmod.body_inputs(config, body, size)["mesh"], path)


def mesh_from_inputs(inputs: dict, path) -> dict:
    """Mesh a body from its resolved mesh inputs (``workflow.config.body_inputs(...)["mesh"]``)."""
    patches = {"bearing_half_angle_deg": inputs["bearing_half_angle"],
               "mass_half_angle_deg": inputs["mass_half_angle"]} if "bearing_half_angle" in inputs else {}
    return mesh_body(inputs["body"], inputs["mass_angle"], inputs["size"], path, **patches)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description="Mesh one gimbal body with gmsh.")
    parser.add_argument("--body", required=True, help="body number 2..5 or name")
    parser.add_argument("--out", required=True, help="output .msh file")
    parser.add_argument("--size", type=float, default=None, help="mesh size in inches (default: config)")
    parser.add_argument("--meta", default=None, help="write the mesh metadata (size used, nodes, cells) here")
    parser.add_argument("--config", default=str(cfgmod.DEFAULT_CONFIG))
    args = parser.parse_args(argv)
    try:
        config = cfgmod.load_config(args.config)
        meta = mesh_from_config(config, args.body, args.out, args.size)
    except (GeometryError, cfgmod.ConfigError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    if args.meta:
        write_json(args.meta, meta)
    print(json.dumps(meta))
    return 0


if __name__ == "__main__":
    sys.exit(main())
