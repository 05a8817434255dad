"""Prototype: a planar articulated-body recursion (3-vectors, 3 x 3 inertias) for flexmb's planar models.

Not part of flexmb: a benchmark prototype for issues 28 and 31 (the design
is in docs/theory.md, "A planar path (design, 2026-11-28)"). It takes a
built :class:`flexmb.System` whose joints all move in one plane (revolute
coordinates about the plane's normal n, prismatic ones in the plane, no
external joints, no Euler parameters, one coordinate at most per body), the
loads B1 and B6 use (gravity, coordinate springs and dampers) and, for
loops, direction rows in the plane (:class:`flexmb.PlanarRevolute` cuts)
and driver rows, and evaluates the state rate in the plane:

* motion vectors ``(w, vx, vy)`` and force vectors ``(tau, fx, fy)``,
  Plucker about the inertial origin as flexmb's spatial kernels use (no
  transforms between bodies), in an in-plane basis ``(e1, e2)``,
  ``e1 x e2 = n``;
* a body's vectors fixed in it are stored at the zero configuration, so
  that at a state they are turned by the body's angle only (``theta_k =
  theta_parent + s q`` for a revolute coordinate, ``s = +-1``);
* the articulated-body recursion (Featherstone) with 3 x 3 articulated
  inertias (6 numbers, symmetric), the loops' rows as two wrenches each,
  ``Y = A^-1 psi^T`` by one backward and one forward pass over all m
  columns at once, ``K = psi Y`` (m x m) by Cholesky, and ``xdd = a0 + Y
  lambda``, ``K lambda = gamma - psi a0`` (the solve of flexmb's
  ``complement="articulated"``, at regular positions: no rank filter).

:func:`planar_model` reads the model from flexmb's packed arrays (the same
data the spatial kernels take) and refuses what it does not cover.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from flexmb.kernels.packing import unpack
from flexmb.kernels.planar import _rot, backward, factor, forward, inertias, kinematics, loads
from flexmb.kernels.tree import tree_state
from flexmb.kernels.views import view2, view3

#: kinds of a body's joint in the planar model
REVOLUTE, PRISMATIC, NONE = 0, 1, 2


def _basis(axes):
    """The plane's normal n (the first revolute axis) and an in-plane basis ``(e1, e2)`` with ``e1 x e2 = n``."""
    n = axes[0] / np.linalg.norm(axes[0])
    e1 = np.cross(n, np.eye(3)[int(np.argmin(abs(n)))])
    e1 /= np.linalg.norm(e1)
    return n, e1, np.cross(n, e1)


