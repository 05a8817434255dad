"""Geometric stiffness of the loads and inertia forces (the state-following tangent).

See :func:`flexmb.assembly.geometric_stiffness` for the derivation. With
the composite inertia ``H`` of a subtree, ``u_d = S_d x a_d`` (a_d: the
spatial acceleration produced before coordinate d), the subtree wrench
``W`` and ``Q omega``, the change of the subtree's load wrench when the
loads turn back by omega:

* c after d: ``G[c, d] = S_c . (H_c u_d - Q_c S_wd)``;
* d after c: ``G[c, d] = S_c . (S_d x* W_d + H_d u_d - Q_d S_wd)``.

The three speeds of a set of Euler parameters are the angular velocity in
the turned axes: a turn along any of them turns the axes of all three
(``dS_c = S_d x S_c``), so within the set each counts as after the others,
and ``a_d`` leaves out the set's own accelerations.

Each coordinate d meets only the coordinates on its path from the ground,
so the kernel costs O(n depth) and forms nothing but G.
"""

from __future__ import annotations

import numpy as np
from .cache import njit

from .tree import _cross_to, _mv_to

_QUATERNION = 3  # flexmb.kernels.QUATERNION

__all__ = ["geometric_stiffness", "geometric_terms", "geometric_times"]


@njit(cache=True)
def _net_wrenches(parent, coord_start, Sx, r, omega, v, alpha_bias, a_bias, inertia_world, mass, force, torque):
    """Spatial accelerations (about the origin) of the bodies and their net wrenches, loads minus inertia (eq. 19).

    Returns the accelerations ``acc`` (one row per body and the ground),
    the net wrenches ``W`` and the applied loads ``Fe``, ``Te`` and
    ``Ge = [r]x [F]x = F r^T - (r . F) I`` of each body, not yet summed
    over subtrees (scalar loops: no small temporaries).
    """
    nb = parent.shape[0]
    acc = np.zeros((nb + 1, 6))
    up = np.zeros((nb + 1, 6))
    W = np.empty((nb, 6))
    Fe = np.empty((nb, 3))
    Te = np.empty((nb, 3))
    Ge = np.empty((nb, 3, 3))
    t1, t2, net_f, Iw_w = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    for k in range(nb):
        p = parent[k]
        if p < 0:
            p = nb
        for i in range(6):
            up[k, i] = up[p, i]
        for c in range(coord_start[k], coord_start[k + 1]):
            for i in range(6):
                up[k, i] += Sx[c, i]
        rx, ry, rz = r[k, 0], r[k, 1], r[k, 2]
        wx, wy, wz = omega[k, 0], omega[k, 1], omega[k, 2]
        vx, vy, vz = v[k, 0], v[k, 1], v[k, 2]
        bx, by, bz = alpha_bias[k, 0], alpha_bias[k, 1], alpha_bias[k, 2]
        t2[0], t2[1], t2[2] = wy * vz - wz * vy, wz * vx - wx * vz, wx * vy - wy * vx  # omega x v
        t1[0], t1[1], t1[2] = by * rz - bz * ry, bz * rx - bx * rz, bx * ry - by * rx  # alpha_bias x r
        for i in range(3):
            acc[k, i] = alpha_bias[k, i] + up[k, i]
            acc[k, 3 + i] = a_bias[k, i] - t1[i] - t2[i] + up[k, 3 + i]
        ax, ay, az = acc[k, 0], acc[k, 1], acc[k, 2]
        t1[0], t1[1], t1[2] = ay * rz - az * ry, az * rx - ax * rz, ax * ry - ay * rx  # alpha x r
        for i in range(3):
            net_f[i] = force[k, i] - mass[k] * (acc[k, 3 + i] + t1[i] + t2[i])
        I = inertia_world[k]
        for i in range(3):
            Iw_w[i] = I[i, 0] * wx + I[i, 1] * wy + I[i, 2] * wz
            t1[i] = I[i, 0] * ax + I[i, 1] * ay + I[i, 2] * az
        t2[0], t2[1], t2[2] = wy * Iw_w[2] - wz * Iw_w[1], wz * Iw_w[0] - wx * Iw_w[2], wx * Iw_w[1] - wy * Iw_w[0]
        fx, fy, fz = net_f[0], net_f[1], net_f[2]
        W[k, 0] = torque[k, 0] - t1[0] - t2[0] + (ry * fz - rz * fy)
        W[k, 1] = torque[k, 1] - t1[1] - t2[1] + (rz * fx - rx * fz)
        W[k, 2] = torque[k, 2] - t1[2] - t2[2] + (rx * fy - ry * fx)
        rf = rx * force[k, 0] + ry * force[k, 1] + rz * force[k, 2]
        for i in range(3):
            W[k, 3 + i] = net_f[i]
            Fe[k, i] = force[k, i]
            Te[k, i] = torque[k, i]
            for j in range(3):
                Ge[k, i, j] = force[k, i] * r[k, j] - (rf if i == j else 0.0)
    return acc, W, Fe, Te, Ge


