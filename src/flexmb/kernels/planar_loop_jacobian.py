"""The state Jacobian of a planar tree with loops on 3-vectors: loop_state_jacobian's planar twin.

:func:`flexmb.kernels.loop_jacobian.loop_state_jacobian` dispatches here
for a planar packed model (callers unchanged). ``J = [[0, I], [P (G - K),
-P C]]`` as there: the constrained accelerations by the planar right-hand
side (:func:`~flexmb.kernels.planar_loops.planar_loop_rhs_into`, whose
kinematics and articulated factors stay in its work), G by
:func:`~flexmb.kernels.planar_tangent.planar_geometric_stiffness` at those
accelerations, and ``P`` column by column as the constrained solve of a
unit generalized force with no loads and ``psi y = 0``: ``y = a + A^-1
psi^T lambda``, ``K lambda = -psi a``, ``a = A^-1 e_j``, with the planar
articulated solves and ``K`` factored once (the planar loops'
:func:`~flexmb.kernels.planar_loops._loop_matrix`). J is assembled by the
shared :func:`~flexmb.kernels.tree_jacobian.fill_state_jacobian`. A freedom
that moves no mass is handed back
(:data:`~flexmb.kernels.planar_loops.HANDOFF`) to the spatial path.
"""

from __future__ import annotations

import numpy as np

from .cache import njit
from .constraint_matrix import solve_constraint_matrix
from .planar import backward, forward
from .planar_loops import HANDOFF, _loop_matrix, _psi_times, _views, planar_loop_rhs_into, planar_loop_work_size
from .planar_tangent import planar_gravity_loads, planar_geometric_stiffness
from .tree_jacobian import fill_state_jacobian

__all__ = ["planar_loop_state_jacobian"]


@njit(cache=True)
def _response(ints, Kin, IA, UD, W, body, coord, lam, pA, tau, uu, acc, out):
    """``out += A^-1 psi^T lam``: one planar solve with every row's wrenches weighted by lam."""
    pA[:, :] = 0.0
    tau[:] = 0.0
    for a in range(lam.shape[0]):
        for side in range(2):
            k = body[a, side]
            if k >= 0:
                for t in range(3):
                    pA[k, t] -= lam[a] * W[a, side, t]
        if coord[a] >= 0:
            tau[coord[a]] += lam[a]
    backward(ints, Kin, IA, UD, pA, tau, uu, False)
    forward(ints, Kin, UD, uu, False, acc, tau)
    out += tau


@njit(cache=True)
def planar_loop_state_jacobian(ints, floats, coord_body, layout, y, n, stiffness, damping, gamma_d, tol, window,
                               rank_limit, J):
    """Fill ``J`` with the state Jacobian of a planar tree with loops at ``y = (x, xd, ...)`` (``qd = u``).

    Parameters
    ----------
    ints, floats : tuple
        The planar model (:func:`flexmb.kernels.packing.unpack_planar`).
    coord_body : ndarray of int, shape (n,)
        The body whose joint owns each coordinate.
    layout, y, n, stiffness, damping, gamma_d, tol, window, rank_limit, J
        As for :func:`~flexmb.kernels.loop_jacobian.loop_state_jacobian`.

    Returns
    -------
    status : int
        0, 2 (not finite), or :data:`~flexmb.kernels.planar_loops.HANDOFF`
        (a freedom that moves no mass: the spatial path decides).
    body : int
        -1.
    """
    nb, m = ints[0].shape[0], layout.row_coord.shape[0]
    work = np.empty(planar_loop_work_size(nb, n, m))
    xdd, lam = np.empty(n), np.empty(m)
    kept, smallest, status = planar_loop_rhs_into(ints, floats, coord_body, layout, y, n, np.zeros(n), gamma_d, tol,
                                                  window, rank_limit, xdd, lam, work)
    if status:
        return status, -1
    # the rhs's kinematics, rows and articulated factors at y stay in its work
    Kin, pA, IA, UD, acc, uu, tau, arm, W, gamma, residual, P, dA, X, G = _views(nb, n, m, work)
    force, torque = np.empty((nb, 2)), np.empty(nb)
    planar_gravity_loads(floats, force, torque)
    Gs = planar_geometric_stiffness(ints, floats, Kin, xdd, force, torque)
    body, coord = layout.row_body, layout.row_coord
    coord_of = np.full(m, -1, dtype=np.int64)
    for a in range(m):
        if coord[a] >= 0:
            coord_of[a] = coord_body[coord[a]]
    Kb, d, dfilt, kept, smallest, finite, V = _loop_matrix(ints, Kin, UD, W, layout, coord_of, P, dA, X, G, tol,
                                                           window, rank_limit)
    if not finite:
        return 2, -1
    Pm = np.empty((n, n))
    col, zero_rows = np.empty(n), np.zeros(m)
    for j in range(n):  # P, column by column: the constrained solve of a unit generalized force, no loads
        pA[:, :] = 0.0
        tau[:] = 0.0
        tau[j] = 1.0
        backward(ints, Kin, IA, UD, pA, tau, uu, False)
        forward(ints, Kin, UD, uu, False, acc, col)
        for a in range(m):
            residual[a] = -_psi_times(W, body, coord, a, acc, Kin, col, False)
        lam[:] = solve_constraint_matrix(Kb, d, dfilt, layout.band, layout.order, zero_rows, residual, V)
        _response(ints, Kin, IA, UD, W, body, coord, lam, pA, tau, uu, acc, col)
        Pm[:, j] = col
    if not fill_state_jacobian(Pm, Gs, stiffness, damping, n, J):
        return 2, -1
    return 0, -1
