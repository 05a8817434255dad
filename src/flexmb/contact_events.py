"""Contact onset and separation as integration events, tunnelling refused, and the notice on tiny contact steps.

A contact's force switches on where its penetration ``delta`` crosses 0
(onset) and off where it falls back through 0 (separation): the
right-hand side has a kink there (a jump, for a law with damping), which
an integrator stepping through it resolves only by cutting its steps
around it, and a step that carries a body from free flight deep into a
surface meets the force only at its end. :class:`ContactEvents` makes
these crossings events of the run (:class:`flexmb.stepping.Run`):

* after each step the penetrations of all contacts are compared with the
  contacts' states (touching or not); a change, or, between two ends on
  the same side, a crossing that the penetrations and their rates at both
  ends predict (the cubic through them, or the meeting of their tangents:
  a grazing touch, a point through a sphere) and the dense output
  confirms, is an event; a touch and release within one step that the
  ends do not foretell is not seen (bound the step, ``max_step``, where
  that matters);
* its time is the earliest root, located on the integrator's dense output
  (Brent's method to :data:`EVENT_TOL` relative, a few hundred unit
  roundoffs), or by the integrator itself where it finds roots (CVODE's
  root finding, ``finds_roots``: :mod:`flexmb.integrators.base`, on the
  penetrations :data:`ROOT_OFFSET` past the touch);
* the run takes the step again from its start up to the event (the new
  integrator's bound), so that the state there comes from a smooth
  interval and not from an interpolant across the kink, keeps the outputs
  up to it, records the event with the rate of penetration there (the
  impact speed at an onset; ``Result.contact_events``; the contact holds
  it until its separation, :mod:`flexmb.impact_speeds`) and restarts the
  integrator there: the step is restarted at the event, not stepped
  through. A contact changes state :data:`ROOT_OFFSET` past the touch
  (or, just after an event whose state lies on the old side by more, twice
  that distance), so that no restart begins on a root;
* a step from free flight into a surface is thus never kept: it is taken
  again up to the touch. A step that carries a touching body through the
  other (the normal of a touching pair of surfaces reversed between the
  step's ends, compared pair by pair, the rows of a contact: a sphere's
  centre past the other's, a pin past the bearing's centre; the force
  would then push it on through) is refused: the integrator is restarted
  from the step's start with an eighth of the step, and the run fails,
  naming the contact, if no step short enough keeps it from passing (a
  law too soft for the load). A plane is a half-space: a sphere pressed
  into it is pushed back out however deep, and cannot pass through;
* while a contact touches, the steps since the last event are counted:
  when more than :data:`CONTACT_STEP_LIMIT` of them are on average a
  hundredth or less of those taken off contact (of a hundredth of the
  span, in a run with few steps off contact; an impact resolved in a
  few hundred steps is not counted: a contact held over thousands of tiny
  steps is), a :class:`~flexmb.errors.StiffnessWarning` says so, once,
  with the remedy.
"""

from __future__ import annotations

import warnings

import numpy as np

from .errors import StiffnessWarning
from .impact_speeds import HeldSpeeds, _contact_groups

__all__ = ["ContactEvents", "contact_gaps", "EVENT_TOL", "ROOT_OFFSET", "CONTACT_STEP_LIMIT",
           "TINY_STEP_RATIO", "REFUSED_STEP_SHRINK", "MIN_REFUSED_STEP"]

#: relative tolerance of an event time located on the dense output (Brent's method), times max(|t|, 1 s)
EVENT_TOL = 1e-13

#: a contact's state changes this far past the touch, m: onset where the penetration rises above
#: +ROOT_OFFSET, separation where it falls below -ROOT_OFFSET (a few hundred roundoffs of a metre-sized
#: position), so that a restart at an event, or a start with a contact just touching, never begins on a
#: root (CVODE refuses that: "root found at and very near t")
ROOT_OFFSET = 1e-15

