"""The constrained solve of a tree with loops by the articulated-body recursion, without A, psi or T (eqs. 30-39).

``(A + E) x = f + psi^T lambda`` with ``psi x = rhs``: ``a0`` and each
column of ``A^-1 psi^T`` from the articulated-body recursion
(:mod:`flexmb.kernels.articulated`), ``K = psi A^-1 psi^T`` within its
band (:func:`_loop_matrix`), factored with its rank revealed by
:mod:`flexmb.kernels.constraint_matrix`, and the response to lambda;
massless freedoms get an armature E that iterative refinement removes.
The ``*_into`` kernels write into given arrays (the loops' CVODE
right-hand side, :func:`flexmb.kernels.loops.loop_rhs_into`); the others
are their allocating wrappers. :mod:`flexmb.kernels.loops` calls them.
"""

from __future__ import annotations

import numpy as np
from numba.extending import register_jitable

from .articulated import articulated_factor_into, articulated_solve, articulated_solve_into
from .cache import njit
from .constraint_matrix import factor_constraint_matrix, solve_constraint_matrix
from .views import view2

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


#: columns of ``A^-1 psi^T`` carried by one sweep of :func:`_columns_solve`
COLUMNS = 4


@njit(cache=True)
def _columns_solve(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, P, G, bodies, root_of, s, nc, X, dA, u):
    """:func:`~flexmb.kernels.articulated.articulated_solve` for ``nc`` load columns at once, on subtree s.

    The bodies of ``bodies`` (increasing) that hang in subtree s are
    visited once, each joint's factors read once for all columns; column j
    gets, per body, the arithmetic of a solve with the loads ``P[:, j]``
    (overwritten: the subtrees' biases) and ``G[:, j]``, its accelerations
    in ``X[:, j]`` and spatial accelerations in ``dA[:, j]`` (the ground's
    row, last, zero); ``u`` (6, nc) is scratch.
    """
    nb = parent.shape[0]
    for q in range(bodies.shape[0] - 1, -1, -1):
        k = bodies[q]
        if root_of[k] != s:
            continue
        c0, c1 = coord_start[k], coord_start[k + 1]
        for c in range(c0, c1):
            for j in range(nc):
                u[c - c0, j] = G[c, j] - (Sw[c, 0] * P[k, j, 0] + Sw[c, 1] * P[k, j, 1] + Sw[c, 2] * P[k, j, 2]
                                          + Sv[c, 0] * P[k, j, 3] + Sv[c, 1] * P[k, j, 4] + Sv[c, 2] * P[k, j, 5])
        for c in range(c0, c1):
            for j in range(nc):
                t = 0.0
                for b in range(c1 - c0):
                    t += Dinv[c, b] * u[b, j]
                X[c, j] = t
        p = parent[k]
        if p >= 0:
            for j in range(nc):
                for i in range(6):
                    t = P[k, j, i]
                    for c in range(c0, c1):
                        t += U[c, i] * X[c, j]
                    P[p, j, i] += t
    for q in range(bodies.shape[0]):
        k = bodies[q]
        if root_of[k] != s:
            continue
        p = parent[k]
        if p < 0:
            p = nb
        for j in range(nc):
            for i in range(6):
                dA[k, j, i] = dA[p, j, i]
            for c in range(coord_start[k], coord_start[k + 1]):
                t = X[c, j]
                for i in range(6):
                    t -= DinvUT[c, i] * dA[p, j, i]
                X[c, j] = t
            for c in range(coord_start[k], coord_start[k + 1]):
                for i in range(3):
                    dA[k, j, i] += Sw[c, i] * X[c, j]
                    dA[k, j, 3 + i] += Sv[c, i] * X[c, j]


