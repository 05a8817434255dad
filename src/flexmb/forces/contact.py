"""Contact force elements: spheres (or points) against planes and against spheres.

A contact pushes two bodies apart when their surfaces overlap by the
penetration ``delta > 0``, along the surfaces' common normal, with a force
given by a *normal law*; a *friction law* adds a force in the tangent
plane, against the contact point's own relative velocity (the slip), with
the normal force as its load. Both act at the middle of the overlap, equal
and opposite on the two bodies, so their power is ``f . u`` with ``u`` the
relative velocity of the two bodies' material points there. Separated
(``delta <= 0``), a contact exerts nothing; touching, it never pulls (the
normal force is clamped at 0).

The elements are compiled: they are laid out in the load tables of the
built-in force elements (:mod:`flexmb.forces.tables`) and evaluated, with
the rest, in one kernel call (:mod:`flexmb.kernels.contact`).

Normal laws (``F`` the normal force, ``delta_dot`` the rate of penetration):

* :class:`LinearContactLaw`: ``F = k delta + c delta_dot``.
* :class:`HuntCrossleyLaw`: ``F = K delta^n (1 + alpha delta_dot)`` [1]_:
  Hertz (n = 3/2) with a damping that vanishes with the penetration; its
  coefficient of restitution falls with the impact speed v_in, as
  ``u - ln(1 + u) = -e u - ln(1 - e u)`` with ``u = alpha v_in``.
* :class:`LankaraniNikraveshLaw` [2]_ and :class:`FloresLaw` [3]_:
  ``F = K delta^n (1 + chi delta_dot / v_in)`` with the coefficient of
  restitution e as the parameter, ``chi = 3 (1 - e^2) / 4`` (accurate for e
  near 1) or ``chi = 8 (1 - e) / (5 e)`` (over the whole range); the
  rebound ratio is then independent of the impact speed.

Friction laws: :class:`CoulombLaw` (regularised), :class:`ViscousLaw`,
:class:`VelocityWeakeningLaw`, :class:`StribeckLaw` -- the friction laws of
:mod:`flexmb.kernels.friction`, which the ``flexmb_friction`` plugin's
prescribed-load elements use too.

References
----------
.. [1] K. H. Hunt and F. R. E. Crossley, "Coefficient of restitution
   interpreted as damping in vibroimpact", J. Appl. Mech. 42 (1975) 440-445.
.. [2] H. M. Lankarani and P. E. Nikravesh, "A contact force model with
   hysteresis damping for impact analysis of multibody systems", J. Mech.
   Des. 112 (1990) 369-376.
.. [3] P. Flores, M. Machado, M. T. Silva and J. M. Martins, "On the
   continuous contact force models for soft materials in multibody
   dynamics", Multibody Syst. Dyn. 25 (2011) 357-375.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from attrs import field, frozen

from .._names import reference
from ..bodies import Body
from ..errors import ModelError
from ..fields import as_array, as_float, as_unit_vector, label, unit_vector, vector3
from ..kernels import contact as _k
from ..kernels.loads import contact_states
from .base import ForceElement
from .tables import LoadTables, class_tables

__all__ = ["NormalLaw", "LinearContactLaw", "HuntCrossleyLaw", "LankaraniNikraveshLaw", "FloresLaw", "FrictionLaw",
           "CoulombLaw", "ViscousLaw", "VelocityWeakeningLaw", "StribeckLaw", "SpherePlaneContact",
           "SphereSphereContact", "ContactHistory", "hertz_stiffness", "restitution_of_hysteresis"]

#: default smoothing speed of the regularised friction laws, m/s (that of ``flexmb_friction``)
DEFAULT_SMOOTHING_SPEED = 1e-3


# ----------------------------------------------------------------------------- validators of the laws

def _law_check(test, words):
    """A validator of a law's field: ``test(value)`` or a ModelError naming the law and the field."""

    def check(instance, attribute, value):
        if not isinstance(value, float) or not np.isfinite(value) or not test(value):
            raise ModelError(f"{type(instance).__name__}: {attribute.name} must be {words}, got {value!r}")

    return check


_POSITIVE = _law_check(lambda v: v > 0, "a finite number > 0")
_NON_NEGATIVE = _law_check(lambda v: v >= 0, "a finite number >= 0")
_EXPONENT = _law_check(lambda v: v >= 1, "a finite number >= 1")


def _optional_mass(instance, attribute, value):
    if value is not None:
        _POSITIVE(instance, attribute, value)


def _optional_float(value):
    return None if value is None else as_float(value)


