"""CVODE stepped in compiled code on a model with loops: the ``CVODE_BDF`` and ``CVODE_Adams`` of looped models.

For a model whose loops the articulated strategy closes
(``System._loop_kernel``), whose force elements are all compiled, whose
drivers have a closed form (``Driver.law``: constant speed, harmonic) and whose coordinates
are their speeds' integrals, and for a run that tracks no work and locates
no contact events, :func:`~flexmb.integrators.direct_choice.compiled_loop`
gives :class:`DirectLoopCVODE` instead of scikit-sundae's CVODE: the loops'
right-hand side and Newton preconditioner as compiled C callbacks
(:mod:`flexmb.kernels.cvode_loop_callbacks`), CVODE's step loop compiled,
and the dense Jacobian of a small model (below ``KRYLOV_MIN_COORDS``)
``System.state_jacobian``'s, compiled
(:func:`~flexmb.kernels.loop_jacobian.loop_state_jacobian`, a C callback)
where the model's tangent is what that kernel forms
(:func:`~flexmb.integrators.cvode_direct.compiled_jacobian`), else called from Python.
With GMRES (from ``KRYLOV_MIN_COORDS``) on such a model, GMRES's products
``J v`` of that Jacobian are compiled too (:mod:`flexmb.kernels.cvode_loop_jtimes`,
``CVodeSetJacTimes``: no right-hand side per product), else CVODE's
difference quotients.

What ``flexmb.stepping.Run`` does after each step of a looped model is done
by the run itself, on the very steps it would do it on
(:func:`flexmb.own_loop.advance_checking`): the compiled loop stores the
outputs its steps pass, projected by the run's rule
(:func:`flexmb.kernels.loop_outputs.advance_storing`), and returns to
Python after a step that left the constraints
farther than the run's bound, that moved a winding angle or a joint in
Bryant angles past its watch, or that left a non-finite state (or an
output it leaves to the run); the run then
stores what outputs are left, moves the offsets, projects and
restarts (``Run._restart_if_drifted``, its bound raised when restarts crowd:
``RESTART_MIN_STEPS``, read from :mod:`flexmb.stepping`) as it does when
stepping in Python. A restart makes a new CVODE memory (:meth:`DirectLoopCVODE.restart`:
the state, the callbacks' buffers and the counters are kept), as the Python
path makes a new solver: the runs take the very steps of scikit-sundae's
(tests/test_cvode_direct_loops.py). Where the run holds BDF to order 3
(flexible bodies in loops at loose tolerances, ``project=True``), CVODE
instead projects the state onto the constraints itself after its steps
(``CVodeSetProjFn``, :func:`flexmb.kernels.cvode_loop_callbacks.project`),
keeping its order and history; the drift check then acts only where a
projection is refused.

Left to scikit-sundae (``compiled_loop`` returns None): loops closed by a
dense strategy (``eigen``, ``svd``, ``qr``), force elements or joints
evaluated in Python, drivers given only by their callables (their motion,
in Python, is not known to compiled code: ``Driver.law`` None), Euler parameters, work terms,
contact events.
"""

from __future__ import annotations

import inspect
from ctypes import byref, c_double, c_long, c_void_p

import numpy as np

from .._signals import act_on_deferred
from ..output_projection import OUTPUT_PROJECTION_GAIN, LoopOutputs
from ..stepped_by_run import SteppedByRun
from .cvode_direct import CV_ADAMS, CV_BDF, STEPS_PER_CALL, DirectCVODE, _addr

#: CVODE's projection moves a state whose constraint residual exceeds this fraction of the run's drift bound or
#: PROJECTION_ATOL_FRACTION of the smallest atol, whichever is less: smaller residuals are left to the next steps
#: and the outputs' projection (a correction of several atol upsets BDF's history: the four-bar at rtol 1e-9)
PROJECTION_BOUND_FRACTION = 0.5
PROJECTION_ATOL_FRACTION = 0.1

#: GMRES takes the compiled J v (flexmb.kernels.cvode_loop_jtimes) where compiled_jacobian allows (False: CVODE's
#: difference quotient, a right-hand side per product)
COMPILED_JTIMES = True
#: its G (the geometric stiffness) is that of the first linear solve after each set-up of the preconditioner (as
#: the dense solver's J), not the current state's; P (the constrained solve) is always the current state's
LAGGED_JTIMES = True

__all__ = ["DirectLoopCVODE", "DirectLoopCVODEBDF", "DirectLoopCVODEAdams", "loop_class"]

