"""The two engines of the pipeline and the contract between them.

* ``gimbal_reduction.solver.fe``: stage 2, the finite-element modes of every body (DOLFINx, PETSc, SLEPc);
* ``gimbal_reduction.solver.dynamics``: stage 4, the flexible multibody equations of the gimbal chain and
  their integrators (NumPy, Numba);
* ``gimbal_reduction.solver.bodydata``: the body file that stage 2 writes and everything after it reads
  (docs/body-data.md).

The engines never import each other, nor ``reduction`` or ``results`` (tests/test_layers.py).
"""
