"""Integrators that step in their own loop between output times: CVODE through scikit-sundae, or compiled.

:class:`flexmb.stepping.Run` hands a run with nothing to check or project
after each step (no loop constraints, no contact events) to
:func:`advance_between_stops`: the integrator steps in its own loop from
stop to stop (the output times, and each percent of the span when showing
progress), and the run's checks after a step (the resolution monitor, the
gimbal watch, the winding offsets) are given to it as a callback.

For CVODE and generalized-alpha stepped in compiled code
(:class:`~flexmb.integrators.cvode_direct.DirectCVODE`,
:class:`~flexmb.genalpha.compiled.CompiledGeneralizedAlpha`: open trees with
compiled force elements) :func:`compiled_options` gives the integrator the
model, the monitor and what to watch: the steps run without Python, the
monitor receives their sizes at its checkpoints, and the loop returns to
call the callback only after a step that an angle's winding bound or the
gimbal watch flags, so the run acts on the very step it would act on when
stepping in Python. DirectCVODE steps through all the stops in one call
(:meth:`~flexmb.integrators.cvode_direct.DirectCVODE.step_through`,
:func:`_through_stops`), storing the outputs and passing the monitor's
quiet checkpoints in compiled code.

A model with loops has more to do after a step (the outputs projected, the
state projected and CVODE restarted when the constraints drift): for CVODE
stepped in compiled code on such a model
(:class:`~flexmb.integrators.cvode_direct_loops.DirectLoopCVODE`)
:func:`advance_checking` lets the compiled loop step until a step needs any
of it, and then does what the run's step loop does after that step, with
the run's own methods.
"""

from __future__ import annotations

import contextlib

import numpy as np

from ._signals import deferred
from .output_projection import LoopOutputs
from .run_memo import last, state_key

__all__ = ["advance_between_stops", "advance_checking", "compiled_options", "NonFinite"]


class NonFinite(Exception):
    """The state or the integrator failed at time ``t`` (the run stops with status 'failed').

    Parameters
    ----------
    t : float
        When, s.
    what : str
        What failed.
    """

    def __init__(self, t, what):
        super().__init__(what)
        self.t = t


class _Wound(Exception):
    """An angle left the winding bound during :func:`advance_between_stops` (the run moves the offsets, goes on)."""


def compiled_options(run, x, xd, krylov_min: int, bound: float) -> dict:
    """What a compiled loop (DirectCVODE, CompiledGeneralizedAlpha) is given by ``run`` besides the common options.

    Parameters
    ----------
    run : Run
        The run (:class:`flexmb.stepping.Run`).
    x, xd : ndarray
        The initial state.
    krylov_min : int
        Coordinates from which BDF solves by GMRES with the O(n) preconditioner.
    bound : float
        The winding angles' bound, rad.

    Returns
    -------
    dict
        The model, the monitor, the watches, the counters; for CVODE, the
        run's ``projection_tol`` on a model with constraints, the Krylov choice (BDF from ``krylov_min`` coordinates on, as for
        scikit-sundae's CVODE), else flexmb's Jacobian (the compiled
        generalized-alpha loop is given its Jacobian as the Python one is).
    """
    system = run.system
    if run.caps.second_order:  # generalized-alpha (flexmb.genalpha.compiled)
        options = dict(system=system, monitor=run.monitor, angles=run.angles, bound=bound, gimbal=run.gimbal,
                       counters=run.counters)
        if system.n_constraints:  # its loops' drift check and projection (CompiledLoopGeneralizedAlpha)
            options.update(state_tol=run.state_tol, projection_tol=run.projection_tol)
        return options
    krylov = run.solver_cls.family == "BDF" and run.n >= krylov_min
    run.counters["jac"] = 0
    options = dict(system=system, krylov=krylov, monitor=run.monitor, angles=run.angles,
                   bound=bound, gimbal=run.gimbal, counters=run.counters)
    if system.n_constraints:  # for CVODE's projection of a looped model's state (DirectLoopCVODE)
        options["projection_tol"] = run.projection_tol
    # flexmb's Jacobian, from Python (a few calls), where it exists: where an element gives coordinate terms
    if not krylov and last(system, "has_coordinate_terms", state_key(run.t0, x, xd),
                           lambda: system.coordinate_terms(system.kinematics(run.t0, x, xd)) is not None):
        layout = run.layout
        options["jacobian"] = lambda t, y: system.state_jacobian(t, *layout.split(y))
    return options


