"""Stage 4: the flexible multibody equations of the chain case -> 2 -> 3 -> 4 -> 5
(``multibody`` in NumPy, ``compiled`` + ``kernels`` in Numba), its integrators, scenes, and
the reduced-model and simulation files (``chainfile``, ``simfile``);
``python -m gimbal_reduction.solver.dynamics.simulate`` runs one scene with one reduced-model file."""
