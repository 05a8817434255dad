"""The force element base class and the loads accumulator (eq. 5).

A force element adds forces at points, torques on bodies, or generalized
forces on coordinates to a :class:`Loads` accumulator. The assembler turns
them into ``F_l = sum_k V_kl . force_k + W_kl . torque_k`` (eq. 5).
"""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from .._validate import name_check
from ..kernels.loads import add_point_forces, add_torques
from .tables import apply_tables, class_tables

__all__ = ["ForceElement", "Loads"]


class Loads:
    """Accumulator of the loads applied in one evaluation.

    Parameters
    ----------
    state : object
        The kinematic state (:class:`flexmb.kinematics.Kinematics`).

    Attributes
    ----------
    force : ndarray, shape (n_bodies + 1, 3)
        Resultant force on each body at its mass centre, N (the last row is
        the ground and is discarded).
    torque : ndarray, shape (n_bodies + 1, 3)
        Resultant torque on each body about its mass centre, N m.
    generalized : ndarray, shape (n_speeds,)
        Generalized forces acting directly on coordinates (joint springs).
    """

    def __init__(self, state):
        self.state = state
        nb1 = state.R.shape[0]
        self.force = np.zeros((nb1, 3))
        self.torque = np.zeros((nb1, 3))
        self.generalized = np.zeros(state.xd.shape[0])

    def add_point_force(self, body_index, point, force) -> None:
        """Add forces applied at inertial points.

        Parameters
        ----------
        body_index : int or ndarray of int, shape (m,)
            Bodies the forces act on (-1 is the ground).
        point : ndarray, shape (m, 3)
            Points of application, inertial, m.
        force : ndarray, shape (m, 3)
            Forces, inertial, N.
        """
        add_point_forces(np.atleast_1d(np.asarray(body_index, dtype=np.int64)),
                         np.ascontiguousarray(np.reshape(point, (-1, 3)), dtype=float),
                         np.ascontiguousarray(np.reshape(force, (-1, 3)), dtype=float),
                         self.state.r, self.force, self.torque)

    def add_torque(self, body_index, torque) -> None:
        """Add torques (inertial components, N m) to bodies.

        Parameters
        ----------
        body_index : int or ndarray of int, shape (m,)
            Bodies the torques act on (-1 is the ground).
        torque : ndarray, shape (m, 3)
            Torques, inertial, N m.
        """
        add_torques(np.atleast_1d(np.asarray(body_index, dtype=np.int64)),
                    np.ascontiguousarray(np.reshape(torque, (-1, 3)), dtype=float), self.torque)


