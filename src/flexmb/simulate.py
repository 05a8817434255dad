"""Time integration of the reduced equations, with constraint projection."""

from __future__ import annotations

import logging
import warnings
from collections.abc import Mapping

import numpy as np

from . import memory, registry
from ._validate import DEFAULT_RTOL, number, simulate_arguments, state_vector
from .errors import FlexmbError, ModelError, SimulationError, StiffnessWarning
from .initial_speeds import held_speeds, split_speeds
from .joints import Joint
from .model import as_system
from .result import Result
from .run_memo import last, state_key
from .stepping import Run
from .progress import shown
from .threads import limited_blas

__all__ = ["simulate", "initial_state", "INTEGRATORS", "MAX_STEPS"]

#: the built-in integrators by name: a read-only view of flexmb's ``flexmb.integrators`` entry points
INTEGRATORS = registry.builtin_table("integrators")

#: the module of the SUNDIALS integrators, whose names an error message lists apart from scipy's
_SUNDIALS = "flexmb.integrators.sundials"


def _name_index(all_names) -> dict:
    """``{name: [positions]}`` of coordinate names and of the joint names before their last dot."""
    index = {}
    for i, c in enumerate(all_names):
        for key in {c, c.rsplit(".", 1)[0]}:
            index.setdefault(key, []).append(i)
    return index


def _coordinate_mask(system, names, speeds=False, index=None):
    """Boolean mask of coordinates (``speeds``: of speeds) from names (coordinate or joint names) or joints.

    ``index``: :func:`_name_index` of those names, when one is at hand (a lookup per name, not a scan).
    """
    all_names = system.speed_names if speeds else system.coordinate_names
    index = _name_index(all_names) if index is None else index
    mask = np.zeros(len(all_names), bool)
    for name in names:
        name = name if isinstance(name, str) else system.model.element(name, Joint).name
        hits = index.get(name, [])
        if not hits:
            what = "speed" if speeds and all_names != system.coordinate_names else "coordinate"
            raise ModelError(f"no {what} or joint named {name!r}; {what}s are {all_names}")
        mask[hits] = True
    return mask


def _fill(system, values, what):
    """The vector of ``{name: value}`` (``what``: 'position' per coordinate from the reference configuration,
    'speed' per speed from rest), and which were given."""
    speeds = what == "speed"
    out = np.zeros(system.n_speeds) if speeds else system.layout.reference()
    given = np.zeros(out.shape, bool)
    if values is not None and not isinstance(values, Mapping):
        raise ModelError(f"initial state: {what}s must be a dict {{name: value}} of coordinate or joint names, got "
                         f"{type(values).__name__} {values!r:.60}")
    index = _name_index(system.speed_names if speeds else system.coordinate_names) if values else None
    for name, value in (values or {}).items():
        mask = _coordinate_mask(system, [name], speeds, index)
        k = int(mask.sum())
        try:
            v = np.broadcast_to(np.asarray(value, dtype=float), (k,))
        except (TypeError, ValueError, OverflowError):
            raise ModelError(f"initial {what} {name!r} must be a number or {k} numbers (one per coordinate), got "
                             f"{value!r:.60}") from None
        if not np.all(np.isfinite(v)):
            raise ModelError(f"initial {what} {name!r} must be finite, got {value!r}")
        out[mask] = v
        given |= mask
    return out, given


