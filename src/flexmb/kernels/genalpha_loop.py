"""The generalized-alpha step loop between two output times, compiled, for open trees with compiled loads.

:class:`flexmb.genalpha.compiled.CompiledGeneralizedAlpha` hands its steps
to :func:`advance`: the steps of :class:`flexmb.genalpha.GeneralizedAlpha`
(``_step_impl``, ``_newton``, ``_accept``), with the right-hand side
:func:`~flexmb.kernels.articulated.open_tree_rhs` called directly on the
model's packed arrays (``System._packed_open``) and the arithmetic of
:mod:`flexmb.kernels.genalpha` in between, until a step passes the output
time. The loop returns to Python (its code, and the steps taken) where the
Python step would do something the loop does not:

- ``NEED_JACOBIAN``: a Jacobian is due; Python forms it with the solver's
  own code and calls again, and the step goes on where it stopped (its
  trial size is kept in ``st[H_TRIAL]``, ``ct[RESUME]`` set);
- ``NEED_FACTOR``: LAPACK found the iteration matrix singular; Python
  factors it (``scipy.linalg.lu_factor``, which warns) at the step
  ``st[H_FACTOR]`` and calls again.

The LU factors of the iteration matrix ``I - gamma' h Jv - beta' h^2 Jx``
are LAPACK's ``dgetrf`` (called through its address: scipy's
``cython_lapack``, the routine ``lu_factor`` calls) on the matrix formed as
:meth:`~flexmb.genalpha.GeneralizedAlpha._factor` forms it: the same
factors to the bit.
- ``RHS_FAILED``: the right-hand side is not finite or a joint moves no
  mass (the time and the true state are left in ``st[FAIL_T]`` and
  ``fail_y``, where Python's diagnosis of them raises);
- ``NONFINITE_STATE``, ``TOO_SMALL`` (the step size fell below the smallest
  step), ``FIXED_FAILED`` (Newton failed with a fixed step);
- ``WATCH``: an angle left its winding bound or a joint in Bryant angles
  nears gimbal lock (the check of
  :func:`flexmb.kernels.cvode_callbacks.advance`, after every step);
- ``CHECKPOINT`` (the resolution monitor's), ``PAUSED`` (a budget of steps,
  so that signals are handled), ``REACHED``.

The solver's scalar state travels in ``st`` (floats) and ``ct`` (integers),
indexed by the constants below; the arrays are updated in place.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, overload

from .articulated import open_tree_rhs
from .cache import njit
from .cvode_callbacks import CHECKPOINT, PAUSED, REACHED, WATCH, _watched
from .genalpha import (CONVERGED, FAILED, NEWTON_MAXITER, P_BETA_P, P_GAMMA_P, error_control, newton_update,
                       predict)

__all__ = ["advance", "REACHED", "CHECKPOINT", "PAUSED", "WATCH", "NEED_JACOBIAN", "NEED_FACTOR", "RHS_FAILED",
           "NONFINITE_STATE", "TOO_SMALL", "FIXED_FAILED", "N_ST", "N_CT"]

#: return codes besides cvode_callbacks' REACHED, CHECKPOINT, PAUSED, WATCH (0-3)
NEED_JACOBIAN, NEED_FACTOR, RHS_FAILED, NONFINITE_STATE, TOO_SMALL, FIXED_FAILED = range(4, 10)
#: a step was taken (internal)
_TAKEN = -1
#: slots of ``st`` (floats): time, last step's start, end of the run, direction, largest step, next step size,
#: the bound after a Newton failure, last error norm (0: none), last step size, the step size the LU factors are
#: for, the step's trial size (resumed), the step to factor at, the failure's time, Newton's regrowth factor
(T, T_OLD, T_BOUND, DIRECTION, MAX_STEP, H_ABS, H_NEWTON, ERR_OLD, H_ABS_OLD, LU_H, H_TRIAL, H_FACTOR, FAIL_T,
 REGROWTH) = range(14)
N_ST = 14
#: slots of ``ct`` (integers): positions, fixed step, Newton iterations, rejected steps, right-hand sides, the
#: Jacobian is there / is current, the LU factors are there, a step is resumed, the offsets are set, LU factorisations
(N_POS, FIXED, N_NEWTON, N_REJECTED, N_RHS, HAS_J, JAC_CURRENT, HAS_LU, RESUME, HAS_OFFSET, N_LU) = range(11)
N_CT = 11


@intrinsic
def _call_getrf(typingctx, fn, m, a, ipiv, info):
    """``dgetrf(m, m, a, m, ipiv, info)`` (LAPACK, Fortran convention) through its address; pointers as int64."""
    def codegen(context, builder, sig, args):
        vp = cgutils.voidptr_t
        fnty = ir.FunctionType(ir.VoidType(), [vp] * 6)
        f = builder.inttoptr(args[0], fnty.as_pointer())
        mp, ap, pp, ip = (builder.inttoptr(v, vp) for v in args[1:])
        builder.call(f, [mp, mp, ap, mp, pp, ip])
        return context.get_dummy_value()
    return types.none(types.int64, types.int64, types.int64, types.int64, types.int64), codegen


@njit(cache=True)
def _factor(getrf, Jx, Jv, h, par, lu, piv, fwork, iwork):
    """LU factors of ``I - gamma' h Jv - beta' h^2 Jx`` into ``lu`` (C order) and ``piv`` (0-based); False if singular.

    The matrix is formed entry by entry as numpy forms it in
    GeneralizedAlpha._factor (the same operations in the same order), in
    Fortran order for ``dgetrf``.
    """
    n = lu.shape[0]
    c1, c2 = par[P_GAMMA_P] * h, par[P_BETA_P] * h * h
    for i in range(n):
        for j in range(n):
            fwork[j * n + i] = ((1.0 if i == j else 0.0) - c1 * Jv[i, j]) - c2 * Jx[i, j]
    iwork[0], iwork[1] = n, 0
    _call_getrf(getrf, iwork.ctypes.data, fwork.ctypes.data, iwork[2:].ctypes.data, iwork[1:].ctypes.data)
    if iwork[1] != 0:
        return False
    for i in range(n):
        piv[i] = iwork[2 + i] - 1
        for j in range(n):
            lu[i, j] = fwork[j * n + i]
    return True


def _model_rate(model, t, y, n, f):
    """The state rate of ``model`` at the true state ``(t, y)`` into ``f`` (True if it is sound): compiled only.

    An overload per kind of model: the open tree's packed arrays (a tuple,
    :func:`~flexmb.kernels.articulated.open_tree_rhs`) here, the loops'
    user data (an int64 array) in :mod:`flexmb.kernels.genalpha_loops`.
    """
    raise NotImplementedError("_model_rate is compiled only")


@overload(_model_rate)
def _open_tree_rate(model, t, y, n, f):
    """:func:`_model_rate` of an open tree (``System._packed_open``)."""
    if not isinstance(model, types.BaseTuple):
        return None

    def impl(model, t, y, n, f):
        rate, status = open_tree_rhs(model, y, n, np.zeros(n))
        f[: 2 * n] = rate[: 2 * n]
        return status == -1
    return impl


@njit(cache=True)
def _rhs(model, offset, t, y, n, ct, fail_y):
    """The state rate at the integrator's ``y`` (``y + offset`` the true state); status != -1 on failure."""
    m = y.shape[0]
    yt = y + offset if ct[HAS_OFFSET] else y.copy()
    ct[N_RHS] += 1
    f = np.zeros(m)
    if _model_rate(model, t, yt, n, f):
        return f, -1
    fail_y[:] = yt
    return f, 0


