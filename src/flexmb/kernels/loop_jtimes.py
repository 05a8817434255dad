"""The state Jacobian of a tree with loops times a vector, in O(n m): GMRES's ``J v`` without a right-hand side.

``J = [[0, I], [P (G - K), -P C]]`` as
:func:`~flexmb.kernels.loop_jacobian.loop_state_jacobian` forms it (which
see: ``System.state_jacobian``'s), applied to one vector ``v = (v1, v2)``:

    J v = (v2, P g),    g = G v1 - K v1 - C v2,

``G v1`` by :func:`~flexmb.kernels.tangent.geometric_times` (two passes
over the tree, from the per-coordinate terms of
:func:`~flexmb.kernels.tangent.geometric_terms`) and ``P g`` by one
constrained solve with the load g and no rows' right-hand side
(:func:`~flexmb.kernels.constrained._constrained_apply_into`), on the
factors of the right-hand side at the same state
(:func:`~flexmb.kernels.loops.loop_rhs_factors_into`): the tree's
kinematics, loads and articulated factors are read from that evaluation's
work array (:func:`~flexmb.kernels.loops.loop_rhs_views`), K's factors
from a buffer it is copied into (:func:`keep_factors`). A product then
costs two O(n) passes and a constrained solve, instead of the right-hand
side a difference quotient costs; the terms (:func:`prepare`) are made at
the state (tests) or, in the loops' CVODE, once per new Jacobian (G
lagged, :data:`flexmb.integrators.cvode_direct_loops.LAGGED_JTIMES`).

The buffer ``jt`` (:func:`jtimes_size`): a header (:data:`H_VALID` ...),
the state whose factors it holds and its accelerations, K's factors; the
terms (21 per coordinate) in another. The loops'
CVODE fills it through the C callbacks of
:mod:`flexmb.kernels.cvode_loop_jtimes`; :func:`loop_state_jtimes` is the
same product from a state alone (tests, benchmarks).

Like the dense Jacobian, it holds what the model's tangent has only where
:func:`flexmb.integrators.cvode_direct.compiled_jacobian` says so.
"""

from __future__ import annotations

import numpy as np
from numba.extending import register_jitable

from .cache import njit
from .constrained import _constrained_apply_into, apply_work_size
from .dynamics import composite_inertias
from .equations import loaded_state_views, loaded_state_work_size
from .loops import loop_rhs_factors_into, loop_rhs_views, loop_rhs_work_size
from .packing import unpack
from .tangent import geometric_terms, geometric_times
from .views import view2

__all__ = ["jtimes_size", "keep_factors", "holds", "prepare", "state_jacobian_times", "loop_state_jtimes", "H_VALID",
           "H_KEPT", "H_SMALLEST", "H_STATUS", "H_VROWS", "H_TERMS", "H_SETUPS", "H_TIMES", "H_RHS", "H_AT",
           "H_LAG", "HEADER"]

#: the header of the buffer: the factors are those of the state that follows (1.0) or none (0.0); kept,
#: smallest, status and V's rows of K's factors; the terms are those of the factors (1.0); counters: set-ups,
#: products, right-hand sides evaluated for a state whose factors were not kept; the preconditioner's set-up
#: the terms were made at where they are lagged; whether they are (1.0)
H_VALID, H_KEPT, H_SMALLEST, H_STATUS, H_VROWS, H_TERMS, H_SETUPS, H_TIMES, H_RHS, H_AT, H_LAG = range(11)
HEADER = 11


@register_jitable
def _offsets(n, m, mr, band):
    """Where the state, Kb, d, dfilt and V start in the buffer (the accelerations follow the state)."""
    o_state = HEADER
    o_kb = o_state + m + n
    o_d = o_kb + mr * (band + 1)
    o_df = o_d + mr
    return o_state, o_kb, o_d, o_df, o_df + mr


@register_jitable
def jtimes_size(n, m, mr, band, nv):
    """Length of the buffer ``jt``.

    Parameters
    ----------
    n, m : int
        Numbers of speeds and of states (``m >= 2 n``).
    mr, band : int
        Rows and K's band (the layout's).
    nv : int
        Room for K's eigenvectors (``mr * mr`` where K is factored densely, else 0).

    Returns
    -------
    int
        The length.
    """
    return _offsets(n, m, mr, band)[4] + nv


