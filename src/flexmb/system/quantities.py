"""Quantities of a System at a state: reactions, flexible shapes, energy, degrees of freedom."""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ..flexible import FlexibleBody
from .._lazy import LazyModule
from .solve import _plain

#: the compiled equations (a model with loops' residuals), imported at first use
_equations = LazyModule("flexmb.kernels.equations")


class StateQuantities:
    """Reactions, shapes, energy and degrees of freedom at a state (mixed into :class:`~flexmb.system.System`)."""

    def reactions(self, t, x, xd, xdd=None):
        """Constraint reactions (Lagrange multipliers) at a state.

        ``A xdd = f + psi^T lambda``; lambda is the minimum-norm solution
        (unique for independent rows). For loops closed by the articulated
        strategy, in O(n m) with A and psi never formed
        (:func:`~flexmb.kernels.loop_statics.loop_reactions`; redundant rows
        then take the dense minimum-norm step, as the right-hand side's
        reactions do). A driver's row gives the torque or
        force it supplies; a cut joint's point rows give the force it
        transmits to its parent body (inertial axes, N).

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.
        xdd : ndarray, shape (n,), optional
            Accelerations at the state (default: solved here).

        Returns
        -------
        ndarray, shape (m,)
            One multiplier per constraint row, labelled by
            ``self.constraints.labels``.
        """
        if xdd is None:
            t, x, xd = self._state("System.reactions", t, x=x, xd=xd)
        else:
            t, x, xd, xdd = self._state("System.reactions", t, x=x, xd=xd, xdd=xdd)
        if self._loop_kernel:  # A, psi never formed: O(n m) (kernels/loop_statics.py)
            return self._loop_reactions(t, x, xd, xdd)
        eq = self._equations(t, x, xd)
        A, f, psi, gamma = eq.A, eq.f, eq.psi, eq.gamma
        if xdd is None:
            xdd = self._solve(t, A, f, psi, gamma)
        if psi.shape[0] == 0:
            return np.zeros(0)
        lam, *_ = np.linalg.lstsq(psi.T, A @ xdd - f, rcond=None)
        return lam

    def shape(self, body, x, t: float = 0.0) -> np.ndarray:
        """Deformed centre line of a flexible body at one configuration.

        Parameters
        ----------
        body : FlexibleBody or str
            A flexible body of the model, or its name.
        x : ndarray, shape (n,)
            Coordinates.
        t : float
            Time, s.

        Returns
        -------
        ndarray, shape (n_segments + 1, 3)
            Root, segment joints and tip, inertial, m.
        """
        body = self.model.element(body, FlexibleBody)
        if body not in self.topology.flexible:
            raise ModelError(f"{getattr(body, 'name', body)!r} is not a flexible body of the model")
        t, x = self._state("System.shape", t, x=x)
        kin = self._kinematics(t, x, np.zeros_like(x))
        rows = np.array([self.topology.index[s] for s in self.topology.flexible[body][1]])
        tip = kin.origin[rows[-1]] + kin.R[rows[-1], :, 0] * body.segment_length
        return np.vstack([kin.origin[rows], tip])

    def energy(self, t, x, xd) -> tuple[float, float]:
        """Kinetic and potential energy at a state.

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.

        Returns
        -------
        kinetic, potential : float
            Energies, J.
        """
        t, x, xd = self._state("System.energy", t, x=x, xd=xd)
        kin = self._kinematics(t, x, xd)
        return kin.kinetic_energy(), self.forces.potential_energy(kin)

    def dof(self, t=0.0, x=None) -> int:
        """Degrees of freedom p = n - rank(psi) at a configuration.

        Parameters
        ----------
        t : float
            Time, s.
        x : ndarray, shape (nq,), optional
            Coordinates (default: the reference configuration, zeros).

        Returns
        -------
        int
            Number of independent speeds p.
        """
        t, x = self._state("System.dof", t, x=self.layout.reference() if x is None else x)
        if not self.n_constraints:
            return self.n_speeds
        if self._loop_kernel:  # the rank as the loop kernel sees it, psi not formed
            return self.n_speeds - self._loop_calibration(t, _plain(np.asarray(x, dtype=float)),
                                                          np.zeros(self.n_speeds))[0]
        psi = self.constraints.evaluate(self._kinematics(t, x, np.zeros(self.n_speeds)), level=1).psi
        return self.strategy.complement(psi).p

    def constraint_residuals(self, t, x, xd) -> tuple[float, float]:
        """The largest position and velocity residuals of the constraints, ``max |phi|`` and ``max |psi xd - b|``.

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.

        Returns
        -------
        position, velocity : float
            The residuals (eqs. 28-29; 0 without constraints).
        """
        t, x, xd = self._state("System.constraint_residuals", t, x=x, xd=xd)
        return self._constraint_residuals(t, x, xd)

    def _constraint_residuals(self, t, x, xd) -> tuple[float, float]:
        """:meth:`constraint_residuals` at a checked state."""
        if self._packed is None:
            rows = self.constraints.evaluate(self._kinematics(t, x, xd), level=1)
            if not rows.phi.size:
                return 0.0, 0.0
            return float(np.max(np.abs(rows.phi))), float(np.max(np.abs(rows.psi @ xd - rows.b)))
        position, velocity = _equations.tree_equations(self._packed, self.layout.join(x, xd), self.n_coords,
                                                       _equations.RESIDUALS, self._no_powers, *self._no_loads)[2]
        if self.constraints.elements:
            rows = self.constraints.element_rows(self._kinematics(t, x, xd))
            position = max(position, float(np.max(np.abs(rows.phi), initial=0.0)))
            velocity = max(velocity, float(np.max(np.abs(rows.psi @ xd - rows.b), initial=0.0)))
        for d, c in zip(self.constraints.drivers, self.constraints.driver_cols):
            position = max(position, abs(x[c] - d.position(t)))
            velocity = max(velocity, abs(xd[c] - d.velocity(t)))
        return float(position), float(velocity)

    def constraint_residual(self, t, x, xd) -> float:
        """The largest constraint residual at a state: ``max(|phi|, |psi xd - b|)`` (eqs. 28-29).

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.

        Returns
        -------
        float
            The residual (m or rad, and per second); 0 without constraints.
        """
        t, x, xd = self._state("System.constraint_residual", t, x=x, xd=xd)
        return max(self._constraint_residuals(t, x, xd))
