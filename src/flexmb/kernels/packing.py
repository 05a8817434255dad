"""A model's constant arrays in four buffers, so that one compiled call unboxes four arrays, not fifty-two.

numba unboxes every array argument of a call from Python, one by one: a
right-hand side that takes the tree layout (:class:`~flexmb.kernels.tree.TreeArrays`),
the load tables (:class:`~flexmb.kernels.loads.LoadTables`) and the cut
joints' rows as separate arrays pays for each at every call, which at a few
bodies costs as much as the evaluation itself. :func:`pack` copies them once
per model into one buffer per kind (float, integer, flag) and an index;
:func:`unpack`, inside the compiled evaluation, gives back views of the
buffers with the original dtypes and shapes.

The fields and their kinds are listed once, in :data:`LAYOUT`: the kernel
side (:func:`unpack`) reads them in that order, and :func:`pack` checks each
array against its entry. A 4th part follows, :data:`PLANAR_LAYOUT`: the
planar data of a model that moves in one plane (:mod:`flexmb.planar_data`,
empty arrays for any other model), read by :func:`unpack_planar`;
:func:`is_planar` tells which, from the index alone.
"""

from __future__ import annotations

import numpy as np
from .cache import njit

from .loads import LoadTables
from .tree import TreeArrays
from .views import view2, view3

__all__ = ["LAYOUT", "PLANAR_LAYOUT", "N_TREE", "N_TABLES", "N_CUTS", "N_PLANAR", "pack", "unpack", "unpack_planar",
           "is_planar", "no_planar"]

#: the kind of each packed field: its buffer ('f' float, 'i' integer, 'b' flag) and its number of
#: dimensions; first the fields of TreeArrays, then of LoadTables, then the cut joints' rows
#: (:attr:`flexmb.constraints.Constraints.cut_arrays`)
LAYOUT = (
    # TreeArrays: parent, coord_start, coord_kind, coord_axis, external, parent_frame, child_frame, lever,
    # child_point, com, mass, inertia, coord_body
    "i1", "i1", "i1", "i1", "b1", "f3", "f3", "f2", "f2", "f2", "f1", "f3", "i1",
    # LoadTables: gravity, coord_cols, coord_k, coord_c, coord_rest, pair_rows, pair_local, pair_par,
    # force_rows, force_local, force_vec, force_in_body, torque_rows, torque_vec, torque_in_body, the
    # five group columns, then contact_rows, contact_local, contact_geom, contact_laws, contact_par,
    # contact_group, contact_always, contact_blocks, sweep_rows, sweep_local, sweep_radius and contact_block_map
    "f1", "i1", "f1", "f1", "f1", "i2", "f3", "f2", "i1", "f2", "f2", "b1", "i1", "f2", "b1",
    "i1", "i1", "i1", "i1", "i1",
    "i2", "f3", "f2", "i2", "f2", "i1", "i1", "i2", "i1", "f3", "f1", "i1",
    # cut rows: points (i, pi, j, pj), directions (i, pi, ai, j, pj), perpendiculars (i, ai, j, bj)
    "i1", "f2", "i1", "f2", "i1", "f2", "f2", "i1", "f2", "i1", "f2", "i1", "f2",
)
#: the planar data's fields (:func:`flexmb.planar_data.planar_data`), a 4th part after :data:`LAYOUT`'s
#: (empty arrays for a model that is not planar): ints parent, coord, kind, coord_cols, ri, rj, drivers;
#: floats axis, lever, u, mass, J, g, coord_k, coord_c, coord_rest, wi, wj, d0
PLANAR_LAYOUT = ("i1",) * 7 + ("f2", "f2", "f2", "f1", "f1", "f1", "f1", "f1", "f1", "f2", "f2", "f2")
#: number of fields of each part
N_TREE, N_TABLES, N_CUTS, N_PLANAR = len(TreeArrays._fields), len(LoadTables._fields), 13, len(PLANAR_LAYOUT)
#: index of the planar part's first field
_P0 = N_TREE + N_TABLES + N_CUTS

_DTYPES = {"f": np.float64, "i": np.int64, "b": np.bool_}


