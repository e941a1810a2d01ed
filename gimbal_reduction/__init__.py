"""gimbal_reduction: model reduction and simulation of the elastic nested gimbals of an IMU.

The pipeline's stages, lowest first (imports point only downward):

- ``workflow``: configuration, units, provenance and the code hashes of the Snakemake rules;
- ``geometry``: the Gmsh geometry of the three rings and the stable platform;
- ``solver.fe``: DOLFINx shells and solid, the supported modes (SLEPc);
  ``solver.dynamics``: the flexible multibody equations and their integrators;
- ``reduction``: momentum coefficients, mode rankings, static modes, reduced models;
- ``results``: the study's tables, findings, figures and reports, and the benchmarks;
- ``api``: the few calls a notebook makes; ``commands``: the ``gimbal`` command.
"""
__version__ = "0.2.0"
