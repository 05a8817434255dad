"""Geometric stiffness and the open tree's state Jacobian of a planar model, on 3-vectors.

The planar twin of :func:`flexmb.kernels.tangent.geometric_stiffness`
(its docstring and :func:`flexmb.assembly.geometric_stiffness` derive the
equations): ``G[c, d] = d g_c / d x_d`` at fixed speeds and accelerations,
``g`` the generalized active plus inertia forces (``A xdd - f = -g``). In
the plane (docs/theory.md, "A planar path"), motion vectors are ``(w, vx,
vy)`` and force vectors ``(tau, fx, fy)``, Plucker about the inertial
origin; with ``H`` the composite inertia of a subtree (3 x 3 symmetric),
``W`` its net wrench (applied loads minus inertia forces), ``u_d = S_d x
a_d`` (``a_d`` the spatial acceleration of d's parent) and ``Q`` the change
of the subtree's load wrench when the loads turn back about the normal n,
which for in-plane forces F at mass centres r is the 3-vector ``Q = sum
(r . F, -F_y, F_x)`` (the spatial ``[[-G_e - [T_e]x], [-[F_e]x]] n`` with
``r . n`` and ``T_e x n`` zero):

* c after d (here c = d: one coordinate per body): ``G[c, d] = S_c . (H_c u_d) - (Q_c . S_c) S_wd``;
* d after c: ``G[c, d] = S_c . (S_d x* W_d + H_d u_d - Q_d S_wd)``,

with ``S_w`` the angular part (``S[0]``) and ``v x* f = (v_x f_y - v_y
f_x, -w f_y, w f_x)``, ``v x m = (0, -w m_y + v_y m_w, w m_x - v_x m_w)``.
Each coordinate meets only those on its path from the ground: O(n depth).

:func:`planar_tree_state_jacobian` is the planar route of
:func:`flexmb.kernels.tree_jacobian.tree_state_jacobian`: ``A^-1`` column by
column through the planar articulated factors (a unit generalized force, no
bias), G here at the state's accelerations, J by the shared
:func:`~flexmb.kernels.tree_jacobian.fill_state_jacobian`.
"""

from __future__ import annotations

import numpy as np

from .cache import njit
from .planar import backward, factor, forward, inertias, kinematics, loads

__all__ = ["planar_geometric_stiffness", "planar_geometric_terms", "planar_gravity_loads",
           "planar_tree_jacobian_parts"]


@njit(cache=True)
def planar_gravity_loads(floats, force, torque):
    """The planar model's applied loads that turn no coordinate's axis: gravity ``m g`` at the mass centres.

    Parameters
    ----------
    floats : tuple
        The planar model's float arrays (:func:`flexmb.kernels.planar.unpack_planar`).
    force : ndarray, shape (>= n_bodies, 2)
        Output: in-plane forces at the mass centres, in the plane's basis.
    torque : ndarray, shape (>= n_bodies,)
        Output: torques about the normal n (zero: gravity has none).
    """
    mass, g = floats[3], floats[5]
    for k in range(mass.shape[0]):
        force[k, 0] = mass[k] * g[0]
        force[k, 1] = mass[k] * g[1]
        torque[k] = 0.0


@njit(cache=True)
def _subtree_wrenches(ints, floats, Kin, xdd, force, torque, acc, T):
    """Per body (ground last): spatial accelerations ``acc`` and, summed over its subtree, ``T = (W, H, Q)``.

    ``T[k, 0:3]`` the net wrench (loads minus inertia forces ``I a + v x* (I
    v)``), ``T[k, 3:9]`` the composite inertia (00, 01, 02, 11, 12, 22),
    ``T[k, 9:12]`` Q (module docstring). Scalar loops: no temporaries.
    """
    parent, coord = ints[0], ints[1]
    mass, J = floats[3], floats[4]
    nb = parent.shape[0]
    acc[nb, 0] = acc[nb, 1] = acc[nb, 2] = 0.0
    T[nb, :] = 0.0
    for k in range(nb):
        p, c = parent[k], coord[k]
        q = xdd[c] if c >= 0 else 0.0
        a0 = acc[p, 0] + Kin[k, 13] + Kin[k, 10] * q
        a1 = acc[p, 1] + Kin[k, 14] + Kin[k, 11] * q
        a2 = acc[p, 2] + Kin[k, 15] + Kin[k, 12] * q
        acc[k, 0], acc[k, 1], acc[k, 2] = a0, a1, a2
        m, rx, ry = mass[k], Kin[k, 5], Kin[k, 6]
        w, vx, vy = Kin[k, 7], Kin[k, 8], Kin[k, 9]
        I00, I01, I02 = J[k] + m * (rx * rx + ry * ry), -m * ry, m * rx
        hx, hy = m * (vx - w * ry), m * (vy + w * rx)  # the linear momentum
        fx, fy = force[k, 0], force[k, 1]
        T[k, 0] = torque[k] + rx * fy - ry * fx - (I00 * a0 + I01 * a1 + I02 * a2) - (vx * hy - vy * hx)
        T[k, 1] = fx - (I01 * a0 + m * a1) + w * hy
        T[k, 2] = fy - (I02 * a0 + m * a2) - w * hx
        T[k, 3], T[k, 4], T[k, 5], T[k, 6], T[k, 7], T[k, 8] = I00, I01, I02, m, 0.0, m
        T[k, 9], T[k, 10], T[k, 11] = rx * fx + ry * fy, -fy, fx
    for k in range(nb - 1, -1, -1):
        p = parent[k]
        if p < nb:
            for i in range(12):
                T[p, i] += T[k, i]


