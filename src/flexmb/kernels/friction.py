"""Friction laws in a plane: the one compiled implementation of each.

A law gives the friction force on a point sliding with velocity ``v_s`` in
the contact plane as ``F = -k v_s`` with a factor ``k >= 0`` (so that the
power ``F . v_s`` is never positive). The laws whose magnitude does not
vanish at rest regularise the jump of the direction at rest: they use
``v_s / sqrt(|v_s|^2 + v_eps^2)`` for the unit vector (``v_eps`` the
smoothing speed).

The scalar factors (``*_factor``) are inlined into the contact kernel
(:mod:`flexmb.kernels.loads`, normal load from the contact law); the
row-by-row laws (``*_law``) serve the prescribed-load friction elements of
the ``flexmb_friction`` plugin.
"""

from __future__ import annotations

import numpy as np

from .cache import njit

__all__ = ["coulomb_factor", "velocity_weakening_factor", "stribeck_factor", "coulomb_law",
           "velocity_weakening_law", "viscous_law"]


@njit(cache=True, inline="always")
def coulomb_factor(load, mu, eps, speed2):
    """Regularised Coulomb: ``k = mu N / sqrt(v^2 + v_eps^2)``.

    Parameters
    ----------
    load : float
        Normal load N, N.
    mu : float
        Friction coefficient.
    eps : float
        Smoothing speed v_eps, m/s.
    speed2 : float
        Squared sliding speed, m^2/s^2.

    Returns
    -------
    float
        k, N s/m.
    """
    return mu * load / np.sqrt(speed2 + eps * eps)


@njit(cache=True, inline="always")
def velocity_weakening_factor(load, mu_s, slope, mu_min, eps, speed2):
    """Linear velocity weakening: ``k = N max(mu_s - s v, mu_min) / sqrt(v^2 + v_eps^2)``.

    Parameters
    ----------
    load : float
        Normal load N, N.
    mu_s : float
        Coefficient at rest.
    slope : float
        Fall of the coefficient with speed s, s/m.
    mu_min : float
        Smallest coefficient.
    eps : float
        Smoothing speed v_eps, m/s.
    speed2 : float
        Squared sliding speed, m^2/s^2.

    Returns
    -------
    float
        k, N s/m.
    """
    mu = max(mu_s - slope * np.sqrt(speed2), mu_min)
    return load * mu / np.sqrt(speed2 + eps * eps)


@njit(cache=True, inline="always")
def stribeck_factor(load, mu_s, mu_k, v_st, exponent, eps, viscous, speed2):
    """Stribeck: ``k = N mu(v) / sqrt(v^2 + v_eps^2) + sigma``, ``mu(v) = mu_k + (mu_s - mu_k) exp(-(v / v_st)^a)``.

    Parameters
    ----------
    load : float
        Normal load N, N.
    mu_s, mu_k : float
        Static (breakaway) and kinetic (Coulomb) coefficients.
    v_st : float
        Stribeck speed, m/s (> 0).
    exponent : float
        Exponent a of the Stribeck curve (2: Gaussian).
    eps : float
        Smoothing speed v_eps, m/s.
    viscous : float
        Viscous coefficient sigma, N s/m.
    speed2 : float
        Squared sliding speed, m^2/s^2.

    Returns
    -------
    float
        k, N s/m.
    """
    v = np.sqrt(speed2)
    mu = mu_k + (mu_s - mu_k) * np.exp(-((v / v_st) ** exponent))
    return load * mu / np.sqrt(speed2 + eps * eps) + viscous


@njit(cache=True)
def coulomb_law(params, v_s):
    """Regularised Coulomb forces, row by row.

    Parameters
    ----------
    params : ndarray, shape (m, 3)
        Normal load N (N), coefficient mu and smoothing speed (m/s) of each row.
    v_s : ndarray, shape (m, 3)
        Sliding velocities, m/s.

    Returns
    -------
    ndarray, shape (m, 3)
        ``-mu N v_s / sqrt(|v_s|^2 + v_eps^2)``, N.
    """
    out = np.empty_like(v_s)
    for i in range(v_s.shape[0]):
        speed2 = v_s[i, 0] ** 2 + v_s[i, 1] ** 2 + v_s[i, 2] ** 2
        k = coulomb_factor(params[i, 0], params[i, 1], params[i, 2], speed2)
        for a in range(3):
            out[i, a] = -k * v_s[i, a]
    return out


@njit(cache=True)
def velocity_weakening_law(params, v_s):
    """Velocity-weakening forces, row by row.

    Parameters
    ----------
    params : ndarray, shape (m, 5)
        Normal load N (N), mu_s, slope (s/m), mu_min and smoothing speed
        (m/s) of each row.
    v_s : ndarray, shape (m, 3)
        Sliding velocities, m/s.

    Returns
    -------
    ndarray, shape (m, 3)
        ``-N max(mu_s - s v, mu_min) v_s / sqrt(v^2 + v_eps^2)``, N.
    """
    out = np.empty_like(v_s)
    for i in range(v_s.shape[0]):
        speed2 = v_s[i, 0] ** 2 + v_s[i, 1] ** 2 + v_s[i, 2] ** 2
        k = velocity_weakening_factor(params[i, 0], params[i, 1], params[i, 2], params[i, 3], params[i, 4], speed2)
        for a in range(3):
            out[i, a] = -k * v_s[i, a]
    return out


@njit(cache=True)
def viscous_law(params, v_s):
    """Viscous forces ``-c v_s``, row by row.

    Parameters
    ----------
    params : ndarray, shape (m, 1)
        Damping constant c of each row, N s/m.
    v_s : ndarray, shape (m, 3)
        Sliding velocities, m/s.

    Returns
    -------
    ndarray, shape (m, 3)
        ``-c v_s``, N.
    """
    out = np.empty_like(v_s)
    for i in range(v_s.shape[0]):
        for a in range(3):
            out[i, a] = -params[i, 0] * v_s[i, a]
    return out
