"""Writing files whole or not at all, and output folders that one run owns at a time.

:func:`atomic_write` writes one file through a temporary name in the same
folder, then renames it into place. :class:`OutputFolder` is what ``flexmb
run`` (:meth:`flexmb.scene.Scene.run`, for a scene file and a built-in scene alike)
writes through:

1. a lock file, ``.flexmb.lock``, on which the run that owns the folder
   holds a ``flock`` (the file also names its pid, for the messages): a
   second run into the same folder is refused at once; the lock of a run
   that died is taken over (the kernel released its ``flock``, whatever pid
   the file names); a folder holding a complete run of another owner
   (another scene) is refused too, unless the run is told to overwrite it;
2. a hidden staging folder inside the output folder, where the whole run is
   written (so that every move below is a rename within one file system);
3. a commit: the staging folder is renamed to ``.flexmb-commit`` (the point
   of no return), then the previous run's ``summary.json`` and the files it
   owned that the new run does not write are removed, the new files are
   moved in, the manifest ``.flexmb-run.json`` listing them follows and
   ``summary.json`` comes last. Signals are held back during the commit; a
   commit cut short by a kill is finished by the next run into the folder.

A reader therefore finds either the previous complete run or the new one;
``summary.json`` is present only beside the complete set of files it names,
by paths relative to the folder (a moved or shared folder stays valid).

Nothing in the folder is trusted to point elsewhere (another user may be
able to write into it, or a link may be left there by mistake): the lock
file is opened without following a link, a symbolic link at a name flexmb
uses (the lock, the manifest, the staging and commit folders, the ``vtk``
and ``cases`` sub-folders) is refused with an error naming it, no file is
moved or removed through a linked folder, and of the files a manifest lists
only those named as flexmb's writers name their files (:data:`WRITTEN`)
are removed, and only if the manifest is a plain file of this user's.
Files that no flexmb run wrote are never removed.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import stat
from pathlib import Path
from typing import Callable

from ._folder_lock import FolderLock, link_refused, read_plain
from ._signals import held
from .errors import ExportError

__all__ = ["atomic_write", "OutputFolder", "LOCK_NAME", "MANIFEST_NAME"]

#: the lock file of an output folder (holds the owner's pid)
LOCK_NAME = ".flexmb.lock"
#: the list of files the last complete run wrote into a folder
MANIFEST_NAME = ".flexmb-run.json"
#: written last: its presence marks a complete run
SUMMARY_NAME = "summary.json"
_STAGING = ".flexmb-staging-"
_COMMIT = ".flexmb-commit"
#: the names flexmb's writers give the files of an output folder (scene/outputs.py, export/vtk.py,
#: study/table.py): a run removes no other file, whatever a manifest lists
WRITTEN = re.compile(r"""(?x)
    summary\.json | summary\.txt | study\.json | study\.png | table\.(csv|npz|parquet) | open_in_paraview\.py
  | \w[^/]*\.(npz|png)                     # <prefix>.npz, <prefix>_<label>.png, ...
  | vtk(_[^/]+)?/\w[^/]*\.(vtu|pvd)        # vtk/<prefix>_0001.vtu, vtk_<label>/<prefix>_<label>.pvd
