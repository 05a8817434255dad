"""Reading scenes: from a file, from TOML text, or from an already parsed document."""

from __future__ import annotations

import os
import re
import stat
import tomllib
from importlib import resources
from pathlib import Path

from ..errors import SceneError
from .loader import _Loader
from .scene import Scene

__all__ = ["builtin_scenes", "load_builtin", "load_scene", "loads_scene", "scene_from_dict"]


#: the largest scene file read, bytes (a scene is text of a few kB; the limit bounds the parse)
MAX_SCENE_BYTES = 16 * 2**20

#: the most parts of a dotted key (``a.b.c`` has 3); a scene's deepest key paths have a few
MAX_KEY_PARTS = 64
#: a line's key (``a.b = ...``) or table header (``[a.b]``, ``[[a.b]]``); not a value's continuation line
_KEY = re.compile(r"^\s*([A-Za-z0-9_\-.\"' ]+?)\s*=")
_HEADER = re.compile(r"^\s*\[\[?([^\[\],=#]*)\]\]?\s*(?:#.*)?$")


def _check_key_parts(text: str, source: str) -> None:
    """Refuse a dotted key of more than :data:`MAX_KEY_PARTS` parts before parsing (tomllib's time grows
    with the square of the parts: 50,000 of them took minutes)."""
    for number, line in enumerate(text.splitlines(), 1):
        match = _KEY.match(line) or _HEADER.match(line)
        key = match.group(1) if match else ""
        if key.count(".") >= MAX_KEY_PARTS:
            raise SceneError(f"{source}: line {number}: a dotted key of {key.count('.') + 1:,} parts, more than "
                             f"the {MAX_KEY_PARTS} a scene's key paths can have")


def loads_scene(text: str, source: str = "<scene>") -> Scene:
    """Read a scene from TOML text.

    Parameters
    ----------
    text : str
        The TOML document.
    source : str
        Name used in messages (normally the file name).

    Returns
    -------
    Scene
        The scene, its model validated and compiled once.

    Raises
    ------
    SceneError
        On invalid TOML (with its line and column) or an invalid entry (with
        its key path).

    See Also
    --------
    load_scene : Read a scene file.
    """
    _check_key_parts(text, source)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        if msg.endswith("(at end of document)"):  # tomllib gives no line there: name the last one
            msg = f"{msg[:-1]}, line {max(len(text.splitlines()), 1)})"
        raise SceneError(f"{source}: invalid TOML: {msg}") from exc
    stem = Path(source).stem if source != "<scene>" else "scene"
    return _Loader(data, source, stem).load()


def load_scene(path) -> Scene:
    """Read a scene file (TOML, SI units; the format is described in ``docs/scenes.md``).

    Parameters
    ----------
    path : str or path-like
        The ``.toml`` file.

    Returns
    -------
    Scene
        With ``.model``, ``.initial``, ``.solver`` and ``.output``;
        ``scene.simulate()`` runs it and ``scene.run(out)`` writes its
        outputs.

    Raises
    ------
    SceneError
        If the file cannot be read, is not valid TOML, or an entry is
        invalid; the message starts with ``<file>: <key path>:``.

    Examples
    --------
    >>> import flexmb as fm
    >>> scene = fm.load_scene("tutorials/02_fourbar.toml")  # doctest: +SKIP
    >>> scene.simulate().status  # doctest: +SKIP
    'finished'
    """
    path = os.fspath(path)
    try:
        # a FIFO or a device would block or never end: a scene is a regular file of bounded size
        with open(path, "rb", opener=lambda p, flags: os.open(p, flags | os.O_NONBLOCK)) as fh:
            info = os.fstat(fh.fileno())
            if not stat.S_ISREG(info.st_mode):
                raise SceneError(f"{path}: not a regular file (a scene file is read whole, once)")
            if info.st_size > MAX_SCENE_BYTES:
                raise SceneError(f"{path}: {info.st_size:,} bytes, more than a scene file holds "
                                 f"(at most {MAX_SCENE_BYTES:,})")
            raw = fh.read()
    except OSError as exc:
        raise SceneError(f"{path}: cannot read the scene file: {exc.strerror or exc}") from exc
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SceneError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start})") from exc
    return loads_scene(text, source=path)



def scene_from_dict(data: dict, source: str = "<scene>") -> Scene:
    """Build a scene from an already parsed TOML document (a nested dict).

    This is what :func:`loads_scene` does after parsing; parameter studies
    (:mod:`flexmb.study`) use it to build each case from the scene's
    document with some key paths replaced.

    Parameters
    ----------
    data : dict
        The document, as :func:`tomllib.loads` returns it (not modified).
    source : str
        Name used in messages (normally the file name).

    Returns
    -------
    Scene
        The scene, its model validated and compiled once.

    Raises
    ------
    SceneError
        On an invalid entry, with its key path.

    See Also
    --------
    loads_scene : Read a scene from TOML text.

    Examples
    --------
    >>> import flexmb as fm
    >>> doc = {"bodies": {"bar": {"shape": "slender_bar", "mass": 2.0, "length": 1.0}},
    ...        "joints": {"pin": {"type": "revolute", "parent": "ground", "child": "bar"}},
    ...        "solver": {"t_end": 1.0}}
    >>> fm.scene_from_dict(doc).model["bar"].mass
    2.0
    """
    import copy

    if not isinstance(data, dict):
        raise SceneError(f"{source}: a scene must be a table (dict), got {type(data).__name__}")
    stem = Path(source).stem if source != "<scene>" else "scene"
    return _Loader(copy.deepcopy(data), source, stem).load()


def _builtin_folder():
    return resources.files("flexmb.scene") / "builtin"


def builtin_scenes() -> list[str]:
    """Names of the built-in scenes: the scene files shipped in ``flexmb/scene/builtin/``.

    Returns
    -------
    list of str
        Sorted names (``'bicycle'``, ``'fourbar'``, ``'wiper'``), each runnable as ``flexmb run NAME``.

    Examples
    --------
    >>> from flexmb.scene import builtin_scenes
    >>> builtin_scenes()
    ['bicycle', 'fourbar', 'wiper']
    """
    return sorted(f.name.removesuffix(".toml") for f in _builtin_folder().iterdir() if f.name.endswith(".toml"))


def load_builtin(name: str) -> Scene:
    """Read a built-in scene (what ``flexmb run NAME`` runs), named by its name in messages and summaries.

    Parameters
    ----------
    name : str
        One of :func:`builtin_scenes`.

    Returns
    -------
    Scene
        The scene of ``flexmb/scene/builtin/<name>.toml``.

    Raises
    ------
    SceneError
        If there is no built-in scene of that name (the message lists them).

    See Also
    --------
    load_scene : Read any scene file.
    """
    if name not in builtin_scenes():
        raise SceneError(f"no built-in scene {name!r}; pick one of {', '.join(builtin_scenes())}")
    return loads_scene((_builtin_folder() / f"{name}.toml").read_text(encoding="utf-8"), source=name)