def initial_state(system, t0: float = 0.0, positions=None, speeds=None, x0=None, xd0=None, fixed=None,
                  hold_speeds: bool = True):
    """Consistent initial coordinates and speeds.

    Starting from ``positions`` (rough guesses are fine), the coordinates not
    listed in ``fixed`` are moved by minimum-norm Newton steps to close the
    loops (``phi(x0, t0) = 0``); then the speeds are made consistent
    (``psi xd0 = b``) by a minimum-norm correction, holding the speeds named
    in ``speeds`` (coordinate speeds, point velocities, body angular
    velocities: :mod:`flexmb.initial_speeds`).

    Parameters
    ----------
    system : System
        Compiled model.
    t0 : float
        Initial time, s.
    positions : dict, optional
        ``{name: value}`` with a coordinate name (``"joint.angle"``), or a
        joint or its name (all its coordinates).
    speeds : dict or list, optional
        As ``positions``; or a list of such dicts,
        :class:`~flexmb.PointVelocity` and :class:`~flexmb.AngularVelocity`.
    x0 : array_like, shape (nq,), optional
        All initial coordinates q (override ``positions``).
    xd0 : array_like, shape (n,), optional
        All initial speeds u (override ``speeds``).
    fixed : list of str or Joint, optional
        Coordinates (or joints, or their names) to hold at their given values
        during assembly (with their speeds: a coordinate held is one whose
        speeds do not move it).
    hold_speeds : bool
        True (default): the speeds given are kept, and speeds the
        constraints or drivers do not allow are refused; False: the
        constraints win, the speeds given are the closest they allow.

    Returns
    -------
    x0 : ndarray, shape (nq,)
        The assembled coordinates q.
    xd0 : ndarray, shape (n,)
        The assembled speeds u.

    Raises
    ------
    ModelError
        If ``positions`` or ``speeds`` is not a dict of names and numbers,
        ``fixed`` not a list of names, or a name is unknown.
    AssemblyError
        If a loop cannot close; the message names the worst rows.
    ModelError
        If the speeds held contradict the constraints or drivers (naming
        both).
    """
    x, _ = _fill(system, positions, "position")
    held_x = np.zeros(system.n_speeds, bool)
    speeds, motions = split_speeds(speeds)
    xd, held_v = _fill(system, speeds, "speed")
    if x0 is not None:
        x = state_vector("initial state", "x0", x0, system.n_coords).copy()
    x = system.layout.normalized(x)  # Euler parameters given of any length
    if xd0 is not None:
        xd = state_vector("initial state", "xd0", xd0, system.n_speeds).copy()
    if fixed is not None and not isinstance(fixed, (list, tuple, set, frozenset, np.ndarray)):
        raise ModelError(f"initial state: fixed must be a list of coordinate or joint names (or joints), got "
                         f"{type(fixed).__name__} {fixed!r:.60}")
    if fixed is not None and len(fixed):
        held_x |= _coordinate_mask(system, fixed, speeds=True)
    if system.n_constraints:
        x, _ = system.project(t0, x, xd, fixed=held_x)
    return x, held_speeds(system, t0, x, xd, held_v, motions, bool(hold_speeds))


def _solver_class(method, system, track_work: bool, contact_events: bool):
    """The integrator class: ``method`` itself, or looked up by name in the plugin registry.

    A name registered as flexmb's scikit-sundae CVODE_BDF or CVODE_Adams
    gives, where the run can step it in compiled code (an open tree, or
    loops closed by the articulated strategy, with compiled force elements,
    no work terms, no contact events), the compiled loop's class
    (:func:`~flexmb.integrators.direct_choice.compiled_loop`),
    looked up by its import path (:func:`flexmb.registry.path`): the
    scikit-sundae class, and scipy.integrate with it, is then never imported.
    """
    if not isinstance(method, str):
        from scipy.integrate import OdeSolver  # a class given: scipy.integrate is imported if it is one

        if not (isinstance(method, type) and issubclass(method, OdeSolver)):
            raise ModelError(f"simulate: method must be an integrator's name or an OdeSolver class, got "
                             f"{type(method).__name__} {method!r:.60}")
        return method
    known = registry.names("integrators")
    if method not in known:
        # the names come from the entry points; their import paths tell SUNDIALS's apart
        sundials = sorted({p.name for p in registry.plugins("integrators") if p.value.startswith(_SUNDIALS + ":")})
        others = [m for m in known if m not in sundials]
        raise ModelError(f"unknown integrator {method!r}; pick one of {others}"
                         + (f" or, from SUNDIALS, {sundials}" if sundials else ""))
    from .contact_events import _contact_groups
    from .integrators.direct_choice import compiled_loop

    events = True if contact_events and _contact_groups(system) else None
    direct = compiled_loop(system, registry.path("integrators", method), track_work, events)
    return direct if direct is not None else registry.get("integrators", method)


#: the default of ``simulate(max_steps=...)``: a run that needs more steps than this is refused before it starts
MAX_STEPS = 10**9

#: explicit steps above which a scene counts as stiff (:class:`StiffnessWarning`)
EXPLICIT_STEP_LIMIT = 3000

#: explicit steps above which 'auto' takes an implicit method; below, DOP853 is as fast as CVODE_BDF
#: at the same error (B1 N = 2 and 4), and on rigid loops more accurate than CVODE at the same cost
#: (the four-bar): benchmarks/auto_choice.py, docs/benchmarks.md "Which integrator 'auto' picks"
AUTO_IMPLICIT_STEPS = 300


