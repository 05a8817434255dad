"""The static balance and the reactions of a tree with loops in O(n m), psi and A never formed (eqs. 3, 5, 28-29).

Statics and the reactions with given accelerations need ``psi^T w`` (the
generalized forces of constraint forces ``w`` on the rows) and the force
array; a row of psi is the two wrenches it is made of
(:func:`~flexmb.kernels.constraints.cut_row_wrenches`), so ``psi^T w`` is
the axes' projection of those wrenches (:func:`~flexmb.kernels.dynamics.axis_projections`,
O(n + m)), and the multipliers of ``A v = load + psi^T lambda``,
``psi v = 0`` come from :func:`~flexmb.kernels.loops.loop_newton_solve`'s solve.
"""

from __future__ import annotations

import numpy as np
from .cache import njit

from .articulated import mass_times
from .dynamics import axis_projections, generalized_force
from .equations import loaded_state
from .loops import _arrays, _constrained_solve, _n_cut, _rows, rows_at_positions

__all__ = ["rows_transpose", "loop_balance", "loop_reactions"]


@njit(cache=True)
def _transpose(parent, coord_body, Sw, Sv, W, body, coord, w):
    """``psi^T w`` from the rows' wrenches: their axes' projection, plus the drivers' unit rows."""
    nb = parent.shape[0]
    wrench = np.zeros((nb, 6))
    for a in range(W.shape[0]):
        for side in range(2):
            k = body[a, side]
            if 0 <= k < nb:
                for i in range(6):
                    wrench[k, i] += w[a] * W[a, side, i]
    out = axis_projections(parent, coord_body, Sw, Sv, wrench)
    for a in range(W.shape[0]):
        if coord[a] >= 0:
            out[coord[a]] += w[a]
    return out


@njit(cache=True)
def rows_transpose(packed, layout, x, w):
    """``psi(x)^T w``: the generalized forces of the multipliers ``w`` on the rows, in O(n + m).

    Parameters
    ----------
    packed : tuple
        The model's constant arrays (:func:`~flexmb.kernels.packing.pack`).
    layout : LoopLayout
        The rows' layout (cut rows, then the drivers' unit rows).
    x : ndarray, shape (nq,)
        Coordinates (:mod:`flexmb.state_layout`).
    w : ndarray, shape (m,)
        One multiplier per row.

    Returns
    -------
    ndarray, shape (n,)
        ``psi^T w``.
    """
    tree, Sw, Sv, spatial, W, body = rows_at_positions(packed, layout, x)
    return _transpose(tree.parent, tree.coord_body, Sw, Sv, W, body, layout.row_coord, w)


@njit(cache=True)
def loop_balance(packed, layout, x, n, w, force0, torque0, generalized0):
    """The generalized active force at rest g (eq. 5) and ``g + psi^T w``, at the positions x, in O(n + m).

    Parameters
    ----------
    packed : tuple
        The model's constant arrays.
    layout : LoopLayout
        The rows' layout.
    x : ndarray, shape (nq,)
        Coordinates.
    n : int
        Number of speeds.
    w : ndarray, shape (m,)
        Multipliers of the rows.
    force0, torque0 : ndarray, shape (n_bodies + 1, 3)
        Loads of the force elements evaluated in Python.
    generalized0 : ndarray, shape (n,)
        Their generalized forces.

    Returns
    -------
    g : ndarray, shape (n,)
        The generalized active force with every speed zero.
    balance : ndarray, shape (n,)
        ``g + psi^T w``.
    """
    nq = x.shape[0]
    y = np.zeros(nq + n)
    y[:nq] = x
    tree, cuts, kin, spatial, fw, tw, generalized = loaded_state(packed, y, nq, np.zeros(0), force0, torque0,
                                                                 generalized0)
    R, origin, r, omega, v, alpha, acc, jp, Sw, Sv = kin
    g = generalized_force(tree.parent, tree.coord_body, r, fw, tw, Sw, Sv) + generalized
    m = layout.row_coord.shape[0]
    W, body, _ = _rows(1, tree, cuts, R, origin, r, omega, v, alpha, acc, layout.row_coord, np.zeros(m - _n_cut(cuts)))
    return g, g + _transpose(tree.parent, tree.coord_body, Sw, Sv, W, body, layout.row_coord, w)


@njit(cache=True)
def loop_reactions(packed, layout, y, nq, xdd, force0, torque0, generalized0, tol, rank_limit):
    """The multipliers lambda of ``A xdd = f + psi^T lambda`` for given accelerations, in O(n m).

    ``A v = (f - A xdd) + psi^T lambda``, ``psi v = 0`` is solved as
    :func:`~flexmb.kernels.loops.loop_newton_solve` solves it (``A xdd`` by
    :func:`~flexmb.kernels.articulated.mass_times`, f by the recursion's
    loads): where ``A xdd - f`` lies in the range of ``psi^T`` (the
    accelerations of the model), ``v = 0`` and lambda is its multipliers.

    Parameters
    ----------
    packed : tuple
        The model's constant arrays.
    layout : LoopLayout
        The rows' layout.
    y : ndarray, shape (>= nq + n,)
        Coordinates and speeds first.
    nq : int
        Number of coordinates.
    xdd : ndarray, shape (n,)
        The accelerations.
    force0, torque0 : ndarray, shape (n_bodies + 1, 3)
        Loads of the force elements evaluated in Python.
    generalized0 : ndarray, shape (n,)
        Their generalized forces.
    tol : float
        Relative pivot below which a row counts as dependent.
    rank_limit : int
        Largest number of rows kept (negative: no limit).

    Returns
    -------
    lam : ndarray, shape (m,)
        The multipliers (dropped rows: zero).
    kept : int
        Number of rows kept; with status 1 or 3, the body whose joint moves no mass.
    status : int
        As for :func:`~flexmb.kernels.loops.loop_rhs`.
    """
    tree, cuts, kin, spatial, fw, tw, generalized = loaded_state(packed, y, nq, np.zeros(0), force0, torque0,
                                                                 generalized0)
    R, origin, r, omega, v, alpha, acc, jp, Sw, Sv = kin
    n = Sw.shape[0]
    nb = tree.parent.shape[0]
    m = layout.row_coord.shape[0]
    load = generalized_force(tree.parent, tree.coord_body, r, fw, tw, Sw, Sv) + generalized
    load -= mass_times(tree.parent, tree.coord_start, tree.coord_body, spatial, Sw, Sv, xdd)
    W, body, _ = _rows(1, tree, cuts, R, origin, r, omega, v, alpha, acc, layout.row_coord, np.zeros(m - _n_cut(cuts)))
    _, lam, kept, _, status = _constrained_solve(tree.parent, tree.coord_start, Sw, Sv, spatial, np.zeros((nb + 1, 6)),
                                                 load, W, body, layout.row_coord, np.zeros(m), _arrays(layout),
                                                 layout.band, tol, 0.0, rank_limit, np.zeros(n))
    return lam, kept, status
