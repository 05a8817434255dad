"""Contact laws: the normal force of a penetration and the friction in the tangent plane.

The geometry (the penetration ``delta`` of two surfaces along their
common normal, its rate ``delta_dot`` and the contact point's relative
velocity) is computed where the loads are applied
(:func:`flexmb.kernels.loads.apply_load_tables`); the functions here turn
it into forces. Codes of the laws, as laid out in the load tables
(``contact_laws`` columns: geometry, normal law, friction law):

* geometry: ``SPHERE_PLANE`` (a sphere, or a point, on one body against a
  plane on another), ``SPHERE_SPHERE``, ``JOURNAL`` (a pin of one body in
  a bearing's hole of another, a revolute joint with clearance: the
  penetration is the pin's eccentricity across the bearing's axis less
  the radial clearance), ``CAPSULE_SPHERE``, ``CAPSULE_CAPSULE`` (a
  segment with a radius against a sphere or another: spheres at the
  closest points; :mod:`flexmb.kernels.contact_geometry` has the layout);
* normal law (``contact_par`` columns 0-4: K, exponent n, damping d,
  effective mass m, and the impact speed v_in held since the contact's
  onset, m/s, 0 where none is held: :mod:`flexmb.impact_speeds`):

  - ``LINEAR``: ``F = K delta + d delta_dot`` (n = 1, d in N s/m);
  - ``HUNT_CROSSLEY``: ``F = K delta^n (1 + d delta_dot)`` (d = alpha, s/m);
  - ``RESTITUTION``: ``F = K delta^n (1 + chi delta_dot / v_in)`` (d = chi,
    from the coefficient of restitution by the Lankarani-Nikravesh or the
    Flores relation; ``v_in`` the impact speed held in column 4, or, where
    none is held, the one the contact's state gives, :func:`impact_speed`);

  every law clamped at ``F >= 0`` (a contact pushes, never pulls);
* friction law (``contact_par`` columns 5-10), with the normal force as
  the load: ``NO_FRICTION``; ``COULOMB`` (mu, v_eps); ``VISCOUS`` (c);
  ``VELOCITY_WEAKENING`` (mu_s, slope, mu_min, v_eps); ``STRIBECK`` (mu_s,
  mu_k, v_st, exponent, v_eps, sigma), all from :mod:`flexmb.kernels.friction`.
"""

from __future__ import annotations

import numpy as np

from .cache import njit
from .friction import coulomb_factor, stribeck_factor, velocity_weakening_factor

__all__ = ["SPHERE_PLANE", "SPHERE_SPHERE", "JOURNAL", "CAPSULE_SPHERE", "CAPSULE_CAPSULE", "LINEAR", "HUNT_CROSSLEY", "RESTITUTION", "NO_FRICTION", "COULOMB",
           "VISCOUS", "VELOCITY_WEAKENING", "STRIBECK", "N_NORMAL", "N_FRICTION", "normal_force", "friction_factor",
           "impact_speed", "hysteresis_invariant", "elastic_energy"]

SPHERE_PLANE, SPHERE_SPHERE, JOURNAL, CAPSULE_SPHERE, CAPSULE_CAPSULE = 0, 1, 2, 3, 4
LINEAR, HUNT_CROSSLEY, RESTITUTION = 0, 1, 2
NO_FRICTION, COULOMB, VISCOUS, VELOCITY_WEAKENING, STRIBECK = 0, 1, 2, 3, 4
#: numbers of parameter columns of the normal and of the friction law (``contact_par`` has both)
N_NORMAL, N_FRICTION = 5, 6


@njit(cache=True, inline="always")
def hysteresis_invariant(s, chi):
    """``h(s) = (1 - s) / chi - ln((1 + chi) / (1 + chi s)) / chi^2`` (``(1 - s^2) / 2`` at chi = 0).

    Along an impact of a mass m under ``F = K delta^n (1 + chi delta_dot / v_in)``
    alone, ``m v_in^2 h(delta_dot / v_in) + K delta^(n+1) / (n + 1)`` stays
    equal to its value at the first touch, 0 (from
    ``m v dv / (1 + alpha v) = -K delta^n d delta``, ``alpha = chi / v_in``).

    Parameters
    ----------
    s : float
        ``delta_dot / v_in`` (> -1 / chi).
    chi : float
        Hysteresis factor (>= 0).

    Returns
    -------
    float
        h(s); for ``chi (1 + |s|) < 1e-3`` from its series
        ``sum_k>=2 (-chi)^(k-2) (1 - s^k) / k``, free of the cancellation
        of the closed form.
    """
    if chi * (1.0 + abs(s)) < 1e-3:
        out = 0.0
        c = 1.0
        sk = s * s
        for k in range(2, 12):
            out += c * (1.0 - sk) / k
            c *= -chi
            sk *= s
        return out
    u = chi * (1.0 - s)
    return (u - np.log1p(u / (1.0 + chi * s))) / (chi * chi)


