"""The arithmetic of a generalized-alpha step, compiled (numba, ``cache=True``).

The step of :class:`flexmb.genalpha.GeneralizedAlpha` (the form of Arnold &
Bruels (2007) [2]_ of Chung & Hulbert's method [1]_, see
:mod:`flexmb.genalpha`) calls the right-hand side, which is Python, once
per Newton iteration; everything between two calls is one of these
kernels:

- :func:`predict`: the parts of ``x1``, ``xd1``, ``abar1`` known before the
  step and the first iterate ``a1 = a0``;
- :func:`newton_update`: with the right-hand side at the iterate, the
  Newton update of ``a1``, the convergence test, and either the next
  iterate or the step's end state;
- :func:`error_control`: the local error estimate, its norm and the step
  size that follows (rejection, or the PI controller's next step);
- :func:`restart_accelerations`: the accelerations at a state moved by a
  projection, from the previous ones and the Jacobian.

The scalar parameters travel in one array ``par`` (indices ``P_*``), the
LU factors of the iteration matrix are scipy's ``lu_factor`` output (row
interchanges 0-based), solved by :func:`lu_solve`. Means of squares are
summed pairwise as numpy sums (:func:`mean`), so the norms, and with them
every step-size decision, are those of the numpy arithmetic these kernels
replaced.

References
----------
.. [1] J. Chung, G. M. Hulbert, J. Appl. Mech. 60 (1993) 371-375.
.. [2] M. Arnold, O. Bruels, Multibody Syst. Dyn. 18 (2007) 185-202.
"""

from __future__ import annotations

import numpy as np
from .cache import njit

__all__ = ["NEWTON_MAXITER", "MIN_FACTOR", "MAX_FACTOR", "KEEP_BAND", "SAFETY", "CONTINUE", "CONVERGED", "FAILED",
           "P_ALPHA_M", "P_ALPHA_F", "P_BETA", "P_GAMMA", "P_BETA_P", "P_GAMMA_P", "P_ERROR_CONSTANT", "P_RTOL",
           "P_NEWTON_TOL", "P_MIN_STEP", "P_MAX_STEP", "N_PAR",
           "lu_solve", "mean", "predict", "newton_update", "newton_apply", "error_control", "error_test",
           "restart_accelerations"]

#: Newton iterations before a step is retried
NEWTON_MAXITER = 6
#: step-size change factors: smallest and largest
MIN_FACTOR, MAX_FACTOR = 0.2, 5.0
#: the band of step-size factors in which the step is kept
KEEP_BAND = (1.0, 1.2)
#: safety factor of the step-size controller
SAFETY = 0.9

#: outcomes of :func:`newton_update`
CONTINUE, CONVERGED, FAILED = 0, 1, 2

#: indices into the parameter array ``par``: alpha_m, alpha_f, beta, gamma, beta' and gamma' (the
#: iteration matrix's), the error constant, rtol, Newton's tolerance, the step floor (0: none) and
#: the largest step
(P_ALPHA_M, P_ALPHA_F, P_BETA, P_GAMMA, P_BETA_P, P_GAMMA_P, P_ERROR_CONSTANT, P_RTOL, P_NEWTON_TOL, P_MIN_STEP,
 P_MAX_STEP) = range(11)
N_PAR = 11


@njit(cache=True)
def lu_solve(lu, piv, b, out):
    """Solve ``S x = b`` into ``out`` from the LU factors of ``S`` (LAPACK getrf's, as ``lu_factor`` returns).

    Parameters
    ----------
    lu : ndarray, shape (n, n)
        Unit lower triangle L (below the diagonal) and upper triangle U of
        ``P S = L U``.
    piv : ndarray, shape (n,)
        Row i was interchanged with row ``piv[i]`` (0-based), in order.
    b : ndarray, shape (n,)
        Right-hand side.
    out : ndarray, shape (n,)
        The solution (may not be ``b``).
    """
    n = b.shape[0]
    for i in range(n):
        out[i] = b[i]
    for i in range(n):
        p = piv[i]
        if p != i:
            out[i], out[p] = out[p], out[i]
    for i in range(n):
        s = out[i]
        for j in range(i):
            s -= lu[i, j] * out[j]
        out[i] = s
    for i in range(n - 1, -1, -1):
        s = out[i]
        for j in range(i + 1, n):
            s -= lu[i, j] * out[j]
        out[i] = s / lu[i, i]


