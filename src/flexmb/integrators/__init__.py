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

import importlib as _importlib

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


def __getattr__(name):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(_importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
