"""Unit quaternions (Euler parameters) for joint rotations, scalar last: ``q = (qx, qy, qz, qw)``.

A rotation by the angle ``a`` about the unit axis ``n`` is
``q = (sin(a/2) n, cos(a/2))``, the order of :class:`scipy.spatial.transform.Rotation`.
The speeds of a quaternion joint are the angular velocity ``w`` of the child
frame in the child frame's own axes, and the kinematic equations are

    qd = W(q) w = 1/2 q * (w, 0),
    W(q) = 1/2 [[qw I + [qv]x], [-qv^T]],        W^T W = I / 4 for a unit q,

so that a displacement ``dw`` along the speeds moves q by ``W dw`` and a
change ``dq`` of q is the displacement ``4 W^T dq`` (zero along q itself).
Every function takes a batch, the quaternions by rows; the rotation of a
quaternion that is not of unit length (an integrator's state between two
normalisations) is that of the quaternion normalised.
"""

from __future__ import annotations

import numpy as np

__all__ = ["rotation_matrix", "rates", "kinematic_matrix", "displacement_matrix", "rate_matrix", "compose",
           "turn_between", "normalized", "from_rotation_matrix", "bryant_angles", "rotation_vector",
           "inverse_right_jacobian"]


def _skew(v: np.ndarray) -> np.ndarray:
    """``[v]x`` of each row, shape (m, 3, 3)."""
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    out[..., 1, 0], out[..., 2, 0], out[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return out


def normalized(q: np.ndarray) -> np.ndarray:
    """Each quaternion divided by its length (a new array).

    Parameters
    ----------
    q : ndarray, shape (m, 4)
        Quaternions, scalar last.

    Returns
    -------
    ndarray, shape (m, 4)
        Unit quaternions.
    """
    q = np.asarray(q, dtype=float)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def rotation_matrix(q: np.ndarray) -> np.ndarray:
    """The rotation matrices of quaternions (normalised first).

    Parameters
    ----------
    q : ndarray, shape (m, 4)
        Quaternions, scalar last.

    Returns
    -------
    ndarray, shape (m, 3, 3)
        ``R = (qw^2 - qv.qv) I + 2 qv qv^T + 2 qw [qv]x``: child axes in the
        parent frame by columns.
    """
    q = normalized(q)
    v, s = q[..., :3], q[..., 3]
    R = 2.0 * v[..., :, None] * v[..., None, :] + 2.0 * s[..., None, None] * _skew(v)
    R += (s * s - np.sum(v * v, axis=-1))[..., None, None] * np.eye(3)
    return R


def rates(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``qd = W(q) w = 1/2 q * (w, 0)``.

    Parameters
    ----------
    q : ndarray, shape (m, 4)
        Quaternions, scalar last.
    w : ndarray, shape (m, 3)
        Angular velocities in the rotated (child) axes, rad/s.

    Returns
    -------
    ndarray, shape (m, 4)
        The quaternions' rates.
    """
    v, s = q[..., :3], q[..., 3:]
    return 0.5 * np.concatenate([s * w + np.cross(v, w), -np.sum(v * w, axis=-1, keepdims=True)], axis=-1)


def kinematic_matrix(q: np.ndarray) -> np.ndarray:
    """``W(q)`` (4 x 3 each): the quaternion's rate per unit angular velocity.

    Parameters
    ----------
    q : ndarray, shape (m, 4)
        Quaternions, scalar last.

    Returns
    -------
    ndarray, shape (m, 4, 3)
        ``1/2 [[qw I + [qv]x], [-qv^T]]``.
    """
    v, s = q[..., :3], q[..., 3]
    W = np.empty(q.shape[:-1] + (4, 3))
    W[..., :3, :] = 0.5 * (s[..., None, None] * np.eye(3) + _skew(v))
    W[..., 3, :] = -0.5 * v
    return W


def displacement_matrix(q: np.ndarray) -> np.ndarray:
    """``P(q) = 4 W(q)^T`` (3 x 4 each): the rotation (in the child axes) of a change of a unit quaternion.

    Parameters
    ----------
    q : ndarray, shape (m, 4)
        Unit quaternions, scalar last.

    Returns
    -------
    ndarray, shape (m, 3, 4)
        ``P`` with ``P W = I`` and ``P q = 0``.
    """
    return 4.0 * np.swapaxes(kinematic_matrix(q), -1, -2)


def rate_matrix(w: np.ndarray) -> np.ndarray:
    """``d(W(q) w)/dq`` (4 x 4 each, independent of q): ``1/2 [[-[w]x, w], [-w^T, 0]]``.

    Parameters
    ----------
    w : ndarray, shape (m, 3)
        Angular velocities in the rotated axes, rad/s.

    Returns
    -------
    ndarray, shape (m, 4, 4)
        The Jacobian of the quaternions' rates at fixed w.
    """
    out = np.zeros(w.shape[:-1] + (4, 4))
    out[..., :3, :3] = -0.5 * _skew(w)
    out[..., :3, 3] = 0.5 * w
    out[..., 3, :3] = -0.5 * w
    return out


def compose(q: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """``q * exp(theta / 2)``, normalised: q turned by the rotation vector ``theta`` in its own axes.

    Parameters
    ----------
    q : ndarray, shape (m, 4)
        Quaternions, scalar last.
    theta : ndarray, shape (m, 3)
        Rotation vectors in the rotated (child) axes, rad.

    Returns
    -------
    ndarray, shape (m, 4)
        Unit quaternions.
    """
    a = np.linalg.norm(theta, axis=-1, keepdims=True)
    # sin(a/2)/a, exact to rounding for small a
    half = np.where(a > 1e-4, np.sin(0.5 * a) / np.where(a > 0, a, 1.0), 0.5 - a * a / 48.0)
    p = np.concatenate([half * theta, np.cos(0.5 * a)], axis=-1)
    v, s = q[..., :3], q[..., 3:]
    pv, ps = p[..., :3], p[..., 3:]
    out = np.concatenate([s * pv + ps * v + np.cross(v, pv), s * ps - np.sum(v * pv, axis=-1, keepdims=True)],
                         axis=-1)
    return normalized(out)


def turn_between(q0: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The rotation vector ``theta`` (in q0's axes, the shorter way) with ``q = q0 * exp(theta / 2)``.

    The inverse of :func:`compose`: ``compose(q0, turn_between(q0, q))``
    is q (normalised, up to its sign).

    Parameters
    ----------
    q0, q : ndarray, shape (m, 4)
        Quaternions, scalar last.

    Returns
    -------
    ndarray, shape (m, 3)
        Rotation vectors, rad (length at most pi).
    """
    q0, q = normalized(q0), normalized(q)
    v0, s0, v, s = q0[..., :3], q0[..., 3:], q[..., :3], q[..., 3:]
    pv = s0 * v - s * v0 - np.cross(v0, v)  # conj(q0) * q
    ps = s0 * s + np.sum(v0 * v, axis=-1, keepdims=True)
    pv = np.where(ps < 0.0, -pv, pv)
    size = np.linalg.norm(pv, axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(size, np.abs(ps))
    return pv * np.where(size > 1e-12, angle / np.where(size > 0, size, 1.0), 2.0 / np.maximum(np.abs(ps), 0.5))


def from_rotation_matrix(R: np.ndarray) -> np.ndarray:
    """The unit quaternions (with ``qw >= 0``) of rotation matrices.

    Parameters
    ----------
    R : ndarray, shape (m, 3, 3)
        Rotation matrices.

    Returns
    -------
    ndarray, shape (m, 4)
        Quaternions, scalar last.
    """
    from scipy.spatial.transform import Rotation

    q = Rotation.from_matrix(np.asarray(R, dtype=float).reshape(-1, 3, 3)).as_quat()
    q *= np.where(q[:, 3:] < 0.0, -1.0, 1.0)
    return q.reshape(np.shape(R)[:-2] + (4,))


def bryant_angles(R: np.ndarray) -> np.ndarray:
    """The Bryant angles ``(rx, ry, rz)`` of rotation matrices, ``R = Rx(rx) Ry(ry) Rz(rz)`` (rad).

    As :class:`flexmb.Spherical` with ``rotation='bryant'`` uses them:
    rotations about x, then the moved y, then the moved z; ``ry`` within
    ``[-pi/2, pi/2]``, singular at its ends.

    Parameters
    ----------
    R : ndarray, shape (..., 3, 3)
        Rotation matrices.

    Returns
    -------
    ndarray, shape (..., 3)
        The angles, rad.
    """
    R = np.asarray(R, dtype=float)
    ry = np.arcsin(np.clip(R[..., 0, 2], -1.0, 1.0))
    rx = np.arctan2(-R[..., 1, 2], R[..., 2, 2])
    rz = np.arctan2(-R[..., 0, 1], R[..., 0, 0])
    return np.stack([rx, ry, rz], axis=-1)


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """The axis-angle views of rotation matrices: the axis times the angle (in ``[0, pi]``), rad.

    Parameters
    ----------
    R : ndarray, shape (..., 3, 3)
        Rotation matrices.

    Returns
    -------
    ndarray, shape (..., 3)
        Rotation vectors.
    """
    from scipy.spatial.transform import Rotation

    R = np.asarray(R, dtype=float)
    return Rotation.from_matrix(R.reshape(-1, 3, 3)).as_rotvec().reshape(R.shape[:-2] + (3,))


def inverse_right_jacobian(theta: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """``J_r(theta)^-1 omega``: the rate of the rotation vector of ``R0 exp([theta]x)`` turning at ``omega``.

    With ``R = R0 exp([theta]x)`` and ``R' = R [omega]x``, ``theta' =
    omega + theta x omega / 2 + c(a) theta x (theta x omega)``, ``a =
    |theta|``, ``c(a) = 1 / a^2 - cot(a / 2) / (2 a)`` (``1/12 + a^2/720``
    for small a). ``J_r(theta)^-T v`` is ``J_r(-theta)^-1 v``.

    Parameters
    ----------
    theta : ndarray, shape (m, 3)
        Rotation vectors, rad (``|theta| < 2 pi``).
    omega : ndarray, shape (m, 3)
        Angular velocities in the rotated axes, rad/s.

    Returns
    -------
    ndarray, shape (m, 3)
        ``theta'``, rad/s.
    """
    a = np.linalg.norm(theta, axis=-1, keepdims=True)
    big = a > 1e-4
    safe = np.where(big, a, 1.0)
    half = 0.5 * safe
    coef = np.where(big, 1.0 / safe**2 - np.cos(half) / (2.0 * safe * np.sin(half)), 1.0 / 12.0 + a * a / 720.0)
    tw = np.cross(theta, omega)
    return omega + 0.5 * tw + coef * np.cross(theta, tw)
