"""The distance and point-on-curve constraint elements against closed forms and against joints.

Two rods from one ground point to two points of a body pin it there: the
body then swings as the revolute pendulum and as the same body closed by a
cut revolute (the loop-joint version); three rods make a spherical joint. A
bead on a hoop that turns about the vertical, on a turning rod and on a
cycloid (the tautochrone) follow their equations of motion; a bead on a
circle, in a scene file, is the simple pendulum, as is a bob on a rod.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.integrate as si
from attrs import frozen

import flexmb as fm
from flexmb.errors import AssemblyError, ModelError

G = 9.81
TIGHT = dict(method="DOP853", rtol=1e-11, atol=1e-13)


@frozen(eq=False)
class Planar(fm.Joint):
    """Translations along the parent's x and y, then a rotation about z: three coordinates."""

    translation_axes = (0, 1)
    rotation_axes = (2,)
    coordinate_names = ("x", "y", "angle")
    cut_point = False


def _bar():
    # the body frame at the pivot, the mass centre 0.5 m along x, not a slender bar (I_c != 0)
    return fm.RigidBody("bar", 1.5, (0.01, 0.2, 0.2), com=(0.5, 0.1, 0.0))


def _pinned(kind):
    """The bar pinned at the ground origin: by a revolute, a planar joint with a cut revolute, or two rods."""
    m = fm.Model(kind)
    bar = _bar()
    m.add(fm.Gravity((0.0, -G, 0.0)))
    if kind == "revolute":
        return m.add(fm.Revolute("pin", m.ground, bar, axis=(0, 0, 1)))
    m.add(Planar("plane", m.ground, bar))
    if kind == "loop":
        return m.add(fm.Revolute("pin", m.ground, bar, axis=(0, 0, 1), cut=True))
    p1, p2 = np.array([0.8, 0.3, 0.0]), np.array([0.4, -0.6, 0.0])
    return m.add(fm.Distance("rod1", m.ground, bar, np.linalg.norm(p1), point2=p1),
                 fm.Distance("rod2", m.ground, bar, np.linalg.norm(p2), point2=p2))


def test_two_rods_pin_a_body_as_a_revolute_and_as_a_loop_joint():
    theta0, t_end = 1.2, 2.0
    runs = {"revolute": fm.simulate(_pinned("revolute"), t_end, positions={"pin": theta0}, n_out=41, **TIGHT)}
    for kind in ("loop", "rods"):
        runs[kind] = fm.simulate(_pinned(kind), t_end, positions={"plane.angle": theta0}, n_out=41, **TIGHT)
    ref = runs["revolute"]
    assert np.ptp(ref.x[:, 0]) > 2.0  # it swings through large angles
    for kind in ("loop", "rods"):
        res = runs[kind]
        for point in ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)):
            np.testing.assert_allclose(res.point_position("bar", point), ref.point_position("bar", point),
                                       rtol=0, atol=1e-8, err_msg=kind)
        np.testing.assert_allclose(res.coordinate("plane.angle"), ref.coordinate("pin.angle"), rtol=0, atol=1e-8)
        assert res.residual.max() < 1e-10
    assert runs["rods"].constraint_labels == ["rod1.length", "rod2.length"]


def test_the_rods_tension_balances_the_pin_force():
    """The rods' multipliers along the rods give the pin force of the revolute model (its reactions)."""
    res = fm.simulate(_pinned("rods"), 0.5, positions={"plane.angle": 0.7}, n_out=6, **TIGHT)
    m, a = 1.5, res.point_acceleration("bar", (0.5, 0.1, 0.0))
    pin = m * a - m * np.array([0.0, -G, 0.0])  # force the rods exert on the bar (Newton for its mass centre)
    force = np.zeros_like(pin)
    for j, p in enumerate(((0.8, 0.3, 0.0), (0.4, -0.6, 0.0))):
        P = res.point_position("bar", p)
        e = P / np.linalg.norm(P, axis=1)[:, None]  # from the ground point to the bar's point
        # rod j runs from the ground (body1) to the bar: d = -P, psi = e . V_P, so its force on the bar is
        # psi^T lambda = lambda e (a negative lambda, a tension, pulls P towards the ground point)
        force += res.reactions[:, j, None] * e
    np.testing.assert_allclose(force, pin, rtol=1e-7, atol=1e-7)


