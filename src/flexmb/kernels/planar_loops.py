"""The loops' right-hand side of a planar model: :func:`~flexmb.kernels.loops.loop_rhs_into` on 3-vectors.

The solve of docs/theory.md, "Loops without the complement", with the
planar recursion of "A planar path (design, 2026-11-28)"
(:mod:`flexmb.kernels.planar`: motion vectors ``(w, vx, vy)`` and force
vectors ``(tau, fx, fy)``, Plucker about the inertial origin in the plane's
basis, 3 x 3 articulated inertias):

    xdd = a0 + A^-1 psi^T lambda,    K lambda = gamma - psi a0,

``a0`` by one backward and one forward pass, each row of psi as the two
planar wrenches it is made of (:func:`rows`; a driver's row a unit force
on its coordinate), and ``K = psi A^-1 psi^T`` summed over the subtrees
hanging from the ground within its band in the factoring order of the
rows' :class:`~flexmb.kernels.loop_layout.LoopLayout`, :data:`COLUMNS`
columns per sweep over a subtree's bodies (:func:`_loop_matrix`), exactly
as :func:`flexmb.kernels.constrained._loop_matrix` does on 6-vectors: O(n)
for a chain of loops (B7). K is factored and solved by the shared,
dimension-free :mod:`flexmb.kernels.constraint_matrix` (the same rank
filter, singular window and rank limit). ``lam`` are the reactions of the
spatial path, row for row, with its sign (``psi^T lam = A xdd - f``): a
planar row's wrenches are the spatial ones' in-plane components.

What it does not cover it hands back (:data:`HANDOFF`) to the spatial
path, which then gives the same numbers: a freedom that moves no mass (the
spatial path lifts it with an armature and refines, or names it), loads of
force elements evaluated in Python (``force0``, ``torque0``) and runs that
integrate the force elements' powers; :func:`~flexmb.kernels.loops.loop_rhs_into`
dispatches. Consumers that read the spatial factors or arrays from the
right-hand side's work afterwards (the loops' compiled ``J v``,
:mod:`flexmb.kernels.loop_jtimes`) keep calling the spatial
:func:`~flexmb.kernels.loops.loop_rhs_factors_into`.
"""

from __future__ import annotations

import numpy as np
from numba.extending import register_jitable

from .cache import njit
from .constrained import COLUMNS, MASSLESS
from .constraint_matrix import factor_constraint_matrix, solve_constraint_matrix
from .planar import _rot, backward, factor, forward, inertias, kinematics, loads
from .views import view2, view3

__all__ = ["HANDOFF", "planar_loop_rhs_into", "planar_loop_work_size", "rows"]

#: the status of :func:`planar_loop_rhs_into` for a model or a state it leaves to the spatial path
HANDOFF = -1


@register_jitable
def planar_loop_work_size(nb, n, m):
    """Length of the work array :func:`planar_loop_rhs_into` needs.

    Parameters
    ----------
    nb, n, m : int
        Numbers of bodies, speeds and rows.

    Returns
    -------
    int
        The length (at most :func:`~flexmb.kernels.loops.loop_rhs_work_size`'s).
    """
    return (37 + 8 * COLUMNS) * (nb + 1) + 2 * n + 8 * m


@njit(cache=True, inline="always")
def _views(nb, n, m, work):
    """The arrays of :func:`planar_loop_rhs_into` in its work (:func:`planar_loop_work_size`)."""
    Kin = view2(work, 0, nb + 1, 20)
    o = 20 * (nb + 1)
    pA, IA = view2(work, o, nb + 1, 3), view2(work, o + 3 * (nb + 1), nb + 1, 6)
    o += 9 * (nb + 1)
    UD, acc = view2(work, o, nb + 1, 4), view2(work, o + 4 * (nb + 1), nb + 1, 3)
    o += 7 * (nb + 1)
    uu, tau, arm = work[o : o + nb + 1], work[o + nb + 1 : o + nb + 1 + n], work[o + nb + 1 + n : o + nb + 1 + 2 * n]
    o += nb + 1 + 2 * n
    W = view3(work, o, m, 2, 3)
    gamma, residual = work[o + 6 * m : o + 7 * m], work[o + 7 * m : o + 8 * m]
    o += 8 * m
    P, dA = view3(work, o, nb + 1, COLUMNS, 3), view3(work, o + 3 * COLUMNS * (nb + 1), nb + 1, COLUMNS, 3)
    o += 6 * COLUMNS * (nb + 1)
    X, G = view2(work, o, nb + 1, COLUMNS), view2(work, o + COLUMNS * (nb + 1), nb + 1, COLUMNS)
    return Kin, pA, IA, UD, acc, uu, tau, arm, W, gamma, residual, P, dA, X, G


