"""Scattering point forces and torques onto bodies, and the positions and velocities of body points."""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["add_point_forces", "add_torques", "body_points"]


@njit(cache=True)
def add_point_forces(rows, points, forces, r, force, torque):
    """Add forces at inertial points to the bodies' resultants at their mass centres.

    Parameters
    ----------
    rows : ndarray of int, shape (m,)
        Body rows (-1: the ground, the last row of ``force`` and ``torque``).
    points, forces : ndarray, shape (m, 3)
        Points of application and forces, inertial.
    r : ndarray, shape (n_bodies + 1, 3)
        Mass centres.
    force, torque : ndarray, shape (n_bodies + 1, 3)
        Accumulators, updated in place: ``force[k] += f``,
        ``torque[k] += (p - r_k) x f``.
    """
    for i in range(rows.shape[0]):
        k = rows[i]
        lx = points[i, 0] - r[k, 0]
        ly = points[i, 1] - r[k, 1]
        lz = points[i, 2] - r[k, 2]
        fx, fy, fz = forces[i, 0], forces[i, 1], forces[i, 2]
        force[k, 0] += fx
        force[k, 1] += fy
        force[k, 2] += fz
        torque[k, 0] += ly * fz - lz * fy
        torque[k, 1] += lz * fx - lx * fz
        torque[k, 2] += lx * fy - ly * fx


@njit(cache=True)
def add_torques(rows, torques, torque):
    """``torque[rows[i]] += torques[i]`` (repeated rows add up).

    Parameters
    ----------
    rows : ndarray of int, shape (m,)
        Body rows (-1: the ground).
    torques : ndarray, shape (m, 3)
        Torques, inertial.
    torque : ndarray, shape (n_bodies + 1, 3)
        Accumulator, updated in place.
    """
    for i in range(rows.shape[0]):
        for a in range(3):
            torque[rows[i], a] += torques[i, a]


@njit(cache=True)
def body_points(rows, local, R, origin, r, omega, v):
    """Inertial positions and velocities of points fixed in bodies.

    Parameters
    ----------
    rows : ndarray of int, shape (m,)
        Body rows (-1: the ground).
    local : ndarray, shape (m, 3)
        The points in their body frames.
    R, origin, r, omega, v : ndarray, shape (n_bodies + 1, ...)
        Rotations, body-frame origins, mass centres, angular velocities and
        mass-centre velocities.

    Returns
    -------
    p, vel : ndarray, shape (m, 3)
        ``R_k local + origin_k`` and ``v_k + omega_k x (p - r_k)``.
    """
    m = rows.shape[0]
    p = np.empty((m, 3))
    vel = np.empty((m, 3))
    for i in range(m):
        k = rows[i]
        for a in range(3):
            p[i, a] = R[k, a, 0] * local[i, 0] + R[k, a, 1] * local[i, 1] + R[k, a, 2] * local[i, 2] + origin[k, a]
        lx, ly, lz = p[i, 0] - r[k, 0], p[i, 1] - r[k, 1], p[i, 2] - r[k, 2]
        w = omega[k]
        vel[i, 0] = v[k, 0] + w[1] * lz - w[2] * ly
        vel[i, 1] = v[k, 1] + w[2] * lx - w[0] * lz
        vel[i, 2] = v[k, 2] + w[0] * ly - w[1] * lx
    return p, vel