""")
#: sub-folders flexmb writes into: a symbolic link in their place is refused
_FOLDERS = re.compile(r"vtk(_.+)?|cases")


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
        e.g. ``".gif"``, or append it, e.g. ``np.savez`` and ``".npz"``).

    Returns
    -------
    pathlib.Path
        The target path.

    Notes
    -----
    The temporary file sits next to the target, so :func:`os.replace` is an
    atomic rename: a reader sees either the old file or the complete new
    one, and a failed or interrupted write leaves nothing behind. The file
    gets the permissions an ordinary ``open(path, "w")`` would give it
    under the umask in force when it is written (``0o666 & ~umask``).
    """
    path = Path(os.fspath(path))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp, mode = _create_temp(path, suffix)
    try:
        write(tmp)
        os.chmod(tmp, mode)  # a writer may have made the file anew
        os.replace(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            os.remove(tmp)
        if not isinstance(exc, KeyboardInterrupt) and _interrupted(exc):
            # a writer's clean-up failed after Ctrl-C (np.savez: "Can't close the ZIP file while there
            # is an open writing handle"): the cause is the interruption, so report that
            raise KeyboardInterrupt from exc
        raise
    return path


def _interrupted(exc: BaseException) -> bool:
    """Whether ``exc`` was raised while a KeyboardInterrupt was being handled."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__context__
    return False


def _create_temp(path: Path, suffix: str) -> tuple[str, int]:
    """Create an empty, uniquely named file next to ``path``; return its name and mode.

    ``os.open(..., 0o666)`` lets the kernel apply the umask in force now,
    without changing it (``os.umask`` would, for every thread).
    """
    while True:
        tmp = str(path.parent / f".{path.name}.{os.urandom(6).hex()}{suffix}")
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue
        try:
            return tmp, os.fstat(fd).st_mode & 0o7777
        finally:
            os.close(fd)


def _remove_tree(path: Path) -> None:
    shutil.rmtree(path, ignore_errors=True)


def _manifest(folder: Path) -> dict | None:
    """The manifest of ``folder``: a plain file of this user's, else None (another's is not trusted)."""
    data = read_plain(folder / MANIFEST_NAME, own=True)
    try:
        manifest = json.loads(data) if data is not None else None
    except ValueError:
        return None
    return manifest if isinstance(manifest, dict) else None


def _read_manifest(folder: Path) -> list[str]:
    """The files a manifest lists that are plain paths inside the folder, not the folder's own bookkeeping."""
    files = (_manifest(folder) or {}).get("files")
    if not isinstance(files, list):
        return []
    return [f for f in files if isinstance(f, str) and _safe_relative(f) and not f.startswith(".flexmb")]


def _safe_relative(rel: str) -> bool:
    """A manifest entry names a file inside the folder (never outside it, never the folder itself)."""
    p = Path(rel)
    return bool(rel) and not p.is_absolute() and ".." not in p.parts and p.parts[0] not in (".", "") \
        and "\\" not in rel and "\0" not in rel


def _real_folder(root: Path, rel: str, create: bool = False) -> bool:
    """Whether the folder of ``rel`` inside ``root`` is reached through real folders only, never a link.

    With ``create``, missing folders are made (one by one: never through a link). Raises
    :class:`~flexmb.errors.ExportError` where a link (or a file) stands in the way of a created one.
    """
    d = root
    for part in Path(rel).parts[:-1]:
        d = d / part
        try:
            st = os.lstat(d)
        except FileNotFoundError:
            if not create:
                return False
            os.mkdir(d)
            continue
        if stat.S_ISLNK(st.st_mode):
            if create:
                raise link_refused(d)
            return False
        if not stat.S_ISDIR(st.st_mode):
            if create:
                raise ExportError(f"{d} is a file where the run writes a folder: remove it, or write to another "
                                  "folder")
            return False
    return True


def _check_folder(root: Path, rel: str) -> None:
    """Raise :class:`~flexmb.errors.ExportError` if a link or a file stands where ``root/rel`` is a folder."""
    d = root
    for part in Path(rel).parts:
        d = d / part
        try:
            st = os.lstat(d)
        except FileNotFoundError:
            return
        if stat.S_ISLNK(st.st_mode):
            raise link_refused(d)
        if not stat.S_ISDIR(st.st_mode):
            raise ExportError(f"{d} is a file where the run writes a folder: remove it, or write to another folder")


def _move_order(files) -> list[str]:
    """Data files first, then the collections (``.pvd``) that list them; summary and manifest apart."""
    rest = [f for f in files if f not in (SUMMARY_NAME, MANIFEST_NAME)]
    return sorted(rest, key=lambda f: (f.endswith(".pvd"), f))


