"""Rank-revealing QR with column pivoting of psi^T (Businger & Golub; Golub & Van Loan 5.4.2)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .._lazy import LazyModule
from .base import Complement, ComplementStrategy

__all__ = ["QRComplement", "complement_from_qr", "pivoted_qr", "qr_rank"]

#: LAPACK through scipy, imported by the first factorization
lapack = LazyModule("scipy.linalg.lapack")

#: Number of coordinates n from which the orthogonal factor Q (n x n) is
#: formed as ``I - V S V^T`` with one matrix product (compact WY form,
#: Schreiber & Van Loan 1989) rather than by LAPACK ``dorgqr``, which does
#: about twice the flops at lower speed. Measured with
#: ``benchmarks/complements_speed.py``: the two break even near n = 96,
#: below which the few extra numpy calls of the WY form cost more than they
#: save (the timings: docs/benchmarks.md, "Complement strategies").
WY_MIN_N = 96

#: LAPACK block size used to size the work arrays.
_NB = 32


@lru_cache(maxsize=64)
def _upper(k: int, m: int) -> np.ndarray:
    """Mask of the upper trapezoid of a k x m array (cached: np.triu per call is slow on tiny arrays)."""
    mask = np.triu(np.ones((k, m)))
    mask.flags.writeable = False
    return mask


def _q_by_wy(qr: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Form Q = H_1 ... H_k = I - V S V^T from the reflectors below the diagonal of ``qr``.

    S is the upper-triangular factor of the compact WY form, obtained from
    ``S^-1 = diag(1/tau) + striu(V^T V)`` (the "UT transform", Joffrain et
    al. 2006), so Q costs one n x k x n matrix product.
    """
    n, k = qr.shape[0], tau.shape[0]
    V = np.tril(qr[:, :k], -1)
    d = np.arange(k)
    V[d, d] = 1.0
    identity = tau == 0.0  # H_i = I (LAPACK's last reflector of a square block): drop v_i
    V[:, identity] = 0.0
    S_inv = np.triu(V.T @ V, 1)
    S_inv[d, d] = 1.0 / np.where(identity, 1.0, tau)
    S, _ = lapack.dtrtri(S_inv, lower=0)
    Q = (V @ S) @ (-V.T)
    Q[np.arange(n), np.arange(n)] += 1.0
    return Q


