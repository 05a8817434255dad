"""Generalized-alpha stepped in compiled code between output times: :func:`compiled_genalpha`.

Looped models have their own class, :class:`CompiledLoopGeneralizedAlpha`
(below).

For a run whose right-hand side is one compiled kernel (an open tree whose
joints and force elements are all compiled, ``System._packed_open``, with
``qd = u``) and whose Newton systems are solved with the dense iteration
matrix, :func:`compiled_genalpha` replaces the run's
:class:`~flexmb.genalpha.GeneralizedAlpha` class by a subclass whose
:meth:`CompiledGeneralizedAlpha.advance` takes the steps between two output
times in one compiled call (:func:`flexmb.kernels.genalpha_loop.advance`):
the same steps, Newton iterations, Jacobians and states as the step of the
Python class (tests/test_genalpha_compiled.py). The loop returns to Python
where Python has something to do: a Jacobian (formed by the solver's own
:meth:`_new_jacobian`; the LU factors of the iteration matrix are
LAPACK's, called from the loop), a failure (diagnosed as the Python step diagnoses it),
the resolution monitor's checkpoints, an angle past its winding bound or a
joint near gimbal lock, every so many steps (signals), and the output
time.

Everything else keeps the Python step (:meth:`GeneralizedAlpha.step`),
for the reasons :func:`compiled_genalpha` gives.
"""

from __future__ import annotations

import numpy as np

from .._signals import act_on_deferred, deferred
from ..stepped_by_run import SteppedByRun
from .solver import _NO_LOW_PASS, NEWTON_REGROWTH, GeneralizedAlpha

__all__ = ["compiled_genalpha", "CompiledGeneralizedAlpha", "CompiledLoopGeneralizedAlpha"]

#: the methods whose step the compiled loop takes: a subclass that overrides one keeps its own (Python) step
_STEP_METHODS = ("_step_impl", "_newton", "_error_control", "_accept", "_factor", "_new_jacobian", "_jacobian",
                 "_start", "_configure", "rebase", "move_to")
_CLASSES: dict = {}


def compiled_genalpha(system, solver_cls, track_work: bool, events, matrix_free: bool) -> type | None:
    """The compiled-loop class for a run of ``solver_cls`` on ``system``, or None where the Python step is kept.

    The Python step stays for: numba's JIT disabled (``NUMBA_DISABLE_JIT=1``,
    :mod:`flexmb.kernels.interpreted`); plugin joints, Python force elements
    (their right-hand side is Python: ``System._packed_open`` is None), and
    loops that CVODE's compiled loops do not serve either (``loop_class``:
    a dense complement strategy, drivers without a closed form; looped
    models it serves get :class:`CompiledLoopGeneralizedAlpha`); Euler parameters (the rotation chart of
    :mod:`flexmb.genalpha.chart`); ``track_work`` (the work rates are
    computed in Python); contact events (the run cuts each step itself);
    the matrix-free Newton solves (GMRES with the O(n) preconditioner,
    :mod:`flexmb.genalpha.krylov`, from ``krylov_min_coords`` speeds); and a
    subclass with a step of its own.

    Parameters
    ----------
    system : System
        The model.
    solver_cls : type
        The integrator chosen.
    track_work : bool
        Whether the run integrates the work terms.
    events : ContactEvents or None
        The run's contact events.
    matrix_free : bool
        Whether the run solves the Newton systems without a matrix.

    Returns
    -------
    type or None
        A :class:`CompiledGeneralizedAlpha` subclass of ``solver_cls``.
    """
    from ..kernels import interpreted

    if interpreted.disabled():  # NUMBA_DISABLE_JIT=1: the compiled loop cannot exist, the Python step is kept
        return None
    if not (isinstance(solver_cls, type) and issubclass(solver_cls, GeneralizedAlpha)):
        return None
    loops = not _serves(system) and _serves_loops(system)
    if not (_serves(system) or loops) or track_work or events is not None or matrix_free:
        return None
    if issubclass(solver_cls, CompiledGeneralizedAlpha):
        return solver_cls if solver_cls._serves(system) else None
    if any(getattr(solver_cls, name) is not getattr(GeneralizedAlpha, name) for name in _STEP_METHODS):
        return None
    base = CompiledLoopGeneralizedAlpha if loops else CompiledGeneralizedAlpha
    cls = _CLASSES.get((solver_cls, base))
    if cls is None:
        cls = _CLASSES[solver_cls, base] = type(solver_cls.__name__, (base, solver_cls),
                                                {"__module__": solver_cls.__module__, "__doc__": solver_cls.__doc__})
    return cls


