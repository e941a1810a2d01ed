"""``python -m gimbal_reduction.solver.simulate``: the simulation CLI under its short, documented name.

The same program as ``python -m gimbal_reduction.solver.dynamics.simulate`` (one scene, one reduced-model
file; the modal exponential integrator by default, ``--integrator rk4|dop853|
generalized-alpha`` to choose another): this module only forwards to it, so that the entry
point the issue and the docs name keeps working after the layout moved the engine into
``gimbal_reduction/solver/dynamics``.

    python -m gimbal_reduction.solver.simulate --scene thesis --model truth
"""

import sys

from gimbal_reduction.solver.dynamics.simulate import main

if __name__ == "__main__":
    sys.exit(main())
