"""The parameters of Chung & Hulbert's generalized-alpha method and its amplification of a mode.

:func:`alpha_parameters` gives ``alpha_m``, ``alpha_f``, ``beta`` and
``gamma`` for a spectral radius at infinity; :func:`amplification_matrix`
is one step on the undamped oscillator, and :func:`numerical_damping` the
damping ratio equivalent to the dissipation of that step, which
:class:`~flexmb.genalpha.GeneralizedAlpha` and 'auto' report.

References
----------
.. [1] J. Chung, G. M. Hulbert, J. Appl. Mech. 60 (1993) 371-375.
"""

from __future__ import annotations

import functools

import numpy as np

from .._validate import number

__all__ = ["DEFAULT_RHO_INF", "alpha_parameters", "amplification_matrix", "numerical_damping", "settings"]

_EPS = np.finfo(float).eps

#: spectral radius at infinity used by default
DEFAULT_RHO_INF = 0.8


def alpha_parameters(rho_inf: float) -> tuple[float, float, float, float]:
    """The parameters of Chung & Hulbert's generalized-alpha method for a spectral radius ``rho_inf``.

    Parameters
    ----------
    rho_inf : float
        Spectral radius of the amplification matrix as ``h omega -> inf``,
        in [0, 1]: 1 keeps all frequencies (no dissipation, the trapezoidal
        rule), 0 annihilates the highest in one step.

    Returns
    -------
    alpha_m, alpha_f, beta, gamma : float
        ``alpha_m = (2 rho - 1) / (rho + 1)``, ``alpha_f = rho / (rho + 1)``,
        ``gamma = 1/2 + alpha_f - alpha_m``, ``beta = (gamma + 1/2)^2 / 4``.

    Raises
    ------
    ModelError
        If ``rho_inf`` is not a number in [0, 1] (a ValueError too).

    Notes
    -----
    Eqs. 25 and 17-18 of Chung & Hulbert (1993) [1]_ (their ``alpha_m``,
    ``alpha_f`` weight the old step end): second-order accurate,
    unconditionally stable for linear problems, with the high-frequency
    dissipation maximal for the low-frequency dissipation it costs.

    References
    ----------
    .. [1] J. Chung, G. M. Hulbert, "A time integration algorithm for
       structural dynamics with improved numerical dissipation: the
       generalized-alpha method", J. Appl. Mech. 60 (1993) 371-375.

    Examples
    --------
    >>> from flexmb.genalpha import alpha_parameters
    >>> alpha_parameters(1.0)
    (0.5, 0.5, 0.25, 0.5)
    """
    rho = number("generalized-alpha", "rho_inf", rho_inf, minimum=0.0, maximum=1.0, strict=False)
    alpha_m = (2.0 * rho - 1.0) / (rho + 1.0)
    alpha_f = rho / (rho + 1.0)
    gamma = 0.5 + alpha_f - alpha_m
    beta = 0.25 * (gamma + 0.5) ** 2
    return alpha_m, alpha_f, beta, gamma


def amplification_matrix(rho_inf: float, h_omega: float) -> np.ndarray:
    """One step of the method on the undamped oscillator ``xdd = -omega^2 x``, as a matrix.

    Parameters
    ----------
    rho_inf : float
        Spectral radius at infinity, in [0, 1].
    h_omega : float
        Step times angular frequency, ``h omega``.

    Returns
    -------
    ndarray, shape (3, 3)
        ``A`` with ``(x1, h xd1, h^2 abar1) = A (x0, h xd0, h^2 abar0)``;
        its spectral radius is the method's amplitude ratio per step, and
        tends to ``rho_inf`` as ``h_omega -> inf``.

    Examples
    --------
    >>> import numpy as np
    >>> from flexmb.genalpha import amplification_matrix
    >>> round(float(np.max(np.abs(np.linalg.eigvals(amplification_matrix(0.6, 1e8))))), 4)
    0.6
    """
    am, af, b, g = alpha_parameters(rho_inf)
    w2 = float(h_omega) ** 2
    # unknowns scaled by h: X = x, V = h xd, B = h^2 abar, a = -omega^2 x  (h^2 a = -w2 x)
    # abar1 = ((1 - af) a1 + af a0 - am abar0) / (1 - am); x1 = x0 + V0 + (1/2 - b) B0 + b B1
    # with h^2 a1 = -w2 x1: solve the linear 3 x 3 step equations for (x1, V1, B1)
    # rows: x1 - b B1 = x0 + V0 + (1/2 - b) B0
    #       V1 - g B1 = V0 + (1 - g) B0
    #       (1 - am) B1 + (1 - af) w2 x1 = -af w2 x0 - am B0
    lhs = np.array([[1.0, 0.0, -b], [0.0, 1.0, -g], [(1 - af) * w2, 0.0, 1 - am]])
    rhs = np.array([[1.0, 1.0, 0.5 - b], [0.0, 1.0, 1 - g], [-af * w2, 0.0, -am]])
    return np.linalg.solve(lhs, rhs)


