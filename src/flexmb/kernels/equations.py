"""All the pieces of the equations of motion at one state, in one compiled call (eqs. 1-5, 28-29).

For a model with loops (or a run that integrates the work of each class of
force elements) the reduced equations need the mass matrix A, the force
array f and the cut joints' rows of psi and gamma: the tree's kinematics
(:func:`~flexmb.kernels.tree.tree_kinematics`), the compiled force
elements (:func:`~flexmb.kernels.loads.apply_load_tables`), the composite
inertias and :func:`~flexmb.kernels.dynamics.mass_matrix`, the bias
wrenches projected on the axes, and
:func:`~flexmb.kernels.constraints.cut_rows`, fused so that an evaluation
crosses from Python into compiled code once.
"""

from __future__ import annotations

import numpy as np
from numba.extending import register_jitable

from .cache import njit

from .constraints import cut_row_wrenches, cut_rows
from .dynamics import bias_wrenches_into, composite_inertias, generalized_force, mass_matrix, spatial_inertias_into
from .loads import apply_load_tables
from .packing import unpack
from .tree import kinematics_work_size, tree_kinematics_into, tree_state
from .views import view2, view3

__all__ = ["loaded_state", "loaded_state_into", "loaded_state_views", "loaded_state_work_size", "tree_equations", "RESIDUALS", "ROWS", "EQUATIONS"]


@njit(cache=True)
def loaded_state(packed, y, nq, powers, force0, torque0, generalized0):
    """The tree's kinematics, spatial inertias and loads at ``y = (x, xd, ...)``: what eq. 3 is made of.

    Parameters
    ----------
    packed : tuple
        The model's constant arrays (:func:`~flexmb.kernels.packing.pack`).
    y : ndarray, shape (>= nq + n,)
        Coordinates and speeds first (:mod:`flexmb.state_layout`; n, the
        number of speeds, is the tree's).
    nq : int
        Number of coordinates.
    powers : ndarray, shape (n_groups,) or (0,)
        If not empty, the power of each compiled force-element class is
        added to its entry.
    force0, torque0 : ndarray, shape (n_bodies + 1, 3)
        Loads of the force elements evaluated in Python (not modified).
    generalized0 : ndarray, shape (n,)
        Their generalized forces on the speeds.

    Returns
    -------
    tree : TreeArrays
        The tree's layout and body data.
    cuts : tuple of ndarray
        The cut joints' rows.
    kin : tuple
        What :func:`~flexmb.kernels.tree.tree_kinematics` returns.
    spatial : ndarray, shape (n_bodies, 6, 6)
        Spatial inertias about the origin.
    fw, tw : ndarray, shape (n_bodies + 1, 3)
        The applied loads minus the velocity-dependent inertia forces
        (:func:`~flexmb.kernels.dynamics.bias_wrenches`).
    generalized : ndarray, shape (n,)
        Generalized forces applied on the coordinates.
    """
    nb = packed[3][0, 1]  # the parents' count: the number of bodies
    work = np.empty(loaded_state_work_size(nb, generalized0.shape[0]))
    return loaded_state_into(packed, y, nq, powers, force0, torque0, generalized0, work)


@register_jitable
def loaded_state_work_size(nb, n):
    """Length of the work array :func:`loaded_state_into` needs.

    Parameters
    ----------
    nb, n : int
        Numbers of bodies and of speeds.

    Returns
    -------
    int
        The length.
    """
    return 36 * (nb + 1) + 51 * nb + 7 * n + kinematics_work_size(nb, n)


