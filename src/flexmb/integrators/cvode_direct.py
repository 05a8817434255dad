"""CVODE stepped in compiled code between output times: the ``CVODE_BDF`` and ``CVODE_Adams`` of open trees.

For an open tree whose joints and force elements are all compiled
(``System._packed_open``), whose coordinates are their speeds' integrals
(``qd = u``), and whose run tracks no work and locates no contact events,
:func:`~flexmb.integrators.direct_choice.compiled_loop` replaces scikit-sundae's :class:`~flexmb.integrators.CVODE`
by :class:`DirectCVODE`: CVODE called directly through ctypes
(:mod:`~flexmb.integrators.cvode_library`), the right-hand side and the
O(n) Newton preconditioner as compiled C callbacks
(:mod:`flexmb.kernels.cvode_callbacks`), and CVODE's step loop between two
output times compiled (:func:`~flexmb.kernels.cvode_callbacks.advance`):
one Python call per run instead of one per step and per
evaluation. A dense Jacobian (below ``KRYLOV_MIN_COORDS`` coordinates) is
flexmb's ``System.state_jacobian``: compiled as a C callback
(:func:`~flexmb.kernels.cvode_callbacks.jac`) where the model's tangent is
what the compiled one covers (:func:`compiled_jacobian`), else called from
Python through a ctypes callback. CVODE is given the
options scikit-sundae gives it for flexmb: the runs take scikit-sundae's
very steps and end in its states (tests/test_cvode_direct.py).

What flexmb's step loop does after every step is done in the compiled
loop, which steps through all the output times (:meth:`DirectCVODE.step_through`)
and returns to Python only where something needs acting on: the resolution
monitor's checkpoints that have something to judge (the quiet ones pass in
the loop), a winding angle or the gimbal watch, a progress mark, and every
:data:`STEPS_PER_CALL` steps (Ctrl-C and other signals).
"""

from __future__ import annotations

import ctypes
from ctypes import byref, c_double, c_int, c_long, c_void_p

import numpy as np

from .._signals import act_on_deferred, deferred
from ..run_memo import once
from .cvode_library import FLAGS, CVODEError, sundials
from .cvode_options import KRYLOV_DIM, MAX_STEPS
from .monitor import CompiledSteps, _Step

__all__ = ["DirectCVODE", "DirectCVODEBDF", "DirectCVODEAdams", "REPLACES", "CVODEError",
           "STEPS_PER_CALL", "compiled_jacobian"]

CV_ADAMS, CV_BDF, SUN_PREC_LEFT = 1, 2, 1
#: steps of one compiled call before it returns to Python (which then handles signals: Ctrl-C, SIGTERM)
STEPS_PER_CALL = 1000


def _addr(f) -> int:
    return ctypes.cast(f, c_void_p).value


_FUNCTIONS: dict = {}


def _functions(S) -> tuple:
    """The addresses of ``CVode``, ``CVodeGetDky`` and ``N_VGetArrayPointer`` in the library ``S`` (read once)."""
    if id(S) not in _FUNCTIONS:
        _FUNCTIONS[id(S)] = (S, (_addr(S.CVode), _addr(S.CVodeGetDky), _addr(S.N_VGetArrayPointer)))
    return _FUNCTIONS[id(S)][1]


def compiled_jacobian(system) -> bool:
    """Whether the compiled state Jacobian gives this model's ``System.state_jacobian``.

    The compiled one (:func:`flexmb.kernels.tree_jacobian.tree_state_jacobian`
    for open trees, :func:`flexmb.kernels.loop_jacobian.loop_state_jacobian`
    with loops) holds the diagonal coordinate springs and dampers and the
    loads' and inertia forces' geometric stiffness. The model's tangent
    must have nothing else: no springs or dampers between points
    (``pair_tangent_all``), no velocity-dependent point forces
    (``velocity_tangent_all``), no constant point forces or body-axis
    torques turning with their bodies (``System._turning_loads``'s).
    Elsewhere the run's Jacobian is ``System.state_jacobian``, called from
    Python.

    Parameters
    ----------
    system : System
        A model the compiled callbacks evaluate (an open tree with
        ``System._packed_open``, or :func:`~flexmb.integrators.cvode_direct_loops.loop_class`'s).

    Returns
    -------
    bool
        True if the run's CVODE takes the compiled Jacobian (a C callback)
        instead of the Python one (worked out once per System: :mod:`flexmb.run_memo`).
    """
    return once(system, "compiled_jacobian", lambda: _tangent_compiled(system))


