"""Load an exported reduced model into python-control and compute a step response.

    .venv/bin/python docs/examples/control_export.py [MODEL.mat]

Without an argument the example makes its own: the reduced model freq-3 on the thesis
scene (``python -m gimbal_reduction.reduction.models``), exported about the scene's initial state with
``python -m gimbal_reduction.solver.dynamics.export`` into a temporary folder.  The .mat holds A, B, C, D
(x = [dy; dy'], u = 4 motor torques [in lbf] + case angular acceleration [rad/s^2],
z = 4 gimbal rates [rad/s] + platform small-angle attitude [rad]; docstring of
gimbal_reduction/solver/dynamics/export.py) and the state, input and output names.

python-control (pinned control==0.10.2 in workflow/envs/requirements.txt) builds the
state-space system; its step response to a unit torque on the outer-gimbal motor over 3 ms
is printed at a few instants.  Without python-control, scipy.signal.StateSpace does the same.
"""
import os
import sys
import tempfile

import numpy as np
import scipy.io

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, ROOT)


def make_model(tmp):
    """Reduce freq-3 on the thesis scene and export it; returns the .mat path."""
    from gimbal_reduction.reduction import models
    from gimbal_reduction.solver.dynamics import export
    bodies = [os.path.join(ROOT, "results", "modes", f"body{b}.h5") for b in models.BODIES]
    model_file = os.path.join(tmp, "freq-3.h5")
    if models.main(["--model", "freq-3", "--scene", "thesis", "--bodies", *bodies,
                    "--out", model_file]) != 0:
        raise SystemExit("could not reduce freq-3 (run the workflow's modes stage first)")
    out = os.path.join(tmp, "freq-3.mat")
    if export.main(["--model-file", model_file, "--scene", "thesis", "--out", out]) != 0:
        raise SystemExit("export failed")
    return out


def step_response(mat_path, duration=3e-3, samples=301):
    """(t, y (outputs, T), names) of the unit step on input 0 (outer-gimbal motor torque)."""
    d = scipy.io.loadmat(mat_path)
    A, B, C, D = d["A"], d["B"], d["C"], d["D"]
    names = [str(s).strip() for s in d["output_names"]]
    t = np.linspace(0.0, duration, samples)
    try:
        import control
        sys_ct = control.ss(A, B, C, D)
        resp = control.step_response(sys_ct, T=t, input=0)
        y = np.asarray(resp.outputs).reshape(C.shape[0], -1)   # (outputs, T) for one input
    except ImportError:                            # scipy.signal fallback
        from scipy import signal
        _, y, _ = signal.lsim(signal.StateSpace(A, B, C, D), np.tile(
            np.eye(B.shape[1])[0], (samples, 1)), t)
        y = y.T
    return t, y, names


MAT = sys.argv[1] if len(sys.argv) > 1 and sys.argv[1].endswith(".mat") else None
with tempfile.TemporaryDirectory() as _tmp:
    T, Y, NAMES = step_response(MAT or make_model(_tmp))
if __name__ == "__main__":
    for k in (0, 100, 200, 300):
        print(f"t = {T[k] * 1e3:.1f} ms: " + ", ".join(f"{n} {v:+.3e}" for n, v in zip(NAMES, Y[:, k])))