@njit(cache=True)
def _block_sum(a, lo, n):
    """numpy's pairwise summation of ``a[lo:lo + n]``, n <= 128: eight partial sums, then the rest."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    m = n - n % 8
    while i < m:
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@njit(cache=True)
def _pairwise_sum(a):
    """numpy's pairwise summation of ``a``: blocks of at most 128, halves (multiples of 8) summed in a tree.

    numpy recurses; here an explicit stack walks the same tree (numba's
    cache cannot hold a recursive function).
    """
    n = a.shape[0]
    if n <= 128:
        return _block_sum(a, 0, n)
    s_lo = np.empty(64, np.int64)
    s_n = np.empty(64, np.int64)
    s_phase = np.zeros(64, np.int64)
    s_left = np.empty(64)
    top, ret = 0, 0.0
    s_lo[0], s_n[0] = 0, n
    while top >= 0:
        lo, m = s_lo[top], s_n[top]
        if m <= 128:
            ret = _block_sum(a, lo, m)
            top -= 1
            continue
        half = m // 2
        half -= half % 8
        phase = s_phase[top]
        if phase == 2:  # both halves done: ret holds the right one
            ret = s_left[top] + ret
            top -= 1
            continue
        if phase == 1:  # the left half done
            s_left[top] = ret
        s_phase[top] = phase + 1
        top += 1
        s_lo[top] = lo if phase == 0 else lo + half
        s_n[top] = half if phase == 0 else m - half
        s_phase[top] = 0
    return ret


@njit(cache=True)
def mean(a):
    """The mean of ``a``, summed as ``numpy.mean`` sums a contiguous float array (to the same bits).

    Parameters
    ----------
    a : ndarray, shape (n,)
        Values (n > 0).

    Returns
    -------
    float
        ``sum(a) / n``.
    """
    return _pairwise_sum(a) / a.shape[0]


@njit(cache=True)
def _matvec(M, v):
    """``M @ v`` by rows (numba's ``np.dot`` binds BLAS, which lengthens the kernels' first compilation)."""
    out = np.empty(M.shape[0])
    for i in range(M.shape[0]):
        s = 0.0
        for j in range(M.shape[1]):
            s += M[i, j] * v[j]
        out[i] = s
    return out


@njit(cache=True)
def predict(y, a0, abar0, h, n, par, base, a1, y1):
    """The parts of a step's end known before it, and the first Newton iterate ``a1 = a0``.

    Parameters
    ----------
    y : ndarray, shape (2 n + n_w,)
        State ``(x0, xd0, w0)`` at the step start.
    a0, abar0 : ndarray, shape (n,)
        Accelerations and algorithmic accelerations at the step start.
    h : float
        Step, s (negative backwards).
    n : int
        Number of positions.
    par : ndarray, shape (N_PAR,)
        Method parameters (``P_*``).
    base : ndarray, shape (3, n)
        Out: ``x_c``, ``xd_c``, ``abar_c``, with ``x1 = x_c + beta' h^2 a1``,
        ``xd1 = xd_c + gamma' h a1`` and ``abar1 = abar_c + c a1``.
    a1 : ndarray, shape (n,)
        Out: the first iterate, ``a0``.
    y1 : ndarray, shape (2 n + n_w,)
        Out: the state at the first iterate, ``(x1, xd1, w0)``.

    Notes
    -----
    The step equations (module docstring of :mod:`flexmb.genalpha`)::

        abar_c = (alpha_f a0 - alpha_m abar0) / (1 - alpha_m)
        x_c = x0 + h xd0 + h^2 ((1/2 - beta) abar0 + beta abar_c)
        xd_c = xd0 + h ((1 - gamma) abar0 + gamma abar_c)
    """
    am, af, b, g = par[P_ALPHA_M], par[P_ALPHA_F], par[P_BETA], par[P_GAMMA]
    bp, gp = par[P_BETA_P], par[P_GAMMA_P]
    for i in range(n):
        abar_c = (af * a0[i] - am * abar0[i]) / (1 - am)
        x_c = y[i] + h * y[n + i] + h * h * ((0.5 - b) * abar0[i] + b * abar_c)
        v_c = y[n + i] + h * ((1 - g) * abar0[i] + g * abar_c)
        base[0, i], base[1, i], base[2, i] = x_c, v_c, abar_c
        a1[i] = a0[i]
        y1[i] = x_c + bp * h * h * a0[i]
        y1[n + i] = v_c + gp * h * a0[i]
    for i in range(2 * n, y.shape[0]):
        y1[i] = y[i]


@njit(cache=True)
def _update_norm(da, scale, cx, cv):
    """``sqrt((mean((cx da / sx)^2) + mean((cv da / sv)^2)) / 2)``: a Newton update's size in x1 and xd1."""
    n = da.shape[0]
    qx, qv = np.empty(n), np.empty(n)
    for i in range(n):
        qx[i] = (cx * da[i] / scale[0, i]) ** 2
        qv[i] = (cv * da[i] / scale[1, i]) ** 2
    return np.sqrt(0.5 * (mean(qx) + mean(qv)))