@njit(cache=True)
def _subtree_sums(parent, W, Fe, Te, Ge):
    """Sum the wrenches and loads over each subtree, from the leaves in."""
    for k in range(parent.shape[0] - 1, -1, -1):
        p = parent[k]
        if p >= 0:
            for i in range(6):
                W[p, i] += W[k, i]
            for i in range(3):
                Fe[p, i] += Fe[k, i]
                Te[p, i] += Te[k, i]
                for j in range(3):
                    Ge[p, i, j] += Ge[k, i, j]


@njit(cache=True)
def _coordinate_terms(parent, coord_start, coord_kind, Sw, Sv, Sx, IC, acc, W, Fe, Te, Ge):
    """Per coordinate: ``u = S x a_pre``, ``hs = H S``, ``qs = Q^T S`` and ``y = S x* W + H u - Q S_w``.

    ``a_pre``: the acceleration that does not turn with the coordinate (for a
    set of Euler parameters, the one before the set); ``Q = [[-Ge - [Te]x],
    [-[Fe]x]]`` (6 x 3). Scalar loops: no small temporaries.
    """
    nb = parent.shape[0]
    n = Sw.shape[0]
    u = np.empty((n, 6))
    hs = np.empty((n, 6))
    qs = np.empty((n, 3))
    y = np.empty((n, 6))
    S = np.empty(6)
    a_pre = np.empty(6)
    a_set = np.empty(6)
    Q = np.empty((6, 3))
    t = np.empty(3)
    for k in range(nb):
        p = parent[k]
        if p < 0:
            p = nb
        for i in range(3):
            for j in range(3):
                Q[i, j] = -Ge[k, i, j]
                Q[3 + i, j] = 0.0
        _skew_add(Q, 0, Te[k], -1.0)
        _skew_add(Q, 3, Fe[k], -1.0)
        for i in range(6):
            a_pre[i] = acc[p, i]
        H = IC[k]
        c0 = coord_start[k]
        for c in range(c0, coord_start[k + 1]):
            a = a_pre
            if coord_kind[c] != _QUATERNION:
                for i in range(6):
                    a_pre[i] += Sx[c, i]
            else:
                if c == c0 or coord_kind[c - 1] != _QUATERNION:  # the set's first speed
                    for i in range(6):
                        a_set[i] = a_pre[i]
                        a_pre[i] += Sx[c, i] + Sx[c + 1, i] + Sx[c + 2, i]
                a = a_set
            for i in range(3):
                S[i] = Sw[c, i]
                S[3 + i] = Sv[c, i]
            _cross_to(t, Sw[c], a[:3])
            u[c, :3] = t
            _cross_to(t, Sw[c], a[3:])
            u[c, 3:] = t
            _cross_to(t, Sv[c], a[:3])
            for i in range(3):
                u[c, 3 + i] += t[i]
            for i in range(6):
                hi = 0.0
                ui = 0.0
                for j in range(6):
                    hi += H[i, j] * S[j]
                    ui += H[i, j] * u[c, j]
                hs[c, i] = hi
                y[c, i] = ui  # H u, completed below
            for j in range(3):
                q = 0.0
                for i in range(6):
                    q += Q[i, j] * S[i]
                qs[c, j] = q
            for i in range(6):
                y[c, i] -= Q[i, 0] * Sw[c, 0] + Q[i, 1] * Sw[c, 1] + Q[i, 2] * Sw[c, 2]
            _cross_to(t, Sw[c], W[k, :3])
            for i in range(3):
                y[c, i] += t[i]
            _cross_to(t, Sv[c], W[k, 3:])
            for i in range(3):
                y[c, i] += t[i]
            _cross_to(t, Sw[c], W[k, 3:])
            for i in range(3):
                y[c, 3 + i] += t[i]
    return u, hs, qs, y


