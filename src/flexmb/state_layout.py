"""The state vector's layout: coordinates q, speeds u, then the tracked works.

A run integrates ``y = (q, u, w)``: the ``nq`` generalized coordinates q,
the ``n`` generalized speeds u (Kane's equations, the partial velocities,
the mass matrix, the constraint Jacobian psi and the accelerations ``ud``
are all per speed) and, with ``track_work``, the works w. The coordinates
follow the speeds by the kinematic equations

    qd = W(q) u,        nq >= n.

A correction or a perturbation of the coordinates is a vector of speed
size (a step along the partial velocities), applied by :meth:`displace`:
``q + W(q) du`` followed by whatever keeps q on its own manifold
(:meth:`normalized`).

The coordinates come in two blocks: first one coordinate per speed, in
the speeds' order, then the coordinates a joint has beyond its speeds
(its last ones), joint after joint. A joint whose speeds are its
coordinates' rates (a revolute, a slider, the Bryant angles of
:class:`~flexmb.Spherical`) has ``W = I`` there: its coordinate i and its
speed i share one index, so that every table built on joint coordinates
(springs, drivers, a flexible body's elastic angles, the compiled
kernels) reads the speeds at the coordinates' indices. A rotation in Euler
parameters (``rotation='quaternion'``, :mod:`flexmb.quaternions`) puts
``qx, qy, qz`` at its angular speeds' indices and ``qw`` in the second
block, with ``qd = W(q) w = 1/2 q * (w, 0)``; a displacement turns the
quaternion by the exact rotation (:func:`flexmb.quaternions.compose`), and
:meth:`normalized` keeps it of unit length. A model without quaternions
has ``nq = n`` and ``W = I``: then ``qd = u``, a displacement is ``q + du``
and this layout changes nothing.

Everything that splits a state, forms its rate or moves its coordinates
goes through one :class:`StateLayout` (``System.layout``).
"""

from __future__ import annotations

import numpy as np

from . import quaternions as quat
from .errors import ModelError

__all__ = ["StateLayout"]


