"""Segment-joint springs and dampers of flexible bodies (eqs. 21, 25-27)."""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from . import ForceElement

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
        topo = state.topology
        key = ("beam", tuple(id(e) for e in elements))
        cache = topo.cache
        if key not in cache:
            cols = np.concatenate([topo.elastic_columns(e.body) for e in elements])
            k = np.concatenate([e.body.joint_stiffness().ravel() for e in elements])
            c = np.concatenate([e.body.damping * e.body.joint_stiffness().ravel() for e in elements])
            cache[key] = (cols, k, c)
        return cache[key]

    @classmethod
    def apply_all(cls, elements, state, loads) -> None:
        """Add ``-K eta - C etadot`` for all flexible bodies at once."""
        cols, k, c = cls._arrays(elements, state)
        loads.generalized[cols] -= k * state.x[cols] + c * state.xd[cols]

    @classmethod
    def potential_all(cls, elements, state) -> float:
        """``sum eta K eta / 2``, J."""
        cols, k, _ = cls._arrays(elements, state)
        return float(0.5 * np.sum(k * state.x[cols] ** 2))

    @classmethod
    def tangent_all(cls, elements, state):
        """Diagonal K and C on the elastic coordinates."""
        return cls._arrays(elements, state)

    def apply(self, state, loads) -> None:
        """Add this body's elastic forces."""
        type(self).apply_all([self], state, loads)

    def potential(self, state) -> float:
        """Elastic energy of this body, J."""
        return type(self).potential_all([self], state)
