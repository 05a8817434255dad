"""Kane's equations: generalized mass matrix and force array (eqs. 1-5)."""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from .forces import Loads
from .rotations import cross

__all__ = ["mass_matrix", "generalized_force", "ForceAssembler"]


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

    Notes
    -----
    Eq. 2 summed body by body costs ``n_bodies n^2``. The same sum is
    regrouped by subtrees: in Plucker form about the inertial origin the
    spatial inertias of the bodies a coordinate moves add up to a
    composite inertia ``IC``, and ``A[c, d] = S_c . IC S_d`` for the
    deeper of the two coordinates' bodies (zero for coordinates on
    different branches). That costs ``36 n_bodies^2 + 6 n^2``.
    """
    topo = kin.topology
    nb = topo.n_bodies
    S = np.concatenate([kin.Sw, kin.Sv], axis=1)  # (n, 6)
    IC = (topo.ancestors.T @ kin.spatial_inertia().reshape(nb, 36)).reshape(nb, 6, 6)
    F = np.einsum("cij,cj->ci", IC[topo.coord_body], S)
    # A[c, d] = S_c . IC_{body(d)} S_d where c moves d's body, else the
    # transposed product where d moves c's body, else 0
    return (S @ F.T) * topo.mass_mask + (F @ S.T) * topo.mass_mask_t


def generalized_force(kin, force, torque) -> np.ndarray:
    """Project forces and torques on the bodies onto the coordinates (eq. 5).

    Parameters
    ----------
    kin : Kinematics
        The kinematic state.
    force, torque : ndarray, shape (n_bodies, 3)
        Force at each mass centre and torque on each body, inertial.

    Returns
    -------
    ndarray, shape (n_coords,)
        ``sum_k V_k^T force_k + W_k^T torque_k``, summed per subtree: each
        coordinate sees the resultant wrench, about the origin, of the
        bodies it moves.
    """
    topo = kin.topology
    nb = topo.n_bodies
    wrench = np.concatenate([torque + cross(kin.r[:nb], force), force], axis=1)
    total = topo.ancestors.T @ wrench  # subtree sums, (nb, 6)
    cb = topo.coord_body
    return np.einsum("ci,ci->c", kin.Sw, total[cb, :3]) + np.einsum("ci,ci->c", kin.Sv, total[cb, 3:])


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
        return generalized_force(kin, loads.force[:-1], loads.torque[:-1]) + loads.generalized

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
        loads = self.loads(kin)
        I = kin.inertia_world()
        w = kin.omega[:-1]
        Iw = np.einsum("kij,kj->ki", I, w)
        torque = loads.torque[:-1] - np.einsum("kij,kj->ki", I, kin.alpha_bias[:-1]) - cross(w, Iw)
        force = loads.force[:-1] - kin.mass[:, None] * kin.a_bias[:-1]
        return generalized_force(kin, force, torque) + loads.generalized

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
