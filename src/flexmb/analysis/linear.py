"""Linearisation and modes (after constraint reduction), and linear statics."""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from attrs import define

from ..threads import limited_blas

__all__ = ["Linearization", "linearize", "modes", "linear_statics"]


@define
class Linearization:
    """Linear equations ``M zdd + C zd + K z = F`` in independent coordinates z.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    M, C, K : ndarray, shape (p, p)
        Mass, damping and stiffness matrices (eqs. 21, 36-39 linearised).
    F : ndarray, shape (p,)
        Generalized force left at the linearisation state (0 at an
        equilibrium).
    T : ndarray, shape (n, p)
        Orthogonal complement: ``x = x0 + T z``.
    x0, xd0 : ndarray, shape (n,)
        The state linearised about.
    t : float
        Time, s.
    """

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    F: np.ndarray
    T: np.ndarray
    x0: np.ndarray
    xd0: np.ndarray
    t: float


@limited_blas
def linearize(system, x0=None, xd0=None, t: float = 0.0, h: float = 1e-6) -> Linearization:
    """Linearise the reduced equations of motion about a state.

    Parameters
    ----------
    system : System
        Compiled model.
    x0, xd0 : ndarray, shape (n,), optional
        State (default zeros); it should satisfy the constraints.
    t : float
        Time, s.
    h : float
        Finite-difference step for the Jacobians of the accelerations.

    Returns
    -------
    Linearization
        ``M = T^T A T``, ``K = -T^T A dxdd/dx T``, ``C = -T^T A dxdd/dxd T``
        and ``F = T^T (f - A xdd_p)``.

    Notes
    -----
    The accelerations come from the reduced equations (eqs. 36-39), so the
    constraint forces never appear; centrifugal (geometric) stiffening and
    gyroscopic terms of a spinning state are included.
    """
    n = system.n_coords
    x0 = np.zeros(n) if x0 is None else np.asarray(x0, dtype=float)
    xd0 = np.zeros(n) if xd0 is None else np.asarray(xd0, dtype=float)
    kin, A, f, _, psi, _, gamma = system.equations(t, x0, xd0)
    c = system.complement(psi)
    T = c.T
    p = T.shape[1]
    Jx = np.zeros((n, p))
    Jv = np.zeros((n, p))
    for i in range(p):
        d = h * T[:, i]
        Jx[:, i] = (system.accelerations(t, x0 + d, xd0) - system.accelerations(t, x0 - d, xd0)) / (2 * h)
        Jv[:, i] = (system.accelerations(t, x0, xd0 + d) - system.accelerations(t, x0, xd0 - d)) / (2 * h)
    M = T.T @ A @ T
    xdd_p = c.particular(gamma) if c.rank else np.zeros(n)
    return Linearization(M=M, C=-T.T @ A @ Jv, K=-T.T @ A @ Jx, F=T.T @ (f - A @ xdd_p), T=T,
                         x0=x0, xd0=xd0, t=t)


@limited_blas
def modes(system_or_lin, n_modes: int | None = None, **kw):
    """Natural frequencies and mode shapes (undamped, ``K phi = w^2 M phi``).

    Parameters
    ----------
    system_or_lin : System or Linearization
        What to analyse (a System is linearised about ``**kw``).
    n_modes : int, optional
        How many of the lowest modes to return (default all).
    **kw
        Passed to :func:`linearize`.

    Returns
    -------
    frequencies : ndarray, shape (k,)
        Natural frequencies, Hz, ascending.
    shapes : ndarray, shape (n, k)
        Mode shapes in the generalized coordinates x (``T phi``), each
        normalised to unit largest entry.

    Examples
    --------
    >>> import flexmb as fm
    >>> m = fm.Model()
    >>> beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005),
    ...                        fm.Material.aluminium(), 16, keep=("bend_y",))
    >>> _ = m.add(fm.Fixed("clamp", m.ground, beam))
    >>> f, _ = fm.modes(m.build(), 1)
    >>> round(float(f[0]), 2)
    4.11
    """
    lin = system_or_lin if isinstance(system_or_lin, Linearization) else linearize(system_or_lin, **kw)
    K = 0.5 * (lin.K + lin.K.T)
    w2, phi = sla.eigh(K, lin.M)
    order = np.argsort(w2)
    w2, phi = w2[order], phi[:, order]
    if n_modes is not None:
        w2, phi = w2[:n_modes], phi[:, :n_modes]
    shapes = lin.T @ phi
    shapes /= shapes[np.argmax(np.abs(shapes), axis=0), np.arange(shapes.shape[1])]
    return np.sqrt(np.maximum(w2, 0.0)) / (2 * np.pi), shapes


@limited_blas
def linear_statics(system, x0=None, t: float = 0.0):
    """Static deflection of the model linearised about ``x0``: ``K z = F``.

    Parameters
    ----------
    system : System
        Compiled model.
    x0 : ndarray, shape (n,), optional
        Reference configuration (default zeros).
    t : float
        Time, s.

    Returns
    -------
    ndarray, shape (n,)
        ``x0 + T K^-1 F``: the linear-statics coordinates.
    """
    lin = linearize(system, x0, None, t)
    return lin.x0 + lin.T @ np.linalg.solve(lin.K, lin.F)
