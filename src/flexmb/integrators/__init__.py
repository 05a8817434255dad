"""Integrators: scipy's solvers, their second-order variants, and SUNDIALS CVODE and IDA.

Every integrator is a :class:`scipy.integrate.OdeSolver` subclass, looked up
by name in the ``flexmb.integrators`` plugin table. What :func:`flexmb.simulate`
may give it (an analytic Jacobian, the second-order block structure) and
what it relies on (dense output) are read from class attributes
(:mod:`flexmb.integrators.base`):

- :mod:`~flexmb.integrators.second_order`: scipy's Radau and BDF, factoring
  only the n x n Schur complement of their Newton matrix;
- :mod:`~flexmb.integrators.sundials`: CVODE's BDF and Adams methods
  (``'CVODE_BDF'``, ``'CVODE_Adams'``) and IDA (``'IDA'``), through
  scikit-sundae.

:mod:`~flexmb.integrators.tolerances` holds the relative tolerance each
runs at when none is given.
"""

from .base import SCIPY_ADAPTERS, SCIPY_CAPABILITIES, Capabilities, adapt, capabilities
from .second_order import SecondOrderBDF, SecondOrderRadau, second_order
from .sundials import CVODE, IDA, CVODEAdams, CVODEBDF, CVODEDenseOutput
from .tolerances import DOP853_DEFAULT_RTOL, default_rtol

__all__ = [
    "Capabilities", "SCIPY_CAPABILITIES", "SCIPY_ADAPTERS", "capabilities", "adapt",
    "SecondOrderRadau", "SecondOrderBDF", "second_order",
    "CVODE", "CVODEBDF", "CVODEAdams", "IDA", "CVODEDenseOutput", "default_rtol", "DOP853_DEFAULT_RTOL",
]