def _choose_method(system, t0, t1, x, xd, rtol=DEFAULT_RTOL, atol=DEFAULT_RTOL / 100, log=True):
    """The integrator for ``method='auto'`` over [t0, t1], and why.

    DOP853's stability bound is about ``h omega_max < 3``; if that needs no
    more than ``AUTO_IMPLICIT_STEPS`` steps, DOP853. Otherwise
    :func:`flexmb.integrators.monitor.stiff_choice`: CVODE_BDF, or Radau
    where lightly damped modes far above the scene's motion are not
    excited, or, where nearly undamped ones ring and resolving them would
    be costly, the generalized-alpha method with a step floor that
    dissipates them.

    Returns
    -------
    method : str or type
        A registered name or a configured :class:`~flexmb.GeneralizedAlpha` class.
    reason : str
        The statement of the choice (also logged to the ``flexmb`` logger if ``log``).
    """
    method, reason = last(system, "auto", state_key(t0, t1, x, xd, rtol, atol),
                          lambda: _method_for(system, t0, t1, x, xd, rtol, atol))
    if log:  # a choice that removes energy on purpose (a step floor) is logged as a warning
        logging.getLogger("flexmb").log(logging.WARNING if getattr(method, "min_step", None) else logging.INFO, reason)
    return method, reason


def _method_for(system, t0, t1, x, xd, rtol, atol):
    """:func:`_choose_method`'s choice, worked out (kept for the next run of the same arguments: :mod:`.run_memo`)."""
    from .integrators.monitor import stiff_choice
    w = system.fastest_rate(t0, x, xd)
    steps = (t1 - t0) * w / 3.0 + 0.0  # + 0.0: a rate of -0.0 (no motion to integrate) reads 0
    if steps == 0:  # no freedom left to vibrate (every coordinate driven or locked by the loops), or no stiffness
        method, reason = "DOP853", ("'auto' chose DOP853: the scene has no vibration to keep stable (its fastest "
                                    "rate is 0 rad/s)")
    elif steps <= AUTO_IMPLICIT_STEPS:
        method, reason = "DOP853", (f"'auto' chose DOP853: an explicit method needs about {steps:.3g} steps over "
                                    f"{t1 - t0:.4g} s to stay stable (at most {AUTO_IMPLICIT_STEPS})")
    else:
        method, reason = stiff_choice(system, t0, t1, x, xd, rtol, atol, steps)
    return method, reason


def _warn_if_stiff(system, solver_cls, t0, t1, x, xd):
    """Warn (:class:`StiffnessWarning`) when an explicit method meets a scene stiff over [t0, t1]."""
    from .integrators import capabilities
    if not capabilities(solver_cls).explicit:
        return
    wn = system.highest_frequency(t0, x, xd)
    w = system.fastest_rate(t0, x, xd)
    n_stable = (t1 - t0) * w / 3.0
    if n_stable > EXPLICIT_STEP_LIMIT:
        damping = f" and its fastest damping rate {w:.4g} rad/s" if w > wn else ""
        warnings.warn(StiffnessWarning(
            f"the scene is stiff for {solver_cls.__name__}: its highest natural frequency is about "
            f"{wn:.4g} rad/s ({wn / (2 * np.pi):.4g} Hz){damping}, so an explicit method needs some "
            f"{n_stable:.3g} steps over {t1 - t0:.4g} s just to stay stable; use method='CVODE_BDF' or "
            f"method='Radau' (or method='auto')"
        ), stacklevel=3)


def _calibrated(system, t0, x, xd):
    """The system a run works on: psi's rank and the singular-position filter judged at the assembled state.

    Off the constraint manifold (integrator stages) redundant rows (Bricard
    linkage) would look independent, so the rank of psi is judged once, on
    the assembled state, as is the scale of the singular-position filter
    (:meth:`ComplementStrategy.singular_window`). The run works on a
    calibrated copy; the caller's system is unchanged. An open tree has no
    rows to judge (and no n x n complement is formed).
    """
    if not system.n_constraints:
        return system
    n_drv = len(system.constraints.drivers)
    if system._loop_kernel:  # the rank and the scale of the filter as the loop kernel sees them
        cut_rank = system._loop_calibration(t0, x, xd, drivers=False)[0]
        if cut_rank is not None and cut_rank >= system.n_speeds:
            raise ModelError(
                f"the model has no degree of freedom left: its {system.n_speeds} coordinates are all fixed by "
                f"{system.n_constraints - n_drv} loop-closure rows (a structure, not a mechanism)"
            )
        return system.calibrated(*system._loop_calibration(t0, x, xd))
    psi = system.constraints.evaluate(system.kinematics(t0, x, xd), level=1).psi
    if system.strategy.complement(psi[: system.n_constraints - n_drv]).p == 0:
        raise ModelError(
            f"the model has no degree of freedom left: its {system.n_coords} coordinates are all fixed by "
            f"{system.n_constraints - n_drv} loop-closure rows (a structure, not a mechanism)"
        )
    c0 = system.strategy.complement(psi)
    return system.calibrated(c0.rank, float(c0.singular_values()[c0.rank - 1]) if c0.rank else None)


