"""Model elements given by object or by name: one lookup and one message for the whole API.

A body, joint, driver or force element can be passed wherever the API names
one, either as the object or as its name. A definition that names another
element (a :class:`~flexmb.Driver`'s joint, a joint's bodies, a force
element's body) declares that field with :func:`reference`; a name there is
kept as given and replaced by the element when the model is built
(:meth:`flexmb.Model.validate`), so an element can be written before the
one it names is added.
"""

from __future__ import annotations

import re

from attrs import field

from .errors import ModelError
from .fields import label

__all__ = ["REFERENCE", "reference", "kind_name", "name_of", "find"]

#: attrs metadata key of a field that holds another element of the model (the value: its class)
REFERENCE = "flexmb.reference"


def kind_name(cls: type) -> str:
    """``FlexibleBody`` -> ``"flexible body"``: the words a message uses for a class."""
    if cls is object:
        return "element"
    return re.sub(r"(?<!^)(?=[A-Z])", " ", cls.__name__).lower()


def _check(cls: type):
    def check(instance, attribute, value):
        if isinstance(value, cls) or (isinstance(value, str) and value.strip()):
            return
        raise ModelError(f"{label(instance)}: {attribute.name} must be a {cls.__name__}, got "
                         f"{type(value).__name__} (or give the {kind_name(cls)}'s name)")

    return check


def reference(kind: type, **kw):
    """An attrs field holding an element of class ``kind`` or its name (a non-empty string).

    The model replaces a name by the element it names when it is built
    (:meth:`flexmb.Model.validate`); a plugin's element that refers to a
    body or a joint declares the field with it, as the built-ins do.

    Parameters
    ----------
    kind : type
        The class of the element, e.g. :class:`flexmb.Body` or
        :class:`flexmb.Joint`.
    **kw
        Other arguments of :func:`attrs.field` (``default``, ...).

    Returns
    -------
    attrs field
        Validated: an instance of ``kind`` or a non-empty string.

    Examples
    --------
    >>> import flexmb as fm
    >>> from attrs import frozen
    >>> @frozen(eq=False)
    ... class Drag(fm.ForceElement):
    ...     body: fm.Body = fm.reference(fm.Body)
    ...     c: float = 0.5
    ...
    ...     def apply(self, state, loads):
    ...         k = state.index(self.body)
    ...         loads.add_point_force(k, state.r[k], -self.c * state.v[k])
    >>> drag = Drag("drag", "bar")  # the bar named before it exists
    >>> model = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    >>> _ = model.add(fm.Revolute("pin", model.ground, bar), drag)
    >>> system = model.build()
    """
    return field(validator=_check(kind), metadata={REFERENCE: kind}, **kw)


def name_of(ref, cls: type, where: str) -> str:
    """The name of an element given by object or by name (for look-ups in name lists)."""
    if isinstance(ref, str):
        return ref
    if isinstance(ref, cls):
        return ref.name
    raise ModelError(f"{where}: expected a {cls.__name__} or its name, got {type(ref).__name__} {ref!r}")


def find(ref, cls: type, elements, where: str, aliases=None):
    """The element among ``elements`` that ``ref`` is or names.

    Parameters
    ----------
    ref : object or str
        The element, or its name.
    cls : type
        The class looked for (``Body``, ``Joint``, ``FlexibleBody``, ...).
    elements : iterable
        The candidates (the model's elements of that kind).
    where : str
        Who asks, the start of the messages.
    aliases : dict, optional
        Elements replaced by the model when it resolved their names: the
        object the caller holds maps to the one in the model.

    Returns
    -------
    object
        The element.

    Raises
    ------
    ModelError
        If no element has that name (the message lists the known ones), the
        object is not among them, or ``ref`` is neither.
    """
    elements = [e for e in elements if isinstance(e, cls)]
    kind = kind_name(cls)
    kinds = kind[:-1] + "ies" if kind.endswith("y") else kind + "s"
    if isinstance(ref, str):
        for e in elements:
            if e.name == ref:
                return e
        raise ModelError(f"{where}: no {kind} named {ref!r}; {kinds}: {[e.name for e in elements]}")
    if not isinstance(ref, cls):
        raise ModelError(f"{where}: expected a {cls.__name__} or its name, got {type(ref).__name__} {ref!r}")
    ref = (aliases or {}).get(ref, ref)
    if not any(e is ref for e in elements):
        raise ModelError(f"{where}: {label(ref)} is not in the model")
    return ref
