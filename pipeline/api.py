"""The runner from Python: run a study and get its data back, open a finished one.

``python -m pipeline run`` (or ``floe-impact run``) and :func:`run_study` do the same run: the
same checks before anything is written, the same lock, ledger and resume, the same files. Where
the command line prints one line and exits with a status, these functions raise:

- :class:`~pipeline.common.errors.StudyError` (a ``ValueError``): bad input, nothing written (exit 2);
- :class:`~pipeline.common.errors.ResultsIOError`: the results cannot be read or written; finished
  cases are kept (exit 74);
- :class:`~pipeline.store.lock.StudyLocked`: another runner holds the study (exit 75);
- ``KeyboardInterrupt``: finished cases are kept; the same call resumes (exit 130).

Cases that fail numerically (exit 1 on the command line) are not an exception: they are in the
returned dataset with their ``status`` and ``message``, and a warning counts them.
"""
from __future__ import annotations

import contextlib
import io
import warnings
from pathlib import Path

from .common.errors import EXIT_OK, ResultsIOError, StudyError
from .run import RunOptions, run_study as _run
from .store.ledger import sidecar
from .store.lock import refuse_if_locked

__all__ = ["run_study", "open_study", "open_sensitivity", "open_emulator", "case_dataset", "study_text", "load"]


def study_text(study: dict) -> str:
    """The TOML text of a study given as a dict of the study file's tables.

    Parameters
    ----------
    study : dict
        The study file's tables by name (``"base"``, ``"grid"``, ``"output"``, ...), as
        :func:`run_study` also takes them (pipeline.study.study_files.study_text).

    Returns
    -------
    str
        The study file's text, which ``floe-impact run`` reads as it is.

    Examples
    --------
    >>> from pipeline import study_text
    >>> print(study_text({"description": "two speeds", "grid": {"V": [2.0, 4.0]}}))
    description = "two speeds"
    <BLANKLINE>
    [grid]
    V = [2.0, 4.0]
    <BLANKLINE>
    """
    # deferred: import pipeline stays light (the CLI's fast refusals)
    from .study.study_files import study_text as text
    return text(study)


def load(study, name: str | None = None):
    """A validated :class:`~pipeline.study.definition.Study` from a study name (``"speed_sweep"``: the file
    ``studies/speed_sweep.toml``), a path to a study file, the TOML text of one (a string of
    several lines), a dict of sections (see :func:`study_text`) or a Study (returned as it is);
    ``name`` names a study given as text or a dict (default ``"study"``)."""
    from .study.definition import Study, load_study_text
    from .study.study_files import find_study, load_study
    if isinstance(study, Study):
        return study
    if isinstance(study, dict):
        return load_study_text(study_text(study), name or "study")
    if isinstance(study, str) and "\n" in study:               # the text of a study file
        return load_study_text(study, name or "study")
    if isinstance(study, (str, Path)):
        return load_study(find_study(str(study)))
    raise StudyError(f"a study is a name, a path, a dict or a Study, got {type(study).__name__}")


