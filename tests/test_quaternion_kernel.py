"""Joints in Euler parameters through the compiled kernels (#29): main's Python evaluation path reproduced.

``tests/data/quaternion_kernel_reference.npz`` holds the state rates at
random states, runs, a linearisation and statics of models in Euler
parameters computed on main (26de9e9) while such a joint computed its motion
in Python (``tests/data/make_quaternion_kernel_reference.py``); the compiled
kernels must reproduce them to 1e-10. The state Jacobian of such models is
checked against differences.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import flexmb as fm

DATA = Path(__file__).resolve().parent / "data"
sys.path.insert(0, str(DATA))

import make_quaternion_kernel_reference as ref  # noqa: E402

REFERENCE = np.load(DATA / "quaternion_kernel_reference.npz")
RUNS = {name: (model, kwargs) for name, model, kwargs in ref.runs()}


def _same(name, new):
    keys = sorted(k.split("/", 1)[1] for k in REFERENCE if k.startswith(name + "/"))
    assert keys and set(keys) == set(new), "the same quantities exist"
    for key in keys:
        old = REFERENCE[f"{name}/{key}"]
        scale = max(1.0, float(np.max(np.abs(old)))) if old.size else 1.0
        np.testing.assert_allclose(np.asarray(new[key]), old, rtol=1e-10, atol=1e-10 * scale,
                                   err_msg=f"{name}: {key}")


@pytest.mark.parametrize("name", sorted(RUNS))
def test_runs_match_main(name):
    model, kwargs = RUNS[name]
    _same(name, ref.run(model, kwargs))


def test_rates_and_analyses_match_main():
    for name, values in [*ref.rates(), *ref.analyses()]:
        _same(name, values)


def test_quaternion_joints_take_the_compiled_route():
    for make in (ref.heavy_top, ref.tumbling, ref.chain, ref.loop):
        system = make()[0].build()
        assert not system.topology.external_groups and system._packed is not None
    assert ref.heavy_top()[0].build()._packed_open is not None  # an open tree: one kernel call per rhs
    assert ref.loop()[0].build().with_complement("auto")._loop_kernel  # loops through the recursion


def _mixed_chain():
    """Ball and free joints in Euler parameters beside a revolute on a spring; gravity and loads turning with bodies."""
    model = fm.Model("mixed")
    a = fm.RigidBody("a", 1.0, (0.02, 0.03, 0.01), com=(0.1, 0.0, -0.3))
    b = fm.RigidBody("b", 2.0, (0.05, 0.02, 0.04), com=(0.0, 0.2, -0.2))
    c = fm.RigidBody("c", 0.5, (0.01, 0.02, 0.03), com=(0.05, 0.05, 0.05))
    d = fm.RigidBody.slender_bar("d", 0.7, 0.4)
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    model.add(fm.Spherical("j1", model.ground, a, rotation="quaternion"),
              fm.Spherical("j2", a, b, parent_point=(0.1, 0.0, -0.5), parent_frame=turn, rotation="quaternion"),
              fm.Free("j3", b, c, parent_point=(0.0, 0.3, -0.3), child_point=(0.02, 0.0, 0.0), rotation="quaternion"),
              fm.Revolute("j4", c, d, parent_point=(0.1, 0.0, 0.0), axis=(0.0, 1.0, 0.0)),
              fm.JointSpringDamper("spring", "j4", stiffness=30.0, damping=0.4),
              fm.Gravity((0.0, 0.0, -9.81)), fm.PointForce("push", c, (1.0, 2.0, -3.0), point=(0.1, 0.0, 0.0)),
              fm.BodyTorque("twist", b, (0.1, -0.2, 0.05), frame="body"))
    return model.build()


def _differences(system, t, y, h=1e-6):
    """Central differences of the state rate with respect to every entry of y = (q, u)."""
    J = np.zeros((y.size, y.size))
    for i in range(y.size):
        e = np.zeros(y.size)
        e[i] = h
        J[:, i] = (system.state_rate(t, y + e) - system.state_rate(t, y - e)) / (2 * h)
    return J


@pytest.mark.parametrize("length", [1.0, 0.9, 1.15])
def test_state_jacobian_of_euler_parameters_against_differences(length):
    """``[[d(W u)/dq, W], [dud/dq, dud/du]]``: the kinematic rows exact at any state; the accelerations' rows exact
    at rest (as for Bryant angles, tests/test_jacobian.py), for quaternions of any length (their direction counts)."""
    system = _mixed_chain()
    layout, nq = system.layout, system.layout.nq
    rng = np.random.default_rng(int(100 * length))
    q = layout.normalized(layout.reference() + 0.4 * rng.normal(size=nq))
    q[system.topology.quaternions[0]] *= length
    for u in (np.zeros(layout.n), rng.normal(size=layout.n)):
        y = layout.join(q, u)
        J, fd = system.state_jacobian(0.0, q, u), _differences(system, 0.0, y)
        assert np.abs(J[:nq] - fd[:nq]).max() < 1e-8 * np.abs(fd[:nq]).max() + 1e-12
        if not u.any():
            assert np.abs(J[nq:] - fd[nq:]).max() < 1e-7 * np.abs(fd[nq:]).max()
            assert np.abs(fd[nq:, :nq]).max() > 1.0  # the accelerations do turn with the quaternions
    # the columns along a quaternion itself are zero: only its direction moves the bodies
    ball = system.coordinate_indices("j1")
    np.testing.assert_allclose(J[nq:, ball] @ q[ball], 0.0, atol=1e-9 * np.abs(J[nq:]).max())


def test_newton_preconditioner_solves_the_kinematic_rows_of_euler_parameters():
    """The O(n) preconditioner against the dense ``I - gamma [[R, W], [-A^-1 K P, -A^-1 C]]`` it stands for."""
    from flexmb.assembly import mass_matrix

    system = _mixed_chain()
    layout, nq, n = system.layout, system.layout.nq, system.layout.n
    rng = np.random.default_rng(4)
    q = layout.normalized(layout.reference() + 0.4 * rng.normal(size=nq))
    q[system.topology.quaternions[0]] *= 1.1
    u = rng.normal(size=n)
    pre = system.newton_preconditioner()
    pre.setup(0.0, q, u)
    K, C = np.diag(pre.stiffness), np.diag(pre.damping)
    assert K.any() and C.any()
    A = mass_matrix(system.kinematics(0.0, q, u))
    P = layout.per_coordinate(q, np.eye(n))
    J = np.block([[layout.rate_jacobian(q, u), layout.kinematic_matrix(q)],
                  [-np.linalg.solve(A, K @ P), -np.linalg.solve(A, C)]])
    gamma = 0.03
    r = rng.normal(size=nq + n)
    z = np.linalg.solve(np.eye(nq + n) - gamma * J, r)
    z1, z2 = pre.solve(r[:nq], r[nq:], gamma)
    np.testing.assert_allclose(np.concatenate([z1, z2]), z, rtol=1e-10, atol=1e-12 * np.abs(z).max())


@pytest.mark.parametrize("method", ["CVODE_BDF", "IDA"])
def test_a_long_chain_in_euler_parameters_takes_the_newton_preconditioner(method):
    """16 ball joints in Euler parameters (48 speeds, KRYLOV_MIN_COORDS): GMRES with the O(n) preconditioner, the
    same motion as DOP853 at a tight tolerance."""
    from flexmb.stepping import KRYLOV_MIN_COORDS

    model = fm.Model("rope")
    parent = model.ground
    for i in range(KRYLOV_MIN_COORDS // 3):
        link = fm.RigidBody(f"l{i}", 0.1, (1e-4, 1e-4, 2e-5), com=(0.0, 0.0, -0.05))
        model.add(fm.Spherical(f"b{i}", parent, link, parent_point=(0.0, 0.0, -0.1 if i else 0.0),
                               rotation="quaternion"))
        parent = link
    model.add(fm.Gravity((0.0, 0.0, -9.81)))
    positions = {"b0": [0.3, 0.1, 0.0, 1.0]}
    speeds = {"b3.wy": 2.0, "b9.wx": -1.0}
    ref_run = fm.simulate(model, 0.1, method="DOP853", rtol=1e-12, atol=1e-14, positions=positions, speeds=speeds,
                          n_out=3, progress=False)
    res = fm.simulate(model, 0.1, method=method, rtol=1e-8, atol=1e-10, positions=positions, speeds=speeds, n_out=3,
                      progress=False)
    assert res.status == "finished" and res.n_jac > 0  # preconditioner set-ups (no dense Jacobian: no springs)
    R, R_ref = res.rotations[-1], ref_run.rotations[-1]
    assert np.abs(R - R_ref).max() < 1e-6


def test_loops_through_euler_parameters_by_the_loop_kernel():
    """The crank-rod-slider loop with its rod on a ball joint in Euler parameters, closed by the articulated-body
    recursion (complement='articulated', A and psi never formed): main's rates (its dense route) to 1e-10, and a
    run whose projections move the quaternion by the loop kernels and keep it of unit length."""
    model, ic = ref.loop()
    system = model.build(complement="articulated")
    assert system._loop_kernel
    name = "loop_rates"
    states, rates = REFERENCE[f"{name}/y"], REFERENCE[f"{name}/rate"]
    for y, rate in zip(states, rates):
        np.testing.assert_allclose(system.state_rate(0.3, y), rate, rtol=1e-10, atol=1e-10 * np.abs(rate).max())
    res = fm.simulate(model, 0.3, method="DOP853", rtol=1e-9, complement="articulated", n_out=21, progress=False,
                      **ic)
    dense = REFERENCE["loop_dop853/x"]
    ball = system.coordinate_indices("ball")
    assert np.max(res.residual) < 1e-9 and np.max(np.abs(np.linalg.norm(res.x[:, ball], axis=1) - 1.0)) < 1e-12
    assert np.abs(res.x - dense).max() < 1e-7  # the same motion within the integration's error


def test_a_joint_class_with_euler_parameters_the_generic_motion_cannot_take_is_refused():
    from attrs import frozen

    @frozen(eq=False)
    class TwoTurns(fm.Joint):
        coordinate_names = ("ax", "ay", "az", "aw", "bx", "by", "bz", "bw")
        quaternions = (((0, 1, 2, 3), (0, 1, 2)), ((4, 5, 6, 7), (3, 4, 5)))

    model = fm.Model()
    body = fm.RigidBody("b", 1.0, (1.0, 1.0, 1.0))
    with pytest.raises(fm.ModelError, match="TwoTurns: the generic motion takes one set of Euler parameters"):
        model.add(TwoTurns("double", model.ground, body)).build()
