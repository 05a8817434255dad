"""SUNDIALS CVODE (variable-order BDF and Adams) and IDA as scipy ``OdeSolver`` subclasses, through scikit-sundae.

The solvers' step loop, error control, Newton iteration and dense LU run in
C; Python is entered only for the right-hand side, the Jacobian and once
per step. The classes drive CVODE (or IDA, on the residual
``y' - f(t, y)``) one internal step at a time (``CV_ONE_STEP`` /
``IDA_ONE_STEP`` with a stop time at ``t_bound``), so they behave as any
scipy solver: ``step()``, ``dense_output()`` (the solver's own
interpolant, ``CVodeGetDky`` / ``IDAGetDky``), ``t``, ``y``,
``step_size``, ``nfev``, ``njev``. They can be given to
:func:`scipy.integrate.solve_ivp` as ``method`` (with ``t_eval``; not with
``dense_output=True``, which keeps the interpolants of past steps: the
solver's is valid only over its last step).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import DenseOutput, OdeSolver

from .cvode_options import KRYLOV_DIM, MAX_STEPS

__all__ = ["CVODE", "CVODEBDF", "CVODEAdams", "IDA", "CVODEDenseOutput", "KRYLOV_DIM", "MAX_STEPS"]

#: the flag of a call that returned at a root (CV_ROOT_RETURN, IDA_ROOT_RETURN)
ROOT_RETURN = 2


class CVODE(OdeSolver):
    """SUNDIALS CVODE, stepped one internal step at a time (base of :class:`CVODEBDF` and :class:`CVODEAdams`).

    A subclass only sets the class attributes: ``family`` ({'BDF',
    'Adams'}), ``max_order``, ``linsolver``. A solver other than CVODE
    (:class:`IDA`) replaces the three methods that speak to it:
    ``_create`` (the scikit-sundae object, initialised), ``_jacfn`` (its
    Jacobian callback) and ``_krylov`` (its preconditioned GMRES options).

    Parameters
    ----------
    fun : callable
        Right-hand side ``fun(t, y) -> ydot``.
    t0 : float
        Initial time.
    y0 : array_like, shape (m,)
        Initial state.
    t_bound : float
        End time; CVODE does not step past it.
    rtol, atol : float or array_like
        Relative and absolute tolerances (CVODE's weighted RMS norm).
    max_step : float
        Largest step (``np.inf``: unbounded).
    first_step : float, optional
        First step size (default: CVODE's estimate).
    jac : callable or array_like, optional
        State Jacobian ``jac(t, y) -> (m, m)``, or a constant matrix;
        default: CVODE's internal finite differences.
    events : (callable, int, array_like), optional
        ``(g, m, direction)``: CVODE's root finding on the m functions
        ``g(t, y)`` (contact gaps, :mod:`flexmb.contact_events`), each
        watched for crossings in its ``direction`` (+1 rising, -1 falling,
        0 both); a step then ends at the first root within it, located to
        CVODE's root tolerance (about 100 unit roundoffs of
        ``max(|t|, |h|)``), and :attr:`root` holds the directions that
        changed there (``+1``, ``-1``, 0), None after a step without a
        root.
    preconditioner : NewtonPreconditioner, optional
        For an open tree (:meth:`flexmb.System.newton_preconditioner`):
        the linear systems are solved by GMRES, preconditioned by its O(n)
        solve of ``(I - gamma J) z = r`` (the coordinate springs and
        dampers exactly; the rest left to the Krylov iterations), with
        Jacobian-vector products by differences of the right-hand side. No
        matrix is formed: O(n) per step. ``jac`` is then not used.
    max_order : int, optional
        The method's largest order (default: the class's ``max_order``).
    vectorized : bool
        Ignored (accepted for :func:`scipy.integrate.solve_ivp`).
    **extraneous
        Other scipy options, ignored.

    Notes
    -----
    The linear systems are ``(I - gamma J) d = r`` of size m, solved by
    SUNDIALS' dense LU (``linsolver = 'dense'``); CVODE re-evaluates the
    Jacobian only when its Newton iteration converges badly or every 50
    steps, and refactors when ``gamma`` changes by more than 30 % or every
    20 steps [1]_.

    References
    ----------
    .. [1] A. C. Hindmarsh et al., "SUNDIALS: Suite of nonlinear and
       differential/algebraic equation solvers", ACM TOMS 31 (2005) 363-396.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.integrate import solve_ivp
    >>> from flexmb.integrators import CVODEBDF
    >>> sol = solve_ivp(lambda t, y: -y, (0.0, 1.0), [1.0], method=CVODEBDF, rtol=1e-8, atol=1e-10)
    >>> bool(abs(sol.y[0, -1] - np.exp(-1.0)) < 1e-6)
    True
    """

    family = "BDF"
    max_order = 5
    linsolver = "dense"
    explicit = False
    uses_jacobian = True
    second_order = False
    has_dense_output = True
    cheap_restart = False
    advances = True
    finds_roots = True

    def __init__(self, fun, t0, y0, t_bound, *, rtol: float = 1e-3, atol=1e-6, max_step: float = np.inf,
                 first_step: float | None = None, jac=None, preconditioner=None, events=None,
                 max_order: int | None = None, vectorized: bool = False, **extraneous):
        super().__init__(fun, t0, y0, t_bound, vectorized=False)
        self._raw_fun = fun
        self.n_steps = 0
        self.root = None
        atol = np.asarray(atol, dtype=float)
        options = dict(
            max_num_steps=MAX_STEPS, max_order=self.max_order if max_order is None else int(max_order), linsolver=self.linsolver, rtol=float(rtol),
            atol=float(atol) if atol.ndim == 0 else [float(a) for a in atol],
            max_step=0.0 if not np.isfinite(max_step) else float(max_step),
            first_step=0.0 if first_step is None else float(first_step),
        )
        if events is not None:
            options.update(self._events(*events))
        if preconditioner is not None:
            options.update(self._krylov(preconditioner))
        elif jac is not None:
            if not callable(jac):
                J = np.array(jac, dtype=float)
                jac = lambda t, y: J  # noqa: E731
            options["jacfn"] = self._jacfn(jac)
        self._mem = self._create(options)

    def _create(self, options: dict):
        """The scikit-sundae solver, initialised at ``(t, y)`` (:class:`IDA` overrides it)."""
        import sksundae

        fun = self._raw_fun

        def rhsfn(t, y, yp):  # the caller's fun itself: scipy's wrapper costs as much as a small model's call
            self.nfev += 1
            yp[:] = fun(t, y)

        mem = sksundae.cvode.CVODE(rhsfn, method=self.family, **options)
        mem.init_step(float(self.t), np.array(self.y, dtype=float))
        return mem

    def _events(self, g, m, direction) -> dict:
        """scikit-sundae's root-finding options for the m functions ``g(t, y)`` (:class:`IDA` overrides it)."""

        def eventsfn(t, y, events):
            events[:] = g(t, y)

        eventsfn.terminal = [False] * m  # each root ends CVode's call (CV_ROOT_RETURN) all the same
        eventsfn.direction = [int(d) for d in direction]
        return dict(eventsfn=eventsfn, num_events=int(m))

    def _jacfn(self, jac):
        """scikit-sundae's Jacobian callback, filling ``J = jac(t, y)`` (:class:`IDA` overrides it)."""

        def jacfn(t, y, yp, JJ):
            self.njev += 1
            JJ[:, :] = jac(t, y)

        return jacfn

    def _krylov(self, pre) -> dict:
        """CVODE options for GMRES preconditioned by the O(n) Newton solve of an open tree."""
        import sksundae

        layout = pre.system.layout  # y = (q, u, works): the preconditioner takes the q and u halves

        def setup(t, y, yp, jok, jnew, gamma):
            if jok and pre.n_setups:
                jnew[0] = 0
                return
            self.njev += 1
            pre.setup(t, *layout.split(y))
            jnew[0] = 1

        def solve(t, y, yp, rvec, zvec, gamma, delta, lr):
            zq, zu = layout.split(zvec)
            zq[:], zu[:] = pre.solve(*layout.split(rvec), gamma)
            layout.extra(zvec)[:] = layout.extra(rvec)  # states nothing depends on (work terms)

        return dict(linsolver="gmres", krylov_dim=KRYLOV_DIM,
                    precond=sksundae.cvode.CVODEPrecond(setup, solve, side="left"))

    def _step_impl(self):
        out = self._call(self.t_bound, "onestep")
        if out.success and out.t == self.t:
            # after an interpolated output (dense output) behind its current
            # time, the one-step mode (CVODE's and IDA's) first returns that
            # time again
            out = self._call(self.t_bound, "onestep")
        if not out.success:
            return False, f"{type(self._mem).__name__}: {out.message} (flag {out.status})"
        self.t = float(out.t)
        self.y = out.y
        # a root: CVODE returns at it (CV_ROOT_RETURN, IDA_ROOT_RETURN: 2), its step reaching beyond
        self.root = np.array(out.i_events[-1]) if out.status == ROOT_RETURN else None
        return True, None

    def _call(self, t, method):
        return self._mem.step(t, method=method, tstop=self.t_bound)

    def advance(self, t: float, on_step=None) -> np.ndarray:
        """Step until ``t`` (at most ``t_bound``) is reached; the state there (CVODE's interpolant).

        CVODE is stepped one internal step at a time, as by :meth:`step`,
        so the output times do not change the steps; only the steps
        themselves run between two output times, none of simulate's checks.

        Parameters
        ----------
        t : float
            Time to reach.
        on_step : callable, optional
            Called with the solver after each step (its ``t_old``, ``t``
            and ``y`` those of the step).

        Returns
        -------
        ndarray
            The state at ``t``; ``self.t`` and ``self.y`` are those of the
            last step's end, at or past ``t``.

        Raises
        ------
        RuntimeError
            If CVODE fails (the message gives its flag and time).
        """
        t = min(float(t), self.t_bound)
        mem, t_bound = self._mem, self.t_bound
        tn = self.t
        while tn < t:
            out = mem.step(t_bound, method="onestep", tstop=t_bound)
            if not out.success:
                self.status = "failed"
                raise RuntimeError(f"{type(mem).__name__}: {out.message} (flag {out.status}) at t = {out.t:.9g} s")
            if out.t == tn:  # after an interpolated output behind its time, one-step mode returns that time again
                continue
            self.n_steps += 1
            self.t_old, tn, self.y = tn, float(out.t), out.y
            if on_step is not None:
                self.t = tn
                on_step(self)
        self.t = tn
        if tn >= t_bound:
            self.status = "finished"
        return self._call(t, "normal").y if tn > t else self.y.copy()

    def _dense_output_impl(self):
        return CVODEDenseOutput(self.t_old, self.t, self)


