"""VTK export for ParaView: one ``.vtu`` file per output time and a ``.pvd`` collection.

Every file is an unstructured grid holding the bodies where they are at
that time (the current configuration: no displacement to warp by), drawn
as their shapes through their joint points. With the system the result
came from (``system=``, a System or the Model):

* a rigid body is the uniform box with its mass and central inertia
  (a ``hexahedron``; a ``line`` for a slender bar, a ``quad`` for a plate),
  centred at its mass centre along its principal axes, so a bar runs
  between the joints at its ends;
* a flexible body is one ``hexahedron`` per segment, the segment's length
  by the section's width and height, and its centre line (``line`` cells
  through the root, every segment joint and the tip);
* every joint is a ``vertex`` on each body it joins, at that body's joint
  point, and a ``line`` (a *lever*) joins a joint point outside the body's
  shape to the nearest point of the shape, so the bodies meet where their
  joints connect; a joint with translations adds a ``line`` from the
  parent's joint point to the child's (the slide).

Without a system a result alone carries no joint points and no sections: a
rigid body is then a line from its body-frame origin through its mass
centre to the mirror point (the whole of a bar whose frame sits at one end),
a flexible body its centre line, and velocities are finite differences.

Point data: ``velocity`` (m/s, exact with a system: ``v + omega x (p -
r)`` of the body that carries the point), the elastic coordinates of the
segment joints (``bending_y``, ``bending_z``, ``torsion``, plus ``axial``,
``shear_y``, ``shear_z`` when a body keeps them) and, with a system, the
section loads ``moment_torsion``, ``moment_bend_y``, ``moment_bend_z`` (N m)
and ``von_mises`` (Pa) (:mod:`flexmb.post`). Cell data: ``body_id``,
``joint_id``, ``segment``, ``part_id`` and, in the files, their names as
string arrays ``body``, ``joint`` and ``part`` (ParaView colours by them
category by category). Field data: ``time``, ``TimeValue`` (ParaView's
time of a file), and the name tables ``body_names``, ``joint_names``,
``part_names``. Mode shapes (and snapshots given a ``reference``) are the
exception to the current configuration: drawn at the reference
configuration with a ``displacement`` to warp by. See ``docs/export.md``.

meshio is imported here and nowhere else in flexmb: ``import flexmb`` does
not load it. A mesh is a :class:`meshio.Mesh`; the files are written by
:func:`_vtu_text` rather than by meshio, whose VTU writer drops field data
and cannot write string arrays, and read back by :func:`read_vtu`, as
meshio 5.3 cannot read string arrays. meshio has no ``.pvd`` writer, so
:func:`write_pvd` writes the collection XML itself with :mod:`xml.etree`.
"""

from __future__ import annotations

import base64
import operator
import os
import re
import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from .._files import atomic_write
from ..errors import ExportError, FlexmbError
from ..model import as_system

__all__ = ["ELASTIC_FIELDS", "SECTION_FIELDS", "PARTS", "body_names", "joint_names", "to_meshio", "write_vtu",
           "write_pvd", "export_vtk", "read_vtu", "paraview_script"]

#: elastic coordinate of a segment joint -> point-data name (rad for rotations, m for translations)
ELASTIC_FIELDS = {"bend_y": "bending_y", "bend_z": "bending_z", "torsion": "torsion",
                  "axial": "axial", "shear_y": "shear_y", "shear_z": "shear_z"}

#: section-load point data written with a system: name -> section-load component (N m)
SECTION_FIELDS = {"moment_torsion": "Mx", "moment_bend_y": "My", "moment_bend_z": "Mz"}

#: what a cell draws, by its ``part_id``: a body's shape (box, bar or segment), a flexible body's centre
#: line, a lever from a joint point to the shape, a joint (vertex), a body axis (``triad=``)
PARTS = ("shape", "centre line", "lever", "joint", "triad")
_SHAPE, _CENTRE, _LEVER, _JOINT, _TRIAD = range(len(PARTS))

# written for every result, 0 where no body keeps them; the translational
# ones only when some body keeps them
_ALWAYS = ("bending_y", "bending_z", "torsion")

_FIELDS = ("t", "x", "positions", "origins", "rotations", "body_names", "coordinate_names", "flexible")

# cell blocks in the files, in this order; VTK cell type numbers
_VTK_CELLS = {"vertex": 1, "line": 3, "quad": 9, "hexahedron": 12}

# corners of a box in VTK's order, as signs along its axes: (hexahedron, quad, line, vertex) by the
# number of axes with a non-zero edge
_CORNERS = {
    3: ("hexahedron", np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                                [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=float)),
    2: ("quad", np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float)),
    1: ("line", np.array([[-1], [1]], dtype=float)),
    0: ("vertex", np.zeros((1, 0))),
}


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


