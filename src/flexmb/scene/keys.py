"""Key paths of a scene document: ``bodies.bar.mass`` names one value, and studies and runs replace values by them.

A key may index an array: ``initial.point_velocities.tip.velocity[0]`` is
the first component of a point's velocity, ``forces.gravity.g[1]`` the y
component of gravity (indices from 0, as in the loader's messages).
"""

from __future__ import annotations

import re

from ..errors import SceneError

__all__ = ["key_paths", "set_key"]

_STEP = re.compile(r"([^.\[\]]+)((?:\[\d+\])*)")


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


def _steps(path: str, source: str, what: str) -> list:
    """``a.b[1]`` -> ``['a', 'b', 1]``: table keys as strings, array indices as integers."""
    steps = []
    for part in path.split("."):
        m = _STEP.fullmatch(part)
        if m is None:
            raise SceneError(f"{source}: {path}: not a key path ({what}): write table.key or table.key[index], "
                             f"got the part {part!r}", path)
        steps.append(m.group(1))
        steps += [int(i) for i in re.findall(r"\d+", m.group(2))]
    return steps


def _where(steps) -> str:
    return "".join(f"[{s}]" if isinstance(s, int) else f".{s}" for s in steps).lstrip(".")


def set_key(data: dict, path: str, value, source: str, what: str = "varied key") -> None:
    """Set ``data[a][b][c] = value`` for the key path ``a.b.c`` (or ``data[a][b][i]`` for ``a.b[i]``).

    Every table (and array) on the way must exist; the last key of a table
    may be new, the index of an array must be within it.

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
        If a table on the way does not exist (the message lists the tables
        there), or an index is not within its array.
    """
    steps = _steps(path, source, what)
    node = data
    for n, k in enumerate(steps):
        here = _where(steps[:n + 1])
        last = n == len(steps) - 1
        if isinstance(k, int):
            if not isinstance(node, list):
                raise SceneError(f"{source}: {_where(steps[:n])}: not an array in the scene ({what} {path!r})", here)
            if k >= len(node):
                raise SceneError(f"{source}: {here}: index out of range in the scene ({what} {path!r}); the array "
                                 f"has {len(node)} values", here)
        if last:
            node[k] = value
            return
        child = node[k] if isinstance(k, int) else node.get(k)
        wanted = list if isinstance(steps[n + 1], int) else dict
        if not isinstance(child, wanted):
            if wanted is list:
                kind = "no such array" if child is None else "not an array"
                raise SceneError(f"{source}: {here}: {kind} in the scene ({what} {path!r})", here)
            known = ", ".join(sorted(k2 for k2, v in node.items() if isinstance(v, dict))) if isinstance(node, dict) \
                else ""
            kind = "no such table" if child is None else "not a table"
            raise SceneError(f"{source}: {here}: {kind} in the scene ({what} {path!r}); tables here: "
                             f"{known or 'none'}", here)
        node = child
