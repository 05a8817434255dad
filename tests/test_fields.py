"""``flexmb.fields``: the converters and validators of element fields, for the core and for plugins.

Every validator rejects bad input with a message naming the element's
class, its name and the field; every one accepts good input. Converters
give read-only float arrays, leave what they cannot convert unchanged (for
the validator to reject, naming the element), and ``as_unit_vector``
normalises. A bool is not a number. The core, the friction plugin and the
tutorial use these very functions: none of them defines its own again.
"""

from __future__ import annotations

import pathlib
import re

import attrs
import numpy as np
import pytest
from attrs import field, frozen

import flexmb as fm
from flexmb import fields

ROOT = pathlib.Path(__file__).resolve().parents[1]
NAN, INF = float("nan"), float("inf")


def widget(converter, validator):
    """A small element class whose one field ``data`` has the given converter and validator."""

    @frozen(eq=False)
    class Widget:
        name: str
        data: object = field(converter=converter, validator=validator)

    return Widget


def no_conversion(value):
    return value


# ----------------------------------------------------------------------------- validators

REJECTED = [
    # (converter, validator, value, message after "Widget 'w': data ")
    (fields.as_float, fields.finite_number, "high", "must be a finite number, got 'high'"),
    (fields.as_float, fields.finite_number, NAN, "must be a finite number, got nan"),
    (fields.as_float, fields.finite_number, -INF, "must be a finite number, got -inf"),
    (fields.as_float, fields.finite_number, None, "must be a finite number, got None"),
    (fields.as_float, fields.positive, 0, "must be > 0, got 0.0"),
    (fields.as_float, fields.positive, -1, "must be > 0, got -1.0"),
    (fields.as_float, fields.positive, NAN, "must be > 0, got nan"),
    (fields.as_float, fields.positive, INF, "must be > 0, got inf"),
    (fields.as_float, fields.positive, "heavy", "must be > 0, got 'heavy'"),
    (fields.as_float, [fields.finite_number, fields.positive], "heavy", "must be a finite number, got 'heavy'"),
    (fields.as_float, [fields.finite_number, fields.positive], -2, "must be > 0, got -2.0"),
    (fields.as_float, fields.non_negative, -0.5, "must be >= 0, got -0.5"),
    (fields.as_float, fields.non_negative, NAN, "must be >= 0, got nan"),
    (fields.as_float, [fields.finite_number, fields.non_negative], INF, "must be a finite number, got inf"),
    (fields.as_count, fields.count, 0, "must be an integer >= 1, got 0"),
    (fields.as_count, fields.count, 2.5, "must be an integer >= 1, got 2.5"),
    (fields.as_count, fields.count, "4", "must be an integer >= 1, got '4'"),
    (fields.as_count, fields.count, NAN, "must be an integer >= 1, got nan"),
    (fields.as_array, fields.finite_array, [1.0, NAN], "must be finite, got [1.0, nan]"),
    (fields.as_array, fields.finite_array, "x", "must be numbers, got 'x'"),
    (fields.as_array, fields.vector3, (1.0, 2.0), "must have shape (3,), got (2,)"),
    (fields.as_array, fields.vector3, (0.0, INF, 0.0), "must be finite, got [0.0, inf, 0.0]"),
    (fields.as_array, fields.vector3, "tip", "must be numbers, got 'tip'"),
    (fields.as_unit_vector, fields.unit_vector, (0, 0, 0), "must be a nonzero vector, got [0.0, 0.0, 0.0]"),
    (fields.as_unit_vector, fields.unit_vector, (0, NAN, 1), "must be finite, got [0.0, nan, 1.0]"),
    (fields.as_unit_vector, fields.unit_vector, (0, 1), "must have shape (3,), got (2,)"),
    (fields.as_array, fields.unit_vector, (0, 0, 2), "must have length 1, got [0.0, 0.0, 2.0]"),
    (fields.as_array, fields.matrix33, np.eye(2), "must have shape (3, 3), got (2, 2)"),
    (fields.as_array, fields.matrix33, np.diag([1.0, NAN, 1.0]), "must be finite, got [[1.0, 0.0, 0.0], [0.0, nan"),
    (fields.as_array, fields.rotation_matrix, 2 * np.eye(3), "must be a rotation matrix (orthonormal, det +1)"),
    (fields.as_array, fields.rotation_matrix, np.diag([1.0, 1.0, -1.0]),
     "must be a rotation matrix (orthonormal, det +1)"),
    (no_conversion, fields.is_a(fm.Material), "steel", "must be a Material, got str"),
    (no_conversion, fields.is_a(fm.Material), fm.Section.rectangular(0.01, 0.01), "must be a Material, got Section"),
]