@njit(cache=True)
def _correct(f, lu, piv, n, a1):
    """Newton's correction ``da = -S^-1 (a1 - f[n:2n])``, added to ``a1``; returns ``da``."""
    r = np.empty(n)
    da = np.empty(n)
    for i in range(n):
        r[i] = a1[i] - f[n + i]
    lu_solve(lu, piv, r, da)
    for i in range(n):
        da[i] = -da[i]
        a1[i] = a1[i] + da[i]
    return da


@njit(cache=True)
def _step_end(f, h, n, par, base, g0, a1, y1, abar1):
    """At convergence: ``abar1 = abar_c + c a1`` and ``w1 = w0 + h (g0 + g1) / 2`` (trapezoidal rule)."""
    c = (1 - par[P_ALPHA_F]) / (1 - par[P_ALPHA_M])
    for i in range(n):
        abar1[i] = base[2, i] + c * a1[i]
    for i in range(g0.shape[0]):
        y1[2 * n + i] = y1[2 * n + i] + 0.5 * h * (g0[i] + f[2 * n + i])


@njit(cache=True)
def newton_update(f, lu, piv, h, n, k, d_old, par, atol, base, g0, a1, y1, abar1, scale):
    """One Newton update of ``a1`` from the right-hand side at the iterate, and the convergence test.

    Parameters
    ----------
    f : ndarray, shape (2 n + n_w,)
        The right-hand side at ``(t1, y1)``.
    lu, piv : ndarray
        LU factors of the iteration matrix ``I - gamma' h Jv - beta' h^2 Jx``
        (see :func:`lu_solve`).
    h : float
        Step, s.
    n, k : int
        Number of positions; the iteration (0 for the first).
    d_old : float
        The previous iteration's scaled update norm (-1 at the first).
    par : ndarray, shape (N_PAR,)
        Method parameters (``P_*``).
    atol : ndarray, shape (n,)
        Absolute tolerances of the positions.
    base : ndarray, shape (3, n)
        From :func:`predict`.
    g0 : ndarray, shape (n_w,)
        Rates of the further states at the step start.
    a1 : ndarray, shape (n,)
        The iterate, updated in place.
    y1 : ndarray, shape (2 n + n_w,)
        The state at the iterate; on return, at the next iterate, or (if
        converged) the step's end state ``(x1, xd1, w1)``.
    abar1 : ndarray, shape (n,)
        Out, if converged: the algorithmic accelerations at the step end.
    scale : ndarray, shape (2, n)
        The scales of ``x1`` and ``xd1`` in Newton's norm, ``sx = atol +
        rtol |x1|`` and ``sv = sx / |h| + rtol |xd1|``, set at the first
        iteration (see Notes).

    Returns
    -------
    outcome : int
        ``CONVERGED``, ``FAILED`` (a non-finite right-hand side, divergence,
        or a rate too slow to converge in the iterations left) or
        ``CONTINUE``.
    d : float
        The update's norm, ``sqrt((|beta' h^2 da / sx|^2 + |gamma' h da /
        sv|^2) / 2n)``.
    rate : float
        The convergence rate ``d / d_old`` (-1 at the first iteration).

    Notes
    -----
    Newton's method on ``r(a1) = a1 - a(t1, x1, xd1)``: ``da = -S^-1 r``,
    which moves the end state by ``dx1 = beta' h^2 da`` and ``dxd1 =
    gamma' h da``. The iteration has converged when what is left of these
    moves is small against what the step's error control allows, and the
    error control bounds positions only, by ``sx = atol + rtol |x|``.

    The scale of the speeds follows from that. A speed off by ``e`` at a
    step end moves the positions by about ``h e`` over the next step (and
    enters the position of the step end itself only through ``x1 = ... +
    h^2 beta abar1``, already counted in ``dx1``), so the speed error that
    matters at the position tolerance is ``sx / h``: hence ``sv = sx / |h|
    + rtol |xd1|``, the second term keeping a relative bound on large
    speeds. With this scale both parts of the norm measure ``da`` on the
    same footing, ``beta' h^2 |da| / sx`` and ``gamma' h^2 |da| / sx`` in
    the limit of small speeds: Newton stops once the acceleration is known
    to ``sx / h^2``, the accuracy the step's position error can use.
    Scaling ``dxd1`` by the position's ``atol`` itself (a speed bound in
    units of length) asks for ``1 / h`` times more, which on short steps
    costs iterations and Jacobians without changing the positions beyond
    the tolerance.

    Converged when ``rate / (1 - rate) d`` is below Newton's tolerance (or
    ``d = 0``); failed when ``rate >= 1`` or ``rate^(m - k) / (1 - rate) d``
    exceeds it, ``m`` the iterations allowed. At convergence ``w1 = w0 + h
    (g0 + g1) / 2`` (the trapezoidal rule on the further states).
    """
    for i in range(f.shape[0]):
        if not np.isfinite(f[i]):
            return FAILED, 0.0, -1.0
    da = _correct(f, lu, piv, n, a1)
    return _newton_test(f, da, h, n, k, d_old, par, atol, base, g0, a1, y1, abar1, scale)


