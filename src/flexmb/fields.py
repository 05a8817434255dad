"""Converters and validators for the attrs fields of model elements.

flexmb's bodies, joints and force elements are frozen attrs classes whose
data are checked when they are built; a plugin's element uses the same
checks through this module. A converter turns the given value into what the
field holds (a float, a read-only float array); a validator checks it and
raises :class:`~flexmb.ModelError` with a message that names the element
and the field, so an error in a large model points at the offending part::

    Thrust 'jet': force must be > 0, got -1.0

A converter leaves a value it cannot convert unchanged (it does not know
the element); the field's validator then rejects it with that message.
Give several validators as a list; they run in order.
:func:`positive` and :func:`non_negative` reject anything that is not a
finite number within their bound with one message naming the bound; put
:func:`finite_number` before them to tell a value that is not a number
apart (``must be a finite number, got 'high'``).

Examples
--------
>>> import numpy as np
>>> from attrs import field, frozen
>>> import flexmb as fm
>>> from flexmb.fields import as_float, as_unit_vector, finite_number, positive, unit_vector
>>> @frozen(eq=False)
... class Thrust(fm.ForceElement):
...     body: fm.Body = fm.reference(fm.Body)
...     force: float = field(converter=as_float, validator=[finite_number, positive])
...     direction: np.ndarray = field(default=(1, 0, 0), converter=as_unit_vector, validator=unit_vector)
>>> Thrust("jet", "hull", force=2, direction=(0, 0, 5)).direction.tolist()
[0.0, 0.0, 1.0]
>>> Thrust("jet", "hull", force=-1)
Traceback (most recent call last):
    ...
flexmb.errors.ModelError: Thrust 'jet': force must be > 0, got -1.0
>>> Thrust("jet", "hull", force="strong")
Traceback (most recent call last):
    ...
flexmb.errors.ModelError: Thrust 'jet': force must be a finite number, got 'strong'
"""

from __future__ import annotations

import numpy as np

from .errors import ModelError

__all__ = ["label", "as_float", "as_array", "as_unit_vector", "as_count", "as_bool", "finite_number", "positive",
           "non_negative", "count", "boolean", "finite_array", "vector3", "unit_vector", "matrix33", "rotation_matrix",
           "is_a"]


def label(instance) -> str:
    """The words that name an element in a message: its class and its name.

    Parameters
    ----------
    instance : object
        The element (its ``name`` attribute, ``'?'`` without one).

    Returns
    -------
    str
        ``Kind 'name'``, e.g. ``RigidBody 'crank'``.

    Examples
    --------
    >>> import flexmb as fm
    >>> from flexmb.fields import label
    >>> label(fm.RigidBody("crank", 1.0, (1.0, 1.0, 1.0)))
    "RigidBody 'crank'"
    """
    return f"{type(instance).__name__} {getattr(instance, 'name', '?')!r}"


# ----------------------------------------------------------------------------- converters

def as_float(value):
    """Convert to ``float``; leave what is not a number (a bool too) for the validator.

    Parameters
    ----------
    value : object
        The value given for the field: a number, or a string of one.

    Returns
    -------
    float or object
        ``float(value)``, or ``value`` itself if it is a bool or cannot be
        converted.

    Examples
    --------
    >>> from flexmb.fields import as_float
    >>> as_float("2.5"), as_float(True), as_float(None)
    (2.5, True, None)
    """
    if isinstance(value, (bool, np.bool_)):
        return value
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError):
        return value


def as_array(value):
    """Copy to a read-only float array; leave what is not numeric for the validator.

    Parameters
    ----------
    value : array_like
        The value given for the field: a number, a sequence of numbers,
        an array.

    Returns
    -------
    ndarray or object
        A new float array that cannot be written to, or ``value`` itself
        if it cannot be converted.

    Examples
    --------
    >>> from flexmb.fields import as_array
    >>> a = as_array([1, 2, 3])
    >>> a, a.flags.writeable
    (array([1., 2., 3.]), False)
    >>> as_array("tip")
    'tip'
    """
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        return value
    arr.setflags(write=False)
    return arr