class StateLayout:
    """Where q, u and the works sit in a state vector, and how q follows u.

    Parameters
    ----------
    nq : int
        Number of generalized coordinates q.
    n : int
        Number of generalized speeds u (``n <= nq``).
    quaternions : tuple of two ndarray of int, optional
        The Euler parameters: their coordinates' indices
        ``(qx, qy, qz, qw)`` (shape (k, 4)) and their angular speeds'
        indices ``(wx, wy, wz)`` (shape (k, 3)); default none. Every other
        coordinate i < n has the rate of speed i.

    Attributes
    ----------
    nq, n : int
        As given.
    size : int
        ``nq + n``: the length of ``(q, u)``.
    identity : bool
        Whether ``W = I`` (then ``qd = u``): true for every model whose
        joints use their coordinates' rates as speeds (no quaternions).

    Examples
    --------
    >>> import numpy as np
    >>> from flexmb.state_layout import StateLayout
    >>> layout = StateLayout(2, 2)
    >>> q, u = layout.split(np.array([0.1, 0.2, 3.0, 4.0, 9.0]))
    >>> q, u, layout.extra(np.array([0.1, 0.2, 3.0, 4.0, 9.0]))
    (array([0.1, 0.2]), array([3., 4.]), array([9.]))
    >>> layout.coordinate_rates(q, u)
    array([3., 4.])
    """

    def __init__(self, nq: int, n: int, quaternions=None):
        if not 0 <= n <= nq:
            raise ModelError(f"a state needs at least as many coordinates as speeds, got nq = {nq}, n = {n}")
        self.nq = int(nq)
        self.n = int(n)
        self.size = self.nq + self.n
        qi, ui = quaternions if quaternions is not None else (np.zeros((0, 4), int), np.zeros((0, 3), int))
        self._q = np.asarray(qi, dtype=np.int64).reshape(-1, 4)
        self._u = np.asarray(ui, dtype=np.int64).reshape(-1, 3)
        if self.nq - self.n != len(self._q):
            raise ModelError(f"a state of {nq} coordinates and {n} speeds needs {nq - n} quaternions, got "
                             f"{len(self._q)}")
        self.identity = not len(self._q)

    def __repr__(self) -> str:
        return f"StateLayout(nq={self.nq}, n={self.n})"

    # -- the parts of a state
    def coordinates(self, y: np.ndarray) -> np.ndarray:
        """The coordinates q of ``y`` (a view).

        Parameters
        ----------
        y : ndarray, shape (>= size,) or (m, >= size)
            A state, or states by rows.

        Returns
        -------
        ndarray, shape (nq,) or (m, nq)
            The coordinates.
        """
        return y[..., : self.nq]

    def speeds(self, y: np.ndarray) -> np.ndarray:
        """The speeds u of ``y`` (a view).

        Parameters
        ----------
        y : ndarray, shape (>= size,) or (m, >= size)
            A state, or states by rows.

        Returns
        -------
        ndarray, shape (n,) or (m, n)
            The speeds.
        """
        return y[..., self.nq : self.size]

    def split(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(q, u)`` of ``y`` (views).

        Parameters
        ----------
        y : ndarray, shape (>= size,) or (m, >= size)
            A state, or states by rows.

        Returns
        -------
        q : ndarray, shape (nq,) or (m, nq)
            The coordinates.
        u : ndarray, shape (n,) or (m, n)
            The speeds.
        """
        return y[..., : self.nq], y[..., self.nq : self.size]

    def extra(self, y: np.ndarray) -> np.ndarray:
        """What follows ``(q, u)`` in ``y``: the tracked works (a view).

        Parameters
        ----------
        y : ndarray, shape (>= size,) or (m, >= size)
            A state, or states by rows.

        Returns
        -------
        ndarray, shape (len(y) - size,) or (m, len(y) - size)
            The works.
        """
        return y[..., self.size :]

    def join(self, q, u, extra=()) -> np.ndarray:
        """The state ``(q, u, extra)``.

        Parameters
        ----------
        q : array_like, shape (nq,)
            Coordinates.
        u : array_like, shape (n,)
            Speeds.
        extra : array_like, optional
            What follows (the tracked works).

        Returns
        -------
        ndarray, shape (size + len(extra),)
            The state.
        """
        return np.concatenate([np.asarray(q, dtype=float), np.asarray(u, dtype=float),
                               np.asarray(extra, dtype=float)])

    # -- the kinematic equations
    def coordinate_rates(self, q: np.ndarray, u: np.ndarray) -> np.ndarray:
        """``qd = W(q) u``: the coordinates' rates (a new array).

        Parameters
        ----------
        q : ndarray, shape (nq,)
            Coordinates.
        u : ndarray, shape (n,)
            Speeds.

        Returns
        -------
        ndarray, shape (nq,)
            ``qd``.
        """
        qd = np.zeros(self.nq)
        qd[: self.n] = u
        if not self.identity:
            qd[self._q] = quat.rates(q[self._q], u[self._u])
        return qd

    def kinematic_matrix(self, q: np.ndarray) -> np.ndarray:
        """``W(q)``: the coordinates' rates per unit speed (dense: for analyses, not for every step).

        Parameters
        ----------
        q : ndarray, shape (nq,)
            Coordinates.

        Returns
        -------
        ndarray, shape (nq, n)
            ``W``.
        """
        W = np.eye(self.nq, self.n)
        if not self.identity:
            W[self._q.ravel()] = 0.0
            W[self._q[:, :, None], self._u[:, None, :]] = quat.kinematic_matrix(q[self._q])
        return W

    def rate_jacobian(self, q: np.ndarray, u: np.ndarray) -> np.ndarray:
        """``d(W(q) u)/dq`` at fixed u: the kinematic equations' own Jacobian (zeros with ``W = I``).

        Parameters
        ----------
        q : ndarray, shape (nq,)
            Coordinates.
        u : ndarray, shape (n,)
            Speeds.

        Returns
        -------
        ndarray, shape (nq, nq)
            The Jacobian.
        """
        J = np.zeros((self.nq, self.nq))
        if not self.identity:
            J[self._q[:, :, None], self._q[:, None, :]] = quat.rate_matrix(u[self._u])
        return J

    def per_coordinate(self, q: np.ndarray, Y: np.ndarray) -> np.ndarray:
        """Columns per unit displacement along the speeds turned into columns per unit coordinate change.

        A Jacobian ``Y = dF/d(du)`` taken along :meth:`displace` becomes
        ``dF/dq = Y P(q)``, ``P`` the displacement per coordinate change
        (``W^+`` on q's manifold); with ``W = I``, ``Y`` itself. F depends
        on a quaternion through its direction only (its rotation is that of
        q normalised), so for q off unit length ``P = P(q / |q|) / |q|``:
        no change along q, the change across it scaled by ``1 / |q|``.

        Parameters
        ----------
        q : ndarray, shape (nq,)
            Coordinates.
        Y : ndarray, shape (m, n)
            Columns per displacement.

        Returns
        -------
        ndarray, shape (m, nq)
            ``Y P(q)``.
        """
        if self.identity:
            return Y
        out = np.zeros((Y.shape[0], self.nq))
        out[:, : self.n] = Y
        out[:, self._q.ravel()] = 0.0
        P = self._displacement_matrices(q)
        for qi, ui, Pk in zip(self._q, self._u, P):
            out[:, qi] += Y[:, ui] @ Pk
        return out

    def displacement(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """``P(q) dq``: a small change of the coordinates as a displacement along the speeds (O(n)).

        The product of :meth:`per_coordinate`'s P with a vector: ``dq``'s
        first n entries where ``W = I``, ``P(q / |q|) dq / |q|`` for each
        quaternion (its change along q itself dropped).

        Parameters
        ----------
        q : ndarray, shape (nq,)
            Coordinates.
        dq : ndarray, shape (nq,)
            A change of them.

        Returns
        -------
        ndarray, shape (n,)
            The displacement.
        """
        du = np.array(dq[: self.n], dtype=float)
        if not self.identity:
            du[self._u] = np.einsum("kij,kj->ki", self._displacement_matrices(q), dq[self._q])
        return du

    def implicit_rates(self, q: np.ndarray, u: np.ndarray, r: np.ndarray, gamma: float) -> np.ndarray:
        """``z`` with ``(I - gamma d(W u)/dq) z = r``: the kinematic equations' rows of a Newton matrix.

        ``z = r`` where ``W = I`` (those rows of :meth:`rate_jacobian` are
        zero); a 4 x 4 solve per quaternion (``I - gamma R(u)``, R
        skew-symmetric: always regular).

        Parameters
        ----------
        q : ndarray, shape (nq,)
            Coordinates.
        u : ndarray, shape (n,)
            Speeds.
        r : ndarray, shape (nq,)
            Right-hand side.
        gamma : float
            The Newton matrix's coefficient.

        Returns
        -------
        ndarray, shape (nq,)
            z.
        """
        z = np.array(r, dtype=float)
        if not self.identity:
            M = np.eye(4) - gamma * quat.rate_matrix(u[self._u])
            z[self._q] = np.linalg.solve(M, r[self._q][..., None])[..., 0]
        return z

    def _displacement_matrices(self, q):
        """``P(q / |q|) / |q|`` of each quaternion, shape (k, 3, 4)."""
        q4 = q[self._q]
        return quat.displacement_matrix(quat.normalized(q4)) / np.linalg.norm(q4, axis=-1)[:, None, None]

    def displace(self, q: np.ndarray, du: np.ndarray) -> np.ndarray:
        """The coordinates moved by ``du`` along the speeds: ``q + W(q) du``, normalised (a new array).

        Every correction (projection, Newton steps of statics and
        assembly) and every perturbation (finite-difference Jacobians,
        linearisation) of the coordinates is a vector of speed size applied
        here.

        Parameters
        ----------
        q : ndarray, shape (nq,)
            Coordinates.
        du : ndarray, shape (n,)
            Displacement along the speeds (rad or m).

        Returns
        -------
        ndarray, shape (nq,)
            The moved coordinates.
        """
        q, du = np.asarray(q, dtype=float), np.asarray(du, dtype=float)
        if self.identity:
            return q + du
        out = q.copy()
        out[: self.n] += du
        out[self._q] = quat.compose(q[self._q], du[self._u])
        return out

    def difference(self, q: np.ndarray, q0: np.ndarray) -> np.ndarray:
        """The displacement along the speeds from ``q0`` to ``q``: the inverse of :meth:`displace`.

        Parameters
        ----------
        q, q0 : ndarray, shape (nq,)
            Coordinates.

        Returns
        -------
        ndarray, shape (n,)
            ``du`` with ``displace(q0, du) = q`` (``q - q0`` where the
            speeds are the coordinates' rates; a quaternion's turn the
            shorter way).
        """
        q, q0 = np.asarray(q, dtype=float), np.asarray(q0, dtype=float)
        du = q[: self.n] - q0[: self.n]
        if not self.identity:
            du[self._u] = quat.turn_between(q0[self._q], q[self._q])
        return du

    def normalized(self, q: np.ndarray) -> np.ndarray:
        """The coordinates put back on their own manifold (a new array; with ``W = I`` a copy).

        Parameters
        ----------
        q : ndarray, shape (nq,)
            Coordinates.

        Returns
        -------
        ndarray, shape (nq,)
            The normalised coordinates.
        """
        out = np.array(q, dtype=float)
        if not self.identity:
            out[self._q] = quat.normalized(out[self._q])
        return out

    def reference(self) -> np.ndarray:
        """The coordinates of the reference configuration: zeros, the quaternions ``(0, 0, 0, 1)``.

        Returns
        -------
        ndarray, shape (nq,)
            The coordinates with every joint at its reference (all markers
            coinciding).
        """
        out = np.zeros(self.nq)
        out[self._q[:, 3]] = 1.0
        return out
