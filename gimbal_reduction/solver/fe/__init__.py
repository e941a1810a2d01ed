"""Stage 2: shell and solid models of the bodies, the bearing connection and the SLEPc
eigen-solve (``python -m gimbal_reduction.solver.fe.modes``), with checks against independent references
(``python -m gimbal_reduction.solver.fe.verify``)."""
