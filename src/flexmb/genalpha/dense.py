"""The interpolant over one generalized-alpha step (:class:`GeneralizedAlphaDenseOutput`).

The step itself is in :mod:`flexmb.genalpha.solver`, the method in
:mod:`flexmb.genalpha`; its form in a rotation chart in
:mod:`flexmb.genalpha.chart`.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import DenseOutput

__all__ = ["GeneralizedAlphaDenseOutput"]


class GeneralizedAlphaDenseOutput(DenseOutput):
    """Interpolant over one generalized-alpha step.

    Positions: the cubic Hermite polynomial through ``x`` and its slopes at
    both ends (``xd``, or ``slope_new`` at the end). Speeds: ``xd0 + s (xd1
    - xd0) + h (s^2 - s) (abar1 - abar0) / 2`` (second order, and bounded
    by the algorithmic accelerations where a mode is not resolved). Further
    states: the quadratic whose end slopes are the rates at both ends (the
    trapezoidal rule at ``s = 1``).

    Parameters
    ----------
    t_old, t : float
        Step start and end, s.
    y_old, y : ndarray, shape (2 n + n_w,)
        States at both ends.
    abar_old, abar : ndarray, shape (n,)
        Algorithmic accelerations at both ends.
    g_old, g : ndarray, shape (n_w,)
        Rates of the further states at both ends.
    n : int
        Number of positions.
    slope_new : ndarray, shape (n,), optional
        The positions' rates at the step end where they are not the speeds
        (a rotation vector's, :mod:`flexmb.genalpha.chart`); default the
        speeds ``y[n:2n]``.
    """

    def __init__(self, t_old, t, y_old, y, abar_old, abar, g_old, g, n, slope_new=None):
        super().__init__(t_old, t)
        self.h = t - t_old
        self.y_old, self.y_new = y_old, y
        self.abar_old, self.abar_new = abar_old, abar
        self.g_old, self.g_new = g_old, g
        self.n_pos = n
        self.slope_new = y[n : 2 * n] if slope_new is None else slope_new

    def _call_impl(self, t):
        n, h = self.n_pos, self.h
        s = (np.atleast_1d(t) - self.t_old) / h
        x0, v0, w0 = self.y_old[:n, None], self.y_old[n : 2 * n, None], self.y_old[2 * n :, None]
        x1, v1 = self.y_new[:n, None], self.y_new[n : 2 * n, None]
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        x = h00 * x0 + h10 * h * v0 + h01 * x1 + h11 * h * self.slope_new[:, None]
        dab = (self.abar_new - self.abar_old)[:, None]
        v = v0 + s * (v1 - v0) + 0.5 * h * (s * s - s) * dab
        g0, g1 = self.g_old[:, None], self.g_new[:, None]
        w = w0 + h * (s * g0 + 0.5 * s * s * (g1 - g0))
        y = np.vstack([x, v, w])
        return y[:, 0] if np.ndim(t) == 0 else y