@njit(cache=True, inline="always")
def _skew_add(Q, row, a, scale):
    """``Q[row : row + 3] += scale [a]x``."""
    Q[row, 1] -= scale * a[2]
    Q[row, 2] += scale * a[1]
    Q[row + 1, 0] += scale * a[2]
    Q[row + 1, 2] -= scale * a[0]
    Q[row + 2, 0] -= scale * a[1]
    Q[row + 2, 1] += scale * a[0]


@njit(cache=True)
def _assemble(parent, coord_start, coord_body, coord_kind, Sw, Sv, u, hs, qs, y):
    """G from the coordinate terms, each coordinate d against those on its path from the ground."""
    n = Sw.shape[0]
    G = np.zeros((n, n))
    for d in range(n):
        k = coord_body[d]
        j = k
        while j >= 0:
            for c in range(coord_start[j], coord_start[j + 1]):
                if j == k and (c >= d or coord_kind[c] == coord_kind[d] == _QUATERNION):
                    # c after d (within the joint: later, the same, or in its set of Euler parameters)
                    G[c, d] = (hs[c, 0] * u[d, 0] + hs[c, 1] * u[d, 1] + hs[c, 2] * u[d, 2]
                               + hs[c, 3] * u[d, 3] + hs[c, 4] * u[d, 4] + hs[c, 5] * u[d, 5]
                               - qs[c, 0] * Sw[d, 0] - qs[c, 1] * Sw[d, 1] - qs[c, 2] * Sw[d, 2])
                    continue
                # d after c: G[c, d] = S_c . y_d
                G[c, d] = (Sw[c, 0] * y[d, 0] + Sw[c, 1] * y[d, 1] + Sw[c, 2] * y[d, 2]
                           + Sv[c, 0] * y[d, 3] + Sv[c, 1] * y[d, 4] + Sv[c, 2] * y[d, 5])
                if j != k:
                    # and d after c, seen from d's row: G[d, c] = S_d . (H_d u_c - Q_d S_wc)
                    G[d, c] = (hs[d, 0] * u[c, 0] + hs[d, 1] * u[c, 1] + hs[d, 2] * u[c, 2]
                               + hs[d, 3] * u[c, 3] + hs[d, 4] * u[c, 4] + hs[d, 5] * u[c, 5]
                               - qs[d, 0] * Sw[c, 0] - qs[d, 1] * Sw[c, 1] - qs[d, 2] * Sw[c, 2])
            j = parent[j]
    return G


@njit(cache=True)
def geometric_stiffness(parent, coord_start, coord_body, coord_kind, Sw, Sv, xdd, r, omega, v, alpha_bias,
                        a_bias, inertia_world, mass, IC, force, torque):
    """``G[c, d] = d g_c / d x_d`` at fixed speeds and accelerations.

    Parameters
    ----------
    parent : ndarray of int, shape (n_bodies,)
        Parent body (-1: ground).
    coord_start : ndarray of int, shape (n_bodies + 1,)
        Coordinate ranges of the tree joints.
    coord_body : ndarray of int, shape (n,)
        Body whose tree joint owns each coordinate.
    coord_kind : ndarray of int, shape (n,)
        The coordinates' kinds (:mod:`flexmb.kernels`: the speeds of a set
        of Euler parameters turn each other's axes).
    Sw, Sv : ndarray, shape (n, 3)
        Plucker axes.
    xdd : ndarray, shape (n,)
        Accelerations.
    r, omega, v, alpha_bias, a_bias : ndarray, shape (>= n_bodies, 3)
        Mass centres, velocities and bias accelerations.
    inertia_world : ndarray, shape (n_bodies, 3, 3)
        Central inertias in inertial axes.
    mass : ndarray, shape (n_bodies,)
        Masses.
    IC : ndarray, shape (n_bodies, 6, 6)
        Composite spatial inertias.
    force, torque : ndarray, shape (>= n_bodies, 3)
        Applied forces at the mass centres and torques, inertial.

    Returns
    -------
    ndarray, shape (n, n)
        G (see :func:`flexmb.assembly.geometric_stiffness`).
    """
    u, hs, qs, y = geometric_terms(parent, coord_start, coord_kind, Sw, Sv, xdd, r, omega, v, alpha_bias, a_bias,
                                   inertia_world, mass, IC, force, torque)
    return _assemble(parent, coord_start, coord_body, coord_kind, Sw, Sv, u, hs, qs, y)


