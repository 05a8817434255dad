"""The state Jacobian of a System and the Newton preconditioner built on it."""

from __future__ import annotations

import numpy as np

from .._lazy import LazyModule
from ..assembly import geometric_stiffness, mass_matrix
from ..errors import AssemblyError, ModelError
from ..forces import BodyTorque, Loads, PointForce
from .solve import _plain
from ..kernels.articulated import articulated_accelerations, mass_times
from .._lazy import LazyModule

#: the loops' Newton kernels, imported at a model with loops' first use
_loops = LazyModule("flexmb.kernels.loops")

#: scipy.linalg, imported by the first Newton preconditioner or Jacobian that factors a matrix
sla = LazyModule("scipy.linalg")


def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _turning_loads(system, kin) -> np.ndarray:
    """Stiffness of constant point forces and torques beyond what :func:`geometric_stiffness` holds.

    The assembler moves a point force to the mass centre with the moment
    ``l x F`` (``l`` from the mass centre to the point), and the geometric
    stiffness takes that moment, like every torque, as fixed in inertial
    axes. The arm turns with the body, ``dl = (W dx) x l``, which adds
    ``W^T [F]x [l]x W``; a force given in body axes turns too,
    ``dF = (W dx) x F``, adding ``-V_P^T [F]x W``; a torque given in body
    axes adds ``-W^T [tau]x W``. Loads given as functions of time are left
    out (what they are at a state is known only by calling them).
    """
    n = system.n_speeds
    G = np.zeros((n, n))
    for _, elements in system.forces.groups:
        for e in elements:
            if type(e) is PointForce and not callable(e.force):
                k, local = kin.locate(e.body, e.point)
                if k < 0:
                    continue
                p = kin.point_position(k, local)
                F = kin.R[k] @ e.force if e.frame == "body" else np.asarray(e.force)
                W = kin.angular_partials(np.array([k]))[0]
                G += W.T @ _skew(F) @ _skew(p - kin.r[k]) @ W
                if e.frame == "body":
                    G -= kin.point_partials(np.array([k]), p[None])[0].T @ _skew(F) @ W
            elif type(e) is BodyTorque and e.frame == "body" and not callable(e.torque):
                k = kin.locate(e.body, e.point)[0]
                if k < 0:
                    continue
                W = kin.angular_partials(np.array([k]))[0]
                G -= W.T @ _skew(kin.R[k] @ e.torque) @ W
    return G


