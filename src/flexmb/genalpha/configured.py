"""Configured generalized-alpha classes: :func:`generalized_alpha`.

The solver is :class:`flexmb.genalpha.solver.GeneralizedAlpha`; a
configured class is a subclass with other class defaults, to pass as
``method`` to :func:`flexmb.simulate` or :func:`scipy.integrate.solve_ivp`.
"""

from __future__ import annotations

from .._validate import number
from .parameters import DEFAULT_RHO_INF, alpha_parameters
from .solver import GeneralizedAlpha

__all__ = ["generalized_alpha"]


def generalized_alpha(rho_inf: float = DEFAULT_RHO_INF, fixed_step: float | None = None,
                      f_max: float | None = None, min_step: float | None = None) -> type:
    """A :class:`GeneralizedAlpha` class with a spectral radius, and optionally a fixed step, a cutoff or a step floor.

    Parameters
    ----------
    rho_inf : float
        Spectral radius at infinity in [0, 1]: 1 keeps every frequency (no
        dissipation), smaller values remove more of the modes far above
        ``1 / h`` per step.
    fixed_step : float, optional
        Fixed step size, s (no error control); default: error-controlled
        steps.
    f_max : float, optional
        Highest frequency resolved by the error control, Hz (see
        :class:`GeneralizedAlpha`); default: all.
    min_step : float, optional
        Smallest error-controlled step, s (see :class:`GeneralizedAlpha`):
        the modes above ``1 / (2 pi min_step)`` Hz are dissipated, never
        resolved; default: no floor.

    Returns
    -------
    type
        A subclass of :class:`GeneralizedAlpha`, to pass as ``method`` to
        :func:`flexmb.simulate` or :func:`scipy.integrate.solve_ivp`.

    Raises
    ------
    ModelError
        If ``rho_inf`` is not a number in [0, 1], or ``fixed_step``,
        ``f_max`` or ``min_step`` is not a finite number > 0 (a ValueError
        too).

    Examples
    --------
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    >>> _ = model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0, -9.81, 0)))
    >>> res = fm.simulate(model, 0.5, positions={"pin": 0.5}, method=fm.generalized_alpha(rho_inf=0.6), rtol=1e-6)
    >>> res.method
    'GeneralizedAlpha(rho_inf=0.6)'
    """
    alpha_parameters(rho_inf)  # validates: a number in [0, 1]
    rho_inf = float(rho_inf)
    fixed_step, f_max, min_step = (None if v is None else number("generalized_alpha", what, v, minimum=0.0)
                                   for what, v in (("fixed_step", fixed_step), ("f_max", f_max),
                                                   ("min_step", min_step)))
    label = (f"rho_inf={float(rho_inf):g}" + (f", fixed_step={float(fixed_step):g}" if fixed_step else "")
             + (f", f_max={float(f_max):g}" if f_max else "")
             + (f", min_step={float(min_step):g}" if min_step else ""))
    return type(f"GeneralizedAlpha({label})", (GeneralizedAlpha,),
                {"rho_inf": float(rho_inf), "fixed_step": None if fixed_step is None else float(fixed_step),
                 "f_max": None if f_max is None else float(f_max),
                 "min_step": None if min_step is None else float(min_step),
                 "__module__": __name__, "__doc__": f"GeneralizedAlpha with {label}."})
