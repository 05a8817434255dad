"""Analysis about a state: linearisation, modes, statics.

Modules
-------
linear
    Linearised equations in independent coordinates, natural modes,
    linear statics.
statics
    Nonlinear static equilibrium (Newton's method, then load continuation).
path_following
    Arc-length path following through limit points and snap-through.
paths
    The load path, its critical points and the follower's options.
calibration
    Segment data fitted to measured natural frequencies and mode shapes.
signals
    Named inputs (loads) and outputs (motions) of a linearised model.
statespace
    State-space models with named inputs and outputs.
frequency
    Frequency responses (Bode).
campbell_diagram
    Campbell diagrams: frequencies and damping against a parameter.
steady
    First-order linearisation about a steady motion (velocity rows allowed).
loop_modes
    The lowest modes of a large looped model by preconditioned Davidson
    iteration, O(n m) per step.
"""

from .linear import Linearization, linear_statics, linearize, modes, tangent_gap
from .path_following import load_path
from .paths import CriticalPoint, LoadPath, PathOptions
from .statics import static_equilibrium
from .calibration import Calibration, calibrate
from .signals import Input, Output
from .statespace import StateSpace, state_space
from .frequency import FrequencyResponse, frequency_response
from .campbell_diagram import Campbell, campbell
from .steady import SteadyLinearization, linearize_steady

__all__ = ["Linearization", "linearize", "modes", "linear_statics", "tangent_gap", "static_equilibrium",
           "load_path", "LoadPath", "CriticalPoint", "PathOptions", "Calibration", "calibrate", "Input", "Output",
           "StateSpace", "state_space", "FrequencyResponse", "frequency_response", "Campbell", "campbell",
           "SteadyLinearization", "linearize_steady"]
