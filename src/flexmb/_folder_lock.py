"""The lock of an output folder (a ``flock`` on a lock file that is never a link), and reading a file there safely.

:class:`FolderLock` is what :class:`flexmb._files.OutputFolder` locks its
folder with, :func:`read_plain` what it reads a manifest with (see that
module for the folder's layout): neither follows a link another user may
have put in the folder.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import time
from pathlib import Path

try:
    import fcntl
except ImportError:  # not on Windows: the pid in the lock file is all there is
    fcntl = None

from .errors import ExportError

__all__ = ["FolderLock", "NOFOLLOW", "link_refused", "read_plain"]

#: open flags that never follow a link at the last component, keep the file from programs a run starts,
#: and never block on a FIFO put in a file's place
NOFOLLOW = getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_NONBLOCK", 0)
#: the longest file :func:`read_plain` reads (the manifest of a run of 10**5 VTU files is a few MB)
READ_LIMIT = 1 << 26


def _pid_alive(pid: int) -> bool:
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, another user's
        return True
    except OSError:
        return False
    return True


def _read_pid(fd: int) -> int | None:
    """The pid a lock file names (information for messages; the ``flock`` decides who holds the lock)."""
    try:
        text = os.pread(fd, 64, 0).split()
        return int(text[0]) if text else None
    except (OSError, ValueError):
        return None


def link_refused(path) -> ExportError:
    """The error for a symbolic link at a name flexmb uses inside an output folder.

    Parameters
    ----------
    path : path-like
        The link.

    Returns
    -------
    ExportError
    """
    return ExportError(f"{path} is a symbolic link: flexmb does not follow links at the names it uses inside an "
                       "output folder (another user or an old run may have put it there); remove the link, or "
                       "write to another folder")


class FolderLock:
    """An exclusive lock on a folder: a ``flock`` on ``.flexmb.lock``, which names the owner's pid.

    The file is opened without following a symbolic link and must be a plain
    file with one name (a link or a hard link in its place is refused: the
    pid written into it would overwrite another file). Where the file system
    has ``flock``, it alone decides: a file naming any pid, alive or not, is
    taken over when no process holds its ``flock`` (a pid may have been
    reused since). Without ``flock`` (some network file systems, Windows)
    the pid is all there is: a file naming a live process is respected.

    Parameters
    ----------
    folder : pathlib.Path
        The folder.
    name : str
        The lock file's name in it.
    """

    def __init__(self, folder: Path, name: str):
        self.path = folder / name
        self.fd = None

    def _busy(self, pid):
        who = f"pid {pid}" if pid else "another process"
        return ExportError(f"output folder {self.path.parent} is in use by another flexmb run ({who}; lock file "
                           f"{self.path}): wait for it to finish or write to another folder")

    def _open(self) -> int:
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | NOFOLLOW, 0o666)
        except OSError as exc:
            if exc.errno == errno.ELOOP or os.path.islink(self.path):
                raise link_refused(self.path) from None
            raise
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode) or st.st_nlink > 1:
            os.close(fd)
            what = "has other names (a hard link)" if stat.S_ISREG(st.st_mode) else "is not a plain file"
            raise ExportError(f"the lock file {self.path} {what}: flexmb writes its pid into it, so it refuses; "
                              "remove it, or write to another folder")
        return fd

    def acquire(self) -> None:
        while self.fd is None:
            fd = self._open()
            try:
                if not self._lock(fd):
                    continue  # the file we locked was the previous owner's, just removed
                os.ftruncate(fd, 0)
                os.write(fd, f"{os.getpid()}\n".encode())
            except BaseException:
                with contextlib.suppress(OSError):
                    os.close(fd)
                raise
            self.fd = fd

    def _lock(self, fd) -> bool:
        """Lock ``fd``; False if it is no longer the file at ``self.path``; raise if held by a live run."""
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    raise self._busy(self._owner(fd)) from None
                # no flock on this file system (ENOLCK, ...): the pid below is all there is
            else:
                try:
                    now = os.lstat(self.path)
                except FileNotFoundError:
                    now = None
                mine = os.fstat(fd)
                if now is None or (now.st_ino, now.st_dev) != (mine.st_ino, mine.st_dev):
                    os.close(fd)
                    return False
                return True  # the flock decides: the pid in the file (maybe reused since) is information only
        owner = _read_pid(fd)
        if owner not in (None, os.getpid()) and _pid_alive(owner):
            raise self._busy(owner)
        return True

    def _owner(self, fd) -> int | None:
        """The pid of the lock's holder; it writes it just after locking, so wait a moment for it."""
        end = time.monotonic() + 1.0
        while True:
            pid = _read_pid(fd)
            if pid is not None or time.monotonic() > end:
                return pid
            time.sleep(0.01)

    def release(self) -> None:
        if self.fd is None:
            return
        with contextlib.suppress(OSError):
            os.remove(self.path)  # while still locked: a waiting run then finds a new inode (see _lock)
        os.close(self.fd)
        self.fd = None


def read_plain(path, limit: int = READ_LIMIT, own: bool = False) -> bytes | None:
    """The bytes of a plain file, read without following a link; None if it is anything else.

    Parameters
    ----------
    path : str or path-like
        The file.
    limit : int
        Files longer than this many bytes are not read (None).
    own : bool
        Read only a file of this user's (its owner is the effective user).

    Returns
    -------
    bytes or None
        None if the file is missing, a symbolic link, not a plain file (a
        FIFO, a device, a folder), too long, another user's (``own``) or
        unreadable.
    """
    try:
        fd = os.open(path, os.O_RDONLY | NOFOLLOW)
    except OSError:
        return None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode) or st.st_size > limit:
            return None
        if own and hasattr(os, "geteuid") and st.st_uid != os.geteuid():
            return None
        chunks, size = [], 0
        while size <= limit:
            chunk = os.read(fd, 1 << 20)
            if not chunk:
                return b"".join(chunks)
            chunks.append(chunk)
            size += len(chunk)
        return None
    except OSError:
        return None
    finally:
        os.close(fd)