def hertz_stiffness(radius1, youngs_modulus1, poisson_ratio1, radius2=np.inf, youngs_modulus2=np.inf,
                    poisson_ratio2=0.0) -> float:
    """Hertz's contact stiffness of two spheres, or a sphere on a plane: ``K = 4/3 E* sqrt(R*)``.

    ``1 / R* = 1 / r1 + 1 / r2`` and ``1 / E* = (1 - nu1^2) / E1 + (1 - nu2^2) / E2``;
    the force of a penetration delta is ``K delta^(3/2)``.

    Parameters
    ----------
    radius1 : float
        Radius of the first sphere, m (> 0).
    youngs_modulus1, poisson_ratio1 : float
        Its material: E1 (Pa, > 0) and nu1 (in [0, 0.5]).
    radius2 : float
        Radius of the second sphere, m (default inf: a plane).
    youngs_modulus2, poisson_ratio2 : float
        Its material (default: rigid).

    Returns
    -------
    float
        K, N/m^1.5.

    Raises
    ------
    ModelError
        If a radius or a modulus is not > 0 or a Poisson ratio is outside
        [0, 0.5] (a point has no Hertz stiffness: give K itself).

    Examples
    --------
    A steel ball of radius 10 mm on a rigid plane: ``E* = 210 GPa / 0.91``.

    >>> import flexmb as fm
    >>> round(fm.hertz_stiffness(0.01, 210e9, 0.3) / 1e9, 3)
    30.769
    """
    values = {"radius1": radius1, "youngs_modulus1": youngs_modulus1, "radius2": radius2,
              "youngs_modulus2": youngs_modulus2}
    for key, v in values.items():
        v = as_float(v)
        if not isinstance(v, float) or np.isnan(v) or not v > 0:
            raise ModelError(f"hertz_stiffness: {key} must be > 0, got {v!r}")
    for key, v in (("poisson_ratio1", poisson_ratio1), ("poisson_ratio2", poisson_ratio2)):
        v = as_float(v)
        if not isinstance(v, float) or not 0.0 <= v <= 0.5:
            raise ModelError(f"hertz_stiffness: {key} must be in [0, 0.5], got {v!r}")
    inv_r = 1.0 / float(radius1) + 1.0 / float(radius2)
    inv_e = (1.0 - float(poisson_ratio1) ** 2) / float(youngs_modulus1) + (1.0 - float(poisson_ratio2) ** 2) / float(
        youngs_modulus2)
    return float(4.0 / 3.0 / inv_e / np.sqrt(inv_r))


def restitution_of_hysteresis(chi: float) -> float:
    """The coefficient of restitution of ``F = K delta^n (1 + chi delta_dot / v_in)``, exactly.

    From ``m v dv / (1 + alpha v) = -K delta^n d delta`` (``alpha = chi /
    v_in``) integrated over an impact (the contact force alone, from and
    back to ``delta = 0``): ``e`` solves ``chi - ln(1 + chi) = -chi e - ln(1 - chi e)``,
    for every exponent n and impact speed. The Lankarani-Nikravesh and
    Flores relations ``chi(e)`` approximate its inverse; the
    Hunt-Crossley law is the case ``chi = alpha v_in``.

    Parameters
    ----------
    chi : float
        Hysteresis factor (>= 0).

    Returns
    -------
    float
        e, in (0, 1] (1 for chi = 0).

    Examples
    --------
    >>> import flexmb as fm
    >>> round(fm.forces.contact.restitution_of_hysteresis(fm.FloresLaw(1e9, 0.5).chi), 4)
    0.4704
    """
    from scipy.optimize import brentq

    chi = float(chi)
    if chi < 0 or not np.isfinite(chi):
        raise ModelError(f"restitution_of_hysteresis: chi must be a finite number >= 0, got {chi!r}")
    if chi == 0.0:
        return 1.0
    # with 1 - chi e = exp(-y): y + expm1(-y) = chi - ln(1 + chi), y in [target, target + 1]
    # (so that 1 - chi e below the rounding of 1, at large chi, is no trouble); series where they cancel
    target = (_series(lambda k: (-1.0) ** k * chi ** k / k) if chi < 1e-2 else chi - np.log1p(chi))

    def g(y):
        return (_series(lambda k: (-1.0) ** k * y ** k / math.factorial(k)) if y < 1e-2 else y + np.expm1(-y)) - target

    y = brentq(g, target, target + 1.0, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=400)
    return float(-np.expm1(-y) / chi)


def _series(term) -> float:
    """``sum_{k=2}^{13} term(k)``: the series of ``x - ln(1 + x)`` and of ``y + expm1(-y)`` for small arguments."""
    return float(sum(term(k) for k in range(13, 1, -1)))


# ----------------------------------------------------------------------------- normal laws

@frozen
class NormalLaw:
    """Base class of the normal laws of a contact (not compiled for a subclass of one's own).

    A law gives its code in :mod:`flexmb.kernels.contact` (``code``) and
    its row of parameters (:meth:`row`): K, n, d and the effective mass.
    """

    code: ClassVar[int] = -1

    def row(self, effective_mass: float) -> list:
        """The law's parameters as the kernel reads them.

        Parameters
        ----------
        effective_mass : float
            The contact's effective mass, kg (read by the restitution laws only).

        Returns
        -------
        list of float
            K, n, d, m and a spare 0 (5 numbers).
        """
        raise NotImplementedError


