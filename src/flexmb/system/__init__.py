"""The compiled system: topology, assembler, constraints and the reduced equations.

:class:`System` is put together from one module per concept:

core
    Build, kinematics, the equations of motion (eqs. 1-3, 21) and the state
    rate.
solve
    The reduced solve for the accelerations (eqs. 36-39).
projection
    Projection of a state onto the constraints (eqs. 28-29).
tangent
    The state Jacobian and the Newton preconditioner.
rates
    The fastest rates of the linearised motion.
quantities
    Reactions, flexible shapes, energy and degrees of freedom at a state.
"""

from .core import Equations, System
from .tangent import NewtonPreconditioner

__all__ = ["System", "Equations", "NewtonPreconditioner"]
