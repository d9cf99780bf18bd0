"""floe-impact solver: a rigid parabolic body striking a floating elastic ice plate.

Pure numerics (no files, no xarray, no dask, no plots). Three lines run one case::

    from solver import Parameters, solve
    result = solve(Parameters(V=5.0, Nmod=40), times=[0.0, 0.05, 0.1])
    result.fields["strain"], result.diagnostics["crack_onset_time"], result.status
"""
from .core import DIAGNOSTIC_INFO, FIELD_INFO, FIELDS, Result, compile_kernels, solve
from .parameters import (INTEGRATORS, PARAMETER_INFO, SETTING_INFO, ParameterError, Parameters,
                         Settings)

__all__ = [
    "DIAGNOSTIC_INFO", "FIELD_INFO", "FIELDS", "INTEGRATORS", "PARAMETER_INFO", "SETTING_INFO",
    "ParameterError", "Parameters", "Result", "Settings", "compile_kernels", "solve",
]