@njit(cache=True)
def _newton(packed, offset, z, a, abar, g, lu, piv, t1, h, par, atol, ct, st, work, fail_y):
    """GeneralizedAlpha._newton on the dense path: (outcome, the last rate ``f``); RHS_FAILED if it fails."""
    n = ct[N_POS]
    base, a1, y1, abar1, scale = work
    predict(z, a, abar, h, n, par, base, a1, y1)
    d = -1.0
    f = np.zeros(z.shape[0])
    for k in range(NEWTON_MAXITER):
        f, status = _rhs(packed, offset, t1, y1, n, ct, fail_y)
        if status != -1:
            st[FAIL_T] = t1
            return RHS_FAILED, f
        ct[N_NEWTON] += 1
        outcome, d, rate = newton_update(f, lu, piv, h, n, k, d, par, atol, base, g, a1, y1, abar1, scale)
        if outcome == CONVERGED:
            return CONVERGED, f
        if outcome == FAILED:
            return FAILED, f
    return FAILED, f


@njit(cache=True)
def _hold(st, ct, h_abs, h, code):
    """Return ``code`` to Python in the middle of a step: its trial size kept, the step to factor at."""
    st[H_TRIAL], st[H_FACTOR] = h_abs, h
    ct[RESUME] = 1
    return code


