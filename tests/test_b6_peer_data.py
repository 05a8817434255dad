"""The flexmb side of the B6 comparison with Exudyn (benchmarks/peers/b6_data.py, compare_b6.py).

Exudyn is not needed: the numbers handed to the peer script are checked
against beam theory and the scene's definition, the planar body states the
peer starts from against the loop closure (the rod's last end on the slider,
with the slider's velocity) and the driver, and the robust choice of a
setting against a grid where a loose setting passes by luck.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
sys.path.insert(0, BENCH)
sys.path.insert(0, os.path.join(BENCH, "peers"))

import flexmb as fm  # noqa: E402

scenes = pytest.importorskip("scenes")
b6_data_mod = pytest.importorskip("b6_data")


@pytest.fixture(scope="module")
def data4():
    return b6_data_mod.b6_data(4)


def test_numbers_are_the_scene_and_beam_theory(data4):
    d = data4
    b, h, L, E, rho = scenes.B6_B, scenes.B6_H, scenes.B6_L, 210e9, 7850.0
    l = L / 4
    m = rho * b * h * l
    assert d["n_segments"] == 4 and d["segment_length"] == pytest.approx(l, rel=1e-15)
    assert d["segment_mass"] == pytest.approx(m, rel=1e-14)
    assert d["segment_inertia"] == pytest.approx(m * (l**2 + b**2) / 12, rel=1e-14)  # block, in-plane width b
    assert d["segment_com"] == pytest.approx(l / 2, rel=1e-15)
    k = E * (h * b**3 / 12) / l
    assert len(d["k"]) == 3 and np.allclose(d["k"], k, rtol=1e-14)  # unclamped: N - 1 joints, E I_z / l
    beta = 2 * scenes.B6_ZETA / (2 * np.pi * scenes.b6_rod_frequency())
    assert np.allclose(d["c"], beta * k, rtol=1e-14)
    assert d["crank_mass"] == 0.5 and d["crank_inertia"] == pytest.approx(0.5 * 0.1**2 / 12, rel=1e-14)
    assert d["crank_com"] == pytest.approx(0.05) and d["slider_mass"] == 0.3
    assert d["speed"] == pytest.approx(10 * np.pi, rel=1e-15)
    assert d["x0"][d["coordinate_names"].index("rail.slide")] == pytest.approx(0.5, rel=1e-14)


def _rod_end(d, states):
    """The rod's last end and its velocity from the last segment's state."""
    x, y, a, vx, vy, w = states[-2]
    arm = d["segment_length"] - d["segment_com"]
    end = np.array([x, y]) + arm * np.array([np.cos(a), np.sin(a)])
    vel = np.array([vx, vy]) + arm * w * np.array([-np.sin(a), np.cos(a)])
    return end, vel


@pytest.mark.parametrize("t0", [0.0, 0.013])
def test_initial_bodies_close_the_loop(t0):
    model, positions = scenes.b6(damped=True, n_segments=5)
    system = model.build()
    guess = dict(positions, **({"rod.j2.bend_z": 0.01} if t0 else {}))
    x0, xd0 = fm.initial_state(system, t0=t0, positions=guess)
    d = dict(b6_data_mod.b6_data(5), x0=x0.tolist(), xd0=xd0.tolist())
    states = b6_data_mod.initial_bodies(d)
    assert len(states) == 1 + 5 + 1
    crank = states[0]
    assert crank[2] == pytest.approx(d["speed"] * t0, abs=1e-12) and crank[5] == pytest.approx(d["speed"])
    end, vel = _rod_end(d, states)
    slider = states[-1]
    assert np.allclose(end, slider[:2], atol=1e-10)  # the cut joint: rod end on the slider
    assert np.allclose(vel, slider[3:5], atol=1e-9)
    if t0:  # a bent, turned state: the loop still closes through every segment
        assert abs(states[3][2] - states[2][2]) > 1e-3


def test_initial_bodies_fail_a_broken_state(data4):
    """The check above can fail: a rod speed the loop does not allow leaves the rod end off the slider's speed."""
    d = dict(data4, xd0=list(data4["xd0"]))
    d["xd0"][d["coordinate_names"].index("rod.j2.bend_z")] += 1.0
    _, vel = _rod_end(d, b6_data_mod.initial_bodies(d))
    assert not np.allclose(vel, b6_data_mod.initial_bodies(d)[-1][3:5], atol=1e-9)


compare_b6 = pytest.importorskip("compare_b6")


def _row(tool, loose, error, wall, family="CVODE_BDF", status="finished"):
    key = {"rtol": loose, "h": None} if tool == "flexmb" else {"rtol": None, "h": loose}
    return {"tool": tool, "n_segments": 8, "integrator": family, "error": error, "wall_s": wall,
            "status": status, **key}


def test_robust_pick_skips_a_loose_setting_that_passes_by_luck():
    rows = [_row("flexmb", 1e-3, 5e-7, 0.5), _row("flexmb", 3e-4, 2e-6, 0.7), _row("flexmb", 1e-4, 4e-7, 0.9),
            _row("flexmb", 1e-5, 1e-8, 1.5)]
    robust, best = compare_b6.robust_pick(rows, 1e-6)
    assert robust["rtol"] == 1e-4 and best["rtol"] == 1e-3
    # a failed tighter run breaks the chain below it
    rows[-1] = _row("flexmb", 1e-5, None, None, status="failed: error test")
    assert compare_b6.robust_pick(rows, 1e-6)[0] is None
    # families are judged apart; the fastest robust setting wins
    ex = [_row("exudyn", 2.5e-4, 2e-6, 0.2, "newton 1e-4"), _row("exudyn", 1.25e-4, 5e-7, 0.3, "newton 1e-4"),
          _row("exudyn", 2.5e-4, 9e-7, 0.25, "newton 1e-5"), _row("exudyn", 1.25e-4, 5e-7, 0.35, "newton 1e-5")]
    robust, best = compare_b6.robust_pick(ex, 1e-6)
    assert (robust["h"], robust["integrator"]) == (2.5e-4, "newton 1e-5") and best is robust
    # a tighter setting that is faster (fewer rejected steps) is robust as well and wins
    cv = [_row("flexmb", 1e-4, 2e-7, 14.0), _row("flexmb", 3e-5, 2e-8, 7.5), _row("flexmb", 1e-5, 8e-9, 4.8)]
    assert compare_b6.robust_pick(cv, 1e-6)[0]["rtol"] == 1e-5
