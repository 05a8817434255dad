"""Constraint equations phi(x, t) = 0, psi and b (eqs. 28-29).

Cut joints contribute rows of three kinds (see :mod:`flexmb.joints`), and
drivers contribute ``q_c - theta(t) = 0``. For each row this module gives
the residual ``phi``, the row of ``psi = dphi/dx``, ``b = -dphi/dt`` and the
acceleration right-hand side ``gamma`` of ``psi xdd = gamma``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .kernels.constraints import cut_rows

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
    """Constraint rows of a model: cut joints (compiled, :mod:`flexmb.kernels.constraints`) and drivers.

    Parameters
    ----------
    topology : Topology
        The model's tree.
    drivers : list of Driver
        Prescribed motions.

    Attributes
    ----------
    labels : list of str
        One label per row, e.g. ``"loop C.point.x"`` or ``"driver motor"``.
    n_rows : int
        Number of constraint rows m.
    """

    def __init__(self, topology, drivers):
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
        self._driver_psi = np.zeros((len(self.drivers), topology.n_coords))
        self._driver_psi[np.arange(len(self.drivers)), self.driver_cols] = 1.0
        labels += [f"driver {d.name}" for d in self.drivers]
        self.labels = labels
        self.n_rows = len(labels)

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
        n = kin.x.shape[0]
        topo = self.topology
        phi_c, psi_c, gamma_c = cut_rows(level, n, kin.R, kin.origin, kin.r, kin.omega, kin.v, kin.alpha_bias,
                                         kin.a_bias, kin.Sw, kin.Sv, topo.parent, topo.coord_start, *self.pt,
                                         *self.dr, *self.pp)
        phis, psis, bs, gammas = [phi_c], [psi_c], [np.zeros(phi_c.shape[0])], [gamma_c]
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
