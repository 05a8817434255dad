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


# ----------------------------------------------------------------------------- the broad phase of a group against a group

def _boxes(local, radius):
    return (np.minimum(local[:, 0], local[:, 1]) - radius[:, None], np.maximum(local[:, 0], local[:, 1]) + radius[:, None])


@pytest.mark.parametrize("spread, size", [(1.0, 0.05), (1.0, 0.5), (1e-3, 0.05), (1e6, 1e-3), (0.0, 0.01)])
def test_the_broad_phase_finds_the_pairs_whose_boxes_overlap(spread, size):
    """Random capsules and spheres in two lists: the grid's pairs against the boxes compared one by one.

    Shapes scattered widely or packed in one cell, of sizes alike or
    spread, one list on a rotated and moved body: every pair whose true
    boxes overlap is found, each once, in row order; none whose boxes
    grown by twice the margin are apart, nor any pair without a row (-1).
    """
    from flexmb.kernels.broadphase import MARGIN, block_candidates

    rng = np.random.default_rng(int(spread * 7 + size * 1000) % 1000)
    n1, n2 = 150, 90
    local = rng.normal(size=(n1 + n2, 1, 3)) * spread + rng.normal(size=(n1 + n2, 2, 3)) * size
    local[::7, 1] = local[::7, 0]  # some spheres
    radius = rng.uniform(0.0, size, n1 + n2)
    rows = np.r_[np.zeros(n1, dtype=np.int64), np.ones(n2, dtype=np.int64)]
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([np.eye(3), [[c, -s, 0], [s, c, 0], [0, 0, 1]], np.eye(3)])
    origin = np.array([[0.0, 0, 0], [0.1 * spread, 0, 0.2 * size], [0, 0, 0]])
    pair_rows = rng.permutation(n1 * n2).reshape(n1, n2)
    pair_rows[rng.random((n1, n2)) < 0.1] = -1  # pairs on one body: no row
    blocks = np.array([[0, n1, n2, 0]])
    found = block_candidates(blocks, rows, local, radius, pair_rows.ravel(), R, origin)
    world = np.einsum("kij,kej->kei", R[rows], local) + origin[rows][:, None, :]
    lo, hi = _boxes(world, radius)
    extent = max(np.max(hi.max(0) - lo.min(0)), 1e-6)
    lo, hi = lo - 2 * MARGIN * extent, hi + 2 * MARGIN * extent
    overlap = np.all((lo[:n1, None] <= hi[None, n1:]) & (lo[None, n1:] <= hi[:n1, None]), axis=2)
    expected = np.sort(pair_rows[overlap & (pair_rows >= 0)])
    assert np.all(np.diff(found) > 0)
    assert set(found) <= set(expected) and len(expected) - len(found) <= int(0.001 * n1 * n2)
    tight_lo, tight_hi = _boxes(world, radius)
    tight = np.all((tight_lo[:n1, None] <= tight_hi[None, n1:]) & (tight_lo[None, n1:] <= tight_hi[:n1, None]), axis=2)
    assert set(pair_rows[tight & (pair_rows >= 0)]) <= set(found)  # every pair whose true boxes touch
    assert 0 < len(found) or spread > 100


def _crossed_beams(n, extra=False):
    """Two clamped beams of n segments crossing, the second 0.5 mm above the first's middle near its own tip.

    Under gravity the second's tip sags faster than the first's middle: they touch.
    """
    def build():
        model = fm.Model()
        beam, other = _beam(n), _beam(n, "other")
        turn = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
        model.add(fm.Fixed("root", model.ground, beam, parent_point=(0, 0, 0.003)),
                  fm.Fixed("root2", model.ground, other, parent_point=(0.5, -0.9, 0.0085), parent_frame=turn,
                           child_frame=np.eye(3)), fm.Gravity((0, 0, -G)))
        group2 = [fm.Capsules(other, 0.0025)]
        if extra:  # a plane and a ball among the shapes: their pairs are evaluated always
            ball = fm.RigidBody("ball", mass=0.1, inertia=np.eye(3) * 1e-5)
            model.add(fm.Free("free", model.ground, ball, parent_point=(0.3, 0.0, 0.012)))
            group2 += [fm.Plane(point=(0, 0, -0.001)), fm.Spheres(ball, 0.006)]
        model.add(fm.ContactGroup("cross", [fm.Capsules(beam, 0.0025)], group2, fm.LinearContactLaw(1e5, 20.0),
                                  fm.CoulombLaw(0.3, 1e-3)))
        return model.build()

    return build


