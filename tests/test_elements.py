"""Definition elements: valid construction, immutability, identity, repr; force elements against closed forms."""

from __future__ import annotations

import attrs
import numpy as np
import pytest

import flexmb as fm

GROUND = fm.Ground()
LINK = fm.RigidBody("link", mass=1.0, inertia=(1.0, 1.0, 1.0))


def _noop(t):
    return 0.0


# (id, factory, class, element name, array fields with their expected values)
ELEMENTS = [
    ("RigidBody", lambda: fm.RigidBody("crank", mass=2, inertia=[[2, 0, 0], [0, 3, 0], [0, 0, 4]], com=[1, 0, 0]),
     fm.RigidBody, "crank", {"inertia": np.diag([2.0, 3.0, 4.0]), "com": [1.0, 0.0, 0.0]}),
    ("RigidBody-diagonal", lambda: fm.RigidBody("crank", 1, [1, 1, 1]),
     fm.RigidBody, "crank", {"inertia": np.eye(3), "com": [0.0, 0.0, 0.0]}),
    ("slender_bar", lambda: fm.RigidBody.slender_bar("bar", mass=3, length=2),
     fm.RigidBody, "bar", {"inertia": np.diag([0.0, 1.0, 1.0]), "com": [1.0, 0.0, 0.0]}),
    ("slender_bar-centred-y", lambda: fm.RigidBody.slender_bar("bar", mass=3, length=2, axis=1, centred=True),
     fm.RigidBody, "bar", {"inertia": np.diag([1.0, 0.0, 1.0]), "com": [0.0, 0.0, 0.0]}),
    ("box", lambda: fm.RigidBody.box("block", mass=12, size=(1, 2, 3), com=(0, 0, 1)),
     fm.RigidBody, "block", {"inertia": np.diag([13.0, 10.0, 5.0]), "com": [0.0, 0.0, 1.0]}),
    ("Ground", lambda: fm.Ground(), fm.Ground, "ground", {"inertia": np.zeros((3, 3)), "com": [0.0, 0.0, 0.0]}),
    ("Marker", lambda: LINK.marker((1, 2, 3)), fm.Marker, "link", {"position": [1.0, 2.0, 3.0], "frame": np.eye(3)}),
    ("Revolute", lambda: fm.Revolute("pin", GROUND, LINK, parent_point=(1, 0, 0), child_point=(0, 1, 0),
                                     axis=(0, 0, 2)),
     fm.Revolute, "pin", {"parent_point": [1.0, 0, 0], "child_point": [0, 1.0, 0], "axis": [0, 0, 2.0]}),
    ("PlanarRevolute", lambda: fm.PlanarRevolute("pin", GROUND, LINK, axis=(0, 1, 0)),
     fm.PlanarRevolute, "pin", {"axis": [0, 1.0, 0], "parent_point": [0.0, 0, 0]}),
    ("Prismatic", lambda: fm.Prismatic("slider", GROUND, LINK, axis=(1, 0, 0), parent_frame=np.eye(3)),
     fm.Prismatic, "slider", {"axis": [1.0, 0, 0], "parent_frame": np.eye(3)}),
    ("Cylindrical", lambda: fm.Cylindrical("cyl", GROUND, LINK, child_frame=np.eye(3)[:, [1, 2, 0]]),
     fm.Cylindrical, "cyl", {"axis": [0, 0, 1.0], "child_frame": np.eye(3)[:, [1, 2, 0]]}),
    ("Universal", lambda: fm.Universal("cardan", GROUND, LINK, axis=(0, 0, 1), axis2=(1, 0, 0)),
     fm.Universal, "cardan", {"axis": [0, 0, 1.0], "axis2": [1.0, 0, 0]}),
    ("Spherical", lambda: fm.Spherical("ball", GROUND, LINK, parent_point=(0, 0, 1)),
     fm.Spherical, "ball", {"parent_point": [0, 0, 1.0]}),
    ("Fixed", lambda: fm.Fixed("weld", GROUND, LINK, child_point=(1, 1, 1)),
     fm.Fixed, "weld", {"child_point": [1.0, 1.0, 1.0]}),
    ("Free", lambda: fm.Free("float", GROUND, LINK), fm.Free, "float", {"parent_point": [0.0, 0, 0]}),
    ("Gravity", lambda: fm.Gravity((0, -10, 0)), fm.Gravity, "gravity", {"g": [0, -10.0, 0]}),
    ("Gravity-named", lambda: fm.Gravity(name="moon"), fm.Gravity, "moon", {"g": [0, 0, -9.81]}),
    ("SpringDamper", lambda: fm.SpringDamper("spring", GROUND, (0, 1, 0), LINK, (1, 0, 0), stiffness=100,
                                             damping=2, rest_length=1),
     fm.SpringDamper, "spring", {"point1": [0, 1.0, 0], "point2": [1.0, 0, 0]}),
    ("JointSpringDamper", lambda: fm.JointSpringDamper("torsion", fm.Cylindrical("cyl", GROUND, LINK),
                                                       stiffness=[10, 20], damping=1, rest=[0, 1]),
     fm.JointSpringDamper, "torsion", {"stiffness": [10.0, 20.0], "damping": 1.0, "rest": [0.0, 1.0]}),
    ("PointForce", lambda: fm.PointForce("push", LINK, (1, 2, 3), point=(0, 0, 1), frame="body"),
     fm.PointForce, "push", {"force": [1.0, 2.0, 3.0], "point": [0, 0, 1.0]}),
    ("BodyTorque", lambda: fm.BodyTorque("twist", LINK, (0, 0, 5)), fm.BodyTorque, "twist", {"torque": [0, 0, 5.0]}),
    ("Driver.constant_speed", lambda: fm.Driver.constant_speed("motor", fm.Revolute("pin", GROUND, LINK), 2.0),
     fm.Driver, "motor", {}),
    ("Driver.harmonic", lambda: fm.Driver.harmonic("shaker", fm.Prismatic("slider", GROUND, LINK), 0.1, 5.0),
     fm.Driver, "shaker", {}),
    ("Driver", lambda: fm.Driver("d", fm.Revolute("pin", GROUND, LINK), _noop, _noop, _noop), fm.Driver, "d", {}),
]
IDS = [e[0] for e in ELEMENTS]


