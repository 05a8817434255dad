"""Spring-dampers: point to point, and on joint coordinates."""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from .. import quaternions
from .._names import reference
from .._validate import name_check
from ..bodies import Body
from ..fields import as_array, as_float, finite_array, label, vector3
from ..joints import Joint
from .base import ForceElement
from .tables import LoadTables, apply_tables, class_tables

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
    """Linear springs and dampers acting on a joint's coordinates, or on the rotation of a joint in Euler parameters.

    Parameters
    ----------
    name : str
        Unique name.
    joint : Joint or str
        A tree joint with coordinates, or its name.
    stiffness : float or array_like, shape (n_speeds,)
        N m/rad on angles, N/m on slides.
    damping : float or array_like, shape (n_speeds,)
        N m s/rad or N s/m.
    rest : float or array_like, shape (n_speeds,)
        Coordinate values where the spring is relaxed; for a rotation in
        Euler parameters, the relaxed rotation as a rotation vector (axis
        times angle, rad).

    Notes
    -----
    Generalized force ``-k (q - q0) - c qdot`` on the joint's coordinates
    (eq. 5: ``F^s - F^d``); potential ``k (q - q0)^2 / 2``. One value per
    speed, which is one per coordinate for every joint whose speeds are its
    coordinates' rates.

    A joint in Euler parameters (``rotation='quaternion'``: the child's
    rotation R relative to the parent, the speeds omega in the child's
    axes) has a **rotation spring** on its three angular speeds: with
    ``theta`` the rotation vector of ``R0^T R`` (``R = R0 exp([theta]x)``,
    ``R0`` the rest rotation, the shorter way: ``|theta| <= pi``; its
    components are the same in the child's axes and in R0's), the
    potential is ``theta^T K theta / 2`` (K = diag of the stiffness), and
    the generalized force on omega is

        Q = -J_r(theta)^-T K theta - C omega,

    ``J_r`` the right Jacobian of SO(3) (``theta' = J_r^-1 omega``,
    :func:`flexmb.quaternions.inverse_right_jacobian`), so that ``Q .
    omega = -d/dt (theta^T K theta / 2) - omega^T C omega``: the spring is
    conservative at any angle. ``J_r^-T theta = theta``, so with equal
    stiffnesses ``Q = -k theta - C omega``: a torque ``-k theta`` in the
    child's axes, about the axis of the turn from rest and proportional to
    its angle (a rotation about one fixed axis obeys ``I theta'' = -k theta``
    exactly, at any amplitude). For small angles it is the Bryant-angle
    spring (the angles and the rotation vector agree to first order). The
    force jumps where the turn from rest passes pi (the shorter way flips);
    the potential does not. The slides of a ``Free`` joint keep ``-k (x -
    x0) - c xd``. Springs on such joints are evaluated in Python (the
    others of the model stay compiled).

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

    On a ball joint in Euler parameters turned 0.5 rad about z, the same
    spring gives the torque -1 N m about z:

    >>> model = fm.Model()
    >>> ball = fm.Spherical("ball", model.ground, fm.RigidBody("b", 1.0, (1, 1, 1)), rotation="quaternion")
    >>> system = model.add(ball, fm.JointSpringDamper("torsion", ball, stiffness=2.0)).build()
    >>> q = [0.0, 0.0, np.sin(0.25), np.cos(0.25)]
    >>> system.forces.active_force(system.kinematics(0.0, np.array(q), np.zeros(3))).round(12)
    array([ 0.,  0., -1.])
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
        n = self.joint.n_speeds
        out = []
        for name in ("stiffness", "damping", "rest"):
            v = getattr(self, name)
            if v.ndim > 1 or (v.ndim == 1 and v.shape[0] != n):
                out.append(f"{label(self)}: {name} must be a scalar or have {n} entries, got shape {v.shape}")
        if n == 0:
            out.append(f"{label(self)}: joint {self.joint.name!r} has no coordinates")
        return out

    def apply(self, state, loads) -> None:
        """Add ``-k (q - q0) - c qdot`` (a rotation in Euler parameters: see Notes).

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.
        loads : Loads
            Accumulator to add to.
        """
        type(self).apply_all([self], state, loads)

    @classmethod
    def apply_all(cls, elements, state, loads) -> None:
        """The springs on coordinates by the compiled kernel, those on rotations in Euler parameters here.

        Parameters
        ----------
        elements : sequence of JointSpringDamper
            The model's elements of this class.
        state : Kinematics
            The current kinematic state.
        loads : Loads
            Accumulator to add to.
        """
        plain = [e for e in elements if not e.joint.quaternions]
        if plain:
            apply_tables(class_tables(cls, plain, state.topology), state, loads)
        for e in elements:
            if e.joint.quaternions:
                force, _ = e._rotation_law(state)
                loads.generalized[state.coordinate_slice(e.joint)] += force

    def _rotation_law(self, state):
        """The generalized force on a joint in Euler parameters' speeds, and its potential (class Notes)."""
        joint = self.joint
        topology = state.topology
        held = topology.joint_map.get(joint, joint)
        coords, speeds = topology.joint_coordinates(held), state.coordinate_slice(joint)
        x, u = state.x[coords], state.xd[speeds]
        n = joint.n_speeds
        k, c, rest = (np.broadcast_to(v, (n,)) for v in (self.stiffness, self.damping, self.rest))
        force = -c * u
        plain = np.ones(n, bool)
        potential = 0.0
        for qpos, upos in joint.quaternions:
            upos = list(upos)
            plain[upos] = False
            q0 = quaternions.compose(np.array([[0.0, 0.0, 0.0, 1.0]]), rest[upos][None])
            theta = quaternions.turn_between(q0, x[list(qpos)][None])
            k_theta = k[upos] * theta[0]
            force[upos] -= quaternions.inverse_right_jacobian(-theta, k_theta[None])[0]  # J_r(theta)^-T K theta
            potential += 0.5 * float(theta[0] @ k_theta)
        force[plain] -= k[plain] * (x[:n][plain] - rest[plain])
        potential += 0.5 * float(np.sum(k[plain] * (x[:n][plain] - rest[plain]) ** 2))
        return force, potential

    @classmethod
    def load_tables(cls, elements, topology) -> LoadTables | None:
        """The joints' coordinates with their constants and rest values (compiled; None with a rotation spring).

        Parameters
        ----------
        elements : sequence of JointSpringDamper
            The model's elements of this class.
        topology : Topology
            The model's tree.

        Returns
        -------
        LoadTables or None
            None if a spring acts on a joint in Euler parameters (the class
            is then applied by :meth:`apply_all`).
        """
        if any(e.joint.quaternions for e in elements):
            return None
        cols, k, c, rest = cls._columns(elements, topology)
        return LoadTables.of(coord_cols=cols, coord_k=k, coord_c=c, coord_rest=rest)

    @staticmethod
    def _columns(elements, topology):
        """The speeds' indices, stiffnesses, damping constants and rest values of the elements (kept per model)."""
        key = ("joint spring columns", tuple(id(e) for e in elements))
        if key in topology.cache:
            return topology.cache[key]
        cols, k, c, rest = [], [], [], []
        for e in elements:
            s = topology.coordinate_slice(e.joint)
            m = s.stop - s.start
            cols.append(np.arange(s.start, s.stop))
            k.append(np.broadcast_to(e.stiffness, (m,)))
            c.append(np.broadcast_to(e.damping, (m,)))
            rest.append(np.broadcast_to(e.rest, (m,)))
        out = topology.cache[key] = (np.concatenate(cols), np.concatenate(k), np.concatenate(c), np.concatenate(rest))
        return out

    @classmethod
    def tangent_all(cls, elements, state):
        """Diagonal k and c on the joints' speeds (a rotation spring's: exact at its rest).

        Parameters
        ----------
        elements : sequence of ForceElement
            The model's elements of this class.
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        cols, k, c : ndarray, shape (m,)
            Speed (and coordinate) indices, stiffnesses and damping
            constants.
        """
        cols, k, c, _ = cls._columns(elements, state.topology)
        return cols, k, c

    def potential(self, state) -> float:
        """Spring energy ``sum k (q - q0)^2 / 2`` (a rotation in Euler parameters: ``theta^T K theta / 2``).

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        float
            Potential energy, J.
        """
        if self.joint.quaternions:
            return self._rotation_law(state)[1]
        s = state.coordinate_slice(self.joint)
        return float(0.5 * np.sum(self.stiffness * (state.x[s] - self.rest) ** 2))
