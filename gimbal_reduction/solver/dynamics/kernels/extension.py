"""The kernels compiled ahead of time into an extension module, so that a fresh process's
first simulation loads no JIT code.

Why: a fresh process that calls a Numba kernel from its on-disk cache pays ~0.3 s before
the first call even for a trivial kernel (Numba initialises its target context: typing and
lowering registries) and ~0.25 s more to unserialise the simulation's ~11 cached entry
points; a simulation of the thesis truth integrates in ~0.05 s.  An extension module is
plain machine code: importing it and calling an entry costs milliseconds.

How: ``build`` runs a workload (the workflow's warm-up, ``gimbal_reduction.solver.dynamics.
warmup --extension``, called by ``make install``) with Numba's JIT while recording every
entry point called from Python and the argument types of each call; it then compiles
exactly those (dispatcher, argument types) pairs with Numba's ahead-of-time compiler
(``numba.pycc``, for this machine's CPU; each exported entry forwards to the JIT's code, whose
LLVM IR is linked, not compiled again) into ``_ahead`` beside this file, with a manifest:
the entries, their types and a fingerprint of the kernels' sources, Numba's version and the
CPU.  The build runs in a process of its own with GIMBAL_KERNELS=build, whose JIT only serves
the recording (``recording_jit``: fast machine code, no module passes, no cache).
``attach(module)``, called at the end of every module that defines entry points, inserts the
extension's entries into their dispatchers as ready overloads for exactly those argument types.
Numba's dispatcher still types every call: a call whose types match is run by the extension,
any other compiles with the JIT as before.  A missing or stale extension (a kernel edited,
another Numba or CPU) attaches nothing: the JIT path, the same results to rounding (the same
code, optimised separately).  ``GIMBAL_KERNELS=jit`` in the environment attaches nothing either
(the JIT path on purpose: tests, development).
"""
from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib
import os
import pickle
import sys
import tempfile
import warnings
from pathlib import Path

from numba.core.errors import NumbaPendingDeprecationWarning

from gimbal_reduction.solver.dynamics.kernels import recording_jit

HERE = Path(__file__).resolve().parent
NAME = "_ahead"                                       # the extension module, beside this file
MANIFEST = HERE / f"{NAME}.manifest.pickle"
PACKAGE = __name__.rsplit(".", 1)[0]
INTERFACE = PACKAGE.rsplit(".", 1)[0] + ".compiled"    # the kernels' Python interface
# what the compiled code depends on besides Numba: every kernel module and the Python
# interface that defines entry points
SOURCES = tuple(sorted(p for p in HERE.glob("*.py") if p.name != "extension.py")) + \
    (HERE.parent / "compiled.py",)


def fingerprint() -> str:
    """sha256 of the kernels' sources, the versions of Python, NumPy, Numba and llvmlite and
    this machine's CPU (the code is compiled for it)."""
    import llvmlite
    import llvmlite.binding
    import numba
    import numpy
    h = hashlib.sha256()
    for path in SOURCES:
        h.update(path.name.encode())
        h.update(path.read_bytes())
    for part in (sys.version, numpy.__version__, numba.__version__, llvmlite.__version__,
                 llvmlite.binding.get_host_cpu_name()):
        h.update(part.encode())
    return h.hexdigest()


@functools.cache
def _manifest():
    """(manifest, module) of a current extension that imports (the manifest: {"fingerprint":
    ..., "entries": {module: [(qualname, symbol, pickled argument types)]}}), or None (no
    extension, a stale or broken one, GIMBAL_KERNELS=jit, or the build: GIMBAL_KERNELS=build)."""
    if os.environ.get("GIMBAL_KERNELS", "") in ("jit", "build") or not MANIFEST.exists():
        return None
    try:
        with open(MANIFEST, "rb") as f:
            manifest = pickle.load(f)
        if manifest.get("fingerprint") != fingerprint():
            return None
        return manifest, importlib.import_module(f"{PACKAGE}.{NAME}")
    except (OSError, ImportError, pickle.UnpicklingError, EOFError):
        return None