#: steps taken while a contact touches, since the last event, before the notice on tiny steps can be given
CONTACT_STEP_LIMIT = 2000

#: the steps in contact are "tiny" at this fraction or less of the mean step off contact
TINY_STEP_RATIO = 1e-2

#: a step refused for tunnelling is retried from its start with this fraction of it
REFUSED_STEP_SHRINK = 0.125

#: a refused step shorter than this (relative to max(|t|, 1 s)) ends the run: the contact cannot hold the body
MIN_REFUSED_STEP = 1e-13


def contact_gaps(system, t, x, xd):
    """Penetrations, their rates and the normals of all contact elements of a system at a state.

    The event functions of :class:`ContactEvents`: a contact touches
    where its penetration is positive (negative: the gap).

    Parameters
    ----------
    system : System
        The compiled model.
    t : float
        Time, s.
    x, xd : ndarray, shape (n,)
        Coordinates and speeds.

    Returns
    -------
    delta, rate : ndarray, shape (c,)
        Penetration (m) and its rate (m/s) of each contact, in the order of
        the system's force groups (:attr:`ContactEvents.names`).
    normal : ndarray, shape (c, 3)
        The contact normals, towards the first side.

    Examples
    --------
    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> ball = fm.RigidBody("ball", mass=1.0, inertia=np.eye(3))
    >>> floor = fm.SpherePlaneContact("floor", ball, 0.05, fm.LinearContactLaw(1e5))
    >>> system = model.add(fm.Prismatic("drop", model.ground, ball, axis=(0, 0, 1)), floor).build()
    >>> delta, rate, normal = contact_gaps(system, 0.0, np.array([0.06]), np.array([-1.0]))
    >>> delta.round(6), rate, normal
    (array([-0.01]), array([1.]), array([[0., 0., 1.]]))
    """
    return _states(system, t, x, xd)[:3]


def _states(system, t, x, xd):
    """:func:`contact_gaps`, and the rows': penetration, normal and element (an index into the contacts)."""
    from .forces.contact_base import merge_rows

    groups = _contact_groups(system)
    if not groups:
        return np.zeros(0), np.zeros(0), np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)), np.zeros(0, dtype=int)
    kin = system._kinematics(t, x, xd)
    merged, rows, owners, first = [], [], [], 0
    for cls, elements in groups:
        row = cls.row_states(elements, kin)
        owner = cls._owners(elements, kin.topology)
        merged.append(row if len(owner) == len(elements) else merge_rows(owner, len(elements), *row))
        rows.append(row)
        owners.append(owner + first)
        first += len(elements)
    return (np.concatenate([p[0] for p in merged]), np.concatenate([p[1] for p in merged]),
            np.concatenate([p[5] for p in merged]), np.concatenate([p[0] for p in rows]),
            np.concatenate([p[5] for p in rows]), np.concatenate(owners))


class Refused(Exception):
    """A step carried a touching contact through its surface (the run retries it shorter)."""


class StepFailure(Exception):
    """A step around a contact event failed at time ``t`` (the run stops with status 'failed').

    Parameters
    ----------
    t : float
        The time, s.
    what : str
        What failed.
    """

    def __init__(self, t, what):
        super().__init__(what)
        self.t = t


