"""Small batched rotation helpers (stacked 3x3 arrays, batch axis first)."""

from __future__ import annotations

import numpy as np

__all__ = ["axis_rotation", "skew", "frame_from_axis", "rotation_chain", "cross"]

_E = np.eye(3)


def skew(v: np.ndarray) -> np.ndarray:
    """Return the cross-product matrices of vectors.

    Parameters
    ----------
    v : ndarray, shape (..., 3)
        Vectors.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``skew(v) @ u == cross(v, u)``.
    """
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1] = -v[..., 2]
    out[..., 0, 2] = v[..., 1]
    out[..., 1, 0] = v[..., 2]
    out[..., 1, 2] = -v[..., 0]
    out[..., 2, 0] = -v[..., 1]
    out[..., 2, 1] = v[..., 0]
    return out


def axis_rotation(axis: int, angle: np.ndarray) -> np.ndarray:
    """Return rotations about a coordinate axis.

    Parameters
    ----------
    axis : {0, 1, 2}
        The axis (x, y or z).
    angle : ndarray, shape (m,)
        Angles in rad.

    Returns
    -------
    ndarray, shape (m, 3, 3)
        Rotation matrices.
    """
    angle = np.asarray(angle, dtype=float)
    c, s = np.cos(angle), np.sin(angle)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    out = np.zeros(angle.shape + (3, 3))
    out[..., axis, axis] = 1.0
    out[..., i, i] = c
    out[..., j, j] = c
    out[..., i, j] = -s
    out[..., j, i] = s
    return out


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


def rotation_chain(axes: tuple[int, ...], q: np.ndarray, qd: np.ndarray):
    """Successive rotations about moving coordinate axes, with their rates.

    The rotation is ``R = R_{a1}(q1) R_{a2}(q2) ...`` (each about the axis of
    the frame produced by the previous ones), so ``axes = (0, 1, 2)`` gives
    the Bryant sequence Rx Ry Rz.

    Parameters
    ----------
    axes : tuple of int
        Axis index of each rotation.
    q, qd : ndarray, shape (m, len(axes))
        Angles (rad) and their rates (rad/s), batched over m joints.

    Returns
    -------
    R : ndarray, shape (m, 3, 3)
        The rotation.
    H : ndarray, shape (m, 3, len(axes))
        Partial angular velocities, in the fixed (first) frame: ``omega = H @ qd``.
    a : ndarray, shape (m, 3)
        The velocity-dependent part of the angular acceleration, ``Hdot @ qd``.
    """
    m = q.shape[0]
    H = np.zeros((m, 3, len(axes)))
    a = np.zeros((m, 3))
    if len(axes) == 1:  # one rotation: a fixed axis, no velocity product
        H[:, axes[0], 0] = 1.0
        return axis_rotation(axes[0], q[:, 0]), H, a
    R = np.broadcast_to(_E, (m, 3, 3)).copy()
    w = np.zeros((m, 3))
    for i, ax in enumerate(axes):
        col = R[:, :, ax]
        H[:, :, i] = col
        wi = col * qd[:, i, None]
        a += cross(w, wi)
        w += wi
        R = R @ axis_rotation(ax, q[:, i])
    return R, H, a


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
