"""CVODE's Jacobian-times-vector for the loops' GMRES as C callbacks: ``J v`` without a right-hand side.

With the Krylov solver (from ``KRYLOV_MIN_COORDS`` coordinates), CVODE's
GMRES needs ``J v`` once per iteration; its own difference quotient
costs a right-hand side each. Where the compiled Jacobian gives the
model's tangent (:func:`flexmb.integrators.cvode_direct.compiled_jacobian`),
:class:`~flexmb.integrators.cvode_direct_loops.DirectLoopCVODE` gives
CVODE these two instead (``CVodeSetJacTimes``): :func:`jtsetup`, at the
start of each linear solve, and :func:`jtimes`, the product of
:mod:`flexmb.kernels.loop_jtimes` on the factors of the right-hand side
CVODE has just evaluated at the same state (the Newton residual's:
:func:`~flexmb.kernels.cvode_loop_callbacks.evaluate` keeps them in the
buffer at ``A_JT``). Where the buffer holds another state (a right-hand
side at another state since), the right-hand side is evaluated again
there, counted apart (``H_RHS``). G's terms are made at the first linear
solve after each set-up of the preconditioner and kept until the next
(``H_LAG``, from ``LAGGED_JTIMES``: G lagged as the dense solver's J is),
or at every linear solve; P is always the current state's.

J is the state Jacobian of the dense path (``System.state_jacobian``:
springs, dampers, the loads' and inertia forces' geometric stiffness, the
constraint forces' not), not the difference quotient's exact derivative:
CVODE's Newton iteration is then the modified Newton of the dense path.
"""

from __future__ import annotations

import numpy as np
from numba import types

from .cache import njit
from .cvode_callbacks import _cfunc
from .cvode_loop_callbacks import (A_C, A_JT, A_K, BAND, M, MROWS, N, N_JT, N_V, NONFINITE, NONFINITE_FLAG, RHS,
                                   SETUPS, _f1, _fail, _layout, _packed, _state, _ud, _vector, _work, evaluate)
from .loop_jtimes import (H_AT, H_LAG, H_RHS, H_SETUPS, H_TERMS, H_TIMES, holds, jtimes_size, prepare,
                          state_jacobian_times)

__all__ = ["jtsetup", "jtimes"]


@njit(cache=True)
def _buffers(ud):
    """The buffer of the current state's factors and the terms of G (21 n)."""
    n, m, mr, band = ud[N], ud[M], ud[MROWS], ud[BAND]
    size = jtimes_size(n, m, mr, band, ud[N_V])
    whole = _f1(ud[A_JT], ud[N_JT])
    return whole[:size], whole[size : size + 21 * n]


@njit(cache=True)
def _ready(ud, t, yv):
    """Make the buffers hold the factors at the true state ``yv`` and the terms of G; (kept, status).

    The factors (P) are always the current state's (those of the right-hand
    side just evaluated there); G's terms too where ``H_LAG`` is 0, else
    (``H_LAG`` 1) those made at the first linear solve after each set-up of
    the preconditioner, kept until the next (G lagged as the dense
    solver's whole J is).
    """
    n, m = ud[N], ud[M]
    jt, terms = _buffers(ud)
    if not holds(jt, yv, m):  # (counted with the right-hand sides, and apart)
        ud[RHS] += 1
        jt[H_RHS] += 1
        kept, status = evaluate(ud, t, yv, np.empty(m))
        if status:
            return kept, status
    if jt[H_LAG] == 1.0:
        if jt[H_AT] == ud[SETUPS]:
            return 0, 0
        jt[H_AT] = ud[SETUPS]
    elif jt[H_TERMS] == 1.0:
        return 0, 0
    work, o = _work(ud)
    prepare(_packed(ud), jt, terms, work[o:], n, m)
    return 0, 0


@njit(cache=True)
def _failed(ud, t, yv, kept, status):
    """CVODE's flag for a failed evaluation (as :func:`~flexmb.kernels.cvode_loop_callbacks.rhs` returns it)."""
    if status == 2:
        return _fail(ud, NONFINITE, t, yv, ud[NONFINITE_FLAG])
    return _fail(ud, kept, t, yv, -1)


@_cfunc(types.int32(types.float64, types.voidptr, types.voidptr, types.voidptr))
def jtsetup(t, y, fy, user_data):
    """CVLsJacTimesSetupFn: the terms of G at ``y`` (the factors: those its right-hand side kept)."""
    ud = _ud(user_data)
    yv = _state(ud, y, ud[M])
    _buffers(ud)[0][H_SETUPS] += 1
    kept, status = _ready(ud, t, yv)
    return _failed(ud, t, yv, kept, status) if status else 0


@_cfunc(types.int32(types.voidptr, types.voidptr, types.float64, types.voidptr, types.voidptr, types.voidptr,
                    types.voidptr))
def jtimes(v, Jv, t, y, fy, user_data, tmp):
    """CVLsJacTimesVecFn: ``Jv = J v`` at ``y`` (:func:`~flexmb.kernels.loop_jtimes.state_jacobian_times`)."""
    ud = _ud(user_data)
    n, m = ud[N], ud[M]
    yv = _state(ud, y, m)
    jt, terms = _buffers(ud)
    jt[H_TIMES] += 1
    kept, status = _ready(ud, t, yv)
    if status:
        return _failed(ud, t, yv, kept, status)
    work, o = _work(ud)
    kept, status = state_jacobian_times(_packed(ud), _layout(ud), jt, terms, work[o:], n, m, _f1(ud[A_K], n),
                                        _f1(ud[A_C], n), _vector(ud, v, m), _vector(ud, Jv, m))
    return _failed(ud, t, yv, kept, status) if status else 0
