"""CVODE's projection of a step's state onto the loops' constraints, one kinematic pass per position (eqs. 28-29).

:func:`~flexmb.kernels.cvode_loop_callbacks.project` (CVODE's ``CVProjFn``)
checks each step's state against the constraints and projects it where it
left them: the positions by Newton's minimum-norm steps
(:func:`~flexmb.kernels.loop_projection.loop_min_norm`), the speeds
mass-orthogonally (:func:`~flexmb.kernels.loops.loop_speeds`), as
``System.project(..., speeds='mass')``. Each of those, and the residuals'
check (``tree_equations(..., RESIDUALS)``), makes its own pass of the
tree's kinematics; the residuals, phi and the rows at a position need only
one. :func:`step_projection` makes one per position the projection visits:
the state's (its residuals, and the rows of Newton's first step or of the
speeds' projection) and each Newton iterate's (its phi, and the rows of the
next step or of the speeds), with the same arithmetic as those functions, so
that it returns their very numbers (tests/test_loop_projection_runs.py).
"""

from __future__ import annotations

import numpy as np

from .cache import njit
from .constraints import cut_row_wrenches
from .equations import _cut_residuals
from .loop_projection import loop_min_norm, min_norm_at_rows
from .loops import rows_at_kinematics, speeds_at_rows
from .packing import is_planar, unpack, unpack_planar
from .planar_loops import HANDOFF
from .planar_projection import planar_step_projection
from .tree import tree_state

__all__ = ["step_projection", "KEPT", "MOVED", "REFUSED", "UNCHECKED", "PROJ_MAX_ITER", "PROJ_MAX_STEP"]

#: Newton iterations and the largest change of a coordinate per iteration (System.project's)
PROJ_MAX_ITER, PROJ_MAX_STEP = 50, 0.5
#: what :func:`step_projection` did: the state kept (within the tolerance), moved onto the constraints, left
#: (the projection refused), or not checked (a residual not finite)
KEPT, MOVED, REFUSED, UNCHECKED = 0, 1, 2, 3


@njit(cache=True)
def _phi(R, origin, r, omega, v, alpha, acc, cuts, x, cols, p_d):
    """phi of the cut rows (as :func:`~flexmb.kernels.loop_projection.loop_phi`) and of the drivers' rows."""
    phi_c = cut_row_wrenches(0, R, origin, r, omega, v, alpha, acc, *cuts)[0]
    m_cut = phi_c.shape[0]
    phi = np.empty(m_cut + cols.shape[0])
    phi[:m_cut] = phi_c
    for k in range(cols.shape[0]):
        phi[m_cut + k] = x[cols[k]] - p_d[k]
    return phi


@njit(cache=True)
def step_projection(packed, layout, y, n, cols, p_d, v_d, tol, newton_tol, gain, rank_tol, window, rank_limit):
    """A step's state checked against the constraints and, past ``tol``, projected onto them.

    Parameters
    ----------
    packed : tuple
        The model's constant arrays.
    layout : LoopLayout
        The rows' layout (cut rows, then the drivers' unit rows).
    y : ndarray, shape (>= 2 n,)
        The true state ``(x, xd, ...)``.
    n : int
        Number of coordinates (= speeds).
    cols : ndarray of int, shape (n_drivers,)
        The drivers' coordinates.
    p_d, v_d : ndarray, shape (n_drivers,)
        Their prescribed positions and speeds at the state's time.
    tol : float
        Residual (position and velocity) up to which the state is kept.
    newton_tol : float
        Newton's tolerance on phi.
    gain : float
        Largest correction per unit residual (a larger one is refused).
    rank_tol, window : float
        Relative pivot below which a row counts as dependent; the singular window.
    rank_limit : int
        Largest rank kept (negative: no limit).

    Returns
    -------
    what : int
        KEPT (``position, velocity <= tol``), MOVED, REFUSED (Newton did
        not converge, a result not finite, or a correction larger than
        ``gain`` times the residual) or UNCHECKED (a residual not finite).
    position, velocity : float
        The state's largest position and velocity residuals (``System._constraint_residuals``').
    x, xd : ndarray, shape (n,)
        The projected positions and speeds (MOVED; else the state's).

    Notes
    -----
    A planar packed model takes :func:`~flexmb.kernels.planar_projection.planar_step_projection`
    (the same steps on 3-vectors), unless it hands the state back.
    """
    tree, _, cuts = unpack(packed)
    if is_planar(packed):  # the planar twin (flexmb.kernels.planar_projection); HANDOFF: decided here
        ints, floats = unpack_planar(packed)
        out = planar_step_projection(tree, ints, floats, tree.coord_body, layout, y, n, cols, p_d, v_d, tol,
                                     newton_tol, gain, rank_tol, window, rank_limit)
        if out[0] != HANDOFF:
            return out
    x, xd = y[:n].copy(), y[n:2 * n].copy()
    kin = tree_state(tree, x, xd)
    R, origin, r, omega, v, alpha, acc, jp, Sw, Sv = kin
    res = _cut_residuals(R, origin, r, omega, v, alpha, acc, cuts)
    position, velocity = res[0], res[1]
    for k in range(cols.shape[0]):
        position = max(position, abs(y[cols[k]] - p_d[k]))
        velocity = max(velocity, abs(y[n + cols[k]] - v_d[k]))
    if not (position > tol or velocity > tol):
        return (KEPT if position <= tol and velocity <= tol else UNCHECKED), position, velocity, x, xd
    mr = layout.row_coord.shape[0]
    free, zeros = np.ones(n, np.bool_), np.zeros(n)
    converged = not position > tol
    for it in range(PROJ_MAX_ITER if position > tol else 0):
        if it:  # the iterate's pass (its speeds zero, as loop_phi's and rows_at_positions')
            kin = tree_state(tree, x, zeros)
            R, origin, r, omega, v, alpha, acc, jp, Sw, Sv = kin
        phi = _phi(R, origin, r, omega, v, alpha, acc, cuts, x, cols, p_d)
        if np.max(np.abs(phi)) <= newton_tol:
            converged = True
            break
        step = min_norm_at_rows(rows_at_kinematics(tree, cuts, layout, kin), layout, zeros, -phi, free, rank_tol,
                                rank_limit)[0]
        big = np.max(np.abs(step))
        x -= step * min(1.0, PROJ_MAX_STEP / big) if big > 0.0 else step
    if not converged:  # x moved past the last pass
        kin = tree_state(tree, x, zeros)
    b = np.zeros(mr)
    b[mr - cols.shape[0]:] = v_d
    v_new, _, status = speeds_at_rows(rows_at_kinematics(tree, cuts, layout, kin), layout, xd, b, rank_tol, window,
                                      rank_limit)
    if status:  # A singular: the minimum-norm correction (System._project_loops' fallback)
        v_new = xd - loop_min_norm(packed, layout, x, xd, b, free, rank_tol, rank_limit)[0]
    big = 0.0
    for i in range(n):
        big = max(big, abs(x[i] - y[i]), abs(v_new[i] - y[n + i]))
    if not (converged and np.all(np.isfinite(x)) and np.all(np.isfinite(v_new))
            and big <= gain * max(position, velocity)):
        return REFUSED, position, velocity, y[:n].copy(), xd
    return MOVED, position, velocity, x, v_new
