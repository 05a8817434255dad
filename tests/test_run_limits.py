"""Issue #33, section 5: runs that would never end are refused before they start (``simulate(max_steps=...)``)."""

from contextlib import nullcontext

import numpy as np
import pytest

import flexmb as fm
from flexmb.simulate import MAX_STEPS, _solver_class, _warn_if_stiff
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


# ----------------------------------------------------------------------------- dampers count as stiffness

def spring_damper_slider(damping, stiffness=1.0, two_bodies=False):
    m = fm.Model()
    b = fm.RigidBody("blk", 1.0, (1, 1, 1))
    m.add(fm.Prismatic("slide", m.ground, b, axis=(1, 0, 0)))
    anchor = m.ground
    if two_bodies:  # the damper between two moving bodies: on their relative motion
        anchor = fm.RigidBody("base", 2.0, (1, 1, 1))
        m.add(fm.Prismatic("base_slide", m.ground, anchor, axis=(1, 0, 0)),
              fm.JointSpringDamper("base_spring", "base_slide", 1.0, 0.0))
    m.add(fm.SpringDamper("sd", anchor, (0, 0, 0), b, (0, 0, 0), stiffness=stiffness, damping=damping,
                          rest_length=0.5))
    return m


@pytest.mark.parametrize("two_bodies", [False, True])
def test_auto_counts_a_stiff_damper(two_bodies):
    """A spring-damper with damping 1e9 ran on DOP853 ('its fastest rate is 0 rad/s'), stepping for minutes."""
    with alarm(60.0):
        res = fm.simulate(spring_damper_slider(1e9, two_bodies=two_bodies), 0.02, positions={"slide": 1.0},
                          progress=False)
    assert res.status == "finished" and res.method != "DOP853" and "stiff" in res.method_reason
    s = spring_damper_slider(1e9, two_bodies=two_bodies).build()
    x = np.array([1.0] if not two_bodies else [0.0, 1.0])
    # the damper's rate c (1/m + 1/M) on the relative motion (c / m against the ground)
    expected = 1e9 * (1.5 if two_bodies else 1.0)
    assert s.fastest_rate(0.0, x, np.zeros_like(x)) == pytest.approx(expected, rel=1e-9)


def test_explicit_method_warned_of_a_stiff_spring():
    """A SpringDamper's stiffness was not counted: no StiffnessWarning for DOP853 on k = 1e8 (omega = 1e4 rad/s)."""
    s = spring_damper_slider(0.0, stiffness=1e8).build()
    with pytest.warns(fm.StiffnessWarning, match="highest natural frequency is about 1e\\+04 rad/s"):
        _warn_if_stiff(s, _solver_class("DOP853", s, False, True), 0.0, 1.0, np.array([1.0]), np.zeros(1))
