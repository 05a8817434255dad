"""A knife edge: a body point that cannot move along a body-fixed direction (one velocity row)."""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from .._names import reference
from ..bodies import Body
from ..fields import as_array, as_unit_vector, unit_vector, vector3
from .base import ConstraintElement, velocity_rows

__all__ = ["KnifeEdge"]


@frozen(eq=False)
class KnifeEdge(ConstraintElement):
    """A blade at a body point that slides along itself only, ``n^T v_P = 0`` (nonholonomic).

    ``n`` is the body-fixed unit normal of the blade (the direction the
    point may not move in), ``v_P`` the velocity of the point. The row is
    ``B = n^T V_P`` (``V_P`` the point's partial velocities, eq. 17),
    ``b = 0``, and ``gamma = -(omega x n) . v_P - n . a_P0`` with ``a_P0``
    the point's acceleration at ``xdd = 0``. The Chaplygin sleigh is a body
    on such a blade.

    Parameters
    ----------
    name : str
        Unique name.
    body : Body or str
        The body carrying the blade.
    point : array_like, shape (3,)
        The blade's contact point in the body frame, m.
    normal : array_like, shape (3,)
        The direction, in the body frame, along which the point may not
        move (normalised).
    """

    body: Body = reference(Body)
    point: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    normal: np.ndarray = field(default=(0.0, 1.0, 0.0), converter=as_unit_vector, validator=unit_vector)

    n_velocity = 1

    def row_names(self) -> list[str]:
        """Names of the rows.

        Returns
        -------
        list of str
            ``['normal']``.
        """
        return ["normal"]

    def rows(self, state):
        """The rows at a state (see :meth:`ConstraintElement.rows`).

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        ConstraintRows
            ``phi``, ``psi``, ``b`` and ``gamma``.
        """
        k, local = state.locate(self.body, self.point)
        p = state.point_position(k, local)
        n = state.R[k] @ self.normal
        v = state.point_velocity(k, p)
        B = n @ state.point_partials(np.array([k]), p[None])[0]
        gamma = -np.cross(state.omega[k], n) @ v - n @ state.point_bias_acceleration(k, p)
        return velocity_rows(B[None], np.zeros(1), np.array([gamma]))
