"""Sliding friction at a body point on a contact plane.

A friction element acts at one point of a body (rigid or flexible) that
slides on a plane with unit normal ``n`` fixed in the inertial frame. Only
the sliding velocity, the point velocity projected on the plane,

    v_s = v - (v . n) n,

matters, and the force always lies in the plane against it:
``F = -k v_s`` with ``k >= 0``, so the power ``F . v = F . v_s <= 0``.

The laws whose magnitude does not vanish at rest (Coulomb, and the
velocity-weakening tip friction of the windshield wiper, Fig. 4 of
Amirouche & Huston (1988) [1]_) take the direction from the regularised
unit vector ``v_s / sqrt(|v_s|^2 + v_eps^2)``: smooth, well posed at zero
speed, and within ``v_eps^2 / (2 |v_s|^2)`` of the true direction once the
point slides faster than the smoothing speed ``v_eps``.

References
----------
.. [1] F. M. L. Amirouche and R. L. Huston, "Dynamics of Large Constrained
   Flexible Structures", ASME J. Dyn. Sys. Meas. Control 110 (1988) 78-83.
"""

from __future__ import annotations

import weakref
from typing import ClassVar

import numpy as np
from attrs import field, frozen

from flexmb import Body, ForceElement, ModelError, reference
from flexmb.fields import (as_array, as_float, as_unit_vector, finite_number, label, non_negative, positive,
                           unit_vector, vector3)
from flexmb.kernels.cache import njit
from flexmb.kernels.friction import coulomb_law, velocity_weakening_law, viscous_law
from flexmb.kernels.loads import body_points

__all__ = ["SlidingFriction", "VelocityWeakeningFriction", "CoulombFriction", "ViscousFriction"]

#: default smoothing speed v_eps, m/s
DEFAULT_SMOOTHING_SPEED = 1e-3


# ----------------------------------------------------------------------------- the base class

#: per topology: element tuple -> (rows, local points, normals, parameters), built once
_GATHERED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


# flexmb's kernel cache (not numba's own): the shipped machine code (flexmb.kernels.prebuilt) serves it too
@njit(cache=True)
def _sliding(p_vel, normals):
    """``v - (v . n) n`` row by row: the sliding velocities."""
    out = np.empty_like(p_vel)
    for i in range(p_vel.shape[0]):
        vn = p_vel[i, 0] * normals[i, 0] + p_vel[i, 1] * normals[i, 1] + p_vel[i, 2] * normals[i, 2]
        for a in range(3):
            out[i, a] = p_vel[i, a] - vn * normals[i, a]
    return out


# the laws' one implementation is flexmb's (the contact elements use the same factors)
_velocity_weakening_law = velocity_weakening_law
_coulomb_law = coulomb_law
_viscous_law = viscous_law


def _compiled_law(cls, params: dict, v_s: np.ndarray) -> np.ndarray:
    """A class's compiled law called with the ``_law`` arguments (a dict of parameter arrays)."""
    table = np.column_stack([np.broadcast_to(np.asarray(params[p], dtype=float), (len(v_s),))
                             for p in cls.parameters])
    return cls.law_kernel(np.ascontiguousarray(table), np.ascontiguousarray(v_s, dtype=float))


