"""Name tables of bodies, joints, forces, constraints, contacts, complements and integrators, from entry points.

Every named class flexmb can look up -- the built-ins included -- comes from
an entry-point group ``flexmb.<kind>``: ``flexmb.bodies``, ``flexmb.joints``, ``flexmb.constraints``,
``flexmb.forces``, ``flexmb.contacts`` (contact geometries and their normal and friction laws),
``flexmb.complements`` and ``flexmb.integrators``. A third
party adds a plugin by declaring an entry point in its own ``pyproject.toml``;
a script adds one for the current session with :func:`register`.

The groups are read lazily, all of them in one pass over the installed
distributions per session, on the first lookup (:func:`refresh` re-reads
them), and a plugin is imported only when it is looked up or listed. A plugin that fails to import, or that is not a subclass
of its kind's base class, is reported by a :class:`~flexmb.errors.PluginError`
naming it, its distribution and the cause, without disturbing the other
plugins. A name claimed by two distributions is an error too: looking it up
raises a ``PluginError`` naming both (pluggy would silently keep one).

flexmb's own names are its entry points in ``pyproject.toml``, read from the
installed metadata like anyone else's: that is the one list of built-in
names. flexmb is always installed (``pip install -e .`` in a checkout); if its
metadata is missing, a lookup raises a ``PluginError`` saying so.
:func:`builtin_table` gives read-only views of the built-ins of a kind
(``flexmb.COMPLEMENTS``, ``flexmb.INTEGRATORS``).
"""

from __future__ import annotations

import importlib
import importlib.metadata
import itertools
import re
import threading
from collections.abc import Mapping
from typing import Any

from attrs import define, field, frozen

from .errors import PluginError

__all__ = ["KINDS", "BuiltinTable", "PluginInfo", "builtin_table", "get", "names", "path", "plugins", "refresh",
           "register"]

#: Plugin kinds and the base class (``module:qualname``) a plugin must subclass, or the base classes it
#: may subclass one of. The entry-point group of a kind is ``flexmb.<kind>``.
KINDS = {
    "bodies": "flexmb.bodies:Body",
    "joints": "flexmb.joints:Joint",
    "forces": "flexmb.forces:ForceElement",
    "constraints": "flexmb.constraint_elements:ConstraintElement",
    # contact geometries (force elements of the contact kind) and their normal and friction laws
    "contacts": ("flexmb.forces.contact_base:Contact", "flexmb.forces.contact_laws:NormalLaw",
                 "flexmb.forces.friction_laws:FrictionLaw"),
    "complements": "flexmb.complements.base:ComplementStrategy",
    "integrators": "scipy.integrate:OdeSolver",
}

_ALIASES = {"body": "bodies", "joint": "joints", "force": "forces", "constraint": "constraints", "contact": "contacts",
            "complement": "complements",
            "integrator": "integrators"}

_SESSION = "session"
_UNKNOWN = "an unknown distribution"


@frozen
class PluginInfo:
    """One row of the plugin listing.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    kind : {'bodies', 'joints', 'forces', 'constraints', 'contacts', 'complements', 'integrators'}
        The plugin kind (entry-point group ``flexmb.<kind>``).
    name : str
        The name it is looked up by.
    value : str
        Import path of the object, ``module:qualname``.
    origin : str
        Distribution and version (``"flexmb 0.1.0"``), or ``"session"`` for
        :func:`register`.
    status : {'ok', 'broken', 'conflict'}
        Whether it loads; ``'conflict'`` when several distributions claim
        the name (one row each).
    error : str
        Why it is broken or in conflict (empty when ok).
    """

    kind: str
    name: str
    value: str
    origin: str
    status: str
    error: str = ""


@define
class _Entry:
    """Mutable record of one claimant of a name; the loaded object is cached on it."""

    kind: str
    name: str
    value: str
    origin: str
    dist: str | None
    loader: Any = field(repr=False)
    obj: Any = None
    loaded: bool = False
    error: str = ""
    cause: BaseException | None = field(default=None, repr=False)

    def describe(self) -> str:
        return f"{self.kind} plugin {self.name!r} ({self.value}) from {_from(self.origin)}"


_lock = threading.RLock()
_groups: dict[str, dict[str, list[_Entry]]] = {}
_scanned: dict[str, list] = {}  # entry-point group -> its entry points, from the session's one read
_session: dict[str, dict[str, _Entry]] = {}


def _from(origin: str) -> str:
    return origin if origin in (_SESSION, _UNKNOWN) else f"distribution {origin}"


def _normalize(dist_name: str | None) -> str | None:
    return None if dist_name is None else re.sub(r"[-_.]+", "-", dist_name).lower()


