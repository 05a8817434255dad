"""Accelerations of a tree with loops in O(n m), without forming A, psi or T (eqs. 30-39).

With ``A xdd = f + psi^T lambda`` and ``psi xdd = gamma`` (eqs. 1-3,
28-29), the accelerations are the open tree's plus the response to the
constraint forces:

    xdd = a0 + A^-1 psi^T lambda,    K lambda = gamma - psi a0,
    a0 = A^-1 f,                     K = psi A^-1 psi^T   (m x m).

This is the mass-orthogonal complement projection of eqs. 30-39 written
without T (docs/theory.md, "Loops without the complement"): ``a0`` and
each column of ``A^-1 psi^T`` come from the articulated-body recursion
(:mod:`flexmb.kernels.articulated`, O(n) each, one factorization), a row of
psi is applied as the two wrenches it is made of
(:func:`~flexmb.kernels.constraints.cut_row_wrenches`) and read back from
the bodies' spatial accelerations. A load on a subtree that hangs from the
ground moves no other body, so each column visits only the subtrees its row
touches, and K has an entry only where two rows share a subtree: banded
(block tridiagonal for a chain of loops) in the order chosen at build time
(:class:`~flexmb.kernels.loop_layout.LoopLayout`), and factored with its
rank revealed and its singular positions filtered by
:mod:`flexmb.kernels.constraint_matrix`.
"""

from __future__ import annotations

import numpy as np
from numba.extending import register_jitable

from .articulated import _minus_bias_wrenches, _minus_bias_wrenches_into, mass_times  # noqa: F401 (loop_jacobian)
from .cache import njit
from .constrained import (LIFT, MASSLESS, _constrained_apply, _constrained_apply_into, _constrained_factor,
                          _constrained_factor_into, _constrained_solve, apply_work_size, row_spatial_accelerations)
from .constraints import ROWS_SCRATCH, cut_row_wrenches, cut_row_wrenches_into
from .dynamics import spatial_inertias
from .equations import loaded_state_into, loaded_state_work_size
from .packing import _view1, is_planar, unpack, unpack_planar
from .planar_loops import HANDOFF, planar_loop_rhs_into
from .tree import TreeArrays, tree_state
from .views import view2, view3

__all__ = ["MASSLESS", "LIFT", "loop_rhs", "loop_rhs_into", "loop_rhs_work_size", "loop_rhs_factors_into",
           "loop_rhs_views", "loop_speeds", "loop_newton_factor", "loop_newton_solve",
           "rows_at_positions", "row_spatial_accelerations"]

#: the packed tree's field ``coord_body`` (the planar path reads it alone: unpacking the whole model costs more)
_COORD_BODY = TreeArrays._fields.index("coord_body")


@njit(cache=True)
def _rows(level, tree, cuts, R, origin, r, omega, v, alpha, acc, coord, gamma_d):
    """The cut rows' wrenches and gamma, and the driver rows appended (their gamma given)."""
    phi_c, W_c, body_c, gamma_c = cut_row_wrenches(level, R, origin, r, omega, v, alpha, acc, *cuts)
    mc = W_c.shape[0]
    m = coord.shape[0]
    W = np.zeros((m, 2, 6))
    body = np.full((m, 2), -1, dtype=np.int64)
    gamma = np.empty(m)
    W[:mc] = W_c
    body[:mc] = body_c
    gamma[:mc] = gamma_c
    gamma[mc:] = gamma_d
    return W, body, gamma


@njit(cache=True)
def _rows_into(tree, cuts, R, origin, r, omega, v, alpha, acc, gamma_d, W, gamma, phi, scratch, no_body):
    """:func:`_rows` at level 2 into ``W`` (m, 2, 6), ``gamma`` (m) and scratch ``phi`` (m), ``scratch``.

    The rows' bodies are not written (``no_body``: an empty (0, 2) int
    array): they are the layout's ``row_body``.
    """
    mc = _n_cut(cuts)
    W[:, :, :] = 0.0
    pt_i, pt_pi, pt_j, pt_pj, dr_i, dr_pi, dr_ai, dr_j, dr_pj, pp_i, pp_ai, pp_j, pp_bj = cuts
    cut_row_wrenches_into(2, R, origin, r, omega, v, alpha, acc, pt_i, pt_pi, pt_j, pt_pj, dr_i, dr_pi, dr_ai, dr_j,
                          dr_pj, pp_i, pp_ai, pp_j, pp_bj, phi[:mc], W[:mc], no_body,
                          gamma[:mc], scratch)
    gamma[mc:] = gamma_d