def _tangent_compiled(system) -> bool:
    """:func:`compiled_jacobian`, worked out."""
    from ..forces import BodyTorque, PointForce

    kin = system.kinematics(0.0, system.layout.reference(), np.zeros(system.n_speeds))
    for cls, elements in system.forces.groups:
        if cls.pair_tangent_all(elements, kin) is not None or cls.velocity_tangent_all(elements, kin) is not None:
            return False
        for e in elements:
            if type(e) is PointForce and not callable(e.force):
                return False
            if type(e) is BodyTorque and e.frame == "body" and not callable(e.torque):
                return False
    return True


class DirectCVODE:
    """CVODE on an open tree with compiled callbacks: one Python call per run (and per thing to act on).

    Built by :class:`flexmb.stepping.Run` with the arguments of the
    integrators it makes; it offers what the run's loop uses of them
    (:meth:`advance`, :meth:`dense_output`, ``t``, ``t_old``, ``y``,
    ``n_steps``, ``status``).

    Parameters
    ----------
    fun : callable
        The run's right-hand side (used only with ``python_rhs``).
    t0 : float
        Start.
    y0 : ndarray, shape (m,)
        The integrator's initial state ``z`` (the state less ``offset``).
    t_bound : float
        End (CVODE's stop time).
    rtol, atol : float or ndarray
        Tolerances.
    max_step : float
        Largest step (``inf``: unbounded).
    first_step : float, optional
        First step (default: CVODE's estimate).
    system : System
        The model (``System._packed_open`` set, ``qd = u``).
    krylov : bool
        GMRES with the O(n) Newton preconditioner instead of the dense
        Jacobian and LU (flexmb's choice from ``KRYLOV_MIN_COORDS`` on).
    jacobian : callable, optional
        ``jacobian(t, y) -> (m, m)`` of the true state for the dense linear
        solver: where :func:`compiled_jacobian` says so, the compiled one
        replaces it (a C callback), else it is called from Python (a
        ctypes callback); without it (and without ``krylov``) CVODE's own
        difference quotients.
    python_rhs : bool
        Call ``fun`` from Python (a ctypes callback) instead of the compiled
        right-hand side (a check of the loop; what a model with Python force
        elements would need). An exception it raises stops CVODE and is
        raised again by :meth:`advance`.
    offset : ndarray, optional
        The winding offsets ``c`` (the callbacks see ``y = z + c``).
    monitor : ResolutionMonitor, optional
        Given the steps at its checkpoints.
    angles : ndarray of int, optional
        The winding angles, watched against ``bound``.
    bound : float
        Their bound.
    gimbal : GimbalWatch, optional
        Its joints' ``ry`` watched while it has not warned.
    counters : dict, optional
        The run's counters: ``"rhs"`` and ``"jac"`` (Jacobians, or
        preconditioner set-ups) are increased as CVODE calls them (and, on
        loops, ``"cvode_projections"``:
        :class:`~flexmb.integrators.cvode_direct_loops.DirectLoopCVODE`).
    nonfinite_flag : int
        What the right-hand side returns when its result is not finite: -1
        (unrecoverable: the run stops there, as flexmb's Python right-hand
        side does) or 1 (recoverable: CVODE retries with a smaller step).
    max_order : int, optional
        The method's largest order (default: the class's ``max_order``).
    **extraneous
        Other options of the integrators a run makes, ignored.
    """

    family, max_order = "BDF", 5
    explicit = second_order = finds_roots = cheap_restart = rebases = moves = False
    uses_jacobian = uses_preconditioner = needs_n_second = False
    advances = steps_in_compiled_code = True
    _compiled_jac = False  # the dense Jacobian by the callbacks' module's C callback ``jac`` (set with the run's)

    def __init__(self, fun, t0, y0, t_bound, *, rtol, atol, max_step=np.inf, first_step=None, system,
                 krylov=False, jacobian=None, python_rhs=False, offset=None, monitor=None,
                 angles=(), bound=np.inf, gimbal=None, counters=None, nonfinite_flag=-1, max_order=None,
                 **extraneous):
        from ..kernels.interpreted import require_jit

        require_jit(f"{type(self).__name__}'s callbacks and step loop")
        cb = self._callbacks()
        if max_order is not None:  # the run's cap (flexmb.stepping.OSCILLATION_MAX_ORDER), else the class's
            self.max_order = min(int(max_order), type(self).max_order)
        self._refuse(system)
        self._cb, self.system, self.monitor, self.gimbal = cb, system, monitor, gimbal
        self._S = S = sundials()
        self.t, self.t_old, self.t_bound, self.n_steps, self.status = float(t0), None, float(t_bound), 0, "running"
        self._mem = self._ls = self._A = self._y = self._out = self._atol = None
        self._ctx = c_void_p()
        self._raised = None  # an exception of a Python callback, raised again after CVODE returns
        self._py_jac = None if jacobian is None else self._python_jacobian(jacobian)
        self._py_rhs = self._python_rhs(fun) if python_rhs else None
        self.n, self.m = system.n_speeds, len(y0)
        self._offset = None if offset is None else np.ascontiguousarray(offset, dtype=float)
        self._angles = np.asarray(angles, dtype=np.int64)
        self._bound = float(bound)
        self._gimbal = np.zeros(0, np.int64) if gimbal is None else np.asarray(gimbal.index, dtype=np.int64)
        self._limit = 0.0 if gimbal is None else float(gimbal.limit)
        self._counters, self._counted = counters, {}
        self._steps = CompiledSteps(monitor)
        self._ud = self._user_data(system, nonfinite_flag)
        self._check(S.SUNContext_Create(0, byref(self._ctx)), "SUNContext_Create")
        S.SUNContext_ClearErrHandlers(self._ctx)  # failures become CVODEError, not lines on stderr
        self._y, self._out = S.N_VNew_Serial(self.m, self._ctx), S.N_VNew_Serial(self.m, self._ctx)
        if not (self._y and self._out):
            raise MemoryError("N_VNew_Serial returned NULL")
        self.y, self._out_data = self._data(self._y), self._data(self._out)  # views of the vectors' data
        self.y[:] = y0
        self._mem = S.CVodeCreate(CV_BDF if self.family == "BDF" else CV_ADAMS, self._ctx)
        if not self._mem:
            raise MemoryError("CVodeCreate returned NULL")
        self._setup(rtol, atol, krylov, max_step, first_step)
        self._tret = np.array([self.t])
        cvode, dky, getptr = _functions(S)
        self._lp = np.array([cvode, dky, self._mem, self._y, self.y.ctypes.data, self._out, self._tret.ctypes.data,
                             self.m, getptr], dtype=np.int64)

    @staticmethod
    def _callbacks():
        """The module of the C callbacks and of the compiled step loop."""
        from ..kernels import cvode_callbacks

        return cvode_callbacks

    @staticmethod
    def _refuse(system) -> None:
        """Raise ValueError for a model these callbacks cannot evaluate."""
        if system._packed_open is None or not system.layout.identity:
            raise ValueError("DirectCVODE needs an open tree whose joints and force elements are all compiled, "
                             "with qd = u")

    def _user_data(self, system, nonfinite_flag):
        cb, n, nb = self._cb, self.n, system.topology.n_bodies
        ud, K, C = once(system, ("direct_cvode_ud", self.m), lambda: self._shared_user_data(system))
        ud = ud.copy()
        sizes = ((cb.A_SPATIAL, "spatial", nb * 36), (cb.A_SW, "Sw", n * 3), (cb.A_SV, "Sv", n * 3),
                 (cb.A_R, "r", (nb + 1) * 3), (cb.A_FAIL_T, "fail_t", 1), (cb.A_FAIL_Y, "fail_y", self.m),
                 (cb.A_WORK, "work", cb.work_size(nb, n, self.m)))
        buffer = np.zeros(sum(size for _, _, size in sizes))  # one allocation, seen as the callbacks' arrays
        base, start, arrays = buffer.ctypes.data, 0, {}
        for slot, key, size in sizes:
            arrays[key], ud[slot], start = buffer[start:start + size], base + 8 * start, start + size
        fl, it, fg, ix = system._packed_open
        self._arrays = dict(fl=fl, it=it, fg=fg, ix=ix, K=K, C=C, offset=self._offset, **arrays)
        ud[cb.N_WORK] = arrays["work"].size
        if self._offset is not None:
            ud[cb.A_OFFSET], ud[cb.HAS_OFFSET] = self._offset.ctypes.data, 1
        ud[cb.STATUS], ud[cb.NONFINITE_FLAG] = -1, nonfinite_flag
        return ud

    def _shared_user_data(self, system):
        """The callbacks' user data that depends on the System alone, with the K and C it points to (read-only)."""
        from ..system.tangent import NewtonPreconditioner

        cb, S, n, nb = self._cb, self._S, self.n, system.topology.n_bodies
        fl, it, fg, ix = system._packed_open
        K, C = (np.array(v, dtype=float) for v in NewtonPreconditioner.diagonal_terms(system))
        K.flags.writeable = C.flags.writeable = False
        ud = np.zeros(cb.UD_SIZE, dtype=np.int64)
        ud[cb.A_GETPTR], ud[cb.N], ud[cb.M], ud[cb.NB] = _addr(S.N_VGetArrayPointer), n, self.m, nb
        ud[cb.A_MATDATA] = _addr(S.SUNDenseMatrix_Data)
        for slot, size, array in ((cb.A_FL, cb.N_FL, fl), (cb.A_IT, cb.N_IT, it), (cb.A_FG, cb.N_FG, fg)):
            ud[slot], ud[size] = array.ctypes.data, array.size
        ud[cb.A_IX], ud[cb.N_IX] = ix.ctypes.data, ix.shape[0]
        ud[cb.A_K], ud[cb.A_C] = K.ctypes.data, C.ctypes.data
        return ud, K, C

    def _setup(self, rtol, atol, krylov, max_step, first_step):
        """CVODE's options in scikit-sundae's order, as flexmb's CVODE_BDF gives them."""
        S, cb, mem, ck = self._S, self._cb, self._mem, self._check
        ck(S.CVodeSetUserData(mem, self._ud.ctypes.data), "CVodeSetUserData")
        f = cb.rhs.address if self._py_rhs is None else _addr(self._py_rhs)
        ck(S.CVodeInit(mem, f, self.t, self._y), "CVodeInit")
        if np.ndim(atol):
            if self._atol is None:
                self._atol = S.N_VNew_Serial(self.m, self._ctx)
                self._data(self._atol)[:] = atol
            ck(S.CVodeSVtolerances(mem, float(rtol), self._atol), "CVodeSVtolerances")
        else:
            ck(S.CVodeSStolerances(mem, float(rtol), float(atol)), "CVodeSStolerances")
        if krylov:
            self._ls = S.SUNLinSol_SPGMR(self._y, SUN_PREC_LEFT, KRYLOV_DIM, self._ctx)
        else:
            self._A = S.SUNDenseMatrix(self.m, self.m, self._ctx)
            self._ls = S.SUNLinSol_Dense(self._y, self._A, self._ctx)
        if not self._ls or not (krylov or self._A):
            raise MemoryError("the SUNDIALS matrix or linear solver constructor returned NULL")
        ck(S.CVodeSetLinearSolver(mem, self._ls, self._A), "CVodeSetLinearSolver")
        if krylov:
            ck(S.CVodeSetPreconditioner(mem, cb.psetup.address, cb.psolve.address), "CVodeSetPreconditioner")
        elif self._compiled_jac:
            ck(S.CVodeSetJacFn(mem, cb.jac.address), "CVodeSetJacFn")
        elif self._py_jac is not None:
            ck(S.CVodeSetJacFn(mem, _addr(self._py_jac)), "CVodeSetJacFn")
        ck(S.CVodeSetMaxNonlinIters(mem, 3), "CVodeSetMaxNonlinIters")
        ck(S.CVodeSetMaxConvFails(mem, 10), "CVodeSetMaxConvFails")
        ck(S.CVodeSetInitStep(mem, 0.0 if first_step is None else float(first_step)), "CVodeSetInitStep")
        ck(S.CVodeSetMinStep(mem, 0.0), "CVodeSetMinStep")
        ck(S.CVodeSetMaxStep(mem, 0.0 if not np.isfinite(max_step) else float(max_step)), "CVodeSetMaxStep")
        ck(S.CVodeSetMaxOrd(mem, self.max_order), "CVodeSetMaxOrd")
        ck(S.CVodeSetMaxNumSteps(mem, MAX_STEPS), "CVodeSetMaxNumSteps")
        ck(S.CVodeSetStopTime(mem, self.t_bound), "CVodeSetStopTime")

    def _python_rhs(self, fun):
        """A ctypes callback (CVRhsFn) filling ``ydot`` with ``fun(t, z)``; -1 (and the exception kept) if it raises."""
        proto = ctypes.CFUNCTYPE(c_int, c_double, c_void_p, c_void_p, c_void_p)

        def f(t, y, ydot, user_data):
            try:
                self._ud[self._cb.RHS] += 1
                self._data(ydot)[:] = fun(t, self._data(y))
                return 0
            except BaseException as exc:  # noqa: BLE001 - nothing may cross into C; advance raises it again
                self._raised = exc
                return -1

        return proto(f)

    def _python_jacobian(self, jacobian):
        """None where the compiled Jacobian (:func:`compiled_jacobian`) replaces the run's, else a ctypes callback.

        The callback (CVLsJacFn) fills the dense matrix with ``jacobian(t, z + c)``; -1 if it raises.
        """
        self._compiled_jac = compiled_jacobian(self.system)
        if self._compiled_jac:
            return None
        proto = ctypes.CFUNCTYPE(c_int, c_double, c_void_p, c_void_p, c_void_p, c_void_p, c_void_p, c_void_p,
                                 c_void_p)

        def jac(t, y, fy, J, user_data, tmp1, tmp2, tmp3):
            try:
                self._ud[self._cb.JACS] += 1
                m = self.m
                data = np.ctypeslib.as_array((c_double * (m * m)).from_address(self._S.SUNDenseMatrix_Data(J)))
                z = self._data(y)
                data.reshape((m, m), order="F")[:] = jacobian(t, z if self._offset is None else z + self._offset)
                return 0
            except BaseException as exc:  # noqa: BLE001 - nothing may cross into C; advance raises it again
                self._raised = exc
                return -1

        return proto(jac)

    def _data(self, v) -> np.ndarray:
        return np.ctypeslib.as_array((c_double * self.m).from_address(self._S.N_VGetArrayPointer(v)))

    @staticmethod
    def _check(flag, what):
        if flag < 0:
            raise CVODEError(f"{what} failed: {FLAGS.get(flag, flag)}")

    def advance(self, t_stop: float, on_step=None) -> np.ndarray:
        """Step until ``t_stop`` (one compiled loop; back in Python at checkpoints, watches and every so many steps).

        Parameters
        ----------
        t_stop : float
            Time to reach (at most ``t_bound``).
        on_step : callable, optional
            Called with the solver after a step that a watch flagged (an
            angle past its bound, a joint near gimbal lock): the run's
            checks of that step (they may raise to restart it).

        Returns
        -------
        ndarray, shape (m,)
            The state at ``t_stop`` (CVODE's interpolant if the last step passed it).

        Raises
        ------
        CVODEError
            If CVODE fails (its flag, the time, the callback's cause).
        KeyboardInterrupt
            Ctrl-C (or SIGTERM, SIGHUP) while it stepped: recorded meanwhile (:class:`flexmb._signals.deferred`,
            here or around the whole run) and raised once the compiled loop returns.
        """
        stops, Y, j, cb = np.array([min(float(t_stop), self.t_bound)]), np.empty((1, self.m)), 0, self._cb
        with deferred():
            while j == 0:
                code, j = self.step_through(stops, np.zeros(1, dtype=np.bool_), 0, Y)
                if code == cb.NOT_FINITE:
                    break
                if code == cb.WATCH and on_step is not None:
                    on_step(self)
        return Y[0].copy()

    def step_through(self, stops, marks, j, Y) -> tuple:
        """Step through ``stops[j:]`` in one compiled call (:func:`flexmb.kernels.cvode_callbacks.advance`).

        A checkpoint of the monitor with something to judge is judged here
        (:class:`~flexmb.integrators.monitor.CompiledSteps`; the quiet ones pass in the loop).

        Parameters
        ----------
        stops, marks, j, Y
            Increasing stops (at most ``t_bound``), those after which to return (progress marks: bool), the
            next one, and the states at the stops reached (filled, shape (len(stops), m)).

        Returns
        -------
        code : int
            The loop's code (``REACHED``, ``CHECKPOINT``, ``PAUSED``, ``WATCH``, ``NOT_FINITE`` of
            :mod:`flexmb.kernels.cvode_callbacks`).
        j : int
            The next stop to reach (the stops before it are in ``Y``).

        Raises
        ------
        CVODEError
            If CVODE fails.
        """
        if self._mem is None:
            raise CVODEError("this DirectCVODE is closed")
        cb, steps = self._cb, self._steps
        code = cb_grow = cb.GROW
        while code == cb_grow:
            steps.load()
            gimbal = self._gimbal if self.gimbal is not None and not self.gimbal.warned else self._gimbal[:0]
            try:
                code, j, k = cb.advance(self._lp, stops, marks, j, self.t_bound, Y, STEPS_PER_CALL, self._angles,
                                        self._bound, gimbal, self._limit, steps.mi, steps.hs, steps.mf)
            finally:
                self._count()
            act_on_deferred()  # a Ctrl-C recorded meanwhile (see advance's docstring)
            self.n_steps += k
            if k:
                self.t = float(self._tret[0])
                h = c_double()
                self._S.CVodeGetLastStep(self._mem, byref(h))
                self.t_old = self.t - h.value
            steps.judge(self.t, self.y) if code == cb.CHECKPOINT else steps.save()
            if code == cb_grow:
                steps.grow()
        if code < 0:
            self.status = "failed"
            if self._raised is not None:
                raised, self._raised = self._raised, None
                raise raised
            self._diagnose()
            raise self._error(code)
        if code == cb.REACHED and self.t >= self.t_bound:
            self.status = "finished"
        return code, j

    def _callback_counts(self) -> dict:
        """The callbacks' counters since the start, by the name of the run's counter they feed."""
        cb, ud = self._cb, self._ud
        return {"rhs": int(ud[cb.RHS]), "jac": int(ud[cb.SETUPS] + ud[cb.JACS])}

    def _count(self):
        """Add the callbacks' counts since the last call to the run's counters (with loops, ``n_complements``)."""
        now, was = self._callback_counts(), self._counted
        if self._counters is not None:
            for key, value in now.items():
                self._counters[key] = self._counters.get(key, 0) + value - was.get(key, 0)
        if self.system.n_constraints:  # each right-hand side one loop solve (System._loop_solve's count)
            self.system.n_complements += now["rhs"] - was.get("rhs", 0)
        self._counted = now

    def _feed(self, mon, times):
        """Give the monitor the steps between ``times`` as its ``step`` takes them one by one."""
        ts = times.tolist()  # (the differences of np.diff, in floats)
        mon.steps.extend([b - a for a, b in zip(ts[:-2], ts[1:-1])])
        mon.n_steps += len(ts) - 2
        mon.step(_Step(ts[-1], ts[-2], self.y))

    def _diagnose(self) -> None:
        """Raise flexmb's own diagnosis (AssemblyError) of the state at which a callback failed, if it gives one.

        The right-hand side at that state, evaluated in Python, names what
        became non-finite or the joint that moves no mass, as a run
        stepping in Python reports it.
        """
        cb, ud = self._cb, self._ud
        if int(ud[cb.STATUS]) == -1:
            return
        t, y = float(self._arrays["fail_t"][0]), self._arrays["fail_y"].copy()
        rate = self.system._state_rate(t, y)  # raises AssemblyError naming the cause where it finds one
        if not np.all(np.isfinite(rate)):
            bad = [self.system.speed_names[i % self.n] for i in np.flatnonzero(~np.isfinite(rate))[:5]]
            raise _nonfinite(t, bad)

    def _error(self, code) -> CVODEError:
        cb, ud = self._cb, self._ud
        what = f"CVODE failed at t = {self.t:.9g} s: {FLAGS.get(code, code)}"
        status = int(ud[cb.STATUS])
        if status != -1:
            t_fail = self._arrays["fail_t"][0]
            if status >= 0:
                cause = (f"joint {self.system.topology.tree_joints[status].name!r} moves no mass or inertia along "
                         "one of its freedoms")
            else:
                cause = "the state derivative became non-finite"
            what += f"; at t = {t_fail:.9g} s {cause}"
        error = CVODEError(what)
        error.t = float(self._arrays["fail_t"][0]) if status != -1 else self.t
        return error

    def dense_output(self):
        """CVODE's interpolant over its last step (``CVodeGetDky``), valid until it steps again.

        Returns
        -------
        callable
            ``t -> y(t)`` for ``t`` in ``[t_old, t]``.
        """
        t_now = self.t

        def interpolate(t):
            if self.t != t_now or self._mem is None:
                raise RuntimeError("a CVODE dense output is valid only until the solver's next step")
            self._check(self._S.CVodeGetDky(self._mem, float(t), 0, self._out), "CVodeGetDky")
            return self._out_data.copy()

        return interpolate

    def stats(self) -> dict:
        """CVODE's counters, and the callbacks' own.

        Returns
        -------
        dict
            ``steps``, ``rhs_cvode``, ``rhs_ls``, ``err_test_fails``,
            ``newton_iters``, ``newton_fails``, ``lin_iters``,
            ``lin_setups``; ``rhs`` and ``jac`` (Jacobians or preconditioner
            set-ups) as the callbacks counted them.
        """
        S, cb, out = self._S, self._cb, {}
        for key, name in (("steps", "NumSteps"), ("rhs_cvode", "NumRhsEvals"), ("rhs_ls", "NumLinRhsEvals"),
                          ("err_test_fails", "NumErrTestFails"), ("newton_iters", "NumNonlinSolvIters"),
                          ("newton_fails", "NumNonlinSolvConvFails"), ("lin_iters", "NumLinIters"),
                          ("lin_setups", "NumLinSolvSetups")):
            v = c_long()
            self._check(getattr(S, f"CVodeGet{name}")(self._mem, byref(v)), f"CVodeGet{name}")
            out[key] = v.value
        out["rhs"] = int(self._ud[cb.RHS])
        out["jac"] = int(self._ud[cb.SETUPS] + self._ud[cb.JACS])
        return out

    def close(self) -> None:
        """Free CVODE, the linear solver, the matrix, the vectors and the context (once)."""
        S = getattr(self, "_S", None)
        if S is None:
            return
        if self._mem:
            S.CVodeFree(byref(c_void_p(self._mem)))
        if self._ls:
            S.SUNLinSolFree(self._ls)
        if self._A:
            S.SUNMatDestroy(self._A)
        for v in (self._y, self._out, self._atol):
            if v:
                S.N_VDestroy(v)
        if self._ctx:
            S.SUNContext_Free(byref(self._ctx))
        self._mem = self._ls = self._A = self._y = self._out = self._atol = None
        self.y = self._out_data = None
        self._S = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        self.close()


