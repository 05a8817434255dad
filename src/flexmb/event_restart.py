"""The run's side of a contact event: the step taken again up to it, the outputs stored, the integrator restarted.

:class:`flexmb.stepping.Run` calls :func:`cut_at_event` after each step of
a run with contact events; :class:`flexmb.contact_events.ContactEvents`
finds the event (or refuses the step).
"""

from __future__ import annotations

import numpy as np

from .contact_events import MIN_REFUSED_STEP, REFUSED_STEP_SHRINK, Refused, StepFailure

__all__ = ["cut_at_event"]


def cut_at_event(run, solver, t_start, z_start):
    """After a step: the solver restarted at a contact event within it, or from its start if refused; else None.

    The step is taken again from its start up to the event (its end
    the new integrator's bound), so that the state there comes from a
    smooth interval and not from an interpolant across the contact's
    kink; the outputs up to it are stored, and the integrator restarts
    at the event.

    Parameters
    ----------
    run : Run
        The run (:class:`flexmb.stepping.Run`): its events, integrator
        factory, outputs and counters.
    solver : OdeSolver
        The solver, after its step from ``t_start``.
    t_start : float
        The step's start, s.
    z_start : ndarray
        The integrator's state there.

    Returns
    -------
    OdeSolver or None
        The restarted solver, or None (the step stands, no event in it).

    Raises
    ------
    StepFailure
        If the step taken again fails, or no step short enough keeps a
        touching body from passing through the other.
    """
    offset = run.offset
    true = (lambda z: z) if offset is None else (lambda z: z + offset)
    dense = solver.dense_output()
    try:
        hit = run.events.after_step(t_start, solver.t, true(np.array(solver.y, dtype=float)),
                                     lambda t: true(dense(t)), getattr(solver, "root", None))
    except Refused as exc:
        h = REFUSED_STEP_SHRINK * (solver.t - t_start)
        if h < MIN_REFUSED_STEP * max(abs(t_start), 1.0):
            raise StepFailure(solver.t, f"{exc}, even with steps of {h:.3g} s: the contact cannot hold the body "
                                      "(stiffen its normal law, or check the load)") from None
        run.n_steps_refused += 1
        return run._make(t_start, z_start, first_step=h)
    if hit is None:
        return None
    t_e, changed = hit
    h = solver.t - t_start
    z_e = z_start
    if t_e > t_start:  # the step again, to the event
        sub = run._make(t_start, z_start, first_step=t_e - t_start, t_bound=t_e, events=False)
        while sub.status == "running":
            msg = sub.step()
            run.n_steps += 1
            if sub.status == "failed" or not np.all(np.isfinite(sub.y)):
                if run.stage_failure is not None:  # the cause (Run._stage_rate)
                    raise run.stage_failure
                raise StepFailure(sub.t, f"the integrator failed: {msg or 'the state became non-finite'}")
            run.t_now = sub.t
            run._store(sub)
        z_e = np.array(sub.y, dtype=float)
    run.t_now = t_e
    run.events.confirm(t_start, t_e, true(z_e), changed)
    if t_e >= run.t_end:  # at the end of the run (reached by the step again): nothing left to restart
        return sub if t_e > t_start else solver
    first = min(max(h, 1e-14), run.t_end - t_e) if run.caps.cheap_restart else None
    return run._make(t_e, z_e, first_step=first)