class CVODEDenseOutput(DenseOutput):
    """CVODE's or IDA's interpolant over its last step (``CVodeGetDky``, ``IDAGetDky``); valid until it steps again.

    Parameters
    ----------
    t_old, t : float
        The last step's interval.
    solver : CVODE
        The solver that took it (an :class:`IDA` too).

    Raises
    ------
    RuntimeError
        When called after the solver has taken another step.
    """

    def __init__(self, t_old: float, t: float, solver: CVODE):
        super().__init__(t_old, t)
        self._solver = solver

    def _call_impl(self, t):
        if self._solver.t != self.t:
            raise RuntimeError("a CVODE dense output is valid only until the solver's next step")
        if t.ndim == 0:
            return self._solver._call(float(t), "normal").y
        return np.column_stack([self._solver._call(float(ti), "normal").y for ti in t])


class CVODEBDF(CVODE):
    """CVODE's variable-order BDF (orders 1-5), for stiff scenes (registered as ``'CVODE_BDF'``).

    Parameters
    ----------
    fun : callable
        Right-hand side ``fun(t, y) -> ydot``.
    t0 : float
        Initial time.
    y0 : array_like, shape (m,)
        Initial state.
    t_bound : float
        End time.
    rtol, atol : float or array_like
        Tolerances.
    max_step : float
        Largest step.
    first_step : float, optional
        First step size.
    jac : callable or array_like, optional
        State Jacobian (see :class:`CVODE`).
    preconditioner : NewtonPreconditioner, optional
        O(n) preconditioned Krylov solves of an open tree (see :class:`CVODE`).
    events : (callable, int, array_like), optional
        Root finding on the functions ``g(t, y)`` (see :class:`CVODE`).
    max_order : int, optional
        The largest BDF order (default 5; simulate lowers it to
        :data:`flexmb.stepping.OSCILLATION_MAX_ORDER` for flexible bodies in
        loops at loose tolerances).
    vectorized : bool
        Ignored.
    **extraneous
        Ignored.

    Examples
    --------
    >>> import flexmb as fm
    >>> fm.registry.get("integrators", "CVODE_BDF").__name__
    'CVODEBDF'
    """

    family = "BDF"
    max_order = 5
    uses_preconditioner = True
    limits_order = True