class ContactEvents:
    """The contact events of one run (see the module docstring).

    Parameters
    ----------
    system : System
        The compiled model; it must have contact elements.
    t0, t_end : float
        The run's span, s.
    explicit : bool
        Whether the integrator is explicit (the notice's remedy differs).
    name : str
        The integrator's name, for the notice.

    Attributes
    ----------
    names : list of str
        The contacts' names, in the order of the gaps.
    touching : ndarray of bool, shape (c,)
        Which contacts touch at the run's current time.
    events : list of (float, str, str, float)
        ``(time, contact name, 'onset' or 'separation', rate)`` in time
        order, with the rate of penetration there (m/s: the impact speed at
        an onset, minus the speed of separation at a separation).
    n_refused : int
        Steps refused for tunnelling.
    """

    def __init__(self, system, t0, t_end, explicit, name):
        self.system, self.layout = system, system.layout
        groups = _contact_groups(system)
        elements = [e for _, els in groups for e in els]
        self.names = [e.name for e in elements]
        self.touching = np.zeros(len(elements), bool)
        self.events: list = []
        self.n_refused = 0
        self.t0, self.t_end, self.explicit, self.name = t0, t_end, explicit, name
        self.steps_on = self.steps_off = 0
        self.time_on = self.time_off = 0.0
        self.warned = False
        self.held = HeldSpeeds.of(system)

    @classmethod
    def of(cls, system, t0, t_end, explicit, name):
        """The events of a run of ``system``, or None if it has no contact elements.

        Parameters
        ----------
        system : System
            The compiled model.
        t0, t_end : float
            The run's span, s.
        explicit : bool
            Whether the integrator is explicit.
        name : str
            The integrator's name.

        Returns
        -------
        ContactEvents or None
        """
        return cls(system, t0, t_end, explicit, name) if _contact_groups(system) else None

    @property
    def count(self) -> int:
        """Number of event functions (contacts)."""
        return len(self.names)

    def gaps(self, t, y) -> np.ndarray:
        """The penetrations at the true state ``y = (x, xd, ...)``.

        Parameters
        ----------
        t : float
            Time, s.
        y : ndarray
            The true state.

        Returns
        -------
        ndarray, shape (c,)
            The penetrations, m (negative: the gaps).
        """
        return contact_gaps(self.system, t, *self.layout.split(y))[0]

    def _switch(self, delta):
        """How far each contact is past its switch: ``delta - band`` apart, ``-(delta + band)`` touching.

        Positive: its state changes (an onset where ``delta`` rose above
        ``band``, a separation where it fell below ``-band``).
        """
        return np.where(self.touching, -(delta + self.band), delta - self.band)

    def root_functions(self, t, y) -> np.ndarray:
        """What an integrator's own root finding watches: how far each contact is past its switch.

        ``delta - band`` for a contact apart, ``-(delta + band)`` for one
        touching (``band`` is :data:`ROOT_OFFSET`, or more just after an
        event whose restart state lies on the old side by more): rising
        through zero where the contact's state changes, never zero at a
        state where it just changed; the integrator watches rising
        crossings only.

        Parameters
        ----------
        t : float
            Time, s.
        y : ndarray
            The true state.

        Returns
        -------
        ndarray, shape (c,)
            How far past its switch each contact is, m.
        """
        return self._switch(self.gaps(t, y))

    def start(self, t, y) -> None:
        """Take the contacts' states at the start of the run (no event).

        A contact touches at the start if its penetration is above
        ``-ROOT_OFFSET``: one started exactly at the touch (a body set down
        on a surface) is a resting contact, not an impact at the speed
        with which it crosses the offset (a restitution law would hold that
        speed, nearly 0, and damp the contact without bound:
        :mod:`flexmb.impact_speeds`).

        Parameters
        ----------
        t : float
            Time, s.
        y : ndarray
            The true state.
        """
        self.delta, self.rate, self.normal, *self.rows = _states(self.system, t, *self.layout.split(y))
        self.touching = self.delta > -ROOT_OFFSET
        self.band = np.full(len(self.names), ROOT_OFFSET)
        self.held.release()  # a contact touching at the start holds no impact speed

    def finish(self) -> None:
        """End the run: the contacts hold no impact speeds any more (:mod:`flexmb.impact_speeds`)."""
        self.held.release()

    def after_step(self, t_start, t_end, y_end, dense, root=None):
        """The first event within the step ``[t_start, t_end]``, or None; refuses a step through a surface.

        Nothing is recorded here: the run takes the step again up to the
        event (on a smooth interval, so its state there is not an
        interpolant across the kink) and hands that state to
        :meth:`confirm`.

        Parameters
        ----------
        t_start, t_end : float
            The step, s.
        y_end : ndarray
            The true state at its end.
        dense : callable
            ``dense(t)``: the true state within the step.
        root : ndarray, optional
            The directions the integrator's own root finding reports at
            ``t_end`` (then the step ended at the root).

        Returns
        -------
        (float, ndarray) or None
            The event's time and the indices of the contacts whose state
            changes there.

        Raises
        ------
        Refused
            If a touching contact's normal reversed within the step.
        """
        delta, rate, normal, *rows = _states(self.system, t_end, *self.layout.split(y_end))
        h = t_end - t_start
        if root is not None and np.any(root != 0):
            return t_end, np.flatnonzero(root != 0)
        through = self._through(rows[1])
        if len(through):
            self.n_refused += 1
            i = through[0]
            raise Refused(f"contact {self.names[i]!r}: its normal reversed within a step of {h:.3g} s at "
                          f"t = {t_start:.9g} s, {delta[i]:.4g} m deep (the body passed through the other)")
        s0, s1 = self._switch(self.delta), self._switch(delta)
        sign = np.where(self.touching, -1.0, 1.0)  # the switch's rate is the penetration's, or minus it
        candidates = {i: t_end for i in np.flatnonzero(s1 > 0)}
        for i in np.flatnonzero(s1 <= 0):  # two ends short of the switch: past it in between?
            for f in _crossing_guesses(s0[i], s1[i], h * sign[i] * self.rate[i], h * sign[i] * rate[i]):
                tm = t_start + f * h
                if self._switch(self.gaps(tm, dense(tm)))[i] > 0:
                    candidates[i] = tm
                    break
        if candidates:
            from scipy.optimize import brentq  # here, not at import: import flexmb leaves scipy.optimize out

            tol = EVENT_TOL * max(abs(t_end), 1.0)
            roots = {}
            for i, tb in candidates.items():
                g = lambda t, i=i: self._switch(self.gaps(t, dense(t)))[i]  # noqa: E731
                ga, gb = g(t_start), (s1[i] if tb == t_end else g(tb))
                # past the switch from the step's start (a restart on the far side of a root): it is there
                roots[i] = (t_start if ga >= 0 or not gb > 0
                            else brentq(g, t_start, tb, xtol=tol, rtol=4 * np.finfo(float).eps))
            t_e = min(roots.values())
            return t_e, np.array(sorted(i for i, r in roots.items() if r <= t_e + tol))
        self._count(h, bool(np.any(self.touching)))
        self.delta, self.rate, self.normal, self.rows = delta, rate, normal, rows
        return None

    def _through(self, normal):
        """The touching contacts one of whose touching rows has its normal reversed at the step's end (``normal``).

        Row by row: a contact of several rows (a capsule's ends, a group's
        pairs) has rows whose normals differ (a ball between a beam and a
        plane), and its deepest row can change within a step.
        """
        delta, before, owner = self.rows
        touching = self.touching[owner] & (delta > -self.band[owner])
        reversed_ = touching & (np.einsum("ij,ij->i", before, normal) < 0)
        return np.unique(owner[reversed_])

    def confirm(self, t_start, t, y, changed) -> None:
        """Record the events of the contacts ``changed`` at ``t``, with the true state ``y`` there.

        The state comes from the step taken again up to the event, which
        can leave a contact a little short of its switch (by the
        integration error): its band then widens to twice that, so that
        its new state holds until the penetration really turns back.

        Parameters
        ----------
        t_start : float
            The start of the step the event was found in, s.
        t : float
            The event's time, s.
        y : ndarray
            The true state at ``t``.
        changed : ndarray of int
            The contacts whose state changes.
        """
        delta, rate, normal, *rows = _states(self.system, t, *self.layout.split(y))
        self._count(t - t_start, bool(np.any(self.touching)))
        self._record(t, changed, rate)
        short = np.where(self.touching, -delta, delta)[changed]  # > 0: on the side it left
        self.band[changed] = np.maximum(ROOT_OFFSET, 2 * short)
        self.delta, self.rate, self.normal, self.rows = delta, rate, normal, rows

    def _record(self, t, changed, rate):
        """Flip the states of the contacts ``changed`` at ``t``, record their events with the rates there.

        A contact holds the rate at its onset as its impact speed until
        its separation (:mod:`flexmb.impact_speeds`).
        """
        self.steps_on, self.time_on = 0, 0.0  # a new stretch of the contacts' states begins
        for i in changed:
            self.touching[i] = not self.touching[i]
            self.events.append((float(t), self.names[i], "onset" if self.touching[i] else "separation",
                                float(rate[i])))
            if self.touching[i]:
                self.held.hold(self.names[i], float(rate[i]))
            else:
                self.held.release(self.names[i])

    def _count(self, h, on):
        """Count a step of ``h`` s in contact (``on``) or off it; give the notice on tiny steps once.

        The steps in contact are those since the last event: an impact
        resolved in a few hundred steps is accuracy, a contact held over
        thousands of tiny steps is the contact's stiffness.
        """
        if on:
            self.steps_on += 1
            self.time_on += h
        else:
            self.steps_off += 1
            self.time_off += h
        if self.warned or self.steps_on <= CONTACT_STEP_LIMIT:
            return
        h_on = self.time_on / self.steps_on
        # off contact: the steps taken there, or, with too few of them, a hundredth of the span
        h_off = self.time_off / self.steps_off if self.steps_off >= 10 else (self.t_end - self.t0) / 100
        if h_on > TINY_STEP_RATIO * h_off:
            return
        self.warned = True
        touching = [nm for nm, on in zip(self.names, self.touching) if on] or self.names
        remedy = ("use an implicit method (method='CVODE_BDF' or 'Radau'): a resting, sliding or rolling contact "
                  "is stiff, and an explicit method is held to its stability bound; or " if self.explicit else "")
        warnings.warn(StiffnessWarning(
            f"contact stiffness forces tiny steps on {self.name}: {self.steps_on} steps while "
            f"{', '.join(repr(n) for n in touching[:3])} touched, of {h_on:.3g} s on average against {h_off:.3g} s "
            f"off contact; {remedy}soften the normal law (a Hertz contact's duration grows as K^(-2/5)) or damp "
            "it, or, where the contact only has to hold, use flexmb.generalized_alpha with a step floor, which "
            "dissipates the contact's vibration"), stacklevel=2)