def _roll_forward(folder: Path) -> None:
    """Finish a commit: replace the previous run's files by the ones in ``.flexmb-commit``.

    Every step can be repeated, so a commit cut short (by a kill) is finished
    by running this again. Of the previous run's files only those named as
    flexmb names its files (:data:`WRITTEN`) are removed; nothing is moved or
    removed through a linked folder.
    """
    commit = folder / _COMMIT
    new = _read_manifest(commit)
    if os.path.lexists(commit / MANIFEST_NAME):
        old = _read_manifest(folder)
    else:  # the manifest was moved already: the old files are gone
        old = []
    if os.path.lexists(commit / SUMMARY_NAME) or os.path.lexists(commit / MANIFEST_NAME):
        # the previous summary goes first: from here on it would describe a mix
        with contextlib.suppress(FileNotFoundError):
            os.remove(folder / SUMMARY_NAME)
    keep = set(new)
    dirs = set()
    for rel in old:
        if rel in keep or not WRITTEN.fullmatch(rel) or not _real_folder(folder, rel):
            continue
        with contextlib.suppress(OSError):
            if stat.S_ISREG(os.lstat(folder / rel).st_mode):  # a run writes plain files only
                os.remove(folder / rel)
        dirs.update(Path(rel).parents)
    made = set()
    for rel in _move_order(new):
        src, dst = os.path.join(commit, rel), os.path.join(folder, rel)
        if not os.path.lexists(src):  # moved by the commit this one finishes
            continue
        if not _real_folder(commit, rel):
            continue  # not a file of the run's: the staging folder holds real folders only
        parent = os.path.dirname(dst)
        if parent not in made:
            _real_folder(folder, rel, create=True)
            made.add(parent)
        # the previous file is removed, not renamed over: ext4 writes a file renamed over another to
        # disk at once (auto_da_alloc), which made this loop over a VTK series six times slower
        with contextlib.suppress(FileNotFoundError):
            os.unlink(dst)
        os.rename(src, dst)
    for name in (MANIFEST_NAME, SUMMARY_NAME):
        if os.path.lexists(commit / name):
            os.replace(commit / name, folder / name)
    # folders the previous run's files were in, if that left them empty (never the output folder)
    for d in sorted((d for d in dirs if str(d) != "."), key=lambda d: len(d.parts), reverse=True):
        with contextlib.suppress(OSError):
            (folder / d).rmdir()
    _remove_tree(commit)


def _check_links(folder: Path) -> None:
    """Refuse a symbolic link at a name flexmb uses in ``folder`` (its bookkeeping, its sub-folders)."""
    with os.scandir(folder) as entries:
        for entry in entries:
            if entry.is_symlink() and (entry.name.startswith(".flexmb") or _FOLDERS.fullmatch(entry.name)):
                raise link_refused(Path(entry.path))