def _kind(kind: str) -> str:
    k = _ALIASES.get(kind, kind)
    if k not in KINDS:
        raise PluginError(f"unknown plugin kind {kind!r}; pick one of {list(KINDS)}")
    return k


def _import(path: str):
    module, _, qualname = path.partition(":")
    obj = importlib.import_module(module)
    for attr in filter(None, qualname.split(".")):
        obj = getattr(obj, attr)
    return obj


def _base(kind: str) -> type | tuple[type, ...]:
    bases = KINDS[kind]
    return _import(bases) if isinstance(bases, str) else tuple(_import(b) for b in bases)


def _path_of(obj) -> str:
    return f"{getattr(obj, '__module__', '?')}:{getattr(obj, '__qualname__', type(obj).__qualname__)}"


def _not_subclass(kind: str, obj) -> str | None:
    """Why ``obj`` cannot be a ``kind`` plugin, or None if it can."""
    base = _base(kind)
    if isinstance(obj, type) and issubclass(obj, base):
        return None
    what = f"class {_path_of(obj)}" if isinstance(obj, type) else f"a {type(obj).__name__} instance, not a class"
    bases = KINDS[kind]
    return f"{what}; it must be a subclass of {bases if isinstance(bases, str) else ' or '.join(bases)}"


_dists: dict[int, tuple] = {}  # id(distribution) -> (distribution, name, version), for the session


def _name_version(dist) -> tuple[str | None, str | None]:
    """A distribution's name and version, its metadata parsed once per session.

    ``importlib.metadata`` parses a distribution's metadata file again at
    every ``dist.name`` and ``dist.version``: twice per entry point, for
    every entry point of a group, without this.
    """
    if dist is None:
        return None, None
    known = _dists.get(id(dist))
    if known is None or known[0] is not dist:
        if isinstance(dist, importlib.metadata.Distribution):
            meta = dist.metadata
            known = (dist, meta["Name"], meta["Version"])
        else:
            known = (dist, getattr(dist, "name", None), getattr(dist, "version", None))
        _dists[id(dist)] = known
    return known[1], known[2]


def _read(kind: str) -> dict[str, list[_Entry]]:
    """Read the entry-point group of ``kind`` (the only place entry points are read).

    Raises
    ------
    PluginError
        If flexmb's own entry points are missing (flexmb is not installed).
    """
    table: dict[str, list[_Entry]] = {}
    flexmb_seen = False
    if not _scanned:  # every kind's group in one read (each read parses every distribution's entry points)
        _scanned.update({f"flexmb.{k}": [] for k in KINDS})
        found = importlib.metadata.entry_points()
        # Python 3.11 gives a dict of groups (its dict interface otherwise warns), later versions the entry points
        for ep in itertools.chain.from_iterable(dict.values(found)) if isinstance(found, dict) else found:
            if ep.group in _scanned:
                _scanned[ep.group].append(ep)
    for ep in _scanned[f"flexmb.{kind}"]:
        dist_name, dist_version = _name_version(getattr(ep, "dist", None))
        origin = f"{dist_name} {dist_version or '?'}" if dist_name else _UNKNOWN
        flexmb_seen |= _normalize(dist_name) == "flexmb"
        claimants = table.setdefault(ep.name, [])
        # one distribution found twice on the path (egg-info and dist-info) is not a conflict
        if any(c.dist is not None and c.dist == _normalize(dist_name) for c in claimants):
            continue
        claimants.append(_Entry(kind, ep.name, ep.value, origin, _normalize(dist_name), ep.load))
    if not flexmb_seen:
        raise PluginError(f"flexmb's own {kind} (entry-point group flexmb.{kind}) are not in the installed "
                          "metadata: flexmb is not installed. Install it, in a checkout with "
                          "`python -m pip install -e .` (rerun it after editing the entry points in pyproject.toml)")
    return table


def _table(kind: str) -> dict[str, list[_Entry]]:
    """Claimants per name: the entry points (read once) overlaid by the session's registrations."""
    if kind not in _groups:
        _groups[kind] = _read(kind)
    merged = dict(_groups[kind])
    merged.update({name: [e] for name, e in _session.get(kind, {}).items()})
    return merged


def _conflict(entries: list[_Entry]) -> str:
    e = entries[0]
    claims = "; ".join(f"{c.origin} ({c.value})" for c in entries)
    return (f"{e.kind} plugin name {e.name!r} is claimed by {len(entries)} distributions: {claims}. "
            f"Uninstall all but one, or pick one for this session with "
            f"flexmb.register({e.kind!r}, {e.name!r}, cls, replace=True)")


