"""Zero-eigenvalue theorem (Walton & Steeves; Kamman & Huston), eqs. 30-37."""

from __future__ import annotations

import numpy as np

from .base import Complement, ComplementStrategy

__all__ = ["EigenComplement"]


class EigenComplement(ComplementStrategy):
    """Eigenvectors of ``S = psi^T psi`` with zero eigenvalues.

    S is symmetric positive semi-definite; its eigenvectors for eigenvalues
    below ``rank_tol * lambda_max`` (default ``rank_tol = 1e-13``, i.e. singular
    values below about 3e-7 of the largest, as squaring halves the digits)
    span the null space of psi (eqs. 30-37).

    Parameters
    ----------
    rank_tol : float, optional
        Relative zero tolerance of the eigenvalues of S (default ``1e-13``).
    singular_rtol : float
        Relative floor of the singular values used in particular solutions;
        see :class:`ComplementStrategy`.
    singular_window : float
        Relative width of the filter of small singular values in particular
        solutions (default 0.1); see :class:`ComplementStrategy`.

    Examples
    --------
    >>> import numpy as np
    >>> from flexmb.complements import EigenComplement
    >>> c = EigenComplement().complement(np.array([[1.0, 1.0, 0.0]]))
    >>> c.p
    2
    """

    name = "eigen"
    default_rank_tol = 1e-13

    def _complement_impl(self, psi):
        lam, vec = np.linalg.eigh(psi.T @ psi)
        lam, vec = lam[::-1], vec[:, ::-1]
        r = int(np.sum(lam > self.tol * lam[0]))
        basis = vec[:, :r]
        s = np.sqrt(lam[:r])
        left = (psi @ basis) / s
        return Complement(vec[:, r:].copy(), r, basis, s, left)
