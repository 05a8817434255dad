"""The reduced equations of motion by the SVD complement, compiled (eqs. 30-39).

With the singular value decomposition ``psi = U S V^T`` the last ``n - r``
columns of V span the null space of psi (the orthogonal complement T,
``psi T = 0``, ``T^T T = I``) and the first r its row space. The
accelerations ``xdd = T zd + xdd_p`` follow from the particular solution
``xdd_p = psi^+ gamma`` and ``(T^T A T) zd = T^T (f - A xdd_p)`` (eqs.
36-39); the constraint reactions from ``psi^T lambda = A xdd - f``. This is
:class:`flexmb.complements.SVDComplement` with :meth:`System._solve
<flexmb.system.System>` in one compiled call; both take the decomposition
and the singular-value filter from here.
"""

from __future__ import annotations

import numpy as np
from .cache import njit

from .articulated import solve_spd

__all__ = ["svd_parts", "filtered", "svd_reduced_solve"]


@njit(cache=True)
def svd_parts(psi, tol):
    """The SVD of psi and its numerical rank.

    Parameters
    ----------
    psi : ndarray, shape (m, n)
        Constraint Jacobian (eq. 29), finite.
    tol : float
        Singular values above ``tol`` times the largest count.

    Returns
    -------
    U : ndarray, shape (m, m)
        Left singular vectors.
    s : ndarray, shape (min(m, n),)
        Singular values, descending.
    Vt : ndarray, shape (n, n)
        Right singular vectors (rows).
    rank : int
        Numerical rank.
    """
    U, s, Vt = np.linalg.svd(np.ascontiguousarray(psi))
    rank = 0
    for i in range(s.shape[0]):
        if s[i] > tol * s[0]:
            rank += 1
    return U, s, Vt, rank


@njit(cache=True)
def filtered(s, g, w):
    """``g / s`` with singular values below ``w`` regularised (:meth:`Complement.particular`).

    ``s / (s^2 + w^2 (1 - s^2/w^2)^2)`` below the window, ``1/s`` above.

    Parameters
    ----------
    s : ndarray, shape (r,)
        Singular values.
    g : ndarray, shape (r,)
        Right-hand side in the singular basis.
    w : float
        The window (> 0).

    Returns
    -------
    ndarray, shape (r,)
        The filtered quotients.
    """
    out = np.empty(s.shape[0])
    for i in range(s.shape[0]):
        fade = max(1.0 - (s[i] / w) ** 2, 0.0) ** 2
        out[i] = s[i] * g[i] / (s[i] * s[i] + (w * w) * fade)
    return out


#: reduced mass matrices up to this size are factored by the loops below, larger ones by LAPACK
SMALL_CHOLESKY = 48


@njit(cache=True)
def _cholesky_solve(M, b):
    """``M z = b`` for symmetric positive definite M; (z, True), or (b, False) if M is not positive definite."""
    p = M.shape[0]
    if p <= SMALL_CHOLESKY:
        z = np.empty((p, 1))
        if not solve_spd(M, b.reshape(p, 1), z):
            return b, False
        return z.reshape(p), True  # a contiguous view (z[:, 0] would type the result non-contiguous)
    try:
        L = np.linalg.cholesky(M)
    except Exception:  # not positive definite
        return b, False
    z = b.copy()
    for i in range(p):
        for k in range(i):
            z[i] -= L[i, k] * z[k]
        z[i] /= L[i, i]
    for i in range(p - 1, -1, -1):
        for k in range(i + 1, p):
            z[i] -= L[k, i] * z[k]
        z[i] /= L[i, i]
    return z, True


@njit(cache=True)
def svd_reduced_solve(A, f, psi, gamma, tol, psi_zero, rank_limit, window):
    """Accelerations and constraint reactions from the reduced equations (eqs. 36-39), SVD complement.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        Generalized mass matrix.
    f : ndarray, shape (n,)
        Force array.
    psi : ndarray, shape (m, n)
        Constraint Jacobian.
    gamma : ndarray, shape (m,)
        Right-hand side of ``psi xdd = gamma``.
    tol : float
        Relative rank tolerance of the SVD.
    psi_zero : float
        A psi with no entry above this constrains nothing (rank 0).
    rank_limit : int
        Largest rank kept (the smallest singular values beyond it move
        into T); negative: no limit.
    window : float
        Singular values below it are filtered in ``psi^+ gamma``
        (:func:`filtered`); 0: none.

    Returns
    -------
    xdd : ndarray, shape (n,)
        Accelerations.
    lam : ndarray, shape (m,)
        Reactions: the minimum-norm ``lambda`` of ``psi^T lambda = A xdd - f``.
    status : int
        0; 1 if ``T^T A T`` is not positive definite; 2 if psi is not finite.
    """
    m, n = psi.shape
    lam = np.zeros(m)
    big = 0.0
    for i in range(m):
        for j in range(n):
            a = abs(psi[i, j])
            if not np.isfinite(a):
                return np.zeros(n), lam, 2
            big = max(big, a)
    if big <= psi_zero:  # T = I
        xdd, ok = _cholesky_solve(A, f.copy())
        return xdd, lam, 0 if ok else 1
    U, s, Vt, r_full = svd_parts(psi, tol)
    r = r_full if rank_limit < 0 else min(r_full, rank_limit)
    p = n - r
    # T: the null space, then the row-space directions beyond the rank limit (Complement.truncated)
    T = np.empty((n, p))
    for c in range(n - r_full):
        T[:, c] = Vt[r_full + c]
    for c in range(r_full - r):
        T[:, n - r_full + c] = Vt[r + c]
    # xdd_p = basis (left^T gamma / s), filtered below the window
    g = np.zeros(r)
    for k in range(r):
        for i in range(m):
            g[k] += U[i, k] * gamma[i]
    q = filtered(s[:r], g, window) if window > 0.0 else g / s[:r]
    xdd = np.zeros(n)
    for k in range(r):
        for j in range(n):
            xdd[j] += Vt[k, j] * q[k]
    if p:
        rhs = T.T @ (f - A @ xdd)
        z, ok = _cholesky_solve(T.T @ A @ T, rhs)
        if not ok:
            return xdd, lam, 1
        xdd = T @ z + xdd
    # lambda = left (basis^T (A xdd - f) / s)
    res = A @ xdd - f
    for k in range(r):
        h = 0.0
        for j in range(n):
            h += Vt[k, j] * res[j]
        h /= s[k]
        for i in range(m):
            lam[i] += U[i, k] * h
    return xdd, lam, 0
