"""Gmsh geometry of the gimbal rings (shell mid-surfaces) and the platform (solid).

Every body lives in its local frame: drive axis (outer bearings) on x, inner
bearings on z, ring axis y. Angles are measured in the x-z plane from +x
towards +z, so a point at angle ``a`` on a circle of radius ``r`` is
``(r cos a, y, r sin a)``.

Physical groups (names are the contract with the solver):

* ring (a cylindrical band, 2D mid-surface in 3D): surface ``shell``; curves
  (the band's cross-section lines) ``input_motor``, ``input_resolver``,
  ``output_motor``, ``output_resolver``, ``eccentric_mass``; point
  ``eccentric_mass_point`` (mid-width of the 45 degree line);
* platform (annular plate, 3D solid): volume ``solid``; rim face patches
  ``input_motor``, ``input_resolver``, ``eccentric_mass``.

The bearing regions are where the bearing points are joined to the body by a
rigid-fit connection (see ``gimbal_reduction.solver.fe.bearings``); meshing them as curves/faces
puts mesh nodes exactly on them.
"""
from __future__ import annotations

import math
from pathlib import Path

import gmsh
import numpy as np

RING_REGIONS = ("input_motor", "input_resolver", "output_motor", "output_resolver", "eccentric_mass")
PLATFORM_REGIONS = ("input_motor", "input_resolver", "eccentric_mass")


class GeometryError(ValueError):
    """Invalid geometry or mesh input; one-line message."""


def bearing_angles(motor_side: int, output_motor_side: int | None) -> dict[str, float]:
    """Angles (deg) of the bearing regions: motors/resolvers on +-x, outputs on +-z."""
    angles = {"input_motor": 0.0 if motor_side > 0 else 180.0}
    angles["input_resolver"] = (angles["input_motor"] + 180.0) % 360.0
    if output_motor_side is not None:
        angles["output_motor"] = 90.0 if output_motor_side > 0 else 270.0
        angles["output_resolver"] = (angles["output_motor"] + 180.0) % 360.0
    return angles


def bearing_points(params: dict) -> np.ndarray:
    """(4, 3) bearing points: input motor, input resolver, output motor, output resolver.

    Outer bearings at +-outer_bearing_distance/2 on x, inner ones on z; the
    platform has no inner bearings (rows 2 and 3 are NaN).
    """
    points = np.full((4, 3), np.nan)
    a_out = params["outer_bearing_distance"] / 2
    points[0] = (params["motor_side"] * a_out, 0.0, 0.0)
    points[1] = (-params["motor_side"] * a_out, 0.0, 0.0)
    if "inner_bearing_distance" in params:
        a_in = params["inner_bearing_distance"] / 2
        s = params["output_motor_side"]
        points[2] = (0.0, 0.0, s * a_in)
        points[3] = (0.0, 0.0, -s * a_in)
    return points


def eccentric_mass_point(params: dict, mass_angle_deg: float) -> np.ndarray:
    """(3,) position of the eccentric mass: ring mid-surface or platform rim, mid-width."""
    a = math.radians(mass_angle_deg)
    r = params["diameter"] / 2
    return np.array([r * math.cos(a), 0.0, r * math.sin(a)])


def _check_size(size: float, smallest_dimension: float, name: str) -> None:
    if not (size > 0 and math.isfinite(size)):
        raise GeometryError(f"mesh size for {name} must be positive and finite, got {size!r}")
    if size > smallest_dimension:
        raise GeometryError(
            f"mesh size {size:g} in for {name} exceeds its smallest dimension {smallest_dimension:g} in: "
            "the mesh would be degenerate")


def physical_group(dim: int, tags: list[int], name: str) -> None:
    """A named physical group (gmsh 4.8 API: group first, then its name)."""
    tag = gmsh.model.addPhysicalGroup(dim, list(tags))
    gmsh.model.setPhysicalName(dim, tag, name)


def _sorted_angles(angles: list[float]) -> list[float]:
    """Unique angles in [0, 360), with extra cuts so that no arc spans 180 deg or more."""
    cuts = sorted(set(round(a % 360.0, 9) for a in angles) | {0.0, 90.0, 180.0, 270.0})
    return cuts


def build_ring(params: dict, mass_angle_deg: float, size: float, coarse: bool = False) -> dict[str, float]:
    """Build the band's mid-surface in the current gmsh model; return region angles (deg).

    The band of radius R = diameter/2 spans y in [-width/2, width/2]. It is cut
    along straight cross-section lines at the bearing and mass angles, so that
    each of these lines is a mesh curve.  The size may not exceed the width, unless
    ``coarse`` (a mesh for checks that hold on any mesh, such as the discrete Hughes
    identities): then up to the radius, the two half-width strips staying one element
    high (the mesh stops coarsening at the cut lines: body 4 has 192 cells from 0.65 in up).
    """
    radius, half_width = params["diameter"] / 2, params["width"] / 2
    _check_size(size, radius if coarse else min(params["width"], radius), params["name"])
    regions = bearing_angles(params["motor_side"], params["output_motor_side"])
    regions["eccentric_mass"] = float(mass_angle_deg)
    cuts = _sorted_angles(list(regions.values()))

    # the band is built as two half-width strips, so the mid-width point of every
    # cross-section line (the eccentric mass point among them) is a mesh vertex
    geo = gmsh.model.geo
    levels = (-half_width, 0.0, half_width)
    centre = {y: geo.addPoint(0, y, 0) for y in levels}
    rim = {}  # (angle, y) -> point tag
    for a in cuts:
        c, s = math.cos(math.radians(a)), math.sin(math.radians(a))
        for y in levels:
            rim[a, y] = geo.addPoint(radius * c, y, radius * s)
    lines = {a: [geo.addLine(rim[a, y0], rim[a, y1]) for y0, y1 in zip(levels, levels[1:])] for a in cuts}
    arcs = {(a0, y): geo.addCircleArc(rim[a0, y], centre[y], rim[a1, y])
            for a0, a1 in zip(cuts, cuts[1:] + [cuts[0]]) for y in levels}
    surfaces = []
    for a0, a1 in zip(cuts, cuts[1:] + [cuts[0]]):
        for half, (y0, y1) in enumerate(zip(levels, levels[1:])):
            loop = geo.addCurveLoop([arcs[a0, y0], lines[a1][half], -arcs[a0, y1], -lines[a0][half]])
            surfaces.append(geo.addSurfaceFilling([loop]))
    geo.synchronize()
    physical_group(2, surfaces, "shell")
    for name, a in regions.items():
        physical_group(1, lines[round(a % 360.0, 9)], name)
    mass_a = round(regions["eccentric_mass"] % 360.0, 9)
    physical_group(0, [rim[mass_a, 0.0]], "eccentric_mass_point")
    return regions


