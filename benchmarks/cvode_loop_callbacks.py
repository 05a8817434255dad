"""CVODE's callbacks for a model with loops as numba C callbacks, and a compiled step loop with the drift check.

Issue 28's prototype.

The loops' counterpart of :mod:`flexmb.kernels.cvode_callbacks` (open trees), for models
whose loops the articulated strategy closes (``System._loop_kernel``) and
whose force elements are all compiled: the right-hand side is
:func:`flexmb.kernels.loops.loop_rhs`, the Newton preconditioner's solve
:func:`flexmb.kernels.loops.loop_newton_solve` with the factors of
:func:`~flexmb.kernels.loops.loop_newton_factor` made at the first solve
with a new gamma after a set-up and kept in buffers (as
``LoopNewtonPreconditioner`` keeps them), the drivers' rows those of
drivers at constant speed (``angle = p0 + w t``: their prescribed
acceleration is zero). The model reaches the callbacks through CVODE's
``user_data``: an int64 array (the slots below) of addresses and sizes of
the packed model, of the loop layout's arrays, of the preconditioner's
buffers, of the float parameters, and counters.

:func:`advance` is CVODE's step loop between two output times with, after
each step, the constraint check of flexmb's ``Run._restart_if_drifted``
(the cut joints' largest position and velocity residuals by
``tree_equations(..., RESIDUALS, ...)``, and the drivers'): it returns
DRIFTED when the residual exceeds the bound, and Python then projects and
restarts CVODE, as simulate does.

This is a benchmark's prototype, not part of flexmb.
"""

from __future__ import annotations

import functools
import hashlib
import os

import numpy as np
from numba import carray, types

from flexmb.kernels import cache as _kc
from flexmb.kernels.cvode_callbacks import _LazyCFunc as _OpenTreeLazyCFunc
from flexmb.kernels.cvode_callbacks import _call_cvode, _call_dky, _call_p_p, _voidp
from flexmb.kernels.equations import RESIDUALS, tree_equations
from flexmb.kernels.loop_layout import LoopLayout
from flexmb.kernels.loops import loop_newton_factor, loop_newton_solve, loop_rhs

#: slots of the user_data array (int64)
(A_GETPTR, A_MATDATA, N, M, NB, A_FL, N_FL, A_IT, N_IT, A_FG, N_FG, A_IX, N_IX,
 A_ROW_BODY, A_ROW_COORD, A_ROOT_OF, A_ROW_ROOTS, A_VISIT_PTR, A_VISIT, A_ROOT_PTR, A_ROOT_ROWS, A_ORDER, A_POSITION,
 MROWS, N_VISIT, N_ROOTS, N_ROOT_ROWS, BAND, N_DRV, A_DRV, A_REAL, RANK_LIMIT, A_K, A_C, A_X,
 A_SW, A_SV, A_W, A_BODY, A_U, A_DUT, A_DINV, A_LIFT, A_KB, A_D, A_DF, A_V, V_ROWS, F_KEPT, F_STATUS, F_VALID,
 SETUPS, RHS, PSOLVES, FACTORS, STATUS, NONFINITE_FLAG) = range(57)
UD_SIZE = 57
#: the float parameters (A_REAL): tol, window, the factors' gamma and smallest pivot, the failure's time, the
#: drift bound
R_TOL, R_WINDOW, R_GAMMA, R_SMALLEST, R_FAIL_T, R_BOUND = range(6)
#: the loop's return codes (CVODE's negative flags pass through)
REACHED, CHECKPOINT, PAUSED, DRIFTED, DRIFTED_PAST = 0, 1, 2, 3, 4


