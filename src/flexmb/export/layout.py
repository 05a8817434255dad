"""Where the bodies, joints and sections of a result are drawn: the mesh layout of the VTK export.

See :mod:`flexmb.export.vtk` for what the cells and point data are.
"""

from __future__ import annotations

import operator
import re

import meshio
import numpy as np

from ..errors import ExportError

__all__ = ["ELASTIC_FIELDS", "SECTION_FIELDS", "PARTS", "NAME_TABLES"]

#: elastic coordinate of a segment joint -> point-data name (rad for rotations, m for translations)
ELASTIC_FIELDS = {"bend_y": "bending_y", "bend_z": "bending_z", "torsion": "torsion",
                  "axial": "axial", "shear_y": "shear_y", "shear_z": "shear_z"}

#: section-load point data written with a system: name -> section-load component (N m)
SECTION_FIELDS = {"moment_torsion": "Mx", "moment_bend_y": "My", "moment_bend_z": "Mz"}

#: what a cell draws, by its ``part_id``: a body's shape (box, bar or segment), a flexible body's centre
#: line, a lever from a joint point to the shape, a joint (vertex), a body axis (``triad=``), a contact
#: element's point (vertex; :mod:`flexmb.export.meshes`)
PARTS = ("shape", "centre line", "lever", "joint", "triad", "contact")
_SHAPE, _CENTRE, _LEVER, _JOINT, _TRIAD, _CONTACT = range(len(PARTS))

#: the name tables in the field data: table -> the cell data its ids name. A table is one field-data
#: entry ``"<table>:<name>"`` per name holding its id (``"body:crank" = [0]``): VTK files flexmb writes
#: hold numbers only, as meshio reads no string arrays; ``contact`` (and its cell data) only with contact
#: elements (:mod:`flexmb.export.meshes`)
NAME_TABLES = {"body": "body_id", "joint": "joint_id", "part": "part_id", "contact": "contact_id"}

# written for every result, 0 where no body keeps them; the translational
# ones only when some body keeps them
_VTK_CELLS = {"vertex": 1, "line": 3, "quad": 9, "hexahedron": 12}

_ALWAYS = ("bending_y", "bending_z", "torsion")

_FIELDS = ("t", "x", "positions", "origins", "rotations", "body_names", "coordinate_names", "flexible")

# cell blocks in the files, in this order; VTK cell type numbers

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
        self._body_frames(names)
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

    def _body_frames(self, names):
        """Where each point of a flexible body sits on the body undeformed: ``frame_row``, ``frame_local``.

        A flexible body's frame is carried by its clamp frame ``<body>.base``
        (clamped) or its first segment (unclamped); undeformed, segment i's
        frame is that frame moved ``i l`` along its x axis. ``frame_row`` is
        -1 for the points of rigid bodies and the ground.
        """
        frame = np.full(self.n_rows + 1, -1, dtype=np.int64)
        offset = np.zeros((self.n_rows + 1, 3))
        for name, rows, l in self.flexible:
            base = names.index(f"{name}.base") if f"{name}.base" in names else int(rows[0])
            frame[base] = base
            frame[rows] = base
            offset[rows, 0] = l * np.arange(len(rows))
        self.frame_row = frame[self.row]
        self.frame_local = offset[self.row] + self.local

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

    def elastic_displacement(self, result, frames, P) -> np.ndarray:
        """The elastic displacement of the points at positions P (n_frames, n_points, 3), m.

        A point of a flexible body minus where it would be on the body
        undeformed, moved rigidly with the body's frame (its clamp frame or
        first segment); 0 for rigid bodies. Warped by it at scale s, a
        flexible body shows its bending magnified 1 + s times.
        """
        out = np.zeros_like(P)
        has = self.frame_row >= 0
        if has.any():
            sel = np.asarray(frames)
            R = np.asarray(result.rotations, dtype=float)[sel][:, self.frame_row[has]]
            O = np.asarray(result.origins, dtype=float)[sel][:, self.frame_row[has]]
            out[:, has] = P[:, has] - (np.einsum("tpij,pj->tpi", R, self.frame_local[has]) + O)
        return out

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

    def exact_velocities(self, system, t, x, xd, P):
        """Velocities of the points from the kinematics of ``system`` (eq. 17), and the rows' angular velocities.

        Returns ``(V, omega)``: V in m/s, shaped like P; omega (rad/s, inertial axes), shape
        (len(t), n_rows + 1, 3), the ground's (0) last.
        """
        nt = len(t)
        omega, v, r = (np.empty((nt, self.n_rows + 1, 3)) for _ in range(3))
        for i in range(nt):  # one compiled kinematics per output time; the points are vectorised
            kin = system.kinematics(t[i], x[i], xd[i])
            omega[i], v[i], r[i] = kin.omega, kin.v, kin.r
        k = self.row
        return v[:, k] + np.cross(omega[:, k], P - r[:, k]), omega

    def differenced_angular_velocities(self, result) -> np.ndarray:
        """The rows' angular velocities from differences of their rotations over the output times.

        ``omega`` is the axial vector of ``Rdot R^T`` (its skew part), with
        ``Rdot`` from ``np.gradient`` as the points' velocities without a
        system (O(dt^2) in the output spacing; NaN with one output).

        Returns
        -------
        ndarray, shape (nt, n_rows + 1, 3)
            rad/s, inertial axes, the ground's (0) last.
        """
        t = np.asarray(result.t, dtype=float)
        R = self._extended(np.asarray(result.rotations, dtype=float), np.eye(3))
        if len(t) < 2:
            return np.full(R.shape[:2] + (3,), np.nan)
        if np.any(np.diff(t) <= 0):
            raise ExportError("result.t must be increasing to difference rotations into angular velocities")
        Rd = np.gradient(R, t, axis=0, edge_order=2 if len(t) > 2 else 1)
        W = np.einsum("tkij,tklj->tkil", Rd, R)
        W = 0.5 * (W - np.swapaxes(W, -1, -2))
        return np.stack([W[..., 2, 1], W[..., 0, 2], W[..., 1, 0]], axis=-1)

    def cell_rows(self) -> list[np.ndarray]:
        """For each cell block, the body row of each cell: that of its first point (a segment's, a joint's body)."""
        return [self.row[conn[:, 0]] for _, conn, _ in self.blocks]

    def cell_blocks(self):
        """meshio cell blocks and cell data (constant over time)."""
        cells = [meshio.CellBlock(ctype, conn) for ctype, conn, _ in self.blocks]
        names = ("body_id", "joint_id", "segment", "part_id")
        return cells, {name: [data[name] for _, _, data in self.blocks] for name in names}

    def tables(self) -> dict:
        """The name tables (field data): ``"<table>:<name>"`` -> its id, see :data:`NAME_TABLES`."""
        return {f"{table}:{name}": np.array([k], dtype=np.int64)
                for table, names in (("body", self.names), ("joint", self.joint_names), ("part", PARTS))
                for k, name in enumerate(names)}