class DirectCVODEBDF(DirectCVODE):
    family, max_order = "BDF", 5
    limits_order = True


class DirectCVODEAdams(DirectCVODE):
    family, max_order = "Adams", 12


#: the integrators stepped in compiled code on an open tree: the import path of scikit-sundae's class -> this one's
REPLACES = {"flexmb.integrators.sundials:CVODEBDF": DirectCVODEBDF,
            "flexmb.integrators.sundials:CVODEAdams": DirectCVODEAdams}

_PARAMETERS = DirectCVODE.__doc__[DirectCVODE.__doc__.index("    Parameters\n"):]
DirectCVODEBDF.__doc__ = (":class:`DirectCVODE` with CVODE's variable-order BDF (orders 1-5): ``'CVODE_BDF'`` on "
                          "open trees.\n\n" + _PARAMETERS)
DirectCVODEAdams.__doc__ = (":class:`DirectCVODE` with CVODE's Adams-Moulton (orders 1-12, Newton): "
                            "``'CVODE_Adams'`` on open trees.\n\n" + _PARAMETERS)


def _nonfinite(t, names):
    from ..errors import AssemblyError
    err = AssemblyError(f"at t = {t:.9g} s: the state rates became non-finite ({', '.join(names)})")
    err.t = t
    return err
