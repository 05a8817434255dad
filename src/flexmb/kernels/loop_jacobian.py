"""The state Jacobian of a tree with loops, compiled: ``System.state_jacobian`` without Python, for small models.

``J = [[0, I], [P (G - K), -P C]]`` in ``y = (x, xd)`` (``qd = u``), as
:meth:`flexmb.system.System.state_jacobian` forms it (eqs. 30-39 for
``P``): ``P = T (T^T A T)^-1 T^T`` is applied here without T, as the
constrained solve of :mod:`flexmb.kernels.loops` with a zero right-hand
side, ``P g = y`` with ``A y = g + psi^T lambda``, ``psi y = 0`` (the
factors of the right-hand side's state, one solve per coordinate: the n
columns of P). G is :func:`~flexmb.kernels.tangent.geometric_stiffness` at
the accelerations of the same solve, K and C the diagonal coordinate
springs and dampers (``NewtonPreconditioner.diagonal_terms``). It is for
models whose tangent has nothing else (no springs between points, no
velocity-dependent point forces, no constant point forces or body-axis
torques turning with their bodies: :func:`flexmb.integrators.cvode_direct.compiled_jacobian`
says which; J assembled by :func:`~flexmb.kernels.tree_jacobian.fill_state_jacobian`, as the open
tree's), called by CVODE's dense linear solver through the C callback
:func:`flexmb.kernels.cvode_loop_callbacks.jac` (n below ``KRYLOV_MIN_COORDS``: n
solves of O(n m) each and an n x n product). A planar packed model takes
the same J on 3-vectors (:func:`~flexmb.kernels.planar_loop_jacobian.planar_loop_state_jacobian`).
"""

from __future__ import annotations

import numpy as np

from .cache import njit
from .dynamics import bias_wrenches, composite_inertias, spatial_inertias
from .loads import apply_load_tables
from .loops import _arrays, _constrained_apply, _constrained_factor, _minus_bias_wrenches, _rows
from .packing import is_planar, unpack, unpack_planar
from .planar_loop_jacobian import planar_loop_state_jacobian
from .planar_loops import HANDOFF
from .tangent import geometric_stiffness
from .tree import tree_state
from .tree_jacobian import fill_state_jacobian

__all__ = ["loop_state_jacobian"]


@njit(cache=True)
def loop_state_jacobian(packed, layout, y, n, stiffness, damping, gamma_d, tol, window, rank_limit, J):
    """Fill ``J`` with the state Jacobian of a tree with loops at ``y = (x, xd, ...)`` (``qd = u``).

    Parameters
    ----------
    packed : tuple
        The model's constant arrays (:func:`~flexmb.kernels.packing.pack`).
    layout : LoopLayout
        The rows' layout (:func:`~flexmb.kernels.loop_layout.loop_layout`).
    y : ndarray, shape (>= 2 n,)
        Coordinates and speeds first.
    n : int
        Number of speeds (and coordinates).
    stiffness, damping : ndarray, shape (n,)
        The diagonal coordinate springs K and dampers C.
    gamma_d : ndarray, shape (n_drivers,)
        The drivers' prescribed accelerations.
    tol, window : float
        As for :func:`~flexmb.kernels.loops.loop_rhs`.
    rank_limit : int
        As for :func:`~flexmb.kernels.loops.loop_rhs`.
    J : ndarray, shape (size, size)
        Filled in place (rows and columns beyond ``2 n``: zero).

    Returns
    -------
    status : int
        0; as :func:`~flexmb.kernels.loops.loop_rhs`'s status otherwise
        (1 a freedom moves no mass and no loop fixes it, 2 not finite, 3 the
        refinement of a massless freedom did not settle).
    body : int
        With status 1 or 3, the body whose joint moves no mass (else -1).
    """
    tree, tables, cuts = unpack(packed)
    if is_planar(packed):  # 3-vectors (flexmb.kernels.planar_loop_jacobian); HANDOFF: decided here
        ints, floats = unpack_planar(packed)
        status, body = planar_loop_state_jacobian(ints, floats, tree.coord_body, layout, y, n, stiffness, damping,
                                                  gamma_d, tol, window, rank_limit, J)
        if status != HANDOFF:
            return status, body
    x = y[:n]
    xd = y[n : 2 * n]
    R, origin, r, omega, v, alpha, acc, jp, Sw, Sv = tree_state(tree, x, xd)
    nb = tree.parent.shape[0]
    force = np.zeros((nb + 1, 3))
    torque = np.zeros((nb + 1, 3))
    generalized = np.zeros(n)
    apply_load_tables(tables, tree.mass, R, origin, r, omega, v, x, xd, force, torque, generalized, np.zeros(0))
    Iw, spatial = spatial_inertias(R, r, tree.mass, tree.inertia)
    fw, tw = bias_wrenches(tree.mass, Iw, omega, alpha, acc, force, torque)
    W, body, gamma = _rows(2, tree, cuts, R, origin, r, omega, v, alpha, acc, layout.row_coord, gamma_d)
    arrays = _arrays(layout)
    factors = _constrained_factor(tree.parent, tree.coord_start, Sw, Sv, spatial, W, body, layout.row_coord, arrays,
                                  layout.band, tol, window, rank_limit, np.zeros(n))
    xdd, lam, kept, smallest, status = _constrained_apply(tree.parent, tree.coord_start, Sw, Sv, W, body,
                                                          layout.row_coord, arrays[6], layout.band, factors,
                                                          _minus_bias_wrenches(nb, r, fw, tw), generalized, gamma)
    if status:
        return status, kept if status != 2 else -1
    G = geometric_stiffness(tree.parent, tree.coord_start, tree.coord_body, tree.coord_kind, Sw, Sv, xdd, r, omega,
                            v, alpha, acc, Iw, tree.mass, composite_inertias(tree.parent, spatial), force, torque)
    # P, column by column: the constrained solve of a unit generalized force, no loads, psi y = 0
    P = np.empty((n, n))
    unit = np.zeros(n)
    zero_loads = np.zeros((nb + 1, 6))
    zero_rows = np.zeros(W.shape[0])
    for j in range(n):
        unit[j] = 1.0
        col, _, kept, _, status = _constrained_apply(tree.parent, tree.coord_start, Sw, Sv, W, body, layout.row_coord,
                                                  arrays[6], layout.band, factors, zero_loads, unit, zero_rows)
        unit[j] = 0.0
        if status:
            return status, kept if status != 2 else -1
        P[:, j] = col
    if not fill_state_jacobian(P, G, stiffness, damping, n, J):
        return 2, -1
    return 0, -1