class CVODEAdams(CVODE):
    """CVODE's variable-order Adams-Moulton (orders 1-12), for smooth non-stiff scenes (``'CVODE_Adams'``).

    Parameters
    ----------
    fun : callable
        Right-hand side ``fun(t, y) -> ydot``.
    t0 : float
        Initial time.
    y0 : array_like, shape (m,)
        Initial state.
    t_bound : float
        End time.
    rtol, atol : float or array_like
        Tolerances.
    max_step : float
        Largest step.
    first_step : float, optional
        First step size.
    jac : callable or array_like, optional
        State Jacobian (see :class:`CVODE`).
    preconditioner : NewtonPreconditioner, optional
        O(n) preconditioned Krylov solves of an open tree (see :class:`CVODE`).
    events : (callable, int, array_like), optional
        Root finding on the functions ``g(t, y)`` (see :class:`CVODE`).
    max_order : int, optional
        The largest order (default: the class's ``max_order``).
    vectorized : bool
        Ignored.
    **extraneous
        Ignored.

    Notes
    -----
    scikit-sundae runs the Adams corrector with Newton's method and the
    dense linear solver too, so the Jacobian is used here as well.

    Examples
    --------
    >>> import flexmb as fm
    >>> fm.registry.get("integrators", "CVODE_Adams").__name__
    'CVODEAdams'
    """

    family = "Adams"
    max_order = 12