def _top(kind):
    m = fm.Model(kind)
    body = fm.RigidBody("top", 2.0, (0.05, 0.08, 0.03), com=(0.1, 0.2, -0.5))
    m.add(fm.Gravity((0.0, 0.0, -G)))
    if kind == "spherical":
        return m.add(fm.Spherical("ball", m.ground, body))
    m.add(fm.Free("free", m.ground, body))
    points = ((0.5, 0.0, 0.0), (0.0, 0.4, 0.1), (0.1, -0.2, -0.7))
    return m.add(*(fm.Distance(f"rod{i}", body, m.ground, np.linalg.norm(p), point1=p) for i, p in enumerate(points)))


def test_three_rods_make_a_spherical_joint():
    speeds = [fm.AngularVelocity("top", (1.5, -0.5, 3.0))]
    ref = fm.simulate(_top("spherical"), 1.5, speeds=speeds, n_out=31, **TIGHT)
    res = fm.simulate(_top("rods"), 1.5, speeds=speeds, n_out=31, **TIGHT)
    for point in ((0.0, 0.0, 0.0), (0.1, 0.2, -0.5), (1.0, 1.0, 1.0)):
        np.testing.assert_allclose(res.point_position("top", point), ref.point_position("top", point),
                                   rtol=0, atol=1e-8)
    np.testing.assert_allclose(res.angular_velocity("top"), ref.angular_velocity("top"), rtol=0, atol=1e-7)
    assert np.ptp(ref.point_position("top", (0.1, 0.2, -0.5))[:, 0]) > 0.1


def _bead():
    return fm.RigidBody("bead", 0.2, (1e-4, 1e-4, 1e-4))


def _reference(rhs, y0, t):
    sol = si.solve_ivp(rhs, (t[0], t[-1]), y0, method="DOP853", t_eval=t, rtol=1e-13, atol=1e-14)
    return sol.y


R_HOOP, OMEGA = 0.4, 6.0


def _hoop(curve="circle"):
    """A bead on a vertical hoop turning at OMEGA about z; the hoop's circle lies in its x-z plane."""
    m = fm.Model("hoop")
    hoop = fm.RigidBody("hoop", 1.0, (0.1, 0.1, 0.1))
    spin = fm.Revolute("spin", m.ground, hoop, axis=(0, 0, 1))
    bead = _bead()
    if curve == "circle":
        on_hoop = fm.PointOnCircle("ring", bead, on=hoop, radius=R_HOOP, normal=(0, 1, 0))
    else:
        def ring(s):
            c, d = np.cos(s), np.sin(s)
            return (R_HOOP * np.array([d, 0.0, -c]), R_HOOP * np.array([c, 0.0, d]),
                    R_HOOP * np.array([-d, 0.0, c]))
        on_hoop = fm.PointOnCurve("ring", bead, on=hoop, curve=ring, bounds=(-np.pi, np.pi), closed=True)
    return m.add(spin, fm.Driver.constant_speed("motor", spin, OMEGA), fm.Free("free", m.ground, bead), on_hoop,
                 fm.Gravity((0.0, 0.0, -G)))


