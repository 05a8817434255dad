"""flexmb: dynamics of large constrained flexible multibody structures.

Kane's equations with partial velocity arrays, closed loops eliminated by
orthogonal complement arrays (Amirouche & Huston 1988).

Messages that are not results (a study resuming, a plot not written) go to
the ``logging`` loggers ``flexmb.*``: silent unless the application
configures logging (the ``flexmb`` command shows them on stderr).
"""

import sys as _sys

if _sys.argv[:1] == ["-m"]:  # the interpreter is still locating the module of `python -m ...`
    import flexmb_command as _command

    if _command.module_run(_sys.orig_argv) == "flexmb":  # `python -m flexmb`: signals answered from here on
        _command.install()

import logging as _logging

from . import _exit
from ._lazy import lazy_names as _lazy_names
from .bodies import Body, Ground, Marker, RigidBody
from .complements import COMPLEMENTS, ComplementStrategy, EigenComplement, SVDComplement, get_complement
from .drivers import Driver
from .constraint_elements import ConstraintElement, velocity_rows
from .errors import (AssemblyError, ExportError, FlexmbError, GimbalLockWarning, ModelError, PluginError, SceneError,
                     SimulationError, StiffnessWarning)
from .forces import BodyTorque, ForceElement, Gravity, JointSpringDamper, Loads, PointForce, SpringDamper
from .joints import Cylindrical, Fixed, Free, Joint, PlanarRevolute, Prismatic, Revolute, Spherical, Universal
from .flexible import FlexibleBody, Segment
from .model import Model
from .registry import PluginInfo, plugins, register
from .profiles import BeamProfile
from .sections import Material, Section
from .result import Result
# the module flexmb.simulate is imported here, not on first use: importing it later would bind the
# package's attribute ``simulate`` to the module over the function
from .simulate import INTEGRATORS, initial_state, simulate
from .initial_speeds import AngularVelocity, PointVelocity
from .complements import ArticulatedComplement, AutoComplement, QRComplement
from ._names import reference

#: public names imported on first use (module-level ``__getattr__``, PEP 562): what a model's build and
#: simulation do not need (the analyses import scipy.optimize, scenes and studies their readers and executors)
_LAZY = {
    # the contact elements, their laws and the constraint elements: imported where first named
    **dict.fromkeys(("CapsuleCapsuleContact", "CapsulePlaneContact", "CapsuleSphereContact", "Capsules", "ContactGroup",
                     "Plane", "Spheres", "FrictionLaw", "NormalLaw", "CoulombLaw", "FloresLaw", "HuntCrossleyLaw",
                     "JournalBearingContact", "LankaraniNikraveshLaw", "LinearContactLaw", "SpherePlaneContact",
                     "SphereSphereContact", "StribeckLaw", "VelocityWeakeningLaw", "ViscousLaw", "hertz_stiffness"),
                    ".forces"),
    **dict.fromkeys(("CurveConstraint", "Distance", "GearPair", "KnifeEdge", "PointOnCircle", "PointOnCurve",
                     "PointOnLine", "RollingDisc"), ".constraint_elements"),
    **dict.fromkeys(("Calibration", "Campbell", "CriticalPoint", "FrequencyResponse", "Input", "Linearization",
                     "LoadPath", "Output", "PathOptions", "StateSpace", "SteadyLinearization", "calibrate",
                     "campbell", "frequency_response", "linear_statics", "linearize", "linearize_steady",
                     "load_path", "modes", "state_space", "static_equilibrium"), ".analysis"),
    **dict.fromkeys(("GeneralizedAlpha", "generalized_alpha"), ".genalpha"),
    "System": ".system",
    **dict.fromkeys(("Scene", "load_scene", "loads_scene", "scene_from_dict"), ".scene"),
    **dict.fromkeys(("Study", "StudyResult", "run_study"), ".study"),
}


__getattr__, __dir__ = _lazy_names(globals(), _LAZY)


__version__ = "0.1.0"

# the exit skips the final collections' passes over the objects still alive (flexmb._exit)
_exit.install()

# a library logs, the application decides what is shown (logging HOWTO, "Configuring Logging for a Library")
_logging.getLogger(__name__).addHandler(_logging.NullHandler())

__all__ = [
    "Body", "Ground", "Marker", "RigidBody",
    "COMPLEMENTS", "ComplementStrategy", "EigenComplement", "SVDComplement", "get_complement",
    "Driver",
    "ConstraintElement", "CurveConstraint", "Distance", "GearPair", "KnifeEdge", "PointOnCircle", "PointOnCurve",
    "PointOnLine", "RollingDisc", "velocity_rows",
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
    "StiffnessWarning", "GimbalLockWarning", "GeneralizedAlpha", "generalized_alpha",
    "ArticulatedComplement", "AutoComplement", "QRComplement",
    "reference",
]

__all__ += ["scene_from_dict", "Study", "StudyResult", "run_study"]
