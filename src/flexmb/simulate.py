"""Time integration of the reduced equations, with constraint projection."""

from __future__ import annotations

import logging
import time as _time
import warnings

import numpy as np

from . import memory, registry
from ._validate import simulate_arguments
from .errors import AssemblyError, FlexmbError, ModelError, SimulationError, StiffnessWarning
from .joints import Joint
from .integrators import adapt, capabilities
from .integrators.monitor import ResolutionMonitor, stiff_choice
from .result import Result
from .progress import Progress, shown
from .threads import limited_blas

__all__ = ["simulate", "initial_state", "INTEGRATORS"]

#: the built-in integrators by name: a read-only view of flexmb's ``flexmb.integrators`` entry points
INTEGRATORS = registry.builtin_table("integrators")

#: the SUNDIALS integrators' names, listed apart from scipy's in error messages
_SUNDIALS = ("CVODE_Adams", "CVODE_BDF", "IDA")


class _NonFinite(Exception):
    def __init__(self, t, what):
        super().__init__(what)
        self.t = t


def _as_system(model_or_system, complement):
    from .system import System

    if isinstance(model_or_system, System):
        # a run never changes the caller's system: another strategy gives a new one
        return model_or_system if complement is None else model_or_system.with_complement(complement)
    return model_or_system.build(complement=complement or "svd")


def _coordinate_mask(system, names):
    """Boolean mask of coordinates from names (coordinate or joint names) or joints."""
    mask = np.zeros(system.n_coords, bool)
    for name in names:
        name = name if isinstance(name, str) else system.model.element(name, Joint).name
        hits = [i for i, c in enumerate(system.coordinate_names) if c == name or c.rsplit(".", 1)[0] == name]
        if not hits:
            raise ModelError(f"no coordinate or joint named {name!r}; coordinates are {system.coordinate_names}")
        mask[hits] = True
    return mask


def _fill(system, values, what):
    out = np.zeros(system.n_coords)
    given = np.zeros(system.n_coords, bool)
    for name, value in (values or {}).items():
        mask = _coordinate_mask(system, [name])
        v = np.broadcast_to(np.asarray(value, dtype=float), (int(mask.sum()),))
        if not np.all(np.isfinite(v)):
            raise ModelError(f"initial {what} {name!r} must be finite, got {value!r}")
        out[mask] = v
        given |= mask
    return out, given


def initial_state(system, t0: float = 0.0, positions=None, speeds=None, x0=None, xd0=None, fixed=None):
    """Consistent initial coordinates and speeds.

    Starting from ``positions`` (rough guesses are fine), the coordinates not
    listed in ``fixed`` are moved by minimum-norm Newton steps to close the
    loops (``phi(x0, t0) = 0``); then the speeds are made consistent
    (``psi xd0 = b``) by a minimum-norm correction, holding the speeds named
    in ``speeds``.

    Parameters
    ----------
    system : System
        Compiled model.
    t0 : float
        Initial time, s.
    positions, speeds : dict, optional
        ``{name: value}`` with a coordinate name (``"joint.angle"``), or a
        joint or its name (all its coordinates).
    x0, xd0 : array_like, shape (n,), optional
        Full initial vectors (override ``positions`` / ``speeds``).
    fixed : list of str or Joint, optional
        Coordinates (or joints, or their names) to hold at their given values
        during assembly.

    Returns
    -------
    x0, xd0 : ndarray, shape (n,)
        The assembled state.

    Raises
    ------
    AssemblyError
        If a loop cannot close; the message names the worst rows.
    """
    x, _ = _fill(system, positions, "position")
    held_x = np.zeros(system.n_coords, bool)
    xd, held_v = _fill(system, speeds, "speed")
    if x0 is not None:
        x = np.array(x0, dtype=float).reshape(system.n_coords)
    if xd0 is not None:
        xd = np.array(xd0, dtype=float).reshape(system.n_coords)
    if fixed:
        held_x |= _coordinate_mask(system, fixed)
    if system.n_constraints == 0:
        return x, xd
    x, _ = system.project(t0, x, xd, fixed=held_x)
    _, xd = system.project(t0, x, xd, fixed=held_v)
    return x, xd


