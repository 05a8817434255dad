"""Time histories of results and section fields (matplotlib).

matplotlib comes with the ``viz`` extra and is imported inside the
functions, so ``import flexmb`` never loads it.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .._files import atomic_write
from .._names import name_of
from ..errors import ExportError
from ..joints import Joint

__all__ = ["plot", "coordinate_units", "plot_envelope", "plot_station"]


def _columns(result, coords) -> list[int]:
    names = list(result.coordinate_names)
    if coords is None:
        return list(range(len(names)))
    if isinstance(coords, (str, Joint)):
        coords = [coords]
    cols = []
    for c in coords:
        c = name_of(c, Joint, "plot")
        hits = [names.index(c)] if c in names else [k for k, n in enumerate(names) if n.rsplit(".", 1)[0] == c]
        if not hits:
            raise ExportError(f"no coordinate or joint {c!r}; coordinates are {names}")
        cols += hits
    return cols


def _joint_coordinate_units() -> dict[str, str | None]:
    """Unit of each joint coordinate name, from every joint class loaded (plugins included).

    A joint's coordinates are its translations (m) and then its rotations
    (rad); a name that is a translation in one class and a rotation in
    another maps to None (unknown).
    """
    from ..flexible import SegmentJoint
    from ..joints import Joint

    units: dict[str, str | None] = {}
    todo = [Joint]
    while todo:
        cls = todo.pop()
        todo.extend(cls.__subclasses__())
        names = tuple(getattr(cls, "coordinate_names", ()))
        n_t, n_r = len(cls.translation_axes), len(cls.rotation_axes)
        if issubclass(cls, SegmentJoint) or not names or len(names) != n_t + n_r:
            continue
        for i, name in enumerate(names):
            unit = "m" if i < n_t else "rad"
            units[name] = unit if units.get(name, unit) == unit else None
    return units


def coordinate_units(result) -> list[tuple[str, str]]:
    """What each coordinate of a result is, and its unit.

    Parameters
    ----------
    result : Result
        A simulation result.

    Returns
    -------
    list of (str, str)
        Per column of ``result.x``: the kind of coordinate, one of
        ``'joint angle'``, ``'joint translation'``, ``'elastic rotation'``,
        ``'elastic displacement'`` or ``'coordinate'`` (a plugin joint's
        coordinate of unknown unit), and its unit (``'rad'``, ``'m'`` or
        ``'-'`` when unknown).

    Notes
    -----
    Read from the names: an elastic coordinate is
    ``<flexible body>.j<i>.<kept coordinate>`` (bending and torsion in
    rad, axial and shear in m); a joint coordinate is
    ``<joint>.<coordinate>``, a translation (m) or rotation (rad) of the
    joint classes loaded.
    """
    from ..flexible import ELASTIC_COORDINATES

    joint_units = _joint_coordinate_units()
    flexible = set(getattr(result, "flexible", {}) or {})
    out = []
    for name in result.coordinate_names:
        joint, _, coord = str(name).rpartition(".")
        body, _, seg = joint.rpartition(".")
        if body in flexible and seg[:1] == "j" and seg[1:].isdigit() and coord in ELASTIC_COORDINATES:
            kind = ELASTIC_COORDINATES[coord][0]
            out.append(("elastic displacement", "m") if kind == "t" else ("elastic rotation", "rad"))
        elif joint_units.get(coord) == "m":
            out.append(("joint translation", "m"))
        elif joint_units.get(coord) == "rad":
            out.append(("joint angle", "rad"))
        else:
            out.append(("coordinate", "-"))
    return out


#: the order of the axes of :func:`plot`
_KIND_ORDER = ("joint angle", "joint translation", "elastic rotation", "elastic displacement", "coordinate")


def _coordinate_groups(result, cols) -> list[tuple[str, str, list[int]]]:
    """The columns grouped by (kind, unit), in the order of ``_KIND_ORDER``, columns in the order given."""
    kinds = coordinate_units(result)
    groups: dict[tuple[str, str], list[int]] = {}
    for c in cols:
        groups.setdefault(kinds[c], []).append(c)
    order = sorted(groups, key=lambda key: _KIND_ORDER.index(key[0]))
    return [(kind, unit, groups[(kind, unit)]) for kind, unit in order]


def plot(result, coords=None, path=None, *, energy: bool = False, figsize=None):
    """Plot time histories of coordinates with matplotlib, one axis per kind and unit.

    Joint angles (rad), joint translations (m), elastic rotations (rad) and
    elastic displacements (m) of flexible bodies each get their own axis,
    labelled with the unit (see :func:`coordinate_units`).

    Parameters
    ----------
    result : Result
        A simulation result.
    coords : str, Joint or list of them, optional
        Coordinate names (``"joint.angle"``), or joints or their names (all
        their coordinates); default all.
    path : str or path-like, optional
        Save the figure there; the ending picks the format (``.png``,
        ``.pdf``, ``.svg``). Without it the figure is made with pyplot, to
        show in a notebook or window.
    energy : bool
        Add a last axis with kinetic, potential and total energy, J.
    figsize : tuple of float, optional
        Figure size, inches (default 7 wide, 2.5 high per axis, at least 4).

    Returns
    -------
    matplotlib.figure.Figure
        The figure; its axes share the time axis (s).

    Raises
    ------
    ExportError
        If a name matches no coordinate, or matplotlib is not installed.

    Examples
    --------
    >>> fig = result.plot(["RJ4", "right_blade.j0"])  # doctest: +SKIP
    >>> [ax.get_ylabel() for ax in fig.axes]  # doctest: +SKIP
    ['joint angle (rad)', 'elastic rotation (rad)']
    """
    try:
        import matplotlib  # noqa: F401
    except ImportError as exc:
        raise ExportError("plot needs matplotlib: pip install 'flexmb[viz]'") from exc
    groups = _coordinate_groups(result, _columns(result, coords))
    n_ax = max(len(groups), 1) + bool(energy)
    if figsize is None:
        figsize = (7.0, max(4.0, 1.0 + 2.5 * n_ax))
    if path is None:
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(n_ax, 1, sharex=True, figsize=figsize, squeeze=False)
    else:
        from matplotlib.figure import Figure

        fig = Figure(figsize=figsize)
        axes = fig.subplots(n_ax, 1, sharex=True, squeeze=False)
    axes = axes[:, 0]
    t = np.asarray(result.t)
    x = np.asarray(result.x)
    for ax, (kind, unit, cols) in zip(axes, groups):
        for c in cols:
            ax.plot(t, x[:, c], label=result.coordinate_names[c])
        ax.set_ylabel(f"{kind} ({unit})")
        if len(cols) <= 12:
            ax.legend(fontsize="small")
    if not groups:
        axes[0].set_ylabel("coordinate (-)")
    if energy:
        axes[-1].plot(t, result.kinetic, label="kinetic")
        axes[-1].plot(t, result.potential, label="potential")
        axes[-1].plot(t, np.asarray(result.kinetic) + np.asarray(result.potential), "k--", label="total")
        axes[-1].set_ylabel("energy (J)")
        axes[-1].legend(fontsize="small")
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    if path is not None:
        path = Path(os.fspath(path))
        fmt = path.suffix.lstrip(".") or "png"
        atomic_write(path, lambda tmp: fig.savefig(tmp, format=fmt), suffix=path.suffix or ".png")
    return fig


def _section_figure(path, figsize):
    try:
        import matplotlib  # noqa: F401
    except ImportError as exc:
        raise ExportError("plots need matplotlib: pip install 'flexmb[viz]'") from exc
    if path is None:
        import matplotlib.pyplot as plt

        return plt.subplots(figsize=figsize)
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    return fig, fig.subplots()


def _section_components(field, components) -> list[int]:
    if not (hasattr(field, "components") and hasattr(field, "values") and hasattr(field, "stations")):
        raise ExportError(f"expected a SectionField (result.section_stresses(body)), got {type(field).__name__}")
    names = list(field.components)
    if components is None:
        components = [c for c in ("sigma_max", "von_mises") if c in names] or names
    elif isinstance(components, str):
        components = [components]
    bad = [c for c in components if c not in names]
    if bad:
        raise ExportError(f"no component(s) {bad}; components are {names}")
    return [names.index(c) for c in components]


def _scale(units):
    """Plot Pa as MPa."""
    return (1e-6, "MPa") if units == "Pa" else (1.0, units)


def _finish(fig, path):
    fig.tight_layout()
    if path is not None:
        path = Path(os.fspath(path))
        fmt = path.suffix.lstrip(".") or "png"
        atomic_write(path, lambda tmp: fig.savefig(tmp, format=fmt), suffix=path.suffix or ".png")
    return fig


def plot_envelope(field, path=None, *, components=None, figsize=(7.0, 4.0)):
    """Plot the envelope of section loads or stresses along a flexible body.

    Parameters
    ----------
    field : SectionField
        From ``result.section_stresses(body)`` (or ``section_loads``,
        ``section_strains``).
    path : str or path-like, optional
        Save the figure there (format from the ending); else use pyplot.
    components : str or list of str, optional
        Components to draw (default ``sigma_max`` and ``von_mises`` when
        present, else all).
    figsize : tuple of float
        Figure size, inches.

    Returns
    -------
    matplotlib.figure.Figure
        The largest absolute value over time against the station position
        (m); stresses in MPa.

    Raises
    ------
    ExportError
        If a component is unknown, or matplotlib is not installed.
    """
    cols = _section_components(field, components)
    fig, ax = _section_figure(path, figsize)
    env = field.envelope()
    for c in cols:
        k, unit = _scale(field.units[c])
        ax.plot(field.stations, k * env.peak[:, c], "o-", label=f"{field.components[c]} ({unit})")
    ax.set_xlabel(f"position along {field.body} (m)")
    ax.set_ylabel("max over time of |value|")
    ax.set_title(f"{field.body}: envelope over t = [{field.t[0]:.3g}, {field.t[-1]:.3g}] s")
    ax.legend(fontsize="small")
    return _finish(fig, path)


def plot_station(field, path=None, *, station: int = 0, components=None, figsize=(7.0, 4.0)):
    """Plot section loads or stresses at one station against time (default: the root).

    Parameters
    ----------
    field : SectionField
        From ``result.section_stresses(body)`` (or ``section_loads``).
    path : str or path-like, optional
        Save the figure there (format from the ending); else use pyplot.
    station : int
        Station index (0: the first segment joint, the root of a clamped
        body; negative counts from the tip).
    components : str or list of str, optional
        Components to draw (default ``sigma_max`` and ``von_mises`` when
        present, else all).
    figsize : tuple of float
        Figure size, inches.

    Returns
    -------
    matplotlib.figure.Figure
        The figure; stresses in MPa.

    Raises
    ------
    ExportError
        If the station or a component is unknown, or matplotlib is not installed.
    """
    cols = _section_components(field, components)
    n = len(field.stations)
    if not -n <= int(station) < n:
        raise ExportError(f"station {station} is out of range: {field.body} has {n} stations")
    fig, ax = _section_figure(path, figsize)
    for c in cols:
        k, unit = _scale(field.units[c])
        ax.plot(field.t, k * field.values[:, station, c], label=f"{field.components[c]} ({unit})")
    ax.set_xlabel("time (s)")
    ax.set_title(f"{field.body} at x = {field.stations[station]:.4g} m")
    ax.legend(fontsize="small")
    return _finish(fig, path)
