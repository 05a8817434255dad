"""The planar articulated-body recursion: 3-vectors and 3 x 3 inertias for models that move in one plane.

A model whose joints all move in one plane (revolute coordinates about one
inertial normal n, prismatic ones normal to it, at most one coordinate per
body) has motion vectors ``(w, vx, vy)`` and force vectors ``(tau, fx,
fy)``, Plucker about the inertial origin as the spatial kernels use them,
in an in-plane basis ``(e1, e2)``, ``e1 x e2 = n`` (docs/theory.md, "A
planar path"). A body's vectors fixed in it are stored at the zero
configuration and turned at a state by the body's angle only (``theta_k =
theta_parent + s q`` for a revolute coordinate, ``s = +-1``).

The model's planar data (:func:`flexmb.planar_data.planar_data`, packed
with the model: :func:`flexmb.kernels.packing.unpack_planar`) are two
tuples. ``ints``: parent (ground: n_bodies), coord (-1: none), kind
(:data:`REVOLUTE`, :data:`PRISMATIC`, :data:`NONE`), coord_cols (the
coordinate springs' coordinates), ri, rj (the direction rows' bodies,
ground: n_bodies), drivers (the driver rows' coordinates). ``floats``:
axis (n_bodies, 2: the sign s, or the slide direction in the parent at
zero), lever (n_bodies, 2: the joint point from the parent's, in the
parent at zero), u (n_bodies, 2: the mass centre from the joint point, in
the body at zero), mass, J (the central inertia about n), g (2: gravity
in the plane), coord_k, coord_c, coord_rest (the coordinate springs and
dampers), wi, wj (n_rows, 2: the rows' points from their bodies' joint
points, at zero), d0 (n_rows, 2: the rows' directions, fixed in body i, at
zero).

The kinematics array ``K`` (n_bodies + 1, 20), ground last, holds per
body: 0 theta, 1-2 cos / sin, 3-4 joint point, 5-6 mass centre, 7-9
spatial velocity ``(w, vOx, vOy)``, 10-12 the joint's axis S, 13-15 its
bias acceleration c, 16-18 the spatial bias acceleration (the sum of c
along the path), 19 unused.
"""

from __future__ import annotations

import numpy as np

from numba.extending import register_jitable

from .cache import njit
from .packing import unpack_planar
from .views import view2

__all__ = ["REVOLUTE", "PRISMATIC", "NONE", "kinematics", "loads", "inertias", "factor", "backward", "forward",
           "planar_work_size", "planar_open_rhs_into"]

#: kind of a body's joint: one revolute coordinate about n
REVOLUTE = 0
#: kind of a body's joint: one prismatic coordinate normal to n
PRISMATIC = 1
#: kind of a body's joint: no coordinate (welded to its parent)
NONE = 2


@njit(cache=True, inline="always")
def _rot(c, s, v0, v1):
    """The in-plane vector ``(v0, v1)`` turned by the angle of cosine c and sine s."""
    return c * v0 - s * v1, s * v0 + c * v1


@njit(cache=True)
def kinematics(ints, floats, x, xd, K):
    """Angles, joint points, mass centres, velocities, joint axes S and bias accelerations, ground last.

    Parameters
    ----------
    ints, floats : tuple of ndarray
        The planar model (module docstring).
    x, xd : ndarray, shape (>= n,)
        Coordinates and speeds.
    K : ndarray, shape (n_bodies + 1, 20)
        Output: the kinematics (module docstring).
    """
    parent, coord, kind = ints[0], ints[1], ints[2]
    axis, lever, u = floats[0], floats[1], floats[2]
    nb = parent.shape[0]
    K[nb, :] = 0.0
    K[nb, 1] = 1.0
    for k in range(nb):
        p = parent[k]
        cp, sp = K[p, 1], K[p, 2]
        c = coord[k]
        q, qd = (x[c], xd[c]) if c >= 0 else (0.0, 0.0)
        lx, ly = lever[k, 0], lever[k, 1]
        if kind[k] == PRISMATIC:
            lx += axis[k, 0] * q
            ly += axis[k, 1] * q
        sx, sy = _rot(cp, sp, lx, ly)
        jx, jy = K[p, 3] + sx, K[p, 4] + sy
        th = K[p, 0] + (axis[k, 0] * q if kind[k] == REVOLUTE else 0.0)
        ct, st = (np.cos(th), np.sin(th)) if kind[k] == REVOLUTE else (cp, sp)
        ux, uy = _rot(ct, st, u[k, 0], u[k, 1])
        K[k, 0], K[k, 1], K[k, 2], K[k, 3], K[k, 4], K[k, 5], K[k, 6] = th, ct, st, jx, jy, jx + ux, jy + uy
        if kind[k] == REVOLUTE:
            s = axis[k, 0]
            S0, S1, S2 = s, s * jy, -s * jx
        elif kind[k] == PRISMATIC:
            S0, (S1, S2) = 0.0, _rot(cp, sp, axis[k, 0], axis[k, 1])
        else:
            S0 = S1 = S2 = 0.0
        w, vx, vy = K[p, 7], K[p, 8], K[p, 9]
        m0, m1, m2 = S0 * qd, S1 * qd, S2 * qd
        K[k, 7], K[k, 8], K[k, 9] = w + m0, vx + m1, vy + m2
        K[k, 10], K[k, 11], K[k, 12] = S0, S1, S2
        # c = v_parent x (S qd): the motion cross product in the plane
        c0, c1, c2 = 0.0, -w * m2 + vy * m0, w * m1 - vx * m0
        K[k, 13], K[k, 14], K[k, 15] = c0, c1, c2
        K[k, 16], K[k, 17], K[k, 18] = K[p, 16] + c0, K[p, 17] + c1, K[p, 18] + c2