@pytest.mark.parametrize("curve", ["circle", "parametric"])
def test_bead_on_a_turning_hoop(curve):
    """``theta'' = sin(theta) (OMEGA^2 cos(theta) - g / R)`` for the angle theta from the hoop's bottom."""
    th0, t = 0.5, np.linspace(0.0, 2.0, 41)
    p0 = R_HOOP * np.array([np.sin(th0), 0.0, -np.cos(th0)])
    res = fm.simulate(_hoop(curve), t[-1], positions={"free.x": p0[0], "free.z": p0[2]},
                      speeds={"free.y": OMEGA * p0[0]}, n_out=len(t), **TIGHT)
    p = res.point_position("bead")
    c, s = np.cos(OMEGA * t), np.sin(OMEGA * t)
    local = np.stack([c * p[:, 0] + s * p[:, 1], -s * p[:, 0] + c * p[:, 1], p[:, 2]], axis=1)  # hoop frame
    theta = np.arctan2(local[:, 0], -local[:, 2])
    ref = _reference(lambda _, y: [y[1], np.sin(y[0]) * (OMEGA**2 * np.cos(y[0]) - G / R_HOOP)], [th0, 0.0], t)
    assert np.ptp(ref[0]) > 0.5
    np.testing.assert_allclose(theta, ref[0], rtol=0, atol=1e-8)
    # on the hoop to the projection tolerance (1e-10 by default)
    np.testing.assert_allclose(np.linalg.norm(local[:, [0, 2]], axis=1), R_HOOP, rtol=0, atol=1e-10)
    assert np.max(np.abs(local[:, 1])) < 1e-10
    if curve == "circle":
        assert res.constraint_labels == ["ring.radial", "ring.axial", "driver motor"]


def test_bead_on_a_turning_rod():
    """A bead free along a horizontal rod turning at w about z: ``r'' = w^2 r``, ``r = r0 cosh(w t)``."""
    w, r0, t = 2.0, 0.1, np.linspace(0.0, 1.0, 21)
    m = fm.Model("rod")
    rod = fm.RigidBody("rod", 1.0, (0.1, 0.1, 0.1))
    spin = fm.Revolute("spin", m.ground, rod, axis=(0, 0, 1))
    bead = _bead()
    m.add(spin, fm.Driver.constant_speed("motor", spin, w), fm.Free("free", m.ground, bead),
          fm.PointOnLine("wire", bead, on=rod, origin=(0.0, 0.0, 0.3), direction=(1.0, 0.0, 0.0)),
          fm.Gravity((0.0, 0.0, -G)))
    res = fm.simulate(m, t[-1], positions={"free.x": r0, "free.z": 0.3}, speeds={"free.y": w * r0}, n_out=len(t),
                      **TIGHT)
    p = res.point_position("bead")
    np.testing.assert_allclose(np.linalg.norm(p[:, :2], axis=1), r0 * np.cosh(w * t), rtol=1e-9)
    np.testing.assert_allclose(np.arctan2(p[:, 1], p[:, 0]), w * t, rtol=0, atol=1e-9)
    np.testing.assert_allclose(p[:, 2], 0.3, rtol=0, atol=1e-12)
    # the wire pushes the bead sideways with the Coriolis force 2 m w r' (along the rod's normals)
    assert res.constraint_labels[:2] == ["wire.normal1", "wire.normal2"]


R_CYC = 0.25


def _cycloid(s):
    return (R_CYC * np.array([s + np.sin(s), 0.0, 1.0 - np.cos(s)]), R_CYC * np.array([1.0 + np.cos(s), 0.0, np.sin(s)]),
            R_CYC * np.array([-np.sin(s), 0.0, np.cos(s)]))


@pytest.mark.parametrize("s0", [0.5, 2.5])
def test_bead_on_a_cycloid_is_the_tautochrone(s0):
    """The arc length from the bottom ``sigma = 4 r sin(s / 2)`` obeys ``sigma'' = -(g / 4 r) sigma`` exactly."""
    m = fm.Model("tautochrone")
    bead = _bead()
    m.add(fm.Free("free", m.ground, bead), fm.Gravity((0.0, 0.0, -G)),
          fm.PointOnCurve("track", bead, curve=_cycloid, bounds=(-3.0, 3.0), samples=16))
    w = np.sqrt(G / (4 * R_CYC))
    t = np.linspace(0.0, 2 * np.pi / w, 41)  # one period, whatever the amplitude
    c0 = _cycloid(s0)[0]
    res = fm.simulate(m, t[-1], positions={"free.x": c0[0], "free.z": c0[2]}, n_out=len(t), **TIGHT)
    x = res.point_position("bead")[:, 0]
    s = np.zeros_like(x)
    for _ in range(60):  # x = r (s + sin s), increasing on (-pi, pi)
        s -= (R_CYC * (s + np.sin(s)) - x) / (R_CYC * (1 + np.cos(s)))
    sigma = 4 * R_CYC * np.sin(s / 2)
    np.testing.assert_allclose(sigma, 4 * R_CYC * np.sin(s0 / 2) * np.cos(w * t), rtol=0, atol=1e-8)
    assert res.residual.max() < 1e-10