@frozen(eq=False)
class ForceElement:
    """Base class of force elements.

    Subclasses must:

    1. have a ``name`` and the element's data as attrs fields;
    2. implement ``apply(state, loads)``: add this element's loads;
    3. if conservative, implement ``potential(state)`` (J), so that energy
       checks see it; dissipative elements keep the default 0.

    For speed, a built-in overrides the class method ``apply_all`` to treat
    all elements of its class in one vectorised call; the default loops.

    The ``state`` gives ``t``, ``x``, ``xd``, ``R`` (rotations), ``r`` (mass
    centres), ``v``, ``omega``, and ``index(body)``, ``point_position``,
    ``point_velocity`` and ``coordinate_slice(joint)``.

    Parameters
    ----------
    name : str
        Unique name of the element.

    Examples
    --------
    A linear drag on a body's mass centre, ``-c v``: one field of data and
    one method. On a 1 m bar turning at 2 rad/s about a pin at its end, the
    mass centre moves at 1 m/s, and the drag's generalized force is
    ``-c (L / 2)^2 * omega = -0.25`` N m for ``c = 0.5`` N s/m.

    >>> import numpy as np
    >>> from attrs import field, frozen
    >>> import flexmb as fm
    >>> @frozen(eq=False)
    ... class Drag(fm.ForceElement):
    ...     body: fm.Body = field()
    ...     c: float = 0.5
    ...
    ...     def apply(self, state, loads):
    ...         k = state.index(self.body)
    ...         loads.add_point_force(k, state.r[k], -self.c * state.v[k])
    >>> model = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    >>> system = model.add(fm.Revolute("pin", model.ground, bar), Drag("drag", bar)).build()
    >>> kin = system.kinematics(0.0, np.zeros(1), np.array([2.0]))
    >>> system.forces.active_force(kin)
    array([-0.25])
    """

    name: str = field(validator=name_check)

    def apply(self, state, loads: Loads) -> None:
        """Add this element's loads.

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.
        loads : Loads
            Accumulator to add to.
        """
        raise NotImplementedError(f"{type(self).__name__} must implement apply(state, loads)")

    def potential(self, state) -> float:
        """Potential energy of the element (0 if not conservative).

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        float
            Potential energy, J.
        """
        return 0.0

    def check(self, model) -> list[str]:
        """List the problems with this element in ``model``.

        Called by :meth:`flexmb.Model.validate`, which collects the problems
        of every element into one :class:`flexmb.ModelError`.

        Parameters
        ----------
        model : Model
            The model the element belongs to.

        Returns
        -------
        list of str
            One message per problem, naming the element (empty if none).
        """
        return []

    @classmethod
    def apply_all(cls, elements, state, loads: Loads) -> None:
        """Apply all elements of this class (default: one at a time).

        Parameters
        ----------
        elements : sequence of ForceElement
            The model's elements of this class.
        state : Kinematics
            The current kinematic state.
        loads : Loads
            Accumulator to add to.
        """
        tables = class_tables(cls, elements, state.topology)
        if tables is not None:  # a built-in class: its compiled kernel
            apply_tables(tables, state, loads)
            return
        for e in elements:
            e.apply(state, loads)

    @classmethod
    def load_tables(cls, elements, topology):
        """The elements as flat tables for the compiled kernel, or None (default: not compiled).

        A built-in class defines this (in its own body: a subclass that
        changes ``apply`` does not inherit it) and ``apply_all`` then runs
        :func:`flexmb.kernels.loads.apply_load_tables`; so does the fused
        right-hand side of an open tree.

        Parameters
        ----------
        elements : sequence of ForceElement
            The model's elements of this class.
        topology : Topology
            The model's tree (:meth:`~flexmb.topology.Topology.locate` maps
            points to body rows).

        Returns
        -------
        LoadTables or None
        """
        return None

    @classmethod
    def potential_all(cls, elements, state) -> float:
        """Summed potential energy of all elements of this class.

        Parameters
        ----------
        elements : sequence of ForceElement
            The model's elements of this class.
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        float
            Potential energy, J.
        """
        return float(sum(e.potential(state) for e in elements))

    @classmethod
    def potential_states(cls, elements, topology, X, positions=None):
        """The potential energy of all elements of this class at many states at once, where it needs only ``x``.

        Parameters
        ----------
        elements : sequence of ForceElement
            The model's elements of this class.
        topology : Topology
            The model's tree.
        X : ndarray, shape (nt, nq)
            The states' coordinates.
        positions : ndarray, shape (nt, n_bodies, 3), optional
            The bodies' mass centres at the states, where the caller has
            them (:class:`~flexmb.forces.Gravity`'s energy needs them).

        Returns
        -------
        ndarray, shape (nt,), or None
            The energies, J; None (here) where only :meth:`potential_all`
            of each state's kinematics gives them.
        """
        return None

    @classmethod
    def tangent_all(cls, elements, state):
        """Diagonal stiffness and damping the elements put on coordinates, if any.

        Used to build the Jacobian for implicit integrators; elements that
        act through bodies return None (their stiffness is not included).

        Parameters
        ----------
        elements : sequence of ForceElement
            The model's elements of this class.
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        tuple of (cols, k, c) or None
            Coordinate indices and the spring and damper constants on them
            (``dF/dx = -k``, ``dF/dxd = -c`` on the diagonal).
        """
        return None

    @classmethod
    def pair_tangent_all(cls, elements, state):
        """Stiffness and damping of forces between two points, on their relative motion, if any.

        Used, like :meth:`tangent_all`, for the implicit integrators'
        Jacobian and for the fastest rate that ``method='auto'`` and the
        :class:`~flexmb.StiffnessWarning` judge by: a stiff spring or damper
        between two bodies left out makes a stiff scene look soft.

        Parameters
        ----------
        elements : sequence of ForceElement
            The model's elements of this class.
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        tuple of (rows, points, K, D) or None
            Body rows (m, 2) and inertial points (m, 2, 3) of the two ends
            of each force; ``K = -dF/d(p2 - p1)`` and ``D = -dF/d(v2 - v1)``
            (m, 3, 3), with F the force on the second end (the first gets
            -F).
        """
        return None

    @classmethod
    def velocity_tangent_all(cls, elements, state):
        """Derivatives of point forces with respect to the points' velocities, if any.

        Used, like :meth:`tangent_all`, for the implicit integrators'
        Jacobian: a stiff velocity-dependent force (a regularised friction,
        a damper) left out of it makes Newton's method slow.

        Parameters
        ----------
        elements : sequence of ForceElement
            The model's elements of this class.
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        tuple of (rows, points, D) or None
            Body rows (m,), inertial points (m, 3) and ``D = dF/dv``
            (m, 3, 3) of each force.
        """
        return None