@frozen
class LinearContactLaw(NormalLaw):
    """A linear spring and damper along the normal: ``F = k delta + c delta_dot``, clamped at >= 0.

    Parameters
    ----------
    stiffness : float
        k, N/m (> 0).
    damping : float
        c, N s/m (>= 0).

    Notes
    -----
    With the damping ratio ``zeta = c / (2 sqrt(k m))`` on a mass m the
    coefficient of restitution does not depend on the impact speed. The
    clamp ends the contact where ``k delta + c delta_dot`` reaches 0, before
    delta does, so e is above the unclamped ``exp(-zeta pi / sqrt(1 - zeta^2))``.

    Examples
    --------
    >>> import flexmb as fm
    >>> fm.LinearContactLaw(1e6, 50.0).row(1.0)
    [1000000.0, 1.0, 50.0, 1.0, 0.0]
    """

    code: ClassVar[int] = _k.LINEAR
    stiffness: float = field(converter=as_float, validator=_POSITIVE)
    damping: float = field(default=0.0, converter=as_float, validator=_NON_NEGATIVE)

    def row(self, effective_mass: float) -> list:
        """K, n, d, m and 0; see :meth:`NormalLaw.row`.

        Parameters
        ----------
        effective_mass : float
            Unused by this law (kept in the row), kg.

        Returns
        -------
        list of float
            The parameters, in the kernel's order.
        """
        return [self.stiffness, 1.0, self.damping, effective_mass, 0.0]


@frozen
class HuntCrossleyLaw(NormalLaw):
    """Hunt and Crossley's dissipative Hertz law: ``F = K delta^n (1 + alpha delta_dot)``, clamped at >= 0.

    Parameters
    ----------
    stiffness : float
        K, N/m^n (> 0); for two spheres :func:`hertz_stiffness`.
    damping : float
        alpha, s/m (>= 0).
    exponent : float
        n (>= 1, default 3/2: Hertz).

    Notes
    -----
    The coefficient of restitution depends on the impact speed v_in: with
    ``u = alpha v_in``, e solves ``u - ln(1 + u) = -e u - ln(1 - e u)``
    (:func:`restitution_of_hysteresis` of u), about ``1 - 2 u / 3`` for small u.

    Examples
    --------
    >>> import flexmb as fm
    >>> fm.HuntCrossleyLaw(1e9, 0.2).row(1.0)
    [1000000000.0, 1.5, 0.2, 1.0, 0.0]
    """

    code: ClassVar[int] = _k.HUNT_CROSSLEY
    stiffness: float = field(converter=as_float, validator=_POSITIVE)
    damping: float = field(default=0.0, converter=as_float, validator=_NON_NEGATIVE)
    exponent: float = field(default=1.5, converter=as_float, validator=_EXPONENT)

    def row(self, effective_mass: float) -> list:
        """K, n, alpha, m and 0; see :meth:`NormalLaw.row`.

        Parameters
        ----------
        effective_mass : float
            Unused by this law (kept in the row), kg.

        Returns
        -------
        list of float
            The parameters, in the kernel's order.
        """
        return [self.stiffness, self.exponent, self.damping, effective_mass, 0.0]


def _restitution(instance, attribute, value):
    low_ok = value > 0 if isinstance(instance, FloresLaw) else value >= 0
    if not isinstance(value, float) or not np.isfinite(value) or not (low_ok and value <= 1):
        words = "in (0, 1]" if isinstance(instance, FloresLaw) else "in [0, 1]"
        raise ModelError(f"{type(instance).__name__}: {attribute.name} must be {words}, got {value!r}")


@frozen
class _RestitutionLaw(NormalLaw):
    """``F = K delta^n (1 + chi(e) delta_dot / v_in)``; subclasses give ``chi(e)``."""

    code: ClassVar[int] = _k.RESTITUTION
    stiffness: float = field(converter=as_float, validator=_POSITIVE)
    restitution: float = field(converter=as_float, validator=_restitution)
    exponent: float = field(default=1.5, converter=as_float, validator=_EXPONENT)
    effective_mass: float | None = field(default=None, converter=_optional_float, validator=_optional_mass,
                                         kw_only=True)

    @property
    def chi(self) -> float:
        """The hysteresis factor chi of the law's relation to e."""
        raise NotImplementedError

    def row(self, effective_mass: float) -> list:
        """K, n, chi, m and 0; see :meth:`NormalLaw.row`.

        Parameters
        ----------
        effective_mass : float
            The contact's effective mass (the law's own, if given), kg.

        Returns
        -------
        list of float
            The parameters, in the kernel's order.
        """
        m = self.effective_mass if self.effective_mass is not None else effective_mass
        return [self.stiffness, self.exponent, self.chi, m, 0.0]


