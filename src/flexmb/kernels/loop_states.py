"""The Result's quantities at many states of a model with loops closed by the articulated strategy, in one call.

:func:`loop_state_quantities` evaluates at each state what
:meth:`flexmb.Result.from_states` stores (``flexmb.output_quantities``):
the bodies' positions, frame origins and rotations, the kinetic energy,
the constraint residuals, the accelerations and the reactions, with the
kernels the system's own routes call at one state (``tree_kinematics`` as
``Kinematics``, ``tree_equations(..., RESIDUALS)`` as
``System._constraint_residuals``, :func:`~flexmb.kernels.loops.loop_rhs`
as ``System._with_reactions``), for models whose loads are all compiled.
"""

from __future__ import annotations

import numpy as np

from .cache import njit
from .dynamics import spatial_inertias
from .equations import RESIDUALS, tree_equations
from .loops import loop_rhs
from .tree import tree_kinematics
from .tree_states import _kinetic

__all__ = ["loop_state_quantities"]


@njit(cache=True)
def loop_state_quantities(packed, layout, tree, mass, inertia, X, XD, cols, P, V, G, tol, window, rank_limit, out,
                          kinetic, redundant):
    """The Result's quantities at the states ``(X[i], XD[i])``.

    Parameters
    ----------
    packed, layout
        The system's packed model and loop layout (``System._packed``, ``System._loop_layout``).
    tree : tuple
        ``Kinematics``' arguments of :func:`~flexmb.kernels.tree.tree_kinematics`
        before ``x`` (the topology's ten arrays).
    mass, inertia : ndarray
        The bodies' masses and central inertias (body frames).
    X, XD : ndarray, shape (nt, n)
        Coordinates and speeds (``qd = u``).
    cols : ndarray of int64
        The drivers' columns; ``P``, ``V``, ``G`` (nt, n_drivers) their
        positions, speeds and accelerations at each state's time.
    tol, window, rank_limit
        The loops' rank tolerance, singular window and rank limit (-1: none).
    out : tuple of ndarray
        Filled: positions, origins (nt, nb, 3), rotations (nt, nb, 3, 3),
        residual, velocity_residual (nt,), xdd (nt, n), reactions (nt, m);
        ``kinetic`` (nt,); ``redundant`` (nt,) True where the rows are
        redundant (the reactions then the minimum-norm ones, left to the
        system's route). Accelerations and reactions NaN where the solve fails.
    """
    positions, origins, rotations, residual, velocity_residual, xdd, reactions = out
    nt, n = X.shape
    nb = mass.shape[0]
    ext = (np.empty((0, 3, 3)), np.empty((0, 3)), np.empty((0, 3)), np.empty((0, 3)), np.empty((0, 3)),
           np.empty((0, 3)))
    no_powers, zeros, generalized = np.zeros(0), np.zeros((nb + 1, 3)), np.zeros(n)
    y = np.empty(2 * n)
    for i in range(nt):
        x, xd = X[i], XD[i]
        R, origin, r, omega, v = tree_kinematics(*tree, x, xd, *ext)[:5]
        positions[i] = r[:-1]
        origins[i] = origin[:-1]
        rotations[i] = R[:-1]
        kinetic[i] = _kinetic(mass, v, omega, spatial_inertias(R, r, mass, inertia)[0])
        y[:n] = x
        y[n:] = xd
        position, velocity = tree_equations(packed, y, n, RESIDUALS, no_powers, zeros, zeros, generalized)[2][:2]
        for k in range(cols.shape[0]):
            position = max(position, abs(x[cols[k]] - P[i, k]))
            velocity = max(velocity, abs(xd[cols[k]] - V[i, k]))
        residual[i], velocity_residual[i] = position, velocity
        a, lam, kept, _, status = loop_rhs(packed, layout, y, n, no_powers, zeros, zeros, generalized, G[i], tol,
                                           window, rank_limit)
        if status:
            xdd[i] = np.nan
            reactions[i] = np.nan
        else:
            xdd[i] = a
            reactions[i] = lam
            redundant[i] = kept < lam.shape[0]
