"""The generalized-alpha step loop on looped models, compiled: the steps, the outputs and the projections.

:class:`flexmb.genalpha.compiled.CompiledLoopGeneralizedAlpha` hands
its steps to :func:`advance`: the steps of
:func:`flexmb.kernels.genalpha_loop._step` (those of
:class:`flexmb.genalpha.GeneralizedAlpha`) with the loops' right-hand side
(:func:`~flexmb.kernels.cvode_loop_callbacks.rate_into`, CVODE's, on the
loops' user data), and after each step what ``flexmb.stepping.Run._step``
does after a step of a looped model:

- the outputs the step passed, from the method's interpolant (that of
  :class:`flexmb.genalpha.dense.GeneralizedAlphaDenseOutput`) plus the
  winding offsets, projected as ``project_output`` projects them
  (:func:`flexmb.kernels.loop_outputs.output_projected`), into an array;
  an output it cannot store so (not finite, its projection refused) is
  left to the run (``OUTPUT_LEFT``);
- the drift check of ``Run._restart_if_drifted`` for an integrator that
  moves in place: ``max(|phi|, h |psi xd - b|)`` against the run's bound,
  and past it the state projected as ``System.project(..., speeds='mass')``
  (:func:`~flexmb.kernels.cvode_loop_callbacks._step_projection`, Newton to
  the run's tolerance) and the method continued from it as
  :meth:`flexmb.genalpha.GeneralizedAlpha.move_to` continues (the
  accelerations corrected with the Jacobian, the lag of ``abar`` kept); a
  projection that does not close is left to the run (``DRIFTED``), which
  raises its diagnosis;
- the watches (winding angles, gimbal lock: ``WATCH``, before the drift
  check, which the run then makes after moving the offsets), the monitor's
  checkpoints and a budget of steps, as the open trees' loop
  (:mod:`flexmb.kernels.genalpha_loop`, whose return codes it shares).
"""

from __future__ import annotations

import math

import numpy as np
from numba import types
from numba.extending import overload

from .cache import njit
from .cvode_callbacks import _watched
from .cvode_loop_callbacks import (A_C, A_K, A_REAL, N_DRV, N_REAL, R_TOL, R_WINDOW, RANK_LIMIT, _drivers, _f1,
                                   _layout, _packed, _residuals, _step_projection, driver, rate_into)
from .genalpha import restart_accelerations
from .genalpha_loop import (CHECKPOINT, FAIL_T, H_ABS, HAS_J, HAS_LU, HAS_OFFSET, JAC_CURRENT, MAX_STEP, N_CT,
                            N_POS, NEED_JACOBIAN, NONFINITE_STATE, PAUSED, REACHED, RHS_FAILED, T, T_BOUND, T_OLD,
                            WATCH, _TAKEN, _model_rate, _rhs, _step)
from .loop_jacobian import loop_state_jacobian
from .loop_outputs import REFUSED, output_projected
from .step_projection import MOVED

__all__ = ["advance", "DRIFTED", "OUTPUT_LEFT", "N_LOOP_CT", "N_PROJ", "N_MADE", "K_OUT", "JAC_IN_LOOP", "N_JAC",
           "MIN_STEP", "N_LOOP_ST"]

#: return codes besides genalpha_loop's (0-9): a drifted state whose projection did not close, an output left
DRIFTED, OUTPUT_LEFT = 10, 11
#: further slots of ``ct`` (after genalpha_loop's): the projections of the state, the outputs' projections, the
#: next output's index, whether the loop forms the Jacobian itself, the Jacobians it formed
N_PROJ, N_MADE, K_OUT, JAC_IN_LOOP, N_JAC = range(N_CT, N_CT + 5)
N_LOOP_CT = N_CT + 5
#: a further slot of ``st`` (after genalpha_loop's 14): the smallest step (0: none)
MIN_STEP = 14
N_LOOP_ST = 15


@overload(_model_rate)
def _loop_rate(model, t, y, n, f):
    """:func:`~flexmb.kernels.genalpha_loop._model_rate` of a looped model (its user data, int64)."""
    if not isinstance(model, types.Array):
        return None

    def impl(model, t, y, n, f):
        status, kept = rate_into(model, t, y, f)
        return status == 0
    return impl


