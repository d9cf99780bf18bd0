"""The result files a study writes beside study.nc (sensitivity.nc, search.nc) carry their
SHA-256 and the identity of the study that wrote them (pipeline.study.study_files.study_identity:
the SHA-256 of its text), recorded when they are written, as study.nc does
(pipeline.store.ledger.write_sidecar): a damaged or edited file, or a file of another study
copied in with its record, is refused on open in one line naming it, never read as results and
never handed to the netCDF library to fail in ("HDF error"). The record is ``.<name>.sha256``
beside the file, JSON ``{"sha256": ..., "size": ..., "study": ...}``, written atomically after
the file. The study a file must belong to is, unless given, the one whose copy (study.toml) the
directory holds."""
from __future__ import annotations

import json
from pathlib import Path

from .casefile import file_sha256
from ..common.errors import ResultsIOError
from ..study.study_files import STUDY_COPY, copy_identity
from .ledger import write_json_record


def record_path(path: Path) -> Path:
    path = Path(path)
    return path.with_name(f".{path.name}.sha256")


def _study(path: Path, study: str | None) -> str | None:
    return study if study is not None else copy_identity(path.parent)


def seal(path: Path, study: str | None = None) -> None:
    """Record the checksum of the file just written at ``path``, and the study it belongs to
    (an identity; default: the directory's study)."""
    path = Path(path)
    write_json_record(record_path(path), {"sha256": file_sha256(path), "size": path.stat().st_size,
                                          "study": _study(path, study)})


def problem(path: Path, study: str | None = None) -> str | None:
    """What is wrong with the sealed file at ``path`` (None: nothing): its record missing or
    unreadable, its bytes not those recorded, or a record naming another study than ``study``
    (default: the directory's)."""
    path = Path(path)
    try:
        record = json.loads(record_path(path).read_text())
        recorded = (record["sha256"], record["size"], record.get("study"))
    except FileNotFoundError:
        return f"has no checksum record ({record_path(path).name}: deleted, or written by an older version)"
    except (OSError, ValueError, KeyError, TypeError):
        return f"has a damaged checksum record ({record_path(path).name})"
    try:
        intact = path.stat().st_size == recorded[1] and file_sha256(path) == recorded[0]
    except OSError as err:
        return f"cannot be read ({err.strerror or err})"
    if not intact:
        return "does not match the checksum recorded when it was written (damaged or edited)"
    own = _study(path, study)
    if own is None:
        return f"cannot be told to belong to a study: no {STUDY_COPY} beside it"
    if recorded[2] != own:
        return (f"belongs to another study (its record names study {str(recorded[2])[:12]}, this one is "
                f"{own[:12]}): copied from elsewhere, or written by an older version")
    return None


def is_intact(path: Path, study: str | None = None) -> bool:
    """The file exists, matches the checksum recorded when it was written and belongs to the
    study (default: the directory's)."""
    return Path(path).is_file() and problem(path, study) is None


def open_sealed(path: Path, study: str | None = None):
    """The file as an xarray.Dataset (lazily), or ResultsIOError naming it if it is missing,
    damaged, edited, another study's, or was written without a record (an older version: run
    again)."""
    import xarray as xr
    path = Path(path)
    if not path.is_file():
        raise ResultsIOError(f"{path} does not exist")
    wrong = problem(path, study)
    if wrong is not None:
        raise ResultsIOError(f"{path} {wrong}; run the study again to rebuild it")
    try:
        return xr.open_dataset(path)
    except (OSError, ValueError) as err:                  # intact yet unreadable: a library's problem
        raise ResultsIOError(f"{path} cannot be read: {str(err).splitlines()[0] if str(err) else type(err).__name__}") from None
