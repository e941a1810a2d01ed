"""Gmsh shapes used only to verify the finite-element models.

* :func:`square_plate` - the NAFEMS FV12 free thin square plate (mid-surface);
* :func:`band_surface` - a bare cylindrical band (ring mid-surface, no regions);
* :func:`band_solid` - the same ring as a 3D solid (rectangular cross-section);
* :func:`annulus_surface` - the platform's mid-surface, for the shell-vs-solid comparison.

Each writes a first-order ``.msh`` file readable by ``gimbal_reduction.solver.fe.forms.load_mesh``.
"""
from __future__ import annotations

import contextlib
from pathlib import Path

import gmsh

from gimbal_reduction.geometry.gimbal import physical_group


def _mesh_and_write(dim: int, size: float, path: str | Path, algorithm: int = 6) -> None:
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.0)
    gmsh.option.setNumber("Mesh.Algorithm", algorithm)
    gmsh.model.mesh.generate(dim)
    gmsh.model.mesh.removeDuplicateNodes()
    gmsh.model.mesh.renumberNodes()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(str(path))


@contextlib.contextmanager
def _gmsh_model(name: str):
    """A fresh gmsh model for one shape, finalised whatever happens."""
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add(name)
    try:
        yield gmsh.model.occ
    finally:
        gmsh.finalize()


def square_plate(side: float, size: float, path: str | Path) -> None:
    """Square plate [0, side]^2 in the x-y plane, unstructured triangles."""
    with _gmsh_model("plate") as occ:
        occ.addRectangle(0, 0, 0, side, side)
        occ.synchronize()
        physical_group(2, [s for _, s in gmsh.model.getEntities(2)], "shell")
        _mesh_and_write(2, size, path)


def band_surface(radius: float, width: float, size: float, path: str | Path) -> None:
    """Cylindrical band of mid-radius ``radius`` about y, y in [-width/2, width/2]."""
    with _gmsh_model("band") as occ:
        occ.addCylinder(0, -width / 2, 0, 0, width, 0, radius)
        occ.synchronize()
        # keep only the lateral surface of the cylinder
        lateral = [s for _, s in gmsh.model.getEntities(2)
                   if abs(gmsh.model.getBoundingBox(2, s)[4] - gmsh.model.getBoundingBox(2, s)[1] - width) < 1e-4 * width]
        physical_group(2, lateral, "shell")
        _mesh_and_write(2, size, path)


def band_solid(radius: float, thickness: float, width: float, size: float, path: str | Path) -> None:
    """Solid ring: mid-radius ``radius``, radial ``thickness``, axial ``width`` (about y)."""
    with _gmsh_model("band_solid") as occ:
        outer = occ.addCylinder(0, -width / 2, 0, 0, width, 0, radius + thickness / 2)
        inner = occ.addCylinder(0, -width / 2, 0, 0, width, 0, radius - thickness / 2)
        occ.cut([(3, outer)], [(3, inner)])
        occ.synchronize()
        physical_group(3, [v for _, v in gmsh.model.getEntities(3)], "solid")
        _mesh_and_write(3, size, path, algorithm=6)


def annulus_surface(outer_radius: float, inner_radius: float, size: float, path: str | Path) -> None:
    """Flat annulus in the x-z plane (normal y): the platform's mid-surface."""
    with _gmsh_model("annulus") as occ:
        outer = occ.addDisk(0, 0, 0, outer_radius, outer_radius)
        inner = occ.addDisk(0, 0, 0, inner_radius, inner_radius)
        occ.cut([(2, outer)], [(2, inner)])
        occ.rotate(occ.getEntities(2), 0, 0, 0, 1, 0, 0, -1.5707963267948966)  # x-y plane -> x-z plane
        occ.synchronize()
        physical_group(2, [s for _, s in gmsh.model.getEntities(2)], "shell")
        _mesh_and_write(2, size, path)
