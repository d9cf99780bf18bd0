"""The structure docs/architecture.md describes, held: no import circles in solver/ and pipeline/,
the solver's files and kernels small, the solver free of files, xarray, dask and plots, and the
command line a parser that calls one function per command."""
import ast
import re
import subprocess
from pathlib import Path

import pytest

from architecture_numbers import numbers, page_block

ROOT = Path(__file__).resolve().parents[1]
#: the loop is the one kernel allowed to be about a page
LOOP = ("loop.py", "integrate")


def _modules(package: str) -> dict:
    """module name -> (path, parsed source) of every module of a package."""
    out = {}
    for path in sorted((ROOT / package).rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = (path, ast.parse(path.read_text()))
    return out


def _imports(name: str, path: Path, tree, known) -> set:
    """The modules of known that a module imports, at its top or inside a function."""
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    deps = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                prefix = package[:len(package) - (node.level - 1)]
                base = ".".join(prefix + ([node.module] if node.module else []))
            # "from . import layout" imports the module layout, not its package
            targets = [f"{base}.{a.name}" for a in node.names] + ([base] if node.module else [])
        elif isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        else:
            continue
        deps.update(t for t in targets if t in known and t != name)
    return deps


def _cycles(graph: dict) -> list:
    """The strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, found, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def test_no_module_imports_another_in_a_circle():
    modules = {**_modules("solver"), **_modules("pipeline")}
    graph = {name: _imports(name, path, tree, modules) for name, (path, tree) in modules.items()}
    assert _cycles(graph) == []
    # the check finds a circle where there is one
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


#: pipeline's stages in the order a study passes through them; a module imports only its own
#: stage and the stages before it. The doors (cli, api, run, show, report, console, the search's
#: rounds) are the package's top level and come last.
STAGES = ("common", "study", "store", "compute", "analyse", "figures")


def _stage(module: str) -> int:
    parts = module.split(".")
    if parts[0] == "solver":
        return -1
    return STAGES.index(parts[1]) if len(parts) > 2 or (len(parts) == 2 and parts[1] in STAGES) \
        else len(STAGES)


def _climbing(graph: dict) -> list:
    """The imports of a pipeline module from a stage after its own, as 'importer -> imported'."""
    return sorted(f"{name} -> {dep}" for name, deps in graph.items() if name.startswith("pipeline")
                  for dep in deps if _stage(dep) > _stage(name))


def test_each_stage_imports_only_the_stages_before_it():
    """common -> study (the file's checked cases) -> store (batch files, study.nc) -> compute
    (workers) -> analyse -> figures -> the doors: a stage never imports one after it, at its top
    or inside a function (the study definition imported the figures' registry, and the
    analysis' rules the surrogate)."""
    modules = {**_modules("solver"), **_modules("pipeline")}
    graph = {name: _imports(name, path, tree, modules) for name, (path, tree) in modules.items()}
    assert _climbing(graph) == []
    assert {name.split(".")[1] for name in modules if name.startswith("pipeline.") and name.count(".") >= 2} \
        == set(STAGES)
    # the check finds an import that climbs
    assert _climbing({"pipeline.study.x": {"pipeline.figures.y", "pipeline.common.z"}}) == \
        ["pipeline.study.x -> pipeline.figures.y"]
    assert _climbing({"pipeline.store.x": {"pipeline.run"}}) == ["pipeline.store.x -> pipeline.run"]


def test_the_plot_kinds_a_study_names_are_the_ones_drawn():
    from pipeline.figures import KINDS
    from pipeline.study.definition import PLOT_KINDS
    assert tuple(KINDS) == PLOT_KINDS


def _is_kernel(node) -> bool:
    """A numba kernel: decorated @kernel (solver.compile.jit), @njit or @numba.njit, with or without
    arguments (the test once looked for "njit" alone and, every kernel being @kernel, examined none)."""
    for decorator in node.decorator_list:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
        if name in ("kernel", "njit", "jit"):
            return True
    return False


def test_the_kernel_check_finds_every_kind_of_kernel():
    found = [_is_kernel(f) for f in ast.parse(
        "@kernel\ndef a(): pass\n@njit(cache=True)\ndef b(): pass\n@numba.njit\ndef c(): pass\n"
        "@lru_cache\ndef d(): pass\ndef e(): pass").body]
    assert found == [True, True, True, False, False]
    kernels = [node.name for _, (path, tree) in _modules("solver").items() for node in ast.walk(tree)
               if isinstance(node, ast.FunctionDef) and _is_kernel(node)]
    assert len(kernels) > 100 and "integrate" in kernels and "observe_zone" in kernels


def test_the_solvers_files_and_kernels_are_small():
    """No solver file above 600 lines; no numba kernel above 80 lines or 10 parameters, the loop
    excepted (about a page)."""
    big = []
    for name, (path, tree) in _modules("solver").items():
        lines = path.read_text().count("\n")
        if lines > 600:
            big.append(f"{path.name}: {lines} lines")
        for node in ast.walk(tree):
            if not isinstance(node, ast.FunctionDef) or not _is_kernel(node):
                continue
            length, params = node.end_lineno - node.lineno + 1, len(node.args.args)
            limit = 130 if (path.name, node.name) == LOOP else 80
            if length > limit or params > 10:
                big.append(f"{path.name}:{node.name}: {length} lines, {params} parameters")
    assert big == []


def _anonymous_tuples(trees: dict) -> list:
    """Where a kernel takes an anonymous tuple: it unpacks a parameter by position (``a, b = ends``),
    or passes a tuple display, or a name bound to one, to another kernel. A named tuple is read by
    its fields' names."""
    functions = [node for tree in trees.values() for node in ast.walk(tree)
                 if isinstance(node, ast.FunctionDef) and _is_kernel(node)]
    kernels, found = {f.name for f in functions}, []
    for f in functions:
        params = {a.arg for a in f.args.args}
        tupled = set()
        for node in ast.walk(f):
            if not isinstance(node, ast.Assign):
                continue
            for target in node.targets:
                if isinstance(target, ast.Tuple) and isinstance(node.value, ast.Name) and node.value.id in params:
                    found.append(f"{f.name} unpacks {node.value.id}")
                pairs = zip(target.elts, node.value.elts) if isinstance(target, ast.Tuple) and isinstance(
                    node.value, ast.Tuple) else [(target, node.value)]
                tupled |= {name.id for name, value in pairs if isinstance(name, ast.Name) and isinstance(value, ast.Tuple)}
        for call in ast.walk(f):
            if isinstance(call, ast.Call) and isinstance(call.func, ast.Name) and call.func.id in kernels:
                found += [f"{f.name} passes {ast.unparse(a)[:40]} to {call.func.id}" for a in call.args
                          if isinstance(a, ast.Tuple) or (isinstance(a, ast.Name) and a.id in tupled)]
    return sorted(set(found))


def test_kernels_take_named_tuples_not_anonymous_ones():
    """A tuple that crosses between kernels is a named tuple, read by its fields' names (26 kernels
    unpacked anonymous tuples of 3 to 10 items to stay under the parameter cap)."""
    assert _anonymous_tuples({name: tree for name, (_, tree) in _modules("solver").items()}) == []
    # the check finds each way of taking one
    fake = ast.parse("@kernel\ndef f(x, ends):\n    a, b = ends\n    zone = (a, b)\n    g(x, (a, b))\n    g(x, zone)\n"
                     "    g(x, P(a, b))\n@kernel\ndef g(x, y):\n    return y.lo\n")
    assert _anonymous_tuples({"m": fake}) == ["f passes (a, b) to g", "f passes zone to g", "f unpacks ends"]


@pytest.mark.parametrize("forbidden", ["xarray", "dask", "matplotlib", "netCDF4", "pipeline"])
def test_the_solver_is_pure_numerics(forbidden):
    for name, (path, tree) in _modules("solver").items():
        for node in ast.walk(tree):         # at its top or inside a function: the solver knows no runner
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level else [])
            assert not any(n.split(".")[0] == forbidden for n in names), f"{path.name} imports {forbidden}"


def test_the_command_line_parses_and_calls_one_function_per_command():
    """cli.py holds the parser, one function per command, the results-directory lookup they share,
    and main (exit statuses); the run itself is pipeline.run.run_study."""
    _, tree = _modules("pipeline")["pipeline.cli"]
    functions = [n.name for n in tree.body if isinstance(n, ast.FunctionDef)]
    assert set(functions) == {"_parser", "command_run", "command_status", "command_show", "study_and_results",
                              "main"}
    run = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "command_run")
    assert "run_study" in ast.unparse(run) and run.end_lineno - run.lineno < 25


def _picture_files(picture: str) -> list:
    """The files a picture places, as paths: each line starts with the names it places (``a.py``,
    ``a.py, b.py`` or ``folder/``), indented two spaces per folder level; what follows two
    spaces is their description, and a line that starts with neither continues one."""
    placed, folders = [], []
    for line in picture.splitlines():
        names = re.match(r"^( *)((?:\w+\.py|\w+/)(?:, \w+\.py)*)(?=\s|$)", line)
        if not names:
            continue
        depth = len(names.group(1)) // 2
        folders = folders[:depth]
        for name in names.group(2).split(", "):
            if name.endswith("/"):
                folders.append(name[:-1])
            else:
                placed.append("/".join([*folders, name]))
    return placed


def test_the_architecture_picture_is_the_layout():
    """docs/architecture.md's picture (its first code block) places every module of solver/ and
    pipeline/ in its folder, and only modules that are there: a new module is placed in it, a
    moved one moved (it listed neither the floe, the zone, the compile modules nor the analysis
    modules once, and only by name)."""
    picture = (ROOT / "docs" / "architecture.md").read_text().split("```")[1]
    placed = _picture_files(picture)
    files = sorted(path.relative_to(ROOT).as_posix() for package in ("solver", "pipeline")
                   for path in (ROOT / package).rglob("*.py") if path.name not in ("__init__.py", "__main__.py"))
    assert sorted(set(placed) - set(files)) == [], "the picture places files that are not there"
    assert sorted(set(files) - set(placed)) == [], "the picture does not place these files"
    # the reader: folders by indentation, several names on a line, descriptions ignored
    assert _picture_files("a/   x\n  b.py, c.py   d.py\n  e/\n    f.py\n          more on f, g.py\n  h.py") == \
        ["a/b.py", "a/c.py", "a/e/f.py", "a/h.py"]


def test_tests_share_helpers_only_through_helpers_and_conftest():
    """A test file imports what it shares with others from tests/helpers.py or gets it from
    tests/conftest.py's fixtures, never from another test file (17 files once took theirs from
    test_pipeline.py: running one file alone then ran the other's module-level code)."""
    importing = []
    for path in sorted((ROOT / "tests").glob("test_*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            names = [node.module or ""] if isinstance(node, ast.ImportFrom) else \
                [alias.name for alias in node.names] if isinstance(node, ast.Import) else []
            if any(name.startswith("test_") for name in names):
                importing.append(path.name)
    assert not importing, f"these test files import from another test file: {sorted(set(importing))}"


def test_the_layout_slots_are_literal_names_generated_from_their_tables():
    """solver/layout.py's D_*, R_*, S_* are literal assignments (a grep finds D_MAX_FORCE; they
    were made by globals().update) and are exactly what solver.outputs generates from its tables
    (``make layout-slots`` rewrites them after a table changes)."""
    from solver import layout, outputs
    text = (ROOT / "solver" / "layout.py").read_text()
    assert outputs.layout_slots() in text, "solver/layout.py's slots differ from solver.outputs: make layout-slots"
    assert "globals()" not in text and "\nD_MAX_FORCE = " in text
    for prefix, slots, count in outputs.LAYOUT_TABLES:
        assert [getattr(layout, f"{prefix}_{slot}") for slot in slots] == list(range(len(slots)))
        assert getattr(layout, count) == len(slots)


def _private_imports(modules: dict) -> list:
    """'module: name' for each name with a leading underscore that a module of the project
    imports from another (dunders like __version__ excepted)."""
    found = []
    for name, (path, tree) in modules.items():
        for node in ast.walk(tree):
            internal = isinstance(node, ast.ImportFrom) and (node.level or (node.module or "").split(".")[0]
                                                              in ("solver", "pipeline"))
            if internal:
                found += [f"{name}: {a.name}" for a in node.names
                          if a.name.startswith("_") and not a.name.startswith("__")]
    return sorted(found)


def test_no_module_imports_another_modules_private_names():
    """What a module shares is public; its underscore names are its own (the parallel compile
    imported the loop's _judge, _observe and _workspace; the runner the report's _count)."""
    assert _private_imports({**_modules("solver"), **_modules("pipeline")}) == []
    assert _private_imports({"m": (None, ast.parse("from .a import _b, c, __version__\nfrom numpy import _x"))}) \
        == ["m: _b"]


def test_the_layout_block_names_every_folder():
    """docs/architecture.md's Layout block (its last code block) names folders that exist, and
    every folder of the repository that git tracks files in, down to solver/'s and pipeline/'s
    subpackages (it listed neither the floe, the zone nor the compile modules once)."""
    text = (ROOT / "docs" / "architecture.md").read_text()
    block = text.split("## Layout", 1)[1].split("```")[1]
    named = {m.group(1) for m in re.finditer(r"^([\w.]+(?:/[\w.]+)*)/\s", block, re.M)}
    assert sorted(name for name in named if not (ROOT / name).is_dir()) == []
    tracked = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True).stdout.split()
    folders = {path.split("/")[0] for path in tracked if "/" in path}
    folders |= {str(Path(path).parent) for path in tracked if path.startswith(("solver/", "pipeline/"))
                and path.endswith("/__init__.py")}
    assert sorted(folders - named) == [], "the Layout block does not name these folders"



#: the libraries a command that does not need them should not pay for (numba too: the doors
#: answer a bad argument at once); an import of the project's own may wait inside a function
#: only to spare its module one of them
HEAVY = ("numba", "xarray", "dask", "distributed", "matplotlib", "scipy", "netCDF4", "openturns", "SALib",
         "dask_jobqueue")


def _top_imports(name, path, tree, known) -> tuple:
    """(the modules of known, the heavy libraries) a module imports when it is imported: its
    top-level statements, an if/try at its top included, functions and classes' methods not."""
    statements = [node for top in tree.body if not isinstance(top, (ast.FunctionDef, ast.ClassDef))
                  for node in ast.walk(top)]
    own = _imports(name, path, ast.Module(body=[s for s in statements if isinstance(s, (ast.Import, ast.ImportFrom))],
                                          type_ignores=[]), known)
    heavy = {a.name.split(".")[0] for s in statements if isinstance(s, ast.Import) for a in s.names}
    heavy |= {s.module.split(".")[0] for s in statements if isinstance(s, ast.ImportFrom) and s.module and not s.level}
    return own, heavy & set(HEAVY)


def _heavy_at_import(modules: dict) -> dict:
    """module -> the heavy libraries importing it loads (its packages' __init__ and what they and
    it import at their tops, transitively)."""
    top = {name: _top_imports(name, path, tree, modules) for name, (path, tree) in modules.items()}
    edges = {name: [m for m in [*(".".join(name.split(".")[:i]) for i in range(1, name.count(".") + 1)),
                                *top[name][0]] if m in top] for name in top}

    def loads(name):
        seen, todo = {name}, [name]
        while todo:
            for m in edges[todo.pop()]:
                if m not in seen:
                    seen.add(m)
                    todo.append(m)
        return set().union(*(top[m][1] for m in seen))
    return {name: loads(name) for name in modules}


def _deferred_for_nothing(modules: dict) -> list:
    """The imports of the project's own inside a function that spare their module no heavy library."""
    heavy, found = _heavy_at_import(modules), []
    for name, (path, tree) in modules.items():
        for function in (n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))):
            for node in (n for n in ast.walk(function) if isinstance(n, (ast.Import, ast.ImportFrom))):
                deps = _imports(name, path, ast.Module(body=[node], type_ignores=[]), modules)
                if deps and not set().union(*(heavy[d] for d in deps)) - heavy[name]:
                    found.append(f"{name}.{function.name}: {ast.unparse(node)}")
    return sorted(set(found))


