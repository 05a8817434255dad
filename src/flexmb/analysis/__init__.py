"""Analysis about a state: linearisation, modes, statics.

Modules
-------
linear
    Linearised equations in independent coordinates, natural modes,
    linear statics.
statics
    Nonlinear static equilibrium.
"""

from .linear import Linearization, linear_statics, linearize, modes
from .statics import static_equilibrium

__all__ = ["Linearization", "linearize", "modes", "linear_statics", "static_equilibrium"]
