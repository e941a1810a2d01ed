"""gimbal_reduction.solver.dynamics.kernels.extension: the kernels compiled ahead of time run as
their dispatchers' overloads for exactly the recorded argument types, agree with the JIT, and a
stale extension is never used."""
import collections
import importlib.util
import os
import pickle
import shutil
import subprocess
import sys
from typing import NamedTuple

import h5py
import numba
import numpy as np
import pytest

from gimbal_reduction.solver.dynamics import scenes, warmup
from gimbal_reduction.solver.dynamics.kernels import extension
from gimbal_reduction.solver.dynamics.synthetic import synthetic_modal_chain


@numba.njit(cache=False, error_model="numpy")
def _weighted(a, w):
    s = 0.0
    for i in range(a.size):
        s += a[i] * w[i]
    return s


@numba.njit(cache=False, error_model="numpy")
def _entry(a, w):
    """An entry point: called from Python; _weighted only from compiled code."""
    return _weighted(a, w) / a.size


def test_recording_sees_the_calls_from_python_only():
    a = np.arange(5.0)
    with extension.recording() as seen:
        _entry(a, a)
        _entry(a, a)
    assert list(seen) == [(__name__, "_entry")]
    disp, types = seen[(__name__, "_entry")]
    assert disp is _entry and types == {(numba.typeof(a), numba.typeof(a))}
    entries = extension.exportable(seen, modules=(__name__,))
    assert [(m, q) for m, q, _, _ in entries] == [(__name__, "_entry")]
    assert entries[0][3].return_type == numba.float64
    # the project's kernels only, by default
    assert extension.exportable(seen) == []


Pair = collections.namedtuple("Pair", "a b")
Twin = collections.namedtuple("Twin", "a b")


@numba.njit(cache=False, error_model="numpy")
def _first(x, s):
    return s


