"""Command line: mesh one body from the config.

``/usr/bin/python3 -m geometry.mesh --body 2 --out results/mesh/body2.msh [--size 0.125]``
"""
from __future__ import annotations

import argparse
import json
import sys

from geometry.gimbal import GeometryError, mesh_body
from workflow import config as cfgmod


def mesh_size(config: dict, params: dict, level: int = 0) -> float:
    """Default mesh size of a body (in), refined ``level`` times by the config's ratio."""
    key = "mesh.ring_size" if params["shape"] == "ring" else "mesh.platform_size"
    return cfgmod.value(config, key) * cfgmod.value(config, "mesh.refinement_ratio") ** level


def mesh_from_config(config: dict, body, path, size: float | None = None) -> dict:
    """Mesh a body with the config's geometry; ``size`` overrides the default mesh size."""
    params = cfgmod.body_parameters(config, body)
    return mesh_body(params, cfgmod.value(config, "eccentric_mass.angle"),
                     size if size is not None else mesh_size(config, params), path,
                     bearing_half_angle_deg=cfgmod.value(config, "bearing_connection.platform_patch_half_angle"),
                     mass_half_angle_deg=cfgmod.value(config, "eccentric_mass.platform_patch_half_angle"))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description="Mesh one gimbal body with gmsh.")
    parser.add_argument("--body", required=True, help="body number 2..5 or name")
    parser.add_argument("--out", required=True, help="output .msh file")
    parser.add_argument("--size", type=float, default=None, help="mesh size in inches (default: config)")
    parser.add_argument("--config", default=str(cfgmod.DEFAULT_CONFIG))
    args = parser.parse_args(argv)
    try:
        config = cfgmod.load_config(args.config)
        meta = mesh_from_config(config, args.body, args.out, args.size)
    except (GeometryError, cfgmod.ConfigError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(json.dumps(meta))
    return 0


if __name__ == "__main__":
    sys.exit(main())
