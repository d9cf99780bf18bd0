"""Exceptions of the runner and its exit statuses (standard library only, so the CLI can fail fast)."""
import shutil
from pathlib import Path


class StudyError(ValueError):
    """A study file or command line that cannot be run; the message is one line."""


class EmulatorError(ValueError):
    """The emulator (pipeline.open_emulator) cannot answer: its one line says why."""


def check_table(section: str, table, known: set) -> None:
    """Refuse a study file's table that is not a table or holds a key not in known (one line)."""
    if not isinstance(table, dict):
        raise StudyError(f"{section} must be a table")
    unknown = set(table) - set(known)
    if unknown:
        raise StudyError(f"{section}: unknown key {sorted(unknown)[0]!r}; known: {', '.join(sorted(known))}")


#: studies with more cases than this need --yes
LARGE_STUDY = 10_000

#: exit statuses of python -m pipeline (pipeline.cli)
EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_IO, EXIT_LOCKED, EXIT_INTERRUPTED = 0, 1, 2, 74, 75, 130


class ResultsIOError(Exception):
    """Reading or writing results failed (permissions, full disk): exit 74."""


class WriteFailed(ResultsIOError):
    """A write into the results directory failed; the runner first asks whether the directory
    itself went (make clean mid-run), which it reports instead."""


def free_space(path: Path) -> str:
    """The free space of the filesystem that holds path (or its nearest existing parent)."""
    path = Path(path).absolute()
    while not path.exists() and path != path.parent:
        path = path.parent
    try:
        return f"{shutil.disk_usage(path).free // 2**20} MiB free on its filesystem"
    except OSError:
        return "free space unknown"


def write_failed(what: Path, err: BaseException) -> WriteFailed:
    detail = getattr(err, "strerror", None) or str(err) or type(err).__name__
    return WriteFailed(f"cannot write {what} ({free_space(Path(what).parent)}): {detail}; finished cases are kept")
