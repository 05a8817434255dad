"""Contact laws given as tables (scene files): ``{"type": "flores", "stiffness": ..., "restitution": ...}``.

The contact elements (:mod:`flexmb.forces.contact`) convert a mapping given
for their ``normal_law`` or ``friction`` into the law its ``type`` names,
and their validators refuse, naming the element and the field, what is
neither a law nor a table that makes one.
"""

from __future__ import annotations

from ..errors import ModelError
from ..fields import label
from .contact_laws import FloresLaw, HuntCrossleyLaw, LankaraniNikraveshLaw, LinearContactLaw, NormalLaw
from .friction_laws import CoulombLaw, FrictionLaw, StribeckLaw, VelocityWeakeningLaw, ViscousLaw

__all__ = ["NORMAL_LAWS", "FRICTION_LAWS"]

#: the laws by the names a table gives as its ``type`` (scene files: ``normal_law = {type = "flores", ...}``)
NORMAL_LAWS = {"linear": LinearContactLaw, "hunt_crossley": HuntCrossleyLaw,
               "lankarani_nikravesh": LankaraniNikraveshLaw, "flores": FloresLaw}
FRICTION_LAWS = {"coulomb": CoulombLaw, "viscous": ViscousLaw, "velocity_weakening": VelocityWeakeningLaw,
                 "stribeck": StribeckLaw}


class _LawTable(dict):
    """A law's table that did not make a law: kept as given, for the validator to name the element."""

    problem = ""


def _law_of(laws):
    """A converter: a mapping with ``type`` (a key of ``laws``) and the law's parameters makes that law."""

    def convert(value):
        if not isinstance(value, dict) or isinstance(value, _LawTable):
            return value
        params = dict(value)
        kind = params.pop("type", None)
        out = _LawTable(value)
        if kind not in laws:
            out.problem = f"a law's table needs type = one of {', '.join(map(repr, laws))}, got {kind!r}"
            return out
        try:
            return laws[kind](**params)
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
                         f"HuntCrossleyLaw, LankaraniNikraveshLaw or FloresLaw), got {value!r}")


def _friction_law(instance, attribute, value):
    if isinstance(value, _LawTable):
        raise ModelError(f"{label(instance)}: {attribute.name}: {value.problem}")
    if value is not None and (not isinstance(value, FrictionLaw) or type(value).code <= 0):
        raise ModelError(f"{label(instance)}: {attribute.name} must be None or a friction law (CoulombLaw, "
                         f"ViscousLaw, VelocityWeakeningLaw or StribeckLaw), got {value!r}")
