"""Shared fixtures: the validated project config and a cached small body file."""
from __future__ import annotations

import copy

import pytest

from gimbal_reduction.workflow import config as cfgmod


@pytest.fixture(scope="session")
def config() -> dict:
    return cfgmod.load_config()


@pytest.fixture
def config_copy(config) -> dict:
    return copy.deepcopy(config)


@pytest.fixture(scope="session")
def inner_gimbal_file(tmp_path_factory, config):
    """Body file of the inner gimbal (default mesh, 20 modes), written through the stage's own code."""
    from gimbal_reduction.geometry.mesh import mesh_from_config
    from gimbal_reduction.solver.fe import modes

    tmp = tmp_path_factory.mktemp("body4")
    mesh = tmp / "body4.msh"
    mesh_from_config(config, 4, mesh)
    payload = modes.compute_body(4, config, mesh, 20, log=lambda *a, **k: None)
    path = tmp / "body4.h5"
    modes.write_body_file(path, payload, "test", 0.0)
    return path, mesh
