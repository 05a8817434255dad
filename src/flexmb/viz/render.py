"""Off-screen renders and GIFs of results (pyvista).

pyvista comes with the ``viz`` extra (``pip install flexmb[viz]``) and is
imported inside the functions, so ``import flexmb`` never loads it. The scene is the one :mod:`flexmb.export.vtk` writes:
with the system the result came from (``system=``), bodies as their shapes
through their joint points (boxes and bars of their real size, segment
sections, joints as balls); without it, rigid bodies as lines through the
frame origin and mass centre and flexible bodies as their centre lines.
Lines are drawn as tubes.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from attrs import evolve, field, frozen

from .._files import atomic_write
from ..errors import ExportError
from .offscreen import _pyvista, offscreen_plotter

__all__ = ["Picture", "RenderOptions", "render_state", "animate"]

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
        Colour map; default ``'tab10'`` when colouring by body,
        ``'viridis'`` when colouring by ``scalars``.
    scalars : {None, 'displacement', 'velocity', 'von_mises'}
        Colour by the magnitude of this point data instead of by body
        (``displacement``: from the first output; ``von_mises`` needs the
        system of a model with flexible bodies).
    radius : float, optional
        Tube radius, m; default 1 % of the largest extent of the scene.
    view : {'auto', 'xy', 'xz', 'yz', 'iso'}
        Camera direction; ``'auto'`` looks along the axis in which the
        bodies move least (the normal of a planar mechanism).
    triad : float
        Body-axis line length for rigid bodies, m (0: none).
    legend : bool
        When colouring by body, add a legend with the body names.
    """

    window_size: tuple = field(default=(800, 600), converter=tuple, validator=_check_window)
    background: str = "white"
    cmap: str | None = None
    scalars: str | None = field(default=None)
    radius: float | None = field(default=None, validator=_check_radius)
    view: str = field(default="auto", validator=_check_view)
    triad: float = 0.0
    legend: bool = False

    @scalars.validator
    def _check_scalars(self, attribute, value):
        if value not in _SCALARS:
            raise ExportError(f"RenderOptions: scalars must be one of {list(_SCALARS)}, got {value!r}")


_SCALARS = (None, "displacement", "velocity", "von_mises")
_UNITS = {"displacement": "m", "velocity": "m/s", "von_mises": "Pa"}


def _options(options, kw) -> RenderOptions:
    options = RenderOptions() if options is None else options
    if not isinstance(options, RenderOptions):
        raise ExportError(f"options must be a RenderOptions, got {type(options).__name__}")
    try:
        return evolve(options, **kw)
    except TypeError as exc:
        raise ExportError(f"unknown render option: {exc}") from None


