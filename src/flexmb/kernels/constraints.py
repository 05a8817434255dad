"""Loop-closure rows of the cut joints: phi, psi, b and gamma (eqs. 28-29).

Three kinds of rows (see :mod:`flexmb.joints`), each evaluated for all cut
joints of the model in one loop:

* point rows: ``P_i - P_j = 0`` (3 rows), the two marker points coincide;
* direction rows: ``d . (P_j - P_i) = 0`` with ``d`` a parent marker axis;
* perpendicularity rows: ``a . b = 0`` for a parent and a child marker axis.

A row of psi is the partial velocity of its residual (eq. 29). Each row
touches two bodies, and its partials on each are those of one spatial
wrench ``W = (tau, F)`` (Plucker, about the inertial origin): a point
weight ``F`` at ``P`` gives ``F . (S_v + S_w x P) = (P x F, F) . (S_w, S_v)``,
an angular weight ``tau`` gives ``tau . S_w``. So a row is two
(body, wrench) pairs (:func:`cut_row_wrenches`), ``psi_a xd = W_a0 . V_i +
W_a1 . V_j`` with ``V_k`` the spatial velocity of body k; the dense row
(:func:`cut_rows`) sums ``S_c . W`` over the coordinates on each body's
path from the ground, walked through the parent array. The pairs are also
what the articulated-body strategy applies as loads
(:mod:`flexmb.kernels.loops`). Cut-joint rows are scleronomic, so ``b = 0``; ``gamma`` is minus the
velocity-dependent part of the residual's second derivative.
"""

from __future__ import annotations

import numpy as np
from .cache import njit

from .tree import _cross_to, _mv_to

__all__ = ["cut_rows", "cut_row_wrenches", "cut_row_wrenches_into", "scatter_rows", "ROWS_SCRATCH"]


@njit(cache=True, inline="always")
def _dot3(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True, inline="always")
def _set_point_wrench(wrench, row, side, sign, p, weight):
    """``wrench[row, side] += sign * (p x weight, weight)``: a point weight's partials as a wrench."""
    wrench[row, side, 0] += sign * (p[1] * weight[2] - p[2] * weight[1])
    wrench[row, side, 1] += sign * (p[2] * weight[0] - p[0] * weight[2])
    wrench[row, side, 2] += sign * (p[0] * weight[1] - p[1] * weight[0])
    for a in range(3):
        wrench[row, side, 3 + a] += sign * weight[a]


@njit(cache=True, inline="always")
def _set_angular_wrench(wrench, row, side, sign, weight):
    """``wrench[row, side] += sign * (weight, 0)``: an angular weight's partials as a wrench."""
    for a in range(3):
        wrench[row, side, a] += sign * weight[a]


@njit(cache=True)
def scatter_rows(psi, wrench, body, parent, coord_start, Sw, Sv):
    """Add the dense rows ``psi[a, c] += S_c . W`` of (body, wrench) pairs, over each body's path.

    Parameters
    ----------
    psi : ndarray, shape (m, n)
        Rows to add to.
    wrench : ndarray, shape (m, 2, 6)
        Each row's two wrenches (Plucker: moment about the origin, force).
    body : ndarray of int, shape (m, 2)
        The bodies they act on (-1: the ground, no partials).
    parent, coord_start : ndarray of int
        The tree layout.
    Sw, Sv : ndarray, shape (n, 3)
        Plucker axes of the coordinates.
    """
    for a in range(wrench.shape[0]):
        for side in range(2):
            k = body[a, side]
            w = wrench[a, side]
            while k >= 0:
                for c in range(coord_start[k], coord_start[k + 1]):
                    psi[a, c] += (w[0] * Sw[c, 0] + w[1] * Sw[c, 1] + w[2] * Sw[c, 2]
                                  + w[3] * Sv[c, 0] + w[4] * Sv[c, 1] + w[5] * Sv[c, 2])
                k = parent[k]


@njit(cache=True, inline="always")
def _point(out, R, origin, k, local):
    _mv_to(out, R[k], local)
    for i in range(3):
        out[i] += origin[k, i]


@njit(cache=True)
def _bias_acceleration(out, k, p, r, omega, alpha_bias, a_bias, tmp):
    """``a_bias + alpha_bias x l + omega x (omega x l)``, ``l = p - r_k``: the point's acceleration at xdd = 0.

    ``tmp`` (9,) is scratch.
    """
    lever, t1, t2 = tmp[0:3], tmp[3:6], tmp[6:9]
    for i in range(3):
        lever[i] = p[i] - r[k, i]
    _cross_to(t1, alpha_bias[k], lever)
    _cross_to(t2, omega[k], lever)
    _cross_to(out, omega[k], t2)
    for i in range(3):
        out[i] += a_bias[k, i] + t1[i]


