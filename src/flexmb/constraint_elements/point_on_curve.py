"""A body point held on a curve fixed in another body (or the ground): two position rows.

:class:`PointOnLine` and :class:`PointOnCircle` are the curves a scene file
names; :class:`PointOnCurve` takes any parametric curve a user writes in
Python. All three share the rows of :class:`CurveConstraint`; a subclass
only finds the curve's point nearest a given point.
"""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from .._names import reference
from ..bodies import Body
from ..constraints import ConstraintRows
from ..errors import AssemblyError, ModelError
from ..fields import (as_array, as_count, as_float, as_unit_vector, count, finite_number, label, positive,
                      unit_vector, vector3)
from ..rotations import frame_from_axis
from .base import ConstraintElement

__all__ = ["CurveConstraint", "PointOnCircle", "PointOnCurve", "PointOnLine"]


def _fail(state, element, problem: str):
    err = AssemblyError(f"at t = {state.t:.9g} s: constraint element {element.name!r} ({type(element).__name__}): "
                        f"{problem}")
    err.t = state.t
    raise err


@frozen(eq=False)
class CurveConstraint(ConstraintElement):
    """Base of the point-on-curve elements: a point P of ``body`` on a curve ``c(s)`` fixed in ``on``.

    The curve is given in the frame of ``on`` (the ground by default). With
    ``p`` the point P in that frame and ``s*`` the parameter of the
    curve's point nearest it (:meth:`closest`), the two position rows are
    ``phi_i = N_i . (p - c(s*))`` for two unit normals ``N_1``, ``N_2`` of
    the curve at ``s*`` (:meth:`normals`; any pair spanning the normal
    plane holds the same constraint). On the curve, their Jacobian is
    ``psi_i = n_i^T (V_P - V_B)`` with ``n_i = R_B N_i`` in inertial axes and
    ``V_B`` the partial velocities of the point of ``on`` under P (eq. 17);
    ``b = 0``. P on the curve means ``p = c(s(t))``, so ``p'' = c'' s'^2 + c'
    s''`` in the frame of ``on``: its normal components are ``N_i . c''
    s'^2`` with ``s' = c' . p' / |c'|^2``, and with ``R_B p'' = a_P - a_B - 2
    omega_B x w`` (``w = v_P - v_B``, the velocity relative to ``on``)

        gamma_i = n_i . (R_B c'' s'^2 + 2 omega_B x w - a_P,0 + a_B,0)

    (``a_P,0``, ``a_B,0``: the accelerations at ``xdd = 0``). The two
    multipliers are the normal force the curve exerts on P along ``n_1``
    and ``n_2`` (N).

    A subclass sets its curve's data as attrs fields and implements
    :meth:`closest`; :meth:`normals` defaults to two vectors perpendicular
    to the tangent.

    Parameters
    ----------
    name : str
        Unique name.
    body : Body or str
        The body carrying the point.
    point : array_like, shape (3,)
        The point in the body's frame, m.
    on : Body or str
        The body the curve is fixed in (default the ground).
    """

    body: Body = reference(Body)
    point: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3, kw_only=True)
    on: Body = reference(Body, default="ground", kw_only=True)

    n_position = 2

    def row_names(self) -> list[str]:
        """Names of the rows.

        Returns
        -------
        list of str
            ``['normal1', 'normal2']``.
        """
        return ["normal1", "normal2"]

    def check(self, model) -> list[str]:
        """List the problems with this element in ``model``: a curve fixed in the point's own body.

        Parameters
        ----------
        model : Model
            The model the element belongs to.

        Returns
        -------
        list of str
            One message per problem, naming the element.
        """
        if self.body is self.on:
            body = getattr(self.body, "name", self.body)
            return [f"constraint element {self.name!r}: body and on are the same body {body!r} (a point of a body "
                    "cannot move along a curve fixed in that body)"]
        return []

    def closest(self, p):
        """The curve's point nearest ``p``, and the curve's derivatives there (in the frame of ``on``).

        Parameters
        ----------
        p : ndarray, shape (3,)
            A point in the frame of ``on``, m.

        Returns
        -------
        c, dc, ddc : ndarray, shape (3,)
            ``c(s*)``, ``dc/ds`` and ``d2c/ds2`` at the nearest point ``s*``.

        Raises
        ------
        ValueError
            If the nearest point is not defined (the message says why).
        """
        raise NotImplementedError(f"{type(self).__name__} must implement closest(p)")

    def normals(self, c, dc, ddc) -> np.ndarray:
        """Two unit normals of the curve at a point, in the frame of ``on``.

        Parameters
        ----------
        c, dc, ddc : ndarray, shape (3,)
            What :meth:`closest` returned.

        Returns
        -------
        ndarray, shape (2, 3)
            Orthonormal, perpendicular to ``dc``.
        """
        return frame_from_axis(dc)[:, :2].T

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

        Raises
        ------
        AssemblyError
            If the curve's nearest point is not defined there.
        """
        k, local = state.locate(self.body, self.point)
        P = state.point_position(k, local)
        kb, _ = state.locate(self.on, np.zeros(3))
        RB, OB = state.R[kb], state.origin[kb]
        try:
            c, dc, ddc = (np.asarray(a, dtype=float).reshape(3) for a in self.closest(RB.T @ (P - OB)))
        except ValueError as exc:
            _fail(state, self, str(exc))
        N = self.normals(c, dc, ddc)
        n = N @ RB.T  # rows n_i = R_B N_i
        w = state.point_velocity(k, P) - state.point_velocity(kb, P)
        V = state.point_partials(np.array([k, kb]), np.stack([P, P]))
        sd = (RB @ dc) @ w / (dc @ dc)
        acc = (RB @ ddc) * sd**2 + 2.0 * np.cross(state.omega[kb], w) - state.point_bias_acceleration(k, P) \
            + state.point_bias_acceleration(kb, P)
        return ConstraintRows(N @ (RB.T @ (P - OB) - c), n @ (V[0] - V[1]), np.zeros(2), n @ acc)


@frozen(eq=False)
class PointOnLine(CurveConstraint):
    """A body point on a straight line fixed in another body (a slider on a rod, a bead on a wire).

    Parameters
    ----------
    name : str
        Unique name.
    body : Body or str
        The body carrying the point.
    point : array_like, shape (3,)
        The point in the body's frame, m.
    on : Body or str
        The body the line is fixed in (default the ground).
    origin : array_like, shape (3,)
        A point of the line in the frame of ``on``, m.
    direction : array_like, shape (3,)
        The line's direction in the frame of ``on`` (normalised).
    """

    origin: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3, kw_only=True)
    direction: np.ndarray = field(default=(1.0, 0.0, 0.0), converter=as_unit_vector, validator=unit_vector,
                                  kw_only=True)

    def closest(self, p):
        """The line's point nearest ``p`` and the line's derivatives (see :meth:`CurveConstraint.closest`).

        Parameters
        ----------
        p : ndarray, shape (3,)
            A point in the frame of ``on``, m.

        Returns
        -------
        c, dc, ddc : ndarray, shape (3,)
            The foot of the perpendicular from ``p``, the direction and 0.
        """
        u = self.direction
        return self.origin + u * (u @ (p - self.origin)), u, np.zeros(3)

    def normals(self, c, dc, ddc) -> np.ndarray:
        """Two unit normals of the line (constant along it).

        Parameters
        ----------
        c, dc, ddc : ndarray, shape (3,)
            What :meth:`closest` returned.

        Returns
        -------
        ndarray, shape (2, 3)
            Orthonormal, perpendicular to the direction.
        """
        return frame_from_axis(self.direction)[:, :2].T


@frozen(eq=False)
class PointOnCircle(CurveConstraint):
    """A body point on a circle fixed in another body (a bead on a hoop, a pendulum's bob on its path).

    The normals are the circle's radial direction and its axis, so the
    multipliers are the radial (positive outward from the centre) and the
    axial force on the point.

    Parameters
    ----------
    name : str
        Unique name.
    body : Body or str
        The body carrying the point.
    point : array_like, shape (3,)
        The point in the body's frame, m.
    on : Body or str
        The body the circle is fixed in (default the ground).
    centre : array_like, shape (3,)
        The circle's centre in the frame of ``on``, m.
    normal : array_like, shape (3,)
        The axis of the circle's plane in the frame of ``on`` (normalised).
    radius : float
        The radius, m.
    """

    radius: float = field(converter=as_float, validator=positive, kw_only=True)
    centre: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3, kw_only=True)
    normal: np.ndarray = field(default=(0.0, 0.0, 1.0), converter=as_unit_vector, validator=unit_vector,
                               kw_only=True)

    def row_names(self) -> list[str]:
        """Names of the rows.

        Returns
        -------
        list of str
            ``['radial', 'axial']``.
        """
        return ["radial", "axial"]

    def closest(self, p):
        """The circle's point nearest ``p`` and the circle's derivatives by arc angle.

        Parameters
        ----------
        p : ndarray, shape (3,)
            A point in the frame of ``on``, m.

        Returns
        -------
        c, dc, ddc : ndarray, shape (3,)
            ``C + r e``, ``r (a x e)`` and ``-r e``, with ``a`` the axis
            and ``e`` the radial unit vector towards ``p`` (on the axis,
            where every point of the circle is as near, the x axis of
            ``frame_from_axis(normal)``).
        """
        a = self.normal
        q = p - self.centre
        q = q - a * (a @ q)
        rq = float(np.linalg.norm(q))
        # on the axis every point of the circle is as near: the one along the frame's x axis is taken
        e = q / rq if rq > 0.0 else frame_from_axis(a)[:, 0]
        return self.centre + self.radius * e, self.radius * np.cross(a, e), -self.radius * e

    def normals(self, c, dc, ddc) -> np.ndarray:
        """The radial direction (outward) and the circle's axis.

        Parameters
        ----------
        c, dc, ddc : ndarray, shape (3,)
            What :meth:`closest` returned.

        Returns
        -------
        ndarray, shape (2, 3)
            ``(e, a)``.
        """
        return np.stack([(c - self.centre) / self.radius, self.normal])


def _callable(instance, attribute, value):
    if not callable(value):
        raise ModelError(f"{label(instance)}: {attribute.name} must be a function s -> (c, dc/ds, d2c/ds2), got "
                         f"{type(value).__name__} {value!r}")


def _interval(value):
    try:
        a, b = (float(v) for v in value)
    except (TypeError, ValueError):
        return value
    return (a, b)


def _check_interval(instance, attribute, value):
    if not (isinstance(value, tuple) and len(value) == 2 and all(np.isfinite(value)) and value[0] < value[1]):
        raise ModelError(f"{label(instance)}: {attribute.name} must be two finite parameters (s_min, s_max) with "
                         f"s_min < s_max, got {value!r}")


@frozen(eq=False)
class PointOnCurve(CurveConstraint):
    """A body point on a parametric curve ``c(s)``, ``s_min <= s <= s_max``, written by the user in Python.

    The nearest point is found by sampling the curve at ``samples`` equally
    spaced parameters, then Newton's method on ``c'(s) . (c(s) - p) = 0``
    from the nearest sample (to 1e-13 of the parameter range). A closed
    curve (``closed=True``: ``c(s_min) = c(s_max)``) wraps the parameter
    around; on an open curve, a nearest point at an end means the point has
    run off the curve, which is refused.

    Parameters
    ----------
    name : str
        Unique name.
    body : Body or str
        The body carrying the point.
    point : array_like, shape (3,)
        The point in the body's frame, m.
    on : Body or str
        The body the curve is fixed in (default the ground).
    curve : callable
        ``curve(s)`` returns ``(c, dc, ddc)``: the curve's point, its first
        and second derivatives by ``s``, each of shape (3,), in the frame of
        ``on`` (m, m, m). ``dc`` must not vanish.
    bounds : tuple of float
        ``(s_min, s_max)``.
    closed : bool
        The curve closes on itself (default False).
    samples : int
        Samples of the first, global search (default 64). More than the
        curve's wiggles between the bounds, so the nearest sample lies in the
        nearest point's basin.

    Examples
    --------
    A cycloid in the x-z plane of the ground, lowest at the origin: a bead
    on it swings with a period ``4 pi sqrt(r / g)`` at any amplitude (the
    tautochrone).

    >>> import numpy as np
    >>> import flexmb as fm
    >>> r = 0.5
    >>> def cycloid(s):
    ...     return (r * np.array([s + np.sin(s), 0.0, 1.0 - np.cos(s)]),
    ...             r * np.array([1.0 + np.cos(s), 0.0, np.sin(s)]), r * np.array([-np.sin(s), 0.0, np.cos(s)]))
    >>> track = fm.PointOnCurve("track", "bead", curve=cycloid, bounds=(-3.0, 3.0))
    """

    curve: object = field(validator=_callable, kw_only=True)
    bounds: tuple = field(converter=_interval, validator=_check_interval, kw_only=True)
    closed: bool = field(default=False, kw_only=True)
    samples: int = field(default=64, converter=as_count, validator=count, kw_only=True)

    def _eval(self, s):
        out = self.curve(float(s))
        try:
            c, dc, ddc = (np.asarray(a, dtype=float).reshape(3) for a in out)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"curve({s!r}) must return three 3-vectors (c, dc/ds, d2c/ds2): {exc}") from None
        return c, dc, ddc

    def closest(self, p):
        """The curve's point nearest ``p`` (sampling, then Newton), with the curve's derivatives there.

        Parameters
        ----------
        p : ndarray, shape (3,)
            A point in the frame of ``on``, m.

        Returns
        -------
        c, dc, ddc : ndarray, shape (3,)
            ``c(s*)``, ``dc/ds`` and ``d2c/ds2`` at the nearest point.

        Raises
        ------
        ValueError
            If the curve returns malformed values, its tangent vanishes, the
            Newton iteration does not converge, or (an open curve) the
            nearest point is an end.
        """
        lo, hi = self.bounds
        span = hi - lo
        grid = np.linspace(lo, hi, self.samples + 1)
        s = grid[int(np.argmin([np.sum((self._eval(g)[0] - p) ** 2) for g in grid]))]
        for _ in range(50):
            c, dc, ddc = self._eval(s)
            f, df = dc @ (c - p), dc @ dc + ddc @ (c - p)
            if not dc @ dc > 0.0:
                raise ValueError(f"the curve's tangent vanishes at s = {s:.9g}")
            step = -f / df if df > 0.0 else -f / (dc @ dc)
            s_new = s + step
            if self.closed:
                s_new = lo + (s_new - lo) % span
            elif s_new <= lo or s_new >= hi:
                raise ValueError(f"the point has run off the curve: its nearest point is beyond an end (s in "
                                 f"[{lo:g}, {hi:g}])")
            done = abs(step) <= 1e-13 * span
            s = s_new
            if done:
                return self._eval(s)
        raise ValueError(f"the nearest point of the curve was not found (Newton's method did not converge near "
                         f"s = {s:.9g})")