def planar_model(system):
    """The planar data of a built system whose motion lies in one plane.

    Parameters
    ----------
    system : flexmb.System
        A built model: revolute coordinates about one axis n, prismatic
        ones normal to it, at most one coordinate per body, loads gravity
        and coordinate springs / dampers only, cut joints with direction
        rows in the plane only, drivers on coordinates.

    Returns
    -------
    tuple
        ``(ints, floats)`` of the planar model (:func:`_unpack_model`).

    Raises
    ------
    ValueError
        If the model is not of that kind.
    """
    tree, tables, cuts = unpack(system._packed)
    nb, n = tree.parent.shape[0], tree.coord_start[-1]
    if np.any(tree.external) or np.any(tree.coord_kind > 1) or np.any(np.diff(tree.coord_start) > 1):
        raise ValueError("planar_model: external joints, Euler parameters or several coordinates on a body")
    R0 = tree_state(tree, np.zeros(n), np.zeros(n))[0]  # body rotations at the zero configuration, ground last
    parent = np.where(tree.parent < 0, nb, tree.parent)
    axes = [R0[parent[tree.coord_body[c]]] @ tree.parent_frame[tree.coord_body[c]][:, tree.coord_axis[c]]
            for c in range(n)]
    rot = [a for a, kind in zip(axes, tree.coord_kind) if kind == 1]
    if not rot:
        raise ValueError("planar_model: no revolute coordinate")
    nrm, e1, e2 = _basis(rot)
    P2 = np.array([e1, e2])
    kind, coord, axis = np.full(nb, NONE), np.full(nb, -1), np.zeros((nb, 2))
    for c in range(n):
        k = tree.coord_body[c]
        kind[k], coord[k] = (REVOLUTE, PRISMATIC)[1 - tree.coord_kind[c]], c
        if tree.coord_kind[c] == 1:
            if abs(abs(axes[c] @ nrm) - 1.0) > 1e-12:
                raise ValueError(f"planar_model: coordinate {c} turns about an axis off the plane's normal")
            axis[k, 0] = np.sign(axes[c] @ nrm)
        else:
            if abs(axes[c] @ nrm) > 1e-12:
                raise ValueError(f"planar_model: coordinate {c} slides off the plane")
            axis[k] = P2 @ axes[c]
    lever = np.array([P2 @ (R0[parent[k]] @ tree.lever[k]) for k in range(nb)])
    u = np.array([P2 @ (R0[k] @ (tree.com[k] - tree.child_point[k])) for k in range(nb)])
    J = np.array([nrm @ R0[k] @ tree.inertia[k] @ R0[k].T @ nrm for k in range(nb)])
    _check_loads(tables)
    pt_i, _, _, _, dr_i, dr_pi, dr_ai, dr_j, dr_pj, pp_i, _, _, _ = cuts
    if pt_i.shape[0] or pp_i.shape[0]:
        raise ValueError("planar_model: point or perpendicularity rows (only in-plane direction rows)")
    nc = dr_i.shape[0]
    ri, rj = np.where(dr_i < 0, nb, dr_i), np.where(dr_j < 0, nb, dr_j)
    cp = np.vstack([tree.child_point, np.zeros((1, 3))])
    wi = np.array([P2 @ (R0[ri[q]] @ (dr_pi[q] - cp[ri[q]])) for q in range(nc)]).reshape(nc, 2)
    wj = np.array([P2 @ (R0[rj[q]] @ (dr_pj[q] - cp[rj[q]])) for q in range(nc)]).reshape(nc, 2)
    d0 = np.array([R0[ri[q]] @ dr_ai[q] for q in range(nc)]).reshape(nc, 3)
    if nc and np.max(abs(d0 @ nrm)) > 1e-12:
        raise ValueError("planar_model: a direction row off the plane")
    drivers = np.asarray(system._loop_layout.row_coord if system._loop_layout is not None else [], dtype=np.int64)
    drivers = drivers[drivers >= 0]
    ints = (parent.astype(np.int64), coord.astype(np.int64), kind.astype(np.int64),
            np.asarray(tables.coord_cols, np.int64), ri.astype(np.int64), rj.astype(np.int64), drivers)
    floats = (axis, lever, u, np.asarray(tree.mass, float), J, P2 @ np.asarray(tables.gravity, float),
              np.asarray(tables.coord_k, float), np.asarray(tables.coord_c, float),
              np.asarray(tables.coord_rest, float), wi, wj, d0 @ P2.T)
    return ints, floats


def _check_loads(tables):
    """Refuse force elements other than gravity and coordinate springs / dampers."""
    for name in ("pair_rows", "force_rows", "torque_rows", "contact_rows", "sweep_rows"):
        if np.asarray(getattr(tables, name)).shape[0]:
            raise ValueError(f"planar_model: the model has {name} (only gravity and coordinate springs)")


def make_work(ints, n):
    """The scratch arrays of :func:`planar_rhs_into` (allocated once per model)."""
    nb, m = ints[0].shape[0], ints[4].shape[0] + ints[6].shape[0]
    return (np.zeros((nb + 1, 20)), np.zeros((nb + 1, 3)), np.zeros((nb + 1, 6)), np.zeros((nb + 1, 4)),
            np.zeros(n), np.zeros(nb + 1), np.zeros((nb + 1, 3)), np.zeros((m, 2, 3)), np.zeros(m),
            np.zeros((nb + 1, m, 3)), np.zeros((n + 1, m)), np.zeros((nb + 1, m)), np.zeros((n, m)),
            np.zeros((nb + 1, m, 3)), np.zeros((m, m)), np.zeros(m))


