"""The Result's quantities at many states of an open tree whose loads are all compiled, in one call.

:func:`tree_state_quantities` evaluates at each state what
:meth:`flexmb.Result.from_states` stores of an open tree
(``flexmb.output_quantities``): the bodies' positions, frame origins and
rotations, the kinetic energy and the accelerations, with the kernels the
system's own routes call at one state (``tree_kinematics`` as
``Kinematics``, on the packed model's tree arrays, :func:`~flexmb.kernels.articulated.open_tree_rhs_into` as
``System._accelerations``), one work array for all states.
"""

from __future__ import annotations

import numpy as np

from .articulated import open_tree_rhs_into, rhs_work_size
from .cache import njit
from .dynamics import spatial_inertias
from .packing import unpack
from .tree import tree_state

__all__ = ["tree_state_quantities"]


@njit(cache=True)
def _kinetic(mass, v, omega, Iw):
    """``sum m v^2 / 2 + omega . I omega / 2`` of the bodies (``Kinematics.kinetic_energy``)."""
    translation = rotation = 0.0
    for k in range(mass.shape[0]):
        translation += mass[k] * (v[k, 0] ** 2 + v[k, 1] ** 2 + v[k, 2] ** 2)
        for j in range(3):
            rotation += omega[k, j] * (Iw[k, j, 0] * omega[k, 0] + Iw[k, j, 1] * omega[k, 1]
                                       + Iw[k, j, 2] * omega[k, 2])
    return 0.5 * translation + 0.5 * rotation


@njit(cache=True)
def tree_state_quantities(packed, X, XD, armature, solve, out, kinetic, status):
    """The Result's quantities at the states ``(X[i], XD[i])`` of an open tree.

    Parameters
    ----------
    packed : tuple
        The system's packed model (``System._packed_open``: the tree, its bodies' data, the loads).
    X, XD : ndarray, shape (nt, nq) and (nt, n)
        Coordinates and speeds.
    armature : ndarray, shape (n,)
        Zeros (the equations of motion's).
    solve : bool
        Whether to solve for the accelerations (else ``xdd`` is left alone).
    out : tuple of ndarray
        Filled: positions, origins (nt, nb, 3), rotations (nt, nb, 3, 3),
        xdd (nt, n); ``kinetic`` (nt,); ``status`` (nt,) the right-hand
        side's status at each state (-1: finite accelerations; else, as
        :func:`~flexmb.kernels.articulated.open_tree_rhs`, a failure left to
        the system's route, which names it).
    """
    positions, origins, rotations, xdd = out
    tree = unpack(packed)[0]
    mass, inertia = tree.mass, tree.inertia
    nt, nq = X.shape
    n = XD.shape[1]
    nb = mass.shape[0]
    y, ydot, work = np.empty(nq + n), np.empty(nq + n), np.empty(rhs_work_size(nb, n))
    for i in range(nt):
        x, xd = X[i], XD[i]
        R, origin, r, omega, v = tree_state(tree, x, xd)[:5]
        positions[i] = r[:-1]
        origins[i] = origin[:-1]
        rotations[i] = R[:-1]
        kinetic[i] = _kinetic(mass, v, omega, spatial_inertias(R, r, mass, inertia)[0])
        if solve:
            y[:nq] = x
            y[nq:] = xd
            status[i] = open_tree_rhs_into(packed, y, nq, armature, ydot, work)
            xdd[i] = ydot[nq:]
