"""A distance constraint: two body points held at a fixed distance (one position row), a massless rod."""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from .._names import reference
from ..bodies import Body
from ..constraints import ConstraintRows
from ..fields import as_array, as_float, positive, vector3
from .base import ConstraintElement

__all__ = ["Distance"]


@frozen(eq=False)
class Distance(ConstraintElement):
    """``|P1 - P2| = length`` between a point of ``body1`` and a point of ``body2``: a massless rod.

    One position row ``phi = |d| - length`` with ``d = P1 - P2``, kept at
    position level (the assembly and the projections close it, so the
    distance does not drift over a long run). With ``e = d / |d|`` and
    ``w = v1 - v2`` the row is ``psi = e^T (V_P1 - V_P2)`` (``V``: the
    points' partial velocities, eq. 17), ``b = 0``, and differentiating
    ``e . w = 0`` along a motion gives ``gamma = -e . (a_P1,0 - a_P2,0) -
    (|w|^2 - (e . w)^2) / |d|`` (``a_P,0``: a point's acceleration at ``xdd
    = 0``). Its multiplier is the rod's tension (N, positive pulling the
    points together).

    Parameters
    ----------
    name : str
        Unique name.
    body1, body2 : Body or str
        The two bodies (either may be the ground, ``"ground"``).
    point1, point2 : array_like, shape (3,)
        The points in their bodies' frames, m.
    length : float
        The distance held, m (> 0).
    """

    body1: Body = reference(Body)
    body2: Body = reference(Body)
    length: float = field(converter=as_float, validator=positive)
    point1: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    point2: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)

    n_position = 1

    def row_names(self) -> list[str]:
        """Names of the rows.

        Returns
        -------
        list of str
            ``['length']``.
        """
        return ["length"]

    def check(self, model) -> list[str]:
        """List the problems with this element in ``model``: a rod from a body to itself.

        Parameters
        ----------
        model : Model
            The model the element belongs to.

        Returns
        -------
        list of str
            One message per problem, naming the element.
        """
        if self.body1 is self.body2:
            body = getattr(self.body1, "name", self.body1)
            return [f"constraint element {self.name!r}: body1 and body2 are the same body {body!r} "
                    "(the distance of two of its points cannot change)"]
        return []

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

        Notes
        -----
        Where the two points coincide (a rod's ends at the reference state
        ``x = 0`` of a model assembled later) the rod has no direction: the
        inertial x axis is taken, and the rod's residual is ``-length``.
        """
        k1, local1 = state.locate(self.body1, self.point1)
        k2, local2 = state.locate(self.body2, self.point2)
        p1, p2 = state.point_position(k1, local1), state.point_position(k2, local2)
        d = p1 - p2
        r = float(np.linalg.norm(d))
        # coincident points (a rod's ends at the reference state x = 0, before the assembly): no direction,
        # the inertial x axis is taken, so the rows are defined and the assembly moves the ends apart along it
        e = d / r if r > 0.0 else np.array([1.0, 0.0, 0.0])
        V = state.point_partials(np.array([k1, k2]), np.stack([p1, p2]))
        w = state.point_velocity(k1, p1) - state.point_velocity(k2, p2)
        a0 = state.point_bias_acceleration(k1, p1) - state.point_bias_acceleration(k2, p2)
        gamma = -e @ a0 - ((w @ w - (e @ w) ** 2) / r if r > 0.0 else 0.0)
        return ConstraintRows(np.array([r - self.length]), (e @ (V[0] - V[1]))[None], np.zeros(1),
                              np.array([gamma]))