@njit(cache=True)
def rows(ints, floats, K, gamma_d, W, gamma):
    """Direction rows ``d . (P_j - P_i) = 0`` (d turning with body i) as two wrenches each, then driver rows.

    ``W`` (m, 2, 3): the wrenches on bodies i and j of each cut row (zero
    for driver rows); ``gamma`` (m): minus the velocity-dependent part of
    each row's second derivative (the drivers': ``gamma_d``).
    """
    ri, rj, drv = ints[4], ints[5], ints[6]
    wi, wj, d0 = floats[9], floats[10], floats[11]
    nc = ri.shape[0]
    for a in range(nc):
        i, j = ri[a], rj[a]
        ci, si, cj, sj = K[i, 1], K[i, 2], K[j, 1], K[j, 2]
        ax, ay = _rot(ci, si, wi[a, 0], wi[a, 1])
        bx, by = _rot(cj, sj, wj[a, 0], wj[a, 1])
        Pix, Piy, Pjx, Pjy = K[i, 3] + ax, K[i, 4] + ay, K[j, 3] + bx, K[j, 4] + by
        dx, dy = _rot(ci, si, d0[a, 0], d0[a, 1])
        ex, ey = Pjx - Pix, Pjy - Piy
        # wrenches: on i the moment (d x e) and -d at P_i; on j +d at P_j
        W[a, 0, 0] = dx * ey - dy * ex - (Pix * dy - Piy * dx)
        W[a, 0, 1], W[a, 0, 2] = -dx, -dy
        W[a, 1, 0], W[a, 1, 1], W[a, 1, 2] = Pjx * dy - Pjy * dx, dx, dy
        wI, wJ = K[i, 7], K[j, 7]
        vix, viy = K[i, 8] - wI * Piy, K[i, 9] + wI * Pix  # point velocities
        vjx, vjy = K[j, 8] - wJ * Pjy, K[j, 9] + wJ * Pjx
        # point bias accelerations: a_O,bias + w x v_P (the angular bias is zero in the plane)
        aix, aiy = K[i, 17] - wI * viy, K[i, 18] + wI * vix
        ajx, ajy = K[j, 17] - wJ * vjy, K[j, 18] + wJ * vjx
        edx, edy = vjx - vix, vjy - viy
        bias = -wI * wI * (dx * ex + dy * ey) + 2.0 * wI * (-dy * edx + dx * edy) + dx * (ajx - aix) + dy * (ajy - aiy)
        gamma[a] = -bias
    for a in range(drv.shape[0]):
        W[nc + a, :, :] = 0.0
        gamma[nc + a] = gamma_d[a]


@njit(cache=True)
def responses(ints, K, UD, W, pC, tauC, uC, Y, accC):
    """``Y = A^-1 psi^T``: every row's two wrenches (or a driver's unit force) through the factors at once.

    ``Y`` (n, m) the coordinates' responses, ``accC`` (nb + 1, m, 3) the
    bodies' spatial accelerations (ground last), ``pC``, ``tauC``, ``uC``
    scratch.
    """
    parent, coord, ri, rj, drv = ints[0], ints[1], ints[4], ints[5], ints[6]
    nb, nc, m = parent.shape[0], ri.shape[0], W.shape[0]
    pC[:, :, :] = 0.0
    tauC[:, :] = 0.0
    for a in range(nc):
        for t in range(3):
            pC[ri[a], a, t] -= W[a, 0, t]
            pC[rj[a], a, t] -= W[a, 1, t]
    for a in range(drv.shape[0]):
        tauC[drv[a], nc + a] = 1.0
    for k in range(nb - 1, -1, -1):
        S0, S1, S2 = K[k, 10], K[k, 11], K[k, 12]
        U0, U1, U2, Di = UD[k, 0], UD[k, 1], UD[k, 2], UD[k, 3]
        c, p = coord[k], parent[k]
        for b in range(m):
            u = (tauC[c, b] if c >= 0 else 0.0) - (S0 * pC[k, b, 0] + S1 * pC[k, b, 1] + S2 * pC[k, b, 2])
            uC[k, b] = u
            if p < nb:
                f = u * Di
                pC[p, b, 0] += pC[k, b, 0] + U0 * f
                pC[p, b, 1] += pC[k, b, 1] + U1 * f
                pC[p, b, 2] += pC[k, b, 2] + U2 * f
    accC[nb, :, :] = 0.0
    for k in range(nb):
        p, c = parent[k], coord[k]
        for b in range(m):
            a0, a1, a2 = accC[p, b, 0], accC[p, b, 1], accC[p, b, 2]
            q = (uC[k, b] - (UD[k, 0] * a0 + UD[k, 1] * a1 + UD[k, 2] * a2)) * UD[k, 3]
            if c >= 0:
                Y[c, b] = q
            accC[k, b, 0], accC[k, b, 1], accC[k, b, 2] = a0 + K[k, 10] * q, a1 + K[k, 11] * q, a2 + K[k, 12] * q