def no_planar() -> tuple[tuple, tuple]:
    """The planar part of a model that is not planar: every field an empty array of its kind.

    Returns
    -------
    ints, floats : tuple of ndarray
        7 and 12 empty arrays (:data:`PLANAR_LAYOUT`).
    """
    arrays = [np.zeros((0,) * int(kind[1]), dtype=_DTYPES[kind[0]]) for kind in PLANAR_LAYOUT]
    return tuple(arrays[:7]), tuple(arrays[7:])


def pack(tree, tables, cuts, planar=None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Copy a model's constant arrays into one buffer per kind and an index.

    Parameters
    ----------
    tree : sequence of ndarray
        The fields of :class:`~flexmb.kernels.tree.TreeArrays`, in order.
    tables : sequence of ndarray
        The fields of :class:`~flexmb.kernels.loads.LoadTables`, in order.
    cuts : sequence of ndarray
        The cut joints' rows, in the order of
        :attr:`flexmb.constraints.Constraints.cut_arrays`.
    planar : tuple, optional
        ``(ints, floats)``, the model's planar data
        (:func:`flexmb.planar_data.planar_data`); None (default): the model
        is not planar (:func:`no_planar`).

    Returns
    -------
    floats : ndarray of float
        The float fields, one after the other.
    ints : ndarray of int
        The integer fields.
    flags : ndarray of bool
        The flag fields.
    index : ndarray of int, shape (n_fields, 4)
        Each field's offset in its buffer and its shape (padded with 1).

    Raises
    ------
    ValueError
        If the numbers of fields, or a field's dtype or dimensions, differ
        from :data:`LAYOUT` (and :data:`PLANAR_LAYOUT`).
    """
    ints, floats = no_planar() if planar is None else planar
    arrays = [*tree, *tables, *cuts, *ints, *floats]
    if (len(tree), len(tables), len(cuts)) != (N_TREE, N_TABLES, N_CUTS):
        raise ValueError(f"pack: expected {N_TREE}, {N_TABLES} and {N_CUTS} fields, "
                         f"got {len(tree)}, {len(tables)} and {len(cuts)}")
    if len(ints) + len(floats) != N_PLANAR or len(ints) != 7:
        raise ValueError(f"pack: expected 7 + 12 planar fields, got {len(ints)} + {len(floats)}")
    parts = {kind: [] for kind in _DTYPES}
    sizes = dict.fromkeys(_DTYPES, 0)
    index = np.ones((len(arrays), 4), dtype=np.int64)
    for k, (a, kind) in enumerate(zip(arrays, LAYOUT + PLANAR_LAYOUT)):
        a = np.asarray(a)
        dtype, ndim = _DTYPES[kind[0]], int(kind[1])
        if a.ndim != ndim or a.dtype != dtype:
            raise ValueError(f"pack: field {k} is {a.dtype}, {a.ndim}-d; the layout says {np.dtype(dtype)}, "
                             f"{ndim}-d")
        index[k, 0] = sizes[kind[0]]
        index[k, 1 : 1 + ndim] = a.shape
        parts[kind[0]].append(a.ravel())
        sizes[kind[0]] += a.size
    floats, ints, flags = (np.concatenate(parts[c]) if parts[c] else np.zeros(0, dtype=_DTYPES[c]) for c in "fib")
    return floats, ints, flags, index


@njit(cache=True, inline="always")
def _view1(buffer, index, k):
    o = index[k, 0]
    return buffer[o : o + index[k, 1]]


@njit(cache=True, inline="always")
def _view2(buffer, index, k):
    return view2(buffer, index[k, 0], index[k, 1], index[k, 2])


@njit(cache=True, inline="always")
def _view3(buffer, index, k):
    return view3(buffer, index[k, 0], index[k, 1], index[k, 2], index[k, 3])


@njit(cache=True)
def unpack(packed):
    """The tree layout, the load tables and the cut rows as views of :func:`pack`'s buffers.

    Parameters
    ----------
    packed : tuple
        ``(floats, ints, flags, index)`` from :func:`pack`.

    Returns
    -------
    tree : TreeArrays
        The tree's layout and body data.
    tables : LoadTables
        The compiled force elements' tables.
    cuts : tuple of ndarray
        The cut joints' rows.
    """
    fl, it, fg, ix = packed
    tree = TreeArrays(_view1(it, ix, 0), _view1(it, ix, 1), _view1(it, ix, 2), _view1(it, ix, 3),
                      _view1(fg, ix, 4), _view3(fl, ix, 5), _view3(fl, ix, 6), _view2(fl, ix, 7),
                      _view2(fl, ix, 8), _view2(fl, ix, 9), _view1(fl, ix, 10), _view3(fl, ix, 11),
                      _view1(it, ix, 12))
    tables = LoadTables(_view1(fl, ix, 13), _view1(it, ix, 14), _view1(fl, ix, 15), _view1(fl, ix, 16),
                        _view1(fl, ix, 17), _view2(it, ix, 18), _view3(fl, ix, 19), _view2(fl, ix, 20),
                        _view1(it, ix, 21), _view2(fl, ix, 22), _view2(fl, ix, 23), _view1(fg, ix, 24),
                        _view1(it, ix, 25), _view2(fl, ix, 26), _view1(fg, ix, 27), _view1(it, ix, 28),
                        _view1(it, ix, 29), _view1(it, ix, 30), _view1(it, ix, 31), _view1(it, ix, 32),
                        _view2(it, ix, 33), _view3(fl, ix, 34), _view2(fl, ix, 35), _view2(it, ix, 36),
                        _view2(fl, ix, 37), _view1(it, ix, 38), _view1(it, ix, 39), _view2(it, ix, 40),
                        _view1(it, ix, 41), _view3(fl, ix, 42), _view1(fl, ix, 43), _view1(it, ix, 44))
    cuts = (_view1(it, ix, 45), _view2(fl, ix, 46), _view1(it, ix, 47), _view2(fl, ix, 48),
            _view1(it, ix, 49), _view2(fl, ix, 50), _view2(fl, ix, 51), _view1(it, ix, 52), _view2(fl, ix, 53),
            _view1(it, ix, 54), _view2(fl, ix, 55), _view1(it, ix, 56), _view2(fl, ix, 57))
    return tree, tables, cuts


@njit(cache=True, inline="always")
def is_planar(packed):
    """Whether the packed model is planar (its planar part is not empty).

    Parameters
    ----------
    packed : tuple
        ``(floats, ints, flags, index)`` from :func:`pack`.

    Returns
    -------
    bool
        True if :func:`unpack_planar` gives a planar model.
    """
    return packed[3][_P0, 1] > 0


@njit(cache=True)
def unpack_planar(packed):
    """The planar data (:func:`flexmb.planar_data.planar_data`) as views of :func:`pack`'s buffers.

    Parameters
    ----------
    packed : tuple
        ``(floats, ints, flags, index)`` from :func:`pack`.

    Returns
    -------
    ints : tuple of ndarray
        parent, coord, kind, coord_cols, ri, rj, drivers.
    floats : tuple of ndarray
        axis, lever, u, mass, J, g, coord_k, coord_c, coord_rest, wi, wj, d0
        (empty arrays, all of them, for a model that is not planar).
    """
    fl, it, _, ix = packed
    o = _P0
    ints = (_view1(it, ix, o), _view1(it, ix, o + 1), _view1(it, ix, o + 2), _view1(it, ix, o + 3),
            _view1(it, ix, o + 4), _view1(it, ix, o + 5), _view1(it, ix, o + 6))
    floats = (_view2(fl, ix, o + 7), _view2(fl, ix, o + 8), _view2(fl, ix, o + 9), _view1(fl, ix, o + 10),
              _view1(fl, ix, o + 11), _view1(fl, ix, o + 12), _view1(fl, ix, o + 13), _view1(fl, ix, o + 14),
              _view1(fl, ix, o + 15), _view2(fl, ix, o + 16), _view2(fl, ix, o + 17), _view2(fl, ix, o + 18))
    return ints, floats
