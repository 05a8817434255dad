"""CVODE's callbacks for a model with loops as C functions, and its step loop with the constraint check, compiled.

The loops' counterpart of :mod:`flexmb.kernels.cvode_callbacks` (open
trees), for models whose loops the articulated strategy closes
(``System._loop_kernel``), whose force elements are all compiled and whose
drivers have a closed form (``Driver.law``: constant speed, harmonic),
evaluated here with their callables' arithmetic (:func:`driver`). The
right-hand side is
:func:`~flexmb.kernels.loops.loop_rhs`; the Newton preconditioner is
``LoopNewtonPreconditioner``'s: its set-up keeps the positions, its solve
makes the factors of :func:`~flexmb.kernels.loops.loop_newton_factor` at
the first solve with a new gamma after a set-up and keeps them in buffers,
then :func:`~flexmb.kernels.loops.loop_newton_solve` (two O(n)
recursions). Each computes what the Python objects compute, with the same
kernels and the same arithmetic, so that CVODE takes the same steps.

The model reaches them through CVODE's ``user_data``: an int64 array (the
slots below) of the addresses and sizes of the packed model, of the loop
layout's arrays, of the preconditioner's buffers, of the winding offsets,
of the float parameters (``A_REAL``), and counters. The failure's time and
state go where :class:`~flexmb.integrators.cvode_direct.DirectCVODE`
reads them (``A_FAIL_T``, ``A_FAIL_Y``).

:func:`advance` is CVODE's step loop up to an output time with, after each
step, the checks of ``flexmb.stepping.Run``'s step loop that can change the
run: it returns to Python after a step that left the constraints farther
than the run's bound (``Run._restart_if_drifted`` then projects and
restarts CVODE, or raises the bound), that moved a winding angle past its
bound or a joint near gimbal lock, that left a non-finite state, or that
reached the output time; and at the monitor's checkpoints and after a
budget of steps (signals), as the open trees' loop does.
"""

from __future__ import annotations

import numpy as np
from numba import carray, types
from numba.extending import register_jitable

from .cache import njit
from .cvode_callbacks import _call_cvode, _call_p_p, _cfunc, _voidp, _watched
from .equations import RESIDUALS, tree_equations
from .loop_layout import LoopLayout
from .loop_jacobian import loop_state_jacobian
from .loop_jtimes import H_VALID, jtimes_size, keep_factors
from .loops import loop_newton_factor, loop_newton_solve, loop_rhs_factors_into, loop_rhs_into, loop_rhs_work_size
from .step_projection import KEPT, MOVED, REFUSED, step_projection
from .views import view2

__all__ = ["rhs", "rate_into", "evaluate", "work_size", "jac", "psetup", "psolve", "project", "advance", "drift", "driver", "UD_SIZE", "REACHED", "CHECKPOINT", "PAUSED", "WATCH",
           "DRIFTED", "NOT_FINITE"]

#: slots of the user_data array (int64): addresses (A_*), sizes, counters, the failure's status
(A_GETPTR, N, M, NB, A_FL, N_FL, A_IT, N_IT, A_FG, N_FG, A_IX, N_IX,
 A_ROW_BODY, A_ROW_COORD, A_ROOT_OF, A_ROW_ROOTS, A_VISIT_PTR, A_VISIT, A_ROOT_PTR, A_ROOT_ROWS, A_ORDER, A_POSITION,
 MROWS, N_VISIT, N_ROOTS, N_ROOT_ROWS, BAND, N_DRV, A_DRV, A_REAL, RANK_LIMIT, A_K, A_C, A_X,
 A_SW, A_SV, A_W, A_BODY, A_U, A_DUT, A_DINV, A_LIFT, A_KB, A_D, A_DF, A_V, V_ROWS, F_KEPT, F_STATUS, F_VALID,
 SETUPS, JACS, RHS, PSOLVES, FACTORS, STATUS, NONFINITE_FLAG, A_FAIL_T, A_FAIL_Y, A_OFFSET, HAS_OFFSET,
 PROJECTIONS, PROJ_REFUSED, PROJ_OK) = range(64)