@frozen
class LankaraniNikraveshLaw(_RestitutionLaw):
    """Lankarani and Nikravesh's law: ``F = K delta^n (1 + 3 (1 - e^2) / 4 delta_dot / v_in)``, clamped at >= 0.

    Derived for e near 1 (its rebound ratio is 0.913 for e = 0.9).

    Parameters
    ----------
    stiffness : float
        K, N/m^n (> 0); for two spheres :func:`hertz_stiffness`.
    restitution : float
        The coefficient of restitution e asked for, in [0, 1].
    exponent : float
        n (>= 1, default 3/2: Hertz).
    effective_mass : float, optional
        The mass m of the contact's impact, kg (keyword only); default
        ``1 / (1 / m1 + 1 / m2)`` of the two bodies' masses (a flexible
        body: the segment's), the ground's infinite.

    Notes
    -----
    The law needs the impact speed v_in of the current impact. Until
    contact events record it at the first touch, the element takes it from
    the contact's state: the v_in that brings the mass m, under this law
    alone, to the current penetration and rate (its first integral,
    :func:`flexmb.kernels.contact.impact_speed`). That is exact for a free
    body striking the ground, or two free bodies, through their mass
    centres; where other forces or the bodies' articulation act during the
    impact, the rebound ratio departs from the law's by their share.
    The rebound ratio is ``restitution_of_hysteresis(chi)`` at every impact
    speed.

    Examples
    --------
    >>> import flexmb as fm
    >>> round(fm.LankaraniNikraveshLaw(1e9, 0.9).chi, 6)
    0.1425
    """

    @property
    def chi(self) -> float:
        """``3 (1 - e^2) / 4``."""
        return 0.75 * (1.0 - self.restitution ** 2)


@frozen
class FloresLaw(_RestitutionLaw):
    """Flores et al.'s law: ``F = K delta^n (1 + 8 (1 - e) / (5 e) delta_dot / v_in)``, clamped at >= 0.

    Derived for the whole range of e (its rebound ratio is 0.894 for
    e = 0.9, 0.470 for e = 0.5).

    Parameters
    ----------
    stiffness : float
        K, N/m^n (> 0); for two spheres :func:`hertz_stiffness`.
    restitution : float
        The coefficient of restitution e asked for, in (0, 1].
    exponent : float
        n (>= 1, default 3/2: Hertz).
    effective_mass : float, optional
        The mass m of the contact's impact, kg (keyword only); default
        ``1 / (1 / m1 + 1 / m2)`` of the two bodies' masses (a flexible
        body: the segment's), the ground's infinite.

    Notes
    -----
    The law needs the impact speed v_in of the current impact. Until
    contact events record it at the first touch, the element takes it from
    the contact's state: the v_in that brings the mass m, under this law
    alone, to the current penetration and rate (its first integral,
    :func:`flexmb.kernels.contact.impact_speed`). That is exact for a free
    body striking the ground, or two free bodies, through their mass
    centres; where other forces or the bodies' articulation act during the
    impact, the rebound ratio departs from the law's by their share.
    The rebound ratio is ``restitution_of_hysteresis(chi)`` at every impact
    speed.

    Examples
    --------
    >>> import flexmb as fm
    >>> fm.FloresLaw(1e9, 0.5).chi
    1.6
    """

    @property
    def chi(self) -> float:
        """``8 (1 - e) / (5 e)``."""
        return 1.6 * (1.0 - self.restitution) / self.restitution


# ----------------------------------------------------------------------------- friction laws

@frozen
class FrictionLaw:
    """Base class of the friction laws of a contact: a code and a row of parameters (:meth:`row`)."""

    code: ClassVar[int] = _k.NO_FRICTION

    def row(self) -> list:
        """The law's parameters as the kernel reads them (6 numbers).

        Returns
        -------
        list of float
            The parameters, in the kernel's order.
        """
        raise NotImplementedError


def _pad(values) -> list:
    return [float(v) for v in values] + [0.0] * (_k.N_FRICTION - len(values))


@frozen
class CoulombLaw(FrictionLaw):
    """Regularised Coulomb friction: ``f = -mu F v_t / sqrt(|v_t|^2 + v_eps^2)``, F the normal force.

    Parameters
    ----------
    mu : float
        Friction coefficient (>= 0).
    smoothing_speed : float
        v_eps, m/s (> 0, default 1e-3): below it the force fades linearly
        to 0 with the slip.

    Examples
    --------
    >>> import flexmb as fm
    >>> fm.CoulombLaw(0.3).row()
    [0.3, 0.001, 0.0, 0.0, 0.0, 0.0]
    """

    code: ClassVar[int] = _k.COULOMB
    mu: float = field(converter=as_float, validator=_NON_NEGATIVE)
    smoothing_speed: float = field(default=DEFAULT_SMOOTHING_SPEED, converter=as_float, validator=_POSITIVE)

    def row(self) -> list:
        """The row: mu, v_eps.

        Returns
        -------
        list of float
            The parameters, in the kernel's order.
        """
        return _pad([self.mu, self.smoothing_speed])


