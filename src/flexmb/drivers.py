"""Prescribed motions (drivers) of joint coordinates.

A driver adds the rheonomic constraint ``phi = q_c - theta(t) = 0`` (eq. 28),
whose speed form ``psi xdot = b`` has ``b = -dphi/dt = theta'(t)`` (eq. 29).
The effort the driver supplies (torque or force) is the constraint reaction
recovered after the accelerations.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from attrs import field, frozen

from ._names import reference
from ._validate import name_check, number
from .errors import ModelError
from .fields import as_count, label
from .joints import Joint

__all__ = ["Driver"]


def _callable(instance, attribute, value):
    if not callable(value):
        raise ModelError(f"{label(instance)}: {attribute.name} must be callable, got {value!r}")


@frozen(eq=False)
class Driver:
    """Prescribe one coordinate of a joint as a function of time.

    Parameters
    ----------
    name : str
        Unique name.
    joint : Joint or str
        The driven joint (a tree joint), or its name: a name is resolved
        when the model is built, so the driver may be written before the
        joint is added.
    position, velocity, acceleration : callable
        ``theta(t)``, ``theta'(t)`` and ``theta''(t)`` (rad or m, and their
        rates); they must be consistent derivatives.
    coordinate : int
        Which coordinate of the joint (0 for a revolute).
    law : tuple, optional
        The closed form of ``theta(t)``, set by :meth:`constant_speed`
        (``('constant_speed', start, speed)``) and :meth:`harmonic`
        (``('harmonic', offset, amplitude, omega)``, omega in rad/s):
        compiled code may then evaluate the driver itself, with the
        callables' arithmetic (CVODE stepped in compiled code on a model
        with loops, :mod:`flexmb.integrators.cvode_direct_loops`). None for
        any other motion, which only the three callables give.

    Examples
    --------
    >>> import flexmb as fm
    >>> m = fm.Model()
    >>> crank = fm.RigidBody.slender_bar("crank", 0.1, 0.1)
    >>> pin = fm.Revolute("pin", m.ground, crank)
    >>> d = fm.Driver.constant_speed("motor", pin, speed=2 * 3.141592653589793)
    >>> float(d.position(0.5))
    3.141592653589793
    """

    name: str = field(validator=name_check)
    joint: Joint = reference(Joint)
    position: Callable[[float], float] = field(validator=_callable)
    velocity: Callable[[float], float] = field(validator=_callable)
    acceleration: Callable[[float], float] = field(validator=_callable)
    coordinate: int = field(default=0, converter=as_count)
    law: tuple | None = field(default=None, kw_only=True)

    def __attrs_post_init__(self):
        if isinstance(self.coordinate, bool) or not isinstance(self.coordinate, int):
            raise ModelError(f"{label(self)}: coordinate must be an integer >= 0, got {self.coordinate!r}")
        if isinstance(self.joint, str):  # a name: checked when the model resolves it
            return
        if not 0 <= self.coordinate < self.joint.n_coords:
            raise ModelError(
                f"{label(self)}: coordinate {self.coordinate} out of range for joint "
                f"{self.joint.name!r} with {self.joint.n_coords} coordinate(s)"
            )

    @property
    def effort_unit(self) -> str:
        """Unit of the effort that holds the driven coordinate: ``'N m'`` (a rotation), ``'N'`` (a translation).

        ``'-'`` when the joint does not say (a joint class computing its own
        motion, or a joint still given by name).
        """
        joint = self.joint
        if isinstance(joint, str):
            return "-"
        n_t, n_r = len(joint.translation_axes), len(joint.rotation_axes)
        if len(joint.coordinate_names) != n_t + n_r:
            return "-"
        return "N" if self.coordinate < n_t else "N m"

    @classmethod
    def constant_speed(cls, name: str, joint: Joint | str, speed: float, start: float = 0.0, coordinate: int = 0):
        """``theta(t) = start + speed * t``.

        Parameters
        ----------
        name : str
            Driver name.
        joint : Joint or str
            Driven joint, or its name.
        speed : float
            Rate, rad/s or m/s.
        start : float
            Value at t = 0.
        coordinate : int
            Coordinate index in the joint.

        Returns
        -------
        Driver
            The driver.
        """
        speed, start = (number(f"Driver {name!r}", what, v) for what, v in (("speed", speed), ("start", start)))
        return cls(
            name,
            joint,
            position=lambda t: start + speed * t,
            velocity=lambda t: speed,
            acceleration=lambda t: 0.0,
            coordinate=coordinate,
            law=("constant_speed", start, speed),
        )

    @classmethod
    def harmonic(cls, name: str, joint: Joint | str, amplitude: float, frequency: float,
                 offset: float = 0.0, coordinate: int = 0):
        """``theta(t) = offset + amplitude * sin(2 pi frequency t)``.

        Parameters
        ----------
        name : str
            Driver name.
        joint : Joint or str
            Driven joint, or its name.
        amplitude : float
            Amplitude, rad or m.
        frequency : float
            Frequency, Hz.
        offset : float
            Mean value.
        coordinate : int
            Coordinate index in the joint.

        Returns
        -------
        Driver
            The driver.
        """
        f, a, o = (number(f"Driver {name!r}", what, v) for what, v in (("frequency", frequency),
                                                                       ("amplitude", amplitude), ("offset", offset)))
        w = 2 * np.pi * f
        return cls(
            name,
            joint,
            position=lambda t: o + a * np.sin(w * t),
            velocity=lambda t: a * w * np.cos(w * t),
            acceleration=lambda t: -a * w * w * np.sin(w * t),
            coordinate=coordinate,
            law=("harmonic", o, a, w),
        )