@pytest.mark.parametrize("extra", [False, True])
def test_group_against_group_with_the_broad_phase_is_every_pair_to_the_bit(monkeypatch, extra):
    """The loads, and a run, with the broad phase and with every pair evaluated are the same, bit for bit.

    With ``extra``, a ball lies on the first beam and a plane under it:
    the group's rows then have opposite normals (the ball's pushes the
    beam down, the plane's up), which the tunnelling check once took, as
    the deepest row changed, for the beam passing through (the run failed).
    """
    import flexmb.forces.contact_groups as groups
    from flexmb.forces.tables import class_tables

    build = _crossed_beams(16, extra)
    fast = build()
    monkeypatch.setattr(groups, "BROAD_PHASE_PAIRS", 10 ** 9)
    every = build()
    tables = [class_tables(fm.ContactGroup, [s.model.element("cross")], s.topology) for s in (fast, every)]
    n2 = 17 if extra else 16  # the ball's sphere joins the other beam's capsules; the plane's pairs stay out
    assert tables[0].contact_blocks.tolist() == [[0, 16, n2, 0]] and len(tables[1].contact_blocks) == 0
    assert len(tables[0].contact_always) == len(tables[0].contact_rows) - 16 * n2 == (32 if extra else 0)
    assert len(tables[1].contact_always) == len(tables[1].contact_rows)
    rng = np.random.default_rng(2)
    touching = 0
    for _ in range(8):
        x = 0.004 * rng.normal(size=fast.n_coords)
        xd = rng.normal(size=fast.n_speeds)
        y = fast.layout.join(x, xd)
        assert np.array_equal(fast.state_rate(0.0, y), every.state_rate(0.0, y))
        delta = fm.ContactGroup.row_states([fast.model.element("cross")], fast.kinematics(0.0, x, xd))[0]
        touching += int(np.sum(delta > 0))
    assert touching >= 5  # pairs touching, in the blocks
    runs = [fm.simulate(s, 0.03, method="CVODE_BDF", rtol=1e-6, progress=False, n_out=5, track_work=True)
            for s in (fast, every)]
    assert runs[0].n_contact_onsets > 0 and runs[0].n_steps == runs[1].n_steps
    assert np.array_equal(runs[0].x, runs[1].x) and np.array_equal(runs[0].xd, runs[1].xd)


def test_the_broad_phase_helpers_are_numpys_min_max_and_searchsorted():
    """The loops that stand for ``a[:, x].min()``, ``.max()`` and ``np.searchsorted`` (numba's would import
    scipy.linalg at every run) give numpy's values, NaN and ties included."""
    from flexmb.kernels.broadphase import _column_max, _column_min, _search

    rng = np.random.default_rng(3)
    for rows in (1, 2, 7, 40):
        a = rng.normal(size=(rows, 3))
        for x in range(3):
            assert _column_min(a, x) == a[:, x].min() and _column_max(a, x) == a[:, x].max()
        a[rows // 2, 1] = np.nan
        assert np.isnan(_column_min(a, 1)) and np.isnan(_column_max(a, 1))
        assert _column_min(a, 0) == a[:, 0].min()
    a = np.array([[np.nan, 1.0]])
    assert np.isnan(_column_min(a, 0)) and np.isnan(_column_max(a, 0))
    for n in (0, 1, 2, 5, 33):
        keys = np.sort(rng.integers(0, 12, size=n)).astype(np.int64)
        for key in range(-1, 14):
            assert _search(keys, key, False) == np.searchsorted(keys, key), (keys, key)
            assert _search(keys, key, True) == np.searchsorted(keys, key, side="right"), (keys, key)