@njit(cache=True)
def _psi_times(ints, W, acc, K, a, xdd, bias):
    """Row a of psi applied to accelerations: its wrenches . the bodies' (spatial accelerations - bias)."""
    nc = ints[4].shape[0]
    if a >= nc:
        return xdd[ints[6][a - nc]]
    i, j = ints[4][a], ints[5][a]
    s = 0.0
    for t in range(3):
        s += W[a, 0, t] * (acc[i, t] - (K[i, 16 + t] if bias else 0.0))
        s += W[a, 1, t] * (acc[j, t] - (K[j, 16 + t] if bias else 0.0))
    return s


@njit(cache=True)
def cholesky(Km):
    """``Km = L L^T`` in place, L in the lower triangle (``Km`` symmetric positive definite)."""
    m = Km.shape[0]
    for j in range(m):
        s = Km[j, j]
        for t in range(j):
            s -= Km[j, t] * Km[j, t]
        Km[j, j] = np.sqrt(s)
        for i in range(j + 1, m):
            s = Km[i, j]
            for t in range(j):
                s -= Km[i, t] * Km[j, t]
            Km[i, j] = s / Km[j, j]


@njit(cache=True)
def cholesky_solve(L, r):
    """Solve ``L L^T lam = r`` in place (L from :func:`cholesky`)."""
    m = r.shape[0]
    for i in range(m):
        s = r[i]
        for t in range(i):
            s -= L[i, t] * r[t]
        r[i] = s / L[i, i]
    for i in range(m - 1, -1, -1):
        s = r[i]
        for t in range(i + 1, m):
            s -= L[t, i] * r[t]
        r[i] = s / L[i, i]


@njit(cache=True)
def planar_rhs_into(ints, floats, y, n, gamma_d, ydot, work, upto):
    """The state rate ``ydot = (xd, xdd)`` at ``y = (x, xd)``; ``upto`` < 5 stops after a part (for timing).

    Parts: 0 kinematics, 1 loads, 2 rows, 3 factors (articulated
    inertias, ``Y``, ``K`` and its Cholesky factor), 4 the solve (``a0``
    by the recursion, ``lambda``, ``xdd = a0 + Y lambda``).
    """
    Kin, pA, IA, UD, tau, uu, acc, W, gamma, pC, tauC, uC, Y, accC, Km, lam = work
    x, xd = y[:n], y[n:2 * n]
    kinematics(ints, floats, x, xd, Kin)
    if upto == 0:
        return
    loads(ints, floats, x, xd, Kin, pA, tau)
    if upto == 1:
        return
    m = W.shape[0]
    if m:
        rows(ints, floats, Kin, gamma_d, W, gamma)
    if upto == 2:
        return
    inertias(floats, Kin, IA)
    factor(ints, Kin, IA, UD, np.zeros(n))
    if m:
        responses(ints, Kin, UD, W, pC, tauC, uC, Y, accC)
        for a in range(m):
            for b in range(m):
                Km[a, b] = _psi_times(ints, W, accC[:, b, :], Kin, a, Y[:, b], False)
        cholesky(Km)
    if upto == 3:
        return
    backward(ints, Kin, IA, UD, pA, tau, uu, True)
    xdd = ydot[n:2 * n]
    forward(ints, Kin, UD, uu, True, acc, xdd)
    if m:
        for a in range(m):
            lam[a] = gamma[a] - _psi_times(ints, W, acc, Kin, a, xdd, True)
        cholesky_solve(Km, lam)
        for c in range(n):
            s = 0.0
            for b in range(m):
                s += Y[c, b] * lam[b]
            xdd[c] += s
    ydot[:n] = xd



