"""Stage 2: shell and solid models of the bodies, the bearing connection and the SLEPc
eigen-solve (``python -m solver.fe.modes``), with checks against independent references
(``python -m solver.fe.verify``)."""