def test_an_import_waits_inside_a_function_only_to_spare_a_heavy_library():
    """Imports sit at a module's top, so a reader sees what it depends on; one of the project's
    own waits inside a function only where the module it names loads numba, xarray, dask,
    matplotlib, scipy or OpenTURNS and its own module does not (31 waited for nothing, among them
    the study checks' imports of solver, which those modules import at their tops anyway)."""
    modules = {**_modules("solver"), **_modules("pipeline")}
    assert _deferred_for_nothing(modules) == []
    # the check finds one that waits for nothing, and lets one that spares a library wait
    fake = {"p": (Path("p/__init__.py"), ast.parse("")),
            "p.light": (Path("p/light.py"), ast.parse("import json\ndef f():\n    from . import heavy\n    from . import other")),
            "p.other": (Path("p/other.py"), ast.parse("X = 1")),
            "p.heavy": (Path("p/heavy.py"), ast.parse("import xarray"))}
    assert _deferred_for_nothing(fake) == ["p.light.f: from . import other"]


def _shadowed(tree) -> list:
    """The names a module imports at its top and defines again there (a def, class or assignment)."""
    imported = {a.asname or a.name.split(".")[0] for node in tree.body if isinstance(node, (ast.Import, ast.ImportFrom))
                for a in node.names}
    defined = [node.name for node in tree.body if isinstance(node, (ast.FunctionDef, ast.ClassDef))]
    defined += [t.id for node in tree.body if isinstance(node, ast.Assign) for t in node.targets
                if isinstance(t, ast.Name)]
    return sorted(set(defined) & imported)


