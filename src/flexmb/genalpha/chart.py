"""Generalized-alpha steps for rotations in Euler parameters: the method on the rotation group.

A model with Euler-parameter joints (``rotation='quaternion'``) has the
state ``y = (q, u, w)`` with ``qd = W(q) u`` (:mod:`flexmb.state_layout`):
a quaternion's speeds are the child's angular velocity ``omega`` in its own
axes, ``R' = R [omega]x``, not the rates of any of its coordinates. The
generalized-alpha method of Arnold & Bruels (:mod:`flexmb.genalpha`) is
written for ``xd = v``. On such a rotation it is the method on the Lie
group SO(3) of Bruls & Cardona (2010) [1]_, eqs. (13)-(16) there::

    R1 = R0 exp([h dq]x),   dq = v0 + h (1/2 - beta) abar0 + h beta abar1
    v1 = v0 + h (1 - gamma) abar0 + h gamma abar1
    (1 - alpha_m) abar1 + alpha_m abar0 = (1 - alpha_f) a1 + alpha_f a0

with v = omega and a = omega', the Lie algebra (the body-axes angular
velocities) being one vector space for all steps, so ``v`` and ``abar``
carry over from step to step unchanged. This is the vector method's step
in the **chart** ``R = R0 exp([x]x)`` centred at the step's start: ``x0 =
0``, ``x1 = h dq`` is what the vector step computes from ``x0 + h v0 + ...``.
So the solver runs its compiled vector step (:mod:`flexmb.kernels.genalpha`)
on the chart state ``z = (x, u, w)`` (n positions), where ``x`` is the
coordinate itself where ``W = I`` (a revolute's angle, a slide) and the
rotation vector from the chart's centre on a quaternion's three speeds, and
moves the centre to the step's end after every step (:meth:`RotationChart.recentre`,
``x`` back to 0 there): the motion is unchanged, as when :func:`flexmb.simulate`
moves the offsets of winding angles.

What follows for the solver:

- the state Jacobian's position columns are taken along the chart,
  ``Jx = (da/dq) W(q)`` (exact at its centre, where the Jacobian is
  formed; Newton absorbs the difference at ``x1``, of order ``h |omega|``);
- a rotation's error is weighed as that of an angle of 1 rad: its scale is
  ``atol + rtol`` (rad) plus ``rtol`` times the step's turn, much as an
  integrator of the quaternion's components weighs them (each of size at
  most 1, and half the rotation error);
- the dense output is the vector method's in the chart of the step's start
  (the Hermite cubic's slope at the end the chart rate
  ``x' = J_r(x)^-1 omega``, :func:`flexmb.quaternions.inverse_right_jacobian`), composed back
  to a unit quaternion;
- the Euler parameters stay of unit length to rounding: every state is
  ``R0 exp(x)`` by :meth:`flexmb.state_layout.StateLayout.displace`;
- a projection's move of the state (:meth:`GeneralizedAlpha.move_to
  <flexmb.genalpha.solver.GeneralizedAlpha.move_to>`) is taken in the
  present chart (:meth:`RotationChart.relative`), where the accelerations
  are corrected along ``Jx``; the chart is then centred at the moved state
  (:meth:`RotationChart.enter`).

Arnold, Bruls & Cardona (2015) [2]_ prove this scheme convergent of second
order in ``R`` and ``v``, as the vector method is; the tests measure the
order (errors falling by 4.00 per halved step) on a tumbling body and a
heavy top. Its local error has, besides the vector method's, the term
``h^3 / 12 v x a`` of the chart's kinematics ``x' = J_r(x)^-1 v``, which
the error estimate does not see; on a fast-spinning top the body-axes
angular velocity swings at the spin rate, and the method needs about twice
the steps of Bryant angles (docs/benchmarks.md).

A model without Euler parameters has no chart (``W = I``): the solver
then integrates ``y`` itself, to the same bits as before.

References
----------
.. [1] O. Bruls, A. Cardona, "On the use of Lie group time integrators in
   multibody dynamics", J. Comput. Nonlinear Dyn. 5 (2010) 031002.
.. [2] M. Arnold, O. Bruls, A. Cardona, "Error analysis of generalized-alpha
   Lie group time integration methods for constrained mechanical systems",
   Numer. Math. 129 (2015) 149-179.
"""