@njit(cache=True)
def planar_geometric_terms(ints, floats, Kin, xdd, force, torque):
    """The per-coordinate terms G is made of: ``u = S x a_parent``, ``hs = H S``, ``qs = Q . S``, ``y``.

    Parameters
    ----------
    ints, floats : tuple
        The planar model (:func:`flexmb.kernels.planar.unpack_planar`).
    Kin : ndarray, shape (n_bodies + 1, 20)
        The state's kinematics (:func:`flexmb.kernels.planar.kinematics`).
    xdd : ndarray, shape (n,)
        Accelerations (an open tree's, or a tree with loops' from its constrained solve).
    force : ndarray, shape (>= n_bodies, 2)
        Applied in-plane forces at the mass centres whose direction stays inertial.
    torque : ndarray, shape (>= n_bodies,)
        Applied torques about the normal n.

    Returns
    -------
    u, hs, y : ndarray, shape (n, 3)
    qs, sw : ndarray, shape (n,)
        ``y = S x* W + H u - Q S_w`` and ``sw = S_w``, the axes' angular parts.
    body : ndarray of int, shape (n,)
        The body of each coordinate.
    """
    parent, coord = ints[0], ints[1]
    nb = parent.shape[0]
    n = xdd.shape[0]
    acc = np.empty((nb + 1, 3))
    T = np.empty((nb + 1, 12))
    _subtree_wrenches(ints, floats, Kin, xdd, force, torque, acc, T)
    u, hs, y = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
    qs, sw = np.zeros(n), np.zeros(n)
    body = np.full(n, -1, dtype=np.int64)
    for k in range(nb):
        c = coord[k]
        if c < 0:
            continue
        body[c] = k
        p = parent[k]
        S0, S1, S2 = Kin[k, 10], Kin[k, 11], Kin[k, 12]
        a0, a1, a2 = acc[p, 0], acc[p, 1], acc[p, 2]
        u0, u1, u2 = 0.0, -S0 * a2 + S2 * a0, S0 * a1 - S1 * a0
        H00, H01, H02, H11, H12, H22 = T[k, 3], T[k, 4], T[k, 5], T[k, 6], T[k, 7], T[k, 8]
        W0, W1, W2 = T[k, 0], T[k, 1], T[k, 2]
        Q0, Q1, Q2 = T[k, 9], T[k, 10], T[k, 11]
        u[c, 0], u[c, 1], u[c, 2] = u0, u1, u2
        hs[c, 0] = H00 * S0 + H01 * S1 + H02 * S2
        hs[c, 1] = H01 * S0 + H11 * S1 + H12 * S2
        hs[c, 2] = H02 * S0 + H12 * S1 + H22 * S2
        qs[c] = Q0 * S0 + Q1 * S1 + Q2 * S2
        sw[c] = S0
        y[c, 0] = S1 * W2 - S2 * W1 + H00 * u0 + H01 * u1 + H02 * u2 - Q0 * S0
        y[c, 1] = -S0 * W2 + H01 * u0 + H11 * u1 + H12 * u2 - Q1 * S0
        y[c, 2] = S0 * W1 + H02 * u0 + H12 * u1 + H22 * u2 - Q2 * S0
    return u, hs, qs, y, sw, body


