"""Benchmark B7 of benchmarks/scenes.py: the chain of N parallelogram four-bars (IFToMM A02 for N = 1).

Its size (2N + 1 coordinates, 2N rows with planar cuts, 5N of rank 2N with
spatial ones, one freedom), the start (the first rod's top at +1 m/s along
+x), and the motion against the closed form: every rod at the same angle
theta, the couplers translating, so energy conservation gives theta'^2 as a
function of theta alone.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import flexmb as fm

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
sys.path.insert(0, BENCH)

scenes = pytest.importorskip("scenes")


@pytest.fixture(scope="module", params=[1, 2], ids=["N1_A02", "N2"])
def run(request):
    n = request.param
    model, initial = scenes.b7(n)
    return n, fm.simulate(model, 0.5, progress=False, **initial)


def test_size():
    model, initial = scenes.b7(4)
    system = model.build()
    assert system.n_coords == 9 and system.n_constraints == 8 and system.dof() == 1
    assert sorted(initial) == ["positions", "speeds"]
    assert set(initial["positions"]) == set(system.coordinate_names)
    spatial = scenes.b7(4, planar_cuts=False)[0].build()
    assert spatial.n_coords == 9 and spatial.n_constraints == 20 and spatial.dof() == 1


@pytest.mark.parametrize("n", [0, -1, 1.5, True])
def test_bad_n_loops(n):
    with pytest.raises(ValueError, match="n_loops"):
        scenes.b7(n)


def test_start():
    model, initial = scenes.b7(2)
    system = model.build()
    x, xd = fm.initial_state(system, 0.0, **initial)
    names = system.coordinate_names
    assert np.all(x == 0.0)
    for k in range(3):
        assert xd[names.index(f"pin_{k}.angle")] == pytest.approx(-1.0, abs=1e-12)
    for k in range(2):
        assert xd[names.index(f"hinge_{k}.angle")] == pytest.approx(1.0, abs=1e-12)
    kin = system.kinematics(0.0, x, xd)
    i = system.body_names.index("rod_0")
    top = kin.point_position(i, np.array([0.0, scenes.B7_L, 0.0]))
    np.testing.assert_allclose(top, [0.0, 1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(kin.point_velocity(i, top), [1.0, 0.0, 0.0], atol=1e-12)


def test_rods_parallel_and_energy_conserved(run):
    n, res = run
    assert res.status == "finished"
    pins = np.array([res.coordinate(f"pin_{k}") for k in range(n + 1)])
    np.testing.assert_allclose(pins, np.broadcast_to(pins[0], pins.shape), rtol=0, atol=1e-6)
    hinges = np.array([res.coordinate(f"hinge_{k}") for k in range(n)])
    np.testing.assert_allclose(hinges, np.broadcast_to(-pins[0], hinges.shape), rtol=0, atol=1e-6)  # couplers translate
    e = res.energy
    assert np.max(np.abs(e / e[0] - 1.0)) < 1e-6
    assert pins[0, -1] < -0.5  # it has fallen well over to +x


def test_closed_form(run):
    n, res = run
    theta = res.coordinate("pin_0")
    a, potential = scenes.b7_reference(theta, n)
    e0 = a * scenes.B7_SPEED**2 + scenes.b7_reference(0.0, n)[1]
    rate = res.xd[:, res.coordinate_names.index("pin_0.angle")]
    for i in np.linspace(0, len(res.t) - 1, 6).astype(int):
        assert rate[i] ** 2 == pytest.approx((e0 - potential[i]) / a, rel=1e-6)
    tip = scenes.b7_tip(res)
    np.testing.assert_allclose(tip[:, :2], np.column_stack([-np.sin(theta), np.cos(theta)]) * scenes.B7_L,
                               atol=1e-12)
    np.testing.assert_allclose(tip[:, 2], 0.0, atol=1e-12)
