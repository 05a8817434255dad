"""Factoring K = psi A^-1 psi^T with its rank revealed and its singular positions filtered (eqs. 30-39).

K (m x m, symmetric positive semi-definite) is the constraint rows'
inverse inertia; its eigenvalues are the squared singular values of psi in
the kinetic-energy metric (of ``psi A^-1/2``). The articulated strategy
(:mod:`flexmb.kernels.loops`) solves ``K lambda = gamma - psi a0`` with it,
as the SVD strategy solves with psi's singular values:

* small or dense K (``m <= DENSE_K``, or a band over half of m): its
  eigenvalues; those at or below ``tol`` times the largest count as zero
  (redundant rows), and at most ``rank_limit`` of the largest are kept;
* large banded K (a chain of loops): ``L D L^T`` within its band, a pivot
  ``d_j`` at or below ``tol K_jj`` dropping row j (a combination of the
  rows before it), the rows of the smallest relative pivots beyond
  ``rank_limit`` dropped too.

Below ``window^2`` an eigenvalue or pivot ``d`` is filtered as
``d + w^2 (1 - d / w^2)^2``: the fading Tikhonov filter of
:meth:`flexmb.complements.Complement.particular` on the mass-weighted
singular value ``sqrt(d)``. It acts on the prescribed part of the
right-hand side only (gamma, b), as the SVD strategy filters ``psi^+
gamma`` only.
"""

from __future__ import annotations

import numpy as np
from .cache import njit

__all__ = ["DENSE_K", "factor_constraint_matrix", "solve_constraint_matrix"]

#: K with at most this many rows (or a band over half its rows) is factored by its eigenvalues, which
#: reveal its rank as the SVD reveals psi's; a larger banded one as L D L^T within its band
DENSE_K = 64


@njit(cache=True)
def factor_constraint_matrix(Kb, diag, band, tol, window, rank_limit):
    """Factor K, given as its lower band in the factoring order (``Kb[i, q] = K[i, i - q]``).

    Parameters
    ----------
    Kb : ndarray, shape (m, band + 1)
        K's lower band; overwritten by L when K is banded.
    diag : ndarray, shape (m,)
        K's diagonal.
    band : int
        Half bandwidth.
    tol : float
        Relative zero tolerance of the eigenvalues or pivots.
    window : float
        Mass-weighted singular values below it are filtered (0: none).
    rank_limit : int
        Largest rank kept (negative: no limit).

    Returns
    -------
    d : ndarray, shape (m,)
        Eigenvalues or pivots, zero where dropped.
    dfilt : ndarray, shape (m,)
        The same, filtered.
    kept : int
        Their number not dropped (the rank).
    smallest : float
        The smallest ``sqrt(d)`` kept.
    V : ndarray, shape (m, m) or (0, 0)
        The eigenvectors; empty when K was factored as ``L D L^T``.
    """
    m = Kb.shape[0]
    if m <= DENSE_K or 2 * band >= m:
        ev, evfilt, kept, smallest, V = _dense_eigen(Kb, band, tol, window, rank_limit)
        return ev, evfilt, kept, smallest, V
    d, dfilt, kept, smallest = _band_ldl(Kb, diag, band, tol, window, rank_limit)
    return d, dfilt, kept, smallest, np.zeros((0, 0))


@njit(cache=True)
def _dense_eigen(Kb, band, tol, window, rank_limit):
    """K's eigenvalues (zero where dropped), the filtered ones, the count kept, the smallest root, the eigenvectors.

    Eigenvalues at or below ``tol`` times the largest are dropped, and all
    but the ``rank_limit`` largest; ``sqrt`` of an eigenvalue is a
    mass-weighted singular value of psi, filtered below ``window``.
    """
    m = Kb.shape[0]
    K = np.zeros((m, m))
    for i in range(m):
        for q in range(min(band, i) + 1):
            K[i, i - q] = Kb[i, q]
            K[i - q, i] = Kb[i, q]
    ev, V = np.linalg.eigh(K)  # ascending
    top = ev[m - 1] if m else 0.0
    w2 = window * window
    evfilt = np.zeros(m)
    kept = 0
    smallest = np.inf
    for q in range(m - 1, -1, -1):
        if not (ev[q] > tol * top and top > 0.0) or (0 <= rank_limit <= kept):
            ev[q] = 0.0
            continue
        kept += 1
        smallest = min(smallest, np.sqrt(ev[q]))
        evfilt[q] = ev[q]
        if ev[q] < w2:
            fade = 1.0 - ev[q] / w2
            evfilt[q] = ev[q] + w2 * fade * fade
    return ev, evfilt, kept, smallest, V