@pytest.mark.parametrize("_, factory, cls, name, arrays", ELEMENTS, ids=IDS)
def test_valid_construction_gives_read_only_float_arrays(_, factory, cls, name, arrays):
    e = factory()
    assert type(e) is cls and e.name.startswith(name)
    for field, expected in arrays.items():
        value = getattr(e, field)
        assert isinstance(value, np.ndarray) and value.dtype == np.float64, field
        np.testing.assert_allclose(value, expected, rtol=1e-15, atol=0, err_msg=field)
        assert not value.flags.writeable, field
        with pytest.raises(ValueError, match="read-only"):
            value[...] = 0.0
        np.testing.assert_allclose(value, expected, rtol=1e-15, atol=0, err_msg=field)


@pytest.mark.parametrize("_, factory, cls, name, arrays", ELEMENTS, ids=IDS)
def test_elements_are_frozen(_, factory, cls, name, arrays):
    e = factory()
    fields = [a.name for a in attrs.fields(cls)]
    for field in fields:
        before = getattr(e, field)
        with pytest.raises(attrs.exceptions.FrozenInstanceError):
            setattr(e, field, before)
        with pytest.raises(attrs.exceptions.FrozenInstanceError):
            delattr(e, field)
        assert getattr(e, field) is before
    with pytest.raises(attrs.exceptions.FrozenInstanceError):
        e.new_attribute = 1


@pytest.mark.parametrize("_, factory, cls, name, arrays", ELEMENTS, ids=IDS)
def test_elements_are_dict_keys_by_identity(_, factory, cls, name, arrays):
    a, b = factory(), factory()
    table = {a: "a", b: "b"}
    assert len(table) == 2 and table[a] == "a" and table[b] == "b"
    assert a == a and a != b  # equal-looking definitions are still distinct elements
    assert hash(a) == hash(a) and a in {a} and b not in {a}