class Tangent:
    """The state-following tangent (mixed into :class:`~flexmb.system.System`)."""

    def state_jacobian(self, t, x, xd, geometric: bool = True) -> np.ndarray | None:
        """Jacobian of the state derivative for implicit integrators.

        ``J = [[0, I], [P (G - K), -P C]]`` in ``y = (q, u)`` (with
        ``qd = W(q) u`` the top row is ``[dW u/dq, W]`` and the displacement
        columns turn into coordinate columns, :mod:`flexmb.state_layout`),
        ``P = T (T^T A T)^-1 T^T`` at
        the current state, K the diagonal spring constants on coordinates
        (segment joints, joint springs), C their dampers plus
        ``-sum V_P^T (dF/dv) V_P`` of velocity-dependent point forces
        (friction), and G the geometric stiffness of the loads and of the
        inertia forces, constant loads turning with their bodies included
        (:meth:`load_stiffness`). It
        follows the state, costs about two right-hand sides instead of 2n,
        and leaves out the changes of the velocity-product terms and of the
        constraint forces (the integrator's Newton iteration absorbs them).

        Parameters
        ----------
        t : float
            Time, s.
        x : ndarray, shape (nq,)
            Coordinates q.
        xd : ndarray, shape (n,)
            Speeds u.
        geometric : bool
            Include G (default); without it, ``J[n:, :n] = -P K``.

        Returns
        -------
        ndarray, shape (nq + n, nq + n) or None
            None if no element contributes a coordinate stiffness.
        """
        t, x, xd = self._state("System.state_jacobian", t, x=x, xd=xd)
        return self._jacobian(t, x, xd, geometric)

    def _jacobian(self, t, x, xd, geometric, always=False):
        """:meth:`state_jacobian` at a checked state; with ``always``, also without coordinate springs (K = C = 0)."""
        Y = self._acceleration_tangent(t, x, xd, geometric, always)
        if Y is None:
            return None
        # the state (q, u): qd = W(q) u; ud by the accelerations' tangent per displacement and per speed
        layout, n = self.layout, self.n_speeds
        nq = layout.nq
        J = np.zeros((layout.size, layout.size))
        J[:nq, :nq] = layout.rate_jacobian(x, xd)
        J[:nq, nq:] = layout.kinematic_matrix(x)
        J[nq:, :nq] = layout.per_coordinate(x, Y[:, :n])
        J[nq:, nq:] = Y[:, n:]
        return J

    def _acceleration_tangent(self, t, x, xd, geometric, always=False):
        """``[P (G - K), -P C]`` (n x 2n): the accelerations per displacement along the speeds and per speed.

        None without coordinate springs unless ``always``.

        Raises
        ------
        AssemblyError
            If it is not finite (naming the speed's row).
        """
        kin = self._kinematics(t, x, xd)
        terms = self.coordinate_terms(kin)
        n = self.n_speeds
        if terms is None:
            if not always:
                return None
            terms = np.zeros((n, n)), np.zeros((n, n))
        K, C = terms
        # X = [G - K, -C]; J[n:] = P X, by solves with the factorization (no explicit P)
        X = np.zeros((n, 2 * n))
        X[:, :n] = -K
        X[:, n:] = -C
        # dense even where accelerations use the articulated-body recursion: the
        # Jacobian is dense, and its 2n right-hand sides share one factorization
        A = mass_matrix(kin)
        if self.n_constraints == 0:
            cho = self._mass_factor(t, A, reduced=False)
            solve = lambda rhs: sla.cho_solve(cho, rhs, check_finite=False)  # noqa: E731
        else:
            rows = self.constraints.evaluate(kin)
            psi, gamma = rows.psi, rows.gamma
            T = self.complement(psi).T
            cho = self._mass_factor(t, T.T @ A @ T, reduced=True)
            solve = lambda rhs: T @ sla.cho_solve(cho, T.T @ rhs, check_finite=False)  # noqa: E731
        if geometric:
            loads = self.forces.loads(kin)  # once, for f and for G
            f = self.forces.force_array(kin, loads=loads)
            xdd = solve(f) if self.n_constraints == 0 else self._solve(t, A, f, psi, gamma)
            X[:, :n] += self.load_stiffness(kin, xdd, loads)
        Y = solve(X)
        if not np.all(np.isfinite(Y)):
            i = int(np.flatnonzero(~np.all(np.isfinite(Y), axis=1))[0])
            raise AssemblyError(f"the state Jacobian is not finite at t = {t:.6g} s (in the row of coordinate "
                                f"{self.speed_names[i]!r}): stiffness, damping or loads beyond the range of "
                                "floats")
        return Y

    def _mass_factor(self, t, M, reduced):
        """The Cholesky factor of the (reduced) mass matrix, or an AssemblyError saying why there is none."""
        if not np.all(np.isfinite(M)):
            raise AssemblyError(f"the mass matrix is not finite at t = {t:.6g} s (masses or inertias beyond the "
                                "range of floats, or non-finite coordinates)")
        try:
            return sla.cho_factor(M, check_finite=False)
        except np.linalg.LinAlgError:
            pass
        d = np.abs(np.diag(M))
        where = ""
        if not reduced:  # name the freedom where the factorization broke down
            c, info = sla.lapack.dpotrf(M, lower=False, clean=False)
            if info > 0:
                where = f" at coordinate {self.speed_names[info - 1]!r}"
        span = (f"; its diagonal spans {d.min():.3g} to {d.max():.3g}, beyond what double precision resolves"
                if d.min() > 0 and d.max() > d.min() / np.finfo(float).eps else "")
        raise AssemblyError(
            f"{'reduced mass matrix T^T A T' if reduced else 'the mass matrix'} is not positive definite at "
            f"t = {t:.6g} s{where}{span} (a body without mass or inertia on a freedom, or masses and inertias that "
            "differ by more orders of magnitude than double precision holds?)")

    def coordinate_terms(self, kin) -> tuple[np.ndarray, np.ndarray] | None:
        """The coordinate stiffness and damping of the state-following tangent.

        K holds the springs on coordinates (segment joints, joint springs)
        on its diagonal; C their dampers plus ``-sum V_P^T (dF/dv) V_P`` of
        velocity-dependent point forces (friction). Forces between two
        points (spring-dampers) add ``V^T K_p V`` and ``V^T D_p V`` with
        ``V = V_P2 - V_P1`` (:meth:`~flexmb.ForceElement.pair_tangent_all`).

        Parameters
        ----------
        kin : Kinematics
            The kinematic state.

        Returns
        -------
        tuple of ndarray, shape (n, n), or None
            K and C; None if no element contributes either.
        """
        parts = [cls.tangent_all(el, kin) for cls, el in self.forces.groups]
        parts = [p for p in parts if p is not None]
        vparts = [cls.velocity_tangent_all(el, kin) for cls, el in self.forces.groups]
        vparts = [p for p in vparts if p is not None]
        pairs = [cls.pair_tangent_all(el, kin) for cls, el in self.forces.groups]
        pairs = [p for p in pairs if p is not None]
        if not parts and not vparts and not pairs:
            return None
        n = self.n_speeds
        K = np.zeros((n, n))
        C = np.zeros((n, n))
        for cols, k, c in parts:
            np.add.at(K, (cols, cols), k)
            np.add.at(C, (cols, cols), c)
        for rows, p, D in vparts:
            VP = kin.point_partials(rows, p)
            C -= np.einsum("min,mij,mjk->nk", VP, D, VP)
        for rows, p, Kp, Dp in pairs:  # on the relative motion of the two ends
            VP = kin.point_partials(rows[:, 1], p[:, 1]) - kin.point_partials(rows[:, 0], p[:, 0])
            K += np.einsum("min,mij,mjk->nk", VP, Kp, VP)
            C += np.einsum("min,mij,mjk->nk", VP, Dp, VP)
        return K, C

    def load_stiffness(self, kin, xdd, loads: Loads | None = None) -> np.ndarray:
        """G: how the generalized loads and inertia forces change with the coordinates at fixed speeds.

        The geometric stiffness of the loads and of the inertia forces
        (:func:`flexmb.assembly.geometric_stiffness`, every load fixed in
        inertial axes at the mass centre), plus the turning with the body of
        constant point forces off the mass centre and of loads given in body
        axes (:func:`_turning_loads`).

        Parameters
        ----------
        kin : Kinematics
            The kinematic state.
        xdd : ndarray, shape (n,)
            Accelerations at the state.
        loads : Loads, optional
            The applied loads at the state, if already computed.

        Returns
        -------
        ndarray, shape (n, n)
            ``G[c, d] = d g_c / d x_d``.
        """
        if loads is None:
            loads = self.forces.loads(kin)
        return geometric_stiffness(kin, xdd, loads.force[:-1], loads.torque[:-1]) + _turning_loads(self, kin)

    def newton_preconditioner(self):
        """An O(n) approximate solver of an implicit integrator's Newton matrix (O(n m) with loops).

        Returns
        -------
        NewtonPreconditioner or LoopNewtonPreconditioner
            See :class:`NewtonPreconditioner` (open trees) and
            :class:`LoopNewtonPreconditioner` (loops
            closed by the articulated strategy).

        Raises
        ------
        ModelError
            If the model has loops or drivers that another strategy closes,
            or is an open tree solved densely (``sparse=False``).
        """
        if self._loop_kernel:
            return LoopNewtonPreconditioner(self)
        if self.n_constraints or not self.articulated:
            raise ModelError("the O(n) Newton preconditioner needs an open tree solved by the articulated-body "
                             "recursion (no loops or drivers, sparse not False), or loops closed by "
                             "complement='articulated' or 'auto'")
        return NewtonPreconditioner(self)


