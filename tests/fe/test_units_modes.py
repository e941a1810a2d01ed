"""Issue 15, end to end: a config in SI units gives body 4 the frequencies of the inch-lbf one."""
import copy
import math

import numpy as np
import yaml

from gimbal_reduction.geometry.mesh import mesh_from_config
from gimbal_reduction.solver.fe import modes
from gimbal_reduction.workflow import config as cfgmod
from gimbal_reduction.workflow.config import ROOT

LBF, INCH = 0.45359237 * 9.80665, 0.0254     # N, m (exact)


def _frequencies(config, tmp_path, name):
    mesh = tmp_path / f"{name}.msh"
    mesh_from_config(config, 4, mesh, 0.5)
    payload = modes.compute_body(4, config, mesh, 4, log=lambda *a, **k: None, mesh_size=0.5)
    return np.asarray(payload["frequencies_hz"])


def test_si_config_gives_the_same_frequencies(tmp_path):
    raw = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    si = copy.deepcopy(raw)
    m = si["material"]
    m["density"] = {"value": m["density"]["value"] * LBF / INCH ** 4, "unit": "kg/m^3", "source": "SI"}
    m["youngs_modulus"] = {"value": m["youngs_modulus"]["value"] * LBF / INCH ** 2 / 1e9, "unit": "GPa",
                           "source": "SI"}
    ring = si["bodies"]["inner_gimbal"]
    ring["thickness"] = {"value": ring["thickness"]["value"] * 25.4, "unit": "mm", "source": "SI"}
    ring["diameter"] = {"value": ring["diameter"]["value"] * 25.4, "unit": "mm", "source": "SI"}
    si["eccentric_mass"]["angle"] = {"value": math.radians(45.0), "unit": "rad", "source": "SI"}
    inch = _frequencies(cfgmod.validate(raw), tmp_path, "inch")
    metric = _frequencies(cfgmod.validate(si), tmp_path, "si")
    assert inch[0] > 100                              # not the 0.985 Hz of an unconverted density
    np.testing.assert_allclose(metric, inch, rtol=1e-8)
