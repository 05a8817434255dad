"""CVODE's projection of a step's state onto the loops' constraints for a planar model, on 3-vectors.

The planar twin of :func:`flexmb.kernels.step_projection.step_projection`
(which dispatches to :func:`planar_step_projection` for a planar packed
model, callers unchanged): the same check, Newton iteration and speeds'
projection, with the planar kinematics (:func:`flexmb.kernels.planar.kinematics`)
in place of the spatial tree's and the planar rows
(:func:`flexmb.kernels.planar_loops.rows`, the spatial rows' in-plane
components) in place of :func:`~flexmb.kernels.constraints.cut_row_wrenches`:

- the residuals: the cut rows' ``phi = d . (P_j - P_i)`` and ``psi xd``
  (each row's two wrenches on its bodies' spatial velocities), the
  drivers' ``x_c - p_d`` and ``xd_c - v_d``;
- Newton's minimum-norm steps by the shared
  :func:`~flexmb.kernels.loop_projection.min_norm_at_rows`, its rows'
  wrenches and axes the planar ones embedded in 6-vectors (``psi``'s
  entries are the same products);
- the speeds mass-orthogonally, ``v = xd + A^-1 psi^T lambda`` with ``K
  lambda = b - psi xd`` (``K = psi A^-1 psi^T``): the planar factors and
  ``K`` of :mod:`flexmb.kernels.planar_loops`, as
  :func:`~flexmb.kernels.loops.speeds_at_rows` solves ``A v = A xd + psi^T
  lambda, psi v = b`` on 6-vectors.

A freedom that moves no mass, K not finite, or a speeds' solve that fails
are handed back (:data:`~flexmb.kernels.planar_loops.HANDOFF`) to the
spatial path, which then decides as it does for any model.
"""

from __future__ import annotations

import numpy as np

from .cache import njit
from .constrained import MASSLESS
from .constraint_matrix import solve_constraint_matrix
from .loop_projection import min_norm_at_rows
from .planar import _rot, backward, factor, forward, inertias, kinematics
from .planar_loops import HANDOFF, _loop_matrix, _views, planar_loop_work_size, rows

__all__ = ["planar_step_projection"]

#: Newton iterations and the largest change of a coordinate per iteration (step_projection's)
PROJ_MAX_ITER, PROJ_MAX_STEP = 50, 0.5
#: step_projection's outcomes (its KEPT, MOVED, REFUSED, UNCHECKED)
KEPT, MOVED, REFUSED, UNCHECKED = 0, 1, 2, 3


@njit(cache=True)
def _cut_phi(ints, floats, K, phi):
    """phi of the cut rows, ``d . (P_j - P_i)`` (d turning with body i), into ``phi[:n_cut]``."""
    ri, rj = ints[4], ints[5]
    wi, wj, d0 = floats[9], floats[10], floats[11]
    for a in range(ri.shape[0]):
        i, j = ri[a], rj[a]
        ci, si, cj, sj = K[i, 1], K[i, 2], K[j, 1], K[j, 2]
        ax, ay = _rot(ci, si, wi[a, 0], wi[a, 1])
        bx, by = _rot(cj, sj, wj[a, 0], wj[a, 1])
        dx, dy = _rot(ci, si, d0[a, 0], d0[a, 1])
        phi[a] = dx * (K[j, 3] + bx - K[i, 3] - ax) + dy * (K[j, 4] + by - K[i, 4] - ay)


@njit(cache=True)
def _psi_xd(W, body, coord, a, K, xd):
    """Row a of psi applied to the speeds: its wrenches . its bodies' spatial velocities (a driver's: xd_c)."""
    if coord[a] >= 0:
        return xd[coord[a]]
    s = 0.0
    for side in range(2):
        k = body[a, side]
        if k >= 0:
            s += W[a, side, 0] * K[k, 7] + W[a, side, 1] * K[k, 8] + W[a, side, 2] * K[k, 9]
    return s


@njit(cache=True)
def _embedded_rows(tree, ints, K, W, body, coord_body):
    """The rows as :func:`~flexmb.kernels.loop_projection.min_norm_at_rows` reads them, planar vectors in 6-vectors."""
    n = coord_body.shape[0]
    m = W.shape[0]
    Sw, Sv = np.zeros((n, 3)), np.zeros((n, 3))
    for c in range(n):
        k = coord_body[c]
        Sw[c, 2], Sv[c, 0], Sv[c, 1] = K[k, 10], K[k, 11], K[k, 12]
    W6 = np.zeros((m, 2, 6))
    for a in range(m):
        for side in range(2):
            W6[a, side, 2], W6[a, side, 3], W6[a, side, 4] = W[a, side, 0], W[a, side, 1], W[a, side, 2]
    return tree, Sw, Sv, np.zeros((0, 6, 6)), W6, body


