"""Converters and validators shared by the frozen definition classes.

Messages name the element (``RigidBody 'crank': mass must be > 0, got -1``),
so an error in a large model points at the offending part.
"""

from __future__ import annotations

import numpy as np

from .errors import ModelError

__all__ = ["as_array", "as_float", "label", "vector3", "matrix33", "positive", "finite_array", "name_check", "is_a"]


def as_array(value):
    """Copy ``value`` to a read-only float array.

    Input that is not numeric is returned unchanged: the field's validator
    then rejects it with a message naming the element (a converter does not
    know the element).
    """
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        return value
    arr.setflags(write=False)
    return arr


def as_float(value):
    """``float(value)``, or ``value`` unchanged for the validator to reject."""
    try:
        return float(value)
    except (TypeError, ValueError):
        return value


def _numeric(instance, attribute, value):
    if not (isinstance(value, np.ndarray) and value.dtype == float):
        raise ModelError(f"{label(instance)}: {attribute.name} must be numbers, got {value!r}")


def is_a(kind):
    """Validator: the value is an instance of ``kind``."""

    def check(instance, attribute, value):
        if not isinstance(value, kind):
            raise ModelError(
                f"{label(instance)}: {attribute.name} must be a {kind.__name__}, got {type(value).__name__}"
            )

    return check


def label(instance) -> str:
    """Return ``Kind 'name'`` for messages."""
    return f"{type(instance).__name__} {getattr(instance, 'name', '?')!r}"


def name_check(instance, attribute, value):
    """Names are non-empty strings."""
    if not isinstance(value, str) or not value.strip():
        raise ModelError(f"{type(instance).__name__}: name must be a non-empty string, got {value!r}")


def finite_array(instance, attribute, value):
    """All entries finite."""
    _numeric(instance, attribute, value)
    if not np.all(np.isfinite(value)):
        raise ModelError(f"{label(instance)}: {attribute.name} must be finite, got {np.asarray(value).tolist()}")


def vector3(instance, attribute, value):
    """A finite 3-vector."""
    _numeric(instance, attribute, value)
    if value.shape != (3,):
        raise ModelError(f"{label(instance)}: {attribute.name} must have shape (3,), got {value.shape}")
    finite_array(instance, attribute, value)


def matrix33(instance, attribute, value):
    """A finite 3x3 matrix."""
    _numeric(instance, attribute, value)
    if value.shape != (3, 3):
        raise ModelError(f"{label(instance)}: {attribute.name} must have shape (3, 3), got {value.shape}")
    finite_array(instance, attribute, value)


def positive(instance, attribute, value):
    """A finite number > 0."""
    if not isinstance(value, float) or not np.isfinite(value) or not value > 0:
        raise ModelError(f"{label(instance)}: {attribute.name} must be > 0, got {value!r}")


def optional_vector3(instance, attribute, value):
    """None or a finite 3-vector."""
    if value is not None:
        vector3(instance, attribute, value)


def rotation_matrix(instance, attribute, value):
    """None or a proper orthonormal 3x3 matrix."""
    if value is None:
        return
    matrix33(instance, attribute, value)
    if not np.allclose(value.T @ value, np.eye(3), atol=1e-9) or np.linalg.det(value) < 0:
        raise ModelError(f"{label(instance)}: {attribute.name} must be a rotation matrix (orthonormal, det +1)")


def optional_array(value):
    """Convert unless None."""
    return None if value is None else as_array(value)
