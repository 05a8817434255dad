"""The bodies at output times as meshio meshes, with velocities and section data (the VTK export's meshes)."""

from __future__ import annotations

import meshio
import numpy as np

from ..errors import ExportError, FlexmbError
from ..model import as_system
from .layout import NAME_TABLES, PARTS, SECTION_FIELDS, _check_index, _check_result, _check_triad, _Layout

__all__ = ["body_names", "joint_names", "table_names", "to_meshio"]


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


def _contact_values(system, result, frames):
    """The model's contact elements at the frames: names, points, forces and penetrations.

    Returns ``(names, points, forces, penetrations)`` with shapes (c,),
    (nf, c, 3), (nf, c, 3), (nf, c), or None without contact elements. The
    point is the middle of the overlap (where the force acts; the point
    nearest to it while separated), the force the one on the element's
    first body (the sphere's, the pin's), 0 while separated.
    """
    from ..forces.contact import Contact
    from ..impact_speeds import HeldSpeeds

    elements = [e for e in system.model.forces if isinstance(e, Contact)]
    if not elements:
        return None
    nf, c = len(frames), len(elements)
    points, forces, depth = np.zeros((nf, c, 3)), np.zeros((nf, c, 3)), np.zeros((nf, c))
    t, x, xd = (np.asarray(getattr(result, k), dtype=float) for k in ("t", "x", "xd"))
    held = HeldSpeeds.of(system)
    for n, i in enumerate(frames):
        kin = system.kinematics(t[i], x[i], xd[i])
        for k, e in enumerate(elements):
            speeds = [held.at(result.contact_events, e.name, t[i])]  # the impact speed the run held
            delta, _, _, _, point, _, force, _ = type(e).states_all([e], kin, speeds)
            points[n, k], forces[n, k], depth[n, k] = point[0], force[0], delta[0]
    return np.array([e.name for e in elements], dtype=str), points, forces, depth


def _with_contacts(P, point_data, cells, cell_data, contacts):
    """Append one vertex per contact element (part ``contact``) and its point data to the meshes' arrays.

    ``contact_force`` (N) and ``contact_penetration`` (m, negative: the
    gap) are 0 at the bodies' points; the bodies' point data are 0 at the
    contact points. The cell data ``contact_id`` names the contact of each
    vertex (-1 for the other cells), by the name table ``contact``.
    """
    names, points, forces, depth = contacts
    nf, npts, c = P.shape[0], P.shape[1], len(names)
    point_data = {k: np.concatenate([v, np.zeros((nf, c) + v.shape[2:])], axis=1) for k, v in point_data.items()}
    point_data["contact_force"] = np.concatenate([np.zeros((nf, npts, 3)), forces], axis=1)
    point_data["contact_penetration"] = np.concatenate([np.zeros((nf, npts)), depth], axis=1)
    cells = [*cells, meshio.CellBlock("vertex", (npts + np.arange(c)).reshape(-1, 1))]
    part = PARTS.index("contact")
    ids = [np.full(len(block.data), -1, dtype=np.int64) for block in cells[:-1]]
    cell_data = {k: [*v, np.full(c, part if k == "part_id" else -1, dtype=np.asarray(v[0]).dtype)]
                 for k, v in cell_data.items()}
    cell_data["contact_id"] = [*ids, np.arange(c, dtype=np.int64)]
    return np.concatenate([P, points], axis=1), point_data, cells, cell_data


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
        V, omega = layout.exact_velocities(system, t[frames], x[frames], np.asarray(result.xd, dtype=float)[frames],
                                           P)
    else:
        P_all = layout.positions(result)
        V = _fd_velocities(result, P_all)[frames]
        omega = layout.differenced_angular_velocities(result)[frames]
        P = P_all[frames]
    point_data = {"elastic_displacement": layout.elastic_displacement(result, frames, P), "velocity": V,
                  **layout.elastic_values(x[frames])}
    if system is not None and layout.bodies:
        point_data.update(_section_values(layout, result, frames))
    cells, cell_data = layout.cell_blocks()
    cell_rows = layout.cell_rows()
    tables = layout.tables()
    contacts = _contact_values(system, result, frames) if system is not None and reference is None else None
    if contacts is not None:
        P, point_data, cells, cell_data = _with_contacts(P, point_data, cells, cell_data, contacts)
        tables.update({f"contact:{name}": np.array([k], dtype=np.int64) for k, name in enumerate(contacts[0])})
        cell_rows.append(np.full(len(contacts[0]), layout.n_rows))  # a contact point: the ground's 0
    base = layout.positions(result, [reference])[0] if reference is not None else None
    cache: dict = {}  # the XML of what the frames share (see _vtu_text)
    for n, i in enumerate(frames):
        # TimeValue: the name ParaView reads as the time of a file opened without the .pvd
        field_data = {"time": np.array([t[i]]), "TimeValue": np.array([t[i]]), **tables}
        field_data.update({k: np.atleast_1d(np.asarray(v)) for k, v in (extra or {}).items()})
        pd = {name: v[n] for name, v in point_data.items()}
        points = P[n]
        if base is not None:
            pd = {"displacement": points - base, **pd}
            points = base
        # the cells' angular velocities (those of the bodies or segments they draw) change with the frame; the
        # other cell data are the same arrays in every frame (their XML is made once, flexmb.export.vtu)
        cd = {**cell_data, "angular_velocity": [omega[n][rows] for rows in cell_rows]}
        mesh = meshio.Mesh(points, cells, point_data=pd, cell_data=cd, field_data=field_data)
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


