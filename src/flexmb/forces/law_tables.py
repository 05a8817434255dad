"""Contact laws given as tables (scene files): ``{"type": "flores", "stiffness": ..., "restitution": ...}``.

The contact elements (:mod:`flexmb.forces.contact`) convert a mapping given
for their ``normal_law`` or ``friction`` into the law its ``type`` names in
the plugin group ``flexmb.contacts`` (:mod:`flexmb.registry`: the built-in
laws ``linear``, ``hunt_crossley``, ``lankarani_nikravesh``, ``flores``,
``coulomb``, ``viscous``, ``velocity_weakening``, ``stribeck``, and any
installed plugin's), and their validators refuse, naming the element and
the field, what is neither a law nor a table that makes one.
"""

from __future__ import annotations

from attrs import field

from ..errors import ModelError, PluginError
from ..fields import label
from .contact_laws import NormalLaw
from .friction_laws import FrictionLaw

__all__ = ["normal_law_field", "friction_field", "contact_names"]


class _LawTable(dict):
    """A law's table that did not make a law: kept as given, for the validator to name the element."""

    problem = ""


def contact_names(base: type) -> list[str]:
    """The names of the laws of a kind in the group ``flexmb.contacts`` (the ``type`` of a law's table).

    Parameters
    ----------
    base : type
        :class:`~flexmb.forces.contact_laws.NormalLaw` or
        :class:`~flexmb.forces.friction_laws.FrictionLaw`.

    Returns
    -------
    list of str
        Sorted names of the loadable laws subclassing ``base``.
    """
    from .. import registry

    out = []
    for name in registry.names("contacts"):
        try:
            obj = registry.get("contacts", name)
        except PluginError:
            continue
        if isinstance(obj, type) and issubclass(obj, base):
            out.append(name)
    return out


def _law_of(base):
    """A converter: a mapping with ``type`` (a law of ``flexmb.contacts`` subclassing ``base``) makes that law."""

    def convert(value):
        from .. import registry

        if not isinstance(value, dict) or isinstance(value, _LawTable):
            return value
        params = dict(value)
        kind = params.pop("type", None)
        out = _LawTable(value)
        try:  # a name of the group that does not load says why; an unknown name gets the laws' names
            cls = registry.get("contacts", kind) if kind in registry.names("contacts") else None
        except PluginError as exc:
            cls, out.problem = None, str(exc)
        if cls is None or not issubclass(cls, base):
            out.problem = out.problem or (f"a law's table needs type = one of "
                                          f"{', '.join(map(repr, contact_names(base)))}, got {kind!r}")
            return out
        try:
            return cls(**params)
        except TypeError as exc:
            out.problem = f"{kind!r} law: {exc}"
        except ModelError as exc:
            out.problem = str(exc)
        return out

    return convert


def _normal_law(instance, attribute, value):
    if isinstance(value, _LawTable):
        raise ModelError(f"{label(instance)}: {attribute.name}: {value.problem}")
    if not isinstance(value, NormalLaw) or type(value).code < 0:
        raise ModelError(f"{label(instance)}: {attribute.name} must be a normal law (LinearContactLaw, "
                         f"HuntCrossleyLaw, LankaraniNikraveshLaw, FloresLaw or a subclass with a compiled code), "
                         f"got {value!r}")


def _friction_law(instance, attribute, value):
    if isinstance(value, _LawTable):
        raise ModelError(f"{label(instance)}: {attribute.name}: {value.problem}")
    if value is not None and (not isinstance(value, FrictionLaw) or type(value).code <= 0):
        raise ModelError(f"{label(instance)}: {attribute.name} must be None or a friction law (CoulombLaw, "
                         f"ViscousLaw, VelocityWeakeningLaw, StribeckLaw or a subclass with a compiled code), got "
                         f"{value!r}")


def normal_law_field():
    """The ``normal_law`` field of a contact element: a normal law, or its table.

    Returns
    -------
    attrs field
        Converted by the law's ``type`` in ``flexmb.contacts``, validated.
    """
    return field(converter=_law_of(NormalLaw), validator=_normal_law)


def friction_field():
    """The ``friction`` field of a contact element: None, a friction law, or its table.

    Returns
    -------
    attrs field
        Default None; converted by the law's ``type`` in ``flexmb.contacts``, validated.
    """
    return field(default=None, converter=_law_of(FrictionLaw), validator=_friction_law)