@njit(cache=True)
def _jacobian(ud, offset, z, t, Jx, Jv, ct):
    """``Jx``, ``Jv`` at the step start by loop_state_jacobian (``System.state_jacobian``'s); False if it fails."""
    n, m = ct[N_POS], z.shape[0]
    y = z + offset if ct[HAS_OFFSET] else z
    real = _f1(ud[A_REAL], N_REAL)
    drv, gamma_d = _drivers(ud), np.empty(ud[N_DRV])
    for k in range(ud[N_DRV]):
        gamma_d[k] = driver(drv, k, t)[2]
    full = np.empty((m, m))
    status, _ = loop_state_jacobian(_packed(ud), _layout(ud), y, n, _f1(ud[A_K], n), _f1(ud[A_C], n), gamma_d,
                                    real[R_TOL], real[R_WINDOW], ud[RANK_LIMIT], full)
    if status:
        return False
    Jx[:, :] = full[n : 2 * n, :n]
    Jv[:, :] = full[n : 2 * n, n : 2 * n]
    ct[HAS_J], ct[JAC_CURRENT], ct[HAS_LU] = 1, 1, 0
    ct[N_JAC] += 1
    return True


@njit(cache=True)
def _interpolate(z_old, z, abar_old, abar, g_old, g, n, t_old, t, t_out, y):
    """``y`` = the step's interpolant at ``t_out`` (GeneralizedAlphaDenseOutput's arithmetic)."""
    h = t - t_old
    s = (t_out - t_old) / h
    s2, s3 = s * s, math.pow(s, 3.0)
    h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
    for i in range(n):
        y[i] = h00 * z_old[i] + h10 * h * z_old[n + i] + h01 * z[i] + h11 * h * z[n + i]
        y[n + i] = z_old[n + i] + s * (z[n + i] - z_old[n + i]) + 0.5 * h * (s * s - s) * (abar[i] - abar_old[i])
    for i in range(z.shape[0] - 2 * n):
        y[2 * n + i] = z_old[2 * n + i] + h * (s * g_old[i] + 0.5 * s * s * (g[i] - g_old[i]))


@njit(cache=True)
def _store(ud, offset, z, abar, g, z_old, abar_old, g_old, st, ct, times, Y, tol, newton_tol, gain):
    """Store the outputs up to the step's end; False at an output left to the run (not finite, refused)."""
    n, m, t = ct[N_POS], z.shape[0], st[T]
    y = np.empty(m)
    while ct[K_OUT] < times.shape[0] and times[ct[K_OUT]] <= t:
        t_out = times[ct[K_OUT]]
        if t_out == t:
            y[:] = z
        else:
            _interpolate(z_old, z, abar_old, abar, g_old, g, n, st[T_OLD], t, t_out, y)
        if ct[HAS_OFFSET]:
            y += offset
        if not np.all(np.isfinite(y)):
            return False
        outcome = output_projected(ud, t_out, y, tol, newton_tol, gain)
        if outcome == REFUSED:
            return False
        ct[N_MADE] += outcome
        Y[ct[K_OUT], :] = y
        ct[K_OUT] += 1
    return True


@njit(cache=True)
def _hold_on_constraints(ud, offset, z, a, abar, Jx, Jv, st, ct, state_tol, newton_tol, fail_y):
    """Run._restart_if_drifted for a method that moves: the state projected and continued if it drifted.

    Returns -1 (kept or moved), DRIFTED (the projection did not close:
    left to the run) or RHS_FAILED (the right-hand side at the moved
    state, where no Jacobian is there to correct the accelerations).
    """
    n, m, t = ct[N_POS], z.shape[0], st[T]
    y = z + offset if ct[HAS_OFFSET] else z.copy()
    position, velocity = _residuals(ud, t, y)
    if max(position, velocity * abs(st[T] - st[T_OLD])) <= state_tol:
        return -1
    what, _, _, x, v = _step_projection(ud, t, y, -1.0, newton_tol, np.inf)
    if what != MOVED:
        return DRIFTED
    moved = y.copy()
    moved[:n] = x
    moved[n : 2 * n] = v
    if ct[HAS_OFFSET]:
        moved -= offset
    lag = abar - a
    if ct[HAS_J]:
        a1, abar1 = restart_accelerations(moved, z, a, Jx, Jv, lag, n)
    else:
        f, status = _rhs(ud, offset, t, moved, n, ct, fail_y)
        if status != -1:
            st[FAIL_T] = t
            return RHS_FAILED
        a1 = f[n : 2 * n].copy()
        abar1 = a1 + lag
    a[:], abar[:], z[:] = a1, abar1, moved
    ct[N_PROJ] += 1
    if st[MIN_STEP] > 0.0:  # as at a start (GeneralizedAlpha.move_to)
        st[H_ABS] = min(max(st[H_ABS], st[MIN_STEP]), st[MAX_STEP])
    return -1