@njit(cache=True)
def _speeds(ints, floats, coord_body, layout, Kin, W, xd, b, tol, window, rank_limit, work):
    """The speeds closest to xd in the mass metric with ``psi v = b`` at Kin's positions; (v, status)."""
    n, m, nb = xd.shape[0], W.shape[0], ints[0].shape[0]
    _, pA, IA, UD, acc, uu, tau, arm, _, _, residual, P, dA, X, G = _views(nb, n, m, work)
    inertias(floats, Kin, IA)
    arm[:] = 0.0
    if factor(ints, Kin, IA, UD, arm, MASSLESS, 0.0) >= 0:
        return xd.copy(), HANDOFF
    body, coord = layout.row_body, layout.row_coord
    coord_of = np.full(m, -1, dtype=np.int64)
    for a in range(m):
        if coord[a] >= 0:
            coord_of[a] = coord_body[coord[a]]
    Kb, d, dfilt, kept, smallest, finite, V = _loop_matrix(ints, Kin, UD, W, layout, coord_of, P, dA, X, G, tol,
                                                           window, rank_limit)
    if not finite:
        return xd.copy(), HANDOFF
    for a in range(m):
        residual[a] = -_psi_xd(W, body, coord, a, Kin, xd)
    lam = solve_constraint_matrix(Kb, d, dfilt, layout.band, layout.order, b, residual, V)
    pA[:, :] = 0.0
    tau[:] = 0.0
    for a in range(m):
        for side in range(2):
            k = body[a, side]
            if k >= 0:
                for t in range(3):
                    pA[k, t] -= lam[a] * W[a, side, t]
        if coord[a] >= 0:
            tau[coord[a]] += lam[a]
    backward(ints, Kin, IA, UD, pA, tau, uu, False)
    forward(ints, Kin, UD, uu, False, acc, tau)
    v = xd + tau
    return v, (0 if np.all(np.isfinite(v)) else HANDOFF)


@njit(cache=True)
def _residuals(ints, floats, layout, Kin, W, y, n, cols, p_d, v_d, phi):
    """step_projection's position and velocity residuals (cut rows, then drivers) at Kin (speeds y's)."""
    nc = ints[4].shape[0]
    _cut_phi(ints, floats, Kin, phi)
    position, velocity = 0.0, 0.0
    for a in range(nc):
        position = max(position, abs(phi[a]))
        velocity = max(velocity, abs(_psi_xd(W, layout.row_body, layout.row_coord, a, Kin, y[n:])))
    for k in range(cols.shape[0]):
        position = max(position, abs(y[cols[k]] - p_d[k]))
        velocity = max(velocity, abs(y[n + cols[k]] - v_d[k]))
    return position, velocity


@njit(cache=True)
def planar_step_projection(tree, ints, floats, coord_body, layout, y, n, cols, p_d, v_d, tol, newton_tol, gain,
                           rank_tol, window, rank_limit):
    """:func:`~flexmb.kernels.step_projection.step_projection` of a planar model on 3-vectors.

    Parameters
    ----------
    tree : tuple
        The spatial tree of the packed model (its layout: parent, coord_start).
    ints, floats : tuple
        The planar model (:func:`flexmb.kernels.packing.unpack_planar`).
    coord_body : ndarray of int, shape (n,)
        The body whose joint owns each coordinate.
    layout, y, n, cols, p_d, v_d, tol, newton_tol, gain, rank_tol, window, rank_limit
        As for :func:`~flexmb.kernels.step_projection.step_projection`.

    Returns
    -------
    what : int
        As step_projection's, or :data:`~flexmb.kernels.planar_loops.HANDOFF`
        (the spatial path decides).
    position, velocity : float
        The state's largest position and velocity residuals.
    x, xd : ndarray, shape (n,)
        The projected positions and speeds (MOVED; else the state's).
    """
    nb, m, nc = ints[0].shape[0], layout.row_coord.shape[0], ints[4].shape[0]
    work = np.empty(planar_loop_work_size(nb, n, m))
    Kin, W, gamma = _views(nb, n, m, work)[0], np.empty((m, 2, 3)), np.empty(m)
    x, xd = y[:n].copy(), y[n:2 * n].copy()
    gamma_d, zeros, phi = np.zeros(m - nc), np.zeros(n), np.empty(m)
    kinematics(ints, floats, x, xd, Kin)
    rows(ints, floats, Kin, gamma_d, W, gamma)
    position, velocity = _residuals(ints, floats, layout, Kin, W, y, n, cols, p_d, v_d, phi)
    if not (position > tol or velocity > tol):
        return (KEPT if position <= tol and velocity <= tol else UNCHECKED), position, velocity, x, xd
    free = np.ones(n, np.bool_)
    converged = not position > tol
    for it in range(PROJ_MAX_ITER if position > tol else 0):
        if it:  # the iterate's pass (its speeds zero, as step_projection's)
            kinematics(ints, floats, x, zeros, Kin)
            rows(ints, floats, Kin, gamma_d, W, gamma)
        _cut_phi(ints, floats, Kin, phi)
        for k in range(cols.shape[0]):
            phi[nc + k] = x[cols[k]] - p_d[k]
        if np.max(np.abs(phi)) <= newton_tol:
            converged = True
            break
        step = min_norm_at_rows(_embedded_rows(tree, ints, Kin, W, layout.row_body, coord_body), layout, zeros, -phi,
                                free, rank_tol, rank_limit)[0]
        big = np.max(np.abs(step))
        x -= step * min(1.0, PROJ_MAX_STEP / big) if big > 0.0 else step
    if not converged:  # x moved past the last pass
        kinematics(ints, floats, x, zeros, Kin)
        rows(ints, floats, Kin, gamma_d, W, gamma)
    b = np.zeros(m)
    b[m - cols.shape[0]:] = v_d
    kinematics(ints, floats, x, xd, Kin)  # the speeds' pass: the bodies' velocities at x
    v_new, status = _speeds(ints, floats, coord_body, layout, Kin, W, xd, b, rank_tol, window, rank_limit, work)
    if status:
        return HANDOFF, position, velocity, y[:n].copy(), y[n:2 * n].copy()
    big = 0.0
    for i in range(n):
        big = max(big, abs(x[i] - y[i]), abs(v_new[i] - y[n + i]))
    if not (converged and np.all(np.isfinite(x)) and np.all(np.isfinite(v_new))
            and big <= gain * max(position, velocity)):
        return REFUSED, position, velocity, y[:n].copy(), xd
    return MOVED, position, velocity, x, v_new
