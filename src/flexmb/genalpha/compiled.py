"""Generalized-alpha stepped in compiled code between output times: :func:`compiled_genalpha`.

Looped models have their own class (:mod:`flexmb.genalpha.compiled_loops`),
chosen here as well.

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
from .solver import _NO_LOW_PASS, NEWTON_REGROWTH, GeneralizedAlpha

__all__ = ["compiled_genalpha", "CompiledGeneralizedAlpha"]

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
    models it serves get :class:`~flexmb.genalpha.compiled_loops.CompiledLoopGeneralizedAlpha`); Euler parameters (the rotation chart of
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
    if loops:  # (the loops' class imported only for a looped model)
        from .compiled_loops import CompiledLoopGeneralizedAlpha as base
    else:
        base = CompiledGeneralizedAlpha
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
    if not (system.n_constraints and system.layout.identity and system._loop_kernel):
        return False
    from ..integrators.cvode_direct_loops import loop_class

    return loop_class(system, "BDF") is not None


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
    #: what the model must be (the error's words)
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
