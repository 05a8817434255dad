"""Generalized-alpha integration (Chung & Hulbert 1993) with error-controlled steps.

For mechanical state ``y = (x, xd, w)`` with ``xdd = a(t, x, xd)`` (and
``w`` optional first-order states that nothing depends on, such as the
integrated work of ``simulate(..., track_work=True)``). The scheme is the
generalized-alpha method in the form of Arnold & Bruels (2007) [2]_, which
satisfies the equations of motion at every step end and keeps, for
nonlinear problems, the second order of Chung & Hulbert [1]_::

    x1 = x0 + h xd0 + h^2 (1/2 - beta) abar0 + h^2 beta abar1
    xd1 = xd0 + h (1 - gamma) abar0 + h gamma abar1
    (1 - alpha_m) abar1 + alpha_m abar0 = (1 - alpha_f) a1 + alpha_f a0
    a1 = a(t1, x1, xd1)

``abar`` is the algorithmic acceleration, a filtered ``a`` that lags by
``(alpha_m - alpha_f) h``. The unknown is ``a1``; Newton's method on
``r(a1) = a1 - a(t1, x1, xd1)`` uses the iteration matrix
``I - gamma' h Jv - beta' h^2 Jx`` with ``beta' = beta (1 - alpha_f) / (1 -
alpha_m)``, ``gamma' = gamma (1 - alpha_f) / (1 - alpha_m)`` and the blocks
of the state Jacobian ``[[0, I], [Jx, Jv]]``, reused over steps while
Newton converges fast.

The step size follows a local error estimate of the positions,
``(1/6 - beta - (alpha_m - alpha_f) / 2) h^2 (abar1 - abar0)`` (the
Zienkiewicz-Xie estimate written for generalized-alpha: the leading term
of the local error when ``abar`` lags ``a`` by ``(alpha_m - alpha_f) h``),
under a PI controller (exponents 0.7/3 and 0.4/3). It is built from the
algorithmic accelerations, and filtered by the iteration matrix as Radau
filters its estimate, so a mode far above ``1 / h`` counts far less than
its true acceleration would make it. That is not enough when modes a few
times above the motion are excited (they are partly resolved, and their
error is real): ``f_max`` then projects the estimate onto the modes of
``Jx`` below ``f_max``, and the modes above are integrated stably and
dissipated, not resolved. Projecting is not enough either when such a
mode is only a few times above the steps' resolution: the estimate of a
mode integrated at ``h omega`` of about 0.1 is thousands of times the
tolerance, the projector (built from a Jacobian that lags the state) lets
a fraction of it through, and a mode that is partly resolved is not
dissipated at all (the spectral radius is 1 to within ``(h omega)^4``).
``min_step`` then keeps the error control from reducing the step below
it: every mode above ``1 / (2 pi min_step)`` Hz is integrated at ``h omega
>= 1`` and damped by the amplification factor of that step (see
:func:`numerical_damping`); a step taken at ``min_step`` is accepted even
when its error estimate exceeds the tolerance. The energy this removes is
for the caller to report (``simulate(..., track_work=True)``: driver work minus the change
of kinetic and elastic energy minus the dampers' work).

The step loop is plain Python over numpy right-hand sides (on B6 the
integrator's own work is under a tenth of a run's time); it is worth
compiling together with the right-hand side once that is.

References
----------
.. [1] J. Chung, G. M. Hulbert, J. Appl. Mech. 60 (1993) 371-375.
.. [2] M. Arnold, O. Bruels, Multibody Syst. Dyn. 18 (2007) 185-202.
"""

from __future__ import annotations

import weakref

import numpy as np
from scipy.integrate import DenseOutput, OdeSolver
from scipy.linalg import eig, lu_factor
from scipy.linalg.lapack import dgetrs as _getrs

__all__ = ["GeneralizedAlpha", "generalized_alpha", "alpha_parameters", "amplification_matrix",
           "numerical_damping", "DEFAULT_RHO_INF"]

#: spectral radius at infinite frequency used by default
DEFAULT_RHO_INF = 0.8

#: Newton iterations before a step is retried
NEWTON_MAXITER = 6
#: step-size change factors: smallest, largest, and the band in which the step is kept
MIN_FACTOR, MAX_FACTOR = 0.2, 5.0
KEEP_BAND = (1.0, 1.2)
SAFETY = 0.9

_EPS = np.finfo(float).eps


