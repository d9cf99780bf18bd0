"""The numbers docs/architecture.md gives of the code's shape, read from the source (python's ast):
printed by ``python tests/architecture_numbers.py``, written into docs/architecture.md between its
markers by ``--write`` (``make architecture-numbers``), and held to the page by
tests/test_architecture.py: a number typed by hand goes stale within days (19 statements of the page
contradicted the code on 2026-12-06)."""
from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "architecture.md"
BEGIN = "<!-- numbers: make architecture-numbers writes this block; tests/test_architecture.py checks it -->"
END = "<!-- end of the numbers -->"


def _trees(package: str) -> dict:
    return {path: ast.parse(path.read_text()) for path in sorted((ROOT / package).rglob("*.py"))}


def _is_kernel(node) -> bool:
    return any((isinstance(d, ast.Name) and d.id == "kernel") or
               (isinstance(d, ast.Call) and isinstance(d.func, ast.Name) and d.func.id == "kernel")
               for d in node.decorator_list)


def _function(trees: dict, file: str, name: str):
    tree = next(t for p, t in trees.items() if p.name == file)
    return next(n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.ClassDef)) and n.name == name)


def _lines(node) -> int:
    return node.end_lineno - node.lineno + 1


def _extra_keys(trees: dict) -> set:
    """The string keys a module reads or writes of a Result's extra: extra["key"], extra.get("key"),
    "key" in ...extra."""
    keys = set()
    for tree in trees.values():
        for node in ast.walk(tree):
            if isinstance(node, ast.Subscript) and isinstance(node.value, (ast.Attribute, ast.Name)) and \
                    (getattr(node.value, "attr", None) == "extra" or getattr(node.value, "id", None) == "extra") and \
                    isinstance(node.slice, ast.Constant) and isinstance(node.slice.value, str):
                keys.add(node.slice.value)
            elif isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "extra" for t in node.targets) \
                    and isinstance(node.value, ast.Dict):
                keys |= {k.value for k in node.value.keys if isinstance(k, ast.Constant)}
            elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "get" and \
                    isinstance(node.func.value, ast.Attribute) and node.func.value.attr == "extra" and node.args and \
                    isinstance(node.args[0], ast.Constant):
                keys.add(node.args[0].value)
    return keys


def _deferred_imports(trees: dict) -> tuple:
    """(imports of the project's own, of libraries) that sit inside a function."""
    own = libraries = 0
    for tree in trees.values():
        for top in tree.body:
            if not isinstance(top, (ast.FunctionDef, ast.ClassDef)):
                continue
            for node in ast.walk(top):
                if isinstance(node, ast.ImportFrom):
                    if node.level or (node.module or "").split(".")[0] in ("solver", "pipeline"):
                        own += 1
                    else:
                        libraries += 1
                elif isinstance(node, ast.Import):
                    for alias in node.names:
                        if alias.name.split(".")[0] in ("solver", "pipeline"):
                            own += 1
                        else:
                            libraries += 1
    return own, libraries


def numbers() -> str:
    """The block of numbers, as the page holds it (markdown lines)."""
    solver, pipeline = _trees("solver"), _trees("pipeline")
    solve, run_case = _function(solver, "core.py", "solve"), _function(solver, "run.py", "run_case")
    result = _function(solver, "run.py", "Result")
    fields = [n for n in result.body if isinstance(n, ast.AnnAssign)]
    keywords = len(solve.args.args) + len(solve.args.kwonlyargs)
    kernels = sorted(((_lines(n), len(n.args.args), p.name, n.name) for p, t in solver.items() for n in ast.walk(t)
                      if isinstance(n, ast.FunctionDef) and _is_kernel(n)), reverse=True)
    loop = next(k for k in kernels if k[3] == "integrate")
    other = next(k for k in kernels if k[3] != "integrate")
    most = max(k[1] for k in kernels)
    widest = sorted(k[3] for k in kernels if k[1] == most)
    files = sorted(((p.read_text().count("\n"), str(p.relative_to(ROOT))) for p in [*solver, *pipeline]), reverse=True)
    extra = sorted(_extra_keys(solver) | _extra_keys(pipeline))
    own, libraries = _deferred_imports({**solver, **pipeline})
    lines = [
        f"- `solve` takes {keywords} keywords ({_lines(solve)} lines with its docstring); `run_case` is "
        f"{_lines(run_case)} lines; a `Result` has {len(fields)} fields.",
        f"- The loop's `integrate` is {loop[0]} lines (its cap 130) and takes {loop[1]} parameters; the next largest "
        f"kernel is `{other[3]}` ({other[0]} lines, {other[2]}); the most parameters a kernel takes is {most} "
        f"({len(widest)} kernels of {len(kernels)} take that many).",
        f"- The largest file is `{files[0][1]}` ({files[0][0]} lines), then `{files[1][1]}` ({files[1][0]}).",
        f"- {len(extra)} keys of a Result's `extra` are read or written in solver/ and pipeline/: "
        f"{', '.join(f'`{k}`' for k in extra)}.",
        f"- {own + libraries} imports sit inside a function: {own} of the project's own, {libraries} of libraries.",
    ]
    return "\n".join(lines)


def page_block() -> str | None:
    """The block the page holds now (None: no markers)."""
    text = PAGE.read_text()
    match = re.search(re.escape(BEGIN) + r"\n(?:(.*?)\n)?" + re.escape(END), text, re.S)
    return match.group(1) if match else None


def write() -> bool:
    """Write the numbers into the page; returns whether it changed."""
    text = PAGE.read_text()
    new = re.sub(re.escape(BEGIN) + r"\n(?:.*?\n)?" + re.escape(END), lambda _: f"{BEGIN}\n{numbers()}\n{END}", text,
                 flags=re.S)
    if new != text:
        PAGE.write_text(new)
    return new != text


if __name__ == "__main__":
    if "--write" in sys.argv:
        print("docs/architecture.md", "rewritten" if write() else "unchanged")
    else:
        print(numbers())
