"""Key paths of a scene document: ``bodies.bar.mass`` names one value, and studies and runs replace values by them."""

from __future__ import annotations

from ..errors import SceneError

__all__ = ["key_paths", "set_key"]


def key_paths(key: str) -> list[str]:
    """The key paths one name sets: ``a.b+c.d`` sets both to the same value.

    Parameters
    ----------
    key : str
        One key path, or several joined by ``+``.

    Returns
    -------
    list of str
        The key paths, stripped.
    """
    return [p.strip() for p in key.split("+") if p.strip()]


def set_key(data: dict, path: str, value, source: str, what: str = "varied key") -> None:
    """Set ``data[a][b][c] = value`` for the key path ``a.b.c``; every table on the way must exist.

    Parameters
    ----------
    data : dict
        The scene document (changed in place).
    path : str
        The key path.
    value : object
        The new value (a whole table replaces the table there).
    source : str
        Name of the scene, for messages.
    what : str
        What sets the key, for messages (``'varied key'``, ``'key of run rigid'``).

    Raises
    ------
    SceneError
        If a table on the way does not exist (the message lists the tables there).
    """
    keys = path.split(".")
    node, walked = data, []
    for k in keys[:-1]:
        walked.append(k)
        child = node.get(k) if isinstance(node, dict) else None
        if not isinstance(child, dict):
            here = ".".join(walked)
            known = ", ".join(sorted(k2 for k2, v in node.items() if isinstance(v, dict))) or "none"
            kind = "no such table" if child is None else "not a table"
            raise SceneError(f"{source}: {here}: {kind} in the scene ({what} {path!r}); tables here: {known}", here)
        node = child
    node[keys[-1]] = value
