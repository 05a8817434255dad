"""Checks of function arguments, and of the name every element has.

The converters and validators of the elements' attrs fields are public, in
:mod:`flexmb.fields`; what is here is for flexmb itself: the ``name`` field
the base classes declare (:func:`name_check`), and the arguments of
functions, where no attrs validator runs (:func:`positive_value`,
:func:`simulate_arguments`).
"""

from __future__ import annotations

import math

import numpy as np

from .errors import ModelError
from .fields import COUNT_MAX, as_bool, as_count

__all__ = ["DEFAULT_RTOL", "LARGEST", "in_range", "name_check", "positive_value", "number", "flag", "whole",
           "simulate_arguments", "state_time", "state_vector"]


#: the largest magnitude whose square is still a float (1.34e154): model data or states beyond it make
#: the products in the equations (``m l^2``, ``k x``, the articulated inertias) overflow
LARGEST = float(np.sqrt(np.finfo(float).max))


def in_range(where: str, values: dict, hint: str = "") -> None:
    """Refuse model data that are not finite or beyond :data:`LARGEST`, where the equations' products overflow.

    Parameters
    ----------
    where : str
        The element, for the message.
    values : dict of str to array_like
        The data by what they are (``"segment mass"``, ...).
    hint : str
        Appended to the message (what to check).

    Raises
    ------
    ModelError
        ``where: its what (value) is beyond 1.34e+154, where products in the equations overflow``.
    """
    for what, v in values.items():
        big = np.max(np.abs(v), initial=0.0)
        if not (np.all(np.isfinite(v)) and big <= LARGEST):
            raise ModelError(f"{where}: its {what} ({big:.3g}) is beyond {LARGEST:.3g}, where products in the "
                             f"equations overflow{hint}")


def name_check(instance, attribute, value):
    """Names are non-empty strings."""
    if not isinstance(value, str) or not value.strip():
        raise ModelError(f"{type(instance).__name__}: name must be a non-empty string, got {value!r}")


def positive_value(where: str, what: str, value) -> float:
    """``float(value)`` if it is a finite number > 0, else raise :class:`ModelError`.

    For arguments of functions (named constructors, :func:`flexmb.simulate`),
    where no attrs validator runs; ``where`` names the element or function.
    """
    try:
        f = float("nan") if isinstance(value, (str, bytes)) else float(value)
    except (TypeError, ValueError, OverflowError):
        f = float("nan")
    if isinstance(value, bool) or not (np.isfinite(f) and f > 0):
        raise ModelError(f"{where}: {what} must be a finite number > 0, got {_short(value)}")
    return f


#: the types :func:`number` takes without asking numpy (Python's own numbers, not bool)
_PLAIN = (float, int)


def number(where: str, what: str, value, *, finite: bool = True, minimum: float | None = None,
           maximum: float | None = None, strict: bool = True) -> float:
    """``float(value)`` for a number argument within bounds, else a :class:`ModelError` naming it.

    For arguments of functions, where no attrs validator runs. A bool, a
    string, None, a complex number, an array or a number that does not fit
    a float (``10**400``) is not a number.

    Parameters
    ----------
    where : str
        The element or function, for the message.
    what : str
        The argument's name.
    value : object
        What the caller gave.
    finite : bool
        Refuse +-inf (NaN is always refused).
    minimum, maximum : float, optional
        Bounds; exclusive with ``strict``, else inclusive.
    strict : bool
        Whether the bounds themselves are refused.

    Returns
    -------
    float

    Raises
    ------
    ModelError
        ``where: what must be ..., got value``.
    """
    try:
        if type(value) not in _PLAIN and (isinstance(value, (str, bytes, complex, np.complexfloating))
                                          or np.ndim(value) != 0):
            raise TypeError
        f = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ModelError(f"{where}: {what} must be a number, got {_short(value)}") from None
    if isinstance(value, (bool, np.bool_)) or math.isnan(f) or (finite and not math.isfinite(f)):
        raise ModelError(f"{where}: {what} must be a finite number, got {_short(value)}")
    low = minimum is not None and not (f > minimum if strict else f >= minimum)
    high = maximum is not None and not (f < maximum if strict else f <= maximum)
    if low or high:
        if minimum is not None and maximum is not None:
            ends = "()" if strict else "[]"
            need = f"in {ends[0]}{minimum:g}, {maximum:g}{ends[1]}"
        elif minimum is not None:
            need = f"{'>' if strict else '>='} {minimum:g}"
        else:
            need = f"{'<' if strict else '<='} {maximum:g}"
        raise ModelError(f"{where}: {what} must be {need}, got {_short(value)}")
    return f




