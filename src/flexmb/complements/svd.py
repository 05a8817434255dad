"""Singh & Likins: T from the singular value decomposition of psi."""

from __future__ import annotations

import numpy as np

from ..kernels.reduced import svd_parts
from .base import Complement, ComplementStrategy

__all__ = ["SVDComplement"]


class SVDComplement(ComplementStrategy):
    """Right singular vectors of the zero singular values of psi.

    ``psi = U S V^T``; singular values below ``rank_tol * s_max`` count as zero
    (default ``rank_tol = 1e-10``). Better conditioned than the eigen strategy,
    which squares the condition number.

    Parameters
    ----------
    rank_tol : float, optional
        Relative zero tolerance of the singular values (default ``1e-10``).
    singular_rtol : float
        Relative floor of the singular values used in particular solutions;
        see :class:`ComplementStrategy`.
    singular_window : float
        Relative width of the filter of small singular values in particular
        solutions (default 0.1); see :class:`ComplementStrategy`.

    Examples
    --------
    >>> import numpy as np
    >>> from flexmb.complements import SVDComplement
    >>> c = SVDComplement().complement(np.array([[1.0, 1.0, 0.0], [2.0, 2.0, 0.0]]))
    >>> c.rank, c.p
    (1, 2)
    """

    name = "svd"
    default_rank_tol = 1e-10

    def _complement_impl(self, psi):
        U, s, Vt, r = svd_parts(np.asarray(psi, dtype=float), self.tol)
        return Complement(Vt[r:].T.copy(), r, Vt[:r].T, s[:r], U[:, :r])
