"""What a run works out from its System and settings alone, kept for the next run on the same System.

A :func:`flexmb.simulate` call on a small model spends much of its time
on work that depends only on the System (the diagonal coordinate springs
the Newton preconditioner reads, whether the compiled Jacobian covers the
model's tangent) or on the System and the run's settings and initial
state (which integrator ``method='auto'`` takes, whether the model has a
Jacobian to give CVODE). :func:`once` keeps the first kind for the
System's lifetime; :func:`last` keeps the latest values of the second kind
(``KEPT`` of them) with the arguments each was worked out from, and works
it out again for other arguments (a new initial state, other tolerances). Either returns the
very value the work would give: force elements are frozen and a System
keeps its tables, so the same arguments give the same result.

The values are held per System object (a weak reference: a System that
is dropped takes its values with it); a copy of a System (another
complement strategy, a calibrated copy) starts without any.
"""

from __future__ import annotations

import threading
import weakref

import numpy as np

__all__ = ["once", "last", "state_key", "KEPT"]

_MEMO: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()

_LOCK = threading.Lock()

#: the values :func:`last` keeps per System and name (different initial states or settings, the latest ones)
KEPT = 8


def _table(system) -> dict:
    table = _MEMO.get(system)
    if table is None:
        with _LOCK:
            table = _MEMO.setdefault(system, {})
    return table


def once(system, what, make):
    """``make()`` the first time ``what`` is asked of ``system``; the same value after.

    Parameters
    ----------
    system : System
        The model the value depends on (and nothing else).
    what : hashable
        The value's name.
    make : callable
        ``make()`` works it out.

    Returns
    -------
    object
        The value (the same object on every call: treat it as read-only).
    """
    table = _table(system)
    try:
        return table[what]
    except KeyError:
        value = make()
        with _LOCK:
            return table.setdefault(what, value)


def last(system, what, key, make):
    """``make()``, unless one of the last ``KEPT`` calls for ``what`` on ``system`` had an equal ``key``: its value.

    Parameters
    ----------
    system : System
        The model.
    what : hashable
        The value's name.
    key : hashable
        Everything else the value depends on (:func:`state_key` for arrays).
    make : callable
        ``make()`` works it out.

    Returns
    -------
    object
        The value.
    """
    table = _table(system)
    held = table.get(("last", what))
    if held is None:
        with _LOCK:
            held = table.setdefault(("last", what), {})
    try:
        return held[key]
    except KeyError:
        value = make()
        with _LOCK:  # (runs on other threads may add and drop values meanwhile)
            held[key] = value
            while len(held) > KEPT:  # the oldest first (dicts keep their order)
                del held[next(iter(held))]
        return value


def state_key(*values) -> tuple:
    """A hashable key of floats and float arrays, equal exactly when their values are (to the bit).

    Parameters
    ----------
    *values : float or ndarray
        The arguments a value depends on.

    Returns
    -------
    tuple
        One entry per value: an array's dtype, shape and bytes, a float's hex form, else the value with its type.
    """
    return tuple([v.hex() if type(v) is float else (v.dtype.str, v.shape, v.tobytes()) if type(v) is np.ndarray
                  else float(v).hex() if isinstance(v, (float, np.floating)) else (type(v), v) for v in values])