@njit(cache=True)
def _step(packed, offset, z, a, abar, g, z_old, abar_old, g_old, getrf, Jx, Jv, lu, piv, fwork, iwork, low_pass, par,
          atol, st, ct, work, fail_y):
    """One step of GeneralizedAlpha._step_impl (dense iteration matrix): _TAKEN, or the code to return."""
    n = ct[N_POS]
    t, direction, fixed = st[T], st[DIRECTION], ct[FIXED]
    h_abs = st[H_TRIAL] if ct[RESUME] else min(st[H_ABS], st[MAX_STEP])
    ct[RESUME] = 0
    smallest = 10 * abs(np.nextafter(t, direction * np.inf) - t)
    err, h_next = 0.0, 0.0
    while True:
        if h_abs < smallest:
            return TOO_SMALL
        h = h_abs * direction
        t1 = t + h
        if direction * (t1 - st[T_BOUND]) > -1e-9 * h_abs:  # a round-off remainder is taken into the step
            t1 = st[T_BOUND]
            h = t1 - t
            h_abs = abs(h)
        if not ct[HAS_J]:
            return _hold(st, ct, h_abs, h, NEED_JACOBIAN)
        if not ct[HAS_LU] or st[LU_H] != h:
            if not _factor(getrf, Jx, Jv, h, par, lu, piv, fwork, iwork):
                return _hold(st, ct, h_abs, h, NEED_FACTOR)
            ct[HAS_LU], ct[N_LU] = 1, ct[N_LU] + 1
            st[LU_H] = h
        outcome, f = _newton(packed, offset, z, a, abar, g, lu, piv, t1, h, par, atol, ct, st, work, fail_y)
        if outcome == RHS_FAILED:
            return RHS_FAILED
        if outcome == FAILED:
            if not ct[JAC_CURRENT]:
                return _hold(st, ct, h_abs, h, NEED_JACOBIAN)
            if fixed:
                st[FAIL_T], st[H_TRIAL] = t1, h_abs
                return FIXED_FAILED
            ct[N_REJECTED] += 1
            h_abs *= 0.5
            st[H_NEWTON] = h_abs
            ct[HAS_LU] = 0
            continue
        if fixed:
            break
        accepted, err, h_next = error_control(lu, piv, low_pass, abar, work[3], z, work[2], n, h, h_abs, st[ERR_OLD],
                                              par, atol)
        if accepted:
            break
        ct[N_REJECTED] += 1
        h_abs = h_next
    _accept(z, a, abar, g, z_old, abar_old, g_old, f, work, st, ct, t1, h_abs, err, h_next)
    return _TAKEN


