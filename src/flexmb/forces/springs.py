"""Spring-dampers: point to point, and on joint coordinates."""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from .._names import reference
from .._validate import name_check
from ..bodies import Body
from ..fields import as_array, as_float, finite_array, label, vector3
from ..joints import Joint
from .base import ForceElement
from .tables import LoadTables, class_tables

__all__ = ["SpringDamper", "JointSpringDamper"]


def _non_negative(instance, attribute, value):
    from ..errors import ModelError

    if not isinstance(value, (float, np.ndarray)) or np.asarray(value).dtype != float:
        raise ModelError(f"{label(instance)}: {attribute.name} must be numbers, got {value!r}")
    v = np.asarray(value)
    if not np.all(np.isfinite(v)) or np.any(v < 0):
        raise ModelError(f"{label(instance)}: {attribute.name} must be finite and >= 0, got {v.tolist()}")


@frozen(eq=False)
class SpringDamper(ForceElement):
    """A linear spring-damper between two points.

    Parameters
    ----------
    name : str
        Unique name.
    body1 : Body or str
        The first body (it may be the ground), or its name.
    point1 : array_like, shape (3,)
        Attachment point in the frame of ``body1``, m.
    body2 : Body or str
        The second body (it may be the ground), or its name.
    point2 : array_like, shape (3,)
        Attachment point in the frame of ``body2``, m.
    stiffness : float
        k, N/m.
    damping : float
        c, N s/m.
    rest_length : float
        l0, m.

    Notes
    -----
    The force on point 2 is ``-(k (l - l0) + c dl/dt) e``, with ``e`` the unit
    vector from point 1 to point 2; point 1 gets the opposite. Potential
    energy ``k (l - l0)^2 / 2``. With ``l0 = 0`` the spring acts as the
    vector ``-k (p2 - p1)``, smooth through ``l = 0``.

    Examples
    --------
    A spring of 10 N/m and rest length 0.5 m from the ground point
    (1, 1, 0) to the tip of a 1 m bar lying along x: stretched to 1 m, it
    stores ``k (l - l0)^2 / 2 = 1.25`` J and pulls the tip up along y, a
    moment ``k (l - l0) L = 5`` N m about the pin.

    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)  # along +x from the pin
    >>> pin = fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1))
    >>> spring = fm.SpringDamper("spring", model.ground, (1.0, 1.0, 0.0), bar, (1.0, 0.0, 0.0),
    ...                          stiffness=10.0, rest_length=0.5)
    >>> system = model.add(pin, spring).build()
    >>> kin = system.kinematics(0.0, np.zeros(1), np.zeros(1))
    >>> spring.potential(kin)
    1.25
    >>> system.forces.active_force(kin).round(12)
    array([5.])
    """

    body1: Body = reference(Body)
    point1: np.ndarray = field(converter=as_array, validator=vector3)
    body2: Body = reference(Body)
    point2: np.ndarray = field(converter=as_array, validator=vector3)
    stiffness: float = field(converter=as_float, validator=_non_negative)
    damping: float = field(default=0.0, converter=as_float, validator=_non_negative)
    rest_length: float = field(default=0.0, converter=as_float, validator=_non_negative)

    def _geometry(self, state):
        i, l1 = state.locate(self.body1, self.point1)
        j, l2 = state.locate(self.body2, self.point2)
        p1 = state.point_position(i, l1)
        p2 = state.point_position(j, l2)
        return i, j, p1, p2

    @classmethod
    def load_tables(cls, elements, topology) -> LoadTables:
        """The spring-dampers' ends, constants and rest lengths (compiled, :mod:`flexmb.forces.tables`).

        Parameters
        ----------
        elements : sequence of SpringDamper
            The model's elements of this class.
        topology : Topology
            The model's tree.

        Returns
        -------
        LoadTables
        """
        rows, local = [], []
        for e in elements:
            i, l1 = topology.locate(e.body1, e.point1)
            j, l2 = topology.locate(e.body2, e.point2)
            rows.append((i, j))
            local.append((l1, l2))
        return LoadTables.of(pair_rows=np.reshape(rows, (-1, 2)), pair_local=np.reshape(local, (-1, 2, 3)),
                             pair_par=[(e.stiffness, e.damping, e.rest_length) for e in elements])

    @classmethod
    def pair_tangent_all(cls, elements, state):
        """The tangents on the relative motion of the ends (:meth:`ForceElement.pair_tangent_all`).

        ``K = k (e e^T + (1 - l0 / l) (I - e e^T))`` (its second term
        the turning of a stretched spring), ``D = c e e^T``; at ``l = 0``
        (where e is not defined) ``K = k I``, ``D = c I``.

        Parameters
        ----------
        elements : sequence of SpringDamper
            The model's elements of this class.
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        tuple of (rows, points, K, D)
        """
        m = len(elements)
        rows, points = np.zeros((m, 2), dtype=np.int64), np.zeros((m, 2, 3))
        K, D = np.zeros((m, 3, 3)), np.zeros((m, 3, 3))
        for a, e in enumerate(elements):
            i, j, p1, p2 = e._geometry(state)
            rows[a], points[a] = (i, j), (p1, p2)
            d = p2 - p1
            length = float(np.linalg.norm(d))
            if length > 0.0:
                ee = np.outer(d, d) / (length * length)
                K[a] = e.stiffness * (ee + (1.0 - e.rest_length / length) * (np.eye(3) - ee))
                D[a] = e.damping * ee
            else:
                K[a], D[a] = e.stiffness * np.eye(3), e.damping * np.eye(3)
        return rows, points, K, D

    def apply(self, state, loads) -> None:
        """Add the spring and damper force pair.

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.
        loads : Loads
            Accumulator to add to.
        """
        type(self).apply_all([self], state, loads)

    def potential(self, state) -> float:
        """Spring energy ``k (l - l0)^2 / 2``.

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        float
            Potential energy, J.
        """
        _, _, p1, p2 = self._geometry(state)
        return float(0.5 * self.stiffness * (np.linalg.norm(p2 - p1) - self.rest_length) ** 2)


