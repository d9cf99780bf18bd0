"""Study files on disk: find one by name, load it, write a study's tables as TOML, and keep
the copy a results directory holds of the study it ran (status and show read it)."""
from __future__ import annotations

import hashlib
import math
import os
import time
from pathlib import Path

from ..common.errors import StudyError
from .definition import Study, load_study_text


def _toml_value(value, where: str) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(v, f'{where}.{k}')}" for k, v in value.items()) + " }"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v, where) for v in value) + "]"
    if hasattr(value, "item") and getattr(value, "ndim", None) == 0:      # a numpy scalar
        return _toml_value(value.item(), where)
    if hasattr(value, "tolist"):                                          # a numpy array
        return _toml_value(value.tolist(), where)
    raise StudyError(f"{where}: cannot write a {type(value).__name__} into a study file")


def study_text(study: dict) -> str:
    """The TOML text of a study given as a dict with the study file's sections, e.g.
    ``{"base": {"Nmod": 20}, "grid": {"V": [2.0, 5.0]}, "output": {"fields": []}}``
    ([[cases]] is a list of dicts under ``"cases"``)."""
    if not isinstance(study, dict):
        raise StudyError(f"a study is a dict of its sections, got {type(study).__name__}")
    lines = []
    for key, value in study.items():                         # top-level keys before any table
        if not isinstance(value, dict) and not (key == "cases" and isinstance(value, list)):
            lines.append(f"{key} = {_toml_value(value, key)}")
    for key, value in study.items():
        if isinstance(value, dict):
            lines += ["", f"[{key}]"] + [f"{k} = {_toml_value(v, f'[{key}] {k}')}" for k, v in value.items()]
        elif key == "cases" and isinstance(value, list):
            for i, case in enumerate(value):
                if not isinstance(case, dict):
                    raise StudyError(f"[[cases]] #{i + 1} must be a dict of parameters")
                lines += ["", "[[cases]]"] + [f"{k} = {_toml_value(v, f'[[cases]] #{i + 1} {k}')}"
                                               for k, v in case.items()]
    return "\n".join(lines) + "\n"


def find_study(name_or_path: str, studies_dir: Path = Path("studies")) -> Path:
    """studies/<name>.toml from a name, or the path itself."""
    path = Path(name_or_path)
    if path.suffix == ".toml" or "/" in name_or_path:
        if not path.is_file():
            raise StudyError(f"no study file {name_or_path!r}")
        return path
    path = studies_dir / f"{name_or_path}.toml"
    if not path.is_file():
        known = sorted(p.stem for p in studies_dir.glob("*.toml"))
        raise StudyError(f"unknown study {name_or_path!r}: no {path}; known: {', '.join(known) or 'none'}")
    return path


def load_study(path: Path, max_cases: int | None = None, name: str | None = None) -> Study:
    """Read and validate a study file; expand its cases. ``max_cases``: refuse a design of
    more cases before building them (the command line's --yes limit). The study is named by the
    file (or ``name``), and a results directory's copy (keep_study_copy) by its header: running
    the copy runs its study as it ran, under its name."""
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as err:
        raise StudyError(f"cannot read {path}: {err.strerror}") from None
    except UnicodeDecodeError as err:
        raise StudyError(f"{path}: not UTF-8 text (byte {err.start}); a study file is TOML") from None
    name = name or path.stem
    if text.startswith(_COPY_HEADER):        # a results directory's copy (keep_study_copy): its study, as it ran
        header, _, text = text.partition("\n")
        name = _header_name(header) or name
    return load_study_text(text, name, path, max_cases)


#: the copy of its study a run keeps in the results directory (status and show read it)
STUDY_COPY = "study.toml"


_COPY_HEADER = "# floe-impact keeps this copy of the study it ran here: name = "


def keep_study_copy(study: Study, out_dir: Path) -> None:
    """Write out_dir/study.toml (a header line naming the study and the file it came from, then
    its text byte for byte) unless it holds that study already (the same name and text: a run of
    the copy itself keeps it as it is); atomically, never through a symbolic link."""
    target = Path(out_dir) / STUDY_COPY
    data = (f"{_COPY_HEADER}{study.name!r}, from {study.path}\n" + study.text).encode()
    try:
        if not target.is_symlink() and target.is_file():
            header, _, text = target.read_bytes().decode("utf-8").partition("\n")
            if _header_name(header) == study.name and text == study.text:
                return
    except (OSError, UnicodeDecodeError):
        pass
    tmp = target.with_name(f".{STUDY_COPY}.tmp-{os.getpid()}-{time.monotonic_ns()}")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
    try:
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view):]
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def study_copy_name(out_dir: Path) -> str | None:
    """The name of the study whose results a directory holds (its copy's header), or None."""
    try:
        with open(Path(out_dir) / STUDY_COPY, "rb") as f:
            header = f.readline().decode("utf-8", errors="replace")
    except OSError:
        return None
    return _header_name(header)


def _header_name(header: str) -> str | None:
    """The study name in the copy's header line (keep_study_copy), or None."""
    if not header.startswith(_COPY_HEADER):
        return None
    quoted = header[len(_COPY_HEADER):].split(", from ", 1)[0].strip()
    return quoted[1:-1] if len(quoted) >= 2 and quoted[0] == quoted[-1] and quoted[0] in "'\"" else None


def default_results(study: Study) -> Path:
    """Where a study's results go unless told: results/<name>, or, for the copy a results
    directory keeps (keep_study_copy) run as a study, that directory."""
    path = Path(study.path)
    if path.name == STUDY_COPY and study_copy_name(path.parent) == study.name:
        return path.parent
    return Path("results") / study.name


def study_identity(text: str) -> str:
    """A study's identity: the SHA-256 of its text as it ran (what its copy holds after the
    header). The files a study writes beside study.nc record it (pipeline.store.sealed)."""
    return hashlib.sha256(text.encode()).hexdigest()


def copy_identity(out_dir: Path) -> str | None:
    """The identity of the study whose copy a results directory holds (None: it holds none)."""
    try:
        text = (Path(out_dir) / STUDY_COPY).read_bytes().decode("utf-8")
    except (OSError, UnicodeDecodeError):
        return None
    if text.startswith(_COPY_HEADER):
        text = text.partition("\n")[2]
    return study_identity(text)


def load_study_copy(out_dir: Path) -> Study:
    """The study a results directory was run with, from its copy (see keep_study_copy)."""
    return load_study(Path(out_dir) / STUDY_COPY, name=Path(out_dir).name)
