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
from .cache import njit

from .articulated import _minus_bias_wrenches, articulated_factor, articulated_solve, mass_times
from .constraint_matrix import factor_constraint_matrix, solve_constraint_matrix
from .constraints import cut_row_wrenches
from .dynamics import spatial_inertias
from .equations import loaded_state
from .packing import unpack
from .tree import tree_state

#: a joint inertia below this times the largest entry of its body's articulated inertia moves no mass
#: (a slender bar's spin closed by a loop: A singular, the reduced mass not)
MASSLESS = 1e-12
#: the armature given to such a freedom, relative to that largest entry; the refinement removes it
LIFT = 1e-4
#: a massless freedom whose motion the rows see below this fraction of what they could is not fixed by them
UNFIXED = 1e-8
#: the refinement stops when a correction is below this times the solution, or after REFINE_MAX passes
REFINE_TOL = 1e-15
REFINE_MAX = 50

__all__ = ["MASSLESS", "LIFT", "loop_rhs", "loop_speeds", "loop_newton_factor", "loop_newton_solve",
           "rows_at_positions", "row_spatial_accelerations"]


@njit(cache=True)
def row_spatial_accelerations(W, body, coord, dA, xdd, a):
    """``psi_a xdd`` from the bodies' spatial accelerations: ``W_a0 . dA_i + W_a1 . dA_j (+ xdd_c)``."""
    s = 0.0
    for side in range(2):
        k = body[a, side]
        if k >= 0:
            for i in range(6):
                s += W[a, side, i] * dA[k, i]
    if coord[a] >= 0:
        s += xdd[coord[a]]
    return s


@njit(cache=True)
def _loop_matrix(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body, coord, root_of, row_roots, visit_ptr, visit,
                 root_ptr, root_rows, position, band, tol, window, rank_limit):
    """``K = psi A^-1 psi^T`` within its band, in the factoring order, factored (:func:`_band_ldl`).

    Column b is read from one solve with row b's wrenches on the subtrees
    it touches; K is factored by
    :func:`~flexmb.kernels.constraint_matrix.factor_constraint_matrix`.
    Returns (L in Kb, d or the eigenvalues, the same filtered, kept,
    smallest, finite, the eigenvectors (0 x 0 if banded)).
    """
    nb = parent.shape[0]
    n = Sw.shape[0]
    m = W.shape[0]
    Kb = np.zeros((m, band + 1))
    pA = np.zeros((nb + 1, 6))
    dA = np.zeros((nb + 1, 6))
    g = np.zeros(n)
    col = np.zeros(n)
    stamp = np.full(max(nb, 1), -1, dtype=np.int64)
    seen = np.full(m, -1, dtype=np.int64)
    for b in range(m):
        bodies = visit[visit_ptr[b] : visit_ptr[b + 1]]
        for q in range(bodies.shape[0]):
            k = bodies[q]
            for i in range(6):
                pA[k, i] = 0.0
        for side in range(2):
            k = body[b, side]
            if k >= 0:
                for i in range(6):
                    pA[k, i] -= W[b, side, i]
        if coord[b] >= 0:
            g[coord[b]] = 1.0
        articulated_solve(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, pA, g, bodies, col, dA)
        if coord[b] >= 0:
            g[coord[b]] = 0.0
        for s in range(2):
            if row_roots[b, s] >= 0:
                stamp[row_roots[b, s]] = b
        # K[a, b] for the rows a that touch b's subtrees, on the lower band only (a after b in the order)
        pb = position[b]
        for s in range(2):
            root = row_roots[b, s]
            if root < 0:
                continue
            for q in range(root_ptr[root], root_ptr[root + 1]):
                a = root_rows[q]
                pa = position[a]
                if pa < pb or seen[a] == b:
                    continue
                seen[a] = b
                v = 0.0
                for side in range(2):
                    k = body[a, side]
                    if k >= 0 and stamp[root_of[k]] == b:
                        for i in range(6):
                            v += W[a, side, i] * dA[k, i]
                if coord[a] >= 0 and stamp[root_of[_coord_body(coord_start, coord[a])]] == b:
                    v += col[coord[a]]
                Kb[pa, pa - pb] = v
    diag = np.empty(m)
    finite = True
    for j in range(m):
        diag[j] = Kb[j, 0]
        for q in range(band + 1):
            finite = finite and np.isfinite(Kb[j, q])
    if not finite:
        return Kb, np.zeros(m), np.zeros(m), 0, 0.0, False, np.zeros((0, 0))
    d, dfilt, kept, smallest, V = factor_constraint_matrix(Kb, diag, band, tol, window, rank_limit)
    return Kb, d, dfilt, kept, smallest, True, V


