"""One runner per study: an OS-level lock (fcntl.flock) on results/<study>/.lock.

The kernel releases the lock when its holder dies, however it dies, so no manual unlock is
ever needed. The file records who holds it (pid, host, start time) for the refusal message.
"""
from __future__ import annotations

import fcntl
import os
import socket
import time
from pathlib import Path


class StudyLocked(Exception):
    """Another runner holds the study's lock."""


class StudyLock:
    def __init__(self, out_dir: Path):
        self.path = Path(out_dir) / ".lock"
        self.fd = None

    def __enter__(self):
        # O_NOFOLLOW: a planted symlink is refused (ELOOP), its target never truncated
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 200, 0).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            raise StudyLocked(f"study {self.path.parent} is being run by another runner ({holder}); "
                              f"wait for it or stop it (its lock goes with it)") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"pid {os.getpid()} on {socket.gethostname()} since "
                      f"{time.strftime('%Y-%m-%d %H:%M:%S')}\n".encode(), 0)
        self.fd = fd
        return self

    def __exit__(self, *exc):
        os.ftruncate(self.fd, 0)
        fcntl.flock(self.fd, fcntl.LOCK_UN)
        os.close(self.fd)
        self.fd = None


def refuse_if_locked(out_dir: Path) -> None:
    """Fail fast, before anything heavy is imported, if a runner holds an existing lock."""
    path = Path(out_dir) / ".lock"
    if not path.exists() or path.is_symlink():
        return
    fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        fcntl.flock(fd, fcntl.LOCK_UN)
    except BlockingIOError:
        holder = os.pread(fd, 200, 0).decode(errors="replace").strip() or "unknown"
        raise StudyLocked(f"study {path.parent} is being run by another runner ({holder}); "
                          f"wait for it or stop it (its lock goes with it)") from None
    finally:
        os.close(fd)