A_MATDATA = 64  # SUNDenseMatrix_Data, for jac
A_WORK = 65  # the work array of rhs (work_size)
#: the buffer of the compiled J v (flexmb.kernels.cvode_loop_jtimes; A_JT 0: none), its length, K's eigenvectors' room
A_JT, N_JT, N_V = 66, 67, 68
UD_SIZE = 69
#: the float parameters (A_REAL): the rank tolerance, the singular window, the factors' gamma and smallest pivot;
#: for :func:`project`, the residual below which a state is kept, the Newton tolerance, the largest correction
#: per unit residual, and the time of the last state it left on the constraints
R_TOL, R_WINDOW, R_GAMMA, R_SMALLEST, R_PROJ_TOL, R_NEWTON_TOL, R_GAIN, R_PROJ_T = range(8)
N_REAL = 8
#: the loop's return codes (CVODE's negative flags pass through)
REACHED, CHECKPOINT, PAUSED, WATCH, DRIFTED, NOT_FINITE = 0, 1, 2, 3, 4, 5
#: the status of a failed callback when it is not a joint's index
NONFINITE, SINGULAR_PRECONDITIONER = -2, -3


# ----------------------------------------------------------------------------- the model from user_data

@njit(cache=True)
def _ud(user_data):
    return carray(user_data, (UD_SIZE,), np.int64)


@njit(cache=True)
def _f1(addr, n):
    return carray(_voidp(addr), (n,), np.float64)


@njit(cache=True)
def _f2(addr, n, k):
    return carray(_voidp(addr), (n, k), np.float64)


@njit(cache=True)
def _i1(addr, n):
    return carray(_voidp(addr), (n,), np.int64)


@njit(cache=True)
def _i2(addr, n, k):
    return carray(_voidp(addr), (n, k), np.int64)


@njit(cache=True)
def _vector(ud, v, m):
    """The data of the N_Vector ``v`` (``N_VGetArrayPointer``), length m."""
    return carray(_call_p_p(ud[A_GETPTR], v), (m,), np.float64)


@njit(cache=True)
def _state(ud, v, m):
    """The true state ``y = z + c`` of the integrator's ``z`` (the N_Vector ``v``; c: the winding offsets)."""
    z = _vector(ud, v, m)
    if not ud[HAS_OFFSET]:
        return z
    return z + _f1(ud[A_OFFSET], m)


@njit(cache=True)
def _packed(ud):
    fl = carray(_voidp(ud[A_FL]), (ud[N_FL],), np.float64)
    it = carray(_voidp(ud[A_IT]), (ud[N_IT],), np.int64)
    fg = carray(_voidp(ud[A_FG]), (ud[N_FG],), np.bool_)
    ix = carray(_voidp(ud[A_IX]), (ud[N_IX], 4), np.int64)
    return fl, it, fg, ix


@njit(cache=True)
def _layout(ud):
    m, nb = ud[MROWS], ud[NB]
    return LoopLayout(_i2(ud[A_ROW_BODY], m, 2), _i1(ud[A_ROW_COORD], m), _i1(ud[A_ROOT_OF], nb),
                      _i2(ud[A_ROW_ROOTS], m, 2), _i1(ud[A_VISIT_PTR], m + 1), _i1(ud[A_VISIT], ud[N_VISIT]),
                      _i1(ud[A_ROOT_PTR], ud[N_ROOTS] + 1), _i1(ud[A_ROOT_ROWS], ud[N_ROOT_ROWS]),
                      _i1(ud[A_ORDER], m), _i1(ud[A_POSITION], m), ud[BAND])


@njit(cache=True)
def _fail(ud, status, t, y, flag):
    """Record why a callback failed (its status, the time, the true state) and return CVODE's flag for it."""
    ud[STATUS] = status
    _f1(ud[A_FAIL_T], 1)[0] = t
    _f1(ud[A_FAIL_Y], ud[M])[:] = y
    return flag


# ----------------------------------------------------------------------------- the callbacks

