"""Capsule contacts (#30 item 1): a segment with a radius against a plane, a sphere and another capsule.

Closed forms and independent formulations used below:

* A rigid rod resting on a plane, its mass centre at s from its first end
  (length L): the plane carries m g, ``m g (L - s) / L`` at the first end
  and ``m g s / L`` at the second (the lever rule; a tilt scales both
  levers alike).
* A sphere against a capsule is a sphere against a sphere centred at the
  point of the capsule's axis closest to the sphere's centre (computed here
  with numpy, not by the kernel).
* Crossed capsules at right angles, axes h apart: overlap ``r1 + r2 - h``
  at the crossing; parallel capsules: the same overlap, at the middle of
  the part where their projections overlap.
* The closest points of two segments: nothing on a fine grid of their
  points is closer.
* A straight cantilever whose segments (capsules) rest on a plane with a
  linear law k per end, clamped at ``r - d``, ``d = m_s g / (2 k)``: the
  straight beam is in equilibrium, each end carrying ``m_s g / 2``.
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb as fm
from flexmb.kernels.contact_geometry import PARALLEL, segments_closest

G = 9.81


def _rod(name="rod", mass=2.0, length=1.0, com=(0.0, 0.0, 0.0)):
    return fm.RigidBody(name, mass=mass, inertia=np.diag([1e-4, 1.0, 1.0]) * mass * length ** 2 / 12, com=com)


@pytest.mark.parametrize("s", [0.5, 0.3, 0.8])
def test_a_capsule_resting_on_a_plane_carries_its_weight_split_by_the_lever_rule(s):
    m, L, r, k = 2.0, 1.0, 0.01, 1e5
    rod = _rod(mass=m, length=L, com=(s, 0.0, 0.0))
    law = fm.LinearContactLaw(k, 2 * np.sqrt(k * m / 2))
    floor = fm.CapsulePlaneContact("floor", rod, r, [[0, 0, 0], [L, 0, 0]], law)
    model = fm.Model()
    model.add(fm.Free("free", model.ground, rod), floor, fm.Gravity((0, 0, -G)))
    res = fm.simulate(model, 1.0, x0=np.array([0, 0, r + 1e-3, 0, 0, 0.0]), xd0=np.zeros(6), method="Radau",
                      rtol=1e-10, atol=1e-12, progress=False, n_out=3)
    system = res.system
    kin = system.kinematics(res.t[-1], res.x[-1], res.xd[-1])
    _, _, fn, _, point, _, _, _ = type(floor).row_states([floor], kin)
    assert fn.sum() == pytest.approx(m * G, rel=1e-9)
    np.testing.assert_allclose(fn, [m * G * (L - s) / L, m * G * s / L], rtol=1e-8)
    # the element's merged state: the total, at the resultant's point (the mass centre's shadow)
    _, _, total, _, centre, _, _, _ = type(floor).states_all([floor], kin)
    assert total[0] == pytest.approx(m * G, rel=1e-9)
    com = system.kinematics(res.t[-1], res.x[-1], res.xd[-1]).r[0]
    np.testing.assert_allclose(centre[0, :2], com[:2], atol=1e-9)


def test_the_stiffness_notice_of_a_radau_run_does_not_recommend_radau():
    """A rod ringing on its contact springs under Radau: the notice named Radau as the remedy to a Radau run."""
    m, L, r, k = 2.0, 1.0, 0.01, 1e5
    rod = _rod(mass=m, length=L, com=(0.8, 0.0, 0.0))  # off the middle: the rod tilts and rings on its ends
    floor = fm.CapsulePlaneContact("floor", rod, r, [[0, 0, 0], [L, 0, 0]], fm.LinearContactLaw(k, 2 * np.sqrt(k * m / 2)))
    model = fm.Model()
    model.add(fm.Free("free", model.ground, rod), floor, fm.Gravity((0, 0, -G)))
    with pytest.warns(fm.StiffnessWarning) as caught:
        fm.simulate(model, 1.0, x0=np.array([0, 0, r + 1e-3, 0, 0, 0.0]), xd0=np.zeros(6), method="Radau",
                    rtol=1e-10, atol=1e-12, progress=False, n_out=3)
    message = str(next(w.message for w in caught if isinstance(w.message, fm.StiffnessWarning)))
    assert "use method='Radau'" not in message
    assert "add damping" in message and "generalized_alpha" in message


def _closest_on_segment(p, q, c):
    d = q - p
    s = np.clip((c - p) @ d / (d @ d), 0.0, 1.0)
    return p + s * d


@pytest.mark.parametrize("where", ["middle", "beyond the first end", "beyond the second end"])
def test_a_sphere_on_a_capsule_equals_a_sphere_on_a_sphere_at_the_closest_point(where):
    """The same forces (normal and friction) on both bodies, to rounding, with both bodies moving and spinning."""
    ends = np.array([[-0.3, 0.1, 0.0], [0.4, -0.2, 0.1]])
    law, friction = fm.HuntCrossleyLaw(1e7, 0.3), fm.CoulombLaw(0.4, 1e-3)
    x_rod = np.array([0.01, -0.02, 0.03, 0.1, -0.2, 0.3])
    xd = np.array([0.3, -0.1, 0.2, 1.0, 2.0, -1.5, -0.4, 0.2, -0.5, 3.0, -1.0, 0.5])

    def forces(make, x):
        model = fm.Model()
        rod, ball = _rod("rod"), fm.RigidBody("ball", mass=1.0, inertia=np.eye(3) * 4e-3)
        model.add(fm.Free("f_rod", model.ground, rod), fm.Free("f_ball", model.ground, ball), make(rod, ball))
        system = model.build()
        kin = system.kinematics(0.0, x, xd)
        return system, kin, system.forces.active_force(kin)

    def capsule(rod, ball):
        return fm.CapsuleSphereContact("c", rod, 0.05, ends, ball, 0.06, law, friction)

    # the ball 0.1 m off the axis (0.01 m into the capsule), at the middle or beyond an end
    _, kin, _ = forces(capsule, np.concatenate([x_rod, np.zeros(6)]))
    world = ends @ kin.R[0].T + kin.origin[0]
    axis = (world[1] - world[0]) / np.linalg.norm(world[1] - world[0])
    side = np.cross(axis, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    target = {"middle": 0.5 * (world[0] + world[1]) + 0.1 * side,
              "beyond the first end": world[0] - 0.06 * axis + 0.08 * side,
              "beyond the second end": world[1] + 0.08 * axis + 0.06 * side}[where]
    x = np.concatenate([x_rod, target, [0.2, 0.1, -0.1]])

    system, kin, f_capsule = forces(capsule, x)
    np.testing.assert_allclose(kin.origin[1], target, atol=1e-15)
    # the closest point of the axis, in the rod's frame, from the positions the capsule model computed
    R_rod, o_rod, c_ball = kin.R[0], kin.origin[0], kin.origin[1]
    world = ends @ R_rod.T + o_rod
    closest = _closest_on_segment(world[0], world[1], c_ball)
    local = R_rod.T @ (closest - o_rod)
    _, _, f_sphere = forces(lambda rod, ball: fm.SphereSphereContact("c", rod, 0.05, ball, 0.06, law, friction,
                                                                     centre1=local), x)
    assert np.max(np.abs(f_capsule)) > 1.0  # they touch
    np.testing.assert_allclose(f_capsule, f_sphere, rtol=1e-12, atol=1e-9 * np.max(np.abs(f_sphere)))


def _two_rods(ends1, ends2, r1, r2, lift):
    model = fm.Model()
    rod = _rod("rod")
    cross = fm.CapsuleCapsuleContact("cross", rod, r1, ends1, model.ground, r2, ends2, fm.LinearContactLaw(1e4))
    model.add(fm.Free("free", model.ground, rod, parent_point=(0, 0, lift)), cross)
    system = model.build()
    kin = system.kinematics(0.0, np.zeros(6), np.zeros(6))
    return cross, kin


def test_crossed_capsules_touch_at_the_crossing_with_the_overlap_of_their_radii():
    r1, r2, h = 0.01, 0.02, 0.025
    cross, kin = _two_rods([[-0.2, 0.1, 0], [0.6, 0.1, 0]], [[0.3, -0.5, 0], [0.3, 0.4, 0]], r1, r2, h)
    delta, _, fn, _, point, normal, force, _ = type(cross).states_all([cross], kin)
    assert delta[0] == pytest.approx(r1 + r2 - h, rel=1e-12)
    np.testing.assert_allclose(normal[0], [0, 0, 1], atol=1e-13)  # rounding of coordinates ~1 m over a gap of cm
    np.testing.assert_allclose(point[0], [0.3, 0.1, h - (r1 - delta[0] / 2)], atol=1e-14)
    assert fn[0] == pytest.approx(1e4 * (r1 + r2 - h), rel=1e-12)
    # apart: the gap reported is negative and nothing pushes
    cross, kin = _two_rods([[-0.2, 0.1, 0], [0.6, 0.1, 0]], [[0.3, -0.5, 0], [0.3, 0.4, 0]], r1, r2, 0.05)
    delta, _, fn, _, _, _, _, _ = type(cross).states_all([cross], kin)
    assert delta[0] == pytest.approx(r1 + r2 - 0.05, rel=1e-12) and fn[0] == 0.0


@pytest.mark.parametrize("second, middle", [([[0.5, 0, 0], [2.0, 0, 0]], 0.75),  # overlapping by [0.5, 1]
                                            ([[2.0, 0, 0], [0.5, 0, 0]], 0.75),  # the same, reversed
                                            ([[0.2, 0, 0], [0.6, 0, 0]], 0.4),  # inside the first
                                            ([[-1.0, 0, 0], [3.0, 0, 0]], 0.5)])  # containing it
def test_parallel_capsules_touch_at_the_middle_of_their_overlap(second, middle):
    r1 = r2 = 0.01
    h = 0.015
    cross, kin = _two_rods([[0, 0, 0], [1.0, 0, 0]], second, r1, r2, h)
    delta, _, fn, _, point, normal, _, _ = type(cross).states_all([cross], kin)
    assert delta[0] == pytest.approx(r1 + r2 - h, rel=1e-12)
    np.testing.assert_allclose(normal[0], [0, 0, 1], atol=1e-13)  # rounding of coordinates ~1 m over a gap of cm
    assert point[0, 0] == pytest.approx(middle, abs=1e-14)


def test_parallel_capsules_end_to_end_touch_at_their_nearer_ends():
    cross, kin = _two_rods([[0, 0, 0], [1.0, 0, 0]], [[1.015, 0, 0], [2.0, 0, 0]], 0.01, 0.01, 0.0)
    delta, _, _, _, point, normal, _, _ = type(cross).states_all([cross], kin)
    assert delta[0] == pytest.approx(0.005, rel=1e-9)
    np.testing.assert_allclose(normal[0], [-1, 0, 0], atol=1e-13)


def test_the_closest_points_of_two_segments_are_closer_than_any_on_a_fine_grid():
    rng = np.random.default_rng(7)
    grid = np.linspace(0.0, 1.0, 401)
    for case in range(60):
        p1, d1, p2 = rng.normal(size=(3, 3))
        # every fourth case nearly or exactly parallel, some degenerate to points
        d2 = rng.normal(size=3) if case % 4 else d1 * rng.uniform(-2, 2) + (1e-9 if case % 8 else 0.0)
        if case % 15 == 0:
            d2 = np.zeros(3)
        s, t = segments_closest(p1, d1, p2, d2)
        assert 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0
        best = np.linalg.norm(p1 + s * d1 - p2 - t * d2)
        a = p1 + grid[:, None] * d1
        b = p2 + grid[:, None] * d2
        on_grid = np.min(np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2))
        # nearly parallel: the middle of the overlap, within sin(angle) x its length of the closest points
        slack = np.sqrt(PARALLEL) * (np.linalg.norm(d1) + np.linalg.norm(d2)) if case % 4 == 0 else 0.0
        assert best <= on_grid + 1e-12 + slack
        assert on_grid - best <= 1e-4 * (np.linalg.norm(d1) + np.linalg.norm(d2)) + 1e-12


def test_a_capsule_across_two_segments_of_a_flexible_body_is_refused_by_name():
    beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(), n_segments=4,
                           keep=("bend_y",))
    model = fm.Model()
    bad = fm.CapsulePlaneContact("lying", beam, 0.005, [[0.1, 0, 0], [0.4, 0, 0]], fm.LinearContactLaw(1e4))
    model.add(fm.Fixed("root", model.ground, beam), bad)
    with pytest.raises(fm.ModelError, match="lying.*different segments of the flexible body 'beam'"):
        model.build().forces.active_force(model.build().kinematics(0.0, np.zeros(4), np.zeros(4)))


def _pressed_cantilever(n, k):
    beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(), n_segments=n,
                           keep=("bend_y",))
    l, r = beam.segment_length, 0.0025
    m_s = beam.mass / n
    d = m_s * G / (2 * k)
    model = fm.Model()
    contacts = [fm.CapsulePlaneContact(f"seg{i}", beam, r, [[i * l, 0, 0], [(i + 1) * l, 0, 0]],
                                       fm.LinearContactLaw(k)) for i in range(n)]
    model.add(fm.Fixed("root", model.ground, beam, parent_point=(0, 0, r - d)), fm.Gravity((0, 0, -G)), *contacts)
    return model, contacts, m_s


def test_a_cantilever_whose_segments_rest_on_a_plane_is_carried_end_by_end():
    n, k = 8, 1e5
    model, contacts, m_s = _pressed_cantilever(n, k)
    system = model.build()
    x0 = 1e-3 * np.sin(np.arange(n))  # bent: Newton must straighten it
    x = fm.static_equilibrium(system, x0=x0, tol=1e-13)
    np.testing.assert_allclose(x, 0.0, atol=1e-11)
    kin = system.kinematics(0.0, x, np.zeros(n))
    _, _, fn, _, _, _, _, _ = type(contacts[0]).row_states(contacts, kin)
    assert fn.shape == (2 * n,)
    np.testing.assert_allclose(fn, m_s * G / 2, rtol=1e-8)
