"""Converters and validators of the friction elements' fields: errors name the element and the field."""

from __future__ import annotations

import numpy as np

from flexmb import ModelError


def _label(instance) -> str:
    return f"{type(instance).__name__} {getattr(instance, 'name', '?')!r}"


def _float(value):
    """``float(value)``, or ``value`` unchanged for the validator to reject."""
    if isinstance(value, bool):
        return value
    try:
        return float(value)
    except (TypeError, ValueError):
        return value


def _array(value):
    """A read-only float copy, or ``value`` unchanged for the validator to reject."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        return value
    arr.setflags(write=False)
    return arr


def _unit(value):
    """A read-only unit 3-vector; anything else is left for the validator."""
    arr = _array(value)
    if isinstance(arr, np.ndarray) and arr.shape == (3,) and np.all(np.isfinite(arr)):
        length = np.linalg.norm(arr)
        if length > 0.0:
            arr = arr / length
            arr.setflags(write=False)
    return arr


def _vector3(instance, attribute, value):
    if not (isinstance(value, np.ndarray) and value.dtype == float):
        raise ModelError(f"{_label(instance)}: {attribute.name} must be numbers, got {value!r}")
    if value.shape != (3,):
        raise ModelError(f"{_label(instance)}: {attribute.name} must have shape (3,), got {value.shape}")
    if not np.all(np.isfinite(value)):
        raise ModelError(f"{_label(instance)}: {attribute.name} must be finite, got {value.tolist()}")


def _unit_vector(instance, attribute, value):
    _vector3(instance, attribute, value)
    if not abs(np.linalg.norm(value) - 1.0) < 1e-12:
        raise ModelError(f"{_label(instance)}: {attribute.name} must be a nonzero vector, got {value.tolist()}")


def _number(instance, attribute, value):
    if not isinstance(value, float) or not np.isfinite(value):
        raise ModelError(f"{_label(instance)}: {attribute.name} must be a finite number, got {value!r}")


def _positive(instance, attribute, value):
    _number(instance, attribute, value)
    if not value > 0.0:
        raise ModelError(f"{_label(instance)}: {attribute.name} must be > 0, got {value!r}")


def _non_negative(instance, attribute, value):
    _number(instance, attribute, value)
    if not value >= 0.0:
        raise ModelError(f"{_label(instance)}: {attribute.name} must be >= 0, got {value!r}")