@njit(cache=True)
def driver(drv, k, t):
    """Position, speed and acceleration of driver ``k`` at ``t``, as its callables give them (flexmb.drivers).

    ``drv[k]`` is ``(column, kind, p1, p2, p3)``: kind 0, constant speed
    (``p1 + p2 t``); kind 1, harmonic (``p1 + p2 sin(p3 t)``).
    """
    if drv[k, 1] == 0.0:
        return drv[k, 2] + drv[k, 3] * t, drv[k, 3], 0.0
    o, a, w = drv[k, 2], drv[k, 3], drv[k, 4]
    return o + a * np.sin(w * t), a * w * np.cos(w * t), -a * w * w * np.sin(w * t)


@njit(cache=True)
def _drivers(ud):
    return _f2(ud[A_DRV], max(ud[N_DRV], 1), 5)


@register_jitable
def work_size(nb, n, m, n_drv):
    """Length of the work array (user_data's ``A_WORK``) of :func:`rhs`.

    Parameters
    ----------
    nb, n, m, n_drv : int
        Numbers of bodies, speeds, rows and drivers.

    Returns
    -------
    int
        The length.
    """
    return 6 * (nb + 1) + n + m + n_drv + loop_rhs_work_size(nb, n, m)


@njit(cache=True)
def rate_into(ud, t, yv, out):
    """The state rate ``(xd, xdd, 0)`` at the true state ``yv`` into ``out`` by :func:`evaluate`, counted.

    The one right-hand side of the compiled loops: CVODE's :func:`rhs` and
    the generalized-alpha loop (:mod:`flexmb.kernels.genalpha_loops`) call it.

    Returns
    -------
    status : int
        0, 2 (not finite), or another (a freedom that moves no mass and
        that no loop fixes: ``kept`` names its joint).
    kept : int
        loop_rhs_into's ``kept``.
    """
    ud[RHS] += 1
    kept, status = evaluate(ud, t, yv, out)
    return status, kept


@_cfunc(types.int32(types.float64, types.voidptr, types.voidptr, types.voidptr))
def rhs(t, y, ydot, user_data):
    """CVRhsFn: ``ydot = (xd, xdd)`` by :func:`rate_into`; NONFINITE_FLAG if not finite, -1 if massless."""
    ud = _ud(user_data)
    m = ud[M]
    yv = _state(ud, y, m)
    status, kept = rate_into(ud, t, yv, _vector(ud, ydot, m))
    if status == 0:
        return 0
    if status == 2:
        return _fail(ud, NONFINITE, t, yv, ud[NONFINITE_FLAG])
    return _fail(ud, kept, t, yv, -1)  # a freedom that moves no mass and that no loop fixes


@njit(cache=True)
def _work(ud):
    """:func:`rhs`'s work array, and where loop_rhs_factors_into's part of it starts."""
    n, nb, mr, n_drv = ud[N], ud[NB], ud[MROWS], ud[N_DRV]
    return _f1(ud[A_WORK], work_size(nb, n, mr, n_drv)), 6 * (nb + 1) + n + mr + n_drv


@njit(cache=True)
def evaluate(ud, t, yv, out):
    """``out = (xd, xdd)`` at the true state ``yv`` by loop_rhs_factors_into, work in ``A_WORK``; (kept, status).

    Where the loops' GMRES takes the compiled ``J v`` (``A_JT`` set), the
    spatial path (:func:`~flexmb.kernels.loops.loop_rhs_factors_into`)
    evaluates, its kinematics and factors left in the work and K's factors
    kept for the product (:func:`~flexmb.kernels.loop_jtimes.keep_factors`),
    which reads them; otherwise :func:`~flexmb.kernels.loops.loop_rhs_into`,
    which takes the planar path for a planar model.
    """
    n, m, nb = ud[N], ud[M], ud[NB]
    real = _f1(ud[A_REAL], N_REAL)
    mr, n_drv = ud[MROWS], ud[N_DRV]
    work, o = _work(ud)
    zeros = view2(work, 0, 2 * (nb + 1), 3)  # the Python loads (none): force0, torque0 and generalized0
    zeros[:, :] = 0.0
    p = o - n - mr - n_drv
    generalized0, lam, gamma_d = work[p : p + n], work[p + n : p + n + mr], work[p + n + mr : o]
    generalized0[:] = 0.0
    drv = _drivers(ud)
    for k in range(n_drv):
        gamma_d[k] = driver(drv, k, t)[2]
    for i in range(n):
        out[i] = yv[n + i]
    for i in range(2 * n, m):  # states nothing depends on
        out[i] = 0.0
    if not ud[A_JT]:  # (a planar model: the planar path)
        kept, smallest, status = loop_rhs_into(_packed(ud), _layout(ud), yv, n, work[:0], zeros[: nb + 1],
                                               zeros[nb + 1 :], generalized0, gamma_d, real[R_TOL], real[R_WINDOW],
                                               ud[RANK_LIMIT], out[n : 2 * n], lam, work[o:])
        return kept, status
    kept, smallest, status, factors = loop_rhs_factors_into(_packed(ud), _layout(ud), yv, n, work[:0],
                                                            zeros[: nb + 1], zeros[nb + 1 :], generalized0, gamma_d,
                                                            real[R_TOL], real[R_WINDOW], ud[RANK_LIMIT], out[n : 2 * n],
                                                            lam, work[o:])
    jt = _f1(ud[A_JT], jtimes_size(n, m, mr, ud[BAND], ud[N_V]))
    jt[H_VALID] = 0.0
    if status == 0:
        keep_factors(jt, yv, out[n : 2 * n], n, m, mr, ud[BAND], factors)
    return kept, status