def _inertia_box(mass, inertia, com):
    """The uniform box with this mass and central inertia: centre, axes (columns, right-handed), half edges.

    A box of edges a, b, c has the principal moments ``m (b^2 + c^2) / 12``
    etc., so ``a^2 = 6 (I_2 + I_3 - I_1) / m``. Edges below 1e-6 of the
    longest are taken as 0 (a slender bar is a line, a point mass a point).
    """
    com = np.asarray(com, dtype=float).reshape(3)
    try:
        m = float(mass)
        inertia = np.asarray(inertia, dtype=float).reshape(3, 3)
    except (TypeError, ValueError):
        return com, np.eye(3), np.zeros(3)
    if not (np.isfinite(m) and m > 0 and np.all(np.isfinite(inertia))):
        return com, np.eye(3), np.zeros(3)
    moments, axes = np.linalg.eigh(0.5 * (inertia + inertia.T))
    if np.linalg.det(axes) < 0:
        axes[:, 2] *= -1.0
    edges = np.sqrt(np.clip(6.0 * (moments.sum() - 2.0 * moments) / m, 0.0, None))
    edges[edges < 1e-6 * edges.max()] = 0.0
    return com, axes, edges / 2.0


def _nearest(box, p) -> np.ndarray:
    """Nearest point to ``p`` of a box (centre, axes, half edges), in the box's body frame."""
    centre, axes, half = box
    return centre + axes @ np.clip(axes.T @ (p - centre), -half, half)


def _section_size(section) -> tuple[float, float]:
    """Width (along y) and height (along z) drawn for a section, m: its outer fibres, else the
    rectangle with its second moments per area."""
    if section.c_y > 0 and section.c_z > 0:
        return 2.0 * section.c_y, 2.0 * section.c_z
    return np.sqrt(12.0 * section.Iz / section.area), np.sqrt(12.0 * section.Iy / section.area)