def test_no_module_defines_a_name_it_imports():
    """A name imported at a module's top is not defined there again: the batch system's own
    check(kind, directory) shadowed the interrupts' check() once its import moved to the top,
    and only the cluster tests saw the TypeError."""
    found = [f"{name}: {', '.join(names)}" for name, (_, tree) in {**_modules("solver"), **_modules("pipeline")}.items()
             if (names := _shadowed(tree))]
    assert found == []
    assert _shadowed(ast.parse("from .a import check, x\nimport numpy as np\ndef check(kind): pass\nnp = 1")) == \
        ["check", "np"]


def test_the_doors_import_no_heavy_library():
    """`import pipeline` and the command line's modules import neither numba nor xarray, dask,
    matplotlib or scipy: a bad argument or --help is answered at once (an import moved to a
    module's top is one that costs it no new library; docs/architecture.md)."""
    import sys
    code = ("import sys, importlib\nfor m in ('pipeline', 'pipeline.cli', 'pipeline.api', 'pipeline.run', "
            "'pipeline.show', 'pipeline.report'):\n    importlib.import_module(m)\n"
            "print(sorted(h for h in ('numba', 'xarray', 'dask', 'distributed', 'matplotlib', 'scipy', 'netCDF4') "
            "if h in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_the_reference_integrator_runs_the_kernels_observers():
    """One set of observers: the DOP853 reference (solver/scipy_reference.py) calls the loop's
    observe_step and defines no observer of its own: it imports no peak finder, no Hermite, and
    none of solver.observe's observers (its tension module's Dense, and dense_given, which sets the
    marks of the dense states it gives)."""
    modules = _modules("solver")
    path, tree = modules["solver.scipy_reference"]
    imported = {(node.module, a.name) for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                for a in node.names}
    assert ("loop", "observe_step") in imported
    assert not {name for module, name in imported if module and module.startswith("observe.")} - {
        "dense_given", "Dense"}
    assert not {name for _, name in imported} & {"global_peak", "field_sum", "node_strain", "hermite", "cubic_max",
                                                  "observe_zone", "observe_body", "observe_tensions"}


def test_the_pages_numbers_are_the_codes():
    """docs/architecture.md's numbers of the code's shape (the sizes of solve, run_case, the loop,
    the largest kernel and file, the keys of a Result's extra, the imports inside functions) are
    those tests/architecture_numbers.py reads from the source now: make architecture-numbers
    rewrites them after a change."""
    assert page_block() == numbers(), "docs/architecture.md's numbers are stale: run make architecture-numbers"