@njit(cache=True)
def advance(ud, offset, z, a, abar, g, z_old, abar_old, g_old, getrf, Jx, Jv, lu, piv, low_pass, par, atol, st, ct,
            t_stop, once, steps, budget, angles, bound, gimbal, limit, fail_y, times, Y, tol, newton_tol, gain,
            state_tol):
    """Take generalized-alpha steps on a looped model, storing its outputs and projecting it, until Python is needed.

    Parameters
    ----------
    ud : ndarray of int64
        The loops' user data (:func:`flexmb.loop_user_data.loop_user_data`).
    Jx, Jv : ndarray, shape (n, n)
        The Jacobian's blocks; where ``ct[JAC_IN_LOOP]`` the loop forms them
        itself when one is due (``System.state_jacobian``'s, compiled:
        :func:`~flexmb.kernels.loop_jacobian.loop_state_jacobian`), else it
        returns NEED_JACOBIAN.
    offset, z, a, abar, g, z_old, abar_old, g_old, getrf, lu, piv, low_pass, par, atol, st, ct
        As for :func:`flexmb.kernels.genalpha_loop.advance` (``st`` and
        ``ct`` with the further slots above).
    t_stop : float
        The first stop (an output time or a progress mark).
    once : bool
        Return at the first stop; else go on to the end of the run.
    steps, budget, angles, bound, gimbal, limit, fail_y
        As for :func:`flexmb.kernels.genalpha_loop.advance`.
    times, Y : ndarray
        The run's output times and the stored outputs (true states,
        projected); ``ct[K_OUT]`` the next one's index.
    tol, newton_tol, gain : float
        ``project_output``'s (:func:`flexmb.kernels.loop_outputs.output_projected`).
    state_tol : float
        The run's drift bound (``Run.state_tol``); the drifted state's
        projection closes the loops to ``newton_tol``.

    Returns
    -------
    code : int
        REACHED (the stop, or the end of the run), CHECKPOINT, PAUSED,
        WATCH, DRIFTED, OUTPUT_LEFT, or genalpha_loop's codes.
    n_steps : int
        Steps taken in this call.
    """
    n, m = ct[N_POS], z.shape[0]
    work = (np.empty((3, n)), np.empty(n), np.empty(m), np.empty(n), np.empty((2, n)))
    fwork, iwork = np.empty(n * n), np.empty(n + 2, np.int32)
    t_bound = st[T_BOUND]
    k, cap = 0, steps.shape[0]
    while st[T] < t_bound:
        code = _step(ud, offset, z, a, abar, g, z_old, abar_old, g_old, getrf, Jx, Jv, lu, piv, fwork, iwork,
                     low_pass, par, atol, st, ct, work, fail_y)
        if code == NEED_JACOBIAN and ct[JAC_IN_LOOP] and _jacobian(ud, offset, z, st[T], Jx, Jv, ct):
            continue  # the step resumed with it (GeneralizedAlpha._new_jacobian, no low-pass projector)
        if code != _TAKEN:
            return code, k
        tn = st[T]
        if k < cap:
            steps[k] = tn
        k += 1
        if not np.all(np.isfinite(z)):
            return NONFINITE_STATE, k
        if not _store(ud, offset, z, abar, g, z_old, abar_old, g_old, st, ct, times, Y, tol, newton_tol, gain):
            return OUTPUT_LEFT, k
        early = tn < t_bound
        if (len(angles) and early or len(gimbal)) and _watched(z, angles if early else angles[:0], bound, gimbal,
                                                               limit):
            return WATCH, k
        if early:
            code = _hold_on_constraints(ud, offset, z, a, abar, Jx, Jv, st, ct, state_tol, newton_tol, fail_y)
            if code != -1:
                return code, k
        if once and tn >= t_stop:
            return REACHED, k
        if k == cap and early:
            return CHECKPOINT, k
        if k == budget and early:
            return PAUSED, k
    return REACHED, k
