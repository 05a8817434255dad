"""Minimum-norm corrections onto the constraints in O(n m), psi never dense (eqs. 28-29).

The projection of a state onto ``phi = 0`` (Newton, minimum-norm steps
``dx = psi^+ phi``) and of speeds onto ``psi xd = b`` (``psi^+ (psi xd -
b)``) need the minimum-norm solution of ``psi dx = r``:
``dx = psi^T (psi psi^T)^+ r``. psi's rows are kept sparse (each has
entries on its two bodies' paths from the ground only,
:func:`sparse_rows`), and ``psi psi^T`` has an entry only where two rows
share a subtree hanging from the ground, the pattern of the loops' K
(:class:`~flexmb.kernels.loop_layout.LoopLayout`): it is factored, its rank
revealed, by :func:`~flexmb.kernels.constraint_matrix.factor_constraint_matrix`.
The same steps as the SVD's pseudo-inverse, in O(n m) instead of O(n m^2).
"""

from __future__ import annotations

import numpy as np
from .cache import njit

from .constraint_matrix import factor_constraint_matrix, solve_constraint_matrix
from .constraints import cut_row_wrenches
from .loops import rows_at_positions
from .packing import unpack
from .tree import tree_state

__all__ = ["sparse_rows", "loop_min_norm", "min_norm_at_rows", "loop_phi"]


@njit(cache=True)
def sparse_rows(W, body, coord, parent, coord_start, Sw, Sv, free):
    """psi's rows in compressed form, on the free coordinates only.

    Parameters
    ----------
    W : ndarray, shape (m, 2, 6)
        Each row's two wrenches (:func:`~flexmb.kernels.constraints.cut_row_wrenches`).
    body : ndarray of int, shape (m, 2)
        Their bodies (-1: the ground).
    coord : ndarray of int, shape (m,)
        A driver row's coordinate (-1: a cut-joint row).
    parent, coord_start : ndarray of int
        The tree layout.
    Sw, Sv : ndarray, shape (n, 3)
        Plucker axes of the coordinates.
    free : ndarray of bool, shape (n,)
        The coordinates a correction may change (the others' columns are left out).

    Returns
    -------
    ptr : ndarray of int, shape (m + 1,)
        Row a's entries are ``idx[ptr[a]:ptr[a + 1]]``, ``val[...]``.
    idx : ndarray of int
        Their coordinates.
    val : ndarray
        Their values.
    """
    m = W.shape[0]
    n = Sw.shape[0]
    work = np.zeros(n)
    mark = np.full(n, -1, dtype=np.int64)
    touched = np.empty(n, dtype=np.int64)
    ptr = np.zeros(m + 1, dtype=np.int64)
    idx_list = []
    val_list = []
    for a in range(m):
        count = 0
        for side in range(2):
            k = body[a, side]
            while k >= 0:
                for c in range(coord_start[k], coord_start[k + 1]):
                    if mark[c] != a:
                        mark[c] = a
                        work[c] = 0.0
                        touched[count] = c
                        count += 1
                    work[c] += (W[a, side, 0] * Sw[c, 0] + W[a, side, 1] * Sw[c, 1] + W[a, side, 2] * Sw[c, 2]
                                + W[a, side, 3] * Sv[c, 0] + W[a, side, 4] * Sv[c, 1] + W[a, side, 5] * Sv[c, 2])
                k = parent[k]
        c = coord[a]
        if c >= 0:
            if mark[c] != a:
                mark[c] = a
                work[c] = 0.0
                touched[count] = c
                count += 1
            work[c] += 1.0
        kept = 0
        for q in range(count):
            c = touched[q]
            if free[c]:
                idx_list.append(c)
                val_list.append(work[c])
                kept += 1
        ptr[a + 1] = ptr[a] + kept
    idx = np.empty(len(idx_list), dtype=np.int64)
    val = np.empty(len(val_list))
    for q in range(len(idx_list)):
        idx[q] = idx_list[q]
        val[q] = val_list[q]
    return ptr, idx, val


@njit(cache=True)
def loop_phi(packed, layout, x):
    """The cut joints' residuals phi at the positions x (eq. 28).

    Parameters
    ----------
    packed : tuple
        The model's constant arrays.
    layout : LoopLayout
        The rows' layout.
    x : ndarray, shape (nq,)
        Coordinates (:mod:`flexmb.state_layout`).

    Returns
    -------
    ndarray, shape (m_cut,)
        phi of the cut-joint rows.
    """
    tree, tables, cuts = unpack(packed)
    zeros = np.zeros(tree.coord_start[-1])
    R, origin, r, omega, v, alpha, acc, jp, Sw, Sv = tree_state(tree, x, zeros)
    return cut_row_wrenches(0, R, origin, r, omega, v, alpha, acc, *cuts)[0]