def build_platform(params: dict, mass_angle_deg: float, size: float,
                   bearing_half_angle_deg: float, mass_half_angle_deg: float) -> dict[str, float]:
    """Build the annular plate as a solid in the current gmsh model; return region angles.

    The annulus (outer radius diameter/2, hole radius hole_diameter/2) lies in
    the x-z plane and is extruded along y over the thickness, centred on y=0.
    Its rim is cut into face patches: each bearing region spans +-bearing_half_angle
    around the bearing angle, the mass region +-mass_half_angle around 45 deg.
    """
    r_out, r_in, thickness = params["diameter"] / 2, params["hole_diameter"] / 2, params["thickness"]
    _check_size(size, min(thickness, r_out - r_in), params["name"])
    regions = bearing_angles(params["motor_side"], None)
    regions["eccentric_mass"] = float(mass_angle_deg)
    half = {name: bearing_half_angle_deg for name in regions}
    half["eccentric_mass"] = mass_half_angle_deg
    edges = []
    for name, a in regions.items():
        edges += [a - half[name], a + half[name]]
    cuts = _sorted_angles(edges)
    geo = gmsh.model.geo
    y0 = -thickness / 2
    centre = geo.addPoint(0, y0, 0)

    def circle(radius, angles):
        pts = [geo.addPoint(radius * math.cos(math.radians(a)), y0, radius * math.sin(math.radians(a)))
               for a in angles]
        return [geo.addCircleArc(p, centre, q) for p, q in zip(pts, pts[1:] + pts[:1])]

    outer_arcs = circle(r_out, cuts)
    inner_arcs = circle(r_in, [0.0, 90.0, 180.0, 270.0])
    face = geo.addPlaneSurface([geo.addCurveLoop(outer_arcs), geo.addCurveLoop(inner_arcs)])
    extruded = geo.extrude([(2, face)], 0, thickness, 0)
    geo.synchronize()
    volume = [tag for dim, tag in extruded if dim == 3]
    physical_group(3, volume, "solid")
    # extrude returns [top, volume, lateral faces in the order of the face's boundary curves]
    laterals = [tag for dim, tag in extruded if dim == 2][1:]
    rim_faces = laterals[: len(outer_arcs)]
    mids = [(a0 + ((a1 - a0) % 360.0) / 2) % 360.0 for a0, a1 in zip(cuts, cuts[1:] + cuts[:1])]
    for name, a in regions.items():
        patch = [f for f, m in zip(rim_faces, mids)
                 if abs((m - a + 180.0) % 360.0 - 180.0) < half[name]]
        physical_group(2, patch, name)
    return regions


def mesh_body(params: dict, mass_angle_deg: float, size: float, path: str | Path | None = None,
              bearing_half_angle_deg: float = 11.25, mass_half_angle_deg: float = 11.25,
              keep_model: bool = False, coarse: bool = False) -> dict:
    """Mesh one body with gmsh; write ``path`` (``.msh``, format 4.1) if given.

    Returns metadata: region angles, node/element counts, mesh size. With
    ``keep_model`` the gmsh session stays open (for ``dolfinx.io.gmsh.model_to_mesh``);
    the caller must then call ``gmsh.finalize()``. ``coarse``: a ring's size may exceed
    its width (``build_ring``).
    """
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add(params["name"])
    if params["shape"] == "ring":
        regions = build_ring(params, mass_angle_deg, size, coarse)
        dim = 2
    else:
        regions = build_platform(params, mass_angle_deg, size, bearing_half_angle_deg, mass_half_angle_deg)
        dim = 3
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.0)
    gmsh.option.setNumber("Mesh.Algorithm", 6)  # frontal-Delaunay triangles: unstructured
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.model.mesh.generate(dim)
    if dim == 3:
        # curved (second-order) tetrahedra: affine ones facet the rim and the hole, an
        # O(h^2) geometric error that dominates the P2 solid's convergence
        gmsh.model.mesh.setOrder(2)
    gmsh.model.mesh.removeDuplicateNodes()
    gmsh.model.mesh.renumberNodes()
    node_tags, _, _ = gmsh.model.mesh.getNodes()
    types, elems, _ = gmsh.model.mesh.getElements(dim)
    n_cells = int(sum(len(e) for e in elems))
    if n_cells == 0:
        gmsh.finalize()
        raise GeometryError(f"mesh of {params['name']} with size {size:g} in is empty")
    meta = {"regions_deg": regions, "nodes": int(len(node_tags)), "cells": n_cells,
            "mesh_size": float(size), "dim": dim}
    if path is not None:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        tmp = path.with_name(path.stem + ".part.msh")
        gmsh.write(str(tmp))
        tmp.replace(path)
    if not keep_model:
        gmsh.finalize()
    return meta
