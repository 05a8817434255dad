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
  scikit-sundae; an open tree with compiled force elements runs them
  stepped in compiled code (:mod:`~flexmb.integrators.cvode_direct`).

:mod:`~flexmb.integrators.tolerances` holds the relative tolerance each
runs at when none is given.

The names of this package are imported on first use (PEP 562): the
solver classes import scipy.integrate (and with it scipy.optimize,
scipy.special and scipy.linalg), which a run stepped in compiled code
never uses (tests/test_lazy_imports.py).
"""

from .._lazy import lazy_names as _lazy_names

#: public names, imported from their module on first use
_LAZY = {
    **dict.fromkeys(("Capabilities", "SCIPY_CAPABILITIES", "SCIPY_ADAPTERS", "capabilities", "adapt"), ".base"),
    **dict.fromkeys(("SecondOrderRadau", "SecondOrderBDF"), ".second_order"),
    **dict.fromkeys(("CVODE", "CVODEBDF", "CVODEAdams", "IDA", "CVODEDenseOutput"), ".sundials"),
    **dict.fromkeys(("default_rtol", "DOP853_DEFAULT_RTOL"), ".tolerances"),
}

__all__ = [
    "Capabilities", "SCIPY_CAPABILITIES", "SCIPY_ADAPTERS", "capabilities", "adapt",
    "SecondOrderRadau", "SecondOrderBDF",
    "CVODE", "CVODEBDF", "CVODEAdams", "IDA", "CVODEDenseOutput", "default_rtol", "DOP853_DEFAULT_RTOL",
]


__getattr__, __dir__ = _lazy_names(globals(), _LAZY)