def _check_work(system, solver_cls, name, t0, t1, x, xd, max_step, max_steps):
    """Refuse a run that needs more than ``max_steps`` steps, before it starts (it would run for hours or for ever).

    The bounds are what every step of the run must respect: ``max_step``,
    a generalized-alpha ``fixed_step``, and, for an explicit method, the
    stability bound ``h |lambda| < 3`` of the fastest rate of the linearised
    motion (:meth:`System.stability_rate`). Each gives a lower
    bound of the number of steps; the largest is compared with ``max_steps``.
    """
    from .integrators import capabilities
    span = t1 - t0
    bounds = [(span / max_step, f"max_step = {max_step:g} s")]
    fixed = getattr(solver_cls, "fixed_step", None)
    if fixed:
        bounds.append((span / fixed, f"fixed_step = {fixed:g} s"))
    if capabilities(solver_cls).explicit:
        w = system.stability_rate(t0, x, xd)
        if w > 0:
            bounds.append((span * w / 3.0, f"the stability of {name} (the fastest rate of the linearised motion is "
                                           f"{w:.4g} 1/s)"))
    turns = _turn_bound(system, t0, x, xd, span, max_steps)
    if turns is not None:
        bounds.append(turns)
    steps, why = max(bounds, key=lambda b: b[0])
    if steps > max_steps:
        raise ModelError(
            f"simulate: {why} needs at least {steps:.3g} steps over [{t0:g}, {t1:g}] s, more than max_steps = "
            f"{max_steps:.3g}; shorten the span, give a larger step, choose another method, or pass a larger "
            "max_steps")


#: the largest spacing of floats at an initial angle, rad: beyond (|angle| > 4e12 rad) the angle is refused
ANGLE_RESOLUTION = 1e-3


def _turn_bound(system, t0, x, xd, span, max_steps):
    """A bound of the steps from the turns of a fast angle, ``(steps, why)``, if it exceeds ``max_steps``.

    An angle whose turns change the motion (gravity on a pendulum, the
    orientation in any load) needs a step or more per turn, at its initial
    speed. Counted for every angle (where the loads ignore an angle, its
    turns are still more than ``max_steps`` allows a run: ``max_steps``
    raises the bound). An angle too large for floats to resolve (farther
    apart than :data:`ANGLE_RESOLUTION`) is refused.

    Returns
    -------
    (float, str) or None
    """
    angles = np.flatnonzero(system.topology.coord_angle)
    if not len(angles) or not span > 0:
        return None
    far = angles[np.spacing(np.abs(x[angles])) > ANGLE_RESOLUTION]
    if len(far):
        k = far[0]
        raise ModelError(f"simulate: coordinate {system.coordinate_names[k]!r} = {x[k]:.3g} rad is beyond what a float "
                         f"resolves (neighbouring floats {np.spacing(abs(x[k])):.3g} rad apart); give the angle "
                         "modulo 2 pi")
    speed = np.abs(system.layout.coordinate_rates(x, xd)[angles])
    turns = span * speed / (2 * np.pi)
    j = int(np.argmax(turns))
    if not turns[j] > max_steps:
        return None
    name = system.coordinate_names[angles[j]]
    return turns[j], f"coordinate {name!r} turning at {speed[j]:.3g} rad/s ({turns[j]:.3g} turns, a step or more each)"
    return None


