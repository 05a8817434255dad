"""The Model: collects bodies, joints, force elements, constraint elements and drivers."""

from __future__ import annotations

from collections import Counter

import attrs
import numpy as np

from . import memory
from ._names import REFERENCE, find
from .bodies import Body, Ground
from .constraint_elements.base import ConstraintElement
from .drivers import Driver
from .errors import ModelError
from .forces import ForceElement
from .joints import Joint

__all__ = ["Model"]


class Model:
    """A multibody model under construction.

    Parameters
    ----------
    name : str
        Model name.

    Examples
    --------
    >>> import flexmb as fm
    >>> model = fm.Model("pendulum")
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    >>> _ = model.add(bar, fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)),
    ...               fm.Gravity((0.0, -9.81, 0.0)))
    >>> model.build().n_coords
    1
    """

    def __init__(self, name: str = "model"):
        self.name = name
        self.ground = Ground()
        self.bodies: list[Body] = []
        self.joints: list[Joint] = []
        self.forces: list[ForceElement] = []
        self.drivers: list[Driver] = []
        self.constraints: list[ConstraintElement] = []
        # elements replaced when their names were resolved: the object a user holds -> the model's
        self._aliases: dict = {}

    def add(self, *items):
        """Add bodies, joints, force elements, constraint elements and drivers (in any order).

        Parameters
        ----------
        *items : Body, Joint, ForceElement, ConstraintElement or Driver
            Elements to add; bodies used by a joint are added with it
            (those it gives by name are added on their own). An element
            may name another that is added later: names are resolved by
            :meth:`validate`.

        Returns
        -------
        Model
            This model, for chaining.

        Raises
        ------
        ModelError
            If an item is of an unknown kind.
        """
        for item in items:
            if isinstance(item, Ground):
                continue
            if isinstance(item, Body):
                if item not in self.bodies:
                    self.bodies.append(item)
            elif isinstance(item, Joint):
                self.joints.append(item)
                for b in (item.parent, item.child):  # a body given by name is added on its own
                    if isinstance(b, Body) and not isinstance(b, Ground) and b not in self.bodies:
                        self.bodies.append(b)
            elif isinstance(item, ForceElement):
                self.forces.append(item)
            elif isinstance(item, Driver):
                self.drivers.append(item)
            elif isinstance(item, ConstraintElement):
                self.constraints.append(item)
            else:
                raise ModelError(
                    f"Model {self.name!r}: cannot add {item!r}; expected a Body, Joint, ForceElement, "
                    "ConstraintElement or Driver"
                )
        return self

    def element(self, ref, kind: type = object):
        """The model's element given by object or by name.

        Parameters
        ----------
        ref : Body, Joint, ForceElement, ConstraintElement, Driver or str
            The element, or its name.
        kind : type
            Look among the elements of this class only (``fm.Joint``,
            ``fm.FlexibleBody``, ...); default: all, the ground included.

        Returns
        -------
        Body, Joint, ForceElement, ConstraintElement or Driver
            The element of the model. For an element that named another by
            name, it is the one the model holds since it resolved the name
            (:meth:`resolve`).

        Raises
        ------
        ModelError
            If no element of that kind has the name (the message lists the
            known ones), or the object is not in the model.

        Examples
        --------
        >>> import flexmb as fm
        >>> model = fm.Model()
        >>> bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
        >>> _ = model.add(fm.Revolute("pin", model.ground, bar))
        >>> model.element("pin") is model.element(model["pin"], fm.Joint)
        True
        """
        pool = [self.ground, *self.bodies, *self.joints, *self.forces, *self.constraints, *self.drivers]
        return find(ref, kind, pool, f"Model {self.name!r}", self._aliases)

    def resolve(self) -> list[str]:
        """Replace the names that elements give for other elements by those elements.

        A joint may name its bodies, a driver its joint and a force element
        its bodies or joint before those are added; each such element is
        replaced in the model by a copy holding the objects (the object the
        caller holds keeps working with :meth:`element` and
        :class:`~flexmb.System`'s look-ups). :meth:`validate` calls this.

        Returns
        -------
        list of str
            One message per name that names no element of the model, each
            naming the element that gave it (empty when all resolved).
        """
        problems = []
        pool = [self.ground, *self.bodies, *self.joints, *self.forces, *self.constraints, *self.drivers]
        for what, group in (("joint", self.joints), ("force element", self.forces),
                            ("constraint element", self.constraints), ("driver", self.drivers)):
            for i, e in enumerate(group):
                if not attrs.has(type(e)):
                    continue
                changes, bad = {}, False
                for a in attrs.fields(type(e)):
                    cls, value = a.metadata.get(REFERENCE), getattr(e, a.name)
                    if cls is None or not (isinstance(value, str) or value in self._aliases):
                        continue
                    try:
                        found = find(value, cls, pool, f"{what} {e.name!r}", self._aliases)
                        changes[a.alias] = self._aliases.get(found, found)
                    except ModelError as exc:
                        bad = True
                        problems.append(str(exc))
                if changes and not bad:
                    try:
                        new = attrs.evolve(e, **changes)
                    except ModelError as exc:
                        problems.append(str(exc))
                        continue
                    group[i] = new
                    self._aliases[e] = new
        return problems

    def __repr__(self) -> str:
        counts = [(len(self.bodies), "body", "bodies"), (len(self.joints), "joint", "joints"),
                  (len(self.forces), "force element", "force elements"),
                  *([(len(self.constraints), "constraint element", "constraint elements")] if self.constraints
                    else []),
                  (len(self.drivers), "driver", "drivers")]
        return (f"<Model {self.name!r}: " + ", ".join(f"{n} {one if n == 1 else many}" for n, one, many in counts)
                + "; print() it for its coordinates, loops and freedoms>")

    def __str__(self) -> str:
        """What ``flexmb info`` says of a scene: bodies, joints, coordinates, loops, rank, redundant rows, freedoms.

        The model is built (its problems listed instead if it is invalid), and
        the rank of the constraint Jacobian is taken at a generic state
        (random coordinates: a model has no initial state).
        """
        from ._describe import GENERIC, describe, generic_state

        try:
            system = self.build()
        except ModelError as exc:
            return f"Model {self.name!r}, which does not build: {exc}"
        return "\n".join([f"Model {self.name!r}", *describe(system, *generic_state(system), where=GENERIC)])

    def __getitem__(self, name: str):
        for group in (self.bodies, self.joints, self.forces, self.constraints, self.drivers):
            for item in group:
                if item.name == name:
                    return item
        if name == self.ground.name:
            return self.ground
        raise KeyError(f"Model {self.name!r} has no element named {name!r}")

    def problems(self) -> list[str]:
        """Return every problem found in the definitions (empty when valid).

        Returns
        -------
        list of str
            One message per problem, each naming the element.
        """
        out: list[str] = self.resolve()
        unresolved = {e for group in (self.joints, self.forces, self.constraints, self.drivers) for e in group
                      if _names_left(e)}
        for kind, group in (("body", self.bodies), ("joint", self.joints), ("force element", self.forces),
                            ("constraint element", self.constraints), ("driver", self.drivers)):
            for name, count in Counter(e.name for e in group).items():
                if count > 1:
                    out.append(f"duplicate {kind} name {name!r} ({count} times)")
        if any(b.name == self.ground.name for b in self.bodies):
            out.append(f"body name {self.ground.name!r} is reserved for the ground")
        grounds = [b for j in self.joints for b in (j.parent, j.child) if isinstance(b, Ground)]
        if any(g is not self.ground for g in grounds):
            out.append("a joint uses a Ground that is not this model's; use model.ground")
        if not self.bodies:
            out.append("the model has no bodies")
        for j in self.joints:
            if j.child is self.ground:
                out.append(f"joint {j.name!r}: the ground cannot be a child; swap parent and child")
        joints = set(self.joints)
        bodies = set(self.bodies) | {self.ground}
        for f in self.forces:
            if f in unresolved:
                continue
            out.extend(f.check(self))
            for attr in ("body", "body1", "body2"):
                b = getattr(f, attr, None)
                if isinstance(b, Body) and b not in bodies:
                    out.append(f"force element {f.name!r}: body {b.name!r} is not in the model")
            j = getattr(f, "joint", None)
            if isinstance(j, Joint) and j not in joints:
                out.append(f"force element {f.name!r}: joint {j.name!r} is not in the model")
        for c in self.constraints:
            if c in unresolved:
                continue
            out.extend(c.check(self))
            for a in attrs.fields(type(c)) if attrs.has(type(c)) else ():
                value = getattr(c, a.name)
                if isinstance(value, Body) and not isinstance(value, Ground) and value not in bodies:
                    out.append(f"constraint element {c.name!r}: body {value.name!r} is not in the model")
                if isinstance(value, Joint) and value not in joints:
                    out.append(f"constraint element {c.name!r}: joint {value.name!r} is not in the model")
        out.extend(_freedoms_without_mass(self, unresolved))
        seen = {}
        for d in self.drivers:
            if d in unresolved:
                continue
            if d.joint not in joints:
                out.append(f"driver {d.name!r}: joint {d.joint.name!r} is not in the model")
            key = (id(d.joint), d.coordinate)
            if key in seen:
                out.append(f"drivers {seen[key]!r} and {d.name!r} both drive {d.joint.name!r}[{d.coordinate}]")
            seen[key] = d.name
        return out

    def validate(self) -> None:
        """Raise one :class:`ModelError` listing every problem, if any.

        Raises
        ------
        ModelError
            With ``.problems`` holding all messages (among them, each name
            an element gives that names nothing in the model:
            ``driver 'motor': no joint named 'A'; joints: ['pin']``); a model that would not
            fit in the available memory (:func:`flexmb.memory.check`, with
            the loops closed through the recursion, the leanest way) is
            refused before anything is allocated.
        """
        self._validated_topology()

    def _validated_topology(self):
        """:meth:`validate`, returning the :class:`~flexmb.topology.Topology` it built (for :meth:`build`)."""
        from .topology import Topology

        problems = self.problems()
        topology = None
        try:
            memory.check(self, loops="articulated")  # before Topology allocates; the leanest strategy's need
            topology = Topology(self)
        except ModelError as exc:
            problems += [p for p in exc.problems if p not in problems]
        except Exception:
            if not problems:  # a crash on a model already known to be invalid adds nothing
                raise
        if problems:
            raise ModelError(
                f"Model {self.name!r} is invalid:\n  - " + "\n  - ".join(problems), problems
            )
        return topology

    def build(self, **options):
        """Validate and compile the model into a :class:`~flexmb.system.System`.

        Parameters
        ----------
        **options
            Passed to :class:`~flexmb.system.System`.

        Returns
        -------
        System
            The compiled system, ready to simulate.
        """
        from .system import System

        topology = self._validated_topology()  # built once: the System takes the tree validation built
        return System(self, _topology=topology, **options)


