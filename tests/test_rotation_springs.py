"""Joint springs on joints in Euler parameters: the rotation spring on the rotation vector (#29).

``Q = -J_r(theta)^-T K theta - C omega`` on the angular speeds, potential
``theta^T K theta / 2`` (:class:`flexmb.JointSpringDamper`). Checked against
the closed forms of a turn about one axis (harmonic at any amplitude), the
small-oscillation frequencies ``sqrt(k_i / I_i)``, conservation of energy
with unequal stiffnesses (which the plain ``-K theta`` would break), and the
Bryant-angle spring for small angles.
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb as fm
from flexmb import quaternions as quat

INERTIA = (1.0, 1.5, 2.0)


def _model(rotation="quaternion", joint="Spherical", **spring):
    model = fm.Model("sprung body")
    body = fm.RigidBody("body", 1.0, INERTIA)
    j = getattr(fm, joint)("ball", model.ground, body, rotation=rotation)
    return model.add(j, fm.JointSpringDamper("spring", j, **spring))


def _rotation_vectors(res):
    return quat.rotation_vector(res.rotations[:, 0])


@pytest.mark.parametrize("damping", [0.0, 0.3])
def test_turn_about_one_axis_is_harmonic_at_any_amplitude(damping):
    k, angle = 4.0, 2.5  # 2.5 rad about z: I3 theta'' = -k theta - c theta', exactly
    I3 = INERTIA[2]
    model = _model(stiffness=k, damping=damping)
    res = fm.simulate(model, 3.0, positions={"ball": [0.0, 0.0, np.sin(angle / 2), np.cos(angle / 2)]},
                      method="DOP853", rtol=1e-11, n_out=31, progress=False)
    wn, zeta = np.sqrt(k / I3), damping / (2 * np.sqrt(k * I3))
    wd = wn * np.sqrt(1 - zeta**2)
    theta = angle * np.exp(-zeta * wn * res.t) * (np.cos(wd * res.t) + zeta / np.sqrt(1 - zeta**2) * np.sin(wd * res.t))
    np.testing.assert_allclose(_rotation_vectors(res), np.column_stack([0 * theta, 0 * theta, theta]), atol=1e-8)
    if damping == 0.0:
        energy = res.kinetic + res.potential
        assert res.potential[0] == pytest.approx(0.5 * k * angle**2, rel=1e-14)
        assert np.max(np.abs(energy - energy[0])) < 1e-8


def test_small_oscillation_frequencies_are_sqrt_k_over_inertia():
    k = np.array([2.0, 3.0, 5.0])
    system = _model(stiffness=k).build()
    lin = fm.linearize(system)
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(lin.M, lin.K)).real)
    np.testing.assert_allclose(w2, np.sort(k / np.array(INERTIA)), rtol=1e-8)
    # the state Jacobian's diagonal (the integrators' and 'auto''s) is exact at rest
    J = system.state_jacobian(0.0, system.layout.reference(), np.zeros(3))
    np.testing.assert_allclose(J[4:, :4] @ system.layout.kinematic_matrix(system.layout.reference()),
                               -np.diag(k / np.array(INERTIA)), atol=1e-12)


def test_unequal_stiffnesses_conserve_energy_at_large_angles():
    # a 3D tumble through turns of up to about 2 rad: the law is the gradient of theta^T K theta / 2 along omega
    model = _model(stiffness=[1.0, 4.0, 9.0])
    res = fm.simulate(model, 6.0, positions={"ball": quat.compose(np.array([[0, 0, 0, 1.0]]),
                                                                   np.array([[0.8, -0.6, 1.2]]))[0]},
                      speeds={"ball": [1.0, 0.5, -0.7]}, method="DOP853", rtol=1e-11, n_out=121, progress=False)
    angles = np.linalg.norm(_rotation_vectors(res), axis=1)
    assert angles.max() > 1.5
    energy = res.kinetic + res.potential
    assert np.max(np.abs(energy - energy[0])) < 1e-8 * abs(energy[0])


def test_plain_k_theta_would_not_conserve_energy(monkeypatch):
    # the test above can fail: dropping J_r^-T from the law makes the same run drift
    monkeypatch.setattr(quat, "inverse_right_jacobian", lambda theta, v: v)
    model = _model(stiffness=[1.0, 4.0, 9.0])
    res = fm.simulate(model, 6.0, positions={"ball": quat.compose(np.array([[0, 0, 0, 1.0]]),
                                                                   np.array([[0.8, -0.6, 1.2]]))[0]},
                      speeds={"ball": [1.0, 0.5, -0.7]}, method="DOP853", rtol=1e-11, n_out=121, progress=False)
    energy = res.kinetic + res.potential
    assert np.max(np.abs(energy - energy[0])) > 1e-4 * abs(energy[0])


@pytest.mark.parametrize("amplitude", [1e-2, 1e-3])
def test_small_angles_as_the_bryant_angle_spring(amplitude):
    # the rotation vector and the Bryant angles agree to first order: the motions differ by O(amplitude^2)
    k, c = [2.0, 3.0, 5.0], [0.1, 0.0, 0.2]
    direction = np.array([0.6, -0.48, 0.64])
    theta0, w0 = amplitude * direction, amplitude * np.array([1.0, -2.0, 0.5])
    res_q = fm.simulate(_model(stiffness=k, damping=c), 4.0,
                        positions={"ball": quat.compose(np.array([[0, 0, 0, 1.0]]), theta0[None])[0]},
                        speeds={"ball": w0}, method="DOP853", rtol=1e-12, n_out=41, progress=False)
    R0 = quat.rotation_matrix(quat.compose(np.array([[0, 0, 0, 1.0]]), theta0[None]))
    angles = quat.bryant_angles(R0)[0]
    ry, rz = angles[1], angles[2]
    E = np.array([[np.cos(ry) * np.cos(rz), np.sin(rz), 0.0], [-np.cos(ry) * np.sin(rz), np.cos(rz), 0.0],
                  [np.sin(ry), 0.0, 1.0]])  # w = E(angles) rates
    res_b = fm.simulate(_model("bryant", stiffness=k, damping=c), 4.0, positions={"ball": angles},
                        speeds={"ball": np.linalg.solve(E, w0)}, method="DOP853", rtol=1e-12, n_out=41,
                        progress=False)
    gap = np.max(np.abs(res_q.rotations - res_b.rotations))
    assert gap < 2 * amplitude**2


def test_rest_rotation_and_free_joint_translation():
    rest = np.array([0.3, -0.2, 0.4])
    model = _model(joint="Free", stiffness=[10.0, 10.0, 10.0, 2.0, 2.0, 2.0],
                   rest=[0.1, 0.2, 0.3, *rest])
    system = model.build()
    q_rest = quat.compose(np.array([[0, 0, 0, 1.0]]), rest[None])[0]
    x = np.concatenate([[0.1, 0.2, 0.3], q_rest[:3], [q_rest[3]]])
    kin = system.kinematics(0.0, x, np.zeros(6))
    np.testing.assert_allclose(system.forces.active_force(kin), 0.0, atol=1e-14)
    # moved 0.05 m along y and turned 0.2 rad about the child's x from rest: -k dx and the torque -k theta
    x2 = np.concatenate([[0.1, 0.25, 0.3], quat.compose(q_rest[None], np.array([[0.2, 0.0, 0.0]]))[0]])
    x2 = np.concatenate([x2[:6], x2[6:]])
    kin = system.kinematics(0.0, x2, np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0]))
    np.testing.assert_allclose(system.forces.active_force(kin), [0.0, -0.5, 0.0, -0.4, 0.0, 0.0], atol=1e-12)
    assert model.forces[0].potential(kin) == pytest.approx(0.5 * 10.0 * 0.05**2 + 0.5 * 2.0 * 0.2**2, rel=1e-12)


def test_mixed_with_springs_on_coordinates():
    # a pin's spring keeps its compiled law when a rotation spring sits in the same class
    model = fm.Model("mixed")
    body = fm.RigidBody("body", 1.0, INERTIA)
    arm = fm.RigidBody.slender_bar("arm", 1.0, 0.5)
    ball = fm.Spherical("ball", model.ground, body, rotation="quaternion")
    pin = fm.Revolute("pin", body, arm, axis=(0, 0, 1))
    model.add(ball, pin, fm.JointSpringDamper("s1", ball, stiffness=3.0),
              fm.JointSpringDamper("s2", pin, stiffness=2.0, damping=0.5, rest=0.1))
    system = model.build()
    x = np.array([0.0, 0.0, 0.0, 0.7, 1.0])
    kin = system.kinematics(0.0, x, np.array([0.0, 0.0, 0.0, 2.0]))
    np.testing.assert_allclose(system.forces.active_force(kin), [0.0, 0.0, 0.0, -2.0 * 0.6 - 0.5 * 2.0], atol=1e-14)


def test_sizes_are_per_speed():
    with pytest.raises(fm.ModelError, match=r"stiffness must be a scalar or have 3 entries, got shape \(4,\)"):
        _model(stiffness=[1.0, 1.0, 1.0, 1.0]).build()


def test_scene_file_takes_a_rotation_spring():
    scene = fm.loads_scene("""
[model]
name = "torsion pendulum"
[bodies.body]
type = "rigid_body"
mass = 1.0
inertia = [1.0, 1.5, 2.0]
[joints.ball]
type = "spherical"
parent = "ground"
child = "body"
rotation = "quaternion"
[forces.spring]
type = "joint_spring_damper"
joint = "ball"
stiffness = [4.0, 4.0, 4.0]
rest = [0.0, 0.0, 0.5]
[initial]
positions = { ball = [0.0, 0.0, 0.0, 1.0] }
[solver]
t_end = 2.0
method = "GeneralizedAlpha"
rtol = 1e-8
""")
    res = scene.simulate(progress=False)
    # about z from 0 to the rest at 0.5 rad: theta = 0.5 (1 - cos(sqrt(k / I3) t)), to the method's error (3.2e-6)
    theta = 0.5 * (1.0 - np.cos(np.sqrt(4.0 / 2.0) * res.t))
    np.testing.assert_allclose(_rotation_vectors(res)[:, 2], theta, atol=1e-5)
    np.testing.assert_allclose(_rotation_vectors(res)[:, :2], 0.0, atol=1e-12)
