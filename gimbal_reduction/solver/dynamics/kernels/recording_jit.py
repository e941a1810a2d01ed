"""The JIT of the process that builds the kernels' extension (``extension``; GIMBAL_KERNELS=build).

There the JIT's code only runs the warm-up that records the entry points.  The extension links
the JIT's LLVM IR (each function optimised by itself, Numba's function passes), not its machine
code, and optimises the linked whole once with its own module passes.  So in that process only
(``set_up``, called by the package's import) Numba's JIT is made to do less:

1. it emits machine code at LLVM's code-generation level 0 (fast instruction selection);
2. it skips its per-library module passes (Numba runs them on every library with all its callees
   linked in: a callee's code was optimised again at every level above it), and it writes nothing
   to Numba's disk cache (``kernels.JIT``).  With 1 and the slice error of ``kernels``, measured
   (the build's CPU in its process, cold, alternating, 3 each): 97-106 CPU-s before, 60-63 after;
3. it emits each function's machine code once (``own_code_only``);
4. a function compiled as a callee gets no Python wrapper (``python_wrappers_for_python_calls_
   only``), and no compiled function gets a C-callable one (Numba's ``cfunc`` form, for passing a
   function as a value: nothing here does);
5. its reference counting finds the arrays of a container without visiting their shapes, strides
   and pointers (``meminfos``);
6. copying a function's IR to inline it shares the source locations (``ir.Loc``) instead of
   copying each.

Measured, 4-6 (the C compiler's part is not in it: ``extension.build``): the build side by side
with the build before them (one core each, 3 rounds, CPU in its process) 50, 52, 54 CPU-s against
59, 61, 60 in one hour, 58, 61, 66 against 68, 69, 78 in a slower one (ratios of the medians 0.87,
0.88). None of this changes the kernels' code in the extension: of its 115 compiled functions 111
disassemble to the same instructions as before; of the others, one differs by alignment padding,
two small Numba helpers (``np.dot``'s, ``max``'s) are there twice (once compiled as a callee
without a wrapper: another symbol), and the module's init sets up fewer environments. The extension
runs as fast or faster than the JIT's code: a 20-modes-per-body chain's RK4 run on the thesis scene
2.54-2.60 s against 2.66-2.83 s, a 30-modes-per-body exponential run over 1 s equal within 1 %
(medians of 5 and 3, 3 rounds).

Every function here changes Numba (0.68, pinned) in this process only; the tests check each
against Numba's own behaviour (tests/dynamics/test_extension.py).
"""

import llvmlite.binding
import numba
from numba.core import codegen, dispatcher, ir, registry, sigutils
from numba.core.runtime import context as nrt_context

# (id of the dispatcher, argument types) of the overloads compiled without a Python wrapper
# (``python_wrappers_for_python_calls_only``): their entry point is null, not to be called
WRAPPERLESS = set()


def set_up():
    """Make this process's JIT the build's (module docstring).  The code-generation level is that
    of Numba's JIT target machine, made with the CPU target's context: this must run before
    anything in the process compiled or decorated a Numba function (the kernels' import in
    ``warmup``'s process does)."""
    if "_toplevel_target_context" in vars(registry.cpu_target):
        raise RuntimeError("kernels: Numba's CPU target exists before the kernels' import: "
                           "GIMBAL_KERNELS=build cannot set its code generation")
    previous = numba.config.OPT
    numba.config.OPT = numba.core.config._process_opt_level("0")
    try:
        registry.cpu_target.target_context          # makes the JIT's target machine at level 0
    finally:
        numba.config.OPT = previous
    codegen.JITCodeLibrary._optimize_final_module = lambda library: None
    codegen.JITCodeLibrary._finalize_specific = own_code_only(codegen.JITCodeLibrary._finalize_specific)
    python_wrappers_for_python_calls_only()
    nrt_context.NRTContext.get_meminfos = meminfos
    ir.Loc.__deepcopy__ = lambda loc, memo: loc


