"""Undamped modes far above a scene's motion: what ``method='auto'`` does about them, and when a run is warned.

A flexible mechanism started impulsively (B6, the slider-crank with a
steel rod) rings in its segment modes, hundreds of Hz to several kHz,
while the mechanism itself moves at a few Hz. Without material damping an
error-controlled integrator resolves every ringing mode to its tolerance
for as long as it rings: for ever. This module

- finds those modes (:func:`ringing_modes`): the oscillatory modes of the
  linearised motion (the eigenvalues of the state Jacobian,
  :meth:`~flexmb.system.System.state_jacobian`) that are nearly undamped
  (damping ratio below :data:`RINGING_ZETA`), lie more than
  :data:`FAR_ABOVE` times above the scene's motion
  (:func:`motion_frequency`), and are excited above the integration
  tolerance by the state (their free-vibration amplitude, from the modal
  components of the speeds and accelerations);
- picks ``method='auto'``'s integrator on a stiff scene
  (:func:`stiff_choice`): for ringing modes that would be costly to
  resolve, the generalized-alpha method with the step floor ``min_step = 1
  / (2 pi f)`` at the lowest ringing frequency f, so that every ringing
  mode is integrated at ``h omega >= 1`` and damped, never resolved
  (:func:`dissipative_choice`, with the statement of what that costs);
  Radau where lightly damped modes far above the motion are not excited
  (CVODE's BDF orders 3-5 are not A-stable near the imaginary axis, and it
  cannot step over them: :data:`BDF_ZETA`); CVODE_BDF otherwise;
- watches an error-controlled run (:class:`ResolutionMonitor`) and warns
  once, after :data:`CHECK_STEPS` steps, when its steps resolve ringing
  modes (:class:`~flexmb.errors.StiffnessWarning`, with the frequencies
  and the remedy).

Scenes with more than :data:`MODES_MAX_COORDS` coordinates are not
analysed (a dense eigenvalue problem of size 2n).
"""

from __future__ import annotations

import logging
import os
import sys
import warnings

import numpy as np
from attrs import frozen
from .._lazy import LazyModule
from ..errors import StiffnessWarning
from ..genalpha.parameters import amplification_matrix, numerical_damping

#: the ringing modes' eigenproblem, imported at its first use (a run that never analyses its modes imports no
#: scipy.linalg)
linalg = LazyModule("scipy.linalg")

__all__ = ["Modes", "ringing_modes", "motion_frequency", "stiff_choice", "dissipative_choice",
           "ResolutionMonitor", "median", "FAR_ABOVE", "RINGING_ZETA", "AUTO_RHO_INF", "MODES_MAX_COORDS", "CHECK_STEPS",
           "RESOLVING_HW", "RESOLVE_STEP_LIMIT", "STEPS_PER_PERIOD", "BDF_ZETA", "EXCITED"]

logger = logging.getLogger("flexmb")

#: a mode this many times above the scene's motion frequency is "far above" it
FAR_ABOVE = 10.0

#: modes with a smaller damping ratio ring (nearly undamped): resolving one to a tolerance
#: ``rtol`` costs some ``ln(1 / rtol) / (2 pi zeta)`` periods, about 600 at 0.5 % and rtol 1e-8
RINGING_ZETA = 0.005

#: spectral radius at infinity of the generalized-alpha method 'auto' picks for ringing modes: on
#: B6 undamped the smallest that leaves the motion alone removes the ringing within 0.1 s; larger
#: ones leave the first mode ringing, not resolved, for the whole second, and cost more Newton work
#: (benchmarks/b6_slider_crank.py --rho-scan, docs/benchmarks.md)
AUTO_RHO_INF = 0.5

#: scenes with more coordinates are not analysed (dense eigenvalues of the 2n x 2n state Jacobian)
MODES_MAX_COORDS = 200

#: steps of an error-controlled run before it is judged (then again after 2x, 4x, ... as many)
CHECK_STEPS = 100

#: a step ``h`` resolves a mode of angular frequency omega when ``h omega`` is below this
RESOLVING_HW = 1.0

#: a run is warned only if, at the rate of its steps, it would take more steps than this over
#: [t0, t_end] (a short run may resolve what rings: it costs seconds, not minutes)
RESOLVE_STEP_LIMIT = 10_000