class _Layout:
    """Where every exported point and cell comes from; built once per export.

    Every point is fixed on one body row (``row``; ``n_rows`` is the
    ground) at ``local``, in that row's body frame, so its position and its
    velocity at any state follow from the row's motion. ``station`` numbers
    the centre-line points of the flexible bodies (root, segment joints,
    tip; -1 elsewhere): the elastic coordinates and section loads live
    there, and a segment's corners carry the values of the station at
    their end of the segment.
    """

    def __init__(self, result, system=None, triad: float = 0.0):
        self.n_rows = len(result.body_names)
        self.triad = triad
        # flexible bodies in the order of their first segments' rows, whatever the order of result.flexible
        # (Result.load sorts it by name)
        self.flexible = sorted(((name, np.asarray(rows, dtype=int), float(l)) for name, (rows, l)
                                in result.flexible.items()), key=lambda f: int(f[1][0]))
        names = list(result.body_names)
        carried = {int(k) for _, rows, _ in self.flexible for k in rows}
        # a clamped flexible body's massless clamp frame, named "<body>.base", sits at the root
        bases = {f"{name}.base" for name, _, _ in self.flexible}
        self.rigid = np.array([k for k, n in enumerate(names) if k not in carried and n not in bases], dtype=int)
        self.names = [names[k] for k in self.rigid] + [name for name, _, _ in self.flexible]
        self.joint_names: list[str] = []
        self._row, self._local, self._station = [], [], []
        self.n_points = 0
        self._cells: dict[str, list] = {t: [] for t in _VTK_CELLS}
        self.n_stations = 0
        self.station_start = {}
        for name, rows, _ in self.flexible:
            self.station_start[name] = self.n_stations
            self.n_stations += len(rows) + 1
        self.bodies = {}  # flexible body name -> FlexibleBody (with a system)
        if system is None:
            self._rigid_from_result(result)
            self._flexible(None)
        else:
            self._rigid_from_system(system)
            self._flexible(system)
            self._joints(system)
        if triad:
            self._triads()
        self._elastic_columns(result)
        self.row = np.concatenate(self._row) if self._row else np.zeros(0, dtype=np.int64)
        self.local = np.concatenate(self._local).reshape(-1, 3) if self._local else np.zeros((0, 3))
        self.station = np.concatenate(self._station) if self._station else np.zeros(0, dtype=np.int64)
        self.blocks = []  # (meshio cell type, connectivity, {cell data name: values})
        for ctype, parts in self._cells.items():
            if parts:
                conn = np.concatenate([c for c, *_ in parts]).astype(np.int64)
                data = {name: np.concatenate([p[k] for p in parts]).astype(np.int64)
                        for k, name in enumerate(("body_id", "joint_id", "segment", "part_id"), start=1)}
                self.blocks.append((ctype, conn, data))

    # -- building
    def _points(self, rows, local, station=None) -> np.ndarray:
        """Add points fixed on body rows; return their indices."""
        local = np.asarray(local, dtype=float).reshape(-1, 3)
        n = len(local)
        self._row.append(np.broadcast_to(np.asarray(rows, dtype=np.int64), (n,)).copy())
        self._local.append(local)
        self._station.append(np.full(n, -1, dtype=np.int64) if station is None
                             else np.broadcast_to(np.asarray(station, dtype=np.int64), (n,)).copy())
        idx = np.arange(self.n_points, self.n_points + n, dtype=np.int64)
        self.n_points += n
        return idx

    def _add_cells(self, ctype, conn, body, part, joint=-1, segment=-1):
        conn = np.asarray(conn, dtype=np.int64)
        conn = conn.reshape(len(conn), -1)
        n = len(conn)
        self._cells[ctype].append((conn, *(np.broadcast_to(np.asarray(v, dtype=np.int64), (n,))
                                           for v in (body, joint, segment, part))))

    def _box_cells(self, row, box, body):
        """The shape of a rigid body: its box, or the faces, edge or point it degenerates to."""
        centre, axes, half = box
        dims = np.flatnonzero(half > 0)
        ctype, signs = _CORNERS[len(dims)]
        local = centre + (signs * half[dims]) @ axes[:, dims].T
        self._add_cells(ctype, self._points(row, local)[None], body, _SHAPE)

    def _rigid_from_system(self, system):
        topo = system.topology
        self._boxes = {}
        for b, k in enumerate(self.rigid):
            body = topo.bodies[k]
            box = _inertia_box(getattr(body, "mass", 0.0), getattr(body, "inertia", None),
                               getattr(body, "com", np.zeros(3)))
            self._boxes[int(k)] = box
            self._box_cells(k, box, b)

    def _rigid_from_result(self, result):
        # the mass centre in the body frame, from the first output (constant for a rigid body)
        R0 = np.asarray(result.rotations, dtype=float)[0]
        d0 = np.asarray(result.positions, dtype=float)[0] - np.asarray(result.origins, dtype=float)[0]
        for b, k in enumerate(self.rigid):
            com = R0[k].T @ d0[k]
            if np.linalg.norm(com) > 0:
                self._add_cells("line", self._points(k, [np.zeros(3), 2.0 * com])[None], b, _SHAPE)
            else:
                self._add_cells("vertex", self._points(k, np.zeros(3))[None], b, _SHAPE)

    def _flexible(self, system):
        nr = len(self.rigid)
        if system is not None:
            self.bodies = {body.name: body for body in system.topology.flexible}
        for b, (name, rows, l) in enumerate(self.flexible, start=nr):
            n = len(rows)
            st = self.station_start[name] + np.arange(n + 1)
            local = np.zeros((n + 1, 3))
            local[-1, 0] = l  # the tip rides on the last segment
            line = self._points(np.append(rows, rows[-1]), local, st)
            self._add_cells("line", np.stack([line[:-1], line[1:]], axis=1), b, _CENTRE, segment=np.arange(n))
            body = self.bodies.get(name)
            if body is None:
                continue
            w, h = _section_size(body.section)
            signs = _CORNERS[3][1]
            corners = (0.5 * (signs + 1.0)) * [l, 0.0, 0.0] + signs * [0.0, w / 2, h / 2]
            ends = (signs[:, 0] > 0).astype(np.int64)  # 0: at the segment's start, 1: at its end
            idx = self._points(np.repeat(rows, 8), np.tile(corners, (n, 1)),
                               (st[:-1, None] + ends[None, :]).ravel())
            self._add_cells("hexahedron", idx.reshape(n, 8), b, _SHAPE, segment=np.arange(n))

    def _body_box(self, system, carrier):
        """The row carrying a body's shape near ``carrier`` and that shape's box, in the carrier's frame."""
        topo = system.topology
        owner = getattr(carrier, "owner", None)
        if owner is not None and owner.name in self.bodies:
            # a segment (or the clamp frame, at the root of segment 0): the segment's section block
            seg = topo.flexible[owner][1][max(carrier.index, 0)]
            l = owner.segment_length
            w, h = _section_size(owner.section)
            return topo.index[seg], (np.array([l / 2, 0.0, 0.0]), np.eye(3), np.array([l / 2, w / 2, h / 2]))
        k = topo.index[carrier]
        return k, self._boxes[k]

    def _joints(self, system):
        """A vertex at every joint point of every body it joins, and a lever to the body's shape.

        A joint whose points may part (one with translations, or a motion of
        its own) also gets a line from the parent's joint point to the
        child's, drawn with the child.
        """
        from ..joints import Joint

        topo = system.topology
        drawn = {int(k): b for b, k in enumerate(self.rigid)}
        drawn_flexible = {name: b for b, (name, _, _) in enumerate(self.flexible, start=len(self.rigid))}
        for j_id, joint in enumerate(system.model.joints):
            self.joint_names.append(joint.name)
            placed = topo.joint_map.get(joint, joint)
            cls = type(placed)
            slides = bool(cls.translation_axes) or getattr(cls.motion, "__func__", None) is not Joint.motion.__func__
            ends, child_body = [], None
            for body, carrier, point in ((joint.parent, placed.parent, placed.parent_point),
                                         (joint.child, placed.child, placed.child_point)):
                k = topo.index.get(carrier, -1)
                p = np.asarray(point, dtype=float)
                if k < 0:  # the ground is not drawn; a slide on it starts from its point there
                    if slides:
                        ends.append(self._points(self.n_rows, p)[0])
                    continue
                b = drawn_flexible[body.name] if body.name in drawn_flexible else drawn.get(int(k))
                if b is None:
                    continue
                ip = self._points(k, p)
                ends.append(ip[0])
                child_body = b
                row, box = self._body_box(system, carrier)
                q = _nearest(box, p)
                size = max(2.0 * float(np.linalg.norm(box[2])), float(np.linalg.norm(p - box[0])))
                if np.linalg.norm(p - q) > 1e-9 * size:
                    self._add_cells("line", [[self._points(row, q)[0], ip[0]]], b, _LEVER, joint=j_id)
                self._add_cells("vertex", ip[None], b, _JOINT, joint=j_id)
            if slides and len(ends) == 2 and child_body is not None:
                self._add_cells("line", [ends], child_body, _JOINT, joint=j_id)

    def _triads(self):
        for b, k in enumerate(self.rigid):
            idx = self._points(k, np.vstack([np.zeros(3), self.triad * np.eye(3)]))
            self._add_cells("line", np.stack([np.full(3, idx[0]), idx[1:]], axis=1), b, _TRIAD)

    def _elastic_columns(self, result):
        """Which column of x feeds which station, per elastic point-data field."""
        self.elastic: dict[str, tuple[list, list]] = {}
        for name, rows, _ in self.flexible:
            n_seg = len(rows)
            pattern = re.compile(rf"^{re.escape(name)}\.j(\d+)\.(\w+)$")
            for col, cname in enumerate(result.coordinate_names):
                m = pattern.match(cname)
                if not m:
                    continue
                k, coord = int(m.group(1)), m.group(2)
                if coord not in ELASTIC_FIELDS or k >= n_seg:
                    raise ExportError(f"coordinate {cname!r} of flexible body {name!r} is not a segment-joint "
                                      f"coordinate <body>.j<k>.<{'|'.join(ELASTIC_FIELDS)}> with k < {n_seg}")
                cols, stations = self.elastic.setdefault(ELASTIC_FIELDS[coord], ([], []))
                cols.append(col)
                # joint j<k> sits at the start of segment k: station k
                stations.append(self.station_start[name] + k)
        for field in _ALWAYS:
            self.elastic.setdefault(field, ([], []))

    # -- evaluation
    def _extended(self, a, fill):
        """A per-body history with the ground appended as the last row."""
        a = np.asarray(a, dtype=float)
        ground = np.broadcast_to(fill, (a.shape[0], 1) + a.shape[2:])
        return np.concatenate([a, ground], axis=1)

    def positions(self, result, frames=None) -> np.ndarray:
        """Inertial positions of the points, shape (n_frames, n_points, 3), m."""
        sel = slice(None) if frames is None else np.asarray(frames)
        R = self._extended(np.asarray(result.rotations)[sel], np.eye(3))[:, self.row]
        O = self._extended(np.asarray(result.origins)[sel], np.zeros(3))[:, self.row]
        return np.einsum("tpij,pj->tpi", R, self.local) + O

    def station_values(self, values: np.ndarray) -> np.ndarray:
        """Point values from station values (n_frames, n_stations); 0 at points without a station."""
        out = np.zeros((len(values), self.n_points))
        has = self.station >= 0
        out[:, has] = values[:, self.station[has]]
        return out

    def elastic_values(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """Point data of the elastic coordinates at states x (n_frames, n), 0 where none applies."""
        out = {}
        for field, (cols, stations) in self.elastic.items():
            s = np.zeros((len(x), self.n_stations))
            s[:, stations] = x[:, cols]
            out[field] = self.station_values(s)
        return out

    def exact_velocities(self, system, t, x, xd, P) -> np.ndarray:
        """Velocities of the points from the kinematics of ``system`` (eq. 17), m/s, shape like P."""
        nt = len(t)
        omega, v, r = (np.empty((nt, self.n_rows + 1, 3)) for _ in range(3))
        for i in range(nt):  # one compiled kinematics per output time; the points are vectorised
            kin = system.kinematics(t[i], x[i], xd[i])
            omega[i], v[i], r[i] = kin.omega, kin.v, kin.r
        k = self.row
        return v[:, k] + np.cross(omega[:, k], P - r[:, k])

    def cell_blocks(self):
        """meshio cell blocks and cell data (constant over time)."""
        cells = [meshio.CellBlock(ctype, conn) for ctype, conn, _ in self.blocks]
        names = ("body_id", "joint_id", "segment", "part_id")
        return cells, {name: [data[name] for _, _, data in self.blocks] for name in names}

    def tables(self) -> dict:
        """The name tables (field data)."""
        return {"body_names": np.array(self.names, dtype=str), "joint_names": np.array(self.joint_names, dtype=str),
                "part_names": np.array(PARTS, dtype=str)}


def _check_system(system, result):
    system = as_system(system, ExportError)
    if list(system.body_names) != list(result.body_names) or system.n_coords != np.shape(result.x)[1]:
        raise ExportError("the system does not match the result: different bodies or number of coordinates")
    if not hasattr(result, "xd") or np.shape(result.xd) != np.shape(result.x):
        raise ExportError(f"result.xd must have the shape of result.x {np.shape(result.x)} "
                          f"for exact velocities")
    return system


def _section_values(layout, result, frames) -> dict[str, np.ndarray]:
    """Section moments and von Mises stress at the points, shape (n_frames, n_points) each.

    From the kept coordinates' springs and dampers (:mod:`flexmb.post`),
    at the stations of the segment joints (and the corners at that end of
    the segments); 0 at the free ends and for components a body does not
    keep, NaN stress for a section without outer-fibre distances.
    """
    from ..post.sections import _section_loads, _stresses

    nf = len(frames)
    out = {name: np.zeros((nf, layout.n_stations)) for name in (*SECTION_FIELDS, "von_mises")}
    sub = _Frames(result, frames)
    for name, body in layout.bodies.items():
        loads = _section_loads(sub, body, None)
        st = layout.station_start[name] + (0 if body.clamped else 1) + np.arange(body.n_joints)
        for field, comp in SECTION_FIELDS.items():
            if comp in loads.components:
                out[field][:, st] = loads.component(comp)
        try:
            out["von_mises"][:, st] = _stresses(sub, body, loads).component("von_mises")
        except FlexmbError:  # no outer-fibre distances: no stress
            out["von_mises"][:, st] = np.nan
    return {name: layout.station_values(v) for name, v in out.items()}


class _Frames:
    """The fields of a result the section loads read, at some output indices."""

    def __init__(self, result, frames):
        self.t = np.asarray(result.t, dtype=float)[frames]
        self.x = np.asarray(result.x, dtype=float)[frames]
        self.xd = np.asarray(result.xd, dtype=float)[frames]
        self.coordinate_names = result.coordinate_names
        self.flexible = result.flexible


def _fd_velocities(result, P_all) -> np.ndarray:
    """Point velocities by differences of the positions over the output times."""
    t = np.asarray(result.t, dtype=float)
    if len(t) < 2:
        return np.full_like(P_all, np.nan)
    if np.any(np.diff(t) <= 0):
        raise ExportError("result.t must be increasing to difference positions into velocities")
    # second-order central differences inside, second-order one-sided at the ends
    return np.gradient(P_all, t, axis=0, edge_order=2 if len(t) > 2 else 1)


def _meshes(result, frames, system=None, triad=0.0, extra=None, reference=None):
    """Meshes at the given output indices, sharing one layout and one pass over the history.

    With ``reference`` (an output index), the points are drawn where they
    are at that output and ``displacement`` carries them to each frame.
    """
    _check_result(result)
    triad = _check_triad(triad)
    if system is not None:
        system = _check_system(system, result)
    frames = np.asarray(list(frames), dtype=int)
    layout = _Layout(result, system, triad)
    t = np.asarray(result.t, dtype=float)
    x = np.asarray(result.x, dtype=float)
    if system is not None:
        P = layout.positions(result, frames)
        V = layout.exact_velocities(system, t[frames], x[frames], np.asarray(result.xd, dtype=float)[frames], P)
    else:
        P_all = layout.positions(result)
        V = _fd_velocities(result, P_all)[frames]
        P = P_all[frames]
    point_data = {"velocity": V, **layout.elastic_values(x[frames])}
    if system is not None and layout.bodies:
        point_data.update(_section_values(layout, result, frames))
    cells, cell_data = layout.cell_blocks()
    tables = layout.tables()
    base = layout.positions(result, [reference])[0] if reference is not None else None
    cache: dict = {}  # the XML of what the frames share (see _vtu_text)
    for n, i in enumerate(frames):
        field_data = {"time": np.array([t[i]]), **tables}
        field_data.update({k: np.atleast_1d(np.asarray(v)) for k, v in (extra or {}).items()})
        pd = {name: v[n] for name, v in point_data.items()}
        points = P[n]
        if base is not None:
            pd = {"displacement": points - base, **pd}
            points = base
        mesh = meshio.Mesh(points, cells, point_data=pd, cell_data=cell_data, field_data=field_data)
        mesh._vtu_cache = cache
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
        The rigid bodies in result order, then the flexible bodies in the
        order of their first segments. The segments of a flexible body (and
        its clamp frame ``"<body>.base"``) are not listed: they are drawn as
        the flexible body.
    """
    _check_result(result)
    return list(_Layout(result).names)


def joint_names(system) -> list[str]:
    """Return the names of the exported joints, in the order of the ``joint_id`` cell data.

    Parameters
    ----------
    system : System or Model
        The model.

    Returns
    -------
    list of str
        The model's joints in the order they were added (segment joints
        of flexible bodies are drawn as the points of their centre lines).
    """
    model = getattr(system, "model", system)
    if not hasattr(model, "joints"):
        raise ExportError(f"expected a flexmb System or Model, got {type(system).__name__}")
    return [j.name for j in model.joints]


def to_meshio(result, i: int, *, system=None, triad: float = 0.0) -> "meshio.Mesh":
    """The bodies at one output time as a meshio mesh.

    Parameters
    ----------
    result : Result
        A simulation result.
    i : int
        Output index (negative counts from the end).
    system : System or Model, optional
        The model the result came from. With it, bodies are drawn through
        their joint points (boxes, segment sections, joints), velocities
        are exact (from ``result.xd`` through the kinematics, ``v + omega x
        (p - r)``) and the section loads are added; without it, a rigid
        body is a line through its frame origin and mass centre and
        velocities are differences of the positions over the output times
        (see Notes).
    triad : float
        Length of the body-axis lines drawn for each rigid body, m (0: none).

    Returns
    -------
    meshio.Mesh
        Points in m, in the current configuration. Cells: ``"hexahedron"``
        (rigid boxes, flexible segments), ``"quad"``, ``"line"`` (slender
        bars, levers to joint points, centre lines, triads), ``"vertex"``
        (joint points). Point data ``velocity`` (m/s), ``bending_y``,
        ``bending_z``, ``torsion`` (rad, at the centre-line points of the
        segment joints and the segment corners at that end, 0 elsewhere) and
        ``axial``, ``shear_y``, ``shear_z`` (m) if kept; with ``system``,
        also the section loads ``moment_torsion``, ``moment_bend_y``,
        ``moment_bend_z`` (N m) and ``von_mises`` (Pa) there. Cell data
        ``body_id`` (into field data ``body_names``, see :func:`body_names`),
        ``joint_id`` (into ``joint_names``, -1 for cells that are not a
        joint's), ``segment`` (-1 for rigid bodies), ``part_id`` (into
        ``part_names``: :data:`PARTS`). Field data ``time`` (s).

    Raises
    ------
    ExportError
        If ``result`` lacks a field or has inconsistent shapes, ``i`` is
        out of range or ``system`` does not match the result.

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
    >>> mesh = to_meshio(res, -1, system=model)
    >>> [(c.type, len(c.data)) for c in mesh.cells]
    [('vertex', 1), ('line', 1)]
    >>> [str(n) for n in mesh.field_data["joint_names"]]
    ['pin']
    """
    nt = _check_result(result)
    i = _check_index(i, nt)
    return next(_meshes(result, [i], system, triad))


# -- the VTU file


_VTU_TYPES = {"f8": "Float64", "f4": "Float32", "i8": "Int64", "i4": "Int32", "i2": "Int16", "i1": "Int8",
              "u8": "UInt64", "u4": "UInt32", "u2": "UInt16", "u1": "UInt8"}


def _vtu_type(a: np.ndarray) -> str:
    key = f"{a.dtype.kind}{a.dtype.itemsize}"
    if a.dtype.kind == "b":
        return "UInt8"
    if key not in _VTU_TYPES:
        raise ExportError(f"cannot write an array of type {a.dtype} to VTK")
    return _VTU_TYPES[key]


def _binary(a: np.ndarray) -> str:
    """Inline binary data: base64 of a UInt64 byte count followed by the native-order bytes."""
    data = np.ascontiguousarray(a).tobytes()
    return base64.b64encode(np.uint64(len(data)).tobytes() + data).decode("ascii")


def _strings(values) -> str:
    """A VTK string array, inline binary: each string's UTF-8 bytes, then a 0."""
    data = b"".join(str(v).encode("utf-8") + b"\0" for v in values)
    return base64.b64encode(np.uint64(len(data)).tobytes() + data).decode("ascii")


