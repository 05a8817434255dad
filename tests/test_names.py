"""Model elements are named by object or by name, everywhere the API names one (issue #20, section 3).

Each test checks that the name gives exactly what the object gives, and that
a name the model lacks fails with a message naming it and listing the known
ones.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import flexmb as fm


def slider_crank_parts():
    """A driven crank with a pendulum hung from its tip: two pins, a driver, loads."""
    crank = fm.RigidBody.slender_bar("crank", 0.5, 0.2)
    arm = fm.RigidBody.slender_bar("arm", 1.0, 0.5)
    return crank, arm


def by_objects():
    crank, arm = slider_crank_parts()
    model = fm.Model("objects")
    A = fm.Revolute("A", model.ground, crank, axis=(0, 0, 1))
    B = fm.Revolute("B", crank, arm, parent_point=(0.2, 0, 0), axis=(0, 0, 1))
    model.add(A, B, fm.Driver.constant_speed("motor", A, speed=3.0),
              fm.JointSpringDamper("spring", B, stiffness=2.0, damping=0.1),
              fm.PointForce("push", arm, (0.0, -1.0, 0.0), point=(0.5, 0, 0)),
              fm.SpringDamper("strap", model.ground, (0.3, 0.3, 0), arm, (0.5, 0, 0), stiffness=5.0),
              fm.Gravity((0.0, -9.81, 0.0)))
    return model


def by_names():
    """The same model, every reference a name, the driver and loads written before what they name."""
    crank, arm = slider_crank_parts()
    model = fm.Model("names")
    model.add(fm.Driver.constant_speed("motor", "A", speed=3.0),
              fm.JointSpringDamper("spring", "B", stiffness=2.0, damping=0.1),
              fm.PointForce("push", "arm", (0.0, -1.0, 0.0), point=(0.5, 0, 0)),
              fm.SpringDamper("strap", "ground", (0.3, 0.3, 0), "arm", (0.5, 0, 0), stiffness=5.0),
              fm.Gravity((0.0, -9.81, 0.0)))
    model.add(crank, arm, fm.Revolute("A", "ground", "crank", axis=(0, 0, 1)),
              fm.Revolute("B", "crank", "arm", parent_point=(0.2, 0, 0), axis=(0, 0, 1)))
    return model


# ----------------------------------------------------------------------------- definitions naming elements


def test_driver_names_its_joint_before_the_joint_exists():
    model = fm.Model()
    crank = fm.RigidBody.slender_bar("crank", 0.5, 0.2)
    motor = fm.Driver.constant_speed("motor", "A", speed=2.0)
    model.add(motor, fm.Revolute("A", model.ground, crank, axis=(0, 0, 1)))
    system = model.build()
    assert model["motor"].joint is model["A"]
    res = fm.simulate(system, 0.5, n_out=6, progress=False)
    np.testing.assert_allclose(res.coordinate("A"), 2.0 * res.t, atol=1e-9)
    # the driver the caller holds still names its effort
    assert np.array_equal(res.driver_effort(motor), res.driver_effort("motor"))


def test_names_give_the_same_equations_as_objects():
    s1, s2 = by_objects().build(), by_names().build()
    assert s1.coordinate_names == s2.coordinate_names and s1.body_names == s2.body_names
    x, xd = np.array([0.3, -0.4]), np.array([3.0, 0.5])
    np.testing.assert_array_equal(s1.accelerations(0.1, x, xd), s2.accelerations(0.1, x, xd))
    np.testing.assert_array_equal(s1.reactions(0.1, x, xd), s2.reactions(0.1, x, xd))


def test_unknown_name_fails_at_build_naming_the_element_and_the_known_ones():
    model = fm.Model()
    crank = fm.RigidBody.slender_bar("crank", 0.5, 0.2)
    model.add(fm.Revolute("A", model.ground, crank), fm.Driver.constant_speed("motor", "Z", speed=1.0),
              fm.PointForce("push", "crnak", (1.0, 0, 0)))
    with pytest.raises(fm.ModelError) as info:
        model.build()
    problems = info.value.problems
    assert "driver 'motor': no joint named 'Z'; joints: ['A']" in problems
    assert "force element 'push': no body named 'crnak'; bodies: ['ground', 'crank']" in problems


def test_a_named_joint_is_checked_like_a_given_one():
    model = fm.Model()
    crank = fm.RigidBody.slender_bar("crank", 0.5, 0.2)
    model.add(fm.Revolute("A", model.ground, crank), fm.Driver.constant_speed("motor", "A", speed=1.0, coordinate=1))
    with pytest.raises(fm.ModelError, match=r"Driver 'motor': coordinate 1 out of range for joint 'A' with 1"):
        model.build()


def test_joint_with_body_names_and_the_object_the_caller_holds():
    model = fm.Model()
    crank = fm.RigidBody.slender_bar("crank", 0.5, 0.2)
    pin = fm.Revolute("A", "ground", "crank", axis=(0, 0, 1))
    model.add(crank, pin)
    system = model.build()
    held = model.element(pin)  # the model holds a copy with the bodies themselves
    assert held is model["A"] and held.parent is model.ground and held.child is crank
    assert system.coordinate_slice(pin) == system.coordinate_slice("A") == system.coordinate_slice(held) == slice(0, 1)
    # names are resolved once: building again changes nothing
    model.build()
    assert model.element(pin) is held


def test_wrong_kinds_are_refused_with_a_message():
    with pytest.raises(fm.ModelError, match=r"Driver 'motor': joint must be a Joint, got float \(or give the "
                                            r"joint's name\)"):
        fm.Driver.constant_speed("motor", 3.0, speed=1.0)
    with pytest.raises(fm.ModelError, match=r"Revolute 'A': parent and child are the same body 'bar'"):
        fm.Revolute("A", "bar", "bar")
    model = by_objects()
    with pytest.raises(fm.ModelError, match=r"Model 'objects': no joint named 'crank'; joints: \['A', 'B'\]"):
        model.element("crank", fm.Joint)
    with pytest.raises(fm.ModelError, match=r"Model 'objects': no element named 'hinge'; elements: \['ground', "):
        model.element("hinge")
    with pytest.raises(fm.ModelError, match=r"expected a Joint or its name, got RigidBody"):
        model.element(model["crank"], fm.Joint)
    with pytest.raises(fm.ModelError, match=r"Model 'objects': Revolute 'C' is not in the model"):
        model.element(fm.Revolute("C", model.ground, fm.RigidBody("x", mass=1.0, inertia=(1.0, 1.0, 1.0))))


# ----------------------------------------------------------------------------- look-ups by name or object


@pytest.fixture(scope="module")
def run():
    model = by_objects()
    system = model.build()
    res = fm.simulate(system, 0.2, n_out=5, positions={"B": 0.3}, progress=False)
    return model, system, res


def test_initial_conditions_take_joints_or_names(run):
    model, system, res = run
    x1, xd1 = fm.initial_state(system, positions={"B": 0.3}, speeds={"B": 1.0}, fixed=["B"])
    x2, xd2 = fm.initial_state(system, positions={model["B"]: 0.3}, speeds={model["B"]: 1.0}, fixed=[model["B"]])
    np.testing.assert_array_equal(x1, x2)
    np.testing.assert_array_equal(xd1, xd2)
    with pytest.raises(fm.ModelError, match=r"expected a Joint or its name, got RigidBody"):
        fm.initial_state(system, positions={model["arm"]: 0.3})


def test_result_takes_objects_or_names(run):
    model, system, res = run
    assert np.array_equal(res.coordinate(model["B"]), res.coordinate("B"))
    assert np.array_equal(res.body_position(model["arm"]), res.body_position("arm"))
    assert np.array_equal(res.driver_effort(model["motor"]), res.driver_effort("motor"))
    with pytest.raises(fm.ModelError, match=r"no body 'bar'; known: \['crank', 'arm'\]"):
        res.body_position("bar")
    with pytest.raises(fm.ModelError, match=r"Result.driver_effort: expected a Driver or its name, got Revolute"):
        res.driver_effort(model["A"])


def test_system_takes_objects_or_names(run):
    model, system, res = run
    assert system.index("arm") == system.index(model["arm"]) == 1
    assert system.coordinate_slice("B") == system.coordinate_slice(model["B"])
    with pytest.raises(fm.ModelError, match=r"no body named 'bar'; bodies: \['ground', 'crank', 'arm'\]"):
        system.index("bar")


def test_joint_loads_take_joints_or_names(run):
    model, system, res = run
    loads = res.joint_loads(system)
    for a, b in zip(loads.joint(model["B"]), loads.joint("B")):
        np.testing.assert_array_equal(a, b)


def test_result_is_picklable_without_its_system(run):
    _, _, res = run
    back = pickle.loads(pickle.dumps(res))
    assert back.system is None
    np.testing.assert_array_equal(back.x, res.x)


# ----------------------------------------------------------------------------- flexible bodies by name


@pytest.fixture(scope="module")
def rod():
    model = fm.Model("rod")
    rod = fm.FlexibleBody("rod", 1.0, fm.Section.rectangular(0.02, 0.005),
                          fm.Material(70e9, 2700.0, 0.33, name="aluminium"), 4, keep=("bend_y",))
    model.add(fm.Fixed("clamp", "ground", "rod"), rod, fm.Gravity((0.0, 0.0, -9.81)))
    system = model.build()
    return model, system, fm.simulate(system, 0.01, n_out=3, method="Radau", progress=False)


def test_section_results_take_a_flexible_body_or_its_name(rod):
    model, system, res = rod
    for method in ("section_loads", "section_strains", "section_stresses"):
        by_name, by_object = getattr(res, method)("rod"), getattr(res, method)(model["rod"])
        assert by_name.components == by_object.components
        np.testing.assert_array_equal(by_name.values, by_object.values)
    assert np.any(res.section_stresses("rod").values != 0.0)


def test_shape_takes_a_flexible_body_or_its_name(rod):
    model, system, res = rod
    x = res.x[-1]
    np.testing.assert_array_equal(system.shape("rod", x), system.shape(model["rod"], x))
    np.testing.assert_array_equal(res.shape(model["rod"]), res.shape("rod"))
    with pytest.raises(fm.ModelError, match=r"no flexible body named 'clamp'; flexible bodies: \['rod'\]"):
        system.shape("clamp", x)