class NewtonPreconditioner:
    """Solves ``(I - gamma J) z = r`` approximately in O(n), for the implicit integration of an open tree.

    With ``y = (q, u)`` and ``J ~ [[R, W], [-A^-1 K P, -A^-1 C]]`` (K and C
    the diagonal coordinate springs and dampers: segment joints, joint
    springs; ``qd = W(q) u``, ``R = d(W u)/dq`` and P the displacement per
    coordinate change, :mod:`flexmb.state_layout`: ``W = I``, ``R = 0``
    and ``P = I`` but for Euler parameters), the second block row of the
    system becomes ``(A + gamma C + gamma^2 K) z2 = A r2 - gamma K P r1``
    (``P W = I``) and the first ``(I - gamma R) z1 = r1 + gamma W z2``
    (a 4 x 4 solve per set of Euler parameters): one product with A
    (:func:`~flexmb.kernels.articulated.mass_times`) and one articulated-body
    solve with the diagonal ``gamma C + gamma^2 K`` as armature, both O(n),
    A never formed. The geometric stiffness and the velocity-dependent
    terms are left out: a Krylov solver (GMRES) preconditioned by this
    converges to the exact Newton step in a few iterations.

    Parameters
    ----------
    system : System
        An open tree (see :meth:`System.newton_preconditioner`).
    """

    def __init__(self, system):
        self.system = system
        self.stiffness, self.damping = self.diagonal_terms(system)
        self._state = None
        self._at = None  # (q, u) of the set-up, for the kinematic equations' rows
        self._zeros = np.zeros((system.topology.n_bodies + 1, 3))
        self.n_setups = 0

    def _kinematic_rows(self, r1, z2, gamma):
        """``z1`` of ``(I - gamma R) z1 = r1 + gamma W z2`` at the set-up's state (``r1 + gamma z2`` with ``W = I``)."""
        layout = self.system.layout
        if layout.identity:
            return r1 + gamma * z2
        q, u = self._at
        return layout.implicit_rates(q, u, r1 + gamma * layout.coordinate_rates(q, z2), gamma)

    def _displaced(self, r1):
        """``P r1``: the coordinates' part of a right-hand side as a displacement along the speeds."""
        layout = self.system.layout
        return r1 if layout.identity else layout.displacement(self._at[0], r1)

    @staticmethod
    def diagonal_terms(system) -> tuple[np.ndarray, np.ndarray]:
        """The diagonal coordinate springs K and dampers C of a system's force elements.

        Parameters
        ----------
        system : System
            The system.

        Returns
        -------
        stiffness, damping : ndarray, shape (n,)
            K and C on each coordinate.
        """
        n = system.n_speeds
        kin = system.kinematics(0.0, system.layout.reference(), np.zeros(n))
        stiffness = np.zeros(n)
        damping = np.zeros(n)
        for cls, elements in system.forces.groups:
            part = cls.tangent_all(elements, kin)
            if part is not None:
                cols, k, c = part
                np.add.at(stiffness, cols, k)
                np.add.at(damping, cols, c)
        return stiffness, damping

    def setup(self, t, x, xd) -> None:
        """Take the mass distribution at a state (positions matter only).

        Parameters
        ----------
        t : float
            Time, s.
        x : ndarray, shape (nq,)
            Coordinates.
        xd : ndarray, shape (n,)
            Speeds.
        """
        kin = self.system.kinematics(t, x, xd)
        self._state = (kin.spatial_inertia(), kin.Sw, kin.Sv, kin.r)
        self._at = (np.array(x, dtype=float), np.array(xd, dtype=float))
        self.n_setups += 1

    def solve(self, r1, r2, gamma):
        """``z`` with ``(I - gamma J) z ~ r``, in two halves.

        Parameters
        ----------
        r1 : ndarray, shape (nq,)
            The right-hand side's coordinate half.
        r2 : ndarray, shape (n,)
            Its speed half.
        gamma : float
            The integrator's coefficient (step size times its method's
            constant).

        Returns
        -------
        z1 : ndarray, shape (nq,)
            The solution's coordinate half.
        z2 : ndarray, shape (n,)
            Its speed half.
        """
        topo = self.system.topology
        spatial, Sw, Sv, r = self._state
        rhs = mass_times(topo.parent, topo.coord_start, topo.coord_body, spatial, Sw, Sv, _plain(r2))
        rhs -= gamma * self.stiffness * self._displaced(r1)
        armature = gamma * self.damping + gamma * gamma * self.stiffness
        z2, bad = articulated_accelerations(topo.parent, topo.coord_start, spatial, Sw, Sv, r, self._zeros,
                                            self._zeros, rhs, armature)
        if bad >= 0:
            raise AssemblyError(f"the Newton preconditioner is singular at joint {topo.tree_joints[bad].name!r}")
        return self._kinematic_rows(r1, z2, gamma), z2

    def solve_accelerations(self, r, c1, c2):
        """``z`` with ``(I - c1 Jv - c2 Jx) z ~ r``: the Newton matrix of a method in accelerations.

        Generalized-alpha's iteration matrix (:class:`~flexmb.genalpha.
        GeneralizedAlpha`, ``c1 = gamma' h``, ``c2 = beta' h^2``). With
        ``Jx ~ -A^-1 K`` and ``Jv ~ -A^-1 C`` it is ``A^-1 (A + c1 C + c2
        K)``, so ``z = (A + c1 C + c2 K)^-1 A r``: one product with A and
        one articulated-body solve with the diagonal ``c1 C + c2 K`` as
        armature, O(n). It is :meth:`solve`'s speed half with ``r1 = 0``
        and the armature's two coefficients free (``c1 = gamma``, ``c2 =
        gamma^2`` there); K acts on displacements along the speeds, the
        coordinates of generalized-alpha's chart (:mod:`flexmb.genalpha.chart`).

        Parameters
        ----------
        r : ndarray, shape (n,)
            Right-hand side (accelerations).
        c1, c2 : float
            The coefficients of ``Jv`` and ``Jx``.

        Returns
        -------
        ndarray, shape (n,)
            The approximate solution.
        """
        topo = self.system.topology
        spatial, Sw, Sv, r_body = self._state
        rhs = mass_times(topo.parent, topo.coord_start, topo.coord_body, spatial, Sw, Sv, _plain(r))
        z, bad = articulated_accelerations(topo.parent, topo.coord_start, spatial, Sw, Sv, r_body, self._zeros,
                                           self._zeros, rhs, c1 * self.damping + c2 * self.stiffness)
        if bad >= 0:
            raise AssemblyError(f"the Newton preconditioner is singular at joint {topo.tree_joints[bad].name!r}")
        return z


