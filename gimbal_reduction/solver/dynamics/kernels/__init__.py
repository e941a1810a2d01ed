"""Compiled kernels of the chain's equations (Numba), by layer.

``linalg``: 3-vectors (as tuples) and 6x6 products; ``modal``: the O(D) passes over a
body's modal rows and the O(D^2) Coriolis passes; ``recursion``: kinematics, the
Newton-Euler backward pass, the articulated-body solve, energies and the case twist;
``rk4``: the compiled RK4 loops.  They are the equations of ``gimbal_reduction.solver.dynamics.multibody``
(docs/dynamics.md Sections 3 and 8) written for speed; ``gimbal_reduction.solver.dynamics.compiled``
packs a chain for them and is their Python interface.  ``exponential`` (the modal
advance and the phi-functions) and ``pece`` (the exponential Adams step loop) are the
exponential integrator's (``gimbal_reduction.solver.dynamics.exponential``, docs/exponential.md).

The chain reaches the kernels as ONE argument ``ch``, the named tuple
``compiled.PackedChain`` (D, off, M6, V, gram, M1, G, om2, cd, C1, C, rho; see
``compiled.pack``); the forward and backward passes share ``recursion.Frames``.

Importing this package raises LLVM's limit of runtime alias checks and sets the
optimisation level (below) before any kernel is compiled.
"""

import os
import time
from contextlib import contextmanager

import llvmlite.binding
import numba
from numba.core import event

# Compiler options of the kernels.  JIT: IEEE arithmetic.  FAST: reassociation only (no
# "no-NaN/no-Inf" assumptions: a diverging state must stay visible).
JIT = dict(cache=True, fastmath=False, error_model="numpy")
FAST = dict(cache=True, fastmath={"reassoc", "contract", "nsz"}, error_model="numpy")


def _allow_runtime_alias_checks(limit=16):
    """Let LLVM vectorise loops over many row views.  Numba cannot tell LLVM that two
    array views do not overlap, so a loop that writes one and reads several is
    vectorised only behind runtime overlap checks, at most 8 by default: the Coriolis
    pass with four rows of G needs more and ran 3x slower, unvectorised.  An LLVM
    option may be given only once per process, hence the guard."""
    if not getattr(llvmlite.binding, "_gimbal_alias_checks", False):
        llvmlite.binding.set_option("", f"--runtime-memory-check-threshold={limit}")
        llvmlite.binding._gimbal_alias_checks = True


_allow_runtime_alias_checks()

# LLVM optimisation level of the kernels: -O1, not Numba's default -O3.  Measured (cold cache,
# the workflow's warm-up: gimbal_reduction.solver.dynamics.warmup, CPU time): 118 CPU-s at 2
# against 176 at 3 (quiet machine); 89.5 at 1 against 105.8 at 2 (one run each, load 13-16);
# the same run times at 1 and 2 (alternating processes, CPU time: right-hand side of a
# 100-modes-per-body synthetic chain 40-42 against 42-48 us, its thesis run 38-52 against
# 40-42 ms).  A NUMBA_OPT given by the user wins.  Set on import, before the first compilation.
#
# Flags passed as constants are wrapped, bool(True), int(0): Numba compiles a callee once per
# literal value of a constant argument, and the recursion's passes (forward, backward, joint)
# were compiled twice, once per value of has_acc or lin_given; a wrapped constant is a plain
# bool or int, one compilation with the branch at run time (the same run times, measured).
OPT_LEVEL = 1
if "NUMBA_OPT" not in os.environ:
    numba.config.OPT = numba.core.config._process_opt_level(str(OPT_LEVEL))


class KernelLoadTimer(event.Listener):
    """The wall time [s] spent loading kernels from Numba's on-disk cache or compiling them
    (Numba's compiler lock held: a dispatcher's first call with new argument types) while
    installed (``kernel_load_timer``): the one-off cost of a process's first run, kept apart
    from the integration time it would otherwise be counted in."""

    def __init__(self):
        self.seconds = 0.0
        self._depth = 0
        self._start = 0.0

    def on_start(self, ev):
        if self._depth == 0:
            self._start = time.perf_counter()
        self._depth += 1

    def on_end(self, ev):
        self._depth -= 1
        if self._depth == 0:
            self.seconds += time.perf_counter() - self._start


@contextmanager
def kernel_load_timer():
    """``with kernel_load_timer() as load:`` ... ``load.seconds``: the kernel loading and
    compiling inside the block (``KernelLoadTimer``)."""
    timer = KernelLoadTimer()
    with event.install_listener("numba:compiler_lock", timer):
        yield timer