def _serves(system) -> bool:
    """Whether the compiled loop can step ``system``: an open tree with a compiled right-hand side and ``qd = u``."""
    return system._packed_open is not None and not system.n_constraints and system.layout.identity


def _serves_loops(system) -> bool:
    """Whether the loops' compiled loop can step ``system`` (CVODE's compiled loops can: ``loop_class``)."""
    from ..loop_user_data import compiled_loops_serve

    return bool(system.n_constraints and system.layout.identity and compiled_loops_serve(system))


def _getrf() -> int:
    """The address of LAPACK's ``dgetrf`` (scipy's ``cython_lapack``: the routine ``lu_factor`` calls)."""
    from numba.extending import get_cython_function_address

    return get_cython_function_address("scipy.linalg.cython_lapack", "dgetrf")


class CompiledGeneralizedAlpha(GeneralizedAlpha):
    """:class:`GeneralizedAlpha` whose steps between output times run in compiled code (see the module docstring).

    Made by :func:`compiled_genalpha` (mixed into the run's class); the
    arguments are those of :class:`GeneralizedAlpha` and the run's.

    Parameters
    ----------
    fun, t0, y0, t_bound
        As for :class:`GeneralizedAlpha`.
    system : System
        The model (``System._packed_open`` set, ``qd = u``).
    offset : ndarray, optional
        The winding offsets ``c`` (the right-hand side is that of ``z + c``);
        :meth:`rebase` moves them with the state.
    monitor : ResolutionMonitor, optional
        Given the steps at its checkpoints.
    angles : ndarray of int, optional
        The winding angles, watched against ``bound``.
    bound : float
        Their bound, rad.
    gimbal : GimbalWatch, optional
        Its joints' ``ry`` watched while it has not warned.
    counters : dict, optional
        The run's counters: ``"rhs"`` is increased by the compiled
        right-hand sides.
    budget : int
        Steps after which the loop returns to Python (signals are handled
        there; the run gives CVODE's ``STEPS_PER_CALL``).
    feed : callable, optional
        ``feed(solver, monitor, times)``: gives the monitor the steps ending
        at ``times[1:]`` (the run gives CVODE's loop's); needed with
        ``monitor``.
    **options
        :class:`GeneralizedAlpha`'s.
    """

    advances = steps_in_compiled_code = True
    #: What the model must be (the error's words)
    _needs = "an open tree whose joints and force elements are all compiled, with qd = u"
    _serves = staticmethod(_serves)

    def __init__(self, fun, t0, y0, t_bound, *, system, offset=None, monitor=None, angles=(), bound=np.inf,
                 gimbal=None, counters=None, budget=1000, feed=None, **options):
        from ..kernels import interpreted

        interpreted.require_jit(f"{type(self).__name__}'s compiled step loop")
        from ..kernels import genalpha_loop as kernel

        if not self._serves(system):
            raise ValueError(f"{type(self).__name__} needs {self._needs}")
        super().__init__(fun, t0, y0, t_bound, **options)
        self._kernel, self.system, self.monitor, self.gimbal, self._counters = kernel, system, monitor, gimbal, counters
        self.n_steps, self._budget, self._feed = 0, int(budget), feed
        m = len(self.z)
        self._offset = np.zeros(m) if offset is None else np.array(offset, dtype=float)
        self._has_offset = offset is not None
        self._angles = np.asarray(angles, dtype=np.int64)
        self._bound = float(bound)
        self._gimbal = np.zeros(0, np.int64) if gimbal is None else np.asarray(gimbal.index, dtype=np.int64)
        self._limit = 0.0 if gimbal is None else float(gimbal.limit)
        self._st, self._ct = np.zeros(kernel.N_ST), np.zeros(kernel.N_CT, dtype=np.int64)
        self._arrays = [np.zeros(m), np.zeros(self.n_pos), np.zeros(self.n_pos), np.zeros(m - 2 * self.n_pos),
                        np.zeros(m), np.zeros(self.n_pos), np.zeros(m - 2 * self.n_pos)]
        self._fail_y = np.zeros(m)
        n = self.n_pos
        self._lu, self._piv = np.zeros((n, n)), np.zeros(n, np.int32)  # the factors, refactored in place
        self._getrf = _getrf()

    def rebase(self, shift) -> None:
        """:meth:`GeneralizedAlpha.rebase`; the offsets its right-hand side adds move by ``shift``.

        Parameters
        ----------
        shift : ndarray, shape (len(y),)
            What to subtract from the state.
        """
        super().rebase(shift)
        self._offset = self._offset + np.asarray(shift, dtype=float)
        self._has_offset = True

    def advance(self, t_stop: float, on_step=None) -> np.ndarray:
        """Step until ``t_stop`` (compiled; back in Python for matrices, checkpoints, watches, every so many steps).

        Parameters
        ----------
        t_stop : float
            Time to reach (at most ``t_bound``).
        on_step : callable, optional
            Called with the solver after a step that a watch flagged (an
            angle past its bound, a joint near gimbal lock).

        Returns
        -------
        ndarray, shape (len(y),)
            The state at ``t_stop`` (the step's interpolant if the last step passed it).

        Raises
        ------
        RuntimeError
            If the step size falls below the smallest step, or Newton fails
            with a fixed step (the Python step's message, ``t`` set).
        AssemblyError
            If the right-hand side fails (flexmb's diagnosis of the state).
        KeyboardInterrupt
            Ctrl-C (or SIGTERM, SIGHUP) while it stepped, raised once the
            compiled loop returns (:class:`flexmb._signals.deferred`).
        """
        with deferred():
            return self._advance(min(float(t_stop), self.t_bound), on_step)

    def _advance(self, t_stop, on_step):
        kernel, mon = self._kernel, self.monitor
        while True:
            live = mon is not None and not mon.warned
            times = np.empty(max(mon.next_check - mon.n_steps, 1) if live else 0)
            t_entry = self.t
            gimbal = self._gimbal if self.gimbal is not None and not self.gimbal.warned else self._gimbal[:0]
            self._enter()
            Jx, Jv = (np.ascontiguousarray(b) for b in self.J) if self.J is not None else (_NO_LOW_PASS, _NO_LOW_PASS)
            code, k = kernel.advance(self.system._packed_open, self._offset, *self._arrays, self._getrf, Jx, Jv,
                                     self._lu, self._piv, _NO_LOW_PASS if self.low_pass is None else self.low_pass,
                                     self._par, self.atol, self._st, self._ct, t_stop, times, self._budget,
                                     self._angles, self._bound, gimbal, self._limit, self._fail_y)
            self._leave(k)
            act_on_deferred()  # a Ctrl-C recorded meanwhile
            if live and k:
                self._feed(self, mon, np.concatenate(([t_entry], times[: min(k, len(times))])))
            if code == kernel.REACHED:
                return self._reached(t_stop)
            if code == kernel.WATCH and on_step is not None:
                on_step(self)
            elif code == kernel.NEED_JACOBIAN:
                self._new_jacobian(self.t, self.z)
            elif code == kernel.NEED_FACTOR:  # singular: scipy's factors and its warning, as the Python step
                self._factor(float(self._st[kernel.H_FACTOR]))
            elif code not in (kernel.CHECKPOINT, kernel.PAUSED, kernel.WATCH):
                self._failed(code)

    def _reached(self, t_stop):
        """The state at ``t_stop``: the last step's end, or its interpolant there."""
        if self.direction * (self.t - self.t_bound) >= 0:
            self.status = "finished"
        if self.t == t_stop:
            return self.y.copy()
        return self.dense_output()(t_stop)

    def _failed(self, code):
        """Raise what the Python step raises (or makes the run raise) for the loop's failure ``code``."""
        from ..own_loop import NonFinite

        kernel, st = self._kernel, self._st
        self.status = "failed"
        if code == kernel.RHS_FAILED:  # flexmb's diagnosis, as the Python right-hand side raises it
            t, y = float(st[kernel.FAIL_T]), self._fail_y.copy()
            self.system._state_rate(t, y)
            raise NonFinite(t, "the state derivative became non-finite")
        if code == kernel.NONFINITE_STATE:
            raise NonFinite(self.t, "the state became non-finite")
        if code == kernel.TOO_SMALL:
            error = RuntimeError("the step size fell below the smallest step (Newton or error test fails)")
        else:
            error = RuntimeError(f"Newton's method failed at t = {st[kernel.FAIL_T]:.9g} with the fixed step "
                                 f"{st[kernel.H_TRIAL]:.3g}")
        error.t = self.t
        raise error

    def _enter(self):
        """The solver's state into the loop's arrays and scalars."""
        K, st, ct = self._kernel, self._st, self._ct
        z, a, abar, g = self._arrays[:4]
        z[:], a[:], abar[:], g[:] = self.z, self.a, self.abar, self.g
        st[K.T], st[K.T_BOUND], st[K.DIRECTION], st[K.MAX_STEP] = self.t, self.t_bound, self.direction, self.max_step
        st[K.H_ABS], st[K.H_NEWTON], st[K.ERR_OLD] = self.h_abs, self.h_newton, self.err_old or 0.0
        st[K.LU_H] = np.nan if self.lu_h is None else self.lu_h
        st[K.REGROWTH] = NEWTON_REGROWTH
        ct[K.N_POS], ct[K.FIXED] = self.n_pos, self.fixed_step is not None
        ct[K.N_NEWTON], ct[K.N_REJECTED], ct[K.N_RHS] = self.n_newton, self.n_rejected, 0
        ct[K.HAS_J], ct[K.JAC_CURRENT], ct[K.HAS_LU] = self.J is not None, self.jac_current, self.lu is not None
        ct[K.HAS_OFFSET], ct[K.N_LU] = self._has_offset, self.nlu
        if self.lu is not None and self.lu[0] is not self._lu:  # factored in Python
            self._lu[:], self._piv[:] = self.lu

    def _leave(self, k):
        """The loop's state back into the solver (the steps taken, the counters, the interpolant's data)."""
        K, st, ct = self._kernel, self._st, self._ct
        rhs = int(ct[K.N_RHS])
        self.nfev += rhs
        if self._counters is not None:
            self._counters["rhs"] = self._counters.get("rhs", 0) + rhs
        if self.system.n_constraints:  # each one loop solve (System._loop_solve's count)
            self.system.n_complements += rhs
        self.n_newton, self.n_rejected = int(ct[K.N_NEWTON]), int(ct[K.N_REJECTED])
        self.h_abs, self.h_newton = float(st[K.H_ABS]), float(st[K.H_NEWTON])
        self.jac_current = bool(ct[K.JAC_CURRENT])
        self.nlu = int(ct[K.N_LU])
        self.lu = (self._lu, self._piv) if ct[K.HAS_LU] else None
        self.lu_h = float(st[K.LU_H]) if ct[K.HAS_LU] else self.lu_h
        if not k:
            return
        z, a, abar, g, z_old, abar_old, g_old = (v.copy() for v in self._arrays)
        self.n_steps += k
        self.t, self.t_old = float(st[K.T]), float(st[K.T_OLD])
        self.y = self.z = z
        self.a, self.abar, self.g = a, abar, g
        self.h_abs_old = float(st[K.H_ABS_OLD])
        self.err_old = None if self.fixed_step is not None else float(st[K.ERR_OLD])
        self._dense = (z_old, abar_old, g_old, z, None, None)
        self._remember()