def _data_array(name, a, field=False) -> str:
    a = np.asarray(a)
    if a.dtype.kind in "US":
        n = f' NumberOfTuples="{a.size}"' if field else ""
        return f'<Array type="String" Name={quoteattr(str(name))}{n} format="binary">{_strings(a.ravel())}</Array>\n'
    if a.dtype.kind == "b":
        a = a.astype(np.uint8)
    if field:  # field data in ASCII, exact (repr)
        a = a.ravel()
        text = " ".join(repr(float(v)) for v in a) if a.dtype.kind == "f" else " ".join(str(int(v)) for v in a)
        return (f'<DataArray type="{_vtu_type(a)}" Name={quoteattr(str(name))} NumberOfTuples="{a.size}" '
                f'format="ascii">{text}</DataArray>\n')
    nc = f' NumberOfComponents="{a.shape[1]}"' if a.ndim == 2 else ""
    return (f'<DataArray type="{_vtu_type(a)}" Name={quoteattr(str(name))}{nc} format="binary">'
            f'{_binary(a)}</DataArray>\n')


def _named(mesh) -> dict:
    """String cell data for ParaView: the names of the ids that have a name table."""
    out = {}
    for ids, table, name in (("body_id", "body_names", "body"), ("joint_id", "joint_names", "joint"),
                             ("part_id", "part_names", "part")):
        if ids in mesh.cell_data and table in mesh.field_data:
            names = np.append(np.asarray(mesh.field_data[table], dtype=str), "")
            out[name] = [names[np.where(v >= 0, v, len(names) - 1)] for v in mesh.cell_data[ids]]
    return out