def own_code_only(emit):
    """``emit`` (Numba's machine-code step of a JIT library) made to emit the library's own
    functions only.  Numba links a copy of every callee's code into each caller's module
    (``linkonce_odr``), so without module passes each level emitted its callees' machine code
    again.  Here a linked callee that an earlier library already emitted under its name is marked
    ``available_externally`` for the emission (LLVM emits no code for it; the call resolves to the
    earlier code by name) and marked back afterwards, so that the module the extension links is
    unchanged.  Measured: the JIT's machine-code step 3.0-3.2 CPU-s against 4.0-4.9 (2 runs
    each)."""
    emitted = set()                 # external functions of the libraries emitted so far
    linkage = llvmlite.binding.Linkage

    def own_code_only(library):
        module = library._final_module
        linked = [f for f in module.functions if not f.is_declaration and f.name in emitted
                  and f.linkage == linkage.linkonce_odr]
        for f in linked:
            f.linkage = linkage.available_externally
        try:
            emit(library)
        finally:
            for f in linked:
                f.linkage = linkage.linkonce_odr
        emitted.update(f.name for f in module.functions
                       if not f.is_declaration and f.linkage == linkage.external)
    return own_code_only


def python_wrappers_for_python_calls_only():
    """Numba makes every compiled function callable from Python: it lowers a wrapper that unboxes
    each argument (for a kernel taking named tuples of arrays, as much code as a small kernel) and
    optimises and emits it, also for the ~60 of the warm-up's ~75 that only compiled code calls.
    Here a function compiled while Numba types a call to it from compiled code (``get_call_
    template``) gets none, and its overload is kept out of the dispatcher's table of what Python
    calls run: a later call from Python with those types compiles it again, with a wrapper (the
    warm-up: 1 such).  ``WRAPPERLESS`` lists the overloads without one (``extension.entry``
    does not hand them out).  Measured: 3.0 CPU-s of Numba's lowering alone."""
    nested = [0]                    # depth of typing calls from compiled code
    get_call_template = dispatcher.Dispatcher.get_call_template
    customize_flags = dispatcher._FunctionCompiler._customize_flags
    compile_signature = dispatcher.Dispatcher.compile
    add_overload = dispatcher.Dispatcher.add_overload

    def typing_a_call_from_compiled_code(self, args, kws):
        nested[0] += 1
        try:
            return get_call_template(self, args, kws)
        finally:
            nested[0] -= 1

    def flags(self, flags):
        flags = customize_flags(self, flags)
        flags.no_cfunc_wrapper = True
        if nested[0]:
            flags.no_cpython_wrapper = True
        return flags

    def compile_from_python(self, sig):
        if not nested[0]:                                   # a call from Python
            args = tuple(sigutils.normalize_signature(sig)[0])
            if (id(self), args) in WRAPPERLESS:
                WRAPPERLESS.discard((id(self), args))
                del self.overloads[args]
        return compile_signature(self, sig)

    def add(self, cres):
        if nested[0]:
            args = tuple(cres.signature.args)
            self.overloads[args] = cres
            WRAPPERLESS.add((id(self), args))
        else:
            add_overload(self, cres)

    dispatcher.Dispatcher.get_call_template = typing_a_call_from_compiled_code
    dispatcher._FunctionCompiler._customize_flags = flags
    dispatcher.Dispatcher.compile = compile_from_python
    dispatcher.Dispatcher.add_overload = add


# whether a type's data model holds a reference-counted pointer (NRT meminfo), by type
_HOLDS_MEMINFO = {}


def holds_meminfo(models, ty) -> bool:
    """Whether a value of type ``ty`` holds a meminfo (in itself or in a member at any depth);
    ``models``: Numba's data model manager."""
    if ty not in _HOLDS_MEMINFO:
        _HOLDS_MEMINFO[ty] = True                       # provisional, for a recursive type
        model = models[ty]
        _HOLDS_MEMINFO[ty] = model.has_nrt_meminfo() or \
            any(holds_meminfo(models, member) for member, _ in model.traverse(None))
    return _HOLDS_MEMINFO[ty]


def meminfos(nrt, builder, ty, val):
    """[(type, meminfo)] inside ``val`` of type ``ty``, in order: Numba's ``NRTContext.
    get_meminfos`` (what every incref and decref lowers), which visits every member at every depth
    and emits an ``extractvalue`` for each; an array alone has seven members, and the kernels
    pass named tuples of tens of arrays.  Here members that hold no meminfo are not visited: the
    same list (checked against Numba's, every call of a warm-up: ~170 000), ~10x fewer
    instructions emitted only for LLVM to delete."""
    models = nrt._context.data_model_manager
    model = models[ty]
    out = []
    if model.has_nrt_meminfo():
        out.append((ty, model.get_nrt_meminfo(builder, val)))
    for member, getter in model.traverse(builder):
        if holds_meminfo(models, member):
            out.extend(meminfos(nrt, builder, member, getter(val)))
    return out