@njit(cache=True)
def keep_factors(jt, y, xdd, n, m, mr, band, factors):
    """Copy K's factors of the right-hand side at the true state ``y`` (its first m entries) into ``jt``.

    Parameters
    ----------
    jt : ndarray
        The buffer (:func:`jtimes_size`).
    y : ndarray, shape (>= m,)
        The state.
    xdd : ndarray, shape (n,)
        Its accelerations.
    n, m, mr, band : int
        Speeds, states, rows, K's band.
    factors : tuple
        :func:`~flexmb.kernels.loops.loop_rhs_factors_into`'s.
    """
    Kb, d, dfilt, kept, smallest, V, status = factors[4:]
    o_state, o_kb, o_d, o_df, o_v = _offsets(n, m, mr, band)
    k = V.shape[0]
    jt[o_state : o_state + m] = y[:m]
    jt[o_state + m : o_state + m + n] = xdd
    view2(jt, o_kb, mr, band + 1)[:, :] = Kb
    jt[o_d : o_d + mr] = d
    jt[o_df : o_df + mr] = dfilt
    view2(jt, o_v, k, k)[:, :] = V
    jt[H_KEPT], jt[H_SMALLEST], jt[H_STATUS], jt[H_VROWS] = kept, smallest, status, k
    jt[H_VALID], jt[H_TERMS] = 1.0, 0.0


@njit(cache=True)
def holds(jt, y, m):
    """Whether ``jt`` holds the factors of the state ``y``."""
    if jt[H_VALID] != 1.0:
        return False
    for i in range(m):
        if jt[HEADER + i] != y[i]:
            return False
    return True


@njit(cache=True)
def _terms(terms, n):
    """The views of the terms u, hs, y (n, 6) and qs (n, 3) in ``terms`` (21 n)."""
    return view2(terms, 0, n, 6), view2(terms, 6 * n, n, 6), view2(terms, 12 * n, n, 3), view2(terms, 15 * n, n, 6)


@njit(cache=True)
def prepare(packed, jt, terms, work, n, m):
    """Make the terms of G in ``terms`` from the right-hand side's work (kinematics, loads) and its accelerations.

    Parameters
    ----------
    packed : tuple
        The model's constant arrays.
    jt : ndarray
        The buffer, holding the factors of that right-hand side and its
        accelerations (:func:`keep_factors`); ``H_TERMS`` set.
    terms : ndarray, shape (21 n,)
        Output: the terms.
    work : ndarray
        The right-hand side's work (:func:`~flexmb.kernels.loops.loop_rhs_factors_into`'s).
    n, m : int
        Speeds and states.
    """
    tree = unpack(packed)[0]
    xdd = jt[HEADER + m : HEADER + m + n]
    nb = tree.parent.shape[0]
    R, kin, Sw, Sv, scratch, force, torque, generalized, Iw, spatial, fw, tw = loaded_state_views(nb, n, work)
    u, hs, qs, y = geometric_terms(tree.parent, tree.coord_start, tree.coord_kind, Sw, Sv, xdd, kin[1], kin[2],
                                   kin[3], kin[4], kin[5], Iw, tree.mass, composite_inertias(tree.parent, spatial),
                                   force, torque)
    tu, ths, tqs, ty = _terms(terms, n)
    tu[:, :] = u
    ths[:, :] = hs
    tqs[:, :] = qs
    ty[:, :] = y
    jt[H_TERMS] = 1.0