@pytest.mark.parametrize("_, factory, cls, name, arrays", ELEMENTS, ids=IDS)
def test_repr_names_class_and_element(_, factory, cls, name, arrays):
    text = repr(factory())
    assert text.startswith(cls.__name__ + "(")
    assert repr(name) in text


def test_inputs_are_copied():
    com = np.array([0.0, 0.0, 1.0])
    inertia = np.eye(3)
    body = fm.RigidBody("b", 1.0, inertia, com)
    com[2] = 5.0
    inertia[0, 0] = 9.0
    assert body.com[2] == 1.0 and body.inertia[0, 0] == 1.0
    assert np.shares_memory(body.com, com) is False


def test_rigid_body_scalars_and_defaults():
    body = fm.RigidBody("b", mass=3, inertia=(1.0, 1.0, 1.0))
    assert type(body.mass) is float and body.mass == 3.0
    np.testing.assert_array_equal(body.inertia, np.eye(3))
    g = fm.Ground()
    assert g.name == "ground" and g.mass == 0.0


def test_slender_bar_and_box_closed_forms():
    m, L = 0.3, 0.3
    bar = fm.RigidBody.slender_bar("bar", m, L, axis=2)
    np.testing.assert_allclose(np.diag(bar.inertia), [m * L**2 / 12, m * L**2 / 12, 0.0], rtol=1e-15)
    np.testing.assert_allclose(bar.com, [0, 0, L / 2])
    m, (a, b, c) = 6.0, (0.1, 0.2, 0.3)
    box = fm.RigidBody.box("box", m, (a, b, c))
    np.testing.assert_allclose(np.diag(box.inertia), m / 12 * np.array([b * b + c * c, a * a + c * c, a * a + b * b]))
    assert np.count_nonzero(box.inertia - np.diag(np.diag(box.inertia))) == 0


JOINT_COORDS = [
    (fm.Revolute, ("angle",)), (fm.PlanarRevolute, ("angle",)), (fm.Prismatic, ("slide",)),
    (fm.Cylindrical, ("slide", "angle")), (fm.Universal, ("angle1", "angle2")), (fm.Spherical, ("rx", "ry", "rz")),
    (fm.Fixed, ()), (fm.Free, ("x", "y", "z", "rx", "ry", "rz")),
]


@pytest.mark.parametrize("cls, names", JOINT_COORDS, ids=[c.__name__ for c, _ in JOINT_COORDS])
def test_joint_defaults_and_coordinates(cls, names):
    j = cls("j", GROUND, LINK)
    assert j.n_coords == len(names) and j.coordinate_names == names
    assert j.parent is GROUND and j.child is LINK and j.cut is False
    assert j.parent_frame is None and j.child_frame is None
    fp, fc = j.frames()
    np.testing.assert_allclose(fp.T @ fp, np.eye(3), atol=1e-14)
    assert np.linalg.det(fp) == pytest.approx(1.0)
    np.testing.assert_array_equal(fc, fp)


def test_axis_joint_frame_has_the_axis_as_z():
    j = fm.Revolute("pin", GROUND, LINK, axis=(1, 2, 2))
    fp, _ = j.frames()
    np.testing.assert_allclose(fp[:, 2], np.array([1, 2, 2]) / 3, rtol=1e-14)
    u = fm.Universal("u", GROUND, LINK, axis=(0, 0, 1), axis2=(1, 0, 0))
    fp, _ = u.frames()
    np.testing.assert_allclose(fp[:, :2], [[0, 1], [0, 0], [1, 0]], atol=1e-14)