@njit(cache=True, inline="always")
def loaded_state_views(nb, n, work):
    """The arrays :func:`loaded_state_into` fills, as views of its work array (one layout for both).

    Parameters
    ----------
    nb, n : int
        Numbers of bodies and of speeds.
    work : ndarray, shape (>= loaded_state_work_size(nb, n),)
        The work array.

    Returns
    -------
    tuple
        ``R`` (nb + 1, 3, 3); ``kin`` (7, nb + 1, 3): origin, r, omega, v,
        alpha, acc, jp; ``Sw``, ``Sv`` (n, 3); the kinematics' scratch;
        ``force``, ``torque`` (nb + 1, 3); ``generalized`` (n); ``Iw`` (nb,
        3, 3); ``spatial`` (nb, 6, 6); ``fw``, ``tw`` (nb, 3).
    """
    R = view3(work, 0, nb + 1, 3, 3)
    o = 9 * (nb + 1)
    kin = view3(work, o, 7, nb + 1, 3)
    o += 21 * (nb + 1)
    Sw, Sv = view2(work, o, n, 3), view2(work, o + 3 * n, n, 3)
    o += 6 * n
    k = kinematics_work_size(nb, n)
    scratch = work[o : o + k]
    o += k
    force, torque = view2(work, o, nb + 1, 3), view2(work, o + 3 * (nb + 1), nb + 1, 3)
    generalized = work[o + 6 * (nb + 1) : o + 6 * (nb + 1) + n]
    o += 6 * (nb + 1) + n
    Iw, spatial = view3(work, o, nb, 3, 3), view3(work, o + 9 * nb, nb, 6, 6)
    fw, tw = view2(work, o + 45 * nb, nb, 3), view2(work, o + 48 * nb, nb, 3)
    return R, kin, Sw, Sv, scratch, force, torque, generalized, Iw, spatial, fw, tw


@njit(cache=True)
def loaded_state_into(packed, y, nq, powers, force0, torque0, generalized0, work):
    """:func:`loaded_state` with every array a view of ``work``: nothing allocated (the loops' CVODE callback).

    Parameters
    ----------
    packed, y, nq, powers, force0, torque0, generalized0
        As :func:`loaded_state`.
    work : ndarray, shape (>= loaded_state_work_size(n_bodies, n),)
        Scratch (its contents on entry are not read); the returned arrays
        are views of it, valid until it is written again.

    Returns
    -------
    tuple
        What :func:`loaded_state` returns.
    """
    tree, tables, cuts = unpack(packed)
    n = generalized0.shape[0]
    nb = tree.parent.shape[0]
    x = y[:nq]
    xd = y[nq : nq + n]
    R, kin, Sw, Sv, scratch, force, torque, generalized, Iw, spatial, fw, tw = loaded_state_views(nb, n, work)
    empty3 = view2(work, 0, 0, 3)
    tree_kinematics_into(tree.parent, tree.coord_start, tree.coord_kind, tree.coord_axis, tree.external,
                         tree.parent_frame, tree.child_frame, tree.lever, tree.child_point, tree.com, x, xd,
                         view3(work, 0, 0, 3, 3), empty3, empty3, empty3, empty3, empty3, R, kin[0], kin[1],
                         kin[2], kin[3], kin[4], kin[5], kin[6], Sw, Sv, scratch)
    origin, r, omega, v, alpha, acc = kin[0], kin[1], kin[2], kin[3], kin[4], kin[5]
    force[:] = force0
    torque[:] = torque0
    generalized[:] = generalized0
    apply_load_tables(tables, tree.mass, R, origin, r, omega, v, x, xd, force, torque, generalized, powers)
    spatial_inertias_into(R, r, tree.mass, tree.inertia, Iw, spatial)
    bias_wrenches_into(tree.mass, Iw, omega, alpha, acc, force, torque, fw, tw)
    kin = (R, origin, r, omega, v, alpha, acc, kin[6][:nb], Sw, Sv)
    return tree, cuts, kin, spatial, fw, tw, generalized


#: what :func:`tree_equations` computes: the cut joints' residuals only, their rows, or the whole equations
RESIDUALS, ROWS, EQUATIONS = 0, 1, 2


