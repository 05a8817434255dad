"""What a run keeps for the next run on the same System (flexmb.run_memo) changes no result.

``simulate`` keeps per System what it works out from the System and its
settings alone (the compiled Jacobian's cover, the diagonal springs the
callbacks read, whether a Jacobian exists, ``method='auto'``'s choice); a
run on a System that has run before must give, to the bit, what the same
run gives on a freshly built System, and a new initial state or other
tolerances must be worked out again.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import flexmb as fm
from flexmb import run_memo

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
sys.path.insert(0, BENCH)

scenes = pytest.importorskip("scenes")

FIELDS = ("t", "x", "xd", "xdd", "positions", "origins", "rotations", "kinetic", "potential", "residual",
          "velocity_residual", "reactions")
COUNTS = ("n_rhs", "n_jac", "n_steps", "n_dof", "method", "method_reason", "rtol", "status")


def _same(a, b):
    for name in FIELDS:
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    for name in COUNTS:
        assert getattr(a, name) == getattr(b, name), name
    assert a.flexible == b.flexible and a.coordinate_names == b.coordinate_names


@pytest.mark.parametrize("method", ["CVODE_BDF", "auto"])
def test_a_second_run_on_a_system_is_a_first_run_on_a_new_one(method):
    """B1 N = 8 (a flexible chain under gravity: coordinate springs, the compiled Jacobian), twice on one System."""
    kw = dict(method=method, rtol=2e-5, atol=2e-7, n_out=5, progress=False)
    system = scenes.b1(8).build()
    first = fm.simulate(system, 1.0, **kw)
    again = fm.simulate(system, 1.0, **kw)
    fresh = fm.simulate(scenes.b1(8).build(), 1.0, **kw)
    assert first.method == "CVODE_BDF" and first.n_jac > 0
    _same(first, fresh)
    _same(again, fresh)


def test_other_settings_are_worked_out_again():
    """'auto' on the same System: a short span takes DOP853, the long one CVODE_BDF, and back, as on new Systems."""
    system = scenes.b1(8).build()
    kw = dict(rtol=2e-5, n_out=2, progress=False)
    for t_end, method in ((1e-6, "DOP853"), (1.0, "CVODE_BDF"), (1e-6, "DOP853")):
        res = fm.simulate(system, t_end, **kw)
        assert res.method == method
        _same(res, fm.simulate(scenes.b1(8).build(), t_end, **kw))
    moved = fm.simulate(system, 1.0, positions={system.coordinate_names[0]: 0.2}, **kw)
    _same(moved, fm.simulate(scenes.b1(8).build(), 1.0, positions={system.coordinate_names[0]: 0.2}, **kw))


def test_last_keeps_the_latest_values_and_state_keys_tell_bits_apart():
    system = type("Holder", (), {})()  # any object a weak reference can point to
    calls = []

    def make(v):
        calls.append(v)
        return v

    key = run_memo.state_key
    assert run_memo.last(system, "a", key(0.0), lambda: make(1)) == 1
    assert run_memo.last(system, "a", key(0.0), lambda: make(2)) == 1
    assert run_memo.last(system, "a", key(-0.0), lambda: make(3)) == 3
    assert run_memo.last(system, "a", key(np.zeros(2)), lambda: make(4)) == 4
    assert run_memo.last(system, "a", key(np.zeros(3)), lambda: make(5)) == 5
    assert run_memo.last(system, "a", key(0.0), lambda: make(6)) == 1
    for k in range(run_memo.KEPT):  # pushes the first ones out
        run_memo.last(system, "a", key(float(k + 1)), lambda: make(None))
    assert run_memo.last(system, "a", key(0.0), lambda: make(7)) == 7
    assert run_memo.once(system, "b", lambda: make(8)) == 8 and run_memo.once(system, "b", lambda: make(9)) == 8
    assert calls == [1, 3, 4, 5] + [None] * run_memo.KEPT + [7, 8]