def _lu_solve(lu, b):
    """``S x = b`` from ``lu_factor``'s factors, by LAPACK getrs directly (scipy's ``lu_solve`` wrapper
    costs more than the solve at a few dozen coordinates)."""
    x, info = _getrs(lu[0], lu[1], b)
    if info != 0:
        raise ValueError(f"getrs failed (info {info})")
    return x


def alpha_parameters(rho_inf: float) -> tuple[float, float, float, float]:
    """The parameters of Chung & Hulbert's generalized-alpha method for a spectral radius ``rho_inf``.

    Parameters
    ----------
    rho_inf : float
        Spectral radius of the amplification matrix as ``h omega -> inf``,
        in [0, 1]: 1 keeps all frequencies (no dissipation, the trapezoidal
        rule), 0 annihilates the highest in one step.

    Returns
    -------
    alpha_m, alpha_f, beta, gamma : float
        ``alpha_m = (2 rho - 1) / (rho + 1)``, ``alpha_f = rho / (rho + 1)``,
        ``gamma = 1/2 + alpha_f - alpha_m``, ``beta = (gamma + 1/2)^2 / 4``.

    Raises
    ------
    ValueError
        If ``rho_inf`` is not in [0, 1].

    Notes
    -----
    Eqs. 25 and 17-18 of Chung & Hulbert (1993) [1]_ (their ``alpha_m``,
    ``alpha_f`` weight the old step end): second-order accurate,
    unconditionally stable for linear problems, with the high-frequency
    dissipation maximal for the low-frequency dissipation it costs.

    References
    ----------
    .. [1] J. Chung, G. M. Hulbert, "A time integration algorithm for
       structural dynamics with improved numerical dissipation: the
       generalized-alpha method", J. Appl. Mech. 60 (1993) 371-375.

    Examples
    --------
    >>> from flexmb.genalpha import alpha_parameters
    >>> alpha_parameters(1.0)
    (0.5, 0.5, 0.25, 0.5)
    """
    rho = float(rho_inf)
    if not 0.0 <= rho <= 1.0:
        raise ValueError(f"rho_inf must be in [0, 1], got {rho_inf!r}")
    alpha_m = (2.0 * rho - 1.0) / (rho + 1.0)
    alpha_f = rho / (rho + 1.0)
    gamma = 0.5 + alpha_f - alpha_m
    beta = 0.25 * (gamma + 0.5) ** 2
    return alpha_m, alpha_f, beta, gamma


def amplification_matrix(rho_inf: float, h_omega: float) -> np.ndarray:
    """One step of the method on the undamped oscillator ``xdd = -omega^2 x``, as a matrix.

    Parameters
    ----------
    rho_inf : float
        Spectral radius at infinity, in [0, 1].
    h_omega : float
        Step times angular frequency, ``h omega``.

    Returns
    -------
    ndarray, shape (3, 3)
        ``A`` with ``(x1, h xd1, h^2 abar1) = A (x0, h xd0, h^2 abar0)``;
        its spectral radius is the method's amplitude ratio per step, and
        tends to ``rho_inf`` as ``h_omega -> inf``.

    Examples
    --------
    >>> import numpy as np
    >>> from flexmb.genalpha import amplification_matrix
    >>> round(float(np.max(np.abs(np.linalg.eigvals(amplification_matrix(0.6, 1e8))))), 4)
    0.6
    """
    am, af, b, g = alpha_parameters(rho_inf)
    w2 = float(h_omega) ** 2
    # unknowns scaled by h: X = x, V = h xd, B = h^2 abar, a = -omega^2 x  (h^2 a = -w2 x)
    # abar1 = ((1 - af) a1 + af a0 - am abar0) / (1 - am); x1 = x0 + V0 + (1/2 - b) B0 + b B1
    # with h^2 a1 = -w2 x1: solve the linear 3 x 3 step equations for (x1, V1, B1)
    # rows: x1 - b B1 = x0 + V0 + (1/2 - b) B0
    #       V1 - g B1 = V0 + (1 - g) B0
    #       (1 - am) B1 + (1 - af) w2 x1 = -af w2 x0 - am B0
    lhs = np.array([[1.0, 0.0, -b], [0.0, 1.0, -g], [(1 - af) * w2, 0.0, 1 - am]])
    rhs = np.array([[1.0, 1.0, 0.5 - b], [0.0, 1.0, 1 - g], [-af * w2, 0.0, -am]])
    return np.linalg.solve(lhs, rhs)


