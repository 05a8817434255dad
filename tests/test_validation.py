"""Bad input gets a clear, specific flexmb error naming the element.

Every test asserts both the exception type (ModelError / AssemblyError /
SimulationError, all FlexmbError) and that the message names the offending
element and the problem. Checks that flexmb does not make yet are marked
(former strict xfails, now fixed in src).
"""

from __future__ import annotations

import re

import numpy as np
import attrs
import pytest
from attrs import frozen

import flexmb as fm
from conftest import fourbar, fourbar_initial

NAN, INF = float("nan"), float("inf")


# ----------------------------------------------------------------------------- helpers

def pendulum(name="pendulum", extra=()):
    """A slender bar on a revolute about z under gravity along -y."""
    model = fm.Model(name)
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)), fm.Gravity((0.0, -9.81, 0.0)), *extra)
    return model


def driven_double_pendulum():
    """Two bars; the first joint driven at constant speed, the second free."""
    model = fm.Model("double")
    b0 = fm.RigidBody.slender_bar("bar0", 1.0, 1.0)
    b1 = fm.RigidBody.slender_bar("bar1", 1.0, 1.0)
    pin0 = fm.Revolute("pin0", model.ground, b0)
    pin1 = fm.Revolute("pin1", b0, b1, parent_point=(1.0, 0, 0))
    model.add(pin0, pin1, fm.Gravity((0.0, -9.81, 0.0)), fm.Driver.constant_speed("motor", pin0, speed=1.0))
    return model


def problems_of(model):
    """Run validate and return the ModelError's problems (it must raise)."""
    with pytest.raises(fm.ModelError) as info:
        model.validate()
    assert isinstance(info.value, fm.FlexmbError)
    assert info.value.problems, "a ModelError from validate lists its problems"
    return info.value


def test_error_hierarchy():
    for cls in (fm.ModelError, fm.AssemblyError, fm.SimulationError):
        assert issubclass(cls, fm.FlexmbError)
    assert fm.ModelError("x").problems == ["x"]
    err = fm.SimulationError("boom", t=0.5, result="partial")
    assert (err.t, err.result) == (0.5, "partial")


# ----------------------------------------------------------------------------- RigidBody

@pytest.mark.parametrize("mass", [0.0, -1.0, -1e-300])
def test_body_non_positive_mass(mass):
    with pytest.raises(fm.ModelError, match=r"RigidBody 'crank': mass must be > 0"):
        fm.RigidBody("crank", mass=mass, inertia=(1.0, 1.0, 1.0))


@pytest.mark.parametrize("mass", [NAN, INF, -INF])
def test_body_non_finite_mass(mass):
    with pytest.raises(fm.ModelError, match=r"RigidBody 'crank': mass must be > 0, got (nan|inf|-inf)"):
        fm.RigidBody("crank", mass=mass, inertia=(1.0, 1.0, 1.0))


