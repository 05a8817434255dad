"""Loops closed through the articulated-body recursion: T, A and psi never formed (eqs. 30-39)."""

from __future__ import annotations

import numpy as np
from attrs import frozen

from ..errors import ModelError
from .base import ComplementStrategy
from .svd import SVDComplement

__all__ = ["ArticulatedComplement"]


@frozen(eq=False)
class ArticulatedComplement(ComplementStrategy):
    """The reduced equations solved as ``xdd = a0 + A^-1 psi^T lambda``, ``K lambda = gamma - psi a0``.

    ``a0 = A^-1 f`` and the columns of ``A^-1 psi^T`` come from the
    articulated-body recursion and ``K = psi A^-1 psi^T`` (m x m) from the
    rows' wrenches (:mod:`flexmb.kernels.loops`): O(n m) per evaluation,
    O(n) for a chain of loops, with no n x n array, against O(n^3) for the
    strategies that build T. The accelerations are those of eqs. 36-39
    (the mass-orthogonal complement projection; docs/theory.md, "Loops
    without the complement"), the reactions the multipliers lambda.

    K's eigenvalues (or, for a large banded K, its pivots ``d_j`` in
    ``L D L^T``) play the part of psi's squared singular values, in the
    kinetic-energy metric: those at or below ``rank_tol`` times the largest
    (a pivot: times ``K_jj``) count as zero (redundant rows), at most the
    rank found at the assembled initial state is kept, and the
    prescribed part of the right-hand side is filtered below
    ``singular_window`` times the smallest root at that state
    (singular positions), as :class:`ComplementStrategy` describes for
    psi's singular values.

    The right-hand side, the reactions and the mass-orthogonal speed
    projection take this route. Where an explicit complement T is asked
    for (:meth:`complement`: the implicit integrators' dense Jacobian,
    statics, linearisation), it is the SVD's, singular values at or below
    ``sqrt(rank_tol)`` of the largest counting as zero.

    Parameters
    ----------
    rank_tol : float, optional
        Relative zero tolerance of K's eigenvalues and pivots (default
        ``1e-13``: K squares the singular values, so this is about 3e-7 on
        them, as for the eigen strategy).
    singular_rtol : float
        Not supported by this strategy (must be 0).
    singular_window : float
        Relative width of the filter of small (mass-weighted) singular
        values (default 0.1); see :class:`ComplementStrategy`.

    Examples
    --------
    >>> import numpy as np
    >>> from flexmb.complements import ArticulatedComplement
    >>> ArticulatedComplement().complement(np.array([[1.0, 1.0, 0.0]])).p
    2
    """

    name = "articulated"
    default_rank_tol = 1e-13

    def __attrs_post_init__(self):
        if self.singular_rtol:
            raise ModelError("ArticulatedComplement: singular_rtol is not supported (use singular_window)")

    def _complement_impl(self, psi):
        # K's eigenvalues are psi's squared (mass-weighted) singular values: the same cut on the SVD's
        return SVDComplement(rank_tol=float(np.sqrt(self.tol)))._complement_impl(psi)