def _cells_text(mesh) -> tuple[str, int]:
    """The CellData and Cells XML of a mesh, and its number of cells."""
    conn, offsets, types = [], [], []
    end = 0
    for block in mesh.cells:
        data = np.asarray(block.data, dtype=np.int64)
        conn.append(data.ravel())
        offsets.append(end + data.shape[1] * np.arange(1, len(data) + 1, dtype=np.int64))
        end += data.size
        vtk_type = _VTK_CELLS.get(block.type) or meshio._vtk_common.meshio_to_vtk_type[block.type]
        types.append(np.full(len(data), vtk_type, dtype=np.uint8))
    cell_data = {name: np.concatenate([np.asarray(v) for v in values]) for name, values in mesh.cell_data.items()}
    cell_data.update({name: np.concatenate(values) for name, values in _named(mesh).items()})
    text = "".join([
        "<CellData>\n",
        *(_data_array(k, v) for k, v in cell_data.items()),
        "</CellData>\n",
        "<Cells>\n",
        _data_array("connectivity", np.concatenate(conn) if conn else np.zeros(0, dtype=np.int64)),
        _data_array("offsets", np.concatenate(offsets) if offsets else np.zeros(0, dtype=np.int64)),
        _data_array("types", np.concatenate(types) if types else np.zeros(0, dtype=np.uint8)),
        "</Cells>\n",
    ])
    return text, sum(len(b.data) for b in mesh.cells)


