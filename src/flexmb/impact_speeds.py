"""The impact speeds contacts hold from their onsets: what the restitution laws divide the rate by.

The Lankarani-Nikravesh and Flores laws (:mod:`flexmb.forces.contact_laws`)
write ``F = K delta^n (1 + chi delta_dot / v_in)``, v_in the approach speed
at the first touch of the current impact (the references of
:mod:`flexmb.forces.contact`). A run with contact events
(:mod:`flexmb.contact_events`) records that speed at each onset, as the
rate of penetration there; a contact of one pair of surfaces (one row of
the load tables: a sphere on a plane or on a sphere, a capsule on a sphere
or on a capsule, a journal) holds it from its onset to its separation, in
column 4 of its row of ``contact_par``, which the compiled kernels read
(:func:`flexmb.kernels.contact.normal_force`). Where none is held (0) the
law takes v_in from the contact's state, the speed that brings its
effective mass under the law alone to the current penetration and rate
(:func:`flexmb.kernels.contact.impact_speed`): in a run without events, for
a contact already touching when the run starts, and for the rows of a
capsule on a plane or of a contact group, whose touches are not events of
their own (their element's event is its deepest row's).

A result keeps its events, so the speeds held at each output are replayed
from them (:meth:`HeldSpeeds.replay`): an event counts for the outputs
after its time (the run stores the outputs up to an event before it
records it).
"""

from __future__ import annotations

import contextlib
import sys

import numpy as np

__all__ = ["HeldSpeeds", "held_speed", "replaying"]


def _contact_groups(system):
    """The system's contact force groups, ``[(class, elements), ...]``.

    Every contact element subclasses :class:`flexmb.forces.contact_base.Contact`: where that module
    was never imported the system has none, and nothing is imported to say so (a run of a model
    without contact does not import the contact modules and their kernels).

    Parameters
    ----------
    system : System
        The compiled model.

    Returns
    -------
    list of tuple
        The contact classes and their elements, in the system's order.
    """
    base = sys.modules.get("flexmb.forces.contact_base")
    if base is None:
        return []
    return [(cls, list(elements)) for cls, elements in system.forces.groups if issubclass(cls, base.Contact)]


class HeldSpeeds:
    """The impact speeds the restitution-law contacts of a system hold, written where the kernels read them.

    One per system (:meth:`of`), shared with its calibrated copies (they
    share its tables). Outside a run every contact holds none (0): a
    run sets them at its events (:class:`flexmb.contact_events.ContactEvents`)
    and clears them when it ends; :meth:`replay` sets those of an output of
    a result.

    Parameters
    ----------
    system : System
        The compiled model.

    Attributes
    ----------
    rows : dict of str to int
        For each contact element of one row with a restitution law, its
        row among the system's contact rows (the order of the contact
        classes in ``system.forces.groups``, then of their tables).
    values : ndarray, shape (c,)
        The speed each contact row holds, m/s (0: none).
    """

    def __init__(self, system):
        from .forces.tables import class_tables
        from .kernels.contact import RESTITUTION

        topology = system.topology
        self.rows: dict = {}
        self._targets = []  # (the class tables' column 4, their held rows, those rows among all)
        offset = 0
        for cls, elements in _contact_groups(system):
            tables = class_tables(cls, elements, topology)
            owner = cls._owners(elements, topology)
            local = []
            for k, element in enumerate(elements):
                mine = np.flatnonzero(owner == k)
                if len(mine) == 1 and tables.contact_laws[mine[0], 1] == RESTITUTION:
                    self.rows[element.name] = offset + int(mine[0])
                    local.append(int(mine[0]))
            self._targets.append((tables.contact_par[:, 4], np.array(local, dtype=np.int64),
                                  offset + np.array(local, dtype=np.int64)))
            offset += len(owner)
        self.values = np.zeros(offset)
        held = np.array(sorted(self.rows.values()), dtype=np.int64)
        packed = _packed_column(system._packed, offset)  # the compiled right-hand side's
        if packed is not None:
            self._targets.append((packed, held, held))

    @classmethod
    def of(cls, system) -> "HeldSpeeds":
        """The system's held speeds (built on first use).

        Parameters
        ----------
        system : System
            The compiled model.

        Returns
        -------
        HeldSpeeds
        """
        shared = system._shared
        if "held speeds" not in shared:
            shared["held speeds"] = cls(system)
        return shared["held speeds"]

    def hold(self, name: str, speed: float) -> None:
        """Hold ``speed`` for the contact ``name`` (nothing for a contact without a held speed).

        Parameters
        ----------
        name : str
            The contact element's name.
        speed : float
            Its impact speed, m/s (> 0; else none is held).
        """
        row = self.rows.get(name)
        if row is not None:
            self.values[row] = speed if speed > 0.0 else 0.0
            self._write()

    def release(self, name: str | None = None) -> None:
        """Hold none for the contact ``name``, or for every contact.

        Parameters
        ----------
        name : str, optional
            The contact element's name (default: all).
        """
        if name is None:
            self.values[:] = 0.0
        elif name in self.rows:
            self.values[self.rows[name]] = 0.0
        else:
            return
        self._write()

    def replay(self, events, t: float) -> None:
        """Hold what a run held at the output time ``t``, from its events.

        Parameters
        ----------
        events : sequence of (float, str, str, float)
            The run's contact events (``Result.contact_events``), in time order.
        t : float
            The output time, s.
        """
        self.values[:] = 0.0
        for name, row in self.rows.items():
            self.values[row] = held_speed(events, name, t)
        self._write()

    def at(self, events, name: str, t: float) -> float:
        """The speed the contact ``name`` held at the output time ``t`` of a run with ``events``.

        Parameters
        ----------
        events : sequence of (float, str, str, float)
            The run's contact events.
        name : str
            The contact element's name.
        t : float
            The output time, s.

        Returns
        -------
        float
            m/s (0: none; always for a contact that holds none, see the module docstring).
        """
        return held_speed(events, name, t) if name in self.rows else 0.0

    def _write(self):
        """Copy the held rows' speeds where the kernels read them (the other rows' column 4 is left alone)."""
        for column, rows, among in self._targets:
            column[rows] = self.values[among]


