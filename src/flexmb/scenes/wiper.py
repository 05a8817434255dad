"""The windshield-wiper mechanism of Amirouche & Huston (1988), after Haug.

Six bodies: 1 chassis (ground), 2 crank, 3 drive link, 4 right wiper arm,
5 connecting link, 6 left wiper arm; joints RJ1 ... RJ7 at the points
printed in the paper's Fig. 3 (centimetres), two of them corrected (see
``POINTS`` and the wiper tutorial for the reasoning):

* RJ1 as printed, (83.52, 7.84, 2.81), nearly coincides with RJ7 (an OCR
  copy) and would give a 43 cm crank that jams the loop; we put the crank
  pivot 4 cm beyond SJ2, at (44.4, 3.8, 1.5): a 4 cm crank that turns fully.
* SJ5 as printed, (11.5, 10.5, 8.4), leaves the second loop close to
  locking; (1.5, 10.5, 8.4) (a table rule read as "1") gives the usual
  near-parallelogram between the two wiper levers.

All revolute axes, and the universal joints' first axes, are normal to the
best-fit plane of the seven points (the glass plane; the points lie within
1.7 cm of it). The crank turns at a prescribed 60 rpm. Each wiper arm is a
rigid link bar of 0.25 m plus a 0.25 m blade, rigid or flexible (finite
segments bending in the glass plane and out of it), resting 5 degrees above
the line between the wiper pivots at t = 0 and sweeping up from there; a
velocity-weakening friction force acts at each blade tip, in the glass
plane, with a prescribed normal load.

With ``WiperOptions(contact=True)`` the blade is pressed on the glass
instead: it hangs from the arm on a lift hinge (a revolute joint about the
blade's width) whose preloaded torsion spring pushes it down, and it
touches the glass through spheres at its nodes (``SpherePlaneContact``,
a linear law for the rubber lip), each with the same velocity-weakening
friction law taken from its own contact: the normal load comes from the
spring and the contacts, the sliding direction from the contact points'
own velocities, and the blade may lift off.
"""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from ..bodies import RigidBody
from ..drivers import Driver
from ..flexible import FlexibleBody
from ..forces.contact import LinearContactLaw, SpherePlaneContact, VelocityWeakeningLaw
from ..forces.springs import JointSpringDamper
from ..joints import Fixed, Revolute, Spherical, Universal
from ..model import Model
from ..rotations import frame_from_axis
from ..sections import Material, Section

__all__ = ["POINTS", "PRINTED_POINTS", "WiperOptions", "wiper", "glass_normal"]

#: Fig. 3 as printed (cm)
PRINTED_POINTS = {
    "RJ1": (83.52, 7.84, 2.81), "SJ2": (40.4, 3.8, 1.5), "UJ3": (-7.5, 2.3, 4.7), "RJ4": (-2.85, 5.8, 7.4),
    "SJ5": (11.5, 10.5, 8.4), "UJ6": (88.4, 14.2, 2.8), "RJ7": (83.52, 7.84, 2.91),
}
#: the points used (cm): RJ1 and SJ5 corrected, the others as printed
POINTS = dict(PRINTED_POINTS, RJ1=(44.4, 3.8, 1.5), SJ5=(1.5, 10.5, 8.4))


def _points_m() -> dict:
    return {k: np.array(v) / 100.0 for k, v in POINTS.items()}


def glass_normal() -> np.ndarray:
    """Unit normal of the best-fit plane of the joint points (pointing to +z).

    Returns
    -------
    ndarray, shape (3,)
        The normal, in the model's inertial frame.
    """
    X = np.array(list(_points_m().values()))
    n = np.linalg.svd(X - X.mean(axis=0))[2][2]
    return n if n[2] > 0 else -n