@njit(cache=True)
def newton_apply(f, da, h, n, k, d_old, par, atol, base, g0, a1, y1, abar1, scale):
    """:func:`newton_update` with Newton's correction ``da`` given (solved elsewhere: a Krylov method).

    Parameters
    ----------
    f : ndarray, shape (2 n + n_w,)
        The right-hand side at ``(t1, y1)`` (finite).
    da : ndarray, shape (n,)
        The correction ``-S^-1 (a1 - f[n:2n])``, added to ``a1``.
    h, n, k, d_old, par, atol, base, g0, a1, y1, abar1, scale
        As for :func:`newton_update`.

    Returns
    -------
    outcome : int
        As for :func:`newton_update`.
    d, rate : float
        As for :func:`newton_update`.
    """
    for i in range(n):
        a1[i] = a1[i] + da[i]
    return _newton_test(f, da, h, n, k, d_old, par, atol, base, g0, a1, y1, abar1, scale)


@njit(cache=True)
def _newton_test(f, da, h, n, k, d_old, par, atol, base, g0, a1, y1, abar1, scale):
    """The convergence test of :func:`newton_update` after the correction ``da``, and the next iterate."""
    rtol, bp, gp = par[P_RTOL], par[P_BETA_P], par[P_GAMMA_P]
    if k == 0:
        for i in range(n):
            scale[0, i] = atol[i] + rtol * abs(y1[i])
            scale[1, i] = scale[0, i] / abs(h) + rtol * abs(y1[n + i])
    d = _update_norm(da, scale, bp * h * h, gp * h) if n else 0.0
    tol = par[P_NEWTON_TOL]
    rate = -1.0
    if d_old >= 0.0:
        rate = d / d_old if d_old > 0 else 0.0
        if rate >= 1.0 or rate ** float(NEWTON_MAXITER - k) / (1 - rate) * d > tol:
            return FAILED, d, rate
    converged = d == 0.0 or (rate >= 0.0 and rate / (1 - rate) * d < tol)
    for i in range(n):
        y1[i] = base[0, i] + bp * h * h * a1[i]
        y1[n + i] = base[1, i] + gp * h * a1[i]
    if converged:
        _step_end(f, h, n, par, base, g0, a1, y1, abar1)
        return CONVERGED, d, rate
    return CONTINUE, d, rate


@njit(cache=True)
def _step_factor(err, err_old):
    """The PI controller's step-size factor (1 within ``KEEP_BAND``), for errors ``err`` and ``err_old`` (0: none)."""
    if err == 0.0:
        factor = MAX_FACTOR
    elif err_old == 0.0:
        factor = SAFETY * err ** (-1.0 / 3.0)
    else:
        factor = SAFETY * err ** (-0.7 / 3.0) * err_old ** (0.4 / 3.0)
    factor = min(MAX_FACTOR, max(MIN_FACTOR, factor))
    if KEEP_BAND[0] <= factor < KEEP_BAND[1]:
        factor = 1.0
    return factor


