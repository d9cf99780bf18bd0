"""floe-impact study runner: a study file -> cases -> dask workers -> batch files -> study.nc -> figures.

From Python::

    import pipeline
    ds = pipeline.run_study("speed_sweep", workers=2)        # the combined study.nc, an xarray.Dataset
    ds = pipeline.open_study("results/speed_sweep")           # a finished study, checksum verified
    case = pipeline.case_dataset(solver.solve(...))          # one solved case, labelled as study.nc

From the shell: ``floe-impact run|status|show`` (= ``python -m pipeline``).
"""
from importlib.metadata import PackageNotFoundError, version as _version

from .api import case_dataset, open_emulator, open_sensitivity, open_study, run_study, study_text
from .common.errors import EmulatorError, ResultsIOError, StudyError
from .store.lock import StudyLocked

try:
    __version__ = _version("floe-impact")
except PackageNotFoundError:                    # a source tree that was not installed
    __version__ = "unknown"

__all__ = ["EmulatorError", "ResultsIOError", "StudyError", "StudyLocked", "case_dataset", "open_emulator",
           "open_sensitivity", "open_study", "run_study", "study_text"]
