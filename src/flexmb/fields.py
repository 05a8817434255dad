"""Converters and validators for the attrs fields of model elements: errors name the element and the field.

flexmb's own bodies, joints and force elements declare their fields with
these, and so can a plugin's (docs/plugins.md): a bad value is refused
when the element is made, with a :class:`~flexmb.ModelError` that names
the element's class, its name and the field.

A converter runs first and does not know the element, so a value it cannot
convert is returned unchanged for the validator to refuse with a proper
message.

Examples
--------
>>> import numpy as np
>>> from attrs import field, frozen
>>> import flexmb as fm
>>> from flexmb import fields
>>> @frozen
... class Drag:
...     name: str
...     area: float = field(converter=fields.as_float, validator=fields.positive)
...     axis: np.ndarray = field(default=(1, 0, 0), converter=fields.as_unit_vector, validator=fields.unit_vector)
>>> Drag("strip", 0.5, axis=(0, 2, 0)).axis
array([0., 1., 0.])
>>> Drag("strip", -0.5)
Traceback (most recent call last):
    ...
flexmb.errors.ModelError: Drag 'strip': area must be > 0, got -0.5
"""

from __future__ import annotations

import numpy as np

from .errors import ModelError

__all__ = ["label", "as_float", "as_array", "as_unit_vector", "finite_number", "positive", "non_negative",
           "finite_array", "vector3", "unit_vector", "matrix33", "is_a"]


def label(instance) -> str:
    """``Kind 'name'``: how messages name an element.

    Parameters
    ----------
    instance : object
        The element (its ``name`` attribute, if any, is quoted).

    Returns
    -------
    str
        The class name and the element's name.
    """
    return f"{type(instance).__name__} {getattr(instance, 'name', '?')!r}"


# ----------------------------------------------------------------------------- converters


def as_float(value):
    """``float(value)``, or ``value`` unchanged for the validator to refuse.

    Parameters
    ----------
    value : object
        The value given.

    Returns
    -------
    float or object
        The float; a bool (not a number here) or anything ``float()``
        refuses, unchanged.
    """
    if isinstance(value, bool):
        return value
    try:
        return float(value)
    except (TypeError, ValueError):
        return value


def as_array(value):
    """A read-only float copy of ``value``, or ``value`` unchanged for the validator to refuse.

    Parameters
    ----------
    value : array_like or object
        The value given.

    Returns
    -------
    ndarray or object
        The copy (not writeable), or the value if it is not numeric.
    """
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        return value
    arr.setflags(write=False)
    return arr


def as_unit_vector(value):
    """A read-only unit 3-vector along ``value``; anything else is left for the validator.

    Parameters
    ----------
    value : array_like or object
        The value given.

    Returns
    -------
    ndarray or object
        ``value / |value|`` for a finite nonzero 3-vector; else what
        :func:`as_array` returns (:func:`unit_vector` refuses it).
    """
    arr = as_array(value)
    if isinstance(arr, np.ndarray) and arr.shape == (3,) and np.all(np.isfinite(arr)):
        length = np.linalg.norm(arr)
        if length > 0.0:
            arr = arr / length
            arr.setflags(write=False)
    return arr


# ----------------------------------------------------------------------------- validators
# attrs validators: ``validator(instance, attribute, value)``, raising ModelError


def finite_number(instance, attribute, value):
    """Validator: a finite float (after :func:`as_float`).

    Parameters
    ----------
    instance : object
        The element being made.
    attribute : attrs.Attribute
        The field.
    value : object
        The converted value.

    Raises
    ------
    ModelError
        ``Kind 'name': field must be a finite number, got value``.
    """
    if not isinstance(value, float) or not np.isfinite(value):
        raise ModelError(f"{label(instance)}: {attribute.name} must be a finite number, got {value!r}")