def numerical_damping(rho_inf: float, h_omega) -> np.ndarray:
    """The damping ratio equivalent to the method's dissipation of an undamped mode, per step.

    A mode of angular frequency ``omega`` integrated with steps ``h`` loses
    the fraction ``1 - r`` of its amplitude per step, ``r`` the spectral
    radius of :func:`amplification_matrix`; a viscous damping ratio ``zeta``
    does the same over the time ``h`` when ``exp(-zeta omega h) = r``, so
    ``zeta = -ln(r) / (h omega)``.

    Parameters
    ----------
    rho_inf : float
        Spectral radius at infinity, in [0, 1].
    h_omega : float or array_like
        Step times angular frequency, ``h omega`` (> 0).

    Returns
    -------
    ndarray
        The equivalent damping ratio for each ``h_omega`` (``inf`` where
        ``rho_inf = 0`` annihilates the mode in one step).

    Examples
    --------
    >>> from flexmb.genalpha import numerical_damping
    >>> float(numerical_damping(1.0, 2.0))
    0.0
    >>> round(float(numerical_damping(0.6, 1.0)), 4)
    0.0051
    """
    hw = np.atleast_1d(np.asarray(h_omega, dtype=float))
    out = np.empty(hw.shape)
    for i, v in enumerate(hw):
        r = float(np.max(np.abs(np.linalg.eigvals(amplification_matrix(rho_inf, v)))))
        out[i] = np.inf if r <= 0.0 else max(0.0, -np.log(min(r, 1.0))) / v
    return out.reshape(np.shape(h_omega))


@functools.lru_cache(maxsize=64)
def settings(rho_inf, rtol, atol, n, n_state, max_step, min_step):
    """The method's parameters, the positions' atol and the kernels' parameter array (``P_*``).

    Parameters
    ----------
    rho_inf, rtol : float
        Spectral radius at infinity; relative tolerance.
    atol : float or array_like
        Absolute tolerance (scalar, or per state entry).
    n, n_state : int
        Number of positions; length of the state.
    max_step : float
        Largest step, s.
    min_step : float or None
        Step floor, s.

    Returns
    -------
    tuple
        ``(alpha_m, alpha_f, beta, gamma, beta', gamma', error constant,
        Newton's tolerance, atol, par)``; the arrays are shared by the
        solvers of one configuration and never written.
    """
    alpha_m, alpha_f, beta, gamma = alpha_parameters(rho_inf)
    ratio = (1.0 - alpha_f) / (1.0 - alpha_m)
    beta_p, gamma_p = beta * ratio, gamma * ratio
    error_constant = 1.0 / 6.0 - beta - 0.5 * (alpha_m - alpha_f)
    atol = np.broadcast_to(np.asarray(atol, dtype=float), (n_state,))[:n].copy()
    if np.any(atol < 0):
        raise ValueError("atol must be >= 0")
    newton_tol = max(10 * _EPS / rtol, min(0.03, rtol**0.5))
    par = np.array([alpha_m, alpha_f, beta, gamma, beta_p, gamma_p, error_constant, rtol, newton_tol,
                    min_step or 0.0, max_step])
    return alpha_m, alpha_f, beta, gamma, beta_p, gamma_p, error_constant, newton_tol, atol, par