@functools.lru_cache(maxsize=None)
def _own_stamp() -> str:
    with open(os.path.abspath(__file__), "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


class _Stamp:
    def get_source_stamp(self):
        return (_kc.sources_stamp(), _own_stamp())


class _Impl(_kc._KernelCacheImpl):
    _locator_classes = [type(c.__name__, (_Stamp, c), {}) for c in _kc._KernelCacheImpl._locator_classes]


class _Cache(_kc.KernelCache):
    """flexmb's kernel cache, stamped with the kernels' sources (cvode_callbacks.py's among them) and this file's."""

    _impl_class = _Impl


class _LazyCFunc(_OpenTreeLazyCFunc):
    """A numba C callback compiled (or loaded from :class:`_Cache`) when its address is first asked for."""

    cache_class = _Cache


def _cfunc(sig):
    return lambda func: _LazyCFunc(func, sig)


def _cached_njit(func):
    import numba

    dispatcher = numba.njit(func)
    dispatcher._cache = _Cache(dispatcher.py_func)
    return dispatcher


# ----------------------------------------------------------------------------- the model from user_data

@_cached_njit
def _ud(user_data):
    return carray(user_data, (UD_SIZE,), np.int64)


@_cached_njit
def _f1(addr, n):
    return carray(_voidp(addr), (n,), np.float64)


@_cached_njit
def _f2(addr, n, k):
    return carray(_voidp(addr), (n, k), np.float64)


@_cached_njit
def _i1(addr, n):
    return carray(_voidp(addr), (n,), np.int64)


@_cached_njit
def _i2(addr, n, k):
    return carray(_voidp(addr), (n, k), np.int64)


@_cached_njit
def _vector(ud, v, m):
    """The data of the N_Vector ``v`` (``N_VGetArrayPointer``), length m."""
    return carray(_call_p_p(ud[A_GETPTR], v), (m,), np.float64)


@_cached_njit
def _packed(ud):
    fl = carray(_voidp(ud[A_FL]), (ud[N_FL],), np.float64)
    it = carray(_voidp(ud[A_IT]), (ud[N_IT],), np.int64)
    fg = carray(_voidp(ud[A_FG]), (ud[N_FG],), np.bool_)
    ix = carray(_voidp(ud[A_IX]), (ud[N_IX], 4), np.int64)
    return fl, it, fg, ix


@_cached_njit
def _layout(ud):
    m, nb = ud[MROWS], ud[NB]
    return LoopLayout(_i2(ud[A_ROW_BODY], m, 2), _i1(ud[A_ROW_COORD], m), _i1(ud[A_ROOT_OF], nb),
                      _i2(ud[A_ROW_ROOTS], m, 2), _i1(ud[A_VISIT_PTR], m + 1), _i1(ud[A_VISIT], ud[N_VISIT]),
                      _i1(ud[A_ROOT_PTR], ud[N_ROOTS] + 1), _i1(ud[A_ROOT_ROWS], ud[N_ROOT_ROWS]),
                      _i1(ud[A_ORDER], m), _i1(ud[A_POSITION], m), ud[BAND])


@_cached_njit
def _fail(ud, status, t, flag):
    """Record why a callback failed (its status, the time) and return CVODE's flag for it."""
    ud[STATUS] = status
    _f1(ud[A_REAL], 8)[R_FAIL_T] = t
    return flag


# ----------------------------------------------------------------------------- the callbacks

@_cfunc(types.int32(types.float64, types.voidptr, types.voidptr, types.voidptr))
def rhs(t, y, ydot, user_data):
    """CVRhsFn: ``ydot = (xd, xdd)`` by loop_rhs; NONFINITE_FLAG if not finite, -1 if singular."""
    ud = _ud(user_data)
    n, m, nb = ud[N], ud[M], ud[NB]
    yv = _vector(ud, y, m)
    out = _vector(ud, ydot, m)
    real = _f1(ud[A_REAL], 8)
    ud[RHS] += 1
    zeros = np.zeros((nb + 1, 3))
    xdd, lam, kept, smallest, status = loop_rhs(_packed(ud), _layout(ud), yv, n, np.zeros(0), zeros, zeros,
                                                np.zeros(n), np.zeros(ud[N_DRV]), real[R_TOL], real[R_WINDOW],
                                                ud[RANK_LIMIT])
    for i in range(n):
        out[i] = yv[n + i]
        out[n + i] = xdd[i]
    for i in range(2 * n, m):
        out[i] = 0.0
    if status == 0:
        return 0
    if status == 2:
        return _fail(ud, -2, t, ud[NONFINITE_FLAG])
    return _fail(ud, kept, t, -1)  # a freedom that moves no mass and that no loop fixes


@_cfunc(types.int32(types.float64, types.voidptr, types.voidptr, types.int32, types.voidptr, types.float64,
                    types.voidptr))
def psetup(t, y, fy, jok, jcur, gamma, user_data):
    """CVLsPrecSetupFn: the positions at ``y`` (kept while ``jok``); the factors are made by the next solve."""
    ud = _ud(user_data)
    flag = carray(jcur, (1,), np.int32)
    if jok and ud[SETUPS] > 0:
        flag[0] = 0
        return 0
    n = ud[N]
    yv = _vector(ud, y, ud[M])
    x = _f1(ud[A_X], n)
    for i in range(n):
        x[i] = yv[i]
    ud[F_VALID] = 0
    ud[SETUPS] += 1
    flag[0] = 1
    return 0


@_cached_njit
def _store(ud, factored, gamma):
    """Copy loop_newton_factor's result into the buffers (valid for ``gamma``)."""
    Sw, Sv, W, body, factors = factored
    U, DinvUT, Dinv, lift, Kb, d, dfilt, kept, smallest, V, status = factors
    n, m = ud[N], ud[MROWS]
    _f2(ud[A_SW], n, 3)[:, :] = Sw
    _f2(ud[A_SV], n, 3)[:, :] = Sv
    _f2(ud[A_W], m, 12)[:, :] = W.reshape((m, 12))
    _i2(ud[A_BODY], m, 2)[:, :] = body
    _f2(ud[A_U], n, 6)[:, :] = U
    _f2(ud[A_DUT], n, 6)[:, :] = DinvUT
    _f2(ud[A_DINV], n, 6)[:, :] = Dinv
    _f1(ud[A_LIFT], n)[:] = lift
    _f2(ud[A_KB], m, ud[BAND] + 1)[:, :] = Kb
    _f1(ud[A_D], m)[:] = d
    _f1(ud[A_DF], m)[:] = dfilt
    k = V.shape[0]
    _f2(ud[A_V], k, k)[:, :] = V
    ud[V_ROWS], ud[F_KEPT], ud[F_STATUS], ud[F_VALID] = k, kept, status, 1
    real = _f1(ud[A_REAL], 8)
    real[R_GAMMA], real[R_SMALLEST] = gamma, smallest
    ud[FACTORS] += 1


@_cached_njit
def _load(ud):
    """The factors in the buffers, as loop_newton_factor returns them."""
    n, m, k = ud[N], ud[MROWS], ud[V_ROWS]
    factors = (_f2(ud[A_U], n, 6), _f2(ud[A_DUT], n, 6), _f2(ud[A_DINV], n, 6), _f1(ud[A_LIFT], n),
               _f2(ud[A_KB], m, ud[BAND] + 1), _f1(ud[A_D], m), _f1(ud[A_DF], m), ud[F_KEPT],
               _f1(ud[A_REAL], 8)[R_SMALLEST], _f2(ud[A_V], k, k), ud[F_STATUS])
    return (_f2(ud[A_SW], n, 3), _f2(ud[A_SV], n, 3), _f2(ud[A_W], m, 12).reshape((m, 2, 6)),
            _i2(ud[A_BODY], m, 2), factors)


@_cfunc(types.int32(types.float64, types.voidptr, types.voidptr, types.voidptr, types.voidptr, types.float64,
                    types.float64, types.int32, types.voidptr))
def psolve(t, y, fy, rv, zv, gamma, delta, lr, user_data):
    """CVLsPrecSolveFn: ``(I - gamma J) z ~ r`` in O(n), as LoopNewtonPreconditioner.solve; -1 if singular."""
    ud = _ud(user_data)
    n, m = ud[N], ud[M]
    r = _vector(ud, rv, m)
    z = _vector(ud, zv, m)
    K, C = _f1(ud[A_K], n), _f1(ud[A_C], n)
    real = _f1(ud[A_REAL], 8)
    ud[PSOLVES] += 1
    E = gamma * K + C
    if ud[F_VALID] == 0 or real[R_GAMMA] != gamma:
        factored = loop_newton_factor(_packed(ud), _layout(ud), _f1(ud[A_X], n).copy(), gamma * E, real[R_TOL],
                                      ud[RANK_LIMIT])
        _store(ud, factored, gamma)
    load = np.empty(n)
    for i in range(n):
        load[i] = K[i] * r[i] + E[i] * r[n + i]
    v, _, _, status = loop_newton_solve(_load(ud), _packed(ud), _layout(ud), load)
    if status:
        return _fail(ud, -3, t, -1)
    for i in range(n):
        z2 = r[n + i] - gamma * v[i]
        z[n + i] = z2
        z[i] = r[i] + gamma * z2
    for i in range(2 * n, m):
        z[i] = r[i]
    return 0


# ----------------------------------------------------------------------------- the step loop

@_cached_njit
def drift(ud, t, y):
    """The largest constraint residual at ``(t, y)``: the cut joints' (tree_equations) and the drivers'."""
    n, nb = ud[N], ud[NB]
    zeros = np.zeros((nb + 1, 3))
    res = tree_equations(_packed(ud), y, n, RESIDUALS, np.zeros(0), zeros, zeros, np.zeros(n))[2]
    worst = max(res[0], res[1])
    drv = _f2(ud[A_DRV], max(ud[N_DRV], 1), 3)
    for k in range(ud[N_DRV]):  # column, p0, w: position p0 + w t, speed w
        c = int(drv[k, 0])
        worst = max(worst, abs(y[c] - (drv[k, 1] + drv[k, 2] * t)), abs(y[n + c] - drv[k, 2]))
    return worst


@_cached_njit
def advance(lp, ud, t_stop, t_bound, steps, budget):
    """Step CVODE (``CV_ONE_STEP``) until ``t_stop``, checking the constraints after each step.

    As :func:`flexmb.kernels.cvode_callbacks.advance`, and DRIFTED (the state at the
    step's end in CVODE's y) when the residual exceeds the bound
    ``A_REAL[R_BOUND]``: the step is kept and Python projects and restarts;
    DRIFTED_PAST if that step also reached ``t_stop`` (the state there in
    the output vector first, as simulate stores the outputs a step passed
    before it projects).

    Returns
    -------
    code : int
        REACHED, CHECKPOINT, PAUSED, DRIFTED, DRIFTED_PAST or CVODE's flag (< 0).
    n_steps : int
        Steps taken in this call.
    """
    tret = carray(_voidp(lp[6]), (1,), np.float64)
    y = carray(_voidp(lp[4]), (lp[7],), np.float64)
    bound = _f1(ud[A_REAL], 8)[R_BOUND]
    tn = tret[0]
    k = 0
    cap = steps.shape[0]
    while tn < t_stop:
        flag = _call_cvode(lp[0], lp[2], t_bound, lp[3], lp[6], 2)
        if flag < 0:
            return flag, k
        t_new = tret[0]
        if t_new == tn:
            continue
        if k < cap:
            steps[k] = t_new
        k += 1
        tn = t_new
        if drift(ud, tn, y) > bound:
            if tn < t_stop:
                return DRIFTED, k
            flag = _output(lp, tn, t_stop, y)  # the output the step passed, before Python projects and restarts
            return (flag if flag < 0 else DRIFTED_PAST), k
        if k == cap and tn < t_stop:
            return CHECKPOINT, k
        if k == budget and tn < t_stop:
            return PAUSED, k
    flag = _output(lp, tn, t_stop, y)
    return (flag if flag < 0 else REACHED), k


@_cached_njit
def _output(lp, tn, t_stop, y):
    """The state at ``t_stop <= tn`` into the output vector (CVODE's interpolant, or y itself); CVODE's flag."""
    if tn > t_stop:
        return _call_dky(lp[1], lp[2], t_stop, 0, lp[5])
    out = carray(_call_p_p(lp[8], _voidp(lp[5])), (lp[7],), np.float64)
    out[:] = y
    return 0