def _solver_class(method):
    """The OdeSolver class: ``method`` itself, or looked up by name in the plugin registry."""
    if not isinstance(method, str):
        return method
    known = registry.names("integrators")
    if method not in known:
        others = [m for m in known if m not in _SUNDIALS]
        sundials = [m for m in known if m in _SUNDIALS]
        raise ModelError(f"unknown integrator {method!r}; pick one of {others}"
                         + (f" or, from SUNDIALS, {sundials}" if sundials else ""))
    return registry.get("integrators", method)


#: explicit steps above which a scene counts as stiff (:class:`StiffnessWarning`)
EXPLICIT_STEP_LIMIT = 3000

#: explicit steps above which 'auto' takes an implicit method; below, DOP853 is as fast as CVODE_BDF
#: at the same error (B1 N = 2 and 4), and on rigid loops more accurate than CVODE at the same cost
#: (the four-bar): benchmarks/auto_choice.py, docs/benchmarks.md "Which integrator 'auto' picks"
AUTO_IMPLICIT_STEPS = 300


#: integrators without a cheap restart (``cheap_restart = False``: CVODE, back to order one) project
#: their own state when the constraint residual exceeds RESTART_ATOL_FACTOR * atol, at most
#: RESTART_TOL_MAX (or projection_tol, if larger); their stored outputs are projected to projection_tol.
#: Measured on the four-bar at rtol 1e-9: projecting at 100 atol restarts CVODE every few steps and
#: the run collapses; at 1e3 atol it restarts 62 times and loses accuracy; at 1e4 atol once.
RESTART_ATOL_FACTOR = 1e4
RESTART_TOL_MAX = 1e-6

#: open trees with at least this many coordinates are integrated by integrators declaring
#: ``uses_preconditioner`` (CVODE_BDF) with O(n) preconditioned Krylov solves instead of a dense
#: Jacobian; measured on B1 and B2 (docs/benchmarks.md, "Large open trees"): dense LU is as fast
#: or faster below
KRYLOV_MIN_COORDS = 48


def _choose_method(system, t0, t1, x, xd, rtol=1e-8, atol=1e-10, log=True):
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
    w = system.fastest_rate(t0, x, xd)
    steps = (t1 - t0) * w / 3.0
    if steps <= AUTO_IMPLICIT_STEPS:
        method, reason = "DOP853", (f"'auto' chose DOP853: an explicit method needs about {steps:.3g} steps over "
                                    f"{t1 - t0:.4g} s to stay stable (at most {AUTO_IMPLICIT_STEPS})")
    else:
        method, reason = stiff_choice(system, t0, t1, x, xd, rtol, atol, steps)
    if log:  # a choice that removes energy on purpose (a step floor) is logged as a warning
        logging.getLogger("flexmb").log(logging.WARNING if getattr(method, "min_step", None) else logging.INFO, reason)
    return method, reason


def _warn_if_stiff(system, solver_cls, t0, t1, x, xd):
    """Warn (:class:`StiffnessWarning`) when an explicit method meets a scene stiff over [t0, t1]."""
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


