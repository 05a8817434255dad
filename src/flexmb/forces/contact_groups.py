"""Contact between groups of shapes: every segment of a blade against the glass, body set A against body set B.

A :class:`ContactGroup` names two groups of shapes -- :class:`Capsules`
(every segment of a flexible body, or a rod's axis with a radius),
:class:`Spheres` and :class:`Plane` -- and one normal law and friction law;
each shape of the first group can touch each shape of the second, on
another body. The pairs are laid out once, as the rows of the capsule,
sphere and plane contacts (:mod:`flexmb.forces.capsules`,
:mod:`flexmb.forces.contact`), and evaluated with them in the compiled
load tables; a pair of capsules, or of a capsule and a sphere, first
compares the shapes' bounding spheres, so that the closest points are
sought only for shapes whose spheres overlap. A body of n segments
against a plane costs 2 n rows, O(n) per evaluation. A group of n
capsules and spheres against one of m (:data:`BROAD_PHASE_PAIRS` pairs or
more) is a *block* of the tables: the broad phase
(:mod:`flexmb.kernels.broadphase`) finds the pairs whose boxes overlap on a
uniform grid, ``O((n + m) log m)`` plus the pairs found per evaluation,
and only those are evaluated (the loads are those of every pair, to the
bit); the events and the histories still look at every pair.
Shapes on one body never touch each other (no self-contact of a
flexible body).

In a scene file a group is a list of tables, each with its ``shape``::

    [forces.blade_on_glass]
    type = "contact_group"
    group1 = [{shape = "capsules", body = "blade", radius = 0.004}]
    group2 = [{shape = "plane", point = [0, 0, 0], normal = [0, 0, 1]}]
    normal_law = {type = "linear", stiffness = 1e5, damping = 20}
"""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from .._names import reference
from ..bodies import Body
from ..errors import ModelError
from ..fields import as_array, as_float, as_unit_vector, finite_array, label, unit_vector, vector3
from .capsules import CapsuleCapsuleContact, CapsulePlaneContact, CapsuleSphereContact, capsule_ends
from .contact import SpherePlaneContact, SphereSphereContact
from .contact_base import Contact, compiled_tables, radius_check
from .contact_laws import NormalLaw
from .friction_laws import FrictionLaw
from .law_tables import friction_field, normal_law_field

__all__ = ["Capsules", "Spheres", "Plane", "ContactGroup", "SHAPES", "BROAD_PHASE_PAIRS"]

#: a group against a group of at least this many pairs of capsules and spheres has its pairs found by the broad
#: phase (:mod:`flexmb.kernels.broadphase`); fewer are tested one by one
BROAD_PHASE_PAIRS = 64


def _segments(instance, attribute, value):
    if value is not None and (not isinstance(value, tuple) or not all(
            isinstance(i, int) and not isinstance(i, bool) and i >= 0 for i in value)):
        raise ModelError(f"Capsules of {getattr(instance.body, 'name', instance.body)!r}: segments must be None "
                         f"(all) or segment numbers >= 0, got {value!r}")


def _point_lists(what, words, tail):
    """A validator of a shape's points: None, or finite numbers of shape ``(k,) + tail``."""

    def check(instance, attribute, value):
        if value is None:
            return
        finite_array(instance, attribute, value)
        if value.ndim != len(tail) + 1 or value.shape[1:] != tail:
            raise ModelError(f"{what} of {getattr(instance.body, 'name', instance.body)!r}: {attribute.name} must be "
                             f"{words}, shape (k, {', '.join(map(str, tail))}), got shape {value.shape}")

    return check


@frozen
class Capsules:
    """Capsules on a body: every segment of a flexible body, or given axes.

    Parameters
    ----------
    body : Body or str
        The body, or its name.
    radius : float
        Their radius, m (>= 0).
    segments : sequence of int, optional
        A flexible body's segments (0 at the root) to take (default all);
        each segment's capsule runs along the body's x axis over it.
    ends : array_like, shape (k, 2, 3), optional
        Instead: the capsules' two ends in the body frame (a rigid body's
        rods; on a flexible body each capsule within one segment).
    """

    body: Body = reference(Body)
    radius: float = field(converter=as_float, validator=radius_check)
    segments: tuple | None = field(default=None, converter=lambda v: v if v is None else tuple(v),
                                   validator=_segments)
    ends: np.ndarray | None = field(default=None, converter=lambda v: v if v is None else as_array(v),
                                    validator=_point_lists("Capsules", "a list of capsules' two ends", (2, 3)))

    def _primitives(self, topology) -> list:
        """The capsules' axes, ``("capsule", body, ends (2, 3), radius)`` each."""
        body = Contact._body(topology, self.body)
        if self.ends is not None:
            return [("capsule", body, e, self.radius) for e in self.ends]
        n = getattr(body, "n_segments", None)
        if n is None:
            raise ModelError(f"Capsules of {getattr(body, 'name', body)!r}: give their ends (a rigid body has no "
                             "segments)")
        picked = range(n) if self.segments is None else self.segments
        if any(i >= n for i in picked):
            raise ModelError(f"Capsules of {body.name!r}: segments must be below {n}, got {list(picked)}")
        l = body.segment_length
        return [("capsule", body, np.array([[i * l, 0.0, 0.0], [(i + 1) * l, 0.0, 0.0]]), self.radius)
                for i in picked]


