"""flexmb.fields: the converters and validators of element fields, for flexmb's elements and plugins alike."""

from __future__ import annotations

import numpy as np
import pytest
from attrs import field, frozen

import flexmb as fm
from flexmb import fields


@frozen
class Probe:
    """An element of a plugin, declared as the docs say."""

    name: str
    area: float = field(default=1.0, converter=fields.as_float, validator=fields.positive)
    mu: float = field(default=0.0, converter=fields.as_float, validator=fields.non_negative)
    offset: float = field(default=0.0, converter=fields.as_float, validator=fields.finite_number)
    point: np.ndarray = field(default=(0, 0, 0), converter=fields.as_array, validator=fields.vector3)
    normal: np.ndarray = field(default=(0, 0, 1), converter=fields.as_unit_vector, validator=fields.unit_vector)
    inertia: np.ndarray = field(default=np.eye(3), converter=fields.as_array, validator=fields.matrix33)
    body: object = field(default=None, validator=fields.is_a(type(None)))


@pytest.mark.parametrize("change, message", [
    ({"area": -1}, "area must be > 0, got -1.0"),
    ({"area": 0}, "area must be > 0, got 0.0"),
    ({"area": np.nan}, "area must be a finite number > 0, got nan"),
    ({"area": "big"}, "area must be a finite number > 0, got 'big'"),
    ({"area": True}, "area must be a finite number > 0, got True"),  # a bool is not a number here
    ({"mu": -0.5}, "mu must be >= 0, got -0.5"),
    ({"mu": np.inf}, "mu must be a finite number >= 0, got inf"),
    ({"offset": None}, "offset must be a finite number, got None"),
    ({"point": (0, 1)}, "point must have shape (3,), got (2,)"),
    ({"point": (0, 0, np.inf)}, "point must be finite, got [0.0, 0.0, inf]"),
    ({"point": "tip"}, "point must be numbers, got 'tip'"),
    ({"normal": (0, 0, 0)}, "normal must be a nonzero vector, got [0.0, 0.0, 0.0]"),
    ({"normal": (0, np.nan, 1)}, "normal must be finite"),
    ({"inertia": np.eye(2)}, "inertia must have shape (3, 3), got (2, 2)"),
    ({"body": 3}, "body must be a NoneType, got int"),
])
def test_a_bad_value_is_refused_naming_the_element_and_the_field(change, message):
    with pytest.raises(fm.ModelError) as info:
        Probe("vane", **change)
    assert str(info.value).startswith("Probe 'vane': ")
    assert message in str(info.value)


def test_converters_give_read_only_floats_and_unit_vectors():
    p = Probe("vane", area=2, point=[1, 2, 3], normal=(0, 3, 4))
    assert p.area == 2.0 and isinstance(p.area, float)
    assert p.point.dtype == float and not p.point.flags.writeable
    np.testing.assert_allclose(p.normal, [0.0, 0.6, 0.8], rtol=0, atol=1e-15)
    assert not p.normal.flags.writeable
    with pytest.raises(ValueError):
        p.point[0] = 5.0


def test_converters_leave_what_they_cannot_convert_for_the_validator():
    assert fields.as_float("big") == "big"
    assert fields.as_float(True) is True
    assert fields.as_array("tip") == "tip"
    assert fields.as_unit_vector((0, 0, 0)).tolist() == [0.0, 0.0, 0.0]  # unit_vector refuses it, naming it


def test_flexmb_s_own_elements_and_the_friction_plugin_use_them():
    from flexmb import bodies, joints

    assert bodies.positive is fields.positive and joints.vector3 is fields.vector3
    friction = pytest.importorskip("flexmb_friction.friction")
    assert friction.unit_vector is fields.unit_vector