@njit(cache=True)
def rows(ints, floats, K, gamma_d, W, gamma):
    """Direction rows ``d . (P_j - P_i) = 0`` (d turning with body i) as two planar wrenches each, then drivers'.

    Parameters
    ----------
    ints, floats : tuple
        The planar model (:func:`flexmb.kernels.packing.unpack_planar`).
    K : ndarray, shape (n_bodies + 1, 20)
        The bodies' planar kinematics (:func:`~flexmb.kernels.planar.kinematics`).
    gamma_d : ndarray, shape (n_drivers,)
        The drivers' prescribed accelerations.
    W : ndarray, shape (m, 2, 3)
        Output: each cut row's wrenches on its bodies i and j (the
        spatial rows' in-plane components; zero for driver rows).
    gamma : ndarray, shape (m,)
        Output: minus the velocity-dependent part of each row's second
        derivative (the drivers': ``gamma_d``).
    """
    ri, rj = ints[4], ints[5]
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
        # on i the moment d x e and -d at P_i; on j +d at P_j
        W[a, 0, 0] = dx * ey - dy * ex - (Pix * dy - Piy * dx)
        W[a, 0, 1], W[a, 0, 2] = -dx, -dy
        W[a, 1, 0], W[a, 1, 1], W[a, 1, 2] = Pjx * dy - Pjy * dx, dx, dy
        wI, wJ = K[i, 7], K[j, 7]
        vix, viy = K[i, 8] - wI * Piy, K[i, 9] + wI * Pix  # the points' velocities
        vjx, vjy = K[j, 8] - wJ * Pjy, K[j, 9] + wJ * Pjx
        # the points' bias accelerations: a_O,bias + w x v_P (the angular bias is zero in the plane)
        aix, aiy = K[i, 17] - wI * viy, K[i, 18] + wI * vix
        ajx, ajy = K[j, 17] - wJ * vjy, K[j, 18] + wJ * vjx
        edx, edy = vjx - vix, vjy - viy
        gamma[a] = (wI * wI * (dx * ex + dy * ey) - 2.0 * wI * (-dy * edx + dx * edy) - dx * (ajx - aix)
                    - dy * (ajy - aiy))
    for a in range(W.shape[0] - nc):  # (none where the layout leaves the drivers out: a calibration's)
        W[nc + a, :, :] = 0.0
        gamma[nc + a] = gamma_d[a]


@njit(cache=True)
def _columns_solve(ints, K, UD, P, G, bodies, root_of, s, nc, X, dA):
    """``A^-1`` of ``nc`` load columns at once on subtree s (the planar twin of constrained._columns_solve).

    Column j loads body k with the force vectors ``-P[k, j]`` (overwritten:
    the subtree's articulated biases) and its coordinate with ``G[k, j]``;
    ``X[k, j]`` receives the acceleration of body k's coordinate, ``dA[k,
    j]`` its spatial acceleration (the ground's row, last, zero).
    """
    parent, coord = ints[0], ints[1]
    nb = parent.shape[0]
    for q in range(bodies.shape[0] - 1, -1, -1):
        k = bodies[q]
        if root_of[k] != s:
            continue
        S0, S1, S2 = K[k, 10], K[k, 11], K[k, 12]
        U0, U1, U2, Di = UD[k, 0], UD[k, 1], UD[k, 2], UD[k, 3]
        p = parent[k]
        for j in range(nc):
            u = (G[k, j] if coord[k] >= 0 else 0.0) - (S0 * P[k, j, 0] + S1 * P[k, j, 1] + S2 * P[k, j, 2])
            X[k, j] = u
            if p < nb:
                f = u * Di
                P[p, j, 0] += P[k, j, 0] + U0 * f
                P[p, j, 1] += P[k, j, 1] + U1 * f
                P[p, j, 2] += P[k, j, 2] + U2 * f
    for q in range(bodies.shape[0]):
        k = bodies[q]
        if root_of[k] != s:
            continue
        p = parent[k]
        for j in range(nc):
            a0, a1, a2 = dA[p, j, 0], dA[p, j, 1], dA[p, j, 2]
            x = (X[k, j] - (UD[k, 0] * a0 + UD[k, 1] * a1 + UD[k, 2] * a2)) * UD[k, 3]
            X[k, j] = x
            dA[k, j, 0], dA[k, j, 1], dA[k, j, 2] = a0 + K[k, 10] * x, a1 + K[k, 11] * x, a2 + K[k, 12] * x