@njit(cache=True)
def geometric_terms(parent, coord_start, coord_kind, Sw, Sv, xdd, r, omega, v, alpha_bias, a_bias, inertia_world,
                    mass, IC, force, torque):
    """The per-coordinate terms G is made of: ``u = S x a_pre``, ``hs = H S``, ``qs = Q^T S``, ``y = S x* W + H u - Q S_w``.

    Parameters
    ----------
    parent, coord_start, coord_kind, Sw, Sv, xdd, r, omega, v, alpha_bias, a_bias, inertia_world, mass, IC, force, torque
        As :func:`geometric_stiffness`.

    Returns
    -------
    u, hs, y : ndarray, shape (n, 6)
    qs : ndarray, shape (n, 3)
        In the order ``u, hs, qs, y``: what :func:`geometric_stiffness`
        assembles G from and :func:`geometric_times` multiplies with.
    """
    n = Sw.shape[0]
    Sx = np.empty((n, 6))
    for c in range(n):
        for i in range(3):
            Sx[c, i] = Sw[c, i] * xdd[c]
            Sx[c, 3 + i] = Sv[c, i] * xdd[c]
    acc, W, Fe, Te, Ge = _net_wrenches(parent, coord_start, Sx, r, omega, v, alpha_bias, a_bias, inertia_world, mass,
                                       force, torque)
    _subtree_sums(parent, W, Fe, Te, Ge)
    return _coordinate_terms(parent, coord_start, coord_kind, Sw, Sv, Sx, IC, acc, W, Fe, Te, Ge)


@njit(cache=True, inline="always")
def _after(coord_kind, c, d):
    """Whether, in one joint, row c takes the ``hs . u - qs . S_w`` form against d: d not after c, or one set."""
    return d <= c or coord_kind[c] == coord_kind[d] == _QUATERNION


@njit(cache=True)
def geometric_times(parent, coord_start, coord_kind, Sw, Sv, u, hs, qs, y, x, out, down, up):
    """``out = G x`` in O(n), G as :func:`geometric_stiffness` assembles it, without forming it.

    Row c of G is ``hs_c . u_d - qs_c . S_wd`` against the coordinates d
    before it on its path from the ground (and itself, and its set of Euler
    parameters), ``S_c . y_d`` against those after it in its subtree: the
    first sums run from the ground out (``up``), the second from the
    leaves in (``down``).

    Parameters
    ----------
    parent, coord_start, coord_kind, Sw, Sv
        As :func:`geometric_stiffness`.
    u, hs, qs, y : ndarray
        :func:`geometric_terms`.
    x : ndarray, shape (n,)
        The vector.
    out : ndarray, shape (n,)
        Output: ``G x``.
    down : ndarray, shape (n_bodies, 6)
        Scratch.
    up : ndarray, shape (n_bodies + 1, 9)
        Scratch.
    """
    nb = parent.shape[0]
    down[:, :] = 0.0
    for k in range(nb - 1, -1, -1):  # the leaves in: down[k] is the sum of y_d x_d over k's subtree
        for c in range(coord_start[k], coord_start[k + 1]):
            s = 0.0
            for i in range(6):
                t = down[k, i]  # (its children's, so far)
                for d in range(coord_start[k], coord_start[k + 1]):
                    if not _after(coord_kind, c, d):
                        t += y[d, i] * x[d]
                s += (Sw[c, i] if i < 3 else Sv[c, i - 3]) * t
            out[c] = s
        for d in range(coord_start[k], coord_start[k + 1]):
            for i in range(6):
                down[k, i] += y[d, i] * x[d]
        p = parent[k]
        if p >= 0:
            for i in range(6):
                down[p, i] += down[k, i]
    up[nb, :] = 0.0
    for k in range(nb):  # the ground out: up[k] sums u_d x_d and S_wd x_d over k's path, k's joint included
        p = parent[k]
        if p < 0:
            p = nb
        for c in range(coord_start[k], coord_start[k + 1]):
            s = 0.0
            for i in range(9):
                t = up[p, i]
                for d in range(coord_start[k], coord_start[k + 1]):
                    if _after(coord_kind, c, d):
                        t += (u[d, i] if i < 6 else Sw[d, i - 6]) * x[d]
                s += (hs[c, i] if i < 6 else -qs[c, i - 6]) * t
            out[c] += s
        for i in range(9):
            t = up[p, i]
            for d in range(coord_start[k], coord_start[k + 1]):
                t += (u[d, i] if i < 6 else Sw[d, i - 6]) * x[d]
            up[k, i] = t