def advance_between_stops(run, solver, bar, bound: float) -> None:
    """Step ``solver`` in its own loop from stop to stop, storing the outputs (nothing to project after a step).

    Parameters
    ----------
    run : Run
        The run (its times, monitor, gimbal watch, angles, outputs).
    solver : OdeSolver
        An integrator with ``advance`` (``advances``).
    bar : Progress
        The progress bar.
    bound : float
        The winding angles' bound, rad (an angle past it ends the step's loop: the run moves the offsets).
    """

    times, t0 = run.times, run.t0
    stops = times[run.k_out:]
    if run.progress:
        stops = np.union1d(stops, np.linspace(t0, run.t_end, 101)[1:])
    monitor, angles, t_end, gimbal = run.monitor, run.angles, run.t_end, run.gimbal

    def watch(solver):
        if gimbal is not None:
            gimbal.check(solver.t, solver.y)
        if solver.t < t_end and np.max(np.abs(solver.y[angles])) > bound:
            raise _Wound

    def wound(solver):
        if monitor is not None:
            monitor.step(solver)
        watch(solver)

    # a callback after each step only where there is something to do (a Python call per step costs); the
    # compiled loop feeds the monitor itself and calls back only after a step that its watches flag
    if getattr(solver, "steps_in_compiled_code", False):
        step = watch if len(angles) or gimbal is not None else None
    else:
        step = wound if len(angles) or gimbal is not None else (None if monitor is None else monitor.step)

    done = 0  # steps of the solvers restarted before this one
    # a compiled loop checks for Ctrl-C after each return (the handlers swapped once for the run, not per call)
    with deferred() if getattr(solver, "steps_in_compiled_code", False) else contextlib.nullcontext():
        if hasattr(solver, "step_through"):  # DirectCVODE: through all the stops in one compiled loop
            _through_stops(run, solver, bar, stops, step, done)
        else:
            _between_stops(run, solver, bar, stops, step, done)


def _through_stops(run, solver, bar, stops, step, done) -> None:
    """:func:`_between_stops` for a solver stepping through many stops per call (``step_through``).

    It returns after the progress marks, at the watches (``step`` is then
    called, as the solver's ``advance`` calls it), at the monitor's
    checkpoints with something to judge and every so many steps; the
    outputs it reached are stored as :func:`_between_stops` stores them.
    """
    cb, t0 = solver._cb, run.t0
    # every stop an output, but the progress marks (the times increase: each output once)
    outputs = np.isin(stops, run.times[run.k_out:]) if run.progress else np.ones(len(stops), dtype=np.bool_)
    marks, Y, j = ~outputs, np.empty((len(stops), solver.m)), 0
    while True:
        while j < len(stops) and stops[j] <= run.t_now:  # passed by the step after which the offsets moved
            j += 1
            bar.update_to(run.t_now - t0)
        if j == len(stops):
            return
        j0 = j
        try:
            code, j = solver.step_through(stops, marks, j, Y)
        except RuntimeError as exc:
            raise NonFinite(getattr(exc, "t", solver.t), f"the integrator failed: {exc}") from exc
        finally:
            run.n_steps = done + solver.n_steps
        _keep(run, Y, stops, outputs, j0, j + (code == cb.NOT_FINITE), bar)
        if code == cb.WATCH and step is not None:
            try:
                step(solver)
            except _Wound:  # at the end of a step: the outputs it passed, then the offsets move
                run.t_now = solver.t
                run._store(solver)
                moved = run._unwound(solver)
                if moved is not solver:
                    done += solver.n_steps
                    solver = moved
            finally:
                run.n_steps = done + solver.n_steps


def _keep(run, Y, stops, outputs, j0, j, bar) -> None:
    """Store the states ``Y[j0:j]`` reached at ``stops[j0:j]`` (the outputs among them), as :func:`_between_stops`."""
    if j == j0:
        return
    rows = Y[j0:j] if run.offset is None else Y[j0:j] + run.offset
    finite = np.isfinite(rows).all(axis=1)
    if not finite.all():
        bad = int(np.argmin(finite))
        _keep(run, Y, stops, outputs, j0, j0 + bad, bar)
        run.t_now = stops[j0 + bad]
        raise NonFinite(run.t_now, "the state became non-finite")
    kept = outputs[j0:j]
    run.out_y.extend(rows[kept])
    run.k_out += int(np.count_nonzero(kept))
    run.t_now = stops[j - 1]
    bar.update_to(run.t_now - run.t0)


