"""An interactive 3-D viewer of results: one self-contained HTML file.

:func:`write_view` writes the mechanism of one or more results into an
HTML page that animates it in 3-D: a time slider, play/pause, the playing
speed, colour by body, by speed or by von Mises stress, the camera turned
with the mouse. The page holds its data and its renderer (a 2-D canvas
with an orthographic projection, written for flexmb in plain JavaScript,
``viewer.html`` next to this module): it needs no network, no server and
no plugin, opens in any browser and can be sent to a colleague as one file.
:meth:`flexmb.Result.view` writes it and returns a :class:`View`, the
file's path that a notebook shows as the viewer itself.

The scene is the one :mod:`flexmb.export.vtk` writes (boxes and segment
blocks as shaded faces, bars and levers as lines, joints as dark dots):
with the system the result came from, the bodies through their joints and
the stresses of flexible bodies; without it, rigid bodies as lines
through frame origin and mass centre. Only numpy and meshio (core
dependencies) are used: no extra is needed.

The file size is bounded: the page keeps at most ``max_frames`` output
times (default 1000) and at most ``max_bytes`` of per-frame data (default
8 MB: positions and fields as 32-bit floats, base64 in the page: about 4/3
of it), taking evenly spaced outputs, the first and the last among them,
when the result has more; besides, a page holds its renderer (17 kB), the
frame times and the drawing's connectivity.
"""

from __future__ import annotations

import base64
import json
import os
from html import escape
from importlib import resources
from pathlib import Path

import numpy as np

from .._files import atomic_write
from ..errors import ExportError

__all__ = ["View", "view_html", "write_view", "MAX_FRAMES", "MAX_BYTES"]

#: default bound on the number of frames a page keeps
MAX_FRAMES = 1000
#: default bound on the bytes of per-frame data (float32 positions and fields) a page keeps
MAX_BYTES = 8_000_000

#: colour fields: point-data name -> (label, unit); the page colours by body too
FIELDS = {"velocity": ("speed", "m/s"), "von_mises": ("von Mises stress", "Pa")}

# the faces of a VTK hexahedron, each counter-clockwise seen from outside
_HEX_FACES = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))
_DATA_MARK = "/*FLEXMB_DATA*/null"


class View(type(Path())):
    """The path of a viewer page that shows itself as the viewer in a notebook.

    A :class:`pathlib.Path` in every respect (what :meth:`flexmb.Result.view`
    returns in a script: open it in a browser), it gives Jupyter and other
    HTML front ends the page inside an ``<iframe>`` (``_repr_html_``), so
    that a notebook cell ending in ``result.view()`` shows the animated
    mechanism.

    Parameters
    ----------
    *args : str or path-like
        The HTML file, as for :class:`pathlib.Path`.
    **kwargs
        As for :class:`pathlib.Path`.

    Examples
    --------
    >>> from flexmb.viz import View
    >>> View("results", "view.html").name
    'view.html'
    """

    def _repr_html_(self) -> str:
        """The page in an ``<iframe>`` (its whole text as ``srcdoc``), titled by the file's path."""
        page = self.read_text(encoding="utf-8")
        return (f'<iframe srcdoc="{escape(page, quote=True)}" title="{escape(str(self))}" '
                'style="width:100%;height:600px;border:1px solid #ddd" sandbox="allow-scripts"></iframe>')


