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

Importing this package raises LLVM's limit of runtime alias checks, sets the optimisation
level and the error of a slice assignment (below) before any kernel is compiled; in the
process that builds the kernels' extension (``BUILDING``) it also sets up the JIT for that
(``recording_jit``).
"""

import os
import time
from contextlib import contextmanager

import llvmlite.binding
import numba
import numba.np.arrayobj
from numba.core import event
from numba.extending import overload

# Whether this process builds the kernels' extension (``extension``; ``make install`` runs
# ``warmup --extension``, which starts it with GIMBAL_KERNELS=build): see ``recording_jit``.
BUILDING = os.environ.get("GIMBAL_KERNELS", "") == "build"

# Compiler options of the kernels.  JIT: IEEE arithmetic.  FAST: reassociation only (no
# "no-NaN/no-Inf" assumptions: a diverging state must stay visible).  Cached on disk, except
# in the build, where the JIT's code only records (``recording_jit``).
_COMMON = dict(cache=not BUILDING)
JIT = dict(_COMMON, fastmath=False, error_model="numpy")
FAST = dict(_COMMON, fastmath={"reassoc", "contract", "nsz"}, error_model="numpy")


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


if BUILDING:
    from gimbal_reduction.solver.dynamics.kernels import recording_jit
    recording_jit.set_up()
if "NUMBA_OPT" not in os.environ:
    numba.config.OPT = numba.core.config._process_opt_level(str(OPT_LEVEL))


def _raise_slice_mismatch(src_shapes, index_shape):
    """Stands for Numba's ``arrayobj.raise_with_shape_context`` (below)."""
    raise NotImplementedError


@overload(_raise_slice_mismatch, target="CPU")
def _raise_slice_mismatch_cpu(src_shapes, index_shape):
    def impl(src_shapes, index_shape):
        raise ValueError("cannot assign slice from input of different size")
    return impl


# The error of a slice assignment from an array of another shape (``a[i, :] = b``): Numba's CPU
# target formats both shapes into its message with its own string machinery (``str``, ``join``,
# f-strings), compiled once per pair of dimensions and linked into every kernel with such an
# assignment, where LLVM optimises it again.  The kernels take the fixed message of Numba's
# generic target instead (the hook is the one Numba gives targets for their own message): the
# extension's build 6-7 CPU-s shorter (63-64 against 69-71, 2 alternating runs each, the JIT set
# up as in the build).  Set for every Numba function of this process.
if hasattr(numba.np.arrayobj, "raise_with_shape_context"):
    numba.np.arrayobj.raise_with_shape_context = _raise_slice_mismatch


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