def test_driver_profiles():
    pin = fm.Revolute("pin", GROUND, LINK)
    d = fm.Driver.constant_speed("motor", pin, speed=2.0, start=0.5)
    assert (d.position(1.5), d.velocity(1.5), d.acceleration(1.5)) == (3.5, 2.0, 0.0)
    assert d.joint is pin and d.coordinate == 0
    h = fm.Driver.harmonic("shaker", fm.Universal("u", GROUND, LINK), amplitude=0.2, frequency=3.0, offset=0.1,
                           coordinate=1)
    assert h.coordinate == 1
    w = 2 * np.pi * 3.0
    for t in (0.0, 0.013, 0.4):
        assert h.position(t) == pytest.approx(0.1 + 0.2 * np.sin(w * t), abs=1e-15)
        # velocity and acceleration are the derivatives of position (central differences)
        eps = 1e-6
        assert h.velocity(t) == pytest.approx((h.position(t + eps) - h.position(t - eps)) / (2 * eps), rel=1e-6)
        assert h.acceleration(t) == pytest.approx((h.velocity(t + eps) - h.velocity(t - eps)) / (2 * eps),
                                                  rel=1e-6, abs=1e-6)


# ----------------------------------------------------------------------------- force elements vs closed forms

def state_of(model, x, xd=None, t=0.0):
    """Build the model; return (system, kinematics, loads, generalized active force F) at a state."""
    system = model.build()
    x = np.atleast_1d(np.asarray(x, dtype=float))
    xd = np.zeros_like(x) if xd is None else np.atleast_1d(np.asarray(xd, dtype=float))
    kin = system.kinematics(t, x, xd)
    loads = system.forces.loads(kin)
    return system, kin, loads, system.forces.active_force(kin, loads)


