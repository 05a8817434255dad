"""Contact geometry: the penetration and the common normal of two surfaces on two bodies.

Each contact row of the load tables (:class:`flexmb.kernels.loads.LoadTables`)
names two body rows ``a``, ``b`` and four points (``contact_local``, shape
(4, 3)) in those rows' frames; its geometry code (``contact_laws[:, 0]``,
the codes of :mod:`flexmb.kernels.contact`) says what they are:

* ``SPHERE_PLANE``: the sphere's centre (row a), a point of the plane and
  its unit normal (row b);
* ``SPHERE_SPHERE``: the two centres;
* ``JOURNAL``: the pin's centre (row a), the bearing's centre and axis (row b);
* ``CAPSULE_SPHERE``: the capsule's first end (row a), the sphere's
  centre (row b), unused, the capsule's second end (row a);
* ``CAPSULE_CAPSULE``: the first capsule's first end (row a), the second
  capsule's two ends (row b), the first capsule's second end (row a).

A capsule (a segment with a radius: a rod, a segment of a flexible body)
against a sphere or a capsule is a sphere against a sphere at the closest
points of its axis and the other's centre or axis; a capsule against a
plane is laid out as two ``SPHERE_PLANE`` rows, one at each end (the
closest points of a segment to a plane are an end, or the whole segment
when parallel). The capsules' rows first compare bounding spheres (the
segment's middle, half its length plus the radius): while they are apart
the row reports their gap, a lower bound of the true one, and skips the
closest points.
"""

from __future__ import annotations

import numpy as np

from .cache import njit
from .contact import CAPSULE_CAPSULE, CAPSULE_SPHERE, JOURNAL, SPHERE_PLANE

__all__ = ["contact_geometry", "segment_point_closest", "segments_closest"]

#: below this ``sin^2`` of the angle between two segments they are taken as parallel (``a e - b^2`` is then
#: within some ten roundings of 0); the middle of the overlap is then at most ``1e-7`` of the overlap's length
#: farther than the closest points
PARALLEL = 1e-14


@njit(cache=True, inline="always")
def _clamp01(x):
    return min(max(x, 0.0), 1.0)


@njit(cache=True)
def segment_point_closest(p, d, q):
    """Parameter s in [0, 1] of the point ``p + s d`` of a segment closest to a point q.

    Parameters
    ----------
    p, d : ndarray, shape (3,)
        The segment's first end and its vector (second end less first).
    q : ndarray, shape (3,)
        The point.

    Returns
    -------
    float
        s (0 for a segment of length 0).
    """
    a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    if a <= 0.0:
        return 0.0
    return _clamp01(((q[0] - p[0]) * d[0] + (q[1] - p[1]) * d[1] + (q[2] - p[2]) * d[2]) / a)


@njit(cache=True)
def segments_closest(p1, d1, p2, d2):
    """Parameters (s, t) of the closest points ``p1 + s d1`` and ``p2 + t d2`` of two segments.

    Ericson's clamped solution (Real-Time Collision Detection, 2005, 5.1.9);
    segments parallel to ``sin^2 < PARALLEL`` (where the closest points are
    not unique) take the middle of the overlap of their projections on the
    first, or the nearer ends if they do not overlap.

    Parameters
    ----------
    p1, d1 : ndarray, shape (3,)
        First segment: its first end and its vector.
    p2, d2 : ndarray, shape (3,)
        Second segment.

    Returns
    -------
    s, t : float
        In [0, 1].
    """
    r0, r1, r2 = p1[0] - p2[0], p1[1] - p2[1], p1[2] - p2[2]
    a = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]
    e = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2]
    f = d2[0] * r0 + d2[1] * r1 + d2[2] * r2
    if a <= 0.0 and e <= 0.0:
        return 0.0, 0.0
    if a <= 0.0:
        return 0.0, _clamp01(f / e)
    c = d1[0] * r0 + d1[1] * r1 + d1[2] * r2
    if e <= 0.0:
        return _clamp01(-c / a), 0.0
    b = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]
    denom = a * e - b * b
    if denom > PARALLEL * a * e:
        s = _clamp01((b * f - c * e) / denom)
    else:  # parallel: the middle of the overlap of the second's projection on the first
        s0, s1 = -c / a, (b - c) / a
        lo, hi = max(min(s0, s1), 0.0), min(max(s0, s1), 1.0)
        s = 0.5 * (lo + hi) if lo <= hi else (0.0 if max(s0, s1) < 0.0 else 1.0)
    t = (b * s + f) / e
    if t < 0.0:
        return _clamp01(-c / a), 0.0
    if t > 1.0:
        return _clamp01((b - c) / a), 1.0
    return s, t


@njit(cache=True, inline="always")
def _world(R, origin, k, local, out):
    """``R_k local + origin_k`` into ``out``."""
    for x in range(3):
        out[x] = R[k, x, 0] * local[0] + R[k, x, 1] * local[1] + R[k, x, 2] * local[2] + origin[k, x]


@njit(cache=True, inline="always")
def _axis(R, k, local, out):
    """``R_k local`` into ``out``."""
    for x in range(3):
        out[x] = R[k, x, 0] * local[0] + R[k, x, 1] * local[1] + R[k, x, 2] * local[2]