def whole(where: str, what: str, value, minimum: int = 1) -> int:
    """An integer argument >= ``minimum`` (``4.0`` is taken as 4), else a :class:`ModelError` naming it.

    Parameters
    ----------
    where : str
        The element or function, for the message.
    what : str
        The argument's name.
    value : object
        What the caller gave.
    minimum : int
        The smallest value accepted.

    Returns
    -------
    int

    Raises
    ------
    ModelError
        ``where: what must be an integer >= minimum, got value``.
    """
    n = as_count(value)
    if isinstance(n, bool) or not isinstance(n, int) or not minimum <= n <= COUNT_MAX:
        raise ModelError(f"{where}: {what} must be an integer >= {minimum}, got {_short(value)}")
    return n


def flag(where: str, what: str, value) -> bool:
    """``value`` as a bool if it is one (``True``, ``False``, a numpy bool), else a :class:`ModelError`.

    A string, a number or None is not taken for a truth value: ``"no"``
    and ``nan`` would otherwise both read as True.

    Parameters
    ----------
    where : str
        The element or function, for the message.
    what : str
        The argument's name.
    value : object
        What the caller gave.

    Returns
    -------
    bool

    Raises
    ------
    ModelError
        ``where: what must be True or False, got value``.
    """
    value = as_bool(value)
    if not isinstance(value, bool):
        raise ModelError(f"{where}: {what} must be True or False, got {_short(value)}")
    return value


def state_time(where: str, t) -> float:
    """``float(t)`` for a time given to a function that evaluates the model, if it is a finite number.

    Raises
    ------
    ModelError
        Naming ``where`` and the value.
    """
    if type(t) is float and t - t == 0.0:  # the common case, checked at the cost of one comparison
        return t
    return number(where, "t", t)


