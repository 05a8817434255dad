"""Pictures of results: off-screen renders and GIFs (pyvista), time histories (matplotlib).

pyvista and matplotlib come with the ``viz`` extra (``pip install
flexmb[viz]``) and are imported inside the functions, so ``import flexmb``
never loads them. The scene is the one :mod:`flexmb.export.vtk` writes:
rigid bodies as a bar from the body-frame origin to the mass centre with a
ball at the mass centre, flexible bodies as their deformed centre line.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from attrs import evolve, field, frozen

from ._files import atomic_write
from ._names import name_of
from .errors import ExportError
from .joints import Joint

__all__ = ["RenderOptions", "render_state", "animate", "plot", "plot_envelope", "plot_station"]

_VIEWS = ("auto", "xy", "xz", "yz", "iso")


def _check_view(instance, attribute, value):
    if value not in _VIEWS:
        raise ExportError(f"RenderOptions: view must be one of {list(_VIEWS)}, got {value!r}")


def _check_window(instance, attribute, value):
    if len(value) != 2 or any(int(v) != v or v < 16 for v in value):
        raise ExportError(f"RenderOptions: window_size must be two integers >= 16 (pixels), got {value!r}")


def _check_radius(instance, attribute, value):
    if value is not None and not (np.isfinite(value) and value > 0):
        raise ExportError(f"RenderOptions: radius must be > 0 (m) or None, got {value!r}")


@frozen
class RenderOptions:
    """How :func:`render_state` and :func:`animate` draw a scene.

    Parameters
    ----------
    window_size : tuple of int
        Image width and height, pixels.
    background : str
        Background colour (any matplotlib/pyvista colour name or hex).
    cmap : str, optional
        Colour map; default ``'tab10'`` when colouring by ``body_id``,
        ``'viridis'`` when colouring by ``scalars``.
    scalars : {None, 'displacement', 'velocity'}
        Colour by the magnitude of this point data instead of by body.
    radius : float, optional
        Tube radius, m; default 1 % of the largest extent of the scene.
    view : {'auto', 'xy', 'xz', 'yz', 'iso'}
        Camera direction; ``'auto'`` looks along the axis in which the
        bodies move least (the normal of a planar mechanism).
    triad : float
        Body-axis line length for rigid bodies, m (0: none).
    """

    window_size: tuple = field(default=(800, 600), converter=tuple, validator=_check_window)
    background: str = "white"
    cmap: str | None = None
    scalars: str | None = field(default=None)
    radius: float | None = field(default=None, validator=_check_radius)
    view: str = field(default="auto", validator=_check_view)
    triad: float = 0.0

    @scalars.validator
    def _check_scalars(self, attribute, value):
        if value not in (None, "displacement", "velocity"):
            raise ExportError(f"RenderOptions: scalars must be None, 'displacement' or 'velocity', got {value!r}")


def _options(options, kw) -> RenderOptions:
    options = RenderOptions() if options is None else options
    if not isinstance(options, RenderOptions):
        raise ExportError(f"options must be a RenderOptions, got {type(options).__name__}")
    try:
        return evolve(options, **kw)
    except TypeError as exc:
        raise ExportError(f"unknown render option: {exc}") from None


def _pyvista():
    try:
        import pyvista as pv
    except ImportError as exc:
        raise ExportError("rendering needs pyvista: pip install 'flexmb[viz]'") from exc
    return pv


def _polydata(pv, mesh, opts):
    """Lines of the scene as PolyData with per-point body id and scalars."""
    points = np.asarray(mesh.points, dtype=float)
    lines = mesh.cells_dict.get("line", np.zeros((0, 2), dtype=int))
    body = np.zeros(len(points))
    for cells, ids in zip(mesh.cells, mesh.cell_data["body_id"]):
        body[cells.data.ravel()] = np.repeat(ids, cells.data.shape[1])
    poly = pv.PolyData(points, lines=np.hstack([np.full((len(lines), 1), 2), lines]).ravel())
    poly.point_data["body_id"] = body
    if opts.scalars:
        poly.point_data[opts.scalars] = np.linalg.norm(mesh.point_data[opts.scalars], axis=1)
    centres = mesh.cells_dict.get("vertex", np.zeros((0, 1), dtype=int)).ravel()
    return poly, centres


def _extent(points: np.ndarray) -> tuple[np.ndarray, float]:
    lo, hi = points.min(axis=0), points.max(axis=0)
    return np.ravel(np.column_stack([lo, hi])), float(np.max(hi - lo)) or 1.0


class _Scene:
    """A plotter with a fixed camera, redrawn frame by frame."""

    def __init__(self, meshes, opts):
        pv = _pyvista()
        self.pv, self.opts = pv, opts
        allp = np.concatenate([m.points for m in meshes])
        bounds, size = _extent(allp)
        self.radius = opts.radius or 0.01 * size
        n_bodies = max(int(np.max(np.concatenate(m.cell_data["body_id"]))) for m in meshes) + 1
        self.clim = [0, max(n_bodies - 1, 1)]
        if opts.scalars:
            vals = [np.linalg.norm(m.point_data[opts.scalars], axis=1) for m in meshes]
            top = max(float(np.nanmax(v)) if np.isfinite(v).any() else 0.0 for v in vals)
            self.clim = [0.0, top or 1.0]
        self.plotter = pv.Plotter(off_screen=True, window_size=list(opts.window_size))
        self.plotter.set_background(opts.background)
        view = opts.view
        if view == "auto":
            spread = np.ptp(allp, axis=0)
            view = ("yz", "xz", "xy")[int(np.argmin(spread))]
        getattr(self.plotter, "view_isometric" if view == "iso" else f"view_{view}")()
        pad = bounds.copy()
        pad[0::2] -= 3 * self.radius
        pad[1::2] += 3 * self.radius
        self.plotter.reset_camera(bounds=pad)
        self.actors = []

    def draw(self, mesh):
        for actor in self.actors:
            self.plotter.remove_actor(actor)
        poly, centres = _polydata(self.pv, mesh, self.opts)
        scalars = self.opts.scalars or "body_id"
        cmap = self.opts.cmap or ("viridis" if self.opts.scalars else "tab10")
        kw = dict(scalars=scalars, cmap=cmap, clim=self.clim, show_scalar_bar=bool(self.opts.scalars))
        if self.opts.scalars:
            unit = "m" if scalars == "displacement" else "m/s"
            kw["scalar_bar_args"] = dict(title=f"|{scalars}| ({unit})", fmt="%.3g", n_labels=3, color="black")
        tubes = poly.tube(radius=self.radius, n_sides=16)
        self.actors = [self.plotter.add_mesh(tubes, **kw)]
        if len(centres):
            balls = self.pv.PolyData(poly.points[centres])
            balls.point_data[scalars] = poly.point_data[scalars][centres]
            glyphs = balls.glyph(geom=self.pv.Sphere(radius=2.0 * self.radius), scale=False, orient=False)
            self.actors.append(self.plotter.add_mesh(glyphs, **{**kw, "show_scalar_bar": False}))


def _frames(result, indices, triad):
    from .export.vtk import to_meshio

    return [to_meshio(result, i, triad=triad) for i in indices]


def render_state(result, i: int, path, options: RenderOptions | None = None, **kw) -> Path:
    """Render the bodies at one output time to an image file, off-screen.

    Parameters
    ----------
    result : Result
        A simulation result.
    i : int
        Output index (negative counts from the end).
    path : str or path-like
        Image file (``.png``, ``.jpg``, ...).
    options : RenderOptions, optional
        Drawing options.
    **kw
        Fields of :class:`RenderOptions` to change (``window_size``, ``view``, ...).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ExportError
        On a bad result, index or option, or if pyvista is not installed.

    Notes
    -----
    Renders with ``Plotter(off_screen=True)``; without a display VTK falls
    back to EGL (or OSMesa) by itself. See ``docs/export.md``.
    """
    opts = _options(options, kw)
    mesh = _frames(result, [i], opts.triad)[0]
    scene = _Scene([mesh], opts)
    scene.draw(mesh)
    path = Path(os.fspath(path))
    try:
        return atomic_write(path, lambda tmp: scene.plotter.screenshot(tmp), suffix=path.suffix or ".png")
    finally:
        scene.plotter.close()


def animate(result, path, *, fps: float = 10.0, stride: int = 1, options: RenderOptions | None = None,
            **kw) -> Path:
    """Write an animated GIF of a result, off-screen.

    Parameters
    ----------
    result : Result
        A simulation result.
    path : str or path-like
        The ``.gif`` file.
    fps : float
        Frames per second of the GIF.
    stride : int
        Use every ``stride``-th output time.
    options : RenderOptions, optional
        Drawing options.
    **kw
        Fields of :class:`RenderOptions` to change.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ExportError
        On a bad result or option, or if pyvista or imageio is missing.
    """
    opts = _options(options, kw)
    if int(stride) != stride or stride < 1:
        raise ExportError(f"stride must be an integer >= 1, got {stride!r}")
    if not (np.isfinite(fps) and fps > 0):
        raise ExportError(f"fps must be > 0, got {fps!r}")
    try:
        import imageio  # noqa: F401  (pyvista's open_gif writes through it)
    except ImportError as exc:
        raise ExportError("animate needs imageio: pip install 'flexmb[viz]'") from exc
    nt = len(np.asarray(getattr(result, "t", [])))
    meshes = _frames(result, range(0, max(nt, 1), int(stride)), opts.triad)
    scene = _Scene(meshes, opts)

    def write(tmp):
        scene.plotter.open_gif(tmp, fps=fps)
        try:
            for mesh in meshes:
                scene.draw(mesh)
                scene.plotter.write_frame()
        finally:
            # flush the GIF before it is renamed into place
            scene.plotter.mwriter.close()
            scene.plotter.mwriter = None

    try:
        return atomic_write(Path(os.fspath(path)), write, suffix=".gif")
    finally:
        scene.plotter.close()


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


def plot(result, coords=None, path=None, *, energy: bool = False, figsize=(7.0, 4.0)):
    """Plot time histories of coordinates with matplotlib.

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
        Add a second panel with kinetic, potential and total energy, J.
    figsize : tuple of float
        Figure size, inches.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.

    Raises
    ------
    ExportError
        If a name matches no coordinate, or matplotlib is not installed.
    """
    try:
        import matplotlib  # noqa: F401
    except ImportError as exc:
        raise ExportError("plot needs matplotlib: pip install 'flexmb[viz]'") from exc
    cols = _columns(result, coords)
    n_ax = 2 if energy else 1
    if path is None:
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(n_ax, 1, sharex=True, figsize=figsize, squeeze=False)
    else:
        from matplotlib.figure import Figure

        fig = Figure(figsize=figsize)
        axes = fig.subplots(n_ax, 1, sharex=True, squeeze=False)
    axes = axes[:, 0]
    t = np.asarray(result.t)
    for c in cols:
        axes[0].plot(t, np.asarray(result.x)[:, c], label=result.coordinate_names[c])
    axes[0].set_ylabel("coordinate (rad or m)")
    if 0 < len(cols) <= 12:
        axes[0].legend(fontsize="small")
    if energy:
        axes[1].plot(t, result.kinetic, label="kinetic")
        axes[1].plot(t, result.potential, label="potential")
        axes[1].plot(t, np.asarray(result.kinetic) + np.asarray(result.potential), "k--", label="total")
        axes[1].set_ylabel("energy (J)")
        axes[1].legend(fontsize="small")
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