@njit(cache=True)
def loop_min_norm(packed, layout, x, v, rhs, free, tol, rank_limit):
    """The minimum-norm correction ``dx = psi^+ (psi v - rhs)`` on the free coordinates, psi at x.

    With ``v = 0`` and ``rhs = -phi`` it is a Newton step of the position
    projection (``x - dx``); with ``v = xd`` and ``rhs = b``, the speeds'
    correction (``xd - dx``).

    Parameters
    ----------
    packed : tuple
        The model's constant arrays.
    layout : LoopLayout
        The rows' layout (cut rows, then the drivers' unit rows).
    x : ndarray, shape (nq,)
        Coordinates (:mod:`flexmb.state_layout`).
    v : ndarray, shape (n,)
        The vector psi is applied to.
    rhs : ndarray, shape (m,)
        What ``psi v`` should be.
    free : ndarray of bool, shape (n,)
        The coordinates the correction may change.
    tol : float
        Relative zero tolerance of ``psi psi^T``'s eigenvalues or pivots.
    rank_limit : int
        Largest rank kept (negative: no limit).

    Returns
    -------
    dx : ndarray, shape (n,)
        The correction (zero on the coordinates not free).
    residual : ndarray, shape (m,)
        ``psi v - rhs``.
    """
    return min_norm_at_rows(rows_at_positions(packed, layout, x), layout, v, rhs, free, tol, rank_limit)


@njit(cache=True)
def min_norm_at_rows(rows, layout, v, rhs, free, tol, rank_limit):
    """:func:`loop_min_norm` from the positions' rows (:func:`~flexmb.kernels.loops.rows_at_positions`).

    Parameters
    ----------
    rows : tuple
        What :func:`~flexmb.kernels.loops.rows_at_positions` returns at the positions.
    layout : LoopLayout
        The rows' layout.
    v, rhs, free, tol, rank_limit
        As for :func:`loop_min_norm`.

    Returns
    -------
    dx : ndarray, shape (n,)
        The correction (zero on the coordinates not free).
    residual : ndarray, shape (m,)
        ``psi v - rhs``.
    """
    n = v.shape[0]
    m = layout.row_coord.shape[0]
    tree, Sw, Sv, _, W, body = rows
    ptr, idx, val = sparse_rows(W, body, layout.row_coord, tree.parent, tree.coord_start, Sw, Sv, np.ones(n, np.bool_))
    residual = np.empty(m)
    work = np.zeros(n)
    for a in range(m):
        s = 0.0
        for q in range(ptr[a], ptr[a + 1]):
            s += val[q] * v[idx[q]]
        residual[a] = s - rhs[a]
    for q in range(idx.shape[0]):  # the columns of the coordinates held fixed leave the correction
        if not free[idx[q]]:
            val[q] = 0.0
    # psi psi^T on the loops' pattern (rows sharing a subtree), its lower band in the factoring order
    band = layout.band
    Kb = np.zeros((m, band + 1))
    for b in range(m):
        for q in range(ptr[b], ptr[b + 1]):
            work[idx[q]] = val[q]
        pb = layout.position[b]
        for s in range(2):
            root = layout.row_roots[b, s]
            if root < 0:
                continue
            for q in range(layout.root_ptr[root], layout.root_ptr[root + 1]):
                a = layout.root_rows[q]
                pa = layout.position[a]
                if pa < pb or pa - pb > band:
                    continue
                dot = 0.0
                for e in range(ptr[a], ptr[a + 1]):
                    dot += val[e] * work[idx[e]]
                Kb[pa, pa - pb] = dot
        for q in range(ptr[b], ptr[b + 1]):
            work[idx[q]] = 0.0
    diag = np.empty(m)
    for j in range(m):
        diag[j] = Kb[j, 0]
    d, dfilt, kept, smallest, V = factor_constraint_matrix(Kb, diag, band, tol, 0.0, rank_limit)
    lam = solve_constraint_matrix(Kb, d, dfilt, band, layout.order, np.zeros(m), residual, V)
    dx = np.zeros(n)
    for a in range(m):
        for q in range(ptr[a], ptr[a + 1]):
            dx[idx[q]] += val[q] * lam[a]
    return dx, residual