# the argument types of the inserted entries, kept alive: Numba interns its types weakly, and a
# type made again later gets a new code, which the dispatcher's table would not match
HELD = []


def attach(module_name: str) -> int:
    """Insert the extension's entries of ``module_name`` into its dispatchers (by name), as
    overloads of exactly their compiled argument types; returns how many (0: JIT only)."""
    current = _manifest()
    if current is None or not current[0]["entries"].get(module_name):
        return 0
    (manifest, ext), namespace = current, vars(sys.modules[module_name])
    for qualname, symbol, pickled in manifest["entries"][module_name]:
        insert(namespace[qualname], pickle.loads(pickled), getattr(ext, symbol))
    return len(manifest["entries"][module_name])


# the inserted entries by (dispatcher's id, argument types), for ``entry``
ENTRIES = {}


def insert(dispatcher, argtypes, function):
    """Make ``function`` (an extension entry) the overload of ``dispatcher`` for exactly the
    argument types ``argtypes`` (Numba types): a Python call with those types runs it; the
    types are kept alive (``HELD``)."""
    dispatcher._insert([t._code for t in argtypes], function, False)
    HELD.append(argtypes)
    ENTRIES[(id(dispatcher), tuple(argtypes))] = function


def entry(dispatcher, args):
    """The compiled function that ``dispatcher(*args)`` runs, to call without the dispatcher:
    the extension's entry of exactly these argument types, else the JIT's overload; the
    dispatcher itself if it has none yet or none callable from Python (its call compiles one).
    For a loop that calls one kernel many times with arguments of the same types: the
    dispatcher types every call, ~9 us
    for the step loop's ~70 arrays in named tuples against ~3 us for the call itself (measured,
    ``kernels.pece.pece_run``).  The caller keeps the types fixed (the same dtypes, dimensions
    and layouts): the function does not check them."""
    types = tuple(dispatcher.typeof_pyval(a) for a in args)
    function = ENTRIES.get((id(dispatcher), types))
    if function is None:
        compiled = dispatcher.overloads.get(types)
        wrapperless = (id(dispatcher), types) in recording_jit.WRAPPERLESS     # the build's
        function = dispatcher if compiled is None or wrapperless else compiled.entry_point
    return function


def attached() -> bool:
    """Whether a current extension is in use in this process (else the kernels are Numba's JIT)."""
    return _manifest() is not None


def up_to_date() -> bool:
    """Whether the extension on disk matches the sources, Numba and this CPU (``fingerprint``)."""
    try:
        with open(MANIFEST, "rb") as f:
            return pickle.load(f).get("fingerprint") == fingerprint()
    except (OSError, pickle.UnpicklingError, EOFError):
        return False


@contextlib.contextmanager
def recording():
    """``with recording() as seen:`` every dispatcher called from Python inside the block, with
    the argument types of its calls, {(module, qualname): (dispatcher, {argument types, ...})}:
    the entry points of the code run (calls from compiled code are not seen).  Positional
    arguments only (the kernels' calls).

    A call is typed in full (``typeof_pyval``, ~7 us an argument) only when its arguments'
    classes and Numba type fingerprints (``compute_fingerprint``, the key of Numba's own typeof
    cache, ~0.1 us) are new for that dispatcher: the warm-up's ~144 000 calls from Python,
    ~2 million arguments, typed in full every time, cost 18.1 and 18.7 CPU-s more than the
    warm-up unrecorded (two runs, warm cache); now 0.2-0.7.  An argument without a fingerprint
    is typed in full on every call."""
    from numba._dispatcher import compute_fingerprint
    from numba.core.dispatcher import Dispatcher
    seen = {}
    known = set()                                           # (dispatcher id, argument keys)
    call = super(Dispatcher, Dispatcher).__call__          # the C dispatcher's

    def record(self, *args, **kws):
        try:
            key = (id(self), tuple((type(a), compute_fingerprint(a)) for a in args))
        except NotImplementedError:                         # a value Numba cannot fingerprint
            key = None
        if key is None or key not in known:
            name = (self.py_func.__module__, self.py_func.__qualname__)
            seen.setdefault(name, (self, set()))[1].add(tuple(self.typeof_pyval(a) for a in args))
            if key is not None:
                known.add(key)
        return call(self, *args, **kws)

    Dispatcher.__call__ = record
    try:
        yield seen
    finally:
        del Dispatcher.__call__