@frozen
class ViscousLaw(FrictionLaw):
    """Viscous friction in the tangent plane while touching: ``f = -c v_t``.

    Parameters
    ----------
    damping : float
        c, N s/m (>= 0).

    Examples
    --------
    >>> import flexmb as fm
    >>> fm.ViscousLaw(2.0).row()[0]
    2.0
    """

    code: ClassVar[int] = _k.VISCOUS
    damping: float = field(converter=as_float, validator=_NON_NEGATIVE)

    def row(self) -> list:
        """The row: c.

        Returns
        -------
        list of float
            The parameters, in the kernel's order.
        """
        return _pad([self.damping])


@frozen
class VelocityWeakeningLaw(FrictionLaw):
    """Linear velocity weakening (the wiper's tip law): ``mu = max(mu_s - s v, mu_min)``, regularised.

    Parameters
    ----------
    mu_static : float
        Coefficient at rest mu_s (>= 0).
    slope : float
        s, s/m (>= 0).
    mu_min : float
        Smallest coefficient (>= 0, <= mu_s; default 0).
    smoothing_speed : float
        v_eps, m/s (> 0, default 1e-3).

    Examples
    --------
    >>> import flexmb as fm
    >>> fm.VelocityWeakeningLaw(0.4, 0.1).row()[:3]
    [0.4, 0.1, 0.0]
    """

    code: ClassVar[int] = _k.VELOCITY_WEAKENING
    mu_static: float = field(converter=as_float, validator=_NON_NEGATIVE)
    slope: float = field(default=0.0, converter=as_float, validator=_NON_NEGATIVE)
    mu_min: float = field(default=0.0, converter=as_float, validator=_NON_NEGATIVE)
    smoothing_speed: float = field(default=DEFAULT_SMOOTHING_SPEED, converter=as_float, validator=_POSITIVE)

    def __attrs_post_init__(self):
        if self.mu_min > self.mu_static:
            raise ModelError(f"VelocityWeakeningLaw: mu_min must be <= mu_static, got {self.mu_min!r} > "
                             f"{self.mu_static!r}")

    def row(self) -> list:
        """The row: mu_s, slope, mu_min, v_eps.

        Returns
        -------
        list of float
            The parameters, in the kernel's order.
        """
        return _pad([self.mu_static, self.slope, self.mu_min, self.smoothing_speed])


@frozen
class StribeckLaw(FrictionLaw):
    """Stribeck friction: ``mu(v) = mu_k + (mu_s - mu_k) exp(-(v / v_st)^a)``, plus viscous ``sigma v``, regularised.

    ``f = -(F mu(v) / sqrt(v^2 + v_eps^2) + sigma) v_t`` with F the normal
    force and v the slip speed ``|v_t|``.

    Parameters
    ----------
    mu_static : float
        Breakaway coefficient mu_s (>= 0).
    mu_kinetic : float
        Coulomb coefficient mu_k (>= 0).
    stribeck_speed : float
        v_st, m/s (> 0).
    exponent : float
        a (> 0, default 2).
    viscous : float
        sigma, N s/m (>= 0, default 0).
    smoothing_speed : float
        v_eps, m/s (> 0, default 1e-3).

    Examples
    --------
    >>> import flexmb as fm
    >>> fm.StribeckLaw(0.5, 0.3, 0.01).row()
    [0.5, 0.3, 0.01, 2.0, 0.001, 0.0]
    """

    code: ClassVar[int] = _k.STRIBECK
    mu_static: float = field(converter=as_float, validator=_NON_NEGATIVE)
    mu_kinetic: float = field(converter=as_float, validator=_NON_NEGATIVE)
    stribeck_speed: float = field(converter=as_float, validator=_POSITIVE)
    exponent: float = field(default=2.0, converter=as_float, validator=_POSITIVE)
    viscous: float = field(default=0.0, converter=as_float, validator=_NON_NEGATIVE)
    smoothing_speed: float = field(default=DEFAULT_SMOOTHING_SPEED, converter=as_float, validator=_POSITIVE)

    def row(self) -> list:
        """The row: mu_s, mu_k, v_st, a, v_eps, sigma.

        Returns
        -------
        list of float
            The parameters, in the kernel's order.
        """
        return _pad([self.mu_static, self.mu_kinetic, self.stribeck_speed, self.exponent, self.smoothing_speed,
                     self.viscous])


# ----------------------------------------------------------------------------- the elements

def _normal_law(instance, attribute, value):
    if not isinstance(value, NormalLaw) or type(value).code < 0:
        raise ModelError(f"{label(instance)}: {attribute.name} must be a normal law (LinearContactLaw, "
                         f"HuntCrossleyLaw, LankaraniNikraveshLaw or FloresLaw), got {value!r}")


