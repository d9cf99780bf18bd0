"""What every result file carries: package version, git commit, library versions, host, date."""
from __future__ import annotations

import datetime as _dt
import importlib.metadata
import platform
import socket
import subprocess
from functools import lru_cache
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
LIBRARIES = ("numpy", "numba", "xarray", "netCDF4", "dask", "distributed", "matplotlib")


def package_version() -> str:
    try:
        return importlib.metadata.version("floe-impact")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


@lru_cache(maxsize=1)
def git_state() -> tuple:
    """(commit, dirty) of the source tree, ("unknown", False) outside a git checkout."""
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=REPO, capture_output=True,
                                text=True, timeout=10, check=True).stdout.strip()
        status = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=REPO,
                                capture_output=True, text=True, timeout=10, check=True).stdout
        return commit, bool(status.strip())
    except (OSError, subprocess.SubprocessError):
        return "unknown", False


#: the CF conventions every result file declares (CF-1.9 and later allow its int64 counts)
CONVENTIONS = "CF-1.11"


def attributes(action: str = "written") -> dict:
    """netCDF global attributes describing the software and the machine, with CF's
    ``Conventions`` and a ``history`` line saying when and by what the file was written
    (``action``: what was done, e.g. "ran study speed_sweep")."""
    commit, dirty = git_state()
    created = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    attrs = {
        "Conventions": CONVENTIONS,
        "history": f"{created}: {action} by floe-impact {package_version()} (git {commit[:12]}"
                   f"{', with uncommitted changes' if dirty else ''})",
        "floe_impact_version": package_version(),
        "git_commit": commit,
        "git_dirty": int(dirty),
        "python_version": platform.python_version(),
        "host": socket.gethostname(),
        "created": created,
    }
    attrs.update(cpu_attributes())
    attrs.update(solver_attributes())
    for lib in LIBRARIES:
        try:
            attrs[f"version_{lib}"] = importlib.metadata.version(lib)
        except importlib.metadata.PackageNotFoundError:
            attrs[f"version_{lib}"] = "not installed"
    return attrs


@lru_cache(maxsize=1)
def solver_attributes() -> dict:
    """The solver's source as it ran (the hash its compiled kernels are keyed by) and the revision
    of its results per quadrature (solver.revision: cases of another revision are recomputed)."""
    from solver.compile.kernel_cache import source_digest
    from solver.revision import RESULTS_REVISION
    return {"solver_source_sha256": source_digest(),
            "results_revision": ", ".join(f"{rule} {rev}" for rule, rev in sorted(RESULTS_REVISION.items()))}


@lru_cache(maxsize=1)
def cpu_attributes() -> dict:
    """The CPU and the instruction sets the numerics ran with: round-off, and so an adaptive
    run's step sequence, depends on them (numpy's SIMD dispatch, numba's target CPU; see
    make test-portable)."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        import numpy._core._multiarray_umath as umath
        found = umath.__cpu_features__
        simd = " ".join([*umath.__cpu_baseline__, *(k for k in umath.__cpu_dispatch__ if found.get(k))])
    except (ImportError, AttributeError):
        simd = "unknown"
    try:
        import numba
        import llvmlite.binding as llvm
        target = numba.config.CPU_NAME or f"{llvm.get_host_cpu_name()} (host)"
    except ImportError:
        target = "unknown"
    return {"cpu_model": model, "cpu_numpy_simd": simd, "cpu_numba_target": target}