def _load(entry: _Entry) -> None:
    """Import the entry's object once; on failure record why, keeping the other plugins usable."""
    if entry.loaded or entry.error:
        return
    try:
        obj = entry.loader()
    except Exception as exc:  # any import-time failure of a plugin is reported, not propagated
        entry.error = f"{entry.describe()} failed to load: {type(exc).__name__}: {exc}"
        entry.cause = exc
        return
    why = _not_subclass(entry.kind, obj)
    if why:
        entry.error = f"{entry.describe()} is {why}"
        return
    entry.obj, entry.loaded = obj, True


def get(kind: str, name: str) -> type:
    """Return the class registered as ``name`` for ``kind``, importing it if needed.

    Parameters
    ----------
    kind : {'bodies', 'joints', 'forces', 'constraints', 'contacts', 'complements', 'integrators'}
        Plugin kind (the singular, e.g. ``'joint'``, is accepted too).
    name : str
        Plugin name, e.g. ``'revolute'`` or ``'RK45'``.

    Returns
    -------
    type
        The plugin class, a subclass of the kind's base class.

    Raises
    ------
    PluginError
        If the name is unknown (the message lists the valid ones), claimed
        by several distributions (the message names them), or the plugin
        fails to import or is not a subclass of the base class.

    See Also
    --------
    names : The names known for a kind.
    register : Add a plugin for the session.

    Examples
    --------
    >>> from flexmb import registry
    >>> registry.get("joints", "revolute").__name__
    'Revolute'
    """
    kind = _kind(kind)
    with _lock:
        entry = _entry(kind, name)
        _load(entry)
    if entry.error:
        raise PluginError(entry.error) from entry.cause
    return entry.obj


def _entry(kind: str, name: str) -> _Entry:
    """The one claimant of ``name``; raises for an unknown or conflicting name (the caller holds the lock)."""
    entries = _table(kind).get(name)
    if not entries:
        raise PluginError(f"no {kind} plugin named {name!r}; pick one of {names(kind)}")
    if len(entries) > 1:
        raise PluginError(_conflict(entries))
    return entries[0]


def path(kind: str, name: str) -> str:
    """The import path (``module:qualname``) of the plugin registered as ``name``, without importing it.

    What a caller needs to tell a plugin apart before paying for its
    import: :func:`flexmb.simulate` runs flexmb's ``'CVODE_BDF'`` and
    ``'CVODE_Adams'`` of an open tree or of loops in compiled code
    (:func:`flexmb.integrators.direct_choice.compiled_loop`), without
    importing the scikit-sundae classes registered under those names
    (and scipy.integrate with them).

    Parameters
    ----------
    kind : {'bodies', 'joints', 'forces', 'constraints', 'contacts', 'complements', 'integrators'}
        Plugin kind (the singular is accepted too).
    name : str
        Plugin name.

    Returns
    -------
    str
        The entry point's value, or ``module:qualname`` of the class
        given to :func:`register`.

    Raises
    ------
    PluginError
        If the name is unknown or claimed by several distributions (as
        :func:`get`); a plugin that would fail to load is not noticed.

    Examples
    --------
    >>> from flexmb import registry
    >>> registry.path("integrators", "CVODE_BDF")
    'flexmb.integrators.sundials:CVODEBDF'
    """
    kind = _kind(kind)
    with _lock:
        return _entry(kind, name).value


def names(kind: str) -> list[str]:
    """Sorted names known for ``kind`` (without importing any plugin).

    Parameters
    ----------
    kind : {'bodies', 'joints', 'forces', 'constraints', 'contacts', 'complements', 'integrators'}
        Plugin kind.

    Returns
    -------
    list of str
        All names, including broken or conflicting ones.

    See Also
    --------
    get : Look one up.
    """
    kind = _kind(kind)
    with _lock:
        return sorted(_table(kind))


def plugins(kind: str | None = None) -> list[PluginInfo]:
    """List the plugins, loading each to report its status.

    Parameters
    ----------
    kind : {'bodies', 'joints', 'forces', 'constraints', 'contacts', 'complements', 'integrators'}, optional
        Only this kind (default: all).

    Returns
    -------
    list of PluginInfo
        One row per plugin, by kind then name; a name claimed by several
        distributions gives one ``'conflict'`` row per claimant.

    See Also
    --------
    get : Look one up (raises for a broken or conflicting one).

    Examples
    --------
    >>> import flexmb
    >>> [p.name for p in flexmb.plugins("complements")]
    ['articulated', 'auto', 'eigen', 'qr', 'svd']
    """
    kinds = list(KINDS) if kind is None else [_kind(kind)]
    rows = []
    with _lock:
        for k in kinds:
            for name, entries in sorted(_table(k).items()):
                if len(entries) > 1:
                    msg = _conflict(entries)
                    rows += [PluginInfo(k, name, e.value, e.origin, "conflict", msg) for e in entries]
                    continue
                e = entries[0]
                _load(e)
                rows.append(PluginInfo(k, name, e.value, e.origin, "broken" if e.error else "ok", e.error))
    return rows