#: the counters CVODE keeps per memory (summed over the restarts by :meth:`DirectLoopCVODE.stats`)
_CVODE_COUNTS = (("steps", "NumSteps"), ("rhs_cvode", "NumRhsEvals"), ("rhs_ls", "NumLinRhsEvals"),
                 ("err_test_fails", "NumErrTestFails"), ("newton_iters", "NumNonlinSolvIters"),
                 ("newton_fails", "NumNonlinSolvConvFails"), ("lin_iters", "NumLinIters"),
                 ("lin_setups", "NumLinSolvSetups"))


def loop_class(system, family: str) -> type | None:
    """The compiled-loop class for a model with loops, or None where its callbacks cannot evaluate the model.

    Parameters
    ----------
    system : System
        The model (with constraints; ``qd = u``).
    family : {'BDF', 'Adams'}
        CVODE's method.

    Returns
    -------
    type or None
        :class:`DirectLoopCVODEBDF` or :class:`DirectLoopCVODEAdams`.
    """
    from ..loop_user_data import compiled_loops_serve

    if not compiled_loops_serve(system):
        return None
    return {"BDF": DirectLoopCVODEBDF, "Adams": DirectLoopCVODEAdams}[family]


def _with_projection(init) -> inspect.Signature:
    """``DirectCVODE.__init__``'s signature with the keywords ``projection_tol`` and ``project`` before its ``**``."""
    params = list(inspect.signature(init).parameters.values())
    extra = [inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=default)
             for name, default in (("projection_tol", 1e-10), ("project", False))]
    return inspect.Signature(params[:-1] + extra + params[-1:])