@njit(cache=True)
def _velocity(out, k, p, r, omega, v, lever):
    """``v_k + omega_k x (p - r_k)`` (``lever`` (3,) scratch)."""
    for i in range(3):
        lever[i] = p[i] - r[k, i]
    _cross_to(out, omega[k], lever)
    for i in range(3):
        out[i] += v[k, i]


@njit(cache=True, inline="always")
def _point_rows(level, row, phi, wrench, body, gamma, R, origin, r, omega, alpha_bias, a_bias, pt_i, pt_pi, pt_j,
                pt_pj, tmp):
    """Point rows ``P_i - P_j = 0`` (eq. 28), their psi (eq. 29) and gamma, from ``row`` on; returns the next row.

    ``tmp`` (>= 30,) is scratch; ``body`` is written only if not empty.
    """
    Pi, Pj, t1, t2, unit = tmp[0:3], tmp[3:6], tmp[6:9], tmp[9:12], tmp[12:21]
    unit[:] = 0.0
    for a in range(3):
        unit[4 * a] = 1.0
    for q in range(pt_i.shape[0]):
        i, j = pt_i[q], pt_j[q]
        _point(Pi, R, origin, i, pt_pi[q])
        _point(Pj, R, origin, j, pt_pj[q])
        if level >= 2:
            _bias_acceleration(t1, i, Pi, r, omega, alpha_bias, a_bias, tmp[21:30])
            _bias_acceleration(t2, j, Pj, r, omega, alpha_bias, a_bias, tmp[21:30])
        for a in range(3):
            phi[row + a] = Pi[a] - Pj[a]
            if level >= 1:
                if body.shape[0]:
                    body[row + a, 0], body[row + a, 1] = i, j
                _set_point_wrench(wrench, row + a, 0, 1.0, Pi, unit[3 * a : 3 * a + 3])
                _set_point_wrench(wrench, row + a, 1, -1.0, Pj, unit[3 * a : 3 * a + 3])
            if level >= 2:
                gamma[row + a] = -(t1[a] - t2[a])
        row += 3
    return row


@njit(cache=True, inline="always")
def _direction_bias(i, j, Pi, Pj, d, e, de, r, omega, v, alpha_bias, a_bias, tmp):
    """The velocity-dependent part of ``d/dt^2 (d . e)`` of a direction row, ``e = P_j - P_i`` (minus gamma).

    ``tmp`` (>= 21,) is scratch.
    """
    t1, t2, t3, t4, more = tmp[0:3], tmp[3:6], tmp[6:9], tmp[9:12], tmp[12:21]
    wi = omega[i]
    # edot, ebias: relative velocity and bias acceleration of the points
    _velocity(t1, j, Pj, r, omega, v, more[:3])
    _velocity(t2, i, Pi, r, omega, v, more[:3])
    for a in range(3):
        t1[a] -= t2[a]  # edot
    _bias_acceleration(t2, j, Pj, r, omega, alpha_bias, a_bias, more)
    _bias_acceleration(t3, i, Pi, r, omega, alpha_bias, a_bias, more)
    for a in range(3):
        t2[a] -= t3[a]  # ebias
    _cross_to(t3, wi, d)  # wd = w_i x d
    bias = _dot3(alpha_bias[i], de) + _dot3(t3, t1) + _dot3(d, t2)
    _cross_to(t4, t3, e)
    _cross_to(t2, d, t1)
    for a in range(3):
        t4[a] += t2[a]
    bias += _dot3(wi, t4)
    return bias


