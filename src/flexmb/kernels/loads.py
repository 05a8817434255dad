"""Scattering point forces and torques onto bodies, and the positions and velocities of body points."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from .cache import njit
from .broadphase import block_candidates
from .contact import elastic_energy, friction_factor, normal_force
from .contact_geometry import contact_geometry

__all__ = ["LoadTables", "add_point_forces", "add_torques", "body_points", "apply_load_tables", "contact_states"]


class LoadTables(NamedTuple):
    """Flat data of compiled force elements (one row per element or coordinate).

    Built by :meth:`LoadTables.of` (``flexmb.forces.tables``); each
    parameter is kept as the field of the same name.

    Parameters
    ----------
    gravity : ndarray, shape (3,)
        Summed uniform gravity, m/s^2.
    coord_cols : ndarray of int, shape (m,)
        Coordinates carrying a spring and damper.
    coord_k, coord_c, coord_rest : ndarray, shape (m,)
        Their stiffnesses, damping constants and rest values.
    pair_rows : ndarray of int, shape (p, 2)
        Body rows of the two ends of each point-to-point spring-damper.
    pair_local : ndarray, shape (p, 2, 3)
        The ends in their rows' body frames.
    pair_par : ndarray, shape (p, 3)
        Stiffness, damping constant and rest length.
    force_rows : ndarray of int, shape (q,)
        Body rows of constant point forces.
    force_local : ndarray, shape (q, 3)
        Points of application in the rows' body frames.
    force_vec : ndarray, shape (q, 3)
        The forces, N.
    force_in_body : ndarray of bool, shape (q,)
        Whether a force's components are in body axes.
    torque_rows : ndarray of int, shape (s,)
        Body rows of constant torques.
    torque_vec : ndarray, shape (s, 3)
        The torques, N m.
    torque_in_body : ndarray of bool, shape (s,)
        Whether a torque's components are in body axes.
    gravity_group, coord_group, pair_group, force_group, torque_group : ndarray of int
        The force-element class (the model's group) each row belongs to,
        for the power of each group (``gravity_group`` has one entry).
    contact_rows : ndarray of int, shape (c, 2)
        Body rows of the two sides of each contact: the sphere's (the
        capsule's, the pin's), then the plane's, the second sphere's (or
        capsule's) or the bearing's.
    contact_local : ndarray, shape (c, 4, 3)
        Four points or directions in those rows' body frames, by geometry
        (:mod:`flexmb.kernels.contact_geometry`).
    contact_geom : ndarray, shape (c, 2)
        The radii, m (the second 0 for a plane; the bearing's hole's for
        a journal).
    contact_laws : ndarray of int, shape (c, 3)
        Codes of the geometry, the normal law and the friction law
        (:mod:`flexmb.kernels.contact`).
    contact_par : ndarray, shape (c, 11)
        The normal law's parameters (columns 0-4), then the friction law's
        (columns 5-10).
    contact_group : ndarray of int, shape (c,)
        The group of each contact, as the other group columns.
    contact_always : ndarray of int, shape (a,)
        The contact rows evaluated at every evaluation, in increasing
        order: all but those of the blocks (default: all).
    contact_blocks : ndarray of int, shape (k, 4)
        The blocks of a contact group against a group, whose rows are
        evaluated only where the broad phase finds their shapes' boxes
        overlapping (:mod:`flexmb.kernels.broadphase`): first shape, the
        numbers of shapes n1 and n2 of the two lists, first entry of
        ``contact_block_map``.
    sweep_rows : ndarray of int, shape (s,)
        Body row of each shape of the blocks.
    sweep_local : ndarray, shape (s, 2, 3)
        Its two ends in that row's frame (a sphere: its centre twice), m.
    sweep_radius : ndarray, shape (s,)
        Its radius, m.
    contact_block_map : ndarray of int
        The contact row of each pair (i, j) of a block, at the block's first
        entry plus ``i n2 + j`` (-1: two shapes on one body, no row).
    """

    gravity: np.ndarray
    coord_cols: np.ndarray
    coord_k: np.ndarray
    coord_c: np.ndarray
    coord_rest: np.ndarray
    pair_rows: np.ndarray
    pair_local: np.ndarray
    pair_par: np.ndarray
    force_rows: np.ndarray
    force_local: np.ndarray
    force_vec: np.ndarray
    force_in_body: np.ndarray
    torque_rows: np.ndarray
    torque_vec: np.ndarray
    torque_in_body: np.ndarray
    gravity_group: np.ndarray
    coord_group: np.ndarray
    pair_group: np.ndarray
    force_group: np.ndarray
    torque_group: np.ndarray
    contact_rows: np.ndarray
    contact_local: np.ndarray
    contact_geom: np.ndarray
    contact_laws: np.ndarray
    contact_par: np.ndarray
    contact_group: np.ndarray
    contact_always: np.ndarray
    contact_blocks: np.ndarray
    sweep_rows: np.ndarray
    sweep_local: np.ndarray
    sweep_radius: np.ndarray
    contact_block_map: np.ndarray

    @classmethod
    def of(cls, **fields) -> "LoadTables":
        """Tables holding ``fields`` and empty elsewhere (one compiled layout for every model).

        Parameters
        ----------
        **fields : array_like
            Some of the attributes.

        Returns
        -------
        LoadTables
        """
        shapes = {"gravity": (3,), "pair_rows": (0, 2), "pair_local": (0, 2, 3), "pair_par": (0, 3),
                  "force_local": (0, 3), "force_vec": (0, 3), "torque_vec": (0, 3), "gravity_group": (1,),
                  "contact_rows": (0, 2), "contact_local": (0, 4, 3), "contact_geom": (0, 2), "contact_laws": (0, 3),
                  "contact_par": (0, 11), "contact_blocks": (0, 4), "sweep_local": (0, 2, 3)}
        if fields.get("contact_always") is None:
            fields = dict(fields, contact_always=np.arange(len(fields.get("contact_rows", ()))))
        out = {}
        for name in cls._fields:
            dtype = (np.int64 if name.endswith(("_rows", "_group", "_laws", "_always", "_blocks", "_map"))
                     or name == "coord_cols" else np.bool_ if name.endswith("_in_body") else float)
            value = fields.get(name)
            out[name] = (np.zeros(shapes.get(name, (0,)), dtype=dtype) if value is None
                         else np.ascontiguousarray(value, dtype=dtype))
        return cls(**out)


@njit(cache=True)
def add_point_forces(rows, points, forces, r, force, torque):
    """Add forces at inertial points to the bodies' resultants at their mass centres.

    Parameters
    ----------
    rows : ndarray of int, shape (m,)
        Body rows (-1: the ground, the last row of ``force`` and ``torque``).
    points, forces : ndarray, shape (m, 3)
        Points of application and forces, inertial.
    r : ndarray, shape (n_bodies + 1, 3)
        Mass centres.
    force, torque : ndarray, shape (n_bodies + 1, 3)
        Accumulators, updated in place: ``force[k] += f``,
        ``torque[k] += (p - r_k) x f``.
    """
    for i in range(rows.shape[0]):
        k = rows[i]
        lx = points[i, 0] - r[k, 0]
        ly = points[i, 1] - r[k, 1]
        lz = points[i, 2] - r[k, 2]
        fx, fy, fz = forces[i, 0], forces[i, 1], forces[i, 2]
        force[k, 0] += fx
        force[k, 1] += fy
        force[k, 2] += fz
        torque[k, 0] += ly * fz - lz * fy
        torque[k, 1] += lz * fx - lx * fz
        torque[k, 2] += lx * fy - ly * fx


@njit(cache=True)
def add_torques(rows, torques, torque):
    """``torque[rows[i]] += torques[i]`` (repeated rows add up).

    Parameters
    ----------
    rows : ndarray of int, shape (m,)
        Body rows (-1: the ground).
    torques : ndarray, shape (m, 3)
        Torques, inertial.
    torque : ndarray, shape (n_bodies + 1, 3)
        Accumulator, updated in place.
    """
    for i in range(rows.shape[0]):
        for a in range(3):
            torque[rows[i], a] += torques[i, a]


@njit(cache=True)
def body_points(rows, local, R, origin, r, omega, v):
    """Inertial positions and velocities of points fixed in bodies.

    Parameters
    ----------
    rows : ndarray of int, shape (m,)
        Body rows (-1: the ground).
    local : ndarray, shape (m, 3)
        The points in their body frames.
    R, origin, r, omega, v : ndarray, shape (n_bodies + 1, ...)
        Rotations, body-frame origins, mass centres, angular velocities and
        mass-centre velocities.

    Returns
    -------
    p, vel : ndarray, shape (m, 3)
        ``R_k local + origin_k`` and ``v_k + omega_k x (p - r_k)``.
    """
    m = rows.shape[0]
    p = np.empty((m, 3))
    vel = np.empty((m, 3))
    for i in range(m):
        _point_motion(R, origin, r, omega, v, rows[i], local[i], p[i], vel[i])
    return p, vel


@njit(cache=True, inline="always")
def _point_motion(R, origin, r, omega, v, k, local, p, vel):
    """Position ``R_k local + origin_k`` and velocity ``v_k + omega_k x (p - r_k)`` of a body point, in place."""
    for a in range(3):
        p[a] = R[k, a, 0] * local[0] + R[k, a, 1] * local[1] + R[k, a, 2] * local[2] + origin[k, a]
    lx, ly, lz = p[0] - r[k, 0], p[1] - r[k, 1], p[2] - r[k, 2]
    w = omega[k]
    vel[0] = v[k, 0] + w[1] * lz - w[2] * ly
    vel[1] = v[k, 1] + w[2] * lx - w[0] * lz
    vel[2] = v[k, 2] + w[0] * ly - w[1] * lx


@njit(cache=True, inline="always")
def _gravity_loads(g, group, mass, v, force, powers, track):
    """Uniform gravity ``m_k g`` at the mass centres (into F, eq. 5)."""
    if g[0] != 0.0 or g[1] != 0.0 or g[2] != 0.0:
        for k in range(mass.shape[0]):
            for a in range(3):
                force[k, a] += mass[k] * g[a]
                if track:
                    powers[group[0]] += mass[k] * g[a] * v[k, a]


@njit(cache=True, inline="always")
def _coordinate_springs(cols, stiff, damp, rest, group, x, xd, generalized, powers, track):
    """Coordinate springs and dampers ``-k (q - q0) - c qdot`` (eqs. 21, 25-27)."""
    for i in range(cols.shape[0]):
        c = cols[i]
        q = stiff[i] * (x[c] - rest[i]) + damp[i] * xd[c]
        generalized[c] -= q
        if track:
            powers[group[i]] -= q * xd[c]


@njit(cache=True, inline="always")
def _pair_force(stiff, damp, rest, pts, vel, f2):
    """Force on the second end of a point-to-point spring-damper, into ``f2``."""
    d0, d1, d2 = pts[1, 0] - pts[0, 0], pts[1, 1] - pts[0, 1], pts[1, 2] - pts[0, 2]
    length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    scale = stiff if rest == 0.0 else stiff * (length - rest) / max(length, 1e-300)
    f2[0], f2[1], f2[2] = -scale * d0, -scale * d1, -scale * d2
    if damp != 0.0 and length > 1e-12:
        e0, e1, e2 = d0 / length, d1 / length, d2 / length
        rate = (e0 * (vel[1, 0] - vel[0, 0]) + e1 * (vel[1, 1] - vel[0, 1])
                + e2 * (vel[1, 2] - vel[0, 2]))
        f2[0] -= damp * rate * e0
        f2[1] -= damp * rate * e1
        f2[2] -= damp * rate * e2


@njit(cache=True, inline="always")
def _pair_loads(pairs, local, par, group, R, origin, r, omega, v, force, torque, powers, track):
    """Point-to-point spring-dampers: equal and opposite forces at their two ends (into F, eq. 5)."""
    if pairs.shape[0]:
        pts = np.empty((2, 3))
        vel = np.empty((2, 3))
        f2 = np.empty(3)
        for i in range(pairs.shape[0]):
            for s in range(2):
                _point_motion(R, origin, r, omega, v, pairs[i, s], local[i, s], pts[s], vel[s])
            _pair_force(par[i, 0], par[i, 1], par[i, 2], pts, vel, f2)
            if track:
                powers[group[i]] += (f2[0] * (vel[1, 0] - vel[0, 0]) + f2[1] * (vel[1, 1] - vel[0, 1])
                                                 + f2[2] * (vel[1, 2] - vel[0, 2]))
            for s in range(2):
                k = pairs[i, s]
                sign = -1.0 if s == 0 else 1.0
                lx, ly, lz = pts[s, 0] - r[k, 0], pts[s, 1] - r[k, 1], pts[s, 2] - r[k, 2]
                fx, fy, fz = sign * f2[0], sign * f2[1], sign * f2[2]
                force[k, 0] += fx
                force[k, 1] += fy
                force[k, 2] += fz
                torque[k, 0] += ly * fz - lz * fy
                torque[k, 1] += lz * fx - lx * fz
                torque[k, 2] += lx * fy - ly * fx


@njit(cache=True, inline="always")
def _point_force_loads(rows, local, vec, in_body, group, R, origin, r, omega, v, force, torque, powers, track):
    """Constant point forces, in inertial or body axes (into F, eq. 5)."""
    f = np.empty(3)
    for i in range(rows.shape[0]):
        k = rows[i]
        loc = local[i]
        for a in range(3):
            f[a] = vec[i, a]
        if in_body[i]:
            for a in range(3):
                f[a] = R[k, a, 0] * vec[i, 0] + R[k, a, 1] * vec[i, 1] \
                    + R[k, a, 2] * vec[i, 2]
        lx = R[k, 0, 0] * loc[0] + R[k, 0, 1] * loc[1] + R[k, 0, 2] * loc[2] + origin[k, 0] - r[k, 0]
        ly = R[k, 1, 0] * loc[0] + R[k, 1, 1] * loc[1] + R[k, 1, 2] * loc[2] + origin[k, 1] - r[k, 1]
        lz = R[k, 2, 0] * loc[0] + R[k, 2, 1] * loc[1] + R[k, 2, 2] * loc[2] + origin[k, 2] - r[k, 2]
        force[k, 0] += f[0]
        force[k, 1] += f[1]
        force[k, 2] += f[2]
        torque[k, 0] += ly * f[2] - lz * f[1]
        torque[k, 1] += lz * f[0] - lx * f[2]
        torque[k, 2] += lx * f[1] - ly * f[0]
        if track:  # f . (v_k + omega_k x (p - r_k))
            w = omega[k]
            powers[group[i]] += (f[0] * (v[k, 0] + w[1] * lz - w[2] * ly)
                                              + f[1] * (v[k, 1] + w[2] * lx - w[0] * lz)
                                              + f[2] * (v[k, 2] + w[0] * ly - w[1] * lx))


@njit(cache=True, inline="always")
def _body_torque_loads(rows, vec, in_body, group, R, omega, torque, powers, track):
    """Constant body torques, in inertial or body axes (into F, eq. 5)."""
    f = np.empty(3)
    for i in range(rows.shape[0]):
        k = rows[i]
        for a in range(3):
            f[a] = vec[i, a]
        if in_body[i]:
            for a in range(3):
                f[a] = R[k, a, 0] * vec[i, 0] + R[k, a, 1] * vec[i, 1] \
                    + R[k, a, 2] * vec[i, 2]
        for a in range(3):
            torque[k, a] += f[a]
            if track:
                powers[group[i]] += f[a] * omega[k, a]


@njit(cache=True, inline="always")
def _contact_eval(rows, local, geom, laws, par, R, origin, r, omega, v, centre, ends, q, u, nrm, f):
    """One contact: its penetration and normal force, and in place its point, relative velocity, normal and force.

    ``q`` is the middle of the overlap along the normal ``nrm`` (pointing
    to the sphere, the capsule or the pin of the first row;
    :func:`~flexmb.kernels.contact_geometry.contact_geometry`), ``u`` the
    velocity of the first row's material point at ``q`` less the second's,
    ``f`` the force on the first row at ``q`` (the second takes ``-f``).
    Returns ``(delta, f_n)``; the rate of the penetration is ``-u . nrm``
    exactly (the spheres' spins move their surfaces along the tangent plane
    only, and the closest points of capsules slide along the surfaces; for
    a journal, while the bearing's axis turns about itself only).
    """
    a, b = rows[0], rows[1]
    delta = contact_geometry(laws[0], rows, local, geom, R, origin, centre, ends, nrm)
    lever = geom[0] - 0.5 * delta
    for x in range(3):
        q[x] = centre[0, x] - lever * nrm[x]
    wa, wb = omega[a], omega[b]
    la0, la1, la2 = q[0] - r[a, 0], q[1] - r[a, 1], q[2] - r[a, 2]
    lb0, lb1, lb2 = q[0] - r[b, 0], q[1] - r[b, 1], q[2] - r[b, 2]
    u[0] = v[a, 0] + wa[1] * la2 - wa[2] * la1 - (v[b, 0] + wb[1] * lb2 - wb[2] * lb1)
    u[1] = v[a, 1] + wa[2] * la0 - wa[0] * la2 - (v[b, 1] + wb[2] * lb0 - wb[0] * lb2)
    u[2] = v[a, 2] + wa[0] * la1 - wa[1] * la0 - (v[b, 2] + wb[0] * lb1 - wb[1] * lb0)
    f[0], f[1], f[2] = 0.0, 0.0, 0.0
    if delta <= 0.0:
        return delta, 0.0
    un = u[0] * nrm[0] + u[1] * nrm[1] + u[2] * nrm[2]
    fn = normal_force(laws[1], par[:5], delta, -un)
    t0, t1, t2 = u[0] - un * nrm[0], u[1] - un * nrm[1], u[2] - un * nrm[2]
    k = friction_factor(laws[2], par[5:], fn, t0 * t0 + t1 * t1 + t2 * t2)
    f[0] = fn * nrm[0] - k * t0
    f[1] = fn * nrm[1] - k * t1
    f[2] = fn * nrm[2] - k * t2
    return delta, fn


@njit(cache=True, inline="always")
def _contact_loads(t, R, origin, r, omega, v, force, torque, powers, track):
    """Contacts: equal and opposite forces at their points (into F, eq. 5); power ``f . u``.

    Every row, or, with blocks of a group against a group, the rows
    evaluated always and those the broad phase finds
    (:mod:`flexmb.kernels.broadphase`), in increasing row order, so that the
    loads are summed as if every row were evaluated (a row whose shapes'
    boxes are apart exerts nothing).
    """
    rows, local, geom, laws, par, group = (t.contact_rows, t.contact_local, t.contact_geom, t.contact_laws,
                                           t.contact_par, t.contact_group)
    if not rows.shape[0]:
        return
    centre = np.empty((2, 3))
    ends = np.empty((2, 3))
    q = np.empty(3)
    u = np.empty(3)
    nrm = np.empty(3)
    f = np.empty(3)
    blocked = t.contact_blocks.shape[0] > 0
    always = t.contact_always
    found = (block_candidates(t.contact_blocks, t.sweep_rows, t.sweep_local, t.sweep_radius, t.contact_block_map, R,
                              origin) if blocked else always[:0])
    a, b = 0, 0
    for step in range(always.shape[0] + found.shape[0] if blocked else rows.shape[0]):
        if not blocked:
            i = step
        elif b >= found.shape[0] or (a < always.shape[0] and always[a] < found[b]):
            i = always[a]
            a += 1
        else:
            i = found[b]
            b += 1
        delta, _ = _contact_eval(rows[i], local[i], geom[i], laws[i], par[i], R, origin, r, omega, v, centre, ends, q,
                                 u, nrm, f)
        if delta <= 0.0:
            continue
        if track:
            powers[group[i]] += f[0] * u[0] + f[1] * u[1] + f[2] * u[2]
        for s in range(2):
            k = rows[i, s]
            sign = 1.0 if s == 0 else -1.0
            lx, ly, lz = q[0] - r[k, 0], q[1] - r[k, 1], q[2] - r[k, 2]
            fx, fy, fz = sign * f[0], sign * f[1], sign * f[2]
            force[k, 0] += fx
            force[k, 1] += fy
            force[k, 2] += fz
            torque[k, 0] += ly * fz - lz * fy
            torque[k, 1] += lz * fx - lx * fz
            torque[k, 2] += lx * fy - ly * fx


@njit(cache=True)
def contact_states(rows, local, geom, laws, par, R, origin, r, omega, v):
    """What each contact does at a state: penetration, forces, point, normal and slip.

    Parameters
    ----------
    rows, local, geom, laws, par : ndarray
        The ``contact_*`` fields of :class:`LoadTables`.
    R, origin, r, omega, v : ndarray, shape (n_bodies + 1, ...)
        Rotations, body-frame origins, mass centres, angular velocities and
        mass-centre velocities (the ground last).

    Returns
    -------
    delta : ndarray, shape (c,)
        Penetration, m (negative: the gap).
    rate : ndarray, shape (c,)
        Its rate, m/s (positive approaching).
    normal_force : ndarray, shape (c,)
        N (0 when separated).
    energy : ndarray, shape (c,)
        Elastic energy of the penetration, J.
    point : ndarray, shape (c, 3)
        Contact point (the middle of the overlap), inertial, m.
    normal : ndarray, shape (c, 3)
        Unit normal, towards the first side.
    force : ndarray, shape (c, 3)
        Force on the first side, inertial, N (the second takes its opposite).
    slip : ndarray, shape (c, 3)
        Tangential velocity of the first side's point relative to the
        second's at the contact point, m/s.
    """
    c = rows.shape[0]
    delta = np.zeros(c)
    rate = np.zeros(c)
    fn = np.zeros(c)
    energy = np.zeros(c)
    point = np.zeros((c, 3))
    normal = np.zeros((c, 3))
    force = np.zeros((c, 3))
    slip = np.zeros((c, 3))
    centre = np.empty((2, 3))
    ends = np.empty((2, 3))
    u = np.empty(3)
    for i in range(c):
        delta[i], fn[i] = _contact_eval(rows[i], local[i], geom[i], laws[i], par[i], R, origin, r, omega, v, centre,
                                        ends, point[i], u, normal[i], force[i])
        un = u[0] * normal[i, 0] + u[1] * normal[i, 1] + u[2] * normal[i, 2]
        rate[i] = -un
        for x in range(3):
            slip[i, x] = u[x] - un * normal[i, x]
        energy[i] = elastic_energy(laws[i, 1], par[i], delta[i])
    return delta, rate, fn, energy, point, normal, force, slip


@njit(cache=True)
def apply_load_tables(tables, mass, R, origin, r, omega, v, x, xd, force, torque, generalized, powers):
    """Add the loads of the compiled built-in force elements (:class:`flexmb.forces.tables.LoadTables`).

    Uniform gravity ``m_k g`` at the mass centres; coordinate springs and
    dampers ``-k (q - q0) - c qdot`` (joint springs, the segment joints of
    flexible bodies, eqs. 21, 25-27); point-to-point spring-dampers;
    constant point forces and body torques, in inertial or body axes; and
    contacts (:mod:`flexmb.kernels.contact`). All
    enter the generalized active force F of eq. 5 through ``force``,
    ``torque`` and ``generalized``.

    Parameters
    ----------
    tables : LoadTables
        The elements' data, flat.
    mass : ndarray, shape (n_bodies,)
        Masses.
    R, origin, r, omega, v : ndarray, shape (n_bodies + 1, ...)
        Rotations, body-frame origins, mass centres, angular velocities and
        mass-centre velocities (the ground last).
    x, xd : ndarray, shape (n,)
        Coordinates and speeds.
    force, torque : ndarray, shape (n_bodies + 1, 3)
        Accumulators at the mass centres, updated in place.
    generalized : ndarray, shape (n,)
        Accumulator of generalized forces, updated in place.
    powers : ndarray, shape (n_groups,) or (0,)
        If not empty, each row's power (its loads' ``F . xd``, eq. 5) is
        added to the entry of its group.
    """
    track = powers.shape[0] > 0
    _gravity_loads(tables.gravity, tables.gravity_group, mass, v, force, powers, track)
    _coordinate_springs(tables.coord_cols, tables.coord_k, tables.coord_c, tables.coord_rest, tables.coord_group, x, xd,
                        generalized, powers, track)
    _pair_loads(tables.pair_rows, tables.pair_local, tables.pair_par, tables.pair_group, R, origin, r, omega, v, force,
                torque, powers, track)
    _point_force_loads(tables.force_rows, tables.force_local, tables.force_vec, tables.force_in_body,
                       tables.force_group, R, origin, r, omega, v, force, torque, powers, track)
    _body_torque_loads(tables.torque_rows, tables.torque_vec, tables.torque_in_body, tables.torque_group, R, omega,
                       torque, powers, track)
    _contact_loads(tables, R, origin, r, omega, v, force, torque, powers, track)