@frozen
class Spheres:
    """Spheres (or points) on a body.

    Parameters
    ----------
    body : Body or str
        The body, or its name.
    radius : float
        Their radius, m (>= 0).
    centres : array_like, shape (k, 3)
        Their centres in the body frame, m (default the origin).
    """

    body: Body = reference(Body)
    radius: float = field(converter=as_float, validator=radius_check)
    centres: np.ndarray = field(default=((0.0, 0.0, 0.0),), converter=as_array,
                              validator=_point_lists("Spheres", "a list of centres", (3,)))

    def _primitives(self, topology) -> list:
        """``("sphere", body, centre, radius)`` each."""
        body = Contact._body(topology, self.body)
        return [("sphere", body, c, self.radius) for c in self.centres]


@frozen
class Plane:
    """A plane (a half-space) of a body or of the ground.

    Parameters
    ----------
    body : Body or str
        The body carrying it (default the ground).
    point : array_like, shape (3,)
        A point of the plane in the body frame, m.
    normal : array_like, shape (3,)
        Its outward normal in the body frame (normalised).
    """

    body: Body = reference(Body, default="ground")
    point: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    normal: np.ndarray = field(default=(0.0, 0.0, 1.0), converter=as_unit_vector, validator=unit_vector)

    def _primitives(self, topology) -> list:
        """One ``("plane", body, point, normal)``."""
        return [("plane", Contact._body(topology, self.body), self.point, self.normal)]


#: the shapes by the names a scene file's table gives as its ``shape``
SHAPES = {"capsules": Capsules, "spheres": Spheres, "plane": Plane}


class _BadGroup(tuple):
    """A group that did not convert: kept for the validator to name the element and the problem."""

    problem = ""


def _as_group(value):
    """A shape or a list of shapes and tables ``{shape = "capsules", ...}``, as a tuple of shapes."""
    items = [value] if isinstance(value, (Capsules, Spheres, Plane, dict)) else value
    out = []
    try:
        for item in items:
            if isinstance(item, dict):
                params = dict(item)
                kind = params.pop("shape", None)
                if kind not in SHAPES:
                    raise ModelError(f"a shape's table needs shape = one of {', '.join(map(repr, SHAPES))}, "
                                     f"got {kind!r}")
                item = SHAPES[kind](**params)
            out.append(item)
    except (ModelError, TypeError) as exc:
        bad = _BadGroup(out)
        bad.problem = str(exc)
        return bad
    return tuple(out)


def _group(instance, attribute, value):
    if isinstance(value, _BadGroup):
        raise ModelError(f"{label(instance)}: {attribute.name}: {value.problem}")
    if not isinstance(value, tuple) or not value or not all(isinstance(s, (Capsules, Spheres, Plane))
                                                            for s in value):
        raise ModelError(f"{label(instance)}: {attribute.name} must be a non-empty list of shapes (Capsules, "
                         f"Spheres, Plane, or tables with their shape), got {value!r}")


def _same_body(a, b) -> bool:
    return a is b or getattr(a, "name", a) == getattr(b, "name", b)


