"""The packed constant arrays of a model (flexmb.kernels.packing): what unpack gives back is what was packed."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

import flexmb as fm
from flexmb.forces.tables import class_tables, merge
from flexmb.kernels.packing import LAYOUT, N_CUTS, N_TABLES, N_TREE, pack, unpack
from flexmb.scenes.wiper import WiperOptions, wiper


@njit(cache=False)
def _fields(packed):
    tree, tables, cuts = unpack(packed)
    return tree, tables, cuts


def _wiper_system():
    model, _ = wiper(WiperOptions(flexible=True, n_segments=4))
    return model.build()


def _tables(system):
    """The compiled force elements' tables, merged as System does."""
    tables = [class_tables(cls, elements, system.topology) for cls, elements in system.forces.groups]
    compiled = [g for g, t in enumerate(tables) if t is not None]
    return tuple(merge([tables[g] for g in compiled], compiled))


def test_layout_has_one_kind_per_field():
    assert len(LAYOUT) == N_TREE + N_TABLES + N_CUTS
    assert set(LAYOUT) <= {"f1", "f2", "f3", "i1", "i2", "b1"}


def test_unpack_gives_back_every_array_of_a_model_with_loops_and_springs():
    system = _wiper_system()  # point and perpendicularity rows of cut joints, segment springs, a plugin
    tree, tables, cuts = system.topology.arrays, _tables(system), system.constraints.cut_arrays
    got = _fields(system._packed)
    for want, have in zip((tree, tables, cuts), got):
        assert len(want) == len(have)
        for a, b in zip(want, have):
            assert a.dtype == b.dtype and a.shape == b.shape
            np.testing.assert_array_equal(a, b)


def test_an_open_tree_packs_empty_cut_rows():
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model = fm.Model("pendulum")
    model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)), fm.Gravity((0.0, -9.81, 0.0)))
    system = model.build()
    _, _, cuts = _fields(system._packed)
    assert all(c.shape[0] == 0 for c in cuts)
    assert system._packed_open is system._packed  # the right-hand side is one kernel call


def test_a_field_of_the_wrong_kind_is_refused():
    system = _wiper_system()
    tree = list(system.topology.arrays)
    tree[0] = tree[0].astype(float)
    with pytest.raises(ValueError, match="field 0 is float64, 1-d; the layout says int64, 1-d"):
        pack(tree, _tables(system), system.constraints.cut_arrays)
    with pytest.raises(ValueError, match="expected 13, 32 and 13 fields"):
        pack(tree[:-1], _tables(system), system.constraints.cut_arrays)