@_cfunc(types.int32(types.float64, types.voidptr, types.voidptr, types.voidptr, types.voidptr, types.voidptr,
                    types.voidptr, types.voidptr))
def jac(t, y, fy, J, user_data, tmp1, tmp2, tmp3):
    """CVLsJacFn: the dense state Jacobian by :func:`~flexmb.kernels.loop_jacobian.loop_state_jacobian`.

    K and C are the diagonal terms of the preconditioner's slots; -1 (the
    cause recorded as :func:`rhs` records it) if the state's equations fail.
    """
    ud = _ud(user_data)
    n, m = ud[N], ud[M]
    yv = _state(ud, y, m)
    real = _f1(ud[A_REAL], N_REAL)
    ud[JACS] += 1
    drv, gamma_d = _drivers(ud), np.empty(ud[N_DRV])
    for k in range(ud[N_DRV]):
        gamma_d[k] = driver(drv, k, t)[2]
    full = np.empty((m, m))
    status, body = loop_state_jacobian(_packed(ud), _layout(ud), yv, n, _f1(ud[A_K], n), _f1(ud[A_C], n), gamma_d,
                                       real[R_TOL], real[R_WINDOW], ud[RANK_LIMIT], full)
    if status == 2:
        return _fail(ud, NONFINITE, t, yv, -1)
    if status:
        return _fail(ud, body, t, yv, -1)
    carray(_call_p_p(ud[A_MATDATA], J), (m, m), np.float64)[:, :] = full.T  # SUNDIALS' column-major data
    return 0


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
    yv = _state(ud, y, ud[M])
    x = _f1(ud[A_X], n)
    for i in range(n):
        x[i] = yv[i]
    ud[F_VALID] = 0
    ud[SETUPS] += 1
    flag[0] = 1
    return 0


@njit(cache=True)
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
    real = _f1(ud[A_REAL], N_REAL)
    real[R_GAMMA], real[R_SMALLEST] = gamma, smallest
    ud[FACTORS] += 1


@njit(cache=True)
def _load(ud):
    """The factors in the buffers, as loop_newton_factor returns them."""
    n, m, k = ud[N], ud[MROWS], ud[V_ROWS]
    factors = (_f2(ud[A_U], n, 6), _f2(ud[A_DUT], n, 6), _f2(ud[A_DINV], n, 6), _f1(ud[A_LIFT], n),
               _f2(ud[A_KB], m, ud[BAND] + 1), _f1(ud[A_D], m), _f1(ud[A_DF], m), ud[F_KEPT],
               _f1(ud[A_REAL], N_REAL)[R_SMALLEST], _f2(ud[A_V], k, k), ud[F_STATUS])
    return (_f2(ud[A_SW], n, 3), _f2(ud[A_SV], n, 3), _f2(ud[A_W], m, 12).reshape((m, 2, 6)),
            _i2(ud[A_BODY], m, 2), factors)


@_cfunc(types.int32(types.float64, types.voidptr, types.voidptr, types.voidptr, types.voidptr, types.float64,
                    types.float64, types.int32, types.voidptr))