L_PEND, TH_PEND = 0.8, 1.0

SCENE = f"""
[model]
name = "two pendulums"

[bodies.bob]
mass = 0.5
inertia = [1e-3, 1e-3, 1e-3]
[bodies.bead]
mass = 0.2
inertia = [1e-4, 1e-4, 1e-4]

[joints.bob_free]
type = "free"
parent = "ground"
child = "bob"
[joints.bead_free]
type = "free"
parent = "ground"
child = "bead"

[constraints.rod]
type = "distance"
body1 = "ground"
body2 = "bob"
length = {L_PEND}

[constraints.ring]
type = "point_on_circle"
body = "bead"
centre = [0.0, 1.0, 0.0]
normal = [0.0, 1.0, 0.0]
radius = {L_PEND}

[forces.gravity]
type = "gravity"
g = [0.0, 0.0, -{G}]

[initial]
positions = {{ "bob_free.x" = {L_PEND * np.sin(TH_PEND)}, "bob_free.z" = {-L_PEND * np.cos(TH_PEND)}, "bead_free.x" = {L_PEND * np.sin(TH_PEND)}, "bead_free.y" = 1.0, "bead_free.z" = {-L_PEND * np.cos(TH_PEND)} }}

[solver]
t_end = 2.0
method = "DOP853"
rtol = 1e-11
atol = 1e-13
n_out = 41
"""


def test_a_rod_and_a_circle_in_a_scene_file_are_the_simple_pendulum():
    scene = fm.loads_scene(SCENE)
    assert [type(e).__name__ for e in scene.model.constraints] == ["Distance", "PointOnCircle"]
    res = scene.simulate()
    ref = _reference(lambda _, y: [y[1], -G / L_PEND * np.sin(y[0])], [TH_PEND, 0.0], res.t)
    for body, centre in (("bob", (0.0, 0.0, 0.0)), ("bead", (0.0, 1.0, 0.0))):
        p = res.point_position(body) - centre
        np.testing.assert_allclose(np.arctan2(p[:, 0], -p[:, 2]), ref[0], rtol=0, atol=1e-8, err_msg=body)
        assert np.max(np.abs(p[:, 1])) < 1e-12


def test_scene_tables_name_their_mistakes():
    with pytest.raises(fm.SceneError, match=r"constraints\.ring.*radius"):
        fm.loads_scene(SCENE.replace(f"radius = {L_PEND}", "radius = -1.0"))
    with pytest.raises(fm.SceneError, match=r"constraints\.rod.*length"):
        fm.loads_scene(SCENE.replace(f"length = {L_PEND}\n", ""))


def test_what_the_elements_refuse():
    m = fm.Model()
    bar = _bar()
    m.add(Planar("plane", m.ground, bar), fm.Distance("rod", bar, bar, 1.0, point2=(1.0, 0.0, 0.0)))
    with pytest.raises(ModelError, match="'rod'.*same body 'bar'"):
        m.build()
    with pytest.raises(ModelError, match="length must be > 0"):
        fm.Distance("rod", "a", "b", 0.0)
    with pytest.raises(ModelError, match="curve must be a function"):
        fm.PointOnCurve("c", "bead", curve=3.0, bounds=(0, 1))
    with pytest.raises(ModelError, match="bounds must be two finite"):
        fm.PointOnCurve("c", "bead", curve=_cycloid, bounds=(1, 0))
    # a bead pushed beyond a curve's end has left the curve
    m = fm.Model()
    bead = _bead()
    m.add(fm.Free("free", m.ground, bead), fm.PointOnCurve("track", bead, curve=_cycloid, bounds=(-1.0, 1.0)))
    with pytest.raises(AssemblyError, match="'track'.*run off the curve"):
        fm.initial_state(m.build(), positions={"free.x": 2.0})