def _frame_indices(nt: int, per_frame: int, max_frames: int, max_bytes: float) -> np.ndarray:
    """Evenly spaced output indices, first and last kept: at most ``max_frames``, ``per_frame`` bytes each."""
    if int(max_frames) != max_frames or max_frames < 1:
        raise ExportError(f"max_frames must be an integer >= 1, got {max_frames!r}")
    if not max_bytes > 0:
        raise ExportError(f"max_bytes must be > 0, got {max_bytes!r}")
    fit = int(max_bytes // per_frame)
    if fit < 1:
        raise ExportError(f"one frame of this scene takes {per_frame} bytes, more than max_bytes={max_bytes:g}: "
                          f"raise max_bytes")
    n = min(nt, int(max_frames), fit)
    if n == nt:
        return np.arange(nt)
    if n == 1:
        return np.array([0])
    return np.unique(np.round(np.linspace(0, nt - 1, n)).astype(int))


def _b64(values) -> str:
    """Little-endian float32 values, base64."""
    return base64.b64encode(np.ascontiguousarray(values, dtype="<f4").tobytes()).decode("ascii")


def _geometry(mesh) -> dict:
    """What the page draws of the mesh's cells: lines, faces, joints and dots, with their body rows."""
    from ..export.layout import PARTS

    centre_part, joint_part = PARTS.index("centre line"), PARTS.index("joint")
    lines, faces, joints, dots = [], [], [], []
    blocks = list(zip(mesh.cells, mesh.cell_data["body_id"], mesh.cell_data["part_id"]))
    # a flexible body's centre line runs inside its segments' blocks: drawn only without them (as viz.render)
    centre = not any(block.type == "hexahedron" for block, _, _ in blocks)
    for block, body, part in blocks:
        data = np.asarray(block.data, dtype=int)
        body = np.asarray(body, dtype=int)
        part = np.asarray(part, dtype=int)
        for cell, b, p in zip(data, body, part):
            if block.type == "line" and (centre or p != centre_part):
                lines.append([int(cell[0]), int(cell[1]), int(b)])
            elif block.type == "hexahedron":
                faces.extend([*(int(cell[k]) for k in face), int(b)] for face in _HEX_FACES)
            elif block.type == "quad":
                faces.append([*(int(c) for c in cell), int(b)])
            elif block.type == "vertex" and p == joint_part:
                joints.append(int(cell[0]))
            elif block.type == "vertex":
                dots.append([int(cell[0]), int(b)])
    return {"lines": lines, "faces": faces, "joints": joints, "dots": dots}


def _magnitude(values) -> np.ndarray:
    """The magnitude at each point of a frame's point data: norm of vectors, absolute value of scalars."""
    values = np.asarray(values, dtype=float)
    return np.linalg.norm(values, axis=1) if values.ndim == 2 else np.abs(values)


def _points_of(drawing: dict, bodies: list[int], n_points: int) -> np.ndarray:
    """Mask of the points that the lines, faces and dots of some bodies (by row) use."""
    mask = np.zeros(n_points, dtype=bool)
    chosen = set(bodies)
    for key in ("lines", "faces", "dots"):
        for item in drawing[key]:
            if item[-1] in chosen:
                mask[item[:-1]] = True
    return mask


def _run_data(label: str, result, system, max_frames, max_bytes) -> dict:
    """One result as the page's data: frame times, geometry, positions and colour fields."""
    from ..export.layout import _check_result
    from ..export.meshes import _meshes, table_names

    nt = _check_result(result)
    first = next(_meshes(result, [0], system))
    fields = [name for name in FIELDS if name in first.point_data]
    n_points = len(first.points)
    frames = _frame_indices(nt, 4 * n_points * (3 + len(fields)), max_frames, max_bytes)
    meshes = list(_meshes(result, frames, system))
    P = np.array([m.points for m in meshes], dtype=float)
    seen = P[np.isfinite(P).all(axis=-1)]
    if not len(seen):
        raise ExportError(f"{label or 'the result'}: no finite point positions to show")
    data = {"label": label, "t": [float(v) for v in np.asarray(result.t, dtype=float)[frames]],
            "outputs": [int(i) for i in frames], "n_outputs": nt, "n_points": n_points,
            "bodies": table_names(first.field_data, "body"),
            "positions": _b64(P), "lo": seen.min(axis=0).tolist(), "hi": seen.max(axis=0).tolist(),
            **_geometry(first), "fields": {}}
    flexible = _points_of(data, [k for k, n in enumerate(data["bodies"]) if n in result.flexible], n_points)
    for name in fields:
        values = np.array([_magnitude(m.point_data[name]) for m in meshes])
        if name == "von_mises":  # computed for flexible bodies only: the others have none (drawn grey)
            values[:, ~flexible] = np.nan
        finite = values[np.isfinite(values)]
        label_, unit = FIELDS[name]
        data["fields"][name] = {"label": label_, "unit": unit, "values": _b64(values),
                                "max": float(finite.max()) if finite.size else 0.0,
                                "partial": bool(finite.size < values.size)}
    return data


def _runs(result, system) -> list[tuple[str, object, object]]:
    """``(label, result, system)`` for one result or a mapping of labelled results (and systems)."""
    if isinstance(result, dict):
        if not result:
            raise ExportError("write_view: no results to show (an empty mapping)")
        if system is not None and not isinstance(system, dict):
            raise ExportError("write_view: with a mapping of results, system must be a mapping by the same labels")
        systems = system or {}
        unknown = sorted(set(systems) - set(result))
        if unknown:
            raise ExportError(f"write_view: systems for unknown results {unknown}; the results: {sorted(result)}")
        return [(str(k), r, systems.get(k)) for k, r in result.items()]
    return [("", result, system)]


def view_html(result, *, system=None, title: str | None = None, max_frames: int = MAX_FRAMES,
              max_bytes: float = MAX_BYTES) -> str:
    """The viewer page of a result (or of labelled results, one at a time with a selector), as text.

    Parameters
    ----------
    result : Result or dict of str to Result
        A simulation result, or several by label (e.g. the runs of a scene:
        the page has a menu to pick one).
    system : System or Model or dict of str to (System or Model), optional
        The model the result came from (a mapping by the same labels for
        several results; a label left out is drawn without): bodies drawn
        through their joints, exact velocities, von Mises stresses of
        flexible bodies (see :func:`flexmb.export.vtk.to_meshio`).
    title : str, optional
        The page's title (default: ``"flexmb viewer"``).
    max_frames : int
        At most this many output times per result.
    max_bytes : float
        At most this many bytes of per-frame data per result (4 per
        coordinate of a point and per field value).

    Returns
    -------
    str
        The HTML page, self-contained.

    Raises
    ------
    ExportError
        On a bad result, system or bound, or if one frame alone exceeds
        ``max_bytes``.
    """
    runs = [_run_data(label, res, sys_, max_frames, max_bytes) for label, res, sys_ in _runs(result, system)]
    data = {"title": title or "flexmb viewer", "runs": runs}
    page = resources.files(__package__).joinpath("viewer.html").read_text(encoding="utf-8")
    text = json.dumps(data, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    return page.replace("<title></title>", f"<title>{escape(data['title'])}</title>").replace(_DATA_MARK, text)


def write_view(result, path, *, system=None, title: str | None = None, max_frames: int = MAX_FRAMES,
               max_bytes: float = MAX_BYTES) -> View:
    """Write the viewer page of a result to an HTML file (whole or not at all).

    Parameters
    ----------
    result : Result or dict of str to Result
        A simulation result, or several by label (see :func:`view_html`).
    path : str or path-like
        The ``.html`` file; its folder is created if missing.
    system : System or Model or dict, optional
        The model the result came from (see :func:`view_html`).
    title : str, optional
        The page's title.
    max_frames : int
        At most this many output times per result.
    max_bytes : float
        At most this many bytes of per-frame data per result.

    Returns
    -------
    View
        ``path``: open it in a browser; a notebook shows it as the viewer.

    Raises
    ------
    ExportError
        As :func:`view_html`.

    Examples
    --------
    >>> import flexmb as fm, tempfile, pathlib
    >>> from flexmb.viz import write_view
    >>> model = fm.Model("pendulum")
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    >>> _ = model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0, -9.81, 0)))
    >>> res = fm.simulate(model, 1.0, positions={"pin": 0.5}, n_out=21)
    >>> page = write_view(res, pathlib.Path(tempfile.mkdtemp()) / "view.html", system=model)
    >>> page.name, page.stat().st_size < 100_000
    ('view.html', True)
    """
    text = view_html(result, system=system, title=title, max_frames=max_frames, max_bytes=max_bytes)
    path = Path(os.fspath(path))

    def write(tmp):
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)

    return View(atomic_write(path, write, suffix=".html"))