@njit(cache=True)
def state_jacobian_times(packed, layout, jt, terms, work, n, m, stiffness, damping, v, Jv):
    """``Jv = J v`` at the state whose factors ``jt`` holds (:func:`keep_factors`), with the terms of G of ``terms``.

    Parameters
    ----------
    packed, layout
        The model and its rows' layout.
    jt, work : ndarray
        The buffer and the right-hand side's work at that state.
    terms : ndarray, shape (21 n,)
        The terms of G (:func:`prepare`): of that state, or of another (J's G lagged).
    n, m : int
        Speeds and states (entries of ``v`` and ``Jv`` from 2 n on: states nothing depends on).
    stiffness, damping : ndarray, shape (n,)
        The diagonal coordinate springs K and dampers C.
    v : ndarray, shape (>= m,)
        The vector.
    Jv : ndarray, shape (>= m,)
        Output.

    Returns
    -------
    kept : int
        With status 3, the body of the massless freedom.
    status : int
        The constrained solve's status (0; 2 not finite; 3 a massless freedom's refinement did not settle).
    """
    tree = unpack(packed)[0]
    nb, mr, band = tree.parent.shape[0], layout.row_coord.shape[0], layout.band
    Sw, Sv = loaded_state_views(nb, n, work[: loaded_state_work_size(nb, n)])[2:4]
    W, gamma, phi, rows_scratch, pA0, IA, U, DinvUT, Dinv, armature0, armature, lift, scratch = loop_rhs_views(
        nb, n, mr, work)
    o_state, o_kb, o_d, o_df, o_v = _offsets(n, m, mr, band)
    k = int(jt[H_VROWS])
    factors = (U, DinvUT, Dinv, lift, view2(jt, o_kb, mr, band + 1), jt[o_d : o_d + mr], jt[o_df : o_df + mr],
               int(jt[H_KEPT]), jt[H_SMALLEST], view2(jt, o_v, k, k), int(jt[H_STATUS]))
    u, hs, qs, y = _terms(terms, n)
    g = np.empty(n)
    geometric_times(tree.parent, tree.coord_start, tree.coord_kind, Sw, Sv, u, hs, qs, y, v[:n], g,
                    np.empty((nb, 6)), np.empty((nb + 1, 9)))
    for i in range(n):
        g[i] -= stiffness[i] * v[i] + damping[i] * v[n + i]
    x, lam = Jv[n : 2 * n], np.empty(mr)
    kept, _, status = _constrained_apply_into(tree.parent, tree.coord_start, Sw, Sv, W, layout.row_body,
                                           layout.row_coord, layout.order, band, factors, np.zeros((nb + 1, 6)), g,
                                           np.zeros(mr), x, lam, np.empty(apply_work_size(nb, n, mr)))
    for i in range(n):
        Jv[i] = v[n + i]
    for i in range(2 * n, m):
        Jv[i] = 0.0
    return kept, status


@njit(cache=True)
def loop_state_jtimes(packed, layout, y, n, stiffness, damping, gamma_d, tol, window, rank_limit, v, Jv):
    """``Jv = J v`` at ``y``, J as :func:`~flexmb.kernels.loop_jacobian.loop_state_jacobian` fills it.

    The right-hand side at ``y`` (its factors kept), the terms, the
    product: what the loops' CVODE callbacks do over several calls.

    Parameters
    ----------
    packed, layout, y, n, stiffness, damping, gamma_d, tol, window, rank_limit
        As :func:`~flexmb.kernels.loop_jacobian.loop_state_jacobian` (``y`` of length m >= 2 n).
    v : ndarray, shape (m,)
        The vector.
    Jv : ndarray, shape (m,)
        Output.

    Returns
    -------
    int
        0; the right-hand side's or the solve's status otherwise (1, 2, 3).
    """
    tree = unpack(packed)[0]
    nb, mr, band, m = tree.parent.shape[0], layout.row_coord.shape[0], layout.band, y.shape[0]
    work, xdd, lam = np.empty(loop_rhs_work_size(nb, n, mr)), np.empty(n), np.empty(mr)
    zeros = np.zeros((nb + 1, 3))
    kept, smallest, status, factors = loop_rhs_factors_into(packed, layout, y, n, np.zeros(0), zeros, zeros,
                                                            np.zeros(n), gamma_d, tol, window, rank_limit, xdd, lam,
                                                            work)
    if status:
        return status
    jt = np.zeros(jtimes_size(n, m, mr, band, factors[9].size))
    keep_factors(jt, y, xdd, n, m, mr, band, factors)
    terms = np.empty(21 * n)
    prepare(packed, jt, terms, work, n, m)
    return state_jacobian_times(packed, layout, jt, terms, work, n, m, stiffness, damping, v, Jv)[1]
