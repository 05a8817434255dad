"""Sparse solution of ``A xdd = f`` for an open tree, without forming A.

For a tree, eq. 2's mass matrix is ``A = J^T M J`` with, in Plucker form
about the inertial origin, ``J = Anc S``: S stacks each body's joint
axes ``S_c`` (block diagonal, one 6-row block per body), ``Anc = (E -
Par)^-1`` adds them along the path from the ground (Par: the 0/1 parent
matrix, E the identity) and M holds the bodies' 6 x 6 spatial inertias
(:meth:`Kinematics.spatial_inertia`). With the body accelerations
``a = J xdd`` and the subtree wrenches ``g = Anc^T M a`` as extra
unknowns, ``A xdd = f`` is the sparse linear system

    -M a + (E - Par)^T g      = 0        (subtree sums, one row per body)
    (E - Par) a        - S xdd = 0        (accelerations add along the path)
             -S^T g            = -f       (eq. 3 projected on each axis)

of size ``12 n_bodies + n`` with about ``48 n_bodies + 12 n`` non-zeros,
whatever the depth of the tree. Its graph is the tree itself, so a sparse
LU eliminating from the leaves produces almost no fill: this is the
articulated-body recursion, done by SuperLU in one call instead of a
Python loop over bodies. The cost per evaluation grows as ``n`` instead of
the ``n^3 / 3`` of a dense Cholesky factorization of A (``n^2`` to form
A), which pays from a few hundred coordinates on (see
:data:`SPARSE_MIN_COORDS`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .errors import AssemblyError

__all__ = ["TreeSolver", "SPARSE_MIN_COORDS"]

#: Open trees with at least this many coordinates are solved by
#: :class:`TreeSolver` (measured on B2: the dense path is faster below,
#: e.g. 0.5 ms against 1.0 ms per solve at n = 192; 15 ms against 2.2 ms
#: at n = 768).
SPARSE_MIN_COORDS = 300


class TreeSolver:
    """Sparse factorization of the mass matrix of an open tree (eqs. 2, 3).

    Parameters
    ----------
    topology : Topology
        The model's tree.

    Notes
    -----
    The sparsity pattern is fixed by the topology. The column ordering
    (COLAMD) is computed at the first factorization and reused; each
    factorization then only fills the values of M and S into the stored
    pattern and runs SuperLU with partial pivoting.
    """

    def __init__(self, topology):
        self.topology = topology
        nb, n = topology.n_bodies, topology.n_coords
        self.n_bodies, self.n_coords = nb, n
        self.size = 12 * nb + n
        e6 = np.arange(6)
        k = np.arange(nb)
        ii, jj = np.meshgrid(e6, e6, indexing="ij")
        has = topology.parent >= 0
        child, par = k[has], topology.parent[has]
        ga = 6 * nb  # first g unknown / first kinematic row
        # (row, col) in the order of the values built by _values
        m_r = (6 * k[:, None, None] + ii).ravel()
        m_c = (6 * k[:, None, None] + jj).ravel()
        eye_r = (6 * k[:, None] + e6).ravel()
        par_r = (6 * par[:, None] + e6).ravel()
        chi_r = (6 * child[:, None] + e6).ravel()
        s_r = ga + (6 * topology.coord_body[:, None] + e6).ravel()
        s_c = np.repeat(12 * nb + np.arange(n), 6)
        self._rows = np.concatenate([m_r, eye_r, par_r, ga + eye_r, ga + chi_r, s_r, s_c])
        self._cols = np.concatenate([m_c, ga + eye_r, ga + chi_r, eye_r, par_r, s_c, s_r])
        self._const = np.concatenate([np.ones(6 * nb), -np.ones(par_r.size), np.ones(6 * nb),
                                      -np.ones(par_r.size)])
        self._pattern = None  # (csc indices, indptr, value permutation, column permutation)

    def _values(self, kin) -> np.ndarray:
        S = np.concatenate([kin.Sw, kin.Sv], axis=1).ravel()
        return np.concatenate([-kin.spatial_inertia().ravel(), self._const, -S, -S])

    def _matrix(self, values):
        if self._pattern is None:
            K = sp.csc_matrix((values, (self._rows, self._cols)), shape=(self.size, self.size))
            perm_c = spla.splu(K, permc_spec="COLAMD").perm_c  # column j goes to perm_c[j]
            # the permuted pattern, and where each value lands in its data array
            P = sp.csc_matrix((np.arange(1.0, values.size + 1), (self._rows, perm_c[self._cols])),
                              shape=(self.size, self.size))
            self._pattern = (P.indices, P.indptr, P.data.astype(int) - 1, perm_c)
        indices, indptr, order, _ = self._pattern
        return sp.csc_matrix((values[order], indices, indptr), shape=(self.size, self.size))

    def factor(self, kin):
        """Factor the system at a kinematic state.

        Parameters
        ----------
        kin : Kinematics
            The kinematic state (only positions matter).

        Returns
        -------
        scipy.sparse.linalg.SuperLU
            The factorization, for :meth:`solve`.

        Raises
        ------
        AssemblyError
            If the system is singular (a body without mass or inertia on a
            freedom) or not finite.
        """
        values = self._values(kin)
        if not np.all(np.isfinite(values)):
            raise AssemblyError(f"the mass matrix is not finite at t = {kin.t:.6g} s (non-finite coordinates?)")
        try:
            return spla.splu(self._matrix(values), permc_spec="NATURAL")
        except RuntimeError as exc:  # "Factor is exactly singular"
            raise AssemblyError(
                f"the mass matrix is singular at t = {kin.t:.6g} s "
                "(a body without mass or inertia on a freedom?)"
            ) from exc

    def solve(self, lu, f) -> np.ndarray:
        """Solve ``A xdd = f`` with a factorization from :meth:`factor`.

        Parameters
        ----------
        lu : scipy.sparse.linalg.SuperLU
            From :meth:`factor`.
        f : ndarray, shape (n,) or (n, k)
            Right-hand side(s).

        Returns
        -------
        ndarray, shape (n,) or (n, k)
            ``A^-1 f``.
        """
        f = np.asarray(f, dtype=float)
        rhs = np.zeros((self.size,) + f.shape[1:])
        rhs[12 * self.n_bodies:] = -f
        perm_c = self._pattern[3]
        return lu.solve(rhs)[perm_c[12 * self.n_bodies:]]