@frozen(eq=False)
class JointSpringDamper(ForceElement):
    """Linear springs and dampers acting on a joint's coordinates.

    Parameters
    ----------
    name : str
        Unique name.
    joint : Joint or str
        A tree joint with coordinates, or its name.
    stiffness : float or array_like, shape (n_coords,)
        N m/rad on angles, N/m on slides.
    damping : float or array_like, shape (n_coords,)
        N m s/rad or N s/m.
    rest : float or array_like, shape (n_coords,)
        Coordinate values where the spring is relaxed.

    Notes
    -----
    Generalized force ``-k (q - q0) - c qdot`` on the joint's coordinates
    (eq. 5: ``F^s - F^d``); potential ``k (q - q0)^2 / 2``.

    Examples
    --------
    A torsion spring of 2 N m/rad and damper of 0.1 N m s/rad on a pin
    turned 0.5 rad and turning at 1 rad/s: the generalized force is
    ``-2 * 0.5 - 0.1 * 1 = -1.1`` N m, the energy ``2 * 0.5^2 / 2 = 0.25`` J.

    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)  # along +x from the pin
    >>> pin = fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1))
    >>> spring = fm.JointSpringDamper("torsion", pin, stiffness=2.0, damping=0.1)
    >>> system = model.add(pin, spring).build()
    >>> kin = system.kinematics(0.0, np.array([0.5]), np.array([1.0]))
    >>> system.forces.active_force(kin).round(12)
    array([-1.1])
    >>> spring.potential(kin)
    0.25
    """

    joint: Joint = reference(Joint)
    stiffness: np.ndarray = field(converter=as_array, validator=_non_negative)
    damping: np.ndarray = field(default=0.0, converter=as_array, validator=_non_negative)
    rest: np.ndarray = field(default=0.0, converter=as_array, validator=finite_array)

    def check(self, model) -> list[str]:
        """Check that the joint has coordinates matching the parameter sizes.

        Parameters
        ----------
        model : Model
            The model the element belongs to.

        Returns
        -------
        list of str
            One message per problem (empty if none).
        """
        n = self.joint.n_coords
        out = []
        for name in ("stiffness", "damping", "rest"):
            v = getattr(self, name)
            if v.ndim > 1 or (v.ndim == 1 and v.shape[0] != n):
                out.append(f"{label(self)}: {name} must be a scalar or have {n} entries, got shape {v.shape}")
        if n == 0:
            out.append(f"{label(self)}: joint {self.joint.name!r} has no coordinates")
        if self.joint.quaternions:
            out.append(f"{label(self)}: joint {self.joint.name!r} describes its rotation by Euler parameters, not "
                       "angles; a joint spring needs rotation='bryant'")
        return out

    def apply(self, state, loads) -> None:
        """Add ``-k (q - q0) - c qdot``.

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.
        loads : Loads
            Accumulator to add to.
        """
        type(self).apply_all([self], state, loads)

    @classmethod
    def load_tables(cls, elements, topology) -> LoadTables:
        """The joints' coordinates with their constants and rest values (compiled).

        Parameters
        ----------
        elements : sequence of JointSpringDamper
            The model's elements of this class.
        topology : Topology
            The model's tree.

        Returns
        -------
        LoadTables
        """
        cols, k, c, rest = [], [], [], []
        for e in elements:
            s = topology.coordinate_slice(e.joint)
            m = s.stop - s.start
            cols.append(np.arange(s.start, s.stop))
            k.append(np.broadcast_to(e.stiffness, (m,)))
            c.append(np.broadcast_to(e.damping, (m,)))
            rest.append(np.broadcast_to(e.rest, (m,)))
        return LoadTables.of(coord_cols=np.concatenate(cols), coord_k=np.concatenate(k), coord_c=np.concatenate(c),
                             coord_rest=np.concatenate(rest))

    @classmethod
    def tangent_all(cls, elements, state):
        """Diagonal k and c on the joints' coordinates.

        Parameters
        ----------
        elements : sequence of ForceElement
            The model's elements of this class.
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        cols, k, c : ndarray, shape (m,)
            Coordinate indices, stiffnesses and damping constants.
        """
        t = class_tables(cls, elements, state.topology)
        return t.coord_cols, t.coord_k, t.coord_c

    def potential(self, state) -> float:
        """Spring energy ``sum k (q - q0)^2 / 2``.

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        float
            Potential energy, J.
        """
        s = state.coordinate_slice(self.joint)
        return float(0.5 * np.sum(self.stiffness * (state.x[s] - self.rest) ** 2))
