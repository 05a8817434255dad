"""The reduced solve of a System: accelerations from ``A xdd = f`` on ``psi xd = b`` (eqs. 36-39)."""

from __future__ import annotations

import numpy as np

from .._lazy import LazyModule
from ..forces import Loads
from ..complements import SVDComplement
from ..complements.base import PSI_ZERO
from .._validate import LARGEST
from ..errors import AssemblyError
from ..kernels.reduced import svd_reduced_solve

#: LAPACK through scipy, imported by the first Cholesky factorization of a mass matrix outside the kernels
_lapack = LazyModule("scipy.linalg.lapack")


def _plain(a) -> np.ndarray:
    """``a`` as a writable C-contiguous float array (a copy only where needed)."""
    a = np.asarray(a, dtype=float)
    if a.flags.c_contiguous and a.flags.writeable:
        return a
    return np.array(a, dtype=float, order="C")


class ReducedSolve:
    """Solving the reduced equations for the accelerations (mixed into :class:`~flexmb.system.System`)."""

    def _raise_non_finite(self, t, x, xd, A, f):
        err = AssemblyError(f"at t = {t:.9g} s: {self._diagnose(t, x, xd, A, f)}")
        err.t = t
        raise err

    def _overflow(self, t, x, xd):
        """The message of a state past ``_validate.LARGEST`` (its coordinate and the loudest force), or None.

        Past it, the products in the equations (``m r^2``, ``k x``)
        overflow, and what fails next (a mass matrix that looks singular)
        is a consequence, not the cause.
        """
        y = np.abs(self.layout.join(x, xd))
        i = int(np.argmax(np.where(np.isnan(y), np.inf, y)))
        if not y[i] > LARGEST:
            return None
        nq = self.layout.nq
        what = f"coordinate {self.coordinate_names[i]!r} = {x[i]:.3g}" if i < nq else \
            f"the speed of {self.speed_names[i - nq]!r} = {xd[i - nq]:.3g}"
        msg = (f"at t = {t:.9g} s: the state overflowed: {what} (beyond {LARGEST:.3g}, where products in the "
               "equations overflow)")
        loudest = self._loudest_force(t, x, xd)
        if loudest is not None:
            msg += f"; force element {loudest.name!r} ({type(loudest).__name__}) gives the largest load"
        return msg + " - the motion grows without bound (an unstable force, or a negative stiffness?)"

    def _loudest_force(self, t, x, xd):
        """The force element whose loads are largest at a state (non-finite counts as largest), or None if none."""
        try:
            kin = self._kinematics(t, x, xd)
        except Exception:  # the kinematics themselves may overflow
            return None
        best, size = None, 0.0
        for cls, elements in self.forces.groups:
            for e in elements:
                loads = Loads(kin)
                try:
                    cls.apply_all([e], kin, loads)
                except Exception:
                    continue
                with np.errstate(invalid="ignore"):
                    m = np.max(np.abs(np.concatenate([loads.force.ravel(), loads.torque.ravel(),
                                                      loads.generalized])), initial=0.0)
                m = np.inf if np.isnan(m) else m
                if m > size:
                    best, size = e, m
        return best

    def _diagnose(self, t, x, xd, A, f):
        """Name what made the equations non-finite."""
        overflow = self._overflow(t, x, xd)
        if overflow is not None:
            return overflow.split(": ", 1)[1]
        kin = self._kinematics(t, x, xd)

        for cls, elements in self.forces.groups:
            for e in elements:
                loads = Loads(kin)
                cls.apply_all([e], kin, loads)
                if not (np.all(np.isfinite(loads.force)) and np.all(np.isfinite(loads.torque))
                        and np.all(np.isfinite(loads.generalized))):
                    return f"force element {e.name!r} ({type(e).__name__}) gave a non-finite load"
        if A is None or not np.all(np.isfinite(A)):
            return "the mass matrix is not finite (non-finite coordinates?)"
        return "the force array is not finite (non-finite speeds?)"

    def _solve(self, t, A, f, psi, gamma, multipliers=False):
        """xdd from the reduced equations; with ``multipliers``, ``(xdd, lambda)`` (the reactions)."""
        if self._svd_kernel:
            # the default strategy: decomposition, particular solution and reduced solve in one call
            self.n_complements += psi.shape[0] > 0
            xdd, lam, status = svd_reduced_solve(
                A, f, _plain(psi).reshape(psi.shape[0], self.n_speeds), _plain(gamma), self.strategy.tol, PSI_ZERO,
                -1 if self._rank_limit is None else self._rank_limit, self.singular_window())
            if status == 2:
                raise AssemblyError("constraint Jacobian psi is not finite")
            if status == 1:
                raise AssemblyError(
                    f"reduced mass matrix T^T A T is not positive definite at t = {t:.6g} s "
                    "(a body without mass or inertia on a freedom?)"
                )
            return (xdd, lam) if multipliers else xdd
        if psi.shape[0] == 0:  # an open tree: T = I, no complement needed
            xdd = self._cholesky_solve(t, A, f)
            return (xdd, np.zeros(0)) if multipliers else xdd
        c = self.complement(psi)
        T = c.T
        xdd = xdd_p = self._particular(c, gamma)
        if T.shape[1]:
            M = T.T @ A @ T
            rhs = T.T @ (f - A @ xdd_p)
            xdd = T @ self._cholesky_solve(t, M, rhs) + xdd_p
        if multipliers:
            return xdd, c.multipliers(A @ xdd - f)
        return xdd

    @property
    def _svd_kernel(self) -> bool:
        """Whether the reduced equations are solved by the compiled SVD route (the default strategy)."""
        return type(self.strategy) is SVDComplement and not self.strategy.singular_rtol

    def _particular(self, c, rhs):
        """``psi^+ rhs`` with the strategy's treatment of singular positions.

        Singular values of psi below ``singular_window * sigma_ref`` are
        filtered (:meth:`Complement.particular`); with the opt-in
        ``singular_rtol``, those below ``singular_rtol`` times the largest
        are left out. Near a singular position (a flattened parallelogram)
        ``gamma / sigma`` would otherwise throw the motion onto the other
        branch (docs/stability.md, section 2).
        """
        srtol = getattr(self.strategy, "singular_rtol", 0.0)
        if srtol and c.rank:
            c = c.truncated(int(np.sum(c.scale > srtol * np.max(c.scale))))
        if not c.rank:
            return np.zeros(self.n_speeds)
        return c.particular(rhs, window=self.singular_window())

    def singular_window(self) -> float:
        """Singular values of psi below this are filtered in particular solutions (0: none).

        Returns
        -------
        float
            ``strategy.singular_window * sigma_ref`` (see
            :class:`~flexmb.complements.ComplementStrategy`).
        """
        if not self.sigma_ref:
            return 0.0
        return getattr(self.strategy, "singular_window", 0.0) * self.sigma_ref

    @staticmethod
    def _cholesky_solve(t, M, rhs):
        """Solve ``M z = rhs`` for the symmetric positive definite (reduced) mass matrix."""
        # LAPACK potrf/potrs directly: scipy's cho_factor/cho_solve wrappers
        # cost more than the factorization itself at a few dozen coordinates
        if M.shape[0] == 0:
            return np.zeros_like(rhs)
        c, info = _lapack.dpotrf(M, lower=False, clean=False)
        if info == 0:
            z, info = _lapack.dpotrs(c, rhs, lower=False)
        if info != 0:
            raise AssemblyError(
                f"reduced mass matrix T^T A T is not positive definite at t = {t:.6g} s "
                "(a body without mass or inertia on a freedom?)"
            )
        return z