def as_system(model_or_system, error=ModelError, *, complement=None):
    """The System of a Model or System: the one conversion every function that takes either uses.

    Parameters
    ----------
    model_or_system : Model or System
        A model (built here, with the default options but ``complement``)
        or a built system (returned as it is, or with ``complement``).
    error : type of Exception
        Raised when the argument is neither (e.g. the calling module's own
        error class).
    complement : str or ComplementStrategy, optional
        Orthogonal complement strategy (default: a model's default, a
        system's own); a system given with one is left unchanged and a new
        one returned (:meth:`System.with_complement
        <flexmb.system.System.with_complement>`).

    Returns
    -------
    System
        The built system.

    Raises
    ------
    ModelError
        If the model is invalid (and, by default, if the argument is
        neither a Model nor a System).
    """
    from .system import System

    if isinstance(model_or_system, System):
        return model_or_system if complement is None else model_or_system.with_complement(complement)
    if isinstance(model_or_system, Model):
        return model_or_system.build() if complement is None else model_or_system.build(complement=complement)
    raise error(f"expected a flexmb System or Model, got {type(model_or_system).__name__}")


def _names_left(element) -> bool:
    """Whether a definition still holds a name where it refers to another element."""
    return attrs.has(type(element)) and any(
        a.metadata.get(REFERENCE) is not None and isinstance(getattr(element, a.name), str)
        for a in attrs.fields(type(element)))


