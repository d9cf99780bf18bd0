"""The result files a study writes beside study.nc (sensitivity.nc, search.nc) carry their
SHA-256, recorded when they are written, as study.nc does (pipeline.store.ledger.write_sidecar): a
damaged or edited file is refused on open in one line naming it, never read as results and
never handed to the netCDF library to fail in ("HDF error"). The record is ``.<name>.sha256``
beside the file, JSON ``{"sha256": ..., "size": ...}``, written atomically after the file."""
from __future__ import annotations

import json
from pathlib import Path

from .casefile import file_sha256
from ..common.errors import ResultsIOError
from .ledger import write_json_record


def record_path(path: Path) -> Path:
    path = Path(path)
    return path.with_name(f".{path.name}.sha256")


def seal(path: Path) -> None:
    """Record the checksum of the file just written at ``path``."""
    path = Path(path)
    write_json_record(record_path(path), {"sha256": file_sha256(path), "size": path.stat().st_size})


def is_intact(path: Path) -> bool:
    """The file exists and matches the checksum recorded when it was written."""
    path = Path(path)
    try:
        record = json.loads(record_path(path).read_text())
        return path.stat().st_size == record["size"] and file_sha256(path) == record["sha256"]
    except (OSError, ValueError, KeyError, TypeError):
        return False


def open_sealed(path: Path):
    """The file as an xarray.Dataset (lazily), or ResultsIOError naming it if it is missing,
    damaged, edited, or was written without a record (an older version: run again)."""
    import xarray as xr
    path = Path(path)
    if not path.is_file():
        raise ResultsIOError(f"{path} does not exist")
    if not is_intact(path):
        raise ResultsIOError(f"{path} does not match the checksum recorded when it was written (damaged, "
                             f"edited, or written by an older version); run the study again to rebuild it")
    try:
        return xr.open_dataset(path)
    except (OSError, ValueError) as err:                  # intact yet unreadable: a library's problem
        raise ResultsIOError(f"{path} cannot be read: {str(err).splitlines()[0] if str(err) else type(err).__name__}") from None