# ----------------------------------------------------------------------------- in place: flat buffers, as CVODE calls



def pack_planar(ints, floats, n):
    """The model in two flat buffers and the work in a third, with an index (offset and shape per array).

    Returns ``(fbuf, ibuf, wbuf, index)``, for :func:`planar_rhs_packed`.
    """
    arrays = [*ints, *floats, *make_work(ints, n)]
    index = np.zeros((len(arrays), 4), dtype=np.int64)
    parts = {"i": [], "f": [], "w": []}
    for k, a in enumerate(arrays):
        kind = "i" if k < len(ints) else ("f" if k < len(ints) + len(floats) else "w")
        index[k, 0] = sum(p.size for p in parts[kind])
        index[k, 1:1 + a.ndim] = a.shape
        parts[kind].append(np.ascontiguousarray(a).ravel())
    fbuf, ibuf, wbuf = (np.concatenate(parts[c]) if parts[c] else np.zeros(0) for c in "fiw")
    return fbuf.astype(np.float64), ibuf.astype(np.int64), wbuf.astype(np.float64), index


@njit(cache=True, inline="always")
def _v1(buf, ix, k):
    return buf[ix[k, 0]:ix[k, 0] + ix[k, 1]]


@njit(cache=True)
def planar_rhs_packed(fbuf, ibuf, wbuf, ix, y, n, gamma_d, ydot, upto):
    """:func:`planar_rhs_into` on :func:`pack_planar`'s buffers (views made here: no per-array arguments)."""
    ints = (_v1(ibuf, ix, 0), _v1(ibuf, ix, 1), _v1(ibuf, ix, 2), _v1(ibuf, ix, 3), _v1(ibuf, ix, 4),
            _v1(ibuf, ix, 5), _v1(ibuf, ix, 6))
    floats = (view2(fbuf, ix[7, 0], ix[7, 1], ix[7, 2]), view2(fbuf, ix[8, 0], ix[8, 1], ix[8, 2]),
              view2(fbuf, ix[9, 0], ix[9, 1], ix[9, 2]), _v1(fbuf, ix, 10), _v1(fbuf, ix, 11), _v1(fbuf, ix, 12),
              _v1(fbuf, ix, 13), _v1(fbuf, ix, 14), _v1(fbuf, ix, 15), view2(fbuf, ix[16, 0], ix[16, 1], ix[16, 2]),
              view2(fbuf, ix[17, 0], ix[17, 1], ix[17, 2]), view2(fbuf, ix[18, 0], ix[18, 1], ix[18, 2]))
    o = 19
    work = (view2(wbuf, ix[o, 0], ix[o, 1], ix[o, 2]), view2(wbuf, ix[o + 1, 0], ix[o + 1, 1], ix[o + 1, 2]),
            view2(wbuf, ix[o + 2, 0], ix[o + 2, 1], ix[o + 2, 2]), view2(wbuf, ix[o + 3, 0], ix[o + 3, 1], ix[o + 3, 2]),
            _v1(wbuf, ix, o + 4), _v1(wbuf, ix, o + 5), view2(wbuf, ix[o + 6, 0], ix[o + 6, 1], ix[o + 6, 2]),
            view3(wbuf, ix[o + 7, 0], ix[o + 7, 1], ix[o + 7, 2], ix[o + 7, 3]), _v1(wbuf, ix, o + 8),
            view3(wbuf, ix[o + 9, 0], ix[o + 9, 1], ix[o + 9, 2], ix[o + 9, 3]),
            view2(wbuf, ix[o + 10, 0], ix[o + 10, 1], ix[o + 10, 2]),
            view2(wbuf, ix[o + 11, 0], ix[o + 11, 1], ix[o + 11, 2]),
            view2(wbuf, ix[o + 12, 0], ix[o + 12, 1], ix[o + 12, 2]),
            view3(wbuf, ix[o + 13, 0], ix[o + 13, 1], ix[o + 13, 2], ix[o + 13, 3]),
            view2(wbuf, ix[o + 14, 0], ix[o + 14, 1], ix[o + 14, 2]), _v1(wbuf, ix, o + 15))
    planar_rhs_into(ints, floats, y, n, gamma_d, ydot, work, upto)