@njit(cache=True)
def tree_equations(packed, y, nq, what, powers, force0, torque0, generalized0):
    """A, f and the cut joints' rows at the state ``y = (x, xd, ...)``; or only the rows; or only their residuals.

    One entry point for the three, so that the kernels they share (the
    tree's kinematics, the cut rows) compile into one machine-code module
    once, not into one per entry point.

    Parameters
    ----------
    packed : tuple
        The model's constant arrays (:func:`~flexmb.kernels.packing.pack`):
        the tree, the compiled force elements' tables and the cut joints'
        rows (the arguments of :func:`~flexmb.kernels.constraints.cut_rows`
        after ``coord_start``).
    y : ndarray, shape (>= nq + n,)
        Coordinates and speeds first (:mod:`flexmb.state_layout`; n, the
        number of speeds, is the tree's).
    nq : int
        Number of coordinates.
    what : int
        :data:`EQUATIONS`: everything below; :data:`ROWS`: ``phi`` and
        ``psi`` (``A``, ``f``, ``gamma`` empty, the loads not read);
        :data:`RESIDUALS`: ``phi = [position, velocity]``, the largest
        residuals of the cut joints' positions and velocities (``psi_a
        xd`` read from the two bodies' spatial velocities, psi not formed:
        O(n + m); 0 without cut joints), all else empty.
    powers : ndarray, shape (n_groups,) or (0,)
        If not empty, the power of each compiled force-element class is
        added to its entry.
    force0, torque0 : ndarray, shape (n_bodies + 1, 3)
        Loads of the force elements evaluated in Python (plugins), added to
        those of the compiled ones (not modified).
    generalized0 : ndarray, shape (n,)
        Their generalized forces on the speeds.

    Returns
    -------
    A : ndarray, shape (n, n)
        Generalized mass matrix (eq. 2).
    f : ndarray, shape (n,)
        Force array (eq. 3).
    phi, gamma : ndarray, shape (m_cut,)
        The cut joints' residuals and right-hand sides of ``psi xdd = gamma``.
    psi : ndarray, shape (m_cut, n)
        Their rows of the constraint Jacobian (eq. 29; with ``what =
        ROWS`` their b is zero).
    """
    if what == EQUATIONS:
        tree, cuts, kin, spatial, fw, tw, generalized = loaded_state(packed, y, nq, powers, force0, torque0,
                                                                     generalized0)
        n = tree.coord_start[-1]
        R, origin, r, omega, v, alpha, acc, jp, Sw, Sv = kin
        A = mass_matrix(tree.parent, tree.coord_start, tree.coord_body, composite_inertias(tree.parent, spatial),
                        Sw, Sv)
        f = generalized_force(tree.parent, tree.coord_body, r, fw, tw, Sw, Sv) + generalized
        phi, psi, gamma = cut_rows(2, n, R, origin, r, omega, v, alpha, acc, Sw, Sv, tree.parent, tree.coord_start,
                                   *cuts)
        return A, f, phi, psi, gamma
    tree, _, cuts = unpack(packed)
    n = tree.coord_start[-1]
    x = y[:nq]
    xd = y[nq : nq + n]
    R, origin, r, omega, v, alpha, acc, jp, Sw, Sv = tree_state(tree, x, xd)
    if what == ROWS:
        phi, psi, _ = cut_rows(1, n, R, origin, r, omega, v, alpha, acc, Sw, Sv, tree.parent, tree.coord_start,
                               *cuts)
        return np.empty((0, 0)), np.empty(0), phi, psi, np.empty(0)
    return np.empty((0, 0)), np.empty(0), _cut_residuals(R, origin, r, omega, v, alpha, acc, cuts), \
        np.empty((0, 0)), np.empty(0)


@njit(cache=True)
def _cut_residuals(R, origin, r, omega, v, alpha, acc, cuts):
    """``[position, velocity]``: the largest residuals of the cut joints (see :func:`tree_equations`)."""
    phi, W, body, _ = cut_row_wrenches(1, R, origin, r, omega, v, alpha, acc, *cuts)
    position = 0.0
    velocity = 0.0
    for a in range(phi.shape[0]):
        position = max(position, abs(phi[a]))
        s = 0.0
        for side in range(2):
            k = body[a, side]
            if k >= 0:  # the body's spatial velocity: (omega, v - omega x r) about the origin
                w = omega[k]
                s += W[a, side, 0] * w[0] + W[a, side, 1] * w[1] + W[a, side, 2] * w[2]
                s += W[a, side, 3] * (v[k, 0] - (w[1] * r[k, 2] - w[2] * r[k, 1]))
                s += W[a, side, 4] * (v[k, 1] - (w[2] * r[k, 0] - w[0] * r[k, 2]))
                s += W[a, side, 5] * (v[k, 2] - (w[0] * r[k, 1] - w[1] * r[k, 0]))
        velocity = max(velocity, abs(s))
    out = np.empty(2)
    out[0] = position
    out[1] = velocity
    return out