def test_body_non_symmetric_inertia():
    J = [[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    with pytest.raises(fm.ModelError, match=r"RigidBody 'crank': inertia must be symmetric"):
        fm.RigidBody("crank", inertia=J, mass=1.0)


def test_body_negative_principal_moment():
    # symmetric, but with eigenvalues (-0.5, 1.5, 1): not positive semi-definite
    J = [[0.5, 1.0, 0.0], [1.0, 0.5, 0.0], [0.0, 0.0, 1.0]]
    with pytest.raises(fm.ModelError, match=r"RigidBody 'crank': inertia must be positive \(semi-\)definite"):
        fm.RigidBody("crank", inertia=J, mass=1.0)
    with pytest.raises(fm.ModelError, match=r"RigidBody 'crank': inertia must be positive"):
        fm.RigidBody("crank", inertia=(-1.0, 1.0, 1.0), mass=1.0)


def test_body_triangle_inequality():
    with pytest.raises(fm.ModelError, match=r"RigidBody 'plate': inertia breaks the triangle inequality"):
        fm.RigidBody("plate", inertia=(1.0, 1.0, 3.0), mass=1.0)
    # the same tensor in rotated axes is caught by its principal moments
    c, s = np.cos(0.7), np.sin(0.7)
    Q = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    with pytest.raises(fm.ModelError, match=r"RigidBody 'plate': inertia breaks the triangle inequality"):
        fm.RigidBody("plate", inertia=Q @ np.diag([1.0, 1.0, 3.0]) @ Q.T, mass=1.0)


def test_body_limits_of_valid_inertia_are_accepted():
    """The checks are not stricter than physics: thin plate (equality) and slender bar (zero moment)."""
    plate = fm.RigidBody("plate", inertia=(1.0, 1.0, 2.0), mass=1.0)
    bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    assert plate.inertia[2, 2] == 2.0 and bar.inertia[0, 0] == 0.0


@pytest.mark.parametrize(
    "field, value, shape",
    [
        ("inertia", np.eye(2), "(3, 3)"),
        ("inertia", (1.0, 1.0, 1.0, 1.0), "(3, 3)"),
        ("inertia", np.ones((3, 3, 1)), "(3, 3)"),
        ("com", (0.0, 0.0), "(3,)"),
        ("com", np.zeros((3, 1)), "(3,)"),
        ("com", 0.0, "(3,)"),
    ],
)
def test_body_wrong_shapes(field, value, shape):
    with pytest.raises(fm.ModelError, match=rf"RigidBody 'crank': {field} must have shape {re.escape(shape)}"):
        fm.RigidBody("crank", **{"mass": 1.0, "inertia": (1.0, 1.0, 1.0), field: value})


@pytest.mark.parametrize("given", [{}, {"mass": 2.0}, {"inertia": (1.0, 1.0, 1.0)}])
def test_a_rigid_body_without_mass_or_inertia_is_refused(given):
    """Issue #32: RigidBody("x") silently took 1 kg and unit inertia; now the body and what is missing are named."""
    missing = " and ".join(k for k in ("mass", "inertia") if k not in given)
    with pytest.raises(fm.ModelError, match=rf"RigidBody 'crank': give its {missing} \(mass in kg, .*slender_bar"):
        fm.RigidBody("crank", **given)
    point = fm.RigidBody("point", 2.0, (0.0, 0.0, 0.0))  # a point mass says so
    assert point.mass == 2.0 and not point.inertia.any()


def test_a_misspelt_driver_key_lists_the_keys_the_loader_reads_and_suggests_the_closest():
    """Issue #32: `rmp` in [drivers.motor] listed the allowed keys without `rpm` and `kind`."""
    import pathlib

    text = (pathlib.Path(fm.__file__).parent / "scene" / "builtin" / "wiper.toml").read_text()
    assert "\nrpm = 60.0\n" in text
    with pytest.raises(fm.SceneError) as info:
        fm.loads_scene(text.replace("\nrpm = 60.0\n", "\nrmp = 60.0\n"), "wiper.toml")
    message = str(info.value)
    assert message.startswith("wiper.toml: drivers.motor.rmp: unknown key for driver kind 'constant_speed'")
    allowed = message.split("allowed keys: ")[1].split(";")[0].split(", ")
    assert {"kind", "rpm", "joint", "speed"} <= set(allowed)
    assert message.endswith("did you mean 'rpm'?")


@pytest.mark.parametrize("bad", [NAN, INF])
def test_body_non_finite_com_and_inertia(bad):
    with pytest.raises(fm.ModelError, match=r"RigidBody 'crank': com must be finite"):
        fm.RigidBody("crank", com=(0.0, bad, 0.0), mass=1.0, inertia=(1.0, 1.0, 1.0))
    with pytest.raises(fm.ModelError, match=r"RigidBody 'crank': inertia must be finite"):
        fm.RigidBody("crank", inertia=(1.0, bad, 1.0), mass=1.0)


@pytest.mark.parametrize("name", ["", "   ", None, 3])
def test_body_bad_name(name):
    with pytest.raises(fm.ModelError, match=r"RigidBody: name must be a non-empty string"):
        fm.RigidBody(name, mass=1.0, inertia=(1.0, 1.0, 1.0))


def test_constructors_validate_too():
    with pytest.raises(fm.ModelError, match=r"RigidBody 'bar': mass must be > 0"):
        fm.RigidBody.slender_bar("bar", mass=-1.0, length=1.0)
    with pytest.raises(fm.ModelError, match=r"RigidBody 'block': mass must be > 0"):
        fm.RigidBody.box("block", mass=0.0, size=(1, 1, 1))
    with pytest.raises(fm.ModelError, match=r"RigidBody 'block': com must be finite"):
        fm.RigidBody.box("block", mass=1.0, size=(1, 1, 1), com=(NAN, 0, 0))


@pytest.mark.parametrize("mass", ["heavy", None])
def test_body_non_numeric_mass(mass):
    with pytest.raises(fm.ModelError, match=r"RigidBody 'crank': (give its )?mass"):
        fm.RigidBody("crank", mass=mass, inertia=(1.0, 1.0, 1.0))


def test_body_non_numeric_com_names_the_body():
    with pytest.raises(fm.ModelError, match=r"RigidBody 'crank': com"):
        fm.RigidBody("crank", com=("a", "b", "c"), mass=1.0, inertia=(1.0, 1.0, 1.0))


# ----------------------------------------------------------------------------- joints

AXIS_JOINTS = [fm.Revolute, fm.PlanarRevolute, fm.Prismatic, fm.Cylindrical]
ALL_JOINTS = AXIS_JOINTS + [fm.Universal, fm.Spherical, fm.Fixed, fm.Free]


@pytest.fixture
def pair():
    return fm.Ground(), fm.RigidBody("link", mass=1.0, inertia=(1.0, 1.0, 1.0))


@pytest.mark.parametrize("cls", AXIS_JOINTS)
def test_joint_zero_axis(cls, pair):
    with pytest.raises(fm.ModelError, match=rf"{cls.__name__} 'j': axis must not be a zero-length vector"):
        cls("j", *pair, axis=(0.0, 0.0, 0.0))


@pytest.mark.parametrize("field", ["axis", "axis2"])
def test_universal_zero_axis(field, pair):
    with pytest.raises(fm.ModelError, match=rf"Universal 'u': {field} must not be a zero-length vector"):
        fm.Universal("u", *pair, **{field: (0.0, 0.0, 0.0)})


@pytest.mark.parametrize("cls", AXIS_JOINTS)
def test_joint_non_finite_axis(cls, pair):
    with pytest.raises(fm.ModelError, match=rf"{cls.__name__} 'j': axis must be finite"):
        cls("j", *pair, axis=(0.0, NAN, 1.0))


@pytest.mark.parametrize("cls", ALL_JOINTS)
@pytest.mark.parametrize("field", ["parent_point", "child_point"])
@pytest.mark.parametrize("bad", [NAN, INF])
def test_joint_non_finite_points(cls, field, bad, pair):
    with pytest.raises(fm.ModelError, match=rf"{cls.__name__} 'j': {field} must be finite"):
        cls("j", *pair, **{field: (0.1, bad, 0.0)})


@pytest.mark.parametrize("cls", ALL_JOINTS)
def test_joint_wrong_point_shape(cls, pair):
    with pytest.raises(fm.ModelError, match=rf"{cls.__name__} 'j': parent_point must have shape \(3,\)"):
        cls("j", *pair, parent_point=(0.1, 0.2))


@pytest.mark.parametrize(
    "frame",
    [
        2.0 * np.eye(3),                       # scaled
        np.diag([1.0, 1.0, -1.0]),             # reflection, det -1
        np.array([[1, 0.3, 0], [0, 1, 0], [0, 0, 1.0]]),  # not orthogonal
    ],
    ids=["scaled", "reflection", "sheared"],
)
@pytest.mark.parametrize("field", ["parent_frame", "child_frame"])
def test_joint_frame_not_a_rotation(frame, field, pair):
    with pytest.raises(fm.ModelError, match=rf"Revolute 'pin': {field} must be a rotation matrix"):
        fm.Revolute("pin", *pair, **{field: frame})


def test_joint_frame_wrong_shape(pair):
    with pytest.raises(fm.ModelError, match=r"Spherical 'ball': parent_frame must have shape \(3, 3\)"):
        fm.Spherical("ball", *pair, parent_frame=np.eye(2))


@pytest.mark.parametrize("cls", ALL_JOINTS)
def test_joint_parent_is_child(cls):
    link = fm.RigidBody("link", mass=1.0, inertia=(1.0, 1.0, 1.0))
    with pytest.raises(fm.ModelError, match=rf"{cls.__name__} 'j': parent and child are the same body 'link'"):
        cls("j", link, link)


def test_universal_axes_not_perpendicular(pair):
    with pytest.raises(fm.ModelError, match=r"Universal 'u': axis and axis2 must be perpendicular \(cos = 0\.707\)"):
        fm.Universal("u", *pair, axis=(1.0, 0.0, 0.0), axis2=(1.0, 1.0, 0.0))
    # perpendicular but not unit, and not along body axes: fine
    fm.Universal("u", *pair, axis=(2.0, 2.0, 0.0), axis2=(0.0, 0.0, 3.0))


@pytest.mark.parametrize("cls", ALL_JOINTS)
@pytest.mark.parametrize("bad", ["", None, 1.0])
def test_joint_non_body_parent_or_child(cls, bad):
    # a body's name is accepted (resolved when the model is built); an empty one is not
    link = fm.RigidBody("link", mass=1.0, inertia=(1.0, 1.0, 1.0))
    kind = type(bad).__name__
    with pytest.raises(fm.ModelError, match=rf"{cls.__name__} 'j': parent must be a Body, got {kind}"):
        cls("j", bad, link)
    with pytest.raises(fm.ModelError, match=rf"{cls.__name__} 'j': child must be a Body, got {kind}"):
        cls("j", link, bad)


def test_joint_marker_is_not_a_body():
    link = fm.RigidBody("link", mass=1.0, inertia=(1.0, 1.0, 1.0))
    with pytest.raises(fm.ModelError, match=r"Revolute 'j': parent must be a Body, got Marker"):
        fm.Revolute("j", link.marker((1, 0, 0)), fm.RigidBody("other", mass=1.0, inertia=(1.0, 1.0, 1.0)))


def test_joint_bad_name(pair):
    with pytest.raises(fm.ModelError, match=r"Revolute: name must be a non-empty string"):
        fm.Revolute("", *pair)


# ----------------------------------------------------------------------------- drivers

def test_driver_coordinate_out_of_range(pair):
    pin = fm.Revolute("pin", *pair)
    for c in (1, -1):
        with pytest.raises(fm.ModelError,
                           match=rf"Driver 'motor': coordinate {c} out of range for joint 'pin' with 1 coordinate"):
            fm.Driver.constant_speed("motor", pin, speed=1.0, coordinate=c)
    uj = fm.Universal("u", *pair)
    with pytest.raises(fm.ModelError, match=r"Driver 'wave': coordinate 2 out of range for joint 'u' with 2"):
        fm.Driver.harmonic("wave", uj, amplitude=0.1, frequency=1.0, coordinate=2)
    weld = fm.Fixed("weld", *pair)
    with pytest.raises(fm.ModelError, match=r"Driver 'motor': coordinate 0 out of range for joint 'weld' with 0"):
        fm.Driver.constant_speed("motor", weld, speed=1.0)


@pytest.mark.parametrize("field", ["position", "velocity", "acceleration"])
def test_driver_not_callable(field, pair):
    pin = fm.Revolute("pin", *pair)
    kw = dict(position=lambda t: t, velocity=lambda t: 1.0, acceleration=lambda t: 0.0)
    kw[field] = 1.0
    with pytest.raises(fm.ModelError, match=rf"Driver 'motor': {field} must be callable, got 1\.0"):
        fm.Driver("motor", pin, **kw)


def test_driver_joint_not_a_joint(pair):
    with pytest.raises(fm.ModelError, match=r"Driver 'motor': joint must be a Joint, got RigidBody"):
        fm.Driver("motor", pair[1], lambda t: t, lambda t: 1.0, lambda t: 0.0)


# ----------------------------------------------------------------------------- force elements

def test_force_element_field_checks(pair):
    ground, link = pair
    with pytest.raises(fm.ModelError, match=r"Gravity 'gravity': g must have shape \(3,\)"):
        fm.Gravity((0.0, -9.81))
    with pytest.raises(fm.ModelError, match=r"Gravity 'moon': g must be finite"):
        fm.Gravity((0.0, NAN, 0.0), name="moon")
    with pytest.raises(fm.ModelError, match=r"SpringDamper 's': stiffness must be finite and >= 0, got -1\.0"):
        fm.SpringDamper("s", ground, (0, 0, 0), link, (0, 0, 0), stiffness=-1.0)
    with pytest.raises(fm.ModelError, match=r"SpringDamper 's': damping must be finite and >= 0, got nan"):
        fm.SpringDamper("s", ground, (0, 0, 0), link, (0, 0, 0), stiffness=1.0, damping=NAN)
    with pytest.raises(fm.ModelError, match=r"SpringDamper 's': rest_length must be finite and >= 0"):
        fm.SpringDamper("s", ground, (0, 0, 0), link, (0, 0, 0), stiffness=1.0, rest_length=-0.1)
    with pytest.raises(fm.ModelError, match=r"SpringDamper 's': point2 must be finite"):
        fm.SpringDamper("s", ground, (0, 0, 0), link, (0, INF, 0), stiffness=1.0)
    with pytest.raises(fm.ModelError, match=r"JointSpringDamper 'js': stiffness must be finite and >= 0"):
        fm.JointSpringDamper("js", fm.Revolute("pin", ground, link), stiffness=[-1.0])
    with pytest.raises(fm.ModelError, match=r"PointForce 'push': frame must be 'ground' or 'body', got 'world'"):
        fm.PointForce("push", link, (1.0, 0, 0), frame="world")
    with pytest.raises(fm.ModelError, match=r"PointForce 'push': force must have shape \(3,\)"):
        fm.PointForce("push", link, (1.0, 0))
    with pytest.raises(fm.ModelError, match=r"PointForce 'push': force must take \(t\) or \(t, state\), takes 3"):
        fm.PointForce("push", link, lambda t, state, extra: (0, 0, 0))
    with pytest.raises(fm.ModelError, match=r"BodyTorque 'twist': torque must be finite"):
        fm.BodyTorque("twist", link, (0.0, 0.0, NAN))
    with pytest.raises(fm.ModelError, match=r"BodyTorque 'twist': frame must be 'ground' or 'body'"):
        fm.BodyTorque("twist", link, (0.0, 0.0, 1.0), frame="local")


@pytest.mark.parametrize(
    "make, field, kind",
    [
        (lambda link, pin: fm.PointForce("f", "", (1.0, 0, 0)), "body", "str"),  # a name is fine, "" is not
        (lambda link, pin: fm.BodyTorque("f", None, (0, 0, 1.0)), "body", "NoneType"),
        (lambda link, pin: fm.SpringDamper("f", link, (0, 0, 0), pin, (0, 0, 0), 1.0), "body2", "Revolute"),
        (lambda link, pin: fm.JointSpringDamper("f", link, stiffness=1.0), "joint", "RigidBody"),
    ],
    ids=["PointForce", "BodyTorque", "SpringDamper", "JointSpringDamper"],
)
def test_force_element_wrong_kind_of_element(make, field, kind):
    link = fm.RigidBody("link", mass=1.0, inertia=(1.0, 1.0, 1.0))
    pin = fm.Revolute("pin", fm.Ground(), link)
    with pytest.raises(fm.ModelError, match=rf"'f': {field} must be a (Body|Joint), got {kind}"):
        make(link, pin)


@frozen(eq=False)
class Exploding(fm.ForceElement):
    """A user element whose apply always fails."""

    why: str = "no table for this state"

    def apply(self, state, loads):
        raise KeyError(self.why)


@frozen(eq=False)
class Picky(fm.ForceElement):
    """A user element raising its own ModelError."""

    def apply(self, state, loads):
        raise fm.ModelError("needs a contact surface")


def test_user_force_element_failing_is_caught_at_build():
    model = pendulum(extra=[Exploding("bumper")])
    with pytest.raises(fm.ModelError,
                       match=r"force element 'bumper' \(Exploding\) failed on the reference state: "
                             r"KeyError: 'no table for this state'") as info:
        model.build()
    assert isinstance(info.value.__cause__, KeyError)
    # and simulate reports it the same way, before integrating
    with pytest.raises(fm.ModelError, match=r"force element 'bumper'"):
        fm.simulate(model, 1.0)


def test_user_force_element_model_error_is_prefixed_with_its_name():
    with pytest.raises(fm.ModelError, match=r"force element 'floor': needs a contact surface"):
        pendulum(extra=[Picky("floor")]).build()


def test_force_element_without_apply():
    with pytest.raises(fm.ModelError, match=r"force element 'todo' \(ForceElement\) failed.*NotImplementedError"):
        pendulum(extra=[fm.ForceElement("todo")]).build()


# ----------------------------------------------------------------------------- model

def test_duplicate_names_all_listed():
    model = fm.Model("dup")
    b1, b2 = fm.RigidBody("link", mass=1.0, inertia=(1.0, 1.0, 1.0)), fm.RigidBody("link", mass=1.0, inertia=(1.0, 1.0, 1.0))
    j1 = fm.Revolute("pin", model.ground, b1)
    j2 = fm.Revolute("pin", model.ground, b2)
    model.add(j1, j2, fm.Gravity(), fm.Gravity(),
              fm.Driver.constant_speed("motor", j1, 1.0), fm.Driver.constant_speed("motor", j2, 1.0))
    err = problems_of(model)
    assert err.problems == [
        "duplicate body name 'link' (2 times)",
        "duplicate joint name 'pin' (2 times)",
        "duplicate force element name 'gravity' (2 times)",
        "duplicate driver name 'motor' (2 times)",
    ]
    msg = str(err)
    assert msg.startswith("Model 'dup' is invalid:")
    assert all(p in msg for p in err.problems)
    with pytest.raises(fm.ModelError, match=r"duplicate body name 'link'"):
        model.build()


def test_validate_lists_every_kind_of_problem_at_once():
    model = fm.Model("many")
    link, ghost = fm.RigidBody("link", mass=1.0, inertia=(1.0, 1.0, 1.0)), fm.RigidBody("ghost", mass=1.0, inertia=(1.0, 1.0, 1.0))
    pin = fm.Revolute("pin", model.ground, link)
    stray = fm.Revolute("stray", model.ground, fm.RigidBody("elsewhere", mass=1.0, inertia=(1.0, 1.0, 1.0)))  # never added
    model.add(pin, fm.Revolute("pin", model.ground, fm.RigidBody("link2", mass=1.0, inertia=(1.0, 1.0, 1.0))),
              fm.Revolute("back", link, model.ground),
              fm.PointForce("push", ghost, (1.0, 0.0, 0.0)),
              fm.Driver.constant_speed("motor", stray, 1.0))
    err = problems_of(model)
    expected = [
        r"duplicate joint name 'pin'",
        r"joint 'back': the ground cannot be a child",
        r"force element 'push': body 'ghost' is not in the model",
        r"driver 'motor': joint 'stray' is not in the model",
    ]
    assert len(err.problems) == len(expected)
    for pattern, problem in zip(expected, err.problems):
        assert re.search(pattern, problem), (pattern, problem)


def test_validate_lists_definition_and_topology_problems_together():
    model = fm.Model("mixed")
    model.add(fm.Revolute("pin", model.ground, fm.RigidBody("link", mass=1.0, inertia=(1.0, 1.0, 1.0))),
              fm.Revolute("pin", model.ground, fm.RigidBody("link2", mass=1.0, inertia=(1.0, 1.0, 1.0))),
              fm.RigidBody("lone", mass=1.0, inertia=(1.0, 1.0, 1.0)))
    err = problems_of(model)
    assert any("duplicate joint name 'pin'" in p for p in err.problems)
    assert any("body 'lone' is not connected to the ground" in p for p in err.problems)


def test_body_not_connected_to_ground():
    model = pendulum()
    lone = fm.RigidBody("lone", mass=1.0, inertia=(1.0, 1.0, 1.0))
    model.add(lone)
    err = problems_of(model)
    assert err.problems == ["body 'lone' is not connected to the ground through tree joints "
                            "(joints run parent -> child from the ground)"]
    # a floating sub-tree: both of its bodies are reported
    model = pendulum()
    a, b = fm.RigidBody("a", mass=1.0, inertia=(1.0, 1.0, 1.0)), fm.RigidBody("b", mass=1.0, inertia=(1.0, 1.0, 1.0))
    model.add(fm.Revolute("ab", a, b))
    err = problems_of(model)
    assert [re.match(r"body '(\w+)' is not connected", p).group(1) for p in err.problems] == ["a", "b"]
    with pytest.raises(fm.ModelError, match=r"body 'a' is not connected to the ground"):
        model.build()


def test_ground_as_child():
    model = fm.Model("upside")
    link = fm.RigidBody("link", mass=1.0, inertia=(1.0, 1.0, 1.0))
    model.add(fm.Revolute("pin", link, model.ground))
    err = problems_of(model)
    assert "joint 'pin': the ground cannot be a child; swap parent and child" in err.problems


def test_foreign_ground():
    model = fm.Model("two grounds")
    model.add(fm.Revolute("pin", fm.Ground(), fm.RigidBody("link", mass=1.0, inertia=(1.0, 1.0, 1.0))))
    err = problems_of(model)
    assert "a joint uses a Ground that is not this model's; use model.ground" in err.problems


def test_empty_model_and_reserved_name():
    with pytest.raises(fm.ModelError, match=r"the model has no bodies"):
        fm.Model("empty").build()
    model = pendulum()
    model.add(fm.Revolute("pin2", model["bar"], fm.RigidBody("ground", mass=1.0, inertia=(1.0, 1.0, 1.0))))
    with pytest.raises(fm.ModelError, match=r"body name 'ground' is reserved for the ground"):
        model.validate()


def test_add_rejects_unknown_items():
    with pytest.raises(fm.ModelError, match=r"Model 'pendulum': cannot add 'bar'; expected a Body, Joint"):
        pendulum().add("bar")


def test_free_joint_closing_a_loop():
    model = fm.Model("loop")
    a, b = fm.RigidBody("a", mass=1.0, inertia=(1.0, 1.0, 1.0)), fm.RigidBody("b", mass=1.0, inertia=(1.0, 1.0, 1.0))
    model.add(fm.Revolute("ja", model.ground, a), fm.Revolute("jb", model.ground, b), fm.Free("float", a, b))
    err = problems_of(model)
    assert err.problems == ["joint 'float' (Free) closes a loop but imposes no constraint"]


def test_driver_on_cut_joint():
    model = fourbar()
    model.add(fm.Driver.constant_speed("motor", model["C"], 1.0))
    err = problems_of(model)
    assert err.problems == ["driver 'motor': joint 'C' is a cut joint and has no coordinates"]


def test_driver_on_joint_not_in_model():
    model = pendulum()
    other = fm.Revolute("other", model.ground, fm.RigidBody("x", mass=1.0, inertia=(1.0, 1.0, 1.0)))
    model.drivers.append(fm.Driver.constant_speed("motor", other, 1.0))  # bypass add (it does not add joints)
    err = problems_of(model)
    assert "driver 'motor': joint 'other' is not in the model" in err.problems


def test_two_drivers_on_one_coordinate():
    model = fourbar()
    model.add(fm.Driver.constant_speed("m1", model["A"], 1.0), fm.Driver.harmonic("m2", model["A"], 0.1, 1.0))
    err = problems_of(model)
    assert err.problems == ["drivers 'm1' and 'm2' both drive 'A'[0]"]
    # two coordinates of one joint may each have a driver
    model = fm.Model("u")
    uj = fm.Universal("u", model.ground, fm.RigidBody("link", mass=1.0, inertia=(1.0, 1.0, 1.0)))
    model.add(uj, fm.Driver.constant_speed("d0", uj, 1.0, coordinate=0),
              fm.Driver.constant_speed("d1", uj, 1.0, coordinate=1))
    model.validate()


@pytest.mark.parametrize(
    "make, body",
    [
        (lambda ghost: fm.PointForce("load", ghost, (1.0, 0.0, 0.0)), "ghost"),
        (lambda ghost: fm.BodyTorque("load", ghost, (0.0, 0.0, 1.0)), "ghost"),
        (lambda ghost: fm.SpringDamper("load", fm.Ground(), (0, 0, 0), ghost, (0, 0, 0), 1.0), "ground"),
        (lambda ghost: fm.SpringDamper("load", ghost, (0, 0, 0), fm.Ground(), (0, 0, 0), 1.0), "ghost"),
    ],
    ids=["PointForce", "BodyTorque", "SpringDamper-foreign-ground", "SpringDamper-body1"],
)
def test_force_element_on_body_not_in_model(make, body):
    model = pendulum()
    model.add(make(fm.RigidBody("ghost", mass=1.0, inertia=(1.0, 1.0, 1.0))))
    err = problems_of(model)
    assert f"force element 'load': body {body!r} is not in the model" in err.problems


@pytest.mark.parametrize("field", ["stiffness", "damping", "rest"])
def test_joint_spring_wrong_size(field):
    model = pendulum()
    kw = {"stiffness": 1.0, field: [1.0, 2.0]}
    model.add(fm.JointSpringDamper("js", model["pin"], **kw))
    err = problems_of(model)
    assert err.problems == [f"JointSpringDamper 'js': {field} must be a scalar or have 1 entries, got shape (2,)"]


def test_joint_spring_on_joint_without_coordinates_or_not_in_model():
    model = pendulum()
    weld = fm.Fixed("weld", model["bar"], fm.RigidBody("tip", mass=1.0, inertia=(1.0, 1.0, 1.0)), parent_point=(1, 0, 0))
    model.add(weld, fm.JointSpringDamper("js", weld, stiffness=1.0))
    err = problems_of(model)
    assert "JointSpringDamper 'js': joint 'weld' has no coordinates" in err.problems

    model = pendulum()
    other = fm.Revolute("other", model.ground, fm.RigidBody("x", mass=1.0, inertia=(1.0, 1.0, 1.0)))
    model.add(fm.JointSpringDamper("js", other, stiffness=1.0))
    err = problems_of(model)
    assert "force element 'js': joint 'other' is not in the model" in err.problems


def test_joint_spring_on_cut_joint_fails_at_build():
    model = fourbar()
    model.add(fm.JointSpringDamper("js", model["C"], stiffness=1.0))
    with pytest.raises(fm.ModelError, match=r"force element 'js'.*joint 'C' has no coordinates: it is a cut joint"):
        model.build()


def test_unknown_complement_strategy():
    pattern = r"unknown complement strategy 'lu'; pick one of \['articulated', 'auto', 'eigen', 'qr', 'svd'\]"
    with pytest.raises(fm.ModelError, match=pattern):
        fm.get_complement("lu")
    with pytest.raises(fm.ModelError, match=pattern):
        pendulum().build(complement="lu")
    with pytest.raises(fm.ModelError, match=pattern):
        fm.simulate(pendulum(), 1.0, complement="lu")
    with pytest.raises(fm.ModelError, match=r"unknown complement strategy None"):
        fm.get_complement(None)


def test_unknown_integrator():
    with pytest.raises(fm.ModelError, match=r"unknown integrator 'Euler'; pick one of \['BDF', 'DOP853', "
                                             r"'GeneralizedAlpha', 'LSODA', 'RK23', 'RK45', 'Radau'\]"):
        fm.simulate(pendulum(), 1.0, method="Euler")


@pytest.mark.parametrize("t0, t_end", [(0.0, 0.0), (1.0, 0.5), (0.0, -1.0)])
def test_t_end_not_after_t0(t0, t_end):
    with pytest.raises(fm.ModelError, match=rf"t_end must be > t0, got t0 = {t0}, t_end = {t_end}"):
        fm.simulate(pendulum(), t_end, t0=t0)


def test_bad_initial_conditions_and_output_times():
    with pytest.raises(fm.ModelError, match=r"no coordinate or joint named 'pim'; coordinates are \['pin\.angle'\]"):
        fm.simulate(pendulum(), 1.0, positions={"pim": 0.3})
    with pytest.raises(fm.ModelError, match=r"initial speed 'pin' must be finite"):
        fm.simulate(pendulum(), 1.0, speeds={"pin": NAN})
    with pytest.raises(fm.ModelError, match=r"t_eval must be increasing and within \[t0, t_end\]"):
        fm.simulate(pendulum(), 1.0, t_eval=[0.0, 2.0])


# ----------------------------------------------------------------------------- no freedom, loops that cannot close

def test_driven_fourbar_runs_kinematically():
    """p = 0 because a driver fixes the only freedom: that is kinematic driving, not an error."""
    model = fourbar()
    model.add(fm.Driver.constant_speed("motor", model["A"], speed=2.0, start=np.pi / 4))
    system = model.build()
    assert system.dof(0.0, fm.initial_state(system, positions=fourbar_initial())[0]) == 0
    res = fm.simulate(model, 0.5, positions=fourbar_initial(), rtol=1e-10)
    np.testing.assert_allclose(res.coordinate("A"), np.pi / 4 + 2.0 * res.t, rtol=0, atol=1e-9)
    assert res.residual.max() < 1e-9


def test_locked_structure_has_no_freedom():
    """A bar pinned at both ends (no driver): one coordinate, two loop rows of rank 1."""
    model = fm.Model("locked")
    bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    model.add(fm.Revolute("pin", model.ground, bar),
              fm.PlanarRevolute("lock", model.ground, bar, parent_point=(1, 0, 0), child_point=(1, 0, 0)),
              fm.Gravity((0.0, -9.81, 0.0)))
    with pytest.raises(fm.ModelError, match=r"the model has no degree of freedom left: its 1 coordinates are "
                                             r"all fixed by 2 loop-closure rows"):
        fm.simulate(model, 1.0)


def far_fourbar(cut=fm.PlanarRevolute):
    """A four-bar whose ground pivots are 1 m apart: crank + coupler + rocker = 0.65 m cannot reach."""
    model = fm.Model("far")
    crank = fm.RigidBody.slender_bar("crank", 0.1, 0.1)
    coupler = fm.RigidBody.slender_bar("coupler", 0.3, 0.3)
    rocker = fm.RigidBody.slender_bar("rocker", 0.25, 0.25)
    model.add(
        fm.Revolute("A", model.ground, crank),
        fm.Revolute("B", crank, coupler, parent_point=(0.1, 0, 0)),
        fm.Revolute("D", model.ground, rocker, parent_point=(1.0, 0, 0)),
        cut("C", coupler, rocker, parent_point=(0.3, 0, 0), child_point=(0.25, 0, 0)),
    )
    return model


@pytest.mark.parametrize("cut, row", [(fm.PlanarRevolute, r"C\.slide\.x"), (fm.Revolute, r"C\.point\.x")])
def test_loop_that_cannot_close(cut, row):
    model = far_fourbar(cut)
    system = model.build()  # building is fine: only assembling fails
    pattern = (r"the constraints cannot be closed at t = 0 s: residual 0\.85 after 50 Newton steps "
               rf"\(largest: {row} = -?0\.85")
    with pytest.raises(fm.AssemblyError, match=pattern):
        fm.initial_state(system)
    with pytest.raises(fm.AssemblyError, match=pattern):
        fm.simulate(model, 1.0)


# ----------------------------------------------------------------------------- simulations going non-finite

def spiking(value, t_spike=0.1):
    """A force of 1 N along y that becomes ``value`` after t_spike."""
    return lambda t: (0.0, value if t > t_spike else 1.0, 0.0)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize("value", [INF, NAN], ids=["inf", "nan"])
def test_non_finite_force_stops_the_simulation(value):
    model = pendulum()
    model.add(fm.PointForce("kick", model["bar"], spiking(value), point=(1.0, 0.0, 0.0)))
    with pytest.raises(fm.SimulationError) as info:
        fm.simulate(model, 1.0, positions={"pin": 0.3})
    err = info.value
    assert err.t == pytest.approx(0.1, abs=0.01)
    assert str(err).startswith(f"simulation failed at t = {err.t:.9g} s")
    res = err.result
    assert isinstance(res, fm.Result)
    assert res.status == "failed" and res.message in str(err)
    assert 0 < len(res.t) < 201 and res.t[-1] <= err.t
    for key in ("t", "x", "xd", "xdd", "positions", "rotations", "kinetic", "potential", "residual",
                "velocity_residual", "reactions"):
        assert np.all(np.isfinite(getattr(res, key))), key
    assert res.n_steps > 0 and res.n_rhs > 0


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_non_finite_force_message_names_the_element():
    model = pendulum()
    model.add(fm.PointForce("kick", model["bar"], spiking(INF), point=(1.0, 0.0, 0.0)))
    with pytest.raises(fm.SimulationError) as info:
        fm.simulate(model, 1.0, positions={"pin": 0.3})
    msg = str(info.value)
    assert "non-finite" in msg and "'kick'" in msg
    assert "positive definite" not in msg


# ----------------------------------------------------------------------------- Result

@pytest.fixture(scope="module")
def driven_result():
    return fm.simulate(driven_double_pendulum(), 0.2, n_out=11, positions={"pin1": 0.2})


def same(a, b):
    """Deep equality of arrays (values, shape and dtype), lists, tuples, dicts and scalars."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(same(u, v) for u, v in zip(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    return type(a) is type(b) and a == b or (isinstance(a, float) and isinstance(b, float) and a == b)


def assert_same_result(a, b):
    for f in attrs.fields(fm.Result):
        if f.name == "system":
            continue  # the compiled model the result came from: kept in memory, not saved
        va, vb = getattr(a, f.name), getattr(b, f.name)
        assert same(va, vb), (f.name, va, vb)
        if isinstance(va, list):
            assert all(type(s) is str for s in vb), f.name


def test_result_save_load_round_trip(driven_result, tmp_path):
    res = driven_result
    assert res.driver_names == ["motor"] and res.coordinate_names == ["pin0.angle", "pin1.angle"]
    path = tmp_path / "run.npz"
    res.save(path)
    loaded = fm.Result.load(path)
    assert_same_result(res, loaded)
    assert not same(res.x, res.x.astype(np.float32)) and not same(res.t, res.t[::-1])  # the check can fail
    assert loaded.x is not res.x
    assert [p.name for p in tmp_path.iterdir()] == ["run.npz"]  # no temporary left behind
    res.save(str(path))  # overwrite, str path
    assert_same_result(res, fm.Result.load(str(path)))


def test_result_round_trip_without_constraints(tmp_path):
    res = fm.simulate(pendulum(), 0.1, n_out=5, positions={"pin": 0.3})
    assert res.constraint_labels == [] and res.reactions.shape == (5, 0)
    res.save(tmp_path / "p.npz")
    assert_same_result(res, fm.Result.load(tmp_path / "p.npz"))


def test_result_unknown_names(driven_result):
    res = driven_result
    assert np.array_equal(res.coordinate("pin1"), res.x[:, 1])
    assert res.driver_effort("motor").shape == res.t.shape
    with pytest.raises(fm.FlexmbError, match=r"no coordinate 'unknown'; known: \['pin0\.angle', 'pin1\.angle'\]"):
        res.coordinate("unknown")
    with pytest.raises(fm.FlexmbError, match=r"no driver 'unknown'; known: \['motor'\]"):
        res.driver_effort("unknown")
    with pytest.raises(fm.FlexmbError, match=r"no body 'unknown'; known: \['bar0', 'bar1'\]"):
        res.body_position("unknown")


# ----------------------------------------------------------------------------- issue 18 section 3: refused at once

B1_SECTION = fm.Section.rectangular(0.02, 0.005)


@pytest.mark.parametrize("n", [NAN, INF, -INF, None, 2.5, 0, -3, True, "4", [4]])
def test_flexible_body_bad_n_segments_is_a_model_error(n):
    with pytest.raises(fm.ModelError, match=r"FlexibleBody 'beam': n_segments must be an integer >= 1, got "):
        fm.FlexibleBody("beam", 1.0, B1_SECTION, fm.Material.aluminium(), n_segments=n)


@pytest.mark.parametrize("n", [4.0, np.int64(4), np.float64(4.0)])
def test_flexible_body_whole_float_n_segments_builds(n):
    beam = fm.FlexibleBody("beam", 1.0, B1_SECTION, fm.Material.aluminium(), n_segments=n, keep=("bend_y",))
    assert beam.n_segments == 4 and type(beam.n_segments) is int
    model = fm.Model()
    model.add(beam, fm.Fixed("clamp", model.ground, beam))
    assert model.build().n_coords == 4


@pytest.mark.parametrize("kw, message", [
    ({"rtol": -1}, r"simulate: rtol must be > 0, got -1"),
    ({"rtol": 0.0}, r"simulate: rtol must be > 0, got 0.0"),
    ({"rtol": 1e-30}, r"simulate: rtol = 1e-30 is below what double precision can meet; the smallest is 100 machine "
                      r"epsilons, 2.2e-14"),
    ({"rtol": NAN}, r"simulate: rtol must be a finite number, got nan"),
    ({"rtol": INF}, r"simulate: rtol must be a finite number, got inf"),
    ({"rtol": "x"}, r"simulate: rtol must be a number, got 'x'"),
    ({"atol": -1e-9}, r"simulate: atol must be finite and >= 0, got -1e-09"),
    ({"atol": NAN}, r"simulate: atol must be finite and >= 0, got nan"),
    ({"n_out": 0}, r"simulate: n_out must be an integer >= 1, got 0"),
    ({"n_out": -5}, r"simulate: n_out must be an integer >= 1, got -5"),
    ({"n_out": 2.5}, r"simulate: n_out must be an integer >= 1, got 2.5"),
    ({"n_out": NAN}, r"simulate: n_out must be an integer >= 1, got nan"),
    ({"n_out": None}, r"simulate: n_out must be an integer >= 1, got None"),
    ({"max_step": 0}, r"simulate: max_step must be > 0, got 0"),
    ({"max_step": -1.0}, r"simulate: max_step must be > 0, got -1.0"),
    ({"max_step": NAN}, r"simulate: max_step must be a finite number, got nan"),
    ({"projection_tol": 0.0}, r"simulate: projection_tol must be > 0, got 0.0"),
    ({"t0": NAN}, r"simulate: t0 must be a finite number, got nan"),
    ({"t0": -INF}, r"simulate: t0 must be a finite number, got -inf"),
    ({"t_eval": [0.0, NAN, 0.5]}, r"t_eval must be increasing and within \[t0, t_end\]"),
    ({"t_eval": []}, r"t_eval must be increasing and within \[t0, t_end\]"),
])
def test_simulate_bad_arguments_are_model_errors(kw, message):
    """Each used to reach scipy (ValueError, IndexError) or, for rtol NaN, blame the mass matrix."""
    with pytest.raises(fm.ModelError, match=message):
        fm.simulate(pendulum(), 0.5, **kw)


@pytest.mark.parametrize("t_end", [INF, NAN])
def test_simulate_non_finite_t_end_is_refused_at_once(t_end):
    """t_end = inf used to integrate forever."""
    with pytest.raises(fm.ModelError, match=rf"simulate: t_end must be a finite number, got {t_end}"):
        fm.simulate(pendulum(), t_end)


def test_simulate_whole_float_n_out_is_taken():
    res = fm.simulate(pendulum(), 0.1, n_out=3.0)
    assert len(res.t) == 3


@pytest.mark.parametrize("length", [0, -1, 0.0, NAN, INF, None, "1"])
def test_slender_bar_non_positive_length(length):
    with pytest.raises(fm.ModelError, match=r"RigidBody.slender_bar 'bar': length must be a finite number > 0"):
        fm.RigidBody.slender_bar("bar", 1.0, length)


def test_slender_bar_bad_axis_and_mass():
    with pytest.raises(fm.ModelError, match=r"RigidBody.slender_bar 'bar': axis must be 0, 1 or 2, got 3"):
        fm.RigidBody.slender_bar("bar", 1.0, 1.0, axis=3)
    with pytest.raises(fm.ModelError, match=r"RigidBody 'bar': mass must be > 0, got 'heavy'"):
        fm.RigidBody.slender_bar("bar", "heavy", 1.0)


@pytest.mark.parametrize("size", [(1.0, 0.0, 1.0), (-1.0, 1.0, 1.0), (1.0, NAN, 1.0), (1.0, 1.0), (1.0, INF, 1.0), "abc"])
def test_box_non_positive_size(size):
    with pytest.raises(fm.ModelError, match=r"RigidBody.box 'block': size must be 3 finite edge lengths > 0"):
        fm.RigidBody.box("block", 1.0, size)


def test_unclamped_flexible_body_of_one_segment_is_refused():
    """Found by the extended hypothesis generators: it passed construction, then failed in BeamElasticity."""
    with pytest.raises(fm.ModelError, match=r"FlexibleBody 'beam': an unclamped flexible body needs n_segments >= 2"):
        fm.FlexibleBody("beam", 1.0, B1_SECTION, fm.Material.aluminium(), n_segments=1, clamped=False)


def test_a_clamped_beam_pinned_about_its_root_bending_axis_names_the_joint_and_clamped_false():
    """Issue #32: a default (clamped) uniform_beam pinned by a Revolute about the axis its root bends about failed
    inside the integrator ("not positive definite", a LinAlgError); the build names the joint and the remedy."""
    def pinned(clamped):
        model = fm.Model("beam")
        beam = fm.FlexibleBody.uniform_beam("beam", 1.0, fm.Section.rectangular(0.02, 0.01), fm.Material.aluminium(),
                                            4, keep=("bend_z",), clamped=clamped)
        return model.add(fm.Revolute("pin", model.ground, beam, axis=(0, 0, 1)), fm.Gravity((0.0, -9.81, 0.0)))

    with pytest.raises(fm.ModelError, match=r"joint 'pin' \(Revolute\) turns the clamped flexible body 'beam' "
                                            r"about \[0.0, 0.0, 1.0\] at its root.*bends \(bend_z\).*clamped=False"):
        pinned(True).build()
    assert fm.simulate(pinned(False), 0.01, n_out=3).status == "finished"


def test_a_spherical_joint_on_a_slender_bar_names_the_spin_and_the_remedy():
    """Issue #32: a slender bar (no inertia about its axis) on a Spherical joint read "simulation failed the mass
    matrix ..." at t = 0; the build names the joint, the body, the axis and the remedies."""
    def ball(body):
        model = fm.Model("top")
        return model.add(fm.Spherical("ball", model.ground, body), fm.Gravity((0.0, -9.81, 0.0)))

    with pytest.raises(fm.ModelError, match=r"joint 'ball' \(Spherical\) turns body 'bar' about the axis "
                                            r"\[1.0, 0.0, 0.0\] .*no inertia.*Universal instead of a Spherical"):
        ball(fm.RigidBody.slender_bar("bar", 1.0, 1.0)).build()
    bar = fm.RigidBody("bar", 1.0, (1e-6, 1.0 / 12, 1.0 / 12), com=(0.5, 0.0, 0.0))  # an axial moment: fine
    assert fm.simulate(ball(bar), 0.01, positions={"ball": [0.1, 0.2, 0.3]}, n_out=3).status == "finished"
    universal = fm.Model("hooke")  # a Universal leaves out the spin: fine too
    universal.add(fm.Universal("u", universal.ground, fm.RigidBody.slender_bar("bar", 1.0, 1.0), axis=(0, 0, 1),
                               axis2=(0, 1, 0)), fm.Gravity((0.0, -9.81, 0.0)))
    universal.build()
