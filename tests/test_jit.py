"""How the kernels compile (solver/compile/jit.py): a kernel called from another kernel is compiled for
linking only (no machine code; its IR cached for linking), the entry point Python calls is
optimised and cached whole, and a warm process compiles nothing."""
import os
import pickle
import subprocess
import sys
import textwrap
from pathlib import Path

import solver
from solver.compile.jit import Kernel, LinkOnlyLibrary

ROOT = Path(__file__).resolve().parents[1]

#: a kernel tree of three levels, and a probe that reports how each level was compiled
TREE = textwrap.dedent("""
    import numpy as np
    from solver.compile.jit import kernel

    @kernel
    def leaf(x, out):
        for i in range(out.shape[0]):
            out[i] = x * (i + 1.0)
        return out.sum()

    @kernel(inline="llvm")
    def middle(x, out):
        return leaf(x, out) + 1.0

    @kernel
    def top(x, n):
        out = np.empty(n)
        return middle(x, out) * 2.0
""")

PROBE = textwrap.dedent("""
    import json, sys
    sys.path.insert(0, sys.argv[1])
    import tree
    value = tree.top(1.5, 4)
    libraries = {name: [type(cres.library).__name__ for cres in getattr(tree, name).link_dispatcher.overloads.values()]
                 for name in ("leaf", "middle")}
    def attributes(name):
        return [sorted(str(a) for a in cres.library._final_module.get_function(cres.fndesc.mangled_name).attributes)
                for cres in getattr(tree, name).link_dispatcher.overloads.values()]
    names = {name: [cres.fndesc.mangled_name for cres in getattr(tree, name).link_dispatcher.overloads.values()]
             for name in ("leaf", "middle")}
    top_ir = "".join(tree.top.inspect_llvm().values())
    called = {name: any(f"@{m}(" in line for m in names[name] for line in top_ir.splitlines() if " call " in line)
              for name in names}
    print(json.dumps({"value": value, "link": libraries,
                      "always_inline": {n: any("alwaysinline" in a for a in attributes(n)[0]) if names[n] else None
                                        for n in ("leaf", "middle")},
                      "called_in_top": called,
                      "top_hits": sum(tree.top.stats.cache_hits.values()),
                      "link_hits": {n: sum(getattr(tree, n).link_dispatcher.stats.cache_hits.values())
                                    for n in ("leaf", "middle")},
                      "called_from_python": [n for n in ("leaf", "middle") if getattr(tree, n)._call_dispatcher]}))
""")


