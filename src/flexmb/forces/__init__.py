"""Force elements: the generalized active force F (eq. 5).

A force element adds forces at points, torques on bodies, or generalized
forces on coordinates to a :class:`Loads` accumulator. The assembler turns
them into ``F_l = sum_k V_kl . force_k + W_kl . torque_k`` (eq. 5), so
gravity, springs, dampers, contact and friction all enter only through F
(contact elements: :mod:`flexmb.forces.contact`).
"""

from .base import ForceElement, Loads
from .capsules import CapsuleCapsuleContact, CapsulePlaneContact, CapsuleSphereContact
from .contact_groups import Capsules, ContactGroup, Plane, Spheres
from .contact import (CoulombLaw, FloresLaw, FrictionLaw, HuntCrossleyLaw, LankaraniNikraveshLaw, LinearContactLaw,
                      JournalBearingContact, NormalLaw, SpherePlaneContact, SphereSphereContact, StribeckLaw,
                      VelocityWeakeningLaw, ViscousLaw, hertz_stiffness)
from .elastic import BeamElasticity
from .gravity import Gravity
from .loads import BodyTorque, PointForce
from .springs import JointSpringDamper, SpringDamper

__all__ = ["ForceElement", "Loads", "Gravity", "SpringDamper", "JointSpringDamper", "PointForce", "BodyTorque",
           "BeamElasticity", "SpherePlaneContact", "SphereSphereContact", "JournalBearingContact", "CapsulePlaneContact",
           "CapsuleSphereContact", "CapsuleCapsuleContact", "ContactGroup", "Capsules", "Spheres", "Plane", "NormalLaw",
           "LinearContactLaw",
           "HuntCrossleyLaw", "LankaraniNikraveshLaw", "FloresLaw", "FrictionLaw", "CoulombLaw", "ViscousLaw",
           "VelocityWeakeningLaw", "StribeckLaw", "hertz_stiffness"]
