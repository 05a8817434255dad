"""Loop-closure rows of the cut joints: phi, psi, b and gamma (eqs. 28-29).

Three kinds of rows (see :mod:`flexmb.joints`), each evaluated for all cut
joints of the model in one loop:

* point rows: ``P_i - P_j = 0`` (3 rows), the two marker points coincide;
* direction rows: ``d . (P_j - P_i) = 0`` with ``d`` a parent marker axis;
* perpendicularity rows: ``a . b = 0`` for a parent and a child marker axis.

A row of psi is the partial velocity of its residual (eq. 29): point
partials ``S_v + S_w x P`` and angular partials ``S_w`` summed over the
coordinates on the body's path from the ground, walked through the parent
array. Cut-joint rows are scleronomic, so ``b = 0``; ``gamma`` is minus the
velocity-dependent part of the residual's second derivative.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .tree import _cross_to, _mv_to

__all__ = ["cut_rows"]


@njit(cache=True, inline="always")
def _dot3(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True)
def _add_point_partials(psi, row, sign, k, p, weight, parent, coord_start, Sw, Sv):
    """``psi[row] += sign * weight . (S_v + S_w x p)`` over the coordinates moving body k."""
    while k >= 0:
        for c in range(coord_start[k], coord_start[k + 1]):
            vx = Sv[c, 0] + Sw[c, 1] * p[2] - Sw[c, 2] * p[1]
            vy = Sv[c, 1] + Sw[c, 2] * p[0] - Sw[c, 0] * p[2]
            vz = Sv[c, 2] + Sw[c, 0] * p[1] - Sw[c, 1] * p[0]
            psi[row, c] += sign * (weight[0] * vx + weight[1] * vy + weight[2] * vz)
        k = parent[k]


@njit(cache=True)
def _add_angular_partials(psi, row, sign, k, weight, parent, coord_start, Sw):
    """``psi[row] += sign * weight . S_w`` over the coordinates moving body k."""
    while k >= 0:
        for c in range(coord_start[k], coord_start[k + 1]):
            psi[row, c] += sign * (weight[0] * Sw[c, 0] + weight[1] * Sw[c, 1] + weight[2] * Sw[c, 2])
        k = parent[k]


@njit(cache=True, inline="always")
def _point(out, R, origin, k, local):
    _mv_to(out, R[k], local)
    for i in range(3):
        out[i] += origin[k, i]


@njit(cache=True)
def _bias_acceleration(out, k, p, r, omega, alpha_bias, a_bias):
    """``a_bias + alpha_bias x l + omega x (omega x l)``, ``l = p - r_k``: the point's acceleration at xdd = 0."""
    lever = np.empty(3)
    t1 = np.empty(3)
    t2 = np.empty(3)
    for i in range(3):
        lever[i] = p[i] - r[k, i]
    _cross_to(t1, alpha_bias[k], lever)
    _cross_to(t2, omega[k], lever)
    _cross_to(out, omega[k], t2)
    for i in range(3):
        out[i] += a_bias[k, i] + t1[i]


@njit(cache=True)
def _velocity(out, k, p, r, omega, v):
    """``v_k + omega_k x (p - r_k)``."""
    lever = np.empty(3)
    for i in range(3):
        lever[i] = p[i] - r[k, i]
    _cross_to(out, omega[k], lever)
    for i in range(3):
        out[i] += v[k, i]


@njit(cache=True, inline="always")
def _point_rows(level, row, phi, psi, gamma, R, origin, r, omega, alpha_bias, a_bias, Sw, Sv, parent, coord_start,
                pt_i, pt_pi, pt_j, pt_pj):
    """Point rows ``P_i - P_j = 0`` (eq. 28), their psi (eq. 29) and gamma, from ``row`` on; returns the next row."""
    Pi = np.empty(3)
    Pj = np.empty(3)
    t1 = np.empty(3)
    t2 = np.empty(3)
    unit = np.zeros((3, 3))
    for a in range(3):
        unit[a, a] = 1.0
    for q in range(pt_i.shape[0]):
        i, j = pt_i[q], pt_j[q]
        _point(Pi, R, origin, i, pt_pi[q])
        _point(Pj, R, origin, j, pt_pj[q])
        if level >= 2:
            _bias_acceleration(t1, i, Pi, r, omega, alpha_bias, a_bias)
            _bias_acceleration(t2, j, Pj, r, omega, alpha_bias, a_bias)
        for a in range(3):
            phi[row + a] = Pi[a] - Pj[a]
            if level >= 1:
                _add_point_partials(psi, row + a, 1.0, i, Pi, unit[a], parent, coord_start, Sw, Sv)
                _add_point_partials(psi, row + a, -1.0, j, Pj, unit[a], parent, coord_start, Sw, Sv)
            if level >= 2:
                gamma[row + a] = -(t1[a] - t2[a])
        row += 3
    return row