@njit(cache=True, inline="always")
def _invariant_residual(V, rate, chi, target):
    """``V^2 h(rate / V) - target`` and its derivative in V."""
    s = rate / V
    h = hysteresis_invariant(s, chi)
    return V * V * h - target, 2.0 * V * h + rate * s / (1.0 + chi * s)


@njit(cache=True)
def impact_speed(delta, rate, stiffness, exponent, chi, mass):
    """The impact speed v_in of a contact of the restitution laws, from its state.

    The speed at the first touch that brings a mass ``mass`` under the law
    ``F = K delta^n (1 + chi delta_dot / v_in)`` alone to the penetration
    ``delta`` with the rate ``delta_dot``: the root of
    ``v_in^2 h(delta_dot / v_in) = K delta^(n+1) / ((n + 1) m)``
    (:func:`hysteresis_invariant`), unique on ``v_in > max(delta_dot, -chi delta_dot, 0)``.
    Exact along such an impact (a free body against the ground, or two free
    bodies, hit through their mass centres), so that the law's coefficient
    of restitution is the Lankarani-Nikravesh or Flores one at every impact
    speed.

    Parameters
    ----------
    delta : float
        Penetration, m (> 0).
    rate : float
        Its rate delta_dot, m/s.
    stiffness, exponent : float
        K (N/m^n) and n.
    chi : float
        Hysteresis factor (>= 0).
    mass : float
        Effective mass of the contact, kg.

    Returns
    -------
    float
        v_in, m/s (> 0).
    """
    target = stiffness * delta ** (exponent + 1.0) / ((exponent + 1.0) * mass)
    V = np.sqrt(rate * rate + 2.0 * target)  # the answer at chi = 0, a lower bound otherwise
    if chi == 0.0 or target == 0.0:
        return V
    lo = rate if rate > 0.0 else -chi * rate  # the residual is negative at (or next to) lo
    hi = max(V, lo) * 2.0 + 1e-300
    for _ in range(200):
        if _invariant_residual(hi, rate, chi, target)[0] > 0.0:
            break
        lo = hi
        hi *= 2.0
    V = min(max(V, lo), hi)
    if V <= lo:
        V = 0.5 * (lo + hi)
    for _ in range(100):
        g, dg = _invariant_residual(V, rate, chi, target)
        if g > 0.0:
            hi = V
        else:
            lo = V
        step = g / dg if dg > 0.0 else 0.0
        new = V - step
        if not (lo < new < hi) or dg <= 0.0:
            new = 0.5 * (lo + hi)
        if abs(new - V) <= 1e-15 * new or hi - lo <= 1e-15 * hi:
            return new
        V = new
    return V


@njit(cache=True, inline="always")
def normal_force(law, par, delta, rate):
    """Normal force of a penetration, clamped at >= 0.

    Parameters
    ----------
    law : int
        ``LINEAR``, ``HUNT_CROSSLEY`` or ``RESTITUTION``.
    par : ndarray, shape (5,)
        K, n, d, m and the held impact speed v_in (0: none; module docstring).
    delta : float
        Penetration, m (> 0).
    rate : float
        Its rate, m/s (> 0 approaching).

    Returns
    -------
    float
        F, N.
    """
    K, n, d = par[0], par[1], par[2]
    if law == LINEAR:
        f = K * delta + d * rate
    elif law == HUNT_CROSSLEY:
        f = K * delta ** n * (1.0 + d * rate)
    else:
        v_in = par[4] if par[4] > 0.0 else impact_speed(delta, rate, K, n, d, par[3])
        f = K * delta ** n * (1.0 + d * rate / v_in)
    return max(f, 0.0)


@njit(cache=True, inline="always")
def elastic_energy(law, par, delta):
    """Elastic energy stored in a penetration: ``K delta^(n+1) / (n + 1)`` (0 if separated).

    Parameters
    ----------
    law : int
        The normal law's code.
    par : ndarray, shape (>= 2,)
        K, n, ...
    delta : float
        Penetration, m.

    Returns
    -------
    float
        J.
    """
    if delta <= 0.0:
        return 0.0
    n = 1.0 if law == LINEAR else par[1]
    return par[0] * delta ** (n + 1.0) / (n + 1.0)


@njit(cache=True, inline="always")
def friction_factor(law, par, load, speed2):
    """Friction factor k (force ``-k v_t``) for a normal load and a squared slip speed.

    Parameters
    ----------
    law : int
        Friction law's code.
    par : ndarray, shape (6,)
        Its parameters (module docstring).
    load : float
        Normal force, N.
    speed2 : float
        Squared slip speed, m^2/s^2.

    Returns
    -------
    float
        k, N s/m.
    """
    if law == COULOMB:
        return coulomb_factor(load, par[0], par[1], speed2)
    if law == VISCOUS:
        return par[0]
    if law == VELOCITY_WEAKENING:
        return velocity_weakening_factor(load, par[0], par[1], par[2], par[3], speed2)
    if law == STRIBECK:
        return stribeck_factor(load, par[0], par[1], par[2], par[3], par[4], par[5], speed2)
    return 0.0
