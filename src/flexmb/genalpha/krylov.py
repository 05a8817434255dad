"""Generalized-alpha's Newton solves without a matrix: GMRES preconditioned by the O(n) Newton solve.

For a large model, :class:`~flexmb.genalpha.GeneralizedAlpha` given a
``preconditioner`` (:meth:`flexmb.System.newton_preconditioner`) solves
its Newton systems ``S da = -r``, ``S = I - gamma' h Jv - beta' h^2 Jx``,
without forming S. The preconditioner's ``solve_accelerations``, ``M^-1
~ S^-1`` (``(A + c1 C + c2 K)^-1 A`` for open trees, ``I - P_D D`` for
loops closed by the articulated strategy; docs/theory.md), holds the stiff
springs and dampers exactly and leaves out the geometric stiffness, the
velocity-product terms and the change of the constraint forces, which are
of order ``(h omega)^2`` and ``h omega`` on the modes the step resolves.
So :class:`KrylovNewton` first iterates with ``da = -M^-1 r`` alone (a
modified Newton iteration, M in the place of the dense path's kept
Jacobian: one right-hand side and one O(n) solve per iteration). Where
that fails (the terms left out matter: Newton's rate test fails with it),
the solver switches, for good, to Newton-Krylov: S applied to a vector by
a directional difference of the right-hand side at the iterate (one
evaluation), GMRES (:func:`gmres`) left-preconditioned by ``M^-1``, in the
norm of the Newton iteration's convergence test. Nothing of size n x n is
formed: O(n) per product for an open tree, O(n m) with m loop rows.

References
----------
.. [1] Y. Saad, M. H. Schultz, "GMRES: a generalized minimal residual
   algorithm for solving nonsymmetric linear systems", SIAM J. Sci. Stat.
   Comput. 7 (1986) 856-869.
.. [2] P. N. Brown, A. C. Hindmarsh, "Reduced storage matrix methods in
   stiff ODE systems", Appl. Math. Comput. 31 (1989) 40-91.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_triangular

from ..kernels import genalpha as kernels
from ..kernels.genalpha import NEWTON_MAXITER

__all__ = ["KRYLOV_DIM", "KRYLOV_MIN_COORDS", "KRYLOV_MIN_LOOP_COORDS", "LINEAR_TOL", "gmres", "KrylovNewton"]

_SQRT_EPS = np.sqrt(np.finfo(float).eps)

#: the largest Krylov space of one solve (as CVODE's GMRES in flexmb.integrators.sundials): the
#: preconditioner holds the stiff springs and dampers exactly, so few iterations remain
KRYLOV_DIM = 10
#: simulate gives generalized-alpha the Newton preconditioner (these matrix-free solves) from this many
#: speeds on (``GeneralizedAlpha.krylov_min_coords``) for open trees, and from KRYLOV_MIN_LOOP_COORDS on
#: for loops closed by the articulated strategy: below, the dense LU of S is as fast or faster (measured
#: with benchmarks/genalpha_krylov.py: B1 equal at 48 and 64 speeds, 1.5x faster matrix-free at 128; B6
#: damped 2.4x and 1.3x slower matrix-free at 66 and 130, 2.2x faster at 258: docs/benchmarks.md)
KRYLOV_MIN_COORDS = 64
KRYLOV_MIN_LOOP_COORDS = 160
#: a Newton correction is solved to LINEAR_TOL times Newton's tolerance in Newton's own norm
#: (CVODE's default, 0.05, for its linear solves)
LINEAR_TOL = 0.05


def gmres(apply, b, weights, tol, max_dim=KRYLOV_DIM):
    """``x`` with ``B x ~ b``, B given by products, in the weighted RMS norm ``|w v| / sqrt(n)``.

    Parameters
    ----------
    apply : callable
        ``apply(v)`` returns ``B v`` (here the preconditioned Newton matrix
        ``M^-1 S``).
    b : ndarray, shape (n,)
        Right-hand side (``M^-1`` times Newton's right-hand side).
    weights : ndarray, shape (n,)
        The norm's weights.
    tol : float
        Stop once the residual's norm is at most this.
    max_dim : int
        The largest Krylov space (no restart: the last iterate is returned).

    Returns
    -------
    x : ndarray, shape (n,)
        The minimal-residual iterate.
    iterations : int
        Products with B.

    Notes
    -----
    GMRES [1]_ with modified Gram-Schmidt and Givens rotations on the
    scaled unknowns ``s = w x``, where the weighted norm is Euclidean. With
    ``B = M^-1 S`` the residual ``M^-1 (b' - S x)`` approximates the
    error ``S^-1 b' - x``, so the test bounds the error of the correction
    in Newton's norm.
    """
    n = b.shape[0]
    root = np.sqrt(n) if n else 1.0
    r0 = weights * b
    beta = np.linalg.norm(r0)
    if n == 0 or beta / root <= tol or not np.isfinite(beta):
        return np.zeros(n), 0
    V = np.empty((max_dim + 1, n))
    H = np.zeros((max_dim + 1, max_dim))
    cs, sn = np.zeros(max_dim), np.zeros(max_dim)
    g = np.zeros(max_dim + 1)
    V[0] = r0 / beta
    g[0] = beta
    k = 0
    for j in range(max_dim):
        w = weights * apply(V[j] / weights)
        for i in range(j + 1):
            H[i, j] = V[i] @ w
            w -= H[i, j] * V[i]
        H[j + 1, j] = np.linalg.norm(w)
        if H[j + 1, j] > 0:
            V[j + 1] = w / H[j + 1, j]
        for i in range(j):  # the earlier rotations on the new column
            H[i, j], H[i + 1, j] = cs[i] * H[i, j] + sn[i] * H[i + 1, j], -sn[i] * H[i, j] + cs[i] * H[i + 1, j]
        rho = np.hypot(H[j, j], H[j + 1, j])
        cs[j], sn[j] = (1.0, 0.0) if rho == 0 else (H[j, j] / rho, H[j + 1, j] / rho)
        H[j, j], H[j + 1, j] = rho, 0.0
        g[j], g[j + 1] = cs[j] * g[j], -sn[j] * g[j]
        k = j + 1
        if abs(g[j + 1]) / root <= tol or rho == 0 or not np.isfinite(g[j + 1]):
            break
    if not np.all(np.isfinite(H[:k, :k])) or np.any(np.diag(H[:k, :k]) == 0):
        return np.zeros(n), k
    y = solve_triangular(H[:k, :k], g[:k], check_finite=False)
    return (V[:k].T @ y) / weights, k


class KrylovNewton:
    """Generalized-alpha's matrix-free Newton solves: the preconditioner's set-up, products with S, GMRES.

    The set-up (:meth:`setup`) takes the place of the dense path's
    Jacobian: it is made at a step's start, kept until Newton fails with
    it, and counted as a Jacobian (``njev``). The corrections are the
    preconditioner's solves alone until Newton fails with them
    (``exact`` False); then GMRES, whose products with S are taken at the
    Newton iterate itself (a Newton-Krylov iteration: the set-up's state
    matters only for the preconditioner).

    Parameters
    ----------
    preconditioner : NewtonPreconditioner
        With ``setup(t, q, u)`` and ``solve_accelerations(r, c1, c2)``.
    fun : callable
        The right-hand side of the step's state ``z`` (in the chart, if any).
    n : int
        Number of speeds.
    nq : int
        Number of coordinates of the state ``y = (q, u, w)``.

    Attributes
    ----------
    n_krylov : int
        GMRES iterations (products with S) so far.
    n_precond : int
        Preconditioner solves so far.
    ready : bool
        The preconditioner holds a set-up.
    exact : bool
        The corrections are solved by GMRES (set by the solver once the
        preconditioner alone failed Newton).
    """

    def __init__(self, preconditioner, fun, n, nq):
        self.pre, self.fun, self.n, self.nq = preconditioner, fun, n, nq
        self.n_krylov = 0
        self.n_precond = 0
        self.ready = False
        self.exact = False

    def setup(self, t, y) -> None:
        """Set the preconditioner up at the state ``y = (q, u, w)`` (coordinates, not the chart's).

        Parameters
        ----------
        t : float
            Time, s.
        y : ndarray
            The state.
        """
        nq, n = self.nq, self.n
        self.pre.setup(t, y[:nq], y[nq : nq + n])
        self.ready = True

    def precondition(self, r, c1, c2):
        """``M^-1 r``, the preconditioner's approximation of ``S^-1 r`` (``c1 = gamma' h``, ``c2 = beta' h^2``).

        Parameters
        ----------
        r : ndarray, shape (n,)
            Right-hand side.
        c1, c2 : float
            The coefficients of ``Jv`` and ``Jx`` in S.

        Returns
        -------
        ndarray, shape (n,)
            The approximate solution.
        """
        self.n_precond += 1
        return self.pre.solve_accelerations(r, c1, c2)

    def correction(self, t1, z1, f1, r, c1, c2, weights, tol):
        """Newton's correction ``da = -S^-1 r`` at the iterate ``(t1, z1)`` where the right-hand side is ``f1``.

        ``-M^-1 r`` unless :attr:`exact`; else by GMRES, with ``S v = v -
        (f(t1, z1 + e (c2 v, c1 v, 0)) - f1)[n:2n] / e``, a forward
        difference along the direction, with ``e = sqrt(eps) (1 + |z1|) /
        |(c2 v, c1 v)|`` (2-norms over positions and speeds).

        Parameters
        ----------
        t1 : float
            Time of the step's end, s.
        z1 : ndarray, shape (2 n + n_w,)
            The iterate's state.
        f1 : ndarray, shape (2 n + n_w,)
            The right-hand side there.
        r : ndarray, shape (n,)
            Newton's residual ``a1 - f1[n:2n]``.
        c1, c2 : float
            ``gamma' h`` and ``beta' h^2``.
        weights : ndarray, shape (n,)
            Newton's norm of a correction (:func:`gmres`).
        tol : float
            The correction's accuracy in that norm.

        Returns
        -------
        ndarray, shape (n,)
            The correction.
        """
        n, fun = self.n, self.fun
        a1 = f1[n : 2 * n]
        size = 1.0 + np.linalg.norm(z1[: 2 * n])
        probe = z1.copy()

        def apply(v):
            dx, dv = c2 * v, c1 * v
            step = np.sqrt(dx @ dx + dv @ dv)
            if step == 0:
                return v.copy()
            e = _SQRT_EPS * size / step
            probe[:n] = z1[:n] + e * dx
            probe[n : 2 * n] = z1[n : 2 * n] + e * dv
            jv = (fun(t1, probe)[n : 2 * n] - a1) / e
            return self.precondition(v - jv, c1, c2)

        b = self.precondition(-r, c1, c2)
        if not self.exact:
            return b
        da, k = gmres(apply, b, weights, tol)
        self.n_krylov += k
        return da

    def newton(self, solver, t1, h, base, a1, y1, abar1, scale):
        """The Newton iteration of ``solver``'s step to ``t1``, each correction by GMRES.

        As the dense path's (``GeneralizedAlpha._newton``, same returns) but
        for the correction, which is solved to ``LINEAR_TOL`` times Newton's
        tolerance in Newton's own norm (that of :func:`~flexmb.kernels.
        genalpha.newton_update`), so that the convergence test and its
        rates read as on the dense path.

        Parameters
        ----------
        solver : GeneralizedAlpha
            The solver (its right-hand side, parameters and counts).
        t1, h : float
            The step's end and size, s.
        base, a1, y1, abar1, scale : ndarray
            As :func:`~flexmb.kernels.genalpha.predict` left them, and scratch.

        Returns
        -------
        end : tuple or None
            ``(y1, a1, abar1, g1)``, or None if Newton failed.
        iterations : int
            Newton iterations.
        rate : float
            The last convergence rate.
        """
        n, par, c1, c2 = self.n, solver._par, solver.gamma_p * h, solver.beta_p * h * h
        sx = solver.atol + solver.rtol * np.abs(y1[:n])
        sv = sx / abs(h) + solver.rtol * np.abs(y1[n : 2 * n])
        weights = np.sqrt(0.5 * ((c2 / sx) ** 2 + (c1 / sv) ** 2))
        tol = LINEAR_TOL * solver.newton_tol
        d, rate = -1.0, -1.0
        for k in range(NEWTON_MAXITER):
            f = self.fun(t1, y1)
            solver.n_newton += 1
            if not np.all(np.isfinite(f)):
                return None, k + 1, rate
            da = self.correction(t1, y1, f, a1 - f[n : 2 * n], c1, c2, weights, tol)
            outcome, d, rate = kernels.newton_apply(f, da, h, n, k, d, par, solver.atol, base, solver.g, a1, y1,
                                                    abar1, scale)
            if outcome == kernels.CONVERGED:
                return (y1, a1, abar1, f[2 * n :]), k + 1, rate
            if outcome == kernels.FAILED:
                return None, k + 1, rate
        return None, NEWTON_MAXITER, rate