from __future__ import annotations

import numpy as np

from ..quaternions import inverse_right_jacobian
from .dense import GeneralizedAlphaDenseOutput

__all__ = ["RotationChart", "ChartDenseOutput"]


class RotationChart:
    """The chart in which generalized-alpha steps a state ``(q, u, w)`` with Euler parameters (module docstring).

    Parameters
    ----------
    layout : StateLayout
        The state's layout (``layout.identity`` false).

    Attributes
    ----------
    centre : ndarray, shape (nq,)
        The chart's centre: the quaternions of the last step's end, zeros
        on the coordinates with ``W = I``.
    rotation : ndarray of bool, shape (n,)
        The speeds that are a quaternion's angular velocity: ``W`` there is
        not the identity (at the reference, ``W = I / 2``).
    """

    def __init__(self, layout):
        self.layout = layout
        self.nq, self.n = layout.nq, layout.n
        reference = layout.reference()
        self.rotation = np.diag(layout.kinematic_matrix(reference)[: self.n]) != 1.0
        self._axes = np.flatnonzero(self.rotation).reshape(-1, 3)  # a joint's three angular speeds are adjacent
        self._plain = np.flatnonzero(~self.rotation)  # the coordinates with W = I (a rotation's sit at its speeds)
        self.centre = reference

    def _centred(self, q):
        """Make ``q``'s rotations the centre (its coordinates with ``W = I`` zero there)."""
        centre = np.array(q, dtype=float)
        centre[self._plain] = 0.0
        self.centre = self.layout.normalized(centre)

    def enter(self, y: np.ndarray) -> np.ndarray:
        """The chart state of ``y``, centred at its own rotations (their chart positions 0).

        Parameters
        ----------
        y : ndarray, shape (nq + n + n_w,)
            A state ``(q, u, w)``.

        Returns
        -------
        ndarray, shape (2 n + n_w,)
            ``z = (x, u, w)``.
        """
        q = y[: self.nq]
        self._centred(q)
        x = np.array(q[: self.n], dtype=float)
        x[self.rotation] = 0.0
        return np.concatenate([x, y[self.nq :]])

    def relative(self, y: np.ndarray, centre: np.ndarray) -> np.ndarray:
        """The chart state of ``y`` in the chart centred at ``centre`` (not moving the chart's own centre).

        Parameters
        ----------
        y : ndarray, shape (nq + n + n_w,)
            A state.
        centre : ndarray, shape (nq,)
            A chart's centre.

        Returns
        -------
        ndarray, shape (2 n + n_w,)
            ``z``: the rotation vectors from ``centre`` on the rotations.
        """
        x = self.layout.difference(y[: self.nq], centre)
        return np.concatenate([x, y[self.nq :]])

    def state(self, z: np.ndarray, centre: np.ndarray | None = None) -> np.ndarray:
        """The state ``(q, u, w)`` at the chart state ``z`` (in the chart centred at ``centre``, default the chart's).

        Parameters
        ----------
        z : ndarray, shape (2 n + n_w,)
            Chart state.
        centre : ndarray, shape (nq,), optional
            Another centre.

        Returns
        -------
        ndarray, shape (nq + n + n_w,)
            ``q = centre exp(x)`` on the rotations, ``x`` elsewhere; u and w as in ``z``.
        """
        q = self.layout.displace(self.centre if centre is None else centre, z[: self.n])
        return np.concatenate([q, z[self.n :]])

    def recentre(self, z: np.ndarray) -> np.ndarray:
        """Move the centre to the rotations of ``z``; the same state in the new chart (rotations at 0).

        Parameters
        ----------
        z : ndarray, shape (2 n + n_w,)
            Chart state (in the present chart).

        Returns
        -------
        ndarray, shape (2 n + n_w,)
            The chart state in the new chart.
        """
        self._centred(self.state(z)[: self.nq])
        out = z.copy()
        out[: self.n][self.rotation] = 0.0
        return out

    def rate(self, fun):
        """The chart's right-hand side ``(u, ud, wd)`` of a state's ``fun(t, y) = (qd, ud, wd)``.

        Its first n entries (the positions' rates) are the speeds; the
        generalized-alpha step never reads them.

        Parameters
        ----------
        fun : callable
            ``fun(t, y)``.

        Returns
        -------
        callable
            ``rate(t, z)``.
        """
        n, nq = self.n, self.nq

        def rate(t, z):
            f = fun(t, self.state(z))
            return np.concatenate([z[n : 2 * n], f[nq:]])

        return rate

    def jacobian(self, J: np.ndarray, z: np.ndarray):
        """``(Jx, Jv)`` along the chart from the state Jacobian ``J`` of ``(q, u, w)`` at ``z``.

        Parameters
        ----------
        J : ndarray, shape (>= nq + n, >= nq + n)
            The state Jacobian.
        z : ndarray, shape (2 n + n_w,)
            The chart state it was formed at.

        Returns
        -------
        Jx, Jv : ndarray, shape (n, n)
            ``(da/dq) W(q)`` and ``da/du``.
        """
        nq, n = self.nq, self.n
        W = self.layout.kinematic_matrix(self.state(z)[:nq])
        return J[nq : nq + n, :nq] @ W, J[nq : nq + n, nq : nq + n].copy()

    def tolerance(self, atol: np.ndarray, rtol: float) -> np.ndarray:
        """The positions' atol with ``rtol`` (an angle of 1 rad) added on the rotations (module docstring).

        Parameters
        ----------
        atol : ndarray, shape (n,)
            Absolute tolerances.
        rtol : float
            Relative tolerance.

        Returns
        -------
        ndarray, shape (n,)
            A new array.
        """
        out = np.array(atol, dtype=float)
        out[self.rotation] += rtol
        return out

    def shift(self, shift: np.ndarray) -> np.ndarray:
        """A move ``y -> y - shift`` of the state's origin (winding angles, never a rotation) in the chart.

        Parameters
        ----------
        shift : ndarray, shape (nq + n + n_w,)
            Zero on the Euler parameters.

        Returns
        -------
        ndarray, shape (2 n + n_w,)
            The same move of ``z``.
        """
        return np.concatenate([shift[: self.n], shift[self.nq :]])

    def end_slope(self, z: np.ndarray) -> np.ndarray:
        """The chart positions' rates at ``z``: the speeds, ``J_r(x)^-1 omega`` on the rotations.

        Parameters
        ----------
        z : ndarray, shape (2 n + n_w,)
            Chart state.

        Returns
        -------
        ndarray, shape (n,)
            ``x'``.
        """
        n = self.n
        x, u = z[:n], z[n : 2 * n]
        out = u.copy()
        out[self._axes] = inverse_right_jacobian(x[self._axes], u[self._axes])
        return out


class ChartDenseOutput(GeneralizedAlphaDenseOutput):
    """The generalized-alpha interpolant in a step's chart, returned as states ``(q, u, w)``.

    Parameters
    ----------
    chart : RotationChart
        The chart (its layout).
    centre : ndarray, shape (nq,)
        The chart's centre over the step (the rotations at its start).
    *args
        As :class:`~flexmb.genalpha.dense.GeneralizedAlphaDenseOutput`, in
        chart states.
    **kwargs
        Its ``slope_new``, from :meth:`RotationChart.end_slope`.
    """

    def __init__(self, chart, centre, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.chart, self.centre = chart, centre

    def _call_impl(self, t):
        z = super()._call_impl(t)
        if z.ndim == 1:
            return self.chart.state(z, self.centre)
        return np.column_stack([self.chart.state(z[:, k], self.centre) for k in range(z.shape[1])])
