"""Spherical and Free joints in Euler parameters (#29 item 2): no gimbal lock, against independent models.

The hand-written quaternion models of ``benchmarks/rotations.py`` (the
rigid body's Euler equations in body axes, ``qd = 1/2 q * (w, 0)``, by
scipy's DOP853; no flexmb code) are the references; the Bryant-angle joints
keep giving what they gave (``tests/test_state_split.py`` holds main's
results of models on them).
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import flexmb as fm
from flexmb import quaternions as quat

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))

import rotations as bench  # noqa: E402


def _hand(scene, q0, w0, times, rtol=1e-12):
    rhs, J = bench.hand_model(scene)
    sol = solve_ivp(rhs, (0.0, times[-1]), np.concatenate([q0, w0]), method="DOP853", rtol=rtol, atol=rtol * 1e-2,
                    t_eval=times)
    return np.array([bench._matrix(q) for q in sol.y[:4].T]), sol.y[4:].T, J


def _run(scene, q0, w0, t_end, rtol=1e-10, n_out=41, method="DOP853"):
    positions, speeds = bench._flexmb_initial(scene, "quaternion", q0, w0)
    return fm.simulate(bench.flexmb_model(scene), t_end, positions=positions, speeds=speeds, method=method,
                       rtol=rtol, n_out=n_out, progress=False)


def test_heavy_top_through_ry_90_deg_matches_the_hand_quaternion_model():
    # tilted 80 deg about y, the spinning top nutates down through the horizontal: its axis passes by the
    # inertial x axis, where the Bryant angles' ry reaches 90 deg
    q0, w0 = bench.initial_state("top", 80.0)
    w0 = w0 * 0.25
    res = _run("top", q0, w0, 0.8)
    R_hand, w_hand, J = _hand("top", q0, w0, res.t)
    R = res.rotations[:, 0]
    assert np.max(np.abs(R - R_hand)) < 1e-7
    np.testing.assert_allclose(res.angular_velocity("body", frame="body"), w_hand, atol=1e-6)
    # through gimbal lock: the axis tilts past the horizontal near inertial x, and the Bryant view of the
    # same rotations (ry up to 90 deg) turns rx and rz by half a turn there
    tilt = np.degrees(np.arccos(R[:, 2, 2]))
    assert tilt[0] == pytest.approx(80.0) and tilt.max() > 95.0
    angles = res.body_rotation("body", view="bryant")
    assert np.degrees(angles[:, 1]).max() > 88.0 and np.max(np.abs(np.diff(angles[:, 0]))) > np.pi / 2
    assert np.max(np.abs(np.linalg.norm(res.x, axis=1) - 1.0)) < 1e-12  # unit quaternions in the outputs
    energy = res.kinetic + res.potential
    assert np.max(np.abs(energy - energy[0])) < 1e-7 * abs(energy[0]) + 1e-9


def test_top_started_exactly_at_gimbal_lock():
    # the axis along inertial x: ry = 90 deg at t = 0, where the Bryant angles' rates are undefined
    q0, w0 = bench.initial_state("top", 90.0)
    res = _run("top", q0, w0, 0.3, n_out=7)
    R_hand, _, _ = _hand("top", q0, w0, res.t)
    assert np.max(np.abs(res.rotations[:, 0] - R_hand)) < 1e-7
    assert res.body_rotation("body", view="bryant")[0, 1] == pytest.approx(np.pi / 2)


def test_torque_free_body_conserves_energy_and_angular_momentum():
    q0, w0 = bench.initial_state("tumbling", 0.0)
    t_end = 5 * 2 * np.pi / np.linalg.norm(w0)  # five periods, with flips about the intermediate axis
    res = _run("tumbling", q0, w0, t_end, rtol=1e-10, n_out=101)
    R = res.rotations[:, 0]
    w = res.angular_velocity("body", frame="body")
    energy = 0.5 * np.einsum("ti,ij,tj->t", w, bench.BODY_INERTIA, w)
    H = np.einsum("tij,jk,tk->ti", R, bench.BODY_INERTIA, w)
    assert np.max(np.abs(energy / energy[0] - 1.0)) < 1e-8
    assert np.max(np.linalg.norm(H - H[0], axis=1)) < 1e-8 * np.linalg.norm(H[0])
    assert np.min(w[:, 1]) < -0.9  # it tumbles: the intermediate-axis spin reverses
    np.testing.assert_allclose(res.kinetic, energy, rtol=1e-12)
    R_hand, _, _ = _hand("tumbling", q0, w0, res.t)
    assert np.max(np.abs(R - R_hand)) < 1e-6
    np.testing.assert_allclose(res.x[:, :3], 0.0, atol=1e-12)  # no translation


def test_bryant_option_is_the_default_and_unchanged():
    model = bench.flexmb_model("top", rotation="bryant")
    joint = model.element("pivot")
    assert type(joint) is fm.Spherical and joint.rotation == "bryant" and joint.coordinate_names == ("rx", "ry", "rz")
    top = fm.RigidBody("top", 1.0, (0.02, 0.02, 0.01), com=(0, 0, 0.1))
    assert type(fm.Spherical("s", fm.Model().ground, top)) is fm.Spherical
    kw = dict(positions={"pivot.rx": 0.5}, speeds={"pivot.rz": 40.0}, method="DOP853", rtol=1e-9, n_out=11,
              progress=False)
    a = fm.simulate(model, 0.3, **kw)
    m2 = fm.Model("top")
    top2 = fm.RigidBody("body", bench.TOP_MASS, bench.TOP_INERTIA, com=tuple(bench.TOP_COM))
    m2.add(fm.Spherical("pivot", m2.ground, top2), fm.Gravity((0.0, 0.0, -bench.G)))
    b = fm.simulate(m2, 0.3, **kw)
    np.testing.assert_array_equal(a.x, b.x)
    assert a.system.layout.identity and a.x.shape == a.xd.shape


def test_quaternion_layout_names_and_kinematic_equations():
    model = fm.Model()
    body = fm.RigidBody("b", 1.0, (1.0, 2.0, 3.0))
    model.add(fm.Free("f", model.ground, body, rotation="quaternion"),
              fm.Revolute("pin", body, fm.RigidBody("arm", 1.0, (0.1, 0.1, 0.1)), axis=(0, 0, 1)))
    system = model.build()
    # one coordinate per speed at the speed's index, qw after all of them
    assert system.coordinate_names == ["f.x", "f.y", "f.z", "f.qx", "f.qy", "f.qz", "pin.angle", "f.qw"]
    assert system.speed_names == ["f.x", "f.y", "f.z", "f.wx", "f.wy", "f.wz", "pin.angle"]
    assert np.flatnonzero(system.topology.coord_angle).tolist() == [6]  # only the pin's angle may wind
    layout = system.layout
    assert (layout.nq, layout.n, layout.identity) == (8, 7, False)
    rng = np.random.default_rng(3)
    q = layout.normalized(rng.normal(size=8))
    u = rng.normal(size=7)
    W = layout.kinematic_matrix(q)
    np.testing.assert_allclose(W @ u, layout.coordinate_rates(q, u), atol=1e-15)
    np.testing.assert_allclose(layout.per_coordinate(q, np.eye(7)) @ W, np.eye(7), atol=1e-14)
    h = 1e-7  # displace is q + W du to first order, and keeps unit quaternions
    np.testing.assert_allclose((layout.displace(q, h * u) - q) / h, W @ u, atol=1e-6)
    assert abs(np.linalg.norm(layout.displace(q, u)[[3, 4, 5, 7]]) - 1.0) < 1e-15
    # d(W u)/dq by central differences
    J = layout.rate_jacobian(q, u)
    fd = np.array([(layout.coordinate_rates(q + h * e, u) - layout.coordinate_rates(q - h * e, u)) / (2 * h)
                   for e in np.eye(8)]).T
    np.testing.assert_allclose(J, fd, atol=1e-8)
    np.testing.assert_array_equal(layout.reference(), [0, 0, 0, 0, 0, 0, 0, 1])
    y = system.layout.join(q, u)
    np.testing.assert_allclose(system.state_rate(0.0, y)[:8], W @ u, atol=1e-15)


def test_quaternion_joint_in_a_loop_is_projected_and_closes():
    # a crank on a pin drives a rod whose quaternion ball joint sits on the crank; the rod's far end is held
    # by a cut ball joint on a slider: projection moves the quaternion along the speeds and keeps it unit
    model = fm.Model("rssp")
    crank = fm.RigidBody.slender_bar("crank", 1.0, 0.2)
    rod = fm.RigidBody("rod", 1.0, (1e-3, 0.03, 0.03), com=(0.3, 0.0, 0.0))
    slider = fm.RigidBody("slider", 1.0, (0.01, 0.01, 0.01))
    model.add(fm.Revolute("pin", model.ground, crank, axis=(0, 0, 1)),
              fm.Spherical("ball", crank, rod, parent_point=(0.2, 0, 0), rotation="quaternion"),
              fm.Prismatic("rail", model.ground, slider, parent_point=(0.0, 0.0, 0.0), axis=(1, 0, 0)),
              fm.Spherical("end", rod, slider, parent_point=(0.6, 0, 0), cut=True),
              fm.Gravity((0.0, -9.81, 0.0)))
    system = model.build()
    x0, xd0 = fm.initial_state(system, positions={"pin": 0.7, "rail": 0.75, "ball": [0.0, 0.0, -0.3, 1.0]},
                               speeds={"pin": 1.0})
    assert system.constraint_residual(0.0, x0, xd0) < 1e-10
    ball = system.coordinate_indices("ball")
    assert [system.coordinate_names[i] for i in ball] == ["ball.qx", "ball.qy", "ball.qz", "ball.qw"]
    assert abs(np.linalg.norm(x0[ball]) - 1.0) < 1e-14
    res = fm.simulate(model, 0.5, x0=x0, xd0=xd0, method="Radau", rtol=1e-8, n_out=11, progress=False)
    assert np.max(res.residual) < 1e-9 and np.max(res.velocity_residual) < 1e-9
    assert np.max(np.abs(np.linalg.norm(res.x[:, ball], axis=1) - 1.0)) < 1e-12
    energy = res.kinetic + res.potential  # no loss but the integration's
    assert np.max(np.abs(energy - energy[0])) < 1e-6


def test_quaternion_joints_refuse_what_needs_angles():
    def top_model(*extra):
        model = fm.Model()
        top = fm.RigidBody("top", 1.0, (0.02, 0.02, 0.01), com=(0, 0, 0.1))
        j = fm.Spherical("pivot", model.ground, top, rotation="quaternion")
        model.add(j, *[e(j) for e in extra])
        return model

    with pytest.raises(fm.ModelError, match="Euler parameters"):
        top_model(lambda j: fm.Driver("drive", j, lambda t: t, lambda t: 1.0, lambda t: 0.0)).build()
    with pytest.raises(fm.ModelError, match="rotation must be one of"):
        fm.Spherical("s", fm.Model().ground, fm.RigidBody("b", 1.0, (1, 1, 1)), rotation="euler")


def test_rotation_views():
    q0, w0 = bench.initial_state("top", 30.0)
    res = _run("top", q0, w0, 0.1, n_out=3)
    R = res.body_rotation("body")
    np.testing.assert_allclose(res.body_rotation("body", view="quaternion")[0], q0, atol=1e-14)
    np.testing.assert_allclose(res.body_rotation("body", view="axis-angle")[0], [0.0, np.radians(30.0), 0.0],
                               atol=1e-14)
    np.testing.assert_allclose(quat.rotation_matrix(res.body_rotation("body", view="quaternion")), R, atol=1e-14)
    with pytest.raises(fm.ModelError, match="view must be one of"):
        res.body_rotation("body", view="euler")


def test_scene_file_takes_the_rotation_option():
    scene = fm.loads_scene("""