@frozen(eq=False)
class SlidingFriction(ForceElement):
    """Base class of friction at a body point sliding on a plane.

    Subclasses must:

    1. declare the law's data as validated attrs fields;
    2. name the per-element numbers the law needs in the class variable
       ``parameters`` (gathered once into arrays of shape (m,));
    3. implement the class method ``_law(params, v_s)`` returning the
       forces, shape (m, 3), for sliding velocities ``v_s`` of shape (m, 3):
       a non-negative multiple of ``-v_s`` on every row, so that the force
       lies in the plane and its power is never positive.

    The base class finds the point (on a rigid body, or on the segment of a
    flexible body that carries it), projects its velocity on the plane and
    applies the forces of all elements of one class in one vectorised call
    (``apply_all``); ``apply``, ``force``, ``sliding_velocity`` and
    ``power`` are the one-element forms.

    Parameters
    ----------
    name : str
        Unique name.
    body : Body
        Body that carries the sliding point (rigid or flexible).
    point : array_like, shape (3,)
        The sliding point in the body frame, m.
    normal : array_like, shape (3,)
        Normal of the contact plane, inertial; normalised on construction.

    Raises
    ------
    ModelError
        On invalid data, with a message naming the element.
    """

    parameters: ClassVar[tuple[str, ...]] = ()

    body: Body = reference(Body)  # the body, or its name (resolved when the model is built)
    point: np.ndarray = field(converter=as_array, validator=vector3)
    normal: np.ndarray = field(converter=as_unit_vector, validator=unit_vector)

    # -- the law
    @classmethod
    def _law(cls, params: dict, v_s: np.ndarray) -> np.ndarray:
        """Friction forces for given sliding velocities (the law; subclasses implement it).

        Parameters
        ----------
        params : dict of str to ndarray, shape (m,)
            The elements' values of each name in ``parameters``.
        v_s : ndarray, shape (m, 3)
            Sliding velocities, inertial, m/s.

        Returns
        -------
        ndarray, shape (m, 3)
            Forces, N: row i a non-negative multiple of ``-v_s[i]``.
        """
        raise NotImplementedError(f"{cls.__name__} must implement _law(params, v_s)")

    # -- vectorised evaluation
    @classmethod
    def _gather(cls, elements, state):
        """Rows, local points, normals and law parameters of ``elements``.

        Built once per topology and element list: locating a point on a
        flexible body and collecting the parameters is not repeated at
        every evaluation.
        """
        key = tuple(elements)
        topology = getattr(state, "topology", None)
        cache = None
        if topology is not None:
            try:
                cache = _GATHERED.setdefault(topology, {})
            except TypeError:  # a state whose topology cannot be weakly referenced
                cache = None
            if cache is not None and key in cache:
                return cache[key]
        located = [state.locate(e.body, e.point) for e in elements]
        rows = np.array([r for r, _ in located], dtype=int)
        local = np.array([p for _, p in located], dtype=float).reshape(-1, 3)
        normals = np.array([e.normal for e in elements]).reshape(-1, 3)
        params = {p: np.array([getattr(e, p) for e in elements], dtype=float) for p in cls.parameters}
        table = np.array([[getattr(e, p) for p in cls.parameters] for e in elements], dtype=float)
        out = (rows.astype(np.int64), np.ascontiguousarray(local), np.ascontiguousarray(normals, dtype=float),
               params, table.reshape(len(elements), len(cls.parameters)))
        if cache is not None:
            cache[key] = out
        return out

    @classmethod
    def evaluate_all(cls, elements, state):
        """Points, sliding velocities and forces of several elements of this class.

        Parameters
        ----------
        elements : sequence of SlidingFriction
            Elements of this class.
        state : Kinematics
            The kinematic state.

        Returns
        -------
        rows : ndarray of int, shape (m,)
            Body rows carrying the points.
        p : ndarray, shape (m, 3)
            Inertial positions of the points, m.
        v_s : ndarray, shape (m, 3)
            Sliding velocities ``v - (v . n) n``, m/s.
        force : ndarray, shape (m, 3)
            Friction forces, inertial, N.
        """
        rows, local, n, params, table = cls._gather(elements, state)
        p, v = body_points(rows, local, state.R, state.origin, state.r, state.omega, state.v)
        v_s = _sliding(v, n)
        if cls.law_kernel is not None:
            return rows, p, v_s, cls.law_kernel(table, v_s)
        return rows, p, v_s, cls._law(params, v_s)

    @classmethod
    def velocity_tangent_all(cls, elements, state):
        """``dF/dv`` of every element at its point, by central differences of the law.

        Only the law is differenced (cheap), with steps well below the
        smoothing speed; the result feeds the implicit integrators'
        Jacobian.

        Parameters
        ----------
        elements : sequence of SlidingFriction
            The model's elements of this class.
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        rows : ndarray of int, shape (m,)
            Body rows of the contact points.
        p : ndarray, shape (m, 3)
            Inertial positions of the contact points, m.
        D : ndarray, shape (m, 3, 3)
            ``dF/dv`` of each friction force, N s/m.
        """
        rows, local, n, params, _ = cls._gather(elements, state)
        p = state.point_position(rows, local)
        v = state.point_velocity(rows, p)
        proj = np.eye(3) - n[:, :, None] * n[:, None, :]
        v_s = np.einsum("mij,mj->mi", proj, v)
        eps = params.get("smoothing_speed", np.ones(len(rows)))
        h = (1e-4 * eps + 1e-7 * np.linalg.norm(v_s, axis=1))[:, None]
        D = np.zeros((len(rows), 3, 3))
        for j in range(3):
            dv = h * proj[:, :, j]
            D[:, :, j] = (cls._law(params, v_s + dv) - cls._law(params, v_s - dv)) / (2 * h)
        return rows, p, D

    @classmethod
    def apply_all(cls, elements, state, loads) -> None:
        """Apply all elements of this class in one call.

        Parameters
        ----------
        elements : sequence of SlidingFriction
            Elements of this class.
        state : Kinematics
            The kinematic state.
        loads : Loads
            Accumulator to add to.
        """
        rows, p, _, force = cls.evaluate_all(elements, state)
        loads.add_point_force(rows, p, force)

    @classmethod
    def power_all(cls, elements, state) -> np.ndarray:
        """Power of each element's force, W (never positive).

        Parameters
        ----------
        elements : sequence of SlidingFriction
            Elements of this class.
        state : Kinematics
            The kinematic state.

        Returns
        -------
        ndarray, shape (m,)
            ``F . v``, evaluated as ``F . v_s`` (equal, as F lies in the
            plane), so that rounding cannot make it positive.
        """
        _, _, v_s, force = cls.evaluate_all(elements, state)
        return np.einsum("mi,mi->m", force, v_s)

    # -- one element
    def apply(self, state, loads) -> None:
        """Add this element's force at its point.

        Parameters
        ----------
        state : Kinematics
            The kinematic state.
        loads : Loads
            Accumulator to add to.
        """
        type(self).apply_all([self], state, loads)

    def force(self, state) -> np.ndarray:
        """The friction force, inertial, N, shape (3,).

        Parameters
        ----------
        state : Kinematics
            The kinematic state.

        Returns
        -------
        ndarray, shape (3,)
            Force on the body at the point.
        """
        return type(self).evaluate_all([self], state)[3][0]

    def sliding_velocity(self, state) -> np.ndarray:
        """The point velocity projected on the contact plane, m/s, shape (3,).

        Parameters
        ----------
        state : Kinematics
            The kinematic state.

        Returns
        -------
        ndarray, shape (3,)
            ``v_s = v - (v . n) n``.
        """
        return type(self).evaluate_all([self], state)[2][0]

    def power(self, state) -> float:
        """Power of the friction force, W (<= 0), for energy balances.

        Parameters
        ----------
        state : Kinematics
            The kinematic state.

        Returns
        -------
        float
            ``F . v``; its time integral is the work lost to friction.
        """
        return float(type(self).power_all([self], state)[0])