def _vtu_text(mesh) -> str:
    """The VTU XML of a meshio mesh: binary point and cell data, ASCII field data, string arrays.

    The meshes of one export share their cells, cell data and name tables
    (and a ``_vtu_cache`` dict): their XML is made once.
    """
    byte_order = "LittleEndian" if sys.byteorder == "little" else "BigEndian"
    field = dict(mesh.field_data)
    if "time" in field:
        field.setdefault("TimeValue", field["time"])  # the name ParaView reads as a file's time
    cache = getattr(mesh, "_vtu_cache", None)
    hit = cache.get("cells") if cache is not None else None
    if hit and len(hit[0]) == len(mesh.cells) and all(a is b for a, b in zip(hit[0], mesh.cells)) \
            and hit[1] is mesh.cell_data:
        cells, n_cells = hit[2:]
    else:
        cells, n_cells = _cells_text(mesh)
        if cache is not None:
            cache["cells"] = (list(mesh.cells), mesh.cell_data, cells, n_cells)

    def field_array(name, value):
        if cache is None or np.asarray(value).dtype.kind not in "US":
            return _data_array(name, value, field=True)
        hit = cache.get(("field", name))
        if hit is None or hit[0] is not value:
            hit = cache[("field", name)] = (value, _data_array(name, value, field=True))
        return hit[1]

    points = np.asarray(mesh.points, dtype=float).reshape(-1, 3)
    return "".join([
        '<?xml version="1.0"?>\n',
        f'<VTKFile type="UnstructuredGrid" version="1.0" byte_order="{byte_order}" header_type="UInt64">\n',
        "<UnstructuredGrid>\n<FieldData>\n",
        *(field_array(k, v) for k, v in field.items()),
        f'</FieldData>\n<Piece NumberOfPoints="{len(points)}" NumberOfCells="{n_cells}">\n<PointData>\n',
        *(_data_array(k, v) for k, v in mesh.point_data.items()),
        "</PointData>\n",
        cells,
        "<Points>\n",
        _data_array("Points", points),
        "</Points>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n",
    ])