@njit(cache=True)
def loop_rhs(packed, layout, y, nq, powers, force0, torque0, generalized0, gamma_d, tol, window, rank_limit):
    """Accelerations and constraint reactions of a tree with loops at ``y = (x, xd, ...)``, in O(n m).

    Parameters
    ----------
    packed : tuple
        The model's constant arrays (:func:`~flexmb.kernels.packing.pack`).
    layout : LoopLayout
        The rows' layout (:func:`~flexmb.kernels.loop_layout.loop_layout`).
    y : ndarray, shape (>= nq + n,)
        Coordinates and speeds first (:mod:`flexmb.state_layout`).
    nq : int
        Number of coordinates.
    powers : ndarray, shape (n_groups,) or (0,)
        If not empty, each compiled force-element class's power is added.
    force0, torque0 : ndarray, shape (n_bodies + 1, 3)
        Loads of the force elements evaluated in Python.
    generalized0 : ndarray, shape (n,)
        Their generalized forces.
    gamma_d : ndarray, shape (n_drivers,)
        The drivers' prescribed accelerations.
    tol : float
        Relative pivot below which a row counts as dependent.
    window : float
        Mass-weighted singular values ``sqrt(d)`` below it are filtered (0: none).
    rank_limit : int
        Largest number of rows kept (negative: no limit).

    Returns
    -------
    xdd : ndarray, shape (n,)
        Accelerations.
    lam : ndarray, shape (m,)
        Reactions: ``psi^T lambda = A xdd - f`` (dropped rows: zero).
    kept : int
        Number of rows kept (the rank of psi); with status 1 or 3, the body
        whose joint moves no mass.
    smallest : float
        Smallest mass-weighted singular value ``sqrt(d)`` of the kept rows.
    status : int
        0; 1 if A is singular (a freedom without mass that no loop fixes);
        2 if not finite; 3 if the refinement of a massless freedom did not
        settle.
    """
    nb, n, m = packed[3][0, 1], generalized0.shape[0], layout.row_coord.shape[0]  # packed[3][0, 1]: the bodies
    xdd, lam = np.empty(n), np.empty(m)
    kept, smallest, status = loop_rhs_into(packed, layout, y, nq, powers, force0, torque0, generalized0, gamma_d, tol,
                                           window, rank_limit, xdd, lam, np.empty(loop_rhs_work_size(nb, n, m)))
    return xdd, lam, kept, smallest, status


@register_jitable
def loop_rhs_work_size(nb, n, m):
    """Length of the work array :func:`loop_rhs_into` needs.

    Parameters
    ----------
    nb, n, m : int
        Numbers of bodies, speeds and rows (cut and driver rows).

    Returns
    -------
    int
        The length.
    """
    return (loaded_state_work_size(nb, n) + 6 * (nb + 1) + 36 * nb + 21 * n + apply_work_size(nb, n, m) + 14 * m
            + ROWS_SCRATCH)


@njit(cache=True)
def loop_rhs_into(packed, layout, y, nq, powers, force0, torque0, generalized0, gamma_d, tol, window, rank_limit, xdd,
                  lam, work):
    """:func:`loop_rhs` into ``xdd`` and ``lam``, scratch in ``work`` (the CVODE callback's): the one dispatch.

    A planar model (:func:`~flexmb.kernels.packing.is_planar`) takes the
    planar path (:func:`~flexmb.kernels.planar_loops.planar_loop_rhs_into`),
    except a run that integrates the force elements' powers (``powers`` not
    empty) and a state where a freedom moves no mass (handed back): those,
    and every other model, take :func:`loop_rhs_factors_into`, which alone
    leaves the spatial arrays and factors in ``work`` (the loops' compiled
    ``J v`` calls it directly, :mod:`flexmb.kernels.loop_jtimes`).

    Parameters
    ----------
    packed, layout, y, nq, powers, force0, torque0, generalized0, gamma_d, tol, window, rank_limit
        As :func:`loop_rhs`.
    xdd : ndarray, shape (n,)
        Output: the accelerations.
    lam : ndarray, shape (m,)
        Output: the reactions.
    work : ndarray, shape (>= loop_rhs_work_size(n_bodies, n, m),)
        Scratch (its contents on entry are not read).

    Returns
    -------
    kept, smallest, status
        As :func:`loop_rhs`.
    """
    if is_planar(packed) and powers.shape[0] == 0:
        ints, floats = unpack_planar(packed)
        coord_body = _view1(packed[1], packed[3], _COORD_BODY)
        kept, smallest, status = planar_loop_rhs_into(ints, floats, coord_body, layout, y, nq, generalized0, gamma_d,
                                                      tol, window, rank_limit, xdd, lam, work)
        if status != HANDOFF:
            return kept, smallest, status
    kept, smallest, status, _ = loop_rhs_factors_into(packed, layout, y, nq, powers, force0, torque0, generalized0,
                                                      gamma_d, tol, window, rank_limit, xdd, lam, work)
    return kept, smallest, status


