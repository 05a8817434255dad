"""Constraint equations phi(x, t) = 0, psi and b (eqs. 28-29).

Cut joints contribute rows of three kinds (see :mod:`flexmb.joints`),
constraint elements (:mod:`flexmb.constraint_elements`) position rows and
velocity rows ``B xd = b``, and drivers ``q_c - theta(t) = 0``, in that
order. For each row this module gives the residual ``phi`` (0 for a velocity
row: it has no position form), the row of ``psi = dphi/dx`` (``B`` for a
velocity row), ``b`` (``-dphi/dt`` for a position row) and the acceleration
right-hand side ``gamma`` of ``psi xdd = gamma``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .errors import ModelError
from ._lazy import LazyModule

#: the cut joints' rows, compiled, imported at a model with loops' first evaluation
_constraints = LazyModule("flexmb.kernels.constraints")

__all__ = ["Constraints", "ConstraintRows"]


class ConstraintRows(NamedTuple):
    """The constraint rows at a state (eqs. 28-29); what a lower ``level`` does not compute is None.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    phi : ndarray, shape (m,)
        Position residuals (eq. 28), m or rad.
    psi : ndarray, shape (m, n), optional
        Constraint Jacobian (eq. 29).
    b : ndarray, shape (m,), optional
        Right-hand side of ``psi xd = b``.
    gamma : ndarray, shape (m,), optional
        Right-hand side of ``psi xdd = gamma``.
    """

    phi: np.ndarray
    psi: np.ndarray | None = None
    b: np.ndarray | None = None
    gamma: np.ndarray | None = None


class Constraints:
    """Constraint rows of a model: cut joints (compiled, :mod:`flexmb.kernels.constraints`), elements and drivers.

    Parameters
    ----------
    topology : Topology
        The model's tree.
    drivers : list of Driver
        Prescribed motions.
    elements : list of ConstraintElement, optional
        Constraint elements (rows written in Python).

    Attributes
    ----------
    labels : list of str
        One label per row, e.g. ``"loop C.point.x"``, ``"blade.normal"`` or
        ``"driver motor"``.
    n_rows : int
        Number of constraint rows m.
    n_cut : int
        Number of cut-joint rows (the first).
    elements : list of ConstraintElement
        The elements, whose rows follow the cut rows.
    element_start : ndarray of int, shape (n_elements + 1,)
        Where each element's rows start (offsets from ``n_cut``).
    holonomic : ndarray of bool, shape (m,)
        Which rows are position rows (``phi = 0``); the others are velocity
        rows, left out of every position projection.
    n_velocity : int
        Number of velocity rows.
    """

    def __init__(self, topology, drivers, elements=()):
        self.topology = topology
        idx = topology.index
        pts, dirs, perps, labels = [], [], [], []
        for j in topology.cut_joints:
            fp, fc = j.frames()
            bi, bj = idx[j.parent], idx[j.child]
            if j.cut_point:
                pts.append((bi, j.parent_point, bj, j.child_point))
                labels += [f"{j.name}.point.{c}" for c in "xyz"]
            for a in j.cut_directions:
                dirs.append((bi, j.parent_point, fp[:, a], bj, j.child_point))
                labels.append(f"{j.name}.slide.{'xyz'[a]}")
            for a, b in j.cut_perpendicular:
                perps.append((bi, fp[:, a], bj, fc[:, b]))
                labels.append(f"{j.name}.perp.{'xyz'[a]}{'xyz'[b]}")

        def arr(rows, i, shape=None):
            out = np.array([r[i] for r in rows])
            if shape is None:
                return np.ascontiguousarray(out.astype(np.int64))
            return np.ascontiguousarray(out.astype(float).reshape(shape))

        self.pt = (arr(pts, 0), arr(pts, 1, (-1, 3)), arr(pts, 2), arr(pts, 3, (-1, 3)))
        self.dr = (arr(dirs, 0), arr(dirs, 1, (-1, 3)), arr(dirs, 2, (-1, 3)), arr(dirs, 3), arr(dirs, 4, (-1, 3)))
        self.pp = (arr(perps, 0), arr(perps, 1, (-1, 3)), arr(perps, 2), arr(perps, 3, (-1, 3)))
        self.drivers = list(drivers)
        self.driver_cols = np.array(
            [topology.coordinate_slice(d.joint).start + d.coordinate for d in self.drivers], dtype=int
        )
        self.cut_arrays = (*self.pt, *self.dr, *self.pp)  # cut_rows' arguments, as the kernels take them
        self._driver_psi = np.zeros((len(self.drivers), topology.n_speeds))
        self._driver_psi[np.arange(len(self.drivers)), self.driver_cols] = 1.0
        self.n_cut = len(labels)
        self.elements = list(elements)
        for e in self.elements:
            for what in ("n_position", "n_velocity"):
                k = getattr(e, what)
                if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 0:
                    raise ModelError(f"constraint element {e.name!r} ({type(e).__name__}): {what} must be a whole "
                                     f"number >= 0, got {k!r}")
        counts = [e.n_position + e.n_velocity for e in self.elements]
        self.element_start = np.concatenate([[0], np.cumsum(counts)]).astype(int)
        holonomic = [True] * self.n_cut
        for e in self.elements:
            names = list(e.row_names())
            if len(names) != e.n_position + e.n_velocity:
                raise ModelError(f"constraint element {e.name!r} ({type(e).__name__}): row_names() gave "
                                 f"{len(names)} names for {e.n_position} position and {e.n_velocity} velocity rows")
            labels += [f"{e.name}.{r}" for r in names]
            holonomic += [True] * e.n_position + [False] * e.n_velocity
        labels += [f"driver {d.name}" for d in self.drivers]
        holonomic += [True] * len(self.drivers)
        self.holonomic = np.array(holonomic, dtype=bool)
        self.n_velocity = int(np.sum(~self.holonomic))
        self.labels = labels
        self.n_rows = len(labels)

    def element_rows(self, kin):
        """The constraint elements' rows at a state (checked: a bad row names its element).

        Parameters
        ----------
        kin : Kinematics
            The kinematic state.

        Returns
        -------
        ConstraintRows
            ``phi`` (0 on the velocity rows), ``psi``, ``b``, ``gamma`` of
            the elements' rows.
        """
        n, m = kin.xd.shape[0], int(self.element_start[-1])
        phi, psi, b, gamma = np.zeros(m), np.zeros((m, n)), np.zeros(m), np.zeros(m)
        for e, i in zip(self.elements, self.element_start):
            rows = e.checked_rows(kin)
            k = rows.psi.shape[0]
            phi[i : i + e.n_position] = rows.phi
            psi[i : i + k], b[i : i + k], gamma[i : i + k] = rows.psi, rows.b, rows.gamma
        return ConstraintRows(phi, psi, b, gamma)

    def element_powers(self, lam, kin) -> np.ndarray:
        """The power ``lambda . b`` of each element's rows (nonzero only for rows with ``b != 0``).

        Parameters
        ----------
        lam : ndarray, shape (m,)
            The multipliers of all rows.
        kin : Kinematics
            The kinematic state.

        Returns
        -------
        ndarray, shape (n_elements,)
            W, as a driver's ``lambda theta'``.
        """
        start = self.element_start
        power = lam[self.n_cut : self.n_cut + start[-1]] * self.element_rows(kin).b
        return np.array([power[i:j].sum() for i, j in zip(start[:-1], start[1:])])

    def refuse_velocity_rows(self, what: str, instead: str = "") -> None:
        """Raise a ModelError naming the elements with velocity rows, for an analysis that cannot take them.

        Parameters
        ----------
        what : str
            The analysis (the start of the message), e.g. ``"linearize"``.
        instead : str
            What to use instead (ends the message), if anything.

        Returns
        -------
        None
            When no row is a velocity row.

        Raises
        ------
        ModelError
            If any row is a velocity row.
        """
        if not self.n_velocity:
            return
        names = ", ".join(repr(e.name) for e in self.elements if e.n_velocity)
        raise ModelError(
            f"{what}: the model has velocity (nonholonomic) constraint rows ({names}); this analysis works in "
            "independent coordinates x = x0 + T z, which a velocity constraint does not give (its independent "
            "speeds are fewer than its free coordinates: docs/constraints.md, 'Linearisation'), and is not "
            f"available for such a model{'; ' + instead if instead else ''}")

    def position_rows(self, rows):
        """``rows`` (ConstraintRows of all rows) restricted to the position rows (all of them if none is a velocity row).

        Parameters
        ----------
        rows : ConstraintRows
            The rows of :meth:`evaluate`.

        Returns
        -------
        ConstraintRows
            Its position rows: what a position projection closes.
        """
        if not self.n_velocity:
            return rows
        h = self.holonomic
        return ConstraintRows(*(None if a is None else a[h] for a in rows))

    def driver_rows(self, t: float, n: int):
        """The drivers' rows of psi and gamma (``xdd_c = theta''(t)``).

        Parameters
        ----------
        t : float
            Time, s.
        n : int
            Number of coordinates.

        Returns
        -------
        psi : ndarray, shape (n_drivers, n)
            Unit rows on the driven coordinates.
        gamma : ndarray, shape (n_drivers,)
            The prescribed accelerations.
        """
        return self._driver_psi, np.array([d.acceleration(t) for d in self.drivers], dtype=float)

    def evaluate(self, kin, level: int = 2):
        """Residuals and their derivatives.

        Parameters
        ----------
        kin : Kinematics
            The kinematic state.
        level : {0, 1, 2}
            0: only phi; 1: also psi and b; 2: also gamma.

        Returns
        -------
        ConstraintRows
            ``phi`` (eq. 28, m or rad); ``psi`` (eq. 29) and ``b`` (``psi xd
            = b``) for level >= 1; ``gamma`` (``psi xdd = gamma``) for level
            2; None for what the level leaves out.
        """
        n = kin.xd.shape[0]
        topo = self.topology
        phi_c, psi_c, gamma_c = _constraints.cut_rows(level, n, kin.R, kin.origin, kin.r, kin.omega, kin.v,
                                                      kin.alpha_bias, kin.a_bias, kin.Sw, kin.Sv, topo.parent,
                                                      topo.coord_start, *self.pt, *self.dr, *self.pp)
        phis, psis, bs, gammas = [phi_c], [psi_c], [np.zeros(phi_c.shape[0])], [gamma_c]
        if self.elements:
            e = self.element_rows(kin)
            phis.append(e.phi)
            psis.append(e.psi)
            bs.append(e.b)
            gammas.append(e.gamma)
        if self.drivers:
            t = kin.t
            cols = self.driver_cols
            phis.append(kin.x[cols] - np.array([d.position(t) for d in self.drivers], dtype=float))
            if level >= 1:
                rows = np.zeros((len(cols), n))
                rows[np.arange(len(cols)), cols] = 1.0
                psis.append(rows)
                bs.append(np.array([d.velocity(t) for d in self.drivers], dtype=float))
            if level >= 2:
                gammas.append(np.array([d.acceleration(t) for d in self.drivers], dtype=float))
        cat = (lambda parts, shape: np.concatenate(parts) if parts else np.zeros(shape))
        phi = cat(phis, (0,))
        if level == 0:
            return ConstraintRows(phi)
        psi = np.vstack(psis) if psis else np.zeros((0, n))
        b = cat(bs, (0,))
        if level == 1:
            return ConstraintRows(phi, psi, b)
        return ConstraintRows(phi, psi, b, cat(gammas, (0,)))
