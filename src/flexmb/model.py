"""The Model: collects bodies, joints, force elements and drivers."""

from __future__ import annotations

from collections import Counter

from . import memory
from .bodies import Body, Ground
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

    def add(self, *items):
        """Add bodies, joints, force elements and drivers (in any order).

        Parameters
        ----------
        *items : Body, Joint, ForceElement or Driver
            Elements to add; bodies used by a joint are added with it.

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
                for b in (item.parent, item.child):
                    if not isinstance(b, Ground) and b not in self.bodies:
                        self.bodies.append(b)
            elif isinstance(item, ForceElement):
                self.forces.append(item)
            elif isinstance(item, Driver):
                self.drivers.append(item)
            else:
                raise ModelError(
                    f"Model {self.name!r}: cannot add {item!r}; expected a Body, Joint, ForceElement or Driver"
                )
        return self

    def __getitem__(self, name: str):
        for group in (self.bodies, self.joints, self.forces, self.drivers):
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
        out: list[str] = []
        for kind, group in (("body", self.bodies), ("joint", self.joints),
                            ("force element", self.forces), ("driver", self.drivers)):
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
            out.extend(f.check(self))
            for attr in ("body", "body1", "body2"):
                b = getattr(f, attr, None)
                if isinstance(b, Body) and b not in bodies:
                    out.append(f"force element {f.name!r}: body {b.name!r} is not in the model")
            j = getattr(f, "joint", None)
            if isinstance(j, Joint) and j not in joints:
                out.append(f"force element {f.name!r}: joint {j.name!r} is not in the model")
        seen = {}
        for d in self.drivers:
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
            With ``.problems`` holding all messages; a model that would not
            fit in the available memory (:func:`flexmb.memory.check`) is
            refused before anything is allocated.
        """
        from .topology import Topology

        problems = self.problems()
        try:
            memory.check(self)  # before Topology allocates anything
            Topology(self)
        except ModelError as exc:
            problems += [p for p in exc.problems if p not in problems]
        except Exception:
            if not problems:  # a crash on a model already known to be invalid adds nothing
                raise
        if problems:
            raise ModelError(
                f"Model {self.name!r} is invalid:\n  - " + "\n  - ".join(problems), problems
            )

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

        self.validate()
        return System(self, **options)