def as_unit_vector(value):
    """Normalise a finite, nonzero 3-vector to a read-only unit vector.

    Parameters
    ----------
    value : array_like, shape (3,)
        The value given for the field.

    Returns
    -------
    ndarray or object
        The unit vector along ``value``; anything else (a zero vector, a
        wrong shape, a non-finite entry) as :func:`as_array` gives it, for
        :func:`unit_vector` to reject.

    Examples
    --------
    >>> from flexmb.fields import as_unit_vector
    >>> as_unit_vector((0, 3, 4)).tolist()
    [0.0, 0.6, 0.8]
    """
    arr = as_array(value)
    if isinstance(arr, np.ndarray) and arr.shape == (3,) and np.all(np.isfinite(arr)):
        length = np.linalg.norm(arr)
        if length > 0.0:
            arr = arr / length
            arr.setflags(write=False)
    return arr


def as_count(value):
    """Convert a finite whole number (``4``, ``4.0``, ``np.int64(4)``) to ``int``.

    Parameters
    ----------
    value : object
        The value given for the field: an integer, or a float or numpy
        number with a whole value.

    Returns
    -------
    int or object
        ``int(value)``, or ``value`` itself (NaN, inf, None, 2.5, a string,
        a bool) for :func:`count` to reject.

    Examples
    --------
    >>> from flexmb.fields import as_count
    >>> as_count(4.0), as_count(2.5)
    (4, 2.5)
    """
    if isinstance(value, (bool, np.bool_, str, bytes)):
        return value
    try:
        f = float(value)
    except (TypeError, ValueError, OverflowError):
        return value
    if np.isfinite(f) and f == int(f):
        return int(f)
    return value


def as_bool(value):
    """Convert a numpy bool to ``bool``; leave anything else for the validator.

    Parameters
    ----------
    value : object
        The value given for the field.

    Returns
    -------
    bool or object
        ``bool(value)`` for ``True``, ``False`` or a numpy bool; ``value``
        itself otherwise (a string, a number, None), for :func:`boolean`
        to reject: ``"no"`` and ``nan`` would both read as True.

    Examples
    --------
    >>> import numpy as np
    >>> from flexmb.fields import as_bool
    >>> as_bool(np.bool_(False)), as_bool("no")
    (False, 'no')
    """
    return bool(value) if isinstance(value, (bool, np.bool_)) else value


# ----------------------------------------------------------------------------- validators

#: the largest count an array can have (int64); a larger integer (``10**400``) is refused as no count
COUNT_MAX = int(np.iinfo(np.int64).max)

# Every validator takes attrs' three arguments; they are documented once, here.

_VALIDATOR_ARGUMENTS = """Parameters
    ----------
    instance : object
        The element being built; the message names it.
    attribute : attrs.Attribute
        The field; the message names it.
    value : object
        The field's value, as its converter left it.

    Raises
    ------
    ModelError
        If the value is refused: ``Kind 'name': field must ..., got ...``."""


def _validator(check):
    """Fill the arguments every validator shares into its docstring (at ``{arguments}``)."""
    check.__doc__ = check.__doc__.replace("{arguments}", _VALIDATOR_ARGUMENTS)
    return check


def _refuse(instance, attribute, problem: str):
    """Raise the message of a refused value: the element, the field, then ``problem``."""
    raise ModelError(f"{label(instance)}: {attribute.name} {problem}")


@_validator
def finite_number(instance, attribute, value):
    """Validator: a finite float (as :func:`as_float` gives it; a bool is not one).

    Anything else is refused with ``must be a finite number, got ...``.

    {arguments}
    """
    if not isinstance(value, float) or not np.isfinite(value):
        _refuse(instance, attribute, f"must be a finite number, got {value!r}")


@_validator
def positive(instance, attribute, value):
    """Validator: a finite float > 0.

    Anything else, NaN, inf and non-numbers too, is refused with
    ``must be > 0, got ...``; list :func:`finite_number` first to say that
    a non-number is not a number.

    {arguments}
    """
    if not isinstance(value, float) or not np.isfinite(value) or not value > 0:
        _refuse(instance, attribute, f"must be > 0, got {value!r}")


@_validator
def non_negative(instance, attribute, value):
    """Validator: a finite float >= 0.

    Anything else, NaN, inf and non-numbers too, is refused with
    ``must be >= 0, got ...``; list :func:`finite_number` first to say that
    a non-number is not a number.

    {arguments}
    """
    if not isinstance(value, float) or not np.isfinite(value) or not value >= 0:
        _refuse(instance, attribute, f"must be >= 0, got {value!r}")


@_validator
def count(instance, attribute, value):
    """Validator: an integer >= 1 (as :func:`as_count` gives it; a bool is not one).

    Anything else is refused with ``must be an integer >= 1, got ...``.

    {arguments}
    """
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= COUNT_MAX:
        _refuse(instance, attribute, f"must be an integer >= 1, got {value!r}")


