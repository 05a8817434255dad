"""CVODE's callbacks for an open tree as numba C callbacks, and CVODE's step loop compiled (issue 31 prototype).

The right-hand side, the dense Jacobian and the Newton preconditioner of an
open tree whose joints and force elements are all compiled (the models whose
``System._packed_open`` is set: B1, B2) are C functions that CVODE calls
directly (``numba.cfunc``). They call flexmb's own kernels
(:func:`~flexmb.kernels.articulated.open_tree_rhs`, the articulated-body
solves, the geometric stiffness) on the model's packed arrays. The model
reaches them only through CVODE's ``user_data``: a pointer to an int64
array (the slots ``A_GETPTR`` ... below) holding the addresses and sizes of the packed buffers,
of the diagonal springs and dampers, of the preconditioner's work arrays
and of SUNDIALS' ``N_VGetArrayPointer`` and ``SUNDenseMatrix_Data`` (called
through their addresses). The callbacks' signatures therefore do not depend
on the model: they compile once per installation, and their machine code
is cached (:class:`_Cache`, stamped with flexmb's kernel sources and this
file, loaded without numba's compiler registries as flexmb's kernels are).

:func:`advance` is CVODE's step loop between two output times, compiled:
``CVode(..., CV_ONE_STEP)`` called through its address until the output time
is passed, then ``CVodeGetDky`` there (what flexmb's ``CVODE.advance`` does
one Python call per step). It returns to Python only at the output time, at
a checkpoint of flexmb's resolution monitor (the steps' times recorded in
between), after a budget of steps (so that Ctrl-C and other signals are
handled while a long interval runs), or on a CVODE failure.

This is a benchmark's prototype, not part of flexmb.
"""

from __future__ import annotations

import functools
import hashlib
import os

import numpy as np
from llvmlite import ir
from numba import carray, types
from numba.core import cgutils, sigutils
from numba.core.ccallback import CFunc
from numba.extending import intrinsic

from flexmb.kernels import cache as _kc
from flexmb.kernels.articulated import articulated_accelerations, mass_times, open_tree_accelerations, \
    open_tree_rhs, solve_spd
from flexmb.kernels.dynamics import composite_inertias, mass_matrix, spatial_inertias
from flexmb.kernels.loads import apply_load_tables
from flexmb.kernels.packing import unpack
from flexmb.kernels.tangent import geometric_stiffness
from flexmb.kernels.tree import tree_state

#: slots of the user_data array (int64): addresses (A_*), sizes and counters
(A_GETPTR, A_MATDATA, N, M, A_FL, N_FL, A_IT, N_IT, A_FG, N_FG, A_IX, N_IX, A_K, A_C, A_SPATIAL, A_SW, A_SV, A_R, NB,
 SETUPS, JACS, RHS, STATUS, A_FAIL_T, NONFINITE_FLAG) = range(25)
UD_SIZE = 25
#: the loop's return codes (CVODE's negative flags pass through)
REACHED, CHECKPOINT, PAUSED = 0, 1, 2


# ----------------------------------------------------------------------------- the cache

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
    """flexmb's kernel cache, stamped with the kernels' sources and this file's."""

    _impl_class = _Impl


class _LazyCFunc:
    """A numba C callback compiled (or loaded from the cache) when its address is first asked for."""

    def __init__(self, func, sig):
        self._func, self._sig, self._cf = func, sig, None
        self.__doc__ = func.__doc__

    @property
    def address(self) -> int:
        """The callback's address (loading its machine code on first use)."""
        if self._cf is None:
            cf = CFunc(self._func, sigutils.normalize_signature(self._sig), locals={}, options={"nopython": True})
            cf._cache = _Cache(self._func)
            cf.compile()
            self._cf = cf
        return self._cf.address


def _cfunc(sig):
    return lambda func: _LazyCFunc(func, sig)


def _cached_njit(func):
    import numba

    dispatcher = numba.njit(func)
    dispatcher._cache = _Cache(dispatcher.py_func)
    return dispatcher


# ----------------------------------------------------------------------------- raw pointers

@intrinsic
def _voidp(typingctx, addr):
    """The address ``addr`` (an integer) as a ``void*``."""
    def codegen(context, builder, sig, args):
        return builder.inttoptr(args[0], cgutils.voidptr_t)
    return types.voidptr(addr), codegen


@intrinsic
def _call_p_p(typingctx, fn, arg):
    """``((void* (*)(void*)) fn)(arg)``: N_VGetArrayPointer, SUNDenseMatrix_Data."""
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

@_cached_njit
def _ud(user_data):
    return carray(user_data, (UD_SIZE,), np.int64)


@_cached_njit
def _floats(addr, n):
    return carray(_voidp(addr), (n,), np.float64)


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
def _fail(ud, status, t, flag):
    """Record why a callback failed (its status, the time) and return CVODE's flag for it."""
    ud[STATUS] = status
    _floats(ud[A_FAIL_T], 1)[0] = t
    return flag


# ----------------------------------------------------------------------------- the callbacks

@_cfunc(types.int32(types.float64, types.voidptr, types.voidptr, types.voidptr))
def rhs(t, y, ydot, user_data):
    """CVRhsFn: ``ydot = (xd, xdd)`` by open_tree_rhs; NONFINITE_FLAG if not finite, -1 if singular."""
    ud = _ud(user_data)
    n, m = ud[N], ud[M]
    yv = _vector(ud, y, m)
    out = _vector(ud, ydot, m)
    ud[RHS] += 1
    rate, status = open_tree_rhs(_packed(ud), yv, np.zeros(n))
    for i in range(2 * n):
        out[i] = rate[i]
    for i in range(2 * n, m):  # states nothing depends on
        out[i] = 0.0
    if status == -1:
        return 0
    if status >= 0 and np.all(np.isfinite(yv)):  # a joint whose articulated inertia is singular
        return _fail(ud, status, t, -1)
    return _fail(ud, -2, t, ud[NONFINITE_FLAG])  # not finite (a non-finite state breaks the solve too)


