"""Analysis about a state: linearisation, modes, statics.

Modules
-------
linear
    Linearised equations in independent coordinates, natural modes,
    linear statics.
statics
    Nonlinear static equilibrium, load continuation and arc-length
    path following through limit points.
"""

from .linear import Linearization, linear_statics, linearize, modes
from .statics import CriticalPoint, LoadPath, PathOptions, load_path, static_equilibrium

__all__ = ["Linearization", "linearize", "modes", "linear_statics", "static_equilibrium", "load_path", "LoadPath",
           "CriticalPoint", "PathOptions"]
