"""A thin disc rolling without slipping on a plane: one position row (contact) and two velocity rows (no slip)."""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from .._names import reference
from ..bodies import Body
from ..constraints import ConstraintRows
from ..errors import AssemblyError
from ..fields import as_array, as_float, as_unit_vector, finite_number, positive, unit_vector, vector3
from ..rotations import frame_from_axis
from .base import ConstraintElement

__all__ = ["RollingDisc"]


@frozen(eq=False)
class RollingDisc(ConstraintElement):
    """A thin disc (a wheel's rim) rolling without slipping on the plane ``normal^T p = height``.

    With ``a`` the disc's axis and ``k`` the plane's unit normal (inertial),
    the rim point nearest the plane is ``P = C - radius d``, ``d`` the unit
    vector along ``k - (k . a) a`` (in the disc's plane, up). Rolling without
    slipping is ``v_P = 0`` for the disc's material point at P, in three rows
    ``e^T V_P xd = 0`` (``V_P``: its partial velocities, eq. 17), for ``e``
    = ``k`` and two fixed directions ``t1``, ``t2`` in the plane:

    * along ``k`` the row is holonomic: it is the time derivative of the
      contact condition ``phi = k . P - height = 0`` (P slides along the rim
      perpendicular to ``k``), kept as a position row;
    * along ``t1``, ``t2`` (no slip) the rows are velocity rows.

    Each row's ``gamma = -e . (a_C0 + alpha_0 x (P - C) - radius omega x
    d')``: ``a_C0``, ``alpha_0`` the centre's and the disc's accelerations
    at ``xdd = 0``, ``d'`` the rate of ``d``; the derivation is in
    docs/constraints.md.

    Parameters
    ----------
    name : str
        Unique name.
    body : Body or str
        The disc.
    radius : float
        The disc's radius, m.
    centre : array_like, shape (3,)
        The disc's centre in the body frame, m.
    axis : array_like, shape (3,)
        The disc's axis in the body frame (normalised).
    normal : array_like, shape (3,)
        The plane's normal, inertial (normalised), pointing to the disc's
        side.
    height : float
        The plane's offset along ``normal``, m.
    """

    body: Body = reference(Body)
    radius: float = field(converter=as_float, validator=positive)
    centre: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    axis: np.ndarray = field(default=(0.0, 0.0, 1.0), converter=as_unit_vector, validator=unit_vector)
    normal: np.ndarray = field(default=(0.0, 0.0, 1.0), converter=as_unit_vector, validator=unit_vector)
    height: float = field(default=0.0, converter=as_float, validator=finite_number)

    n_position = 1
    n_velocity = 2

    def row_names(self) -> list[str]:
        """Names of the rows.

        Returns
        -------
        list of str
            ``['contact', 'slip1', 'slip2']``.
        """
        return ["contact", "slip1", "slip2"]

    def contact_point(self, state):
        """The rim point nearest the plane, and the disc's geometry there.

        Parameters
        ----------
        state : Kinematics
            The kinematic state.

        Returns
        -------
        k : int
            The disc's row in the per-body arrays.
        C, P : ndarray, shape (3,)
            Centre and contact point, inertial, m.
        a, d : ndarray, shape (3,)
            The disc's axis and the unit vector from P to C.
        s : float
            ``|k - (k . a) a|``: the sine of the angle between the axis and the normal.
        """
        k, local = state.locate(self.body, self.centre)
        C = state.point_position(k, local)
        a = state.R[k] @ self.axis
        n = self.normal
        sv = n - (n @ a) * a
        s = float(np.linalg.norm(sv))
        if not s > 1e-9:
            err = AssemblyError(f"at t = {state.t:.9g} s: constraint element {self.name!r} (RollingDisc): the disc "
                                "lies flat on the plane (its axis is along the normal): the contact point is not "
                                "defined")
            err.t = state.t
            raise err
        d = sv / s
        return k, C, C - self.radius * d, a, d, s

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
        k, C, P, a, d, s = self.contact_point(state)
        n = self.normal
        w = state.omega[k]
        a_dot = np.cross(w, a)
        s_dot = -(n @ a_dot) * a - (n @ a) * a_dot
        d_dot = (s_dot - d * (d @ s_dot)) / s
        acc = state.point_bias_acceleration(k, C) + np.cross(state.alpha_bias[k], P - C) \
            - self.radius * np.cross(w, d_dot)
        frame = frame_from_axis(n)
        E = np.stack([n, frame[:, 0], frame[:, 1]])  # the normal, then two fixed directions in the plane
        psi = E @ state.point_partials(np.array([k]), P[None])[0]
        return ConstraintRows(np.array([n @ P - self.height]), psi, np.zeros(3), -E @ acc)
