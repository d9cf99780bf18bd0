r"""How the solver's kernels are compiled: each kernel once, the whole program optimised once.

numba compiles every function as a library of its own: a function called from another kernel is
optimised by LLVM, turned into machine code and cached, and then its code is linked into its
caller's library, which is optimised and turned into machine code again, and so on up to
``integrate``. A function deep in the tree is optimised once for each level above it, and the
first compile took about 100 s, 62 s of it in LLVM (docs/performance.md, "The first compile").

A :class:`Kernel` is a solver function with two numba dispatchers:

* called from another kernel, the *link* dispatcher types and lowers it to LLVM IR with the
  function-level passes only: no module optimisation, no machine code, no CPython wrapper
  (:class:`LinkOnlyLibrary`). Its IR is linked into the caller as before, and cached on disk
  as IR (:class:`LinkCache`), so that a process compiling the tree afresh links what another
  process compiled (solver/compile/parallel_compile.py);
* called from Python (``integrate`` from ``solve``; a piece from a test or the DOP853 reference),
  the *call* dispatcher compiles it as numba always does, optimises the whole linked program
  at once at numba's optimisation level, emits it and caches it (solver.compile.kernel_cache).

So LLVM optimises and emits the program once per entry point. The code that runs is the same
program, optimised by the same pipeline at its top; the results are bit for bit (no fast-math
is added: IEEE arithmetic is left as written) and ``make bench-revisions`` measures the speed.

A helper meant to be inlined is ``@kernel(inline="llvm")``: compiled once like any kernel, its
function marked ``alwaysinline`` so that LLVM inlines it into every caller when the program is
optimised. numba's own ``inline="always"`` types and lowers the helper again at each call site;
moving 23 helpers of the step, the loop, the error control and the observers from numba's
inlining to LLVM's cut the first compile by a fifth, bit for bit (docs/performance.md). The
8 small helpers of the forcing's innermost loop (model/layer.py, model/basis.py) keep numba's
``inline="always"`` (a plain numba dispatcher): under LLVM's they measured 2 % slower.
A kernel called from another kernel is compiled for its arguments' plain types: numba types a
constant argument as a literal (``floe_dry_sums(floe, d, x, 0)``: ``Literal[int](0)``) and would
compile a copy of the callee, and of everything it inlines, for each constant its callers pass
(25 such copies, 3 s of a one-process compile: docs/performance.md). A kernel that needs a
constant's value at compile time (a tuple index, an array's dimension count) takes it from a
module constant, not from an argument.

A kernel called from another kernel *borrows* its arrays: its caller holds them for the length of
the call, so numba's reference counting (NRT incref and decref at each binding of an array, and
of every array a tuple holds) is compiled out of it (numba's ``_nrt=False``): 15 % of a run's
samples were there (docs/performance.md, "Reference counting"). A kernel that makes arrays
(``np.empty``) or hands them to its caller (returns them, or a tuple of them; or calls a kernel
that does) is ``@kernel(nrt=True)``: its references are counted as numba always counts them. A
kernel left borrowing that does either is refused by name when it compiles (numba's typing
refuses an allocation; :class:`LinkOnlyLowering` refuses an array handed on), so a wrong mark is
a compile error, never a freed array. The arithmetic is unchanged: the results are bit for bit.
"""
from __future__ import annotations

import functools
import importlib

from llvmlite import binding as llvm
from numba import njit, types
from numba.core import caching, codegen, compiler, ir, sigutils, typed_passes
from numba.core.compiler_machinery import register_pass
from numba.extending import typeof_impl

#: the options of every kernel (its Python-callable dispatcher adds cache=True)
OPTIONS = {"nogil": True}
#: how a kernel may be inlined into its callers (see kernel)
INLINE = ("never", "llvm", "always")
#: the numba internals a link-only library uses (numba 0.68 has them); where one is missing, a
#: kernel is numba's plain dispatcher (the same results, the slower first compile)
LINK_ONLY = (all(hasattr(codegen.CPUCodeLibrary, name) for name in
                 ("_get_module_for_linking", "_optimize_final_module", "_raise_if_finalized"))
             and hasattr(codegen, "require_global_compiler_lock") and hasattr(codegen, "JITCodeLibrary"))


