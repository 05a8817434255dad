"""Accelerations of an open tree in O(n), without forming the mass matrix.

Kane's equations of an open tree (eqs. 1-5) read, coordinate by
coordinate, ``S_c . sum_{j after c} (I_j dA_j - B_j) = Q_c``: the axis of c
against the wrench the bodies after it need, where (in Plucker form about
the inertial origin) ``I_j`` is body j's spatial inertia, ``dA_j`` the part
of its spatial acceleration that the accelerations ``xdd`` produce
(``dA_j = dA_P + S_j xdd_j``), ``B_j`` its applied loads minus the
velocity-dependent inertia forces (the force array's wrench, eq. 3) and
``Q_c`` the generalized forces applied on coordinates. This is the
articulated-body recursion (Featherstone): one pass from the leaves in
condenses each subtree onto its joint, one pass from the ground out
solves each joint's few accelerations. All quantities are about the same
origin, so no frame transformations appear.
"""

from __future__ import annotations

import numpy as np
from numba.extending import register_jitable

from .cache import njit

from .dynamics import axis_projections, bias_wrenches, bias_wrenches_into, spatial_inertias, spatial_inertias_into
from .loads import apply_load_tables
from .packing import is_planar, unpack
from .planar import planar_open_rhs_into
from .tree import euler_parameter_rates, kinematics_work_size, tree_kinematics_into
from .views import view2, view3

__all__ = ["solve_spd", "articulated_factor", "articulated_factor_into", "articulated_solve", "articulated_solve_into",
           "articulated_accelerations", "open_tree_accelerations", "open_tree_rhs", "open_tree_rhs_into",
           "rhs_work_size", "mass_times"]


