"""The state Jacobian of an open tree, compiled: ``System.state_jacobian`` without Python, for small models.

``J = [[0, I], [A^-1 (G - K), -A^-1 C]]`` in ``y = (x, xd)`` (``qd = u``),
as :meth:`flexmb.system.System.state_jacobian` forms it without
constraints: ``A^-1`` applied column by column by the articulated-body
solve of a unit generalized force (the factors of the right-hand side's
state, :func:`~flexmb.kernels.articulated.articulated_factor`), G
:func:`~flexmb.kernels.tangent.geometric_stiffness` at the state's
accelerations, K and C the diagonal coordinate springs and dampers
(``NewtonPreconditioner.diagonal_terms``). It is for models whose tangent
has nothing else (:func:`flexmb.integrators.cvode_direct.compiled_jacobian`
says which), called by CVODE's dense linear solver through the C callback
:func:`flexmb.kernels.cvode_callbacks.jac` (n below ``KRYLOV_MIN_COORDS``:
n solves of O(n) each and an n x n product). :func:`fill_state_jacobian`
assembles J from ``A^-1`` (or, with loops, the constrained solve's P) and
G here and in :func:`flexmb.kernels.loop_jacobian.loop_state_jacobian`.
A planar model (:func:`~flexmb.kernels.packing.is_planar`) takes the
planar route, ``A^-1`` and G on 3-vectors
(:func:`~flexmb.kernels.planar_tangent.planar_tree_jacobian_parts`), the
same J.
"""

from __future__ import annotations

import numpy as np

from .articulated import _minus_bias_wrenches, articulated_factor, articulated_solve
from .cache import njit
from .dynamics import bias_wrenches, composite_inertias, spatial_inertias
from .loads import apply_load_tables
from .packing import is_planar, unpack, unpack_planar
from .planar_tangent import planar_tree_jacobian_parts
from .tangent import geometric_stiffness
from .tree import tree_state

__all__ = ["tree_state_jacobian", "fill_state_jacobian"]


@njit(cache=True)
def fill_state_jacobian(P, G, stiffness, damping, n, J):
    """Fill ``J`` with ``[[0, I], [P (G - K), -P C]]``; whether it is finite.

    Parameters
    ----------
    P : ndarray, shape (n, n)
        The solve's matrix: ``A^-1`` (open tree) or ``T (T^T A T)^-1 T^T`` (loops, eqs. 30-39).
    G : ndarray, shape (n, n)
        The geometric stiffness; its diagonal is changed (``G - K``).
    stiffness, damping : ndarray, shape (n,)
        The diagonal coordinate springs K and dampers C.
    n : int
        Number of speeds (and coordinates).
    J : ndarray, shape (size, size)
        Filled in place (rows and columns beyond ``2 n``: zero).

    Returns
    -------
    bool
        True if every entry is finite.
    """
    for j in range(n):
        G[j, j] -= stiffness[j]
    J[:, :] = 0.0
    for i in range(n):
        J[i, n + i] = 1.0
        for j in range(n):
            s = 0.0
            for k in range(n):
                s += P[i, k] * G[k, j]
            J[n + i, j] = s
            J[n + i, n + j] = -P[i, j] * damping[j]
    for i in range(n, 2 * n):
        for j in range(2 * n):
            if not np.isfinite(J[i, j]):
                return False
    return True


@njit(cache=True)
def tree_state_jacobian(packed, y, n, stiffness, damping, J):
    """Fill ``J`` with the state Jacobian of an open tree at ``y = (x, xd, ...)`` (``qd = u``).

    Parameters
    ----------
    packed : tuple
        The model's constant arrays (:func:`~flexmb.kernels.packing.pack`).
    y : ndarray, shape (>= 2 n,)
        Coordinates and speeds first.
    n : int
        Number of speeds (and coordinates).
    stiffness, damping : ndarray, shape (n,)
        The diagonal coordinate springs K and dampers C.
    J : ndarray, shape (size, size)
        Filled in place (rows and columns beyond ``2 n``: zero).

    Returns
    -------
    status : int
        0; 1 a joint's articulated inertia is singular (a freedom that moves
        no mass), 2 not finite.
    body : int
        With status 1, the body of that joint (else -1).
    """
    if is_planar(packed):  # the model moves in one plane: 3-vectors (flexmb.kernels.planar_tangent)
        ints, floats = unpack_planar(packed)
        P, G, bad = planar_tree_jacobian_parts(ints, floats, y, n)
        if bad >= 0:
            return 1, bad
        return (0, -1) if fill_state_jacobian(P, G, stiffness, damping, n, J) else (2, -1)
    tree, tables, _ = unpack(packed)
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
    U, DinvUT, Dinv, bad = articulated_factor(tree.parent, tree.coord_start, spatial, Sw, Sv, np.zeros(n))
    if bad >= 0:
        return 1, bad
    bodies = np.arange(nb)
    dA = np.zeros((nb + 1, 6))
    xdd = np.empty(n)
    articulated_solve(tree.parent, tree.coord_start, Sw, Sv, U, DinvUT, Dinv, _minus_bias_wrenches(nb, r, fw, tw),
                      generalized, bodies, xdd, dA)
    G = geometric_stiffness(tree.parent, tree.coord_start, tree.coord_body, tree.coord_kind, Sw, Sv, xdd, r, omega,
                            v, alpha, acc, Iw, tree.mass, composite_inertias(tree.parent, spatial), force, torque)
    # A^-1, column by column: the articulated solve of a unit generalized force, no loads
    P = np.empty((n, n))
    unit = np.zeros(n)
    pA = np.zeros((nb + 1, 6))
    col = np.empty(n)
    for j in range(n):
        unit[j] = 1.0
        pA[:, :] = 0.0
        dA[:, :] = 0.0
        articulated_solve(tree.parent, tree.coord_start, Sw, Sv, U, DinvUT, Dinv, pA, unit, bodies, col, dA)
        unit[j] = 0.0
        P[:, j] = col
    if not fill_state_jacobian(P, G, stiffness, damping, n, J):
        return 2, -1
    return 0, -1
