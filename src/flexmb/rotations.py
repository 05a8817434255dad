"""Small batched rotation helpers (stacked 3x3 arrays, batch axis first)."""

from __future__ import annotations

import numpy as np

__all__ = ["frame_from_axis", "cross"]

_E = np.eye(3)


def frame_from_axis(axis, second=None) -> np.ndarray:
    """Return a right-handed orthonormal frame whose z column is ``axis``.

    Parameters
    ----------
    axis : array_like, shape (3,)
        The direction of the frame's z axis (need not be unit).
    second : array_like, shape (3,), optional
        A direction for the frame's x axis (made orthogonal to ``axis``).

    Returns
    -------
    ndarray, shape (3, 3)
        Columns are the frame's x, y, z axes.
    """
    z = np.asarray(axis, dtype=float)
    z = z / np.linalg.norm(z)
    if second is None:
        trial = _E[int(np.argmin(np.abs(z)))]
    else:
        trial = np.asarray(second, dtype=float)
    x = trial - z * (trial @ z)
    x /= np.linalg.norm(x)
    y = cross(z, x)
    return np.column_stack([x, y, z])


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis, with broadcasting (faster than np.cross on small arrays).

    Parameters
    ----------
    a, b : ndarray, shape (..., 3)
        Vectors.

    Returns
    -------
    ndarray, shape (..., 3)
        ``a x b``.
    """
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(a.shape if a.shape == b.shape else np.broadcast_shapes(a.shape, b.shape))
    np.subtract(a1 * b2, a2 * b1, out=out[..., 0])
    np.subtract(a2 * b0, a0 * b2, out=out[..., 1])
    np.subtract(a0 * b1, a1 * b0, out=out[..., 2])
    return out
