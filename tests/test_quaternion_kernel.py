"""Joints in Euler parameters through the compiled kernels (#29): main's Python evaluation path reproduced.

``tests/data/quaternion_kernel_reference.npz`` holds the state rates at
random states, runs, a linearisation and statics of models in Euler
parameters computed on main (26de9e9) while such a joint computed its motion
in Python (``tests/data/make_quaternion_kernel_reference.py``); the compiled
kernels must reproduce them to 1e-10. The state Jacobian of such models is
checked against differences.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import flexmb as fm

DATA = Path(__file__).resolve().parent / "data"
sys.path.insert(0, str(DATA))

import make_quaternion_kernel_reference as ref  # noqa: E402

REFERENCE = np.load(DATA / "quaternion_kernel_reference.npz")
RUNS = {name: (model, kwargs) for name, model, kwargs in ref.runs()}


def _same(name, new):
    keys = sorted(k.split("/", 1)[1] for k in REFERENCE if k.startswith(name + "/"))
    assert keys and set(keys) == set(new), "the same quantities exist"
    for key in keys:
        old = REFERENCE[f"{name}/{key}"]
        scale = max(1.0, float(np.max(np.abs(old)))) if old.size else 1.0
        np.testing.assert_allclose(np.asarray(new[key]), old, rtol=1e-10, atol=1e-10 * scale,
                                   err_msg=f"{name}: {key}")


@pytest.mark.parametrize("name", sorted(RUNS))
def test_runs_match_main(name):
    model, kwargs = RUNS[name]
    _same(name, ref.run(model, kwargs))


def test_rates_and_analyses_match_main():
    for name, values in [*ref.rates(), *ref.analyses()]:
        _same(name, values)


def test_quaternion_joints_take_the_compiled_route():
    for make in (ref.heavy_top, ref.tumbling, ref.chain, ref.loop):
        system = make()[0].build()
        assert not system.topology.external_groups and system._packed is not None
    assert ref.heavy_top()[0].build()._packed_open is not None  # an open tree: one kernel call per rhs
    assert ref.loop()[0].build().with_complement("auto")._loop_kernel  # loops through the recursion
