"""Projection of a state onto the constraints (eqs. 28-29): positions by Newton, speeds mass-orthogonally."""

from __future__ import annotations

import numpy as np

from ..assembly import mass_matrix
from ..complements.base import PSI_ZERO
from ..errors import AssemblyError, ModelError
from ..kernels.reduced import svd_reduced_solve
from .._lazy import LazyModule
from .solve import _plain

#: the loops' projection kernels, imported at a model with loops' first projection
_projection = LazyModule("flexmb.kernels.loop_projection")


class Projection:
    """Projection onto the constraint manifold (mixed into :class:`~flexmb.system.System`)."""

    def _min_norm(self, a, rhs, rcond=1e-12):
        """Minimum-norm least-squares solution of ``a x = rhs``, rank capped at ``rank_limit``.

        Like ``np.linalg.lstsq(a, rhs, rcond)``, except that singular values
        beyond ``rank_limit`` count as zero: near (not on) the constraint
        manifold a redundant row would otherwise be inverted through a
        singular value of the size of the violation.
        """
        U, s, Vt = np.linalg.svd(a, full_matrices=False)
        r = int(np.sum(s > rcond * s[0])) if s.size else 0
        if self.rank_limit is not None:
            r = min(r, self.rank_limit)
        return Vt[:r].T @ ((U[:, :r].T @ rhs) / s[:r])

    def project(self, t, x, xd, tol=1e-12, max_iter=50, fixed=None, max_step=0.5, speeds="min-norm"):
        """Project a state onto the constraints (Newton, minimum-norm steps).

        The positions are moved onto the position rows (``phi = 0``) only;
        the speeds onto all rows, velocity rows (``B xd = b``) included.

        Parameters
        ----------
        t : float
            Time, s.
        x : ndarray, shape (nq,)
            Coordinates q to correct (moved along the speeds,
            :meth:`~flexmb.state_layout.StateLayout.displace`).
        xd : ndarray, shape (n,)
            Speeds u to correct.
        tol : float
            Target for max ``|phi|`` (m or rad).
        max_iter : int
            Newton iterations allowed.
        fixed : ndarray of bool, shape (n,), optional
            Speeds (and the coordinates they move) to leave unchanged.
        max_step : float
            Largest change of any coordinate in one Newton step (rad or m),
            so that rough guesses do not jump to a far branch.
        speeds : {'min-norm', 'mass'}
            How the speeds are corrected: the minimum-norm correction of the
            free speeds (default), or the mass-orthogonal projection onto
            ``psi xd = b`` (``fixed`` must be None): the correction is
            A-orthogonal to the consistent speeds, so it changes the kinetic
            energy only to second order (Bayo & Ledesma's mass-orthogonal
            projection), also near a singular position where the minimum-norm
            correction is a large multiple of the residual.

        Returns
        -------
        x, xd : ndarray
            Corrected state with ``phi = 0`` and ``psi xd = b``.

        Raises
        ------
        AssemblyError
            If the constraints cannot be closed; the message names the
            constraint rows with the largest residual.
        """
        t, x, xd = self._state("System.project", t, x=x, xd=xd)
        if fixed is not None:
            fixed = np.asarray(fixed)
            if fixed.shape != (self.n_speeds,) or fixed.dtype != bool:
                raise ModelError(f"System.project: fixed must be a boolean array of shape ({self.n_speeds},), "
                                 f"got {fixed.dtype} of shape {fixed.shape}")
        return self._project(t, x, xd, tol, max_iter, fixed, max_step, speeds)

    def _project(self, t, x, xd, tol=1e-12, max_iter=50, fixed=None, max_step=0.5, speeds="min-norm"):
        """:meth:`project` of a checked state (the run's own states: outputs, drifted states; the inputs not changed)."""
        x, xd = x.copy(), xd.copy()
        if self.n_constraints == 0:
            return x, xd
        free = np.ones(self.n_speeds, bool) if fixed is None else ~fixed
        if self._loop_kernel:  # psi never dense: O(n m) steps (kernels/loop_projection.py)
            return self._project_loops(t, x, xd, tol, max_iter, free, max_step, speeds, fixed is None)
        position_rows = self.constraints.position_rows  # velocity rows have no position form: left out here
        for _ in range(max_iter):
            rows = self._rows(t, x, xd)
            if np.max(np.abs(rows.phi)) <= tol:
                break
            held = position_rows(rows)
            step = self._min_norm(held.psi[:, free], held.phi)
            big = np.max(np.abs(step))
            du = np.zeros(self.n_speeds)
            du[free] = -step * min(1.0, max_step / big) if big > 0 else -step
            x = self.layout.displace(x, du)
        else:
            self._not_closed(t, x, xd, max_iter)
        psi, b = rows.psi, rows.b  # those of the converged positions: the loop's last evaluation
        if speeds == "mass" and fixed is None:
            return x, self._mass_orthogonal_speeds(self._kinematics(t, x, xd), psi, b, xd)
        step = self._min_norm(psi[:, free], psi @ xd - b)
        xd[free] -= step
        return x, xd

    def _not_closed(self, t, x, xd, max_iter):
        """Raise the AssemblyError of a projection whose Newton steps did not close the loops."""
        phi = self.constraints.evaluate(self._kinematics(t, x, xd), level=0).phi
        worst = np.argsort(-np.abs(phi))[:3]
        rows = ", ".join(f"{self.constraints.labels[i]} = {phi[i]:.3g}" for i in worst)
        raise AssemblyError(
            f"the constraints cannot be closed at t = {t:.6g} s: residual {np.max(np.abs(phi)):.3g} "
            f"after {max_iter} Newton steps (largest: {rows})"
        )

    def _project_loops(self, t, x, xd, tol, max_iter, free, max_step, speeds, unfixed):
        """:meth:`project` by the loop kernels: the same minimum-norm steps, psi kept sparse, O(n m) each."""
        packed, layout = self._packed, self._loop_layout
        limit = -1 if self.rank_limit is None else self.rank_limit
        drivers, cols = self.constraints.drivers, self.constraints.driver_cols
        free = np.ascontiguousarray(free)
        zeros = np.zeros(self.n_speeds)
        for _ in range(max_iter):
            phi = np.concatenate([_projection.loop_phi(packed, layout, x),
                                  [x[c] - d.position(t) for d, c in zip(drivers, cols)]])
            if np.max(np.abs(phi)) <= tol:
                break
            step, _ = _projection.loop_min_norm(packed, layout, x, zeros, -phi, free, self._loop_tol, limit)
            big = np.max(np.abs(step))
            x = self.layout.displace(x, -step * min(1.0, max_step / big) if big > 0 else -step)
        else:
            self._not_closed(t, x, xd, max_iter)
        b = np.zeros(self.n_constraints)
        b[self.n_constraints - len(drivers):] = [d.velocity(t) for d in drivers]
        if speeds == "mass" and unfixed:
            v = self._loop_speeds(t, x, xd, b)
            if v is not None:
                return x, v
        step, _ = _projection.loop_min_norm(packed, layout, x, _plain(xd), b, free, self._loop_tol, limit)
        return x, xd - step

    def _mass_orthogonal_speeds(self, kin, psi, b, xd, c=None):
        """``xd_p + T (T^T A T)^-1 T^T A (xd - xd_p)`` with ``xd_p = psi^+ b``: the consistent speeds
        nearest to ``xd`` in the kinetic-energy metric (``c``: the complement to use)."""
        if c is None and self._loop_kernel:
            v = self._loop_speeds(kin.t, kin.x, xd, b)
            if v is not None:
                return v
        if c is None and self._svd_kernel:  # the compiled reduced solve with f = A xd, gamma = b
            A = mass_matrix(kin)
            v, _, status = svd_reduced_solve(A, A @ xd, _plain(psi).reshape(psi.shape[0], self.n_speeds),
                                             _plain(b), self.strategy.tol, PSI_ZERO,
                                             -1 if self._rank_limit is None else self._rank_limit,
                                             self.singular_window())
            if status == 0:
                self.n_complements += 1
                return v
        c = self.complement(psi) if c is None else c
        vp = self._particular(c, b)
        T = c.T
        if T.shape[1] == 0:
            return vp
        A = mass_matrix(kin)
        return vp + T @ self._cholesky_solve(kin.t, T.T @ A @ T, T.T @ (A @ (xd - vp)))

