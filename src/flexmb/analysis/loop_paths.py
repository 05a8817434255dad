"""Arc-length path following of a model whose loops the articulated strategy closes, in O(n m): T never formed.

:mod:`flexmb.analysis.path_following` follows ``R(x, lambda) = T^T g = 0``
with the p x p tangent ``J = T^T H T`` (``H = d(g + psi^T mu)/dx`` at fixed
multipliers mu, eqs. 5, 28-39). Here each of its dense pieces is taken
without T, as :mod:`flexmb.analysis.loop_statics` takes the Newton step
(``P_S r = 0`` exactly where ``T^T r = 0``, ``P_S`` the constrained solve
with ``S = A + K``, docs/theory.md "Statics without the complement"):

* the path's slope at the start, ``J v = -dR/dlambda``: the Krylov solve
  of ``P_S H dx = -P_S g_lambda`` in the null space of psi;
* the bordered systems of the predictor and of Riks' corrector,
  ``[J, dR/dlambda; a^T, b] [dz; dl] = [r; e]``, with ``a^T dz`` written as
  ``t . (T dz) / c^2``: one GMRES solve of the (n + 1) x (n + 1) system
  ``[P_S H, P_S g_lambda; t^T / c^2, b]``, left-preconditioned by ``P_S``
  as the statics are; it stays regular at limit points, where J is
  singular, as the dense bordered matrix does;
* the stability count (the negative eigenvalues of ``K = -sym(J)``): for
  at most :data:`SUBSPACE_MAX` independent coordinates, ``V^T K_H V`` in an
  orthonormal basis V of the null space of psi (p constrained solves; the
  eigenvalues of ``-sym(J)`` themselves, as V = T C with C orthogonal),
  each basis carried from the previous point by a projection so that the
  bifurcation search interpolates K between two points in bases that
  follow each other; for more, the lowest eigenvalues of ``K_H v = w A v``
  on ``psi v = 0`` by :class:`~flexmb.analysis.loop_modes.LoopModes`'s
  Davidson iteration (same signs by Sylvester's law of inertia), their
  number doubled while all are negative, each to the accuracy that
  settles its sign (:data:`SIGN_RTOL`), or in a basis of the whole
  null space where that fails (an eigenvalue crossing zero).

The loads: Newton's homotopy as in the statics, or named force elements,
whose generalized force is the difference of two compiled balances, with
and without their loads added (the balance is linear in the loads).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.sparse.linalg import LinearOperator, gmres

from ..assembly import apply_group
from ..errors import ModelError
from ..fields import label
from ..forces import ForceElement
from ..forces.base import Loads
from ..kernels.loop_statics import loop_balance
from ..system.solve import _plain
from .loop_modes import LoopModes
from .loop_statics import KRYLOV_FLOOR, KRYLOV_RESTART, KRYLOV_RTOL, KRYLOV_SINGULAR, LoopEquations, _LoopPoint
from .loop_statics import _NewtonFailed, _NotConverged

__all__ = ["LoopPathEquations", "SUBSPACE_MAX", "STABILITY_MODES", "SIGN_RTOL"]

#: the most independent coordinates p whose tangent stiffness is formed in a basis of the null space of psi
SUBSPACE_MAX = 40

#: the lowest eigenvalues the Davidson iteration looks at first for the stability count (doubled while all negative)
STABILITY_MODES = 4

#: a Davidson pair counts when its residual is below this fraction of ``|w| |A x|``: its sign is then settled
#: (the differences' noise, relative to the stiffest freedom, keeps a flexible body's lowest pairs far above
#: :data:`~flexmb.analysis.loop_modes.RESIDUAL_RTOL`)
SIGN_RTOL = 0.1


def chosen_loads(system, load) -> list:
    """The force elements a load factor scales, from an element, a name or a sequence of them.

    Parameters
    ----------
    system : System
        The compiled model.
    load : ForceElement, str or sequence of them
        What :func:`flexmb.load_path` was given.

    Returns
    -------
    list of ForceElement
        The elements, in the order given.

    Raises
    ------
    ModelError
        If ``load`` names none, or an element that is not among the system's force elements.
    """
    refs = [load] if isinstance(load, (str, ForceElement)) else list(load)
    if not refs:
        raise ModelError("load_path: load names no force element (give an element, a name, a list or None)")
    elements = [e for _, group in system.forces.groups for e in group]
    chosen = []
    for ref in refs:
        e = system.model.element(ref, ForceElement)
        if not any(e is o for o in elements):
            raise ModelError(f"load_path: {label(e)} is not among the system's force elements")
        chosen.append(e)
    return chosen


class Stiffness(NamedTuple):
    """The stability record of a path point: eigenvalues ascending, ``K`` (p x p, or None) and its basis."""

    eigs: np.ndarray
    K: np.ndarray | None
    basis: np.ndarray | None


class _Products(LoopModes):
    """:class:`LoopModes` with the static tangent stiffness (``-H``, fixed multipliers) as its stiffness."""

    def __init__(self, eq, pt, lam):
        super().__init__(eq.system, pt.x, np.zeros(eq.n), eq.t, eq.h)
        self.eq, self.pt, self.lam = eq, pt, lam

    def stiffness_times(self, v):
        """``A P (-H v)``, the static tangent stiffness times v made consistent with the loops.

        ``-H v`` is a central difference of ``g + psi^T mu`` (mu fixed)
        along the unit direction of v; ``A P`` (P the constrained solve
        with A) adds the constraint forces that keep it on the loops: the
        same ``V^T K V`` on ``psi V = 0``, and residuals that the Davidson
        iteration can make vanish (at fixed mu, ``H v`` has a part along
        ``psi^T`` that no displacement on the loops balances).

        Parameters
        ----------
        v : ndarray, shape (n,)
            A displacement on ``psi v = 0``.

        Returns
        -------
        ndarray, shape (n,)
            Generalized forces.
        """
        v = np.ravel(v)
        size = float(np.linalg.norm(v))
        if size == 0.0:
            return np.zeros_like(v)
        eq, x, mu, d = self.eq, self.pt.x, self.pt.mu, self.h * v / size
        diff = eq._shifted(eq.move(x, d), self.lam, mu) - eq._shifted(eq.move(x, -d), self.lam, mu)
        self.n_rhs += 2
        return self.mass_times(self.project(-diff * (size / (2 * self.h))))


class LoopPathEquations(LoopEquations):
    """The equations of :func:`flexmb.load_path` for loops closed by the articulated strategy, O(n m) per product.

    Parameters
    ----------
    system : System
        A model with loops closed by the articulated strategy (``system._loop_kernel``).
    t : float
        Time, s.
    load : ForceElement, str, sequence of them, or None
        The load the factor scales (None: Newton's homotopy from x0).
    x0 : ndarray, shape (nq,)
        The start, on the constraints.
    h : float
        Central-difference step along a unit direction.
    """

    def __init__(self, system, t, load, x0, h=1e-6):
        super().__init__(system, t, x0, h)
        self.chosen = None
        if load is None:
            return
        chosen = chosen_loads(system, load)
        self.chosen = [(cls, [e for e in group if any(e is c for c in chosen)]) for cls, group in system.forces.groups]
        self.chosen = [(cls, group) for cls, group in self.chosen if group]
        self.name = ", ".join(e.name for e in chosen)

    def _load(self, x):
        """The chosen loads' generalized force at x: two balances, with their loads added and without."""
        system, x = self.system, _plain(np.asarray(x, dtype=float))
        y = np.concatenate([x, np.zeros(self.n)])
        force, torque, generalized = system._python_loads(self.t, y, system._no_powers)
        kin = system._kinematics(self.t, x, np.zeros(self.n))
        acc = Loads(kin)
        for cls, group in self.chosen:
            apply_group(cls, group, kin, acc)
        args = (system._packed, system._loop_layout, x, self.n, self._zero_rows)
        with_load = loop_balance(*args, force + acc.force, torque + acc.torque, generalized + acc.generalized)[0]
        return with_load - loop_balance(*args, force, torque, generalized)[0]

    def _shifted(self, x, lam, w):
        if self.chosen is None:
            return super()._shifted(x, lam, w)
        x = _plain(np.asarray(x, dtype=float))
        return self._balance(x, w)[1] - (1.0 - lam) * self._load(x)

    def __call__(self, x, lam, tangent=True) -> _LoopPoint:
        """The equations at ``(x, lambda)``: ``R = g + psi^T mu`` (``tangent`` is the dense path's signature)."""
        if self.chosen is None:
            return super().__call__(x, lam, tangent)
        x = _plain(np.array(x, dtype=float))
        F, _ = self._balance(x, self._zero_rows)
        g_lam = self._load(x)
        g = F - (1.0 - lam) * g_lam
        _, mu = self._solve(x, np.zeros(self.n), g)
        return _LoopPoint(x, self._shifted(x, lam, mu), g, g_lam, mu)

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
        _NotConverged
            If the loops cannot be closed: a failed step of the path.
        """
        try:
            return super().project(x)
        except _NewtonFailed as exc:
            raise _NotConverged(str(exc), np.inf, np.inf, 0) from None

    def along(self, pt, lam):
        """The path's slope ``dx/dlambda`` at fixed load factor: ``P_S H dx = -P_S dg/dlambda`` on psi dx = 0.

        Parameters
        ----------
        pt : _LoopPoint
            The equations at the point.
        lam : float
            Its load factor.

        Returns
        -------
        ndarray, shape (n,)
            ``dx/dlambda``, along the speeds (``T v`` with ``J v = -dR/dlambda``).

        Raises
        ------
        numpy.linalg.LinAlgError
            Where the tangent stiffness is singular.
        """
        try:
            return self.krylov(pt, lam, pt.R_lam)
        except _NewtonFailed:
            raise np.linalg.LinAlgError("singular tangent stiffness") from None

    def bordered(self, pt, lam, tx, tl, c, end, residual=True):
        """The bordered system ``[J, R_lam; (T^T tx / c^2)^T, tl] [dz; dl] = [-R or 0; end]`` with ``dx = T dz``.

        One GMRES solve of ``[P_S H, P_S g_lambda; tx^T / c^2, tl]`` in the
        null space of psi (see the module's notes).

        Parameters
        ----------
        pt : _LoopPoint
            The equations at the point.
        lam : float
            Its load factor.
        tx : ndarray, shape (n,)
            The border's coordinate part (a tangent, along the speeds).
        tl : float
            The border's load-factor part.
        c : float
            The arc length's scale of the coordinates.
        end : float
            The border row's right-hand side.
        residual : bool
            The first rows' right-hand side: ``-R`` (Riks' corrector) or 0
            (the tangent).

        Returns
        -------
        dx : ndarray, shape (n,)
            ``T dz``, along the speeds.
        dl : float
            The load factor's part.
        size : float
            ``max |dx|``.

        Raises
        ------
        numpy.linalg.LinAlgError
            If the solve stalls (a singular bordered matrix).
        """
        x, n = pt.x, self.n
        apply = self.operator(pt, lam, onto=True)
        slope = self._tangential(x, self._solve(x, self.stiffness, pt.R_lam)[0])
        border = np.asarray(tx, dtype=float) / c**2

        def product(v):
            top, d = apply(v[:n])
            return np.append(top + v[n] * slope, border @ d + tl * v[n])

        top = np.zeros(n)
        floor = 0.0
        if residual:
            top = -self._tangential(x, self._solve(x, self.stiffness, pt.g)[0])
            floor = KRYLOV_FLOOR * float(np.linalg.norm(self._solve(x, self.stiffness, np.abs(pt.g))[0]))
        rhs = np.append(top, end)
        scale = float(np.linalg.norm(rhs))
        if scale <= floor:
            return np.zeros(n), 0.0, 0.0
        op = LinearOperator((n + 1, n + 1), matvec=product, dtype=float)
        sol, _ = gmres(op, rhs, rtol=KRYLOV_RTOL, atol=floor, restart=min(n + 1, KRYLOV_RESTART),
                       maxiter=max(1, 4 * (n + 1) // KRYLOV_RESTART + 1))
        sol[:n] = self._tangential(x, sol[:n])
        left = float(np.linalg.norm(product(sol) - rhs))
        if not (np.all(np.isfinite(sol)) and left <= max(KRYLOV_SINGULAR * scale, 10 * floor)):
            raise np.linalg.LinAlgError("singular bordered tangent matrix")
        return sol[:n], float(sol[n]), float(np.max(np.abs(sol[:n]))) if n else 0.0

    def stiffness_at(self, pt, lam, previous):
        """The stability record at a point, the basis carried on from the previous point's.

        Parameters
        ----------
        pt : _LoopPoint
            The equations at the point.
        lam : float
            Its load factor.
        previous : Stiffness or None
            The previous point's record.

        Returns
        -------
        Stiffness
            The eigenvalues, ascending (of ``-sym(J)`` for p <= :data:`SUBSPACE_MAX`,
            else the lowest of the pencil ``(K, A)``), and K in its basis (or None).
        """
        ops = _Products(self, pt, lam)
        p = self.system.dof(self.t, pt.x)
        if p == 0:
            return Stiffness(np.zeros(0), np.zeros((0, 0)), np.zeros((self.n, 0)))
        if p <= SUBSPACE_MAX:
            if previous is not None and previous.basis is not None and previous.basis.shape[1] == p:
                start = previous.basis.T
            else:
                start = np.random.default_rng(0).normal(size=(p, self.n))
            V = np.column_stack([ops.project(ops.mass_times(v)) for v in start])
            V, R = np.linalg.qr(V)
            V = V * np.where(np.diag(R) < 0, -1.0, 1.0)  # the basis follows the previous one, no sign flips
            KV = np.column_stack([ops.stiffness_times(v) for v in V.T])
            K = 0.5 * (V.T @ KV + KV.T @ V)
            return Stiffness(np.linalg.eigvalsh(K), K, V)
        k = STABILITY_MODES
        try:
            while 4 * (k + 2) < p:
                w2, _ = ops.lowest(k, rtol=SIGN_RTOL)
                if w2[-1] >= 0:
                    return Stiffness(w2, None, None)
                k *= 2
        except ModelError:  # an eigenvalue too near zero for its sign to settle: every one, in a basis
            pass
        return Stiffness(ops.subspace(p)[0], None, None)
