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
(:meth:`normalized`). Every joint of flexmb's today has ``W = I`` and
``nq = n``: then the kinematic equations are ``qd = u``, a displacement
is ``q + du`` and this layout changes nothing.

Everything that splits a state, forms its rate or moves its coordinates
goes through one :class:`StateLayout` (``System.layout``), so that a joint
whose coordinates are not its speeds only has to supply ``W(q)`` and its
normalisation here.
"""

from __future__ import annotations

import numpy as np

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

    Attributes
    ----------
    nq, n : int
        As given.
    size : int
        ``nq + n``: the length of ``(q, u)``.
    identity : bool
        Whether ``W = I`` (then ``qd = u``): true for every model whose
        joints use their coordinates' rates as speeds.

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

    def __init__(self, nq: int, n: int):
        if not 0 <= n <= nq:
            raise ModelError(f"a state needs at least as many coordinates as speeds, got nq = {nq}, n = {n}")
        self.nq = int(nq)
        self.n = int(n)
        self.size = self.nq + self.n
        self.identity = self.nq == self.n

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
        return np.array(u, dtype=float)

    def kinematic_matrix(self, q: np.ndarray) -> np.ndarray:
        """``W(q)``: the coordinates' rates per unit speed.

        Parameters
        ----------
        q : ndarray, shape (nq,)
            Coordinates.

        Returns
        -------
        ndarray, shape (nq, n)
            ``W``.
        """
        return np.eye(self.nq, self.n)

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
        return np.zeros((self.nq, self.nq))

    def per_coordinate(self, q: np.ndarray, Y: np.ndarray) -> np.ndarray:
        """Columns per unit displacement along the speeds turned into columns per unit coordinate change.

        A Jacobian ``Y = dF/d(du)`` taken along :meth:`displace` becomes
        ``dF/dq = Y P(q)``, ``P`` the displacement per coordinate change
        (``W^+`` on q's manifold); with ``W = I``, ``Y`` itself.

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
        return Y

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
        return self.normalized(q + self.kinematic_matrix(q) @ du)

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
        return np.array(q, dtype=float)
