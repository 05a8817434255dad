"""Motion histories in the user's terms: a body point's position, velocity and acceleration, a body's angular velocity.

A benchmark states its reference as the motion of a point (IFToMM A02: the
crank tip's position and velocity) or a body's angular velocity; these
compose them from the stored states and the system's kinematics (eqs.
6-18): ``p = R_k s + o_k``, ``v_P = v_k + omega_k x (p - r_k)`` and
``a_P = a_bias,P + V_P xdd`` (eq. 17 and its derivative).
"""

from __future__ import annotations

import numpy as np

from .._validate import state_vector
from ..bodies import Body
from ..errors import ModelError

__all__ = ["point_motion", "angular_velocity"]

#: what each derivative order is called, for messages
_NAMES = ("point_position", "point_velocity", "point_acceleration")


def _system(result, system, where):
    from ..model import as_system

    system = system if system is not None else result.system
    if system is None:
        raise ModelError(f"Result.{where} needs the system the result came from (a loaded result does not keep "
                         f"it): res.{where}(..., system=system)")
    system = as_system(system)
    if len(system.coordinate_names) != result.x.shape[1] or list(system.coordinate_names) != list(
            result.coordinate_names):
        raise ModelError(f"Result.{where}: the system's coordinates {system.coordinate_names[:4]}... are not the "
                         f"result's {list(result.coordinate_names)[:4]}...: give the system the result came from")
    return system


def _located(system, body, point, where):
    body = system.model.element(body, Body)
    point = state_vector(f"Result.{where}", "point", point, 3)
    k, local = system.topology.locate(body, point)
    return body, k, local, point


def point_motion(result, body, point=(0.0, 0.0, 0.0), derivative=0, system=None):
    """Position, velocity or acceleration history of a point fixed in a body.

    Parameters
    ----------
    result : Result
        A simulation result.
    body : Body or str
        The body (rigid or flexible; on a flexible body the point is
        carried by the segment it lies on), or its name.
    point : array_like, shape (3,)
        The point in the body's frame, m (default its origin).
    derivative : {0, 1, 2} or tuple of them
        Position (m), velocity (m/s) or acceleration (m/s^2); a tuple gives
        each, from one pass over the output states.
    system : System or Model, optional
        The model the result came from (default ``result.system``).

    Returns
    -------
    ndarray, shape (nt, 3), or tuple of them
        Inertial components at the output times.

    Raises
    ------
    ModelError
        If the body is not in the model, the point is not 3 finite numbers,
        or no system is known.

    Notes
    -----
    Exact at each output state ``(t, x, xd, xdd)`` (eq. 17 and its
    derivative), not differences of sampled positions.
    """
    orders = derivative if isinstance(derivative, tuple) else (derivative,)
    if not orders or any(d not in (0, 1, 2) for d in orders):
        raise ModelError(f"point motion: derivative must be 0, 1 or 2 (or a tuple of them), got {derivative!r}")
    where = _NAMES[orders[0]]
    system = _system(result, system, where)
    _, k, local, point = _located(system, body, point, where)
    nt = result.t.shape[0]
    out = {d: np.empty((nt, 3)) for d in orders}
    if k < 0:  # a point of the ground: it stays where it is
        for d in orders:
            out[d][:] = point if d == 0 else 0.0
    rows = np.array([k])
    for i in range(nt if k >= 0 else 0):
        kin = system.kinematics(result.t[i], result.x[i], result.xd[i])
        p = kin.point_position(k, local)
        for d in orders:
            if d == 0:
                out[d][i] = p
            elif d == 1:
                out[d][i] = kin.point_velocity(k, p)
            else:
                out[d][i] = kin.point_bias_acceleration(k, p) + kin.point_partials(rows, p[None])[0] @ result.xdd[i]
    return tuple(out[d] for d in orders) if isinstance(derivative, tuple) else out[derivative]


def angular_velocity(result, body, frame: str = "inertial", point=(0.0, 0.0, 0.0), system=None) -> np.ndarray:
    """Angular velocity history of a body (of the segment carrying ``point``, on a flexible body).

    Parameters
    ----------
    result : Result
        A simulation result.
    body : Body or str
        The body, or its name.
    frame : {'inertial', 'body'}
        The axes of the components: inertial, or the body's own frame.
    point : array_like, shape (3,)
        On a flexible body, a point (body frame, m) on the segment meant
        (default the root segment); ignored for a rigid body.
    system : System or Model, optional
        The model the result came from (default ``result.system``).

    Returns
    -------
    ndarray, shape (nt, 3)
        rad/s.

    Raises
    ------
    ModelError
        If ``frame`` is neither, or as :func:`point_motion`.
    """
    if frame not in ("inertial", "body"):
        raise ModelError(f"Result.angular_velocity: frame must be 'inertial' or 'body', got {frame!r}")
    system = _system(result, system, "angular_velocity")
    _, k, _, _ = _located(system, body, point, "angular_velocity")
    nt = result.t.shape[0]
    if k < 0:
        return np.zeros((nt, 3))
    out = np.empty((nt, 3))
    for i in range(nt):
        kin = system.kinematics(result.t[i], result.x[i], result.xd[i])
        out[i] = kin.omega[k] if frame == "inertial" else kin.R[k].T @ kin.omega[k]
    return out