@njit(cache=True)
def _loop_matrix(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body, coord, root_of, row_roots, visit_ptr, visit,
                 root_ptr, root_rows, position, band, tol, window, rank_limit):
    """``K = psi A^-1 psi^T`` within its band, in the factoring order, factored (:func:`_band_ldl`).

    K is summed over the subtrees hanging from the ground (A is block
    diagonal by subtree): on subtree s, the columns of the rows touching
    it come from sweeps of :func:`_columns_solve`, :data:`COLUMNS` rows
    at a time, each with that row's wrenches on s; K is factored by
    :func:`~flexmb.kernels.constraint_matrix.factor_constraint_matrix`.
    Returns (L in Kb, d or the eigenvalues, the same filtered, kept,
    smallest, finite, the eigenvectors (0 x 0 if banded)).
    """
    nb = parent.shape[0]
    n = Sw.shape[0]
    m = W.shape[0]
    Kb = np.zeros((m, band + 1))
    P = np.empty((nb + 1, COLUMNS, 6))
    dA = np.zeros((nb + 1, COLUMNS, 6))
    X = np.empty((n, COLUMNS))
    G = np.empty((n, COLUMNS))
    u = np.empty((6, COLUMNS))
    for s in range(root_ptr.shape[0] - 1):
        r0, r1 = root_ptr[s], root_ptr[s + 1]
        if r1 == r0:
            continue
        first = root_rows[r0]
        bodies = visit[visit_ptr[first] : visit_ptr[first + 1]]  # subtree s's bodies among them
        for j0 in range(r0, r1, COLUMNS):
            nc = min(COLUMNS, r1 - j0)
            for q in range(bodies.shape[0]):
                k = bodies[q]
                if root_of[k] == s:
                    P[k, :, :] = 0.0
                    G[coord_start[k] : coord_start[k + 1], :] = 0.0
            for j in range(nc):
                b = root_rows[j0 + j]
                for side in range(2):
                    k = body[b, side]
                    if k >= 0 and root_of[k] == s:
                        for i in range(6):
                            P[k, j, i] -= W[b, side, i]
                if coord[b] >= 0 and root_of[_coord_body(coord_start, coord[b])] == s:
                    G[coord[b], j] = 1.0
            _columns_solve(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, P, G, bodies, root_of, s, nc, X, dA, u)
            # K[a, b] on the lower band (a after b in the order): subtree s's part, for the rows a touching s
            for j in range(nc):
                b = root_rows[j0 + j]
                pb = position[b]
                for q in range(r0, r1):
                    a = root_rows[q]
                    pa = position[a]
                    if pa < pb:
                        continue
                    v = 0.0
                    for side in range(2):
                        k = body[a, side]
                        if k >= 0 and root_of[k] == s:
                            for i in range(6):
                                v += W[a, side, i] * dA[k, j, i]
                    if coord[a] >= 0 and root_of[_coord_body(coord_start, coord[a])] == s:
                        v += X[coord[a], j]
                    Kb[pa, pa - pb] += v
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
    dx, lam = np.empty(Sw.shape[0]), np.empty(W.shape[0])
    _respond_into(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body, coord, Kb, d, dfilt, band, order, pA, g,
                  filtered, exact, V, dx, lam, np.zeros((nb + 1, 6)), np.empty(6))
    return dx, lam


@njit(cache=True)
def _respond_into(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body, coord, Kb, d, dfilt, band, order, pA, g,
                  filtered, exact, V, dx, lam, dA, u):
    """:func:`_respond` into ``dx`` (n) and ``lam`` (m); scratch ``dA`` (its ground row zero) and ``u`` (6)."""
    nb = parent.shape[0]
    m = W.shape[0]
    lam[:] = solve_constraint_matrix(Kb, d, dfilt, band, order, filtered, exact, V)
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
    articulated_solve_into(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, pA, g, parent[:0], nb, dx, dA, u)


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
    lifted = False
    for c in range(n):
        lifted = lifted or lift[c] > 0.0
    if not lifted:  # nothing to check, nothing allocated (the usual case)
        return -1
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
    nb = parent.shape[0]
    n = Sw.shape[0]
    U, DinvUT, Dinv, lift = np.empty((n, 6)), np.empty((n, 6)), np.empty((n, 6)), np.empty(n)
    Kb, d, dfilt, kept, smallest, V, status = _constrained_factor_into(
        parent, coord_start, Sw, Sv, spatial, W, body, coord, layout_arrays, band, tol, window, rank_limit, armature0,
        np.empty(n), lift, np.empty((nb, 6, 6)), U, DinvUT, Dinv, np.zeros((nb + 1, 6)), np.empty(n))
    return U, DinvUT, Dinv, lift, Kb, d, dfilt, kept, smallest, V, status


