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

from .tree import _cross, _mv

_QUATERNION = 3  # flexmb.kernels.QUATERNION

__all__ = ["geometric_stiffness"]


@njit(cache=True, inline="always")
def _skew(a):
    out = np.zeros((3, 3))
    out[0, 1] = -a[2]
    out[0, 2] = a[1]
    out[1, 0] = a[2]
    out[1, 2] = -a[0]
    out[2, 0] = -a[1]
    out[2, 1] = a[0]
    return out


@njit(cache=True)
def _net_wrenches(parent, coord_start, Sx, r, omega, v, alpha_bias, a_bias, inertia_world, mass, force, torque):
    """Spatial accelerations (about the origin) of the bodies and their net wrenches, loads minus inertia (eq. 19).

    Returns the accelerations ``acc`` (one row per body and the ground),
    the net wrenches ``W`` and the applied loads ``Fe``, ``Te`` and
    ``Ge = [r]x [F]x`` of each body, not yet summed over subtrees.
    """
    nb = parent.shape[0]
    acc = np.zeros((nb + 1, 6))
    up = np.zeros((nb + 1, 6))
    W = np.empty((nb, 6))
    Fe = np.empty((nb, 3))
    Te = np.empty((nb, 3))
    Ge = np.empty((nb, 3, 3))
    for k in range(nb):
        p = parent[k]
        if p < 0:
            p = nb
        up[k] = up[p]
        for c in range(coord_start[k], coord_start[k + 1]):
            up[k] += Sx[c]
        acc[k, :3] = alpha_bias[k] + up[k, :3]
        acc[k, 3:] = a_bias[k] - _cross(alpha_bias[k], r[k]) - _cross(omega[k], v[k]) + up[k, 3:]
        alpha = acc[k, :3]
        a_r = acc[k, 3:] + _cross(alpha, r[k]) + _cross(omega[k], v[k])
        net_f = force[k] - mass[k] * a_r
        net_t = (torque[k] - _mv(inertia_world[k], alpha)
                 - _cross(omega[k], _mv(inertia_world[k], omega[k])))
        W[k, :3] = net_t + _cross(r[k], net_f)
        W[k, 3:] = net_f
        Fe[k] = force[k]
        Te[k] = torque[k]
        Ge[k] = _skew(r[k]) @ _skew(force[k])
    return acc, W, Fe, Te, Ge


@njit(cache=True)
def _subtree_sums(parent, W, Fe, Te, Ge):
    """Sum the wrenches and loads over each subtree, from the leaves in."""
    for k in range(parent.shape[0] - 1, -1, -1):
        p = parent[k]
        if p >= 0:
            W[p] += W[k]
            Fe[p] += Fe[k]
            Te[p] += Te[k]
            Ge[p] += Ge[k]


@njit(cache=True)
def _coordinate_terms(parent, coord_start, coord_kind, Sw, Sv, Sx, IC, acc, W, Fe, Te, Ge):
    """Per coordinate: ``u = S x a_pre``, ``hs = H S``, ``qs = Q^T S`` and ``y = S x* W + H u - Q S_w``.

    ``a_pre``: the acceleration that does not turn with the coordinate (for a
    set of Euler parameters, the one before the set).
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
    for k in range(nb):
        p = parent[k]
        if p < 0:
            p = nb
        Q = np.empty((6, 3))
        Q[:3] = -Ge[k] - _skew(Te[k])
        Q[3:] = -_skew(Fe[k])
        a_pre[:] = acc[p]
        H = IC[k]
        c0 = coord_start[k]
        for c in range(c0, coord_start[k + 1]):
            a = a_pre
            if coord_kind[c] != _QUATERNION:
                a_pre += Sx[c]
            else:
                if c == c0 or coord_kind[c - 1] != _QUATERNION:  # the set's first speed
                    a_set[:] = a_pre
                    a_pre += Sx[c] + Sx[c + 1] + Sx[c + 2]
                a = a_set
            S[:3] = Sw[c]
            S[3:] = Sv[c]
            u[c, :3] = _cross(Sw[c], a[:3])
            u[c, 3:] = _cross(Sw[c], a[3:]) + _cross(Sv[c], a[:3])
            hs[c] = H @ S
            qs[c] = Q.T @ S
            Hu = H @ u[c]
            QS = Q @ Sw[c]
            y[c, :3] = _cross(Sw[c], W[k, :3]) + _cross(Sv[c], W[k, 3:]) + Hu[:3] - QS[:3]
            y[c, 3:] = _cross(Sw[c], W[k, 3:]) + Hu[3:] - QS[3:]
    return u, hs, qs, y


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
    n = Sw.shape[0]
    Sx = np.empty((n, 6))
    for c in range(n):
        Sx[c, :3] = Sw[c] * xdd[c]
        Sx[c, 3:] = Sv[c] * xdd[c]
    acc, W, Fe, Te, Ge = _net_wrenches(parent, coord_start, Sx, r, omega, v, alpha_bias, a_bias, inertia_world, mass,
                                       force, torque)
    _subtree_sums(parent, W, Fe, Te, Ge)
    u, hs, qs, y = _coordinate_terms(parent, coord_start, coord_kind, Sw, Sv, Sx, IC, acc, W, Fe, Te, Ge)
    return _assemble(parent, coord_start, coord_body, coord_kind, Sw, Sv, u, hs, qs, y)
