r"""The first compile on two cores: a helper process compiles subtrees of ``integrate`` while
this process compiles the rest (docs/performance.md, "The first compile").

numba compiles in one process under one lock. A kernel called from another kernel is compiled
for linking only (solver.compile.jit), and that IR is cached on disk (``LinkCache``), so a second
process can compile part of the call tree and leave it where the first one finds it:

* this process compiles ``integrate`` as usual, from its first line: the work space, the
  initial state (the layer's reaction under the Gauss rule, the largest subtree), and on;
* the helper compiles subtrees this process reaches late (solver.first_compile.helper_jobs): the observers
  (``observe_step``), the step, the event search (it takes steps) and the step's verdict, then the
  crack-onset kernels;
* a function is compiled by one process only: before compiling, a process claims it (a file
  named by the function and its signature, in the key's directory); a process that finds it
  claimed waits for the other's cache entry. The call tree has no cycles, so two processes
  never wait on each other. A claim whose process has ended is taken over.

The helper needs the exact argument types of its subtrees before ``integrate`` is typed:
solver/first_compile.py builds them as ``integrate`` does, from the same tiny case
(compile_kernels' first solve); this module is the machinery only, and knows no kernel.

The code that runs is the same: each function's IR is the same whichever process lowered it,
and ``integrate``'s whole program is optimised once, in this process (``make bit-for-bit``).
``FLOE_IMPACT_COMPILE_HELPER=0`` compiles in one process.
"""
from __future__ import annotations

import contextlib
import hashlib
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
import warnings
from pathlib import Path

from . import jit, kernel_cache

#: set to "0" to compile in one process
ENABLE = "FLOE_IMPACT_COMPILE_HELPER"
#: how long a process waits for a function another process claimed before compiling it itself [s]
PATIENCE = 120.0
#: the claims' subdirectory of the key's directory
CLAIMS = "claims"


class Claims:
    """Who compiles which function: one file per (function, signature), holding the pid."""

    def __init__(self, directory: Path):
        self.directory = directory
        self.held = set()
        directory.mkdir(parents=True, exist_ok=True)

    def path(self, cache, sig, codegen) -> Path:
        name = f"{cache._impl.filename_base}\0{cache._index_key(sig, codegen)!r}"
        return self.directory / hashlib.sha256(name.encode()).hexdigest()[:32]

    def take(self, path: Path) -> bool:
        """Claim path for this process; False if another process holds it."""
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            return False
        os.write(fd, str(os.getpid()).encode())
        os.close(fd)
        self.held.add(path)
        return True

    def holder_alive(self, path: Path) -> bool:
        """Is the process that holds path running (a zombie, ended but not yet reaped, is not)?"""
        try:
            pid = int(path.read_text() or 0)
            if not pid:
                return True                          # being written
            os.kill(pid, 0)
        except (OSError, ValueError):
            return False
        try:
            return Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0] != "Z"
        except (OSError, IndexError):
            return True                              # no /proc: os.kill said it exists

    def load_or_claim(self, cache, sig, target_context):
        """The compile result another process leaves for (cache, sig), or None once this
        process holds the claim (it compiles, and LinkCache.save_overload releases)."""
        path = self.path(cache, sig, target_context.codegen())
        waited = time.monotonic()
        while True:
            cres = cache.load_cached(sig, target_context)
            if cres is not None:
                return cres
            if self.take(path):
                return None
            if not self.holder_alive(path) or time.monotonic() - waited > PATIENCE:
                path.unlink(missing_ok=True)         # its process ended: take it over
                continue
            time.sleep(0.01)

    def release(self, cache, sig, codegen) -> None:
        path = self.path(cache, sig, codegen)
        if path in self.held:
            self.held.discard(path)
            path.unlink(missing_ok=True)

    def release_all(self) -> None:
        """Give up what this process still holds (a compile that raised)."""
        for path in self.held:
            path.unlink(missing_ok=True)
        self.held.clear()



@contextlib.contextmanager
def claiming():
    """Within: this process claims each function it compiles for linking, and waits for those
    another claiming process compiles (the helper, and any process that compiles kernels while
    compile_kernels runs, such as the test suite's warm-up, tests/warm_kernels.py)."""
    directory = kernel_cache.SolverCacheLocator.directory
    if jit.claims is not None or directory is None or os.name != "posix":
        yield
        return
    jit.claims = Claims(directory / CLAIMS)
    try:
        yield
    finally:
        jit.claims.release_all()
        jit.claims = None


def _cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:                            # not Linux
        return os.cpu_count() or 1


@contextlib.contextmanager
def _stop_on_interrupt(process):
    """Within: on Ctrl-C, stop the helper in the signal handler itself, then raise as before.
    Python raises KeyboardInterrupt wherever the compile is, and inside a destructor (llvmlite
    frees its objects in __del__) the exception is printed and dropped, the compile going on.
    Off the main thread no handler can be set, and none is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.getsignal(signal.SIGINT)

    def interrupted(signum, frame):
        process.kill()
        if callable(previous):
            previous(signum, frame)
        elif previous != signal.SIG_IGN:
            raise KeyboardInterrupt
    signal.signal(signal.SIGINT, interrupted)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous if previous is not None else signal.SIG_DFL)


@contextlib.contextmanager
def helper(job):
    """Within: a helper process runs ``job`` (a module-level function, with no arguments, that
    compiles part of the kernels: solver.first_compile.run_helper), and this process claims what
    it compiles. At the end, wait for the helper; on an exception (Ctrl-C among them), stop it."""
    directory = kernel_cache.SolverCacheLocator.directory
    if (os.environ.get(ENABLE, "1") == "0" or os.name != "posix" or not jit.LINK_ONLY or directory is None
            or _cpus() < 2 or jit.claims is not None or kernel_cache.is_complete()):
        yield
        return
    # the helper asks to die with this process before its imports (seconds on a loaded machine):
    # a parent killed while the helper still imported numba left it compiling, orphaned, once in
    # a full suite beside a long study; then it checks that its parent is still this process
    code = ("import os, signal, sys\n"
            "try:\n    import ctypes; ctypes.CDLL(None).prctl(1, signal.SIGTERM)   # PR_SET_PDEATHSIG\n"
            "except (OSError, AttributeError):\n    pass\n"
            f"if os.getppid() != {os.getpid()}:\n    sys.exit(0)\n"
            f"sys.path.insert(0, {str(Path(__file__).resolve().parents[2])!r})\n"
            f"from {job.__module__} import {job.__name__}\n{job.__name__}()\n")
    with tempfile.TemporaryFile() as log:
        process = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.DEVNULL,
                                   stdout=subprocess.DEVNULL, stderr=log)
        try:
            with _stop_on_interrupt(process), claiming():
                yield
        except BaseException:
            process.kill()
            process.wait()
            raise
        if process.wait() != 0:
            log.seek(0)
            last = (log.read().decode(errors="replace").strip().splitlines() or ["no message"])[-1]
            warnings.warn(f"the compile helper process failed (exit {process.returncode}: {last}); "
                          "the kernels compiled in this process", RuntimeWarning, stacklevel=3)