def _probe(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT), NUMBA_CACHE_DIR=str(tmp_path / "numba-cache"))
    proc = subprocess.run([sys.executable, "-c", PROBE, str(tmp_path)], env=env, capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    import json
    return json.loads(proc.stdout)


def test_callees_compile_for_linking_only_and_a_warm_process_compiles_nothing(tmp_path):
    """First process: the entry point runs (value exact), its callees are link-only libraries and
    never got a Python-callable dispatcher. Second process: the entry point comes from the cache
    and no callee is compiled at all (the cached entry point carries their code). Third process,
    the entry point's own cache entry removed: the link-only libraries are cached as IR
    (solver.compile.jit.LinkCache), so it types none of its callees, it loads and links them, and
    computes the same value (so a second process can compile part of a tree:
    solver/compile/parallel_compile.py)."""
    (tmp_path / "tree.py").write_text(TREE)
    expected = 2.0 * (1.5 * (1 + 2 + 3 + 4) + 1.0)
    cold = _probe(tmp_path)
    assert cold["value"] == expected
    assert cold["link"] == {"leaf": ["LinkOnlyLibrary"], "middle": ["LinkOnlyLibrary"]}
    assert cold["top_hits"] == 0 and cold["called_from_python"] == []
    # middle is inline="llvm": marked alwaysinline, and no call to it is left in the program
    assert cold["always_inline"] == {"leaf": False, "middle": True}
    assert cold["called_in_top"]["middle"] is False
    warm = _probe(tmp_path)
    assert warm["value"] == expected and warm["top_hits"] == 1
    assert warm["link"] == {"leaf": [], "middle": []}
    entry = list((tmp_path / "numba-cache").rglob("tree.top-*"))
    assert entry and all(not path.name.startswith("link-") for path in entry)
    for path in entry:
        path.unlink()
    again = _probe(tmp_path)
    assert again["value"] == expected and again["top_hits"] == 0
    # middle comes from the cache with leaf's code linked in: leaf is not even looked up
    assert again["link_hits"] == {"leaf": 0, "middle": 1}
    assert again["link"] == {"leaf": [], "middle": ["LinkOnlyLibrary"]}
    assert again["always_inline"]["middle"] is True and again["called_in_top"]["middle"] is False


def test_a_kernel_called_from_python_gets_numbas_own_dispatcher():
    """An inner kernel called from Python (a test, the DOP853 reference) is compiled whole, with
    machine code, as numba compiles any function; it computes what its Python source does."""
    from solver.model.plate import mode_a
    from solver.loop import integrate
    assert isinstance(mode_a, Kernel) and isinstance(integrate, Kernel)
    plate = solver.core.Tables(solver.Parameters(Nmod=1), 16, False, "paper", 4).model.plate
    z = 0.3 + 0.4j
    assert mode_a(z, 0, plate) == mode_a.py_func(z, 0, plate)
    assert mode_a.signatures
    assert not any(isinstance(cres.library, LinkOnlyLibrary) for cres in mode_a.dispatcher.overloads.values())


def test_an_unknown_inline_mode_is_refused_by_name():
    from solver.compile.jit import kernel
    try:
        kernel(inline="sometimes")(lambda x: x)
    except ValueError as error:
        assert "inline='sometimes'" in str(error) and "llvm" in str(error)
    else:
        raise AssertionError("inline='sometimes' was accepted")


def test_this_numba_has_what_a_link_only_library_needs():
    """Where numba lacks an internal the link-only library uses, kernels fall back to numba's
    plain dispatcher; on the numba the project installs they must not."""
    from solver.compile import jit
    assert jit.LINK_ONLY


def test_a_kernel_pickles_as_a_reference_to_itself():
    from solver.loop import integrate
    assert pickle.loads(pickle.dumps(integrate)) is integrate


#: kernels that borrow their arrays and kernels that count references (solver/compile/jit.py)
BORROWING = textwrap.dedent("""
    import numpy as np
    from solver.compile.jit import kernel

    def _sum_pair(pair):
        total = 0.0
        for i in range(pair[0].shape[0]):
            first = pair[0]
            second = pair[1]
            total += first[i] * second[i]
        return total

    borrowing = kernel(_sum_pair)
    counting = kernel(nrt=True)(_sum_pair)

    @kernel
    def top(n):
        x = np.arange(n) * 1.0
        pair = (x, x + 1.0)
        return borrowing(pair) + counting(pair)

    @kernel
    def hands_on(x):
        return x                # numba accepts it without reference counting; the caller would decref it

    @kernel
    def top_hands(n):
        return hands_on(np.ones(n)).sum()

    @kernel(nrt=True)
    def makes(n):
        return np.ones(n)

    @kernel
    def takes(n):
        return makes(n).sum()

    @kernel
    def top_takes(n):
        return takes(n)

    @kernel
    def allocates(n):
        return np.ones(n).sum()

    @kernel
    def top_allocates(n):
        return allocates(n)
""")

BORROWING_PROBE = textwrap.dedent("""
    import json, sys
    sys.path.insert(0, sys.argv[1])
    import borrowing_tree as tree

    def refusal(entry):
        try:
            getattr(tree, entry)(4)
        except Exception as error:
            return type(error).__name__, str(error)
        return None, ""

    value = tree.top(4)
    print(json.dumps({"value": value,
                      "counted": {name: getattr(tree, name).link_dispatcher.targetoptions.get("_nrt", True)
                                  for name in ("borrowing", "counting")},
                      "hands_on": refusal("top_hands"), "takes": refusal("top_takes"),
                      "allocates": refusal("top_allocates")}))
""")


def test_a_borrowing_kernel_counts_no_references_and_one_that_hands_arrays_on_is_refused_by_name(tmp_path):
    """A kernel called from another borrows its arrays: it is compiled without numba's reference
    counting, where the same function as @kernel(nrt=True) is compiled with it; both compute what
    Python does. A borrowing kernel that returns an array, or takes one from a kernel, is refused
    by its name when it compiles, and numba's typing refuses one that makes an array (a wrong mark
    is a compile error, not a freed array)."""
    import json
    (tmp_path / "borrowing_tree.py").write_text(BORROWING)
    env = dict(os.environ, PYTHONPATH=str(ROOT), NUMBA_CACHE_DIR=str(tmp_path / "numba-cache"))
    proc = subprocess.run([sys.executable, "-c", BORROWING_PROBE, str(tmp_path)], env=env, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    probe = json.loads(proc.stdout)
    x = [0.0, 1.0, 2.0, 3.0]
    assert probe["value"] == 2.0 * sum(v * (v + 1.0) for v in x)
    assert probe["counted"] == {"borrowing": False, "counting": True}
    kind, message = probe["hands_on"]
    assert kind == "KernelNeedsNRT" and "hands_on returns" in message and "nrt=True" in message
    kind, message = probe["takes"]
    assert kind == "KernelNeedsNRT" and "takes takes" in message and "from makes" in message
    kind, message = probe["allocates"]
    assert kind == "TypingError" and "ones" in message
