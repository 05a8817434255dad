"""Nonlinear static equilibrium (after constraint reduction)."""

from __future__ import annotations

import numpy as np

from ..errors import AssemblyError
from ..threads import limited_blas
from .linear import linearize

__all__ = ["static_equilibrium"]


@limited_blas
def static_equilibrium(system, x0=None, t: float = 0.0, tol: float = 1e-10, max_iter: int = 50):
    """Nonlinear static equilibrium (e.g. gravity sag) by Newton's method.

    Solves ``T^T f(x, 0) = 0`` on ``phi(x) = 0``, starting from ``x0``.

    Parameters
    ----------
    system : System
        Compiled model.
    x0 : ndarray, shape (n,), optional
        Starting configuration (default zeros).
    t : float
        Time, s.
    tol : float
        Convergence: the largest Newton step (rad or m) below ``tol``.
    max_iter : int
        Iterations allowed.

    Returns
    -------
    ndarray, shape (n,)
        Equilibrium coordinates.

    Raises
    ------
    AssemblyError
        If Newton's method does not converge; the message gives the
        remaining step and force residual.
    """
    n = system.n_coords
    x = np.zeros(n) if x0 is None else np.array(x0, dtype=float)
    zero = np.zeros(n)
    x, _ = system.project(t, x, zero)
    step = np.inf
    for _ in range(max_iter):
        lin = linearize(system, x, zero, t)
        try:
            dz = np.linalg.solve(lin.K, lin.F)
        except np.linalg.LinAlgError:
            raise AssemblyError("static equilibrium: the stiffness matrix is singular "
                                "(a mechanism with an unloaded free motion?)") from None
        x = x + lin.T @ dz
        x, _ = system.project(t, x, zero)
        step = np.max(np.abs(dz)) if dz.size else 0.0
        if step < tol:
            return x
    raise AssemblyError(
        f"static equilibrium did not converge in {max_iter} Newton steps: last step {step:.3g}, "
        f"force residual {np.max(np.abs(lin.F)):.3g}"
    )