# ----------------------------------------------------------------------------- the laws

@frozen(eq=False)
class VelocityWeakeningFriction(SlidingFriction):
    """Friction whose magnitude falls linearly with the sliding speed (tip friction, Fig. 4).

    Parameters
    ----------
    name : str
        Unique name.
    body : Body
        Body that carries the sliding point (rigid or flexible).
    point : array_like, shape (3,)
        The sliding point in the body frame, m.
    normal : array_like, shape (3,)
        Normal of the contact plane, inertial; normalised on construction
        (a zero vector is rejected).
    normal_load : float
        Normal force N pressing the point on the plane, N (> 0).
    mu_static : float
        Friction coefficient at rest, mu_s (>= 0): ``F0 = mu_s N``.
    slope : float
        Fall of the coefficient with speed, s, in s/m (>= 0).
    mu_min : float
        Floor of the coefficient, ``0 <= mu_min <= mu_static`` (default 0).
    smoothing_speed : float
        Smoothing speed v_eps, m/s (> 0, keyword only, default 1e-3): below
        this sliding speed the force fades linearly to zero instead of
        jumping (see Notes).

    Raises
    ------
    ModelError
        On invalid data, with a message naming the element.

    See Also
    --------
    CoulombFriction : The same with a constant coefficient (``slope = 0``).

    Notes
    -----
    With ``v_s = v - (v . n) n`` the sliding velocity of the point and
    ``v = |v_s|`` its speed, the force is::

        F(v)  = N max(mu_s - s v, mu_min)               (Fig. 4 of [1]_)
        force = -F(v) v_s / sqrt(v^2 + v_eps^2)

    The magnitude is ``F0 = mu_s N`` at rest and falls with speed, never
    below ``mu_min N`` (0 by default: above ``mu_s / s`` no friction is
    left). The factor ``v / sqrt(v^2 + v_eps^2)`` regularises the jump of
    the direction at rest: below ``v_eps`` the force behaves like a viscous
    damper ``-(mu_s N / v_eps) v_s``, above it the force reaches
    ``F(v) (1 - v_eps^2 / (2 v^2))``. A smaller ``v_eps`` is closer to the
    ideal law but stiffer near rest (time constant ``m v_eps / (mu_s N)``):
    use an implicit integrator (Radau) then. The power
    ``force . v_s <= 0`` always.

    References
    ----------
    .. [1] F. M. L. Amirouche and R. L. Huston, "Dynamics of Large
       Constrained Flexible Structures", ASME J. Dyn. Sys. Meas. Control
       110 (1988) 78-83.

    Examples
    --------
    >>> import flexmb as fm
    >>> from flexmb_friction import VelocityWeakeningFriction
    >>> block = fm.RigidBody("block", mass=2.0)
    >>> f = VelocityWeakeningFriction("tip", block, point=(0, 0, 0), normal=(0, 0, 2),
    ...                               normal_load=19.62, mu_static=0.4, slope=0.2)
    >>> f.normal.tolist(), f.smoothing_speed
    ([0.0, 0.0, 1.0], 0.001)
    """

    parameters = ("normal_load", "mu_static", "slope", "mu_min", "smoothing_speed")

    normal_load: float = field(converter=as_float, validator=[finite_number, positive])
    mu_static: float = field(converter=as_float, validator=[finite_number, non_negative])
    slope: float = field(converter=as_float, validator=[finite_number, non_negative])
    mu_min: float = field(default=0.0, converter=as_float, validator=[finite_number, non_negative])
    smoothing_speed: float = field(default=DEFAULT_SMOOTHING_SPEED, converter=as_float,
                                   validator=[finite_number, positive], kw_only=True)

    def __attrs_post_init__(self):
        if self.mu_min > self.mu_static:
            raise ModelError(f"{label(self)}: mu_min must be <= mu_static, got mu_min = {self.mu_min!r} > "
                             f"mu_static = {self.mu_static!r}")

    law_kernel = _velocity_weakening_law

    @classmethod
    def _law(cls, params, v_s):
        """``-N max(mu_s - s v, mu_min) v_s / sqrt(v^2 + v_eps^2)`` (the compiled law)."""
        return _compiled_law(cls, params, v_s)