def test_recording_types_each_new_kind_of_call_once_and_exactly():
    """The recorder types a call in full only when its arguments' kinds are new (fingerprints):
    what it records equals Numba's typing of every call, for arrays differing only in layout,
    write flag or dtype, scalars of different types, and named tuples of different classes
    with the same fields; a repeated kind is not typed again."""
    a = np.arange(6.0)
    frozen = np.arange(6.0)
    frozen.setflags(write=False)
    calls = [(a, 1.0), (a, 1.0), (a[::2], 1.0), (frozen, 1.0), (a.astype(np.int64), 1.0),
             (a, 2), (a, True), (a, Pair(1.0, 2)), (a, Twin(1.0, 2)), (a, Twin(3.0, 4))]
    typed = []
    with extension.recording() as seen:
        for args in calls:                  # compiles each kind (Numba types them too)
            _first(*args)
        original = _first.typeof_pyval
        _first.typeof_pyval = lambda v: typed.append(v) or original(v)
        try:
            for args in calls:              # the same kinds again: nothing new to type
                _first(*args)
        finally:
            del _first.typeof_pyval
    assert seen[(__name__, "_first")][1] == {tuple(numba.typeof(v) for v in args) for args in calls}
    assert typed == []


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_a_built_entry_is_its_dispatchers_overload_for_exactly_its_types(tmp_path):
    a, w = np.linspace(0.0, 1.0, 7), np.linspace(2.0, 3.0, 7)
    with extension.recording() as seen:
        expected = _entry(a, w)
    path = extension.build(extension.exportable(seen, modules=(__name__,)), tmp_path, log=lambda _: None)
    spec = importlib.util.spec_from_file_location(extension.NAME, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    manifest = pickle.loads((tmp_path / extension.MANIFEST.name).read_bytes())
    [(qualname, symbol, pickled)] = manifest["entries"][__name__]
    assert qualname == "_entry" and manifest["fingerprint"] == extension.fingerprint()
    fresh = numba.njit(cache=False, error_model="numpy")(_entry.py_func)   # nothing compiled yet
    extension.insert(fresh, pickle.loads(pickled), getattr(module, symbol))
    scale = np.abs(a * w).sum() / a.size
    assert abs(fresh(a, w) - expected) <= 1e-14 * scale
    assert fresh.signatures == []           # run by the extension: the JIT compiled nothing
    # other argument types (a strided view) are not the extension's: the JIT compiles them,
    # and reads the view right (the extension would read contiguous memory)
    strided = np.linspace(0.0, 1.0, 14)[::2]
    assert abs(fresh(strided, w) - np.dot(strided, w) / 7) <= 1e-14 * scale
    assert len(fresh.signatures) == 1


def test_entry_is_what_the_dispatcher_runs_for_these_types(monkeypatch):
    """kernels.extension.entry: the dispatcher itself before anything is compiled, then the JIT's
    overload of exactly these types (the same value as the dispatcher's call); an extension entry
    inserted (at import, before any JIT compilation) where there is one; other types their own."""
    monkeypatch.setattr(extension, "ENTRIES", {})
    monkeypatch.setattr(extension, "HELD", [])
    fresh = numba.njit(cache=False, error_model="numpy")(_entry.py_func)
    a, w = np.linspace(0.0, 1.0, 7), np.linspace(2.0, 3.0, 7)
    assert extension.entry(fresh, (a, w)) is fresh                  # nothing compiled yet
    expected = fresh(a, w)
    jit = extension.entry(fresh, (a, w))
    assert jit is not fresh and abs(jit(a, w) - expected) <= 1e-14 * np.abs(a * w).sum()
    strided = np.linspace(0.0, 1.0, 14)[::2]
    assert extension.entry(fresh, (strided, w)) is fresh            # a layout not compiled yet

    other = numba.njit(cache=False)(lambda x, y: -1.0)             # a compiled stand-in entry
    other(a, w)
    inserted = other.overloads[other.signatures[0]].entry_point
    ahead = numba.njit(cache=False, error_model="numpy")(_entry.py_func)   # as at import
    extension.insert(ahead, fresh.signatures[0], inserted)
    assert extension.entry(ahead, (a, w)) is inserted and ahead(a, w) == -1.0


def test_a_stale_or_refused_extension_attaches_nothing(tmp_path, monkeypatch):
    manifest = tmp_path / extension.MANIFEST.name
    monkeypatch.setattr(extension, "MANIFEST", manifest)
    monkeypatch.delenv("GIMBAL_KERNELS", raising=False)
    try:
        extension._manifest.cache_clear()
        assert not extension.up_to_date() and extension._manifest() is None        # missing
        manifest.write_bytes(pickle.dumps({"fingerprint": "0" * 64, "entries": {}}))
        extension._manifest.cache_clear()
        assert not extension.up_to_date() and extension._manifest() is None        # stale
        manifest.write_bytes(pickle.dumps({"fingerprint": extension.fingerprint(), "entries": {}}))
        extension._manifest.cache_clear()
        assert extension.up_to_date()                                              # current
        monkeypatch.setenv("GIMBAL_KERNELS", "jit")
        extension._manifest.cache_clear()
        assert extension._manifest() is None                                       # refused
    finally:
        monkeypatch.undo()
        extension._manifest.cache_clear()


def _simulate(tmp_path, model, name, env, scene=os.path.join(scenes.SCENES_DIR, "thesis.yaml"),
              options=()):
    out = tmp_path / f"{name}.h5"
    subprocess.run([sys.executable, "-m", "gimbal_reduction.solver.dynamics.simulate",
                    "--scene", scene, "--model-file", str(model),
                    "--out", str(out), "--no-config-check", *options],
                   check=True, capture_output=True, env={**os.environ, **env})
    with h5py.File(out) as f:
        return f["gamma"][()], dict(f.attrs)


WARMUP_SCENES = [os.path.join(scenes.SCENES_DIR, f"{name}.yaml") for name in ("thesis", "damped")]


@pytest.mark.skipif(not extension.up_to_date(), reason="no current extension (make install builds it)")
@pytest.mark.parametrize("run", warmup.runs(WARMUP_SCENES, "exponential", []),
                         ids=lambda run: f"{os.path.basename(run[0])}-{run[1]}-{run[2][1]}")
def test_every_warmup_run_over_its_whole_window_loads_every_kernel_from_the_extension(tmp_path, run):
    """The extension's entries are those the warm-up called (``make install`` builds it from the
    thesis and damped scenes); runs it shortens (warmup.SHORT_WINDOW) must call nothing a whole
    window calls besides."""
    scene, kind, options, _ = run
    chain = synthetic_modal_chain(warmup.MODES_PER_BODY, seed=0)
    model = tmp_path / f"{kind}.h5"
    warmup.write_model(model, chain if kind == "elastic" else warmup.rigid_chain(chain), kind)
    gamma, attrs = _simulate(tmp_path, model, "run", {}, scene, options)
    assert attrs["kernels"] == "extension" and np.isfinite(gamma).all()
    assert attrs["kernel_load_s"] == 0.0        # nothing compiled with the JIT


@pytest.mark.skipif(not extension.up_to_date(), reason="no current extension (make install builds it)")
def test_the_extension_and_the_jit_agree_and_the_file_says_which_ran(tmp_path):
    model = tmp_path / "synthetic.h5"
    warmup.write_model(model, synthetic_modal_chain(warmup.MODES_PER_BODY, seed=0), "synthetic")
    ahead, a = _simulate(tmp_path, model, "extension", {})
    jit, j = _simulate(tmp_path, model, "jit", {"GIMBAL_KERNELS": "jit"})
    assert a["kernels"] == "extension" and j["kernels"] == "jit"
    assert a["kernel_load_s"] == 0.0            # a fresh process: every kernel from the extension
    assert a["steps"] == j["steps"]
    # the same code optimised apart: round-off, carried through ~40 steps
    assert np.abs(ahead - jit).max() <= 1e-10 * np.abs(jit).max()
    for attrs in (a, j):
        assert attrs["wall_time_s"] >= attrs["integration_time_s"] + attrs["kernel_load_s"]


@pytest.mark.skipif(not extension.up_to_date(), reason="no current extension (make install builds it)")
def test_the_checks_compiled_rk4_steps_load_from_the_extension():
    """verify-dynamics' conservation and order checks and the stability tests take compiled RK4
    steps without outputs (integrators.rk4_advance): the whole-run kernel over one interval
    (compiled.CompiledRhs.rk4_steps), whose entry the warm-up's RK4 run records.  In a fresh
    process another chain's steps compile nothing."""
    code = ("from gimbal_reduction.solver.dynamics import integrators, kernels\n"
            "from gimbal_reduction.solver.dynamics.kernels import extension\n"
            "from gimbal_reduction.solver.dynamics.problem import Problem\n"
            "from gimbal_reduction.solver.dynamics.synthetic import synthetic_modal_chain\n"
            "with kernels.kernel_load_timer() as load:\n"
            "    problem = Problem(synthetic_modal_chain(5, seed=1), omega_max=0.0)\n"
            "    y, yd = integrators.rk4_advance(problem, problem.y0, problem.yd0 + 1.0, 0.0, 1e-6, 50)\n"
            "print(extension.attached(), load.seconds, float(abs(yd).max()))\n")
    run = _python(code, {})
    assert run.returncode == 0, run.stderr
    attached, load_s, rate = run.stdout.split()
    assert attached == "True" and float(load_s) == 0.0 and 0.0 < float(rate) < 1e3


@numba.njit(cache=False, error_model="numpy")
def _assign_row(a, b):
    a[0, :] = b
    return a


def test_a_slice_assignment_of_another_shape_raises_the_plain_error():
    a = np.zeros((2, 3))
    assert np.array_equal(_assign_row(a, np.arange(3.0))[0], [0.0, 1.0, 2.0])
    with pytest.raises(ValueError, match="cannot assign slice from input of different size"):
        _assign_row(a, np.arange(4.0))


KERNELS = "gimbal_reduction.solver.dynamics.kernels"


def _python(code, env):
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**os.environ, **env})