@njit(cache=True)
def _row_times(W, body, coord_of, a, dA, X, j, root_of, s):
    """Subtree s's part of ``psi_a`` applied to column j's accelerations (``coord_of[a]``: a driver row's body)."""
    v = 0.0
    for side in range(2):
        k = body[a, side]
        if k >= 0 and root_of[k] == s:
            v += W[a, side, 0] * dA[k, j, 0] + W[a, side, 1] * dA[k, j, 1] + W[a, side, 2] * dA[k, j, 2]
    k = coord_of[a]
    if k >= 0 and root_of[k] == s:
        v += X[k, j]
    return v


@njit(cache=True)
def _loop_matrix(ints, K, UD, W, layout, coord_of, P, dA, X, G, tol, window, rank_limit):
    """``K = psi A^-1 psi^T`` within its band in the factoring order, factored (constrained._loop_matrix's twin).

    Returns (L or K's band in Kb, d, dfilt, kept, smallest, finite, V), as
    :func:`flexmb.kernels.constrained._loop_matrix`.
    """
    body, root_of, visit_ptr, visit = layout.row_body, layout.root_of, layout.visit_ptr, layout.visit
    root_ptr, root_rows, position, band = layout.root_ptr, layout.root_rows, layout.position, layout.band
    nb = ints[0].shape[0]
    m = W.shape[0]
    Kb = np.zeros((m, band + 1))
    dA[nb, :, :] = 0.0
    for s in range(root_ptr.shape[0] - 1):
        r0, r1 = root_ptr[s], root_ptr[s + 1]
        if r1 == r0:
            continue
        first = root_rows[r0]
        bodies = visit[visit_ptr[first] : visit_ptr[first + 1]]  # subtree s's bodies among them
        for j0 in range(r0, r1, COLUMNS):
            nc = min(COLUMNS, r1 - j0)
            for q in range(bodies.shape[0]):
                k = bodies[q]
                if root_of[k] == s:
                    P[k, :, :] = 0.0
                    G[k, :] = 0.0
            for j in range(nc):
                b = root_rows[j0 + j]
                for side in range(2):
                    k = body[b, side]
                    if k >= 0 and root_of[k] == s:
                        for i in range(3):
                            P[k, j, i] -= W[b, side, i]
                k = coord_of[b]
                if k >= 0 and root_of[k] == s:
                    G[k, j] = 1.0
            _columns_solve(ints, K, UD, P, G, bodies, root_of, s, nc, X, dA)
            for j in range(nc):  # K[a, b] on the lower band (a after b in the order), subtree s's part
                pb = position[root_rows[j0 + j]]
                for q in range(r0, r1):
                    a = root_rows[q]
                    pa = position[a]
                    if pa >= pb:
                        Kb[pa, pa - pb] += _row_times(W, body, coord_of, a, dA, X, j, root_of, s)
    diag = np.empty(m)
    finite = True
    for j in range(m):
        diag[j] = Kb[j, 0]
        for q in range(band + 1):
            finite = finite and np.isfinite(Kb[j, q])
    if not finite:
        return Kb, np.zeros(m), np.zeros(m), 0, 0.0, False, np.zeros((0, 0))
    d, dfilt, kept, smallest, V = factor_constraint_matrix(Kb, diag, band, tol, window, rank_limit)
    return Kb, d, dfilt, kept, smallest, True, V


@njit(cache=True)
def _psi_times(W, body, coord, a, acc, Kin, xdd, bias):
    """Row a of psi applied to accelerations: its wrenches . the bodies' spatial accelerations (less their bias)."""
    if coord[a] >= 0:
        return xdd[coord[a]]
    s = 0.0
    for side in range(2):
        k = body[a, side]
        if k >= 0:
            for t in range(3):
                s += W[a, side, t] * (acc[k, t] - (Kin[k, 16 + t] if bias else 0.0))
    return s