@frozen(eq=False)
class CoulombFriction(SlidingFriction):
    """Coulomb friction of constant coefficient, regularised at rest.

    Parameters
    ----------
    name : str
        Unique name.
    body : Body
        Body that carries the sliding point (rigid or flexible).
    point : array_like, shape (3,)
        The sliding point in the body frame, m.
    normal : array_like, shape (3,)
        Normal of the contact plane, inertial; normalised on construction
        (a zero vector is rejected).
    normal_load : float
        Normal force N, N (> 0).
    mu : float
        Friction coefficient (>= 0).
    smoothing_speed : float
        Smoothing speed v_eps, m/s (> 0, keyword only, default 1e-3): the
        sliding speed below which the force fades linearly to zero.

    Raises
    ------
    ModelError
        On invalid data, with a message naming the element.

    See Also
    --------
    VelocityWeakeningFriction : A coefficient falling with speed.

    Notes
    -----
    ``force = -mu N v_s / sqrt(|v_s|^2 + v_eps^2)`` with ``v_s`` the sliding
    velocity. A block of mass m pressed by its weight (``N = m g``) and
    launched at ``v0`` stops after ``v0 / (mu g)`` at ``v0^2 / (2 mu g)``;
    with the regularisation its speed reaches ``v_eps`` after
    ``(v0 - 0.533 v_eps) / (mu g)`` and then decays with the time constant
    ``v_eps / (mu g)``, and it creeps to
    ``v0^2 / (2 mu g) + O(v_eps^2 ln(v0 / v_eps) / (mu g))``.

    Examples
    --------
    >>> import flexmb as fm
    >>> from flexmb_friction import CoulombFriction
    >>> block = fm.RigidBody("block", mass=1.0)
    >>> CoulombFriction("slide", block, (0, 0, 0), (0, 0, 1), normal_load=9.81, mu=0.3).mu
    0.3
    """

    parameters = ("normal_load", "mu", "smoothing_speed")

    normal_load: float = field(converter=as_float, validator=[finite_number, positive])
    mu: float = field(converter=as_float, validator=[finite_number, non_negative])
    smoothing_speed: float = field(default=DEFAULT_SMOOTHING_SPEED, converter=as_float,
                                   validator=[finite_number, positive], kw_only=True)

    law_kernel = _coulomb_law

    @classmethod
    def _law(cls, params, v_s):
        """``-mu N v_s / sqrt(v^2 + v_eps^2)`` (the compiled law)."""
        return _compiled_law(cls, params, v_s)