class OutputFolder:
    """An output folder written by one run at a time, whole or not at all.

    Use it as a context manager: entering locks the folder and opens a
    hidden staging folder in it; :meth:`stage` names the staging path of
    each output file; :meth:`commit` swaps the staged run into place. Leaving
    without a commit (an error, Ctrl-C) discards the staged files and keeps
    the previous run; leaving releases the lock.

    Parameters
    ----------
    path : str or path-like
        The output folder (created if missing).
    owner : str, optional
        What writes the run, e.g. the scene file: recorded in the manifest.
        A folder holding a complete run of another owner (or of an unknown
        one) is refused unless ``overwrite``, so that a run never removes
        the files of another scene's run without being told to. None: no
        check, nothing recorded.
    overwrite : bool
        Replace the run of another owner all the same.

    Raises
    ------
    ExportError
        On entering, if another live run holds the folder (the message names
        its pid), if the folder holds another owner's run and ``overwrite``
        is False (the message names both and says how to overwrite), or if
        the folder cannot be created or written.

    See Also
    --------
    atomic_write : Write one file whole or not at all.

    Notes
    -----
    The folder's layout is described in the module docstring of
    :mod:`flexmb._files` and in ``docs/scenes.md`` ("Output folders").

    Examples
    --------
    >>> import json, tempfile
    >>> from pathlib import Path
    >>> from flexmb._files import OutputFolder, atomic_write
    >>> out = tempfile.mkdtemp()
    >>> with OutputFolder(out) as folder:
    ...     _ = atomic_write(folder.stage("a.txt"), lambda tmp: Path(tmp).write_text("a"))
    ...     folder.commit({"files": {"a": "a.txt"}})
    >>> json.load(open(out + "/summary.json"))["files"]
    {'a': 'a.txt'}
    """

    def __init__(self, path, owner: str | None = None, overwrite: bool = False):
        self.path = Path(os.fspath(path))
        self.owner = owner
        self.overwrite = overwrite
        self.staging = None
        self.committed = False
        self._lock = FolderLock(self.path, LOCK_NAME)

    def __enter__(self) -> "OutputFolder":
        if self.path.exists() and not self.path.is_dir():
            raise ExportError(f"the output folder {self.path} is a file, not a folder")
        try:
            self.path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ExportError(f"cannot create the output folder {self.path}: {exc.strerror or exc}") from None
        try:
            self._lock.acquire()
        except OSError as exc:
            raise ExportError(f"cannot write to the output folder {self.path}: {exc.strerror or exc}") from None
        try:
            _check_links(self.path)
            self._recover()
            self._check_owner()
            self.staging = self.path / f"{_STAGING}{os.getpid()}"
            _remove_tree(self.staging)
            self.staging.mkdir()
        except BaseException:
            self._lock.release()
            raise
        return self

    def __exit__(self, *exc) -> None:
        try:
            if self.staging is not None and not self.committed:
                with held():  # a SIGTERM inside rmtree left the staging folder half removed
                    _remove_tree(self.staging)
        finally:
            self._lock.release()

    def _recover(self) -> None:
        """Finish a commit a killed run left; remove the staging folders of dead runs."""
        if os.path.isdir(self.path / _COMMIT):  # not a link: _check_links refused one
            with held():
                _roll_forward(self.path)
        for p in self.path.glob(f"{_STAGING}*"):
            _remove_tree(p)  # shutil.rmtree removes no link's target

    def _check_owner(self) -> None:
        """Refuse to replace a complete run of another owner (unless told to overwrite it)."""
        if self.owner is None or self.overwrite:
            return
        manifest = _manifest(self.path)
        if manifest is None:
            return  # no complete run of this user's here: nothing of another run to remove
        previous = manifest.get("owner")
        if previous == self.owner or not _read_manifest(self.path):
            return
        what = f"the outputs of {previous}" if previous else "the outputs of an earlier flexmb run (its scene is not recorded)"
        raise ExportError(f"output folder {self.path} holds {what}; this run of {self.owner} would replace "
                          "them: write to another folder (--out DIR), or replace them with "
                          "--overwrite (overwrite=True)")

    def stage(self, rel) -> Path:
        """The staging path of an output file.

        Parameters
        ----------
        rel : str
            The file's path relative to the output folder, e.g. ``"vtk/a.pvd"``.

        Returns
        -------
        pathlib.Path
            Where to write it now (its folder is created).
        """
        if self.staging is None:
            raise ExportError("OutputFolder.stage: use the folder in a `with` block")
        if not _safe_relative(rel) or rel in (MANIFEST_NAME, LOCK_NAME, SUMMARY_NAME):
            raise ExportError(f"output file name {rel!r} is not a plain path inside the output folder")
        p = self.staging / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def folder(self, rel: str) -> Path:
        """A sub-folder whose files are written directly, not staged: kept from run to run.

        A study's ``cases/`` is one: each case's file is written as the case
        ends, so that a study stopped at any moment resumes with the cases it
        finished. It is created if missing, never through a link.

        Parameters
        ----------
        rel : str
            The folder's path relative to the output folder, e.g. ``"cases"``.

        Returns
        -------
        pathlib.Path
            The folder.

        Raises
        ------
        ExportError
            If a symbolic link or a file stands in its place.
        """
        if self.staging is None:
            raise ExportError("OutputFolder.folder: use the folder in a `with` block")
        if not _safe_relative(rel) or rel.startswith(".flexmb"):
            raise ExportError(f"folder name {rel!r} is not a plain path inside the output folder")
        _check_folder(self.path, rel)
        _real_folder(self.path, f"{rel}/-", create=True)
        return self.path / rel

    def final(self, rel) -> str:
        """The path an output file will have once committed (for the caller; a summary names ``rel`` itself).

        Parameters
        ----------
        rel : str
            The file's path relative to the output folder.

        Returns
        -------
        str
            ``os.path.join(path, rel)``.
        """
        return os.path.join(os.fspath(self.path), rel)

    def staged(self, rel) -> bool:
        """Whether an output file has been written to the staging folder.

        Parameters
        ----------
        rel : str
            The file's path relative to the output folder.

        Returns
        -------
        bool
            True if the staged file exists.
        """
        return self.staging is not None and (self.staging / rel).is_file()

    def commit(self, summary: dict | None = None) -> None:
        """Swap the staged run into place; write ``summary.json`` last.

        Parameters
        ----------
        summary : dict, optional
            Written as ``summary.json`` (``None``: no summary; a previous one
            is removed all the same, since it would describe another run).
            The files it names (``"files"``, ``"vtk"``) are paths relative
            to the output folder, so that the folder stays valid when it is
            moved, copied or shared.

        Raises
        ------
        ExportError
            If the summary's ``"files"`` name a file that was not written, or
            a path that is not relative to the folder.
        """
        staging = self.staging
        if summary is not None:
            named = _summary_files(summary)
            outside = [p for p in named if not _safe_relative(p)]
            if outside:
                raise ExportError(f"the summary names files by paths not relative to the output folder: {outside[:3]}")
            missing = [p for p in named if not self.staged(p)]
            if missing:
                raise ExportError(f"the summary names files that were not written: {missing[:3]}")
            atomic_write(staging / SUMMARY_NAME,
                         lambda tmp: Path(tmp).write_text(json.dumps(summary, indent=2, default=str) + "\n"))
        files = sorted(Path(os.path.relpath(os.path.join(d, f), staging)).as_posix()
                       for d, _, names in os.walk(staging) for f in names)
        manifest = {"format": 1, "writer": "flexmb", "pid": os.getpid(), "files": files}
        if self.owner is not None:
            manifest["owner"] = self.owner
        atomic_write(staging / MANIFEST_NAME, lambda tmp: Path(tmp).write_text(json.dumps(manifest, indent=1) + "\n"))
        _check_links(self.path)  # refused now, not past the point of no return
        for rel in {os.path.dirname(f) for f in files if "/" in f}:
            _check_folder(self.path, rel)
        with held():
            os.replace(staging, self.path / _COMMIT)  # the point of no return
            self.committed = True
            _roll_forward(self.path)


def _summary_files(summary: dict) -> list[str]:
    """The file paths a summary names under ``"files"`` (also nested ``"vtk"`` entries of built-in scenes)."""
    out = []
    for key, value in summary.items():
        if key in ("files",) and isinstance(value, dict):
            out += [v for v in value.values() if isinstance(v, str)]
        elif key == "vtk" and isinstance(value, str):
            out.append(value)
        elif isinstance(value, dict) and key != "files":
            out += [v for k, v in value.items() if k == "vtk" and isinstance(v, str)]
    return out