@njit(cache=True)
def _constrained_factor_into(parent, coord_start, Sw, Sv, spatial, W, body, coord, layout_arrays, band, tol, window,
                             rank_limit, armature0, armature, lift, IA, U, DinvUT, Dinv, dA, v):
    """:func:`_constrained_factor` with its n-sized factors in given arrays.

    ``armature`` (n) and ``IA`` (n_bodies, 6, 6) are scratch, ``lift``
    (n), ``U``, ``DinvUT``, ``Dinv`` (n, 6) outputs, ``dA`` (n_bodies +
    1, 6; its ground row zero) and ``v`` (n) scratch. Returns ``(Kb, d,
    dfilt, kept, smallest, V, status)``, the rest of
    :func:`_constrained_factor`'s tuple.
    """
    root_of, row_roots, visit_ptr, visit, root_ptr, root_rows, order, position = layout_arrays
    m = W.shape[0]
    armature[:] = armature0
    bad = articulated_factor_into(parent, coord_start, spatial, Sw, Sv, armature, MASSLESS, LIFT, IA, U, DinvUT, Dinv)
    for i in range(armature.shape[0]):
        lift[i] = armature[i] - armature0[i]  # E: what the factorization added to massless freedoms
    if bad >= 0:
        return np.zeros((m, band + 1)), np.zeros(m), np.zeros(m), bad, 0.0, np.zeros((0, 0)), 1
    unfixed = _unfixed_massless(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body, coord, lift, dA, v)
    if unfixed >= 0:
        return np.zeros((m, band + 1)), np.zeros(m), np.zeros(m), unfixed, 0.0, np.zeros((0, 0)), 1
    Kb, d, dfilt, kept, smallest, finite, V = _loop_matrix(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body,
                                                           coord, root_of, row_roots, visit_ptr, visit, root_ptr,
                                                           root_rows, position, band, tol, window, rank_limit)
    return Kb, d, dfilt, kept, smallest, V, 0 if finite else 2


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
    nb = parent.shape[0]
    n = Sw.shape[0]
    m = W.shape[0]
    x, lam = np.empty(n), np.empty(m)
    kept, smallest, status = _constrained_apply_into(parent, coord_start, Sw, Sv, W, body, coord, order, band, factors,
                                                     pA0, g0, rhs, x, lam, np.empty(apply_work_size(nb, n, m)))
    return x, lam, kept, smallest, status


@register_jitable
def apply_work_size(nb, n, m):
    """Length of the scratch of :func:`_constrained_apply_into`.

    Parameters
    ----------
    nb, n, m : int
        Numbers of bodies, speeds and rows.

    Returns
    -------
    int
        The length.
    """
    return 12 * (nb + 1) + 2 * n + m + 6


@njit(cache=True)
def _constrained_apply_into(parent, coord_start, Sw, Sv, W, body, coord, order, band, factors, pA0, g0, rhs, x, lam,
                            work):
    """:func:`_constrained_apply` into ``x`` (n) and ``lam`` (m), scratch ``work`` (:func:`apply_work_size`).

    Returns (kept, smallest, status), as :func:`_constrained_apply`.
    """
    U, DinvUT, Dinv, lift, Kb, d, dfilt, kept, smallest, V, status = factors
    nb = parent.shape[0]
    n = Sw.shape[0]
    m = W.shape[0]
    lam[:] = 0.0
    if status == 1:
        x[:] = 0.0
        return kept, 0.0, 1
    dA, pA = view2(work, 0, nb + 1, 6), view2(work, 6 * (nb + 1), nb + 1, 6)
    o = 12 * (nb + 1)
    g, dx, residual, u = work[o : o + n], work[o + n : o + 2 * n], work[o + 2 * n : o + 2 * n + m], work[-6:]
    dA[:, :] = 0.0
    pA[:, :] = pA0
    articulated_solve_into(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, pA, g0, parent[:0], nb, x, dA, u)
    if status == 2:
        return 0, 0.0, 2
    for a in range(m):
        residual[a] = -row_spatial_accelerations(W, body, coord, dA, x, a)
    _respond_into(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body, coord, Kb, d, dfilt, band, order, pA, g, rhs,
                  residual, V, dx, lam, dA, u)
    for i in range(n):
        x[i] += dx[i]
    lifted = False
    for i in range(n):
        lifted = lifted or lift[i] > 0.0
    converged = _refine(parent, coord_start, Sw, Sv, U, DinvUT, Dinv, W, body, coord, Kb, d, dfilt, band, order, V,
                        lift, x, x.copy(), lam, pA, g, dA) if lifted else True
    for i in range(n):
        if not np.isfinite(x[i]):
            return kept, smallest, 2
    if not converged:  # name the first massless freedom's body in kept's place
        for i in range(n):
            if lift[i] > 0.0:
                return _coord_body(coord_start, i), smallest, 3
    return kept, smallest, 0


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