def _printed(code, kernels_mode):
    """The words ``code`` prints in a child process with GIMBAL_KERNELS=kernels_mode (it must
    succeed)."""
    child = _python(code, {"GIMBAL_KERNELS": kernels_mode})
    assert child.returncode == 0, child.stderr
    return child.stdout.split()


# a kernel for the build-process tests below, in their child's source: f(x) = 2 x + 1
_AFFINE = "f = numba.njit(**dict(kernels.JIT, cache=False))(lambda x: 2.0 * x + 1.0)\n"


def test_the_build_process_caches_nothing_skips_module_passes_and_attaches_nothing():
    code = ("import copy, numba\n"
            "from numba.core import codegen, ir\n"
            "from gimbal_reduction.solver.dynamics import kernels\n"
            "from gimbal_reduction.solver.dynamics.kernels import extension\n"
            + _AFFINE +
            "loc = ir.Loc('f.py', 1)\n"
            "print(kernels.BUILDING, kernels.JIT['cache'], extension.attached(), f(3.0),\n"
            "      codegen.JITCodeLibrary._optimize_final_module.__module__, int(numba.config.OPT),\n"
            "      copy.deepcopy(loc) is loc)\n")
    assert _printed(code, "build") == ["True", "False", "False", "7.0", KERNELS + ".recording_jit",
                                       "1", "True"]
    assert _printed(code, "jit") == ["False", "True", "False", "7.0", "numba.core.codegen", "1",
                                     "False"]


