"""The orthogonal complement strategy interface (eqs. 30-39)."""

from __future__ import annotations

import numpy as np
from attrs import define, field, frozen
from scipy.linalg import solve_triangular

from ..errors import AssemblyError, ModelError

__all__ = ["Complement", "ComplementStrategy"]


@define
class Complement:
    """An orthogonal complement of psi and a particular solver.

    Built by :meth:`ComplementStrategy.complement`; the parameters are also
    its attributes.

    Parameters
    ----------
    T : ndarray, shape (n, p)
        Orthonormal basis of the null space of psi: ``psi T = 0``,
        ``T^T T = I``.
    rank : int
        Numerical rank of psi.
    basis : ndarray, shape (n, rank)
        Orthonormal basis of the row space of psi.
    scale : ndarray, shape (rank,)
        Singular values of psi on ``basis`` (``psi basis = U diag(scale)``).
    left : ndarray, shape (m, rank)
        Left singular vectors ``U`` (an orthonormal basis of the range of psi).
    factor : ndarray, shape (rank, rank), optional
        Upper-triangular K with ``psi basis = left K``, for strategies that
        are not an SVD (``qr``: a complete orthogonal decomposition); then
        ``scale`` holds ``|diag(K)|``. None (the default) means
        ``K = diag(scale)``.
    """

    T: np.ndarray
    rank: int
    basis: np.ndarray
    scale: np.ndarray
    left: np.ndarray
    factor: np.ndarray | None = None

    @property
    def p(self) -> int:
        """Number of independent speeds."""
        return self.T.shape[1]

    def particular(self, rhs: np.ndarray) -> np.ndarray:
        """Minimum-norm solution x of ``psi x = rhs`` (least squares if inconsistent).

        Parameters
        ----------
        rhs : ndarray, shape (m,)
            Right-hand side (b for speeds, gamma for accelerations).

        Returns
        -------
        ndarray, shape (n,)
            ``x = psi^+ rhs``.
        """
        if self.factor is not None:  # psi = left K basis^T: x = basis K^-1 left^T rhs
            return self.basis @ solve_triangular(self.factor, self.left.T @ rhs, check_finite=False)
        return self.basis @ ((self.left.T @ rhs) / self.scale)

    def truncated(self, rank: int) -> "Complement":
        """The complement of psi with its rank capped at ``rank``.

        The row-space directions with the smallest singular values beyond
        ``rank`` are moved into T. Off the constraint manifold (an
        integrator's stage state) redundant rows (Bricard linkage) look
        independent, with tiny singular values of the order of the
        constraint violation; counting them would lock the mechanism and
        divide the acceleration terms by them.

        Parameters
        ----------
        rank : int
            Largest rank to keep (>= 0).

        Returns
        -------
        Complement
            Itself if ``self.rank <= rank``, else the truncated complement.
        """
        if self.rank <= rank:
            return self
        order = np.argsort(-self.scale, kind="stable")
        keep, drop = order[:rank], order[rank:]
        T = np.hstack([self.T, self.basis[:, drop]])
        return Complement(T, rank, self.basis[:, keep], self.scale[keep], self.left[:, keep])


@frozen(eq=False)
class ComplementStrategy:
    """Base class of ways to build the orthogonal complement T of psi.

    Subclasses must:

    1. implement ``_complement_impl(psi)`` returning a :class:`Complement`
       (T with orthonormal columns spanning the null space of psi, the
       rank, and the row-space data for particular solutions);
    2. treat a rank-deficient psi (redundant constraints) correctly, using
       a zero tolerance relative to the largest eigen/singular value;
    3. set a class attribute ``name``.

    The public :meth:`complement` handles the empty case and checks.

    Parameters
    ----------
    rtol : float, optional
        Relative zero tolerance; default per strategy.
    singular_rtol : float
        Singular values of psi below ``singular_rtol`` times the largest are
        left out of the particular solution ``xdd_p = psi^+ gamma`` (the
        number of freedoms p is unchanged). Off by default (0). Set it (e.g.
        1e-2) for mechanisms that pass through singular positions, such as
        a parallelogram four-bar at its flattened configurations: near such
        a point a tiny constraint violation makes ``gamma / sigma`` throw
        the motion onto the other branch (or back); without those terms it
        moves on by its inertia and the projection corrects the small error.
    """

    name = "base"
    default_rtol = 1e-10

    rtol: float | None = None
    singular_rtol: float = field(default=0.0, kw_only=True)

    @singular_rtol.validator
    def _check_singular_rtol(self, attribute, value):
        if not (isinstance(value, (int, float)) and 0.0 <= value < 1.0):
            raise ModelError(f"{type(self).__name__}: singular_rtol must be in [0, 1), got {value!r}")

    @property
    def tol(self) -> float:
        """The relative zero tolerance in use."""
        return self.default_rtol if self.rtol is None else self.rtol

    def complement(self, psi: np.ndarray) -> Complement:
        """Return the orthogonal complement of ``psi``.

        Parameters
        ----------
        psi : ndarray, shape (m, n)
            Constraint Jacobian (eq. 29).

        Returns
        -------
        Complement
            T (n x p) with ``psi T = 0`` and ``T^T T = I``, p = n - rank(psi).

        Raises
        ------
        AssemblyError
            If psi contains non-finite entries.
        """
        m, n = psi.shape
        if m == 0 or not np.any(psi):
            return Complement(np.eye(n), 0, np.zeros((n, 0)), np.zeros(0), np.zeros((m, 0)))
        if not np.all(np.isfinite(psi)):
            raise AssemblyError("constraint Jacobian psi is not finite")
        return self._complement_impl(psi)

    def _complement_impl(self, psi: np.ndarray) -> Complement:
        raise NotImplementedError