@njit(cache=True)
def solve_spd(D, rhs, out, tiny=0.0):
    """Solve the small symmetric positive definite ``D Z = rhs`` into ``out`` (Cholesky, column by column).

    Parameters
    ----------
    D : ndarray, shape (m, m)
        The matrix (its lower triangle is read).
    rhs, out : ndarray, shape (m, k)
        Right-hand sides and the solutions.
    tiny : float
        Cholesky pivots at or below it count as zero (default 0).

    Returns
    -------
    bool
        False if D is not positive definite (``out`` is then not valid).
    """
    m = D.shape[0]
    L = np.zeros((m, m))
    for j in range(m):
        s = D[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > tiny:
            return False
        L[j, j] = np.sqrt(s)
        for i in range(j + 1, m):
            s = D[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / L[j, j]
    ncol = rhs.shape[1]
    for col in range(ncol):
        for i in range(m):
            s = rhs[i, col]
            for k in range(i):
                s -= L[i, k] * out[k, col]
            out[i, col] = s / L[i, i]
        for i in range(m - 1, -1, -1):
            s = out[i, col]
            for k in range(i + 1, m):
                s -= L[k, i] * out[k, col]
            out[i, col] = s / L[i, i]
    return True


@njit(cache=True)
def _minus_bias_wrenches(nb, r, force, torque):
    """Minus the wrenches ``B_k`` about the origin (eq. 3's loads and velocity terms, Plucker form); the ground's row (last) zero."""
    pA = np.empty((nb + 1, 6))
    _minus_bias_wrenches_into(nb, r, force, torque, pA)
    return pA


@njit(cache=True)
def _minus_bias_wrenches_into(nb, r, force, torque, pA):
    """:func:`_minus_bias_wrenches` into ``pA`` (n_bodies + 1, 6)."""
    pA[nb] = 0.0
    for k in range(nb):
        pA[k, 0] = -(torque[k, 0] + r[k, 1] * force[k, 2] - r[k, 2] * force[k, 1])
        pA[k, 1] = -(torque[k, 1] + r[k, 2] * force[k, 0] - r[k, 0] * force[k, 2])
        pA[k, 2] = -(torque[k, 2] + r[k, 0] * force[k, 1] - r[k, 1] * force[k, 0])
        pA[k, 3] = -force[k, 0]
        pA[k, 4] = -force[k, 1]
        pA[k, 5] = -force[k, 2]


@njit(cache=True, inline="always")
def _joint_axes(k, c0, c1, IA, Sw, Sv, U):
    """``U_c = I^A_k S_c`` for the coordinates of body k's joint."""
    for c in range(c0, c1):
        for i in range(6):
            U[c, i] = (IA[k, i, 0] * Sw[c, 0] + IA[k, i, 1] * Sw[c, 1] + IA[k, i, 2] * Sw[c, 2]
                       + IA[k, i, 3] * Sv[c, 0] + IA[k, i, 4] * Sv[c, 1] + IA[k, i, 5] * Sv[c, 2])


@njit(cache=True)
def articulated_factor(parent, coord_start, spatial, Sw, Sv, armature, floor=0.0, lift=0.0):
    """The articulated-body inertias of a tree, condensed from the leaves in (Featherstone).

    ``I^A_k`` is body k's spatial inertia plus its children's, each
    condensed onto its joint: ``I^a = I^A - U D^-1 U^T`` with ``U = I^A S``
    and ``D = S^T I^A S + diag(armature)``. What a solve needs is kept per
    coordinate: ``U``, ``D^-1 U^T`` and the rows of ``D^-1``.

    Parameters
    ----------
    parent : ndarray of int, shape (n_bodies,)
        Parent body (-1: ground); parents come before children.
    coord_start : ndarray of int, shape (n_bodies + 1,)
        Coordinate ranges of the tree joints.
    spatial : ndarray, shape (n_bodies, 6, 6)
        Spatial inertias about the origin.
    Sw, Sv : ndarray, shape (n, 3)
        Plucker axes of the coordinates.
    armature : ndarray, shape (n,)
        Diagonal added to A (zeros for the equations of motion).
    floor : float
        A joint inertia (pivot of D) at or below ``floor`` times the
        largest entry ``s`` of the body's articulated inertia counts as
        zero: a freedom that moves no mass, up to round-off (default 0: only
        a pivot <= 0 does).
    lift : float
        If > 0, such a joint is not reported: ``lift * s`` is added to
        its coordinates' entries of ``armature`` (in place) and to D, so
        that the factors are those of ``A + diag(armature)``.

    Returns
    -------
    U : ndarray, shape (n, 6)
        ``I^A S``, one row per coordinate.
    DinvUT : ndarray, shape (n, 6)
        ``D^-1 U^T``, one row per coordinate.
    Dinv : ndarray, shape (n, 6)
        Row a of the joint's ``D^-1`` on its coordinate ``c0 + a`` (columns
        beyond the joint's freedoms unused).
    bad : int
        -1, or the body whose joint has a singular articulated inertia
        (a freedom without mass or inertia); the factors are then not valid.
    """
    n = Sw.shape[0]
    U, DinvUT, Dinv = np.empty((n, 6)), np.empty((n, 6)), np.empty((n, 6))
    bad = articulated_factor_into(parent, coord_start, spatial, Sw, Sv, armature, floor, lift, spatial.copy(), U,
                                  DinvUT, Dinv)
    return U, DinvUT, Dinv, bad


@njit(cache=True)
def articulated_factor_into(parent, coord_start, spatial, Sw, Sv, armature, floor, lift, IA, U, DinvUT, Dinv):
    """:func:`articulated_factor` into given arrays; returns ``bad``.

    Parameters
    ----------
    parent, coord_start, spatial, Sw, Sv, armature, floor, lift
        As :func:`articulated_factor`.
    IA : ndarray, shape (n_bodies, 6, 6)
        Scratch: the articulated inertias (``spatial`` is copied into it).
    U, DinvUT, Dinv : ndarray, shape (n, 6)
        Outputs: the factors (:func:`articulated_factor`).

    Returns
    -------
    int
        -1, or the body whose joint has a singular articulated inertia.
    """
    nb = parent.shape[0]
    IA[:] = spatial
    Dinv[:] = 0.0
    for k in range(nb - 1, -1, -1):
        c0, c1 = coord_start[k], coord_start[k + 1]
        m = c1 - c0
        _joint_axes(k, c0, c1, IA, Sw, Sv, U)
        tiny = 0.0
        if floor > 0.0 and m:  # I^A is positive semi-definite: its largest entry is on the diagonal
            for i in range(6):
                tiny = max(tiny, abs(IA[k, i, i]))
            tiny *= floor
        # D^-1 stays in this loop: moved into a helper (inlined or not), it slowed the recursion
        if m == 1:  # one freedom (most joints): D is a number, nothing to factor
            d = (Sw[c0, 0] * U[c0, 0] + Sw[c0, 1] * U[c0, 1] + Sw[c0, 2] * U[c0, 2]
                 + Sv[c0, 0] * U[c0, 3] + Sv[c0, 1] * U[c0, 4] + Sv[c0, 2] * U[c0, 5]) + armature[c0]
            if not d > tiny and lift > 0.0:
                armature[c0] += lift * tiny / floor
                d += lift * tiny / floor
            if not d > tiny:
                return k
            for i in range(6):
                DinvUT[c0, i] = U[c0, i] / d
            Dinv[c0, 0] = 1.0 / d
        elif m:
            D = np.empty((m, m))
            rhs = np.zeros((m, 6 + m))
            for a in range(m):
                ca = c0 + a
                for b in range(m):
                    cb = c0 + b
                    D[a, b] = (Sw[ca, 0] * U[cb, 0] + Sw[ca, 1] * U[cb, 1] + Sw[ca, 2] * U[cb, 2]
                               + Sv[ca, 0] * U[cb, 3] + Sv[ca, 1] * U[cb, 4] + Sv[ca, 2] * U[cb, 5])
                D[a, a] += armature[ca]
                for i in range(6):
                    rhs[a, i] = U[ca, i]
                rhs[a, 6 + a] = 1.0
            sol = np.empty((m, 6 + m))
            ok = solve_spd(D, rhs, sol, tiny)
            if not ok and lift > 0.0:
                for a in range(m):
                    armature[c0 + a] += lift * tiny / floor
                    D[a, a] += lift * tiny / floor
                ok = solve_spd(D, rhs, sol, tiny)
            if not ok:
                return k
            for a in range(m):
                for i in range(6):
                    DinvUT[c0 + a, i] = sol[a, i]
                for b in range(m):
                    Dinv[c0 + a, b] = sol[a, 6 + b]
        p = parent[k]
        if p >= 0:  # I^a = I^A - U D^-1 U^T, added to the parent
            for i in range(6):
                for j in range(6):
                    s = IA[k, i, j]
                    for c in range(c0, c1):
                        s -= U[c, i] * DinvUT[c, j]
                    IA[p, i, j] += s
    return -1


@njit(cache=True)
def articulated_solve(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, pA, generalized, bodies, xdd, dA):
    """One solve with the factors of :func:`articulated_factor`: accelerations from loads.

    From the leaves in, each joint's ``u = Q - S^T p^A`` and the bias
    ``p^a = p^A + U D^-1 u`` added to the parent's; from the ground out,
    ``xdd = D^-1 u - D^-1 U^T dA_P`` and ``dA_k = dA_P + S_k xdd_k``.

    Parameters
    ----------
    parent, coord_start : ndarray of int
        The tree layout.
    Sw, Sv : ndarray, shape (n, 3)
        Plucker axes of the coordinates.
    U, DinvUT, Dinv : ndarray, shape (n, 6)
        The factors.
    pA : ndarray, shape (n_bodies + 1, 6)
        Minus each body's applied wrench (Plucker, about the origin);
        overwritten (the subtrees' biases), on ``bodies`` only.
    generalized : ndarray, shape (n,)
        Generalized forces applied on the coordinates (read on ``bodies``'
        coordinates only).
    bodies : ndarray of int
        The bodies to visit, increasing: all of them, or whole subtrees
        hanging from the ground (a load on them moves no other body).
    xdd : ndarray, shape (n,)
        The accelerations, written on ``bodies``' coordinates.
    dA : ndarray, shape (n_bodies + 1, 6)
        Spatial accelerations, written on ``bodies`` (the ground's row,
        last, must be zero).
    """
    articulated_solve_into(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, pA, generalized, bodies, bodies.shape[0],
                           xdd, dA, np.empty(6))


@njit(cache=True)
def articulated_solve_into(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, pA, generalized, bodies, count, xdd, dA, u):
    """:func:`articulated_solve` on ``bodies[:count]`` (or on bodies ``0 ... count - 1`` if ``bodies`` is empty), scratch ``u`` (6,).

    Parameters
    ----------
    parent, coord_start, Sw, Sv, U, DinvUT, Dinv, pA, generalized, xdd, dA
        As :func:`articulated_solve`.
    bodies : ndarray of int
        The bodies to visit, increasing; empty: all of them.
    count : int
        How many.
    u : ndarray, shape (6,)
        Scratch.
    """
    nb = parent.shape[0]
    every = bodies.shape[0] == 0
    for q in range(count - 1, -1, -1):
        k = q if every else bodies[q]
        c0, c1 = coord_start[k], coord_start[k + 1]
        for c in range(c0, c1):
            u[c - c0] = generalized[c] - (Sw[c, 0] * pA[k, 0] + Sw[c, 1] * pA[k, 1] + Sw[c, 2] * pA[k, 2]
                                          + Sv[c, 0] * pA[k, 3] + Sv[c, 1] * pA[k, 4] + Sv[c, 2] * pA[k, 5])
        for c in range(c0, c1):  # D^-1 u, kept in xdd until the outward pass
            s = 0.0
            for b in range(c1 - c0):
                s += Dinv[c, b] * u[b]
            xdd[c] = s
        p = parent[k]
        if p >= 0:
            for i in range(6):
                s = pA[k, i]
                for c in range(c0, c1):
                    s += U[c, i] * xdd[c]
                pA[p, i] += s
    for q in range(count):
        k = q if every else bodies[q]
        p = parent[k]
        if p < 0:
            p = nb
        for i in range(6):
            dA[k, i] = dA[p, i]
        for c in range(coord_start[k], coord_start[k + 1]):
            s = xdd[c]
            for i in range(6):
                s -= DinvUT[c, i] * dA[p, i]
            xdd[c] = s
        for c in range(coord_start[k], coord_start[k + 1]):
            for i in range(3):
                dA[k, i] += Sw[c, i] * xdd[c]
                dA[k, 3 + i] += Sv[c, i] * xdd[c]


@njit(cache=True)
def articulated_accelerations(parent, coord_start, spatial, Sw, Sv, r, force, torque, generalized, armature):
    """Solve ``(A + diag(armature)) xdd = f`` of an open tree by the articulated-body recursion.

    With ``armature = 0`` this is eq. 3 solved for the accelerations; a
    positive armature on a coordinate adds to its joint's inertia
    ``D = S^T I^A S`` exactly as ``A + diag(armature)`` would (the Newton
    matrices of implicit integrators, ``A + a C + b K`` with diagonal
    coordinate dampers C and springs K, are of this form).
    :func:`articulated_factor`, then :func:`articulated_solve`.

    Parameters
    ----------
    parent : ndarray of int, shape (n_bodies,)
        Parent body (-1: ground); parents come before children.
    coord_start : ndarray of int, shape (n_bodies + 1,)
        Coordinate ranges of the tree joints.
    spatial : ndarray, shape (n_bodies, 6, 6)
        Spatial inertias about the origin.
    Sw, Sv : ndarray, shape (n, 3)
        Plucker axes of the coordinates.
    r : ndarray, shape (>= n_bodies, 3)
        Mass centres.
    force, torque : ndarray, shape (>= n_bodies, 3)
        Applied loads minus the velocity-dependent inertia forces, at the
        mass centres (:func:`flexmb.kernels.dynamics.bias_wrenches`).
    generalized : ndarray, shape (n,)
        Generalized forces applied on the coordinates.
    armature : ndarray, shape (n,)
        Diagonal added to A (zeros for the equations of motion).

    Returns
    -------
    xdd : ndarray, shape (n,)
        Accelerations.
    bad : int
        -1, or the body whose joint has a singular articulated inertia
        (a freedom without mass or inertia); xdd is then not valid.
    """
    nb = parent.shape[0]
    n = Sw.shape[0]
    U, DinvUT, Dinv, bad = articulated_factor(parent, coord_start, spatial, Sw, Sv, armature)
    if bad >= 0:
        return np.zeros(n), bad
    pA = _minus_bias_wrenches(nb, r, force, torque)
    xdd = np.empty(n)
    articulated_solve(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, pA, generalized,
                      np.arange(nb), xdd, np.zeros((nb + 1, 6)))
    return xdd, -1


@njit(cache=True)
def open_tree_accelerations(parent, coord_start, R, r, omega, alpha_bias, a_bias, mass, inertia, Sw, Sv, force,
                            torque, generalized, armature):
    """Eq. 3 of an open tree solved for xdd from the kinematics and the applied loads, in one call.

    The spatial inertias (:func:`~flexmb.kernels.dynamics.spatial_inertias`),
    the loads minus the velocity-dependent inertia forces
    (:func:`~flexmb.kernels.dynamics.bias_wrenches`) and
    :func:`articulated_accelerations`, fused so that an evaluation crosses
    from Python into compiled code once.

    Parameters
    ----------
    parent, coord_start : ndarray of int
        The tree layout.
    R, r, omega, alpha_bias, a_bias : ndarray
        Kinematics, one row per body and the ground last.
    mass : ndarray, shape (n_bodies,)
        Masses.
    inertia : ndarray, shape (n_bodies, 3, 3)
        Central inertias in the body frames.
    Sw, Sv : ndarray, shape (n, 3)
        Plucker axes of the coordinates.
    force, torque : ndarray, shape (n_bodies + 1, 3)
        Applied loads at the mass centres.
    generalized : ndarray, shape (n,)
        Generalized forces applied on the coordinates.
    armature : ndarray, shape (n,)
        Diagonal added to A (zeros for the equations of motion).

    Returns
    -------
    xdd : ndarray, shape (n,)
        Accelerations.
    bad : int
        -1, or the body whose joint has a singular articulated inertia.
    """
    Iw, spatial = spatial_inertias(R, r, mass, inertia)
    f, t = bias_wrenches(mass, Iw, omega, alpha_bias, a_bias, force, torque)
    return articulated_accelerations(parent, coord_start, spatial, Sw, Sv, r, f, t, generalized, armature)


@njit(cache=True)
def open_tree_rhs(packed, y, nq, armature):
    """The state derivative of an open tree whose loads are all compiled, in one call.

    :func:`~flexmb.kernels.tree.tree_kinematics`, the built-in loads
    (:func:`~flexmb.kernels.loads.apply_load_tables`) and
    :func:`open_tree_accelerations`: the right-hand side of a model without
    plugin joints or Python force elements, with nothing boxed in between.

    Parameters
    ----------
    packed : tuple
        The model's constant arrays (:func:`~flexmb.kernels.packing.pack`:
        four buffers, where numba's dispatch of the separate arrays would
        cost more than this kernel at a few bodies).
    y : ndarray, shape (nq + n + k,)
        The state ``(q, u, ...)``; entries past ``nq + n`` are not read.
    nq : int
        Number of coordinates q (n, the speeds', is that of ``armature``).
    armature : ndarray, shape (n,)
        Diagonal added to A (zeros for the equations of motion).

    Returns
    -------
    ydot : ndarray, shape (nq + n,)
        ``(qd, ud)``, ``qd = W(q) u``
        (:func:`~flexmb.kernels.tree.euler_parameter_rates`).
    status : int
        -1 if ``ydot`` is finite, -2 if not, or the body whose joint has a
        singular articulated inertia.
    """
    n, nb = armature.shape[0], packed[3][0, 1]  # the parents' count: the number of bodies
    ydot = np.empty(nq + n)
    status = open_tree_rhs_into(packed, y, nq, armature, ydot, np.empty(rhs_work_size(nb, n)))
    return ydot, status


@register_jitable
def rhs_work_size(nb, n):
    """Length of the work array :func:`open_tree_rhs_into` needs.

    Parameters
    ----------
    nb, n : int
        Numbers of bodies and of speeds.

    Returns
    -------
    int
        The length.
    """
    return 48 * (nb + 1) + 87 * nb + 26 * n + 6 + kinematics_work_size(nb, n)


@njit(cache=True)
def open_tree_rhs_into(packed, y, nq, armature, ydot, work):
    """:func:`open_tree_rhs` into ``ydot``, with scratch ``work``: nothing allocated (what CVODE's callback calls).

    Parameters
    ----------
    packed, y, nq, armature
        As :func:`open_tree_rhs`.
    ydot : ndarray, shape (>= nq + n,)
        Output: ``(qd, ud)`` in its first ``nq + n`` entries.
    work : ndarray, shape (>= rhs_work_size(n_bodies, n),)
        Scratch (its contents on entry are not read).

    Returns
    -------
    int
        The status of :func:`open_tree_rhs`.
    """
    if is_planar(packed):  # the model moves in one plane: 3-vectors (flexmb.kernels.planar)
        return planar_open_rhs_into(packed, y, nq, armature, ydot, work)
    tree, tables, _ = unpack(packed)
    n = armature.shape[0]
    nb = tree.parent.shape[0]
    x, xd = y[:nq], y[nq : nq + n]
    R = view3(work, 0, nb + 1, 3, 3)
    o = 9 * (nb + 1)
    kin = view3(work, o, 7, nb + 1, 3)  # origin, r, omega, v, alpha, acc, jp
    o += 21 * (nb + 1)
    Sw, Sv = view2(work, o, n, 3), view2(work, o + 3 * n, n, 3)
    o += 6 * n
    m = kinematics_work_size(nb, n)
    empty3 = view2(work, 0, 0, 3)
    tree_kinematics_into(tree.parent, tree.coord_start, tree.coord_kind, tree.coord_axis, tree.external,
                         tree.parent_frame, tree.child_frame, tree.lever, tree.child_point, tree.com, x, xd,
                         view3(work, 0, 0, 3, 3), empty3, empty3, empty3, empty3, empty3, R, kin[0], kin[1],
                         kin[2], kin[3], kin[4], kin[5], kin[6], Sw, Sv, work[o : o + m])
    o += m
    origin, r, omega, v, alpha, acc = kin[0], kin[1], kin[2], kin[3], kin[4], kin[5]
    loads = work[o : o + 6 * (nb + 1) + n]  # force, torque, generalized
    loads[:] = 0.0
    force, torque = view2(loads, 0, nb + 1, 3), view2(loads, 3 * (nb + 1), nb + 1, 3)
    generalized = loads[6 * (nb + 1) :]
    o += 6 * (nb + 1) + n
    apply_load_tables(tables, tree.mass, R, origin, r, omega, v, x, xd, force, torque, generalized, work[:0])
    Iw, spatial = view3(work, o, nb, 3, 3), view3(work, o + 9 * nb, nb, 6, 6)
    IA = view3(work, o + 45 * nb, nb, 6, 6)
    f, t = view2(work, o + 81 * nb, nb, 3), view2(work, o + 84 * nb, nb, 3)
    o += 87 * nb
    U, DinvUT = view2(work, o, n, 6), view2(work, o + 6 * n, n, 6)
    Dinv = view2(work, o + 12 * n, n, 6)
    xdd = work[o + 18 * n : o + 19 * n]
    o += 19 * n
    pA, dA = view2(work, o, nb + 1, 6), view2(work, o + 6 * (nb + 1), nb + 1, 6)
    u = work[o + 12 * (nb + 1) : o + 12 * (nb + 1) + 6]
    spatial_inertias_into(R, r, tree.mass, tree.inertia, Iw, spatial)
    bias_wrenches_into(tree.mass, Iw, omega, alpha, acc, force, torque, f, t)
    bad = articulated_factor_into(tree.parent, tree.coord_start, spatial, Sw, Sv, armature, 0.0, 0.0, IA, U, DinvUT,
                                  Dinv)
    xdd[:] = 0.0
    if bad < 0:
        _minus_bias_wrenches_into(nb, r, f, t, pA)
        dA[nb] = 0.0
        articulated_solve_into(tree.parent, tree.coord_start, Sw, Sv, U, DinvUT, Dinv, pA, generalized,
                               tree.parent[:0], nb, xdd, dA, u)
    status = bad
    for i in range(n):
        ydot[i] = xd[i]
        ydot[nq + i] = xdd[i]
        if status == -1 and not (np.isfinite(xdd[i]) and np.isfinite(xd[i])):
            status = -2
    if nq > n:
        euler_parameter_rates(tree.coord_start, tree.coord_kind, tree.coord_axis, x, xd, ydot)
    return status


@njit(cache=True)
def mass_times(parent, coord_start, coord_body, spatial, Sw, Sv, u):
    """``A u`` for an open tree or the tree of a model with loops, in O(n), A never formed.

    The accelerations ``u`` give the bodies the spatial accelerations
    ``dA_k = dA_P + S_k u_k``; ``(A u)_c`` is the axis of c against the
    inertia wrench ``sum I_j dA_j`` of the bodies after it (eq. 2).

    Parameters
    ----------
    parent : ndarray of int, shape (n_bodies,)
        Parent body (-1: ground).
    coord_start : ndarray of int, shape (n_bodies + 1,)
        Coordinate ranges of the tree joints.
    coord_body : ndarray of int, shape (n,)
        Body whose tree joint owns each coordinate.
    spatial : ndarray, shape (n_bodies, 6, 6)
        Spatial inertias about the origin.
    Sw, Sv : ndarray, shape (n, 3)
        Plucker axes of the coordinates.
    u : ndarray, shape (n,)
        The vector to multiply.

    Returns
    -------
    ndarray, shape (n,)
        ``A u``.
    """
    nb = parent.shape[0]
    dA = np.zeros((nb + 1, 6))
    W = np.empty((nb, 6))
    for k in range(nb):
        p = parent[k]
        if p < 0:
            p = nb
        for i in range(6):
            dA[k, i] = dA[p, i]
        for c in range(coord_start[k], coord_start[k + 1]):
            for i in range(3):
                dA[k, i] += Sw[c, i] * u[c]
                dA[k, 3 + i] += Sv[c, i] * u[c]
        for i in range(6):
            s = 0.0
            for j in range(6):
                s += spatial[k, i, j] * dA[k, j]
            W[k, i] = s
    return axis_projections(parent, coord_body, Sw, Sv, W)
