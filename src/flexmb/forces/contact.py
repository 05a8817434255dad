"""Contact force elements: spheres (or points) against planes and spheres, pins in bearings with clearance.

A contact pushes two bodies apart when their surfaces overlap by the
penetration ``delta > 0``, along the surfaces' common normal, with a force
given by a *normal law*; a *friction law* adds a force in the tangent
plane, against the contact point's own relative velocity (the slip), with
the normal force as its load. Both act at the middle of the overlap, equal
and opposite on the two bodies, so their power is ``f . u`` with ``u`` the
relative velocity of the two bodies' material points there. Separated
(``delta <= 0``), a contact exerts nothing; touching, it never pulls (the
normal force is clamped at 0).

The elements are compiled: they are laid out in the load tables of the
built-in force elements (:mod:`flexmb.forces.tables`) and evaluated, with
the rest, in one kernel call (:mod:`flexmb.kernels.contact`).

Normal laws (``F`` the normal force, ``delta_dot`` the rate of penetration):

* :class:`LinearContactLaw`: ``F = k delta + c delta_dot``.
* :class:`HuntCrossleyLaw`: ``F = K delta^n (1 + alpha delta_dot)`` [1]_:
  Hertz (n = 3/2) with a damping that vanishes with the penetration; its
  coefficient of restitution falls with the impact speed v_in, as
  ``u - ln(1 + u) = -e u - ln(1 - e u)`` with ``u = alpha v_in``.
* :class:`LankaraniNikraveshLaw` [2]_ and :class:`FloresLaw` [3]_:
  ``F = K delta^n (1 + chi delta_dot / v_in)`` with the coefficient of
  restitution e as the parameter, ``chi = 3 (1 - e^2) / 4`` (accurate for e
  near 1) or ``chi = 8 (1 - e) / (5 e)`` (over the whole range); the
  rebound ratio is then independent of the impact speed.

Friction laws: :class:`CoulombLaw` (regularised), :class:`ViscousLaw`,
:class:`VelocityWeakeningLaw`, :class:`StribeckLaw` -- the friction laws of
:mod:`flexmb.kernels.friction`, which the ``flexmb_friction`` plugin's
prescribed-load elements use too.

References
----------
.. [1] K. H. Hunt and F. R. E. Crossley, "Coefficient of restitution
   interpreted as damping in vibroimpact", J. Appl. Mech. 42 (1975) 440-445.
.. [2] H. M. Lankarani and P. E. Nikravesh, "A contact force model with
   hysteresis damping for impact analysis of multibody systems", J. Mech.
   Des. 112 (1990) 369-376.
.. [3] P. Flores, M. Machado, M. T. Silva and J. M. Martins, "On the
   continuous contact force models for soft materials in multibody
   dynamics", Multibody Syst. Dyn. 25 (2011) 357-375.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from attrs import field, frozen

from .._names import reference
from ..bodies import Body
from ..errors import ModelError
from ..fields import as_array, as_float, as_unit_vector, label, unit_vector, vector3
from ..kernels import contact as _k
from .contact_base import ZERO, Contact, compiled_tables, radius_check
from .contact_laws import (FloresLaw, HuntCrossleyLaw, LankaraniNikraveshLaw, LinearContactLaw, NormalLaw,
                           hertz_stiffness, restitution_of_hysteresis)
from .friction_laws import CoulombLaw, FrictionLaw, StribeckLaw, VelocityWeakeningLaw, ViscousLaw
from .law_tables import friction_field, normal_law_field

__all__ = ["NormalLaw", "LinearContactLaw", "HuntCrossleyLaw", "LankaraniNikraveshLaw", "FloresLaw", "FrictionLaw",
           "CoulombLaw", "ViscousLaw", "VelocityWeakeningLaw", "StribeckLaw", "Contact", "SpherePlaneContact",
           "SphereSphereContact", "JournalBearingContact", "hertz_stiffness", "restitution_of_hysteresis"]


# ----------------------------------------------------------------------------- the elements

@frozen(eq=False)
class SpherePlaneContact(Contact):
    """A sphere (or a point) on a body against a plane of another body or of the ground.

    Parameters
    ----------
    name : str
        Unique name.
    body : Body or str
        The body carrying the sphere (rigid or flexible), or its name.
    radius : float
        Sphere radius r, m (>= 0; 0: a point).
    normal_law : NormalLaw or dict
        The normal force of a penetration (:class:`LinearContactLaw`,
        :class:`HuntCrossleyLaw`, :class:`LankaraniNikraveshLaw`,
        :class:`FloresLaw`).
    friction : FrictionLaw or dict, optional
        The tangential force (:class:`CoulombLaw`, :class:`ViscousLaw`,
        :class:`VelocityWeakeningLaw`, :class:`StribeckLaw`); None: none. Either law
        may be a table: ``{"type": "flores", "stiffness": ..., "restitution": ...}``
        (the types: the laws of the plugin group ``flexmb.contacts``), as scene files give it.
    centre : array_like, shape (3,)
        Sphere centre in the frame of ``body``, m (default its origin).
    plane_body : Body or str
        The body carrying the plane (default the ground).
    plane_point : array_like, shape (3,)
        A point of the plane in the frame of ``plane_body``, m.
    plane_normal : array_like, shape (3,)
        The plane's outward normal in the frame of ``plane_body``
        (normalised): the sphere is outside the body on this side.

    Notes
    -----
    Penetration ``delta = r - (c - p) . n`` with c the sphere's centre, p
    the plane's point and n its normal; the plane is unbounded (a
    half-space). The force acts at ``c - (r - delta / 2) n``.

    Examples
    --------
    A ball of 1 kg and radius 0.1 m, 1 mm into the floor with a linear law
    of 10^5 N/m: the floor pushes it up with 100 N and stores 0.05 J.

    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> ball = fm.RigidBody("ball", mass=1.0, inertia=np.eye(3) * 4e-3)
    >>> floor = fm.SpherePlaneContact("floor", ball, 0.1, fm.LinearContactLaw(1e5))
    >>> system = model.add(fm.Free("free", model.ground, ball), floor).build()
    >>> kin = system.kinematics(0.0, np.array([0.0, 0.0, 0.099, 0.0, 0.0, 0.0]), np.zeros(6))
    >>> system.forces.active_force(kin)[:3].round(9)
    array([  0.,   0., 100.])
    >>> round(floor.potential(kin), 12)
    0.05
    """

    geometry: ClassVar[int] = _k.SPHERE_PLANE

    body: Body = reference(Body)
    radius: float = field(converter=as_float, validator=radius_check)
    normal_law: NormalLaw = normal_law_field()
    friction: FrictionLaw | None = friction_field()
    centre: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    plane_body: Body = reference(Body, default="ground")
    plane_point: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    plane_normal: np.ndarray = field(default=(0.0, 0.0, 1.0), converter=as_unit_vector, validator=unit_vector)

    def _sides(self):
        return self.body, self.plane_body

    load_tables = compiled_tables

    def layout(self, topology) -> list:
        """One row: the sphere's centre, the plane's point and its normal.

        Parameters
        ----------
        topology : Topology
            The model's tree.

        Returns
        -------
        list of tuple
            The rows, as :meth:`~flexmb.forces.contact_base.Contact.layout` describes them.
        """
        i, c = self.locate(topology, self.body, self.centre)
        j, p = self.locate(topology, self.plane_body, self.plane_point)
        # a flexible body's segment frames are parallel to the body frame at the reference state
        return [((i, j), np.array([c, p, self.plane_normal, ZERO]), (self.radius, 0.0), self.geometry)]


@frozen(eq=False)
class SphereSphereContact(Contact):
    """Two spheres (or a sphere and a point) on two bodies.

    Parameters
    ----------
    name : str
        Unique name.
    body1 : Body or str
        The body carrying the first sphere, or its name.
    radius1 : float
        Its radius, m (>= 0).
    body2 : Body or str
        The body carrying the second sphere (it may be the ground).
    radius2 : float
        Its radius, m (>= 0).
    normal_law : NormalLaw or dict
        The normal force of a penetration.
    friction : FrictionLaw or dict, optional
        The tangential force; None: none. Either law may be a table, as for
        :class:`SpherePlaneContact`.
    centre1, centre2 : array_like, shape (3,)
        The centres in their bodies' frames, m (default the origins).

    Notes
    -----
    Penetration ``delta = r1 + r2 - |c1 - c2|``; the force acts along
    ``n = (c1 - c2) / |c1 - c2|`` at ``c1 - (r1 - delta / 2) n``. For the
    Hertz stiffness of two spheres, :func:`hertz_stiffness` with both radii.

    Examples
    --------
    Two balls of radius 0.1 m whose centres are 0.19 m apart overlap by
    10 mm: a linear law of 10^4 N/m pushes them apart with 100 N.

    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> a = fm.RigidBody("a", mass=1.0, inertia=np.eye(3) * 4e-3)
    >>> b = fm.RigidBody("b", mass=1.0, inertia=np.eye(3) * 4e-3)
    >>> hit = fm.SphereSphereContact("hit", a, 0.1, b, 0.1, fm.LinearContactLaw(1e4))
    >>> free_b = fm.Free("fb", model.ground, b, parent_point=(0.19, 0, 0))
    >>> system = model.add(fm.Free("fa", model.ground, a), free_b, hit).build()
    >>> kin = system.kinematics(0.0, np.zeros(12), np.zeros(12))
    >>> system.forces.active_force(kin)[[0, 6]].round(9)
    array([-100.,  100.])
    """

    geometry: ClassVar[int] = _k.SPHERE_SPHERE

    body1: Body = reference(Body)
    radius1: float = field(converter=as_float, validator=radius_check)
    body2: Body = reference(Body)
    radius2: float = field(converter=as_float, validator=radius_check)
    normal_law: NormalLaw = normal_law_field()
    friction: FrictionLaw | None = friction_field()
    centre1: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    centre2: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)

    def _sides(self):
        return self.body1, self.body2

    load_tables = compiled_tables

    def layout(self, topology) -> list:
        """One row: the two centres.

        Parameters
        ----------
        topology : Topology
            The model's tree.

        Returns
        -------
        list of tuple
            The rows, as :meth:`~flexmb.forces.contact_base.Contact.layout` describes them.
        """
        i, c1 = self.locate(topology, self.body1, self.centre1)
        j, c2 = self.locate(topology, self.body2, self.centre2)
        return [((i, j), np.array([c1, c2, ZERO, ZERO]), (self.radius1, self.radius2), self.geometry)]


@frozen(eq=False)
class JournalBearingContact(Contact):
    """A revolute joint with clearance: a pin (journal) of one body in a bearing's hole of another.

    The pin and the hole are cylinders with parallel axes (the bearing's
    axis); they touch where the pin's eccentricity across that axis exceeds
    the radial clearance ``c = R_hole - r_pin``, and a normal law and a
    friction law act there as in the other contacts: free flight inside
    the clearance, impacts on its wall, sliding along it.

    Parameters
    ----------
    name : str
        Unique name.
    pin_body : Body or str
        The body carrying the pin, or its name.
    pin_radius : float
        r_pin, m (>= 0).
    bearing_body : Body or str
        The body with the hole (it may be the ground).
    bearing_radius : float
        R_hole, m (> r_pin).
    normal_law : NormalLaw or dict
        The normal force of a penetration; for two steel cylinders in
        internal contact Flores and Ambrosio's Hertz stiffness
        ``K = 4 / (3 (s1 + s2)) sqrt(r_pin R_hole / (R_hole - r_pin))``,
        ``s = (1 - nu^2) / E``.
    friction : FrictionLaw or dict, optional
        The tangential force at the wall (the pin's spin in the hole
        slides it); None: none. Either law may be a table, as for
        :class:`SpherePlaneContact`.
    pin_centre, bearing_centre : array_like, shape (3,)
        The axes' points in their bodies' frames, m (default the origins).
    bearing_axis : array_like, shape (3,)
        The bearing's axis in the frame of ``bearing_body`` (normalised;
        default z: planar mechanisms in the x-y plane).

    Notes
    -----
    With ``e`` the pin's centre less the bearing's, across the axis, the
    penetration is ``delta = |e| - c``; the normal points from the wall to
    the bearing's centre, ``n = -e / |e|``, and the force on the pin acts at
    ``c_pin - (r_pin - delta / 2) n``. The pin's axis is taken parallel to
    the bearing's (no tilt in the hole).

    Examples
    --------
    A pin of radius 9.5 mm in a hole of 10 mm, 0.6 mm off centre: 0.1 mm
    into the wall, a linear law of 10^6 N/m pushes it back with 100 N.

    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> rod = fm.RigidBody("rod", mass=0.2, inertia=np.eye(3) * 1e-4)
    >>> gap = fm.JournalBearingContact("gap", rod, 0.0095, model.ground, 0.010, fm.LinearContactLaw(1e6))
    >>> system = model.add(fm.Free("free", model.ground, rod), gap).build()
    >>> kin = system.kinematics(0.0, np.array([0.0006, 0, 0, 0, 0, 0]), np.zeros(6))
    >>> system.forces.active_force(kin)[:3].round(9)
    array([-100.,    0.,    0.])
    """

    geometry: ClassVar[int] = _k.JOURNAL

    pin_body: Body = reference(Body)
    pin_radius: float = field(converter=as_float, validator=radius_check)
    bearing_body: Body = reference(Body)
    bearing_radius: float = field(converter=as_float, validator=radius_check)
    normal_law: NormalLaw = normal_law_field()
    friction: FrictionLaw | None = friction_field()
    pin_centre: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    bearing_centre: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    bearing_axis: np.ndarray = field(default=(0.0, 0.0, 1.0), converter=as_unit_vector, validator=unit_vector)

    def __attrs_post_init__(self):
        if not self.bearing_radius > self.pin_radius:
            raise ModelError(f"{label(self)}: bearing_radius must exceed pin_radius (a radial clearance > 0), got "
                             f"{self.bearing_radius!r} <= {self.pin_radius!r}")

    @property
    def clearance(self) -> float:
        """The radial clearance ``R_hole - r_pin``, m."""
        return self.bearing_radius - self.pin_radius

    def _sides(self):
        return self.pin_body, self.bearing_body

    load_tables = compiled_tables

    def layout(self, topology) -> list:
        """One row: the pin's centre, the bearing's centre and its axis.

        Parameters
        ----------
        topology : Topology
            The model's tree.

        Returns
        -------
        list of tuple
            The rows, as :meth:`~flexmb.forces.contact_base.Contact.layout` describes them.
        """
        i, c = self.locate(topology, self.pin_body, self.pin_centre)
        j, p = self.locate(topology, self.bearing_body, self.bearing_centre)
        return [((i, j), np.array([c, p, self.bearing_axis, ZERO]), (self.pin_radius, self.bearing_radius),
                 self.geometry)]