def _friction_law(instance, attribute, value):
    if value is not None and (not isinstance(value, FrictionLaw) or type(value).code <= 0):
        raise ModelError(f"{label(instance)}: {attribute.name} must be None or a friction law (CoulombLaw, "
                         f"ViscousLaw, VelocityWeakeningLaw or StribeckLaw), got {value!r}")


def _radius(instance, attribute, value):
    if not isinstance(value, float) or not np.isfinite(value) or value < 0:
        raise ModelError(f"{label(instance)}: {attribute.name} must be a finite number >= 0, got {value!r}")


@frozen
class ContactHistory:
    """What a contact element did at each output time of a result (:meth:`Contact.history`).

    Parameters
    ----------
    name : str
        The element's name.
    t : ndarray, shape (nt,)
        Output times, s.
    penetration : ndarray, shape (nt,)
        delta, m (negative: the gap while separated).
    penetration_rate : ndarray, shape (nt,)
        delta_dot, m/s (positive approaching).
    normal_force : ndarray, shape (nt,)
        N (0 while separated).
    force : ndarray, shape (nt, 3)
        Normal plus friction force on the first body (the sphere's), inertial, N.
    friction_force : ndarray, shape (nt, 3)
        Its tangential part, N.
    point : ndarray, shape (nt, 3)
        Contact point (the middle of the overlap), inertial, m.
    normal : ndarray, shape (nt, 3)
        Unit normal, towards the first body.
    slip : ndarray, shape (nt, 3)
        Tangential velocity of the first body's material point relative to
        the second's at the contact point, m/s.
    elastic_energy : ndarray, shape (nt,)
        Energy stored in the penetration, J.
    """

    name: str
    t: np.ndarray
    penetration: np.ndarray
    penetration_rate: np.ndarray
    normal_force: np.ndarray
    force: np.ndarray
    friction_force: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    slip: np.ndarray
    elastic_energy: np.ndarray

    @property
    def slip_speed(self) -> np.ndarray:
        """``|slip|``, m/s, shape (nt,)."""
        return np.linalg.norm(self.slip, axis=1)

    @property
    def in_contact(self) -> np.ndarray:
        """Whether the surfaces overlap (``penetration > 0``), shape (nt,)."""
        return self.penetration > 0


