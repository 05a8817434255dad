"""The step loop of a simulation: an integrator driven from output time to output time.

:func:`flexmb.simulate` prepares a run (the system, the initial state, the
integrator) and hands it to :class:`Run`, which integrates the state
``y = (x, xd[, w])`` with the reduced accelerations (eqs. 36-39), stores the
states at the output times, projects drifted states back onto the
constraints (eqs. 28-29) and turns every failure into a status and a
message with the time it happened.

Angles that wind up do not loosen the error control. An integrator weighs
the error of a state component by ``1 / (rtol |y_i| + atol)``, so an angle
that has turned to 60 rad would be controlled 60 times more loosely than
one at 1 rad, though the position error it causes does not depend on how many
turns it made. The integrator is therefore given ``z = y - c``, where the
offset ``c`` is a multiple of ``WINDING_PERIOD`` on each angle
(:attr:`~flexmb.topology.Topology.coord_angle`) and zero elsewhere; the
right-hand side, the Jacobian and the Newton preconditioner see
``y = z + c``, and the stored states are ``y`` (the unwrapped angles). When
an angle leaves ``|z_i| <= WINDING_BOUND`` after a step, its offset moves
by whole periods, leaving ``WINDING_BOUND - WINDING_PERIOD < |z_i| <=
WINDING_BOUND`` (about once per turn), and the integrator follows: in place
if it can (``rebase``, :mod:`flexmb.integrators.base`), otherwise restarted
from the moved state. An angle is thus weighed as one of at most
``WINDING_BOUND`` (3 pi) however far it has turned; one that never gets
that far keeps a zero offset, and its run is unchanged.
"""

from __future__ import annotations

import time as _time

import numpy as np

from ._signals import escaped, interruption, who
from .contact_events import ContactEvents, StepFailure
from .event_restart import cut_at_event
from .gimbal import GimbalWatch
from .errors import AssemblyError
from .offset_preconditioner import OffsetPreconditioner
from .output_projection import project_output
from .own_loop import NonFinite, advance_between_stops, advance_checking, compiled_options
from .progress import Progress
from .result import Result
from .run_memo import last, state_key

__all__ = ["Run"]

#: integrators without a cheap restart (``cheap_restart = False``: CVODE, back to order one) project their own
#: state when the constraint residual exceeds RESTART_ATOL_FACTOR * atol, at most RESTART_TOL_MAX (or
#: projection_tol, if larger); their stored outputs are projected to projection_tol. On the four-bar at rtol
#: 1e-9 projecting at 100 atol restarts CVODE every few steps (the run collapses), at 1e3 atol 62 times, at 1e4 once.
RESTART_ATOL_FACTOR = 1e4
RESTART_TOL_MAX = 1e-6

#: a restart of such an integrator within RESTART_MIN_STEPS steps of the one before raises the run's
#: bound tenfold, up to RESTART_TOL_CEILING: from rtol 1e-6 up the capped bound is within reach of
#: the order-one steps after a restart, and CVODE restarted every few steps (thousands of times a
#: second on the four-bar and on B6 at rtol 1e-5; benchmarks/restart_bound.py, docs/benchmarks.md);
#: runs that restart rarely keep the bound (their loop drift, and the energy ledger, as before)
RESTART_MIN_STEPS = 50
RESTART_TOL_CEILING = 1e-4

#: BDF orders 4 and 5 are not stable near the imaginary axis (A(73 deg)- and A(52 deg)-stable only): a flexible
#: body's lightly damped modes sit there, and at loose tolerances, where the step reaches them, CVODE's error
#: estimate is held by the bodies' deformation speeds and orders 4-5 take more steps than order 3 (B6, its
#: looped flexible rod, docs/benchmarks.md "What limits CVODE's step on B6"). An integrator that takes
#: ``max_order`` (``limits_order``) is held to OSCILLATION_MAX_ORDER on a model with flexible bodies in loops
#: from rtol OSCILLATION_RTOL_MIN up; at tighter tolerances the higher orders pay (and rigid loops keep them)
OSCILLATION_MAX_ORDER = 3
OSCILLATION_RTOL_MIN = 1e-4

#: open trees with at least this many coordinates are integrated by integrators declaring
#: ``uses_preconditioner`` (CVODE_BDF) with O(n) preconditioned Krylov solves instead of a dense
#: Jacobian; measured on B1 and B2 (docs/benchmarks.md, "Large open trees"): dense LU is as fast
#: or faster below
KRYLOV_MIN_COORDS = 48