@limited_blas
def simulate(model, t_end: float, *, t0: float = 0.0, positions=None, speeds=None, x0=None, xd0=None,
             fixed=None, n_out: int = 201, t_eval=None, method: str = "auto", rtol: float = 1e-8,
             atol: float | None = None, complement=None, projection_tol: float = 1e-10,
             max_step: float = np.inf, progress: bool | None = None, track_work: bool = False) -> Result:
    """Simulate a model from ``t0`` to ``t_end``.

    The state (x, xd) is integrated by an OdeSolver (scipy's, or SUNDIALS'
    CVODE); the accelerations come from the reduced equations (eqs. 36-39)
    at every evaluation. After
    each step the position and speed residuals are checked, and when either
    exceeds ``projection_tol`` the state is projected back onto the
    constraints and the solver restarted. The stored output states, which
    are interpolated between steps, are projected onto the constraints too.

    Parameters
    ----------
    model : Model or System
        What to simulate.
    t_end : float
        End time, s.
    t0 : float
        Start time, s.
    positions, speeds, x0, xd0, fixed
        Initial conditions, see :func:`initial_state`.
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
    rtol, atol : float
        Integration tolerances (``atol`` defaults to ``rtol / 100``).
    complement : {'svd', 'eigen', 'qr', 'auto'} or ComplementStrategy, optional
        Orthogonal complement strategy, or a registered plugin's name
        (default: the system's, ``'svd'``).
    projection_tol : float
        Largest residual ``|phi|`` or ``|psi xd - b|`` tolerated before projecting.
    max_step : float
        Largest step, s.
    progress : bool, optional
        Show progress on stderr: a bar in a terminal or a notebook, a line
        every half minute in a log (:mod:`flexmb.progress`). Default: shown,
        except in a CI job.
    track_work : bool
        Integrate, with the state, the work done by each driver and by each
        class of force elements (``Result.work``), for energy balances:
        ``sum of all works = change of kinetic energy``.

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
        names it), if the outputs would not fit in the available memory
        (:mod:`flexmb.memory`), or if the model has no degree of freedom left.

    Warns
    -----
    StiffnessWarning
        If ``method`` is explicit ('RK45', 'RK23', 'DOP853') and the scene is
        stiff over [t0, t_end] (see ``method='auto'``), before the run; and
        once, early in the run, if an error-controlled method spends its
        steps resolving nearly undamped modes far above the scene's motion
        (:class:`flexmb.integrators.monitor.ResolutionMonitor`).

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
    t0, t_end, n_out, t_eval, rtol, atol, max_step, projection_tol = simulate_arguments(
        t0, t_end, n_out, t_eval, rtol, atol, max_step, projection_tol)
    system = _as_system(model, complement)
    auto = method == "auto"
    solver_cls = None if auto else _solver_class(method)
    name = method if isinstance(method, str) else getattr(method, "__name__", str(method))
    atol = rtol / 100 if atol is None else atol
    memory.check(system, n_out if t_eval is None else len(t_eval), what="simulate", model=False)
    progress = shown(progress)

    x, xd = initial_state(system, t0, positions, speeds, x0, xd0, fixed)
    reason = ""
    if auto:
        method, reason = _choose_method(system, t0, t_end, x, xd, rtol, atol)
        solver_cls = _solver_class(method)
        name = getattr(method, "__name__", method)
    else:
        _warn_if_stiff(system, solver_cls, t0, t_end, x, xd)
    n_drv = len(system.constraints.drivers)
    if system.n_constraints:  # an open tree has no rows to judge (and no n x n complement is formed)
        kin0 = system.kinematics(t0, x, xd)
        psi_loops = system.constraints.evaluate(kin0, level=1)[1][: system.n_constraints - n_drv]
        if system.strategy.complement(psi_loops).p == 0:
            raise ModelError(
                f"the model has no degree of freedom left: its {system.n_coords} coordinates are all fixed by "
                f"{system.n_constraints - n_drv} loop-closure rows (a structure, not a mechanism)"
            )
        # the rank of psi is judged once, on the assembled state: off the constraint manifold
        # (integrator stages) redundant rows (Bricard linkage) would look independent
        c0 = system.strategy.complement(system.constraints.evaluate(kin0, level=1)[1])
        # and the scale of the singular-position filter (ComplementStrategy.singular_window): the run
        # works on a calibrated copy, the caller's system is unchanged
        system = system.calibrated(c0.rank, float(c0.singular_values()[c0.rank - 1]) if c0.rank else None)
    n = system.n_coords
    times = np.linspace(t0, t_end, n_out) if t_eval is None else np.asarray(t_eval, dtype=float)
    if times.ndim != 1 or np.any(np.diff(times) <= 0) or times[0] < t0 or times[-1] > t_end:
        raise ModelError("t_eval must be increasing and within [t0, t_end]")

    counters = {"rhs": 0}
    start_complements = system.n_complements

    work_names = ([f"driver {d.name}" for d in system.constraints.drivers] + system.forces.group_names()
                  if track_work else [])
    n_w = len(work_names)

    def fun(t, y):
        counters["rhs"] += 1
        if not n_w:
            return system.state_rate(t, y)  # finite, or AssemblyError naming the cause
        xs, vs = y[:n], y[n : 2 * n]
        rates = np.zeros(n_w)
        A, f, psi, gamma = system.reduced_parts(t, y, powers=rates[n_drv:])
        try:
            xdd, lam = system._solve(t, A, f, psi, gamma, multipliers=True)
        except AssemblyError:
            xdd = np.full(n, np.nan)
        if not np.all(np.isfinite(xdd)):
            if not (np.all(np.isfinite(f)) and np.all(np.isfinite(A))):
                system.accelerations(t, xs, vs)  # raises with the diagnosis
            system._solve(t, A, f, psi, gamma)  # raises if the reduced equations are singular
            bad = [system.coordinate_names[i] for i in np.flatnonzero(~np.isfinite(xdd))[:5]]
            raise _NonFinite(t, f"accelerations became non-finite ({', '.join(bad)})")
        if n_drv:
            rates[:n_drv] = lam[-n_drv:] * np.array([d.velocity(t) for d in system.constraints.drivers])
        return np.concatenate([vs, xdd, rates])

    out_y = []
    n_steps = n_proj = 0
    t_wall = _time.perf_counter()
    status, message = "running", ""
    y = np.concatenate([x, xd, np.zeros(n_w)])
    k_out = 0
    if times[0] == t0:
        out_y.append(y.copy())
        k_out = 1

    extra = {}
    # what the integrator can use is declared by its class (flexmb.integrators.base)
    solver_cls = adapt(solver_cls)
    caps = capabilities(solver_cls)
    monitor = ResolutionMonitor.for_run(system, solver_cls, caps, t0, t_end, rtol, atol, name, auto)
    if not caps.has_dense_output:
        raise ModelError(f"integrator {name!r} has no dense output, which simulate needs for its output times")
    if caps.needs_n_second:  # written for y = (x, xd, ...) itself (GeneralizedAlpha)
        extra["n_second"] = n
    preconditioner = None
    if caps.uses_preconditioner and system.articulated and n >= KRYLOV_MIN_COORDS:
        # an open tree: O(n) Newton solves, no matrix (System.newton_preconditioner)
        preconditioner = extra["preconditioner"] = system.newton_preconditioner()
    elif caps.uses_jacobian and system.state_jacobian(t0, x, xd) is not None:
        counters["jac"] = 0

        def jac(t, y):
            counters["jac"] += 1
            J = system.state_jacobian(t, y[:n], y[n : 2 * n])
            return np.pad(J, ((0, n_w), (0, n_w))) if n_w else J

        extra["jac"] = jac
        if caps.second_order:
            # the Jacobian has the block form [[0, I], [Jx, Jv]]: factor n x n only
            extra["n_second"] = n

    # an integrator whose restart discards a multistep history (CVODE: back to order 1) projects its
    # own state only past a looser bound tied to its tolerance; the stored outputs are projected to
    # projection_tol all the same
    state_tol = (projection_tol if caps.cheap_restart
                 else max(projection_tol, min(RESTART_ATOL_FACTOR * atol, RESTART_TOL_MAX)))

    def make(tstart, ystart, first_step=None):
        return solver_cls(fun, tstart, ystart, t_end, rtol=rtol, atol=atol, max_step=max_step,
                          first_step=first_step, **extra)

    t_now = t0
    solver = None
    bar = Progress(t_end - t0, "simulating", "s", enabled=progress)
    own_loop = caps.advances and not system.n_constraints
    try:
        solver = make(t0, y)
        if own_loop:
            # nothing to check or project after a step: the solver steps in its own loop from one
            # output time to the next (and to each percent of the span when showing progress)
            stops = times[k_out:]
            if progress:
                stops = np.union1d(stops, np.linspace(t0, t_end, 101)[1:])
            for t_stop in stops:
                try:
                    y_stop = solver.advance(t_stop, None if monitor is None else monitor.step)
                except RuntimeError as exc:
                    raise _NonFinite(solver.t, f"the integrator failed: {exc}") from exc
                t_now = t_stop
                if not np.all(np.isfinite(y_stop)):
                    raise _NonFinite(t_now, "the state became non-finite")
                if k_out < len(times) and times[k_out] == t_stop:
                    out_y.append(y_stop)
                    k_out += 1
                bar.update_to(t_now - t0)
        while solver.status == "running" and not own_loop:
            try:
                msg = solver.step()
            except (ValueError, np.linalg.LinAlgError) as exc:  # scipy's checks on a non-finite Jacobian
                raise _NonFinite(solver.t, f"the integrator failed: {exc}") from exc
            n_steps += 1
            if solver.status == "failed":
                raise _NonFinite(solver.t, f"the integrator failed: {msg}")
            if not np.all(np.isfinite(solver.y)):
                raise _NonFinite(solver.t, "the state became non-finite")
            if monitor is not None:  # warns once if the steps resolve ringing modes (StiffnessWarning)
                monitor.step(solver)
            t_now = solver.t
            if k_out < len(times) and times[k_out] <= t_now:
                dense = solver.dense_output()
                while k_out < len(times) and times[k_out] <= t_now:
                    y_out = dense(times[k_out]) if times[k_out] != t_now else solver.y.copy()
                    if system.n_constraints:
                        # the interpolant leaves the constraints by about rtol
                        # between steps: store consistent states, by the rule
                        # the steps follow
                        y_out[:n], y_out[n : 2 * n] = _project_output(
                            system, times[k_out], y_out[:n], y_out[n : 2 * n], projection_tol)
                    out_y.append(y_out)
                    k_out += 1
            if solver.status == "running" and system.n_constraints:
                xs, vs = solver.y[:n], solver.y[n : 2 * n]
                if system.constraint_residual(t_now, xs, vs) > state_tol:
                    xs, vs = system.project(t_now, xs, vs, tol=min(1e-12, projection_tol), speeds="mass")
                    n_proj += 1
                    step = solver.step_size
                    first = min(max(step, 1e-14), t_end - t_now) if step else None
                    solver = make(t_now, np.concatenate([xs, vs, solver.y[2 * n :]]), first_step=first)
            bar.update_to(t_now - t0)
        status, message = "finished", "reached t_end"
    except (_NonFinite, AssemblyError) as exc:
        status = "failed"
        t_now = getattr(exc, "t", t_now)
        message = str(exc) if isinstance(exc, AssemblyError) else f"at t = {t_now:.9g} s: {exc}"
    except KeyboardInterrupt:
        status, message = "interrupted", f"interrupted by the user at t = {t_now:.9g} s"
    finally:
        bar.close()  # the bar's line ends before any message
    wall = _time.perf_counter() - t_wall
    if own_loop and solver is not None:
        n_steps = solver.n_steps

    Y = np.array(out_y).reshape(len(out_y), 2 * n + n_w)
    result = _collect(system, times[: len(out_y)], Y[:, : 2 * n])
    result.work = {name: Y[:, 2 * n + i].copy() for i, name in enumerate(work_names)}
    result.n_dof = system.dof(t0, x)
    result.n_rhs = counters["rhs"]
    result.n_jac = counters.get("jac", 0) if preconditioner is None else preconditioner.n_setups
    result.n_steps = n_steps
    result.n_complements = system.n_complements - start_complements
    result.n_projections = n_proj
    result.wall_time = wall
    result.status, result.message = status, message
    result.method = name
    result.method_reason = reason
    result.complement = system.strategy.name
    if status == "failed":
        raise SimulationError(f"simulation failed {message}", t=t_now, result=result)
    return result


#: largest ratio of an output projection's correction to the residual it removes
OUTPUT_PROJECTION_GAIN = 1e3


def _project_output(system, t, x, xd, tol):
    """An output state projected onto the constraints, unless that is ill-conditioned.

    Near a singular position (a flattened four-bar) the minimum-norm
    correction divides the residual by a tiny singular value of psi; such a
    correction, larger than ``OUTPUT_PROJECTION_GAIN`` times the residual,
    is refused, and the state is projected in the well-conditioned
    directions only (:func:`_project_partial`). Speeds are projected
    mass-orthogonally, as after the steps.
    """
    res = system.constraint_residual(t, x, xd)
    if res <= tol:
        return x, xd
    try:
        xp, vp = system.project(t, x, xd, tol=min(1e-12, tol), speeds="mass")
    except AssemblyError:
        return _project_partial(system, t, x, xd, res)
    if max(np.max(np.abs(xp - x)), np.max(np.abs(vp - xd))) > OUTPUT_PROJECTION_GAIN * res:
        return _project_partial(system, t, x, xd, res)
    return xp, vp


def _project_partial(system, t, x, xd, res, n_iter=3):
    """Project a state near a singular position in the well-conditioned directions only.

    The rows of psi along singular values below ``system.singular_window()``
    are left out (on the flattened parallelogram the violation along them is
    of second order in the state's error, and correcting it would move the
    state along the other branch); the speeds are projected
    mass-orthogonally onto what remains. The positions and the speeds are
    judged apart: each correction is kept only if it reduces its own
    residual (``|phi|``, ``|psi xd - b|``) and is no larger than
    ``OUTPUT_PROJECTION_GAIN`` times the state's residual.
    """
    window = system.singular_window()
    if window <= 0.0:
        return x, xd

    def well_conditioned(psi):
        c = system.complement(psi)
        return c.truncated(int(np.sum(c.scale >= window)))

    limit = OUTPUT_PROJECTION_GAIN * res
    xp = np.array(x, dtype=float)
    for _ in range(n_iter):
        phi, psi, _ = system.constraints.evaluate(system.kinematics(t, xp, xd), level=1)
        c = well_conditioned(psi)
        if c.rank:
            xp -= c.particular(phi)
    kin = system.kinematics(t, xp, xd)
    phi, psi, b = system.constraints.evaluate(kin, level=1)
    phi0 = system.constraints.evaluate(system.kinematics(t, x, xd), level=0)
    if np.max(np.abs(phi)) >= np.max(np.abs(phi0)) or np.max(np.abs(xp - x)) > limit:
        xp = np.array(x, dtype=float)  # the positions are kept
        kin = system.kinematics(t, xp, xd)
        phi, psi, b = system.constraints.evaluate(kin, level=1)
    # the speeds, judged apart: a speed residual along the singular direction
    # (not corrected) must not veto the positions' correction
    vp = system._mass_orthogonal_speeds(kin, psi, b, xd, c=well_conditioned(psi))
    if np.max(np.abs(psi @ vp - b)) >= np.max(np.abs(psi @ xd - b)) or np.max(np.abs(vp - xd)) > limit:
        vp = np.array(xd, dtype=float)
    return xp, vp


def _collect(system, t, Y) -> Result:
    """Evaluate the output quantities at the stored states."""
    n = system.n_coords
    nt, nb, m = len(t), system.topology.n_bodies, system.n_constraints
    xdd = np.zeros((nt, n))
    pos = np.zeros((nt, nb, 3))
    org = np.zeros((nt, nb, 3))
    rot = np.zeros((nt, nb, 3, 3))
    kin_e = np.zeros(nt)
    pot_e = np.zeros(nt)
    res = np.zeros(nt)
    vres = np.zeros(nt)
    lam = np.zeros((nt, m))
    for i in range(nt):
        x, xd = Y[i, :n], Y[i, n:]
        kin = system.kinematics(t[i], x, xd)
        try:
            if m == 0:  # no reactions: the system's own route (O(n) for an open tree)
                xdd[i], lam_i = system.accelerations(t[i], x, xd), np.zeros(0)
            else:
                A, f, psi, gamma = system.reduced_parts(t[i], Y[i])
                xdd[i], lam_i = system._solve(t[i], A, f, psi, gamma, multipliers=True)
        except FlexmbError:
            xdd[i], lam_i = np.nan, np.full(m, np.nan)
        pos[i] = kin.r[:-1]
        org[i] = kin.origin[:-1]
        rot[i] = kin.R[:-1]
        kin_e[i] = kin.kinetic_energy()
        pot_e[i] = system.forces.potential_energy(kin)
        if m:
            res[i], vres[i] = system.constraint_residuals(t[i], x, xd)
            lam[i] = lam_i
    return Result(
        t=np.asarray(t, float), x=Y[:, :n].copy(), xd=Y[:, n:].copy(), xdd=xdd, positions=pos, origins=org,
        rotations=rot, kinetic=kin_e, potential=pot_e, residual=res, velocity_residual=vres,
        reactions=lam, coordinate_names=list(system.coordinate_names), body_names=list(system.body_names),
        constraint_labels=list(system.constraints.labels),
        driver_names=[d.name for d in system.constraints.drivers],
        flexible={b.name: ([system.topology.index[sg] for sg in segs], b.segment_length)
                  for b, (_, segs, _) in system.topology.flexible.items()},
        system=system,
    )