def numerical_damping(rho_inf: float, h_omega) -> np.ndarray:
    """The damping ratio equivalent to the method's dissipation of an undamped mode, per step.

    A mode of angular frequency ``omega`` integrated with steps ``h`` loses
    the fraction ``1 - r`` of its amplitude per step, ``r`` the spectral
    radius of :func:`amplification_matrix`; a viscous damping ratio ``zeta``
    does the same over the time ``h`` when ``exp(-zeta omega h) = r``, so
    ``zeta = -ln(r) / (h omega)``.

    Parameters
    ----------
    rho_inf : float
        Spectral radius at infinity, in [0, 1].
    h_omega : float or array_like
        Step times angular frequency, ``h omega`` (> 0).

    Returns
    -------
    ndarray
        The equivalent damping ratio for each ``h_omega`` (``inf`` where
        ``rho_inf = 0`` annihilates the mode in one step).

    Examples
    --------
    >>> from flexmb.genalpha import numerical_damping
    >>> float(numerical_damping(1.0, 2.0))
    0.0
    >>> round(float(numerical_damping(0.6, 1.0)), 4)
    0.0051
    """
    hw = np.atleast_1d(np.asarray(h_omega, dtype=float))
    out = np.empty(hw.shape)
    for i, v in enumerate(hw):
        r = float(np.max(np.abs(np.linalg.eigvals(amplification_matrix(rho_inf, v)))))
        out[i] = np.inf if r <= 0.0 else max(0.0, -np.log(min(r, 1.0))) / v
    return out.reshape(np.shape(h_omega))


class GeneralizedAlphaDenseOutput(DenseOutput):
    """Interpolant over one generalized-alpha step.

    Positions: the cubic Hermite polynomial through ``x`` and ``xd`` at both
    ends. Speeds: ``xd0 + s (xd1 - xd0) + h (s^2 - s) (abar1 - abar0) / 2``
    (second order, and bounded by the algorithmic accelerations where a
    mode is not resolved). Further states: the quadratic whose end slopes
    are the rates at both ends (the trapezoidal rule at ``s = 1``).

    Parameters
    ----------
    t_old, t : float
        Step start and end, s.
    y_old, y : ndarray, shape (2 n + n_w,)
        States at both ends.
    abar_old, abar : ndarray, shape (n,)
        Algorithmic accelerations at both ends.
    g_old, g : ndarray, shape (n_w,)
        Rates of the further states at both ends.
    n : int
        Number of positions.
    """

    def __init__(self, t_old, t, y_old, y, abar_old, abar, g_old, g, n):
        super().__init__(t_old, t)
        self.h = t - t_old
        self.y_old, self.y_new = y_old, y
        self.abar_old, self.abar_new = abar_old, abar
        self.g_old, self.g_new = g_old, g
        self.n_pos = n

    def _call_impl(self, t):
        n, h = self.n_pos, self.h
        s = (np.atleast_1d(t) - self.t_old) / h
        x0, v0, w0 = self.y_old[:n, None], self.y_old[n : 2 * n, None], self.y_old[2 * n :, None]
        x1, v1 = self.y_new[:n, None], self.y_new[n : 2 * n, None]
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        x = h00 * x0 + h10 * h * v0 + h01 * x1 + h11 * h * v1
        dab = (self.abar_new - self.abar_old)[:, None]
        v = v0 + s * (v1 - v0) + 0.5 * h * (s * s - s) * dab
        g0, g1 = self.g_old[:, None], self.g_new[:, None]
        w = w0 + h * (s * g0 + 0.5 * s * s * (g1 - g0))
        y = np.vstack([x, v, w])
        return y[:, 0] if np.ndim(t) == 0 else y


#: memory of the last instance per right-hand side, for restarts at the time it stopped (see GeneralizedAlpha)
_MEMORY: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