class _NoEnvironment:
    """The codegen as a link-only library shows it: its code never runs on its own, so there is
    no environment pointer to set (numba sets it in the machine code it has not made)."""

    def __init__(self, codegen_):
        self._codegen = codegen_

    def set_env(self, env_name, env):
        pass

    def __getattr__(self, name):
        return getattr(self._codegen, name)


class LinkOnlyLibrary(codegen.JITCodeLibrary):
    """A kernel's code for linking into its callers only: finalising links its callees' IR in,
    and does not optimise the module or emit machine code (its callers do, once)."""

    #: mark the kernel's functions for LLVM to inline into every caller
    always_inline = False

    def add_ir_module(self, ir_module):
        if self.always_inline:
            for function in ir_module.functions:
                if not function.is_declaration:
                    function.attributes.add("alwaysinline")
        super().add_ir_module(ir_module)

    def finalize(self):
        codegen.require_global_compiler_lock()
        self._raise_if_finalized()
        seen = set()
        for library in self._linking_libraries:
            if library not in seen:
                seen.add(library)
                self._reload_init.update(library._reload_init)
                self._final_module.link_in(library._get_module_for_linking(), preserve=True)
        self._finalized = True

    def get_pointer_to_function(self, name):
        self._ensure_finalized()
        return 0                                     # no machine code: a link dispatcher is never called

    @property
    def codegen(self):
        return _NoEnvironment(self._codegen)

    def serialize_using_object_code(self):
        """The library as the link cache stores it: its IR for linking (there is no object code)."""
        return (self.name, LINK_IR, self._get_module_for_linking().as_bitcode())

    @classmethod
    def from_serialized(cls, codegen_, state):
        """The library serialize_using_object_code stored, finalised: its callees are linked in."""
        name, kind, bitcode = state
        if kind != LINK_IR:
            raise ValueError(f"not a link-only library: {kind!r}")
        library = cls(codegen_, name)
        library._final_module = library._shared_module = llvm.parse_bitcode(bitcode)
        library._finalized = True
        return library


#: the kind of a serialised LinkOnlyLibrary
LINK_IR = "link-ir"


class LinkCacheImpl(caching.CompileResultCacheImpl):
    """numba's cache of compile results, for link dispatchers: the IR for linking, under
    file names of their own (``link-<module>.<function>-...``)."""

    def get_filename_base(self, fullname, abiflags):
        return "link-" + super().get_filename_base(fullname, abiflags)

    def rebuild(self, target_context, payload):
        libdata, fndesc, env, signature, objectmode, lifted, typeann, reload_init, referenced_envs = payload
        for init in reload_init or ():
            init()
        library = LinkOnlyLibrary.from_serialized(target_context.codegen(), libdata)
        return compiler.CompileResult(
            target_context=target_context, typing_context=target_context.typing_context, library=library,
            environment=env, entry_point=target_context.get_executable(library, fndesc, env), fndesc=fndesc,
            type_annotation=typeann, signature=signature, objectmode=objectmode, lifted=lifted, typing_error=None,
            call_helper=None, metadata=None, reload_init=reload_init, referenced_envs=referenced_envs)


#: while kernels compile in two processes, who compiles which function (solver.compile.parallel_compile)
claims = None


