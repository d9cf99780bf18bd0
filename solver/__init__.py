"""floe-impact solver: a rigid parabolic body striking a floating elastic ice plate.

Pure numerics (no files, no xarray, no dask, no plots). Three lines run one case::

    from solver import Parameters, solve
    result = solve(Parameters(V=5.0, Nmod=40), times=[0.0, 0.05, 0.1])
    result.fields["strain"], result.crack_onset(8e-5), result.status
"""
from importlib.metadata import PackageNotFoundError as _NotInstalled, version as _version

from .compile import kernel_cache as _kernel_cache

# before any kernel is defined: the compiled kernels are cached under a key of every solver source
# file (solver.compile.kernel_cache), so that an edit anywhere in the solver compiles afresh
_kernel_cache.install()

from .core import Result, compile_kernels, solve
from .outputs import DIAGNOSTIC_INFO, FIELD_INFO, FIELDS
from .statuses import STATUS_INFO
from .fracture import EPS_Y_INFO, PAPER_EPS_Y, crack_onset, default_eps_Y
from .parameters import PARAMETER_INFO, ParameterError, Parameters
from .settings import INTEGRATORS, SETTING_INFO, Settings
from .spec import BodyState, RunState, StageEnd

try:
    __version__ = _version("floe-impact")
except _NotInstalled:                           # a source tree that was not installed
    __version__ = "unknown"

__all__ = [
    "DIAGNOSTIC_INFO", "EPS_Y_INFO", "FIELD_INFO", "FIELDS", "INTEGRATORS", "PAPER_EPS_Y",
    "PARAMETER_INFO", "SETTING_INFO", "STATUS_INFO", "BodyState", "ParameterError", "Parameters", "Result",
    "RunState", "Settings", "StageEnd", "compile_kernels", "crack_onset", "default_eps_Y", "solve",
]
