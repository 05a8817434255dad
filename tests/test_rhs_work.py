"""The open tree's right-hand side into a reused work array equals main's allocating one (tests/data/rhs_work.npz).

The stored rates and Jacobians were computed by main before the change
(tests/data/make_rhs_work.py, commit 2ad8ab4); here
:func:`~flexmb.kernels.articulated.open_tree_rhs_into` is called at each
stored state with one work array, filled with NaN before the first call
and never cleared (so a value left from an earlier state or never written
would show), and ``System.state_rate`` / ``System.state_jacobian`` are
evaluated as well. The views that carve the work array
(:mod:`flexmb.kernels.views`) are checked against numpy's reshape.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from numba import njit
from numba.core.errors import TypingError

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "data"))

import make_rhs_work  # noqa: E402
from flexmb.kernels.articulated import open_tree_rhs_into, rhs_work_size  # noqa: E402
from flexmb.kernels.views import view2, view3  # noqa: E402

DATA = np.load(HERE / "data" / "rhs_work.npz")


@pytest.mark.parametrize("name", list(make_rhs_work.MODELS))
def test_rates_into_a_reused_work_array_are_mains(name):
    # the spatial route, which made the stored rates (the planar route is held to it by tests/test_planar_open.py)
    system = make_rhs_work.MODELS[name]().build(planar=False)
    assert system._packed_open is not None
    nq, n = system.layout.nq, system.n_speeds
    work = np.full(rhs_work_size(system.topology.n_bodies, n), np.nan)
    armature = np.zeros(n)
    for y, ref in zip(DATA[f"{name}_y"], DATA[f"{name}_rate"]):
        out = np.full(nq + n + 2, np.nan)  # longer than the rates: the tail stays untouched
        assert open_tree_rhs_into(system._packed_open, y, nq, armature, out, work) == -1
        np.testing.assert_allclose(out[: nq + n], ref, rtol=1e-10, atol=1e-10)
        assert np.isnan(out[nq + n :]).all()
        np.testing.assert_allclose(system.state_rate(0.0, y), ref, rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("name", list(make_rhs_work.MODELS))
def test_planar_rates_into_a_reused_work_array_are_a_fresh_calls(name):
    """The planar route reads nothing a previous call left in the work array, and writes nothing past the rates."""
    system = make_rhs_work.MODELS[name]().build()
    if not system.planar:
        pytest.skip(f"{name} is not planar: {system.planar_reason}")
    nq, n = system.layout.nq, system.n_speeds
    size = rhs_work_size(system.topology.n_bodies, n)
    reused, armature = np.full(size, np.nan), np.zeros(n)
    for y in DATA[f"{name}_y"]:
        out = np.full(nq + n + 2, np.nan)
        assert open_tree_rhs_into(system._packed_open, y, nq, armature, out, reused) == -1
        fresh = np.full(nq + n, np.nan)
        assert open_tree_rhs_into(system._packed_open, y, nq, armature, fresh, np.zeros(size)) == -1
        np.testing.assert_array_equal(out[: nq + n], fresh)
        assert np.isnan(out[nq + n :]).all()
        np.testing.assert_array_equal(system.state_rate(0.0, y), fresh)


@pytest.mark.parametrize("name", make_rhs_work.JACOBIANS)
def test_jacobians_are_mains(name):
    system = make_rhs_work.MODELS[name]().build()
    y, nq = DATA[f"{name}_y"][0], system.layout.nq
    np.testing.assert_allclose(system.state_jacobian(0.0, y[:nq], y[nq:]), DATA[f"{name}_jac"], rtol=1e-10,
                               atol=1e-10)


def test_the_stored_rates_can_fail():
    """The comparison sees a change: the B1 rates at a state with one speed moved differ from the stored ones."""
    system = make_rhs_work.MODELS["b1_8"]().build()
    y = DATA["b1_8_y"][0].copy()
    y[-1] += 1e-6
    assert not np.allclose(system.state_rate(0.0, y), DATA["b1_8_rate"][0], rtol=1e-10, atol=1e-10)


@njit
def _views(buffer):
    return view2(buffer, 3, 4, 5).copy(), view3(buffer, 7, 2, 3, 4).copy()


@njit
def _written(buffer):
    view3(buffer, 2, 2, 2, 2)[1, 0, 1] = -1.0


def test_views_are_numpys_reshapes():
    w = np.arange(60.0)
    a, b = _views(w)
    np.testing.assert_array_equal(a, w[3:23].reshape(4, 5))
    np.testing.assert_array_equal(b, w[7:31].reshape(2, 3, 4))
    i = np.arange(60)
    a, b = _views(i)
    assert a.dtype == np.int64
    np.testing.assert_array_equal(b, i[7:31].reshape(2, 3, 4))
    _written(w)
    assert w[2 + 4 + 1] == -1.0  # a view, not a copy


def test_views_refuse_a_strided_buffer():
    with pytest.raises(TypingError, match="contiguous 1-d array"):
        _views(np.arange(120.0)[::2])
