"""The relative tolerance an integrator runs at when :func:`flexmb.simulate` is given none.

The tolerances bound each step's local error, not the error at the end of
a run. In a motion whose pace depends on its energy (a pendulum going over
the top, a mechanism falling through its flat positions again and again)
every step's error changes the energy a little, for a Runge-Kutta method
always the same way, so the position error grows with the square of the
run's length. DOP853, which 'auto' takes for exactly such models (rigid
mechanisms, no stiff springs), buys accuracy cheaply: at order 8, a
tolerance 20 times tighter costs 20^(1/9), 1.4 times the steps. So its
default is :data:`DOP853_DEFAULT_RTOL`; every other integrator's is
:data:`~flexmb._validate.DEFAULT_RTOL` (CVODE_BDF at low order on flexible
models would pay 24-44 % more right-hand sides for ten times tighter).
docs/guide.md "Tolerances over long runs", docs/benchmarks.md "Default
tolerances".

An integrator class may declare its own, as the class attribute
``default_rtol``; scipy's solvers get theirs from :data:`SCIPY_DEFAULT_RTOL`
(looked up along the class's bases, so a subclass of DOP853 has DOP853's).
"""

from __future__ import annotations

from .._validate import DEFAULT_RTOL
from .base import scipy_name

__all__ = ["DOP853_DEFAULT_RTOL", "SCIPY_DEFAULT_RTOL", "default_rtol"]

#: DOP853's default relative tolerance: B7 at N = 40 over 20 s (ten turns) within 1e-6 m of its own
#: equation with a margin over the spread of its error between neighbouring tolerances
#: (benchmarks/default_tolerances.py, docs/benchmarks.md "Default tolerances")
DOP853_DEFAULT_RTOL = 5e-10

#: scipy's solvers whose default relative tolerance is not DEFAULT_RTOL, by their name in scipy.integrate
SCIPY_DEFAULT_RTOL = {"DOP853": DOP853_DEFAULT_RTOL}


def default_rtol(solver_cls: type) -> float:
    """The relative tolerance ``solver_cls`` runs at when simulate is given none.

    Parameters
    ----------
    solver_cls : type
        An :class:`scipy.integrate.OdeSolver` subclass.

    Returns
    -------
    float
        The class's ``default_rtol`` attribute if it (or a base) declares
        one, else the entry of its nearest base in :data:`SCIPY_DEFAULT_RTOL`,
        else :data:`~flexmb._validate.DEFAULT_RTOL` (1e-8).

    Examples
    --------
    >>> from scipy.integrate import DOP853, Radau
    >>> from flexmb.integrators import default_rtol
    >>> default_rtol(DOP853), default_rtol(Radau)
    (5e-10, 1e-08)
    """
    if hasattr(solver_cls, "default_rtol"):
        return float(solver_cls.default_rtol)
    return next((SCIPY_DEFAULT_RTOL[name] for name in map(scipy_name, getattr(solver_cls, "__mro__", ()))
                 if name in SCIPY_DEFAULT_RTOL), DEFAULT_RTOL)
