"""VTK export for ParaView: one ``.vtu`` file per output time and a ``.pvd`` collection.

Every file is an unstructured grid of lines:

* a rigid body is a line from its body-frame origin to its mass centre, a
  vertex at the mass centre and, on request, a triad of its body axes;
* a flexible body is its deformed centre line, a polyline through the root,
  every segment joint and the tip (:meth:`Result.shape`).

Point data: ``displacement`` and ``velocity`` of every point, and the
elastic coordinates of the segment joints (``bending_y``, ``bending_z``,
``torsion``, plus ``axial``, ``shear_y``, ``shear_z`` when a body keeps
them). With a system, also the section loads at the segment joints:
``moment_torsion``, ``moment_bend_y``, ``moment_bend_z`` (N m) and
``von_mises`` (Pa), see :mod:`flexmb.stresses`. Cell data: ``body_id`` (an index into :func:`body_names`) and
``segment``. Field data: ``time`` (and ``TimeValue``, which ParaView reads
as the time of a file series). See ``docs/export.md``.

meshio is imported here and nowhere else in flexmb: ``import flexmb`` does
not load it. meshio has no ``.pvd`` writer, so :func:`write_pvd` writes the
collection XML itself with :mod:`xml.etree`.
"""

from __future__ import annotations

import operator
import os
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np

from .._files import atomic_write
from ..errors import ExportError
from ..result import Result

__all__ = ["ELASTIC_FIELDS", "SECTION_FIELDS", "body_names", "to_meshio", "write_vtu", "write_pvd", "export_vtk",
           "export_snapshot", "export_modes"]

#: elastic coordinate of a segment joint -> point-data name (rad for rotations, m for translations)
ELASTIC_FIELDS = {"bend_y": "bending_y", "bend_z": "bending_z", "torsion": "torsion",
                  "axial": "axial", "shear_y": "shear_y", "shear_z": "shear_z"}

# written for every result, 0 where no body keeps them; the translational
# ones only when some body keeps them
_ALWAYS = ("bending_y", "bending_z", "torsion")

_FIELDS = ("t", "x", "positions", "origins", "rotations", "body_names", "coordinate_names", "flexible")


def _check_result(result) -> int:
    """Check the fields the export reads; return the number of output times."""
    missing = [f for f in _FIELDS if not hasattr(result, f)]
    if missing:
        raise ExportError(f"cannot export a {type(result).__name__}: it has no field(s) {missing} "
                          f"(pass a flexmb Result)")
    t = np.asarray(result.t)
    if t.ndim != 1 or t.size == 0:
        raise ExportError(f"result.t must be a non-empty 1-d array of times, got shape {t.shape}")
    nt = t.size
    nb = len(result.body_names)
    expected = {"positions": (nt, nb, 3), "origins": (nt, nb, 3), "rotations": (nt, nb, 3, 3),
                "x": (nt, len(result.coordinate_names))}
    for name, shape in expected.items():
        got = np.shape(getattr(result, name))
        if got != shape:
            raise ExportError(f"result.{name} has shape {got}, expected {shape} "
                              f"({nt} output times, {nb} bodies, {len(result.coordinate_names)} coordinates)")
    for name, entry in result.flexible.items():
        try:
            rows, length = entry
            rows = np.asarray(rows)
            length = float(length)
        except (TypeError, ValueError):
            raise ExportError(f"result.flexible[{name!r}] must be (segment rows, segment length), "
                              f"got {entry!r}") from None
        if rows.ndim != 1 or rows.size == 0 or rows.dtype.kind not in "iu" or rows.min() < 0 or rows.max() >= nb:
            raise ExportError(f"result.flexible[{name!r}]: segment rows must be body rows in [0, {nb}), "
                              f"got {rows.tolist()}")
        if not (np.isfinite(length) and length > 0):
            raise ExportError(f"result.flexible[{name!r}]: segment length must be > 0, got {length}")
    return nt


