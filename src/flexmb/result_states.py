"""What a :class:`~flexmb.Result` holds at each output state besides the state.

The accelerations (or, given them, the reactions), the bodies' mass
centres, origins and rotations, the kinetic and potential energies, the
constraint residuals and the reactions, evaluated once per output state
when the result is made (:meth:`flexmb.Result.from_states`).
"""

from __future__ import annotations

import numpy as np

from .errors import FlexmbError
from .impact_speeds import replaying

__all__ = ["evaluate_states"]


def evaluate_states(system, t, X, XD, XDD, events=None) -> dict:
    """The output quantities of :meth:`flexmb.Result.from_states` at each state.

    Parameters
    ----------
    system : System
        The model.
    t : ndarray, shape (nt,)
        The output times, s.
    X, XD : ndarray, shape (nt, n)
        The coordinates and speeds (checked by the caller).
    XDD : ndarray, shape (nt, n), or None
        The accelerations, or None to compute them.
    events : list, optional
        The run's contact events: the impact speeds held as the run held
        them (:mod:`flexmb.impact_speeds`).

    Returns
    -------
    dict
        ``xdd``, ``positions``, ``origins``, ``rotations``, ``kinetic``,
        ``potential``, ``residual``, ``velocity_residual``, ``reactions``:
        :class:`~flexmb.Result`'s arrays of those names.
    """
    nt, n = XD.shape
    nb, m = system.topology.n_bodies, system.n_constraints
    out = {"xdd": np.zeros((nt, n)) if XDD is None else XDD.copy(), "positions": np.zeros((nt, nb, 3)),
           "origins": np.zeros((nt, nb, 3)), "rotations": np.zeros((nt, nb, 3, 3)), "kinetic": np.zeros(nt),
           "potential": np.zeros(nt), "residual": np.zeros(nt), "velocity_residual": np.zeros(nt),
           "reactions": np.zeros((nt, m))}
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