#: a ringing mode counts as excited when its free-vibration amplitude exceeds this many
#: tolerance scales ``atol + rtol |x|`` in some coordinate
EXCITED = 1.0

#: an error-controlled method spends about this many steps per period of a ringing mode it
#: resolves (B6 undamped at rtol 1e-8: CVODE_BDF 83, Radau 115 per period of its 11.4 kHz mode);
#: 'auto' dissipates ringing modes when resolving them would cost more than RESOLVE_STEP_LIMIT steps
STEPS_PER_PERIOD = 100

#: modes far above the motion with a smaller damping ratio, none of them excited, make 'auto' take
#: Radau rather than CVODE_BDF, which cannot step over them (the crossover is measured by
#: benchmarks/stiff_pendulum.py and benchmarks/auto_choice.py; the numbers are in docs/benchmarks.md)
BDF_ZETA = 0.01


@frozen
class Modes:
    """Oscillatory modes of a scene's linearised motion at one state, slowest first.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    frequency : ndarray, shape (k,)
        Damped natural frequencies, Hz.
    damping : ndarray, shape (k,)
        Damping ratios (0 undamped).
    excitation : ndarray, shape (k,)
        Free-vibration amplitude of each mode in the state, in tolerance
        scales ``atol + rtol |x|`` (largest over the coordinates).
    motion : float
        The scene's motion frequency, Hz (:func:`motion_frequency`).

    Examples
    --------
    >>> import numpy as np
    >>> from flexmb.integrators.monitor import Modes
    >>> m = Modes(np.array([2.0, 300.0]), np.array([0.0, 0.0]), np.array([5.0, 5.0]), 5.0)
    >>> m.ringing().tolist()
    [False, True]
    """

    frequency: np.ndarray
    damping: np.ndarray
    excitation: np.ndarray
    motion: float

    def ringing(self, excited: bool = True) -> np.ndarray:
        """Mask of the nearly undamped modes far above the motion (and, by default, excited).

        Parameters
        ----------
        excited : bool
            Also require an excitation above the tolerance.

        Returns
        -------
        ndarray of bool, shape (k,)
            ``damping < RINGING_ZETA`` and ``frequency > FAR_ABOVE * motion``
            (and ``excitation > EXCITED``).
        """
        mask = (self.damping < RINGING_ZETA) & (self.frequency > FAR_ABOVE * self.motion)
        return mask & (self.excitation > EXCITED) if excited else mask


def _angular(system, driver) -> bool:
    """Whether a driver prescribes an angle (its coordinate's name says so)."""
    name = driver.joint.coordinate_names[driver.coordinate]
    return "angle" in name or name in ("rx", "ry", "rz")


def motion_frequency(system, t0: float, t1: float, modes_hz=(), n_rigid: int = 0) -> float:
    """A frequency of the scene's own motion over [t0, t1], Hz.

    The largest of: one cycle over the run, ``1 / (t1 - t0)``; each
    driver's rate, ``|velocity| / (2 pi)`` for an angle and
    ``|acceleration| / (2 pi |velocity|)`` for any coordinate, sampled at 5
    times over the run; and, for a structure (no driver and no freedom
    without stiffness, ``n_rigid = 0``), its lowest natural frequency, since
    its motion is its vibration.

    Parameters
    ----------
    system : System
        The compiled model.
    t0, t1 : float
        The run's time span, s.
    modes_hz : array_like
        Natural frequencies of the scene, Hz, slowest first.
    n_rigid : int
        Freedoms of the mechanism without stiffness (rigid motions).

    Returns
    -------
    float
        Frequency, Hz.
    """
    f = 1.0 / max(t1 - t0, 1e-300)
    drivers = system.constraints.drivers
    for d in drivers:
        for t in np.linspace(t0, t1, 5):
            v, a = abs(float(d.velocity(t))), abs(float(d.acceleration(t)))
            if _angular(system, d):
                f = max(f, v / (2 * np.pi))
            if v > 0 and np.isfinite(a / v):
                f = max(f, a / v / (2 * np.pi))
    if not drivers and n_rigid == 0 and len(modes_hz):
        f = max(f, float(modes_hz[0]))
    return f