class DirectLoopCVODE(SteppedByRun, DirectCVODE):
    """CVODE on a model with loops with compiled callbacks, stepped until a step needs the run's attention.

    Built by :class:`flexmb.stepping.Run` with the options of
    :class:`~flexmb.integrators.cvode_direct.DirectCVODE` (the same
    parameters); driven by :func:`flexmb.own_loop.advance_checking`
    through :meth:`step_on`, restarted in place by :meth:`restart`.
    """

    checks_constraints = restarts_in_place = True

    def __init__(self, *args, projection_tol=1e-10, project=False, **kwargs):
        self._projection_tol, self._projects = float(projection_tol), bool(project)
        self._last_steps = 0  # steps taken by the last step_on
        super().__init__(*args, **kwargs)
        from ..kernels.loop_outputs import advance_storing

        self._advance = advance_storing  # the step loop storing the outputs

    __init__.__signature__ = _with_projection(DirectCVODE.__init__)

    def _setup(self, rtol, atol, krylov, max_step, first_step):
        """CVODE's options (:meth:`DirectCVODE._setup`), kept for :meth:`restart`."""
        if not hasattr(self, "_carried"):  # the first memory: CVODE's counters of the restarted ones start at 0
            self._options, self._carried = (rtol, atol, krylov, max_step), {key: 0 for key, _ in _CVODE_COUNTS}
        super()._setup(rtol, atol, krylov, max_step, first_step)
        if krylov and self._jtimes_applies():
            self._compiled_jtimes()
        self._projects = self._projects and self.family == "BDF"  # (CVODE projects BDF steps only)
        if self._projects:
            self._project_in_cvode()

    def _jtimes_applies(self) -> bool:
        """Whether GMRES takes the compiled ``J v`` (:func:`~flexmb.integrators.cvode_direct.compiled_jacobian`)."""
        if not hasattr(self, "_jtimes"):
            from .cvode_direct import compiled_jacobian

            self._jtimes = COMPILED_JTIMES and compiled_jacobian(self.system)
        return self._jtimes

    def _compiled_jtimes(self) -> None:
        """GMRES's ``J v`` by the C callbacks of :mod:`flexmb.kernels.cvode_loop_jtimes` (``CVodeSetJacTimes``).

        The right-hand side keeps its factors for them in the buffer at
        ``A_JT`` (:func:`flexmb.kernels.loop_jtimes.jtimes_size`), followed
        by G's terms (21 per coordinate; lagged: :data:`LAGGED_JTIMES`);
        made with the first memory and kept over the restarts (its counters too).
        """
        from ..kernels import cvode_loop_jtimes
        from ..kernels.loop_jtimes import H_AT, H_LAG, H_VALID, jtimes_size

        cb, a, ud = self._cb, self._arrays, self._ud
        if "jt" not in a:
            lay = self.system._loop_layout
            size = jtimes_size(self.n, self.m, lay.row_coord.shape[0], int(lay.band), a["V"].size)
            a["jt"] = np.zeros(size + 21 * self.n)  # the factors' buffer, then G's terms
            ud[cb.A_JT], ud[cb.N_JT], ud[cb.N_V] = a["jt"].ctypes.data, a["jt"].size, a["V"].size
            a["jt"][H_LAG], a["jt"][H_AT] = float(LAGGED_JTIMES), -1.0
        a["jt"][H_VALID] = 0.0  # no factors kept yet
        self._check(self._S.CVodeSetJacTimes(self._mem, cvode_loop_jtimes.jtsetup.address,
                                             cvode_loop_jtimes.jtimes.address), "CVodeSetJacTimes")

    def _project_in_cvode(self) -> None:
        """CVODE's own projection onto the constraints after each step (``CVodeSetProjFn``), its error not projected.

        :func:`~flexmb.kernels.cvode_loop_callbacks.project` moves a state
        whose residual exceeds ``PROJECTION_BOUND_FRACTION`` of the run's
        drift bound (:meth:`step_on`) or ``PROJECTION_ATOL_FRACTION`` of
        atol, whichever is less, onto the constraints (Newton to a tenth of
        that, at most ``min(1e-12, projection_tol)``, as the run's own projection) (positions by Newton, speeds
        mass-orthogonally, as ``System.project(..., speeds='mass')``), so
        that CVODE keeps its order and history where the run restarted it
        (docs/benchmarks.md, "What limits CVODE's step on B6"); where it
        refuses, the step loop's drift check hands the state to the run.
        """
        S, cb, mem, ck = self._S, self._cb, self._mem, self._check
        real = self._arrays["real"]
        self._atol_min = float(np.min(self._options[1]))
        real[cb.R_PROJ_TOL] = PROJECTION_ATOL_FRACTION * self._atol_min  # until step_on gives the run's bound
        real[cb.R_NEWTON_TOL] = min(1e-12, self._projection_tol, 0.1 * real[cb.R_PROJ_TOL])
        real[cb.R_GAIN] = OUTPUT_PROJECTION_GAIN
        ck(S.CVodeSetProjFn(mem, cb.project.address), "CVodeSetProjFn")
        ck(S.CVodeSetProjErrEst(mem, 0), "CVodeSetProjErrEst")

    @staticmethod
    def _callbacks():
        """The module of the loops' C callbacks and of their compiled step loop."""
        from ..kernels import cvode_loop_callbacks

        return cvode_loop_callbacks

    @staticmethod
    def _refuse(system) -> None:
        """Raise ValueError for a model the loops' callbacks cannot evaluate (see :func:`loop_class`)."""
        if not system.layout.identity or loop_class(system, "BDF") is None:
            raise ValueError("DirectLoopCVODE needs loops closed by the articulated strategy, force elements all "
                             "compiled, drivers with a closed form (Driver.law), and qd = u")

    def _user_data(self, system, nonfinite_flag):
        from ..loop_user_data import loop_user_data

        S = self._S
        ud, self._arrays = loop_user_data(system, self.m, self._offset, nonfinite_flag, _addr(S.N_VGetArrayPointer),
                                          _addr(S.SUNDenseMatrix_Data))
        self._offset = None if self._offset is None else self._arrays["offset"]  # the array the callbacks read
        return ud

    def restart(self, z, offset=None) -> None:
        """Start CVODE again from ``z`` at :attr:`t` (order one, its own first step), as a new solver would.

        A new CVODE memory and linear solver (the Python path makes a new
        scikit-sundae solver: the same fresh start), on the same vectors,
        callbacks' buffers and counters.

        Parameters
        ----------
        z : ndarray, shape (m,)
            The integrator's new state (the true state less ``offset``).
        offset : ndarray, optional
            The winding offsets from now on (None: none).
        """
        S = self._S
        for key, value in self._cvode_counts().items():
            self._carried[key] += value
        S.CVodeFree(byref(c_void_p(self._mem)))
        S.SUNLinSolFree(self._ls)
        if self._A:
            S.SUNMatDestroy(self._A)
        self._mem = self._ls = self._A = None
        self.y[:] = z
        cb, buf = self._cb, self._arrays["offset"]
        buf[:] = 0.0 if offset is None else offset
        self._offset = None if offset is None else buf
        self._ud[cb.HAS_OFFSET] = offset is not None
        self._ud[cb.F_VALID] = self._ud[cb.PROJ_OK] = 0
        self._mem = S.CVodeCreate(CV_BDF if self.family == "BDF" else CV_ADAMS, self._ctx)
        if not self._mem:
            raise MemoryError("CVodeCreate returned NULL")
        rtol, atol, krylov, max_step = self._options
        self._setup(rtol, atol, krylov, max_step, None)
        self._tret[0] = self.t
        self._lp[2] = self._mem
        self.t_old = None

    def step_on(self, t_stop: float, bound: float, outputs=None) -> int:
        """Step until a step needs the run's attention (see the module docstring), or up to ``t_stop``.

        Parameters
        ----------
        t_stop : float
            The next output time (or progress mark): the loop returns after
            the step that reaches it, before interpolating.
        bound : float
            The run's drift bound on the constraint residuals (BDF: CVODE's
            projection acts from ``PROJECTION_BOUND_FRACTION`` of it on).
        outputs : flexmb.output_projection.LoopOutputs, optional
            The run's outputs: those the steps pass are stored there
            (projected, :func:`flexmb.kernels.loop_outputs.advance_storing`),
            and the loop goes on from output to output while the run would
            do nothing after its steps. None: one stop, nothing stored.

        Returns
        -------
        int
            :mod:`~flexmb.kernels.cvode_loop_callbacks`'s code (REACHED,
            CHECKPOINT, PAUSED, WATCH, DRIFTED, NOT_FINITE); :attr:`t`,
            :attr:`y` and :meth:`dense_output` are those of the last step.

        Raises
        ------
        CVODEError, AssemblyError
            If CVODE or a callback failed (flexmb's diagnosis of the state
            where it did, as in :meth:`DirectCVODE.advance`).
        """
        if self._mem is None:
            raise RuntimeError("this DirectLoopCVODE is closed")
        mon, cb = self.monitor, self._cb
        live = mon is not None and not mon.warned
        times = np.empty(max(mon.next_check - mon.n_steps, 1) if live else 0)
        t_entry = self._tret[0]
        gimbal = self._gimbal if self.gimbal is not None and not self.gimbal.warned else self._gimbal[:0]
        self._drift_bound = float(bound)
        if self._projects:
            real = self._arrays["real"]
            real[cb.R_PROJ_TOL] = min(PROJECTION_BOUND_FRACTION * float(bound), PROJECTION_ATOL_FRACTION * self._atol_min)
            real[cb.R_NEWTON_TOL] = min(1e-12, self._projection_tol, 0.1 * real[cb.R_PROJ_TOL])
        out = LoopOutputs(np.zeros(0), 0, self.m, 0.0, True) if outputs is None else outputs
        try:
            code, k, out.k, made = self._advance(
                self._lp, self._ud, min(float(t_stop), self.t_bound), self.t_bound, float(bound), times,
                STEPS_PER_CALL, self._angles, self._bound, gimbal, self._limit, out.times, out.k, out.Y, out.tol,
                out.newton_tol, out.gain, out.once)
            out.made += made
        finally:
            self._count()
        act_on_deferred()  # a Ctrl-C recorded meanwhile (DirectCVODE.advance's docstring)
        self.n_steps += k
        self._last_steps = k
        if k:
            self.t = float(self._tret[0])
            h = c_double()
            self._S.CVodeGetLastStep(self._mem, byref(h))
            self.t_old = self.t - h.value
            if live:
                self._feed(mon, np.concatenate(([t_entry], times[: min(k, len(times))])))
        if code < 0:
            self.status = "failed"
            if self._raised is not None:
                raised, self._raised = self._raised, None
                raise raised
            if int(self._ud[cb.STATUS]) == cb.SINGULAR_PRECONDITIONER:  # LoopNewtonPreconditioner's error
                from ..errors import AssemblyError

                raise AssemblyError("the Newton preconditioner of the loops is singular (a freedom without mass, "
                                    "stiffness or damping that no loop fixes)")
            self._diagnose()
            raise self._error(code)
        if self.t >= self.t_bound:
            self.status = "finished"
        return code

    def within_bound(self, code: int) -> bool:
        """Whether the last :meth:`step_on` found its last step's state within its drift bound (:func:`drift`).

        True where that call took a step and returned for another cause than
        the drift (or a non-finite state) before the run's end, after a step
        whose state the step loop checked, or CVODE's projection kept (its
        residuals within ``PROJECTION_BOUND_FRACTION`` of the bound), or
        CVODE's projection moved onto the constraints and whose drift,
        evaluated here by the loop's own :func:`drift`, is within the bound.

        Parameters
        ----------
        code : int
            What that :meth:`step_on` returned.

        Returns
        -------
        bool
            True if the drift of the state at :attr:`t` was found ``<= bound``.
        """
        cb = self._cb
        if not self._last_steps or code in (cb.DRIFTED, cb.NOT_FINITE) or code < 0 or self.t >= self.t_bound:
            return False
        if not (self._ud[cb.PROJ_OK] == 2 and self._arrays["real"][cb.R_PROJ_T] == self.t):
            return True  # checked by the step loop (no projection at t), or kept by the projection (PROJ_OK 1)
        y = self.y if self._offset is None else self.y + self._offset
        return cb.drift(self._ud, self.t, y) <= self._drift_bound

    def _callback_counts(self) -> dict:
        """:meth:`DirectCVODE._callback_counts`, and CVODE's projections that moved the state (the run's
        ``"cvode_projections"``: :attr:`flexmb.Result.n_cvode_projections`)."""
        return dict(super()._callback_counts(), cvode_projections=int(self._ud[self._cb.PROJECTIONS]))

    def _cvode_counts(self) -> dict:
        """CVODE's counters of the current memory (since the last restart)."""
        out = {}
        for key, name in _CVODE_COUNTS:
            v = c_long()
            self._check(getattr(self._S, f"CVodeGet{name}")(self._mem, byref(v)), f"CVodeGet{name}")
            out[key] = v.value
        return out

    def stats(self) -> dict:
        """CVODE's counters summed over the restarts, and the callbacks' own.

        Returns
        -------
        dict
            As :meth:`DirectCVODE.stats`, and ``psolves`` and ``factors``
            (the preconditioner's solves, and its factorisations: one per
            set-up and gamma), ``projections`` and ``projections_refused``
            (CVODE's projections that moved the state, and those refused);
            with the compiled ``J v``, ``jtimes``, ``jtimes_setups`` and
            ``jtimes_rhs`` (its products, set-ups, and the right-hand sides
            it evaluated again, included in ``rhs``).
        """
        cb, ud = self._cb, self._ud
        out = {k: v + self._carried[k] for k, v in self._cvode_counts().items()}
        out.update(rhs=int(ud[cb.RHS]), jac=int(ud[cb.SETUPS] + ud[cb.JACS]), psolves=int(ud[cb.PSOLVES]),
                   factors=int(ud[cb.FACTORS]), projections=int(ud[cb.PROJECTIONS]),
                   projections_refused=int(ud[cb.PROJ_REFUSED]))
        if "jt" in self._arrays:
            from ..kernels import loop_jtimes as lj

            jt = self._arrays["jt"]
            out.update(jtimes=int(jt[lj.H_TIMES]), jtimes_setups=int(jt[lj.H_SETUPS]), jtimes_rhs=int(jt[lj.H_RHS]))
        return out