def table_names(field_data, table: str = "body") -> list[str]:
    """Return the names of a name table of an exported mesh or file, in the order of their ids.

    Parameters
    ----------
    field_data : dict
        The field data of a mesh from :func:`to_meshio`, of a ``.vtu``
        file read back (``meshio.read(path).field_data``,
        ``pyvista.read(path).field_data``), or of one block of a ``.pvd``.
    table : {'body', 'joint', 'part'}
        The table: the names of the cell data ``body_id``, ``joint_id`` or
        ``part_id``.

    Returns
    -------
    list of str
        ``names[k]`` is the name of id ``k``: the field-data entries
        ``"<table>:<name>"`` holding ``k``.

    Raises
    ------
    ExportError
        If ``table`` is not one of the tables, or the ids are not 0, 1, ...
        (a field data that is not flexmb's).

    Examples
    --------
    >>> import numpy as np
    >>> from flexmb.export.vtk import table_names
    >>> table_names({"time": np.array([0.5]), "body:rocker": np.array([1]), "body:crank": np.array([0])})
    ['crank', 'rocker']
    """
    if table not in NAME_TABLES:
        raise ExportError(f"table must be one of {sorted(NAME_TABLES)}, got {table!r}")
    prefix = f"{table}:"
    ids = {}
    for key, value in field_data.items():
        if str(key).startswith(prefix):
            ids[str(key)[len(prefix):]] = int(np.ravel(value)[0])
    names = sorted(ids, key=ids.get)
    if sorted(ids.values()) != list(range(len(ids))):
        raise ExportError(f"the field data's '{prefix}<name>' entries hold ids {sorted(ids.values())}, "
                          f"expected 0 to {len(ids) - 1}: not a flexmb export")
    return names


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
        (joint points). Point data ``elastic_displacement`` (m: a flexible
        body's points minus where they would be on the body undeformed,
        moved rigidly with its clamp frame or first segment; 0 for rigid
        bodies), ``velocity`` (m/s), ``bending_y``, ``bending_z``,
        ``torsion`` (rad, at the centre-line points of the segment joints
        and the segment corners at that end, 0 elsewhere) and ``axial``,
        ``shear_y``, ``shear_z`` (m) if kept; with ``system``, also the
        section loads ``moment_torsion``, ``moment_bend_y``,
        ``moment_bend_z`` (N m) and ``von_mises`` (Pa) there. Cell data
        ``body_id`` (see :func:`body_names`), ``joint_id`` (-1 for cells
        that are not a joint's), ``segment`` (-1 for rigid bodies),
        ``part_id`` (:data:`PARTS`) and ``angular_velocity`` (rad/s,
        inertial axes: that of the body, or the flexible body's segment, the
        cell draws, the body of its first point; exact with ``system``, from
        differences of the rotations without it; 0 for contact points). Field data ``time`` and ``TimeValue``
        (s), and the name tables of the ids, one entry ``"body:<name>"``,
        ``"joint:<name>"``, ``"part:<name>"`` holding the id per name
        (:func:`table_names` reads them back). The mesh is what the
        ``.vtu`` file holds: numbers only.

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
    >>> from flexmb.export.vtk import table_names, to_meshio
    >>> model = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    >>> _ = model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0, -9.81, 0)))
    >>> res = fm.simulate(model, 0.1, positions={"pin": 0.5}, n_out=3)
    >>> mesh = to_meshio(res, -1, system=model)
    >>> [(c.type, len(c.data)) for c in mesh.cells]
    [('vertex', 1), ('line', 1)]
    >>> table_names(mesh.field_data, "joint")
    ['pin']
    """
    nt = _check_result(result)
    i = _check_index(i, nt)
    return next(_meshes(result, [i], system, triad))


# -- the VTU file
