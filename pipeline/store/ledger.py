"""The study ledger: what is done, in which batch file, with the file's checksum.

``results/<study>/ledger.jsonl`` has one line per batch file, appended (and fsynced) by the
runner when the worker that wrote the file reports it::

    {"file": "<sha256[:32]>.nc", "sha256": ..., "size": ..., "mtime_ns": ...,
     "cases": [[case_id, status, message, run_time], ...]} <crc32 of the JSON>

``status``, ``--dry-run`` and resume read this file alone: no result file is opened. Each
line carries its own CRC-32, so a damaged or half-written line is recognised and dropped.

The ledger is an index, not the data: every batch file is named by the SHA-256 of its bytes,
so the ledger can always be rebuilt from the files. :func:`reconcile` (at the start of every
run, under the study lock) makes the two agree:

- an entry whose file is missing is dropped (its cases are computed again);
- an entry whose file changed size or time is checked against its checksum; a damaged file
  is set aside (renamed ``*.damaged-<time>``, never deleted) and its cases computed again;
- a batch file with no valid entry (the runner was killed between the worker's write and
  the ledger line, or the line was damaged) is checked against the checksum in its name and
  read back into the ledger: finished work is never lost;
- a case in several entries counts once (the last entry wins).

The full check of every byte happens before combining (on the workers, see combine.py).
"""
from __future__ import annotations

import hashlib
import json
import os
import time
import zlib
from dataclasses import dataclass, field
from pathlib import Path

from ..common import provenance

LEDGER = "ledger.jsonl"
BATCHES = "batches"


def _line(entry: dict) -> str:
    text = json.dumps(entry, separators=(",", ":"))
    return f"{text} {zlib.crc32(text.encode()):08x}\n"


def _parse(line: str):
    text, _, crc = line.rstrip("\n").rpartition(" ")
    if not text or len(crc) != 8:
        return None
    try:
        if int(crc, 16) != zlib.crc32(text.encode()):
            return None
        entry = json.loads(text)
    except ValueError:
        return None
    if not isinstance(entry, dict) or not isinstance(entry.get("file"), str) \
            or not isinstance(entry.get("cases"), list):
        return None
    return entry


@dataclass
class Ledger:
    """The entries of a study's ledger and the index case_id -> (entry, position in its batch)."""

    out_dir: Path
    entries: list = field(default_factory=list)
    bad_lines: int = 0

    @property
    def path(self) -> Path:
        return Path(self.out_dir) / LEDGER

    @property
    def batches_dir(self) -> Path:
        return Path(self.out_dir) / BATCHES

    @classmethod
    def load(cls, out_dir: Path) -> "Ledger":
        ledger = cls(Path(out_dir))
        try:
            fd = os.open(ledger.path, os.O_RDONLY | os.O_NOFOLLOW)
        except FileNotFoundError:
            return ledger
        with os.fdopen(fd, "rb") as f:
            raw = f.read()
        for line in raw.decode("utf-8", errors="replace").splitlines():
            entry = _parse(line)
            if entry is None:
                ledger.bad_lines += 1
            else:
                ledger.entries.append(entry)
        return ledger

    def index(self, wider: dict | None = None) -> dict:
        """case_id -> (entry, position of the case in its batch); the last entry wins. wider
        (Study.wider_ids: case id -> the id of the run that computes everything, at least as
        far): a case the ledger does not hold is served by the complete result of its wider run."""
        out = {}
        for entry in self.entries:
            for position, row in enumerate(entry["cases"]):
                out[row[0]] = (entry, position)
        if not wider:
            return out
        from ..common.tables import COMPLETE      # (loads the solver, hence numba: status and the doors do not)
        for cid, wide in wider.items():
            if cid not in out and wide in out and out[wide][0]["cases"][out[wide][1]][1] in COMPLETE:
                out[cid] = out[wide]
        return out

    def states(self, wider: dict | None = None) -> dict:
        """case_id -> status of every case the ledger records (or serves: index)."""
        return {cid: entry["cases"][pos][1] for cid, (entry, pos) in self.index(wider).items()}

    def append(self, entry: dict) -> None:
        """Add a batch's line; on disk (fsynced) before the call returns. A write that fails
        (a full disk) leaves no torn line: the ledger is cut back to its old length, and the
        error names the ledger."""
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW, 0o644)
        try:
            start = os.lseek(fd, 0, os.SEEK_END)
            try:
                _write_all(fd, _line(entry).encode())
                os.fsync(fd)
            except OSError as err:
                try:
                    os.ftruncate(fd, start)
                except OSError:
                    pass                      # a torn line is caught by its CRC at the next load
                raise OSError(err.errno, err.strerror, str(self.path)) from None
        finally:
            os.close(fd)
        self.entries.append(entry)

    def rewrite(self) -> None:
        """Replace the ledger by its current entries, atomically."""
        tmp = self.path.with_name(f".{LEDGER}.tmp-{os.getpid()}-{time.monotonic_ns()}")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
        try:
            try:
                _write_all(fd, "".join(_line(e) for e in self.entries).encode())
                os.fsync(fd)
            finally:
                os.close(fd)
            os.replace(tmp, self.path)
        except OSError as err:
            tmp.unlink(missing_ok=True)
            raise OSError(err.errno, err.strerror, str(self.path)) from None
        self.bad_lines = 0

    def drop(self, file_name: str) -> None:
        self.entries = [e for e in self.entries if e["file"] != file_name]


def _write_all(fd: int, data: bytes) -> None:
    """os.write until every byte is written (a write may be short, on a full disk say)."""
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