@njit(cache=True)
def _respond(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body, coord, Kb, d, dfilt, band, order, pA, g, filtered,
             exact, V):
    """``A^-1 psi^T lambda`` (one solve with every row's wrenches) and lambda, ``K lambda = filtered + exact``."""
    nb = parent.shape[0]
    n = Sw.shape[0]
    m = W.shape[0]
    lam = solve_constraint_matrix(Kb, d, dfilt, band, order, filtered, exact, V)
    pA[:, :] = 0.0
    g[:] = 0.0
    for a in range(m):
        for side in range(2):
            k = body[a, side]
            if k >= 0:
                for i in range(6):
                    pA[k, i] -= lam[a] * W[a, side, i]
        if coord[a] >= 0:
            g[coord[a]] += lam[a]
    dx = np.empty(n)
    articulated_solve(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, pA, g, np.arange(nb), dx, np.zeros((nb + 1, 6)))
    return dx, lam


@njit(cache=True)
def _unfixed_massless(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body, coord, lift, dA, v):
    """The body of a massless freedom that no constraint row fixes, or -1.

    For a lifted coordinate c, ``v = (A + E)^-1 e_c`` is (to the size of
    E) a motion that moves no mass; if no row of psi sees it
    (``|psi v|`` below :data:`UNFIXED` of what the rows' wrenches could
    give), the reduced mass matrix is singular along it.
    """
    nb = parent.shape[0]
    n = Sw.shape[0]
    m = W.shape[0]
    g = np.zeros(n)
    pA = np.zeros((nb + 1, 6))
    for c in range(n):
        if not lift[c] > 0.0:
            continue
        g[c] = 1.0
        pA[:, :] = 0.0
        articulated_solve(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, pA, g, np.arange(nb), v, dA)
        g[c] = 0.0
        seen = 0.0
        scale = 0.0
        for a in range(m):
            seen = max(seen, abs(row_spatial_accelerations(W, body, coord, dA, v, a)))
            s = 0.0
            for side in range(2):
                k = body[a, side]
                if k >= 0:
                    w = 0.0
                    z = 0.0
                    for i in range(6):
                        w += W[a, side, i] * W[a, side, i]
                        z += dA[k, i] * dA[k, i]
                    s += np.sqrt(w * z)
            if coord[a] >= 0:
                s += abs(v[coord[a]])
            scale = max(scale, s)
        if not seen > UNFIXED * scale:
            return _coord_body(coord_start, c)
    return -1


