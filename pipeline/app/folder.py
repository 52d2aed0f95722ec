"""The output folder of a run: one run at a time, and room to save what finished when the
disk fills.

Two runs writing one folder at once overwrite each other's results.h5 and caches (one was
left saying ``complete`` while ``show`` could not read it), so a run holds an exclusive lock
on ``<out>/.microslip-run.lock`` for its whole length; a second run is refused in one line
naming the process that holds it. The kernel drops the lock with its process, so a run
killed by SIGKILL leaves no stale lock, only the (unlocked) file.

The lock file also holds a reserve of disk space (RESERVE_BYTES). When the disk fills
mid-run, the reserve is given back so that the results file can drop its half-written curve
and close, keeping every finished one (a full disk otherwise left a results file it could
not close).
"""

from __future__ import annotations

import datetime as _dt
import errno
import os
import shutil
import socket
from pathlib import Path

from microslip.results.writer import is_disk_full

try:
    import fcntl
except ImportError:  # not a POSIX system: no lock (the folder is the user's to keep apart)
    fcntl = None

LOCK_NAME = ".microslip-run.lock"
#: flock's errors on file systems that do not lock (some network mounts): no lock then.
UNLOCKABLE = (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOSYS)
#: Disk space kept back for closing the results file after the disk fills [bytes]: closing
#: writes HDF5 metadata, kilobytes (a full tmpfs closed a 12-curve file within it).
RESERVE_BYTES = 256 * 1024


class FolderBusy(RuntimeError):
    """Another run holds the folder; the message is one line naming it."""


class NoSpace(RuntimeError):
    """The disk of the output folder is full; the message is one line: which folder, how much
    space there was and what the run needs. ``before_work``: found before anything ran."""

    def __init__(self, message: str, before_work: bool = False):
        super().__init__(message)
        self.before_work = before_work


def free_bytes(folder: Path) -> int:
    """Bytes free to this user on the folder's file system."""
    return shutil.disk_usage(folder).free


def size_text(nbytes: float) -> str:
    if nbytes >= 1e9:
        return f"{nbytes / 1e9:.1f} GB"
    if nbytes >= 1e6:
        return f"{nbytes / 1e6:.0f} MB"
    return f"{max(nbytes, 0) / 1e3:.0f} kB"


class FolderLock:
    """``with FolderLock(out) as lock:`` the run's hold on ``out`` (see the module);
    FolderBusy if another run has it, NoSpace if the reserve does not fit."""

    def __init__(self, out: Path, reserve: int = RESERVE_BYTES):
        self.out = Path(out)
        self.path = self.out / LOCK_NAME
        self.reserve = reserve
        self._fd: int | None = None
        self._header = b""

    def __enter__(self) -> FolderLock:
        if fcntl is None:
            return self
        try:
            fd = self._locked()
        except OSError as err:
            if err.errno in UNLOCKABLE:  # a file system without locks: run unguarded
                self.path.unlink(missing_ok=True)
                return self
            raise FolderBusy(f"{self.out}: cannot hold the folder for the run ({LOCK_NAME}: "
                             f"{err.strerror}); give another --out") from None
        self._header = (f"{os.getpid()} {socket.gethostname()} "
                        f"{_dt.datetime.now().isoformat(timespec='seconds')}\n").encode()
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, self._header, 0)
            _reserve(fd, len(self._header), self.reserve)
        except OSError as err:
            self._drop(fd)
            if is_disk_full(err):
                raise NoSpace(f"{self.out}: no space left on its device "
                              f"({size_text(free_bytes(self.out))} free); free some there, "
                              "or give --out on another disk", before_work=True) from None
            raise
        self._fd = fd
        return self

    def _locked(self) -> int:
        """A descriptor of the lock file, locked (the file may be replaced between opening
        and locking by a run that finished: then lock the new one)."""
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as err:
                if not isinstance(err, BlockingIOError):
                    os.close(fd)
                    raise
                holder = os.pread(fd, 200, 0).split(b"\n")[0].decode(errors="replace")
                os.close(fd)
                pid, host, since = (holder.split(" ") + ["?", "?", "?"])[:3]
                raise FolderBusy(f"{self.out}: in use by another run (process {pid} on "
                                 f"{host}, since {since}); wait for it to finish, or give "
                                 "another --out") from None
            try:
                same = os.fstat(fd).st_ino == os.stat(self.path).st_ino
            except FileNotFoundError:
                same = False
            if same:
                return fd
            os.close(fd)  # locked a file its run had just removed: take the new one

    def release_reserve(self) -> None:
        """Give the reserved space back (the disk is full: the results file needs it)."""
        if self._fd is not None:
            os.ftruncate(self._fd, len(self._header))

    def _drop(self, fd: int) -> None:
        """Remove the lock file and let it go (removed while held: no other run can be
        holding this one)."""
        try:
            self.path.unlink(missing_ok=True)
        finally:
            os.close(fd)

    def __exit__(self, *exc) -> bool:
        if self._fd is not None:
            self._drop(self._fd)
            self._fd = None
        return False


def _reserve(fd: int, offset: int, nbytes: int) -> None:
    """Allocate ``nbytes`` of the file after ``offset`` (blocks, not a sparse hole: written
    where the file system cannot allocate ahead, with bytes it cannot compress away)."""
    if nbytes <= 0:
        return
    try:
        os.posix_fallocate(fd, offset, nbytes)
        return
    except (AttributeError, OSError) as err:
        if is_disk_full(err):
            raise
    os.pwrite(fd, os.urandom(nbytes), offset)