@_validator
def boolean(instance, attribute, value):
    """Validator: ``True`` or ``False`` (as :func:`as_bool` gives it).

    Anything else is refused with ``must be True or False, got ...``.

    {arguments}
    """
    if not isinstance(value, bool):
        _refuse(instance, attribute, f"must be True or False, got {value!r}")


@_validator
def finite_array(instance, attribute, value):
    """Validator: a float array, of any shape, with finite entries (as :func:`as_array` gives it).

    What is not a float array is refused with ``must be numbers, got ...``,
    a NaN or inf entry with ``must be finite, got [...]``.

    {arguments}
    """
    _numbers(instance, attribute, value)
    if not np.all(np.isfinite(value)):
        _refuse(instance, attribute, f"must be finite, got {value.tolist()}")


def _numbers(instance, attribute, value):
    """A float array, as :func:`as_array` gives for numeric input."""
    if not (isinstance(value, np.ndarray) and value.dtype == float):
        _refuse(instance, attribute, f"must be numbers, got {value!r}")


def _finite_shaped(instance, attribute, value, shape):
    """A float array of ``shape`` with finite entries."""
    _numbers(instance, attribute, value)
    if value.shape != shape:
        _refuse(instance, attribute, f"must have shape {shape}, got {value.shape}")
    finite_array(instance, attribute, value)


@_validator
def vector3(instance, attribute, value):
    """Validator: a finite 3-vector (a point, or a direction of any length).

    Refused: what is not numbers, a shape other than (3,)
    (``must have shape (3,), got ...``), a NaN or inf entry.

    {arguments}
    """
    _finite_shaped(instance, attribute, value, (3,))


@_validator
def unit_vector(instance, attribute, value):
    """Validator: a finite 3-vector of length 1 (as :func:`as_unit_vector` gives it).

    Refused as by :func:`vector3`, and a zero vector, which
    :func:`as_unit_vector` cannot normalise (``must be a nonzero vector``),
    or another length (``must have length 1``).

    {arguments}
    """
    vector3(instance, attribute, value)
    length = np.linalg.norm(value)
    if length == 0.0:
        _refuse(instance, attribute, f"must be a nonzero vector, got {value.tolist()}")
    if not abs(length - 1.0) < 1e-12:
        _refuse(instance, attribute, f"must have length 1, got {value.tolist()}")


@_validator
def matrix33(instance, attribute, value):
    """Validator: a finite 3 x 3 matrix.

    Refused: what is not numbers, a shape other than (3, 3)
    (``must have shape (3, 3), got ...``), a NaN or inf entry.

    {arguments}
    """
    _finite_shaped(instance, attribute, value, (3, 3))


@_validator
def rotation_matrix(instance, attribute, value):
    """Validator: a proper rotation matrix (orthonormal, determinant +1).

    Refused as by :func:`matrix33`, and with ``must be a rotation matrix
    (orthonormal, det +1)``. For a field that may be None, wrap it:
    ``attrs.validators.optional(rotation_matrix)``.

    {arguments}
    """
    matrix33(instance, attribute, value)
    if not np.allclose(value.T @ value, np.eye(3), atol=1e-9) or np.linalg.det(value) < 0:
        _refuse(instance, attribute, "must be a rotation matrix (orthonormal, det +1)")


def is_a(kind: type):
    """A validator that accepts instances of ``kind``.

    For a field that holds another element of the model (a body, a joint),
    use :func:`flexmb.reference` instead: it also accepts the element's name.

    Parameters
    ----------
    kind : type
        The class the value must be an instance of.

    Returns
    -------
    callable
        ``check(instance, attribute, value)``, raising :class:`~flexmb.ModelError`
        ``must be a Kind, got OtherKind``.

    Examples
    --------
    >>> from attrs import field, frozen
    >>> import flexmb as fm
    >>> from flexmb.fields import is_a
    >>> @frozen
    ... class Lining:
    ...     name: str
    ...     material: fm.Material = field(validator=is_a(fm.Material))
    >>> Lining("pad", "rubber")
    Traceback (most recent call last):
        ...
    flexmb.errors.ModelError: Lining 'pad': material must be a Material, got str
    """

    def check(instance, attribute, value):
        if not isinstance(value, kind):
            _refuse(instance, attribute, f"must be a {kind.__name__}, got {type(value).__name__}")

    return check