@njit(cache=True)
def _constrained_factor(parent, coord_start, Sw, Sv, spatial, W, body, coord, layout_arrays, band, tol, window,
                        rank_limit, armature0):
    """What :func:`_constrained_apply` needs of ``A + diag(armature0)`` and psi: their factors, load-independent.

    The articulated-body factors of ``A + E`` (a freedom that moves no
    mass, a slender bar's spin closed by a loop: A singular, the reduced
    mass ``T^T A T`` not, gets an armature, :data:`LIFT`) and ``K = psi (A +
    E)^-1 psi^T`` factored (:func:`_loop_matrix`).

    Returns the tuple ``(U, DinvUT, Dinv, lift, Kb, d, dfilt, kept,
    smallest, V, status)``: status 0; 1 if a freedom moves no mass and no
    row fixes it (``kept`` its body); 2 if K is not finite.
    """
    root_of, row_roots, visit_ptr, visit, root_ptr, root_rows, order, position = layout_arrays
    nb = parent.shape[0]
    n = Sw.shape[0]
    m = W.shape[0]
    armature = armature0.copy()
    U, DinvUT, Dinv, bad = articulated_factor(parent, coord_start, spatial, Sw, Sv, armature, MASSLESS, LIFT)
    lift = armature - armature0  # E: what the factorization added to massless freedoms
    none = (np.zeros((m, band + 1)), np.zeros(m), np.zeros(m))
    if bad >= 0:
        return U, DinvUT, Dinv, lift, none[0], none[1], none[2], bad, 0.0, np.zeros((0, 0)), 1
    unfixed = _unfixed_massless(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body, coord, lift,
                                np.zeros((nb + 1, 6)), np.empty(n))
    if unfixed >= 0:
        return U, DinvUT, Dinv, lift, none[0], none[1], none[2], unfixed, 0.0, np.zeros((0, 0)), 1
    Kb, d, dfilt, kept, smallest, finite, V = _loop_matrix(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body,
                                                           coord, root_of, row_roots, visit_ptr, visit, root_ptr,
                                                           root_rows, position, band, tol, window, rank_limit)
    return U, DinvUT, Dinv, lift, Kb, d, dfilt, kept, smallest, V, 0 if finite else 2


@njit(cache=True)
def _constrained_apply(parent, coord_start, Sw, Sv, W, body, coord, order, band, factors, pA0, g0, rhs):
    """x and lambda with ``(A + E) x = f + psi^T lambda``, ``psi x = rhs``, by :func:`_constrained_factor`'s factors.

    f is given as loads ``(pA0, g0)``. Where the factorization lifted
    massless freedoms (E), the solution of ``A + E`` is refined by solves
    with the load ``E x`` until it no longer changes (iterative
    refinement: each pass divides the error by about the ratio of E to the
    reduced mass along those freedoms).

    Returns (x, lambda, kept, smallest pivot, status); status as the
    factors' (1, 2), or 3 if the refinement did not settle in
    :data:`REFINE_MAX` passes (no loop fixes the massless freedom, or too
    weakly): then the first massless freedom's body is returned in place
    of ``kept``.
    """
    U, DinvUT, Dinv, lift, Kb, d, dfilt, kept, smallest, V, status = factors
    nb = parent.shape[0]
    n = Sw.shape[0]
    m = W.shape[0]
    if status == 1:
        return np.zeros(n), np.zeros(m), kept, 0.0, 1
    x = np.empty(n)
    dA = np.zeros((nb + 1, 6))
    pA = pA0.copy()
    articulated_solve(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, pA, g0, np.arange(nb), x, dA)
    if status == 2:
        return x, np.zeros(m), 0, 0.0, 2
    residual = np.empty(m)
    for a in range(m):
        residual[a] = -row_spatial_accelerations(W, body, coord, dA, x, a)
    g = np.zeros(n)
    dx, lam = _respond(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body, coord, Kb, d, dfilt, band, order, pA, g,
                       rhs, residual, V)
    for i in range(n):
        x[i] += dx[i]
    lifted = False
    for i in range(n):
        lifted = lifted or lift[i] > 0.0
    converged = _refine(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body, coord, Kb, d, dfilt, band, order, V,
                        lift, x, x.copy(), lam, pA, g, dA) if lifted else True
    for i in range(n):
        if not np.isfinite(x[i]):
            return x, lam, kept, smallest, 2
    if not converged:  # name the first massless freedom's body in kept's place
        for i in range(n):
            if lift[i] > 0.0:
                return x, lam, _coord_body(coord_start, i), smallest, 3
    return x, lam, kept, smallest, 0


