"""The orthogonal complement strategy interface (eqs. 30-39)."""

from __future__ import annotations

import numpy as np
from attrs import define, field, frozen

from .._lazy import LazyModule
from ..errors import AssemblyError, ModelError
from ..kernels.reduced import filtered

__all__ = ["Complement", "ComplementStrategy"]

#: scipy.linalg, imported by the first least-squares solve on a complete orthogonal decomposition
_linalg = LazyModule("scipy.linalg")

#: Entries of psi at or below this (m per coordinate unit, or dimensionless)
#: are round-off: a psi made only of them constrains nothing (e.g. a cut
#: joint between two bodies welded together), rank 0. A relative rank test
#: alone would count its noise (singular values ~1e-16) as constraints.
PSI_ZERO = 1e-12


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

    def particular(self, rhs: np.ndarray, window: float = 0.0) -> np.ndarray:
        """Minimum-norm solution x of ``psi x = rhs`` (least squares if inconsistent).

        Parameters
        ----------
        rhs : ndarray, shape (m,)
            Right-hand side (b for speeds, gamma for accelerations).
        window : float
            Singular values ``s`` of psi below ``window`` are inverted as
            ``s / (s^2 + w^2 (1 - s^2/w^2)^2)`` instead of ``1/s`` (a
            Tikhonov filter that fades in below the window: exact for
            ``s >= w``, continuous with its slope at ``s = w``, and at most
            about ``1/w``). It keeps a constraint violation from being divided
            by a collapsing singular value near a singular position (see
            :attr:`ComplementStrategy.singular_window`). 0 (default): none.

        Returns
        -------
        ndarray, shape (n,)
            ``x = psi^+ rhs``.
        """
        if self.factor is not None:  # psi = left K basis^T: x = basis K^-1 left^T rhs
            # |diag K| of the pivoted QR bounds the smallest singular value from above and
            # reveals it within a modest factor: an SVD of K only where one may be in the window
            if window > 0.0 and self.scale.size and np.min(self.scale) < 10.0 * window:
                U, s, Vt = np.linalg.svd(self.factor)
                return self.basis @ (Vt.T @ _filtered(s, U.T @ (self.left.T @ rhs), window))
            return self.basis @ _linalg.solve_triangular(self.factor, self.left.T @ rhs, check_finite=False)
        if window > 0.0:
            return self.basis @ _filtered(self.scale, self.left.T @ rhs, window)
        return self.basis @ ((self.left.T @ rhs) / self.scale)

    def multipliers(self, rhs: np.ndarray) -> np.ndarray:
        """Minimum-norm solution lambda of ``psi^T lambda = rhs`` (least squares), on psi's kept rank.

        The constraint reactions (Lagrange multipliers) of ``A xdd = f +
        psi^T lambda`` are ``multipliers(A xdd - f)``: from the
        factorization already made, no second least-squares solve.

        Parameters
        ----------
        rhs : ndarray, shape (n,)
            Right-hand side, e.g. ``A xdd - f``.

        Returns
        -------
        ndarray, shape (m,)
            lambda.
        """
        g = self.basis.T @ rhs
        if self.factor is not None:  # psi^T = basis K^T left^T
            return self.left @ _linalg.solve_triangular(self.factor, g, trans="T", check_finite=False)
        return self.left @ (g / self.scale)

    def singular_values(self) -> np.ndarray:
        """Singular values of psi on its row space (``scale``, or those of ``factor``), descending.

        Returns
        -------
        ndarray, shape (rank,)
            The singular values.
        """
        if self.factor is not None:
            return np.linalg.svd(self.factor, compute_uv=False)
        return np.sort(self.scale)[::-1]

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


def _filtered(s, g, w):
    """``g / s`` with singular values below ``w`` regularised (:meth:`Complement.particular`)."""
    return filtered(np.ascontiguousarray(s, dtype=float), np.ascontiguousarray(g, dtype=float), float(w))


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
    rank_tol : float, optional
        Relative zero tolerance; default per strategy.
    singular_window : float
        Default treatment of singular positions (e.g. a parallelogram
        four-bar flattened, where psi loses rank and the anti-parallelogram
        branch crosses). ``System.sigma_ref`` is the smallest nonzero
        singular value of psi at the assembled initial state (set by
        :func:`~flexmb.simulate`); singular values below ``singular_window``
        times it are inverted with the fading Tikhonov filter of
        :meth:`Complement.particular` in the particular solutions
        ``psi^+ gamma`` (eq. 38) and ``psi^+ b``. Near a singular position
        the component of gamma along the collapsing direction is mostly the
        state's tiny constraint violation; divided by the vanishing singular
        value it throws the motion onto the level set ``phi = const`` and
        from there onto the other branch. Filtered, the mechanism moves on by
        its inertia on the branch its velocity points along, and the
        (mass-orthogonal) projection of :func:`~flexmb.simulate` removes the
        small error after it. Exact wherever no singular value has fallen
        below ``singular_window`` times ``sigma_ref``: mechanisms that stay
        away from singular positions are unchanged. Default 0.1; 0
        turns it off. See docs/stability.md, section 2.
    singular_rtol : float
        Opt-in, older and blunter: singular values of psi below
        ``singular_rtol`` times the largest are left out of the particular
        solution ``xdd_p = psi^+ gamma`` (the number of freedoms p is
        unchanged). Off by default (0). It acts at the same place in every
        run, whatever the initial state, so it can also protect a run that
        starts near a singular position (where ``singular_window``, judged
        at the start, is small); but on a badly scaled psi it would drop
        terms everywhere.
    """

    name = "base"
    default_rank_tol = 1e-10

    rank_tol: float | None = None
    singular_rtol: float = field(default=0.0, kw_only=True)
    singular_window: float = field(default=0.1, kw_only=True)

    @singular_rtol.validator
    def _check_singular_rtol(self, attribute, value):
        if not (isinstance(value, (int, float)) and 0.0 <= value < 1.0):
            raise ModelError(f"{type(self).__name__}: singular_rtol must be in [0, 1), got {value!r}")

    @singular_window.validator
    def _check_singular_window(self, attribute, value):
        if not (isinstance(value, (int, float)) and 0.0 <= value < 1.0):
            raise ModelError(f"{type(self).__name__}: singular_window must be in [0, 1), got {value!r}")

    @property
    def tol(self) -> float:
        """The relative zero tolerance in use."""
        return self.default_rank_tol if self.rank_tol is None else self.rank_tol

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
        if m == 0 or not np.any(np.abs(psi) > PSI_ZERO):
            return Complement(np.eye(n), 0, np.zeros((n, 0)), np.zeros(0), np.zeros((m, 0)))
        if not np.all(np.isfinite(psi)):
            raise AssemblyError("constraint Jacobian psi is not finite")
        return self._complement_impl(psi)

    def _complement_impl(self, psi: np.ndarray) -> Complement:
        raise NotImplementedError
