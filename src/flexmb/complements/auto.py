"""Automatic choice between the QR and SVD complements, per call, by size and conditioning."""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from .base import Complement, ComplementStrategy
from .qr import complement_from_qr, pivoted_qr
from .svd import SVDComplement

__all__ = ["AutoComplement"]


def _positive(instance, attribute, value):
    if not value > 0:
        raise ValueError(f"AutoComplement: {attribute.name} must be > 0, got {value!r}")


@frozen(eq=False)
class AutoComplement(ComplementStrategy):
    """QR of psi^T when it is large and reveals the rank clearly, SVD otherwise.

    On a :class:`~flexmb.System` whose evaluation is compiled (every model
    but those with plugin joints), ``"auto"`` solves the reduced equations
    by the articulated strategy (:class:`~flexmb.complements.ArticulatedComplement`: the
    right-hand side, the reactions and the mass-orthogonal speed
    projection, with its tolerances): it was the cheaper on every looped
    model measured (``benchmarks/rhs_cost.py``; docs/benchmarks.md). The
    rule below builds the explicit complements T that other consumers ask
    for (:meth:`complement`).

    The rule, applied to each psi (m x n) passed to :meth:`complement`:

    1. if ``n < min_n`` (default 20), use the SVD: for such small matrices
       it is as fast as the QR or a few microseconds faster (the QR path
       makes more Python calls), and it is the safer;
    2. otherwise factor ``psi^T P = Q R`` (:class:`~flexmb.complements.QRComplement`)
       and look at the diagonal ratios ``rho_i = |R_ii| / |R_00|``. If none
       lies within a factor ``band`` (default 100) of the tolerance, i.e.
       in ``[rank_tol / band, rank_tol * band]``, the rank is clear and the QR
       result is returned;
    3. else the rank is ambiguous (the ratios only estimate the singular
       value ratios ``s_i / s_0``) and the SVD decides.

    Both thresholds are measured (``benchmarks/complements_speed.py``; the
    timings: docs/benchmarks.md, "Complement strategies"): with
    ``m = n/3 + 1`` the QR and the SVD cost the same up to n = 16, and the
    QR is faster from n = 24 on, the more so the larger psi. Over 340 random
    psi up to 200 x 800 with graded spectra (singular values down to 1e-16)
    and row scalings from 0.1 to 10,
    ``rho_i`` differed from ``s_i / s_0`` by at most a factor 7.1, so a band
    of 100 leaves a margin of 14. An ambiguous case costs one QR on top of
    the SVD.

    Parameters
    ----------
    rank_tol : float, optional
        Relative zero tolerance of both the QR diagonal and the singular
        values (default ``1e-10``).
    min_n : int
        Number of coordinates from which QR is tried first.
    band : float
        Factor around ``rank_tol`` within which a QR diagonal ratio is
        ambiguous.
    singular_rtol : float
        Relative floor of the singular values used in particular solutions;
        see :class:`ComplementStrategy`.
    singular_window : float
        Relative width of the filter of small singular values in particular
        solutions (default 0.1); see :class:`ComplementStrategy`.

    Examples
    --------
    >>> import numpy as np
    >>> from flexmb.complements import AutoComplement
    >>> auto = AutoComplement()
    >>> auto.choose(np.ones((2, 3)))
    'svd'
    >>> auto.choose(np.eye(3, 40))
    'qr'
    >>> auto.complement(np.eye(3, 40)).p
    37
    """

    name = "auto"
    default_rank_tol = 1e-10

    min_n: int = field(default=20, validator=_positive)
    band: float = field(default=100.0, validator=_positive)

    def _decide(self, psi: np.ndarray):
        """Apply the rule to a nonzero finite psi: ``('svd', None)`` or ``('qr', (Q, R, piv, rank))``."""
        if psi.shape[1] < self.min_n:
            return "svd", None
        Q, R, piv = pivoted_qr(psi)
        rho = np.abs(np.diagonal(R))
        rho = rho / rho[0]
        if np.any((rho >= self.tol / self.band) & (rho <= self.tol * self.band)):
            return "svd", None
        return "qr", (Q, R, piv, int(np.sum(rho > self.tol)))

    def choose(self, psi: np.ndarray) -> str:
        """Name of the strategy the rule picks for ``psi``.

        Parameters
        ----------
        psi : ndarray, shape (m, n)
            Constraint Jacobian (eq. 29).

        Returns
        -------
        {'qr', 'svd'}
            ``'svd'`` also for an empty or all-zero psi (T = I either way).
        """
        psi = np.asarray(psi, dtype=float)
        if psi.shape[0] == 0 or not np.any(psi):
            return "svd"
        return self._decide(psi)[0]

    def _complement_impl(self, psi) -> Complement:
        which, qr = self._decide(psi)
        if which == "qr":
            return complement_from_qr(psi, *qr)
        return SVDComplement(rank_tol=self.rank_tol)._complement_impl(psi)