@njit(cache=True, inline="always")
def _direction_rows(level, row, phi, wrench, body, gamma, R, origin, r, omega, v, alpha_bias, a_bias, dr_i, dr_pi,
                    dr_ai, dr_j, dr_pj, tmp):
    """Direction rows ``d . (P_j - P_i) = 0`` (eq. 28), their psi (eq. 29) and gamma; returns the next row.

    ``tmp`` (>= 36,) is scratch; ``body`` is written only if not empty.
    """
    Pi, Pj, e, d, de = tmp[0:3], tmp[3:6], tmp[6:9], tmp[9:12], tmp[12:15]
    for q in range(dr_i.shape[0]):
        i, j = dr_i[q], dr_j[q]
        _point(Pi, R, origin, i, dr_pi[q])
        _point(Pj, R, origin, j, dr_pj[q])
        _mv_to(d, R[i], dr_ai[q])
        for a in range(3):
            e[a] = Pj[a] - Pi[a]
        phi[row] = _dot3(d, e)
        _cross_to(de, d, e)
        if level >= 1:
            if body.shape[0]:
                body[row, 0], body[row, 1] = i, j
            _set_angular_wrench(wrench, row, 0, 1.0, de)
            _set_point_wrench(wrench, row, 0, -1.0, Pi, d)
            _set_point_wrench(wrench, row, 1, 1.0, Pj, d)
        if level >= 2:
            gamma[row] = -_direction_bias(i, j, Pi, Pj, d, e, de, r, omega, v, alpha_bias, a_bias, tmp[15:36])
        row += 1
    return row


@njit(cache=True, inline="always")
def _perpendicular_rows(level, row, phi, wrench, body, gamma, R, omega, alpha_bias, pp_i, pp_ai, pp_j, pp_bj, tmp):
    """Perpendicularity rows ``a . b = 0`` (eq. 28), their psi (eq. 29) and gamma; returns the next row.

    ``tmp`` (>= 18,) is scratch; ``body`` is written only if not empty.
    """
    va, vb, ab, t1, t2, t3 = tmp[0:3], tmp[3:6], tmp[6:9], tmp[9:12], tmp[12:15], tmp[15:18]
    for q in range(pp_i.shape[0]):
        i, j = pp_i[q], pp_j[q]
        _mv_to(va, R[i], pp_ai[q])
        _mv_to(vb, R[j], pp_bj[q])
        phi[row] = _dot3(va, vb)
        _cross_to(ab, va, vb)
        if level >= 1:
            if body.shape[0]:
                body[row, 0], body[row, 1] = i, j
            _set_angular_wrench(wrench, row, 0, 1.0, ab)
            _set_angular_wrench(wrench, row, 1, -1.0, ab)
        if level >= 2:
            wi, wj = omega[i], omega[j]
            _cross_to(t1, wi, va)
            _cross_to(t2, t1, vb)  # (w_i x a) x b
            _cross_to(t1, wj, vb)
            _cross_to(t3, va, t1)  # a x (w_j x b)
            bias = 0.0
            for a in range(3):
                bias += ab[a] * (alpha_bias[i, a] - alpha_bias[j, a]) + (t2[a] + t3[a]) * (wi[a] - wj[a])
            gamma[row] = -bias
        row += 1
    return row


@njit(cache=True)
def cut_row_wrenches(level, R, origin, r, omega, v, alpha_bias, a_bias, pt_i, pt_pi, pt_j, pt_pj, dr_i, dr_pi,
                     dr_ai, dr_j, dr_pj, pp_i, pp_ai, pp_j, pp_bj):
    """The rows of all cut joints, each row's partials as two (body, wrench) pairs.

    Parameters
    ----------
    level : int
        0: phi only; 1: also the wrenches (b is zero); 2: also gamma.
    R, origin, r, omega, v, alpha_bias, a_bias : ndarray
        Kinematics, one row per body and the ground last (index -1).
    pt_i, pt_pi, pt_j, pt_pj : ndarray
        Point rows: parent body, parent point (body frame), child body,
        child point.
    dr_i, dr_pi, dr_ai, dr_j, dr_pj : ndarray
        Direction rows: parent body and point, the axis in the parent body
        frame, child body and point.
    pp_i, pp_ai, pp_j, pp_bj : ndarray
        Perpendicularity rows: parent body and axis, child body and axis.

    Returns
    -------
    phi : ndarray, shape (m,)
        Residuals.
    wrench : ndarray, shape (m, 2, 6)
        Row a of psi is ``psi_a xd = wrench[a, 0] . V_body[a, 0] + wrench[a, 1]
        . V_body[a, 1]``, with ``V_k = sum S_c xd_c`` over the coordinates on
        body k's path (zero below level 1).
    body : ndarray of int, shape (m, 2)
        The two bodies of each row (-1: the ground).
    gamma : ndarray, shape (m,)
        Right-hand sides of ``psi xdd = gamma`` (zero below level 2).
    """
    m = 3 * pt_i.shape[0] + dr_i.shape[0] + pp_i.shape[0]
    phi, wrench, body, gamma = np.zeros(m), np.zeros((m, 2, 6)), np.full((m, 2), -1, dtype=np.int64), np.zeros(m)
    cut_row_wrenches_into(level, R, origin, r, omega, v, alpha_bias, a_bias, pt_i, pt_pi, pt_j, pt_pj, dr_i, dr_pi,
                          dr_ai, dr_j, dr_pj, pp_i, pp_ai, pp_j, pp_bj, phi, wrench, body, gamma, np.empty(ROWS_SCRATCH))
    return phi, wrench, body, gamma


