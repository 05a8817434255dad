"""A rolling disc on a Free joint in Euler parameters (``rotation='quaternion'``), against the closed forms (#29).

The same thin disc as tests/test_constraint_elements.py (there on a chain of
prismatic, cylindrical and revolute joints: heading, lean and spin angles),
here on one :class:`flexmb.Free` joint with the rotation in Euler
parameters, started from its angular velocity (:class:`flexmb.AngularVelocity`;
the centre's velocity follows from the rolling rows). The lean, heading and
spin are read from the disc's axis ``a`` (its body y axis): ``sin(lean) =
a_z``, the heading is the angle of ``(a_y, -a_x)``, the spin rate about the
axis ``w . a``. The steady precession and the upright lean history follow
the closed forms of that file; a perturbed, nutating run is the same motion
on the joint chain, on a Free joint in Bryant angles and in Euler
parameters; and a steady precession through the Bryant angles' singularity
(ry = -90 deg) keeps its closed form.
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb as fm
from flexmb import quaternions as quat

from test_constraint_elements import G, M_DISC, R_DISC, disc_model, steady_spin

RTOL, ATOL = 1e-10, 1e-12


def free_disc_model(rotation="quaternion"):
    """The disc of :func:`disc_model` on one Free joint (body y its axis), rolling on z = 0."""
    model = fm.Model(f"disc on a {rotation} Free joint")
    disc = fm.RigidBody("disc", M_DISC, (M_DISC * R_DISC**2 / 4, M_DISC * R_DISC**2 / 2, M_DISC * R_DISC**2 / 4))
    return model.add(fm.Free("free", model.ground, disc, rotation=rotation), fm.Gravity((0, 0, -G)),
                     fm.RollingDisc("roll", disc, R_DISC, axis=(0, 1, 0)))


def _turn(axis, angle):
    c, s = np.cos(angle), np.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = np.eye(3)
    R[i, i] = R[j, j] = c
    R[i, j], R[j, i] = -s, s
    return R


def start(theta, heading_rate, lean_rate, spin, psi0=0.0, phi0=0.0, rotation="quaternion"):
    """Positions and speeds of the Free joint: heading psi0, lean theta, spin angle phi0 (the chain's angles).

    The rotation is ``Rz(psi0) Rx(theta) Ry(phi0)``, the centre at ``r cos(theta)`` above the contact, and the
    angular velocity (inertial) ``heading_rate k + lean_rate n + spin a`` with n the heading direction.
    """
    R0 = _turn(2, psi0) @ _turn(0, theta) @ _turn(1, phi0)
    rotation_coordinates = quat.from_rotation_matrix(R0) if rotation == "quaternion" else quat.bryant_angles(R0)
    positions = {"free": [0.0, 0.0, R_DISC * np.cos(theta), *rotation_coordinates]}
    omega = heading_rate * np.array([0.0, 0.0, 1.0]) + lean_rate * _turn(2, psi0)[:, 0] + spin * R0[:, 1]
    return {"positions": positions, "speeds": [fm.AngularVelocity("disc", omega)]}


def lean_heading_axial(res):
    """Lean, heading (unwrapped) and angular velocity along the disc's axis, from the disc's rotations."""
    a = res.rotations[:, res.body_names.index("disc"), :, 1]
    axial = np.einsum("ij,ij->i", res.angular_velocity("disc"), a)
    return np.arcsin(a[:, 2]), np.unwrap(np.arctan2(-a[:, 0], a[:, 1])), axial


@pytest.mark.parametrize("theta, omega, psi0, phi0", [
    (0.2, 3.0, 0.0, 0.0),
    (-0.35, 5.0, 0.0, 0.0),
    # the disc's body z axis along inertial x at t = 0.5 s: Bryant angles would lock there (ry = -90 deg)
    (0.2, 3.0, -1.5, -np.pi / 2 - 0.5 * steady_spin(0.2, 3.0)),
])
def test_quaternion_disc_keeps_its_steady_precession(theta, omega, psi0, phi0):
    spin = steady_spin(theta, omega)
    res = fm.simulate(free_disc_model(), 2.0, **start(theta, omega, 0.0, spin, psi0, phi0), rtol=RTOL, atol=ATOL,
                      n_out=21)
    assert res.coordinate_names[3:] == ["free.qx", "free.qy", "free.qz", "free.qw"]
    lean, heading, axial = lean_heading_axial(res)
    assert np.max(np.abs(lean - theta)) < 1e-8
    assert np.max(np.abs(heading - psi0 - omega * res.t)) < 1e-8
    assert np.max(np.abs(axial - (omega * np.sin(theta) + spin))) < 1e-8  # w3 of steady_spin
    centre = res.origins[:, res.body_names.index("disc")]
    assert np.max(np.abs(centre[:, 2] - R_DISC * np.cos(theta))) < 1e-10  # the contact row
    speed = np.linalg.norm(res.point_velocity("disc", (0.0, 0.0, 0.0)), axis=1)
    assert np.max(np.abs(speed - R_DISC * abs(omega * np.sin(theta) + spin))) < 1e-8  # rolling on a circle
    if psi0:
        ry = res.body_rotation("disc", view="bryant")[:, 1]
        assert np.degrees(np.min(ry)) == pytest.approx(-90.0, abs=1e-4)  # through the Bryant angles' singularity
    # the wrong relation (10 % more spin) does not stay steady: the test can fail
    off = fm.simulate(free_disc_model(), 2.0, **start(theta, omega, 0.0, 1.1 * spin, psi0, phi0), rtol=RTOL,
                      atol=ATOL, n_out=21)
    assert np.max(np.abs(lean_heading_axial(off)[0] - theta)) > 1e-3


@pytest.mark.parametrize("spin, rel", [(10.0, 1e-6), (2.0, 1e-4)])
def test_quaternion_disc_upright_lean_history_follows_the_linear_closed_form(spin, rel):
    """The closed form of tests/test_constraint_elements.py: ``theta'' = (4 / 5)(g / r - 3 s^2) theta``."""
    lean_rate = 1e-3
    res = fm.simulate(free_disc_model(), 1.0, **start(0.0, 0.0, lean_rate, spin), rtol=1e-11, atol=1e-13, n_out=51)
    lean = lean_heading_axial(res)[0]
    rate2 = 0.8 * (G / R_DISC - 3 * spin**2)
    root = np.sqrt(abs(rate2))
    ref = lean_rate / root * (np.sinh(root * res.t) if rate2 > 0 else np.sin(root * res.t))
    assert np.max(np.abs(lean - ref)) < rel * np.max(np.abs(lean))


def test_perturbed_run_is_the_same_on_euler_parameters_bryant_angles_and_the_joint_chain():
    theta, omega, lean_rate = 0.2, 3.0, 0.4
    spin = steady_spin(theta, omega)
    kw = dict(rtol=RTOL, atol=ATOL, n_out=61)
    q = fm.simulate(free_disc_model(), 3.0, **start(theta, omega, lean_rate, spin), **kw)
    bryant = fm.simulate(free_disc_model("bryant"), 3.0, **start(theta, omega, lean_rate, spin, rotation="bryant"),
                         **kw)
    chain = fm.simulate(disc_model(), 3.0, positions={"heading.slide": R_DISC, "lean": theta},
                        speeds={"heading.angle": omega, "lean": lean_rate, "spin": spin}, fixed=["lean"], **kw)
    assert np.ptp(lean_heading_axial(q)[0]) > 0.05  # it nutates
    assert np.max(np.abs(np.degrees(bryant.x[:, 4]))) < 60.0  # far from the Bryant angles' singularity
    k = chain.body_names.index("disc")
    for other, i in ((bryant, 0), (chain, k)):
        assert np.max(np.abs(q.rotations[:, 0] - other.rotations[:, i])) < 1e-7
        assert np.max(np.abs(q.origins[:, 0] - other.origins[:, i])) < 1e-8
    assert np.ptp(q.energy) < 1e-9 * np.max(np.abs(q.energy))  # rolling without slipping does no work
    system = free_disc_model().build()
    assert max(system.constraint_residual(t, x, u) for t, x, u in zip(q.t, q.x, q.xd)) < 1e-9
    assert np.max(np.abs(np.linalg.norm(q.x[:, 3:], axis=1) - 1.0)) < 1e-12  # unit Euler parameters


def test_a_contradiction_names_the_speeds_of_euler_parameters():
    # the speed held is free.wx (the 4th speed; the 4th coordinate is free.qx): the message names the speed
    s = free_disc_model().build()
    kw = start(0.2, 3.0, 0.0, steady_spin(0.2, 3.0))
    with pytest.raises(fm.ModelError, match=r"given \(free\.wx, the angular velocity of 'disc'\) contradict"):
        fm.initial_state(s, positions=kw["positions"], speeds=[{"free.wx": 5.0}, *kw["speeds"]])
    # the constraints win when asked: the closest speeds to both that roll
    x, u = fm.initial_state(s, positions=kw["positions"], speeds=[{"free.wx": 5.0}, *kw["speeds"]], hold_speeds=False)
    assert s.constraint_residuals(0.0, x, u)[1] < 1e-12


def test_a_scene_starts_the_quaternion_disc_from_its_angular_velocity_in_body_axes():
    theta, omega = 0.2, 3.0
    spin = steady_spin(theta, omega)
    kw = start(theta, omega, 0.0, spin)
    R0 = quat.rotation_matrix(np.array(kw["positions"]["free"][3:]))
    w_body = R0.T @ kw["speeds"][0].omega
    scene = fm.loads_scene(f"""
[bodies.disc]
mass = {M_DISC}
inertia = [{M_DISC * R_DISC**2 / 4}, {M_DISC * R_DISC**2 / 2}, {M_DISC * R_DISC**2 / 4}]

[joints.free]
type = "free"
parent = "ground"
child = "disc"
rotation = "quaternion"

[forces.gravity]
type = "gravity"
g = [0.0, 0.0, {-G}]

[constraints.roll]
type = "rolling_disc"
body = "disc"
radius = {R_DISC}
axis = [0.0, 1.0, 0.0]

[initial]
positions = {{ free = {list(map(float, kw["positions"]["free"]))} }}

[initial.angular_velocities.rolling]
body = "disc"
omega = {list(map(float, w_body))}
frame = "body"

[solver]
t_end = 1.0
rtol = {RTOL}
atol = {ATOL}
n_out = 11
""")
    res = scene.simulate()
    api = fm.simulate(free_disc_model(), 1.0, **kw, rtol=RTOL, atol=ATOL, n_out=11)
    np.testing.assert_allclose(res.x, api.x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.xd, api.xd, rtol=0, atol=1e-12)
    lean, heading, axial = lean_heading_axial(res)
    assert np.max(np.abs(lean - theta)) < 1e-8 and np.max(np.abs(heading - omega * res.t)) < 1e-8