def _write_text(path, text: str) -> None:
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)


def _write_mesh(mesh, path) -> Path:
    """Write a .vtu file, with the mesh's field data, whole or not at all (through a temporary name)."""
    text = _vtu_text(mesh)
    return atomic_write(path, lambda tmp: _write_text(tmp, text), suffix=".vtu")


def read_vtu(path) -> "meshio.Mesh":
    """Read a ``.vtu`` file written by flexmb, string arrays included.

    Parameters
    ----------
    path : str or path-like
        The file.

    Returns
    -------
    meshio.Mesh
        Points, cells, point and cell data and field data; the string
        arrays (the name tables ``body_names``, ``joint_names``,
        ``part_names`` and the cell data ``body``, ``joint``, ``part``) as
        arrays of str.

    Notes
    -----
    meshio 5.3 reads VTU files but not VTK string arrays (it stops at
    ``Illegal data type 'String'``): this reader takes them out, lets
    meshio read the rest and puts them back. pyvista (VTK) reads the files
    as they are.
    """
    tree = ET.parse(os.fspath(path))
    root = tree.getroot()
    strings: dict[str, dict] = {"FieldData": {}, "CellData": {}, "PointData": {}}
    for parent in root.iter():
        if parent.tag not in strings:
            continue
        for arr in [a for a in parent if a.tag == "Array" and a.get("type") == "String"]:
            strings[parent.tag][arr.get("Name")] = _read_strings(arr)
            parent.remove(arr)
    with tempfile.TemporaryDirectory() as tmp:
        stripped = os.path.join(tmp, "mesh.vtu")
        tree.write(stripped)
        mesh = meshio.read(stripped)
    mesh.field_data.update(strings["FieldData"])
    for name, values in strings["PointData"].items():
        mesh.point_data[name] = values
    sizes = np.cumsum([len(c.data) for c in mesh.cells])[:-1]
    for name, values in strings["CellData"].items():
        mesh.cell_data[name] = np.split(values, sizes)
    return mesh


