"""The generalized-alpha solver: :class:`GeneralizedAlpha`, its dense output, and configured classes.

The method, its error estimate and step control are described in
:mod:`flexmb.genalpha`; the arithmetic of a step is compiled
(:mod:`flexmb.kernels.genalpha`), this module calls the right-hand side
and keeps the bookkeeping: Jacobians, LU factors, the memory across
restarts, rejections and counts.

References
----------
.. [1] J. Chung, G. M. Hulbert, J. Appl. Mech. 60 (1993) 371-375.
.. [2] M. Arnold, O. Bruels, Multibody Syst. Dyn. 18 (2007) 185-202.
"""

from __future__ import annotations

import math
import weakref

import numpy as np
from scipy.integrate import OdeSolver
from scipy.linalg import lu_factor

from ..kernels import genalpha as kernels
from .chart import ChartDenseOutput, RotationChart
from .dense import GeneralizedAlphaDenseOutput
from .jacobian import forward_differences, low_pass, warn_f_max_cost
from .krylov import KRYLOV_MIN_COORDS, KRYLOV_MIN_LOOP_COORDS, KrylovNewton
from .parameters import DEFAULT_RHO_INF, settings

__all__ = ["GeneralizedAlpha", "GeneralizedAlphaDenseOutput"]

_EPS = np.finfo(float).eps
#: after a Newton failure, the factor per accepted step by which the step may grow back (see ``_accept``)
NEWTON_REGROWTH = 1.05
#: the error estimate's projector when there is none (``f_max`` not set, or no mode above it)
_NO_LOW_PASS = np.empty((0, 0))

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
        mode counts). It needs the dense Jacobian's eigenvectors: O(n^3)
        time and n x n complex memory at each new Jacobian (a warning from
        ``F_MAX_WARN_SIZE`` positions on), and no ``preconditioner``.
    min_step : float, optional
        Smallest step the error control may take, s: a step of this size is
        accepted even when its error estimate exceeds the tolerance, so every
        mode above ``1 / (2 pi min_step)`` Hz is integrated at ``h omega >=
        1`` and dissipated (:func:`numerical_damping`) rather than resolved.
        Newton failures may still halve the step below it, and the steps
        after one grow back by at most ``NEWTON_REGROWTH`` a step (default:
        the class's, None: no floor).
    preconditioner : NewtonPreconditioner, optional
        The model's O(n) Newton preconditioner
        (:meth:`flexmb.System.newton_preconditioner`): the Newton systems
        are then solved without a matrix (:mod:`flexmb.genalpha.krylov`:
        its ``solve_accelerations`` as the iteration matrix until Newton
        fails with it, then GMRES with products by differences of ``fun``,
        preconditioned by it), and ``jac`` is not used. ``simulate``
        passes it from ``krylov_min_coords`` speeds on (open trees) or
        ``krylov_min_loop_coords`` (loops).
    layout : StateLayout, optional
        For a state ``(q, u, w)`` whose coordinates are not the speeds'
        integrals (Euler parameters, ``qd = W(q) u``,
        :mod:`flexmb.state_layout`): the layout, ``len(q) = layout.nq``
        and ``n_second = layout.n``. The rotations are then stepped on
        their group (:mod:`flexmb.genalpha.chart`). Default: ``y = (x, xd,
        w)`` with ``xd`` the rates of ``x``.
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
    n_krylov : int
        GMRES iterations so far (products with the Newton matrix; 0 on
        the dense path).
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

    ``simulate`` projects the state onto the constraints in place
    (:meth:`move_to`, the accelerations made consistent with the moved
    state). A new instance created with the same ``fun`` object at the
    time where the previous one stopped (a restart at a contact event)
    continues from the previous one's memory:
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
    uses_preconditioner = True
    #: Speeds from which simulate passes the O(n) Newton preconditioner (matrix-free Newton solves), open trees.
    krylov_min_coords = KRYLOV_MIN_COORDS
    #: Speeds from which simulate passes the O(n m) Newton preconditioner, models with loops.
    krylov_min_loop_coords = KRYLOV_MIN_LOOP_COORDS
    second_order = True
    has_dense_output = True
    needs_n_second = True
    rebases = True
    moves = True

    def __init__(self, fun, t0, y0, t_bound, *, n_second=None, jac=None, rtol=1e-6, atol=1e-8,
                 max_step=np.inf, first_step=None, rho_inf=None, fixed_step=None, f_max=None, min_step=None,
                 preconditioner=None, layout=None, vectorized=False, **extraneous):
        if extraneous:
            import warnings

            warnings.warn(f"the following arguments have no effect for GeneralizedAlpha: "
                          f"{', '.join(sorted(extraneous))}", stacklevel=2)
        super().__init__(fun, t0, y0, t_bound, vectorized=False)
        self._configure(n_second, rtol, atol, max_step, rho_inf, fixed_step, f_max, min_step)
        # z: the state the step works on; y itself unless rotations are stepped in a chart (chart.py)
        self._chart = None if layout is None or layout.identity else RotationChart(layout)
        if self._chart is None:
            self.z, self._zfun = self.y, self.fun
        else:
            self.z, self._zfun = self._chart.enter(self.y), self._chart.rate(self.fun)
            self.atol = self._chart.tolerance(self.atol, self.rtol)
        self._jac_fun = jac
        self._krylov = self._matrix_free(preconditioner, layout)
        self.n_newton = 0
        self.n_rejected = 0
        self.J = None  # (Jx, Jv)
        self.low_pass = None  # projector of the error estimate onto the modes below f_max
        self.jac_current = False
        self.lu = None  # (LU factors, C-contiguous; row interchanges) of the iteration matrix
        self.lu_h = None
        self.err_old = None
        self.h_abs_old = None
        self.h_newton = np.inf  # the bound on the step after a Newton failure (see _accept)
        h_next = self._start(fun, t0)
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

    def _configure(self, n_second, rtol, atol, max_step, rho_inf, fixed_step, f_max, min_step):
        """Check and set the options, the method's parameters and the kernels' parameter array."""
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
        if n_second is None:
            if self.n % 2:
                raise ValueError("GeneralizedAlpha needs n_second when len(y0) is odd")
            n_second = self.n // 2
        self.n_pos = n = int(n_second)
        if not 0 < 2 * n <= self.n:
            raise ValueError(f"n_second must be in [1, len(y0) / 2], got {n_second}")
        if not max_step > 0:
            raise ValueError("max_step must be > 0")
        self.rtol = max(float(rtol), 100 * _EPS)
        self.max_step = float(max_step)
        # cached for a scalar atol: simulate may make many solvers (contact events)
        chosen = (settings(self.rho_inf, self.rtol, float(atol), n, self.n, self.max_step, self.min_step)
                  if np.ndim(atol) == 0 else
                  settings.__wrapped__(self.rho_inf, self.rtol, atol, n, self.n, self.max_step, self.min_step))
        (self.alpha_m, self.alpha_f, self.beta, self.gamma, self.beta_p, self.gamma_p, self.error_constant,
         self.newton_tol, self.atol, self._par) = chosen

    def _matrix_free(self, preconditioner, layout):
        """The matrix-free Newton solves with ``preconditioner`` (None without one); checks ``f_max``'s cost."""
        if preconditioner is None:
            if self.f_max is not None:
                warn_f_max_cost(self.n_pos)
            return None
        if self.f_max is not None:
            raise ValueError("GeneralizedAlpha: f_max needs the dense Jacobian's eigenvectors, which the matrix-free "
                             "Newton solves (preconditioner) never form: give one or the other")
        return KrylovNewton(preconditioner, self._zfun, self.n_pos, self.n_pos if layout is None else layout.nq)

    def _start(self, fun, t0):
        """Accelerations at the start: from the previous instance's memory, or a right-hand side.

        Returns the previous instance's next step size (None without memory).
        """
        n = self.n_pos
        memory = self._recall(fun, t0)
        if memory is not None and (memory[0] is not None or (self._krylov is not None and memory[-1])):
            (self.J, self.low_pass, self.lu, self.lu_h, self.err_old, self.h_abs_old, offset, h_next,
             z_end, a_end, g_end, self.h_newton, centre, ready) = memory
            if self.J is None:  # matrix-free: the accelerations at the moved state (as costly as a product)
                self._krylov.ready = ready
                self.a = self._zfun(self.t, self.z)[n : 2 * n].copy()
                self.abar = self.a + offset
            else:  # the state was moved by a projection (about the tolerance): a to first order in the move
                Jx, Jv = self.J
                z = self.z if self._chart is None else self._chart.relative(self.y, centre)
                self.a, self.abar = kernels.restart_accelerations(z, z_end, a_end, Jx, Jv, offset, n)
            self.g = g_end.copy()
            return h_next
        f0 = self._zfun(self.t, self.z)
        self.a = f0[n : 2 * n].copy()
        self.g = f0[2 * n :].copy()
        self.abar = self.a.copy()
        return None

    @property
    def n_krylov(self):
        """GMRES iterations so far (0 on the dense path)."""
        return 0 if self._krylov is None else self._krylov.n_krylov

    @property
    def step_size(self):
        """Size of the last step taken, s (None before the first step)."""
        return None if self.t_old is None else abs(self.t - self.t_old)

    # -- memory across restarts (simulate makes a new solver at a contact event)
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
                                               self.h_abs_old, self.abar - self.a, self.h_abs, self.z, self.a,
                                               self.g, self.h_newton,
                                               None if self._chart is None else self._chart.centre,
                                               self._krylov is not None and self._krylov.ready))
        except TypeError:
            pass

    # -- helpers
    def _initial_step(self) -> float:
        """From the accelerations: the position error constant times h^3 a-dot at about the tolerance."""
        n = self.n_pos
        x, v = self.z[:n], self.z[n : 2 * n]
        sc = self.atol + self.rtol * np.abs(x)
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
        """Jx, Jv at (t, y) (a state of the step, ``z``): from ``jac`` or by forward differences."""
        n = self.n_pos
        self.njev += 1
        if self._jac_fun is not None:
            if self._chart is not None:  # along the chart: (da/dq) W(q)
                return self._chart.jacobian(np.asarray(self._jac_fun(t, self._chart.state(y)), dtype=float), y)
            J = np.asarray(self._jac_fun(t, y), dtype=float)
            return J[n : 2 * n, :n].copy(), J[n : 2 * n, n : 2 * n].copy()
        return forward_differences(self._zfun, t, y, n)

    def _new_jacobian(self, t, y):
        """A Jacobian at the step start, the low-pass projector from it; the LU factors to redo.

        On the matrix-free path the preconditioner's set-up at the step
        start (``self.y``) takes the Jacobian's place (counted in ``njev``).
        """
        if self._krylov is not None:
            self.njev += 1
            self._krylov.setup(t, self.y)
            self.jac_current = True
            return
        self.J = self._jacobian(t, y)
        self.low_pass = None if self.f_max is None else low_pass(self.J[0], self.f_max)
        self.jac_current = True
        self.lu = None

    def _factor(self, h):
        Jx, Jv = self.J
        n = self.n_pos
        S = np.eye(n) - (self.gamma_p * h) * Jv - (self.beta_p * h * h) * Jx
        lu, piv = lu_factor(S, overwrite_a=True, check_finite=False)
        self.lu = (np.ascontiguousarray(lu), piv)
        self.lu_h = h
        self.nlu += 1

    def _newton(self, t1, h):
        """Solve for a1 at t1 = t + h: ((y1, a1, abar1, g1) or None if it failed, iterations, last rate).

        Python calls the right-hand side; the arithmetic between two calls
        is one compiled :func:`~flexmb.kernels.genalpha.newton_update`.
        """
        n = self.n_pos
        base, a1, y1 = np.empty((3, n)), np.empty(n), np.empty(len(self.z))
        abar1, scale = np.empty(n), np.empty((2, n))
        kernels.predict(self.z, self.a, self.abar, h, n, self._par, base, a1, y1)
        if self._krylov is not None:
            return self._krylov.newton(self, t1, h, base, a1, y1, abar1, scale)
        lu, piv = self.lu
        d, rate = -1.0, -1.0
        for k in range(kernels.NEWTON_MAXITER):
            f = self._zfun(t1, y1)
            self.n_newton += 1
            outcome, d, rate = kernels.newton_update(f, lu, piv, h, n, k, d, self._par, self.atol, base, self.g,
                                                     a1, y1, abar1, scale)
            if outcome == kernels.CONVERGED:
                return (y1, a1, abar1, f[2 * n :]), k + 1, rate
            if outcome == kernels.FAILED:
                return None, k + 1, rate
        return None, kernels.NEWTON_MAXITER, rate

    def _error_control(self, end, h, h_abs):
        """The error test of a converged step (see :func:`~flexmb.kernels.genalpha.error_control`).

        The estimate is filtered by the iteration matrix: its LU factors on
        the dense path, the preconditioner's solve on the matrix-free one
        (the stiff springs and dampers exactly, as S holds them).
        """
        if self._krylov is None:
            return kernels.error_control(
                *self.lu, _NO_LOW_PASS if self.low_pass is None else self.low_pass, self.abar, end[2], self.z,
                end[0], self.n_pos, h, h_abs, self.err_old or 0.0, self._par, self.atol)
        sol = self._krylov.precondition(end[2] - self.abar, self.gamma_p * h, self.beta_p * h * h)
        return kernels.error_test(np.array(sol, dtype=float), _NO_LOW_PASS, self.z, end[0], self.n_pos, h, h_abs,
                                  self.err_old or 0.0, self._par, self.atol)

    def _step_impl(self):
        t, direction = self.t, float(self.direction)
        fixed = self.fixed_step is not None
        h_abs = min(self.h_abs, self.max_step)
        smallest = 10 * abs(math.nextafter(t, direction * math.inf) - t)
        while True:
            if h_abs < smallest:
                return False, "the step size fell below the smallest step (Newton or error test fails)"
            h = h_abs * direction
            t1 = t + h
            # a remainder of round-off size after this step is taken into it
            if direction * (t1 - self.t_bound) > -1e-9 * h_abs:
                t1 = self.t_bound
                h = t1 - t
                h_abs = abs(h)
            if self.J is None and (self._krylov is None or not self._krylov.ready):
                self._new_jacobian(t, self.z)
            if self._krylov is None and (self.lu is None or self.lu_h != h):
                self._factor(h)
            end = self._newton(t1, h)[0]
            if end is None:
                if self._krylov is not None and not self._krylov.exact:  # the preconditioner alone failed: GMRES
                    self._krylov.exact = True
                    continue
                if not self.jac_current:
                    self._new_jacobian(t, self.z)
                    continue
                if fixed:
                    return False, f"Newton's method failed at t = {t1:.9g} with the fixed step {h_abs:.3g}"
                self.n_rejected += 1
                h_abs *= 0.5
                self.h_newton = h_abs
                self.lu = None
                continue
            if fixed:
                break
            # filtered by the iteration matrix (as Radau filters its estimate): modes far above 1 / h,
            # which the method dissipates instead of resolving, do not set the step
            accepted, err, h_next = self._error_control(end, h, h_abs)
            if accepted:
                break
            self.n_rejected += 1
            h_abs = h_next
        self._accept(t1, h_abs, end, None if fixed else err, None if fixed else h_next)
        return True, None

    def _accept(self, t1, h_abs, end, err, h_next):
        """Take the step to t1: the new state, the error history, the Jacobian's fate, the next step size.

        The next step is the error control's, but at most the halved step of
        the last Newton failure times ``NEWTON_REGROWTH`` per step since: the
        error control knows nothing of Newton, and without the bound went
        straight back to the failing step (a Jacobian and an LU each time).
        """
        z1, self.a, abar_old, self.abar, g_old, self.g = end[0], end[1], self.abar, end[2], self.g, end[3]
        chart = self._chart
        if chart is None:
            self._dense = (self.z, abar_old, g_old, z1, None, None)
            self.y = self.z = z1
        else:  # the interpolant in the step's chart; then the chart moves to the step's end
            self._dense = (self.z, abar_old, g_old, z1, chart.centre, chart.end_slope(z1))
            self.y = chart.state(z1)
            self.z = chart.recentre(z1)
        self.t = t1
        self.h_abs_old = h_abs
        self.err_old = None if err is None else max(err, 1e-10)
        # the Jacobian is kept until Newton fails with it (_step_impl): a Newton iteration that converges
        # slowly converges all the same (taking a new one then cost more than the iterations it saved)
        self.jac_current = False
        if h_next is not None:
            self.h_newton *= NEWTON_REGROWTH
            self.h_abs = min(h_next, self.h_newton)
        self._remember()

    def rebase(self, shift) -> None:
        """Move the origin of the state, ``y -> y - shift``, where the motion is unchanged.

        The caller's right-hand side adds ``shift`` back from now on
        (:func:`flexmb.simulate` keeps winding angles near zero so). The
        accelerations, the Jacobian, its factors and the step-size history
        stay; the state, the last step's start (for the interpolant) and the
        memory for restarts move, so no step is lost.

        Parameters
        ----------
        shift : ndarray, shape (len(y),)
            What to subtract from the state.
        """
        shift = np.asarray(shift, dtype=float)
        moved = shift if self._chart is None else self._chart.shift(shift)  # never a rotation
        self.y = self.y - shift
        self.z = self.y if self._chart is None else self.z - moved
        if self._dense is not None:
            z_old, abar_old, g_old, z_new, centre, slope = self._dense
            self._dense = (z_old - moved, abar_old, g_old, z_new - moved, centre, slope)
        if self.t_old is not None:
            self._remember()

    def move_to(self, y) -> None:
        """Continue from ``y``, a state moved off the last step's end (a projection onto the constraints).

        A one-step method's history is its last accelerations: they are made
        consistent with the moved state, and everything else (the Jacobian,
        its factors, the error and step-size history) stays, so no new
        solver is made and no step is lost.

        Parameters
        ----------
        y : ndarray, shape (len(y),)
            The moved state, at the same time.

        Notes
        -----
        The step equations need ``a0 = a(t, x0, xd0)`` (the equations of
        motion hold at every step end) and the algorithmic accelerations
        ``abar0``, a filter of the past ``a`` that lags them: for a smooth
        motion ``abar - a = (alpha_m - alpha_f) h da/dt + O(h^2)``. A move
        ``(dx, dxd)`` changes ``a`` by ``Jx dx + Jv dxd`` to first order and
        the lag only by ``O(h |dx|)``. So ``a`` is corrected with the
        Jacobian in use (a right-hand side at the moved state when a
        Jacobian is due anyway), and ``abar`` keeps its lag: ``abar = a +
        (abar_old - a_old)``. Setting ``abar = a`` instead (as at the first
        step) would drop a term of order ``h``, a first-order error on every
        move, where keeping the lag costs ``O(h |dx| + |dx|^2)``. The
        further states ``w`` and their rates are kept. The dense output of
        the last step is unchanged (the caller stored its outputs before
        the move). A step below ``min_step`` (after a Newton failure) is
        raised to it, as at a start.

        With Euler parameters (:mod:`flexmb.genalpha.chart`) the move is
        taken in the present chart (the rotation vectors from its centre to
        the moved rotations, along which ``Jx`` is formed), and the chart is
        then centred at the moved state. The speeds and accelerations of a
        rotation are body-axes vectors, the same in every chart, so only the
        correction above changes them.
        """
        n, chart = self.n_pos, self._chart
        y = np.array(y, dtype=float)
        z = y if chart is None else chart.relative(y, chart.centre)  # the move in the present chart
        lag = self.abar - self.a
        if self.J is not None:
            Jx, Jv = self.J
            self.a, self.abar = kernels.restart_accelerations(z, self.z, self.a, Jx, Jv, lag, n)
        else:
            self.a = self._zfun(self.t, z)[n : 2 * n].copy()
            self.abar = self.a + lag
        if chart is None:
            self.y = self.z = y
        else:  # the chart centred at the moved state (unit Euler parameters, as after every step)
            self.z = chart.enter(y)
            self.y = chart.state(self.z)
        if self.min_step is not None:  # as at a start (and as a new solver did after each projection)
            self.h_abs = min(max(self.h_abs, self.min_step), self.max_step)
        self._remember()

    def _dense_output_impl(self):
        z_old, abar_old, g_old, z_new, centre, slope = self._dense
        args = (self.t_old, self.t, z_old, z_new, abar_old, self.abar, g_old, self.g, self.n_pos)
        if self._chart is None:
            return GeneralizedAlphaDenseOutput(*args)
        return ChartDenseOutput(self._chart, centre, *args, slope_new=slope)