def _check_index(i, nt: int) -> int:
    try:
        i = operator.index(i)
    except TypeError:
        raise ExportError(f"output index must be an integer, got {i!r}") from None
    if not -nt <= i < nt:
        raise ExportError(f"output index {i} is out of range: the result has {nt} output times "
                          f"(indices 0 to {nt - 1}, or negative from the end)")
    return i % nt


def _check_triad(triad) -> float:
    triad = float(triad)
    if not (np.isfinite(triad) and triad >= 0):
        raise ExportError(f"triad must be a length >= 0 (m), got {triad}")
    return triad


class _Layout:
    """Where every exported point and cell comes from; built once per result.

    Points: per rigid body, its origin, its mass centre and (with a triad)
    the tips of its three axes; then per flexible body its ``N + 1``
    centre-line points. ``row`` is the body row that carries each point
    (used for exact velocities).
    """

    def __init__(self, result, triad: float):
        names = list(result.body_names)
        self.triad = triad
        self.flexible = [(name, np.asarray(rows, dtype=int), float(l)) for name, (rows, l) in result.flexible.items()]
        carried = {int(k) for _, rows, _ in self.flexible for k in rows}
        # a clamped flexible body's massless clamp frame, named "<body>.base", sits at the root
        bases = {f"{name}.base" for name, _, _ in self.flexible}
        self.rigid = np.array([k for k, n in enumerate(names) if k not in carried and n not in bases], dtype=int)
        self.names = [names[k] for k in self.rigid] + [name for name, _, _ in self.flexible]

        per = 5 if triad else 2
        nr = len(self.rigid)
        start = np.arange(nr) * per
        lines = [np.stack([start, start + 1], axis=1)]
        line_body = [np.arange(nr)]
        if triad:
            for a in range(3):
                lines.append(np.stack([start, start + 2 + a], axis=1))
                line_body.append(np.arange(nr))
        row = [np.repeat(self.rigid, per)]
        offset = nr * per
        segment = [np.full(sum(len(b) for b in line_body), -1)]
        self.elastic: dict[str, tuple[list, list]] = {}
        for b, (name, rows, _) in enumerate(self.flexible, start=nr):
            n_seg = len(rows)
            ends = offset + np.arange(n_seg)
            lines.append(np.stack([ends, ends + 1], axis=1))
            line_body.append(np.full(n_seg, b))
            segment.append(np.arange(n_seg))
            row.append(np.append(rows, rows[-1]))  # the tip rides on the last segment
            pattern = re.compile(rf"^{re.escape(name)}\.j(\d+)\.(\w+)$")
            for col, cname in enumerate(result.coordinate_names):
                m = pattern.match(cname)
                if not m:
                    continue
                k, coord = int(m.group(1)), m.group(2)
                if coord not in ELASTIC_FIELDS or k >= n_seg:
                    raise ExportError(f"coordinate {cname!r} of flexible body {name!r} is not a segment-joint "
                                      f"coordinate <body>.j<k>.<{'|'.join(ELASTIC_FIELDS)}> with k < {n_seg}")
                cols, points = self.elastic.setdefault(ELASTIC_FIELDS[coord], ([], []))
                cols.append(col)
                # joint j<k> sits at the start of segment k: centre-line point k
                points.append(offset + k)
            offset += n_seg + 1
        for field in _ALWAYS:
            self.elastic.setdefault(field, ([], []))
        self.n_points = offset
        self.row = np.concatenate(row)
        self.lines = np.concatenate(lines).astype(np.int64)
        self.line_body = np.concatenate(line_body).astype(np.int64)
        self.line_segment = np.concatenate(segment).astype(np.int64)
        self.vertices = (start + 1)[:, None].astype(np.int64)  # the mass centres

    def points(self, result) -> np.ndarray:
        """Inertial positions of the points at every output time, shape (nt, n_points, 3)."""
        origins = np.asarray(result.origins, dtype=float)
        R = np.asarray(result.rotations, dtype=float)
        parts = []
        if len(self.rigid):
            k = self.rigid
            blocks = [origins[:, k], np.asarray(result.positions, dtype=float)[:, k]]
            if self.triad:
                blocks += [origins[:, k] + self.triad * R[:, k][..., a] for a in range(3)]
            parts.append(np.stack(blocks, axis=2).reshape(len(origins), -1, 3))
        for _, rows, l in self.flexible:
            # the same centre line as Result.shape: segment origins, then the tip
            tip = origins[:, rows[-1]] + R[:, rows[-1], :, 0] * l
            parts.append(np.concatenate([origins[:, rows], tip[:, None]], axis=1))
        if not parts:
            return np.zeros((len(origins), 0, 3))
        return np.concatenate(parts, axis=1)

    def elastic_values(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """Point data of the elastic coordinates at one state x, 0 where none applies."""
        out = {}
        for field, (cols, points) in self.elastic.items():
            v = np.zeros(self.n_points)
            v[points] = x[cols]
            out[field] = v
        return out

    def exact_velocities(self, system, t: float, x, xd, points: np.ndarray) -> np.ndarray:
        """Velocities of the points from the kinematics of ``system`` (eq. 17), m/s."""
        kin = system.kinematics(t, x, xd)
        k = self.row
        return kin.v[k] + np.cross(kin.omega[k], points - kin.r[k])

    def mesh(self, points, displacement, velocity, x, field_data) -> "meshio.Mesh":
        """One meshio mesh from the per-point arrays of one output time."""
        cells = [meshio.CellBlock("line", self.lines)]
        body_id = [self.line_body]
        segment = [self.line_segment]
        if len(self.vertices):
            cells.append(meshio.CellBlock("vertex", self.vertices))
            body_id.append(np.arange(len(self.vertices), dtype=np.int64))
            segment.append(np.full(len(self.vertices), -1, dtype=np.int64))
        point_data = {"displacement": displacement, "velocity": velocity, **self.elastic_values(x)}
        return meshio.Mesh(points, cells, point_data=point_data,
                           cell_data={"body_id": body_id, "segment": segment},
                           field_data={k: np.atleast_1d(np.asarray(v)) for k, v in field_data.items()})


def _check_system(system, result):
    if not (hasattr(system, "kinematics") and hasattr(system, "body_names")):
        raise ExportError(f"system must be a flexmb System, got {type(system).__name__}")
    if list(system.body_names) != list(result.body_names) or system.n_coords != np.shape(result.x)[1]:
        raise ExportError("the system does not match the result: different bodies or number of coordinates")
    if not hasattr(result, "xd") or np.shape(result.xd) != np.shape(result.x):
        raise ExportError(f"result.xd must have the shape of result.x {np.shape(result.x)} "
                          f"for exact velocities")


def _velocities(layout, result, P, system, frames) -> dict[int, np.ndarray]:
    """Point velocities at the requested frames: exact with a system, else finite differences."""
    t = np.asarray(result.t, dtype=float)
    if system is not None:
        x, xd = np.asarray(result.x, dtype=float), np.asarray(result.xd, dtype=float)
        return {i: layout.exact_velocities(system, t[i], x[i], xd[i], P[i]) for i in frames}
    if len(t) < 2:
        return {i: np.full_like(P[i], np.nan) for i in frames}
    if np.any(np.diff(t) <= 0):
        raise ExportError("result.t must be increasing to difference positions into velocities")
    # second-order central differences inside, second-order one-sided at the ends
    V = np.gradient(P, t, axis=0, edge_order=2 if len(t) > 2 else 1)
    return {i: V[i] for i in frames}


#: section-load point data written with a system: name -> section-load component (N m)
SECTION_FIELDS = {"moment_torsion": "Mx", "moment_bend_y": "My", "moment_bend_z": "Mz"}


def _section_values(layout, result, system) -> dict[str, np.ndarray]:
    """Section moments and von Mises stress at the segment-joint points, shape (nt, n_points) each.

    From the kept coordinates' springs and dampers (:mod:`flexmb.stresses`);
    0 at other points and for components a body does not keep.
    """
    from ..stresses import _section_loads, _stresses

    nt = len(np.asarray(result.t))
    out = {name: np.zeros((nt, layout.n_points)) for name in (*SECTION_FIELDS, "von_mises")}
    bodies = {b.name: b for b in getattr(system.topology, "flexible", {})}
    offset = layout.n_points - sum(len(rows) + 1 for _, rows, _ in layout.flexible)
    for name, rows, _ in layout.flexible:
        body = bodies.get(name)
        if body is not None:
            loads = _section_loads(result, body, None)
            points = offset + (0 if body.clamped else 1) + np.arange(body.n_joints)
            for field, comp in SECTION_FIELDS.items():
                if comp in loads.components:
                    out[field][:, points] = loads.component(comp)
            out["von_mises"][:, points] = _stresses(result, body, loads).component("von_mises")
        offset += len(rows) + 1
    return out


def _meshes(result, frames, system=None, triad=0.0, extra=None):
    """Meshes at the given output indices, sharing one layout and one pass over the history."""
    _check_result(result)
    triad = _check_triad(triad)
    if system is not None:
        _check_system(system, result)
    layout = _Layout(result, triad)
    P = layout.points(result)
    V = _velocities(layout, result, P, system, frames)
    t = np.asarray(result.t, dtype=float)
    x = np.asarray(result.x, dtype=float)
    section = _section_values(layout, result, system) if system is not None and layout.flexible else {}
    for i in frames:
        field_data = {"time": t[i], **(extra or {})}
        mesh = layout.mesh(P[i], P[i] - P[0], V[i], x[i], field_data)
        mesh.point_data.update({name: v[i] for name, v in section.items()})
        yield mesh


def body_names(result) -> list[str]:
    """Return the names of the exported bodies, in the order of the ``body_id`` cell data.

    Parameters
    ----------
    result : Result
        A simulation result.

    Returns
    -------
    list of str
        The rigid bodies in result order, then the flexible bodies. The
        segments of a flexible body (and its clamp frame ``"<body>.base"``)
        are not listed: they are drawn as the flexible body.
    """
    _check_result(result)
    return list(_Layout(result, 0.0).names)


def to_meshio(result, i: int, *, system=None, triad: float = 0.0) -> "meshio.Mesh":
    """The bodies at one output time as a meshio mesh of lines.

    Parameters
    ----------
    result : Result
        A simulation result.
    i : int
        Output index (negative counts from the end).
    system : System, optional
        The system the result came from. With it, velocities are exact
        (from ``result.xd`` through the kinematics, ``v + omega x r``);
        without it, they are differences of the positions over the output
        times (see Notes).
    triad : float
        Length of the body-axis lines drawn for each rigid body, m (0: none).

    Returns
    -------
    meshio.Mesh
        Points in m. Cells: ``"line"`` (rigid bodies origin -> mass centre,
        triads, flexible segments), ``"vertex"`` (rigid mass centres).
        Point data ``displacement`` (m, from the same point at ``t[0]``),
        ``velocity`` (m/s), ``bending_y``, ``bending_z``, ``torsion`` (rad,
        at the segment-joint points, 0 elsewhere) and ``axial``,
        ``shear_y``, ``shear_z`` (m) if kept; with ``system``, also the
        section loads ``moment_torsion``, ``moment_bend_y``,
        ``moment_bend_z`` (N m, kept coordinates' springs and dampers) and
        ``von_mises`` (Pa) at the segment-joint points; cell data ``body_id`` (index
        into :func:`body_names`) and ``segment`` (-1 for rigid bodies);
        field data ``time`` (s).

    Raises
    ------
    ExportError
        If ``result`` lacks a field or has inconsistent shapes, or ``i`` is
        out of range.

    Notes
    -----
    Without a system, velocities are ``np.gradient`` of the point positions
    over ``result.t``: second-order central differences at interior times,
    second-order one-sided differences at the first and last (first order
    with two outputs, NaN with one). Their error is O(dt^2) in the output
    spacing, not the integrator's; pass ``system`` for exact values.

    Examples
    --------
    >>> import flexmb as fm
    >>> from flexmb.export.vtk import to_meshio
    >>> model = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    >>> _ = model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0, -9.81, 0)))
    >>> res = fm.simulate(model, 0.1, positions={"pin": 0.5}, n_out=3)
    >>> to_meshio(res, -1).points.shape
    (2, 3)
    """
    nt = _check_result(result)
    i = _check_index(i, nt)
    return next(_meshes(result, [i], system, triad))


def _write_mesh(mesh, path) -> Path:
    """Write a .vtu file, with the mesh's field data, through a temporary name."""
    # meshio's vtu writer drops field data (its reader does read it): add it
    fd = ET.Element("FieldData")
    data = dict(mesh.field_data)
    if "time" in data:
        data.setdefault("TimeValue", data["time"])  # the name ParaView reads as a file's time
    for name, value in data.items():
        value = np.asarray(value).ravel()
        if value.dtype.kind in "iub":
            vtype, text = "Int64", " ".join(str(int(v)) for v in value)
        else:
            vtype, text = "Float64", " ".join(repr(float(v)) for v in value)
        da = ET.SubElement(fd, "DataArray", type=vtype, Name=str(name), NumberOfTuples=str(value.size),
                           format="ascii")
        da.text = text

    def write(tmp):
        meshio.write(tmp, mesh, file_format="vtu")
        tree = ET.parse(tmp)
        tree.getroot().find("UnstructuredGrid").insert(0, fd)
        tree.write(tmp)

    return atomic_write(path, write, suffix=".vtu")


def _check_prefix(prefix: str) -> str:
    if not isinstance(prefix, str) or not prefix or os.sep in prefix or "/" in prefix or prefix.startswith("."):
        raise ExportError(f"prefix must be a non-empty file-name stem without a folder, not starting with '.' "
                          f"(a hidden file), got {prefix!r}")
    return prefix


def write_vtu(result, folder, prefix: str = "flexmb", *, system=None, triad: float = 0.0) -> list[Path]:
    """Write one ``.vtu`` file per output time.

    Parameters
    ----------
    result : Result
        A simulation result.
    folder : str or path-like
        Output folder (created if missing).
    prefix : str
        File-name stem: files are ``<prefix>_0000.vtu``, ``<prefix>_0001.vtu``, ...
    system : System, optional
        For exact velocities, see :func:`to_meshio`.
    triad : float
        Body-axis line length for rigid bodies, m (0: none).

    Returns
    -------
    list of pathlib.Path
        The files, in output order.

    Raises
    ------
    ExportError
        On a malformed result or prefix.
    """
    nt = _check_result(result)
    prefix = _check_prefix(prefix)
    folder = Path(os.fspath(folder))
    width = max(4, len(str(nt - 1)))
    paths = []
    for i, mesh in enumerate(_meshes(result, range(nt), system, triad)):
        paths.append(_write_mesh(mesh, folder / f"{prefix}_{i:0{width}d}.vtu"))
    return paths


def write_pvd(paths, times, path) -> Path:
    """Write a ParaView collection (``.pvd``) listing data files with their times.

    Parameters
    ----------
    paths : sequence of str or path-like
        The data files (``.vtu``), in time order; they must exist.
    times : array_like, shape (len(paths),)
        Their times, s, strictly increasing.
    path : str or path-like
        The ``.pvd`` file to write. File names in it are relative to its folder.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ExportError
        If the lengths differ, the times are not finite and increasing, or a
        file is missing.

    Notes
    -----
    The format is ``<VTKFile type="Collection"><Collection><DataSet
    timestep="t" group="" part="0" file="name.vtu"/>...``; times are written
    with ``repr`` so they read back exactly.
    """
    paths = [Path(os.fspath(p)) for p in paths]
    times = np.asarray(times, dtype=float).ravel()
    if len(paths) == 0 or len(paths) != len(times):
        raise ExportError(f"write_pvd needs one time per file and at least one file: got {len(paths)} files "
                          f"and {len(times)} times")
    if not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
        raise ExportError("write_pvd: times must be finite and strictly increasing")
    missing = [str(p) for p in paths if not p.is_file()]
    if missing:
        raise ExportError(f"write_pvd: data file(s) not found: {missing[:3]}")
    path = Path(os.fspath(path))
    base = path.parent.resolve() if path.parent.exists() else Path(os.path.abspath(path.parent))
    root = ET.Element("VTKFile", type="Collection", version="0.1",
                      byte_order="LittleEndian" if sys.byteorder == "little" else "BigEndian")
    collection = ET.SubElement(root, "Collection")
    for p, t in zip(paths, times):
        rel = Path(os.path.relpath(p.resolve(), base)).as_posix()
        ET.SubElement(collection, "DataSet", timestep=repr(float(t)), group="", part="0", file=rel)
    ET.indent(root)
    tree = ET.ElementTree(root)
    return atomic_write(path, lambda tmp: tree.write(tmp, encoding="utf-8", xml_declaration=True), suffix=".pvd")


def export_vtk(result, folder, prefix: str = "flexmb", *, system=None, triad: float = 0.0) -> Path:
    """Write a result for ParaView: one ``.vtu`` per output time and ``<prefix>.pvd``.

    Parameters
    ----------
    result : Result
        A simulation result.
    folder : str or path-like
        Output folder (created if missing).
    prefix : str
        File-name stem.
    system : System, optional
        For exact velocities, see :func:`to_meshio`.
    triad : float
        Body-axis line length for rigid bodies, m (0: none).

    Returns
    -------
    pathlib.Path
        The ``.pvd`` file; open it in ParaView (File > Open).

    Raises
    ------
    ExportError
        On a malformed result or prefix.

    Examples
    --------
    >>> import tempfile, flexmb as fm
    >>> from flexmb.export.vtk import export_vtk
    >>> model = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    >>> _ = model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0, -9.81, 0)))
    >>> res = fm.simulate(model, 0.1, positions={"pin": 0.5}, n_out=3)
    >>> export_vtk(res, tempfile.mkdtemp()).name
    'flexmb.pvd'
    """
    paths = write_vtu(result, folder, prefix, system=system, triad=triad)
    return write_pvd(paths, result.t, Path(os.fspath(folder)) / f"{prefix}.pvd")


def _as_system(system):
    from ..system import System

    if isinstance(system, System):
        return system
    if hasattr(system, "build"):
        return system.build()
    raise ExportError(f"expected a flexmb System or Model, got {type(system).__name__}")


def _state_result(system, t: float, xs, xds) -> Result:
    """A Result holding a few states of ``system`` (positions only), for export."""
    n = system.n_coords
    frames = []
    for name, v in (("x", xs), ("xd", xds)):
        v = np.asarray(v, dtype=float)
        if v.shape != (len(xs), n) or not np.all(np.isfinite(v)):
            raise ExportError(f"{name} must be a finite array of {n} coordinates per state, got shape "
                              f"{v.shape[1:]}")
        frames.append(v)
    X, XD = frames
    kins = [system.kinematics(t, x, xd) for x, xd in zip(X, XD)]
    nt = len(X)
    zeros = np.zeros(nt)
    topo = system.topology
    return Result(
        t=np.full(nt, float(t)), x=X, xd=XD, xdd=np.zeros_like(X),
        positions=np.array([k.r[:-1] for k in kins]), origins=np.array([k.origin[:-1] for k in kins]),
        rotations=np.array([k.R[:-1] for k in kins]), kinetic=zeros, potential=zeros, residual=zeros,
        velocity_residual=zeros, reactions=np.zeros((nt, 0)), coordinate_names=list(system.coordinate_names),
        body_names=list(system.body_names),
        flexible={b.name: ([topo.index[sg] for sg in segs], b.segment_length)
                  for b, (_, segs, _) in topo.flexible.items()},
        status="finished", message="exported state",
    )


def export_snapshot(system, x, path, *, xd=None, t: float = 0.0, reference=None, triad: float = 0.0) -> Path:
    """Write one state of a system to a ``.vtu`` file.

    Parameters
    ----------
    system : System or Model
        The model (a Model is built with the default complement).
    x : array_like, shape (n,)
        Coordinates.
    path : str or path-like
        The ``.vtu`` file to write.
    xd : array_like, shape (n,), optional
        Speeds (default 0); velocities are exact.
    t : float
        Time written to the field data, s.
    reference : array_like, shape (n,), optional
        Coordinates the displacement is measured from (default 0: the
        reference configuration).
    triad : float
        Body-axis line length for rigid bodies, m (0: none).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ExportError
        If ``x``, ``xd`` or ``reference`` has the wrong length or is not finite.
    """
    system = _as_system(system)
    n = system.n_coords
    ref = np.zeros(n) if reference is None else reference
    xd = np.zeros(n) if xd is None else xd
    res = _state_result(system, t, _stack(ref, x, n), _stack(np.zeros(n), xd, n))
    mesh = next(_meshes(res, [1], system, triad))
    return _write_mesh(mesh, path)


def _stack(a, b, n):
    try:
        return np.array([np.asarray(a, dtype=float).reshape(n), np.asarray(b, dtype=float).reshape(n)])
    except (TypeError, ValueError):
        raise ExportError(f"a state must have {n} coordinates, got shapes {np.shape(a)} and {np.shape(b)}") from None


def export_modes(system, frequencies, shapes, folder, *, scale: float = 0.1, prefix: str = "mode", x0=None,
                 triad: float = 0.0) -> list[Path]:
    """Write one ``.vtu`` file per mode shape.

    Mode k is drawn at ``x = x0 + scale * shapes[:, k]``; the displacement
    point data is measured from ``x0``.

    Parameters
    ----------
    system : System or Model
        The model the modes belong to.
    frequencies : array_like, shape (k,)
        Natural frequencies, Hz (from :func:`flexmb.modes`).
    shapes : array_like, shape (n, k)
        Mode shapes in the coordinates x, one per column.
    folder : str or path-like
        Output folder (created if missing).
    scale : float
        Amplitude of the largest coordinate of each (unit-normalised) mode,
        rad or m.
    prefix : str
        File-name stem: ``<prefix>_01.vtu`` is the first mode.
    x0 : array_like, shape (n,), optional
        The configuration linearised about (default 0).
    triad : float
        Body-axis line length for rigid bodies, m (0: none).

    Returns
    -------
    list of pathlib.Path
        The files, lowest mode first. Field data: ``frequency`` (Hz) and
        ``mode`` (1-based); velocities are zero (a still shape).

    Raises
    ------
    ExportError
        If ``shapes`` does not have ``n`` rows and one column per frequency,
        or ``scale`` is not finite.
    """
    system = _as_system(system)
    prefix = _check_prefix(prefix)
    n = system.n_coords
    f = np.asarray(frequencies, dtype=float).ravel()
    S = np.asarray(shapes, dtype=float)
    if S.ndim == 1:
        S = S[:, None]
    if S.shape != (n, f.size):
        raise ExportError(f"shapes must have shape (n_coords, n_modes) = ({n}, {f.size}), got {S.shape}")
    if not np.isfinite(scale):
        raise ExportError(f"scale must be finite, got {scale}")
    x0 = _stack(np.zeros(n), np.zeros(n) if x0 is None else x0, n)[1]
    width = max(2, len(str(f.size)))
    folder = Path(os.fspath(folder))
    paths = []
    for k in range(f.size):
        res = _state_result(system, 0.0, np.array([x0, x0 + scale * S[:, k]]), np.zeros((2, n)))
        mesh = next(_meshes(res, [1], system, triad, extra={"frequency": f[k], "mode": np.int64(k + 1)}))
        del mesh.field_data["time"]
        paths.append(_write_mesh(mesh, folder / f"{prefix}_{k + 1:0{width}d}.vtu"))
    return paths
