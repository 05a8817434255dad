"""The built-in force elements as flat tables, applied by one compiled kernel.

Each built-in class (gravity, the spring-dampers, the segment joints of
flexible bodies, constant point forces and torques) lays its elements out
in a :class:`LoadTables` once per model (:meth:`ForceElement.load_tables`);
:func:`flexmb.kernels.loads.apply_load_tables` adds their loads to the
force array of eq. 5 in compiled code. The same kernel serves a class's
``apply_all`` and the fused right-hand side of an open tree
(:func:`flexmb.kernels.articulated.open_tree_rhs`), which merges the tables
of all compiled classes: one implementation of each element.
"""

from __future__ import annotations

import numpy as np

from ..kernels.loads import LoadTables, apply_load_tables

__all__ = ["LoadTables", "merge", "apply_tables", "class_tables"]

_NO_POWERS = np.zeros(0)


def merge(tables, groups=None) -> LoadTables:
    """One table holding the rows of several (gravities summed).

    Parameters
    ----------
    tables : sequence of LoadTables
        The tables to merge.
    groups : sequence of int, optional
        The group (index of the force-element class in
        ``ForceAssembler.groups``) of each table's rows, for the powers of
        :func:`~flexmb.kernels.loads.apply_load_tables` (default: all 0).

    Returns
    -------
    LoadTables
        Their rows, in order.
    """
    tables = list(tables)
    if not tables:
        return LoadTables.of()
    groups = [0] * len(tables) if groups is None else list(groups)
    fields = {"gravity": np.sum([t.gravity for t in tables], axis=0),
              "gravity_group": [next((g for t, g in zip(tables, groups) if np.any(t.gravity)), 0)]}
    rows_of = {"coord_group": "coord_cols", "pair_group": "pair_rows", "force_group": "force_rows",
               "torque_group": "torque_rows", "contact_group": "contact_rows"}
    fields.update(_merged_blocks(tables))
    for name in LoadTables._fields[1:]:
        if name in fields:
            continue
        if name in rows_of:
            fields[name] = np.concatenate([np.full(len(getattr(t, rows_of[name])), g) for t, g in zip(tables, groups)])
        else:
            fields[name] = np.concatenate([getattr(t, name) for t in tables])
    return LoadTables.of(**fields)


def _merged_blocks(tables) -> dict:
    """The contact rows, blocks and shapes of several tables, with their indices moved to the merged rows."""
    rows = np.cumsum([0] + [len(t.contact_rows) for t in tables])
    shapes = np.cumsum([0] + [len(t.sweep_rows) for t in tables])
    entries = np.cumsum([0] + [len(t.contact_block_map) for t in tables])
    return {"contact_always": np.concatenate([t.contact_always + rows[k] for k, t in enumerate(tables)]),
            "contact_blocks": np.concatenate([t.contact_blocks + np.array([shapes[k], 0, 0, entries[k]])
                                              for k, t in enumerate(tables)]),
            "contact_block_map": np.concatenate([np.where(t.contact_block_map >= 0, t.contact_block_map + rows[k], -1)
                                                 for k, t in enumerate(tables)])}


def class_tables(element_class, elements, topology) -> LoadTables | None:
    """The tables of a class's elements in a model, built once and kept in the topology's cache.

    Parameters
    ----------
    element_class : type
        A force-element class.
    elements : sequence of ForceElement
        Elements of that class.
    topology : Topology
        The model's tree.

    Returns
    -------
    LoadTables or None
        None if the class (or one of these elements) has no compiled form.
    """
    key = ("load tables", element_class, tuple(id(e) for e in elements))
    cache = topology.cache
    if key not in cache:
        own = "load_tables" in vars(element_class)
        cache[key] = element_class.load_tables(elements, topology) if own else None
    return cache[key]


def apply_tables(tables: LoadTables, state, loads) -> None:
    """Add the loads of compiled elements to a :class:`~flexmb.forces.Loads`.

    Parameters
    ----------
    tables : LoadTables
        The elements' data.
    state : Kinematics
        The current kinematic state.
    loads : Loads
        Accumulator to add to.
    """
    apply_load_tables(tables, state.mass, state.R, state.origin, state.r, state.omega, state.v, state.x, state.xd,
                      loads.force, loads.torque, loads.generalized, _NO_POWERS)