class LinkCache(caching.Cache):
    """The on-disk cache of a kernel's link dispatcher (solver.compile.kernel_cache's directory). While
    two processes compile (``claims`` set), a function one of them compiles the other waits for."""
    _impl_class = LinkCacheImpl

    def load_cached(self, sig, target_context):
        """The cached result for sig, if it is one for sig: numba's index and data files are
        not written atomically together, and two processes saving two signatures of one
        function at once can leave an index entry naming the other's data."""
        cres = super().load_overload(sig, target_context)
        if cres is not None and tuple(cres.signature.args) != tuple(sigutils.normalize_signature(sig)[0]):
            return None
        return cres

    def load_overload(self, sig, target_context):
        if claims is None:
            return self.load_cached(sig, target_context)
        return claims.load_or_claim(self, sig, target_context)

    def save_overload(self, sig, data):
        super().save_overload(sig, data)
        if claims is not None:
            claims.release(self, sig, data.codegen)


class KernelNeedsNRT(TypeError):
    """A borrowing kernel (no reference counting) that hands arrays to its caller."""


def _refuse_handed_arrays(state):
    """Refuse a borrowing kernel that returns arrays or takes them from a kernel that returns
    them: without reference counting its caller would free what it still holds, or never free
    what it was given."""
    models = state.targetctx.data_model_manager
    name = f"{state.func_id.modname}.{state.func_id.func_qualname}"
    if models[state.return_type].contains_nrt_meminfo():
        raise KernelNeedsNRT(f"kernel {name} returns {state.return_type}, which holds arrays: "
                             f"declare it @kernel(nrt=True)")
    for block in state.func_ir.blocks.values():
        for assign in block.find_insts(ir.Assign):
            call = assign.value
            if isinstance(call, ir.Expr) and call.op == "call":
                callee = state.typemap[call.func.name]
                returned = state.calltypes[call].return_type
                if isinstance(callee, types.Dispatcher) and models[returned].contains_nrt_meminfo():
                    raise KernelNeedsNRT(f"kernel {name} takes {returned}, which holds arrays, from "
                                         f"{callee.dispatcher.py_func.__qualname__}: declare it "
                                         f"@kernel(nrt=True)")


@register_pass(mutates_CFG=True, analysis_only=False)
class LinkOnlyLowering(typed_passes.NativeLowering):
    """numba's lowering into a LinkOnlyLibrary."""
    _name = "floe_impact_link_only_lowering"
    always_inline = False

    def run_pass(self, state):
        if not state.flags.nrt:
            _refuse_handed_arrays(state)
        state.library = LinkOnlyLibrary(state.targetctx.codegen(), state.func_id.func_qualname)
        state.library.always_inline = self.always_inline
        return super().run_pass(state)


@register_pass(mutates_CFG=True, analysis_only=False)
class InlineLinkOnlyLowering(LinkOnlyLowering):
    """numba's lowering into a LinkOnlyLibrary whose functions LLVM inlines into each caller."""
    _name = "floe_impact_inline_link_only_lowering"
    always_inline = True


class LinkOnlyCompiler(compiler.CompilerBase):
    """numba's nopython pipeline with the lowering into a LinkOnlyLibrary."""
    lowering = LinkOnlyLowering

    def define_pipelines(self):
        pm = compiler.DefaultPassBuilder.define_nopython_pipeline(self.state)
        pm.passes = [(self.lowering if pass_ is typed_passes.NativeLowering else pass_, text)
                     for pass_, text in pm.passes]
        pm.finalize()
        return [pm]


class InlineLinkOnlyCompiler(LinkOnlyCompiler):
    """numba's nopython pipeline with the lowering for LLVM to inline."""
    lowering = InlineLinkOnlyLowering


#: what a Kernel answers for its call dispatcher
DELEGATED = frozenset(("stats", "signatures", "overloads", "nopython_signatures", "inspect_types", "inspect_llvm",
                       "inspect_asm", "get_compile_result"))


