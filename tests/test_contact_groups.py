"""Contact groups and the broad phase (#30 item 4): automatic pairs between groups of shapes.

References: the same pairs declared one by one (the elements of
tests/test_contact_capsules.py), the true gap of two capsules by a fine
grid of their axes' points (the bounding test must never drop a touching
pair), and the weight of a beam lying on a plane (from a scene file).
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb as fm

G = 9.81


def _beam(n=6, name="beam"):
    return fm.FlexibleBody(name, 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(), n_segments=n,
                           keep=("bend_y", "bend_z"))


def _forces(elements, bodies_joints, x, xd):
    model = fm.Model()
    model.add(*bodies_joints(model), *elements)
    system = model.build()
    kin = system.kinematics(0.0, x, xd)
    return system.forces.active_force(kin)


def test_every_segment_of_a_beam_against_a_plane_is_the_segments_declared_one_by_one():
    n = 6
    law, friction = fm.LinearContactLaw(1e5, 30.0), fm.CoulombLaw(0.3, 1e-3)
    rng = np.random.default_rng(3)
    x, xd = 0.02 * rng.normal(size=2 * n), rng.normal(size=2 * n)

    def run(make):
        beam = _beam(n)
        return _forces(make(beam), lambda m: [fm.Fixed("root", m.ground, beam, parent_point=(0, 0, 0.001))],
                      x, xd)

    group = run(lambda b: [fm.ContactGroup("floor", [fm.Capsules(b, 0.003)], [fm.Plane(point=(0, 0, -0.002))],
                                           law, friction)])
    l = 1.0 / n
    one_by_one = run(lambda b: [fm.CapsulePlaneContact(f"s{i}", b, 0.003, [[i * l, 0, 0], [(i + 1) * l, 0, 0]], law,
                                                       friction, plane_point=(0, 0, -0.002)) for i in range(n)])
    assert np.max(np.abs(one_by_one)) > 1.0  # some segments touch
    np.testing.assert_allclose(group, one_by_one, rtol=1e-13, atol=1e-12)


def test_body_set_against_body_set_is_every_pair_on_other_bodies():
    """Two balls and a rod against a ball and a rod: 2x2 + 1x2 pairs, the pair of one body left out."""
    law = fm.HuntCrossleyLaw(1e7, 0.2)
    rng = np.random.default_rng(5)
    x = 0.005 * rng.normal(size=24)
    xd = rng.normal(size=24)
    rod_ends = [[-0.05, 0, 0], [0.05, 0, 0]]
    places = [(0, 0, 0), (0.06, 0, 0), (0.0, 0.07, 0), (0.03, 0.03, 0)]

    def run(make):
        a1, a2, rod, b1 = (fm.RigidBody(n, mass=1.0, inertia=np.eye(3) * 1e-3) for n in ("a1", "a2", "rod", "b1"))
        return _forces(make(a1, a2, rod, b1), lambda model: [
            fm.Free(f"f{k}", model.ground, body, parent_point=p) for k, (body, p) in
            enumerate(zip((a1, a2, rod, b1), places))], x, xd)

    f_group = run(lambda a1, a2, rod, b1: [fm.ContactGroup(
        "sets", [{"shape": "spheres", "body": a1, "radius": 0.03}, {"shape": "spheres", "body": "a2", "radius": 0.03},
                 fm.Capsules(rod, 0.02, ends=[rod_ends])],
        [fm.Spheres(b1, 0.03), fm.Capsules("rod", 0.02, ends=[rod_ends])], law)])
    f_pairs = run(lambda a1, a2, rod, b1: [
        fm.SphereSphereContact("p1", a1, 0.03, b1, 0.03, law), fm.SphereSphereContact("p2", a2, 0.03, b1, 0.03, law),
        fm.CapsuleSphereContact("p3", rod, 0.02, rod_ends, a1, 0.03, law),
        fm.CapsuleSphereContact("p4", rod, 0.02, rod_ends, a2, 0.03, law),
        fm.CapsuleSphereContact("p5", rod, 0.02, rod_ends, b1, 0.03, law)])
    assert np.sum(np.abs(f_pairs) > 1.0) >= 6  # several pairs touch
    np.testing.assert_allclose(f_group, f_pairs, rtol=1e-13, atol=1e-12)


def _grid_gap(e1, r1, e2, r2):
    s = np.linspace(0.0, 1.0, 301)[:, None]
    a, b = e1[0] + s * (e1[1] - e1[0]), e2[0] + s * (e2[1] - e2[0])
    return np.min(np.linalg.norm(a[:, None] - b[None, :], axis=2)) - r1 - r2


def test_the_bounding_test_never_drops_a_touching_pair_and_bounds_the_gap():
    from flexmb.kernels.loads import contact_states

    rng = np.random.default_rng(11)
    n = 400
    local = np.zeros((n, 4, 3))
    local[:, 0], local[:, 3] = rng.normal(size=(n, 3)) * 0.3, rng.normal(size=(n, 3)) * 0.3
    local[:, 1], local[:, 2] = rng.normal(size=(n, 3)) * 0.3, rng.normal(size=(n, 3)) * 0.3
    radii = rng.uniform(0.01, 0.2, size=(n, 2))
    rows = np.tile([0, 1], (n, 1))
    laws = np.tile([4, 0, 0], (n, 1))  # CAPSULE_CAPSULE, linear, no friction
    par = np.zeros((n, 11))
    par[:, 0], par[:, 1], par[:, 3] = 1e4, 1.0, 1.0
    R = np.tile(np.eye(3), (2, 1, 1))
    zeros = np.zeros((2, 3))
    delta, _, fn, _, _, _, _, _ = contact_states(rows, local, radii, laws, par, R, zeros, zeros, zeros, zeros)
    touching = 0
    for i in range(n):
        gap = _grid_gap(local[i, [0, 3]], radii[i, 0], local[i, [1, 2]], radii[i, 1])
        assert -delta[i] <= gap + 1e-12  # the reported gap never exceeds the true one
        if gap < -1e-3:  # touching beyond the grid's resolution
            touching += 1
            assert fn[i] > 0 and -delta[i] == pytest.approx(gap, abs=1e-3)
    assert 50 < touching < n - 50


def test_groups_refuse_planes_against_planes_and_bad_shapes_by_name():
    beam = _beam()
    model = fm.Model()
    model.add(fm.Fixed("root", model.ground, beam),
              fm.ContactGroup("flat", [fm.Plane(beam)], [fm.Plane()], fm.LinearContactLaw(1e4)))
    with pytest.raises(fm.ModelError, match=r"flat.*a plane of 'beam' against a plane of 'ground'"):
        model.build().forces.active_force(model.build().kinematics(0.0, np.zeros(12), np.zeros(12)))
    with pytest.raises(fm.ModelError, match=r"bad.*group1: a shape's table needs shape = one of 'capsules'"):
        fm.ContactGroup("bad", [{"shape": "cube", "body": "beam"}], [fm.Plane()], fm.LinearContactLaw(1e4))
    with pytest.raises(fm.ModelError, match=r"Spheres of 'a': centres must be a list of centres, shape \(k, 3\)"):
        fm.Spheres("a", 0.1, centres=[1.0, 2.0, 3.0])
    with pytest.raises(fm.ModelError, match=r"Capsules of 'a': ends must be .* shape \(k, 2, 3\), got shape \(2, 3\)"):
        fm.Capsules("a", 0.1, ends=[[0.0, 0, 0], [1.0, 0, 0]])
    with pytest.raises(fm.ModelError, match="group2 must be a non-empty list of shapes"):
        fm.ContactGroup("empty", [fm.Plane()], [], fm.LinearContactLaw(1e4))
    model = fm.Model()
    model.add(fm.Fixed("root", model.ground, beam),
              fm.ContactGroup("few", [fm.Capsules(beam, 0.01, segments=[2, 9])], [fm.Plane()],
                              fm.LinearContactLaw(1e4)))
    with pytest.raises(fm.ModelError, match=r"Capsules of 'beam': segments must be below 6, got \[2, 9\]"):
        model.build().forces.active_force(model.build().kinematics(0.0, np.zeros(12), np.zeros(12)))


SCENE = """
[model]
name = "lying"