[model]
name = "top"
[bodies.body]
type = "rigid_body"
mass = 1.0
inertia = [0.02, 0.02, 0.01]
com = [0.0, 0.0, 0.1]
[joints.pivot]
type = "spherical"
parent = "ground"
child = "body"
rotation = "quaternion"
[forces.gravity]
type = "gravity"
g = [0.0, 0.0, -9.81]
[initial]
positions = { pivot = [0.0, 0.8660254037844386, 0.0, 0.5] }
speeds = { "pivot.wz" = 40.0 }
[solver]
t_end = 0.2
method = "DOP853"
rtol = 1e-10
""")
    assert type(scene.model.element("pivot")) is fm.joints.SphericalQuaternion
    res = scene.simulate(progress=False)
    q0, w0 = bench.initial_state("top", 120.0)
    R_hand, _, _ = _hand("top", q0, w0, res.t)
    assert np.max(np.abs(res.rotations[:, 0] - R_hand)) < 1e-7
    with pytest.raises(fm.SceneError, match="no speed or joint named 'pivot.qw'"):
        fm.loads_scene("""
[model]
name = "top"
[bodies.body]
type = "rigid_body"
mass = 1.0
inertia = [0.02, 0.02, 0.01]
[joints.pivot]
type = "spherical"
parent = "ground"
child = "body"
rotation = "quaternion"
[initial]
speeds = { "pivot.qw" = 1.0 }
[solver]
t_end = 0.1
""")


def test_linearisation_and_statics_move_the_quaternion_along_the_speeds():
    # a pendulum on a ball joint, hanging: at the reference the body angular velocity is the Bryant rates, so
    # both descriptions give the same M and K (central differences along W(q) T for the quaternion)
    def pendulum(rotation, gravity=(0.0, 0.0, -9.81), push=(0.0, 0.0, 0.0)):
        model = fm.Model()
        bob = fm.RigidBody("bob", 2.0, (0.01, 0.02, 0.03), com=(0.0, 0.0, -0.5))
        return model.add(fm.Spherical("ball", model.ground, bob, rotation=rotation), fm.Gravity(gravity),
                         fm.PointForce("push", bob, push, point=(0.2, 0.0, -0.5))).build()

    lq, lb = fm.linearize(pendulum("quaternion")), fm.linearize(pendulum("bryant"))
    assert lq.method == "fd"
    np.testing.assert_allclose(lq.M, lb.M, atol=1e-12)
    np.testing.assert_allclose(lq.K, lb.K, atol=1e-6)
    np.testing.assert_allclose(np.diag(lq.K), [9.81, 9.81, 0.0], atol=1e-6)  # m g l about x and y
    # statics under a sideways gravity and a push off the bob's axis (Newton's steps turn the quaternion):
    # at rest there, of unit length
    system = pendulum("quaternion", gravity=(9.81, 0.0, 0.0), push=(0.0, 2.0, 0.0))
    x = fm.static_equilibrium(system, system.layout.normalized(np.array([0.1, 0.2, 0.0, 1.0])))
    assert abs(np.linalg.norm(x) - 1.0) < 1e-14
    np.testing.assert_allclose(system.accelerations(0.0, x, np.zeros(3)), 0.0, atol=1e-8)


@pytest.mark.parametrize("cls", [fm.joints.SphericalQuaternion, fm.joints.FreeQuaternion], ids=lambda c: c.__name__)
def test_quaternion_joint_motion_against_differences(cls):
    """The partial angular velocities and velocities are the motion's rates along qd = W(q) u (central differences)."""
    rng = np.random.default_rng(8)
    m, nq = 4, len(cls.coordinate_names)
    q = rng.normal(size=(m, nq))
    q[:, -4:] = quat.normalized(q[:, -4:])
    u = rng.normal(size=(m, nq - 1))
    qd = np.concatenate([u[:, : nq - 4], quat.rates(q[:, -4:], u[:, -3:])], axis=1)
    R, d, Hw, Hv, aw, av = cls.motion(q, u)
    h = 1e-6
    Rp, dp, *_ = cls.motion(q + h * qd, u)
    Rm, dm, *_ = cls.motion(q - h * qd, u)
    S = (Rp - Rm) / (2 * h) @ np.swapaxes(R, 1, 2)
    omega = np.stack([S[:, 2, 1], S[:, 0, 2], S[:, 1, 0]], axis=1)
    np.testing.assert_allclose(np.einsum("mij,mj->mi", Hw, u), omega, atol=1e-8)
    np.testing.assert_allclose(np.einsum("mij,mj->mi", Hv, u), (dp - dm) / (2 * h), atol=1e-8)
    # H changes along the motion by R [w]x, whose product with w vanishes: no velocity-product terms
    assert not np.any(aw) and not np.any(av)
    np.testing.assert_allclose(R, quat.rotation_matrix(q[:, -4:]), atol=1e-15)