@frozen(eq=False)
class Contact(ForceElement):
    """Base class of the compiled contact elements (:class:`SpherePlaneContact`, :class:`SphereSphereContact`).

    A subclass gives its geometry's code (``geometry``) and its row of the
    load tables (:meth:`_layout`); the laws, the loads, the powers, the
    elastic energy and the histories are shared.

    Parameters
    ----------
    name : str
        Unique name.
    """

    geometry: ClassVar[int] = -1

    def _layout(self, topology):
        """Rows, local points (3, 3) and radii (2,) of this contact in the tables."""
        raise NotImplementedError

    @staticmethod
    def _locate(topology, body, point):
        """:meth:`Topology.locate`, a body given by name too (the element held by the caller keeps names)."""
        if isinstance(body, str):
            body = next((b for b in topology.index if b.name == body), body)
        return topology.locate(body, point)

    def _sides(self):
        """The two bodies in contact, the sphere's first."""
        raise NotImplementedError

    def check(self, model) -> list[str]:
        """Refuse a contact of a body with itself or of the ground with the ground.

        Parameters
        ----------
        model : Model
            The model the element belongs to.

        Returns
        -------
        list of str
            One message per problem, naming the element.
        """
        a, b = self._sides()
        if a is b or (isinstance(a, str) and a == getattr(b, "name", b)):
            return [f"{label(self)}: both sides are on the body {getattr(a, 'name', a)!r}"]
        return []

    @classmethod
    def _tables(cls, elements, topology) -> LoadTables:
        """The contacts' bodies, geometry, law codes and parameters (each concrete class's ``load_tables``)."""
        rows, local, geom, laws, par = [], [], [], [], []
        for e in elements:
            (i, j), pts, radii = e._layout(topology)
            # bodies have mass > 0 (their constructors say so); the ground's is infinite
            m_eff = 1.0 / sum(1.0 / float(topology.mass[k]) for k in (i, j) if k >= 0)
            rows.append((i, j))
            local.append(pts)
            geom.append(radii)
            laws.append((cls.geometry, e.normal_law.code, 0 if e.friction is None else e.friction.code))
            friction = [0.0] * _k.N_FRICTION if e.friction is None else e.friction.row()
            par.append(e.normal_law.row(m_eff) + friction)
        return LoadTables.of(contact_rows=np.reshape(rows, (-1, 2)), contact_local=np.reshape(local, (-1, 3, 3)),
                             contact_geom=np.reshape(geom, (-1, 2)), contact_laws=np.reshape(laws, (-1, 3)),
                             contact_par=np.reshape(par, (-1, _k.N_NORMAL + _k.N_FRICTION)))

    @classmethod
    def states_all(cls, elements, state):
        """What each element does at a kinematic state (:func:`flexmb.kernels.loads.contact_states`).

        Parameters
        ----------
        elements : sequence of Contact
            Elements of this class in the model.
        state : Kinematics
            The kinematic state.

        Returns
        -------
        tuple of ndarray
            delta, rate, normal force, elastic energy (shape (c,)), point,
            normal, force, slip (shape (c, 3)), as
            :func:`~flexmb.kernels.loads.contact_states` returns them.
        """
        t = class_tables(cls, elements, state.topology)
        return contact_states(t.contact_rows, t.contact_local, t.contact_geom, t.contact_laws, t.contact_par,
                              state.R, state.origin, state.r, state.omega, state.v)

    def apply(self, state, loads) -> None:
        """Add this contact's forces (compiled, with the rest of its class).

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.
        loads : Loads
            Accumulator to add to.
        """
        type(self).apply_all([self], state, loads)

    @classmethod
    def potential_all(cls, elements, state) -> float:
        """Elastic energy stored in the penetrations, ``K delta^(n+1) / (n + 1)`` summed, J.

        Parameters
        ----------
        elements : sequence of Contact
            The model's elements of this class.
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        float
            J.
        """
        return float(np.sum(cls.states_all(elements, state)[3]))

    def potential(self, state) -> float:
        """Elastic energy of this contact's penetration, J.

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        float
            J (0 while separated).
        """
        return type(self).potential_all([self], state)

    def history(self, result, system=None) -> ContactHistory:
        """Penetration, forces and slip of this contact at each output time of a result.

        Computed from the stored states (positions and speeds) with the
        element's own compiled evaluation.

        Parameters
        ----------
        result : Result
            A result of a model holding this element.
        system : System or Model, optional
            The model the result came from (default ``result.system``).

        Returns
        -------
        ContactHistory
            The penetration, forces, point, normal, slip and elastic energy
            at each output time.

        Raises
        ------
        ModelError
            If no system is known or this element is not in it.
        """
        from ..model import as_system

        system = system if system is not None else result.system
        if system is None:
            raise ModelError(f"{label(self)}.history needs the system the result came from (a loaded result does "
                             f"not keep it): history(res, system=system)")
        system = as_system(system)
        me = system.model.element(self, ForceElement)  # the model's copy, if it resolved names
        nt = result.t.shape[0]
        out = {k: np.zeros(nt) for k in ("penetration", "penetration_rate", "normal_force", "elastic_energy")}
        out.update({k: np.zeros((nt, 3)) for k in ("force", "friction_force", "point", "normal", "slip")})
        for i in range(nt):
            kin = system.kinematics(result.t[i], result.x[i], result.xd[i])
            delta, rate, fn, energy, point, normal, force, slip = type(me).states_all([me], kin)
            out["penetration"][i], out["penetration_rate"][i] = delta[0], rate[0]
            out["normal_force"][i], out["elastic_energy"][i] = fn[0], energy[0]
            out["force"][i], out["point"][i], out["normal"][i], out["slip"][i] = force[0], point[0], normal[0], slip[0]
            out["friction_force"][i] = force[0] - fn[0] * normal[0]
        return ContactHistory(self.name, np.array(result.t, dtype=float), **out)


@frozen(eq=False)
class SpherePlaneContact(Contact):
    """A sphere (or a point) on a body against a plane of another body or of the ground.

    Parameters
    ----------
    name : str
        Unique name.
    body : Body or str
        The body carrying the sphere (rigid or flexible), or its name.
    radius : float
        Sphere radius r, m (>= 0; 0: a point).
    normal_law : NormalLaw
        The normal force of a penetration (:class:`LinearContactLaw`,
        :class:`HuntCrossleyLaw`, :class:`LankaraniNikraveshLaw`,
        :class:`FloresLaw`).
    friction : FrictionLaw, optional
        The tangential force (:class:`CoulombLaw`, :class:`ViscousLaw`,
        :class:`VelocityWeakeningLaw`, :class:`StribeckLaw`); None: none.
    centre : array_like, shape (3,)
        Sphere centre in the frame of ``body``, m (default its origin).
    plane_body : Body or str
        The body carrying the plane (default the ground).
    plane_point : array_like, shape (3,)
        A point of the plane in the frame of ``plane_body``, m.
    plane_normal : array_like, shape (3,)
        The plane's outward normal in the frame of ``plane_body``
        (normalised): the sphere is outside the body on this side.

    Notes
    -----
    Penetration ``delta = r - (c - p) . n`` with c the sphere's centre, p
    the plane's point and n its normal; the plane is unbounded (a
    half-space). The force acts at ``c - (r - delta / 2) n``.

    Examples
    --------
    A ball of 1 kg and radius 0.1 m, 1 mm into the floor with a linear law
    of 10^5 N/m: the floor pushes it up with 100 N and stores 0.05 J.

    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> ball = fm.RigidBody("ball", mass=1.0, inertia=np.eye(3) * 4e-3)
    >>> floor = fm.SpherePlaneContact("floor", ball, 0.1, fm.LinearContactLaw(1e5))
    >>> system = model.add(fm.Free("free", model.ground, ball), floor).build()
    >>> kin = system.kinematics(0.0, np.array([0.0, 0.0, 0.099, 0.0, 0.0, 0.0]), np.zeros(6))
    >>> system.forces.active_force(kin)[:3].round(9)
    array([  0.,   0., 100.])
    >>> round(floor.potential(kin), 12)
    0.05
    """

    geometry: ClassVar[int] = _k.SPHERE_PLANE

    body: Body = reference(Body)
    radius: float = field(converter=as_float, validator=_radius)
    normal_law: NormalLaw = field(validator=_normal_law)
    friction: FrictionLaw | None = field(default=None, validator=_friction_law)
    centre: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    plane_body: Body = reference(Body, default="ground")
    plane_point: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    plane_normal: np.ndarray = field(default=(0.0, 0.0, 1.0), converter=as_unit_vector, validator=unit_vector)

    def _sides(self):
        return self.body, self.plane_body

    @classmethod
    def load_tables(cls, elements, topology) -> LoadTables:
        """The contacts' bodies, geometry, law codes and parameters (compiled, :mod:`flexmb.forces.tables`).

        Parameters
        ----------
        elements : sequence of SpherePlaneContact
            The model's elements of this class.
        topology : Topology
            The model's tree.

        Returns
        -------
        LoadTables
            Their ``contact_*`` rows.
        """
        return cls._tables(elements, topology)

    def _layout(self, topology):
        i, c = self._locate(topology, self.body, self.centre)
        j, p = self._locate(topology, self.plane_body, self.plane_point)
        # a flexible body's segment frames are parallel to the body frame at the reference state
        return (i, j), np.array([c, p, self.plane_normal]), (self.radius, 0.0)


