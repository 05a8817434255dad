"""CVODE's callbacks for an open tree as C functions, and CVODE's step loop between two output times, compiled.

The right-hand side and the O(n) Newton preconditioner of an open tree whose joints and force elements are all compiled (a model whose
``System._packed_open`` is set) are C functions that CVODE calls directly
(``numba.cfunc``): they call the kernels of the other modules
(:func:`~flexmb.kernels.articulated.open_tree_rhs`, the articulated-body
solves) on the model's packed arrays. (A dense Jacobian is flexmb's own
``System.state_jacobian``, called from Python a few times per run: one
implementation of it.) The model
reaches them only through CVODE's ``user_data``: a pointer to an int64
array (the slots ``A_GETPTR`` ... below) holding the addresses and sizes of
the packed buffers, of the diagonal springs and dampers, of the winding
offsets, of the preconditioner's work arrays, and of SUNDIALS'
``N_VGetArrayPointer`` and ``SUNDenseMatrix_Data`` (called through their addresses). Their signatures therefore do not depend on the model: they
compile once per installation, and their machine code goes through
flexmb's kernel cache (:class:`~flexmb.kernels.cache.KernelCache`: the
shipped entries first, the whole-source stamp).

:func:`advance` is CVODE's step loop through the output times:
``CVode(..., CV_ONE_STEP)`` called through its address until an output
time is passed, then ``CVodeGetDky`` there, the state stored, and on to the
next. It returns to Python only at the end, at a progress mark, at a
checkpoint of the resolution monitor that has something to judge (the
steps are recorded, and the checkpoints where the monitor would find
nothing to analyse passed, in compiled code), when a watched angle leaves its winding bound
or a joint in Bryant angles nears gimbal lock (the checks flexmb's step
loop makes after every step, made here in compiled code), after a budget of
steps (so that Ctrl-C and other signals are handled while a long interval
runs), or on a CVODE failure (its flag).
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import carray, types
from numba.core import cgutils, sigutils
from numba.core.ccallback import CFunc
from numba.extending import intrinsic

from .articulated import articulated_accelerations, mass_times, open_tree_rhs_into, rhs_work_size
from .cache import KernelCache, njit
from .dynamics import spatial_inertias
from .packing import unpack
from .tree import tree_state
from .tree_jacobian import tree_state_jacobian

__all__ = ["rhs", "jac", "psetup", "psolve", "advance", "work_size", "UD_SIZE", "REACHED", "CHECKPOINT", "PAUSED", "WATCH",
           "GROW", "NOT_FINITE"]

#: slots of the user_data array (int64): addresses (A_*), sizes, counters, the failure's status
(A_GETPTR, N, M, A_FL, N_FL, A_IT, N_IT, A_FG, N_FG, A_IX, N_IX, A_K, A_C, A_SPATIAL, A_SW, A_SV, A_R, NB,
 SETUPS, JACS, RHS, STATUS, A_FAIL_T, NONFINITE_FLAG, A_OFFSET, HAS_OFFSET, A_FAIL_Y, A_WORK, N_WORK,
 A_MATDATA) = range(30)
UD_SIZE = 30
#: the loop's return codes (CVODE's negative flags pass through)
REACHED, CHECKPOINT, PAUSED, WATCH, GROW, NOT_FINITE = 0, 1, 2, 3, 4, 5
#: the status of a failed callback when it is not a joint's index
NONFINITE = -2


class _LazyCFunc:
    """A C callback compiled (or loaded from flexmb's kernel cache) when its address is first asked for."""

    #: the cache its machine code is kept in (a subclass may stamp it with other sources)
    cache_class = KernelCache

    def __init__(self, func, sig):
        self._func, self._sig, self._cf = func, sig, None
        self.__doc__ = func.__doc__
        self.__wrapped__ = func

    @property
    def address(self) -> int:
        """The callback's address (its machine code loaded or compiled on first use)."""
        if self._cf is None:
            cf = CFunc(self._func, sigutils.normalize_signature(self._sig), locals={}, options={"nopython": True})
            cf._cache = self.cache_class(self._func)
            cf.compile()
            self._cf = cf
        return self._cf.address


def _cfunc(sig):
    return lambda func: _LazyCFunc(func, sig)


# ----------------------------------------------------------------------------- raw pointers

@intrinsic
def _voidp(typingctx, addr):
    """The address ``addr`` (an integer) as a ``void*``."""
    def codegen(context, builder, sig, args):
        return builder.inttoptr(args[0], cgutils.voidptr_t)
    return types.voidptr(addr), codegen


@intrinsic
def _call_p_p(typingctx, fn, arg):
    """``((void* (*)(void*)) fn)(arg)``: N_VGetArrayPointer."""
    def codegen(context, builder, sig, args):
        fnty = ir.FunctionType(cgutils.voidptr_t, [cgutils.voidptr_t])
        return builder.call(builder.inttoptr(args[0], fnty.as_pointer()), [args[1]])
    return types.voidptr(fn, arg), codegen


@intrinsic
def _call_cvode(typingctx, fn, mem, tout, yout, tret, itask):
    """``CVode(mem, tout, yout, tret, itask)`` through its address (every pointer given as an int64)."""
    def codegen(context, builder, sig, args):
        vp, i32 = cgutils.voidptr_t, ir.IntType(32)
        fnty = ir.FunctionType(i32, [vp, ir.DoubleType(), vp, vp, i32])
        f = builder.inttoptr(args[0], fnty.as_pointer())
        return builder.call(f, [builder.inttoptr(args[1], vp), args[2], builder.inttoptr(args[3], vp),
                                builder.inttoptr(args[4], vp), builder.trunc(args[5], i32)])
    return types.int32(types.int64, types.int64, types.float64, types.int64, types.int64, types.int64), codegen


@intrinsic
def _call_dky(typingctx, fn, mem, t, k, dky):
    """``CVodeGetDky(mem, t, k, dky)`` through its address."""
    def codegen(context, builder, sig, args):
        vp, i32 = cgutils.voidptr_t, ir.IntType(32)
        fnty = ir.FunctionType(i32, [vp, ir.DoubleType(), i32, vp])
        f = builder.inttoptr(args[0], fnty.as_pointer())
        return builder.call(f, [builder.inttoptr(args[1], vp), args[2], builder.trunc(args[3], i32),
                                builder.inttoptr(args[4], vp)])
    return types.int32(types.int64, types.int64, types.float64, types.int64, types.int64), codegen


# ----------------------------------------------------------------------------- the model from user_data

@njit(cache=True)
def _ud(user_data):
    return carray(user_data, (UD_SIZE,), np.int64)


@njit(cache=True)
def _floats(addr, n):
    return carray(_voidp(addr), (n,), np.float64)


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
    return z + _floats(ud[A_OFFSET], m)


@njit(cache=True)
def _packed(ud):
    fl = carray(_voidp(ud[A_FL]), (ud[N_FL],), np.float64)
    it = carray(_voidp(ud[A_IT]), (ud[N_IT],), np.int64)
    fg = carray(_voidp(ud[A_FG]), (ud[N_FG],), np.bool_)
    ix = carray(_voidp(ud[A_IX]), (ud[N_IX], 4), np.int64)
    return fl, it, fg, ix


@njit(cache=True)
def _fail(ud, status, t, y, flag):
    """Record why a callback failed (its status, the time, the true state) and return CVODE's flag for it."""
    ud[STATUS] = status
    _floats(ud[A_FAIL_T], 1)[0] = t
    _floats(ud[A_FAIL_Y], ud[M])[:] = y
    return flag


def work_size(nb, n, m):
    """Length of the work array (user_data's ``A_WORK``) of :func:`rhs`.

    Parameters
    ----------
    nb : int
        Number of bodies.
    n : int
        Number of speeds.
    m : int
        Length of the integrator's state.

    Returns
    -------
    int
        ``open_tree_rhs_into``'s work, the zero armature (n) and the true state with its winding offsets (m).
    """
    return rhs_work_size(nb, n) + n + m


# ----------------------------------------------------------------------------- the callbacks

@_cfunc(types.int32(types.float64, types.voidptr, types.voidptr, types.voidptr))
def rhs(t, y, ydot, user_data):
    """CVRhsFn: ``ydot = (xd, xdd)`` by open_tree_rhs; NONFINITE_FLAG if not finite, -1 if a joint is singular."""
    ud = _ud(user_data)
    n, m, nb = ud[N], ud[M], ud[NB]
    out = _vector(ud, ydot, m)
    work = _floats(ud[A_WORK], ud[N_WORK])
    w = rhs_work_size(nb, n)
    armature = work[w : w + n]
    armature[:] = 0.0
    yv = _vector(ud, y, m)
    if ud[HAS_OFFSET]:  # the true state y = z + c, in the work array
        c = _floats(ud[A_OFFSET], m)
        z = yv
        yv = work[w + n : w + n + m]
        for i in range(m):
            yv[i] = z[i] + c[i]
    ud[RHS] += 1
    status = open_tree_rhs_into(_packed(ud), yv, n, armature, out, work[:w])
    for i in range(2 * n, m):  # states nothing depends on
        out[i] = 0.0
    if status == -1:
        return 0
    if status >= 0 and _finite(yv):  # a joint whose articulated inertia is singular
        return _fail(ud, status, t, yv, -1)
    return _fail(ud, NONFINITE, t, yv, ud[NONFINITE_FLAG])  # not finite (a non-finite state breaks the solve too)


@njit(cache=True)
def _finite(a):
    """Whether every entry of ``a`` is finite (a loop: ``np.all`` would load numba's array-math module)."""
    for i in range(a.shape[0]):
        if not np.isfinite(a[i]):
            return False
    return True


@_cfunc(types.int32(types.float64, types.voidptr, types.voidptr, types.voidptr, types.voidptr, types.voidptr,
                    types.voidptr, types.voidptr))
def jac(t, y, fy, J, user_data, tmp1, tmp2, tmp3):
    """CVLsJacFn: the dense state Jacobian by :func:`~flexmb.kernels.tree_jacobian.tree_state_jacobian`.

    K and C are the diagonal terms of the preconditioner's slots; -1 (the
    cause recorded as :func:`rhs` records it) if the state's equations fail.
    """
    ud = _ud(user_data)
    n, m = ud[N], ud[M]
    yv = _state(ud, y, m)
    ud[JACS] += 1
    full = np.empty((m, m))
    status, body = tree_state_jacobian(_packed(ud), yv, n, _floats(ud[A_K], n), _floats(ud[A_C], n), full)
    if status == 2:
        return _fail(ud, NONFINITE, t, yv, -1)
    if status:
        return _fail(ud, body, t, yv, -1)
    carray(_call_p_p(ud[A_MATDATA], J), (m, m), np.float64)[:, :] = full.T  # SUNDIALS' column-major data
    return 0


@_cfunc(types.int32(types.float64, types.voidptr, types.voidptr, types.int32, types.voidptr, types.float64,
                    types.voidptr))
def psetup(t, y, fy, jok, jcur, gamma, user_data):
    """CVLsPrecSetupFn: the mass distribution at ``y`` (kept while ``jok``), as NewtonPreconditioner.setup."""
    ud = _ud(user_data)
    flag = carray(jcur, (1,), np.int32)
    if jok and ud[SETUPS] > 0:
        flag[0] = 0
        return 0
    n, m, nb = ud[N], ud[M], ud[NB]
    yv = _state(ud, y, m)
    tree, _, _ = unpack(_packed(ud))
    R, origin, r, omega, v, alpha, acc, jp, Sw, Sv = tree_state(tree, yv[:n], yv[n : 2 * n])
    Iw, spatial = spatial_inertias(R, r, tree.mass, tree.inertia)
    _floats(ud[A_SPATIAL], nb * 36)[:] = spatial.ravel()
    _floats(ud[A_SW], n * 3)[:] = Sw.ravel()
    _floats(ud[A_SV], n * 3)[:] = Sv.ravel()
    _floats(ud[A_R], (nb + 1) * 3)[:] = r.ravel()
    ud[SETUPS] += 1
    flag[0] = 1
    return 0


@_cfunc(types.int32(types.float64, types.voidptr, types.voidptr, types.voidptr, types.voidptr, types.float64,
                    types.float64, types.int32, types.voidptr))
def psolve(t, y, fy, rv, zv, gamma, delta, lr, user_data):
    """CVLsPrecSolveFn: ``(I - gamma J) z ~ r`` in O(n), as NewtonPreconditioner.solve; -1 if singular."""
    ud = _ud(user_data)
    n, m, nb = ud[N], ud[M], ud[NB]
    r = _vector(ud, rv, m)
    z = _vector(ud, zv, m)
    tree, _, _ = unpack(_packed(ud))
    spatial = _floats(ud[A_SPATIAL], nb * 36).reshape((nb, 6, 6))
    Sw = _floats(ud[A_SW], n * 3).reshape((n, 3))
    Sv = _floats(ud[A_SV], n * 3).reshape((n, 3))
    centres = _floats(ud[A_R], (nb + 1) * 3).reshape((nb + 1, 3))
    K, C = _floats(ud[A_K], n), _floats(ud[A_C], n)
    r1 = r[:n].copy()
    rhs_ = mass_times(tree.parent, tree.coord_start, tree.coord_body, spatial, Sw, Sv, r[n : 2 * n].copy())
    rhs_ -= gamma * K * r1
    armature = gamma * C + gamma * gamma * K
    zeros = np.zeros((nb + 1, 3))
    z2, bad = articulated_accelerations(tree.parent, tree.coord_start, spatial, Sw, Sv, centres, zeros, zeros, rhs_,
                                        armature)
    if bad >= 0:
        return _fail(ud, bad, t, _state(ud, y, m), -1)
    for i in range(n):
        z[i] = r1[i] + gamma * z2[i]
        z[n + i] = z2[i]
    for i in range(2 * n, m):
        z[i] = r[i]
    return 0


# ----------------------------------------------------------------------------- the step loop

@njit(cache=True)
def _watched(y, angles, bound, gimbal, limit):
    """Whether an angle of ``y`` is farther than ``bound`` from zero or a ``gimbal`` angle has ``|cos| < limit``."""
    for i in angles:
        if abs(y[i]) > bound:
            return True
    for i in gimbal:
        if abs(np.cos(y[i])) < limit:
            return True
    return False


#: slots of the resolution monitor's state the step loop keeps (int64 ``mi``; float ``mf``): whether it
#: watches, the steps recorded since its last check (in ``hs``), its step count and next checkpoint; the run's
#: span, the scene's motion frequency (NaN: not known, every checkpoint returns), the start of the last step,
#: and the monitor's RESOLVE_STEP_LIMIT, FAR_ABOVE, RESOLVING_HW
LIVE, COUNT, N_STEPS, NEXT_CHECK = range(4)
T0, T1, F_MOTION, T_PREV, STEP_LIMIT, FAR, HW = range(7)


@njit(cache=True)
def _median(hs, count):
    """``flexmb.integrators.monitor.median`` of ``hs[:count]`` (the same arithmetic)."""
    s = np.sort(hs[:count])
    k = count // 2
    return s[k] if count % 2 else (s[k - 1] + s[k]) / 2


@njit(cache=True)
def _record(mi, hs, mf, t_old, t_new):
    """Record a step for the resolution monitor; True at a checkpoint where it has something to judge.

    A checkpoint at which ``ResolutionMonitor.step`` would find nothing to analyse (the run stays short at
    the median step's rate, or the steps are too long to resolve anything far above the motion) is passed
    here, as it passes it: the next checkpoint twice as far, the recorded steps cleared.
    """
    c = mi[COUNT]
    hs[c] = t_new - t_old
    mi[COUNT], mf[T_PREV] = c + 1, t_old
    mi[N_STEPS] += 1
    if mi[N_STEPS] < mi[NEXT_CHECK]:
        return False
    h = _median(hs, c + 1)
    if (mf[T1] - mf[T0]) / h <= mf[STEP_LIMIT] or h * 2 * np.pi * mf[FAR] * mf[F_MOTION] >= mf[HW]:
        mi[NEXT_CHECK] *= 2
        mi[COUNT] = 0
        return False
    return True


@njit(cache=True)
def advance(lp, stops, marks, j, t_bound, Y, budget, angles, bound, gimbal, limit, mi, hs, mf):
    """Step CVODE (``CV_ONE_STEP``) through the stops ``stops[j:]``, the state at each in a row of ``Y``.

    Parameters
    ----------
    lp : ndarray of int64
        ``[CVode, CVodeGetDky, mem, y N_Vector, y data, output N_Vector, tret (double*), m,
        N_VGetArrayPointer]``: addresses and the state's length.
    stops : ndarray of float
        The stops (output times, progress marks), increasing.
    marks : ndarray of bool
        The stops after which the loop returns PAUSED (progress marks: Python updates the bar there).
    j : int
        The first stop to reach.
    t_bound : float
        The end of the run (CVODE's ``tout`` in one-step mode, as flexmb gives it).
    Y : ndarray, shape (len(stops), m)
        Filled: the state at each stop reached (CVODE's interpolant where a step passed it).
    budget : int
        Steps after which the loop returns PAUSED, so that Python handles signals (Ctrl-C) meanwhile.
    angles : ndarray of int64
        The winding angles: the loop returns WATCH after a step ending before ``t_bound`` with one of them
        farther than ``bound`` from zero (flexmb.stepping's winding offsets move then).
    bound : float
        Their bound, rad.
    gimbal : ndarray of int64
        The ``ry`` of joints in Bryant angles: the loop returns WATCH after a step ending with
        ``|cos ry| < limit`` for one of them (flexmb.gimbal).
    limit : float
        Their limit.
    mi, hs, mf : ndarray
        The resolution monitor's state (slots LIVE ... above, the steps since its last check in ``hs``):
        the loop records the steps, passes the quiet checkpoints (:func:`_record`), returns CHECKPOINT at
        the others and GROW when ``hs`` is full.

    Returns
    -------
    code : int
        REACHED (every stop reached), CHECKPOINT, PAUSED, WATCH, GROW, NOT_FINITE (the state at stop ``j``
        is not finite), or CVODE's flag (< 0).
    j : int
        The next stop to reach.
    n_steps : int
        Steps taken in this call.
    """
    tret = carray(_voidp(lp[6]), (1,), np.float64)
    y = carray(_voidp(lp[4]), (lp[7],), np.float64)
    out = carray(_call_p_p(lp[8], _voidp(lp[5])), (lp[7],), np.float64)
    tn, k, checkpoint = tret[0], 0, False
    while j < stops.shape[0]:
        t_stop = stops[j]
        while tn < t_stop:
            if mi[LIVE] and mi[COUNT] == hs.shape[0]:
                return GROW, j, k
            flag = _call_cvode(lp[0], lp[2], t_bound, lp[3], lp[6], 2)
            if flag < 0:
                return flag, j, k
            t_new = tret[0]
            if t_new == tn:  # after an interpolated output behind its time, one-step mode returns that time again
                continue
            k += 1
            checkpoint = mi[LIVE] != 0 and _record(mi, hs, mf, tn, t_new)
            tn = t_new
            if (len(angles) and tn < t_bound or len(gimbal)) and _watched(y, angles if tn < t_bound else angles[:0],
                                                                          bound, gimbal, limit):
                return WATCH, j, k
            if checkpoint and tn < t_stop:
                return CHECKPOINT, j, k
            if k >= budget and tn < t_stop:
                return PAUSED, j, k
        if tn > t_stop:
            flag = _call_dky(lp[1], lp[2], t_stop, 0, lp[5])
            if flag < 0:
                return flag, j, k
        else:
            out[:] = y
        Y[j] = out
        if not np.all(np.isfinite(out)):
            return NOT_FINITE, j, k
        j += 1
        if checkpoint:
            return CHECKPOINT, j, k
        if k >= budget or marks[j - 1]:
            return PAUSED, j, k
    return REACHED, j, k