@njit(cache=True)
def planar_geometric_stiffness(ints, floats, Kin, xdd, force, torque):
    """``G[c, d] = d g_c / d x_d`` of a planar model at fixed speeds and accelerations.

    Parameters
    ----------
    ints, floats : tuple
        The planar model (:func:`flexmb.kernels.planar.unpack_planar`).
    Kin : ndarray, shape (n_bodies + 1, 20)
        The state's kinematics (:func:`flexmb.kernels.planar.kinematics`).
    xdd : ndarray, shape (n,)
        Accelerations: an open tree's, or the constrained solve's of a tree
        with loops (as :func:`flexmb.kernels.loop_jacobian.loop_state_jacobian`
        passes them to the spatial one).
    force : ndarray, shape (>= n_bodies, 2)
        Applied in-plane forces at the mass centres whose direction stays
        inertial (:func:`planar_gravity_loads`).
    torque : ndarray, shape (>= n_bodies,)
        Applied torques about the normal n.

    Returns
    -------
    ndarray, shape (n, n)
        G, equal to :func:`flexmb.kernels.tangent.geometric_stiffness` of the same state.
    """
    u, hs, qs, y, sw, body = planar_geometric_terms(ints, floats, Kin, xdd, force, torque)
    parent, coord = ints[0], ints[1]
    nb = parent.shape[0]
    n = xdd.shape[0]
    G = np.zeros((n, n))
    for d in range(n):
        k = body[d]
        G[d, d] = hs[d, 0] * u[d, 0] + hs[d, 1] * u[d, 1] + hs[d, 2] * u[d, 2] - qs[d] * sw[d]
        j = parent[k]
        while j < nb:
            c = coord[j]
            if c >= 0:  # d after c
                G[c, d] = Kin[j, 10] * y[d, 0] + Kin[j, 11] * y[d, 1] + Kin[j, 12] * y[d, 2]
                G[d, c] = hs[d, 0] * u[c, 0] + hs[d, 1] * u[c, 1] + hs[d, 2] * u[c, 2] - qs[d] * sw[c]
            j = parent[j]
    return G


@njit(cache=True)
def planar_tree_jacobian_parts(ints, floats, y, n):
    """``A^-1`` and G of a planar open tree at ``y = (x, xd, ...)``: what its state Jacobian is made of.

    Parameters
    ----------
    ints, floats : tuple
        The planar model (:func:`flexmb.kernels.planar.unpack_planar`).
    y : ndarray, shape (>= 2 n,)
        Coordinates and speeds first.
    n : int
        Number of speeds (and coordinates).

    Returns
    -------
    P : ndarray, shape (n, n)
        ``A^-1``, column by column: the planar articulated solve of a unit
        generalized force, no loads and no bias.
    G : ndarray, shape (n, n)
        :func:`planar_geometric_stiffness` at the state's accelerations.
    bad : int
        The body of a joint whose articulated inertia is singular (a freedom
        that moves no mass), else -1.
    """
    nb = ints[0].shape[0]
    x, xd = y[:n], y[n:2 * n]
    Kin = np.empty((nb + 1, 20))
    pA, IA, UD = np.empty((nb + 1, 3)), np.zeros((nb + 1, 6)), np.empty((nb + 1, 4))
    tau, uu, acc, xdd = np.empty(n), np.empty(nb + 1), np.empty((nb + 1, 3)), np.empty(n)
    kinematics(ints, floats, x, xd, Kin)
    loads(ints, floats, x, xd, Kin, pA, tau)
    inertias(floats, Kin, IA)
    P = np.empty((n, n))
    G = np.empty((0, 0))
    bad = factor(ints, Kin, IA, UD, np.zeros(n))
    if bad >= 0:
        return P, G, bad
    backward(ints, Kin, IA, UD, pA, tau, uu, True)
    forward(ints, Kin, UD, uu, True, acc, xdd)
    force, torque = np.empty((nb, 2)), np.empty(nb)
    planar_gravity_loads(floats, force, torque)
    G = planar_geometric_stiffness(ints, floats, Kin, xdd, force, torque)
    col = np.empty(n)
    for j in range(n):
        pA[:, :] = 0.0
        tau[:] = 0.0
        tau[j] = 1.0
        backward(ints, Kin, IA, UD, pA, tau, uu, False)
        forward(ints, Kin, UD, uu, False, acc, col)
        P[:, j] = col
    return P, G, -1