@njit(cache=True)
def planar_loop_rhs_into(ints, floats, coord_body, layout, y, nq, generalized0, gamma_d, tol, window, rank_limit,
                         xdd, lam, work):
    """Accelerations and reactions of a planar tree with loops at ``y``: loop_rhs_into's, on 3-vectors.

    Parameters
    ----------
    ints, floats : tuple
        The planar model (:func:`flexmb.kernels.packing.unpack_planar`).
    coord_body : ndarray of int, shape (n,)
        The body whose joint owns each coordinate.
    layout : LoopLayout
        The rows' layout (the planar rows in the spatial rows' order).
    y : ndarray, shape (>= nq + n,)
        Coordinates and speeds first.
    nq : int
        Number of coordinates (n: a planar model has no Euler parameters).
    generalized0 : ndarray, shape (n,)
        Generalized forces of the force elements evaluated in Python.
    gamma_d, tol, window, rank_limit
        As for :func:`~flexmb.kernels.loops.loop_rhs`.
    xdd : ndarray, shape (n,)
        Output: the accelerations.
    lam : ndarray, shape (m,)
        Output: the reactions (dropped rows: zero).
    work : ndarray, shape (>= planar_loop_work_size(n_bodies, n, m),)
        Scratch.

    Returns
    -------
    kept, smallest : int, float
        As :func:`~flexmb.kernels.loops.loop_rhs`.
    status : int
        As :func:`~flexmb.kernels.loops.loop_rhs` (0 or 2), or :data:`HANDOFF`
        where a freedom moves no mass (the spatial path lifts or names it).
    """
    n, m, nb = generalized0.shape[0], lam.shape[0], ints[0].shape[0]
    Kin, pA, IA, UD, acc, uu, tau, arm, W, gamma, residual, P, dA, X, G = _views(nb, n, m, work)
    x, xd = y[:nq], y[nq : nq + n]
    kinematics(ints, floats, x, xd, Kin)
    loads(ints, floats, x, xd, Kin, pA, tau)
    for c in range(n):
        tau[c] += generalized0[c]
    rows(ints, floats, Kin, gamma_d, W, gamma)
    inertias(floats, Kin, IA)
    arm[:] = 0.0
    if factor(ints, Kin, IA, UD, arm, MASSLESS, 0.0) >= 0:  # a freedom that moves no mass
        return 0, 0.0, HANDOFF
    body, coord = layout.row_body, layout.row_coord
    coord_of = np.full(m, -1, dtype=np.int64)  # a driver row's body
    for a in range(m):
        if coord[a] >= 0:
            coord_of[a] = coord_body[coord[a]]
    Kb, d, dfilt, kept, smallest, finite, V = _loop_matrix(ints, Kin, UD, W, layout, coord_of, P, dA, X, G, tol,
                                                           window, rank_limit)
    backward(ints, Kin, IA, UD, pA, tau, uu, True)
    forward(ints, Kin, UD, uu, True, acc, xdd)
    lam[:] = 0.0
    if not finite:
        return 0, 0.0, 2
    for a in range(m):
        residual[a] = -_psi_times(W, body, coord, a, acc, Kin, xdd, True)
    lam[:] = solve_constraint_matrix(Kb, d, dfilt, layout.band, layout.order, gamma, residual, V)
    # A^-1 psi^T lambda: one solve with every row's wrenches weighted by lambda
    pA[:, :] = 0.0
    tau[:] = 0.0
    for a in range(m):
        for side in range(2):
            k = body[a, side]
            if k >= 0:
                for t in range(3):
                    pA[k, t] -= lam[a] * W[a, side, t]
        if coord[a] >= 0:
            tau[coord[a]] += lam[a]
    backward(ints, Kin, IA, UD, pA, tau, uu, False)
    forward(ints, Kin, UD, uu, False, acc, tau)  # tau (read by backward) receives the response
    for c in range(n):
        xdd[c] += tau[c]
        if not np.isfinite(xdd[c]):
            return kept, smallest, 2
    return kept, smallest, 0