[materials.aluminium]
preset = "aluminium"

[sections.strip]
kind = "rectangular"
b = 0.02
h = 0.005

[bodies.beam]
type = "flexible_body"
shape = "uniform_beam"
length = 1.0
section = "strip"
material = "aluminium"
n_segments = 10
keep = ["bend_y"]

[joints.clamp]
type = "fixed"
parent = "ground"
child = "beam"
parent_point = [0.0, 0.0, {z}]

[forces.gravity]
type = "gravity"
g = [0.0, 0.0, -9.81]

[forces.floor]
type = "contact_group"
group1 = [{{shape = "capsules", body = "beam", radius = 0.0025}}]
group2 = [{{shape = "plane", point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0]}}]
normal_law = {{type = "linear", stiffness = {k}}}

[solver]
t_end = 0.01
"""


def test_a_scene_file_declares_a_group_and_the_beam_lies_on_the_plane_end_by_end():
    """Clamped at ``r - d`` with ``d = m_s g / (2 k)``: the straight beam rests on its 20 segment ends."""
    k, n = 1e5, 10
    m_s = 1.0 * 0.02 * 0.005 * fm.Material.aluminium().density / n
    scene = fm.loads_scene(SCENE.format(z=0.0025 - m_s * G / (2 * k), k=k))
    system = scene.system()
    floor = scene.model.element("floor")
    kin = system.kinematics(0.0, np.zeros(n), np.zeros(n))
    np.testing.assert_allclose(system.forces.active_force(kin), 0.0, atol=1e-9)
    _, _, fn, _, _, _, _, _ = type(floor).row_states([floor], kin)
    np.testing.assert_allclose(fn, m_s * G / 2, rtol=1e-9)
    delta, _, total, _, point, _, _, _ = type(floor).states_all([floor], kin)
    assert total[0] == pytest.approx(n * m_s * G, rel=1e-9)
    assert point[0, 0] == pytest.approx(0.5, rel=1e-9)  # the resultant at the middle of the beam
