"""The output projection near a singular position for loops closed by the articulated strategy, in O(n) memory.

:func:`flexmb.output_projection._project_partial` projects a state in the
well-conditioned directions of psi only: the rows along psi's (Euclidean)
singular values below the singular window are left out. At a chain of
four-bars lying flat (B7) half of the singular values fall below it, so
any basis of what is left out is n^2/4 numbers. Here nothing of that size
is formed: with ``G = psi psi^T`` (m x m, sparse: the loops' pattern) the
kept part of its spectrum is reached through the rational filter

    F(G) = -(1/N) sum_j (z_j I - G)^-1 = G^-1 (I + (R G^-1)^N)^-1,

``z_j = R exp(i pi (2j + 1) / N)``, the N roots of ``z^N = -R^N``, with R
the geometric mean of the largest left-out and the smallest kept
eigenvalue of G: ``F(l) = 1 / (l (1 + (R / l)^N))`` is ``1 / l`` on the
kept eigenvalues and 0 on the others, both to ``(l_d / l_k)^(N/2)``, N
chosen to make that 1e-15. Then

* a position step is ``psi_k^+ phi = psi^T F(G) phi`` (Newton);
* the speeds are projected mass-orthogonally onto ``P_k (psi v - b) = 0``
  with ``P_k = G F(G)`` the projector onto the kept rows:
  ``v = xd + A^-1 psi^T y``, ``P_k K P_k y = P_k (b - psi xd)`` with
  ``K = psi A^-1 psi^T``, y in the range of ``P_k``, by conjugate gradients
  preconditioned by ``F(G)``; A^-1 by the articulated-body recursion.

Each filter costs N/2 sparse complex factorisations of m x m (N = 6-10 on
B7), each product O(n m) for a chain of loops: the same results as the
dense SVD (tests/test_statics_loops.py, to 1e-10) without an n x n array.
"""

from __future__ import annotations

import numpy as np

from .errors import AssemblyError
from .kernels.articulated import articulated_factor, articulated_solve
from .kernels.loop_projection import loop_phi, sparse_rows
from .kernels.loops import rows_at_positions

__all__ = ["LoopRows", "KeptRows", "partial_speeds"]

#: the filter's error on the kept and on the left-out eigenvalues of G
FILTER_TOL = 1e-15
#: relative residual at which the speeds' conjugate gradients stop
CG_TOL = 1e-15


class LoopRows:
    """The rows of a system whose loops the kernels close, at positions x: psi (sparse), phi and b.

    Parameters
    ----------
    system : System
        The system (``system._loop_kernel`` true).
    t : float
        Time, s.
    x : ndarray, shape (nq,)
        Coordinates.
    """

    def __init__(self, system, t, x):
        import scipy.sparse as sp

        packed, layout = system._packed, system._loop_layout
        tree, Sw, Sv, spatial, W, body = rows_at_positions(packed, layout, x)
        n, m = Sw.shape[0], layout.row_coord.shape[0]
        ptr, idx, val = sparse_rows(W, body, layout.row_coord, tree.parent, tree.coord_start, Sw, Sv,
                                    np.ones(n, np.bool_))
        self.psi = sp.csr_matrix((val, idx, ptr), shape=(m, n))
        drivers, cols = system.constraints.drivers, system.constraints.driver_cols
        self.phi = np.concatenate([loop_phi(packed, layout, x), [x[c] - d.position(t) for d, c in zip(drivers, cols)]])
        self.b = np.zeros(m)
        self.b[m - len(drivers):] = [d.velocity(t) for d in drivers]
        self._tree = (tree, Sw, Sv, spatial)

    def mass_solver(self, system, t):
        """The solver ``g -> A^-1 g`` of the mass matrix at these positions, by the articulated-body recursion.

        Parameters
        ----------
        system : System
            The system the rows are of.
        t : float
            Time, s (for the error message).

        Returns
        -------
        callable
            ``g -> A^-1 g``, O(n) per call.

        Raises
        ------
        AssemblyError
            If a joint moves no mass or inertia along a freedom (it is named).
        """
        tree, Sw, Sv, spatial = self._tree
        nb, n = tree.parent.shape[0], Sw.shape[0]
        U, DinvUT, Dinv, bad = articulated_factor(tree.parent, tree.coord_start, spatial, Sw, Sv, np.zeros(n))
        if bad >= 0:
            raise AssemblyError(system._massless_message(bad, f"at t = {t:.6g} s"))

        def solve(g):
            out = np.empty(n)
            articulated_solve(tree.parent, tree.coord_start, Sw, Sv, U, DinvUT, Dinv, np.zeros((nb + 1, 6)),
                              np.ascontiguousarray(g, dtype=float), np.arange(nb), out, np.zeros((nb + 1, 6)))
            return out

        return solve