#: the offsets of the angles are multiples of WINDING_PERIOD, rad. An angle farther than WINDING_BOUND
#: from its offset has its offset moved by whole periods, to between WINDING_BOUND - WINDING_PERIOD and
#: WINDING_BOUND from the angle, on the side it came from: about once per turn, and never near zero,
#: where the weight 1 / (rtol |z| + atol) would jump to 1 / atol once per turn (steps collapsing and
#: growing again cost generalized-alpha accuracy: benchmarks/winding.py). Angles that stay within
#: +-WINDING_BOUND keep a zero offset: those runs are unchanged.
WINDING_PERIOD = 2.0 * np.pi
WINDING_BOUND = 3.0 * np.pi


def _matrix_free(system, solver_cls, caps) -> bool:
    """Whether a run of ``solver_cls`` solves its Newton systems with the O(n) preconditioner and no matrix.

    From the class's own threshold of speeds (GeneralizedAlpha's
    ``krylov_min_coords``, ``krylov_min_loop_coords``; else
    ``KRYLOV_MIN_COORDS``) on open trees and loops closed through the
    recursion, unless the class's ``f_max`` needs the dense Jacobian.
    """
    floor = getattr(solver_cls, f"krylov_min_{'loop_' if system._loop_kernel else ''}coords", KRYLOV_MIN_COORDS)
    return bool(caps.uses_preconditioner and (system.articulated or system._loop_kernel)
                and system.n_speeds >= floor and not getattr(solver_cls, "f_max", None))


