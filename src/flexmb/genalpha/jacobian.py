"""The dense path's Jacobian of generalized-alpha: forward differences, and the low-pass projector of ``f_max``.

:class:`~flexmb.genalpha.GeneralizedAlpha` forms ``Jx = da/dx`` and ``Jv =
da/dxd`` densely when it has no Newton preconditioner (small models, or a
cutoff ``f_max``): from the caller's ``jac``, or by
:func:`forward_differences`; with ``f_max`` its error estimate is
projected by :func:`low_pass`, from the eigenvectors of ``Jx``.
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.linalg import eig

__all__ = ["F_MAX_WARN_SIZE", "forward_differences", "low_pass", "warn_f_max_cost"]

_SQRT_EPS = np.sqrt(np.finfo(float).eps)

#: from this many positions on, ``f_max`` warns of its cost (the dense eigenproblem of Jx at each Jacobian)
F_MAX_WARN_SIZE = 1000


def forward_differences(fun, t, y, n):
    """``Jx``, ``Jv`` by forward differences of ``fun`` at ``(t, y)``: 2 n + 1 evaluations.

    Parameters
    ----------
    fun : callable
        ``fun(t, y)``, the state derivative, ``[n:2n]`` the accelerations.
    t : float
        Time, s.
    y : ndarray, shape (2 n + n_w,)
        State.
    n : int
        Number of positions.

    Returns
    -------
    Jx, Jv : ndarray, shape (n, n)
        The accelerations per position and per speed; the increment of
        entry k is ``sqrt(eps) max(1, |y_k|)``.
    """
    f0 = fun(t, y)[n : 2 * n]
    Jx, Jv = np.empty((n, n)), np.empty((n, n))
    for k in range(2 * n):
        d = _SQRT_EPS * max(1.0, abs(y[k]))
        yp = y.copy()
        yp[k] += d
        col = (fun(t, yp)[n : 2 * n] - f0) / d
        if k < n:
            Jx[:, k] = col
        else:
            Jv[:, k - n] = col
    return Jx, Jv


def low_pass(Jx, f_max):
    """``I - sum v_k w_k^H / (w_k^H v_k)`` over the eigenpairs of Jx above f_max (None if none).

    Built from the high modes (distinct, well separated) with left and
    right eigenvectors, so the cluster of zero eigenvalues (constraint
    directions, rigid motions) needs no inverse.

    Parameters
    ----------
    Jx : ndarray, shape (n, n)
        The accelerations per position.
    f_max : float
        The cutoff, Hz.

    Returns
    -------
    ndarray, shape (n, n) or None
        The projector onto the modes below ``f_max``.
    """
    lam, W, V = eig(Jx, left=True, right=True, check_finite=False)
    high = np.abs(lam) > (2 * np.pi * f_max) ** 2
    if not np.any(high):
        return None
    V, W = V[:, high], W[:, high]
    d = np.einsum("ik,ik->k", W.conj(), V)
    return np.eye(len(Jx)) - ((V / d) @ W.conj().T).real


def warn_f_max_cost(n) -> None:
    """Warn that ``f_max`` on n positions costs a dense eigenproblem per Jacobian (from ``F_MAX_WARN_SIZE`` on).

    Parameters
    ----------
    n : int
        Number of positions.
    """
    if n >= F_MAX_WARN_SIZE:
        warnings.warn(f"GeneralizedAlpha: f_max on {n} positions takes the eigenvectors of the dense {n} x {n} "
                      f"Jacobian at each new Jacobian (O(n^3) time, about {48 * n * n / 1e6:.0f} MB); leave f_max "
                      "unset for the matrix-free Newton solves of a large model", stacklevel=4)