class Kernel:
    """A solver function compiled by numba: the link dispatcher for callers in other kernels,
    the call dispatcher (cached, made on first use) for callers in Python."""

    def __init__(self, py_func, options, always_inline=False, nrt=False):
        functools.update_wrapper(self, py_func)
        self.py_func = py_func
        self._options = options
        pipeline = InlineLinkOnlyCompiler if always_inline else LinkOnlyCompiler
        # called from a kernel it borrows its arrays: no reference counting unless nrt (module docstring)
        self.link_dispatcher = njit(no_cpython_wrapper=True, no_cfunc_wrapper=True, _nrt=nrt,
                                    pipeline_class=pipeline, **options)(py_func)
        # a constant argument at a call site is typed Literal[int](0), and numba compiles a copy
        # of the callee for each constant: the link dispatcher compiles for the plain types
        self.link_dispatcher.get_call_template = functools.partial(_plain_call_template,
                                                                   self.link_dispatcher.get_call_template)
        try:
            self.link_dispatcher._cache = LinkCache(py_func)
        except RuntimeError:                         # no locator for its file: not cached
            pass
        self._call_dispatcher = None

    @property
    def dispatcher(self):
        """The dispatcher Python calls: numba's own, cached (solver.compile.kernel_cache)."""
        if self._call_dispatcher is None:
            self._call_dispatcher = njit(cache=True, **self._options)(self.py_func)
        return self._call_dispatcher

    def __call__(self, *args, **kwargs):
        return self.dispatcher(*args, **kwargs)

    def __getattr__(self, name):
        if name in DELEGATED:                        # the call dispatcher's; no other name is looked up
            return getattr(self.dispatcher, name)    # there (numba probes globals for "name", ...)
        raise AttributeError(name)

    def __reduce__(self):
        return _kernel_named, (self.py_func.__module__, self.py_func.__qualname__)

    def __repr__(self):
        return f"<solver kernel {self.py_func.__module__}.{self.py_func.__qualname__}>"


def _plain_call_template(get_call_template, args, kws):
    """The link dispatcher's call template for the arguments' plain types (``Literal[int](0)``
    as ``int64``): one copy of a kernel whatever constants its callers pass."""
    return get_call_template(tuple(types.unliteral(a) for a in args),
                             {name: types.unliteral(a) for name, a in kws.items()})


def _kernel_named(module, qualname):
    return getattr(importlib.import_module(module), qualname)


@typeof_impl.register(Kernel)
def _typeof_kernel(value, context):
    """A kernel seen from another kernel is its link dispatcher."""
    return types.Dispatcher(value.link_dispatcher)


def kernel(py_func=None, **options):
    """Decorate a solver function as a Kernel: ``@kernel`` or ``@kernel(fastmath=...)``.

    ``inline`` says how a helper reaches its callers' code:

    * ``"never"`` (the default): compiled once, called; LLVM may still inline it where it pays;
    * ``"llvm"``: compiled once, and LLVM inlines it into every caller when the program is
      optimised (the attribute ``alwaysinline``): the speed of an inlined helper at the compile
      cost of one function;
    * ``"always"``: numba's own inlining, which types and lowers the helper again at every call
      site. Kept for the small helpers of the forcing's innermost loop (model/layer.py,
      model/basis.py), where it measured 2 % faster than ``"llvm"``.

    ``nrt=True`` for a kernel that makes arrays or hands them to its caller (the module
    docstring): numba counts its references. Without it a kernel called from another borrows its
    arrays and counts none. (Python's calls, and numba's ``inline="always"`` helpers, which
    become their callers' code, count as numba always does.)
    """
    options = {**OPTIONS, **options}
    if py_func is None:
        return lambda f: kernel(f, **options)
    inline = options.pop("inline", "never")
    nrt = options.pop("nrt", False)
    if inline not in INLINE:
        raise ValueError(f"kernel {py_func.__qualname__}: inline={inline!r}, not one of {INLINE}")
    if inline == "always":
        return njit(cache=True, inline="always", **options)(py_func)
    if not LINK_ONLY:
        return njit(cache=True, **options)(py_func)
    return Kernel(py_func, options, always_inline=inline == "llvm", nrt=bool(nrt))
