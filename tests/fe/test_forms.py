"""Shell and solid models: rigid motions carry no strain energy, masses match the geometry."""
import math

import numpy as np
import pytest
from mpi4py import MPI

from gimbal_reduction.geometry import verification as shapes
from gimbal_reduction.geometry.mesh import mesh_from_config
from gimbal_reduction.solver.bodydata import rigid_modes
from gimbal_reduction.solver.fe import forms as fe, modes
from gimbal_reduction.workflow import config as cfgmod

COMM = MPI.COMM_SELF


def assembled(path, params, config):
    mesh, _, _, _ = fe.load_mesh(path, COMM)
    if params["model"] == "shell":
        V, a_k, a_m = fe.shell_forms(mesh, params, {k: v["value"] for k, v in config["shell"].items()})
    else:
        V, a_k, a_m = fe.solid_forms(mesh, params)
    K, M = fe.assemble_matrix(a_k), fe.assemble_matrix(a_m)
    bs = V.dofmap.index_map_bs
    coords = np.repeat(V.tabulate_dof_coordinates(), bs, axis=0)
    return (modes.gather_matrix(K, COMM), modes.gather_matrix(M, COMM),
            rigid_modes(coords, np.arange(len(coords)) % bs))


@pytest.mark.parametrize("body", [2, 5])
def test_rigid_modes_have_no_strain_energy(tmp_path, config, body):
    path = tmp_path / "b.msh"
    mesh_from_config(config, body, path)
    params = cfgmod.body_parameters(config, body)
    K, M, X = assembled(path, params, config)
    energy = np.abs(X.T @ (K @ X))
    scale = abs(K.diagonal()).max() * 1e-12 * len(K.diagonal())
    assert energy.max() < scale, energy.max()


def test_ring_mass_matches_geometry(tmp_path, config):
    """Structural mass and moments of inertia of a bare band against closed forms."""
    params = cfgmod.body_parameters(config, 2)
    radius, t, b, rho = params["diameter"] / 2, params["thickness"], params["width"], params["density"]
    shapes.band_surface(radius, b, 0.125, tmp_path / "band.msh")
    K, M, X = assembled(tmp_path / "band.msh", params, config)
    rigid_mass = X.T @ (M @ X)
    mass = rho * 2 * math.pi * radius * b * t
    # faceted mid-surface: area is short by ~(h/R)^2/6 relative
    assert rigid_mass[0, 0] == pytest.approx(mass, rel=2e-4)
    # thin-walled band about its axis y: m (R^2 + t^2/4 ... ) ~ m R^2 (1 + t^2/(12 R^2)) with rotary inertia
    assert rigid_mass[4, 4] == pytest.approx(mass * radius**2 * (1 + t**2 / (12 * radius**2)), rel=1e-3)
    # about a diameter (x): m R^2/2 + m b^2/12 (+ rotary inertia of the wall)
    expected = mass * (radius**2 / 2 + b**2 / 12 + t**2 / 24)
    assert rigid_mass[3, 3] == pytest.approx(expected, rel=1e-3)
