"""Applied forces and torques: constant or given by a function of time."""

from __future__ import annotations

import inspect
from typing import Any

import numpy as np
from attrs import field, frozen

from .._names import reference
from .._validate import name_check
from ..bodies import Body
from ..errors import ModelError
from ..fields import as_array, label, vector3
from .base import ForceElement
from .tables import LoadTables

__all__ = ["PointForce", "BodyTorque"]


def _vector_or_callable(value):
    return value if callable(value) else as_array(value)


def _check_value(instance, attribute, value):
    if callable(value):
        n = len(inspect.signature(value).parameters)
        if n not in (1, 2):
            raise ModelError(f"{label(instance)}: {attribute.name} must take (t) or (t, state), takes {n} arguments")
    else:
        vector3(instance, attribute, value)


def _check_frame(instance, attribute, value):
    if value not in ("ground", "body"):
        raise ModelError(f"{label(instance)}: frame must be 'ground' or 'body', got {value!r}")


def _evaluate(value, state) -> np.ndarray:
    if not callable(value):
        return value
    if len(inspect.signature(value).parameters) == 1:
        return np.asarray(value(state.t), dtype=float)
    return np.asarray(value(state.t, state), dtype=float)


@frozen(eq=False)
class PointForce(ForceElement):
    """A force at a point of a body.

    Parameters
    ----------
    name : str
        Unique name.
    body : Body or str
        Body the force acts on, or its name.
    force : array_like, shape (3,), or callable
        Force, N: a constant vector, or ``f(t)`` / ``f(t, state)`` returning one.
    point : array_like, shape (3,)
        Point of application in the body frame, m.
    frame : {'ground', 'body'}
        Frame of the force components.

    Examples
    --------
    1 N pushing down on the tip of a 1 m bar that lies along x gives a
    moment of -1 N m about the pin; with ``frame='body'`` the force turns
    with the bar, so at 90 deg the same body-frame force still gives -1 N m.

    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)  # along +x from the pin
    >>> pin = fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1))
    >>> push = fm.PointForce("push", bar, (0.0, -1.0, 0.0), point=(1.0, 0.0, 0.0), frame="body")
    >>> system = model.add(pin, push).build()
    >>> for angle in (0.0, np.pi / 2):
    ...     kin = system.kinematics(0.0, np.array([angle]), np.zeros(1))
    ...     print(system.forces.active_force(kin).round(12))
    [-1.]
    [-1.]
    """

    body: Body = reference(Body)
    force: Any = field(converter=_vector_or_callable, validator=_check_value)
    point: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    frame: str = field(default="ground", validator=_check_frame)

    @classmethod
    def load_tables(cls, elements, topology) -> LoadTables | None:
        """Constant forces as tables (compiled); None if one is a function of time.

        Parameters
        ----------
        elements : sequence of PointForce
            The model's elements of this class.
        topology : Topology
            The model's tree.

        Returns
        -------
        LoadTables or None
        """
        if any(callable(e.force) for e in elements):
            return None
        where = [topology.locate(e.body, e.point) for e in elements]
        return LoadTables.of(force_rows=[k for k, _ in where], force_local=np.reshape([p for _, p in where], (-1, 3)),
                             force_vec=np.reshape([e.force for e in elements], (-1, 3)),
                             force_in_body=[e.frame == "body" for e in elements])

    def apply(self, state, loads) -> None:
        """Add the force at its point.

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.
        loads : Loads
            Accumulator to add to.
        """
        if not callable(self.force):  # the compiled kernel (load_tables)
            type(self).apply_all([self], state, loads)
            return
        k, local = state.locate(self.body, self.point)
        f = _evaluate(self.force, state)
        if self.frame == "body":
            f = state.R[k] @ f
        loads.add_point_force(k, state.point_position(k, local), f)


@frozen(eq=False)
class BodyTorque(ForceElement):
    """A pure torque on a body.

    Parameters
    ----------
    name : str
        Unique name.
    body : Body or str
        Body the torque acts on, or its name.
    torque : array_like, shape (3,), or callable
        Torque, N m: a constant vector, or ``f(t)`` / ``f(t, state)``.
    frame : {'ground', 'body'}
        Frame of the torque components.
    point : array_like, shape (3,)
        On a flexible body, a body-frame point of the segment that takes the
        torque (ignored on a rigid body).

    Examples
    --------
    A torque that grows with time, ``(0, 0, 3 t)`` N m, on a pinned bar: its
    generalized force on the pin angle at t = 2 s is 6 N m.

    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)  # along +x from the pin
    >>> pin = fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1))
    >>> motor = fm.BodyTorque("motor", bar, lambda t: (0.0, 0.0, 3.0 * t))
    >>> system = model.add(pin, motor).build()
    >>> kin = system.kinematics(2.0, np.zeros(1), np.zeros(1))
    >>> system.forces.active_force(kin)
    array([6.])
    """

    body: Body = reference(Body)
    torque: Any = field(converter=_vector_or_callable, validator=_check_value)
    frame: str = field(default="ground", validator=_check_frame)
    point: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)

    @classmethod
    def load_tables(cls, elements, topology) -> LoadTables | None:
        """Constant torques as tables (compiled); None if one is a function of time.

        Parameters
        ----------
        elements : sequence of BodyTorque
            The model's elements of this class.
        topology : Topology
            The model's tree.

        Returns
        -------
        LoadTables or None
        """
        if any(callable(e.torque) for e in elements):
            return None
        return LoadTables.of(torque_rows=[topology.locate(e.body, e.point)[0] for e in elements],
                             torque_vec=np.reshape([e.torque for e in elements], (-1, 3)),
                             torque_in_body=[e.frame == "body" for e in elements])

    def apply(self, state, loads) -> None:
        """Add the torque.

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.
        loads : Loads
            Accumulator to add to.
        """
        if not callable(self.torque):  # the compiled kernel (load_tables)
            type(self).apply_all([self], state, loads)
            return
        k, _ = state.locate(self.body, self.point)
        tq = _evaluate(self.torque, state)
        if self.frame == "body":
            tq = state.R[k] @ tq
        loads.add_torque(k, tq)
