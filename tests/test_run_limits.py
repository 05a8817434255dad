"""Issue #33, section 5: runs that would never end are refused before they start (``simulate(max_steps=...)``)."""

from contextlib import nullcontext

import numpy as np
import pytest

import flexmb as fm
from flexmb.simulate import MAX_STEPS
from strategies import alarm


def pendulum(spring=False):
    m = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    pin = fm.Revolute("pin", m.ground, bar, axis=(0, 0, 1))
    m.add(pin, fm.Gravity((0, -9.81, 0)))
    if spring:
        m.add(fm.JointSpringDamper("spring", pin, 3.0, 0.1))
    return m


def test_tiny_max_step_refused():
    """``max_step=1e-300``: the run stepped for ever."""
    match = (r"simulate: max_step = 1e-300 s needs at least 1e\+300 steps over \[0, 1\] s, more than "
             r"max_steps = 1e\+09; .* pass a larger max_steps")
    with alarm(30.0), pytest.raises(fm.ModelError, match=match):
        fm.simulate(pendulum(), 1.0, positions={"pin": 0.5}, max_step=1e-300, progress=False)


def test_tiny_fixed_step_refused():
    """``generalized_alpha(fixed_step=1e-300)``: the run stepped for ever."""
    with alarm(30.0), pytest.raises(fm.ModelError, match=r"fixed_step = 1e-300 s needs at least 1e\+300 steps"):
        fm.simulate(pendulum(), 1.0, positions={"pin": 0.5}, method=fm.generalized_alpha(fixed_step=1e-300),
                    progress=False)


@pytest.mark.parametrize("spring, method", [(False, "auto"), (False, "RK45"), (True, "DOP853")])
def test_endless_span_refused(spring, method):
    """``t_end = 1e300``: 'auto' took DOP853 (no springs: a rate of 0) and stepped for ever."""
    match = (r"simulate: the stability of (DOP853|RK45) \(the fastest rate of the linearised motion is [\d.]+ "
             r"1/s\) needs at least [\d.]+e\+299 steps")
    stiff = pytest.warns(fm.StiffnessWarning) if spring else nullcontext()
    with alarm(30.0), stiff, pytest.raises(fm.ModelError, match=match):
        fm.simulate(pendulum(spring), 1e300, positions={"pin": 0.5}, method=method, progress=False)


def test_max_steps_can_be_raised_or_lowered():
    # 1 s at max_step 1e-3: 1000 steps at least
    with pytest.raises(fm.ModelError, match="max_step = 0.001 s needs at least 1e\\+03 steps .* max_steps = 500"):
        fm.simulate(pendulum(), 1.0, positions={"pin": 0.5}, max_step=1e-3, max_steps=500, progress=False)
    res = fm.simulate(pendulum(), 0.01, positions={"pin": 0.5}, max_step=1e-5, max_steps=2000, progress=False)
    assert res.status == "finished" and res.n_steps >= 1000
    assert MAX_STEPS == 10**9


@pytest.mark.parametrize("bad", [0, -1, float("nan"), "many", None])
def test_max_steps_checked(bad):
    with pytest.raises(fm.ModelError, match="simulate: max_steps must be"):
        fm.simulate(pendulum(), 0.1, max_steps=bad, progress=False)


def test_stability_rate_of_a_pendulum():
    # gravity's geometric stiffness: sqrt(m g (L/2) cos q / (m L^2 / 3)) for the bar hanging at q from the vertical
    s = pendulum().build()
    q = 0.5  # the pin angle from +x (the bar along x at q = 0; gravity along -y)
    w = s.stability_rate(0.0, np.array([q]), np.zeros(1))
    assert w == pytest.approx(np.sqrt(1.5 * 9.81 * abs(np.sin(q))), rel=1e-9)
    assert s.fastest_rate(0.0, np.array([q]), np.zeros(1)) == 0.0