def _read_strings(arr) -> np.ndarray:
    text = (arr.text or "").strip()
    if arr.get("format", "ascii") == "ascii":
        raw = bytes(int(c) for c in text.split())
    else:
        raw = base64.b64decode(text)[8:]  # our header: one UInt64 byte count
    return np.array([s.decode("utf-8") for s in raw.split(b"\0")[:-1]], dtype=str)


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
    system : System or Model, optional
        The model the result came from: bodies through their joints, exact
        velocities, section loads; see :func:`to_meshio`.
    triad : float
        Body-axis line length for rigid bodies, m (0: none).

    Returns
    -------
    list of pathlib.Path
        The files, in output order.

    Raises
    ------
    ExportError
        On a malformed result or prefix, or a system that does not match.
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
    with ``repr`` so they read back exactly. ParaView opens it as one time
    series.
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
    system : System or Model, optional
        The model the result came from: pass it to draw the bodies through
        their joints, with exact velocities and the section loads and
        stresses (see :func:`to_meshio`).
    triad : float
        Body-axis line length for rigid bodies, m (0: none).

    Returns
    -------
    pathlib.Path
        The ``.pvd`` file; open it in ParaView (File > Open), or run
        :func:`paraview_script` in ``pvpython``.

    Raises
    ------
    ExportError
        On a malformed result or prefix, or a system that does not match.

    Examples
    --------
    >>> import tempfile, flexmb as fm
    >>> from flexmb.export.vtk import export_vtk
    >>> model = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    >>> _ = model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0, -9.81, 0)))
    >>> res = fm.simulate(model, 0.1, positions={"pin": 0.5}, n_out=3)
    >>> export_vtk(res, tempfile.mkdtemp(), system=model).name
    'flexmb.pvd'
    """
    paths = write_vtu(result, folder, prefix, system=system, triad=triad)
    return write_pvd(paths, result.t, Path(os.fspath(folder)) / f"{prefix}.pvd")


def paraview_script(path) -> Path:
    """Write the ParaView script that opens flexmb's ``.pvd`` series coloured by stress.

    Parameters
    ----------
    path : str or path-like
        Where to write it (e.g. ``results/open_in_paraview.py``).

    Returns
    -------
    pathlib.Path
        ``path``. Run it with ``pvpython path`` (or ``paraview
        --script=path``): it opens every ``.pvd`` below its folder, or the
        ones named on its command line; see
        :mod:`flexmb.export.open_in_paraview`.
    """
    from . import open_in_paraview

    source = Path(open_in_paraview.__file__).read_text(encoding="utf-8")
    return atomic_write(path, lambda tmp: Path(tmp).write_text(source, encoding="utf-8"), suffix=".py")