def pivoted_qr(psi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Column-pivoted QR of ``psi^T``: ``psi^T[:, piv] = Q R``.

    Parameters
    ----------
    psi : ndarray, shape (m, n)
        Finite constraint Jacobian (eq. 29).

    Returns
    -------
    Q : ndarray, shape (n, n)
        Orthogonal factor.
    R : ndarray, shape (k, m)
        Upper-trapezoidal factor, ``k = min(m, n)``; ``|R[i, i]|`` does not
        increase with i.
    piv : ndarray of int, shape (m,)
        Row permutation of psi (column permutation of psi^T).

    Notes
    -----
    Q is the n x n orthogonal factor whose trailing columns span the null
    space of psi (eqs. 30-39). Calls LAPACK ``dgeqp3`` directly (scipy.linalg.qr adds checks that cost
    more than the factorization on the tiny matrices of rigid loops).
    """
    m, n = psi.shape
    qr, jpvt, tau, _, _ = lapack.dgeqp3(np.array(psi.T, order="F"), lwork=2 * m + (m + 1) * _NB, overwrite_a=1)
    k = tau.shape[0]
    R = qr[:k] * _upper(k, m)
    if n >= WY_MIN_N:
        Q = _q_by_wy(qr, tau)
    else:
        full = np.zeros((n, n), order="F")
        full[:, :k] = qr[:, :k]
        Q, _, _ = lapack.dorgqr(full, tau, lwork=max(1, n * _NB), overwrite_a=1)
    return Q, R, jpvt - 1


def qr_rank(R: np.ndarray, tol: float) -> int:
    """Numerical rank from the diagonal of a pivoted QR's R: the count of ``|R_ii| > tol |R_00|``.

    Parameters
    ----------
    R : ndarray, shape (k, m)
        Upper-trapezoidal factor of :func:`pivoted_qr`, ``R[0, 0] != 0``.
    tol : float
        Relative zero tolerance.

    Returns
    -------
    int
        The numerical rank.
    """
    d = np.abs(np.diagonal(R))
    return int(np.sum(d > tol * d[0]))


def complement_from_qr(psi: np.ndarray, Q: np.ndarray, R: np.ndarray, piv: np.ndarray, rank: int) -> Complement:
    """Build the :class:`Complement` of psi from its pivoted QR and numerical rank.

    ``T = Q[:, r:]`` and ``basis = Q[:, :r]``. With R's rows beyond the rank
    dropped, ``psi basis = (psi^T[:, piv] ... )`` gives ``psi[piv] basis =
    R_1^T`` exactly (R_1 = R[:r]); a thin QR ``R_1^T = Q' K`` then writes
    ``psi basis = left K`` with orthonormal ``left`` (``left[piv] = Q'``)
    and upper-triangular K (r x r): a complete orthogonal decomposition
    ``psi ≈ left K basis^T``, whose minimum-norm least-squares solution is
    ``basis K^-1 left^T rhs`` (Golub & Van Loan 5.5.6).

    Parameters
    ----------
    psi : ndarray, shape (m, n)
        Constraint Jacobian (eq. 29).
    Q, R, piv : ndarray
        Its pivoted QR, from :func:`pivoted_qr`.
    rank : int
        Numerical rank r, from :func:`qr_rank`.

    Returns
    -------
    Complement
        T (n x (n - r)), the row-space basis, ``left`` (m x r) and the
        triangular ``factor`` K (r x r).
    """
    m = psi.shape[0]
    r = rank
    # thin QR R[:r]^T = left_p K through LAPACK directly (numpy's qr wrapper dominates on small matrices)
    qr2, tau2, _, _ = lapack.dgeqrf(np.array(R[:r].T, order="F"), lwork=max(1, r * _NB), overwrite_a=1)
    K = qr2[:r] * _upper(r, r)
    left_p, _, _ = lapack.dorgqr(qr2, tau2, lwork=max(1, r * _NB), overwrite_a=1)  # (m, r)
    left = np.empty((m, r))
    left[piv] = left_p
    return Complement(Q[:, r:].copy(), r, Q[:, :r].copy(), np.abs(K.diagonal()), left, K)


class QRComplement(ComplementStrategy):
    """Trailing columns of Q in a column-pivoted QR of psi^T.

    ``psi^T P = Q R`` with P a permutation chosen so that ``|R_ii|``
    decreases (rank-revealing QR). The rank r is the count of diagonal
    entries with ``|R_ii| > rank_tol |R_00|`` (default ``rank_tol = 1e-10``, as for
    the SVD; ``|R_00|`` is the largest row norm of psi, within a factor
    ``sqrt(m)`` of its largest singular value). Then ``T = Q[:, r:]`` is an
    orthonormal basis of the null space of psi (eqs. 30-39) and
    ``Q[:, :r]`` of its row space.

    Particular solutions (:meth:`Complement.particular`) are the
    minimum-norm least-squares ones, as with the SVD, through a thin QR of
    the r x m block ``R[:r]^T`` (a complete orthogonal decomposition), so
    redundant constraints are handled.

    It needs no iteration, unlike the SVD, and forms Q with one matrix
    product for large n (see :data:`WY_MIN_N`): faster than ``svd`` on
    large psi, as fast on the wiper's 9 x 33, and a little slower on the
    tiny psi of rigid loops, where Python overhead dominates
    (``benchmarks/complements_speed.py``; the timings: docs/benchmarks.md,
    "Complement strategies"). Pivoted QR reveals the rank
    reliably in practice but not always (Kahan's matrix); when a diagonal
    ratio lies near ``rank_tol``, prefer ``svd`` or ``auto``.

    Parameters
    ----------
    rank_tol : float, optional
        Relative zero tolerance of the diagonal of R (default ``1e-10``).
    singular_rtol : float
        Relative floor of the singular values used in particular solutions;
        see :class:`ComplementStrategy`.
    singular_window : float
        Relative width of the filter of small singular values in particular
        solutions (default 0.1); see :class:`ComplementStrategy`.

    Examples
    --------
    >>> import numpy as np
    >>> from flexmb.complements import QRComplement
    >>> c = QRComplement().complement(np.array([[1.0, 1.0, 0.0], [2.0, 2.0, 0.0]]))
    >>> c.rank, c.p
    (1, 2)
    """

    name = "qr"
    default_rank_tol = 1e-10

    def _complement_impl(self, psi):
        Q, R, piv = pivoted_qr(psi)
        return complement_from_qr(psi, Q, R, piv, qr_rank(R, self.tol))