@frozen(eq=False)
class SphereSphereContact(Contact):
    """Two spheres (or a sphere and a point) on two bodies.

    Parameters
    ----------
    name : str
        Unique name.
    body1 : Body or str
        The body carrying the first sphere, or its name.
    radius1 : float
        Its radius, m (>= 0).
    body2 : Body or str
        The body carrying the second sphere (it may be the ground).
    radius2 : float
        Its radius, m (>= 0).
    normal_law : NormalLaw
        The normal force of a penetration.
    friction : FrictionLaw, optional
        The tangential force; None: none.
    centre1, centre2 : array_like, shape (3,)
        The centres in their bodies' frames, m (default the origins).

    Notes
    -----
    Penetration ``delta = r1 + r2 - |c1 - c2|``; the force acts along
    ``n = (c1 - c2) / |c1 - c2|`` at ``c1 - (r1 - delta / 2) n``. For the
    Hertz stiffness of two spheres, :func:`hertz_stiffness` with both radii.

    Examples
    --------
    Two balls of radius 0.1 m whose centres are 0.19 m apart overlap by
    10 mm: a linear law of 10^4 N/m pushes them apart with 100 N.

    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> a = fm.RigidBody("a", mass=1.0, inertia=np.eye(3) * 4e-3)
    >>> b = fm.RigidBody("b", mass=1.0, inertia=np.eye(3) * 4e-3)
    >>> hit = fm.SphereSphereContact("hit", a, 0.1, b, 0.1, fm.LinearContactLaw(1e4))
    >>> free_b = fm.Free("fb", model.ground, b, parent_point=(0.19, 0, 0))
    >>> system = model.add(fm.Free("fa", model.ground, a), free_b, hit).build()
    >>> kin = system.kinematics(0.0, np.zeros(12), np.zeros(12))
    >>> system.forces.active_force(kin)[[0, 6]].round(9)
    array([-100.,  100.])
    """

    geometry: ClassVar[int] = _k.SPHERE_SPHERE

    body1: Body = reference(Body)
    radius1: float = field(converter=as_float, validator=_radius)
    body2: Body = reference(Body)
    radius2: float = field(converter=as_float, validator=_radius)
    normal_law: NormalLaw = field(validator=_normal_law)
    friction: FrictionLaw | None = field(default=None, validator=_friction_law)
    centre1: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    centre2: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)

    def _sides(self):
        return self.body1, self.body2

    @classmethod
    def load_tables(cls, elements, topology) -> LoadTables:
        """The contacts' bodies, geometry, law codes and parameters (compiled, :mod:`flexmb.forces.tables`).

        Parameters
        ----------
        elements : sequence of SphereSphereContact
            The model's elements of this class.
        topology : Topology
            The model's tree.

        Returns
        -------
        LoadTables
            Their ``contact_*`` rows.
        """
        return cls._tables(elements, topology)

    def _layout(self, topology):
        i, c1 = self._locate(topology, self.body1, self.centre1)
        j, c2 = self._locate(topology, self.body2, self.centre2)
        return (i, j), np.array([c1, c2, np.zeros(3)]), (self.radius1, self.radius2)