@frozen
class WiperOptions:
    """Parameters of the wiper scene (SI units).

    Parameters
    ----------
    flexible : bool
        Flexible blades (finite segments) or rigid ones.
    n_segments : int
        Segments per flexible blade.
    rpm : float
        Crank speed, rev/min.
    arm_length, blade_length : float
        Rigid link bar and blade lengths, m.
    blade_width, blade_thickness : float
        Blade section (spring-steel carrier), m: width in the glass plane,
        thickness normal to it.
    damping_ratio : float
        Blade damping, fraction of critical in its first out-of-plane mode.
    normal_load : float
        Blade-on-glass normal load, N.
    mu_static, slope, smoothing_speed : float
        Friction law ``mu = max(mu_static - slope v, 0)``, regularised below
        ``smoothing_speed`` (m/s).
    friction : bool
        Include the tip friction.
    masses : dict of str to float
        Masses of the rigid links ``crank``, ``drive_link``, ``arm`` and
        ``connecting_link``, kg.
    contact : bool
        Press each blade on the glass through contacts (see the module
        docstring) instead of the prescribed tip load; ``friction`` then
        gives the contacts their friction law.
    contact_spheres : int
        Spheres along each blade, evenly spaced from its tip towards the
        hinge (at the nodes of a flexible blade with as many segments).
    sphere_radius : float
        Their radius, m.
    contact_stiffness, contact_damping : float
        The rubber lip's linear law per sphere, N/m and N s/m.
    hinge_stiffness, hinge_damping : float
        The lift hinge's torsion spring, N m/rad and N m s/rad; its preload
        is set so that a rigid blade lying on the glass would be pressed
        with ``normal_load`` in all.
    """

    flexible: bool = True
    n_segments: int = 6
    rpm: float = 60.0
    arm_length: float = 0.25
    blade_length: float = 0.25
    blade_width: float = 0.010
    blade_thickness: float = 0.002
    damping_ratio: float = 0.02
    normal_load: float = 5.0
    mu_static: float = 0.4
    slope: float = 0.1
    smoothing_speed: float = 0.01
    friction: bool = True
    masses: dict = field(factory=lambda: {"crank": 0.10, "drive_link": 0.25, "arm": 0.20,
                                          "connecting_link": 0.40})
    contact: bool = False
    contact_spheres: int = 6
    sphere_radius: float = 0.004
    contact_stiffness: float = 2.0e4
    contact_damping: float = 20.0
    hinge_stiffness: float = 2.0
    hinge_damping: float = 0.005


def _blade(o: WiperOptions, name: str):
    """One blade: finite segments bending in the glass plane and out of it, or a rigid steel strip."""
    steel = Material(210e9, 7850.0, 0.3, name="spring steel")
    # Section.rectangular(b, h): b along the blade's y (in the glass plane), h along z (its normal)
    section = Section.rectangular(o.blade_width, o.blade_thickness)
    if o.flexible:
        # on a lift hinge the root is pinned: its first segment turns with the hinge
        return FlexibleBody.uniform_beam(name, o.blade_length, section, steel, o.n_segments,
                                         keep=("bend_y", "bend_z"), damping_ratio=o.damping_ratio,
                                         clamped=not o.contact)
    mass = steel.density * section.area * o.blade_length
    return RigidBody.box(name, mass, (o.blade_length, o.blade_width, o.blade_thickness),
                         com=(o.blade_length / 2, 0.0, 0.0))