def psolve(t, y, fy, rv, zv, gamma, delta, lr, user_data):
    """CVLsPrecSolveFn: ``(I - gamma J) z ~ r`` in O(n m), as LoopNewtonPreconditioner.solve; -1 if singular."""
    ud = _ud(user_data)
    n, m = ud[N], ud[M]
    r = _vector(ud, rv, m)
    z = _vector(ud, zv, m)
    K, C = _f1(ud[A_K], n), _f1(ud[A_C], n)
    real = _f1(ud[A_REAL], N_REAL)
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
        return _fail(ud, SINGULAR_PRECONDITIONER, t, _state(ud, y, m), -1)
    for i in range(n):
        z2 = r[n + i] - gamma * v[i]
        z[n + i] = z2
        z[i] = r[i] + gamma * z2
    for i in range(2 * n, m):
        z[i] = r[i]
    return 0


# ----------------------------------------------------------------------------- the step loop

@njit(cache=True)
def drift(ud, t, y):
    """The largest constraint residual at the true state ``(t, y)``, as ``System._constraint_residuals`` gives it.

    The cut joints' position and velocity residuals (``tree_equations(...,
    RESIDUALS, ...)``) and the drivers' (:func:`driver`).
    """
    position, velocity = _residuals(ud, t, y)
    return max(position, velocity)


@njit(cache=True)
def _residuals(ud, t, y):
    """The largest position and the largest velocity residual at ``(t, y)`` (:func:`drift`'s two parts)."""
    n, nb = ud[N], ud[NB]
    zeros = np.zeros((nb + 1, 3))
    res = tree_equations(_packed(ud), y, n, RESIDUALS, np.zeros(0), zeros, zeros, np.zeros(n))[2]
    position, velocity = res[0], res[1]
    drv = _drivers(ud)
    for k in range(ud[N_DRV]):
        c = int(drv[k, 0])
        p, v, _ = driver(drv, k, t)
        position = max(position, abs(y[c] - p))
        velocity = max(velocity, abs(y[n + c] - v))
    return position, velocity


@njit(cache=True)
def advance(lp, ud, t_stop, t_bound, bound, steps, budget, angles, wind, gimbal, limit):
    """Step CVODE (``CV_ONE_STEP``) until a step needs the run's attention, or up to ``t_stop``.

    Parameters
    ----------
    lp : ndarray of int64
        As for :func:`flexmb.kernels.cvode_callbacks.advance`.
    ud : ndarray of int64
        The callbacks' user_data (:data:`UD_SIZE` slots).
    t_stop, t_bound : float
        The time to reach (an output time) and the end of the run (CVODE's stop time).
    bound : float
        The run's drift bound: the loop returns DRIFTED after a step whose
        state leaves the constraints by more than ``bound`` (:func:`drift`;
        not evaluated after a step whose state CVODE's projection,
        :func:`project`, left on the constraints); the run decides (it may
        raise its bound instead of restarting).
    steps : ndarray of float
        The times reached by the steps, for the monitor (CHECKPOINT when full; length 0: none).
    budget : int
        Steps after which the loop returns PAUSED (signals).
    angles, wind, gimbal, limit
        The winding angles and their bound, the ``ry`` of joints in Bryant
        angles and their limit: WATCH after a step that one of them flags
        (:func:`flexmb.kernels.cvode_callbacks._watched`).

    Returns
    -------
    code : int
        REACHED (the last step ended at or past ``t_stop``), CHECKPOINT,
        PAUSED, WATCH, DRIFTED, NOT_FINITE (the step's state is not finite),
        or CVODE's flag (< 0).
    n_steps : int
        Steps taken in this call.
    """
    tret = carray(_voidp(lp[6]), (1,), np.float64)
    z = carray(_voidp(lp[4]), (lp[7],), np.float64)
    m = lp[7]
    tn = tret[0]
    k = 0
    cap = steps.shape[0]
    while tn < t_stop:
        flag = _call_cvode(lp[0], lp[2], t_bound, lp[3], lp[6], 2)
        if flag < 0:
            return flag, k
        t_new = tret[0]
        if t_new == tn:  # after an interpolated output behind its time, one-step mode returns that time again
            continue
        if k < cap:
            steps[k] = t_new
        k += 1
        tn = t_new
        if not np.all(np.isfinite(z)):
            return NOT_FINITE, k
        if tn < t_bound and not _projected_at(ud, tn) and drift(ud, tn, z + _f1(ud[A_OFFSET], m)
                                                                 if ud[HAS_OFFSET] else z) > bound:
            return DRIFTED, k
        if (len(angles) and tn < t_bound or len(gimbal)) and _watched(z, angles if tn < t_bound else angles[:0],
                                                                      wind, gimbal, limit):
            return WATCH, k
        if k == cap and tn < t_stop:
            return CHECKPOINT, k
        if k == budget and tn < t_stop:
            return PAUSED, k
    return REACHED, k