def exportable(seen, modules=(PACKAGE, INTERFACE)):
    """[(module, qualname, dispatcher, signature)] of the recorded entries (``recording``) the
    extension can take: module-level kernels of ``modules`` (and their submodules) with the
    JIT's overload of exactly these argument types (its return type, its code)."""
    out = []
    for (module, qualname), (disp, type_sets) in sorted(seen.items()):
        if not any(module == m or module.startswith(m + ".") for m in modules) or \
                getattr(sys.modules.get(module), qualname, None) is not disp:
            continue
        for types in sorted(type_sets, key=str):
            cres = disp.overloads.get(types)
            if cres is not None:
                out.append((module, qualname, disp, cres.signature))
            else:
                print(f"extension: {module}.{qualname}{types} left to the JIT (no overload of "
                      f"exactly these types)", file=sys.stderr)
    return out


def forwarder(dispatcher, nargs):
    """``def forward(a0, ..., a{nargs-1}): return dispatcher(a0, ...)``: the exported entry.  It
    calls the JIT's compiled overload, whose code the ahead-of-time compiler then links (with its
    own flags) instead of typing and lowering the kernel a second time."""
    names = ", ".join(f"a{i}" for i in range(nargs))
    namespace = {"kernel": dispatcher}
    exec(f"def forward({names}):\n    return kernel({names})\n", namespace)
    return namespace["forward"]


def build(entries, directory=HERE, log=print):
    """Compile ``entries`` (``exportable``, their JIT overloads compiled in this process) into
    the extension module ``NAME`` in ``directory`` and write its manifest (``MANIFEST``'s name)
    there, both atomically; returns the path of the module.  Compiled for this machine's CPU.
    Numba's C parts of the module (its module init, reference counting, typed containers: the
    same for every build) are compiled at -O1, not Python's -O3: 1.8 against 2.7 CPU-s of the C
    compiler (one run each); they run a few allocations per kernel call."""
    import llvmlite.binding
    with warnings.catch_warnings():          # pycc is pending deprecation, with no replacement yet
        warnings.simplefilter("ignore", NumbaPendingDeprecationWarning)
        from numba.pycc import CC

    directory = Path(directory)
    cc = CC(NAME, source_module=__name__)
    cc.target_cpu = llvmlite.binding.get_host_cpu_name()
    cc._extra_cflags = {"posix": ["-O1"]}       # after Python's flags: gcc takes the last -O
    manifest = {"fingerprint": fingerprint(), "entries": {}}
    for k, (module, qualname, disp, sig) in enumerate(entries):
        symbol = f"k{k}_{qualname.lstrip('_')}"
        cc.export(symbol, sig)(forwarder(disp, len(sig.args)))
        manifest["entries"].setdefault(module, []).append((qualname, symbol, pickle.dumps(sig.args)))
        log(f"extension: [{k + 1}/{len(entries)}] {module.rsplit('.', 1)[-1]}.{qualname}")
    with tempfile.TemporaryDirectory(prefix="ahead_", dir=directory) as tmp:
        cc.output_dir = tmp
        cc.compile()
        with open(Path(tmp) / MANIFEST.name, "wb") as f:
            pickle.dump(manifest, f)
        os.replace(Path(tmp) / cc.output_file, directory / cc.output_file)
        os.replace(Path(tmp) / MANIFEST.name, directory / MANIFEST.name)
    return directory / cc.output_file
