"""Generalized-alpha on models with Euler-parameter joints: the method on the rotation group (#29).

References: the hand-written quaternion models of ``benchmarks/rotations.py``
(Euler's equations in body axes with ``qd = 1/2 q * (w, 0)``, no flexmb
code) by scipy's DOP853 at rtol 1e-13, and the closed forms (energy,
angular momentum, unit norm). Models without Euler parameters keep their
generalized-alpha results to the bit (``tests/test_genalpha_reference.py``).
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


def _scene(scene):
    q0, w0 = bench.initial_state(scene, 80.0)
    return q0, (w0 * 0.25 if scene == "top" else w0)


def _reference(scene, q0, w0, times):
    rhs, J = bench.hand_model(scene)
    sol = solve_ivp(rhs, (0.0, times[-1]), np.concatenate([q0, w0]), method="DOP853", rtol=1e-13, atol=1e-15,
                    t_eval=times)
    return np.array([bench._matrix(q) for q in sol.y[:4].T]), sol.y[4:].T, J


def _run(scene, t_end, method, rtol=1e-10, n_out=5):
    q0, w0 = _scene(scene)
    positions, speeds = bench._flexmb_initial(scene, "quaternion", q0, w0)
    return fm.simulate(bench.flexmb_model(scene), t_end, positions=positions, speeds=speeds, method=method,
                       rtol=rtol, n_out=n_out, progress=False)


@pytest.mark.parametrize("scene, t_end, h0", [("tumbling", 4.0, 0.1), ("top", 0.5, 0.01)])
def test_second_order_convergence_on_the_rotation_group(scene, t_end, h0):
    # fixed steps h0, h0/2, h0/4, h0/8: the global errors of R and w at t_end fall by 4 per halving
    q0, w0 = _scene(scene)
    errors = []
    for k in range(4):
        res = _run(scene, t_end, fm.generalized_alpha(0.8, fixed_step=h0 / 2**k))
        R_ref, w_ref, _ = _reference(scene, q0, w0, res.t)
        errors.append((np.max(np.abs(res.rotations[-1, 0] - R_ref[-1])),
                       np.max(np.abs(res.angular_velocity("body", frame="body")[-1] - w_ref[-1]))))
        assert np.max(np.abs(np.linalg.norm(res.x[:, -4:], axis=1) - 1.0)) < 1e-14  # unit quaternions
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    np.testing.assert_allclose(ratios, 4.0, rtol=0.02)


def test_error_controlled_tumbling_keeps_energy_and_momentum():
    # five periods of the tumbling body (its spin about the intermediate axis reverses) at rtol 1e-8
    scene = "tumbling"
    q0, w0 = _scene(scene)
    t_end = 5 * 2 * np.pi / np.linalg.norm(w0)
    res = _run(scene, t_end, "GeneralizedAlpha", rtol=1e-8, n_out=101)
    assert res.status == "finished"
    R, w = res.rotations[:, 0], res.angular_velocity("body", frame="body")
    R_ref, w_ref, J = _reference(scene, q0, w0, res.t)
    assert np.min(w[:, 1]) < -0.9  # it tumbles
    energy = 0.5 * np.einsum("ti,ij,tj->t", w, J, w)
    H = np.einsum("tij,jk,tk->ti", R, J, w)
    assert np.max(np.abs(energy / energy[0] - 1.0)) < 2e-5
    assert np.max(np.linalg.norm(H - H[0], axis=1)) < 2e-5 * np.linalg.norm(H[0])
    assert np.max(np.abs(R - R_ref)) < 1e-4 and np.max(np.abs(w - w_ref)) < 1e-4
    assert np.max(np.abs(np.linalg.norm(res.x[:, -4:], axis=1) - 1.0)) < 1e-14


def test_heavy_top_through_the_horizontal_matches_the_hand_model():
    scene = "top"
    q0, w0 = _scene(scene)
    res = _run(scene, 0.8, "GeneralizedAlpha", rtol=1e-8, n_out=41)
    R_ref, w_ref, J = _reference(scene, q0, w0, res.t)
    R, w = res.rotations[:, 0], res.angular_velocity("body", frame="body")
    assert np.degrees(np.arccos(R[:, 2, 2])).max() > 95.0  # past the horizontal, near gimbal lock of Bryant
    assert np.max(np.abs(R - R_ref)) < 1e-4 and np.max(np.abs(w - w_ref)) < 1e-3
    energy = res.kinetic + res.potential
    assert np.max(np.abs(energy - energy[0])) < 1e-5 * abs(energy[0]) + 1e-7
    H = np.einsum("tij,jk,tk->ti", R, J, w)  # the vertical and the axial components are conserved
    assert np.max(np.abs(H[:, 2] - H[0, 2])) < 1e-5 and np.max(np.abs((w @ J)[:, 2] - (w @ J)[0, 2])) < 1e-5


def test_dense_output_between_steps_is_second_order():
    # outputs between the steps of a fixed step run: their error falls by 4 per halving, as at the steps
    scene = "tumbling"
    q0, w0 = _scene(scene)
    errors = []
    for h in (0.1, 0.05, 0.025):
        res = _run(scene, 1.0, fm.generalized_alpha(0.8, fixed_step=h), n_out=8)  # mid-step times
        R_ref, w_ref, _ = _reference(scene, q0, w0, res.t)
        errors.append(np.max(np.abs(res.rotations[:, 0] - R_ref)))
    assert 3.6 < errors[0] / errors[1] < 4.4 and 3.6 < errors[1] / errors[2] < 4.4


def test_inverse_right_jacobian_is_the_rate_of_the_rotation_vector():
    rng = np.random.default_rng(3)
    for _ in range(5):
        theta, omega = rng.normal(size=3), rng.normal(size=3)
        theta *= 2.5 / np.linalg.norm(theta) * rng.uniform(1e-6, 1.0)
        q0 = quat.normalized(rng.normal(size=(1, 4)))
        d = 1e-6  # R(t) = R0 exp(theta) exp(omega t): the rotation vector from R0 changes at J_r^-1 omega
        q = quat.compose(quat.compose(q0, theta[None]), d * omega[None])
        qm = quat.compose(quat.compose(q0, theta[None]), -d * omega[None])
        rate = (quat.turn_between(q0, q) - quat.turn_between(q0, qm))[0] / (2 * d)
        np.testing.assert_allclose(quat.inverse_right_jacobian(theta[None], omega[None])[0], rate, atol=1e-8)


def _top_on_a_spring(rotation, stiffness=4e6):
    # a heavy top carrying a 10 g slider on an undamped spring along its axis: a 3.2 kHz mode far above the top
    model = fm.Model("sprung top")
    top = fm.RigidBody("top", 1.0, (0.02, 0.02, 0.01), com=(0.0, 0.0, 0.1))
    slider = fm.RigidBody("slider", 0.01, (1e-6, 1e-6, 1e-6))
    rail = fm.Prismatic("rail", top, slider, parent_point=(0.0, 0.0, 0.1), axis=(0.0, 0.0, 1.0))
    model.add(fm.Spherical("pivot", model.ground, top, rotation=rotation), rail,
              fm.JointSpringDamper("spring", rail, stiffness=stiffness), fm.Gravity((0.0, 0.0, -9.81)))
    return model


def test_auto_picks_generalized_alpha_for_ringing_modes_beside_a_quaternion_joint():
    a = np.radians(15.0)  # tilted about y, spinning about its axis; the slider off its rest: its mode rings
    res = fm.simulate(_top_on_a_spring("quaternion"), 0.1,
                      positions={"pivot": [0.0, np.sin(a / 2), 0.0, np.cos(a / 2)], "rail": 1e-4},
                      speeds={"pivot.wz": 10.0}, method="auto", rtol=1e-6, n_out=11, progress=False)
    assert res.status == "finished" and res.method.startswith("GeneralizedAlpha(rho_inf=0.5")
    assert np.max(np.abs(np.linalg.norm(res.x[:, res.system.coordinate_indices("pivot")], axis=1) - 1.0)) < 1e-14
    assert abs(res.x[-1, res.system.coordinate_indices("rail")[0]]) < 1e-5  # rung down
    # the same scene in Bryant angles (W = I: the vector method), which 'auto' steps alike
    ref = fm.simulate(_top_on_a_spring("bryant"), 0.1, positions={"pivot.ry": a, "rail": 1e-4},
                      speeds={"pivot.rz": 10.0}, method="auto", rtol=1e-6, n_out=11, progress=False)
    assert ref.method == res.method
    # the two differ by their integration errors at rtol 1e-6 (1.3e-5 measured)
    assert np.max(np.abs(res.rotations[:, 0] - ref.rotations[:, 0])) < 1e-4


def test_quaternion_joint_in_a_loop_under_generalized_alpha():
    # the crank-rod-slider loop with a quaternion ball joint: projections move the method in place (move_to),
    # the moved state taken in the last step's chart, the chart then centred at it
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
    res = fm.simulate(model, 0.5, x0=x0, xd0=xd0, method="GeneralizedAlpha", rtol=1e-8, n_out=11, progress=False)
    ref = fm.simulate(model, 0.5, x0=x0, xd0=xd0, method="Radau", rtol=1e-11, n_out=11, progress=False)
    assert res.status == "finished" and res.n_projections > 0
    assert np.max(res.residual) < 1e-9 and np.max(res.velocity_residual) < 1e-9
    assert np.max(np.abs(res.rotations - ref.rotations)) < 1e-5
    energy = res.kinetic + res.potential
    assert np.max(np.abs(energy - energy[0])) < 1e-5


def test_winding_angle_beside_a_quaternion_joint_is_rebased():
    # a wheel spinning on a revolute on the tumbling body: its angle winds past 3 pi many times, and the
    # method rebases its state (the chart's rotation untouched)
    model = fm.Model("gyrostat")
    body = fm.RigidBody("body", 1.0, (1.0, 2.0, 3.0))
    wheel = fm.RigidBody("wheel", 0.1, (0.01, 0.01, 0.02))
    model.add(fm.Free("float", model.ground, body, rotation="quaternion"),
              fm.Revolute("axle", body, wheel, axis=(0.0, 0.0, 1.0)))
    speeds = {"float.wx": 0.05, "float.wy": 1.0, "float.wz": 0.05, "axle": 30.0}
    res = fm.simulate(model, 3.0, speeds=speeds, method="GeneralizedAlpha", rtol=1e-8, n_out=7, progress=False)
    ref = fm.simulate(model, 3.0, speeds=speeds, method="DOP853", rtol=1e-12, n_out=7, progress=False)
    assert res.n_rebases > 5
    np.testing.assert_allclose(res.x, ref.x, atol=1e-4)
    assert np.max(np.abs(res.rotations - ref.rotations)) < 1e-4



def _top_solver(steps=20):
    """GeneralizedAlpha on the hand-written heavy top (``y = (qx, qy, qz, qw, w)``) after ``steps`` steps."""
    from flexmb.genalpha import GeneralizedAlpha
    from flexmb.state_layout import StateLayout

    rhs, _ = bench.hand_model("top")
    q0, w0 = _scene("top")
    solver = GeneralizedAlpha(rhs, 0.0, np.concatenate([q0, w0]), 1.0, n_second=3, rtol=1e-6, atol=1e-8,
                              layout=StateLayout(4, 3, ([[0, 1, 2, 3]], [[0, 1, 2]])))
    for _ in range(steps):
        solver.step()
    return solver, rhs


@pytest.mark.parametrize("with_jacobian", [True, False])
def test_move_to_on_the_rotation_group_recentres_the_chart_and_corrects_the_accelerations(with_jacobian):
    """A projection's move of a quaternion state: taken in the chart, which is then centred at the moved state."""
    errors = []
    for size in (1e-3, 1e-4):
        solver, rhs = _top_solver()
        t, lag = solver.t, solver.abar - solver.a
        assert np.max(np.abs(lag)) > 1e-6  # abar lags a: something to keep
        if with_jacobian:  # one at the step's end, so that the correction is exact to first order
            solver._new_jacobian(t, solver.z)
        else:
            solver.J = None  # a Jacobian is due: the accelerations are evaluated at the moved state
        q = quat.compose(solver.y[:4], size * np.array([0.6, -0.8, 0.3]))  # turned in body axes
        moved = np.concatenate([q, solver.y[4:] + size * np.array([1.0, -2.0, 0.5])])
        solver.move_to(moved)
        assert solver.t == t
        np.testing.assert_allclose(solver.y, moved, rtol=0, atol=1e-15)  # the true state, unit Euler parameters
        assert np.array_equal(solver.z[:3], np.zeros(3))  # the chart centred at the moved rotation
        np.testing.assert_allclose(solver._chart.centre, q, rtol=0, atol=1e-15)
        np.testing.assert_allclose(solver.abar - solver.a, lag, rtol=0, atol=1e-15)  # the lag is kept
        errors.append(np.max(np.abs(solver.a - rhs(t, moved)[4:])))
        solver.step()  # and the integration goes on from there
        assert solver.status == "running" and solver.t > t
        assert abs(np.linalg.norm(solver.y[:4]) - 1.0) < 1e-14
    if with_jacobian:  # a + Jx dx + Jv dxd, dx the rotation vector in the chart: second order in the move
        assert errors[1] < 0.02 * errors[0] and errors[0] < 1e-4, errors
    else:
        assert max(errors) < 1e-12, errors
