"""Initial speeds in the user's terms, and speeds that contradict the constraints (issue #29, item 4).

A point's velocity or a body's angular velocity is held while the other
speeds take the least correction onto the constraints; speeds the
constraints or the drivers do not allow are refused, naming both, unless
``hold_speeds=False`` lets the constraints win.
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb as fm
from flexmb.errors import ModelError

from conftest import fourbar, fourbar_initial

THETA = np.pi / 4


def _closed(system):
    x, _ = fm.initial_state(system, positions=fourbar_initial(THETA))
    return x


@pytest.mark.parametrize("complement", ["articulated", "svd"])
def test_crank_tip_velocity_gives_the_crank_speed(complement):
    s = fourbar().build(complement=complement)
    tip_v = 0.1 * 3.0 * np.array([-np.sin(THETA), np.cos(THETA), 0.0])
    x, xd = fm.initial_state(s, positions=fourbar_initial(THETA),
                             speeds=[fm.PointVelocity("crank", (0.1, 0.0, 0.0), tip_v)])
    _, xd_ref = fm.initial_state(s, positions=fourbar_initial(THETA), speeds={"A": 3.0})
    np.testing.assert_allclose(xd, xd_ref, atol=1e-12)
    # one component is enough for one degree of freedom
    _, xd_x = fm.initial_state(s, positions=fourbar_initial(THETA),
                               speeds=fm.PointVelocity("crank", (0.1, 0, 0), tip_v, directions=(1.0, 0.0, 0.0)))
    np.testing.assert_allclose(xd_x, xd_ref, atol=1e-12)
    assert s.constraint_residuals(0.0, x, xd)[1] < 1e-12


def test_coupler_angular_velocity_is_met_in_both_frames():
    s = fourbar().build()
    x = _closed(s)
    for frame in ("inertial", "body"):
        x, xd = fm.initial_state(s, x0=x, speeds=[fm.AngularVelocity("coupler", (0.0, 0.0, 2.5), frame=frame)])
        kin = s.kinematics(0.0, x, xd)
        k = s.index("coupler")
        np.testing.assert_allclose(kin.omega[k], (0.0, 0.0, 2.5), atol=1e-12)  # planar: z is z in both frames
        assert s.constraint_residuals(0.0, x, xd)[1] < 1e-12


def test_simulate_takes_them_and_the_result_shows_them():
    tip_v = 0.1 * 3.0 * np.array([-np.sin(THETA), np.cos(THETA), 0.0])
    res = fm.simulate(fourbar(), 0.01, positions=fourbar_initial(THETA), n_out=3,
                      speeds=[fm.PointVelocity("crank", (0.1, 0.0, 0.0), tip_v)])
    np.testing.assert_allclose(res.point_velocity("crank", (0.1, 0.0, 0.0))[0], tip_v, atol=1e-12)


def test_a_speed_the_driver_forbids_is_refused_naming_both():
    m = fourbar()
    m.add(fm.Driver.constant_speed("motor", m.element("A"), speed=2.0))
    s = m.build()
    with pytest.raises(ModelError, match=r"A\.angle.*contradict.*motor.*hold_speeds=False"):
        fm.initial_state(s, positions=fourbar_initial(THETA), speeds={"A": 1.0})
    with pytest.raises(ModelError, match="contradict"):
        fm.simulate(m, 0.01, positions=fourbar_initial(THETA), speeds={"A": 1.0})
    x, xd = fm.initial_state(s, positions=fourbar_initial(THETA), speeds={"A": 1.0}, hold_speeds=False)
    assert xd[s.coordinate_names.index("A.angle")] == pytest.approx(2.0, abs=1e-12)
    assert s.constraint_residuals(0.0, x, xd)[1] < 1e-12


@pytest.mark.parametrize("complement", ["articulated", "svd"])
def test_speeds_the_loop_forbids_are_refused_unless_the_loop_wins(complement):
    s = fourbar().build(complement=complement)
    with pytest.raises(ModelError, match=r"A\.angle, D\.angle.*contradict.*C"):
        fm.initial_state(s, positions=fourbar_initial(THETA), speeds={"A": 1.0, "D": 5.0})
    x, xd = fm.initial_state(s, positions=fourbar_initial(THETA), speeds={"A": 1.0, "D": 5.0}, hold_speeds=False)
    assert s.constraint_residuals(0.0, x, xd)[1] < 1e-12
    with pytest.raises(ModelError, match="velocity of point"):
        fm.initial_state(s, positions=fourbar_initial(THETA),
                         speeds=[{"A": 1.0}, fm.PointVelocity("rocker", (0.25, 0, 0), (5.0, 5.0, 0.0))])


def test_open_tree_point_velocity_and_its_contradiction():
    m = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", 1.0, 2.0)
    m.add(fm.Revolute("pin", m.ground, bar, axis=(0, 0, 1)))
    _, xd = fm.initial_state(m.build(), speeds=[fm.PointVelocity("bar", (2.0, 0, 0), (0.0, 3.0, 0.0))])
    np.testing.assert_allclose(xd, [1.5], atol=1e-14)
    with pytest.raises(ModelError, match="velocity of point"):  # a radial speed of a pinned bar's tip
        fm.initial_state(m.build(), speeds=[fm.PointVelocity("bar", (2.0, 0, 0), (1.0, 3.0, 0.0))])


def test_bad_specifications_are_refused():
    with pytest.raises(ModelError, match="frame must be"):
        fm.AngularVelocity("b", (0, 0, 1), frame="world")
    with pytest.raises(ModelError, match="directions"):
        fm.PointVelocity("b", (0, 0, 0), (1, 0, 0), directions=(0, 0, 0))
    with pytest.raises(ModelError, match="speeds: an entry must be"):
        fm.initial_state(fourbar().build(), positions=fourbar_initial(THETA), speeds=[3.0])
    with pytest.raises(ModelError, match="the ground does not move"):
        m = fourbar()
        fm.initial_state(m.build(), positions=fourbar_initial(THETA),
                         speeds=[fm.PointVelocity(m.ground, (0, 0, 0), (1, 0, 0))])


BETA, THETA1, W1 = 0.5, 0.7, 2.0

CARDAN = f"""
[model]
name = "cardan"