def run_study(study, out=None, workers: int = 2, scheduler: str | None = None, *, name: str | None = None,
              cluster: str | None = None, jobs: int = 0, tls: tuple | None = None, batch_seconds: float = 1.0, rerun_failed: bool = False, plots: bool = True,
              force: bool = False, quiet: bool = False):
    """Run a study and return its combined results as an ``xarray.Dataset`` (``study.nc``).

    Parameters
    ----------
    study : str, pathlib.Path, dict or Study
        A study name (``studies/<name>.toml``), a study file, the TOML text of a study file, or a
        dict of the study file's sections (see :func:`study_text`).
    out : str or pathlib.Path, optional
        The results directory; default ``results/<name>``. Finished cases found there are kept
        and not computed again (resume).
    workers : int
        Local dask worker processes (ignored with ``scheduler`` or ``cluster``).
    scheduler : str, optional
        Address of a running ``dask.distributed`` scheduler to run the cases on.
    name : str, optional
        The name of a study given as text or a dict (default ``"study"``).
    cluster : {"slurm", "pbs"}, optional
        Run the workers as ``jobs`` jobs of this batch system (dask-jobqueue, the extra
        ``floe-impact[hpc]``), with TLS and a worker lifetime below the walltime; queue, account,
        memory and walltime come from dask's jobqueue configuration. Every job is cancelled when
        the run ends.
    jobs : int
        With ``cluster``: the worker jobs kept running (a job that ends is replaced).
    tls : tuple of str, optional
        With a ``tls://`` scheduler: (CA file, certificate, key) of this client.
    batch_seconds : float
        Solver time per batch file.
    rerun_failed : bool
        Compute again the cases that failed before.
    plots : bool
        Draw the study's figures into ``out``.
    force : bool
        Use ``out`` even if it is a non-empty directory holding no floe-impact results.
    quiet : bool
        Silence the runner's progress lines (they go to stderr).

    Returns
    -------
    xarray.Dataset
        ``study.nc``, opened lazily; one dimension per grid key (``case`` for ``[[cases]]``,
        ``sample`` for a ``[design]``). For a ``[search]``, ``search.nc`` (the critical values;
        the runs are in ``out/evaluations``).

    Raises
    ------
    StudyError
        Bad input; nothing was written.
    ResultsIOError
        The results directory cannot be used or written; finished cases are kept.
    StudyLocked
        Another runner holds the study.

    Examples
    --------
    A grid of two speeds and two thicknesses, four cases on two local workers::

        import pipeline
        ds = pipeline.run_study({"grid": {"V": [2.0, 5.0], "hi": [0.3, 0.6]},
                                 "output": {"fields": ["strain"]}}, name="four", workers=2)
        ds["max_strain"].sel(V=5.0)                  # along hi
        ds["crack_onset_time"].sel(eps_Y=8e-5)       # NaN where the ice did not crack
    """

    _check_arguments(workers=workers, jobs=jobs, batch_seconds=batch_seconds, scheduler=scheduler,
                     cluster=cluster, tls=tls, rerun_failed=rerun_failed, plots=plots, force=force, quiet=quiet)
    study = load(study, name)
    from .study.study_files import default_results
    out_dir = Path(out) if out is not None else default_results(study)
    refuse_if_locked(out_dir)
    options = RunOptions(workers=workers, scheduler=scheduler, tls=tls, cluster=cluster, jobs=jobs,
                         batch_seconds=batch_seconds,
                         rerun_failed=rerun_failed, no_plots=not plots, force=force)
    sink = io.StringIO()
    with contextlib.redirect_stderr(sink) if quiet else contextlib.nullcontext():
        code = _run(study, out_dir, options)
    if study.search:                          # a threshold search: its results, not its runs
        from .store.sealed import open_sealed
        return open_sealed(out_dir / "search.nc")
    ds = open_study(out_dir)
    if code != EXIT_OK:
        failed = int(ds.attrs.get("cases_failed", 0)) + int(ds.attrs.get("cases_missing", 0))
        warnings.warn(f"{failed} of {study.n_cases} cases did not end ok or have no result; their "
                      f"status and message say why (python -m pipeline status {out_dir})", RuntimeWarning,
                      stacklevel=2)
    return ds


def _check_arguments(**given) -> None:
    """run_study's arguments of the wrong type or range: one StudyError naming the argument."""
    def whole(value):
        return isinstance(value, int) and not isinstance(value, bool)

    rules = {"workers": (lambda v: whole(v) and v >= 1, "a whole number >= 1"),
             "jobs": (lambda v: whole(v) and v >= 0, "a whole number >= 0"),
             "batch_seconds": (lambda v: isinstance(v, (int, float)) and not isinstance(v, bool), "a number of seconds"),
             "scheduler": (lambda v: v is None or isinstance(v, str), "None or an address (a string)"),
             "cluster": (lambda v: v is None or v in ("slurm", "pbs"), 'None, "slurm" or "pbs"'),
             "tls": (lambda v: v is None or (isinstance(v, (tuple, list)) and len(v) == 3
                                             and all(isinstance(f, (str, Path)) for f in v)),
                     "None or (CA file, certificate, key)")}
    for key, value in given.items():
        ok, what = rules.get(key, (lambda v: isinstance(v, bool), "True or False"))
        if not ok(value):
            raise StudyError(f"run_study: {key} must be {what}, got {value!r} ({type(value).__name__})")


def open_study(results, verify: bool = True):
    """Open a finished study's ``study.nc`` as an ``xarray.Dataset`` (lazily).

    Parameters
    ----------
    results : str or pathlib.Path
        A results directory, its ``study.nc``, or a study name (then ``results/<name>``).
    verify : bool
        Check the file against the checksum the runner recorded with it, and refuse it
        (:class:`ResultsIOError`) if they differ: a damaged or edited file is not read as results.

    Returns
    -------
    xarray.Dataset
        ``study.nc``, opened lazily: one dimension per grid key (``case``, ``sample``), each
        variable with its ``units`` and ``long_name`` (docs/variables.md).

    Raises
    ------
    ResultsIOError
        No such results directory, no ``study.nc`` in it (the study has not run to its end), or
        a file that does not match its checksum.

    Examples
    --------
    ::

        ds = pipeline.open_study("speed_sweep")      # results/speed_sweep/study.nc
        ds["max_strain"].plot()
    """
    import xarray as xr

    from .store.casefile import file_sha256
    path = Path(results)
    if path.suffix == ".nc":
        out_dir = path.parent
    elif path.is_dir():
        out_dir = path
    elif "/" not in str(results) and (Path("results") / str(results)).is_dir():
        out_dir = Path("results") / str(results)
    else:
        raise ResultsIOError(f"no results directory {results}")
    path = out_dir / "study.nc"
    if not path.is_file():
        raise ResultsIOError(f"{out_dir} holds no study.nc (has the study been run to its end?)")
    if verify:
        record = sidecar(out_dir)
        if not record or record.get("sha256") != file_sha256(path):
            raise ResultsIOError(f"{path} does not match the checksum recorded when it was written; run the "
                                 f"study again to rebuild it from its batch files")
    return xr.open_dataset(path)


