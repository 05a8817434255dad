"""An explicit method's stage that cannot be evaluated rejects the step; a model that fails everywhere still stops with its cause.

Seen: a ball on a Free joint dropped on a plane under DOP853 failed soon
after its first bounce with "the mass matrix is singular ... joint 'free'
moves no mass": a step grown long in free flight threw its stages 1e10 m
beneath the floor, where the contact force is enormous and the articulated
inertias about the origin lose every digit. The step would only have been
rejected; the run died instead (``flexmb.stepping.Run._stage_rate``).
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb as fm

R, H, G = 0.05, 0.2, 9.81


def _dropped_ball(rotation):
    model = fm.Model("dropped ball")
    ball = fm.RigidBody("ball", 1.0, np.eye(3) * 0.4 * R**2)
    law = fm.FloresLaw(fm.hertz_stiffness(R, 2.0e11, 0.3), 0.8)
    return model.add(fm.Free("free", model.ground, ball, rotation=rotation),
                     fm.SpherePlaneContact("floor", ball, R, law), fm.Gravity((0.0, 0.0, -G))).build()


def _drop(system, rotation, method):
    angles = [0.0, 0.0, 0.0] if rotation == "bryant" else [0.0, 0.0, 0.0, 1.0]
    return fm.simulate(system, 0.6, positions={"free": [0.0, 0.0, R + H, *angles]},
                       speeds={"free": [0.1, 0.0, 0.0, 1.0, 2.0, 3.0]}, method=method, rtol=1e-10, n_out=7,
                       progress=False)


@pytest.mark.parametrize("rotation", ["bryant", "quaternion"])
def test_a_ball_on_a_free_joint_bounces_under_an_explicit_method(rotation):
    system = _dropped_ball(rotation)
    explicit = _drop(system, rotation, "DOP853")
    implicit = _drop(system, rotation, "Radau")
    assert explicit.status == implicit.status == "finished"
    kinds = [e[2] for e in explicit.contact_events]
    assert kinds == [e[2] for e in implicit.contact_events] == ["onset", "separation"] * (len(kinds) // 2)
    assert len(kinds) >= 2
    # the first touch where the free fall meets the floor (a fall of H from rest), at the free fall's speed
    t_touch, name, _, speed = explicit.contact_events[0]
    assert name == "floor"
    assert t_touch == pytest.approx(np.sqrt(2 * H / G), abs=1e-9)
    assert speed == pytest.approx(np.sqrt(2 * G * H), rel=1e-8)
    # the two integrators agree on the ball's centre (and it is above the floor, rising at 0.6 s)
    centre = explicit.x[:, :3]
    np.testing.assert_allclose(centre, implicit.x[:, :3], atol=1e-7)
    assert centre[-1, 2] > R


def test_a_run_whose_equations_fail_still_stops_with_their_cause():
    """From t = 0.1 s a force is NaN: every stage fails; the run stops at 0.1 s naming it, not the step size."""
    model = fm.Model("pendulum")
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    push = fm.PointForce("push", bar, lambda t: (0.0, np.nan if t > 0.1 else -1.0, 0.0), point=(1.0, 0.0, 0.0))
    system = model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)), push).build()
    for method in ("DOP853", "RK45"):
        with pytest.raises(fm.SimulationError, match="non-finite") as info:
            fm.simulate(system, 1.0, method=method, progress=False)
        assert info.value.result.status == "failed"
        assert "step size" not in str(info.value)
        assert info.value.t == pytest.approx(0.1, abs=1e-6)
