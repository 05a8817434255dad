"""The compiled loops' CVODE stepped from output to output, the outputs interpolated and projected in compiled code.

:func:`advance_storing` is what :class:`flexmb.integrators.cvode_direct_loops.DirectLoopCVODE`
calls to step: CVODE's step loop with the run's checks
(:func:`~flexmb.kernels.cvode_loop_callbacks.advance`), and after a step
that passed output times what ``flexmb.stepping.Run._store`` does there:
each output state (the step's own, or CVODE's interpolant ``CVodeGetDky``;
plus the winding offsets) projected onto the constraints as
:func:`flexmb.output_projection.project_output` projects it
(:func:`output_projected`), into a preallocated array. It goes on to the
next output time where the run would do nothing after the step (its
drift, winding and gimbal checks all found by the step loop as passed,
no progress mark, no monitor checkpoint, steps left in the budget), and
returns to Python otherwise; an output it cannot store as the run would
(not finite, a projection refused or not closed, which
``project_output`` takes to its partial projection) is left to the run.
The arithmetic is the run's: the same kernels on the same numbers.
"""

from __future__ import annotations

import numpy as np
from numba import carray

from .cache import njit
from .cvode_callbacks import _call_dky, _call_p_p, _voidp
from .cvode_loop_callbacks import (A_OFFSET, HAS_OFFSET, N, NOT_FINITE, PROJ_OK, REACHED, _f1, _projected_at,
                                   _residuals, _step_projection, advance, drift)
from .step_projection import MOVED

__all__ = ["advance_storing", "output_projected", "KEPT", "PROJECTED", "REFUSED"]

#: :func:`output_projected`'s outcomes
KEPT, PROJECTED, REFUSED = 0, 1, 2


@njit(cache=True)
def output_projected(ud, t, y, tol, newton_tol, gain):
    """Project the output state ``y`` (true state, shape (2n,)) in place as ``project_output`` does.

    Kept if its largest residual (``System._constraint_residuals``'s, by
    :func:`~flexmb.kernels.cvode_loop_callbacks._residuals`) is within
    ``tol``; else the positions by the loops' Newton to ``newton_tol`` and the
    speeds mass-orthogonally (``System.project(..., speeds='mass')``, by
    :func:`~flexmb.kernels.step_projection.step_projection`), eqs. 28-29.

    Returns
    -------
    int
        KEPT, PROJECTED, or REFUSED (Newton did not close the loops, the
        correction is not finite or exceeds ``gain`` times the residual:
        ``y`` unchanged, left to ``project_output``'s partial projection).
    """
    n = ud[N]
    position, velocity = _residuals(ud, t, y)
    res = max(position, velocity)
    if res <= tol:
        return KEPT
    # tol -1: the positions by Newton whatever their residual, as System.project; the gain checked below on res
    what, _, _, x, v = _step_projection(ud, t, y, -1.0, newton_tol, np.inf)
    big = 0.0
    for i in range(n):
        big = max(big, abs(x[i] - y[i]), abs(v[i] - y[n + i]))
    if what != MOVED or big > gain * res:
        return REFUSED
    y[:n] = x
    y[n:2 * n] = v
    return PROJECTED


@njit(cache=True)
def _output_state(lp, ud, t, t_out, y):
    """``y`` = the integrator's state at ``t_out`` (the last step's at ``t``, else CVODE's interpolant) plus the offsets."""
    m = lp[7]
    if t_out == t:
        y[:] = carray(_voidp(lp[4]), (m,), np.float64)
    else:
        if _call_dky(lp[1], lp[2], t_out, 0, lp[5]) < 0:
            return False
        y[:] = carray(_call_p_p(lp[8], _voidp(lp[5])), (m,), np.float64)
    if ud[HAS_OFFSET]:
        y += _f1(ud[A_OFFSET], m)
    return True


@njit(cache=True)
def _store(lp, ud, t, times, k_out, Y, tol, newton_tol, gain):
    """Store the outputs up to ``t`` from ``k_out`` on into ``Y``; the next output's index and the projections made.

    Stops at an output it leaves to the run (not finite, REFUSED).
    """
    y = np.empty(lp[7])
    made = 0
    while k_out < times.shape[0] and times[k_out] <= t:
        if not (_output_state(lp, ud, t, times[k_out], y) and np.all(np.isfinite(y))):
            break
        outcome = output_projected(ud, times[k_out], y, tol, newton_tol, gain)
        if outcome == REFUSED:
            break
        made += outcome
        Y[k_out, :] = y
        k_out += 1
    return k_out, made


@njit(cache=True)
def advance_storing(lp, ud, t_stop, t_bound, bound, steps, budget, angles, wind, gimbal, limit, times, k_out, Y,
                    tol, newton_tol, gain, once):
    """Step CVODE and store the outputs the steps pass, until a step needs the run's attention.

    Parameters
    ----------
    lp, ud, t_stop, t_bound, bound, steps, budget, angles, wind, gimbal, limit
        As for :func:`~flexmb.kernels.cvode_loop_callbacks.advance`
        (``t_stop`` the first stop; ``steps`` filled across the calls, the
        loop returning CHECKPOINT when it is full; ``budget`` in all).
    times : ndarray
        The run's output times; ``k_out`` the next one's index.
    Y : ndarray, shape (len(times), m)
        The stored output states (true states, projected).
    tol, newton_tol, gain : float
        ``project_output``'s: the residual below which an output is kept,
        the Newton tolerance of its projection, the largest correction per
        unit residual.
    once : bool
        Return after the first stop (a progress mark's, or a caller that stores nothing).

    Returns
    -------
    code, n_steps : int
        As :func:`~flexmb.kernels.cvode_loop_callbacks.advance` (the last
        one's code; the steps of all).
    k_out : int
        The next output's index (the outputs before it stored in ``Y``).
    made : int
        The outputs projected (``System.project``'s mass-orthogonal speeds each).
    """
    tret = carray(_voidp(lp[6]), (1,), np.float64)
    m, live, nt = lp[7], steps.shape[0] > 0, times.shape[0]
    k = made = 0
    while True:
        code, kk = advance(lp, ud, min(t_stop, t_bound), t_bound, bound, steps[k:] if live else steps, budget - k,
                           angles, wind, gimbal, limit)
        k += kk
        if code < 0 or code == NOT_FINITE:
            return code, k, k_out, made
        t = tret[0]
        k_out, more = _store(lp, ud, t, times, k_out, Y, tol, newton_tol, gain)
        made += more
        if (once or code != REACHED or kk == 0 or t >= t_bound or k >= budget or (live and k >= steps.shape[0])
                or (k_out < nt and times[k_out] <= t)):
            return code, k, k_out, made
        if ud[PROJ_OK] == 2 and _projected_at(ud, t):  # moved by CVODE's projection (kept: within half the bound)
            z = carray(_voidp(lp[4]), (m,), np.float64)
            if drift(ud, t, z + _f1(ud[A_OFFSET], m) if ud[HAS_OFFSET] else z) > bound:
                return code, k, k_out, made
        t_stop = times[k_out] if k_out < nt else t_bound