@njit(cache=True)
def loads(ints, floats, x, xd, K, pA, tau):
    """Bias forces minus applied loads ``pA = v x* (I v) - f`` per body (ground last), joint forces ``tau``.

    Gravity ``m g`` at the mass centres; coordinate springs and dampers
    ``tau_c = -k (x - rest) - c xd``.

    Parameters
    ----------
    ints, floats : tuple of ndarray
        The planar model.
    x, xd : ndarray, shape (>= n,)
        Coordinates and speeds.
    K : ndarray, shape (n_bodies + 1, 20)
        The kinematics (:func:`kinematics`).
    pA : ndarray, shape (n_bodies + 1, 3)
        Output: the bodies' bias wrenches (the ground's zero).
    tau : ndarray, shape (n,)
        Output: the generalized forces on the coordinates.
    """
    mass, g = floats[3], floats[5]
    nb = mass.shape[0]
    for k in range(nb + 1):
        pA[k, 0] = pA[k, 1] = pA[k, 2] = 0.0
    for k in range(nb):
        m = mass[k]
        rx, ry = K[k, 5], K[k, 6]
        w, vx, vy = K[k, 7], K[k, 8], K[k, 9]
        # v x* (I v): the linear momentum h (the moment's own term w x h0 is zero in the plane)
        hx, hy = m * (vx - w * ry), m * (vy + w * rx)
        pA[k, 0] = vx * hy - vy * hx - m * (rx * g[1] - ry * g[0])
        pA[k, 1] = -w * hy - m * g[0]
        pA[k, 2] = w * hx - m * g[1]
    tau[:] = 0.0
    cols, kk, cc, rest = ints[3], floats[6], floats[7], floats[8]
    for i in range(cols.shape[0]):
        c = cols[i]
        tau[c] -= kk[i] * (x[c] - rest[i]) + cc[i] * xd[c]


@njit(cache=True)
def inertias(floats, K, IA):
    """Each body's inertia about the origin: 6 entries (00, 01, 02, 11, 12, 22) of the symmetric 3 x 3.

    Parameters
    ----------
    floats : tuple of ndarray
        The planar model's floats.
    K : ndarray, shape (n_bodies + 1, 20)
        The kinematics (:func:`kinematics`).
    IA : ndarray, shape (>= n_bodies, 6)
        Output, rows 0 ... n_bodies - 1.
    """
    mass, J = floats[3], floats[4]
    for k in range(mass.shape[0]):
        m, rx, ry = mass[k], K[k, 5], K[k, 6]
        IA[k, 0], IA[k, 1], IA[k, 2] = J[k] + m * (rx * rx + ry * ry), -m * ry, m * rx
        IA[k, 3], IA[k, 4], IA[k, 5] = m, 0.0, m


@njit(cache=True, inline="always")
def _sym_times(I, k, a0, a1, a2):
    """Row k of the packed symmetric 3 x 3 matrices ``I`` times ``(a0, a1, a2)``."""
    return (I[k, 0] * a0 + I[k, 1] * a1 + I[k, 2] * a2, I[k, 1] * a0 + I[k, 3] * a1 + I[k, 4] * a2,
            I[k, 2] * a0 + I[k, 4] * a1 + I[k, 5] * a2)