class IDA(CVODE):
    """SUNDIALS IDA (variable-order BDF for ``F(t, y, y') = 0``) on ``F = y' - fun(t, y)`` (``'IDA'``).

    It shares :class:`CVODE`'s stepping, dense output (``IDAGetDky``),
    options and restart behaviour; only the solver object differs.

    Parameters
    ----------
    fun : callable
        Right-hand side ``fun(t, y) -> ydot``.
    t0 : float
        Initial time.
    y0 : array_like, shape (m,)
        Initial state; the initial derivative is ``fun(t0, y0)``.
    t_bound : float
        End time.
    rtol, atol : float or array_like
        Tolerances.
    max_step : float
        Largest step.
    first_step : float, optional
        First step size.
    jac : callable or array_like, optional
        State Jacobian ``J = d fun / d y`` (see :class:`CVODE`); IDA is given
        its iteration matrix ``dF/dy + cj dF/dy' = cj I - J``.
    preconditioner : NewtonPreconditioner, optional
        O(n) preconditioned Krylov solves of an open tree (see
        :class:`CVODE`): ``(cj I - J) z = r`` is solved as
        ``(I - J / cj) z = r / cj``.
    events : (callable, int, array_like), optional
        Root finding on the functions ``g(t, y)``, by IDA's root finding (see
        :class:`CVODE`).
    max_order : int, optional
        The largest order (default: the class's ``max_order``).
    vectorized : bool
        Ignored.
    **extraneous
        Ignored.

    Notes
    -----
    For the ODEs flexmb integrates, IDA runs the same variable-order BDF as
    :class:`CVODEBDF` (fixed-leading-coefficient form, orders 1-5), but its
    iteration matrix ``cj I - J`` holds the method's coefficient ``cj``:
    IDA sets it up anew, evaluating the Jacobian again, whenever ``cj``
    has drifted by more than its threshold, where CVODE refactors
    ``I - gamma J`` with the Jacobian it kept [1]_. Each set-up thus costs a
    Jacobian; CVODE_BDF is the cheaper choice on ODEs, and IDA the solver
    to build on for index-reduced DAE formulations.

    References
    ----------
    .. [1] A. C. Hindmarsh et al., "SUNDIALS: Suite of nonlinear and
       differential/algebraic equation solvers", ACM TOMS 31 (2005) 363-396.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.integrate import solve_ivp
    >>> from flexmb.integrators import IDA
    >>> sol = solve_ivp(lambda t, y: -y, (0.0, 1.0), [1.0], method=IDA, rtol=1e-8, atol=1e-10)
    >>> bool(abs(sol.y[0, -1] - np.exp(-1.0)) < 1e-6)
    True
    """

    family = "BDF"
    max_order = 5
    uses_preconditioner = True

    def _create(self, options: dict):
        import sksundae

        f = self.fun

        def resfn(t, y, yp, res):
            res[:] = yp - f(t, y)

        mem = sksundae.ida.IDA(resfn, **options)
        y0 = np.array(self.y, dtype=float)
        mem.init_step(float(self.t), y0, np.array(f(self.t, y0), dtype=float))
        return mem

    def _events(self, g, m, direction) -> dict:
        def eventsfn(t, y, yp, events):
            events[:] = g(t, y)

        eventsfn.terminal = [False] * m
        eventsfn.direction = [int(d) for d in direction]
        return dict(eventsfn=eventsfn, num_events=int(m))

    def _jacfn(self, jac):
        def jacfn(t, y, yp, res, cj, JJ):
            self.njev += 1
            JJ[:, :] = -jac(t, y)
            JJ[np.diag_indices_from(JJ)] += cj

        return jacfn

    def _krylov(self, pre) -> dict:
        import sksundae

        layout = pre.system.layout  # y = (q, u, works): the preconditioner takes the q and u halves

        def setup(t, y, yp, res, cj):
            self.njev += 1
            pre.setup(t, *layout.split(y))

        def solve(t, y, yp, res, rvec, zvec, cj, delta):
            zq, zu = layout.split(zvec)
            rq, ru = layout.split(rvec)
            zq[:], zu[:] = pre.solve(rq / cj, ru / cj, 1.0 / cj)
            layout.extra(zvec)[:] = layout.extra(rvec) / cj  # states nothing depends on (work terms)

        return dict(linsolver="gmres", krylov_dim=KRYLOV_DIM, precond=sksundae.ida.IDAPrecond(setup, solve))
