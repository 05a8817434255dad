"""Capsule contacts: a segment with a radius (a rod, a segment of a flexible body) against a plane, a sphere or another.

A capsule is the set of points within its radius of a segment, its axis.
Against a sphere or a capsule it is a sphere at the closest point of its
axis (to the sphere's centre, or to the other's axis: Ericson's clamped
closest points of two segments, the middle of their overlap when they are
parallel), so that a sphere on a capsule is exactly a sphere on a sphere
there. Against a plane (a half-space) it is two spheres, one at each end:
the deepest points of a segment are an end, or the whole segment when it
lies parallel to the plane, and then the two ends' forces carry the load
as a distributed contact would: with a linear law of stiffness k per end,
as a Winkler foundation of ``2 k / L`` per unit length does (the resultant
and its moment), so that a capsule resting on a plane carries its weight
split between its ends by the lever rule. A segment of a flexible body is
a capsule on that segment (its ends in the body frame, on one segment):
:class:`~flexmb.forces.contact_groups.ContactGroup` makes one per segment.

The elements are compiled with the other contacts
(:mod:`flexmb.kernels.contact_geometry`), with the same normal and
friction laws (:mod:`flexmb.forces.contact`).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from attrs import field, frozen

from .._names import reference
from ..bodies import Body
from ..errors import ModelError
from ..fields import as_array, as_float, as_unit_vector, finite_array, label, unit_vector, vector3
from ..kernels import contact as _k
from .contact_base import ZERO, Contact, compiled_tables, radius_check
from .contact_laws import NormalLaw
from .friction_laws import FrictionLaw
from .law_tables import friction_field, normal_law_field

__all__ = ["CapsulePlaneContact", "CapsuleSphereContact", "CapsuleCapsuleContact", "capsule_ends"]


def _ends(instance, attribute, value):
    finite_array(instance, attribute, value)
    if value.shape != (2, 3):
        raise ModelError(f"{label(instance)}: {attribute.name} must have shape (2, 3) (the axis' two ends), got "
                         f"shape {value.shape}")


def capsule_ends(element, topology, body, ends) -> tuple[int, np.ndarray]:
    """The body row carrying a capsule and its two ends in that row's frame.

    Parameters
    ----------
    element : ForceElement
        The element, for the messages.
    topology : Topology
        The model's tree.
    body : Body or str
        The capsule's body (rigid or flexible), or its name.
    ends : ndarray, shape (2, 3)
        The axis' ends in the body frame, m.

    Returns
    -------
    row : int
        Body row (-1: the ground).
    local : ndarray, shape (2, 3)
        The ends in that row's frame.

    Raises
    ------
    ModelError
        If the ends lie on different segments of a flexible body (a
        capsule is rigid: one per segment).
    """
    middle = 0.5 * (ends[0] + ends[1])
    row, local = Contact.locate(topology, body, middle)
    shifted = ends + (local - middle)  # a flexible body's segment frames are its frame shifted at the reference
    length = getattr(Contact._body(topology, body), "segment_length", None)
    if length is not None and (shifted[:, 0].min() < -1e-9 * length or shifted[:, 0].max() > length * (1 + 1e-9)):
        raise ModelError(f"{label(element)}: the ends {ends.tolist()} lie on different segments of the flexible "
                         f"body {getattr(body, 'name', body)!r} (segments of {length:g} m): give one capsule per "
                         f"segment (a ContactGroup of its capsules makes them)")
    return row, shifted


@frozen(eq=False)
class CapsulePlaneContact(Contact):
    """A capsule on a body against a plane of another body or of the ground.

    Parameters
    ----------
    name : str
        Unique name.
    body : Body or str
        The body carrying the capsule (rigid, or flexible with both ends on
        one segment), or its name.
    radius : float
        Capsule radius r, m (>= 0; 0: a segment).
    ends : array_like, shape (2, 3)
        The two ends of its axis in the frame of ``body``, m.
    normal_law : NormalLaw or dict
        The normal force of each end's penetration (:mod:`flexmb.forces.contact`).
    friction : FrictionLaw or dict, optional
        The tangential force; None: none. Either law may be a table, as for
        :class:`~flexmb.forces.contact.SpherePlaneContact`.
    plane_body : Body or str
        The body carrying the plane (default the ground).
    plane_point : array_like, shape (3,)
        A point of the plane in the frame of ``plane_body``, m.
    plane_normal : array_like, shape (3,)
        The plane's outward normal in the frame of ``plane_body``.

    Notes
    -----
    Two rows, one per end: ``delta_i = r - (e_i - p) . n`` with ``e_i`` the
    ends; each end's force acts at ``e_i - (r - delta_i / 2) n`` (module
    docstring: why the ends). A result's history of the element
    (:meth:`~flexmb.forces.contact_base.Contact.states_all`) reports the
    deeper end's penetration and the two forces' sum at their resultant's
    point.

    Examples
    --------
    A rod of 2 kg and 1 m with a radius of 10 mm, level, 1 mm into the
    floor with a linear law of 10^4 N/m per end: 10 N at each end.

    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> rod = fm.RigidBody("rod", mass=2.0, inertia=np.diag([1e-4, 0.17, 0.17]))
    >>> floor = fm.CapsulePlaneContact("floor", rod, 0.01, [[-0.5, 0, 0], [0.5, 0, 0]], fm.LinearContactLaw(1e4))
    >>> system = model.add(fm.Free("free", model.ground, rod), floor).build()
    >>> kin = system.kinematics(0.0, np.array([0.0, 0.0, 0.009, 0.0, 0.0, 0.0]), np.zeros(6))
    >>> system.forces.active_force(kin)[:3].round(9)
    array([ 0.,  0., 20.])
    """

    geometry: ClassVar[int] = _k.SPHERE_PLANE

    body: Body = reference(Body)
    radius: float = field(converter=as_float, validator=radius_check)
    ends: np.ndarray = field(converter=as_array, validator=_ends)
    normal_law: NormalLaw = normal_law_field()
    friction: FrictionLaw | None = friction_field()
    plane_body: Body = reference(Body, default="ground")
    plane_point: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    plane_normal: np.ndarray = field(default=(0.0, 0.0, 1.0), converter=as_unit_vector, validator=unit_vector)

    load_tables = compiled_tables

    def _sides(self):
        return self.body, self.plane_body

    def layout(self, topology) -> list:
        """Two rows, one per end: each end's sphere against the plane.

        Parameters
        ----------
        topology : Topology
            The model's tree.

        Returns
        -------
        list of tuple
            The rows, as :meth:`~flexmb.forces.contact_base.Contact.layout` describes them.
        """
        i, ends = capsule_ends(self, topology, self.body, self.ends)
        j, p = self.locate(topology, self.plane_body, self.plane_point)
        return [((i, j), np.array([e, p, self.plane_normal, ZERO]), (self.radius, 0.0), self.geometry) for e in ends]


@frozen(eq=False)
class CapsuleSphereContact(Contact):
    """A capsule on a body against a sphere (or a point) on another.

    Parameters
    ----------
    name : str
        Unique name.
    body : Body or str
        The body carrying the capsule (rigid, or flexible with both ends on
        one segment), or its name.
    radius : float
        Capsule radius, m (>= 0).
    ends : array_like, shape (2, 3)
        The two ends of its axis in the frame of ``body``, m.
    sphere_body : Body or str
        The body carrying the sphere (it may be the ground).
    sphere_radius : float
        Its radius, m (>= 0).
    normal_law : NormalLaw or dict
        The normal force of a penetration.
    friction : FrictionLaw or dict, optional
        The tangential force; None: none.
    centre : array_like, shape (3,)
        The sphere's centre in the frame of ``sphere_body``, m.

    Notes
    -----
    With ``a`` the point of the axis closest to the sphere's centre c:
    ``delta = r + r_s - |a - c|``, along ``n = (a - c) / |a - c|``, at
    ``a - (r - delta / 2) n``: a sphere of radius r at a against the sphere.

    Examples
    --------
    A ball of radius 0.1 m whose centre is 0.1 m above the middle of a
    level rod of radius 0.01 m: 10 mm of overlap, 100 N with 10^4 N/m.

    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> ball = fm.RigidBody("ball", mass=1.0, inertia=np.eye(3) * 4e-3)
    >>> hit = fm.CapsuleSphereContact("hit", model.ground, 0.01, [[-1, 0, 0], [1, 0, 0]], ball, 0.1,
    ...                               fm.LinearContactLaw(1e4))
    >>> system = model.add(fm.Free("free", model.ground, ball, parent_point=(0.2, 0, 0.1)), hit).build()
    >>> kin = system.kinematics(0.0, np.zeros(6), np.zeros(6))
    >>> system.forces.active_force(kin)[:3].round(9)
    array([  0.,   0., 100.])
    """

    geometry: ClassVar[int] = _k.CAPSULE_SPHERE

    body: Body = reference(Body)
    radius: float = field(converter=as_float, validator=radius_check)
    ends: np.ndarray = field(converter=as_array, validator=_ends)
    sphere_body: Body = reference(Body)
    sphere_radius: float = field(converter=as_float, validator=radius_check)
    normal_law: NormalLaw = normal_law_field()
    friction: FrictionLaw | None = friction_field()
    centre: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)

    load_tables = compiled_tables

    def _sides(self):
        return self.body, self.sphere_body

    def layout(self, topology) -> list:
        """One row: the capsule's ends and the sphere's centre.

        Parameters
        ----------
        topology : Topology
            The model's tree.

        Returns
        -------
        list of tuple
            The rows, as :meth:`~flexmb.forces.contact_base.Contact.layout` describes them.
        """
        i, ends = capsule_ends(self, topology, self.body, self.ends)
        j, c = self.locate(topology, self.sphere_body, self.centre)
        return [((i, j), np.array([ends[0], c, ZERO, ends[1]]), (self.radius, self.sphere_radius), self.geometry)]


@frozen(eq=False)
class CapsuleCapsuleContact(Contact):
    """Two capsules on two bodies (rods, segments of flexible bodies): crossed, parallel or end to end.

    Parameters
    ----------
    name : str
        Unique name.
    body1 : Body or str
        The body carrying the first capsule, or its name.
    radius1 : float
        Its radius, m (>= 0).
    ends1 : array_like, shape (2, 3)
        Its axis' ends in the frame of ``body1``, m.
    body2 : Body or str
        The body carrying the second capsule (it may be the ground).
    radius2 : float
        Its radius, m (>= 0).
    ends2 : array_like, shape (2, 3)
        Its axis' ends in the frame of ``body2``, m.
    normal_law : NormalLaw or dict
        The normal force of a penetration.
    friction : FrictionLaw or dict, optional
        The tangential force; None: none.

    Notes
    -----
    With ``a``, ``b`` the closest points of the two axes
    (:func:`flexmb.kernels.contact_geometry.segments_closest`; parallel
    axes: the middle of their overlap): ``delta = r1 + r2 - |a - b|`` along
    ``n = (a - b) / |a - b|``, at ``a - (r1 - delta / 2) n``. One point of
    contact: two parallel capsules lying on each other are pushed apart at
    the middle of their overlap, not along it (no moment against tilting
    about it).

    Examples
    --------
    Two rods of radius 10 mm crossed at right angles, their axes 15 mm
    apart: 5 mm of overlap, 50 N with 10^4 N/m.

    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> rod = fm.RigidBody("rod", mass=1.0, inertia=np.diag([1e-4, 0.1, 0.1]))
    >>> cross = fm.CapsuleCapsuleContact("cross", rod, 0.01, [[-0.5, 0, 0], [0.5, 0, 0]], model.ground, 0.01,
    ...                                  [[0, -0.5, 0], [0, 0.5, 0]], fm.LinearContactLaw(1e4))
    >>> system = model.add(fm.Free("free", model.ground, rod, parent_point=(0, 0, 0.015)), cross).build()
    >>> kin = system.kinematics(0.0, np.zeros(6), np.zeros(6))
    >>> system.forces.active_force(kin)[:3].round(9)
    array([ 0.,  0., 50.])
    """

    geometry: ClassVar[int] = _k.CAPSULE_CAPSULE

    body1: Body = reference(Body)
    radius1: float = field(converter=as_float, validator=radius_check)
    ends1: np.ndarray = field(converter=as_array, validator=_ends)
    body2: Body = reference(Body)
    radius2: float = field(converter=as_float, validator=radius_check)
    ends2: np.ndarray = field(converter=as_array, validator=_ends)
    normal_law: NormalLaw = normal_law_field()
    friction: FrictionLaw | None = friction_field()

    load_tables = compiled_tables

    def _sides(self):
        return self.body1, self.body2

    def layout(self, topology) -> list:
        """One row: the two capsules' ends.

        Parameters
        ----------
        topology : Topology
            The model's tree.

        Returns
        -------
        list of tuple
            The rows, as :meth:`~flexmb.forces.contact_base.Contact.layout` describes them.
        """
        i, e1 = capsule_ends(self, topology, self.body1, self.ends1)
        j, e2 = capsule_ends(self, topology, self.body2, self.ends2)
        return [((i, j), np.array([e1[0], e2[0], e2[1], e1[1]]), (self.radius1, self.radius2), self.geometry)]