[bodies.shaft1]
mass = 1.0
inertia = [0.01, 0.1, 0.1]
[bodies.shaft2]
mass = 1.0
inertia = [0.01, 0.1, 0.1]

[joints.bearing1]
type = "revolute"
parent = "ground"
child = "shaft1"
axis = [1.0, 0.0, 0.0]
[joints.bearing2]
type = "revolute"
parent = "ground"
child = "shaft2"
axis = [{np.cos(BETA)}, {np.sin(BETA)}, 0.0]
[joints.cardan]
type = "universal"
parent = "shaft1"
child = "shaft2"
axis = [0.0, 0.0, 1.0]
axis2 = [{-np.sin(BETA)}, {np.cos(BETA)}, 0.0]
cut = true

[drivers.motor]
joint = "bearing1"
speed = {W1}
start = {THETA1}

[initial]
positions = {{ bearing1 = {THETA1}, bearing2 = 0.6 }}
speeds = {{ bearing2 = 1.0 }}

[solver]
t_end = 0.01
n_out = 2
"""


def test_a_cardan_joint_speed_that_contradicts_its_driver_is_refused_unless_the_driver_wins():
    """Issue #29's example: a driven Hooke joint between two bearings at BETA, the output bearing given a speed.

    The output turns at ``w2 = w1 cos(BETA) / (1 - sin(BETA)^2 sin(theta1)^2)`` (theta1 from where the input
    fork is normal to the shafts' plane), so 1 rad/s contradicts the driver's 2 rad/s: refused naming the speed
    and the driver when the scene is read (it was accepted, and the first output row violated the driver); with
    hold_speeds = false the driver wins and the output bearing turns at the Hooke joint's rate.
    """
    with pytest.raises(ModelError, match=r"bearing2\.angle.*contradict.*driver motor.*hold_speeds=False"):
        fm.loads_scene(CARDAN)  # refused as the scene is read (it was refused by simulate)
    scene = fm.loads_scene(CARDAN.replace("speeds = {", "hold_speeds = false\nspeeds = {"))
    assert scene.initial.hold_speeds is False
    res = scene.simulate()
    w2 = W1 * np.cos(BETA) / (1 - np.sin(BETA) ** 2 * np.sin(THETA1) ** 2)
    assert res.xd[0, res.coordinate_names.index("bearing1.angle")] == pytest.approx(W1, abs=1e-12)
    assert abs(res.xd[0, res.coordinate_names.index("bearing2.angle")]) == pytest.approx(w2, rel=1e-10)
    assert w2 - 1.0 > 0.5  # the speed given was far from the one allowed
    with pytest.raises(fm.SceneError, match=r"initial\.hold_speeds.*true or false"):
        fm.loads_scene(CARDAN.replace("speeds = {", "hold_speeds = 1\nspeeds = {"))
