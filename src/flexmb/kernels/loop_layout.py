"""Which bodies each constraint row moves, and where K = psi A^-1 psi^T has entries: fixed by the topology.

The articulated strategy (:mod:`flexmb.kernels.loops`) applies each row of
psi as loads on the subtrees (hanging from the ground) that its two bodies
belong to; a load on one subtree moves no other, so row b's column of
``A^-1 psi^T`` is nonzero on those subtrees only, and ``K_ab`` only where
rows a and b share a subtree. :func:`loop_layout` lists both, once per
model, and orders the rows so that K is narrowly banded (reverse
Cuthill-McKee).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["LoopLayout", "loop_layout"]


class LoopLayout(NamedTuple):
    """Which bodies each constraint row's column visits and where K has entries; fixed by the topology.

    Built once per model by :func:`loop_layout`; each parameter is kept as
    the field of the same name.

    Parameters
    ----------
    row_body : ndarray of int, shape (m, 2)
        The two bodies of each cut-joint row (-1: the ground), then -1 for
        each driver row.
    row_coord : ndarray of int, shape (m,)
        The driven coordinate of each driver row (-1 for cut-joint rows).
    root_of : ndarray of int, shape (n_bodies,)
        The subtree (numbered from 0) that each body hangs in.
    row_roots : ndarray of int, shape (m, 2)
        The subtrees a row touches (-1: none).
    visit_ptr, visit : ndarray of int
        The bodies of row a's subtrees, increasing:
        ``visit[visit_ptr[a]:visit_ptr[a + 1]]``.
    root_ptr, root_rows : ndarray of int
        The rows touching subtree s: ``root_rows[root_ptr[s]:root_ptr[s + 1]]``.
    order : ndarray of int, shape (m,)
        The rows in the order K is factored (reverse Cuthill-McKee).
    position : ndarray of int, shape (m,)
        Inverse of ``order``.
    band : int
        Half bandwidth of K in that order.
    """

    row_body: np.ndarray
    row_coord: np.ndarray
    root_of: np.ndarray
    row_roots: np.ndarray
    visit_ptr: np.ndarray
    visit: np.ndarray
    root_ptr: np.ndarray
    root_rows: np.ndarray
    order: np.ndarray
    position: np.ndarray
    band: int


def loop_layout(parent, coord_body, cut_bodies, driver_cols) -> LoopLayout:
    """The :class:`LoopLayout` of a tree and its constraint rows.

    Parameters
    ----------
    parent : ndarray of int, shape (n_bodies,)
        Parent body (-1: ground); parents before children.
    coord_body : ndarray of int, shape (n,)
        Body whose joint owns each coordinate.
    cut_bodies : ndarray of int, shape (m_cut, 2)
        The two bodies of each cut-joint row, in row order.
    driver_cols : ndarray of int, shape (n_drivers,)
        The driven coordinates.

    Returns
    -------
    LoopLayout
        The layout.
    """
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    parent = np.asarray(parent, dtype=np.int64)
    nb = parent.shape[0]
    root_of = np.empty(nb, dtype=np.int64)
    roots = []
    for k in range(nb):  # parents come first
        if parent[k] < 0:
            root_of[k] = len(roots)
            roots.append(k)
        else:
            root_of[k] = root_of[parent[k]]
    members = [[] for _ in roots]
    for k in range(nb):
        members[root_of[k]].append(k)
    m_cut, n_drv = len(cut_bodies), len(driver_cols)
    m = m_cut + n_drv
    row_body = np.full((m, 2), -1, dtype=np.int64)
    row_body[:m_cut] = np.asarray(cut_bodies, dtype=np.int64).reshape(m_cut, 2)
    row_coord = np.full(m, -1, dtype=np.int64)
    row_coord[m_cut:] = np.asarray(driver_cols, dtype=np.int64)
    row_roots = np.full((m, 2), -1, dtype=np.int64)
    for a in range(m):
        touched = sorted({int(root_of[b]) for b in row_body[a] if b >= 0}
                         | ({int(root_of[coord_body[row_coord[a]]])} if row_coord[a] >= 0 else set()))
        row_roots[a, : len(touched)] = touched
    visit_ptr = np.zeros(m + 1, dtype=np.int64)
    visits = []
    for a in range(m):
        bodies = sorted(b for s in row_roots[a] if s >= 0 for b in members[s])
        visits.extend(bodies)
        visit_ptr[a + 1] = len(visits)
    by_root = [[] for _ in roots]
    for a in range(m):
        for s in row_roots[a]:
            if s >= 0:
                by_root[s].append(a)
    root_ptr = np.zeros(len(roots) + 1, dtype=np.int64)
    root_ptr[1:] = np.cumsum([len(r) for r in by_root])
    root_rows = np.array([a for r in by_root for a in r], dtype=np.int64)
    # K's pattern: rows sharing a subtree; reverse Cuthill-McKee for a narrow band
    rows_i, rows_j = [], []
    for r in by_root:
        ra = np.asarray(r, dtype=np.int64)
        rows_i.append(np.repeat(ra, len(ra)))
        rows_j.append(np.tile(ra, len(ra)))
    if m:
        ii, jj = np.concatenate(rows_i), np.concatenate(rows_j)
        pattern = csr_matrix((np.ones(len(ii)), (ii, jj)), shape=(m, m))
        order = np.asarray(reverse_cuthill_mckee(pattern, symmetric_mode=True), dtype=np.int64)
    else:
        ii = jj = np.zeros(0, dtype=np.int64)
        order = np.zeros(0, dtype=np.int64)
    position = np.empty(m, dtype=np.int64)
    position[order] = np.arange(m)
    band = int(np.max(np.abs(position[ii] - position[jj]))) if len(ii) else 0
    return LoopLayout(row_body, row_coord, root_of, row_roots, visit_ptr, np.asarray(visits, dtype=np.int64),
                      root_ptr, root_rows, order, position, band)
