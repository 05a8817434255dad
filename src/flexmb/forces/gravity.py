"""Uniform gravity on every body."""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from .._validate import name_check
from ..fields import as_array, vector3
from .base import ForceElement
from .tables import LoadTables

__all__ = ["Gravity"]


@frozen(eq=False)
class Gravity(ForceElement):
    """Uniform gravity: force ``m_k g`` at each mass centre.

    Parameters
    ----------
    g : array_like, shape (3,)
        Gravitational acceleration, inertial, m/s^2.
    name : str
        Name (default ``"gravity"``).

    Notes
    -----
    Potential energy ``U = -sum_k m_k (g @ r_k)``.

    Examples
    --------
    A bar of 1 kg and 1 m pinned at one end, turned up by 90 deg: its mass
    centre is 0.5 m higher and ``U = m g h = 4.905`` J. Flat (angle 0),
    gravity's generalized force on the pin angle is the moment
    ``-m g L / 2 = -4.905`` N m.

    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)  # along +x from the pin
    >>> pin = fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1))
    >>> _ = model.add(pin, fm.Gravity((0.0, -9.81, 0.0)))
    >>> system = model.build()
    >>> up = system.kinematics(0.0, np.array([np.pi / 2]), np.zeros(1))
    >>> round(model["gravity"].potential(up), 9)
    4.905
    >>> flat = system.kinematics(0.0, np.zeros(1), np.zeros(1))
    >>> system.forces.active_force(flat).round(9)
    array([-4.905])
    """

    g: np.ndarray = field(default=(0.0, 0.0, -9.81), converter=as_array, validator=vector3)
    name: str = field(default="gravity", validator=name_check)

    @classmethod
    def load_tables(cls, elements, topology) -> LoadTables:
        """The summed ``g`` of all gravity elements (compiled, :mod:`flexmb.forces.tables`).

        Parameters
        ----------
        elements : sequence of Gravity
            The model's gravity elements.
        topology : Topology
            The model's tree.

        Returns
        -------
        LoadTables
        """
        return LoadTables.of(gravity=np.sum([e.g for e in elements], axis=0))

    def apply(self, state, loads) -> None:
        """Add ``m g`` to every body.

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.
        loads : Loads
            Accumulator to add to.
        """
        type(self).apply_all([self], state, loads)

    def potential(self, state) -> float:
        """Potential energy ``U = -sum_k m_k (g @ r_k)``.

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        float
            Potential energy, J.
        """
        return float(-np.add.reduce(state.mass * (state.r[:-1] @ self.g)))  # (np.sum's reduction, unwrapped)

    @classmethod
    def potential_states(cls, elements, topology, X, positions=None):
        """:meth:`potential` of all elements at many states at once, from the mass centres ``positions``.

        Parameters
        ----------
        elements : sequence of Gravity
            The model's gravity elements.
        topology : Topology
            The model's tree (its masses).
        X : ndarray, shape (nt, nq)
            The states' coordinates (not read).
        positions : ndarray, shape (nt, n_bodies, 3), optional
            The bodies' mass centres at the states.

        Returns
        -------
        ndarray, shape (nt,), or None
            Potential energies, J (the sum over the elements, in their
            order, as :meth:`~flexmb.forces.ForceElement.potential_all`
            adds them); None without ``positions``.
        """
        if positions is None:
            return None
        total = np.zeros(len(positions))
        for e in elements:
            total += -np.add.reduce(topology.mass * (positions @ e.g), axis=1)
        return total