@njit(cache=True, inline="always")
def _sphere_normal(centre, nrm):
    """``|c0 - c1|`` and the unit normal ``(c0 - c1) / |c0 - c1|`` (z when they coincide)."""
    d0, d1, d2 = centre[0, 0] - centre[1, 0], centre[0, 1] - centre[1, 1], centre[0, 2] - centre[1, 2]
    dist = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if dist > 0.0:
        nrm[0], nrm[1], nrm[2] = d0 / dist, d1 / dist, d2 / dist
    else:  # concentric: any direction
        nrm[0], nrm[1], nrm[2] = 0.0, 0.0, 1.0
    return dist


@njit(cache=True, inline="always")
def _journal(centre, nrm, clearance):
    """A pin in a bearing: the penetration, the normal back to the bearing's centre (``nrm`` holds the axis)."""
    dk = 0.0
    for x in range(3):
        dk += (centre[0, x] - centre[1, x]) * nrm[x]
    d0 = centre[0, 0] - centre[1, 0] - dk * nrm[0]
    d1 = centre[0, 1] - centre[1, 1] - dk * nrm[1]
    d2 = centre[0, 2] - centre[1, 2] - dk * nrm[2]
    dist = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if dist > 0.0:
        nrm[0], nrm[1], nrm[2] = -d0 / dist, -d1 / dist, -d2 / dist
    else:  # centred: no contact unless the clearance is 0; any direction across the axis
        a0, a1, a2 = nrm[0], nrm[1], nrm[2]
        if abs(a0) < 0.9:
            nrm[0], nrm[1], nrm[2] = 0.0, a2, -a1
        else:
            nrm[0], nrm[1], nrm[2] = -a2, 0.0, a0
        s = np.sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2])
        nrm[0], nrm[1], nrm[2] = nrm[0] / s, nrm[1] / s, nrm[2] / s
    return dist - clearance


@njit(cache=True, inline="always")
def _capsule(kind, rows, local, geom, R, origin, centre, ends, nrm):
    """A capsule against a sphere or a capsule: its closest points into ``centre``; the penetration.

    ``centre`` holds the first ends (row a) and the sphere's centre or the
    second capsule's first end (row b) on entry; ``ends`` is scratch (2, 3).
    """
    a, b = rows[0], rows[1]
    _world(R, origin, a, local[3], ends[0])
    for x in range(3):
        ends[0, x] -= centre[0, x]  # the first capsule's vector
    half_b = 0.0
    if kind == CAPSULE_CAPSULE:
        _world(R, origin, b, local[2], ends[1])
        for x in range(3):
            ends[1, x] -= centre[1, x]
            half_b += ends[1, x] * ends[1, x]
        half_b = 0.5 * np.sqrt(half_b)
    else:
        ends[1, 0], ends[1, 1], ends[1, 2] = 0.0, 0.0, 0.0
    half_a = 0.5 * np.sqrt(ends[0, 0] ** 2 + ends[0, 1] ** 2 + ends[0, 2] ** 2)
    gap2 = 0.0
    for x in range(3):
        gap2 += (centre[0, x] + 0.5 * ends[0, x] - centre[1, x] - 0.5 * ends[1, x]) ** 2
    bound = geom[0] + geom[1] + half_a + half_b
    if gap2 > bound * bound:  # the bounding spheres are apart: their gap, and their centres
        for x in range(3):
            centre[0, x] += 0.5 * ends[0, x]
            centre[1, x] += 0.5 * ends[1, x]
        return bound - _sphere_normal(centre, nrm)
    if kind == CAPSULE_CAPSULE:
        s, t = segments_closest(centre[0], ends[0], centre[1], ends[1])
    else:
        s, t = segment_point_closest(centre[0], ends[0], centre[1]), 0.0
    for x in range(3):
        centre[0, x] += s * ends[0, x]
        centre[1, x] += t * ends[1, x]
    return geom[0] + geom[1] - _sphere_normal(centre, nrm)


@njit(cache=True, inline="always")
def contact_geometry(kind, rows, local, geom, R, origin, centre, ends, nrm):
    """One row's penetration; in place its two centres and its unit normal.

    Parameters
    ----------
    kind : int
        The geometry's code.
    rows : ndarray of int, shape (2,)
        The body rows a, b.
    local : ndarray, shape (4, 3)
        The row's points (module docstring).
    geom : ndarray, shape (2,)
        The radii (the bearing's hole's second for a journal), m.
    R, origin : ndarray, shape (n_bodies + 1, ...)
        Rotations and body-frame origins.
    centre : ndarray, shape (2, 3)
        Out: the centres of the two touching spheres (a plane's: the
        plane's point; a capsule's: its closest point; a journal's: the
        pin's and the bearing's centres).
    ends : ndarray, shape (2, 3)
        Scratch.
    nrm : ndarray, shape (3,)
        Out: the unit normal, towards the side of row a.

    Returns
    -------
    float
        The penetration delta, m (negative: the gap).
    """
    a, b = rows[0], rows[1]
    _world(R, origin, a, local[0], centre[0])
    _world(R, origin, b, local[1], centre[1])
    if kind == SPHERE_PLANE:
        _axis(R, b, local[2], nrm)
        dist = 0.0
        for x in range(3):
            dist += (centre[0, x] - centre[1, x]) * nrm[x]
        return geom[0] - dist
    if kind == JOURNAL:
        _axis(R, b, local[2], nrm)
        return _journal(centre, nrm, geom[1] - geom[0])
    if kind == CAPSULE_SPHERE or kind == CAPSULE_CAPSULE:
        return _capsule(kind, rows, local, geom, R, origin, centre, ends, nrm)
    return geom[0] + geom[1] - _sphere_normal(centre, nrm)
