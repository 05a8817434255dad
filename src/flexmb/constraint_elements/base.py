"""The constraint element base class: rows ``phi = 0`` or ``B xd = b`` that a user writes in Python.

A constraint element adds rows to the model's constraints beside the cut
joints' and the drivers' (:class:`flexmb.constraints.Constraints`):

* **position rows** ``phi(x, t) = 0``, given with ``psi = dphi/dx``,
  ``b = -dphi/dt`` and ``gamma`` (``psi xdd = gamma``), exactly as the loop
  rows (eqs. 28-29): the assembly and the projections close them;
* **velocity rows** ``B(x, t) xd = b(x, t)`` with ``gamma = -Bdot xd +
  bdot`` (``B xdd = gamma``), which have no position form (a rolling wheel,
  a knife edge): they enter psi, the orthogonal complement, the speed
  projections and the reactions, never the position projection.

docs/constraints.md derives how both kinds enter eqs. 30-39.
"""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from .._validate import name_check
from ..constraints import ConstraintRows
from ..errors import AssemblyError

__all__ = ["ConstraintElement", "velocity_rows"]


@frozen(eq=False)
class ConstraintElement:
    """Base class of constraint elements (position rows first, then velocity rows).

    Subclasses must:

    1. have a ``name`` and the element's data as attrs fields (a body or a
       joint by :func:`flexmb.reference`, so that a name is resolved when
       the model is built);
    2. set the class attributes (or properties) ``n_position`` and
       ``n_velocity``: how many rows of each kind the element adds;
    3. implement ``rows(state)``, returning ``(phi, psi, b, gamma)`` (a
       tuple, or a :class:`~flexmb.constraints.ConstraintRows`) with ``phi``
       of shape ``(n_position,)`` and ``psi`` (n_rows x n), ``b``, ``gamma``
       (n_rows) for all rows, position rows first. :func:`velocity_rows`
       builds it for an element of velocity rows only.

    ``state`` is the model's :class:`~flexmb.kinematics.Kinematics`: ``t``,
    ``x``, ``xd``, ``R``, ``r``, ``omega``, ``v``, the bias accelerations
    ``alpha_bias``, ``a_bias`` (at ``xdd = 0``) and the look-ups
    ``index(body)``, ``locate(body, point)``, ``coordinate_slice(joint)``,
    ``point_position``, ``point_velocity``, ``point_bias_acceleration``,
    ``point_partials``, ``angular_partials``.

    Parameters
    ----------
    name : str
        Unique name of the element.

    Examples
    --------
    A gear pair between two revolute joints, ``q1 + k q2 = 0`` (one
    position row):

    >>> import numpy as np
    >>> from attrs import frozen
    >>> import flexmb as fm
    >>> @frozen(eq=False)
    ... class Gear(fm.ConstraintElement):
    ...     joint1: fm.Joint = fm.reference(fm.Joint)
    ...     joint2: fm.Joint = fm.reference(fm.Joint)
    ...     k: float = 2.0
    ...     n_position = 1
    ...
    ...     def rows(self, state):
    ...         i = state.coordinate_slice(self.joint1).start
    ...         j = state.coordinate_slice(self.joint2).start
    ...         psi = np.zeros((1, state.xd.shape[0]))
    ...         psi[0, i], psi[0, j] = 1.0, self.k  # per speed (a revolute's speed is its angle's rate)
    ...         return np.array([state.x[i] + self.k * state.x[j]]), psi, np.zeros(1), np.zeros(1)
    >>> m = fm.Model()
    >>> a = fm.RigidBody("a", 1.0, (1.0, 1.0, 1.0))
    >>> b = fm.RigidBody("b", 1.0, (1.0, 1.0, 1.0))
    >>> _ = m.add(fm.Revolute("p1", m.ground, a), fm.Revolute("p2", m.ground, b), Gear("gear", "p1", "p2"))
    >>> m.build().dof()
    1
    """

    name: str = field(validator=name_check)

    #: Number of position rows ``phi = 0`` (first).
    n_position = 0
    #: Number of velocity rows ``B xd = b`` (after the position rows).
    n_velocity = 0

    def row_names(self) -> list[str]:
        """Names of the rows (the constraint labels are ``"<element>.<row>"``).

        Returns
        -------
        list of str
            ``n_position + n_velocity`` names; default ``"0"``, ``"1"``, ...
        """
        return [str(i) for i in range(self.n_position + self.n_velocity)]

    def rows(self, state) -> ConstraintRows:
        """The element's rows at a state.

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        tuple of ndarray
            ``(phi, psi, b, gamma)``: ``phi`` (n_position), ``psi`` (n_rows
            x n), ``b`` and ``gamma`` (n_rows).
        """
        raise NotImplementedError(f"{type(self).__name__} must implement rows(state)")

    def check(self, model) -> list[str]:
        """List the problems with this element in ``model`` (called by :meth:`flexmb.Model.validate`).

        Parameters
        ----------
        model : Model
            The model the element belongs to.

        Returns
        -------
        list of str
            One message per problem, naming the element (empty if none).
        """
        return []

    def checked_rows(self, state) -> ConstraintRows:
        """:meth:`rows`, with their shapes and values checked; what is wrong names the element.

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        ConstraintRows
            Float arrays of the documented shapes.

        Raises
        ------
        AssemblyError
            If :meth:`rows` fails, returns arrays of the wrong shapes or
            non-finite values (``.t``: the time).
        """
        n, k, kp = state.xd.shape[0], self.n_position + self.n_velocity, self.n_position
        what = f"constraint element {self.name!r} ({type(self).__name__})"
        try:
            out = self.rows(state)
            phi, psi, b, gamma = (np.asarray(a, dtype=float) for a in out)
        except AssemblyError:
            raise
        except Exception as exc:
            err = AssemblyError(f"at t = {state.t:.9g} s: {what} failed: {type(exc).__name__}: {exc}")
            err.t = state.t
            raise err from exc
        for name, a, shape in (("phi", phi, (kp,)), ("psi", psi, (k, n)), ("b", b, (k,)), ("gamma", gamma, (k,))):
            if a.shape != shape:
                err = AssemblyError(f"{what}: rows() gave {name} of shape {a.shape}, expected {shape} "
                                    f"({kp} position and {self.n_velocity} velocity rows, {n} coordinates)")
                err.t = state.t
                raise err
            if not np.all(np.isfinite(a)):
                err = AssemblyError(f"at t = {state.t:.9g} s: {what} gave a non-finite {name}")
                err.t = state.t
                raise err
        return ConstraintRows(phi, psi, b, gamma)


def velocity_rows(B, b, gamma) -> ConstraintRows:
    """The :class:`~flexmb.constraints.ConstraintRows` of velocity rows ``B xd = b``, ``B xdd = gamma``.

    Parameters
    ----------
    B : array_like, shape (k, n)
        The rows.
    b : array_like, shape (k,)
        Their right-hand side.
    gamma : array_like, shape (k,)
        ``-Bdot xd + bdot``.

    Returns
    -------
    ConstraintRows
        With an empty ``phi``.
    """
    return ConstraintRows(np.zeros(0), np.atleast_2d(np.asarray(B, dtype=float)), np.atleast_1d(b),
                          np.atleast_1d(gamma))