class Run:
    """One simulation run of a system from its initial state.

    Parameters
    ----------
    system : System
        The (calibrated) system to integrate.
    solver_cls : type
        The integrator, an OdeSolver class.
    name : str
        The integrator's name, for messages.
    times : ndarray, shape (k,)
        Output times, increasing, within ``[t0, t_end]``.
    t0, t_end : float
        Span, s.
    rtol, atol, max_step, projection_tol : float
        As for :func:`flexmb.simulate`.
    track_work : bool
        Integrate the work of the drivers and of each class of force
        elements along with the state.
    progress : bool
        Show a progress bar.
    auto : bool
        Whether ``method='auto'`` chose the integrator (the resolution
        monitor words its warning accordingly).
    contact_events : bool
        Locate the onsets and separations of the contacts as events and
        restart the integrator there, refusing steps through a surface
        (:mod:`flexmb.contact_events`); no effect without contact elements.

    Attributes
    ----------
    status, message : str
        How the run ended, after :meth:`execute`.
    offset : ndarray, shape (nq + n + n_w,) or None
        What the integrator's state lacks of the true one, ``y = z + offset``
        (multiples of ``WINDING_PERIOD`` on the angles); None until an angle
        first winds past ``WINDING_BOUND``.
    n_rebases : int
        How many times the offsets moved.
    events : ContactEvents or None
        The run's contact events (None without contacts or events).
    """

    def __init__(self, system, solver_cls, name, times, *, t0, t_end, rtol, atol, max_step, projection_tol,
                 track_work, progress, auto, contact_events=True):
        from .integrators import adapt, capabilities
        from .integrators.direct_choice import compiled_loop
        from .integrators.monitor import ResolutionMonitor

        self.system = system
        self.n = system.n_speeds
        self.layout = system.layout  # y = (q, u, works), qd = W(q) u
        self.name, self.times, self.t0, self.t_end = name, times, t0, t_end
        self.rtol, self.atol, self.max_step = rtol, atol, max_step
        self.projection_tol, self.progress = projection_tol, progress
        self.n_drv = len(system.constraints.drivers)
        elements = system.constraints.elements  # their work: that of their rows with b != 0
        self.work_names = ([f"driver {d.name}" for d in system.constraints.drivers] + system.forces.group_names()
                           + [f"constraint {e.name}" for e in elements] if track_work else [])
        self.n_w, self.n_el = len(self.work_names), len(elements) if track_work else 0
        self.counters = {"rhs": 0}
        self.start_complements = system.n_complements
        # what the integrator can use is declared by its class (flexmb.integrators.base)
        self.solver_cls = adapt(solver_cls)
        self.caps = capabilities(self.solver_cls)
        self.gimbal = GimbalWatch.of(system)
        self.monitor = ResolutionMonitor.for_run(system, self.solver_cls, self.caps, t0, t_end, rtol, atol, name, auto)
        # the integrator's own state is projected past a bound (_restart_if_drifted); the outputs are
        # projected to projection_tol all the same
        self.state_tol = (max(projection_tol, float(np.min(atol))) if self.caps.moves
                          else projection_tol if self.caps.cheap_restart
                          else max(projection_tol, min(RESTART_ATOL_FACTOR * atol, RESTART_TOL_MAX)))
        self.events = (ContactEvents.of(system, t0, t_end, self.caps.explicit, name) if contact_events else None)
        # CVODE (open trees and loops) or generalized-alpha (open trees) stepped in compiled code where the force
        # elements are compiled (the cases each keeps in Python: compiled_loop's and compiled_genalpha's docstrings)
        direct = compiled_loop(system, self.solver_cls, track_work, self.events)
        if direct is None and self.caps.second_order:  # (flexmb.genalpha imported only for such a class)
            from .genalpha.compiled import compiled_genalpha

            direct = compiled_genalpha(system, self.solver_cls, track_work, self.events,
                                       _matrix_free(system, self.solver_cls, self.caps))
        if direct is not None:
            self.solver_cls, self.caps = direct, capabilities(direct)
        # an event needs the step that crossed it: the run steps the integrator itself then
        self.own_loop = self.caps.advances and not system.n_constraints and self.events is None
        self.angles = np.flatnonzero(system.topology.coord_angle)
        self.offset, self.n_rebases, self.preconditioner = None, 0, None
        # one function object for every solver of the run: an integrator may remember its state across
        # restarts by its right-hand side (GeneralizedAlpha)
        self._fun = self._stage_rate if self.caps.explicit else self.rhs
        self.stage_failure: Exception | None = None  # why a stage of the step being taken could not be evaluated
        self.options: dict = {}
        self.out_y, self.k_out = [], 0
        self.n_steps = self.n_proj = self.n_steps_refused = 0
        self.last_restart = -RESTART_MIN_STEPS  # the step count at the last projection and restart
        self.t_now = t0
        self.status, self.message = "running", ""
        self.error: BaseException | None = None  # what made the run fail, if it did
        self.wall = 0.0

    def rhs(self, t, y) -> np.ndarray:
        """The state rate ``(qd, ud[, work rates])``; non-finite accelerations raise :class:`NonFinite`.

        Parameters
        ----------
        t : float
            Time, s.
        y : ndarray, shape (nq + n + n_w,)
            The integrator's state ``z``; the rate is that of ``y = z + offset``.

        Returns
        -------
        ndarray, shape (nq + n + n_w,)
            Its rate.
        """
        self.counters["rhs"] += 1
        system, n = self.system, self.n
        if self.offset is not None:
            y = y + self.offset
        if not self.n_w:
            return system._state_rate(t, y)  # finite, or AssemblyError naming the cause
        xs, vs = self.layout.split(y)
        rates = np.zeros(self.n_w)
        if system._loop_kernel:  # finite, or AssemblyError naming the cause
            xdd, lam = system._loop_solve(t, y, powers=rates[self.n_drv:], multipliers=True)
            if self.n_drv:
                rates[: self.n_drv] = lam[-self.n_drv:] * np.array([d.velocity(t) for d in system.constraints.drivers])
            return self.layout.join(self.layout.coordinate_rates(xs, vs), xdd, rates)
        n_g = self.n_w - self.n_drv - self.n_el
        A, f, psi, gamma = system._reduced_parts(t, y, powers=rates[self.n_drv : self.n_drv + n_g])
        try:
            xdd, lam = system._solve(t, A, f, psi, gamma, multipliers=True)
        except AssemblyError:
            xdd = np.full(n, np.nan)
        if not np.all(np.isfinite(xdd)):
            if not (np.all(np.isfinite(f)) and np.all(np.isfinite(A))):
                system._accelerations(t, xs, vs)  # raises with the diagnosis
            system._solve(t, A, f, psi, gamma)  # raises if the reduced equations are singular
            bad = [system.speed_names[i] for i in np.flatnonzero(~np.isfinite(xdd))[:5]]
            raise NonFinite(t, f"accelerations became non-finite ({', '.join(bad)})")
        if self.n_drv:
            rates[: self.n_drv] = lam[-self.n_drv:] * np.array([d.velocity(t) for d in system.constraints.drivers])
        if self.n_el:
            rates[self.n_drv + n_g:] = system.constraints.element_powers(lam, system._kinematics(t, xs, vs))
        return self.layout.join(self.layout.coordinate_rates(xs, vs), xdd, rates)

    def _stage_rate(self, t, y) -> np.ndarray:
        """:meth:`rhs` for an explicit method's stages: a stage that cannot be evaluated rejects the step.

        An explicit step's stages are trial states: a step too long for a
        stiff contact throws them far beyond the motion (a ball 1e10 m under
        its floor), where the equations can fail (the articulated inertias
        about the origin lose every digit) although the step would only have
        been rejected. Such a stage returns NaN, which the error estimate
        rejects, and the step is taken again shorter; the first failure since
        the last accepted step is kept in :attr:`stage_failure` and reported
        if the integrator gives up, so a model whose equations fail still
        stops with their cause, not with the step size it was left with.
        """
        try:
            return self.rhs(t, y)
        except (NonFinite, AssemblyError) as exc:
            if not np.isfinite(t):  # not a trial state: the step size itself is lost (a NaN error norm)
                raise
            if getattr(exc, "t", None) is None:
                exc.t = t
            if self.stage_failure is None:  # the first since the last accepted step: the cause
                self.stage_failure = exc
            return np.full(len(y), np.nan)

    def _jac(self, t, y):
        self.counters["jac"] += 1
        if self.offset is not None:
            y = y + self.offset
        J = self.system.state_jacobian(t, *self.layout.split(y))
        return np.pad(J, ((0, self.n_w), (0, self.n_w))) if self.n_w else J

    def _set_options(self, x, xd) -> None:
        """What the integrator is given besides the rhs: a Jacobian or a preconditioner, the second-order size."""
        caps, system, n = self.caps, self.system, self.n
        if getattr(self.solver_cls, "steps_in_compiled_code", False):
            self.options = compiled_options(self, x, xd, KRYLOV_MIN_COORDS, WINDING_BOUND)
            if not caps.second_order:  # CVODE: all it is given, with the order cap
                if caps.limits_order and self.oscillation_limited():
                    self.options["max_order"] = OSCILLATION_MAX_ORDER
                    self.options["project"] = bool(system.n_constraints)  # loops: CVODE projects (DirectLoopCVODE)
                return
            from .integrators.cvode_direct import STEPS_PER_CALL, DirectCVODE, compiled_jacobian

            # generalized-alpha: CVODE's loop's budget of steps and its feed of the monitor; loops: the Jacobian's kind
            self.options.update(budget=STEPS_PER_CALL, feed=DirectCVODE._feed,
                                **({"compiled_jacobian": compiled_jacobian(system)} if system.n_constraints else {}))
        if caps.needs_n_second:  # written for y = (x, xd, ...): given the layout when qd = W(q) u (GeneralizedAlpha)
            self.options["n_second"] = n
            if not system.layout.identity:
                self.options["layout"] = system.layout
        if self.events is not None and caps.finds_roots:  # the integrator's root finding, on the true state
            events = self.events
            self.options["events"] = (
                lambda t, z: events.root_functions(t, z if self.offset is None else z + self.offset), events.count)
        if caps.limits_order and self.oscillation_limited():
            self.options["max_order"] = OSCILLATION_MAX_ORDER
        if _matrix_free(system, self.solver_cls, caps):
            # an open tree, or loops closed through the recursion: O(n) Newton solves, no matrix (also qd = W(q) u)
            self.preconditioner = system.newton_preconditioner()
            self.options["preconditioner"] = OffsetPreconditioner(self.preconditioner, self)
        elif caps.uses_jacobian and system.state_jacobian(self.t0, x, xd) is not None:
            self.counters["jac"] = 0
            self.options["jac"] = self._jac
            if caps.second_order and system.layout.identity:
                # the Jacobian has the block form [[0, I], [Jx, Jv]] (qd = u): factor n x n only
                self.options["n_second"] = n

    def oscillation_limited(self) -> bool:
        """Whether a BDF method's orders above OSCILLATION_MAX_ORDER cost steps here.

        Returns
        -------
        bool
            True for a model with flexible bodies and loops (cut joints or
            constraint elements) run at rtol >= OSCILLATION_RTOL_MIN.
        """
        system = self.system
        return (bool(system.constraints.n_cut or system.constraints.elements) and bool(system.topology.flexible)
                and float(np.min(self.rtol)) >= OSCILLATION_RTOL_MIN)

    def _make(self, tstart, ystart, first_step=None, t_bound=None, events=True):
        options = self.options if events else {k: v for k, v in self.options.items() if k != "events"}
        if events and "events" in options:  # the root functions rise through 0 where a contact's state changes
            g, m = options["events"]
            options = dict(options, events=(g, m, np.ones(m)))
        if self.offset is not None and getattr(self.solver_cls, "steps_in_compiled_code", False):
            options = dict(options, offset=self.offset)  # the winding offsets its callbacks add
        return self.solver_cls(self._fun, tstart, ystart, self.t_end if t_bound is None else t_bound,
                               rtol=self.rtol, atol=self.atol, max_step=self.max_step, first_step=first_step,
                               **options)

    def execute(self, x, xd) -> None:
        """Integrate from ``(x, xd)`` at ``t0`` to ``t_end``; set :attr:`status` and :attr:`message`.

        Parameters
        ----------
        x, xd : ndarray, shape (nq,) and (n,)
            The assembled initial state: coordinates q and speeds u.
        """
        self._set_options(x, xd)
        y = self.layout.join(x, xd, np.zeros(self.n_w))
        if self.times[0] == self.t0:
            self.out_y.append(y.copy())
            self.k_out = 1
        t_wall = _time.perf_counter()
        solver = None
        bar = Progress(self.t_end - self.t0, "simulating", "s", enabled=self.progress)
        try:
            if self.events is not None:
                self.events.start(self.t0, y)
            shift = self._winding(y)
            solver = self._make(self.t0, y if shift is None else y - shift)
            if self.own_loop:
                advance_between_stops(self, solver, bar, WINDING_BOUND)
            elif getattr(solver, "checks_constraints", False):  # loops: CVODE stepped in compiled code
                advance_checking(self, solver, bar)
            else:
                self._step(solver, bar)
            self.status, self.message = "finished", "reached t_end"
        except (NonFinite, StepFailure, AssemblyError) as exc:
            self.status = "failed"
            self.t_now = getattr(exc, "t", self.t_now)
            self.message = str(exc) if isinstance(exc, AssemblyError) else f"at t = {self.t_now:.9g} s: {exc}"
            self.error = exc
        except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM / SIGHUP in the flexmb command (_signals)
            self.status, self.message = "interrupted", f"interrupted by {who(exc)} at t = {self.t_now:.9g} s"
        except Exception as exc:  # anything else (a plugin's, the integrator's): failed, with the outputs so far
            stop = interruption(exc) if isinstance(exc, SystemError) else None
            through = escaped(exc) if isinstance(exc, SystemError) else None
            if stop is not None:  # an interruption as a compiled kernel returned (numba's SystemError)
                self.status, self.message = "interrupted", f"interrupted by {who(stop)} at t = {self.t_now:.9g} s"
            elif through is not None:  # e.g. a study case's time limit, raised as a kernel returned
                raise through from None
            else:
                self.status, self.error = "failed", exc
                self.message = f"at t = {self.t_now:.9g} s: {type(exc).__name__}: {exc}"
        finally:
            bar.close()  # the bar's line ends before any message
            if self.events is not None:
                self.events.finish()
        self.wall = _time.perf_counter() - t_wall

    def _step(self, solver, bar) -> None:
        """Step by step: check each step, store the outputs it passed, project a drifted state.

        With contact events (:mod:`flexmb.contact_events`), a step within
        which a contact touches or separates is cut at the event: the
        outputs up to it are stored and the integrator restarted there; a
        step that carries a touching body through its surface is refused
        and taken again from its start, shorter.
        """
        events = self.events
        while solver.status == "running":
            if events is not None:
                t_start, z_start = solver.t, np.array(solver.y, dtype=float)
            try:
                msg = solver.step()
            except (ValueError, np.linalg.LinAlgError) as exc:  # scipy's checks on a non-finite Jacobian
                raise NonFinite(solver.t, f"the integrator failed: {exc}") from exc
            self.n_steps += 1
            if solver.status == "failed" or not np.all(np.isfinite(solver.y)):
                if self.stage_failure is not None:  # the cause, not the step size it left (_stage_rate)
                    raise self.stage_failure
                raise NonFinite(solver.t, f"the integrator failed: {msg}" if solver.status == "failed"
                                else "the state became non-finite")
            self.stage_failure = None
            if self.monitor is not None:  # warns once if the steps resolve ringing modes (StiffnessWarning)
                self.monitor.step(solver)
            if self.gimbal is not None:  # warns once if a joint in Bryant angles nears gimbal lock
                self.gimbal.check(solver.t, solver.y)
            if events is not None:
                cut = cut_at_event(self, solver, t_start, z_start)
                if cut is not None:
                    solver = cut
                    bar.update_to(self.t_now - self.t0)
                    continue
            self.t_now = solver.t
            self._store(solver)
            if solver.status == "running":
                solver = self._unwound(solver)
                if self.system.n_constraints:
                    solver = self._restart_if_drifted(solver)
            bar.update_to(self.t_now - self.t0)

    def _store(self, solver, y_now=None) -> None:
        """Store the states at the output times the last step passed (up to :attr:`t_now`).

        Parameters
        ----------
        solver : OdeSolver
            The solver, after its step.
        y_now : ndarray, optional
            The true state at :attr:`t_now` when that is not the step's end
            (a contact event within the step).
        """
        times, system, layout = self.times, self.system, self.layout
        if not (self.k_out < len(times) and times[self.k_out] <= self.t_now):
            return
        dense = solver.dense_output()
        while self.k_out < len(times) and times[self.k_out] <= self.t_now:
            t_out = times[self.k_out]
            if t_out == self.t_now:
                y_out = solver.y.copy() if y_now is None else y_now.copy()
                if y_now is None and self.offset is not None:
                    y_out = y_out + self.offset
            else:
                y_out = dense(t_out)
                if self.offset is not None:
                    y_out = y_out + self.offset
            if not np.all(np.isfinite(y_out)):  # an interpolant's extra stage that failed (_stage_rate)
                raise self.stage_failure or NonFinite(t_out, "the state became non-finite")
            q, u = layout.split(y_out)
            q[:] = layout.normalized(q)  # coordinates on their own manifold (W = I: unchanged)
            if system.n_constraints:
                # the interpolant leaves the constraints by about rtol between steps: store
                # consistent states, by the rule the steps follow
                q[:], u[:] = project_output(system, t_out, q, u, self.projection_tol)
            self.out_y.append(y_out)
            self.k_out += 1

    def _restart_if_drifted(self, solver):
        """The solver, continued from the projected state if the constraints drifted past the bound.

        The bound is :attr:`state_tol` on ``|phi|`` and ``|psi xd - b|``,
        but for an integrator that moves in place (``moves``, a one-step
        method: :class:`~flexmb.GeneralizedAlpha`) ``state_tol = max(
        projection_tol, atol)`` on ``|phi|`` and ``state_tol / h`` on ``|psi
        xd - b|``, ``h`` its last step: its error control resolves no
        position finer than ``atol``, and a speed error moves the positions
        by ``h`` times itself over a step (the scale of speeds in its Newton
        norm, :func:`flexmb.kernels.genalpha.newton_update`). Drift below
        that is left to the outputs' projection; above it the state is
        projected and the integrator continues from it in place
        (``move_to``), or is restarted (:meth:`_restart`).
        """
        t_now, offset = self.t_now, self.offset
        y = solver.y if offset is None else solver.y + offset
        xs, vs = self.layout.split(y)
        position, velocity = self.system._constraint_residuals(t_now, xs, vs)
        residual = max(position, velocity * (solver.step_size or 0.0)) if self.caps.moves else max(position, velocity)
        if residual <= self.state_tol:
            return solver
        if (not self.caps.cheap_restart and self.n_steps - self.last_restart < RESTART_MIN_STEPS
                and self.state_tol < RESTART_TOL_CEILING):  # restarting every few steps: allow more drift
            self.state_tol = min(10.0 * self.state_tol, max(RESTART_TOL_CEILING, self.projection_tol))
            if residual <= self.state_tol:
                return solver
        xs, vs = self.system._project(t_now, xs, vs, tol=min(1e-12, self.projection_tol), speeds="mass")
        self.n_proj += 1
        self.last_restart = self.n_steps
        y = self.layout.join(xs, vs, self.layout.extra(y))
        z = y if offset is None else y - offset
        if self.caps.moves:
            solver.move_to(z)
            return solver
        return self._restart(solver, z)

    def _restart(self, solver, z):
        """A new solver from ``z`` at the time ``solver`` reached (after a projection, or a move of the offsets).

        An integrator with a cheap restart (a one-step method) continues
        with its last step size. One without (``cheap_restart = False``:
        CVODE, IDA) starts again at order one, and chooses its first step
        itself: after a projection the state has moved off the slow
        manifold of the stiff modes (on a damped flexible body in a loop
        the correction excites the overdamped segment modes, rates growing
        as N^2 to N^3 with the segments N), and the order-one step that
        resolves their transient can lie further below the last high-order
        step than CVODE's error-test failures in one step can cut it (at
        most seven, each by at most a factor of ten).
        """
        if getattr(solver, "restarts_in_place", False):  # a new CVODE memory on the same buffers: the same start
            solver.restart(z, self.offset)
            return solver
        step = solver.step_size if self.caps.cheap_restart else None
        first = min(max(step, 1e-14), self.t_end - solver.t) if step else None
        return self._make(solver.t, z, first_step=first)

    def _winding(self, y):
        """The move of the offsets that brings the angles of ``y`` (the integrator's) back near them, or None.

        None while every angle is within ``WINDING_BOUND`` of its offset;
        otherwise the offset of each angle farther than that moves by whole
        periods (``WINDING_PERIOD``) towards it, to between ``WINDING_BOUND -
        WINDING_PERIOD`` and ``WINDING_BOUND`` from it, and :attr:`offset`
        and :attr:`n_rebases` are updated.

        Parameters
        ----------
        y : ndarray, shape (nq + n + n_w,)
            The integrator's state.

        Returns
        -------
        shift : ndarray, shape (nq + n + n_w,) or None
            What to subtract from the integrator's state.
        """
        if not len(self.angles):
            return None
        z = y[self.angles]
        size = np.abs(z)
        if not np.max(size) > WINDING_BOUND:
            return None
        turns = np.where(size > WINDING_BOUND,
                         np.floor((size - (WINDING_BOUND - WINDING_PERIOD)) / WINDING_PERIOD), 0.0)
        shift = np.zeros(len(y))
        shift[self.angles] = np.copysign(WINDING_PERIOD * turns, z)
        self.offset = shift.copy() if self.offset is None else self.offset + shift
        self.n_rebases += 1
        return shift

    def _unwound(self, solver):
        """The solver, with the offsets moved if an angle wound past ``WINDING_BOUND`` (see the module docstring).

        An integrator declaring ``rebases`` moves its own state (and
        history) in place; any other is restarted from the moved state.
        """
        shift = self._winding(solver.y)
        if shift is None:
            return solver
        if self.caps.rebases:
            solver.rebase(shift)
            return solver
        return self._restart(solver, solver.y - shift)

    def result(self, x) -> Result:
        """The Result of the run: the stored states and the run's counters.

        Parameters
        ----------
        x : ndarray, shape (nq,)
            The initial coordinates (the degrees of freedom are counted
            there).

        Returns
        -------
        Result
            With ``status`` and ``message`` of the run.
        """
        system, layout = self.system, self.layout
        Y = np.array(self.out_y).reshape(len(self.out_y), layout.size + self.n_w)
        preconditioner = self.preconditioner
        works = layout.extra(Y)
        return Result.from_states(
            system, *layout.split(Y), t=self.times[: len(self.out_y)],
            work={name: works[:, i].copy() for i, name in enumerate(self.work_names)},
            n_dof=last(system, "dof", state_key(self.t0, x), lambda: system.dof(self.t0, x)),
            n_rhs=self.counters["rhs"],
            n_jac=self.counters.get("jac", 0) if preconditioner is None else preconditioner.n_setups,
            n_steps=self.n_steps, n_complements=system.n_complements - self.start_complements, n_rebases=self.n_rebases,
            n_projections=self.n_proj, n_cvode_projections=self.counters.get("cvode_projections", 0), wall_time=self.wall,
            status=self.status, message=self.message, method=self.name, complement=system.strategy.name,
            contact_events=[] if self.events is None else list(self.events.events), n_refused=self.n_steps_refused)
