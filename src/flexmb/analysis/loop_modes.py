"""The lowest modes of a large looped model by shift-invert Lanczos, in O(n m) per step.

The modes of :func:`flexmb.modes` are the eigenpairs of the linearised
reduced equations, ``K z = w^2 M z`` with ``M = T^T A T`` and
``K = -T^T A (dxdd/dx) T`` (eqs. 36-39 linearised; T the orthogonal
complement of psi). Written in the coordinates ``v = T z`` (the
displacements that keep the loops closed, ``psi v = 0``) they are

    ``P (K_x v) = w^2 v``,    ``K_x v = -A (dxdd/dx) v``,

``P = T (T^T A T)^-1 T^T`` the mass-orthogonal solve onto the loops'
tangent space: ``P b`` is the v of ``A v = b + psi^T lambda``,
``psi v = 0`` (:func:`~flexmb.kernels.loops.loop_newton` with no
armature). For a model whose loops the articulated strategy closes
(:mod:`flexmb.kernels.loops`), every piece costs O(n m): ``K_x v`` is a
central difference of two right-hand sides along v (as
:func:`flexmb.linearize` differences along the columns of T), A v one
pass of :func:`~flexmb.kernels.articulated.mass_times` and P one
constrained solve. A, K, T and M are never formed.

The k lowest eigenvalues come from ARPACK's shift-invert mode in the
kinetic-energy inner product (``scipy.sparse.linalg.eigsh``, mode 3, A as
its metric): each step solves ``(K_x - sigma A) v = A r`` on ``psi v = 0``
by GMRES, preconditioned by the same solve with K_x replaced by the
diagonal coordinate springs K_d (segment joints, joint springs): the
constrained articulated-body recursion with ``-K_d / sigma`` as armature
(:class:`~flexmb.system.tangent.LoopNewtonPreconditioner`'s solve), which
leaves out only the geometric stiffness of the loads and of the constraint
forces, so GMRES converges in a few iterations where those are small (a
structure near its unloaded state). Where they are not (a loaded
equilibrium), the differences' noise, which grows with the constraint
forces, keeps GMRES from :data:`INNER_RTOL`, and the path stops with a
ModelError that names the dense one. The shift sits just below zero, so
that the k found are the lowest; an eigenvalue found below it (an unstable
equilibrium) stops the path too. Lanczos takes K symmetric, as it is at an
equilibrium: the stiffness among the modes found is checked for it.

For few independent coordinates p (at most :data:`SUBSPACE_MAX`, or
fewer than ARPACK's 2k + 1 vectors), a basis of the whole tangent space
from p constrained solves takes its place (:meth:`LoopModes.subspace`):
the dense linearisation in another basis, O(p n m).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from ..errors import ModelError
from ..kernels.articulated import mass_times
from ..kernels.loops import loop_newton
from ..system.solve import _plain
from ..system.tangent import NewtonPreconditioner

__all__ = ["LoopModes", "loop_modes", "takes_loop_modes", "SPARSE_MODES_MIN"]

#: the fewest coordinates n at which :func:`flexmb.modes` takes this path for a few modes of a looped model:
#: below it the dense linearisation (T by the SVD of psi, O(n^3)) costs little and gives every mode
SPARSE_MODES_MIN = 200

#: the most independent coordinates p solved in a basis of the whole tangent space (:meth:`LoopModes.subspace`):
#: ARPACK's Lanczos basis holds more vectors than a small p has
SUBSPACE_MAX = 40

#: the shift of the Lanczos iteration, 1/s^2: just below zero, so that the modes come out from the lowest up
#: (a mechanism's zero-frequency modes included)
SHIFT = -1.0

#: GMRES's relative residual per shift-invert solve: near the differences' own noise, so that the
#: eigenvalues agree with those of the dense linearisation
INNER_RTOL = 1e-8

#: the largest asymmetry of the stiffness among the modes found, relative to its largest entry, that the
#: Lanczos path takes for the differences' noise
SYMMETRY_TOL = 1e-6

#: ARPACK's relative accuracy of the shift-inverted eigenvalues
ARPACK_TOL = 1e-12


class LoopModes:
    """The operators of ``P K_x v = w^2 v`` on the loops' tangent space of one state, never forming a matrix.

    Parameters
    ----------
    system : System
        A model whose loops the articulated strategy closes
        (``system._loop_kernel``).
    x0 : ndarray, shape (nq,)
        The coordinates linearised about.
    xd0 : ndarray, shape (n,)
        The speeds.
    t : float
        Time, s.
    h : float
        Step of the central differences along a unit displacement (as
        :func:`flexmb.linearize`'s).
    """

    def __init__(self, system, x0, xd0, t, h):
        self.system, self.x0, self.xd0, self.t, self.h = system, _plain(x0), _plain(xd0), t, h
        pre = NewtonPreconditioner(system)
        kin = system.kinematics(t, x0, xd0)
        self._mass = (system.topology.parent, system.topology.coord_start, system.topology.coord_body,
                      kin.spatial_inertia(), kin.Sw, kin.Sv)
        self.stiffness = pre.stiffness
        self._zero = np.zeros(system.n_speeds)
        self._limit = -1 if system.rank_limit is None else system.rank_limit
        self.n_rhs = 0
        self.n_solves = 0

    def mass_times(self, v):
        """``A v``, O(n)."""
        return mass_times(*self._mass, _plain(np.ravel(v)))

    def constrained(self, armature, load):
        """v with ``(A + diag(armature)) v = load + psi^T lambda``, ``psi v = 0``.

        Raises
        ------
        ModelError
            If the constrained matrix is singular.
        """
        s = self.system
        v, status = loop_newton(s._packed, s._loop_layout, self.x0, _plain(armature), _plain(load), s._loop_tol,
                                self._limit)
        self.n_solves += 1
        if status:
            raise ModelError("modes: the shift-invert solve of the loops is singular (a freedom without mass or "
                             "stiffness that no loop fixes)")
        return v

    def stiffness_times(self, v):
        """``K_x v = -A (dxdd/dx) v`` by central differences along the unit direction of v (as :func:`linearize`)."""
        v = np.ravel(v)
        size = float(np.linalg.norm(v))
        if size == 0.0:
            return np.zeros_like(v)
        s, d = self.system, self.h * v / size
        move = s.layout.displace
        diff = s.accelerations(self.t, move(self.x0, d), self.xd0) - s.accelerations(self.t, move(self.x0, -d),
                                                                                      self.xd0)
        self.n_rhs += 2
        return -self.mass_times(diff) * (size / (2 * self.h))

    def project(self, b):
        """``P b``: the displacement on ``psi v = 0`` with ``A v = b + psi^T lambda``."""
        return self.constrained(self._zero, b)

    def shifted_solve(self, b, sigma):
        """v on ``psi v = 0`` with ``P (K_x - sigma A) v = P b``, by right-preconditioned GMRES.

        Raises
        ------
        ModelError
            If the residual stays above :data:`INNER_RTOL`.
        """
        from scipy.sparse.linalg import LinearOperator, gmres

        n = self.system.n_speeds
        armature = -self.stiffness / sigma

        def apply(v):
            return self.project(self.stiffness_times(v)) - sigma * np.ravel(v)

        def precondition(r):  # (K_d - sigma A) y = A r on psi y = 0
            return self.constrained(armature, self.mass_times(r) / -sigma)

        rhs = self.project(b)
        op = LinearOperator((n, n), matvec=lambda u: apply(precondition(u)), dtype=float)
        u, _ = gmres(op, rhs, rtol=INNER_RTOL, atol=0.0, restart=30, maxiter=3)
        v = precondition(u)
        miss = float(np.linalg.norm(apply(v) - rhs)) / max(float(np.linalg.norm(rhs)), 1e-300)
        if not miss <= INNER_RTOL:
            raise ModelError(f"modes: the shift-invert solve of the loops left a relative residual {miss:.3g} at the "
                             f"shift {sigma:.6g} 1/s^2; the dense path takes it: modes(linearize(system), k)")
        return v

    def lowest(self, k, sigma):
        """The k eigenvalues ``w^2`` nearest the shift and their vectors v (``T phi``), ascending.

        Parameters
        ----------
        k : int
            How many (fewer than the independent coordinates p by ARPACK's
            rule; see :meth:`subspace` for small p).
        sigma : float
            The shift, 1/s^2, below the lowest eigenvalue.

        Returns
        -------
        w2 : ndarray, shape (k,)
        v : ndarray, shape (n, k)
        """
        from scipy.sparse.linalg import LinearOperator, eigsh

        n = self.system.n_speeds
        op = LinearOperator((n, n), matvec=self.stiffness_times, dtype=float)
        metric = LinearOperator((n, n), matvec=self.mass_times, dtype=float)
        inverse = LinearOperator((n, n), matvec=lambda b: self.shifted_solve(b, sigma), dtype=float)
        start = self.project(self.mass_times(np.ones(n)))
        w2, v = eigsh(op, k=k, M=metric, sigma=sigma, which="LM", OPinv=inverse, v0=start, tol=ARPACK_TOL)
        order = np.argsort(w2)
        w2, v = w2[order], v[:, order]
        S = v.T @ np.column_stack([self.stiffness_times(c) for c in v.T])  # Lanczos takes K symmetric
        if np.max(np.abs(S - S.T), initial=0.0) > SYMMETRY_TOL * np.max(np.abs(S), initial=0.0):
            raise ModelError("modes: the stiffness of the loops is not symmetric at this state (not an equilibrium: "
                             "the constraint forces or the loads do work on the modes); the dense path takes its "
                             "symmetric part: modes(linearize(system), k)")
        return w2, v

    def subspace(self, p):
        """Every eigenpair in a basis of the loops' tangent space built from p solves (small p).

        ``V = P A R`` for p random columns R spans the p-dimensional space
        ``psi v = 0``; ``V^T K_x V`` and ``V^T A V`` are the linearisation's
        K and M in that basis (as :func:`flexmb.linearize` forms them in
        the basis T). O(p n m), an n x p array.

        Returns
        -------
        w2 : ndarray, shape (p,)
        v : ndarray, shape (n, p)
        """
        n = self.system.n_speeds
        rng = np.random.default_rng(0)
        V = np.column_stack([self.project(self.mass_times(rng.normal(size=n))) for _ in range(p)])
        V, _ = np.linalg.qr(V)  # orthonormal columns: unit directions, as T's
        AV = np.column_stack([self.mass_times(c) for c in V.T])
        KV = np.column_stack([self.stiffness_times(c) for c in V.T])
        K = V.T @ KV
        w2, phi = sla.eigh(0.5 * (K + K.T), V.T @ AV)
        return w2, V @ phi


def takes_loop_modes(system, n_modes, method) -> bool:
    """Whether :func:`flexmb.modes` takes this path: a looped model closed by the articulated strategy.

    With ``n`` at least :data:`SPARSE_MODES_MIN`, a number of modes asked
    for (not all of them), and the linearisation by differences ('auto' or
    'fd': with loops 'auto' takes differences).

    Parameters
    ----------
    system : System or Linearization
        What :func:`flexmb.modes` was given.
    n_modes : int or None
        How many modes.
    method : str
        :func:`flexmb.linearize`'s method.

    Returns
    -------
    bool
    """
    return (n_modes is not None and method in ("auto", "fd") and getattr(system, "_loop_kernel", False)
            and system.n_speeds >= SPARSE_MODES_MIN)


def loop_modes(system, k, x0, xd0, t, h):
    """The k lowest ``w^2`` and their shapes ``T phi`` of a looped model, in O(n m) per step.

    Parameters
    ----------
    system : System
        See :func:`takes_loop_modes`.
    k : int
        How many (at most the independent coordinates p).
    x0 : ndarray, shape (nq,)
        Coordinates.
    xd0 : ndarray, shape (n,)
        Speeds.
    t : float
        Time, s.
    h : float
        Difference step.

    Returns
    -------
    w2 : ndarray, shape (min(k, p),)
        Ascending.
    shapes : ndarray, shape (n, min(k, p))
        In the coordinates x.
    """
    p = system.dof(t, x0)
    ops = LoopModes(system, x0, xd0, t, h)
    k = min(k, p)
    if p <= max(SUBSPACE_MAX, 2 * k + 1):  # ARPACK's basis (2k + 1 vectors) would not fit in the space
        w2, v = ops.subspace(p)
        return w2[:k], v[:, :k]
    w2, v = ops.lowest(k, SHIFT)
    if w2[0] <= SHIFT:  # an unstable equilibrium: others may lie further below, where Lanczos does not look
        raise ModelError(f"modes: an eigenvalue ({w2[0]:.6g} 1/s^2) lies below the shift {SHIFT:g} 1/s^2 (an unstable "
                         "equilibrium), and more may lie further below; the dense path finds them all: "
                         "modes(linearize(system), k)")
    return w2, v