@njit(cache=True)
def _refine(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body, coord, Kb, d, dfilt, band, order, V, lift, x, last,
            lam, pA, g, dA):
    """Iterative refinement of ``x`` and ``lam`` (in place) for the armature ``lift``; True if it settled.

    The residual of ``A x = f + psi^T lambda`` is ``E x`` after the first
    solve (``last`` is x then; overwritten), ``E dx`` after each correction.
    """
    nb = parent.shape[0]
    n = Sw.shape[0]
    m = W.shape[0]
    residual = np.empty(m)
    for _ in range(REFINE_MAX):
        # the correction: A_E dx = E last + psi^T dlam, psi dx = 0
        big = 0.0
        for i in range(n):
            g[i] = lift[i] * last[i]
            big = max(big, abs(x[i]))
        pA[:, :] = 0.0
        e = np.empty(n)
        articulated_solve(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, pA, g.copy(), np.arange(nb), e, dA)
        for a in range(m):
            residual[a] = -row_spatial_accelerations(W, body, coord, dA, e, a)
        dx, dlam = _respond(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body, coord, Kb, d, dfilt, band, order, pA,
                            g, np.zeros(m), residual, V)
        step = 0.0
        for i in range(n):
            dx[i] += e[i]
            x[i] += dx[i]
            last[i] = dx[i]
            step = max(step, abs(dx[i]))
        lstep = 0.0
        lbig = 0.0
        for a in range(m):
            lam[a] += dlam[a]
            lstep = max(lstep, abs(dlam[a]))
            lbig = max(lbig, abs(lam[a]))
        if not (step > REFINE_TOL * big or lstep > REFINE_TOL * lbig):
            return True
    return False


@njit(cache=True)
def _constrained_solve(parent, coord_start, Sw, Sv, spatial, pA0, g0, W, body, coord, rhs, layout_arrays, band, tol,
                       window, rank_limit, armature0):
    """x and lambda with ``(A + diag(armature0)) x = f + psi^T lambda``, ``psi x = rhs``; f as loads ``(pA0, g0)``.

    :func:`_constrained_factor` then :func:`_constrained_apply` (which
    see for the massless freedoms and the returned status).
    """
    factors = _constrained_factor(parent, coord_start, Sw, Sv, spatial, W, body, coord, layout_arrays, band, tol,
                                  window, rank_limit, armature0)
    return _constrained_apply(parent, coord_start, Sw, Sv, W, body, coord, layout_arrays[6], band, factors, pA0, g0,
                              rhs)


@njit(cache=True, inline="always")
def _coord_body(coord_start, c):
    """The body whose joint owns coordinate c (binary search of coord_start)."""
    lo, hi = 0, coord_start.shape[0] - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if coord_start[mid] <= c:
            lo = mid
        else:
            hi = mid
    return lo


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
    tree, cuts, kin, spatial, fw, tw, generalized = loaded_state(packed, y, nq, powers, force0, torque0, generalized0)
    R, origin, r, omega, v, alpha, acc, jp, Sw, Sv = kin
    nb = tree.parent.shape[0]
    W, body, gamma = _rows(2, tree, cuts, R, origin, r, omega, v, alpha, acc, layout.row_coord, gamma_d)
    return _constrained_solve(tree.parent, tree.coord_start, Sw, Sv, spatial, _minus_bias_wrenches(nb, r, fw, tw),
                              generalized, W, body, layout.row_coord, gamma, _arrays(layout), layout.band, tol, window,
                              rank_limit, np.zeros(Sw.shape[0]))


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
    tree, Sw, Sv, spatial, W, body = rows_at_positions(packed, layout, x)
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
    R, origin, r, omega, v, alpha, acc, jp, Sw, Sv = tree_state(tree, x, np.zeros(tree.coord_start[-1]))
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