#: length of the scratch of :func:`cut_row_wrenches_into`
ROWS_SCRATCH = 36


@njit(cache=True)
def cut_row_wrenches_into(level, R, origin, r, omega, v, alpha_bias, a_bias, pt_i, pt_pi, pt_j, pt_pj, dr_i, dr_pi,
                          dr_ai, dr_j, dr_pj, pp_i, pp_ai, pp_j, pp_bj, phi, wrench, body, gamma, scratch):
    """:func:`cut_row_wrenches` into given arrays: nothing allocated (the loops' right-hand side).

    Parameters
    ----------
    level, R, origin, r, omega, v, alpha_bias, a_bias, pt_i, pt_pi, pt_j, pt_pj, dr_i, dr_pi, dr_ai, dr_j, dr_pj, pp_i, pp_ai, pp_j, pp_bj
        As :func:`cut_row_wrenches`.
    phi, gamma : ndarray, shape (m,)
        Outputs (gamma written from level 2).
    wrench : ndarray, shape (m, 2, 6)
        Output from level 1; it must be zero on entry (the rows add to it).
    body : ndarray of int, shape (m, 2) or (0, 2)
        Output from level 1, if not empty (the bodies are fixed by the
        model: :attr:`~flexmb.kernels.loop_layout.LoopLayout.row_body`).
    scratch : ndarray, shape (>= ROWS_SCRATCH,)
        Scratch.
    """
    row = _point_rows(level, 0, phi, wrench, body, gamma, R, origin, r, omega, alpha_bias, a_bias, pt_i, pt_pi, pt_j,
                      pt_pj, scratch)
    row = _direction_rows(level, row, phi, wrench, body, gamma, R, origin, r, omega, v, alpha_bias, a_bias, dr_i,
                          dr_pi, dr_ai, dr_j, dr_pj, scratch)
    _perpendicular_rows(level, row, phi, wrench, body, gamma, R, omega, alpha_bias, pp_i, pp_ai, pp_j, pp_bj, scratch)


@njit(cache=True)
def cut_rows(level, n, R, origin, r, omega, v, alpha_bias, a_bias, Sw, Sv, parent, coord_start,
             pt_i, pt_pi, pt_j, pt_pj, dr_i, dr_pi, dr_ai, dr_j, dr_pj, pp_i, pp_ai, pp_j, pp_bj):
    """The rows of all cut joints, psi dense (:func:`cut_row_wrenches` scattered by :func:`scatter_rows`).

    Parameters
    ----------
    level : int
        0: phi only; 1: also psi (b is zero); 2: also gamma.
    n : int
        Number of coordinates.
    R, origin, r, omega, v, alpha_bias, a_bias : ndarray
        Kinematics, one row per body and the ground last (index -1).
    Sw, Sv : ndarray, shape (n, 3)
        Plucker axes of the coordinates.
    parent, coord_start : ndarray of int
        The tree layout.
    pt_i, pt_pi, pt_j, pt_pj, dr_i, dr_pi, dr_ai, dr_j, dr_pj, pp_i, pp_ai, pp_j, pp_bj : ndarray
        The cut joints' rows, as :func:`cut_row_wrenches` takes them.

    Returns
    -------
    phi : ndarray, shape (m,)
        Residuals.
    psi : ndarray, shape (m, n)
        Rows of the constraint Jacobian (zero rows below level 1).
    gamma : ndarray, shape (m,)
        Right-hand sides of ``psi xdd = gamma`` (zero below level 2).
    """
    phi, wrench, body, gamma = cut_row_wrenches(level, R, origin, r, omega, v, alpha_bias, a_bias, pt_i, pt_pi, pt_j,
                                                pt_pj, dr_i, dr_pi, dr_ai, dr_j, dr_pj, pp_i, pp_ai, pp_j, pp_bj)
    psi = np.zeros((phi.shape[0] if level >= 1 else 0, n))
    if level >= 1:
        scatter_rows(psi, wrench, body, parent, coord_start, Sw, Sv)
    return phi, psi, gamma