def positive(instance, attribute, value):
    """Validator: a finite float > 0.

    Parameters
    ----------
    instance : object
        The element being made.
    attribute : attrs.Attribute
        The field.
    value : object
        The converted value.

    Raises
    ------
    ModelError
        ``... must be a finite number > 0, got ...`` (not a number, NaN,
        infinite) or ``... must be > 0, got ...``.
    """
    if not isinstance(value, float) or not np.isfinite(value):
        raise ModelError(f"{label(instance)}: {attribute.name} must be a finite number > 0, got {value!r}")
    if not value > 0:
        raise ModelError(f"{label(instance)}: {attribute.name} must be > 0, got {value!r}")


def non_negative(instance, attribute, value):
    """Validator: a finite float >= 0.

    Parameters
    ----------
    instance : object
        The element being made.
    attribute : attrs.Attribute
        The field.
    value : object
        The converted value.

    Raises
    ------
    ModelError
        ``... must be a finite number >= 0, got ...`` or ``... must be >= 0, got ...``.
    """
    if not isinstance(value, float) or not np.isfinite(value):
        raise ModelError(f"{label(instance)}: {attribute.name} must be a finite number >= 0, got {value!r}")
    if not value >= 0:
        raise ModelError(f"{label(instance)}: {attribute.name} must be >= 0, got {value!r}")


def _numeric(instance, attribute, value):
    if not (isinstance(value, np.ndarray) and value.dtype == float):
        raise ModelError(f"{label(instance)}: {attribute.name} must be numbers, got {value!r}")


def finite_array(instance, attribute, value):
    """Validator: a float array (after :func:`as_array`), every entry finite.

    Parameters
    ----------
    instance : object
        The element being made.
    attribute : attrs.Attribute
        The field.
    value : object
        The converted value.

    Raises
    ------
    ModelError
        ``... must be numbers, got ...`` or ``... must be finite, got [...]``.
    """
    _numeric(instance, attribute, value)
    if not np.all(np.isfinite(value)):
        raise ModelError(f"{label(instance)}: {attribute.name} must be finite, got {np.asarray(value).tolist()}")


def vector3(instance, attribute, value):
    """Validator: a finite 3-vector.

    Parameters
    ----------
    instance : object
        The element being made.
    attribute : attrs.Attribute
        The field.
    value : object
        The converted value.

    Raises
    ------
    ModelError
        Not numbers, not of shape (3,), or not finite.
    """
    _numeric(instance, attribute, value)
    if value.shape != (3,):
        raise ModelError(f"{label(instance)}: {attribute.name} must have shape (3,), got {value.shape}")
    finite_array(instance, attribute, value)


def unit_vector(instance, attribute, value):
    """Validator: a finite 3-vector of length 1 (after :func:`as_unit_vector`: a nonzero one).

    Parameters
    ----------
    instance : object
        The element being made.
    attribute : attrs.Attribute
        The field.
    value : object
        The converted value.

    Raises
    ------
    ModelError
        As :func:`vector3`, or ``... must be a nonzero vector, got [...]``.
    """
    vector3(instance, attribute, value)
    if not abs(np.linalg.norm(value) - 1.0) < 1e-12:
        raise ModelError(f"{label(instance)}: {attribute.name} must be a nonzero vector, got {value.tolist()}")


def matrix33(instance, attribute, value):
    """Validator: a finite 3 x 3 matrix.

    Parameters
    ----------
    instance : object
        The element being made.
    attribute : attrs.Attribute
        The field.
    value : object
        The converted value.

    Raises
    ------
    ModelError
        Not numbers, not of shape (3, 3), or not finite.
    """
    _numeric(instance, attribute, value)
    if value.shape != (3, 3):
        raise ModelError(f"{label(instance)}: {attribute.name} must have shape (3, 3), got {value.shape}")
    finite_array(instance, attribute, value)


def is_a(kind):
    """A validator: the value is an instance of ``kind``.

    Parameters
    ----------
    kind : type
        The class required.

    Returns
    -------
    callable
        The attrs validator (``... must be a Kind, got OtherKind``).
    """

    def check(instance, attribute, value):
        if not isinstance(value, kind):
            raise ModelError(
                f"{label(instance)}: {attribute.name} must be a {kind.__name__}, got {type(value).__name__}"
            )

    return check
