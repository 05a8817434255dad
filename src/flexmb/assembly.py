"""Kane's equations: generalized mass matrix and force array (eqs. 1-5)."""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from .errors import AssemblyError, FlexmbError
from .forces import Loads
from .kernels import dynamics as _dyn
from .kernels import tangent as _tangent

__all__ = ["mass_matrix", "composite_inertias", "generalized_force", "geometric_stiffness", "ForceAssembler",
           "apply_group"]


def apply_group(kind, elements, kin, loads) -> None:
    """``kind.apply_all(elements, kin, loads)``; an element that raises is named in an :class:`AssemblyError`.

    A force element's own code (a plugin's, a user's subclass) may fail in
    the middle of a run; the error then says which element failed, when,
    and how, whatever the integrator (the run stops with its outputs so
    far, :class:`~flexmb.SimulationError`). flexmb's own errors pass
    unchanged.

    Parameters
    ----------
    kind : type
        The elements' class.
    elements : sequence of ForceElement
        The model's elements of this class.
    kin : Kinematics
        The kinematic state.
    loads : Loads
        Accumulator to add to.

    Raises
    ------
    AssemblyError
        ``at t = ... s: force element 'name' (Kind) failed: Error: message``,
        with ``.t`` the time; chained to the element's exception.
    """
    try:
        kind.apply_all(elements, kin, loads)
    except FlexmbError:
        raise
    except Exception as exc:
        culprit = elements[0] if len(elements) == 1 else None
        for e in elements if culprit is None else ():  # which one: each alone, on a scratch accumulator
            try:
                kind.apply_all([e], kin, Loads(kin))
            except Exception:
                culprit = e
                break
        what = (f"force element {culprit.name!r} ({kind.__name__})" if culprit is not None
                else f"the force elements of class {kind.__name__}")
        err = AssemblyError(f"at t = {kin.t:.9g} s: {what} failed: {type(exc).__name__}: {exc}")
        err.t = kin.t
        raise err from exc


def mass_matrix(kin) -> np.ndarray:
    """Generalized mass matrix (eq. 2).

    Parameters
    ----------
    kin : Kinematics
        The kinematic state.

    Returns
    -------
    ndarray, shape (n_speeds, n_speeds)
        ``A = sum_k m_k V_k^T V_k + W_k^T I_k W_k``.

    Notes
    -----
    Eq. 2 summed body by body costs ``n_bodies n^2``. The same sum is
    regrouped by subtrees: in Plucker form about the inertial origin the
    spatial inertias of the bodies a coordinate moves add up to a
    composite inertia ``IC``, and ``A[c, d] = S_c . IC S_d`` for the
    deeper of the two coordinates' bodies (zero for coordinates on
    different branches). The compiled kernel
    (:func:`flexmb.kernels.dynamics.mass_matrix`) walks each coordinate's
    path from the ground: O(n depth).
    """
    topo = kin.topology
    return _dyn.mass_matrix(topo.parent, topo.coord_start, topo.coord_body, composite_inertias(kin), kin.Sw,
                            kin.Sv)


