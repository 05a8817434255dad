"""Normal laws of the contact elements, and Hertz's stiffness.

Each law is a small frozen record of its parameters that gives its code in
:mod:`flexmb.kernels.contact` and its row of parameters for the load
tables; :mod:`flexmb.forces.contact` has the overview and the references.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from attrs import field, frozen

from ..errors import ModelError
from ..fields import as_float
from ..kernels import contact as _k

__all__ = ["NormalLaw", "LinearContactLaw", "HuntCrossleyLaw", "LankaraniNikraveshLaw", "FloresLaw",
           "hertz_stiffness", "restitution_of_hysteresis"]


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
            K, n, d, m and 0: the impact speed held, none until an onset
            (:mod:`flexmb.impact_speeds`; read by the restitution laws only).
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
    The law needs the impact speed v_in of the current impact: the rate
    of penetration at the contact's onset, held until its separation, in a
    run with contact events (:mod:`flexmb.impact_speeds`). Where none is
    held (no events, a contact touching at the run's start, the rows of a
    capsule on a plane or of a group) the element takes it from the
    contact's state: the v_in that brings the mass m, under this law
    alone, to the current penetration and rate (its first integral,
    :func:`flexmb.kernels.contact.impact_speed`), exact for a free body
    striking the ground, or two free bodies, through their mass centres.
    The rebound ratio is ``restitution_of_hysteresis(chi)`` at every impact
    speed, less the share of the other forces acting during the impact.

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
    The law needs the impact speed v_in of the current impact: the rate
    of penetration at the contact's onset, held until its separation, in a
    run with contact events (:mod:`flexmb.impact_speeds`). Where none is
    held (no events, a contact touching at the run's start, the rows of a
    capsule on a plane or of a group) the element takes it from the
    contact's state: the v_in that brings the mass m, under this law
    alone, to the current penetration and rate (its first integral,
    :func:`flexmb.kernels.contact.impact_speed`), exact for a free body
    striking the ground, or two free bodies, through their mass centres.
    The rebound ratio is ``restitution_of_hysteresis(chi)`` at every impact
    speed, less the share of the other forces acting during the impact.

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