# ----------------------------------------------------------------------------- CVODE's projection

@njit(cache=True)
def _step_projection(ud, t, y, tol, newton_tol, gain):
    """:func:`.step_projection` of the true state ``y`` at ``t`` with the run's rows, drivers and rank settings."""
    nd, real = ud[N_DRV], _f1(ud[A_REAL], N_REAL)
    drv = _drivers(ud)
    cols, p_d, v_d = np.empty(nd, np.int64), np.empty(nd), np.empty(nd)
    for k in range(nd):
        cols[k] = int(drv[k, 0])
        p_d[k], v_d[k], _ = driver(drv, k, t)
    return step_projection(_packed(ud), _layout(ud), y, ud[N], cols, p_d, v_d, tol, newton_tol, gain, real[R_TOL],
                           real[R_WINDOW], ud[RANK_LIMIT])


@_cfunc(types.int32(types.float64, types.voidptr, types.voidptr, types.float64, types.voidptr, types.voidptr))
def project(t, ycur, corr, eps, err, user_data):
    """CVProjFn: ``corr`` = the state projected onto the constraints (:func:`.step_projection`) less ``ycur``.

    A state whose position and velocity residuals (:func:`_residuals`'s) are
    within ``R_PROJ_TOL`` is kept (``corr = 0``); one whose positions are
    within it has its speeds projected only. A projection that does not
    converge, is not finite, or moves the state by more than ``R_GAIN``
    times the residual (near a singular position, where the minimum-norm
    step divides by a tiny singular value; ``flexmb.output_projection``'s
    rule) is refused: ``corr = 0``, counted in ``PROJ_REFUSED``, and the
    step loop's drift check (:func:`advance`) hands the state to the run,
    which projects and restarts as without CVODE's projection. Otherwise
    the time is kept (``R_PROJ_T``) and ``PROJ_OK`` says what was done
    (1: kept, its residuals within ``R_PROJ_TOL``; 2: moved onto the
    constraints): the step loop then skips its drift check. The error
    estimate is not projected (``CVodeSetProjErrEst(mem, 0)``); ``err`` is
    not used. CVODE calls it on every attempt of a step, before its error
    test: the last call before a step is accepted is that step's.
    """
    ud = _ud(user_data)
    n, m, nd = ud[N], ud[M], ud[N_DRV]
    y = _state(ud, ycur, m)
    c = _vector(ud, corr, m)
    c[:] = 0.0
    real = _f1(ud[A_REAL], N_REAL)
    ud[PROJ_OK] = 0
    what, position, velocity, x, v = _step_projection(ud, t, y, real[R_PROJ_TOL], real[R_NEWTON_TOL], real[R_GAIN])
    if what == REFUSED:
        ud[PROJ_REFUSED] += 1
    if what == KEPT or what == MOVED:
        ud[PROJ_OK], real[R_PROJ_T] = 1 + what, t
    if what != MOVED:  # (a residual not finite: left to the step loop's check)
        return 0
    for i in range(n):
        c[i] = x[i] - y[i]
        c[n + i] = v[i] - y[n + i]
    ud[PROJECTIONS] += 1
    return 0


@njit(cache=True)
def _projected_at(ud, t):
    """Whether CVODE's projection (:func:`project`) left the state of time ``t`` on the constraints."""
    return ud[PROJ_OK] >= 1 and _f1(ud[A_REAL], N_REAL)[R_PROJ_T] == t
