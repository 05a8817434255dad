"""The broad phase of a contact group against a group: the pairs of shapes whose boxes overlap, on a uniform grid.

A :class:`~flexmb.forces.contact_groups.ContactGroup` of n capsules or
spheres against m others lays out a row of the load tables for each pair
(:mod:`flexmb.kernels.contact_geometry`); evaluating them all costs n m
bounding tests per evaluation. A *block* of the tables
(:class:`~flexmb.kernels.loads.LoadTables`: ``contact_blocks``, the shapes
``sweep_rows``, ``sweep_local``, ``sweep_radius`` and the pairs' rows
``contact_block_map``) names the two lists of shapes instead, and
:func:`block_candidates` finds the pairs whose axis-aligned boxes overlap:

* each shape's box (its two ends, or its centre, grown by its radius and a
  margin of ``MARGIN`` of the block's size, so that rounding never drops a
  touching pair) in inertial axes;
* a uniform grid of cells as large as the largest box: the second list's
  boxes are sorted by the cell of their lower corner, and each box of the
  first list looks up the 27 cells around its own (a box of the second
  list that overlaps it has its lower corner there, boxes being no larger
  than a cell) by binary search in the sorted keys;
* the rows of the overlapping pairs (``-1`` in the map: two shapes on one
  body, no row) are returned sorted.

Cost ``O((n + m) log m + k)`` for k overlapping pairs: about linear for
shapes of similar sizes (a beam's segments against another's, however the
two lie). A pair whose boxes are apart cannot touch (its capsules are
inside their boxes), so the rows not returned exert nothing: evaluated in
row order with the other rows, the loads are those of every pair, to the
last bit (:func:`flexmb.kernels.loads.apply_load_tables`).
"""

from __future__ import annotations

import numpy as np

from .cache import njit

__all__ = ["block_candidates", "MARGIN"]

#: the boxes grow by this fraction of the block's extent (at least 1e-15 m), so that a pair the closest-point
#: test finds touching is never dropped by the rounding of its boxes
MARGIN = 1e-9


@njit(cache=True)
def _boxes(first, count, rows, local, radius, R, origin, lo, hi):
    """The inertial boxes of shapes ``first .. first + count`` into lo, hi (shape (count, 3))."""
    for s in range(count):
        k = rows[first + s]
        for x in range(3):
            a = origin[k, x] + R[k, x, 0] * local[first + s, 0, 0] + R[k, x, 1] * local[first + s, 0, 1] \
                + R[k, x, 2] * local[first + s, 0, 2]
            b = origin[k, x] + R[k, x, 0] * local[first + s, 1, 0] + R[k, x, 1] * local[first + s, 1, 1] \
                + R[k, x, 2] * local[first + s, 1, 2]
            lo[s, x] = min(a, b) - radius[first + s]
            hi[s, x] = max(a, b) + radius[first + s]


# Column extremes and sorted searches are loops here, not numpy's: numba implements those in
# numba.np.arraymath, whose import imports scipy.linalg (numba checks there for BLAS), and every
# kernel that applies loads compiles this module in.

@njit(cache=True, inline="always")
def _column_min(a, x):
    """``a[:, x].min()`` of a non-empty 2-d array (NaN if any entry is, as numpy's)."""
    out = a[0, x]
    for i in range(1, a.shape[0]):
        v = a[i, x]
        if v < out or v != v:
            out = v
    return out


@njit(cache=True, inline="always")
def _column_max(a, x):
    """``a[:, x].max()`` of a non-empty 2-d array (NaN if any entry is, as numpy's)."""
    out = a[0, x]
    for i in range(1, a.shape[0]):
        v = a[i, x]
        if v > out or v != v:
            out = v
    return out


@njit(cache=True, inline="always")
def _search(sorted_keys, key, right):
    """``np.searchsorted(sorted_keys, key, side="right" if right else "left")`` by bisection."""
    lo, hi = 0, sorted_keys.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if sorted_keys[mid] < key or (right and sorted_keys[mid] == key):
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True)
def _grow(lo, hi):
    """Grow the boxes by the margin; return the grid's corner (3,) and cell size (the largest box's side)."""
    corner = np.empty(3)
    top = np.empty(3)
    for x in range(3):
        corner[x] = _column_min(lo, x)
        top[x] = _column_max(hi, x)
    margin = MARGIN * max(top[0] - corner[0], top[1] - corner[1], top[2] - corner[2], 1e-6)
    lo -= margin
    hi += margin
    corner -= margin
    size = 0.0
    for s in range(lo.shape[0]):
        for x in range(3):
            size = max(size, hi[s, x] - lo[s, x])
    return corner, size