def composite_inertias(kin) -> np.ndarray:
    """Spatial inertia about the origin of each body's subtree (computed once per state).

    Parameters
    ----------
    kin : Kinematics
        The kinematic state.

    Returns
    -------
    ndarray, shape (n_bodies, 6, 6)
        The sum of :meth:`Kinematics.spatial_inertia` over the body and
        everything after it.
    """
    if kin._composite is None:
        kin._composite = _dyn.composite_inertias(kin.topology.parent, kin.spatial_inertia())
    return kin._composite


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
    ndarray, shape (n_speeds,)
        ``sum_k V_k^T force_k + W_k^T torque_k``, summed per subtree: each
        coordinate sees the resultant wrench, about the origin, of the
        bodies it moves.
    """
    topo = kin.topology
    return _dyn.generalized_force(topo.parent, topo.coord_body, kin.r, force, torque, kin.Sw, kin.Sv)


def geometric_stiffness(kin, xdd, force, torque) -> np.ndarray:
    """Derivative of the generalized forces with respect to the coordinates, at fixed speeds and accelerations.

    ``G[c, d] = d g_c / d x_d`` with ``g = sum_k V_k^T (F_k - m_k a_k) +
    W_k^T (T_k - I_k alpha_k - omega_k x I_k omega_k)`` (eqs. 3, 5, 19:
    the generalized active plus inertia forces, ``A xdd - f = -g``), for
    applied forces that keep their inertial direction while their points
    of application move with the bodies (gravity exactly), and for the
    inertia forces of the accelerations ``xdd``: the geometric stiffness
    of the loads and the ``(dA/dx) xdd`` terms. Changes of the
    velocity-product terms other than by a rigid rotation are left out.

    Parameters
    ----------
    kin : Kinematics
        The kinematic state.
    xdd : ndarray, shape (n_speeds,)
        Accelerations.
    force, torque : ndarray, shape (n_bodies, 3)
        Applied forces at the mass centres and torques, inertial.

    Returns
    -------
    ndarray, shape (n_speeds, n_speeds)
        G; the Jacobian of the accelerations is ``A^-1 (G - K)`` in an
        open tree with coordinate springs K.

    Notes
    -----
    Moving coordinate d by ``delta`` moves everything after it rigidly by
    the twist ``S_d delta`` (Plucker, about the origin). The axis S_c of a
    coordinate after d turns with it, the resultant wrench W of a subtree
    after d turns too, except for the parts that do not: the applied loads'
    directions and the accelerations ``a_d`` produced before d. With ``H``
    the composite inertia of a subtree and ``u_d = S_d x a_d``,

    * c after d: ``G[c, d] = S_c . (H_c u_d - Q_c S_wd)``;
    * d after c: ``G[c, d] = S_c . (S_d x* W_d + H_d u_d - Q_d S_wd)``,

    where ``Q omega`` is the change of the subtree's load wrench when the
    loads turn back by omega. Every product is (n x 6)(6 x n): O(n^2).
    """
    topo = kin.topology
    return _tangent.geometric_stiffness(
        topo.parent, topo.coord_start, topo.coord_body, topo.coord_kind, kin.Sw, kin.Sv, np.asarray(xdd, dtype=float),
        kin.r, kin.omega, kin.v, kin.alpha_bias, kin.a_bias, kin.inertia_world(), kin.mass, composite_inertias(kin),
        np.ascontiguousarray(force), np.ascontiguousarray(torque))


def _power(kin, loads) -> float:
    """Power of accumulated loads: ``sum force . v + torque . omega`` over the bodies, plus ``generalized . xd``.

    Equal to ``F . xd`` (eq. 5): the generalized forces are the loads'
    projections on the partial velocities, whose combination with ``xd``
    is each body's velocity.
    """
    # the ground's row (last) moves not: its loads do no work, so whole arrays can be dotted
    return float(np.vdot(loads.force, kin.v) + np.vdot(loads.torque, kin.omega) + loads.generalized @ kin.xd)


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

    def loads(self, kin, powers: np.ndarray | None = None) -> Loads:
        """Apply every force element to a fresh :class:`Loads`.

        Parameters
        ----------
        kin : Kinematics
            The kinematic state.
        powers : ndarray, shape (n_groups,), optional
            If given, filled with the power of each class's loads (see
            :meth:`group_powers`), from the same evaluation.

        Returns
        -------
        Loads
            Forces and torques on the bodies and generalized forces on the
            coordinates.
        """
        loads = Loads(kin)
        before = 0.0
        for i, (cls, elements) in enumerate(self.groups):
            apply_group(cls, elements, kin, loads)
            if powers is not None:
                total = _power(kin, loads)
                powers[i] = total - before
                before = total
        return loads

    def active_force(self, kin, loads: Loads | None = None) -> np.ndarray:
        """Generalized active force F (eq. 5).

        Parameters
        ----------
        kin : Kinematics
            The kinematic state.
        loads : Loads, optional
            The applied loads, if already computed (default: :meth:`loads`).

        Returns
        -------
        ndarray, shape (n_coords,)
            ``F_l = sum_k V_kl . force_k + W_kl . torque_k`` plus the
            generalized forces on coordinates.
        """
        if loads is None:
            loads = self.loads(kin)
        return generalized_force(kin, loads.force[:-1], loads.torque[:-1]) + loads.generalized

    def force_array(self, kin, powers: np.ndarray | None = None, loads: Loads | None = None) -> np.ndarray:
        """Force array f of eq. 3: F minus the velocity-dependent inertia forces.

        Parameters
        ----------
        kin : Kinematics
            The kinematic state.
        powers : ndarray, shape (n_groups,), optional
            If given, filled with each force-element class's power
            (:meth:`group_powers`) from the same evaluation.
        loads : Loads, optional
            The applied loads, if already computed (then ``powers`` is not
            filled).

        Returns
        -------
        ndarray, shape (n_coords,)
            ``f = F - sum_k [m_k V_k^T (Vdot_k xd) + W_k^T (I_k Wdot_k xd + w_k x I_k w_k)]``.
        """
        if loads is None:
            loads = self.loads(kin, powers)
        force, torque = _dyn.bias_wrenches(kin.mass, kin.inertia_world(), kin.omega, kin.alpha_bias, kin.a_bias,
                                           loads.force, loads.torque)
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
        self.loads(kin, out)
        return out

    def group_names(self) -> list[str]:
        """One label per force-element class (its elements' names joined).

        Returns
        -------
        list of str
            Labels in the order of ``groups``.
        """
        return [", ".join(e.name for e in elements) for _, elements in self.groups]

    def potential_energy(self, kin) -> float:
        """Summed potential energy of the conservative elements.

        Parameters
        ----------
        kin : Kinematics
            The kinematic state.

        Returns
        -------
        float
            Potential energy, J.
        """
        return float(sum(cls.potential_all(elements, kin) for cls, elements in self.groups))
