"""flexmb: dynamics of large constrained flexible multibody structures.

Kane's equations with partial velocity arrays, closed loops eliminated by
orthogonal complement arrays (Amirouche & Huston 1988).

Messages that are not results (a study resuming, a plot not written) go to
the ``logging`` loggers ``flexmb.*``: silent unless the application
configures logging (the ``flexmb`` command shows them on stderr).
"""

import logging as _logging

from .bodies import Body, Ground, Marker, RigidBody
from .complements import COMPLEMENTS, ComplementStrategy, EigenComplement, SVDComplement, get_complement
from .drivers import Driver
from .constraint_elements import ConstraintElement, GearPair, KnifeEdge, RollingDisc, velocity_rows
from .errors import (AssemblyError, ExportError, FlexmbError, ModelError, PluginError, SceneError, SimulationError,
                     StiffnessWarning)
from .forces import BodyTorque, ForceElement, Gravity, JointSpringDamper, Loads, PointForce, SpringDamper
from .forces import (CapsuleCapsuleContact, CapsulePlaneContact, CapsuleSphereContact, Capsules, ContactGroup, Plane,
                     Spheres)
from .forces import FrictionLaw, NormalLaw
from .forces import (CoulombLaw, FloresLaw, HuntCrossleyLaw, JournalBearingContact, LankaraniNikraveshLaw,
                     LinearContactLaw, SpherePlaneContact, SphereSphereContact, StribeckLaw, VelocityWeakeningLaw,
                     ViscousLaw, hertz_stiffness)
from .joints import Cylindrical, Fixed, Free, Joint, PlanarRevolute, Prismatic, Revolute, Spherical, Universal
from .flexible import FlexibleBody, Segment
from .analysis import (Calibration, Campbell, CriticalPoint, FrequencyResponse, Input, Linearization, LoadPath,
                       Output, PathOptions, StateSpace, SteadyLinearization, calibrate, campbell, frequency_response,
                       linear_statics, linearize, linearize_steady, load_path, modes, state_space, static_equilibrium)
from .model import Model
from .registry import PluginInfo, plugins, register
from .profiles import BeamProfile
from .sections import Material, Section
from .result import Result
from .simulate import INTEGRATORS, initial_state, simulate
from .initial_speeds import AngularVelocity, PointVelocity
from .genalpha import GeneralizedAlpha, generalized_alpha
from .system import System
from .scene import Scene, load_scene, loads_scene
from .complements import ArticulatedComplement, AutoComplement, QRComplement
from ._names import reference

__version__ = "0.1.0"

# a library logs, the application decides what is shown (logging HOWTO, "Configuring Logging for a Library")
_logging.getLogger(__name__).addHandler(_logging.NullHandler())

__all__ = [
    "Body", "Ground", "Marker", "RigidBody",
    "COMPLEMENTS", "ComplementStrategy", "EigenComplement", "SVDComplement", "get_complement",
    "Driver",
    "ConstraintElement", "GearPair", "KnifeEdge", "RollingDisc", "velocity_rows",
    "AssemblyError", "ExportError", "FlexmbError", "ModelError", "PluginError", "SimulationError",
    "BodyTorque", "ForceElement", "Gravity", "JointSpringDamper", "Loads", "PointForce", "SpringDamper",
    "SpherePlaneContact", "SphereSphereContact", "JournalBearingContact", "CapsulePlaneContact", "CapsuleSphereContact",
    "CapsuleCapsuleContact", "ContactGroup", "Capsules", "Spheres", "Plane", "NormalLaw", "FrictionLaw",
    "LinearContactLaw", "HuntCrossleyLaw",
    "LankaraniNikraveshLaw",
    "FloresLaw", "CoulombLaw", "ViscousLaw", "VelocityWeakeningLaw", "StribeckLaw", "hertz_stiffness",
    "Cylindrical", "Fixed", "Free", "Joint", "PlanarRevolute", "Prismatic", "Revolute", "Spherical", "Universal",
    "FlexibleBody", "Segment", "Material", "Section", "BeamProfile",
    "Linearization", "linear_statics", "linearize", "SteadyLinearization", "linearize_steady", "modes",
    "static_equilibrium", "Calibration", "calibrate",
    "Input", "Output", "StateSpace", "state_space", "FrequencyResponse", "frequency_response", "Campbell",
    "campbell",
    "CriticalPoint", "LoadPath", "PathOptions", "load_path",
    "Model", "PluginInfo", "plugins", "register", "Result", "INTEGRATORS", "initial_state", "simulate", "System",
    "PointVelocity", "AngularVelocity",
    "Scene", "SceneError", "load_scene", "loads_scene",
    "StiffnessWarning", "GeneralizedAlpha", "generalized_alpha",
    "ArticulatedComplement", "AutoComplement", "QRComplement",
    "reference",
]

from .scene import scene_from_dict
from .study import Study, StudyResult, run_study

__all__ += ["scene_from_dict", "Study", "StudyResult", "run_study"]
