"""Motion of body points from a result: positions and exact velocities from the kinematics of each output state."""

from __future__ import annotations

import numpy as np

__all__ = ["point_motion"]


def point_motion(res, system, body, point) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity of a body point at every output time, exact from the state.

    Parameters
    ----------
    res : Result
        A result of ``system``.
    system : System
        The system the result came from.
    body : Body or str
        The body (rigid or flexible), or its name.
    point : array_like, shape (3,)
        The point in the body's frame, m (on a flexible body: along its
        undeformed centre line, carried by the segment it falls in).

    Returns
    -------
    position, velocity : ndarray, shape (nt, 3)
        Inertial position (m) and velocity (m/s).

    Notes
    -----
    The velocity is ``v_k + omega_k x (p - r_k)`` of the body row carrying
    the point (eq. 17), from the kinematics at each output state
    ``(t, x, xd)``: no differences of sampled positions.
    """
    if isinstance(body, str):
        body = system.model[body]
    k, local = system.topology.locate(body, np.asarray(point, dtype=float))
    nt = len(res.t)
    p, v = np.empty((nt, 3)), np.empty((nt, 3))
    for i in range(nt):  # one compiled kinematics per output time
        kin = system.kinematics(res.t[i], res.x[i], res.xd[i])
        p[i] = kin.point_position(k, local)
        v[i] = kin.point_velocity(k, p[i])
    return p, v