@pytest.mark.parametrize("converter, validator, value, message", REJECTED)
def test_validators_name_the_element_and_the_field(converter, validator, value, message):
    with pytest.raises(fm.ModelError) as info:
        widget(converter, validator)("w", value)
    assert str(info.value).startswith(f"Widget 'w': data {message}")


ACCEPTED = [
    # (converter, validator, value, what the field then holds)
    (fields.as_float, fields.finite_number, "-2.5", -2.5),
    (fields.as_float, fields.positive, 3, 3.0),
    (fields.as_float, fields.non_negative, 0, 0.0),
    (fields.as_float, [fields.finite_number, fields.positive], np.float64(1e-300), 1e-300),
    (fields.as_count, fields.count, 4.0, 4),
    (fields.as_count, fields.count, np.int64(7), 7),
    (fields.as_array, fields.finite_array, [[1, 2], [3, 4]], [[1.0, 2.0], [3.0, 4.0]]),
    (fields.as_array, fields.vector3, (1, 2, 3), [1.0, 2.0, 3.0]),
    (fields.as_unit_vector, fields.unit_vector, (0, 0, -7), [0.0, 0.0, -1.0]),
    (fields.as_array, fields.matrix33, np.ones((3, 3)), np.ones((3, 3)).tolist()),
    (fields.as_array, fields.rotation_matrix, [[0, -1, 0], [1, 0, 0], [0, 0, 1]], [[0, -1, 0], [1, 0, 0], [0, 0, 1]]),
]


@pytest.mark.parametrize("converter, validator, value, held", ACCEPTED)
def test_validators_accept_good_values(converter, validator, value, held):
    data = widget(converter, validator)("w", value).data
    if isinstance(held, list):
        assert data.tolist() == held and data.dtype == float and not data.flags.writeable
    else:
        assert data == held and type(data) is type(held)


def test_is_a_accepts_an_instance_of_its_kind():
    steel = fm.Material.steel()
    assert widget(no_conversion, fields.is_a(fm.Material))("w", steel).data is steel


def test_label_names_the_class_and_the_name():
    assert fields.label(fm.RigidBody("crank", mass=1.0, inertia=(1.0, 1.0, 1.0))) == "RigidBody 'crank'"
    assert fields.label(object()) == "object '?'"


def test_the_message_names_a_subclass_by_its_own_name():
    @frozen(eq=False)
    class Sub(widget(fields.as_float, fields.positive)):
        pass

    with pytest.raises(fm.ModelError, match=r"^Sub 'tip': data must be > 0, got -1\.0$"):
        Sub("tip", -1)


# ----------------------------------------------------------------------------- converters

def test_as_array_gives_a_read_only_float_copy():
    source = np.array([1, 2, 3])
    arr = fields.as_array(source)
    assert arr.dtype == float and not arr.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        arr[0] = 5.0
    source[0] = 9
    assert arr[0] == 1.0  # a copy: the caller's array stays the caller's


@pytest.mark.parametrize("value", ["tip", [[1.0, 2.0], [3.0]], object(), {"x": 1}, 10**400])
def test_as_array_leaves_what_it_cannot_convert_unchanged(value):
    assert fields.as_array(value) is value


@pytest.mark.parametrize("value, expected", [("2.5", 2.5), (3, 3.0), (np.float64(0.5), 0.5), (np.int64(-2), -2.0)])
def test_as_float_converts_numbers(value, expected):
    out = fields.as_float(value)
    assert type(out) is float and out == expected


@pytest.mark.parametrize("value", ["high", None, object(), [1.0], 10**400, True, False, np.bool_(True)])
def test_as_float_leaves_what_is_not_a_number_unchanged(value):
    assert fields.as_float(value) is value


