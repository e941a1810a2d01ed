"""docs/examples/control_export.py runs: the exported .mat loads into python-control and its
step response equals an independent zero-order-hold propagation (expm) of the same matrices."""
import numpy as np
import pytest
import scipy.io
from scipy.linalg import expm

from tests.dynamics_fixtures import real_bodies_only
from tests.test_examples import run_example


@real_bodies_only
def test_control_example_step_response(tmp_path, monkeypatch):
    pytest.importorskip("control")
    ex = run_example("control_export")
    assert ex.Y.shape == (7, ex.T.size) and np.all(np.isfinite(ex.Y))
    mat = ex.make_model(str(tmp_path))
    t, y, _ = ex.step_response(mat)
    d = scipy.io.loadmat(mat)
    A, B, C = d["A"], d["B"], d["C"]
    n = A.shape[0]
    aug = np.zeros((n + 1, n + 1))
    aug[:n, :n], aug[:n, n] = A, B[:, 0]
    step = expm(aug * (t[1] - t[0]))
    x = np.zeros(n + 1)
    x[n] = 1.0
    ref = np.empty_like(y)
    for k in range(t.size):
        ref[:, k] = C @ x[:n]
        x = step @ x
    scale = np.max(np.abs(ref), axis=1, keepdims=True)
    assert np.max(np.abs(y - ref) / scale) < 1e-6
