"""Uniform gravity on every body."""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from .._validate import as_array, name_check, vector3
from . import ForceElement

__all__ = ["Gravity"]


@frozen(eq=False)
class Gravity(ForceElement):
    """Uniform gravity: force ``m_k g`` at each mass centre.

    Parameters
    ----------
    g : array_like, shape (3,)
        Gravitational acceleration, inertial, m/s^2.
    name : str
        Name (default ``"gravity"``).

    Notes
    -----
    Potential energy ``U = -sum_k m_k (g @ r_k)``.
    """

    g: np.ndarray = field(default=(0.0, 0.0, -9.81), converter=as_array, validator=vector3)
    name: str = field(default="gravity", validator=name_check)

    def apply(self, state, loads) -> None:
        """Add ``m g`` to every body."""
        loads.force[:-1] += state.mass[:, None] * self.g

    def potential(self, state) -> float:
        """Potential energy ``U = -sum_k m_k (g @ r_k)``, J."""
        return float(-np.sum(state.mass * (state.r[:-1] @ self.g)))
