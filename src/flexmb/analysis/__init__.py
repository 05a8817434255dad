"""Analysis about a state: linearisation, modes, statics.

Modules
-------
linear
    Linearised equations in independent coordinates, natural modes,
    linear statics.
statics
    Nonlinear static equilibrium.
calibration
    Segment data fitted to measured natural frequencies and mode shapes.
"""

from .linear import Linearization, linear_statics, linearize, modes
from .statics import static_equilibrium
from .calibration import Calibration, calibrate

__all__ = ["Linearization", "linearize", "modes", "linear_statics", "static_equilibrium", "Calibration",
           "calibrate"]