def ringing_modes(system, t0: float, t1: float, x, xd, rtol: float, atol: float,
                  t_start: float | None = None) -> Modes | None:
    """The oscillatory modes of the scene at (t0, x, xd), with their damping and excitation.

    Parameters
    ----------
    system : System
        The compiled (calibrated) model.
    t0, t1 : float
        Time of the state analysed and end of the run, s.
    x, xd : ndarray, shape (n,)
        Consistent coordinates and speeds at ``t0``.
    rtol, atol : float
        The run's tolerances (the scale of the excitation).
    t_start : float, optional
        Start of the run, for :func:`motion_frequency` (default ``t0``).

    Returns
    -------
    Modes or None
        None when the scene has no coordinate stiffness or more than
        :data:`MODES_MAX_COORDS` coordinates.

    Notes
    -----
    With the state Jacobian ``J`` (of ``y = (q, u)``) and its eigenpairs ``lambda_k``,
    left ``u_k`` and right ``r_k``, the free vibration of mode k in the
    state has the modal amplitude ``u_k^H ydot / (lambda_k u_k^H r_k)``,
    ``ydot = (qd, ud)``: the forced (quasi-static) part of the response
    changes slowly and adds little to ``ydot``. Its coordinates are the
    first nq entries of ``2 |c_k r_k|`` (a complex pair).
    """
    n = system.n_coords
    if n > MODES_MAX_COORDS:
        return None
    J = system.state_jacobian(t0, x, xd)
    if J is None:
        return None
    lam, left, right = linalg.eig(J, left=True, right=True, check_finite=False)
    scale = np.abs(lam).max(initial=0.0)
    if not np.all(np.isfinite(lam)) or scale == 0.0:
        return None
    nonzero = np.abs(lam) > 1e-9 * scale
    osc = nonzero & (lam.imag > 1e-9 * scale)
    # freedoms without stiffness: p minus the modes (a pair of eigenvalues each)
    n_rigid = max(system.dof(t0, x) - int(np.sum(nonzero)) // 2, 0)
    lam, left, right = lam[osc], left[:, osc], right[:, osc]
    order = np.argsort(np.abs(lam))
    lam, left, right = lam[order], left[:, order], right[:, order]
    omega = np.abs(lam)
    zeta = -lam.real / omega
    layout = system.layout
    ydot = layout.join(layout.coordinate_rates(x, xd), system.accelerations(t0, x, xd))
    c = (left.conj().T @ ydot) / (lam * np.einsum("ik,ik->k", left.conj(), right))
    amplitude = 2.0 * np.abs(c[None, :] * layout.coordinates(right.T).T)
    tol = atol + rtol * np.abs(np.asarray(x, float))
    excitation = np.max(amplitude / tol[:, None], axis=0) if len(lam) else np.zeros(0)
    freq = omega * np.sqrt(np.clip(1.0 - zeta**2, 0.0, None)) / (2 * np.pi)
    start = t0 if t_start is None else t_start
    return Modes(freq, zeta, excitation, motion_frequency(system, start, t1, freq, n_rigid))


def _band(freqs) -> str:
    freqs = np.sort(np.asarray(freqs))
    low, high = f"{freqs[0]:.4g}", f"{freqs[-1]:.4g}"
    count = f" ({len(freqs)} modes)" if len(freqs) > 1 else ""
    return f"{low} Hz{count}" if low == high else f"{low} to {high} Hz{count}"


def stiff_choice(system, t0: float, t1: float, x, xd, rtol: float, atol: float, steps: float):
    """The integrator ``method='auto'`` takes on a stiff scene, and why.

    Parameters
    ----------
    system : System
        The compiled model.
    t0, t1 : float
        Time span, s.
    x, xd : ndarray, shape (n,)
        Consistent initial coordinates and speeds.
    rtol, atol : float
        The run's tolerances.
    steps : float
        The steps an explicit method would need to stay stable (for the statement).

    Returns
    -------
    method : str or type
        The generalized-alpha class of :func:`dissipative_choice` when
        ringing modes would cost more than :data:`RESOLVE_STEP_LIMIT` steps
        to resolve (``STEPS_PER_PERIOD`` per period of the fastest);
        ``'Radau'`` when the modes far above the motion with a damping ratio
        below :data:`BDF_ZETA` are not excited (if some are, the steps
        resolve them anyway, and CVODE_BDF is the faster at that);
        ``'CVODE_BDF'`` otherwise (and
        for scenes of more than :data:`MODES_MAX_COORDS` coordinates).
    reason : str
        The statement of the choice.
    """
    stiff = f"the scene is stiff (an explicit method needs about {steps:.3g} steps over {t1 - t0:.4g} s to stay stable)"
    modes = ringing_modes(system, t0, t1, x, xd, rtol, atol)
    if modes is not None:
        ring = modes.ringing()
        if np.any(ring) and STEPS_PER_PERIOD * modes.frequency[ring].max() * (t1 - t0) > RESOLVE_STEP_LIMIT:
            return dissipative_choice(modes)
        light = (modes.damping < BDF_ZETA) & (modes.frequency > FAR_ABOVE * modes.motion)
        still = light & (modes.excitation <= EXCITED)
        # with some excited, the steps resolve them anyway, and CVODE resolves faster than Radau
        if np.any(still) and not np.any(light & ~still):
            return "Radau", (f"'auto' chose Radau: {stiff}, and its lightly damped modes at "
                             f"{_band(modes.frequency[still])}, far above its motion (about {modes.motion:.3g} Hz), "
                             f"are hardly excited: Radau steps over them, CVODE_BDF cannot (its BDF orders 3 to 5 "
                             f"are unstable near undamped oscillations)")
    return "CVODE_BDF", f"'auto' chose CVODE_BDF: {stiff}"


def dissipative_choice(modes: Modes):
    """The generalized-alpha integrator for the ringing modes of ``modes``, and the statement of the choice.

    Parameters
    ----------
    modes : Modes
        From :func:`ringing_modes`, with at least one ringing mode.

    Returns
    -------
    method : type
        ``generalized_alpha(AUTO_RHO_INF, f_max=f / 2, min_step=1 / (2 pi
        f))`` with f the lowest ringing frequency.
    reason : str
        The ringing modes, the motion, the step floor and the damping the
        method adds to the lowest ringing mode and per step to the fastest
        (:func:`~flexmb.genalpha.numerical_damping`).
    """
    freqs = modes.frequency[modes.ringing()]
    f_low, f_high = float(freqs.min()), float(freqs.max())
    min_step = 1.0 / (2 * np.pi * f_low)
    from ..genalpha import generalized_alpha

    cls = generalized_alpha(AUTO_RHO_INF, f_max=0.5 * f_low, min_step=min_step)
    z_low = float(numerical_damping(AUTO_RHO_INF, 1.0))
    loss_high = 1.0 - float(np.max(np.abs(np.linalg.eigvals(amplification_matrix(AUTO_RHO_INF, f_high / f_low)))))
    reason = (f"'auto' chose the generalized-alpha method (rho_inf={AUTO_RHO_INF:g}): the scene has nearly undamped "
              f"modes at {_band(freqs)}, excited by the initial state and far above its motion (about "
              f"{modes.motion:.3g} Hz), which an error-controlled integrator would resolve for as long as they ring. "
              f"Its steps never go below {min_step:.3g} s (above that, its error control follows the motion below "
              f"{0.5 * f_low:.3g} Hz at rtol), so these modes are dissipated, not resolved: the method damps the "
              f"{f_low:.4g} Hz mode at about {100 * z_low:.2g} % of critical and the faster ones more, up to "
              f"{100 * loss_high:.2g} % of their amplitude per step. "
              f"simulate(..., track_work=True) gives the energy removed (driver work minus the change of kinetic "
              f"and elastic energy); to resolve the modes instead, pass method='CVODE_BDF' or 'Radau'")
    return cls, reason


def median(values) -> float:
    """``np.median`` of a list of finite floats, to the bit, without numpy's overhead per call.

    An odd count gives the middle value, an even count the mean of the two
    middle ones, ``(a + b) / 2`` as ``np.mean`` forms it.

    Parameters
    ----------
    values : list of float
        Finite values (at least one).

    Returns
    -------
    float
        Their median.
    """
    s = sorted(values)
    k = len(s) // 2
    return float(s[k]) if len(s) % 2 else float((s[k - 1] + s[k]) / 2)


def _caller_stacklevel() -> int:
    """The stacklevel of the first frame outside the flexmb package (the user's call), for warnings.warn."""
    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    frame, level = sys._getframe(1), 1
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(package + os.sep):
        frame, level = frame.f_back, level + 1
    return level


class ResolutionMonitor:
    """Watches the steps of an error-controlled run and warns once if they resolve ringing modes.

    After :data:`CHECK_STEPS` steps (then after twice, four times ... as
    many), the run is judged on its median step ``h`` over the steps since
    the last check: if at that rate the run would take more than
    :data:`RESOLVE_STEP_LIMIT` steps, and ``h`` resolves (``h omega <
    RESOLVING_HW``) some
    mode that :func:`ringing_modes` finds at the current state nearly
    undamped and far above the motion, a
    :class:`~flexmb.errors.StiffnessWarning` names their frequencies, the
    steps the rest of the run will take at that rate, and the remedy: to
    dissipate them if they are excited above the tolerance, else an
    L-stable method, which steps over them.
    Nothing is analysed while the steps are too long to resolve anything
    far above the motion.

    Parameters
    ----------
    system : System
        The compiled model.
    t0, t1 : float
        The run's time span, s.
    rtol, atol : float
        The run's tolerances.
    name : str
        The integrator's name, for the message.
    auto : bool
        The integrator was chosen by ``method='auto'`` (the remedy is then
        not to ask for it).

    Attributes
    ----------
    warned : bool
        Whether the warning was given.
    """

    def __init__(self, system, t0: float, t1: float, rtol: float, atol: float, name: str, auto: bool = False):
        self.system, self.t0, self.t1, self.rtol, self.atol, self.name = system, t0, t1, rtol, atol, name
        self.auto = auto
        self.steps = []
        self.next_check = CHECK_STEPS
        self.n_steps = 0
        self.warned = self.system.n_coords > MODES_MAX_COORDS
        self._motion = None

    @classmethod
    def for_run(cls, system, solver_cls, caps, t0, t1, rtol, atol, name, auto=False):
        """A monitor for a run with ``solver_cls``, or None for explicit methods and step-floored ones.

        Parameters
        ----------
        system : System
            The compiled model.
        solver_cls : type
            The integrator class.
        caps : Capabilities
            Its capabilities (:func:`~flexmb.integrators.capabilities`).
        t0, t1 : float
            The run's time span, s.
        rtol, atol : float
            The run's tolerances.
        name : str
            The integrator's name.
        auto : bool
            Chosen by ``method='auto'``.

        Returns
        -------
        ResolutionMonitor or None
            None for explicit methods (warned before the run) and for
            integrators that never resolve what rings (a step floor or a
            fixed step).
        """
        if caps.explicit or getattr(solver_cls, "min_step", None) or getattr(solver_cls, "fixed_step", None):
            return None
        return cls(system, t0, t1, rtol, atol, name, auto)

    def motion(self) -> float:
        """:func:`motion_frequency` over the run's span (worked out once per monitor).

        Returns
        -------
        float
            Frequency, Hz.
        """
        if self._motion is None:
            self._motion = motion_frequency(self.system, self.t0, self.t1)
        return self._motion

    def step(self, solver) -> None:
        """Record one step of ``solver`` (its ``t`` and ``t_old``) and judge the run at the checkpoints.

        Parameters
        ----------
        solver : OdeSolver
            The integrator, after a successful step.
        """
        if self.warned or solver.t_old is None:
            return
        self.steps.append(abs(solver.t - solver.t_old))
        self.n_steps += 1
        if self.n_steps < self.next_check:
            return
        self.next_check *= 2
        h = median(self.steps)
        self.steps = []
        # a run that stays short at this rate, or steps too long to resolve anything far above the
        # motion: nothing to analyse
        if ((self.t1 - self.t0) / h <= RESOLVE_STEP_LIMIT
                or h * 2 * np.pi * FAR_ABOVE * self.motion() >= RESOLVING_HW):
            return
        modes = ringing_modes(self.system, solver.t, self.t1, *self.system.layout.split(solver.y), self.rtol,
                              self.atol, t_start=self.t0)
        if modes is None:
            return
        resolved = modes.ringing(excited=False) & (h * 2 * np.pi * modes.frequency < RESOLVING_HW)
        if not np.any(resolved):
            return
        self.warned = True
        remaining = (self.t1 - solver.t) / h
        f_low = float(modes.frequency[resolved].min())
        floor = 1.0 / (2 * np.pi * f_low)
        dissipate = f"method=fm.generalized_alpha(rho_inf={AUTO_RHO_INF:g}, min_step={floor:.3g})"
        if np.any(resolved & (modes.excitation > EXCITED)):
            remedy = ("If these vibrations are not what you need, use "
                      + (f"{dissipate}, which dissipates them" if self.auto
                         else f"method='auto' (it dissipates them) or {dissipate}")
                      + "; or add material damping to the flexible bodies")
        elif self.name == "Radau":  # L-stable already: its error test, not its stability, holds the steps down
            remedy = (f"Radau, L-stable, still resolves them to meet the tolerance: add damping (material damping, a "
                      f"damped contact law), or take steps over them with {dissipate}")
        else:
            remedy = ("They are hardly excited: an L-stable method steps over them, use method='Radau'"
                      + ("" if self.auto else " (or method='auto')"))
        warnings.warn(StiffnessWarning(
            f"{self.name} is resolving nearly undamped modes at {_band(modes.frequency[resolved])}, far above the "
            f"scene's motion (about {modes.motion:.3g} Hz): its steps are about {h:.3g} s at t = {solver.t:.4g} s, "
            f"some {remaining:.3g} more to t = {self.t1:.4g} s. {remedy}"
        ), stacklevel=_caller_stacklevel())


class CompiledSteps:
    """A monitor's state as a compiled step loop keeps it (:func:`flexmb.kernels.cvode_callbacks.advance`).

    The loop records the steps in ``hs`` and passes the checkpoints at which
    :meth:`ResolutionMonitor.step` would find nothing to analyse, with its
    very arithmetic (``mi``, ``mf``: the slots of
    :mod:`flexmb.kernels.cvode_callbacks`); :meth:`load` copies the
    monitor's state in before a call, :meth:`save` back after it, and
    :meth:`judge` hands a checkpoint with something to judge to the monitor.

    Parameters
    ----------
    monitor : ResolutionMonitor or None
        The run's monitor (None: nothing recorded).
    """

    def __init__(self, monitor):
        self.monitor = monitor
        self.mi, self.mf, self.hs = np.zeros(4, dtype=np.int64), np.zeros(7), np.zeros(0)
        if monitor is not None:
            self.mf[:] = (monitor.t0, monitor.t1, np.nan, 0.0, RESOLVE_STEP_LIMIT, FAR_ABOVE, RESOLVING_HW)

    def load(self) -> None:
        """Copy the monitor's state in (``hs`` holding at least the steps to two checkpoints on)."""
        mon, mi = self.monitor, self.mi
        mi[0] = live = mon is not None and not mon.warned
        if not live:
            return
        count = len(mon.steps)
        if self.hs.shape[0] < count + 2 * (mon.next_check - mon.n_steps):
            self.hs = np.empty(count + 4 * mon.next_check)
        self.hs[:count] = mon.steps
        mi[1:], self.mf[2] = (count, mon.n_steps, mon.next_check), mon.motion()

    def grow(self) -> None:
        """Twice the room for the steps (the loop found ``hs`` full)."""
        self.hs = np.concatenate([self.hs, np.empty(max(self.hs.shape[0], 1))])

    def save(self) -> None:
        """Copy the loop's state back to the monitor."""
        mon, mi = self.monitor, self.mi
        if mi[0]:
            mon.steps, mon.n_steps, mon.next_check = self.hs[: mi[1]].tolist(), int(mi[2]), int(mi[3])

    def judge(self, t: float, y) -> None:
        """Give the monitor the step that reached its checkpoint (ending at ``t`` in ``y``), as a step of its own.

        Parameters
        ----------
        t : float
            The step's end.
        y : ndarray
            The solver's state there.
        """
        mon, mi = self.monitor, self.mi
        mi[1] -= 1
        mi[2] -= 1
        self.save()
        mon.step(_Step(t, float(self.mf[3]), y))


class _Step:
    """What the monitor reads of a solver after a step."""

    def __init__(self, t, t_old, y):
        self.t, self.t_old, self.y = float(t), float(t_old), y
