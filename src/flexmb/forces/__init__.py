"""Force elements: the generalized active force F (eq. 5).

A force element adds forces at points, torques on bodies, or generalized
forces on coordinates to a :class:`Loads` accumulator. The assembler turns
them into ``F_l = sum_k V_kl . force_k + W_kl . torque_k`` (eq. 5), so
gravity, springs, dampers, contact and friction all enter only through F
(contact elements: :mod:`flexmb.forces.contact`).
"""

from .base import ForceElement, Loads
from .elastic import BeamElasticity
from .gravity import Gravity
from .loads import BodyTorque, PointForce
from .springs import JointSpringDamper, SpringDamper
from .._lazy import lazy_names as _lazy_names

# the contact elements and their laws are imported where one is first named (a model without contact
# never imports them, nor their kernels)
_LAZY = {
    **dict.fromkeys(("CapsuleCapsuleContact", "CapsulePlaneContact", "CapsuleSphereContact"), ".capsules"),
    **dict.fromkeys(("Capsules", "ContactGroup", "Plane", "Spheres"), ".contact_groups"),
    **dict.fromkeys(("CoulombLaw", "FloresLaw", "FrictionLaw", "HuntCrossleyLaw", "LankaraniNikraveshLaw",
                     "LinearContactLaw", "JournalBearingContact", "NormalLaw", "SpherePlaneContact",
                     "SphereSphereContact", "StribeckLaw", "VelocityWeakeningLaw", "ViscousLaw", "hertz_stiffness"),
                    ".contact"),
}

__getattr__, __dir__ = _lazy_names(globals(), _LAZY)

__all__ = ["ForceElement", "Loads", "Gravity", "SpringDamper", "JointSpringDamper", "PointForce", "BodyTorque",
           "BeamElasticity", "SpherePlaneContact", "SphereSphereContact", "JournalBearingContact", "CapsulePlaneContact",
           "CapsuleSphereContact", "CapsuleCapsuleContact", "ContactGroup", "Capsules", "Spheres", "Plane", "NormalLaw",
           "LinearContactLaw",
           "HuntCrossleyLaw", "LankaraniNikraveshLaw", "FloresLaw", "FrictionLaw", "CoulombLaw", "ViscousLaw",
           "VelocityWeakeningLaw", "StribeckLaw", "hertz_stiffness"]