def _parts(pv, mesh, scalars):
    """The mesh's lines (PolyData), solids (hexahedra and quads), joint balls and other points.

    Cell data ``body_id`` on each; with ``scalars``, point data ``value`` (its magnitude).
    """
    points = np.asarray(mesh.points, dtype=float)
    value = None
    if scalars:
        value = np.asarray(mesh.point_data[scalars], dtype=float)
        value = np.linalg.norm(value, axis=1) if value.ndim == 2 else np.abs(value)
    lines, solids, joints, dots = [], {}, [], []
    blocks = list(zip(mesh.cells, mesh.cell_data["body_id"], mesh.cell_data["part_id"]))
    # a flexible body's centre line runs inside its segments' blocks: draw it only without them
    centre = not any(b.type == "hexahedron" for b, _, _ in blocks)
    for block, body, part in blocks:
        data = np.asarray(block.data)
        if block.type == "line":
            keep = centre | (part != _CENTRE_PART)
            lines.append((data[keep], body[keep]))
        elif block.type in ("hexahedron", "quad"):
            solids[(block.type, len(solids))] = (data, body)
        elif block.type == "vertex":
            joints.append(data[part == _JOINT_PART].ravel())
            dots.append((data[part != _JOINT_PART].ravel(), body[part != _JOINT_PART]))

    def with_data(obj, body):
        obj.cell_data["body_id"] = np.asarray(body, dtype=float)
        if value is not None:
            obj.point_data["value"] = value
        return obj

    out = {}
    conn = np.concatenate([d for d, _ in lines]) if lines else np.zeros((0, 2), dtype=int)
    if len(conn):
        poly = pv.PolyData(points, lines=np.hstack([np.full((len(conn), 1), 2), conn]).ravel())
        out["lines"] = with_data(poly, np.concatenate([b for _, b in lines]))
    if solids:
        vtk_type = {"hexahedron": pv.CellType.HEXAHEDRON, "quad": pv.CellType.QUAD}
        cells = np.concatenate([np.hstack([np.full((len(d), 1), d.shape[1]), d]).ravel() for d, _ in solids.values()])
        types = np.concatenate([np.full(len(d), vtk_type[t], dtype=np.uint8) for (t, _), (d, _) in solids.items()])
        grid = pv.UnstructuredGrid(cells, types, points)
        out["solids"] = with_data(grid, np.concatenate([b for _, b in solids.values()]))
    idx = np.concatenate(joints) if joints else np.zeros(0, dtype=int)
    if len(idx):
        out["joints"] = pv.PolyData(points[idx])
    idx = np.concatenate([d for d, _ in dots]) if dots else np.zeros(0, dtype=int)
    if len(idx):
        cloud = pv.PolyData(points[idx])
        cloud.point_data["body_id"] = np.concatenate([b for _, b in dots]).astype(float)
        if value is not None:
            cloud.point_data["value"] = value[idx]
        out["dots"] = cloud
    return out


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
        self.n_bodies = max(int(np.max(np.concatenate(m.cell_data["body_id"]))) for m in meshes) + 1
        if opts.scalars:
            vals = [np.linalg.norm(np.reshape(m.point_data[opts.scalars], (len(m.points), -1)), axis=1)
                    for m in meshes]
            top = max(float(np.nanmax(v)) if np.isfinite(v).any() else 0.0 for v in vals)
            self.clim = [0.0, top or 1.0]
        self.plotter = offscreen_plotter(window_size=list(opts.window_size))
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
        self.legend = None

    def _style(self, scalars_name, bar=False):
        if self.opts.scalars:
            unit = _UNITS[self.opts.scalars]
            kw = dict(scalars=scalars_name, cmap=self.opts.cmap or "viridis", clim=self.clim, show_scalar_bar=bar)
            if bar:
                kw["scalar_bar_args"] = dict(title=f"|{self.opts.scalars}| ({unit})", fmt="%.3g", n_labels=3,
                                             color="black")
            return kw
        n = max(self.n_bodies, 2)
        return dict(scalars="body_id", cmap=self.opts.cmap or "tab10", clim=[-0.5, n - 0.5], n_colors=n,
                    show_scalar_bar=False)

    def draw(self, mesh):
        pv = self.pv
        for actor in self.actors:
            self.plotter.remove_actor(actor)
        self.actors = []
        parts = _parts(pv, mesh, self.opts.scalars)
        scalars = "value" if self.opts.scalars else "body_id"
        bar = True
        if "lines" in parts:
            tubes = parts["lines"].tube(radius=self.radius, n_sides=16)
            self.actors.append(self.plotter.add_mesh(tubes, **self._style(scalars, bar)))
            bar = False
        if "solids" in parts:
            self.actors.append(self.plotter.add_mesh(parts["solids"], **self._style(scalars, bar)))
        if "dots" in parts:  # bodies drawn as a point (a point mass, a bar without length)
            glyphs = parts["dots"].glyph(geom=pv.Sphere(radius=2.0 * self.radius), scale=False, orient=False)
            self.actors.append(self.plotter.add_mesh(glyphs, **self._style(scalars)))
        if "joints" in parts:
            glyphs = parts["joints"].glyph(geom=pv.Sphere(radius=1.6 * self.radius), scale=False, orient=False)
            self.actors.append(self.plotter.add_mesh(glyphs, color="dimgray"))
        if self.opts.legend and not self.opts.scalars and not self.legend:
            import matplotlib

            cmap = matplotlib.colormaps[self.opts.cmap or "tab10"].resampled(max(self.n_bodies, 2))
            from ..export.vtk import table_names

            names = table_names(mesh.field_data, "body")
            self.legend = self.plotter.add_legend([[n, cmap(k)[:3]] for k, n in enumerate(names)],
                                                  bcolor="white", face="rectangle", loc="lower right",
                                                  size=(0.2, 0.04 * len(names)))


