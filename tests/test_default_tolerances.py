"""simulate()'s default tolerances: 1e-8, and 5e-10 for DOP853 (issue 28, docs/guide.md "Tolerances over long runs").

The global error of a long run of a large motion (an angle going round,
a chain falling through its flat positions) grows with the square of the
run's length: the integrator's local errors change the energy a little
at every step, always the same way for a Runge-Kutta method, and the
energy sets how fast the motion goes round. The defaults are measured
against references outside flexmb: the pendulum's and the B7 chain's own
one-degree-of-freedom equations (scipy's DOP853 at rtol 1e-13). At the
old default (DOP853 at rtol 1e-8) the pendulum's tip is 1.0e-6 m off after
10 s and B7's (N = 40, 20 s) 9.9e-6 m, so these tests fail there.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest
from scipy.integrate import DOP853, solve_ivp

import flexmb as fm
from flexmb.integrators import default_rtol

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
G = 9.81


def pendulum():
    model = fm.Model("pendulum")
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0.0, -G, 0.0)))
    return model.build()


def pendulum_tip(t, w0):
    """The 1 m bar's tip from its own equation theta'' = -(3 g / 2 L) cos(theta), from 0 at ``w0``."""
    sol = solve_ivp(lambda _, y: [y[1], -1.5 * G * np.cos(y[0])], (0.0, t[-1]), [0.0, w0], method="DOP853",
                    rtol=1e-13, atol=1e-14, t_eval=t)
    return np.column_stack([np.cos(sol.y[0]), np.sin(sol.y[0])])


class Loose(DOP853):
    """A plugin integrator declaring its own default tolerance."""

    default_rtol = 1e-5


@pytest.mark.parametrize("method, rtol", [("auto", 5e-10), ("DOP853", 5e-10), ("RK45", 1e-8), ("Radau", 1e-8),
                                          ("CVODE_BDF", 1e-8), ("GeneralizedAlpha", 1e-8), (Loose, 1e-5)])
def test_default_rtol_is_the_integrators(method, rtol):
    res = fm.simulate(pendulum(), 0.2, speeds={"pin": 1.0}, method=method, n_out=3, progress=False)
    assert res.rtol == rtol
    assert fm.simulate(pendulum(), 0.2, speeds={"pin": 1.0}, method=method, rtol=1e-6, n_out=3,
                       progress=False).rtol == 1e-6  # a given rtol is used as given, whatever the integrator


def test_default_atol_follows_the_default_rtol():
    """``atol`` defaults to rtol / 100 of the rtol in use: the defaults are rtol 5e-10, atol 5e-12 for DOP853."""
    system = pendulum()
    kw = dict(speeds={"pin": 10.0}, method="DOP853", n_out=11, progress=False)
    default = fm.simulate(system, 2.0, **kw)
    given = fm.simulate(system, 2.0, rtol=5e-10, atol=5e-12, **kw)
    np.testing.assert_array_equal(default.x, given.x)
    assert default.n_steps == given.n_steps


def test_the_default_is_declared_or_looked_up_along_the_bases():
    class MyDOP853(DOP853):
        pass

    assert default_rtol(DOP853) == default_rtol(MyDOP853) == 5e-10
    assert default_rtol(Loose) == 1e-5
    assert default_rtol(fm.GeneralizedAlpha) == default_rtol(fm.integrators.CVODEBDF) == 1e-8


def test_pendulum_over_the_top_at_defaults():
    """13 turns in 10 s at the defaults: the tip within 2e-7 m of the bar's own equation (1.0e-6 m at rtol 1e-8)."""
    t = np.linspace(0.0, 10.0, 101)
    res = fm.simulate(pendulum(), 10.0, speeds={"pin": 10.0}, n_out=len(t), progress=False)
    assert res.method == "DOP853"
    tip = np.column_stack([np.cos(res.x[:, 0]), np.sin(res.x[:, 0])])
    assert np.max(np.linalg.norm(tip - pendulum_tip(t, 10.0), axis=1)) < 2e-7


@pytest.mark.slow
def test_b7_n40_over_20s_at_defaults():
    """Issue 28: B7 at N = 40 over 20 s with simulate()'s defaults, the first rod's top within 1e-6 m."""
    sys.path.insert(0, BENCH)
    scenes = pytest.importorskip("scenes")
    model, initial = scenes.b7(40)
    res = fm.simulate(model, 20.0, progress=False, **initial)
    assert res.status == "finished" and res.method == "DOP853"
    exact = scenes.b7_closed_form(res.t, 40)
    assert np.max(np.linalg.norm(scenes.b7_tip(res)[:, :2] - exact, axis=1)) < 1e-6


SCENE = """
[bodies.bar]
shape = "slender_bar"
mass = 1.0
length = 1.0
[joints.pin]
type = "revolute"
parent = "ground"
child = "bar"
[solver]
t_end = 0.2
n_out = 3
"""


def test_a_scene_without_rtol_runs_at_simulates_default():
    scene = fm.loads_scene(SCENE)
    assert scene.solver.rtol is None
    assert scene.simulate(progress=False).rtol == 5e-10  # 'auto' takes DOP853: no springs
    assert scene.simulate(progress=False, method="Radau").rtol == 1e-8
    assert scene.simulate(progress=False, rtol=1e-6).rtol == 1e-6
    assert "rtol the integrator's default" in scene.info()
    assert "rtol 1e-06" in fm.loads_scene(SCENE + "rtol = 1e-6\n").info()
