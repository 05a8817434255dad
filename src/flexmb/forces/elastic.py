"""Segment-joint springs and dampers of flexible bodies (eqs. 21, 25-27)."""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from .base import ForceElement
from .tables import LoadTables, class_tables

__all__ = ["BeamElasticity"]


@frozen(eq=False)
class BeamElasticity(ForceElement):
    """Elastic and internal-friction forces of one flexible body.

    Added automatically for every :class:`~flexmb.FlexibleBody`. Generalized
    force ``-K eta - C etadot`` on its elastic coordinates (``F^s - F^d`` of
    eq. 5), with K from :meth:`FlexibleBody.joint_stiffness` and
    ``C = beta K``; potential ``eta K eta / 2``.

    Parameters
    ----------
    name : str
        ``"<body>.elasticity"``.
    body : FlexibleBody
        The flexible body.
    """

    body: object = field(default=None)

    @classmethod
    def _arrays(cls, elements, state):
        t = class_tables(cls, elements, state.topology)
        return t.coord_cols, t.coord_k, t.coord_c

    @classmethod
    def load_tables(cls, elements, topology) -> LoadTables:
        """``-K eta - C etadot`` of all flexible bodies as coordinate springs (compiled).

        Parameters
        ----------
        elements : sequence of BeamElasticity
            The model's elements of this class.
        topology : Topology
            The model's tree.

        Returns
        -------
        LoadTables
        """
        cols = np.concatenate([topology.elastic_columns(e.body) for e in elements])
        k = np.concatenate([e.body.joint_stiffness().ravel() for e in elements])
        c = np.concatenate([e.body.damping * e.body.joint_stiffness().ravel() for e in elements])
        return LoadTables.of(coord_cols=cols, coord_k=k, coord_c=c, coord_rest=np.zeros(cols.shape[0]))

    @classmethod
    def potential_all(cls, elements, state) -> float:
        """Elastic energy ``sum eta K eta / 2`` of all flexible bodies.

        Parameters
        ----------
        elements : sequence of ForceElement
            The model's elements of this class.
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        float
            Potential energy, J.
        """
        cols, k, _ = cls._arrays(elements, state)
        return float(0.5 * np.add.reduce(k * state.x[cols] ** 2))  # (np.sum's reduction, unwrapped)

    @classmethod
    def potential_states(cls, elements, topology, X, positions=None):
        """:meth:`potential_all` at the states ``X`` at once (``eta K eta / 2`` needs the coordinates only).

        Parameters
        ----------
        elements : sequence of BeamElasticity
            The model's elements of this class.
        topology : Topology
            The model's tree.
        X : ndarray, shape (nt, nq)
            The states' coordinates.
        positions : ndarray, optional
            The mass centres (not needed here).

        Returns
        -------
        ndarray, shape (nt,)
            Potential energies, J.
        """
        t = class_tables(cls, elements, topology)
        return 0.5 * np.add.reduce(t.coord_k * np.asarray(X, dtype=float)[:, t.coord_cols] ** 2, axis=1)

    @classmethod
    def tangent_all(cls, elements, state):
        """Diagonal K and C on the elastic coordinates.

        Parameters
        ----------
        elements : sequence of ForceElement
            The model's elements of this class.
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        cols, k, c : ndarray, shape (n_elastic,)
            Elastic coordinate indices, joint stiffnesses and damping
            constants ``beta K``.
        """
        return cls._arrays(elements, state)

    def apply(self, state, loads) -> None:
        """Add this body's elastic forces.

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.
        loads : Loads
            Accumulator to add to.
        """
        type(self).apply_all([self], state, loads)

    def potential(self, state) -> float:
        """Elastic energy of this body.

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        float
            Potential energy, J.
        """
        return type(self).potential_all([self], state)