def set_aside(path: Path, why: str = "damaged") -> Path:
    """Rename a damaged file out of the way (never delete a user's bytes)."""
    aside = path.with_name(f"{path.name}.{why}-{time.strftime('%Y%m%dT%H%M%S')}-{time.monotonic_ns() % 10**6}")
    os.rename(path, aside)
    return aside


def _matches(path: Path, entry: dict) -> bool:
    try:
        st = os.stat(path, follow_symlinks=False)
    except FileNotFoundError:
        return False
    return st.st_size == entry.get("size") and st.st_mtime_ns == entry.get("mtime_ns")


def reconcile(out_dir: Path, notes: list) -> Ledger:
    """Make the ledger agree with the batch files (module docstring); returns it. Appends a
    one-line note per repair to ``notes``. Runs under the study lock."""
    from .casefile import DamagedFile, file_sha256, read_batch_arrays
    ledger = Ledger.load(out_dir)
    batches = ledger.batches_dir
    changed = ledger.bad_lines > 0
    if ledger.bad_lines:
        notes.append(f"{ledger.bad_lines} damaged line(s) in {LEDGER} dropped; their batch files are read back")
    kept = []
    for entry in ledger.entries:
        path = batches / entry["file"]
        if path.is_symlink() or not path.is_file():
            notes.append(f"batch file {entry['file']} is missing: its {len(entry['cases'])} case(s) are computed again")
            changed = True
            continue
        if not _matches(path, entry):                          # cheap check first
            if file_sha256(path) != entry.get("sha256"):
                aside = set_aside(path)
                notes.append(f"batch file {entry['file']} is damaged; moved to {aside.name}; its cases "
                             f"are computed again")
                changed = True
                continue
            st = path.stat()
            entry = {**entry, "size": st.st_size, "mtime_ns": st.st_mtime_ns}
            changed = True
        kept.append(entry)
    ledger.entries = kept
    known = {e["file"] for e in kept}
    if batches.is_dir():
        for path in sorted(batches.iterdir()):
            if path.name in known or not path.name.endswith(".nc") or path.name.startswith("."):
                continue
            if path.is_symlink() or not path.is_file():
                continue
            try:
                ds = read_batch_arrays(path, None, ("case", "status", "message", "run_time"))
            except DamagedFile as err:
                aside = set_aside(path)
                notes.append(f"batch file {path.name} is not valid ({err}); moved to {aside.name}")
                continue
            st = path.stat()
            entry = {"file": path.name, "sha256": file_sha256(path), "size": st.st_size, "mtime_ns": st.st_mtime_ns,
                     "cases": [[str(c), str(s), str(m), float(r)] for c, s, m, r in
                               zip(ds["case"], ds["status"], ds["message"], ds["run_time"])]}
            ledger.entries.insert(0, entry)                    # the recorded entries win over it
            notes.append(f"batch file {path.name} was not in the ledger ({len(entry['cases'])} finished "
                         f"case(s)); added")
            changed = True
    if changed:
        ledger.rewrite()
    return ledger


# --- what study.nc was made from: a rerun with nothing new rewrites nothing ------------

def inputs_fingerprint(study, index: dict) -> str:
    """A hash of what study.nc is made from: the study file, the schema, the code (version,
    commit, dirty) and the checksum of the batch file that holds each run."""
    from ..study.identity import SCHEMA_VERSION
    commit, dirty = provenance.git_state()
    h = hashlib.sha256(json.dumps({"study": study.text, "schema": SCHEMA_VERSION,
                                   "code": [provenance.package_version(), commit, dirty]}).encode())
    for cid in study.run_ids:
        entry = index.get(cid)
        h.update(f"{cid}:{entry[0]['sha256'] if entry else '-'};".encode())
    return h.hexdigest()


def _sidecar(out_dir: Path) -> Path:
    return Path(out_dir) / ".study.nc.inputs"


def write_json_record(target: Path, record: dict) -> None:
    """``record`` as JSON at ``target``, atomically, never through a symbolic link."""
    tmp = target.with_name(f"{target.name}.tmp-{os.getpid()}")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_NOFOLLOW, 0o644)
    with os.fdopen(fd, "w") as f:
        f.write(json.dumps(record))
    os.replace(tmp, target)


def write_sidecar(out_dir: Path, fingerprint: str) -> None:
    path = Path(out_dir) / "study.nc"
    st = path.stat()
    from .casefile import file_sha256
    write_json_record(_sidecar(out_dir), {"fingerprint": fingerprint, "size": st.st_size,
                                          "mtime_ns": st.st_mtime_ns, "sha256": file_sha256(path)})


def sidecar(out_dir: Path) -> dict | None:
    try:
        return json.loads(_sidecar(out_dir).read_text())
    except (OSError, ValueError):
        return None


def is_up_to_date(out_dir: Path, fingerprint: str) -> bool:
    """True if study.nc was built from exactly these inputs and has not been touched since:
    the sidecar written with it records the fingerprint and study.nc's size, mtime and
    SHA-256 (no netCDF file is opened)."""
    record = sidecar(out_dir)
    try:
        st = (Path(out_dir) / "study.nc").stat()
    except OSError:
        return False
    if not (record and record.get("fingerprint") == fingerprint and record.get("size") == st.st_size
            and record.get("mtime_ns") == st.st_mtime_ns):
        return False
    from .casefile import file_sha256  # a flipped bit with its time kept, too
    return record.get("sha256") == file_sha256(Path(out_dir) / "study.nc")
