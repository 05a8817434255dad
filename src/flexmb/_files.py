"""Writing files whole or not at all: a temporary name in the same folder, then a rename."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from typing import Callable

__all__ = ["atomic_write"]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


# mkstemp creates files readable by the owner only; give the final file the
# permissions an ordinary open() would.
_MODE = 0o666 & ~_umask()


def atomic_write(path, write: Callable[[str], None], suffix: str = ".tmp") -> Path:
    """Write a file through a temporary name, then move it into place.

    Parameters
    ----------
    path : str or path-like
        Target file; its folder is created if missing.
    write : callable
        ``write(tmp)`` writes the whole file to the path ``tmp``.
    suffix : str
        Ending of the temporary name (some writers choose the format by it,
        e.g. ``".gif"``).

    Returns
    -------
    pathlib.Path
        The target path.

    Notes
    -----
    The temporary file sits next to the target, so :func:`os.replace` is an
    atomic rename: a reader sees either the old file or the complete new
    one, and a failed write leaves nothing behind.
    """
    path = Path(os.fspath(path))
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        os.chmod(tmp, _MODE)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.remove(tmp)
        raise
    return path