class CompiledLoopGeneralizedAlpha(SteppedByRun, CompiledGeneralizedAlpha):
    """:class:`CompiledGeneralizedAlpha` for looped models, stepped by the run's checking loop.
    For a model whose loops CVODE's compiled loops serve (the articulated
    strategy closes them, force elements compiled, drivers with a closed form,
    ``qd = u``: :func:`~flexmb.integrators.cvode_direct_loops.loop_class`), on
    the dense Newton path (below ``krylov_min_loop_coords`` speeds), without
    work terms or contact events, :func:`flexmb.genalpha.compiled.compiled_genalpha`
    mixes this class into the run's. Its steps run in
    :func:`flexmb.kernels.genalpha_loops.advance` with the loops' right-hand side
    on the loops' user data (:func:`flexmb.loop_user_data.loop_user_data`, as
    CVODE's compiled loops), and so do the run's outputs (stored projected) and
    the projections of its drifted state (continued in place, as ``move_to``):
    the same steps, Newton iterations, Jacobians, projections and states as the
    Python step (tests/test_genalpha_compiled_loops.py). The run drives it as it
    drives CVODE's compiled loops (:func:`flexmb.own_loop.advance_checking`,
    through :meth:`CompiledLoopGeneralizedAlpha.step_on` and
    :meth:`~CompiledLoopGeneralizedAlpha.within_bound`). The loop forms the
    Jacobian itself where the compiled one is the model's
    (``compiled_jacobian``; runs then agree with the Python step's to the
    tolerance, not to the last bit); it returns to Python for a Jacobian
    otherwise (the solver's own, as on open trees), a singular iteration
    matrix, a failure, an output or a projection it leaves to the run, a
    watch, the monitor's checkpoints and a budget of steps.

    Parameters
    ----------
    fun, t0, y0, t_bound
        As for :class:`~flexmb.genalpha.GeneralizedAlpha`.
    state_tol : float
        The run's drift bound (``Run.state_tol``).
    projection_tol : float
        The run's ``projection_tol`` (a drifted state's projection closes
        the loops to ``min(1e-12, projection_tol)``).
    compiled_jacobian : bool
        Whether the compiled Jacobian is the model's
        (:func:`flexmb.integrators.cvode_direct.compiled_jacobian`, given by
        the run): the loop then forms it itself.
    **options
        As for :class:`~flexmb.genalpha.compiled.CompiledGeneralizedAlpha`.
    """

    checks_constraints = True
    _needs = ("loops closed by the articulated strategy, force elements all compiled, drivers with a closed form "
              "(Driver.law), and qd = u")
    _serves = staticmethod(_serves_loops)
    #: The loop forms the Jacobian itself where the compiled one is the model's (``compiled_jacobian``).
    jacobian_in_loop = True

    def __init__(self, fun, t0, y0, t_bound, *, state_tol=1e-10, projection_tol=1e-10, compiled_jacobian=False,
                 **options):
        super().__init__(fun, t0, y0, t_bound, **options)
        from ..kernels import cvode_loop_callbacks, genalpha_loops
        from ..loop_user_data import loop_user_data

        self._cb, self._loops = cvode_loop_callbacks, genalpha_loops
        self.m = len(self.z)  # the state's size (advance_checking's outputs)
        self._ud, self._ud_arrays = loop_user_data(self.system, len(self.z), None, 0)
        self._st, self._ct = np.zeros(genalpha_loops.N_LOOP_ST), np.zeros(genalpha_loops.N_LOOP_CT, dtype=np.int64)
        self._state_tol, self._newton_tol = float(state_tol), min(1e-12, float(projection_tol))
        self._checked = False
        n = self.n_pos
        self._Jx, self._Jv = np.zeros((n, n)), np.zeros((n, n))  # the Jacobian's blocks, formed in the loop
        self._jac_in_loop = (self.jacobian_in_loop and compiled_jacobian and self._jac_fun is not None
                             and self.f_max is None)

    def step_on(self, t_stop: float, bound: float, outputs=None) -> int:
        """Step until a step needs the run's attention, or to ``t_stop`` (``outputs.once``) or the run's end.

        Parameters
        ----------
        t_stop : float
            The next output time or progress mark.
        bound : float
            The run's drift bound as :func:`~flexmb.own_loop.advance_checking`
            gives it (not used: the loop applies ``state_tol``, the run's own).
        outputs : flexmb.output_projection.LoopOutputs, optional
            The run's outputs, stored there as the steps pass them (None:
            one stop, nothing stored).

        Returns
        -------
        int
            :mod:`~flexmb.kernels.cvode_loop_callbacks`'s code: REACHED,
            CHECKPOINT, PAUSED, WATCH, DRIFTED (a projection or an output
            left to the run), NOT_FINITE.

        Raises
        ------
        RuntimeError, AssemblyError
            As :meth:`CompiledGeneralizedAlpha.advance`.
        """
        from ..output_projection import LoopOutputs

        K, L, cb = self._kernel, self._loops, self._cb
        out = LoopOutputs(np.zeros(0), 0, len(self.z), 0.0, True) if outputs is None else outputs
        total = 0
        while True:
            code, k = self._call(float(t_stop), out)
            total += k
            if code == K.NEED_JACOBIAN:
                self._new_jacobian(self.t, self.z)
            elif code == K.NEED_FACTOR:  # singular: scipy's factors and its warning, as the Python step
                self._factor(float(self._st[K.H_FACTOR]))
            elif code in (K.RHS_FAILED, K.TOO_SMALL, K.FIXED_FAILED):
                self._failed(code)
            else:
                break
        if self.t >= self.t_bound:
            self.status = "finished"
        self._checked = total > 0 and code in (K.REACHED, K.CHECKPOINT, K.PAUSED)
        return {K.REACHED: cb.REACHED, K.CHECKPOINT: cb.CHECKPOINT, K.PAUSED: cb.PAUSED, K.WATCH: cb.WATCH,
                K.NONFINITE_STATE: cb.NOT_FINITE}.get(code, cb.DRIFTED)

    def _call(self, t_stop, out):
        """One call of the compiled loop: (its code, the steps taken)."""
        L, mon, st, ct = self._loops, self.monitor, self._st, self._ct
        live = mon is not None and not mon.warned
        times = np.empty(max(mon.next_check - mon.n_steps, 1) if live else 0)
        t_entry = self.t
        gimbal = self._gimbal if self.gimbal is not None and not self.gimbal.warned else self._gimbal[:0]
        self._enter()
        st[L.MIN_STEP] = self.min_step or 0.0
        ct[L.N_PROJ] = ct[L.N_MADE] = 0
        ct[L.K_OUT], ct[L.JAC_IN_LOOP], ct[L.N_JAC] = out.k, self._jac_in_loop, 0
        Jx, Jv = self._Jx, self._Jv
        if self.J is not None and self.J[0] is not Jx:  # formed in Python
            Jx[:], Jv[:] = self.J
        try:
            code, k = L.advance(self._ud, self._offset, *self._arrays, self._getrf, Jx, Jv, self._lu, self._piv,
                                _NO_LOW_PASS if self.low_pass is None else self.low_pass, self._par, self.atol, st,
                                ct, t_stop, out.once, times, self._budget, self._angles, self._bound, gimbal,
                                self._limit, self._fail_y, out.times, out.Y, out.tol, out.newton_tol, out.gain,
                                self._state_tol)
        finally:
            out.k = int(ct[L.K_OUT])
            out.made += int(ct[L.N_MADE])
            out.moved += int(ct[L.N_PROJ])
        jacobians = int(ct[L.N_JAC])
        if jacobians:  # formed by the loop (GeneralizedAlpha._new_jacobian's, no low-pass projector)
            self.J, self.low_pass = (Jx, Jv), None
            self.njev += jacobians
            if self._counters is not None:
                self._counters["jac"] = self._counters.get("jac", 0) + jacobians
        self._leave(k)
        act_on_deferred()  # a Ctrl-C recorded meanwhile
        if live and k:
            self._feed(self, mon, np.concatenate(([t_entry], times[: min(k, len(times))])))
        return code, k

    def within_bound(self, code: int) -> bool:
        """Whether the last :meth:`step_on` checked its last step's drift itself (and projected it if needed).

        Parameters
        ----------
        code : int
            What that :meth:`step_on` returned.

        Returns
        -------
        bool
            True where the compiled loop made the run's drift check after
            the last step (the run need not make it again).
        """
        return self._checked and self.t < self.t_bound