@njit(cache=True, inline="always")
def loop_rhs_views(nb, n, m, work):
    """The arrays :func:`loop_rhs_factors_into` leaves in its work after :func:`~flexmb.kernels.equations.loaded_state_into`'s.

    Parameters
    ----------
    nb, n, m : int
        Numbers of bodies, speeds and rows.
    work : ndarray, shape (>= loop_rhs_work_size(nb, n, m),)
        The work array.

    Returns
    -------
    tuple
        The rows' wrenches ``W`` (m, 2, 6), ``gamma``, ``phi`` (m) and
        their scratch; the bias loads ``pA0`` (nb + 1, 6); ``IA`` (nb, 6,
        6); the articulated factors ``U``, ``DinvUT``, ``Dinv`` (n, 6);
        ``armature0``, ``armature``, ``lift`` (n); the solve's scratch.
    """
    o = loaded_state_work_size(nb, n)
    W, gamma, phi = view3(work, o, m, 2, 6), work[o + 12 * m : o + 13 * m], work[o + 13 * m : o + 14 * m]
    rows_scratch = work[o + 14 * m : o + 14 * m + ROWS_SCRATCH]
    o += 14 * m + ROWS_SCRATCH
    pA0 = view2(work, o, nb + 1, 6)
    IA = view3(work, o + 6 * (nb + 1), nb, 6, 6)
    o += 6 * (nb + 1) + 36 * nb
    U, DinvUT, Dinv = view2(work, o, n, 6), view2(work, o + 6 * n, n, 6), view2(work, o + 12 * n, n, 6)
    armature0, armature = work[o + 18 * n : o + 19 * n], work[o + 19 * n : o + 20 * n]
    lift = work[o + 20 * n : o + 21 * n]
    scratch = work[o + 21 * n : o + 21 * n + apply_work_size(nb, n, m)]
    return W, gamma, phi, rows_scratch, pA0, IA, U, DinvUT, Dinv, armature0, armature, lift, scratch


@njit(cache=True)
def loop_rhs_factors_into(packed, layout, y, nq, powers, force0, torque0, generalized0, gamma_d, tol, window,
                          rank_limit, xdd, lam, work):
    """:func:`loop_rhs_into` by the spatial path always, and the constrained solve's factors (the state Jacobian's).

    The spatial kinematics, loads, rows and articulated factors stay in
    ``work`` (:func:`loop_rhs_views`) for the consumers that read them (the
    loops' compiled ``J v``); a planar model's right-hand side alone goes
    through :func:`loop_rhs_into`.

    Parameters
    ----------
    packed, layout, y, nq, powers, force0, torque0, generalized0, gamma_d, tol, window, rank_limit, xdd, lam, work
        As :func:`loop_rhs_into`.

    Returns
    -------
    kept, smallest, status
        As :func:`loop_rhs`.
    factors : tuple
        ``(U, DinvUT, Dinv, lift, Kb, d, dfilt, kept, smallest, V,
        status)`` of :func:`~flexmb.kernels.constrained._constrained_factor`
        (the first four: views of ``work``, :func:`loop_rhs_views`).
    """
    n, m = generalized0.shape[0], lam.shape[0]
    tree, cuts, kin, spatial, fw, tw, generalized = loaded_state_into(
        packed, y, nq, powers, force0, torque0, generalized0, work[: loaded_state_work_size(packed[3][0, 1], n)])
    R, origin, r, omega, v, alpha, acc, jp, Sw, Sv = kin
    nb = tree.parent.shape[0]
    W, gamma, phi, rows_scratch, pA0, IA, U, DinvUT, Dinv, armature0, armature, lift, scratch = loop_rhs_views(
        nb, n, m, work)
    _rows_into(tree, cuts, R, origin, r, omega, v, alpha, acc, gamma_d, W, gamma, phi, rows_scratch,
               layout.row_body[:0])
    body = layout.row_body
    _minus_bias_wrenches_into(nb, r, fw, tw, pA0)
    armature0[:] = 0.0
    dA = view2(scratch, 0, nb + 1, 6)  # the apply's scratch, lent to the factors' check of massless freedoms
    dA[:, :] = 0.0
    Kb, d, dfilt, kept, smallest, V, status = _constrained_factor_into(
        tree.parent, tree.coord_start, Sw, Sv, spatial, W, body, layout.row_coord, _arrays(layout), layout.band, tol,
        window, rank_limit, armature0, armature, lift, IA, U, DinvUT, Dinv, dA, xdd)
    factors = (U, DinvUT, Dinv, lift, Kb, d, dfilt, kept, smallest, V, status)
    kept, smallest, status = _constrained_apply_into(tree.parent, tree.coord_start, Sw, Sv, W, body, layout.row_coord,
                                                     layout.order, layout.band, factors, pA0, generalized, gamma, xdd,
                                                     lam, scratch)
    return kept, smallest, status, factors