def held_speed(events, name: str, t: float) -> float:
    """The impact speed a contact held at the output time ``t`` of a run, from the run's events.

    The rate of its last onset before ``t``, unless it separated since
    (also before ``t``); else 0 (none held).

    Parameters
    ----------
    events : sequence of (float, str, str, float)
        ``Result.contact_events``, in time order.
    name : str
        The contact element's name.
    t : float
        The output time, s.

    Returns
    -------
    float
        m/s (0: none).

    Examples
    --------
    >>> events = [(0.1, "floor", "onset", 2.0), (0.2, "floor", "separation", -1.5)]
    >>> [held_speed(events, "floor", t) for t in (0.1, 0.15, 0.2, 0.3)]
    [0.0, 2.0, 2.0, 0.0]
    """
    speed = 0.0
    for time, who, kind, rate in events:
        if time >= t:
            break
        if who == name:
            speed = max(rate, 0.0) if kind == "onset" else 0.0
    return speed


@contextlib.contextmanager
def replaying(system, events, times):
    """``hold(i)``: the contacts of ``system`` hold what a run with ``events`` held at ``times[i]``; none after.

    Parameters
    ----------
    system : System
        The compiled model.
    events : sequence of (float, str, str, float) or None
        The run's contact events (none: nothing is held, ``hold`` does nothing).
    times : ndarray
        The output times, s.

    Yields
    ------
    callable
        ``hold(i)``, to call before the evaluation of output i.
    """
    if not events:
        yield lambda i: None
        return
    held = HeldSpeeds.of(system)
    try:
        yield lambda i: held.replay(events, times[i])
    finally:
        held.release()


def _packed_column(packed, rows):
    """Column 4 of ``contact_par`` in a system's packed buffers (a view), or None without them."""
    if packed is None:
        return None
    from .kernels.loads import LoadTables
    from .kernels.packing import N_TREE

    floats, _, _, index = packed
    k = N_TREE + LoadTables._fields.index("contact_par")
    start, n, m = (int(v) for v in index[k, :3])
    if n != rows:
        raise RuntimeError(f"HeldSpeeds: the packed tables have {n} contact rows, the contact classes {rows}")
    return floats[start : start + n * m].reshape(n, m)[:, 4]