@pytest.mark.parametrize("q, qd", [(-0.3, 0.7), (0.0, 0.0), (0.2, -1.2), (0.5, 0.4)])
def test_spring_damper_on_prismatic_collinear(q, qd):
    k, c, l0 = 50.0, 3.0, 0.8
    model = fm.Model()
    slider = fm.RigidBody("slider", mass=2.0, inertia=(1.0, 1.0, 1.0))
    model.add(fm.Prismatic("rail", model.ground, slider, axis=(1, 0, 0)),
              fm.SpringDamper("spring", model.ground, (-1.0, 0, 0), slider, (0, 0, 0), k, c, l0))
    system, _, _, F = state_of(model, [q], [qd])
    l, ldot = 1.0 + q, qd
    assert F[0] == pytest.approx(-k * (l - l0) - c * ldot, rel=1e-12, abs=1e-12)
    assert system.energy(0.0, [q], [qd])[1] == pytest.approx(0.5 * k * (l - l0) ** 2, rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("q, qd", [(-0.4, 0.7), (0.3, -1.1), (1.5, 0.2)])
def test_spring_damper_on_prismatic_oblique(q, qd):
    """Spring from (0, h) on the ground to the slider on the x axis: F = -(k (l - l0) + c ldot) dl/dq."""
    k, c, l0, h = 40.0, 2.5, 0.3, 0.5
    model = fm.Model()
    slider = fm.RigidBody("slider", mass=2.0, inertia=(1.0, 1.0, 1.0))
    model.add(fm.Prismatic("rail", model.ground, slider, axis=(1, 0, 0)),
              fm.SpringDamper("spring", model.ground, (0, h, 0), slider, (0, 0, 0), k, c, l0))
    system, _, _, F = state_of(model, [q], [qd])
    l = np.hypot(q, h)
    dl_dq = q / l
    ldot = dl_dq * qd
    assert F[0] == pytest.approx(-(k * (l - l0) + c * ldot) * dl_dq, rel=1e-12, abs=1e-12)
    # the spring part is minus the gradient of its potential
    U = lambda s: system.energy(0.0, [s], [0.0])[1]  # noqa: E731
    _, _, _, F0 = state_of(model, [q], [0.0])
    eps = 1e-6
    assert F0[0] == pytest.approx(-(U(q + eps) - U(q - eps)) / (2 * eps), rel=1e-7)


@pytest.mark.parametrize("q", [-0.2, 0.0, 0.35])
def test_spring_with_zero_rest_length_is_smooth_through_zero(q):
    k = 30.0
    model = fm.Model()
    slider = fm.RigidBody("slider", mass=1.0, inertia=(1.0, 1.0, 1.0))
    model.add(fm.Prismatic("rail", model.ground, slider, axis=(0, 1, 0)),
              fm.SpringDamper("spring", model.ground, (0, 0, 0), slider, (0, 0, 0), k))
    _, _, _, F = state_of(model, [q], [1.0])
    assert F[0] == pytest.approx(-k * q, abs=1e-12)


def test_joint_spring_damper_generalized_force():
    k, c, q0 = np.array([10.0, 20.0]), np.array([1.0, 0.5]), np.array([0.1, -0.2])
    model = fm.Model()
    link = fm.RigidBody("link", mass=1.0, inertia=(1.0, 1.0, 1.0))
    cyl = fm.Cylindrical("cyl", model.ground, link, axis=(0, 1, 0))
    model.add(cyl, fm.JointSpringDamper("torsion", cyl, stiffness=k, damping=c, rest=q0))
    x, xd = np.array([0.3, 0.4]), np.array([-0.5, 2.0])
    system, _, _, F = state_of(model, x, xd)
    np.testing.assert_allclose(F, -k * (x - q0) - c * xd, rtol=1e-14)
    assert system.energy(0.0, x, xd)[1] == pytest.approx(0.5 * np.sum(k * (x - q0) ** 2), rel=1e-14)


AXIS = np.array([1.0, 2.0, 2.0])  # |AXIS| = 3


@pytest.mark.parametrize("frame", ["ground", "body"])
@pytest.mark.parametrize("q", [0.0, 0.7, -2.0])
def test_body_torque_on_revolute_is_torque_dot_axis(frame, q):
    tau = np.array([0.3, -0.5, 2.0])
    model = fm.Model()
    link = fm.RigidBody("link", 1.0, (1.0, 2.0, 2.5), com=(0.1, 0.2, 0.3))
    model.add(fm.Revolute("pin", model.ground, link, parent_point=(0.5, 0, 0), axis=AXIS),
              fm.BodyTorque("twist", link, tau, frame=frame))
    _, kin, loads, F = state_of(model, [q], [1.0])
    # a rotation about the axis leaves the axial component of a body-frame torque unchanged
    assert F[0] == pytest.approx(tau @ AXIS / 3, rel=1e-13)
    expected = tau if frame == "ground" else kin.R[0] @ tau
    np.testing.assert_allclose(loads.torque[0], expected, rtol=1e-14)
    np.testing.assert_array_equal(loads.force[0], 0.0)


def test_body_torque_does_no_work_on_a_slide():
    tau = np.array([0.0, 0.0, 4.0])
    model = fm.Model()
    link = fm.RigidBody("link", mass=1.0, inertia=(1.0, 1.0, 1.0))
    model.add(fm.Cylindrical("cyl", model.ground, link, axis=(0, 0, 1)), fm.BodyTorque("twist", link, tau))
    _, _, _, F = state_of(model, [0.2, 0.3])
    np.testing.assert_allclose(F, [0.0, 4.0], atol=1e-15)


@pytest.mark.parametrize("theta", [0.0, 0.5, 2.0, -1.0])
def test_point_force_in_body_frame_rotates_with_the_body(theta):
    """A body-frame force (0, 1, 0) at body point (1, 0, 0) stays tangential: unit moment at every angle."""
    model = fm.Model()
    arm = fm.RigidBody.slender_bar("arm", 1.0, 1.0)
    model.add(fm.Revolute("pin", model.ground, arm, axis=(0, 0, 1)),
              fm.PointForce("follower", arm, (0.0, 1.0, 0.0), point=(1.0, 0.0, 0.0), frame="body"))
    _, kin, loads, F = state_of(model, [theta])
    c, s = np.cos(theta), np.sin(theta)
    np.testing.assert_allclose(loads.force[0], [-s, c, 0.0], atol=1e-15)
    # about the mass centre (lever 0.5 along the bar) the moment is 0.5
    np.testing.assert_allclose(loads.torque[0], [0.0, 0.0, 0.5], atol=1e-15)
    assert F[0] == pytest.approx(1.0, rel=1e-14)


@pytest.mark.parametrize("theta", [0.0, 0.5, 2.0])
def test_point_force_in_ground_frame_does_not_rotate(theta):
    model = fm.Model()
    arm = fm.RigidBody.slender_bar("arm", 1.0, 1.0)
    model.add(fm.Revolute("pin", model.ground, arm, axis=(0, 0, 1)),
              fm.PointForce("dead", arm, lambda t: (0.0, t, 0.0), point=(1.0, 0.0, 0.0)))
    _, _, loads, F = state_of(model, [theta], t=0.3)
    np.testing.assert_allclose(loads.force[0], [0.0, 0.3, 0.0], atol=1e-15)
    assert F[0] == pytest.approx(0.3 * np.cos(theta), abs=1e-14)


def test_point_force_callable_receives_state():
    seen = []

    def force(t, state):
        seen.append((t, state.x.copy()))
        return (0.0, 0.0, 1.0)

    model = fm.Model()
    arm = fm.RigidBody.slender_bar("arm", 1.0, 1.0)
    model.add(fm.Revolute("pin", model.ground, arm), fm.PointForce("f", arm, force))
    _, _, loads, _ = state_of(model, [0.25], t=0.5)
    assert seen[-1][0] == 0.5 and seen[-1][1].tolist() == [0.25]
    np.testing.assert_allclose(loads.force[0], [0, 0, 1.0])


def bryant(rx, ry, rz):
    def rot(axis, a):
        c, s = np.cos(a), np.sin(a)
        i, j = (axis + 1) % 3, (axis + 2) % 3
        R = np.eye(3)
        R[i, i] = R[j, j] = c
        R[i, j], R[j, i] = -s, s
        return R

    return rot(0, rx) @ rot(1, ry) @ rot(2, rz)


def test_gravity_potential_is_minus_m_g_dot_r():
    g = np.array([0.3, -9.81, 0.5])
    m1, m2 = 2.0, 0.7
    com1 = np.array([0.1, -0.2, 0.3])
    p0 = np.array([1.0, 2.0, -0.5])
    model = fm.Model()
    b1 = fm.RigidBody("b1", m1, (1.0, 1.2, 1.5), com1)
    b2 = fm.RigidBody.slender_bar("b2", m2, 0.8)
    model.add(fm.Free("float", model.ground, b1, parent_point=p0),
              fm.Revolute("pin", b1, b2, parent_point=(0.4, 0, 0), axis=(0, 1, 0)),
              fm.Gravity(g))
    x = np.array([0.2, -0.1, 0.4, 0.3, -0.5, 1.1, 0.6])
    system, kin, loads, F = state_of(model, x)

    # body 1 by hand: origin = p0 + translation, mass centre = origin + R com
    R1 = bryant(*x[3:6])
    r1 = p0 + x[:3] + R1 @ com1
    np.testing.assert_allclose(kin.r[0], r1, rtol=1e-14, atol=1e-14)
    # body 2: pin at (0.4, 0, 0) on body 1, rotation about y of body 1, bar centre 0.4 along its x
    R2 = R1 @ bryant(0.0, x[6], 0.0)
    r2 = p0 + x[:3] + R1 @ np.array([0.4, 0, 0]) + R2 @ np.array([0.4, 0, 0])
    np.testing.assert_allclose(kin.r[1], r2, rtol=1e-14, atol=1e-14)

    U = system.energy(0.0, x, np.zeros_like(x))[1]
    assert U == pytest.approx(-(m1 * g @ r1 + m2 * g @ r2), rel=1e-13)
    np.testing.assert_allclose(loads.force[:2], [m1 * g, m2 * g], rtol=1e-15)
    np.testing.assert_array_equal(loads.torque[:2], 0.0)

    # F = -dU/dx (gravity is conservative)
    eps = 1e-6
    grad = np.array([(system.energy(0.0, x + eps * e, 0 * x)[1] - system.energy(0.0, x - eps * e, 0 * x)[1])
                     / (2 * eps) for e in np.eye(len(x))])
    np.testing.assert_allclose(F, -grad, rtol=1e-7, atol=1e-7)