@njit(cache=True)
def solve_constraint_matrix(Kb, d, dfilt, band, order, filtered, exact, V):
    """lambda of ``K lambda = filtered + exact`` from :func:`factor_constraint_matrix`, ``filtered`` filtered.

    Dropped rows' (or eigenvalues') multipliers are zero. Only the
    prescribed part of the right-hand side (gamma, b) is filtered, as the
    SVD strategy filters ``psi^+ gamma`` only: the part that the
    unconstrained motion brings (``-psi a0``) is removed exactly, so the
    accelerations keep to the constraints' tangent along weak directions
    too (docs/theory.md, "Loops without the complement").

    Parameters
    ----------
    Kb : ndarray, shape (m, band + 1)
        L (banded K) or unused (dense K).
    d, dfilt : ndarray, shape (m,)
        The eigenvalues or pivots, plain and filtered.
    band : int
        Half bandwidth.
    order : ndarray of int, shape (m,)
        The rows in the factoring order.
    filtered, exact : ndarray, shape (m,)
        The two parts of the right-hand side, in row order.
    V : ndarray, shape (m, m) or (0, 0)
        The eigenvectors (dense K).

    Returns
    -------
    ndarray, shape (m,)
        lambda, in row order.
    """
    m = Kb.shape[0]
    if V.shape[0]:  # K = V diag(d) V^T, in the factoring order
        lam = np.zeros(m)
        for q in range(m):
            if not d[q] > 0.0:
                continue
            gq = 0.0
            eq = 0.0
            for j in range(m):
                gq += V[j, q] * filtered[order[j]]
                eq += V[j, q] * exact[order[j]]
            c = gq / dfilt[q] + eq / d[q]
            for j in range(m):
                lam[order[j]] += V[j, q] * c
        return lam
    z = np.empty(m)
    e = np.empty(m)
    for j in range(m):
        v = filtered[order[j]]
        w = exact[order[j]]
        for q in range(1, min(band, j) + 1):
            v -= Kb[j, q] * z[j - q]
            w -= Kb[j, q] * e[j - q]
        z[j] = v
        e[j] = w
    for j in range(m):
        z[j] = z[j] / dfilt[j] + e[j] / d[j] if d[j] > 0.0 else 0.0
    for j in range(m - 1, -1, -1):
        v = z[j]
        for i in range(j + 1, min(m, j + band + 1)):
            v -= Kb[i, i - j] * z[i]
        z[j] = v
    lam = np.empty(m)
    for j in range(m):
        lam[order[j]] = z[j]
    return lam


@njit(cache=True)
def _band_ldl(Kb, diag, band, tol, window, rank_limit):
    """``L D L^T`` of the banded K in place (Kb[i, d] = K[i, i - d]); returns (d, d_filtered, kept, smallest).

    Rows whose pivot is at or below ``tol * diag`` are dropped (d = 0,
    their column of L zero). ``d_filtered`` holds the pivots below
    ``window^2`` filtered, for the part of the right-hand side that
    the filter acts on. With ``rank_limit >= 0`` and more rows kept, the
    rows of the smallest relative pivots are dropped and K factored again.
    """
    m = Kb.shape[0]
    K0 = Kb.copy()
    drop = np.zeros(m, dtype=np.bool_)
    w2 = window * window
    for attempt in range(2):
        d = np.zeros(m)
        dfilt = np.zeros(m)
        ratio = np.zeros(m)
        smallest = np.inf
        kept = 0
        for j in range(m):
            # d_j = K_jj - sum_k L_jk^2 d_k
            s = Kb[j, 0]
            for q in range(1, min(band, j) + 1):
                s -= Kb[j, q] * Kb[j, q] * d[j - q]
            ratio[j] = s / diag[j] if diag[j] > 0.0 else 0.0
            if drop[j] or not s > tol * diag[j]:
                drop[j] = True
                for i in range(j + 1, min(m, j + band + 1)):
                    Kb[i, i - j] = 0.0
                continue
            kept += 1
            smallest = min(smallest, np.sqrt(s))
            d[j] = s
            dfilt[j] = s
            if s < w2:
                fade = 1.0 - s / w2
                dfilt[j] = s + w2 * fade * fade
            for i in range(j + 1, min(m, j + band + 1)):
                # L_ij = (K_ij - sum_k L_ik L_jk d_k) / d_j
                v = Kb[i, i - j]
                for k in range(max(i - band, 0), j):
                    v -= Kb[i, i - k] * Kb[j, j - k] * d[k]
                Kb[i, i - j] = v / s
        if rank_limit < 0 or kept <= rank_limit or attempt == 1:
            return d, dfilt, kept, smallest
        # keep the rank_limit rows of the largest relative pivots
        idx = np.argsort(-ratio)
        for q in range(m):
            drop[idx[q]] = drop[idx[q]] or q >= rank_limit
        Kb[:, :] = K0
    return d, dfilt, kept, smallest