def _between_stops(run, solver, bar, stops, step, done) -> None:
    """The loop of :func:`advance_between_stops` over its stops."""
    times, t0 = run.times, run.t0
    for t_stop in stops:
        y_stop = None
        while y_stop is None and t_stop > run.t_now:
            try:
                y_stop = solver.advance(t_stop, step)
            except RuntimeError as exc:
                raise NonFinite(getattr(exc, "t", solver.t), f"the integrator failed: {exc}") from exc
            except _Wound:  # at the end of a step: the outputs it passed, then the offsets move
                run.t_now = solver.t
                run._store(solver)
                moved = run._unwound(solver)
                if moved is not solver:
                    done += solver.n_steps
                    solver = moved
            finally:
                run.n_steps = done + solver.n_steps
        if y_stop is None:  # passed by the step after which the offsets moved, and stored then
            bar.update_to(run.t_now - t0)
            continue
        if run.offset is not None:
            y_stop = y_stop + run.offset
        run.t_now = t_stop
        if not np.all(np.isfinite(y_stop)):
            raise NonFinite(run.t_now, "the state became non-finite")
        if run.k_out < len(times) and times[run.k_out] == t_stop:
            run.out_y.append(y_stop)
            run.k_out += 1
        bar.update_to(run.t_now - t0)


def advance_checking(run, solver, bar) -> None:
    """Step a :class:`~flexmb.integrators.cvode_direct_loops.DirectLoopCVODE` to the end, doing the run's checks.

    The compiled loop stores the outputs its steps pass, projected as
    ``Run._store`` projects them (:class:`~flexmb.output_projection.LoopOutputs`,
    handed to the run after each return), and returns after a step that
    reached a progress mark, that left the constraints by more than
    ``run.state_tol``, that a winding angle or the gimbal watch flags, or
    that left a non-finite state (and at the monitor's checkpoints, every so
    many steps, and at an output it leaves to the run: not finite, its
    projection refused). After each return the run does what
    ``Run._step`` does after a step: the gimbal check, the outputs left
    (``Run._store``), the winding offsets
    (``Run._unwound``) and the drift (``Run._restart_if_drifted``, which
    may restart the solver in place; not evaluated again where the compiled
    loop found the step's state within the bound:
    ``DirectLoopCVODE.within_bound``); steps after which none of it does
    anything are not seen by Python.

    Parameters
    ----------
    run : Run
        The run.
    solver : DirectLoopCVODE
        Its integrator, at the start.
    bar : Progress
        The progress bar.
    """
    times, t0 = run.times, run.t0
    marks = np.linspace(t0, run.t_end, 101)[1:] if run.progress else np.zeros(0)
    not_finite = solver._cb.NOT_FINITE
    outputs = LoopOutputs(times, run.k_out, solver.m, run.projection_tol, once=len(marks) > 0)
    with deferred():  # the handlers swapped once for the run (see advance_between_stops)
        while solver.status == "running":
            t_stop = times[run.k_out] if run.k_out < len(times) else run.t_end
            if len(marks):
                j = np.searchsorted(marks, run.t_now, side="right")
                if j < len(marks):
                    t_stop = min(t_stop, marks[j])
            outputs.k = run.k_out  # (outputs the run stored itself: Run._store)
            try:  # the bound a hair lower: the run decides on its own residual (the same arithmetic)
                code = solver.step_on(t_stop, run.state_tol * (1.0 - 1e-9), outputs)
            except RuntimeError as exc:
                raise NonFinite(getattr(exc, "t", solver.t), f"the integrator failed: {exc}") from exc
            finally:
                run.n_steps = solver.n_steps
                outputs.hand_over(run)
            if code == not_finite:
                raise NonFinite(solver.t, "the state became non-finite")
            if run.gimbal is not None:
                run.gimbal.check(solver.t, solver.y)
            run.t_now = solver.t
            run._store(solver)
            if solver.status == "running":
                rebases = run.n_rebases
                solver = run._unwound(solver)
                # the step loop found the last step's state within a hair below the bound: the run's check, of
                # the same arithmetic, would keep it (checked again where the offsets moved the state's numbers)
                if not (solver.within_bound(code) and run.n_rebases == rebases):
                    solver = run._restart_if_drifted(solver)
            bar.update_to(run.t_now - t0)
