"""The static equations of a model whose loops the articulated strategy closes, in O(n m): T never formed.

:mod:`flexmb.analysis.path_following` writes the static equations as
``R = T^T g = 0`` on ``phi = 0`` and their tangent as the p x p matrix
``J = T^T H T``, ``H = d(g + psi^T mu)/dx`` at fixed multipliers mu
(eqs. 5, 28-39). For loops closed through the articulated-body recursion
the same Newton step is taken without T (docs/theory.md, "Statics without
the complement"): with ``P_S = T (T^T S T)^-1 T^T`` for a symmetric
positive definite S, ``T^T r = 0`` exactly where ``P_S r = 0``, and the
step ``dx = T dz``, ``J dz = -R``, is the solution in the null space of psi
of

    P_S H dx = -P_S g,

``P_S b`` being the constrained solve ``S v = b + psi^T lambda``,
``psi v = 0`` (:func:`~flexmb.kernels.loops.loop_newton_solve`, O(n m), the
solve of the loops' Newton preconditioner). It is solved by GMRES, each
product ``H d`` a central difference of ``g + psi^T mu`` along d (as the
dense path differences along T's columns; ``psi^T mu`` from the rows'
wrenches, :func:`~flexmb.kernels.loop_statics.loop_balance`). With
``S = A + K`` (K the diagonal coordinate springs) the preconditioned
operator is near the identity on a stiff structure and has p eigenvalues
at most on a mechanism, so GMRES takes a few products. The multipliers mu
are the mass-weighted ones of ``A v = g + psi^T mu`` (equal to the
least-squares ones at the equilibrium, which is all Newton's quadratic
convergence asks), the residual reported is ``g + psi^T mu`` (= ``A v``,
in N or N m) and the step is ``max |dx|``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.sparse.linalg import LinearOperator, gmres

from ..errors import AssemblyError
from ..kernels.loop_statics import loop_balance
from ..kernels.loops import loop_newton_factor, loop_newton_solve, loop_speeds
from ..system.solve import _plain
from ..system.tangent import NewtonPreconditioner

#: relative residual of the Krylov solve of a Newton step, and the Krylov dimension between restarts
KRYLOV_RTOL, KRYLOV_RESTART = 1e-8, 60
#: the rounding floor of ``P_S g``: this times ``|P_S |g||``
KRYLOV_FLOOR = 1e-13
#: a Krylov solve left above this relative residual means a singular tangent stiffness
KRYLOV_SINGULAR = 1e-6


class _LoopPoint(NamedTuple):
    """The static equations at one state: ``R = g + psi^T mu`` (n), ``g``, ``dg/dlambda``, mu."""

    x: np.ndarray
    R: np.ndarray
    g: np.ndarray
    R_lam: np.ndarray
    mu: np.ndarray


class _NewtonFailed(Exception):
    """A Newton step that cannot be taken (the caller turns it into its own failure)."""


class _NotConverged(Exception):
    """A Newton iteration or a path step that failed: why, the last correction, the residual, the iterations."""

    def __init__(self, why, step, residual, iterations):
        super().__init__(why)
        self.why, self.step, self.residual, self.iterations = why, step, residual, iterations


class LoopEquations:
    """``g(x, lambda) = F(x) - (1 - lambda) F(x0)`` and its Newton step, for loops closed by the articulated strategy.

    The counterpart of :class:`~flexmb.analysis.path_following._Equations`
    (Newton's homotopy, all loads scaled) for :func:`~flexmb.static_equilibrium`'s
    Newton iteration: O(n m) per product, no n x n array.

    Parameters
    ----------
    system : System
        A model with loops closed by the articulated strategy (``system._loop_kernel``).
    t : float
        Time, s.
    x0 : ndarray, shape (nq,)
        The start, on the constraints: ``F(x0)`` is the homotopy's reference.
    h : float
        Central-difference step along a unit direction.
    """

    def __init__(self, system, t, x0, h=1e-6):
        system.constraints.refuse_velocity_rows("static equilibrium")
        self.system, self.t, self.h = system, float(t), h
        self.n = system.n_speeds
        self.move = system.layout.displace
        self.name = "Newton homotopy F(x) - (1 - lambda) F(x0)"
        self.limit = -1 if system.rank_limit is None else system.rank_limit
        self.stiffness = _plain(NewtonPreconditioner.diagonal_terms(system)[0])
        self._zero_rows = np.zeros(system.n_constraints)
        self.n_products = 0
        self.ref = self._balance(_plain(np.array(x0, dtype=float)), self._zero_rows)[0]

    def _balance(self, x, w):
        """``g(x)`` at rest (all loads) and ``g(x) + psi(x)^T w``."""
        system = self.system
        y = np.concatenate([x, np.zeros(self.n)])
        force, torque, generalized = system._python_loads(self.t, y, system._no_powers)
        return loop_balance(system._packed, system._loop_layout, x, self.n, w, force, torque, generalized)

    def _solve(self, x, armature, load):
        """``v, lambda`` of ``(A + diag(armature)) v = load + psi^T lambda``, ``psi v = 0`` at x."""
        system = self.system
        factored = loop_newton_factor(system._packed, system._loop_layout, x, armature, system._loop_tol, self.limit)
        v, lam, kept, status = loop_newton_solve(factored, system._packed, system._loop_layout, _plain(load))
        if status in (1, 3):
            raise AssemblyError(system._massless_message(kept, f"static equilibrium at t = {self.t:.6g} s"))
        if status:
            raise _NewtonFailed("the forces or the constraint rows are not finite")
        return v, lam

    def project(self, x):
        """The coordinates x moved onto the constraints (:meth:`System.project`).

        Parameters
        ----------
        x : ndarray, shape (nq,)
            Coordinates.

        Returns
        -------
        ndarray, shape (nq,)
            On the constraints.

        Raises
        ------
        _NewtonFailed
            If the loops cannot be closed: a failed step.
        """
        try:
            return self.system.project(self.t, x, np.zeros(self.n))[0]
        except AssemblyError as exc:
            raise _NewtonFailed(f"the constraints cannot be closed ({exc})") from None

    def __call__(self, x, lam, tangent=True) -> _LoopPoint:
        """The equations at ``(x, lambda)`` (``tangent`` is accepted for the dense path's signature)."""
        x = _plain(np.array(x, dtype=float))
        F, _ = self._balance(x, self._zero_rows)
        g = F - (1.0 - lam) * self.ref
        _, mu = self._solve(x, np.zeros(self.n), g)
        R = g + self._balance(x, mu)[1] - F  # g + psi^T mu
        return _LoopPoint(x, R, g, self.ref, mu)

    def _tangential(self, x, d):
        """``d`` projected onto ``psi d = 0`` (mass-orthogonally, :func:`~flexmb.kernels.loops.loop_speeds`)."""
        system = self.system
        v, _, status = loop_speeds(system._packed, system._loop_layout, x, _plain(d), self._zero_rows,
                                   system._loop_tol, 0.0, self.limit)
        if status:
            raise _NewtonFailed("the mass matrix is singular on the constraints' null space")
        return v

    def _shifted(self, x, lam, w):
        """``g(x, lambda) + psi(x)^T w`` (the balance differenced at fixed multipliers w)."""
        return self._balance(_plain(x), w)[1] - (1.0 - lam) * self.ref

    def operator(self, pt: _LoopPoint, lam, onto=False):
        """The product ``d -> (P_S H d_t, d_t)`` at a point, ``d_t`` the part of d in the null space of psi.

        ``H d_t`` is a central difference of ``g + psi^T mu`` (mu fixed)
        along the unit direction of ``d_t``; one product costs two balances,
        one constrained solve and one projection onto the null space (two
        with ``onto``).

        ``P_S``'s result is on ``psi v = 0`` to the kernel's accuracy only;
        near a singular position (psi's smallest singular values a few
        thousandths) that leaves it off the null space enough to stall a
        solve whose right-hand side is on it: ``onto=True`` takes the
        result's part there too (the bordered solves of the path). Newton's
        step (:meth:`krylov`) leaves it: on a mechanism with no stiffness
        along its free motion the products are round-off, and their part off
        the null space is what stalls the solve and reports the singular
        tangent stiffness.

        Parameters
        ----------
        pt : _LoopPoint
            The equations at the point.
        lam : float
            Its load factor.
        onto : bool
            Whether the result's part on the null space is taken.

        Returns
        -------
        callable
            ``d -> (P_S H d_t, d_t)``, both ndarray of shape (n,).
        """
        x, mu, h = pt.x, pt.mu, self.h

        def product(d):
            d = self._tangential(x, np.ravel(d))
            size = float(np.linalg.norm(d))
            if size == 0.0:
                return np.zeros(self.n), d
            e = d / size
            self.n_products += 1
            diff = self._shifted(self.move(x, h * e), lam, mu) - self._shifted(self.move(x, -h * e), lam, mu)
            v = self._solve(x, self.stiffness, diff * (size / (2 * h)))[0]
            return (self._tangential(x, v) if onto else v), d

        return product

    def newton_step(self, pt: _LoopPoint, lam):
        """``dx`` in the null space of psi with ``T^T (H dx + g) = 0``, by GMRES on ``P_S H dx = -P_S g``.

        Parameters
        ----------
        pt : _LoopPoint
            The equations at the state.
        lam : float
            The load factor.

        Returns
        -------
        dx : ndarray, shape (n,)
            The step, along the speeds.
        size : float
            ``max |dx|``.

        Raises
        ------
        _NewtonFailed
            If the tangent stiffness is singular (the Krylov solve stalls above its floor).
        """
        dx = self.krylov(pt, lam, pt.g)
        return dx, float(np.max(np.abs(dx))) if dx.size else 0.0

    def krylov(self, pt: _LoopPoint, lam, load):
        """``dx`` in the null space of psi with ``T^T (H dx + load) = 0``, by GMRES on ``P_S H dx = -P_S load``.

        The products take their direction's part in the null space of psi
        first (the operator is singular on the rest, where round-off would
        otherwise leave arbitrary components), the right-hand side is
        projected there too (near the solution its rounding error, of the
        size of ``|P_S| |load|``, is as large as itself, and GMRES would
        chase the part no product can give), and the solve stops at that
        rounding floor.

        Parameters
        ----------
        pt : _LoopPoint
            The equations at the state.
        lam : float
            The load factor.
        load : ndarray, shape (n,)
            Generalized forces (``g`` for a Newton step, ``dg/dlambda`` for the path's slope).

        Returns
        -------
        ndarray, shape (n,)
            dx, along the speeds (zeros where ``P_S load`` is round-off).

        Raises
        ------
        _NewtonFailed
            If the tangent stiffness is singular (the Krylov solve stalls above its floor).
        """
        x = pt.x
        apply = self.operator(pt, lam)

        def product(d):
            return apply(d)[0]

        # in the null space of psi up to round-off of its own size (not of |P_S| |g|): the operator's range
        rhs = -self._tangential(x, self._solve(x, self.stiffness, load)[0])
        scale = float(np.linalg.norm(rhs))
        floor = KRYLOV_FLOOR * float(np.linalg.norm(self._solve(x, self.stiffness, np.abs(load))[0]))
        if scale <= floor:  # the residual is round-off: no step
            return np.zeros(self.n)
        op = LinearOperator((self.n, self.n), matvec=product, dtype=float)
        dx, _ = gmres(op, rhs, rtol=KRYLOV_RTOL, atol=floor, restart=min(self.n, KRYLOV_RESTART),
                      maxiter=max(1, 4 * self.n // KRYLOV_RESTART + 1))
        dx = self._tangential(x, dx)
        left = float(np.linalg.norm(product(dx) - rhs))
        if not (np.all(np.isfinite(dx)) and left <= max(KRYLOV_SINGULAR * scale, 10 * floor)):
            raise _NewtonFailed("the tangent stiffness is singular")
        return dx