def test_the_build_emits_a_callee_once_and_leaves_the_linked_module_whole():
    """In the build a caller's machine code calls its callee's earlier code by name
    (``recording_jit.own_code_only``); the module the extension links still defines the callee."""
    code = ("import numba\n"
            "from gimbal_reduction.solver.dynamics import kernels\n"
            + _AFFINE +
            "g = numba.njit(**dict(kernels.JIT, cache=False))(lambda x: f(x) * f(x + 1.0))\n"
            "print(g(3.0))\n"
            "module = g.overloads[g.signatures[0]].library._get_module_for_linking()\n"
            "callee = module.get_function(f.overloads[f.signatures[0]].fndesc.mangled_name)\n"
            "print(bool(callee.is_declaration), callee.linkage.name, f(3.0))\n")
    assert _printed(code, "build") == ["63.0", "False", "linkonce_odr", "7.0"]


# f compiled as g's callee, then called from Python; what ``extension.entry`` hands out for f
_CALLEE_THEN_PYTHON = (
    "import numba\n"
    "from gimbal_reduction.solver.dynamics import kernels\n"
    "from gimbal_reduction.solver.dynamics.kernels import extension, recording_jit\n"
    + _AFFINE +
    "g = numba.njit(**dict(kernels.JIT, cache=False))(lambda x: f(x) * f(x + 1.0))\n"
    "key = (id(f), (numba.float64,))\n"
    "print(g(3.0), key in recording_jit.WRAPPERLESS, extension.entry(f, (3.0,)) is f)\n"
    "print(f(3.0), key in recording_jit.WRAPPERLESS, extension.entry(f, (3.0,)) is f, f(4.0))\n")


def test_the_build_gives_python_wrappers_only_to_what_python_calls():
    """In the build a function compiled as a callee has no Python wrapper (its entry point is
    null): ``extension.entry`` does not hand it out, and a call from Python compiles it again
    with one (``recording_jit.python_wrappers_for_python_calls_only``)."""
    assert _printed(_CALLEE_THEN_PYTHON, "build") == ["63.0", "True", "True", "7.0", "False", "False",
                                                      "9.0"]
    assert _printed(_CALLEE_THEN_PYTHON, "jit") == ["63.0", "False", "False", "7.0", "False", "False",
                                                    "9.0"]


class _Pair(NamedTuple):
    rows: np.ndarray
    scale: float
    inner: tuple


@pytest.mark.parametrize("value", [
    np.zeros((2, 3)), 1.5, (1.0, 2), (np.zeros(3), np.zeros((2, 2), dtype=np.complex128)),
    _Pair(np.zeros((4, 2)), 2.0, (np.zeros(3, dtype=np.int64), 3.0, np.zeros((1, 1, 1)))),
    _Pair(np.zeros(1, dtype=[("stage", np.int64), ("t", np.float64)]), 0.0, (np.ones(2),) * 3),
], ids=["array", "float", "scalars", "arrays", "nested", "records"])
def test_the_builds_reference_counting_finds_numbas_meminfos_with_fewer_instructions(value):
    """``recording_jit.meminfos`` (the build's) against Numba's own ``get_meminfos``: the same
    (type, meminfo) list in the same order, with no more instructions emitted (fewer for arrays)."""
    import llvmlite.ir as llir
    from numba.core import registry
    from gimbal_reduction.solver.dynamics.kernels import recording_jit
    # a copy of the CPU context: ``nrt`` is cached on the context it is read from, and the base
    # context's (reference counting off) would be copied into every later compilation's
    context = registry.cpu_target.target_context.subtarget(enable_nrt=True)
    ty = numba.typeof(value)

    def emitted(get_meminfos):
        module = llir.Module()
        function = llir.Function(module, llir.FunctionType(
            llir.VoidType(), [context.data_model_manager[ty].get_value_type()]), "f")
        builder = llir.IRBuilder(function.append_basic_block())
        found = get_meminfos(builder, ty, function.args[0])
        return [t for t, _ in found], len(function.blocks[0].instructions)

    ours, ours_size = emitted(lambda *a: recording_jit.meminfos(context.nrt, *a))
    numbas, numbas_size = emitted(context.nrt.get_meminfos)
    assert ours == numbas
    assert ours_size <= numbas_size and (ours_size < numbas_size or not ours)


def test_the_build_refuses_a_cpu_target_made_before_the_kernels():
    late = _python("import numba\nnumba.njit(lambda: 1)\n"
                   "import gimbal_reduction.solver.dynamics.kernels\n", {"GIMBAL_KERNELS": "build"})
    assert late.returncode != 0
    assert late.stderr.strip().splitlines()[-1] == (
        "RuntimeError: kernels: Numba's CPU target exists before the kernels' import: "
        "GIMBAL_KERNELS=build cannot set its code generation")
