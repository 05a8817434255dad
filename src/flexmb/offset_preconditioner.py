"""A Newton preconditioner for an integrator that holds the state less the winding offsets (:mod:`flexmb.stepping`).

A run integrates ``z = y - c``, with ``c`` whole turns on the angles that
wound up; the system's preconditioner is set up at the true state ``y``.
"""

from __future__ import annotations

__all__ = ["OffsetPreconditioner"]


class OffsetPreconditioner:
    """A Newton preconditioner set up at ``y = z + c`` while the integrator holds ``z`` (:mod:`flexmb.stepping`).

    Parameters
    ----------
    pre : NewtonPreconditioner
        The system's preconditioner.
    run : Run
        The run whose offset (``Run.offset``) is added.
    """

    def __init__(self, pre, run):
        self.pre, self.run, self.system = pre, run, pre.system

    @property
    def n_setups(self) -> int:
        """Set-ups so far."""
        return self.pre.n_setups

    def setup(self, t, x, xd) -> None:
        """Set up at the true coordinates ``x + c``.

        Parameters
        ----------
        t : float
            Time, s.
        x : ndarray, shape (nq,)
            The integrator's coordinates (less the offsets).
        xd : ndarray, shape (n,)
            Speeds.
        """
        offset = self.run.offset
        self.pre.setup(t, x if offset is None else x + offset[: len(x)], xd)

    def solve(self, r1, r2, gamma):
        """As :meth:`NewtonPreconditioner.solve` (increments do not depend on the offset).

        Parameters
        ----------
        r1 : ndarray, shape (nq,)
            The right-hand side's coordinate half.
        r2 : ndarray, shape (n,)
            Its speed half.
        gamma : float
            The integrator's coefficient (step size times its method's
            constant).

        Returns
        -------
        z1 : ndarray, shape (nq,)
            The solution's coordinate half.
        z2 : ndarray, shape (n,)
            Its speed half.
        """
        return self.pre.solve(r1, r2, gamma)