@frozen(eq=False)
class ViscousFriction(SlidingFriction):
    """Viscous friction in the contact plane, ``-c v_s``.

    Parameters
    ----------
    name : str
        Unique name.
    body : Body
        Body that carries the sliding point (rigid or flexible).
    point : array_like, shape (3,)
        The sliding point in the body frame, m.
    normal : array_like, shape (3,)
        Normal of the contact plane, inertial; normalised on construction
        (a zero vector is rejected).
    damping : float
        Damping constant c, N s/m (> 0).

    Raises
    ------
    ModelError
        On invalid data, with a message naming the element.

    Notes
    -----
    ``force = -c v_s``, linear and smooth, so no regularisation is needed;
    power ``-c |v_s|^2``. A mass m launched at ``v0`` glides
    ``m v0 / c`` before it stops.

    Examples
    --------
    >>> import flexmb as fm
    >>> from flexmb_friction import ViscousFriction
    >>> block = fm.RigidBody("block", mass=1.0)
    >>> ViscousFriction("oil", block, (0, 0, 0), (0, 0, 1), damping=2.0).damping
    2.0
    """

    parameters = ("damping",)

    damping: float = field(converter=as_float, validator=[finite_number, positive])

    law_kernel = _viscous_law

    @classmethod
    def _law(cls, params, v_s):
        """``-c v_s`` (the compiled law)."""
        return _compiled_law(cls, params, v_s)
