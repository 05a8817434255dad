"""The lowest modes of a large looped model by preconditioned Davidson iteration, in O(n m) per step.

The modes of :func:`flexmb.modes` are the eigenpairs of the linearised
reduced equations, ``K z = w^2 M z`` with ``M = T^T A T`` and
``K = -T^T A (dxdd/dx) T`` (eqs. 36-39 linearised; T the orthogonal
complement of psi). In a basis V of displacements that keep the loops
closed (``psi V = 0``) they are the Rayleigh-Ritz problem
``(V^T K_x V) y = w^2 (V^T A V) y`` with ``K_x v = -A (dxdd/dx) v``,
exact when V spans the whole tangent space (T's columns are one such
basis). For a model whose loops the articulated strategy closes
(:mod:`flexmb.kernels.loops`) every piece costs O(n m): ``K_x v`` is a
central difference of two right-hand sides along v (as
:func:`flexmb.linearize` differences along the columns of T), ``A v``
one pass of :func:`~flexmb.kernels.articulated.mass_times`, and the
constrained solve of ``(A + E) v = b + psi^T lambda``, ``psi v = 0``
(:func:`~flexmb.kernels.loops.loop_newton_solve`, factored once per
armature) maps loads onto the tangent
space. A, K, T and M are never formed.

For a few modes of many independent coordinates p, V grows by the
generalized Davidson method (Davidson, J. Comput. Phys. 17 (1975) 87;
Morgan & Scott, SIAM J. Sci. Stat. Comput. 7 (1986) 817): the residuals
``r = K_x x - w^2 A x`` of the Ritz pairs not yet converged, each solved
with the preconditioner ``(K_d - sigma A) t = r`` on ``psi t = 0`` (K_d
the diagonal coordinate springs: segment joints, joint springs; the
constrained articulated-body recursion with ``-K_d / sigma`` as armature,
:class:`~flexmb.system.tangent.LoopNewtonPreconditioner`'s solve), are
added to V until every residual is below :data:`RESIDUAL_RTOL` of its
``w^2 |A x|``. Rayleigh-Ritz picks the lowest pairs of the basis,
negative ones (an unstable equilibrium) included, and takes K's
symmetric part as the dense path does; the differences' noise enters the
eigenvalues once, through ``V^T K_x V``, and no solve has to converge on
it. The preconditioner leaves out the geometric stiffness of the loads
and of the constraint forces: a loaded equilibrium takes a few more
iterations. Away from an equilibrium, where K is not symmetric, the
residuals do not vanish and the path stops with a ModelError that names
the dense path.

For few independent coordinates (at most :data:`SUBSPACE_MAX`, or fewer
than the basis would hold), V is a basis of the whole tangent space from
p constrained solves (:meth:`LoopModes.subspace`): the dense
linearisation in another basis, O(p n m).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from ..errors import ModelError
from ..kernels.articulated import mass_times
from ..kernels.loops import loop_newton_factor, loop_newton_solve
from ..system.solve import _plain
from ..system.tangent import NewtonPreconditioner

__all__ = ["LoopModes", "loop_modes", "takes_loop_modes", "SPARSE_MODES_MIN", "SUBSPACE_MAX", "SHIFT", "RESIDUAL_RTOL",
           "MAX_ITERATIONS"]

#: the fewest coordinates n at which :func:`flexmb.modes` takes this path for a few modes of a looped model:
#: below it the linearisation of every mode (p constrained solves and 2p differences, a p x p eigenproblem) costs little
SPARSE_MODES_MIN = 200

#: the most independent coordinates p solved in a basis of the whole tangent space (:meth:`LoopModes.subspace`):
#: the dense problem in a basis of p vectors costs little there, and gives every mode
SUBSPACE_MAX = 40

#: the preconditioner's shift, 1/s^2: below zero, so that ``K_d - SHIFT A`` is positive definite also on
#: freedoms without springs
SHIFT = -1.0

#: a Ritz pair has converged when its residual ``|K_x x - w^2 A x|`` is below this fraction of ``|w^2| |A x|``
RESIDUAL_RTOL = 1e-7

#: Davidson iterations allowed
MAX_ITERATIONS = 60


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
    where : str
        The function named in error messages.
    """

    def __init__(self, system, x0, xd0, t, h, where="modes"):
        self.system, self.x0, self.xd0, self.t, self.h = system, _plain(x0), _plain(xd0), t, h
        self.where = where
        pre = NewtonPreconditioner(system)
        kin = system.kinematics(t, x0, xd0)
        self._mass = (system.topology.parent, system.topology.coord_start, system.topology.coord_body,
                      kin.spatial_inertia(), kin.Sw, kin.Sv)
        self.stiffness = pre.stiffness
        self._zero = np.zeros(system.n_speeds)
        self._limit = -1 if system.rank_limit is None else system.rank_limit
        self.n_rhs = 0
        self.n_solves = 0
        self._factors = {}

    def mass_times(self, v):
        """``A v``, O(n), A never formed.

        Parameters
        ----------
        v : ndarray, shape (n,)
            Speeds (or displacements).

        Returns
        -------
        ndarray, shape (n,)
            The generalized forces ``A v``.
        """
        return mass_times(*self._mass, _plain(np.ravel(v)))

    def constrained(self, armature, load):
        """The v with ``(A + diag(armature)) v = load + psi^T lambda`` and ``psi v = 0``.

        Parameters
        ----------
        armature : ndarray, shape (n,)
            Diagonal added to A.
        load : ndarray, shape (n,)
            Generalized forces.

        Returns
        -------
        ndarray, shape (n,)
            The displacement v on the loops' tangent space.

        Raises
        ------
        ModelError
            If the constrained matrix is singular.
        """
        s = self.system
        armature = _plain(armature)
        key = armature.tobytes()  # two armatures: none (P) and the preconditioner's
        if key not in self._factors:
            self._factors[key] = loop_newton_factor(s._packed, s._loop_layout, self.x0, armature, s._loop_tol,
                                                    self._limit)
        v, _, _, status = loop_newton_solve(self._factors[key], s._packed, s._loop_layout, _plain(load))
        self.n_solves += 1
        if status:
            raise ModelError(f"{self.where}: the constrained solve of the loops is singular (a freedom without "
                             "mass or stiffness that no loop fixes)")
        return v

    def stiffness_times(self, v):
        """``K_x v = -A (dxdd/dx) v`` by central differences along the unit direction of v (as :func:`linearize`).

        Parameters
        ----------
        v : ndarray, shape (n,)
            A displacement on ``psi v = 0``.

        Returns
        -------
        ndarray, shape (n,)
            The generalized forces ``K_x v`` (two right-hand sides).
        """
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
        """``P b``: the displacement on ``psi v = 0`` with ``A v = b + psi^T lambda``.

        Parameters
        ----------
        b : ndarray, shape (n,)
            Generalized forces.

        Returns
        -------
        ndarray, shape (n,)
            The displacement ``P b``.
        """
        return self.constrained(self._zero, b)

    def _extend(self, basis, W):
        """``basis`` (V, A V, K_x V) with W's columns added, A-orthonormal and on ``psi v = 0``."""
        V, AV, KV = basis
        for _ in range(2):  # twice is enough (Gram-Schmidt in the A metric, by blocks)
            W = W - V @ (AV.T @ W)
        AW = np.column_stack([self.mass_times(c) for c in W.T])
        G = W.T @ AW
        ev, U = np.linalg.eigh(0.5 * (G + G.T))
        keep = ev > 1e-10 * max(float(ev[-1]), 1e-300)
        W = W @ (U[:, keep] / np.sqrt(ev[keep]))
        W = np.column_stack([self.project(self.mass_times(c)) for c in W.T])  # round-off off psi v = 0 removed
        AW = np.column_stack([self.mass_times(c) for c in W.T])
        KW = np.column_stack([self.stiffness_times(c) for c in W.T])
        return np.hstack([V, W]), np.hstack([AV, AW]), np.hstack([KV, KW])

    def lowest(self, k, sigma=None, rtol=RESIDUAL_RTOL):
        """The k lowest eigenvalues ``w^2`` and their vectors v (``T phi``), ascending, by Davidson iteration.

        Parameters
        ----------
        k : int
            How many (the basis grows to ``4 (k + 2)`` vectors, which p
            must exceed; see :meth:`subspace` for small p).
        sigma : float, optional
            The preconditioner's shift, 1/s^2 (default :data:`SHIFT`).
        rtol : float
            A pair has converged when its residual is below this fraction
            of ``|w^2| |A x|`` (default :data:`RESIDUAL_RTOL`; a sign
            needs far less).

        Returns
        -------
        w2 : ndarray, shape (k,)
            Eigenvalues ``w^2``, 1/s^2, ascending.
        v : ndarray, shape (n, k)
            Their vectors ``T phi``, A-orthonormal.

        Raises
        ------
        ModelError
            If the residuals do not fall below ``rtol`` in
            :data:`MAX_ITERATIONS` iterations.
        """
        sigma = SHIFT if sigma is None else sigma
        n = self.system.n_speeds
        armature = -self.stiffness / sigma

        def precondition(r):  # (K_d - sigma A) t = r on psi t = 0
            return self.constrained(armature, r / -sigma)

        rng = np.random.default_rng(0)
        W = np.column_stack([precondition(self.mass_times(rng.normal(size=n))) for _ in range(k + 2)])
        empty = np.zeros((n, 0))
        basis = (empty, empty, empty)
        for iteration in range(MAX_ITERATIONS):
            basis = self._extend(basis, W)
            V, AV, KV = basis
            S = V.T @ KV
            w2, Y = np.linalg.eigh(0.5 * (S + S.T))  # V is A-orthonormal
            w2, Y = w2[:k], Y[:, :k]
            X, AX, KX = V @ Y, AV @ Y, KV @ Y
            R = KX - AX * w2
            miss = np.linalg.norm(R, axis=0) / np.maximum(np.abs(w2) * np.linalg.norm(AX, axis=0), 1e-300)
            if np.all(miss <= rtol):
                self.n_iterations = iteration + 1
                return w2, X
            W = np.column_stack([precondition(R[:, j]) for j in np.flatnonzero(miss > rtol)])
            if V.shape[1] + W.shape[1] > 4 * (k + 2):  # restart from the Ritz vectors
                basis = (X, AX, KX)
        raise ModelError(f"modes: the Davidson iteration of the loops left residuals up to {np.max(miss):.3g} of "
                         f"w^2 |A x| after {MAX_ITERATIONS} iterations (not an equilibrium, where the stiffness is "
                         "not symmetric?); the dense path takes its symmetric part: modes(linearize(system), k)")

    def basis(self, p):
        """An orthonormal basis of the loops' tangent space ``psi v = 0`` from p solves, and A times it.

        ``V = P A R`` for p random columns R (a fixed seed: the same basis
        at every call) spans the p-dimensional space ``psi v = 0``; its QR
        factor makes the columns orthonormal (unit directions, as the
        columns of the SVD's T). O(p n m), n x p arrays.

        Parameters
        ----------
        p : int
            The number of independent coordinates.

        Returns
        -------
        V : ndarray, shape (n, p)
            Orthonormal columns with ``psi V = 0``.
        AV : ndarray, shape (n, p)
            ``A V`` (p passes of the recursion).
        """
        n = self.system.n_speeds
        if p == 0:
            return np.zeros((n, 0)), np.zeros((n, 0))
        rng = np.random.default_rng(0)
        V = np.empty((n, p))
        for j in range(p):
            V[:, j] = self.project(self.mass_times(rng.normal(size=n)))
        V, _ = np.linalg.qr(V)  # orthonormal columns: unit directions, as T's
        AV = np.empty((n, p))
        for j in range(p):
            AV[:, j] = self.mass_times(V[:, j])
        return V, AV

    def subspace(self, p):
        """Every eigenpair in a basis of the loops' tangent space built from p solves (small p).

        In the basis of :meth:`basis`, ``V^T K_x V`` and ``V^T A V`` are
        the linearisation's K and M (as :func:`flexmb.linearize` forms
        them). O(p n m), an n x p array.

        Parameters
        ----------
        p : int
            The number of independent coordinates.

        Returns
        -------
        w2 : ndarray, shape (p,)
            Eigenvalues ``w^2``, 1/s^2, ascending.
        v : ndarray, shape (n, p)
            Their vectors ``T phi``.
        """
        V, AV = self.basis(p)
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
        True where the sparse path applies.
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
    if p <= max(SUBSPACE_MAX, 4 * (k + 2)):  # Davidson's basis would not fit in the space
        w2, v = ops.subspace(p)
        return w2[:k], v[:, :k]
    return ops.lowest(k)
