"""Where the compiled kernels are cached, keyed by the source they came from.

numba's own cache stamps each function with a hash of its own file only, while a kernel carries
the functions it calls compiled inside it: ``integrate`` (loop.py) holds the layer's law
(model/law.py), and an edit of the law alone left the old law running from the cache. Here every
kernel of the solver is cached under one directory named by

    key = sha256(every *.py file of the solver package, by relative path and content;
                 numba, llvmlite, numpy and Python versions; the target CPU and its features)

so that any edit of any solver file, an update of numba or another CPU compiles afresh, and two
trees with the same source (an editable install, a wheel, a dask worker, another clone) share
their compiled kernels. The directory is

    $FLOE_IMPACT_KERNEL_CACHE/<key>            if that variable is set,
    $NUMBA_CACHE_DIR/floe-impact/<key>         else if numba's is,
    <the solver package>/__pycache__/kernels/<key>   else if writable,
    ~/.cache/floe-impact/kernels/<key>         else (XDG_CACHE_HOME honoured).

Keys not used recently do not pile up: when a new key's directory is made, only the
``KEEP`` most recently used ones are kept (a process marks its key used at import).
Functions outside the solver package keep numba's own locators.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import sys
from pathlib import Path

import llvmlite
import numba
import numpy
from numba.core import caching, config

#: how many keys (source trees x targets) a cache root keeps
KEEP = 6
PACKAGE = Path(__file__).resolve().parents[1]


def target_cpu() -> tuple:
    """(name, features) of the CPU numba compiles for: NUMBA_CPU_NAME/FEATURES or the host's."""
    from llvmlite import binding
    name = config.CPU_NAME or binding.get_host_cpu_name()
    features = config.CPU_FEATURES if config.CPU_FEATURES is not None else binding.get_host_cpu_features().flatten()
    return name, features


def source_digest(package: Path = PACKAGE) -> str:
    """sha256 of every Python file of the package, by relative path and content."""
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        digest.update(path.relative_to(package).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


def cache_key(package: Path = PACKAGE) -> str:
    """The name of the cache directory: the source, the compiler's versions and the target."""
    name, features = target_cpu()
    versions = f"numba {numba.__version__} llvmlite {llvmlite.__version__} numpy {numpy.__version__} " \
               f"python {sys.version_info[:3]}{getattr(sys, 'abiflags', '')}"
    digest = hashlib.sha256(f"{source_digest(package)}\n{versions}\n{name}\n{features}".encode())
    return f"{name}-{digest.hexdigest()[:20]}"


def _writable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
        return os.access(path, os.W_OK)
    except OSError:
        return False


def cache_root(package: Path = PACKAGE) -> Path:
    """The directory whose subdirectories, one per key, hold the compiled kernels."""
    if os.environ.get("FLOE_IMPACT_KERNEL_CACHE"):
        return Path(os.environ["FLOE_IMPACT_KERNEL_CACHE"])
    if config.CACHE_DIR:
        return Path(config.CACHE_DIR) / "floe-impact"
    in_tree = package / "__pycache__" / "kernels"
    if _writable(in_tree):
        return in_tree
    home = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return home / "floe-impact" / "kernels"


def prune(root: Path, keep: int = KEEP) -> list:
    """Remove all but the `keep` most recently used key directories of root; returns those removed."""
    try:
        entries = [p for p in root.iterdir() if p.is_dir()]
    except OSError:
        return []
    entries.sort(key=lambda p: p.stat().st_mtime, reverse=True)
    for old in entries[keep:]:
        shutil.rmtree(old, ignore_errors=True)
    return entries[keep:]


def open_directory(package: Path = PACKAGE) -> Path:
    """This tree's cache directory, made if new (then older keys are pruned) and marked used."""
    root = cache_root(package)
    path = root / cache_key(package)
    new = not path.is_dir()
    path.mkdir(parents=True, exist_ok=True)
    os.utime(path)
    if new:
        prune(root)
    return path


class SolverCacheLocator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
    """numba's locator for the solver's functions: the keyed directory, the key as the source
    stamp (numba then drops an index written by other source), the file's subpath kept."""

    directory: Path | None = None

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        relative = Path(py_file).resolve().parent.relative_to(PACKAGE)
        self._cache_path = str(self.directory / relative)

    def get_cache_path(self):
        return self._cache_path

    def get_source_stamp(self):
        return self.directory.name

    @classmethod
    def from_function(cls, py_func, py_file):
        if cls.directory is None or not Path(py_file).resolve().is_relative_to(PACKAGE):
            return None
        return super().from_function(py_func, py_file)


#: the file, in a key's directory, that lists the index files compile_kernels left there: a run
#: that finds it (and them) needs no process of its own to fill the cache
COMPLETE = "complete"


def mark_complete() -> None:
    """Record that every entry point of this key is cached (compile_kernels calls it last): the
    list of the index files in the key's directory then, its entry points' among them."""
    directory = SolverCacheLocator.directory
    if directory is None:
        return
    indexes = sorted(p.relative_to(directory).as_posix() for p in directory.rglob("*.nbi"))
    try:
        partial = directory / f"{COMPLETE}.{os.getpid()}"
        partial.write_text("".join(f"{name}\n" for name in indexes))
        os.replace(partial, directory / COMPLETE)
    except OSError:                                  # a read-only cache: each run checks it again
        pass


def is_complete() -> bool:
    """Are this key's kernels all cached: the list compile_kernels wrote, and every index in it?"""
    directory = SolverCacheLocator.directory
    try:
        names = (directory / COMPLETE).read_text().split() if directory is not None else []
    except OSError:
        return False
    return bool(names) and all((directory / name).is_file() for name in names)


def install() -> Path:
    """Put SolverCacheLocator first among numba's locators (before any kernel is defined)."""
    if SolverCacheLocator.directory is None:
        SolverCacheLocator.directory = open_directory()
        impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl     # numba < 0.61: _CacheImpl
        impl._locator_classes.insert(0, SolverCacheLocator)
    return SolverCacheLocator.directory