class KeptRows:
    """The rows of psi along its singular values kept by a cut: ``F(G)`` and ``P_k`` as operators.

    psi's singular values s are kept where ``s >= window``, ``s^2 >
    rank_tol * s_max^2`` (the articulated strategy's rank rule) and, at
    most ``rank_limit`` of them, the largest (the rule of
    :meth:`~flexmb.complements.Complement.truncated`).

    Parameters
    ----------
    psi : scipy.sparse matrix, shape (m, n)
        The rows.
    window : float
        The singular window (> 0).
    rank_tol : float
        Relative zero tolerance of psi's squared singular values.
    rank_limit : int
        Largest number of rows kept (negative: no limit).

    Attributes
    ----------
    k : int
        Number of singular values kept.
    """

    def __init__(self, psi, window, rank_tol, rank_limit):
        import scipy.sparse as sp

        m = psi.shape[0]
        self.m = m
        self.G = G = (psi @ psi.T).tocsc()
        top = _largest(G)
        cut = max(window * window, rank_tol * top)
        below = _count_below(G, cut)
        if 0 <= rank_limit < m - below:  # the rank limit cuts higher: between two eigenvalues, found by counts
            cut, below = _cut_at_count(G, cut, top, m - rank_limit), m - rank_limit
        self.k = m - below
        self._solves = []
        if self.k == 0:
            return
        if below == 0:  # every eigenvalue kept: F(G) = G^-1
            self._solves, self._N = [_factor(G)], 0
            return
        l_d, l_k = _neighbours(G, cut, below, top)
        R = np.sqrt(l_d * l_k)
        N = max(4, int(np.ceil(2.0 * np.log(FILTER_TOL) / np.log(l_d / l_k))))
        N += N % 2
        eye = sp.identity(m, format="csc", dtype=complex)
        Gc = G.astype(complex)
        self._N = N
        self._solves = [_factor((z * eye - Gc).tocsc()) for z in R * np.exp(1j * np.pi * (2 * np.arange(N // 2) + 1) / N)]

    def inverse(self, v):
        """Apply ``F(G)``: G^-1 on the kept eigenvalues, 0 on the others.

        Parameters
        ----------
        v : ndarray, shape (m,)
            A vector of row values.

        Returns
        -------
        ndarray, shape (m,)
            ``F(G) v``.
        """
        if self.k == 0:
            return np.zeros(self.m)
        if self._N == 0:
            return self._solves[0](v)
        s = np.zeros(self.m)
        vc = np.asarray(v, dtype=complex)
        for solve in self._solves:  # the nodes in conjugate pairs: twice the real part of the upper half's
            s += 2.0 * solve(vc).real
        return -s / self._N

    def project(self, v):
        """The part of v along the kept rows, ``P_k v = G F(G) v``.

        Parameters
        ----------
        v : ndarray, shape (m,)
            A vector of row values.

        Returns
        -------
        ndarray, shape (m,)
            ``P_k v``.
        """
        if self._N == 0 and self.k:
            return np.array(v, dtype=float)
        return self.G @ self.inverse(v)


def _factor(M):
    """A solver of ``M z = v`` (sparse LU)."""
    import scipy.sparse.linalg as spl

    return spl.splu(M.tocsc()).solve


def _largest(G):
    """G's largest eigenvalue."""
    import scipy.sparse.linalg as spl

    if G.shape[0] <= 8:
        return float(np.linalg.eigvalsh(G.toarray())[-1])
    return float(spl.eigsh(G, k=1, which="LA", return_eigenvectors=False)[0])


def _count_below(G, cut):
    """Number of G's eigenvalues below ``cut``: the negative pivots of ``G - cut I`` (Sylvester's inertia)."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spl

    m = G.shape[0]
    lu = spl.splu((G - cut * sp.identity(m, format="csc")).tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                  options=dict(SymmetricMode=True))
    return int(np.sum(lu.U.diagonal() < 0.0))


def _cut_at_count(G, low, high, count):
    """A cut in ``(low, high]`` with exactly ``count`` eigenvalues of G below it (bisection on a log scale)."""
    for _ in range(200):
        mid = np.sqrt(low * high)
        c = _count_below(G, mid)
        if c == count:
            return mid
        low, high = (mid, high) if c < count else (low, mid)
    raise AssemblyError("the output projection could not separate psi's singular values at its rank limit")


def _neighbours(G, cut, below, top):
    """The largest eigenvalue of G below ``cut`` and the smallest at or above it.

    By shift-invert Lanczos about the cut: the most negative and the
    largest ``1 / (l - cut)`` (a few digits are enough: they only choose
    the filter's nodes); for m <= 8 from all of G's eigenvalues.
    """
    import scipy.sparse.linalg as spl

    m = G.shape[0]
    if m <= 8:
        ev = np.linalg.eigvalsh(G.toarray())
        return max(ev[below - 1], 1e-14 * top), ev[below]
    l_d = spl.eigsh(G, k=1, sigma=cut, which="SA", tol=1e-6, return_eigenvectors=False)[0]
    l_k = spl.eigsh(G, k=1, sigma=cut, which="LA", tol=1e-6, return_eigenvectors=False)[0]
    return max(min(l_d, cut), 1e-14 * top), max(l_k, cut)


def partial_speeds(rows, kept, solve, xd):
    """The speeds nearest to xd in the kinetic-energy metric with ``P_k (psi v - b) = 0``.

    Parameters
    ----------
    rows : LoopRows
        psi and b at the positions.
    kept : KeptRows
        The rows kept.
    solve : callable
        ``g -> A^-1 g``.
    xd : ndarray, shape (n,)
        The speeds.

    Returns
    -------
    ndarray, shape (n,)
        ``xd + A^-1 psi^T y`` with ``P_k K P_k y = P_k (b - psi xd)``, y in the range of P_k.
    """
    if kept.k == 0:
        return np.array(xd, dtype=float)
    psi = rows.psi
    rhs = kept.project(rows.b - psi @ xd)
    y, res = np.zeros_like(rhs), rhs.copy()
    z = kept.inverse(res)
    p, rz = z.copy(), float(res @ z)
    limit = CG_TOL * np.linalg.norm(rhs)
    for _ in range(2 * kept.m + 10):  # conjugate gradients: at most k steps in exact arithmetic
        if np.linalg.norm(res) <= limit or rz == 0.0:
            break
        q = kept.project(psi @ solve(psi.T @ kept.project(p)))
        a = rz / float(p @ q)
        y += a * p
        res -= a * q
        z = kept.inverse(res)
        rz, rz_old = float(res @ z), rz
        p = z + (rz / rz_old) * p
    return xd + solve(psi.T @ kept.project(y))
