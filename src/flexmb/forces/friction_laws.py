"""Friction laws of the contact elements: the laws of :mod:`flexmb.kernels.friction`, loaded by the normal force.

Each law is a small frozen record of its parameters that gives its code in
:mod:`flexmb.kernels.contact` and its row of parameters for the load tables.
"""

from __future__ import annotations

from typing import ClassVar

from attrs import field, frozen

from ..errors import ModelError
from ..fields import as_float
from ..kernels import contact as _k
from .contact_laws import _NON_NEGATIVE, _POSITIVE

__all__ = ["FrictionLaw", "CoulombLaw", "ViscousLaw", "VelocityWeakeningLaw", "StribeckLaw",
           "DEFAULT_SMOOTHING_SPEED"]

#: default smoothing speed of the regularised friction laws, m/s (that of ``flexmb_friction``)
DEFAULT_SMOOTHING_SPEED = 1e-3


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