def state_vector(where: str, what: str, value, size: int, *, at_least: bool = False) -> np.ndarray:
    """A state or coordinate vector as the compiled kernels need it, or a :class:`ModelError`.

    The kernels run without bounds checks: a vector of the wrong length
    would be read or written past its end. Every public function that
    hands a state to them checks it here first, once (the integrators'
    own right-hand sides, which only ever pass the states they were given,
    do not pay for it again).

    Parameters
    ----------
    where : str
        The function, for the message (e.g. ``"System.accelerations"``).
    what : str
        The argument's name (``"x"``, ``"xd"``, ``"y"``, ...).
    value : array_like
        What the caller gave.
    size : int
        The required length (the model's coordinates, or twice that for a
        state ``y = (x, xd)``).
    at_least : bool
        Accept a longer vector (only its first ``size`` entries are read).

    Returns
    -------
    ndarray, shape (size,) (or longer, with ``at_least``)
        A writable, C-contiguous float64 array: ``value`` itself when it is
        one already, else a copy.

    Raises
    ------
    ModelError
        If ``value`` is not a 1-d array of real numbers of that length, or
        is not finite (naming the first non-finite entry).
    """
    a = value
    if not (type(a) is np.ndarray and a.dtype == np.float64 and a.ndim == 1 and a.flags.c_contiguous
            and a.flags.writeable):
        if isinstance(value, (str, bytes, dict, set)) or value is None or np.iscomplexobj(value):
            raise ModelError(f"{where}: {what} must be an array of {size} real numbers, got "
                             f"{type(value).__name__} {_short(value)}")
        try:
            a = np.array(value, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise ModelError(f"{where}: {what} must be an array of {size} real numbers, got "
                             f"{type(value).__name__} {_short(value)}") from None
    if a.ndim != 1 or (a.shape[0] < size if at_least else a.shape[0] != size):
        need = f"(>= {size},)" if at_least else f"({size},)"
        raise ModelError(f"{where}: {what} must have shape {need}, got {a.shape}")
    if not np.isfinite(a[:size]).all():
        i = int(np.flatnonzero(~np.isfinite(a[:size]))[0])
        raise ModelError(f"{where}: {what} must be finite, got {what}[{i}] = {a[i]}")
    return a


def _short(value) -> str:
    """``repr(value)``, cut to one line of a message."""
    r = repr(value.item() if isinstance(value, np.generic) else value).replace("\n", " ")
    return r if len(r) <= 60 else r[:57] + "..."


#: the smallest relative tolerance an integration can meet in double precision (scipy's bound too)
RTOL_MIN = 100 * np.finfo(float).eps

#: the relative tolerance of a simulation given none, unless its integrator declares another
#: (``default_rtol``, :mod:`flexmb.integrators.tolerances`)
DEFAULT_RTOL = 1e-8


def simulate_arguments(t0, t_end, n_out, t_eval, rtol, atol, max_step, projection_tol):
    """Check the numeric arguments of :func:`flexmb.simulate` before anything is built.

    Returns
    -------
    t0, t_end : float
        Finite, ``t_end > t0``.
    n_out : int
        An integer >= 1 (``4.0`` is taken as 4).
    t_eval : ndarray or None
        Finite output times, 1-d, increasing, within ``[t0, t_end]``.
    rtol : float
        Finite, >= RTOL_MIN (100 machine epsilons).
    atol : float or ndarray or None
        Finite, >= 0 (None: ``rtol / 100``).
    max_step, projection_tol : float
        > 0; ``max_step`` may be ``inf``.

    Raises
    ------
    ModelError
        Naming the argument and what is wrong with it.
    """
    where = "simulate"
    t0 = number(where, "t0", t0)
    t_end = number(where, "t_end", t_end)
    if not t_end > t0:
        raise ModelError(f"t_end must be > t0, got t0 = {t0}, t_end = {t_end}")
    n = whole(where, "n_out", n_out)
    if t_eval is not None:
        try:
            t_eval = np.array(t_eval, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise ModelError(f"{where}: t_eval must be an array of times, got {t_eval!r}") from None
        if (t_eval.ndim != 1 or t_eval.size == 0 or not np.all(np.isfinite(t_eval)) or np.any(np.diff(t_eval) <= 0)
                or t_eval[0] < t0 or t_eval[-1] > t_end):
            raise ModelError("t_eval must be increasing and within [t0, t_end]")
    rtol = number(where, "rtol", rtol, minimum=0.0)
    if rtol < RTOL_MIN:
        raise ModelError(f"{where}: rtol = {rtol:g} is below what double precision can meet; the smallest is "
                         f"100 machine epsilons, {RTOL_MIN:.2g}")
    if type(atol) is float:  # a plain float: the checks below, without numpy's arrays
        if not (math.isfinite(atol) and atol >= 0):
            raise ModelError(f"{where}: atol must be finite and >= 0, got {atol!r}")
        atol = float(atol)
    elif atol is not None:
        try:
            a = np.array(atol, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise ModelError(f"{where}: atol must be a number or an array of numbers, got {atol!r}") from None
        if isinstance(atol, bool) or not np.all(np.isfinite(a)) or np.any(a < 0):
            raise ModelError(f"{where}: atol must be finite and >= 0, got {atol!r}")
        atol = float(a) if a.ndim == 0 else a
    max_step = number(where, "max_step", max_step, finite=False, minimum=0.0)
    projection_tol = number(where, "projection_tol", projection_tol, minimum=0.0)
    return t0, t_end, n, t_eval, rtol, atol, max_step, projection_tol