@njit(cache=True)
def _accept(z, a, abar, g, z_old, abar_old, g_old, f, work, st, ct, t1, h_abs, err, h_next):
    """GeneralizedAlpha._accept: the step's end becomes the state, the old one the interpolant's start."""
    n = ct[N_POS]
    a1, y1, abar1 = work[1], work[2], work[3]
    z_old[:] = z
    abar_old[:] = abar
    g_old[:] = g
    z[:] = y1
    a[:] = a1
    abar[:] = abar1
    g[:] = f[2 * n :]
    st[T_OLD], st[T] = st[T], t1
    st[H_ABS_OLD] = h_abs
    ct[JAC_CURRENT] = 0
    if not ct[FIXED]:
        st[ERR_OLD] = max(err, 1e-10)
        st[H_NEWTON] *= st[REGROWTH]
        st[H_ABS] = min(h_next, st[H_NEWTON])


@njit(cache=True)
def advance(packed, offset, z, a, abar, g, z_old, abar_old, g_old, getrf, Jx, Jv, lu, piv, low_pass, par, atol, st, ct,
            t_stop, steps, budget, angles, bound, gimbal, limit, fail_y):
    """Take generalized-alpha steps until one ends at or past ``t_stop`` (or a reason to return to Python).

    Parameters
    ----------
    packed : tuple
        The model's packed arrays (``System._packed_open``).
    offset : ndarray, shape (m,)
        The winding offsets (read where ``ct[HAS_OFFSET]``).
    z, a, abar, g : ndarray
        The state ``(x, xd)`` at the last step's end (the integrator's, less
        the offsets), its accelerations, algorithmic accelerations and
        further rates; updated in place.
    z_old, abar_old, g_old : ndarray
        Out: the same at the last step's start (the interpolant's).
    getrf : int
        The address of LAPACK's ``dgetrf``.
    Jx, Jv : ndarray, shape (n, n)
        The Jacobian's blocks (read where ``ct[HAS_J]``).
    lu, piv : ndarray, shape (n, n) and (n,) int32
        LU factors of the iteration matrix (``lu_factor``'s), for the step
        ``st[LU_H]`` (valid where ``ct[HAS_LU]``); refactored in place when
        the step changes.
    low_pass : ndarray, shape (n, n) or (0, 0)
        The error estimate's projector (empty: none).
    par, atol : ndarray
        The method's parameters (:mod:`flexmb.kernels.genalpha`) and the
        positions' absolute tolerances.
    st, ct : ndarray
        The solver's scalars (slots above), updated in place.
    t_stop : float
        The output time.
    steps : ndarray
        The steps' end times, for the resolution monitor; CHECKPOINT when
        full (length 0: none kept).
    budget : int
        Steps after which the loop returns PAUSED.
    angles, bound, gimbal, limit
        The watches, as for :func:`flexmb.kernels.cvode_callbacks.advance`.
    fail_y : ndarray, shape (m,)
        Out: the true state at which the right-hand side failed.

    Returns
    -------
    code : int
        REACHED, CHECKPOINT, PAUSED, WATCH or one of the codes above.
    n_steps : int
        Steps taken in this call.
    """
    n, m = ct[N_POS], z.shape[0]
    work = (np.empty((3, n)), np.empty(n), np.empty(m), np.empty(n), np.empty((2, n)))
    fwork, iwork = np.empty(n * n), np.empty(n + 2, np.int32)
    direction, t_bound = st[DIRECTION], st[T_BOUND]
    k, cap = 0, steps.shape[0]
    while direction * (t_stop - st[T]) > 0:
        code = _step(packed, offset, z, a, abar, g, z_old, abar_old, g_old, getrf, Jx, Jv, lu, piv, fwork, iwork,
                     low_pass, par, atol, st, ct, work, fail_y)
        if code != _TAKEN:
            return code, k
        tn = st[T]
        if k < cap:
            steps[k] = tn
        k += 1
        if not np.all(np.isfinite(z)):
            return NONFINITE_STATE, k
        early = direction * (t_bound - tn) > 0
        if (len(angles) and early or len(gimbal)) and _watched(z, angles if early else angles[:0], bound, gimbal,
                                                               limit):
            return WATCH, k
        if k == cap and direction * (t_stop - tn) > 0:
            return CHECKPOINT, k
        if k == budget and direction * (t_stop - tn) > 0:
            return PAUSED, k
    return REACHED, k