def test_as_unit_vector_normalises_to_a_read_only_vector():
    u = fields.as_unit_vector([0, 3, 4])
    np.testing.assert_allclose(u, [0.0, 0.6, 0.8], rtol=1e-15)
    assert u.dtype == float and not u.flags.writeable
    assert fields.as_unit_vector([0.0, -1e-9, 0.0]).tolist() == [0.0, -1.0, 0.0]


@pytest.mark.parametrize("value", [(0, 0, 0), (0, 1), (0, NAN, 1), (INF, 0, 0)])
def test_as_unit_vector_leaves_what_it_cannot_normalise_as_an_array(value):
    out = fields.as_unit_vector(value)
    np.testing.assert_array_equal(out, np.array(value, dtype=float))
    assert not out.flags.writeable
    assert fields.as_unit_vector("up") == "up"


@pytest.mark.parametrize("value, expected", [(4, 4), (4.0, 4), (np.int64(4), 4), (np.float32(2.0), 2)])
def test_as_count_converts_whole_numbers(value, expected):
    out = fields.as_count(value)
    assert type(out) is int and out == expected


@pytest.mark.parametrize("value", [2.5, NAN, INF, None, "4", True, [4]])
def test_as_count_leaves_the_rest_unchanged(value):
    assert fields.as_count(value) is value


# ----------------------------------------------------------------------------- bools are not numbers

@pytest.mark.parametrize("validator", [fields.finite_number, fields.positive, fields.non_negative])
def test_a_bool_is_not_a_number(validator):
    with pytest.raises(fm.ModelError, match=r"^Widget 'w': data must be .*, got True$"):
        widget(fields.as_float, validator)("w", True)


def test_a_bool_is_not_a_count():
    with pytest.raises(fm.ModelError, match=r"^Widget 'w': data must be an integer >= 1, got True$"):
        widget(fields.as_count, fields.count)("w", True)


def test_a_bool_mass_is_refused():
    with pytest.raises(fm.ModelError, match=r"^RigidBody 'b': mass must be > 0, got True$"):
        fm.RigidBody("b", mass=True, inertia=(1.0, 1.0, 1.0))


def test_a_bool_friction_load_is_refused():
    friction = pytest.importorskip("flexmb_friction")
    with pytest.raises(fm.ModelError, match=r"^ViscousFriction 'oil': damping must be a finite number, got True$"):
        friction.ViscousFriction("oil", "block", (0, 0, 0), (0, 0, 1), damping=True)


# ----------------------------------------------------------------------------- one implementation

def test_core_and_plugin_elements_use_these_validators():
    mass = attrs.fields(fm.RigidBody).mass.validator  # optional: a missing mass is refused by its own check
    assert getattr(mass, "validator", mass) is fields.positive
    assert attrs.fields(fm.RigidBody).com.converter is fields.as_array
    assert attrs.fields(fm.Revolute).parent_point.validator is fields.vector3
    assert attrs.fields(fm.FlexibleBody).n_segments.validator is fields.count
    friction = pytest.importorskip("flexmb_friction")
    normal = attrs.fields(friction.CoulombFriction).normal
    assert normal.converter is fields.as_unit_vector and normal.validator is fields.unit_vector
    assert attrs.fields(friction.ViscousFriction).damping.converter is fields.as_float


def test_nothing_defines_a_field_check_again():
    names = "|".join(fields.__all__ + ["_float", "_array", "_unit", "_vector", "_vector3", "_unit_vector",
                                       "_label", "_point"])
    definition = re.compile(rf"^\s*def ({names})\((instance, attribute, value|value|instance)\)", re.M)
    places = [*(ROOT / "src" / "flexmb").rglob("*.py"), *(ROOT / "plugins").rglob("*.py"),
              *(ROOT / "tutorials").glob("*.py")]
    again = [f"{p.relative_to(ROOT)}: {m.group(0).strip()}" for p in places if p.name != "fields.py"
             for m in definition.finditer(p.read_text(encoding="utf-8"))]
    assert not again, again
    assert not (ROOT / "plugins" / "flexmb_friction" / "_fields.py").exists()