class DirectLoopCVODEBDF(DirectLoopCVODE):
    family, max_order = "BDF", 5
    limits_order = True


class DirectLoopCVODEAdams(DirectLoopCVODE):
    family, max_order = "Adams", 12


_PARAMETERS = DirectCVODE.__doc__[DirectCVODE.__doc__.index("    Parameters\n"):].replace("""    **extraneous""", """\
    projection_tol : float
        The run's ``projection_tol`` (CVODE's projection closes the loops'
        positions to ``min(1e-12, projection_tol)`` or tighter).
    project : bool
        BDF: CVODE projects the state onto the constraints after its steps
        (:meth:`DirectLoopCVODE._project_in_cvode`) instead of the run
        restarting it; given by the run where it holds BDF to order 3
        (flexible bodies in loops, ``flexmb.stepping.oscillation_limited``).
    **extraneous""")
DirectLoopCVODE.__doc__ += "\n" + _PARAMETERS
DirectLoopCVODEBDF.__doc__ = (":class:`DirectLoopCVODE` with CVODE's variable-order BDF: ``'CVODE_BDF'`` on loops.\n\n"
                              + _PARAMETERS)
DirectLoopCVODEAdams.__doc__ = (":class:`DirectLoopCVODE` with CVODE's Adams-Moulton (Newton): ``'CVODE_Adams'`` on "
                                "loops.\n\n" + _PARAMETERS)