@_cached_njit
def open_tree_jacobian(packed, y, K, C):
    """The state Jacobian ``[[0, I], [A^-1 (G - K), -A^-1 C]]`` of an open tree with diagonal springs and dampers.

    ``System.state_jacobian`` of a model whose coordinate terms are the
    diagonal K and C (no point forces, no pair or velocity tangents): A by
    composite inertias, G by the geometric stiffness of the compiled loads
    and of the inertia forces of the accelerations, ``A^-1`` by Cholesky.
    Returns the (2n, 2n) matrix and False if A is not positive definite.
    """
    tree, tables, _ = unpack(packed)
    n = K.shape[0]
    x = y[:n]
    xd = y[n : 2 * n]
    R, origin, r, omega, v, alpha, acc, jp, Sw, Sv = tree_state(tree, x, xd)
    nb1 = R.shape[0]
    force = np.zeros((nb1, 3))
    torque = np.zeros((nb1, 3))
    generalized = np.zeros(n)
    apply_load_tables(tables, tree.mass, R, origin, r, omega, v, x, xd, force, torque, generalized, np.zeros(0))
    xdd, bad = open_tree_accelerations(tree.parent, tree.coord_start, R, r, omega, alpha, acc, tree.mass,
                                       tree.inertia, Sw, Sv, force, torque, generalized, np.zeros(n))
    Iw, spatial = spatial_inertias(R, r, tree.mass, tree.inertia)
    IC = composite_inertias(tree.parent, spatial)
    A = mass_matrix(tree.parent, tree.coord_start, tree.coord_body, IC, Sw, Sv)
    G = geometric_stiffness(tree.parent, tree.coord_start, tree.coord_body, Sw, Sv, xdd, r, omega, v, alpha, acc,
                            Iw, tree.mass, IC, force, torque)
    X = np.zeros((n, 2 * n))
    for i in range(n):
        for j in range(n):
            X[i, j] = G[i, j]
        X[i, i] -= K[i]
        X[i, n + i] = -C[i]
    Y = np.empty((n, 2 * n))
    J = np.zeros((2 * n, 2 * n))
    ok = solve_spd(A, X, Y)
    for i in range(n):
        J[i, n + i] = 1.0
        for j in range(2 * n):
            J[n + i, j] = Y[i, j]
    return J, ok


@_cfunc(types.int32(types.float64, types.voidptr, types.voidptr, types.voidptr, types.voidptr, types.voidptr,
                    types.voidptr, types.voidptr))
def jac(t, y, fy, Jmat, user_data, tmp1, tmp2, tmp3):
    """CVLsJacFn: the dense state Jacobian (column-major, SUNDenseMatrix_Data); 1 if not finite, -1 if singular."""
    ud = _ud(user_data)
    n, m = ud[N], ud[M]
    yv = _vector(ud, y, m)
    ud[JACS] += 1
    J, ok = open_tree_jacobian(_packed(ud), yv, _floats(ud[A_K], n), _floats(ud[A_C], n))
    if not ok:
        return _fail(ud, -3, t, -1)
    data = carray(_call_p_p(ud[A_MATDATA], Jmat), (m * m,), np.float64)
    finite = True
    for j in range(m):
        for i in range(m):
            value = J[i, j] if i < 2 * n and j < 2 * n else 0.0
            data[i + j * m] = value
            finite = finite and np.isfinite(value)
    return 0 if finite else _fail(ud, -2, t, 1)


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
    yv = _vector(ud, y, m)
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
        return _fail(ud, bad, t, -1)
    for i in range(n):
        z[i] = r1[i] + gamma * z2[i]
        z[n + i] = z2[i]
    for i in range(2 * n, m):
        z[i] = r[i]
    return 0


# ----------------------------------------------------------------------------- the step loop

@_cached_njit
def advance(lp, t_stop, t_bound, steps, budget):
    """Step CVODE (``CV_ONE_STEP``) until ``t_stop``; the state there in the output vector.

    Parameters
    ----------
    lp : ndarray of int64
        ``[CVode, CVodeGetDky, mem, y N_Vector, y data, output N_Vector, tret (double*), m,
        N_VGetArrayPointer]``: addresses and the state's length.
    t_stop, t_bound : float
        The output time and the end of the run (CVODE's ``tout`` in one-step mode, as flexmb gives it).
    steps : ndarray of float
        The times reached by the steps, recorded for the monitor; the loop returns CHECKPOINT when it is
        full (length 0: none recorded).
    budget : int
        Steps after which the loop returns PAUSED, so that Python handles signals (Ctrl-C) meanwhile.

    Returns
    -------
    code : int
        REACHED (the state at ``t_stop`` is in the output vector), CHECKPOINT, PAUSED, or CVODE's flag
        (< 0).
    n_steps : int
        Steps taken in this call.
    """
    tret = carray(_voidp(lp[6]), (1,), np.float64)
    y = carray(_voidp(lp[4]), (lp[7],), np.float64)
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
        if k == cap and tn < t_stop:
            return CHECKPOINT, k
        if k == budget and tn < t_stop:
            return PAUSED, k
    if tn > t_stop:
        flag = _call_dky(lp[1], lp[2], t_stop, 0, lp[5])
        if flag < 0:
            return flag, k
        return REACHED, k
    out = carray(_call_p_p(lp[8], _voidp(lp[5])), (lp[7],), np.float64)
    out[:] = y
    return REACHED, k