def wiper(options: WiperOptions | None = None, friction_cls=None):
    """Build the wiper model.

    Parameters
    ----------
    options : WiperOptions, optional
        Scene parameters (default: flexible blades, friction on).
    friction_cls : type, optional
        Force element class for the tip friction, called as
        ``friction_cls(name, body, point=..., normal=..., normal_load=...,
        mu_static=..., slope=..., smoothing_speed=...)``; default: the
        ``velocity_weakening_friction`` force plugin.

    Returns
    -------
    model : Model
        The mechanism.
    initial : dict
        Rough initial coordinates (crank at 0, the rest to be assembled;
        with contacts, the lift hinges at 0: the blades lying on the
        glass, their spheres just touching it).
    """
    o = options or WiperOptions()
    P = _points_m()
    n = glass_normal()
    model = Model("wiper")
    g = model.ground
    m = o.masses
    crank = RigidBody.bar("crank", m["crank"], P["SJ2"] - P["RJ1"])
    drive = RigidBody.bar("drive_link", m["drive_link"], P["UJ3"] - P["SJ2"])
    link = RigidBody.bar("connecting_link", m["connecting_link"], P["UJ6"] - P["SJ5"])
    pivots = P["RJ7"] - P["RJ4"]
    pivots -= n * (pivots @ n)
    e_p = pivots / np.linalg.norm(pivots)
    # arms rest 5 deg above the line between the pivots and sweep up from there
    rest = np.radians(5.0)
    up = np.cos(rest) * e_p + np.sin(rest) * np.cross(n, e_p)
    arm_vec = o.arm_length * up
    right = RigidBody.bar("right_arm", m["arm"], arm_vec)
    left = RigidBody.bar("left_arm", m["arm"], arm_vec)
    axis_frame = frame_from_axis(n)

    def ujoint(name, parent, child, pp, cp, along):
        # the cross's second axis is perpendicular to the glass normal and to the link, so the
        # joint blocks the link's spin about its own axis
        a2 = np.cross(n, along)
        return Universal(name, parent, child, parent_point=pp, child_point=cp, axis=n, axis2=a2)

    joints = [
        Revolute("RJ1", g, crank, parent_point=P["RJ1"], axis=n),
        Spherical("SJ2", crank, drive, parent_point=P["SJ2"] - P["RJ1"], parent_frame=axis_frame),
        Revolute("RJ4", g, right, parent_point=P["RJ4"], axis=n),
        ujoint("UJ3", drive, right, P["UJ3"] - P["SJ2"], P["UJ3"] - P["RJ4"], P["UJ3"] - P["SJ2"]),
        Spherical("SJ5", right, link, parent_point=P["SJ5"] - P["RJ4"], parent_frame=axis_frame),
        Revolute("RJ7", g, left, parent_point=P["RJ7"], axis=n),
        ujoint("UJ6", link, left, P["UJ6"] - P["SJ5"], P["UJ6"] - P["RJ7"], P["UJ6"] - P["SJ5"]),
    ]
    model.add(*joints)
    model.add(Driver.constant_speed("motor", joints[0], speed=2 * np.pi * o.rpm / 60.0))
    blade_frame = np.column_stack([up, np.cross(n, up), n])
    tips = []
    for side, arm, pivot in (("right", right, P["RJ4"]), ("left", left, P["RJ7"])):
        name = f"{side}_blade"
        blade = _blade(o, name)
        if o.contact:
            _press(model, o, side, arm, blade, arm_vec, blade_frame, pivot + arm_vec, n)
        else:
            model.add(Fixed(f"{side}_clamp", arm, blade, parent_point=arm_vec, parent_frame=blade_frame,
                            child_frame=np.eye(3)))
        tips.append((name, blade))
    if o.friction and not o.contact:
        if friction_cls is None:
            from ..registry import get

            friction_cls = get("forces", "velocity_weakening_friction")
        for name, blade in tips:
            model.add(friction_cls(f"{name}_friction", blade, point=(o.blade_length, 0.0, 0.0), normal=n,
                                   normal_load=o.normal_load, mu_static=o.mu_static, slope=o.slope,
                                   smoothing_speed=o.smoothing_speed))
    return model, {"RJ1": 0.0, **({"right_lift": 0.0, "left_lift": 0.0} if o.contact else {})}


def _press(model, o: WiperOptions, side, arm, blade, arm_vec, blade_frame, hinge, n):
    """A blade on a lift hinge at the arm's end, pressed by a torsion spring, touching the glass through spheres.

    The hinge turns about the blade's width (its y); a positive angle
    pushes the tip into the glass. The glass under this blade is the plane
    normal to n a sphere's radius and half the blade's thickness below the
    hinge (the arm turns about n, so the hinge keeps its height). The
    spring's rest angle makes ``k (rest - 0) = F sum(x^2) / sum(x)``: the
    moment that a rigid blade lying on the glass on linear springs at the
    spheres' places x balances with the total normal force F.
    """
    by = blade_frame[:, 1]
    joint_frame = np.column_stack([n, blade_frame[:, 0], by])  # z along the width; x the normal, y the blade
    child_frame = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])  # the same, in the blade's frame
    lift = Revolute(f"{side}_lift", arm, blade, parent_point=arm_vec, parent_frame=joint_frame,
                    child_frame=child_frame, axis=by)
    x = o.blade_length * np.arange(1, o.contact_spheres + 1) / o.contact_spheres
    preload = o.normal_load * np.sum(x ** 2) / np.sum(x)
    spring = JointSpringDamper(f"{side}_press", lift, stiffness=o.hinge_stiffness, damping=o.hinge_damping,
                               rest=preload / o.hinge_stiffness)
    law = LinearContactLaw(o.contact_stiffness, o.contact_damping)
    friction = (VelocityWeakeningLaw(o.mu_static, o.slope, smoothing_speed=o.smoothing_speed) if o.friction
                else None)
    below = hinge - n * (o.blade_thickness / 2 + o.sphere_radius)
    contacts = [SpherePlaneContact(f"{side}_lip_{k + 1}", blade, o.sphere_radius, law, friction=friction,
                                   centre=(xk, 0.0, -o.blade_thickness / 2), plane_point=below, plane_normal=n)
                for k, xk in enumerate(x)]
    model.add(lift, spring, *contacts)