@njit(cache=True)
def factor(ints, K, IA, UD, armature, floor=0.0, lift=0.0):
    """The articulated inertias, from the leaves in: ``UD[k] = (U = IA S, 1 / D)``, ``IA_P += IA - U U^T / D``.

    ``D = S^T I^A S + armature[c]`` on body k's coordinate c, as
    :func:`flexmb.kernels.articulated.articulated_factor_into`.

    Parameters
    ----------
    ints : tuple of ndarray
        The planar model's integers.
    K : ndarray, shape (n_bodies + 1, 20)
        The kinematics (:func:`kinematics`).
    IA : ndarray, shape (>= n_bodies, 6)
        The bodies' inertias (:func:`inertias`) on entry, their articulated
        inertias on return.
    UD : ndarray, shape (>= n_bodies, 4)
        Output: per body ``(U, 1 / D)`` (zeros for a joint without a
        coordinate).
    armature : ndarray, shape (n,)
        Diagonal added to A (zeros for the equations of motion).
    floor : float
        A pivot D at or below ``floor`` times the largest diagonal entry of
        the body's (planar) articulated inertia counts as zero (default 0:
        only a pivot <= 0 does).
    lift : float
        If > 0, such a joint is not reported: ``lift`` times that entry is
        added to its coordinate's ``armature`` (in place) and to D.

    Returns
    -------
    int
        -1, or the body whose joint has a singular articulated inertia
        (the factors are then not valid).
    """
    parent, coord = ints[0], ints[1]
    nb = parent.shape[0]
    for k in range(nb - 1, -1, -1):
        S0, S1, S2 = K[k, 10], K[k, 11], K[k, 12]
        U0, U1, U2 = _sym_times(IA, k, S0, S1, S2)
        c = coord[k]
        Di = 0.0
        if c >= 0:
            D = S0 * U0 + S1 * U1 + S2 * U2 + armature[c]
            tiny = floor * max(abs(IA[k, 0]), abs(IA[k, 3]), abs(IA[k, 5])) if floor > 0.0 else 0.0
            if not D > tiny and lift > 0.0:
                armature[c] += lift * tiny / floor
                D += lift * tiny / floor
            if not D > tiny:
                return k
            Di = 1.0 / D
        UD[k, 0], UD[k, 1], UD[k, 2], UD[k, 3] = U0, U1, U2, Di
        p = parent[k]
        if p == nb:
            continue
        IA[p, 0] += IA[k, 0] - U0 * U0 * Di
        IA[p, 1] += IA[k, 1] - U0 * U1 * Di
        IA[p, 2] += IA[k, 2] - U0 * U2 * Di
        IA[p, 3] += IA[k, 3] - U1 * U1 * Di
        IA[p, 4] += IA[k, 4] - U1 * U2 * Di
        IA[p, 5] += IA[k, 5] - U2 * U2 * Di
    return -1


@njit(cache=True)
def backward(ints, K, IA, UD, pA, tau, uu, bias):
    """From the leaves in: ``u = tau - S . pA``, ``pA_P += pA + Ia c + U u / D``.

    Parameters
    ----------
    ints : tuple of ndarray
        The planar model's integers.
    K : ndarray, shape (n_bodies + 1, 20)
        The kinematics.
    IA, UD : ndarray
        The factors (:func:`factor`).
    pA : ndarray, shape (n_bodies + 1, 3)
        The bodies' bias wrenches (:func:`loads`); overwritten (the
        subtrees' biases).
    tau : ndarray, shape (n,)
        Generalized forces on the coordinates.
    uu : ndarray, shape (>= n_bodies,)
        Output: each joint's ``u``.
    bias : bool
        Whether the joints' bias accelerations c enter (the ``Ia c``
        term): True for the equations of motion, False for a response to
        loads alone.
    """
    parent, coord = ints[0], ints[1]
    nb = parent.shape[0]
    for k in range(nb - 1, -1, -1):
        S0, S1, S2 = K[k, 10], K[k, 11], K[k, 12]
        U0, U1, U2, Di = UD[k, 0], UD[k, 1], UD[k, 2], UD[k, 3]
        c = coord[k]
        u = (tau[c] if c >= 0 else 0.0) - (S0 * pA[k, 0] + S1 * pA[k, 1] + S2 * pA[k, 2])
        uu[k] = u
        p = parent[k]
        if p == nb:
            continue
        f = u * Di
        p0, p1, p2 = pA[k, 0] + U0 * f, pA[k, 1] + U1 * f, pA[k, 2] + U2 * f
        if bias:
            c0, c1, c2 = K[k, 13], K[k, 14], K[k, 15]
            a0, a1, a2 = _sym_times(IA, k, c0, c1, c2)
            g = (U0 * c0 + U1 * c1 + U2 * c2) * Di
            p0 += a0 - U0 * g
            p1 += a1 - U1 * g
            p2 += a2 - U2 * g
        pA[p, 0] += p0
        pA[p, 1] += p1
        pA[p, 2] += p2


