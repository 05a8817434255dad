"""Integrators of looped models that the run steps itself: :class:`SteppedByRun`.

A mixin of the compiled loops' integrators, whose steps
:func:`flexmb.own_loop.advance_checking` takes through their ``step_on`` so
that the run's constraint checks and restarts act after each of them.
"""

from __future__ import annotations

__all__ = ["SteppedByRun"]


class SteppedByRun:
    """Mixin of an integrator of looped models that the run steps through ``step_on``, not ``advance``.

    The compiled loops' CVODE and generalized-alpha
    (:class:`~flexmb.integrators.cvode_direct_loops.DirectLoopCVODE`,
    :class:`~flexmb.genalpha.compiled.CompiledLoopGeneralizedAlpha`) are
    driven by :func:`flexmb.own_loop.advance_checking`: the run's constraint
    checks and restarts act after their steps, so ``advances`` is False and
    :meth:`advance` is refused.
    """

    advances = False

    def advance(self, t_stop: float, on_step=None):
        """Refused: a looped model's steps need the run's checks (see ``step_on``).

        Parameters
        ----------
        t_stop : float
            Time to reach.
        on_step : callable, optional
            Not used.

        Raises
        ------
        TypeError
            Always.
        """
        raise TypeError(f"{type(self).__name__} is stepped by step_on (flexmb.own_loop.advance_checking): the "
                        "constraint checks and restarts of the run act after its steps")