def _crossing_guesses(g0, g1, m0, m1):
    """Fractions of a step where a function short of zero at both ends may rise above it in between.

    From the values ``g0, g1 <= 0`` and the rates times the step ``m0, m1``
    at the ends: the maximum of the cubic Hermite through them, and the
    meeting of the two end tangents (exact for the kink of a point passing
    a sphere's centre), each where it lies above 0.

    Returns
    -------
    list of float
        The fractions in (0, 1), best first (none: no crossing predicted).
    """
    guesses = []
    # p(s) = a s^3 + b s^2 + m0 s + g0
    a = 2 * g0 - 2 * g1 + m0 + m1
    b = -3 * g0 + 3 * g1 - 2 * m0 - m1
    roots = np.roots([3 * a, 2 * b, m0]) if (a or b) else np.array([])
    for s in roots:
        if abs(s.imag) < 1e-12 and 0 < s.real < 1:
            s = s.real
            p = ((a * s + b) * s + m0) * s + g0
            if p > 0:
                guesses.append((p, s))
    if m0 > 0 > m1:  # the tangents meet above both ends
        s = (g1 - m1 - g0) / (m0 - m1)
        if 0 < s < 1 and g0 + m0 * s > 0:
            guesses.append((g0 + m0 * s, s))
    return [s for _, s in sorted(guesses, reverse=True)]
