"""Gmsh geometry: physical groups readable by meshio, bearing data, bad sizes."""
import json

import meshio
import numpy as np
import pytest

from gimbal_reduction.geometry.gimbal import GeometryError, bearing_points
from gimbal_reduction.geometry.mesh import main as mesh_cli, mesh_from_config
from gimbal_reduction.workflow import config as cfgmod


@pytest.mark.parametrize("body", [2, 4, 5])
def test_mesh_has_regions(tmp_path, config, body):
    path = tmp_path / "b.msh"
    meta = mesh_from_config(config, body, path)
    mesh = meshio.read(path)
    names = set(mesh.field_data)
    assert {"input_motor", "input_resolver", "eccentric_mass"} <= names
    if body < 5:
        assert {"shell", "output_motor", "output_resolver", "eccentric_mass_point"} <= names
        # the mass point lies on the mid-surface at 45 deg, mid-width
        params = cfgmod.body_parameters(config, body)
        r = params["diameter"] / 2
        assert np.min(np.linalg.norm(mesh.points - [r / np.sqrt(2), 0, r / np.sqrt(2)], axis=1)) < 1e-9
    else:
        assert "solid" in names
    assert meta["cells"] > 100


def test_bearing_points_follow_motor_sides(config):
    p3 = bearing_points(cfgmod.body_parameters(config, 3))
    np.testing.assert_allclose(p3[0], [3.125, 0, 0])     # input motor at +x
    np.testing.assert_allclose(p3[2], [0, 0, -2.625])    # output motor: body 4's motor at -x4 = -z3
    p4 = bearing_points(cfgmod.body_parameters(config, 4))
    np.testing.assert_allclose(p4[0], [-2.625, 0, 0])    # inner gimbal's motor at -x
    p5 = bearing_points(cfgmod.body_parameters(config, 5))
    assert np.isnan(p5[2:]).all()


@pytest.mark.parametrize("size", [0.0, -0.1, float("nan"), 0.6])
def test_bad_mesh_size(tmp_path, config, size):
    with pytest.raises(GeometryError):
        mesh_from_config(config, 2, tmp_path / "b.msh", size)
    assert not (tmp_path / "b.msh").exists()


def test_mesh_cli_writes_its_metadata(tmp_path):
    """gimbal_reduction.geometry.mesh --meta: the size used (here the --size override), node and cell counts."""
    out, meta = tmp_path / "b.msh", tmp_path / "b.json"
    assert mesh_cli(["--body", "4", "--size", "0.5", "--out", str(out), "--meta", str(meta)]) == 0
    data = json.loads(meta.read_text())
    assert data["mesh_size"] == 0.5 and data["cells"] > 0 and data["nodes"] > 0
    assert set(data["regions_deg"]) >= {"input_motor", "output_motor", "eccentric_mass"}
