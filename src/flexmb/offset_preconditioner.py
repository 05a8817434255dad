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
        x, xd : ndarray
            The integrator's coordinates (less the offsets) and the speeds.
        """
        offset = self.run.offset
        self.pre.setup(t, x if offset is None else x + offset[: len(x)], xd)

    def solve(self, r1, r2, gamma):
        """As the system preconditioner's ``solve`` (increments do not depend on the offset).

        Parameters
        ----------
        r1, r2 : ndarray, shape (nq,) and (n,)
            The right-hand side's coordinate and speed halves.
        gamma : float
            The integrator's coefficient (step size times its method's
            constant).

        Returns
        -------
        z1, z2 : ndarray, shape (nq,) and (n,)
            ``z`` with ``(I - gamma J) z ~ r``, in two halves.
        """
        return self.pre.solve(r1, r2, gamma)

    def solve_accelerations(self, r, c1, c2):
        """As the system preconditioner's ``solve_accelerations`` (generalized-alpha's Newton matrix).

        Parameters
        ----------
        r : ndarray, shape (n,)
            Right-hand side (accelerations).
        c1, c2 : float
            The coefficients of ``Jv`` and ``Jx``.

        Returns
        -------
        ndarray, shape (n,)
            ``z`` with ``(I - c1 Jv - c2 Jx) z ~ r``.
        """
        return self.pre.solve_accelerations(r, c1, c2)