class LoopNewtonPreconditioner(NewtonPreconditioner):
    """Solves ``(I - gamma J) z = r`` approximately in O(n m), for the implicit integration of a model with loops.

    The loops' counterpart of :class:`NewtonPreconditioner`, with the same
    springs and dampers and the same :meth:`setup` and :meth:`solve`.
    With ``J ~ [[0, I], [-P K, -P C]]``, ``P = T (T^T A T)^-1 T^T`` (K and C
    the diagonal coordinate springs and dampers), the second block row gives
    ``z2 = r2 - gamma P_E (K r1 + E r2)`` with ``E = gamma K + C`` and
    ``P_E = T (T^T (A + gamma E) T)^-1 T^T``, and ``z1 = r1 + gamma z2``
    (with Euler parameters, r1 as a displacement and z1 by the kinematic
    equations' rows, as for open trees).
    ``P_E b`` is the constrained solve ``(A + gamma E) v = b + psi^T lambda``,
    ``psi v = 0`` (:func:`~flexmb.kernels.loops.loop_newton_solve`): the
    articulated-body recursion with ``gamma E`` as armature, T never formed.
    Its factors (those of ``A + gamma E`` and of ``K = psi (A + gamma
    E)^-1 psi^T``, :func:`~flexmb.kernels.loops.loop_newton_factor`) depend
    on the set-up's positions and on gamma only: they are made at the first
    solve with a new gamma after a set-up and kept for the solves with that
    gamma (CVODE calls the solve a few times per Newton iteration, and keeps
    gamma over several steps), so that a solve costs two O(n) recursions.
    The geometric stiffness and the velocity-dependent terms are left out,
    as for open trees: GMRES converges to the exact Newton step in a few
    iterations. :meth:`solve` raises an :class:`~flexmb.AssemblyError` if
    the Newton matrix is singular.

    Parameters
    ----------
    system : System
        A model with loops closed by the articulated strategy
        (:meth:`System.newton_preconditioner`).
    """

    _factored = None  # (gamma or (c1, c2), the factors at the set-up's positions)

    def setup(self, t, x, xd) -> None:  # the positions only; the factors are made by the first solve
        self._state = _plain(np.array(x, dtype=float))
        self._at = (self._state, np.array(xd, dtype=float))
        self._factored = None
        self.n_setups += 1

    def solve(self, r1, r2, gamma):
        system = self.system
        E = gamma * self.stiffness + self.damping
        if self._factored is None or self._factored[0] != gamma:
            self._factored = (gamma, _loops.loop_newton_factor(system._packed, system._loop_layout, self._state,
                                                               gamma * E, system._loop_tol,
                                                               -1 if system.rank_limit is None else system.rank_limit))
        load = _plain(self.stiffness * self._displaced(r1) + E * r2)
        v, _, _, status = _loops.loop_newton_solve(self._factored[1], system._packed, system._loop_layout, load)
        if status:
            raise AssemblyError("the Newton preconditioner of the loops is singular (a freedom without mass, "
                                "stiffness or damping that no loop fixes)")
        z2 = r2 - gamma * v
        return self._kinematic_rows(r1, z2, gamma), z2

    def solve_accelerations(self, r, c1, c2):
        """``z`` with ``(I - c1 Jv - c2 Jx) z ~ r`` (see :meth:`NewtonPreconditioner.solve_accelerations`).

        With ``Jx ~ -P K``, ``Jv ~ -P C`` the matrix is ``I + P D``, ``D = c1
        C + c2 K``, and ``(I + P D)^-1 = I - P_D D`` with ``P_D = T (T^T (A
        + D) T)^-1 T^T`` (multiply out: ``P_D + P D P_D = T M^-1 (M + T^T D
        T) M_D^-1 T^T = P``, ``M = T^T A T``, ``M_D = M + T^T D T``). So
        ``z = r - P_D (D r)``: one constrained solve with ``D`` as armature
        (:func:`~flexmb.kernels.loops.loop_newton_factor` once per set-up and
        coefficients, then :func:`~flexmb.kernels.loops.loop_newton_solve`), O(n m).

        Parameters
        ----------
        r : ndarray, shape (n,)
            Right-hand side (accelerations).
        c1, c2 : float
            The coefficients of ``Jv`` and ``Jx``.

        Returns
        -------
        ndarray, shape (n,)
            The approximate solution.
        """
        system = self.system
        D = c1 * self.damping + c2 * self.stiffness
        if self._factored is None or self._factored[0] != (c1, c2):  # made once per set-up and coefficients
            limit = -1 if system.rank_limit is None else system.rank_limit
            self._factored = ((c1, c2), _loops.loop_newton_factor(system._packed, system._loop_layout, self._state, D,
                                                                  system._loop_tol, limit))
        v, _, _, status = _loops.loop_newton_solve(self._factored[1], system._packed, system._loop_layout,
                                                   _plain(D * r))
        if status:
            raise AssemblyError("the Newton preconditioner of the loops is singular (a freedom without mass, "
                                "stiffness or damping that no loop fixes)")
        return r - v