@njit(cache=True)
def forward(ints, K, UD, uu, bias, acc, xdd):
    """From the ground out: ``a = a_P (+ c)``, ``xdd = (u - U . a) / D``, ``a += S xdd``.

    Parameters
    ----------
    ints : tuple of ndarray
        The planar model's integers.
    K : ndarray, shape (n_bodies + 1, 20)
        The kinematics.
    UD : ndarray
        The factors (:func:`factor`).
    uu : ndarray, shape (>= n_bodies,)
        The joints' ``u`` (:func:`backward`).
    bias : bool
        As :func:`backward`.
    acc : ndarray, shape (n_bodies + 1, 3)
        Output: the bodies' spatial accelerations (ground last, zero).
    xdd : ndarray, shape (n,)
        Output: the accelerations of the coordinates.
    """
    parent, coord = ints[0], ints[1]
    nb = parent.shape[0]
    acc[nb, 0] = acc[nb, 1] = acc[nb, 2] = 0.0
    for k in range(nb):
        p = parent[k]
        a0, a1, a2 = acc[p, 0], acc[p, 1], acc[p, 2]
        if bias:
            a0 += K[k, 13]
            a1 += K[k, 14]
            a2 += K[k, 15]
        c = coord[k]
        q = (uu[k] - (UD[k, 0] * a0 + UD[k, 1] * a1 + UD[k, 2] * a2)) * UD[k, 3]
        if c >= 0:
            xdd[c] = q
        acc[k, 0], acc[k, 1], acc[k, 2] = a0 + K[k, 10] * q, a1 + K[k, 11] * q, a2 + K[k, 12] * q


@register_jitable
def planar_work_size(nb, n):
    """Length of the work array :func:`planar_open_rhs_into` needs.

    Parameters
    ----------
    nb, n : int
        Numbers of bodies and of coordinates.

    Returns
    -------
    int
        The length (at most :func:`flexmb.kernels.articulated.rhs_work_size`).
    """
    return 37 * (nb + 1) + 2 * n


@njit(cache=True)
def planar_open_rhs_into(packed, y, nq, armature, ydot, work):
    """The state rate of a planar open tree (what :func:`~flexmb.kernels.articulated.open_tree_rhs_into` calls).

    Parameters
    ----------
    packed : tuple
        The model's packed buffers, with its planar data
        (:func:`flexmb.kernels.packing.unpack_planar`).
    y : ndarray, shape (>= nq + n,)
        The state ``(x, xd, ...)``.
    nq : int
        Number of coordinates (n: planar models have no Euler parameters).
    armature : ndarray, shape (n,)
        Diagonal added to A (zeros for the equations of motion).
    ydot : ndarray, shape (>= nq + n,)
        Output: ``(xd, xdd)``.
    work : ndarray, shape (>= planar_work_size(n_bodies, n),)
        Scratch.

    Returns
    -------
    int
        -1 if ``ydot`` is finite, -2 if not, or the body whose joint has a
        singular articulated inertia (``xdd`` is then zero).
    """
    ints, floats = unpack_planar(packed)
    n, nb = armature.shape[0], ints[0].shape[0]
    x, xd = y[:nq], y[nq : nq + n]
    nb1 = nb + 1
    K, pA = view2(work, 0, nb1, 20), view2(work, 20 * nb1, nb1, 3)
    IA, UD = view2(work, 23 * nb1, nb1, 6), view2(work, 29 * nb1, nb1, 4)
    acc, uu = view2(work, 33 * nb1, nb1, 3), work[36 * nb1 : 37 * nb1]
    tau, xdd = work[37 * nb1 : 37 * nb1 + n], work[37 * nb1 + n : 37 * nb1 + 2 * n]
    kinematics(ints, floats, x, xd, K)
    loads(ints, floats, x, xd, K, pA, tau)
    inertias(floats, K, IA)
    status = factor(ints, K, IA, UD, armature, 0.0, 0.0)
    xdd[:] = 0.0
    if status < 0:
        backward(ints, K, IA, UD, pA, tau, uu, True)
        forward(ints, K, UD, uu, True, acc, xdd)
    for i in range(n):
        ydot[i] = xd[i]
        ydot[nq + i] = xdd[i]
        if status == -1 and not (np.isfinite(xdd[i]) and np.isfinite(xd[i])):
            status = -2
    return status
