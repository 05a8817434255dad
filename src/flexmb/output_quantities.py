"""The quantities :meth:`flexmb.Result.from_states` stores at each state: positions, energies, residuals, reactions.

:func:`evaluate_states` evaluates them state by state through the
system's routes; for a model whose loops the articulated strategy closes
and whose loads are all compiled, one compiled call evaluates all but the
potential energy at all states
(:func:`flexmb.kernels.loop_states.loop_state_quantities`, the same
kernels on the same numbers); for an open tree whose loads are all
compiled (``System._packed_open``), one compiled call
(:func:`flexmb.kernels.tree_states.tree_state_quantities`) does the same.
There, the potential energy of each state is the force elements' own
(``potential_states`` of all states at once, from the coordinates and the
mass centres, where every class has it, else ``ForceSet.potential_energy``
state by state), and the reactions of a state with redundant rows are the
system's (its minimum-norm ones).
"""

from __future__ import annotations

import numpy as np

from .errors import FlexmbError
from .impact_speeds import replaying

__all__ = ["evaluate_states"]


def evaluate_states(system, t, X, XD, XDD, events=None) -> dict:
    """The output quantities of :meth:`Result.from_states` at each state (with the impact speeds ``events`` held).

    Parameters
    ----------
    system : System
        The model.
    t : ndarray, shape (nt,)
        The states' times, s.
    X, XD : ndarray, shape (nt, nq) and (nt, n)
        The checked states.
    XDD : ndarray, shape (nt, n) or None
        Given accelerations (None: solved, with the reactions).
    events : sequence, optional
        The run's contact events (their impact speeds held at the output times).

    Returns
    -------
    dict
        ``xdd``, ``positions``, ``origins``, ``rotations``, ``kinetic``,
        ``potential``, ``residual``, ``velocity_residual``, ``reactions``.
    """
    nt, n = XD.shape
    nb, m = system.topology.n_bodies, system.n_constraints
    out = {"xdd": np.zeros((nt, n)) if XDD is None else XDD.copy(), "positions": np.zeros((nt, nb, 3)),
           "origins": np.zeros((nt, nb, 3)), "rotations": np.zeros((nt, nb, 3, 3)), "kinetic": np.zeros(nt),
           "potential": np.zeros(nt), "residual": np.zeros(nt), "velocity_residual": np.zeros(nt),
           "reactions": np.zeros((nt, m))}
    if m and XDD is None and not events and _compiled(system):
        return _evaluate_loops(system, t, X, XD, out)
    if m == 0 and not events and _tree_compiled(system):
        return _evaluate_tree(system, t, X, XD, XDD, out)
    with replaying(system, events, t) as hold:  # what the run held (flexmb.impact_speeds)
        for i in range(nt):
            hold(i)
            x, xd = X[i], XD[i]
            kin = system._kinematics(t[i], x, xd)  # the states were checked once (from_states)
            try:
                if XDD is not None:
                    out["reactions"][i] = system.reactions(t[i], x, xd, XDD[i]) if m else 0.0
                elif m == 0:  # no reactions: the system's own route (O(n) for an open tree)
                    out["xdd"][i] = system._accelerations(t[i], x, xd)
                else:
                    out["xdd"][i], out["reactions"][i] = system._with_reactions(t[i], system.layout.join(x, xd))
            except FlexmbError:
                if XDD is None:
                    out["xdd"][i] = np.nan
                out["reactions"][i] = np.nan
            out["positions"][i] = kin.r[:-1]
            out["origins"][i] = kin.origin[:-1]
            out["rotations"][i] = kin.R[:-1]
            out["kinetic"][i] = kin.kinetic_energy()
            out["potential"][i] = system.forces.potential_energy(kin)
            if m:
                out["residual"][i], out["velocity_residual"][i] = system._constraint_residuals(t[i], x, xd)
    return out


def _compiled(system) -> bool:
    """Whether :func:`_evaluate_loops` applies: loops by the loop kernels, loads and joints all compiled, ``qd = u``."""
    return bool(system._loop_kernel and not system._python_groups and not system.topology.external_groups
                and not system.constraints.elements and system.layout.identity)


def _evaluate_loops(system, t, X, XD, out) -> dict:
    """:func:`evaluate_states` by :func:`~flexmb.kernels.loop_states.loop_state_quantities` (see the module docstring)."""
    from .kernels.loop_states import loop_state_quantities

    topo, nt = system.topology, len(t)
    drivers, cols = system.constraints.drivers, np.array(system.constraints.driver_cols, dtype=np.int64)
    P, V, G = (np.array([[getattr(d, what)(ti) for d in drivers] for ti in t], dtype=float).reshape(nt, len(drivers))
               for what in ("position", "velocity", "acceleration"))
    X, XD = np.ascontiguousarray(X, dtype=float), np.ascontiguousarray(XD, dtype=float)
    tree = (topo.parent, topo.coord_start, topo.coord_kind, topo.coord_axis, topo.external, topo.parent_frame,
            topo.child_frame, topo.lever, topo.child_point, topo.com)
    redundant = np.zeros(nt, dtype=np.bool_)
    loop_state_quantities(system._packed, system._loop_layout, tree, topo.mass, topo.inertia, X, XD, cols, P, V, G,
                          system._loop_tol, system.singular_window(),
                          -1 if system._rank_limit is None else system._rank_limit,
                          (out["positions"], out["origins"], out["rotations"], out["residual"],
                           out["velocity_residual"], out["xdd"], out["reactions"]), out["kinetic"], redundant)
    system.n_complements += nt  # one loop solve each (System._loop_solve's count)
    for i in np.flatnonzero(redundant):  # the minimum-norm reactions, as the system's route gives them
        system.n_complements -= 1
        out["xdd"][i], out["reactions"][i] = system._with_reactions(t[i], system.layout.join(X[i], XD[i]))
    return _potential(system, t, X, XD, out)


def _tree_compiled(system) -> bool:
    """Whether :func:`_evaluate_tree` applies: an open tree whose joints and loads are all compiled."""
    return system._packed_open is not None


def _evaluate_tree(system, t, X, XD, XDD, out) -> dict:
    """:func:`evaluate_states` of an open tree by :func:`~flexmb.kernels.tree_states.tree_state_quantities`.

    A state whose accelerations fail is evaluated again by the system's
    route (which names the failure: its accelerations then NaN).
    """
    from .kernels.tree_states import tree_state_quantities

    X, XD = np.ascontiguousarray(X, dtype=float), np.ascontiguousarray(XD, dtype=float)
    status = np.full(len(t), -1, dtype=np.int64)
    tree_state_quantities(system._packed_open, X, XD, system._no_armature, XDD is None, (out["positions"], out["origins"], out["rotations"], out["xdd"]),
                          out["kinetic"], status)
    for i in np.flatnonzero(status != -1):
        try:
            out["xdd"][i] = system._accelerations(t[i], X[i], XD[i])
        except FlexmbError:
            out["xdd"][i] = np.nan
    return _potential(system, t, X, XD, out)


def _potential(system, t, X, XD, out) -> dict:
    """``out["potential"]``: each class's ``potential_states`` where all have it, else state by state."""
    topo = system.topology
    parts = [cls.potential_states(elements, topo, X, positions=out["positions"])
             for cls, elements in system.forces.groups]
    if all(p is not None for p in parts):  # in one call per class
        for p in parts:
            out["potential"] += p
        return out
    for i in range(len(t)):
        out["potential"][i] = system.forces.potential_energy(system._kinematics(t[i], X[i], XD[i]))
    return out
