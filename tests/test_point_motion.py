"""Point positions, velocities, accelerations and body angular velocities of a Result (issue #29, item 4).

Checked against closed forms (a pendulum: ``L theta'`` and
``L theta'' t + L theta'^2 n``), against each other by differences over
fine output times (a four-bar closed by the articulated strategy, a
flexible beam), and against what the result already stores (the mass
centres, the flexible body's shape).
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb as fm
from flexmb.errors import ModelError

from conftest import fourbar, fourbar_initial


def _pendulum(axis=(0.0, 0.0, 1.0)):
    m = fm.Model("pendulum")
    bar = fm.RigidBody.slender_bar("bar", 2.0, 1.2)
    m.add(fm.Revolute("pin", m.ground, bar, axis=axis), fm.Gravity((0.0, -9.81, 0.0)))
    return m


def test_pendulum_tip_against_the_closed_forms():
    res = fm.simulate(_pendulum(), 1.0, positions={"pin": 0.3}, speeds={"pin": 2.0}, n_out=41, rtol=1e-10)
    th, thd, thdd = res.x[:, 0], res.xd[:, 0], res.xdd[:, 0]
    L = 1.2
    e = np.stack([np.cos(th), np.sin(th), 0 * th], axis=1)
    n = np.stack([-np.sin(th), np.cos(th), 0 * th], axis=1)
    np.testing.assert_allclose(res.point_position("bar", (L, 0, 0)), L * e, atol=1e-14)
    np.testing.assert_allclose(res.point_velocity("bar", (L, 0, 0)), L * thd[:, None] * n, atol=1e-13)
    np.testing.assert_allclose(res.point_acceleration("bar", (L, 0, 0)),
                               L * thdd[:, None] * n - L * thd[:, None] ** 2 * e, atol=1e-12)
    np.testing.assert_allclose(res.angular_velocity("bar"), np.stack([0 * th, 0 * th, thd], axis=1), atol=1e-14)
    # the mass centre is what the result stores
    np.testing.assert_allclose(res.point_position("bar", (L / 2, 0, 0)), res.body_position("bar"), atol=1e-14)


def test_body_frame_angular_velocity_is_the_axis_in_the_body():
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    res = fm.simulate(_pendulum(axis=tuple(axis)), 0.5, speeds={"pin": 1.5}, n_out=11)
    w_body = res.angular_velocity("bar", frame="body")
    w = res.angular_velocity("bar")
    np.testing.assert_allclose(w, res.xd[:, :1] * axis, atol=1e-13)
    np.testing.assert_allclose(np.linalg.norm(w_body, axis=1), np.abs(res.xd[:, 0]), atol=1e-13)
    for i in range(len(res.t)):
        np.testing.assert_allclose(res.rotations[i, 0] @ w_body[i], w[i], atol=1e-13)


def _central(values, t):
    return (values[2:] - values[:-2]) / (t[2:] - t[:-2])[:, None]


@pytest.mark.parametrize("complement", ["articulated", "svd"])
def test_four_bar_coupler_point_derivatives_by_differences(complement):
    """In a closed loop: the velocity is the time derivative of the position, the acceleration of the velocity."""
    s = fourbar().build(complement=complement)
    res = fm.simulate(s, 0.2, positions=fourbar_initial(), speeds={"A": 3.0}, n_out=2001, rtol=1e-11)
    p = res.point_position("coupler", (0.15, 0.02, 0.0))
    v = res.point_velocity("coupler", (0.15, 0.02, 0.0))
    a = res.point_acceleration("coupler", (0.15, 0.02, 0.0))
    scale_v, scale_a = np.abs(v).max(), np.abs(a).max()
    np.testing.assert_allclose(_central(p, res.t), v[1:-1], atol=1e-5 * scale_v)
    np.testing.assert_allclose(_central(v, res.t), a[1:-1], atol=1e-4 * scale_a)
    # the rocker's tip and the coupler's far end are one point (the loop's cut joint)
    np.testing.assert_allclose(res.point_velocity("coupler", (0.3, 0, 0)), res.point_velocity("rocker", (0.25, 0, 0)),
                               atol=1e-8 * scale_v)


def test_flexible_beam_tip_is_the_shapes_last_point_and_moves_with_it():
    m = fm.Model("beam")
    beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(), 6,
                           keep=("bend_y",), damping=1e-3)
    m.add(fm.Fixed("clamp", m.ground, beam), fm.Gravity((0.0, 0.0, -9.81)))
    res = fm.simulate(m, 0.05, n_out=1001, rtol=1e-10)
    tip = res.point_position("beam", (1.0, 0.0, 0.0))
    np.testing.assert_allclose(tip, res.shape("beam")[:, -1], atol=1e-13)
    v = res.point_velocity("beam", (1.0, 0.0, 0.0))
    np.testing.assert_allclose(_central(tip, res.t), v[1:-1], atol=1e-4 * np.abs(v).max())


def test_ground_points_do_not_move_and_names_are_checked():
    res = fm.simulate(_pendulum(), 0.1, n_out=5)
    ground = res.system.model.ground
    np.testing.assert_array_equal(res.point_position(ground, (1.0, 2.0, 3.0)), np.tile([1.0, 2.0, 3.0], (5, 1)))
    np.testing.assert_array_equal(res.point_velocity(ground, (1.0, 2.0, 3.0)), np.zeros((5, 3)))
    with pytest.raises(ModelError, match="nobody"):
        res.point_position("nobody")
    with pytest.raises(ModelError, match=r"point must have shape \(3,\)"):
        res.point_velocity("bar", (1.0, 2.0))
    with pytest.raises(ModelError, match="frame must be"):
        res.angular_velocity("bar", frame="world")


def test_a_loaded_result_needs_its_system(tmp_path):
    model = _pendulum()
    res = fm.simulate(model, 0.1, speeds={"pin": 1.0}, n_out=5)
    res.save(tmp_path / "r.npz")
    loaded = fm.Result.load(tmp_path / "r.npz")
    with pytest.raises(ModelError, match=r"system=system"):
        loaded.point_velocity("bar", (1.2, 0, 0))
    np.testing.assert_allclose(loaded.point_velocity("bar", (1.2, 0, 0), system=model),
                               res.point_velocity("bar", (1.2, 0, 0)), atol=1e-15)
    with pytest.raises(ModelError, match="not the result's"):
        loaded.point_velocity("bar", system=fourbar())