@njit(cache=True)
def loop_speeds(packed, layout, x, xd, b, tol, window, rank_limit):
    """The consistent speeds nearest to ``xd`` in the kinetic-energy metric: ``xd + A^-1 psi^T K^+ (b - psi xd)``.

    Bayo & Ledesma's mass-orthogonal projection of the speeds onto ``psi xd =
    b`` (:meth:`flexmb.system.System.project` with ``speeds='mass'``), by
    the same O(n m) solves as :func:`loop_rhs`.

    Parameters
    ----------
    packed : tuple
        The model's constant arrays.
    layout : LoopLayout
        The rows' layout.
    x : ndarray, shape (nq,)
        Coordinates (:mod:`flexmb.state_layout`).
    xd : ndarray, shape (n,)
        Speeds.
    b : ndarray, shape (m,)
        Right-hand side of ``psi xd = b``.
    tol, window : float
        As for :func:`loop_rhs`.
    rank_limit : int
        As for :func:`loop_rhs`.

    Returns
    -------
    xd : ndarray, shape (n,)
        The projected speeds.
    kept : int
        Number of rows kept.
    status : int
        0; 1 if A is singular; 2 if not finite.
    """
    return speeds_at_rows(rows_at_positions(packed, layout, x), layout, xd, b, tol, window, rank_limit)


@njit(cache=True)
def speeds_at_rows(rows, layout, xd, b, tol, window, rank_limit):
    """:func:`loop_speeds` from the rows at the positions (:func:`rows_at_positions`' or :func:`rows_at_kinematics`')."""
    tree, Sw, Sv, spatial, W, body = rows
    n = xd.shape[0]
    zeros = np.zeros(n)
    # minimise (v - xd)^T A (v - xd) on psi v = b: A v = A xd + psi^T lambda, A xd as generalized forces
    nb = tree.parent.shape[0]
    Axd = mass_times(tree.parent, tree.coord_start, tree.coord_body, spatial, Sw, Sv, xd)
    out, lam, kept, smallest, status = _constrained_solve(tree.parent, tree.coord_start, Sw, Sv, spatial,
                                                          np.zeros((nb + 1, 6)), Axd, W, body, layout.row_coord, b,
                                                          _arrays(layout), layout.band, tol, window, rank_limit,
                                                          zeros)
    if status:
        return xd.copy(), kept, status
    return out, kept, status


@njit(cache=True)
def loop_newton_factor(packed, layout, x, armature, tol, rank_limit):
    """The factors of a Newton step's solve at the positions x with the armature E (see :func:`loop_newton_solve`).

    The tree's axes and spatial inertias and the rows' wrenches at x, the
    articulated-body factors of ``A + diag(armature)`` and ``K = psi (A +
    E)^-1 psi^T`` factored: everything of :func:`loop_newton_solve` that
    does not depend on its load, O(n m) once for any number of solves.

    Parameters
    ----------
    packed : tuple
        The model's constant arrays.
    layout : LoopLayout
        The rows' layout.
    x : ndarray, shape (nq,)
        Coordinates (:mod:`flexmb.state_layout`).
    armature : ndarray, shape (n,)
        Diagonal E added to A.
    tol : float
        As for :func:`loop_rhs`.
    rank_limit : int
        As for :func:`loop_rhs`.

    Returns
    -------
    tuple
        ``(Sw, Sv, W, body, factors)``, opaque: the first argument of
        :func:`loop_newton_solve`.
    """
    tree, Sw, Sv, spatial, W, body = rows_at_positions(packed, layout, x)
    factors = _constrained_factor(tree.parent, tree.coord_start, Sw, Sv, spatial, W, body, layout.row_coord,
                                  _arrays(layout), layout.band, tol, 0.0, rank_limit, armature)
    return Sw, Sv, W, body, factors


