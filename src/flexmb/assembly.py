"""Kane's equations: generalized mass matrix and force array (eqs. 1-5)."""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from .forces import Loads
from .rotations import cross

__all__ = ["mass_matrix", "ForceAssembler"]


def mass_matrix(kin) -> np.ndarray:
    """Generalized mass matrix (eq. 2).

    Parameters
    ----------
    kin : Kinematics
        The kinematic state.

    Returns
    -------
    ndarray, shape (n_coords, n_coords)
        ``A = sum_k m_k V_k^T V_k + W_k^T I_k W_k``.
    """
    V, W = kin.V[:-1], kin.W[:-1]
    rows, n = 3 * V.shape[0], V.shape[2]
    Vm = (V * np.sqrt(kin.mass)[:, None, None]).reshape(rows, n)
    IW = (kin.inertia_world() @ W).reshape(rows, n)
    return Vm.T @ Vm + W.reshape(rows, n).T @ IW


class ForceAssembler:
    """Applies the force elements and forms the force array f (eq. 3).

    Parameters
    ----------
    forces : list of ForceElement
        The model's force elements; grouped by class and applied one
        ``apply_all`` call per class.
    """

    def __init__(self, forces):
        groups = defaultdict(list)
        for e in forces:
            groups[type(e)].append(e)
        self.groups = list(groups.items())

    def loads(self, kin) -> Loads:
        """Apply every force element to a fresh :class:`Loads`."""
        loads = Loads(kin)
        for cls, elements in self.groups:
            cls.apply_all(elements, kin, loads)
        return loads

    def active_force(self, kin, loads: Loads | None = None) -> np.ndarray:
        """Generalized active force F (eq. 5), shape (n_coords,)."""
        if loads is None:
            loads = self.loads(kin)
        F = np.einsum("kin,ki->n", kin.V[:-1], loads.force[:-1])
        F += np.einsum("kin,ki->n", kin.W[:-1], loads.torque[:-1])
        return F + loads.generalized

    def force_array(self, kin) -> np.ndarray:
        """Force array f of eq. 3: F minus the velocity-dependent inertia forces.

        Parameters
        ----------
        kin : Kinematics
            The kinematic state.

        Returns
        -------
        ndarray, shape (n_coords,)
            ``f = F - sum_k [m_k V_k^T (Vdot_k xd) + W_k^T (I_k Wdot_k xd + w_k x I_k w_k)]``.
        """
        F = self.active_force(kin)
        I = kin.inertia_world()
        w = kin.omega[:-1]
        Iw = np.einsum("kij,kj->ki", I, w)
        torque = np.einsum("kij,kj->ki", I, kin.alpha_bias[:-1]) + cross(w, Iw)
        force = kin.mass[:, None] * kin.a_bias[:-1]
        return F - np.einsum("kin,ki->n", kin.V[:-1], force) - np.einsum("kin,ki->n", kin.W[:-1], torque)

    def group_powers(self, kin) -> np.ndarray:
        """Power of each force-element class, ``F_g . xd`` (W), in ``self.groups`` order.

        Parameters
        ----------
        kin : Kinematics
            The kinematic state.

        Returns
        -------
        ndarray, shape (n_groups,)
            Power delivered by the elements of each class.
        """
        out = np.zeros(len(self.groups))
        for i, (cls, elements) in enumerate(self.groups):
            loads = Loads(kin)
            cls.apply_all(elements, kin, loads)
            out[i] = self.active_force(kin, loads) @ kin.xd
        return out

    def group_names(self) -> list[str]:
        """One label per force-element class (its elements' names joined)."""
        return [", ".join(e.name for e in elements) for _, elements in self.groups]

    def potential_energy(self, kin) -> float:
        """Summed potential energy of the conservative elements, J."""
        return float(sum(cls.potential_all(elements, kin) for cls, elements in self.groups))