class GeneralizedAlpha(OdeSolver):
    """Generalized-alpha method with error-controlled steps, for ``y = (x, xd, w)`` with ``xdd = a(t, x, xd)``.

    A :class:`scipy.integrate.OdeSolver`: ``simulate(..., method=
    "GeneralizedAlpha")`` or ``scipy.integrate.solve_ivp(..., method=
    GeneralizedAlpha, n_second=n)``. ``fun(t, y)`` returns ``(xd, xdd, g)``;
    the method dissipates the modes far above ``1 / h`` with the spectral
    radius ``rho_inf`` per step and integrates the rest to second order.
    Use :func:`generalized_alpha` for a class with another ``rho_inf``.

    Parameters
    ----------
    fun : callable
        ``fun(t, y)`` returning ``dy/dt``, shape (2 n + n_w,): its first n
        entries must equal ``y[n:2n]``.
    t0 : float
        Initial time, s.
    y0 : array_like, shape (2 n + n_w,)
        Initial state ``(x, xd, w)``.
    t_bound : float
        End time, s.
    n_second : int, optional
        n, the number of positions (default ``len(y0) // 2``).
    jac : callable, optional
        ``jac(t, y)``, the state Jacobian, shape (2 n + n_w, 2 n + n_w) with
        the block form ``[[0, I, 0], [Jx, Jv, 0], [0, 0, 0]]``; only ``Jx``
        and ``Jv`` are read. Default: forward differences of ``fun`` (2 n
        evaluations).
    rtol, atol : float or array_like
        Tolerances of the local position error estimate (``atol`` per
        position, or scalar).
    max_step : float
        Largest step, s.
    first_step : float, optional
        First step, s (default: from the initial accelerations).
    rho_inf : float, optional
        Spectral radius at infinity in [0, 1] (default: the class's
        ``rho_inf``, :data:`DEFAULT_RHO_INF` = 0.8).
    fixed_step : float, optional
        Take steps of this size (the last one shortened) with no error
        control; Newton failures then raise an error (default: the class's,
        None).
    f_max : float, optional
        Highest frequency (Hz) whose motion the error control resolves: the
        error estimate is projected onto the modes of ``Jx`` below it, so
        the modes above are integrated stably and dissipated where
        ``h omega > 1``, never resolved (default: the class's, None: every
        mode counts).
    min_step : float, optional
        Smallest step the error control may take, s: a step of this size is
        accepted even when its error estimate exceeds the tolerance, so every
        mode above ``1 / (2 pi min_step)`` Hz is integrated at ``h omega >=
        1`` and dissipated (:func:`numerical_damping`) rather than resolved.
        Newton failures may still halve the step below it (default: the
        class's, None: no floor).
    vectorized : bool
        Ignored (accepted for ``solve_ivp``).
    **extraneous
        Other options are ignored with a warning.

    Attributes
    ----------
    rho_inf : float
        Spectral radius at infinity in use.
    n_newton : int
        Newton iterations so far.
    n_rejected : int
        Rejected steps so far (error test or Newton failure).
    f_max : float or None
        Frequency cutoff of the error estimate in use, Hz.
    min_step : float or None
        Floor of the error-controlled steps in use, s.

    Notes
    -----
    Implemented in the form of Arnold & Bruels (2007) [2]_ of Chung &
    Hulbert's method [1]_ (see the module docstring): the equations of
    motion hold at each step end, the algorithmic accelerations ``abar``
    carry the history. The first step starts with ``abar0 = a(t0)``, which
    costs a transient of order h in ``abar`` that the dissipation removes.
    ``abar`` lags ``a`` by about ``(alpha_m - alpha_f) h``; a change of
    step from h to h' is not corrected for (scaling ``abar - a`` by
    ``h' / h`` would multiply the large ``a`` of unresolved modes), and
    adds a local error of order ``h^2 |h' - h|``, no more than a step's
    truncation error.

    A new instance created with the same ``fun`` object at the time where
    the previous one stopped (``simulate`` restarts after projecting the
    state onto the constraints) continues from the previous one's memory:
    its Jacobian, iteration matrix, step-size history and next step (in
    place of ``first_step``) and ``abar - a``; the accelerations at the
    moved state are the previous ones corrected to first order with the
    Jacobian (``a + Jx dx + Jv dxd``), which saves a right-hand side per
    restart.

    The class declares its capabilities (:mod:`flexmb.integrators.base`):
    implicit, uses the Jacobian's second-order block form, and always takes
    ``n_second``; ``simulate`` passes ``jac`` and ``n_second`` accordingly.

    References
    ----------
    .. [1] J. Chung, G. M. Hulbert, "A time integration algorithm for
       structural dynamics with improved numerical dissipation: the
       generalized-alpha method", J. Appl. Mech. 60 (1993) 371-375.
    .. [2] M. Arnold, O. Bruels, "Convergence of the generalized-alpha
       scheme for constrained mechanical systems", Multibody Syst. Dyn. 18
       (2007) 185-202.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.integrate import solve_ivp
    >>> from flexmb.genalpha import GeneralizedAlpha
    >>> sol = solve_ivp(lambda t, y: [y[1], -y[0]], (0.0, np.pi), [1.0, 0.0], method=GeneralizedAlpha,
    ...                 rtol=1e-8, atol=1e-10)
    >>> bool(abs(sol.y[0, -1] + 1.0) < 1e-5)
    True
    """

    rho_inf: float = DEFAULT_RHO_INF
    fixed_step: float | None = None
    f_max: float | None = None
    min_step: float | None = None
    explicit = False
    uses_jacobian = True
    second_order = True
    has_dense_output = True
    needs_n_second = True

    def __init__(self, fun, t0, y0, t_bound, *, n_second=None, jac=None, rtol=1e-6, atol=1e-8,
                 max_step=np.inf, first_step=None, rho_inf=None, fixed_step=None, f_max=None, min_step=None,
                 vectorized=False, **extraneous):
        if extraneous:
            import warnings

            warnings.warn(f"the following arguments have no effect for GeneralizedAlpha: "
                          f"{', '.join(sorted(extraneous))}", stacklevel=2)
        super().__init__(fun, t0, y0, t_bound, vectorized=False)
        if rho_inf is not None:
            self.rho_inf = float(rho_inf)
        if fixed_step is not None:
            self.fixed_step = float(fixed_step)
        if f_max is not None:
            self.f_max = float(f_max)
        if self.f_max is not None and not self.f_max > 0:
            raise ValueError(f"f_max must be > 0, got {self.f_max!r}")
        if min_step is not None:
            self.min_step = float(min_step)
        if self.min_step is not None and not self.min_step > 0:
            raise ValueError(f"min_step must be > 0, got {self.min_step!r}")
        self.alpha_m, self.alpha_f, self.beta, self.gamma = alpha_parameters(self.rho_inf)
        ratio = (1.0 - self.alpha_f) / (1.0 - self.alpha_m)
        self.beta_p, self.gamma_p = self.beta * ratio, self.gamma * ratio
        d_alpha = self.alpha_m - self.alpha_f
        self.error_constant = 1.0 / 6.0 - self.beta - 0.5 * d_alpha
        if n_second is None:
            if self.n % 2:
                raise ValueError("GeneralizedAlpha needs n_second when len(y0) is odd")
            n_second = self.n // 2
        self.n_pos = n = int(n_second)
        if not 0 < 2 * n <= self.n:
            raise ValueError(f"n_second must be in [1, len(y0) / 2], got {n_second}")
        self.rtol = max(float(rtol), 100 * _EPS)
        self.atol = np.broadcast_to(np.asarray(atol, dtype=float), (self.n,))[:n].copy()
        if np.any(self.atol < 0):
            raise ValueError("atol must be >= 0")
        if not max_step > 0:
            raise ValueError("max_step must be > 0")
        self.max_step = float(max_step)
        self._jac_fun = jac
        self.newton_tol = max(10 * _EPS / self.rtol, min(0.03, self.rtol**0.5))
        self.n_newton = 0
        self.n_rejected = 0

        self.J = None  # (Jx, Jv)
        self.low_pass = None  # projector of the error estimate onto the modes below f_max
        self.jac_current = False
        self.lu = None
        self.lu_h = None
        self.err_old = None
        self.h_abs_old = None
        memory = self._recall(fun, t0)
        h_next = None
        if memory is not None and memory[0] is not None:
            (self.J, self.low_pass, self.lu, self.lu_h, self.err_old, self.h_abs_old, offset, h_next,
             y_end, a_end, g_end) = memory
            # the state was moved by a projection (about the tolerance): a to first order in the move
            Jx, Jv = self.J
            self.a = a_end + Jx @ (self.y[:n] - y_end[:n]) + Jv @ (self.y[n : 2 * n] - y_end[n : 2 * n])
            self.g = g_end.copy()
            self.abar = self.a + offset
        else:
            f0 = self.fun(self.t, self.y)
            self.a = f0[n : 2 * n].copy()
            self.g = f0[2 * n :].copy()
            self.abar = self.a.copy()
        if self.fixed_step is not None:
            self.h_abs = min(abs(self.fixed_step), self.max_step)
        elif h_next is not None:
            self.h_abs = min(h_next, self.max_step)
        elif first_step is not None:
            if not first_step > 0:
                raise ValueError("first_step must be > 0")
            self.h_abs = min(float(first_step), self.max_step)
        else:
            self.h_abs = self._initial_step()
        if self.min_step is not None:
            self.h_abs = min(max(self.h_abs, self.min_step), self.max_step)
        self._fun_key = fun
        self._dense = None

    @property
    def step_size(self):
        """Size of the last step taken, s (None before the first step)."""
        return None if self.t_old is None else abs(self.t - self.t_old)

    # -- memory across restarts (simulate makes a new solver after each projection)
    @staticmethod
    def _recall(fun, t0):
        try:
            memory = _MEMORY.get(fun)
        except TypeError:
            return None
        if memory is None or memory[0] != t0:
            return None
        return memory[1]

    def _remember(self):
        try:
            _MEMORY[self._fun_key] = (self.t, (self.J, self.low_pass, self.lu, self.lu_h, self.err_old,
                                               self.h_abs_old, self.abar - self.a, self.h_abs, self.y, self.a,
                                               self.g))
        except TypeError:
            pass

    # -- helpers
    def _scale(self, x):
        return self.atol + self.rtol * np.abs(x)

    def _initial_step(self) -> float:
        """From the accelerations: the position error constant times h^3 a-dot at about the tolerance."""
        n = self.n_pos
        x, v = self.y[:n], self.y[n : 2 * n]
        sc = self._scale(x)
        d1 = np.sqrt(np.mean((v / sc) ** 2)) if n else 0.0
        d2 = np.sqrt(np.mean((self.a / sc) ** 2)) if n else 0.0
        # a step over which the second-order terms stay near the tolerance
        cands = [abs(self.t_bound - self.t), self.max_step]
        if d2 > 0:
            cands.append(0.1 * (1.0 / d2) ** 0.5)
        if d1 > 0:
            cands.append(0.1 / d1)
        return max(min(cands), 1e-12 * max(1.0, abs(self.t)))

    def _jacobian(self, t, y):
        """Jx, Jv at (t, y): from ``jac`` or by forward differences."""
        n = self.n_pos
        self.njev += 1
        if self._jac_fun is not None:
            J = np.asarray(self._jac_fun(t, y), dtype=float)
            return J[n : 2 * n, :n].copy(), J[n : 2 * n, n : 2 * n].copy()
        f0 = self.fun(t, y)[n : 2 * n]
        Jx, Jv = np.empty((n, n)), np.empty((n, n))
        for k in range(2 * n):
            d = np.sqrt(_EPS) * max(1.0, abs(y[k]))
            yp = y.copy()
            yp[k] += d
            col = (self.fun(t, yp)[n : 2 * n] - f0) / d
            if k < n:
                Jx[:, k] = col
            else:
                Jv[:, k - n] = col
        return Jx, Jv

    def _low_pass(self):
        """``I - sum v_k w_k^H / (w_k^H v_k)`` over the eigenpairs of Jx above f_max (None if none).

        Built from the high modes (distinct, well separated) with left and
        right eigenvectors, so the cluster of zero eigenvalues (constraint
        directions, rigid motions) needs no inverse.
        """
        if self.f_max is None:
            return None
        Jx = self.J[0]
        lam, W, V = eig(Jx, left=True, right=True, check_finite=False)
        high = np.abs(lam) > (2 * np.pi * self.f_max) ** 2
        if not np.any(high):
            return None
        V, W = V[:, high], W[:, high]
        d = np.einsum("ik,ik->k", W.conj(), V)
        return np.eye(len(Jx)) - ((V / d) @ W.conj().T).real

    def _factor(self, h):
        Jx, Jv = self.J
        n = self.n_pos
        S = np.eye(n) - (self.gamma_p * h) * Jv - (self.beta_p * h * h) * Jx
        self.lu = lu_factor(S, overwrite_a=True, check_finite=False)
        self.lu_h = h
        self.nlu += 1

    def _newton(self, t1, h):
        """Solve for a1 at t1 = t + h; returns (converged, x1, v1, a1, abar1, g1, n_iter, rate)."""
        n = self.n_pos
        x0, v0, w0 = self.y[:n], self.y[n : 2 * n], self.y[2 * n :]
        am, af, b, g = self.alpha_m, self.alpha_f, self.beta, self.gamma
        a0, abar0 = self.a, self.abar
        # the parts of x1, v1, abar1 known before the step; a1 enters through beta', gamma'
        abar_c = (af * a0 - am * abar0) / (1 - am)
        c = (1 - af) / (1 - am)
        x_c = x0 + h * v0 + h * h * ((0.5 - b) * abar0 + b * abar_c)
        v_c = v0 + h * ((1 - g) * abar0 + g * abar_c)
        a1 = a0.copy()
        sx, sv = None, None
        rate, d_old = None, None
        y1 = np.empty(self.n)
        y1[2 * n :] = w0
        for k in range(NEWTON_MAXITER):
            x1 = x_c + self.beta_p * h * h * a1
            v1 = v_c + self.gamma_p * h * a1
            y1[:n], y1[n : 2 * n] = x1, v1
            f = self.fun(t1, y1)
            self.n_newton += 1
            if not np.all(np.isfinite(f)):
                return False, None, None, None, None, None, k + 1, None
            da = -_lu_solve(self.lu, a1 - f[n : 2 * n])
            a1 = a1 + da
            if sx is None:
                sx, sv = self._scale(x1), self._scale(v1)
            d = np.sqrt(0.5 * (np.mean((self.beta_p * h * h * da / sx) ** 2)
                               + np.mean((self.gamma_p * h * da / sv) ** 2))) if n else 0.0
            if d_old is not None:
                rate = d / d_old if d_old > 0 else 0.0
                if rate >= 1.0 or rate ** (NEWTON_MAXITER - k) / (1 - rate) * d > self.newton_tol:
                    return False, None, None, None, None, None, k + 1, rate
            if d == 0.0 or (rate is not None and rate / (1 - rate) * d < self.newton_tol):
                x1 = x_c + self.beta_p * h * h * a1
                v1 = v_c + self.gamma_p * h * a1
                abar1 = abar_c + c * a1
                return True, x1, v1, a1, abar1, f[2 * n :], k + 1, rate
            d_old = d
        return False, None, None, None, None, None, NEWTON_MAXITER, rate

    def _step_impl(self):
        t, n = self.t, self.n_pos
        fixed = self.fixed_step is not None
        h_abs = min(self.h_abs, self.max_step)
        min_step = 10 * np.abs(np.nextafter(t, self.direction * np.inf) - t)
        while True:
            if h_abs < min_step:
                return False, "the step size fell below the smallest step (Newton or error test fails)"
            h = h_abs * self.direction
            t1 = t + h
            # a remainder of round-off size after this step is taken into it
            if self.direction * (t1 - self.t_bound) > -1e-9 * h_abs:
                t1 = self.t_bound
                h = t1 - t
                h_abs = abs(h)
            if self.J is None:
                self.J = self._jacobian(t, self.y)
                self.low_pass = self._low_pass()
                self.jac_current = True
                self.lu = None
            if self.lu is None or self.lu_h != h:
                self._factor(h)
            ok, x1, v1, a1, abar1, g1, n_iter, rate = self._newton(t1, h)
            if not ok:
                if not self.jac_current:
                    self.J = self._jacobian(t, self.y)
                    self.low_pass = self._low_pass()
                    self.jac_current = True
                    self.lu = None
                    continue
                if fixed:
                    return False, f"Newton's method failed at t = {t1:.9g} with the fixed step {h_abs:.3g}"
                self.n_rejected += 1
                h_abs *= 0.5
                self.lu = None
                continue
            if fixed:
                err = 0.0
                factor = 1.0
                break
            # filtered by the iteration matrix (as Radau filters its estimate): modes far above 1 / h,
            # which the method dissipates instead of resolving, do not set the step
            est = self.error_constant * h * h * _lu_solve(self.lu, abar1 - self.abar)
            if self.low_pass is not None:
                est = self.low_pass @ est
            sc = self.atol + self.rtol * np.maximum(np.abs(self.y[:n]), np.abs(x1))
            err = float(np.sqrt(np.mean((est / sc) ** 2))) if n else 0.0
            floor = self.min_step
            at_floor = floor is not None and h_abs <= floor * (1.0 + 1e-12)
            if err > 1.0 and not at_floor:
                self.n_rejected += 1
                h_abs *= max(MIN_FACTOR, SAFETY * err ** (-1.0 / 3.0))
                if floor is not None:
                    h_abs = max(h_abs, floor)
                continue
            # PI control (Gustafsson): exponents 0.7/3 and 0.4/3 on the order-3 local error
            if err == 0.0:
                factor = MAX_FACTOR
            elif self.err_old is None or self.err_old == 0.0:
                factor = SAFETY * err ** (-1.0 / 3.0)
            else:
                factor = SAFETY * err ** (-0.7 / 3.0) * self.err_old ** (0.4 / 3.0)
            factor = min(MAX_FACTOR, max(MIN_FACTOR, factor))
            break

        y_old, abar_old, g_old = self.y, self.abar, self.g
        y1 = np.concatenate([x1, v1, self.y[2 * n :] + 0.5 * h * (self.g + g1)])
        self._dense = (y_old, abar_old, g_old)
        self.y, self.t = y1, t1
        self.a, self.abar, self.g = a1, abar1, g1
        self.h_abs_old = h_abs
        self.err_old = max(err, 1e-10) if not fixed else None
        # a Jacobian that let Newton converge slowly is refreshed before the next step
        if self.jac_current:
            self.jac_current = False
        elif n_iter > 2 and rate is not None and rate > 1e-3:
            self.J = None
        if not fixed:
            if KEEP_BAND[0] <= factor < KEEP_BAND[1]:
                factor = 1.0
            self.h_abs = min(h_abs * factor, self.max_step)
            if self.min_step is not None:
                self.h_abs = min(max(self.h_abs, self.min_step), self.max_step)
        self._remember()
        return True, None

    def _dense_output_impl(self):
        y_old, abar_old, g_old = self._dense
        return GeneralizedAlphaDenseOutput(self.t_old, self.t, y_old, self.y, abar_old, self.abar, g_old,
                                           self.g, self.n_pos)