@njit(cache=True)
def _cells(corner, size, top):
    """The number of cells along each axis (the cell size doubled until their product fits an int64)."""
    dims = np.empty(3, dtype=np.int64)
    while True:
        total = 1.0
        for x in range(3):
            total *= np.floor((top[x] - corner[x]) / size) + 3.0
        if total < 1e15:
            break
        size *= 2.0
    for x in range(3):
        dims[x] = np.int64(np.floor((top[x] - corner[x]) / size)) + 3
    return dims, size


@njit(cache=True)
def _cell(value, corner, size, dim):
    return min(max(np.int64(np.floor((value - corner) / size)), 0), dim - 1)


@njit(cache=True)
def block_candidates(blocks, rows, local, radius, block_map, R, origin):
    """The contact rows of every block whose two shapes' boxes overlap, sorted.

    Parameters
    ----------
    blocks : ndarray of int, shape (k, 4)
        Each block's first shape, its numbers of shapes n1 and n2 (the
        first list, then the second), and its first entry in ``block_map``.
    rows : ndarray of int, shape (s,)
        Each shape's body row (-1: the ground).
    local : ndarray, shape (s, 2, 3)
        Its two ends in that row's frame (a sphere: its centre twice), m.
    radius : ndarray, shape (s,)
        Its radius, m.
    block_map : ndarray of int
        The contact row of the pair (i, j) of a block at its first entry
        plus ``i n2 + j`` (-1: none).
    R, origin : ndarray
        The body rows' rotations and frame origins (the ground last).

    Returns
    -------
    ndarray of int
        The rows, in increasing order.
    """
    total = 0
    for b in range(blocks.shape[0]):
        total += blocks[b, 1] * blocks[b, 2]
    out = np.empty(total, dtype=np.int64)
    found = 0
    for b in range(blocks.shape[0]):
        first, n1, n2, start = blocks[b, 0], blocks[b, 1], blocks[b, 2], blocks[b, 3]
        if n1 == 0 or n2 == 0:
            continue
        lo = np.empty((n1 + n2, 3))
        hi = np.empty((n1 + n2, 3))
        _boxes(first, n1 + n2, rows, local, radius, R, origin, lo, hi)
        corner, size = _grow(lo, hi)
        top = np.empty(3)
        for x in range(3):
            top[x] = _column_max(hi, x)
        dims, size = _cells(corner, max(size, 1e-300), top)
        keys = np.empty(n2, dtype=np.int64)
        for j in range(n2):
            s = n1 + j
            keys[j] = ((_cell(lo[s, 0], corner[0], size, dims[0]) * dims[1]
                        + _cell(lo[s, 1], corner[1], size, dims[1])) * dims[2]
                       + _cell(lo[s, 2], corner[2], size, dims[2]))
        order = np.argsort(keys)
        sorted_keys = keys[order]
        for i in range(n1):
            c = np.empty(3, dtype=np.int64)
            for x in range(3):
                c[x] = _cell(lo[i, x], corner[x], size, dims[x])
            for cx in range(max(c[0] - 1, 0), min(c[0] + 2, dims[0])):
                for cy in range(max(c[1] - 1, 0), min(c[1] + 2, dims[1])):
                    base = (cx * dims[1] + cy) * dims[2]
                    a = _search(sorted_keys, base + max(c[2] - 1, 0), False)
                    z = _search(sorted_keys, base + min(c[2] + 1, dims[2] - 1), True)
                    for t in range(a, z):
                        j = order[t]
                        s = n1 + j
                        if (lo[i, 0] <= hi[s, 0] and lo[s, 0] <= hi[i, 0] and lo[i, 1] <= hi[s, 1]
                                and lo[s, 1] <= hi[i, 1] and lo[i, 2] <= hi[s, 2] and lo[s, 2] <= hi[i, 2]):
                            row = block_map[start + i * n2 + j]
                            if row >= 0:
                                out[found] = row
                                found += 1
    return np.sort(out[:found])