def open_sensitivity(results):
    """Open a study's sensitivity indices (``sensitivity.nc``, written when the study has an
    ``[analysis]``) as an ``xarray.Dataset`` along (output, key).

    Parameters
    ----------
    results : str or pathlib.Path
        A results directory, or a study name (then ``results/<name>``).

    Returns
    -------
    xarray.Dataset
        The indices along (output, key): Sobol' ``S1`` and ``ST`` with their intervals, or
        Morris' ``mu_star`` and ``sigma``, and each output's censored fraction; for ``pce`` its
        Q2 and the terms of each expansion.

    Raises
    ------
    ResultsIOError
        No ``sensitivity.nc`` (the study has no ``[analysis]``, or has not run to its end), or a
        file that does not match its checksum.

    Examples
    --------
    ::

        indices = pipeline.open_sensitivity("sensitivity")
        indices["ST"].sel(output="max_strain")
    """
    from .store.sealed import open_sealed
    out_dir = Path(results)
    if not out_dir.is_dir() and "/" not in str(results) and (Path("results") / str(results)).is_dir():
        out_dir = Path("results") / str(results)
    path = out_dir / "sensitivity.nc"
    if not path.is_file():
        raise ResultsIOError(f"{out_dir} holds no sensitivity.nc (does the study have an [analysis], and has "
                             f"it run to its end?)")
    return open_sealed(path)


def case_dataset(result, eps_Y=None):
    """One case :func:`solver.solve` ran, as a Dataset labelled as a study's ``study.nc``.

    Parameters
    ----------
    result : solver.Result
        A solved case (a run that breaks too: its breaks along ``break_number``).
    eps_Y : float or array_like, optional
        Yield strains of the crack-onset variables. Default: 10 a decade from 1e-5 to 1e-1 and the
        paper's 8e-5, as a study's; a run that ended at its answer, the ones it answered; ice that
        breaks, up to its yield strain.

    Returns
    -------
    xarray.Dataset
        The fields over (t, x), series over t, diagnostics, crack onset along eps_Y, parameters,
        run records, status and event records, with the names, units and long names of study.nc
        (t and x here in seconds and metres).

    Raises
    ------
    solver.ParameterError
        An eps_Y above the largest the run answered, or above the yield strain of ice that breaks.

    Examples
    --------
    ::

        case = pipeline.case_dataset(solver.solve(solver.Parameters(V=5.0), times=[0.0, 0.05]))
        case["strain"].sel(t=0.05, method="nearest")
    """
    from .store.dataset import case_dataset as labelled    # xarray: only when a case is converted
    return labelled(result, eps_Y)


def open_emulator(results):
    """The polynomial-chaos emulator of a study whose ``[analysis]`` is ``method = "pce"``: each
    output predicted anywhere in the design's box, with its cross-validated error estimate
    (pipeline.analyse.emulator; numpy alone, no OpenTURNS needed).

    Parameters
    ----------
    results : str or pathlib.Path
        A results directory, or a study name (then ``results/<name>``).

    Returns
    -------
    pipeline.analyse.emulator.Emulator
        ``.predict(output, **key_values) -> Prediction(value, error)``; ``.outputs``, ``.keys``,
        ``.box``, ``.q2``.

    Raises
    ------
    ResultsIOError
        No ``sensitivity.nc``, or one that does not match its checksum.
    pipeline.analyse.emulator.EmulatorError
        The study's analysis is not ``method = "pce"``.

    Examples
    --------
    ::

        emulator = pipeline.open_emulator("sensitivity_pce")
        value, error = emulator.predict("max_strain", K=1e7, he=0.03, R=10.0, V=3.0, hi=0.5)
    """
    from .analyse.emulator import Emulator
    with open_sensitivity(results) as indices:
        return Emulator(indices.load())