@njit(cache=True)
def loop_newton_solve(factored, packed, layout, load):
    """``v`` with ``(A + diag(armature)) v = load + psi^T lambda`` and ``psi v = 0``: a Newton step's solve.

    ``P_E load`` with ``P_E = T (T^T (A + E) T)^-1 T^T``, two articulated-body
    solves with the factors of :func:`loop_newton_factor` (O(n) each), T
    never formed: the solve of the Newton preconditioner of a model with
    loops (:class:`flexmb.system.tangent.LoopNewtonPreconditioner`).

    Parameters
    ----------
    factored : tuple
        :func:`loop_newton_factor`'s result at the positions and armature wanted.
    packed : tuple
        The model's constant arrays.
    layout : LoopLayout
        The rows' layout.
    load : ndarray, shape (n,)
        Generalized forces.

    Returns
    -------
    v : ndarray, shape (n,)
        The solution.
    lam : ndarray, shape (m,)
        The multipliers (dropped rows: zero).
    kept : int
        Number of rows kept; with status 1 or 3, the body whose joint moves no mass.
    status : int
        0; 1 if ``A + E`` is singular on a freedom no row fixes; 2 if not finite; 3 if not settled.
    """
    Sw, Sv, W, body, factors = factored
    tree, _, _ = unpack(packed)
    m = layout.row_coord.shape[0]
    nb = tree.parent.shape[0]
    out, lam, kept, smallest, status = _constrained_apply(tree.parent, tree.coord_start, Sw, Sv, W, body,
                                                          layout.row_coord, layout.order, layout.band, factors,
                                                          np.zeros((nb + 1, 6)), load, np.zeros(m))
    return out, lam, kept, status


@njit(cache=True)
def rows_at_positions(packed, layout, x):
    """The tree's axes and spatial inertias and the rows' wrenches at the positions x (speeds zero).

    Parameters
    ----------
    packed : tuple
        The model's constant arrays.
    layout : LoopLayout
        The rows' layout (cut rows, then the drivers' unit rows).
    x : ndarray, shape (nq,)
        Coordinates (:mod:`flexmb.state_layout`).

    Returns
    -------
    tree : TreeArrays
        The tree's layout and body data.
    Sw, Sv : ndarray, shape (n, 3)
        Plucker axes of the coordinates.
    spatial : ndarray, shape (n_bodies, 6, 6)
        Spatial inertias about the origin.
    W : ndarray, shape (m, 2, 6)
        The rows' wrenches (the drivers' zero).
    body : ndarray of int, shape (m, 2)
        Their bodies (-1: none).
    """
    tree, tables, cuts = unpack(packed)
    return rows_at_kinematics(tree, cuts, layout, tree_state(tree, x, np.zeros(tree.coord_start[-1])))


@njit(cache=True)
def rows_at_kinematics(tree, cuts, layout, kin):
    """:func:`rows_at_positions` from the tree's kinematics ``kin`` (``tree_state``'s) at the positions (any speeds)."""
    R, origin, r, omega, v, alpha, acc, jp, Sw, Sv = kin
    Iw, spatial = spatial_inertias(R, r, tree.mass, tree.inertia)
    m = layout.row_coord.shape[0]
    W, body, _ = _rows(1, tree, cuts, R, origin, r, omega, v, alpha, acc, layout.row_coord, np.zeros(m - _n_cut(cuts)))
    return tree, Sw, Sv, spatial, W, body


@njit(cache=True, inline="always")
def _arrays(layout):
    """The layout's index arrays that :func:`_constrained_solve` reads."""
    return (layout.root_of, layout.row_roots, layout.visit_ptr, layout.visit, layout.root_ptr, layout.root_rows,
            layout.order, layout.position)


@njit(cache=True, inline="always")
def _n_cut(cuts):
    """Number of cut-joint rows: three per point row set, one per direction and perpendicularity row."""
    return 3 * cuts[0].shape[0] + cuts[4].shape[0] + cuts[9].shape[0]