@frozen(eq=False)
class ContactGroup(Contact):
    """Every shape of one group against every shape of another, on other bodies (the broad phase).

    Parameters
    ----------
    name : str
        Unique name.
    group1, group2 : sequence of Capsules, Spheres, Plane or dict
        The groups: shapes, or tables with ``shape`` = ``"capsules"``,
        ``"spheres"`` or ``"plane"`` and the shape's parameters.
    normal_law : NormalLaw or dict
        The normal force of each pair's penetration.
    friction : FrictionLaw or dict, optional
        The tangential force; None: none.

    Notes
    -----
    Each pair is the contact element of its two shapes (a capsule on a
    plane: :class:`~flexmb.forces.capsules.CapsulePlaneContact`, two rows;
    a sphere on a sphere: :class:`~flexmb.forces.contact.SphereSphereContact`;
    ...); a plane against a plane is refused. Results report the group as
    one element (:meth:`~flexmb.forces.contact_base.Contact.states_all`:
    the deepest pair, the forces summed);
    :meth:`~flexmb.forces.contact_base.Contact.row_states` gives each pair.

    Examples
    --------
    A beam of 8 segments lying on the floor: 16 rows, the ends of its
    segments; at rest on it, 1 mm deep with 10^4 N/m per end, 20 N each.

    >>> import numpy as np
    >>> import flexmb as fm
    >>> beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(),
    ...                        n_segments=8, keep=("bend_y",))
    >>> floor = fm.ContactGroup("floor", [fm.Capsules(beam, 0.0025)], [fm.Plane()], fm.LinearContactLaw(1e4))
    >>> model = fm.Model()
    >>> system = model.add(fm.Fixed("root", model.ground, beam, parent_point=(0, 0, 0.0015)), floor).build()
    >>> kin = system.kinematics(0.0, np.zeros(8), np.zeros(8))
    >>> delta, _, fn, _, _, _, _, _ = fm.ContactGroup.row_states([floor], kin)
    >>> fn.shape, round(float(fn.sum()), 9)
    ((16,), 160.0)
    """

    group1: tuple = field(converter=_as_group, validator=_group)
    group2: tuple = field(converter=_as_group, validator=_group)
    normal_law: NormalLaw = normal_law_field()
    friction: FrictionLaw | None = friction_field()

    load_tables = compiled_tables

    def check(self, model) -> list[str]:
        """Nothing beyond the shapes' own checks (pairs of shapes on one body are left out).

        Parameters
        ----------
        model : Model
            The model the element belongs to.

        Returns
        -------
        list of str
            Empty.
        """
        return []

    def _pair(self, k, p, q):
        """The contact element of two primitives (capsule, sphere or plane), the capsule or the sphere first."""
        order = ("capsule", "sphere", "plane")
        if order.index(p[0]) > order.index(q[0]):
            p, q = q, p
        name, laws = f"{self.name}[{k}]", (self.normal_law, self.friction)
        kinds = (p[0], q[0])
        if kinds == ("capsule", "plane"):
            return CapsulePlaneContact(name, p[1], p[3], p[2], *laws, plane_body=q[1], plane_point=q[2],
                                       plane_normal=q[3])
        if kinds == ("capsule", "sphere"):
            return CapsuleSphereContact(name, p[1], p[3], p[2], q[1], q[3], *laws, centre=q[2])
        if kinds == ("capsule", "capsule"):
            return CapsuleCapsuleContact(name, p[1], p[3], p[2], q[1], q[3], q[2], *laws)
        if kinds == ("sphere", "plane"):
            return SpherePlaneContact(name, p[1], p[3], *laws, centre=p[2], plane_body=q[1], plane_point=q[2],
                                      plane_normal=q[3])
        if kinds == ("sphere", "sphere"):
            return SphereSphereContact(name, p[1], p[3], q[1], q[3], *laws, centre1=p[2], centre2=q[2])
        raise ModelError(f"{label(self)}: a plane of {getattr(p[1], 'name', p[1])!r} against a plane of "
                         f"{getattr(q[1], 'name', q[1])!r}: planes touch nothing but spheres and capsules")

    def layout(self, topology) -> list:
        """The rows of every pair of shapes of the two groups on different bodies.

        Parameters
        ----------
        topology : Topology
            The model's tree.

        Returns
        -------
        list of tuple
            The rows, as :meth:`~flexmb.forces.contact_base.Contact.layout` describes them.
        """
        return self._laid_out(topology)[0]

    def blocks(self, topology) -> list:
        """The pairs of capsules and spheres of the two groups, for the broad phase (:mod:`flexmb.kernels.broadphase`).

        One block when they make :data:`BROAD_PHASE_PAIRS` pairs or more
        (fewer are cheaper tested one by one); the pairs with a plane are
        evaluated always (a plane meets every shape's box).

        Parameters
        ----------
        topology : Topology
            The model's tree.

        Returns
        -------
        list of tuple
            As :meth:`~flexmb.forces.contact_base.Contact.blocks` describes them.
        """
        return self._laid_out(topology)[1]

    def _laid_out(self, topology):
        """The rows and the block, once per model (kept in the topology's cache)."""
        key = ("contact group", id(self))
        if key in topology.cache:
            return topology.cache[key]
        first = [p for shape in self.group1 for p in shape._primitives(topology)]
        second = [q for shape in self.group2 for q in shape._primitives(topology)]
        solid1 = [k for k, p in enumerate(first) if p[0] != "plane"]
        solid2 = [k for k, q in enumerate(second) if q[0] != "plane"]
        pairs = -np.ones((len(first), len(second)), dtype=np.int64)
        rows = []
        for a, p in enumerate(first):
            for b, q in enumerate(second):
                if not _same_body(p[1], q[1]):
                    pairs[a, b] = len(rows)
                    rows.extend(self._pair(len(rows), p, q).layout(topology))
        blocks = []
        if len(solid1) * len(solid2) >= BROAD_PHASE_PAIRS:
            blocks.append(([self._shape(topology, first[k]) for k in solid1],
                           [self._shape(topology, second[k]) for k in solid2], pairs[np.ix_(solid1, solid2)]))
        topology.cache[key] = rows, blocks
        return rows, blocks

    def _shape(self, topology, primitive):
        """A capsule's or a sphere's body row, its two ends in that row's frame (a sphere's centre twice), radius."""
        kind, body, where, radius = primitive
        if kind == "capsule":
            row, ends = capsule_ends(self, topology, body, where)
            return row, ends, radius
        row, centre = self.locate(topology, body, where)
        return row, np.array([centre, centre]), radius