# flexmb.export.vtk.PARTS: the part_id of centre lines and joints
_CENTRE_PART, _JOINT_PART = 1, 3


def _frames(result, indices, opts, system=None):
    from ..export.vtk import to_meshio

    meshes = [to_meshio(result, i, system=system, triad=opts.triad) for i in indices]
    if opts.scalars == "displacement":
        first = to_meshio(result, 0, system=system, triad=opts.triad).points
        for mesh in meshes:
            mesh.point_data["displacement"] = mesh.points - first
    elif opts.scalars and opts.scalars not in meshes[0].point_data:
        raise ExportError(f"the result has no {opts.scalars!r} to colour by"
                          + (": pass system= of a model with flexible bodies" if opts.scalars == "von_mises"
                             else ""))
    return meshes


class Picture(type(Path())):
    """The path of a rendered image that shows itself where pictures can be shown.

    A :class:`pathlib.Path` in every respect (what :meth:`flexmb.Result.show`
    returns in a script), it also gives IPython and Jupyter the PNG
    (``_repr_png_``) and HTML renderers such as sphinx-gallery the image
    embedded in an ``<img>`` tag (``_repr_html_``), so that a notebook cell or
    a documentation page ending in ``result.show()`` shows the picture.

    Parameters
    ----------
    *args : str or path-like
        The image file, as for :class:`pathlib.Path`.
    **kwargs
        As for :class:`pathlib.Path`.

    Examples
    --------
    >>> from flexmb.viz import Picture
    >>> Picture("results", "state.png").name
    'state.png'
    """

    def _repr_png_(self) -> bytes | None:
        """The PNG's bytes (None, so that IPython shows the path, if the file is not a PNG)."""
        data = self.read_bytes()
        return data if data[:8] == b"\x89PNG\r\n\x1a\n" else None

    def _repr_html_(self) -> str | None:
        """An ``<img>`` with the PNG inline (base64), titled by the file's path."""
        import base64
        from html import escape

        data = self._repr_png_()
        if data is None:
            return None
        return (f'<img src="data:image/png;base64,{base64.b64encode(data).decode("ascii")}" '
                f'alt="{escape(str(self))}" title="{escape(str(self))}">')


def render_state(result, i: int, path, options: RenderOptions | None = None, *, system=None, **kw) -> Path:
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
    system : System or Model, optional
        The model the result came from: bodies drawn through their joints,
        exact velocities, stresses (see :func:`flexmb.export.vtk.to_meshio`).
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
    Renders off-screen (:func:`flexmb.viz.offscreen_plotter`: without a
    display, VTK's EGL window, or OSMesa). See ``docs/export.md``.
    """
    opts = _options(options, kw)
    mesh = _frames(result, [i], opts, system)[0]
    scene = _Scene([mesh], opts)
    scene.draw(mesh)
    path = Path(os.fspath(path))
    try:
        return atomic_write(path, lambda tmp: scene.plotter.screenshot(tmp), suffix=path.suffix or ".png")
    finally:
        scene.plotter.close()


def animate(result, path, *, fps: float = 10.0, stride: int = 1, options: RenderOptions | None = None,
            system=None, **kw) -> Path:
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
    system : System or Model, optional
        The model the result came from (see :func:`render_state`).
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
    meshes = _frames(result, range(0, max(nt, 1), int(stride)), opts, system)
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


