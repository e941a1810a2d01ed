"""Command line: mesh one body from the config.

``gimbal mesh --body 2 --out results/mesh/body2.msh [--size 0.125] [--meta body2.json]``

The stage reads the config only through ``gimbal_reduction.workflow.config.body_inputs(...)["mesh"]``,
whose hash is the rule's rerun trigger. ``--meta`` writes the mesh's metadata (the
size used, node and cell counts, region angles) for the modal stage.
"""
from __future__ import annotations

import json
import math
import sys

from gimbal_reduction.geometry.gimbal import GeometryError, mesh_body
from gimbal_reduction.workflow import cli
from gimbal_reduction.workflow import config as cfgmod
from gimbal_reduction.workflow.provenance import provenance, write_json


# Size guard (before gmsh and before the modal stage's assembly): the DOFs of a body's
# model estimated from its mesh size, measured on the default meshes (bodies 2-4: P2 shell,
# 6 DOFs per node, 9504 / 8316 / 6588 DOFs at 0.25 in: 55-58 DOFs per (area / h^2); the
# platform: P3 solid, 16002 DOFs at 0.5 in: 265 per (volume / h^3)), and the memory of the
# modal stage per DOF (matrices, the supported basis and MUMPS's Cholesky factor; the issue's
# 2.1 M-DOF ring exhausted memory).  An explicit --max-dofs lifts the limit.
DOFS_PER_AREA = 58.0
DOFS_PER_VOLUME = 270.0
BYTES_PER_DOF = {"ring": 20e3, "plate": 60e3}
MAX_DOFS = 400_000


def estimated_dofs(inputs: dict) -> tuple[int, float]:
    """(DOFs, bytes) of the modal stage on a body meshed from ``inputs`` (the resolved mesh
    inputs, ``gimbal_reduction.workflow.config.body_inputs(...)["mesh"]``)."""
    body, h = inputs["body"], float(inputs["size"])
    if body["shape"] == "ring":
        area = math.pi * body["diameter"] * body["width"]
        dofs = DOFS_PER_AREA * area / h ** 2
    else:
        volume = math.pi / 4 * (body["diameter"] ** 2 - body["hole_diameter"] ** 2) * body["thickness"]
        dofs = DOFS_PER_VOLUME * volume / h ** 3
    return int(dofs), dofs * BYTES_PER_DOF["ring" if body["shape"] == "ring" else "plate"]


def check_size(inputs: dict, max_dofs: int = MAX_DOFS, what: str = "mesh.ring_size") -> int:
    """GeometryError (one line naming the body, the size and the option that lifts it) if the
    mesh size is not a positive finite number or the model would exceed ``max_dofs`` DOFs."""
    h = inputs["size"]
    name = inputs["body"].get("name", "body")
    if not (isinstance(h, (int, float)) and math.isfinite(h) and h > 0):
        raise GeometryError(f"{name}: mesh size must be a positive finite number of inches, got {h!r} "
                            f"({what})")
    dofs, memory = estimated_dofs(inputs)
    if dofs > max_dofs:
        raise GeometryError(f"{name}: mesh size {h:g} in ({what}) gives ~{dofs:,} DOFs and ~{memory / 2**30:.3g} "
                            f"GiB for the modal stage, above the limit {max_dofs:,} DOFs (--max-dofs N "
                            f"lifts it; or a larger size)")
    return dofs


def mesh_size(config: dict, params: dict, level: int = 0) -> float:
    """Default mesh size of a body (in), refined ``level`` times by the config's ratio."""
    key = "mesh.ring_size" if params["shape"] == "ring" else "mesh.platform_size"
    return cfgmod.value(config, key) * cfgmod.value(config, "mesh.refinement_ratio") ** level


def mesh_from_config(config: dict, body, path, size: float | None = None, coarse: bool = False) -> dict:
    """Mesh a body with the config's geometry; ``size`` overrides the default mesh size
    (``coarse``: a ring's size may exceed its width, ``gimbal_reduction.geometry.gimbal.build_ring``)."""
    return mesh_from_inputs(cfgmod.body_inputs(config, body, size)["mesh"], path, coarse)


def mesh_from_inputs(inputs: dict, path, coarse: bool = False) -> dict:
    """Mesh a body from its resolved mesh inputs (``gimbal_reduction.workflow.config.body_inputs(...)["mesh"]``)."""
    patches = {"bearing_half_angle_deg": inputs["bearing_half_angle"],
               "mass_half_angle_deg": inputs["mass_half_angle"]} if "bearing_half_angle" in inputs else {}
    return mesh_body(inputs["body"], inputs["mass_angle"], inputs["size"], path, coarse=coarse, **patches)


def main(argv=None) -> int:
    parser = cli.OneLineParser(prog="gimbal_reduction.geometry.mesh", description="Mesh one gimbal body with gmsh.")
    parser.add_argument("--body", required=True, help="body number 2..5 or name")
    parser.add_argument("--out", required=True, help="output .msh file")
    parser.add_argument("--size", type=cli.positive_number("--size"), default=None,
                        help="mesh size in inches (default: config)")
    parser.add_argument("--meta", default=None, help="write the mesh metadata (size used, nodes, cells) here")
    parser.add_argument("--coarse", action="store_true",
                        help="a ring's size may exceed its width (up to its radius): a mesh for checks "
                             "that hold on any mesh (the discrete Hughes identities), not for results")
    parser.add_argument("--config", default=str(cfgmod.DEFAULT_CONFIG))
    parser.add_argument("--max-dofs", type=cli.positive_int("--max-dofs"), default=MAX_DOFS,
                        help=f"refuse a mesh whose model would exceed this many DOFs (default {MAX_DOFS:,})")
    try:
        args = parser.parse_args(cli.values_joined(sys.argv[1:] if argv is None else argv, parser))
    except SystemExit as exc:
        return exc.code
    try:
        config = cfgmod.load_config(args.config)
        inputs = cfgmod.body_inputs(config, args.body, args.size)["mesh"]
        key = "--size" if args.size is not None else \
            ("mesh.ring_size" if inputs["body"]["shape"] == "ring" else "mesh.platform_size")
        check_size(inputs, args.max_dofs, key)
        cli.check_writable(args.out)
        if args.meta:
            cli.check_writable(args.meta)
        meta = mesh_from_inputs(inputs, args.out, args.coarse)
        if args.meta:   # the mesh's sidecar: its provenance too (config hash: the mesh's inputs)
            write_json(args.meta, meta, provenance(cfgmod.inputs_hash(inputs)))
    except (GeometryError, cfgmod.ConfigError, ValueError) as exc:
        print(f"error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 1
    except OSError as exc:
        print(f"error: {cli.write_failure(args.meta or args.out, exc)}", file=sys.stderr)
        return 1
    print(json.dumps(meta))
    return 0


if __name__ == "__main__":
    sys.exit(main())
