"""Kinematics of the tree, one pass from the ground out (eqs. 6-18).

Notation (per tree joint j joining body k to its parent P), as in
:mod:`flexmb.kinematics`:

* ``R_M = R_P F_p``: the parent marker frame in inertial axes;
* ``o'_k``: the joint point on the child side (inertial);
* ``s_k = o'_k - o'_P``: vector from the parent's joint point to this one.

A coordinate c of joint j has the inertial partial angular velocity
``G_w = R_M h_w`` and partial velocity ``G_v = R_M h_v`` at the joint
point; in Plucker form about the inertial origin its motion is
``S_c = (G_w, G_v - G_w x o'_j)``, and any point p of a body downstream of
the joint moves with ``S_v + S_w x p`` (eqs. 7, 17).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba.extending import register_jitable

from .cache import njit
from .views import view2, view3

__all__ = ["TreeArrays", "joint_motions", "euler_parameter_rates", "tree_kinematics", "tree_kinematics_into",
           "kinematics_work_size", "tree_state", "upstream_rows"]


class TreeArrays(NamedTuple):
    """The tree's flat layout and constant body data, as the compiled kernels take it.

    Built once by :class:`flexmb.topology.Topology` (``Topology.arrays``);
    each parameter is kept as the field of the same name.

    Parameters
    ----------
    parent, coord_start, coord_kind, coord_axis, external : ndarray of int or bool
        The layout (see :func:`tree_kinematics`).
    parent_frame, child_frame, lever, child_point, com : ndarray
        The joints' frames and points and the mass centres (see
        :func:`tree_kinematics`).
    mass : ndarray, shape (n_bodies,)
        Masses, kg.
    inertia : ndarray, shape (n_bodies, 3, 3)
        Central inertias in the body frames, kg m^2.
    coord_body : ndarray of int, shape (n,)
        Body whose tree joint owns each coordinate.
    """

    parent: np.ndarray
    coord_start: np.ndarray
    coord_kind: np.ndarray
    coord_axis: np.ndarray
    external: np.ndarray
    parent_frame: np.ndarray
    child_frame: np.ndarray
    lever: np.ndarray
    child_point: np.ndarray
    com: np.ndarray
    mass: np.ndarray
    inertia: np.ndarray
    coord_body: np.ndarray

_TRANSLATION, _QUATERNION = 0, 3


@njit(cache=True, inline="always")
def _cross(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@njit(cache=True, inline="always")
def _mv(M, v):
    return np.array([M[0, 0] * v[0] + M[0, 1] * v[1] + M[0, 2] * v[2],
                     M[1, 0] * v[0] + M[1, 1] * v[1] + M[1, 2] * v[2],
                     M[2, 0] * v[0] + M[2, 1] * v[1] + M[2, 2] * v[2]])


# In-place helpers (no allocation in the loops over bodies): out may not alias the inputs.

@njit(cache=True, inline="always")
def _cross_to(out, a, b):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@njit(cache=True, inline="always")
def _mv_to(out, M, v):
    for i in range(3):
        out[i] = M[i, 0] * v[0] + M[i, 1] * v[1] + M[i, 2] * v[2]


@njit(cache=True, inline="always")
def _mm_to(out, A, B):
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@njit(cache=True, inline="always")
def _mmt_to(out, A, B):
    """``out = A @ B.T``."""
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[j, 0] + A[i, 1] * B[j, 1] + A[i, 2] * B[j, 2]


@njit(cache=True, inline="always")
def _euler_parameter_turn(x, xd, c, qw, R, w, awk, hw, hv):
    """The set of Euler parameters at speeds ``c, c + 1, c + 2`` (:mod:`flexmb.quaternions`): ``R <- R R(q)``.

    ``q = (x[c], x[c + 1], x[c + 2], x[qw])``, normalised; the speeds are
    the angular velocity in the turned axes, so their partial angular
    velocities are the columns of the turned ``R`` and ``d/dt(R(q)) u =
    R(q) (u x u) = 0``: the set adds only ``w x (sum hw u)`` to the
    velocity-dependent angular acceleration ``awk`` (w: the rotations
    before it), then its angular velocity to ``w``.
    """
    qx, qy, qz, qs = x[c], x[c + 1], x[c + 2], x[qw]
    size = np.sqrt(qx * qx + qy * qy + qz * qz + qs * qs)
    qx, qy, qz, qs = qx / size, qy / size, qz / size, qs / size
    # R(q) = (qs^2 - qv.qv) I + 2 qv qv^T + 2 qs [qv]x
    diag = qs * qs - (qx * qx + qy * qy + qz * qz)
    t00, t11, t22 = diag + 2.0 * qx * qx, diag + 2.0 * qy * qy, diag + 2.0 * qz * qz
    t01, t10 = 2.0 * qx * qy - 2.0 * qs * qz, 2.0 * qx * qy + 2.0 * qs * qz
    t02, t20 = 2.0 * qx * qz + 2.0 * qs * qy, 2.0 * qx * qz - 2.0 * qs * qy
    t12, t21 = 2.0 * qy * qz - 2.0 * qs * qx, 2.0 * qy * qz + 2.0 * qs * qx
    for i in range(3):
        r0, r1, r2 = R[i, 0], R[i, 1], R[i, 2]
        R[i, 0] = r0 * t00 + r1 * t10 + r2 * t20
        R[i, 1] = r0 * t01 + r1 * t11 + r2 * t21
        R[i, 2] = r0 * t02 + r1 * t12 + r2 * t22
    s0 = s1 = s2 = 0.0
    for a in range(3):
        u = xd[c + a]
        for i in range(3):
            hw[c + a, i] = R[i, a]
            hv[c + a, i] = 0.0
        s0 += R[0, a] * u
        s1 += R[1, a] * u
        s2 += R[2, a] * u
    awk[0] += w[1] * s2 - w[2] * s1
    awk[1] += w[2] * s0 - w[0] * s2
    awk[2] += w[0] * s1 - w[1] * s0
    w[0] += s0
    w[1] += s1
    w[2] += s2


@njit(cache=True)
def joint_motions(x, xd, coord_start, coord_kind, coord_axis, external, Rj, d, hw, hv, aw, av):
    """Relative motions of the generic joints (translations, rotations about moving axes, Euler parameters).

    A generic joint's coordinates are translations along fixed axes of
    the parent marker frame, rotations about successive moving axes
    (``R = R_a1(q1) R_a2(q2) ...``, the Bryant sequence for axes x, y, z)
    and at most one set of Euler parameters, last (its speeds the angular
    velocity in the turned axes, :func:`_euler_parameter_turn`).
    Bodies flagged ``external`` (joint classes with their own
    ``motion()``) are skipped: their rows are filled in Python.

    Parameters
    ----------
    x : ndarray, shape (nq,)
        Coordinates: one per speed at the speed's index, then the Euler
        parameters' ``qw`` (:mod:`flexmb.state_layout`).
    xd : ndarray, shape (n,)
        Speeds.
    coord_start : ndarray of int, shape (n_bodies + 1,)
        Body k's tree joint owns ``xd[coord_start[k]:coord_start[k + 1]]``.
    coord_kind, coord_axis : ndarray of int, shape (n,)
        Translation (0), rotation (1) or Euler parameters (3), and the
        marker axis (0, 1, 2); for Euler parameters the index in x of
        their ``qw``.
    external : ndarray of bool, shape (n_bodies,)
        Joints whose motion is computed elsewhere.
    Rj, d, hw, hv, aw, av : ndarray
        Outputs (filled for non-external bodies): joint rotation
        (n_bodies, 3, 3), child point in the parent marker frame
        (n_bodies, 3), per-coordinate partial angular velocity and velocity
        in the parent marker frame (n, 3), and the velocity-dependent
        angular and linear accelerations ``Hdot qd`` (n_bodies, 3).
    """
    nb = coord_start.shape[0] - 1
    w = np.empty(3)
    ci = np.empty(3)
    for k in range(nb):
        if external[k]:
            continue
        R = Rj[k]
        R[:, :] = 0.0
        R[0, 0] = R[1, 1] = R[2, 2] = 1.0
        w[:] = 0.0
        aw[k] = 0.0
        av[k] = 0.0
        d[k] = 0.0
        c0 = coord_start[k]
        for c in range(c0, coord_start[k + 1]):
            ax = coord_axis[c]
            if coord_kind[c] == _QUATERNION:  # the set, at its first speed (its last freedoms)
                if c == c0 or coord_kind[c - 1] != _QUATERNION:
                    _euler_parameter_turn(x, xd, c, ax, R, w, aw[k], hw, hv)
                continue
            hw[c, :] = 0.0
            hv[c, :] = 0.0
            if coord_kind[c] == _TRANSLATION:
                d[k, ax] += x[c]
                hv[c, ax] = 1.0
                continue
            # the axis turned by the rotations before it; a += w x w_i, w += w_i
            for i in range(3):
                hw[c, i] = R[i, ax]
            q = xd[c]
            aw[k, 0] += (w[1] * hw[c, 2] - w[2] * hw[c, 1]) * q
            aw[k, 1] += (w[2] * hw[c, 0] - w[0] * hw[c, 2]) * q
            aw[k, 2] += (w[0] * hw[c, 1] - w[1] * hw[c, 0]) * q
            for i in range(3):
                w[i] += hw[c, i] * q
            # R <- R @ R_ax(x_c): the columns i, j of the plane turn
            cq, sq = np.cos(x[c]), np.sin(x[c])
            i1, j1 = (ax + 1) % 3, (ax + 2) % 3
            for i in range(3):
                ci[i] = R[i, i1]
            for i in range(3):
                R[i, i1] = cq * ci[i] + sq * R[i, j1]
                R[i, j1] = cq * R[i, j1] - sq * ci[i]


@njit(cache=True, inline="always")
def euler_parameter_rates(coord_start, coord_kind, coord_axis, x, xd, qd):
    """The Euler parameters' entries of ``qd = W(q) u``: ``1/2 q * (w, 0)`` (:mod:`flexmb.state_layout`).

    The other entries of qd (``qd[i] = u[i]``, ``W = I``) are left to the
    caller.

    Parameters
    ----------
    coord_start : ndarray of int, shape (n_bodies + 1,)
        Speed ranges of the tree joints.
    coord_kind, coord_axis : ndarray of int, shape (n,)
        The joints' coordinate kinds and axes (:func:`joint_motions`).
    x : ndarray, shape (nq,)
        Coordinates q.
    xd : ndarray, shape (n,)
        Speeds u.
    qd : ndarray, shape (>= nq,)
        Output: the coordinates' rates, written at the Euler parameters.
    """
    for k in range(coord_start.shape[0] - 1):
        c0 = coord_start[k]
        for c in range(c0, coord_start[k + 1]):
            if coord_kind[c] == _QUATERNION and (c == c0 or coord_kind[c - 1] != _QUATERNION):
                vx, vy, vz, s = x[c], x[c + 1], x[c + 2], x[coord_axis[c]]
                wx, wy, wz = xd[c], xd[c + 1], xd[c + 2]
                qd[c] = 0.5 * (s * wx + (vy * wz - vz * wy))
                qd[c + 1] = 0.5 * (s * wy + (vz * wx - vx * wz))
                qd[c + 2] = 0.5 * (s * wz + (vx * wy - vy * wx))
                qd[coord_axis[c]] = -0.5 * (vx * wx + vy * wy + vz * wz)


@njit(cache=True, inline="always")
def _external_motions(coord_start, external, ext_Rj, ext_d, ext_hw, ext_hv, ext_aw, ext_av, Rj, d, hw, hv, aw, av):
    """Copy the motions of the external joints (computed in Python) into the joint-motion arrays."""
    for k in range(coord_start.shape[0] - 1):
        if external[k]:
            Rj[k] = ext_Rj[k]
            d[k] = ext_d[k]
            aw[k] = ext_aw[k]
            av[k] = ext_av[k]
            for c in range(coord_start[k], coord_start[k + 1]):
                hw[c] = ext_hw[c]
                hv[c] = ext_hv[c]


@njit(cache=True, inline="always")
def _place_body(k, p, R, RM, s, jp, origin, r, parent_frame, child_frame, lever, child_point, com, Rj, d, F, G,
                t1, t2, u):
    """Rotation ``R_k = R_P F_p R_j F_c^T``, joint point ``o'_k = o'_P + s``, origin and mass centre (eqs. 6-8).

    Also leaves the parent marker frame ``R_M = R_P F_p`` in ``RM`` and ``s = R_P lever + R_M d`` in ``s``.
    """
    RP = R[p]
    _mm_to(RM, RP, parent_frame[k])
    _mm_to(F, parent_frame[k], Rj[k])
    _mmt_to(G, F, child_frame[k])
    _mm_to(R[k], RP, G)
    # s = R_P lever + R_M d; o'_k = o'_P + s; origin and mass centre
    _mv_to(s, RP, lever[k])
    _mv_to(t1, RM, d[k])
    _mv_to(t2, R[k], child_point[k])
    _mv_to(u, R[k], com[k])
    for i in range(3):
        s[i] += t1[i]
        jp[k, i] = jp[p, i] + s[i]
        origin[k, i] = jp[k, i] - t2[i]
        r[k, i] = origin[k, i] + u[i]


@njit(cache=True, inline="always")
def _body_velocity(k, p, c0, c1, RM, hw, hv, xd, jp, r, omega, v_o, v, Sw, Sv, Gw, Gv, v_rel, t1):
    """Plucker axes ``S_c`` of the joint's coordinates, then the body's angular and mass-centre velocities (eqs. 7, 17).

    ``v_rel`` receives the joint's relative velocity ``sum G_v qd`` at the joint point.
    """
    w = omega[k]
    vo = v_o[k]
    for i in range(3):
        w[i] = omega[p, i]
        vo[i] = v_o[p, i]
        v_rel[i] = 0.0
    for c in range(c0, c1):
        _mv_to(Gw[c], RM, hw[c])
        _mv_to(Gv[c], RM, hv[c])
        _cross_to(t1, Gw[c], jp[k])
        q = xd[c]
        for i in range(3):
            Sw[c, i] = Gw[c, i]
            Sv[c, i] = Gv[c, i] - t1[i]
            w[i] += Gw[c, i] * q
            vo[i] += Sv[c, i] * q
            v_rel[i] += Gv[c, i] * q
    _cross_to(t1, w, r[k])
    for i in range(3):
        v[k, i] = vo[i] + t1[i]


@njit(cache=True, inline="always")
def _body_bias_accelerations(k, p, RM, s, v_rel, aw, av, omega, jp, r, alpha, a_jp, acc, t1, t2, u):
    """Angular and mass-centre accelerations of body k at ``xdd = 0`` (eqs. 13, 18)."""
    w = omega[k]
    wP = omega[p]
    # alpha_k = alpha_P + wP x (w - wP) + R_M aw
    for i in range(3):
        t2[i] = w[i] - wP[i]
    _cross_to(t1, wP, t2)
    _mv_to(t2, RM, aw[k])
    for i in range(3):
        alpha[k, i] = alpha[p, i] + t1[i] + t2[i]
    # a_jp,k = a_jp,P + alpha_P x s + wP x (wP x s + 2 v_rel) + R_M av
    _cross_to(t1, alpha[p], s)
    for i in range(3):
        a_jp[k, i] = a_jp[p, i] + t1[i]
    _cross_to(t1, wP, s)
    for i in range(3):
        t1[i] += 2.0 * v_rel[i]
    _cross_to(t2, wP, t1)
    _mv_to(t1, RM, av[k])
    for i in range(3):
        a_jp[k, i] += t2[i] + t1[i]
    # acc_k = a_jp,k + alpha_k x u + w x (w x u), u = r_k - o'_k
    for i in range(3):
        u[i] = r[k, i] - jp[k, i]
    _cross_to(t1, alpha[k], u)
    for i in range(3):
        acc[k, i] = a_jp[k, i] + t1[i]
    _cross_to(t1, w, u)
    _cross_to(t2, w, t1)
    for i in range(3):
        acc[k, i] += t2[i]


@njit(cache=True)
def tree_kinematics(parent, coord_start, coord_kind, coord_axis, external, parent_frame, child_frame, lever,
                    child_point, com, x, xd, ext_Rj, ext_d, ext_hw, ext_hv, ext_aw, ext_av):
    """Rotations, positions, velocities, partial velocities and bias accelerations of all bodies.

    The joint motions (:func:`joint_motions`), then one pass in tree order
    (a parent before its children), O(n).

    Parameters
    ----------
    parent : ndarray of int, shape (n_bodies,)
        Parent body (-1: ground).
    coord_start : ndarray of int, shape (n_bodies + 1,)
        Coordinate ranges of the tree joints.
    coord_kind, coord_axis : ndarray of int, shape (n,)
        The generic joint motion's coordinates (:func:`joint_motions`).
    external : ndarray of bool, shape (n_bodies,)
        Joints whose motion is given in the ``ext_*`` arrays.
    parent_frame, child_frame : ndarray, shape (n_bodies, 3, 3)
        Joint frame in the parent and child body frames.
    lever : ndarray, shape (n_bodies, 3)
        ``parent_point - parent_joint_point``: from the parent's own joint
        point to this joint's, in the parent body frame.
    child_point, com : ndarray, shape (n_bodies, 3)
        Joint point and mass centre in the body frame.
    x : ndarray, shape (nq,)
        Coordinates (:func:`joint_motions`).
    xd : ndarray, shape (n,)
        Speeds.
    ext_Rj, ext_d, ext_hw, ext_hv, ext_aw, ext_av : ndarray
        The motions of the external joints, in the layout of
        :func:`joint_motions` (read on the external rows only; empty arrays
        when there are none).

    Returns
    -------
    R : ndarray, shape (n_bodies + 1, 3, 3)
        Body rotations; the last row the ground.
    origin, r, omega, v, alpha, acc : ndarray, shape (n_bodies + 1, 3)
        Body-frame origins, mass centres, angular velocities, mass-centre
        velocities and the bias accelerations (``xdd = 0``, eqs. 13, 18).
    joint_point : ndarray, shape (n_bodies, 3)
        Child-side joint points ``o'_k``.
    Sw, Sv : ndarray, shape (n, 3)
        Plucker axes of the coordinates.
    """
    nb = parent.shape[0]
    n = xd.shape[0]
    R = np.empty((nb + 1, 3, 3))
    origin = np.empty((nb + 1, 3))
    r = np.empty((nb + 1, 3))
    jp = np.empty((nb + 1, 3))
    omega = np.empty((nb + 1, 3))
    v = np.empty((nb + 1, 3))
    alpha = np.empty((nb + 1, 3))
    acc = np.empty((nb + 1, 3))
    Sw = np.empty((n, 3))
    Sv = np.empty((n, 3))
    tree_kinematics_into(parent, coord_start, coord_kind, coord_axis, external, parent_frame, child_frame, lever,
                         child_point, com, x, xd, ext_Rj, ext_d, ext_hw, ext_hv, ext_aw, ext_av, R, origin, r, omega,
                         v, alpha, acc, jp, Sw, Sv, np.empty(kinematics_work_size(nb, n)))
    return R, origin, r, omega, v, alpha, acc, jp[:nb].copy(), Sw, Sv


@register_jitable
def kinematics_work_size(nb, n):
    """Length of the work array :func:`tree_kinematics_into` needs.

    Parameters
    ----------
    nb : int
        Number of bodies.
    n : int
        Number of speeds.

    Returns
    -------
    int
        The length.
    """
    return 24 * nb + 6 + 12 * n + 42


@njit(cache=True)
def tree_kinematics_into(parent, coord_start, coord_kind, coord_axis, external, parent_frame, child_frame, lever,
                         child_point, com, x, xd, ext_Rj, ext_d, ext_hw, ext_hv, ext_aw, ext_av, R, origin, r, omega,
                         v, alpha, acc, jp, Sw, Sv, work):
    """:func:`tree_kinematics` into given arrays: nothing allocated (a right-hand side called by CVODE reuses them).

    Parameters
    ----------
    parent, coord_start, coord_kind, coord_axis, external, parent_frame, child_frame, lever, child_point, com : ndarray
        The tree's layout and body data (:func:`tree_kinematics`).
    x, xd : ndarray
        Coordinates and speeds.
    ext_Rj, ext_d, ext_hw, ext_hv, ext_aw, ext_av : ndarray
        The external joints' motions (:func:`tree_kinematics`).
    R : ndarray, shape (n_bodies + 1, 3, 3)
        Output: body rotations, the ground last.
    origin, r, omega, v, alpha, acc, jp : ndarray, shape (n_bodies + 1, 3)
        Outputs: what :func:`tree_kinematics` returns (``jp`` with the
        ground's row, zero, last).
    Sw, Sv : ndarray, shape (n, 3)
        Outputs: Plucker axes of the coordinates.
    work : ndarray, shape (>= kinematics_work_size(n_bodies, n),)
        Scratch.
    """
    nb = parent.shape[0]
    n = xd.shape[0]
    Rj = view3(work, 0, nb, 3, 3)
    d = view2(work, 9 * nb, nb, 3)
    aw = view2(work, 12 * nb, nb, 3)
    av = view2(work, 15 * nb, nb, 3)
    v_o = view2(work, 18 * nb, nb + 1, 3)  # Plucker linear velocity about the origin
    a_jp = view2(work, 21 * nb + 3, nb + 1, 3)
    o = 24 * nb + 6
    hw = view2(work, o, n, 3)
    hv = view2(work, o + 3 * n, n, 3)
    Gw = view2(work, o + 6 * n, n, 3)
    Gv = view2(work, o + 9 * n, n, 3)
    o += 12 * n
    RM = view2(work, o, 3, 3)
    F = view2(work, o + 9, 3, 3)
    G = view2(work, o + 18, 3, 3)
    s = work[o + 27 : o + 30]
    t1 = work[o + 30 : o + 33]
    t2 = work[o + 33 : o + 36]
    v_rel = work[o + 36 : o + 39]
    u = work[o + 39 : o + 42]
    joint_motions(x, xd, coord_start, coord_kind, coord_axis, external, Rj, d, hw, hv, aw, av)
    _external_motions(coord_start, external, ext_Rj, ext_d, ext_hw, ext_hv, ext_aw, ext_av, Rj, d, hw, hv, aw, av)
    R[nb] = 0.0
    R[nb, 0, 0] = R[nb, 1, 1] = R[nb, 2, 2] = 1.0
    for i in range(3):  # the ground's rows
        origin[nb, i] = r[nb, i] = jp[nb, i] = omega[nb, i] = v_o[nb, i] = 0.0
        v[nb, i] = alpha[nb, i] = a_jp[nb, i] = acc[nb, i] = 0.0
    for k in range(nb):
        p = parent[k]
        if p < 0:
            p = nb
        _place_body(k, p, R, RM, s, jp, origin, r, parent_frame, child_frame, lever, child_point, com, Rj, d, F, G,
                    t1, t2, u)
        _body_velocity(k, p, coord_start[k], coord_start[k + 1], RM, hw, hv, xd, jp, r, omega, v_o, v, Sw, Sv, Gw, Gv,
                       v_rel, t1)
        _body_bias_accelerations(k, p, RM, s, v_rel, aw, av, omega, jp, r, alpha, a_jp, acc, t1, t2, u)


@njit(cache=True)
def upstream_rows(bodies, parent, coord_start, n):
    """0/1 rows: which coordinates move each of the given bodies.

    Parameters
    ----------
    bodies : ndarray of int, shape (m,)
        Body indices (-1, the ground, gives a row of zeros).
    parent : ndarray of int, shape (n_bodies,)
        Parent body (-1: ground).
    coord_start : ndarray of int, shape (n_bodies + 1,)
        Coordinate ranges of the tree joints.
    n : int
        Number of coordinates.

    Returns
    -------
    ndarray, shape (m, n)
        ``out[i, c] = 1`` if coordinate c's joint is on the path from the
        ground to ``bodies[i]`` (its own joint included).
    """
    out = np.zeros((bodies.shape[0], n))
    for i in range(bodies.shape[0]):
        k = bodies[i]
        while k >= 0:
            out[i, coord_start[k]:coord_start[k + 1]] = 1.0
            k = parent[k]
    return out


@njit(cache=True)
def tree_state(tree, x, xd):
    """:func:`tree_kinematics` of a tree without external joints, from its :class:`TreeArrays`.

    Parameters
    ----------
    tree : TreeArrays
        The tree's layout and body data.
    x : ndarray, shape (nq,)
        Coordinates (:func:`joint_motions`).
    xd : ndarray, shape (n,)
        Speeds.

    Returns
    -------
    tuple
        What :func:`tree_kinematics` returns.
    """
    none3 = np.empty((0, 3))
    return tree_kinematics(tree.parent, tree.coord_start, tree.coord_kind, tree.coord_axis, tree.external,
                           tree.parent_frame, tree.child_frame, tree.lever, tree.child_point, tree.com, x, xd,
                           np.empty((0, 3, 3)), none3, none3, none3, none3, none3)