def generalized_alpha(rho_inf: float = DEFAULT_RHO_INF, fixed_step: float | None = None,
                      f_max: float | None = None, min_step: float | None = None) -> type:
    """A :class:`GeneralizedAlpha` class with a spectral radius, and optionally a fixed step, a cutoff or a step floor.

    Parameters
    ----------
    rho_inf : float
        Spectral radius at infinity in [0, 1]: 1 keeps every frequency (no
        dissipation), smaller values remove more of the modes far above
        ``1 / h`` per step.
    fixed_step : float, optional
        Fixed step size, s (no error control); default: error-controlled
        steps.
    f_max : float, optional
        Highest frequency resolved by the error control, Hz (see
        :class:`GeneralizedAlpha`); default: all.
    min_step : float, optional
        Smallest error-controlled step, s (see :class:`GeneralizedAlpha`):
        the modes above ``1 / (2 pi min_step)`` Hz are dissipated, never
        resolved; default: no floor.

    Returns
    -------
    type
        A subclass of :class:`GeneralizedAlpha`, to pass as ``method`` to
        :func:`flexmb.simulate` or :func:`scipy.integrate.solve_ivp`.

    Raises
    ------
    ValueError
        If ``rho_inf`` is not in [0, 1], or ``fixed_step``, ``f_max`` or
        ``min_step`` is not positive.

    Examples
    --------
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    >>> _ = model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0, -9.81, 0)))
    >>> res = fm.simulate(model, 0.5, positions={"pin": 0.5}, method=fm.generalized_alpha(rho_inf=0.6), rtol=1e-6)
    >>> res.method
    'GeneralizedAlpha(rho_inf=0.6)'
    """
    alpha_parameters(rho_inf)  # validates
    if fixed_step is not None and not float(fixed_step) > 0:
        raise ValueError(f"fixed_step must be > 0, got {fixed_step!r}")
    if f_max is not None and not float(f_max) > 0:
        raise ValueError(f"f_max must be > 0, got {f_max!r}")
    if min_step is not None and not float(min_step) > 0:
        raise ValueError(f"min_step must be > 0, got {min_step!r}")
    label = (f"rho_inf={float(rho_inf):g}" + (f", fixed_step={float(fixed_step):g}" if fixed_step else "")
             + (f", f_max={float(f_max):g}" if f_max else "")
             + (f", min_step={float(min_step):g}" if min_step else ""))
    return type(f"GeneralizedAlpha({label})", (GeneralizedAlpha,),
                {"rho_inf": float(rho_inf), "fixed_step": None if fixed_step is None else float(fixed_step),
                 "f_max": None if f_max is None else float(f_max),
                 "min_step": None if min_step is None else float(min_step),
                 "__module__": __name__, "__doc__": f"GeneralizedAlpha with {label}."})