@njit(cache=True, inline="always")
def _direction_bias(i, j, Pi, Pj, d, e, de, r, omega, v, alpha_bias, a_bias):
    """The velocity-dependent part of ``d/dt^2 (d . e)`` of a direction row, ``e = P_j - P_i`` (minus gamma)."""
    t1 = np.empty(3)
    t2 = np.empty(3)
    t3 = np.empty(3)
    t4 = np.empty(3)
    wi = omega[i]
    # edot, ebias: relative velocity and bias acceleration of the points
    _velocity(t1, j, Pj, r, omega, v)
    _velocity(t2, i, Pi, r, omega, v)
    for a in range(3):
        t1[a] -= t2[a]  # edot
    _bias_acceleration(t2, j, Pj, r, omega, alpha_bias, a_bias)
    _bias_acceleration(t3, i, Pi, r, omega, alpha_bias, a_bias)
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
def _direction_rows(level, row, phi, psi, gamma, R, origin, r, omega, v, alpha_bias, a_bias, Sw, Sv, parent,
                    coord_start, dr_i, dr_pi, dr_ai, dr_j, dr_pj):
    """Direction rows ``d . (P_j - P_i) = 0`` (eq. 28), their psi (eq. 29) and gamma; returns the next row."""
    Pi = np.empty(3)
    Pj = np.empty(3)
    e = np.empty(3)
    d = np.empty(3)
    de = np.empty(3)
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
            _add_angular_partials(psi, row, 1.0, i, de, parent, coord_start, Sw)
            _add_point_partials(psi, row, 1.0, j, Pj, d, parent, coord_start, Sw, Sv)
            _add_point_partials(psi, row, -1.0, i, Pi, d, parent, coord_start, Sw, Sv)
        if level >= 2:
            gamma[row] = -_direction_bias(i, j, Pi, Pj, d, e, de, r, omega, v, alpha_bias, a_bias)
        row += 1
    return row


@njit(cache=True, inline="always")
def _perpendicular_rows(level, row, phi, psi, gamma, R, omega, alpha_bias, Sw, parent, coord_start,
                        pp_i, pp_ai, pp_j, pp_bj):
    """Perpendicularity rows ``a . b = 0`` (eq. 28), their psi (eq. 29) and gamma; returns the next row."""
    va = np.empty(3)
    vb = np.empty(3)
    ab = np.empty(3)
    t1 = np.empty(3)
    t2 = np.empty(3)
    t3 = np.empty(3)
    for q in range(pp_i.shape[0]):
        i, j = pp_i[q], pp_j[q]
        _mv_to(va, R[i], pp_ai[q])
        _mv_to(vb, R[j], pp_bj[q])
        phi[row] = _dot3(va, vb)
        _cross_to(ab, va, vb)
        if level >= 1:
            _add_angular_partials(psi, row, 1.0, i, ab, parent, coord_start, Sw)
            _add_angular_partials(psi, row, -1.0, j, ab, parent, coord_start, Sw)
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
def cut_rows(level, n, R, origin, r, omega, v, alpha_bias, a_bias, Sw, Sv, parent, coord_start,
             pt_i, pt_pi, pt_j, pt_pj, dr_i, dr_pi, dr_ai, dr_j, dr_pj, pp_i, pp_ai, pp_j, pp_bj):
    """The rows of all cut joints.

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
    psi : ndarray, shape (m, n)
        Rows of the constraint Jacobian (zero rows below level 1).
    gamma : ndarray, shape (m,)
        Right-hand sides of ``psi xdd = gamma`` (zero below level 2).
    """
    m = 3 * pt_i.shape[0] + dr_i.shape[0] + pp_i.shape[0]
    phi = np.zeros(m)
    psi = np.zeros((m if level >= 1 else 0, n))
    gamma = np.zeros(m)
    row = _point_rows(level, 0, phi, psi, gamma, R, origin, r, omega, alpha_bias, a_bias, Sw, Sv, parent, coord_start,
                      pt_i, pt_pi, pt_j, pt_pj)
    row = _direction_rows(level, row, phi, psi, gamma, R, origin, r, omega, v, alpha_bias, a_bias, Sw, Sv, parent,
                          coord_start, dr_i, dr_pi, dr_ai, dr_j, dr_pj)
    _perpendicular_rows(level, row, phi, psi, gamma, R, omega, alpha_bias, Sw, parent, coord_start, pp_i, pp_ai, pp_j,
                        pp_bj)
    return phi, psi, gamma
