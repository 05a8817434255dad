"""The fastest rates of a System's linearised motion (method 'auto', the stiffness warning)."""

from __future__ import annotations

import numpy as np

from .tangent import NewtonPreconditioner
from ..kernels.articulated import articulated_accelerations
from .._lazy import LazyModule
from .solve import _plain

#: the loops' Newton kernels, imported at a model with loops' first use
_loops = LazyModule("flexmb.kernels.loops")


#: open trees (and loops closed by the articulated strategy) with more coordinates estimate their fastest
#: rates (method 'auto', the stiffness warning) by Arnoldi iteration with O(n) products instead of dense
#: eigenvalues
DENSE_RATES_MAX = 200


class Rates:
    """The highest frequency and fastest rate at a state (mixed into :class:`~flexmb.system.System`)."""

    def highest_frequency(self, t, x, xd) -> float:
        """Estimate of the highest natural angular frequency from the coordinate springs, rad/s.

        ``sqrt(max eig(P K))`` (see :meth:`state_jacobian`); 0 if no element
        puts a stiffness on coordinates.

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.

        Returns
        -------
        float
            Angular frequency, rad/s.
        """
        t, x, xd = self._state("System.highest_frequency", t, x=x, xd=xd)
        return self._rates(t, x, xd)[0]

    def fastest_rate(self, t, x, xd) -> float:
        """The fastest time scale of the coordinate springs and dampers, rad/s.

        The larger of :meth:`highest_frequency` and the highest damping rate
        ``max |eig(P C)|``: an overdamped mode decays at about that rate, and
        limits the step of an explicit method just as a frequency does. Used
        by ``method='auto'`` and the :class:`~flexmb.StiffnessWarning`.

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.

        Returns
        -------
        float
            Rate, rad/s (1/s for a damping rate).
        """
        t, x, xd = self._state("System.fastest_rate", t, x=x, xd=xd)
        return max(self._rates(t, x, xd))

    def stability_rate(self, t, x, xd) -> float:
        """The largest ``|eigenvalue|`` of the linearised motion, loads' geometric stiffness included, 1/s.

        An explicit method is stable only for steps ``h`` with ``h |lambda|``
        below about 3 for every eigenvalue of the state Jacobian: the
        springs and dampers on coordinates (:meth:`fastest_rate`) and the
        stiffness of the loads (gravity on a pendulum) alike. Dense, for
        models of at most ``DENSE_RATES_MAX`` coordinates; larger ones give
        :meth:`fastest_rate`.

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.

        Returns
        -------
        float
            Rate, 1/s (inf if the Jacobian is not finite).
        """
        t, x, xd = self._state("System.stability_rate", t, x=x, xd=xd)
        if self.n_speeds > DENSE_RATES_MAX:
            return self.fastest_rate(t, x, xd)
        J = self._jacobian(t, x, xd, geometric=True, always=True)
        return float(np.max(np.abs(np.linalg.eigvals(J)), initial=0.0))

    def _rates(self, t, x, xd) -> tuple[float, float]:
        # the last state's rates are kept: 'auto', the stiffness warning and `flexmb info` ask for them in turn
        key = (float(t), np.asarray(x, dtype=float).tobytes(), np.asarray(xd, dtype=float).tobytes(),
               id(self.strategy))
        last = getattr(self, "_last_rates", None)
        if last is not None and last[0] == key:
            return last[1]
        rates = self._rates_at(t, x, xd)
        self._last_rates = (key, rates)
        return rates

    def _rates_at(self, t, x, xd) -> tuple[float, float]:
        if (self.articulated or self._loop_kernel) and self.n_speeds > DENSE_RATES_MAX:
            rates = self._rates_iterative(t, x, xd)
            if rates is not None:
                return rates
        Y = self._acceleration_tangent(t, x, xd, geometric=False)  # per displacement and per speed
        if Y is None:
            return 0.0, 0.0
        n = self.n_speeds
        if n > DENSE_RATES_MAX:  # the largest eigenvalues alone, by Arnoldi iteration: O(n^2) products, not O(n^3)
            rates = (float(np.sqrt(_largest(-Y[:, :n]))), _largest(-Y[:, n:]))
        else:
            stiff = np.linalg.eigvals(-Y[:, :n])
            damp = np.linalg.eigvals(-Y[:, n:])
            rates = (float(np.sqrt(max(np.max(stiff.real), 0.0))), float(np.max(np.abs(damp))))
        return tuple(r if np.isfinite(r) else np.inf for r in rates)

    def _rates_iterative(self, t, x, xd):
        """The largest eigenvalues of ``P K`` and ``P C`` by Arnoldi iteration, O(n) per product (O(n m) with loops).

        ``P = A^-1`` for open trees, ``T (T^T A T)^-1 T^T`` for loops closed
        by the articulated strategy (:func:`~flexmb.kernels.loops.loop_newton_solve`,
        T never formed). For models whose coordinate springs and dampers are
        diagonal (None if a velocity-dependent element, such as friction,
        couples coordinates: the dense path then applies).
        """
        kin = self._kinematics(t, x, xd)
        if any(cls.velocity_tangent_all(el, kin) is not None or cls.pair_tangent_all(el, kin) is not None
               for cls, el in self.forces.groups):
            return None
        from scipy.sparse.linalg import ArpackNoConvergence, LinearOperator, eigs

        pre = NewtonPreconditioner(self)
        pre.setup(t, x, xd)
        topo, n = self.topology, self.n_speeds
        spatial, Sw, Sv, r = pre._state
        zeros = np.zeros((topo.n_bodies + 1, 3))
        limit = -1 if self.rank_limit is None else self.rank_limit
        factored = _loops.loop_newton_factor(self._packed, self._loop_layout, _plain(np.array(x, dtype=float)),
                                             self._no_armature, self._loop_tol, limit) if self._loop_kernel else None

        def largest(diag):
            if not np.any(diag):
                return 0.0

            def apply(v):
                if self._loop_kernel:
                    z, *_ = _loops.loop_newton_solve(factored, self._packed, self._loop_layout,
                                                     _plain(diag * np.ravel(v)))
                    return z
                z, _ = articulated_accelerations(topo.parent, topo.coord_start, spatial, Sw, Sv, r, zeros, zeros,
                                                 diag * np.ravel(v), self._no_armature)
                return z

            op = LinearOperator((n, n), matvec=apply, dtype=float)
            try:
                return float(np.max(np.abs(eigs(op, k=1, which="LM", tol=1e-3, return_eigenvectors=False))))
            except ArpackNoConvergence as exc:
                return float(np.max(np.abs(exc.eigenvalues))) if len(exc.eigenvalues) else np.inf

        rates = (float(np.sqrt(largest(pre.stiffness))), largest(pre.damping))
        return tuple(v if np.isfinite(v) else np.inf for v in rates)



def _largest(M: np.ndarray) -> float:
    """The largest ``|eigenvalue|`` of a dense square matrix by Arnoldi iteration (to 1e-3; inf if not finite)."""
    from scipy.sparse.linalg import ArpackNoConvergence, eigs

    if not np.all(np.isfinite(M)):
        return np.inf
    if not np.any(M):
        return 0.0
    try:
        return float(np.max(np.abs(eigs(M, k=1, which="LM", tol=1e-3, return_eigenvectors=False))))
    except ArpackNoConvergence as exc:
        return float(np.max(np.abs(exc.eigenvalues))) if len(exc.eigenvalues) else np.inf