def register(kind: str, name: str, obj: type, *, replace: bool = False) -> None:
    """Add a plugin for the current session.

    Parameters
    ----------
    kind : {'bodies', 'joints', 'forces', 'constraints', 'contacts', 'complements', 'integrators'}
        Plugin kind (the singular is accepted too).
    name : str
        Name to look it up by.
    obj : type
        The class, a subclass of the kind's base class (``Body``, ``Joint``,
        ``ForceElement``, ``ComplementStrategy``, scipy ``OdeSolver``).
    replace : bool
        Allow overriding an existing name (a built-in, an installed plugin,
        or an earlier registration) for this session; this also settles a
        conflict between two distributions.

    Raises
    ------
    PluginError
        If ``obj`` is not a subclass of the base class, or ``name`` exists
        and ``replace`` is false.

    See Also
    --------
    plugins : The listing, where session plugins show origin ``'session'``.

    Examples
    --------
    >>> import flexmb
    >>> class Mine(flexmb.SVDComplement):
    ...     name = "mine"
    >>> flexmb.register("complements", "mine", Mine)
    >>> flexmb.get_complement("mine").name
    'mine'
    """
    kind = _kind(kind)
    if not isinstance(name, str) or not name or name != name.strip():
        raise PluginError(f"cannot register {kind} plugin {name!r}: the name must be a non-empty string without "
                          "surrounding spaces")
    why = _not_subclass(kind, obj)
    if why:
        raise PluginError(f"cannot register {kind} plugin {name!r}: it is {why}")
    with _lock:
        existing = _table(kind).get(name)
        if existing and not replace:
            origins = ", ".join(e.origin for e in existing)
            raise PluginError(f"a {kind} plugin named {name!r} already exists (from {origins}); "
                              "pass replace=True to override it for this session")
        _session.setdefault(kind, {})[name] = _Entry(kind, name, _path_of(obj), _SESSION, None, lambda: obj,
                                                     obj=obj, loaded=True)


def refresh() -> None:
    """Forget the entry points read so far; the next lookup reads them again.

    Call it after installing a plugin in a running session. Registrations
    made with :func:`register` are kept.

    See Also
    --------
    plugins : List what was found.
    """
    with _lock:
        _groups.clear()
        _scanned.clear()
        _dists.clear()


def _builtin_entries(kind: str) -> dict[str, _Entry]:
    """flexmb's own claimant of each of its names of ``kind`` (a session override does not hide it)."""
    with _lock:
        if kind not in _groups:
            _groups[kind] = _read(kind)
        return {name: e for name, entries in _groups[kind].items() for e in entries if e.dist == "flexmb"}


class BuiltinTable(Mapping):
    """Read-only view of flexmb's own plugins of one kind: name -> class, from its installed entry points.

    Parameters
    ----------
    kind : {'bodies', 'joints', 'forces', 'constraints', 'contacts', 'complements', 'integrators'}
        Plugin kind.

    See Also
    --------
    builtin_table : The view of a kind.
    """

    def __init__(self, kind: str):
        self._kind = _kind(kind)

    def __getitem__(self, name: str) -> type:
        entry = _builtin_entries(self._kind).get(name) if isinstance(name, str) else None
        if entry is None:
            raise KeyError(name)
        with _lock:
            _load(entry)
        if entry.error:
            raise PluginError(entry.error) from entry.cause
        return entry.obj

    def __iter__(self):
        return iter(sorted(_builtin_entries(self._kind)))

    def __len__(self) -> int:
        return len(_builtin_entries(self._kind))

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._kind!r}: {', '.join(self)})"


def builtin_table(kind: str) -> BuiltinTable:
    """The built-ins of a kind as a read-only mapping (what ``flexmb.COMPLEMENTS`` is for complements).

    Parameters
    ----------
    kind : {'bodies', 'joints', 'forces', 'constraints', 'contacts', 'complements', 'integrators'}
        Plugin kind (the singular is accepted too).

    Returns
    -------
    BuiltinTable
        ``{name: class}`` of flexmb's own entry points of the kind, read
        lazily from the installed metadata; plugins of other distributions
        and session registrations are not in it.

    Examples
    --------
    >>> from flexmb import registry
    >>> sorted(registry.builtin_table("complements"))
    ['articulated', 'auto', 'eigen', 'qr', 'svd']
    """
    return BuiltinTable(kind)