def _rotation_axes(joint) -> np.ndarray | None:
    """The unit axes (child body frame, columns) the joint turns its child about at q = 0, None if not known."""
    if type(joint).motion.__func__ is not Joint.motion.__func__ or not joint.rotation_axes:
        return None  # a joint with a motion of its own: its axes are not the frame's
    _, child_frame = joint.frames()
    return np.asarray(child_frame, dtype=float)[:, list(joint.rotation_axes)]


def _freedoms_without_mass(model, unresolved) -> list[str]:
    """Joint rotations that move no mass of their own, caught at build time (the mass matrix would be singular).

    Two cases, each named with its remedy: a joint that turns a clamped
    flexible body about an axis its clamped root joint also bends about, at
    the same point (the body frame between them is massless); and a joint
    that turns a rigid body at the end of a branch (no other joint on it)
    about an axis through the joint point about which the body has no
    inertia (a slender bar's own axis). A driven joint has no freedom there.
    """
    from .bodies import RigidBody
    from .flexible import ELASTIC_COORDINATES, FlexibleBody

    out = []
    joints = [j for j in model.joints if j not in unresolved]
    driven = {id(d.joint) for d in model.drivers}
    for j in joints:
        body, axes = j.child, _rotation_axes(j)
        if axes is None or j.cut or id(j) in driven or not isinstance(body, (RigidBody, FlexibleBody)):
            continue  # a driver prescribes the joint's motion: no freedom left there
        kind = type(j).__name__
        if isinstance(body, FlexibleBody):
            kept = [k for k in body.keep if ELASTIC_COORDINATES[k][0] == "r"]
            if not body.clamped or not kept or np.linalg.norm(j.child_point) > 1e-9 * body.length:
                continue
            span = np.eye(3)[:, [ELASTIC_COORDINATES[k][1] for k in kept]]
            for u in axes.T:
                if np.linalg.norm(u - span @ (span.T @ u)) < 1e-9:
                    out.append(
                        f"joint {j.name!r} ({kind}) turns the clamped flexible body {body.name!r} about "
                        f"{[round(float(v), 6) + 0.0 for v in u]} at its root, about which its clamped root joint also "
                        f"bends ({', '.join(kept)}): through the massless body frame between them the two move the "
                        "same mass the same way, and the mass matrix is singular. For a pinned root give the body "
                        "clamped=False (its first segment is then the body frame); a clamped root is attached with "
                        "a Fixed (or driven) joint")
                    break
            continue
        on_body = [k for k in joints if body in (k.parent, k.child)]
        if len(on_body) > 1:
            continue  # more bodies or a loop on it: they may move or fix that freedom
        r = body.com - j.child_point
        inertia = body.inertia + body.mass * (r @ r * np.eye(3) - np.outer(r, r))  # about the joint point
        sub_inertia = axes.T @ inertia @ axes
        values, vectors = np.linalg.eigh(sub_inertia)
        if values[0] <= 1e-12 * max(np.trace(inertia), np.finfo(float).tiny):
            axis = axes @ vectors[:, 0]
            axis = axis / np.linalg.norm(axis)
            out.append(
                f"joint {j.name!r} ({kind}) turns body {body.name!r} about the axis "
                f"{[round(float(v), 6) + 0.0 for v in axis]} (body frame) through the joint point, about which "
                f"{body.name!r} has no inertia (a slender bar has none about its own axis): nothing resists that "
                f"spin and the mass matrix is singular. Give {body.name!r} an inertia about that axis (a small "
                "axial moment in RigidBody(name, mass, inertia)), or use a joint without that rotation (a "
                "Universal instead of a Spherical)")
    return out