@njit(cache=True)
def error_control(lu, piv, low_pass, abar0, abar1, y0, y1, n, h, h_abs, err_old, par, atol):
    """The local error estimate of a converged step, its norm, and the step size that follows.

    Parameters
    ----------
    lu, piv : ndarray
        LU factors of the iteration matrix (see :func:`lu_solve`).
    low_pass : ndarray, shape (n, n) or (0, 0)
        Projector of the estimate onto the modes of ``Jx`` below ``f_max``
        (empty: none).
    abar0, abar1 : ndarray, shape (n,)
        Algorithmic accelerations at the step start and end.
    y0, y1 : ndarray, shape (2 n + n_w,)
        States at the step start and end.
    n : int
        Number of positions.
    h, h_abs : float
        The step and its size, s.
    err_old : float
        The previous accepted step's error norm (0: none).
    par : ndarray, shape (N_PAR,)
        Method parameters (``P_*``; ``P_MIN_STEP`` 0 for no floor).
    atol : ndarray, shape (n,)
        Absolute tolerances of the positions.

    Returns
    -------
    accepted : bool
        The step passes the error test (or is taken at the step floor).
    err : float
        The estimate's RMS norm scaled by ``atol + rtol max(|x0|, |x1|)``.
    h_next : float
        If accepted, the next step's size (PI controller, kept in the band
        ``KEEP_BAND``, within ``[min_step, max_step]``); if not, the size to
        retry with.

    Notes
    -----
    The estimate is ``(1/6 - beta - (alpha_m - alpha_f) / 2) h^2 S^-1 (abar1
    - abar0)``, filtered by the iteration matrix S (as Radau filters its
    estimate) and projected by ``low_pass``. The PI controller (Gustafsson)
    takes ``0.9 err^(-0.7/3) err_old^(0.4/3)`` on the order-3 local error,
    within ``[MIN_FACTOR, MAX_FACTOR]``; a rejected step is retried at
    ``max(MIN_FACTOR, 0.9 err^(-1/3))`` times its size.
    """
    diff = np.empty(n)
    sol = np.empty(n)
    for i in range(n):
        diff[i] = abar1[i] - abar0[i]
    lu_solve(lu, piv, diff, sol)
    return error_test(sol, low_pass, y0, y1, n, h, h_abs, err_old, par, atol)


@njit(cache=True)
def error_test(sol, low_pass, y0, y1, n, h, h_abs, err_old, par, atol):
    """:func:`error_control` with the filtered difference ``S^-1 (abar1 - abar0)`` given (overwritten).

    Parameters
    ----------
    sol : ndarray, shape (n,)
        ``S^-1 (abar1 - abar0)``, S the iteration matrix or an approximation
        of it (the Newton preconditioner); used as scratch.
    low_pass, y0, y1, n, h, h_abs, err_old, par, atol
        As for :func:`error_control`.

    Returns
    -------
    accepted : bool
        As for :func:`error_control`.
    err, h_next : float
        As for :func:`error_control`.
    """
    ch2 = par[P_ERROR_CONSTANT] * h * h
    for i in range(n):
        sol[i] = ch2 * sol[i]
    est = _matvec(low_pass, sol) if low_pass.shape[0] else sol
    err = 0.0
    if n:
        rtol = par[P_RTOL]
        q = np.empty(n)
        for i in range(n):
            sc = atol[i] + rtol * max(abs(y0[i]), abs(y1[i]))
            q[i] = (est[i] / sc) ** 2
        err = np.sqrt(mean(q))
    floor, max_step = par[P_MIN_STEP], par[P_MAX_STEP]
    at_floor = floor > 0.0 and h_abs <= floor * (1.0 + 1e-12)
    if err > 1.0 and not at_floor:
        h_retry = h_abs * max(MIN_FACTOR, SAFETY * err ** (-1.0 / 3.0))
        return False, err, max(h_retry, floor)
    h_next = min(h_abs * _step_factor(err, err_old), max_step)
    if floor > 0.0:
        h_next = min(max(h_next, floor), max_step)
    return True, err, h_next


@njit(cache=True)
def restart_accelerations(y, y_end, a_end, Jx, Jv, offset, n):
    """The accelerations at a state moved (by a projection) from where a step ended, to first order.

    Parameters
    ----------
    y : ndarray, shape (2 n + n_w,)
        The moved state.
    y_end : ndarray, shape (2 n + n_w,)
        The state where the step ended.
    a_end : ndarray, shape (n,)
        Accelerations there.
    Jx, Jv : ndarray, shape (n, n)
        Blocks of the state Jacobian, ``da/dx`` and ``da/dxd``.
    offset : ndarray, shape (n,)
        ``abar - a`` at the step end, kept.
    n : int
        Number of positions.

    Returns
    -------
    a, abar : ndarray, shape (n,)
        ``a_end + Jx (x - x_end) + Jv (xd - xd_end)``, and ``a + offset``.
    """
    dx = np.empty(n)
    dv = np.empty(n)
    for i in range(n):
        dx[i] = y[i] - y_end[i]
        dv[i] = y[n + i] - y_end[n + i]
    jx, jv = _matvec(Jx, dx), _matvec(Jv, dv)
    a = np.empty(n)
    abar = np.empty(n)
    for i in range(n):
        a[i] = a_end[i] + jx[i] + jv[i]
        abar[i] = a[i] + offset[i]
    return a, abar