@limited_blas
def simulate(model, t_end: float, *, t0: float = 0.0, positions=None, speeds=None, x0=None, xd0=None,
             fixed=None, n_out: int = 201, t_eval=None, method: str = "auto", rtol: float | None = None,
             atol: float | None = None, complement=None, projection_tol: float = 1e-10,
             max_step: float = np.inf, progress: bool | None = None, track_work: bool = False,
             hold_speeds: bool = True, max_steps: float = MAX_STEPS, contact_events: bool = True) -> Result:
    """Simulate a model from ``t0`` to ``t_end``.

    The state (x, xd) is integrated by an OdeSolver (scipy's, or SUNDIALS'
    CVODE); the accelerations come from the reduced equations (eqs. 36-39)
    at every evaluation. After
    each step the position and speed residuals are checked, and past a
    bound the state is projected back onto the constraints and the solver
    continues from it (:meth:`flexmb.stepping.Run._restart_if_drifted`):
    ``projection_tol``, or one tied to the tolerance for integrators whose
    restart is costly (CVODE) or that move in place (generalized-alpha).
    The stored output states, which are interpolated between steps, are
    projected onto the constraints to ``projection_tol``.

    Parameters
    ----------
    model : Model or System
        What to simulate.
    t_end : float
        End time, s.
    t0 : float
        Start time, s.
    positions, speeds, x0, xd0, fixed, hold_speeds
        Initial conditions, see :func:`initial_state` (``speeds`` also takes
        :class:`~flexmb.PointVelocity` and :class:`~flexmb.AngularVelocity`).
    n_out : int
        Number of equally spaced output times (ignored if ``t_eval``).
    t_eval : array_like, optional
        Output times, increasing, within [t0, t_end].
    method : {'auto', 'DOP853', 'RK45', 'RK23', 'Radau', 'BDF', 'LSODA', 'CVODE_BDF', 'CVODE_Adams', 'IDA', 'GeneralizedAlpha'} or OdeSolver class
        Integrator; explicit ones for non-stiff models, SUNDIALS'
        CVODE_BDF (or IDA) or Radau/BDF for stiff, GeneralizedAlpha (or a class
        from :func:`~flexmb.generalized_alpha`) for undamped flexible bodies
        whose fast modes should be dissipated. A name is looked up in the
        plugin registry (entry-point group ``flexmb.integrators``), so
        installed plugins are accepted too. What the integrator is given
        (the analytic Jacobian, the second-order block structure) follows
        the capabilities its class declares (:mod:`flexmb.integrators.base`).
        ``'auto'`` estimates the highest frequency of the coordinate springs
        and takes DOP853 when an explicit method needs at most
        ``AUTO_IMPLICIT_STEPS`` steps just to stay stable. On a stiff scene
        it looks at the modes of the linearised motion
        (:func:`flexmb.integrators.monitor.stiff_choice`): CVODE_BDF (the
        fastest on the benchmark scenes, ``benchmarks/auto_choice.py``);
        Radau where lightly damped modes far above the scene's motion are
        not excited (it steps over them, CVODE_BDF cannot); and where nearly
        undamped modes far above the motion ring and would be costly to
        resolve, the generalized-alpha method with a step floor that
        dissipates them (``Result.method_reason`` states the floor and the
        damping it adds; the ``flexmb`` logger too).
    rtol, atol : float, optional
        Integration tolerances: each step's local error is held within
        ``rtol |y_i| + atol`` in every state component (angles counted from
        their nearest whole turns, :mod:`flexmb.stepping`). ``atol``
        defaults to ``rtol / 100``; ``rtol`` to the integrator's
        ``default_rtol`` (:mod:`flexmb.integrators.tolerances`): 1e-8, and 5e-10
        for DOP853, whose global error over long runs of large motions
        grows with the square of the run's length (docs/guide.md
        "Tolerances over long runs"). ``Result.rtol`` is the one used.
    complement : {'svd', 'eigen', 'qr', 'auto'} or ComplementStrategy, optional
        Orthogonal complement strategy, or a registered plugin's name
        (default: the system's, ``'svd'``).
    projection_tol : float
        Largest residual ``|phi|`` or ``|psi xd - b|`` of the outputs, and
        the least the integrator's state is allowed before it is projected.
    max_step : float
        Largest step, s.
    progress : bool, optional
        Show progress on stderr: a bar in a terminal or a notebook, a line
        every half minute in a log (:mod:`flexmb.progress`). Default: shown,
        except in a CI job.
    track_work : bool
        Integrate, with the state, the work done by each driver, by each
        class of force elements and by each constraint element (a row with
        ``b != 0``: ``lambda b``; ``Result.work``), for energy balances:
        ``sum of all works = change of kinetic energy``.
    max_steps : float
        The most steps a run may need: a run that needs more (given
        ``max_step``, a generalized-alpha ``fixed_step``, or the stability
        bound of an explicit method on a stiff scene) is refused before it
        starts, instead of running for hours (default ``MAX_STEPS``, 1e9).
    contact_events : bool
        With contact elements: locate each contact's onset and separation
        as an event (CVODE's root finding; on the dense output for the
        other integrators), store the outputs up to it and restart the
        integrator there, refuse a step that carries a touching body
        through its surface and take it again shorter, and warn
        (:class:`~flexmb.errors.StiffnessWarning`) when the contacts force
        tiny steps (:mod:`flexmb.contact_events`). The events are in
        ``Result.contact_events``. False: the contacts are stepped through.

    Returns
    -------
    Result
        Time histories and counters.

    Raises
    ------
    SimulationError
        If the state goes non-finite or the solver fails; ``.result`` holds
        the outputs computed up to then and ``.t`` the time.
    ModelError
        If an argument is out of range (non-finite ``t0`` or ``t_end``,
        ``rtol <= 0``, ``n_out < 1``, ``max_step <= 0``, ...; the message
        names it), if the run needs more than ``max_steps`` steps (counted
        from ``max_step``, a fixed step, an explicit method's stability, or
        the turns of the fastest angle), if an initial angle is too large
        for floats to resolve, if the outputs would not fit in the available
        memory (:mod:`flexmb.memory`), or if the model has no degree of
        freedom left.

    Warns
    -----
    StiffnessWarning
        If ``method`` is explicit ('RK45', 'RK23', 'DOP853') and the scene is
        stiff over [t0, t_end] (see ``method='auto'``), before the run; and
        once, early in the run, if an error-controlled method spends its
        steps resolving nearly undamped modes far above the scene's motion
        (:class:`flexmb.integrators.monitor.ResolutionMonitor`); and once
        if the steps taken while a contact touches are tiny
        (:mod:`flexmb.contact_events`).

    Examples
    --------
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    >>> _ = model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0, -9.81, 0)))
    >>> res = fm.simulate(model, 1.0, positions={"pin": 0.5})
    >>> res.status
    'finished'
    """
    from .integrators import adapt, capabilities, default_rtol
    rtol_given = rtol is not None
    t0, t_end, n_out, t_eval, rtol, atol, max_step, projection_tol = simulate_arguments(
        t0, t_end, n_out, t_eval, rtol if rtol_given else DEFAULT_RTOL, atol, max_step, projection_tol)
    max_steps = number("simulate", "max_steps", max_steps, minimum=0.0)
    # a run never changes the caller's system: another strategy gives a new one
    system = as_system(model, complement=complement)
    auto = isinstance(method, str) and method == "auto"
    solver_cls = None if auto else _solver_class(method, system, track_work, contact_events)
    name = method if isinstance(method, str) else getattr(method, "__name__", str(method))
    memory.check(system, n_out if t_eval is None else len(t_eval), what="simulate", model=False)
    progress = shown(progress)

    x, xd = initial_state(system, t0, positions, speeds, x0, xd0, fixed, hold_speeds)
    reason = ""
    if auto:
        method, reason = _choose_method(system, t0, t_end, x, xd, rtol, rtol / 100 if atol is None else atol)
        solver_cls = _solver_class(method, system, track_work, contact_events)
        name = getattr(method, "__name__", method)
    else:
        _warn_if_stiff(system, solver_cls, t0, t_end, x, xd)
    if not rtol_given:
        rtol = default_rtol(adapt(solver_cls))
    atol = rtol / 100 if atol is None else atol
    _check_work(system, solver_cls, name, t0, t_end, x, xd, max_step, max_steps)
    system = _calibrated(system, t0, x, xd)
    times = np.linspace(t0, t_end, n_out) if t_eval is None else np.asarray(t_eval, dtype=float)
    if times.ndim != 1 or np.any(np.diff(times) <= 0) or times[0] < t0 or times[-1] > t_end:
        raise ModelError("t_eval must be increasing and within [t0, t_end]")
    if not capabilities(adapt(solver_cls)).has_dense_output:
        raise ModelError(f"integrator {name!r} has no dense output, which simulate needs for its output times")
    run = Run(system, solver_cls, name, times, t0=t0, t_end=t_end, rtol=rtol, atol=atol, max_step=max_step,
              projection_tol=projection_tol, track_work=track_work, progress=progress, auto=auto,
              contact_events=bool(contact_events))
    run.execute(x, xd)
    result = run.result(x)
    result.method_reason, result.rtol = reason, rtol
    status, message, t_now = run.status, run.message, run.t_now
    if status == "failed":
        raise SimulationError(f"simulation failed {message}", t=t_now, result=result) from run.error
    return result
