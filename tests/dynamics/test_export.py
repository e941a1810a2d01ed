"""The exported linear state space against the nonlinear simulation (small motion from rest).

A reduced model (freq-3 on the real bodies: 12 elastic coordinates) is driven from the
thesis's initial angles, at rest, by a constant small torque on every motor and a constant
small case acceleration about X for 3 ms.  Its exported (A, B, C) step response (exact
zero-order-hold propagation, expm) must match the simulation's gimbal rates and platform
attitude change to RTOL of each output's peak."""
import json
import os

import numpy as np
import pytest
import scipy.io
from scipy.linalg import expm

from gimbal_reduction.reduction import models
from gimbal_reduction.solver.dynamics import export, simulate
from gimbal_reduction.solver.dynamics.simfile import read_sim
from tests.dynamics_fixtures import REAL_MODES, real_bodies_only
from gimbal_reduction.workflow.provenance import read_provenance

RTOL = 1e-4          # of each output's peak over the run (measured: <= 1.4e-5)
TORQUE = (0.02, -0.01, 0.01, 0.005)      # in lbf
ALPHA = 0.2                               # rad/s^2, case acceleration about X (constant)

SCENE = f"""name: small_step
description: "small constant motor torques and case acceleration from rest (export check)"
duration: {{value: 0.003, unit: s, source: test}}
output_interval: {{value: 1.0e-5, unit: s, source: test}}
initial_angles: {{value: [0.0, -1.5707963267948966, 0.0, 0.0], unit: rad, source: thesis}}
initial_rates: {{value: [0.0, 0.0, 0.0, 0.0], unit: rad/s, source: test}}
motor_torques: {{value: {list(TORQUE)}, unit: in*lbf, source: test}}
case_motion:
  angular_acceleration_amplitude: {{value: [{ALPHA}, 0.0, 0.0], unit: rad/s^2, source: test}}
  angular_acceleration_frequency: {{value: [0.0, 0.0, 0.0], unit: Hz, source: test}}
  angular_acceleration_phase: {{value: [0.0, 0.0, 0.0], unit: rad, source: test}}
  initial_angular_velocity: {{value: [0.0, 0.0, 0.0], unit: rad/s, source: test}}
damping_ratio: {{value: 0.0, unit: "1", source: test}}
"""


def _vee(S):
    return np.array([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]]) / 2


@real_bodies_only
def test_step_response_matches_simulation(tmp_path):
    scene = tmp_path / "small_step.yaml"
    scene.write_text(SCENE)
    model_file, sim_file, out = (str(tmp_path / n) for n in ("model.h5", "sim.h5", "ss.mat"))
    bodies = [os.path.join(REAL_MODES, f"body{b}.h5") for b in models.BODIES]
    assert models.main(["--model", "freq-3", "--scene", str(scene), "--bodies", *bodies,
                        "--out", model_file]) == 0
    assert simulate.main(["--scene", str(scene), "--model-file", model_file, "--out", sim_file]) == 0
    assert export.main(["--model-file", model_file, "--scene", str(scene), "--out", out]) == 0
    ss = scipy.io.loadmat(out)
    npz = np.load(str(tmp_path / "ss.npz"))
    A, B, C = ss["A"], ss["B"], ss["C"]
    assert np.array_equal(A, npz["A"]) and A.shape == (2 * (4 + 12), 2 * (4 + 12))
    # provenance (issue 16): the model file's config hash, the git revision, the versions
    rec = json.loads(str(npz["provenance"]))
    assert rec["config_hash"] == read_provenance(model_file)["config_hash"] and rec["git"]
    assert read_provenance(out) == read_provenance(str(tmp_path / "ss.npz")) == rec
    assert B.shape == (A.shape[0], 7) and C.shape == (7, A.shape[0])
    sim = read_sim(sim_file)
    t = sim["t"]
    u = np.array([*TORQUE, ALPHA, 0.0, 0.0])
    n = A.shape[0]
    aug = np.zeros((n + 1, n + 1))
    aug[:n, :n], aug[:n, n] = A, B @ u
    step = expm(aug * (t[1] - t[0]))
    x = np.zeros(n + 1)
    x[n] = 1.0
    z = np.empty((t.size, C.shape[0]))
    for k in range(t.size):
        z[k] = C @ x[:n]
        x = step @ x
    R = sim["platform_attitude"]
    phi = np.array([_vee(R[0].T @ Rk) for Rk in R])
    measured = np.hstack([sim["gamma_dot"], phi])
    peak = np.max(np.abs(measured), axis=0)
    assert np.all(peak > 0)
    mismatch = np.max(np.abs(z - measured), axis=0) / peak
    print("relative mismatch per output:", dict(zip(export.OUTPUT_NAMES, mismatch.round(8))))
    assert np.all(mismatch < RTOL), mismatch
