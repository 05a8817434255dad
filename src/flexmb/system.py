"""The compiled system: topology, assembler, constraints and the reduced equations."""

from __future__ import annotations

import copy

import numpy as np
import scipy.linalg as sla
from scipy.linalg.lapack import dpotrf as _potrf
from scipy.linalg.lapack import dpotrs as _potrs

from . import memory
from .assembly import ForceAssembler, _power, geometric_stiffness, mass_matrix
from .forces import Loads
from .complements import SVDComplement, get_complement
from .complements.base import PSI_ZERO
from .constraints import Constraints
from .bodies import Body
from .errors import AssemblyError, ModelError
from .flexible import FlexibleBody
from .joints import Joint
from .kinematics import Kinematics
from .topology import Topology
from .forces.tables import class_tables, merge
from .kernels.equations import cut_residual, cut_rows_at, tree_equations
from .kernels.reduced import svd_reduced_solve
from .kernels.articulated import articulated_accelerations, mass_times, open_tree_accelerations, open_tree_rhs

__all__ = ["System", "NewtonPreconditioner"]


def _plain(a) -> np.ndarray:
    """``a`` as a writable C-contiguous float array (a copy only where needed)."""
    a = np.asarray(a, dtype=float)
    if a.flags.c_contiguous and a.flags.writeable:
        return a
    return np.array(a, dtype=float, order="C")


#: open trees with more coordinates estimate their fastest rates (method 'auto', the stiffness warning)
#: by Arnoldi iteration with O(n) products instead of dense eigenvalues
DENSE_RATES_MAX = 200


class System:
    """A model compiled for evaluation: ``A(x, t) xdd = f`` with ``psi xd = b``.

    Parameters
    ----------
    model : Model
        A validated model.
    complement : str or ComplementStrategy
        Orthogonal complement strategy (``"svd"``, ``"eigen"``, ``"qr"``,
        ``"auto"`` or a registered plugin's name).
    sparse : bool or None
        Solve the equations of an open tree by the articulated-body
        recursion (:mod:`flexmb.kernels.articulated`: O(n) per evaluation,
        A never formed) rather than by a dense Cholesky factorization of A
        (False). None (default): the recursion for every open tree. Models
        with loops always use the dense complement path.

    Attributes
    ----------
    n_coords : int
        Number of generalized coordinates n.
    n_constraints : int
        Number of constraint rows m.
    coordinate_names : list of str
        ``"joint.coordinate"`` per coordinate.
    n_complements : int
        Count of complement computations so far.
    articulated : bool
        Whether the accelerations come from the articulated-body recursion.
    """

    def __init__(self, model, complement="svd", sparse=None):
        if model.resolve():  # an element names one the model lacks: raise every problem
            model.validate()
        self.model = model
        memory.check(model, what=f"Model {model.name!r}")  # before Topology allocates its arrays
        self.topology = Topology(model)
        from .forces.elastic import BeamElasticity

        elastic = [BeamElasticity(f"{b.name}.elasticity", b) for b in self.topology.flexible]
        self.forces = ForceAssembler(list(model.forces) + elastic)
        self.constraints = Constraints(self.topology, model.drivers)
        self.strategy = get_complement(complement)
        self.n_coords = self.topology.n_coords
        self.n_constraints = self.constraints.n_rows
        self.coordinate_names = self.topology.coordinate_names
        self.body_names = [b.name for b in self.topology.bodies]
        self.n_complements = 0
        if sparse and self.n_constraints:
            raise ModelError("sparse=True needs an open tree: this model has loop or driver constraints")
        if sparse is None:
            sparse = self.n_constraints == 0
        self.articulated = bool(sparse)
        self._no_armature = np.zeros(self.n_coords)
        self._rank_limit: int | None = None
        self._sigma_ref: float | None = None
        self._trial()
        # joints and force elements all compiled: one kernel call per evaluation (plain tuples: what
        # the kernels' dispatch reads fastest)
        tables = [class_tables(cls, elements, self.topology) for cls, elements in self.forces.groups]
        compiled = [g for g, t in enumerate(tables) if t is not None]
        # force-element classes evaluated in Python (plugins), with their group index
        self._python_groups = [(g, *self.forces.groups[g]) for g, t in enumerate(tables) if t is None]
        merged = tuple(merge([tables[g] for g in compiled], compiled))
        self._fused = self._fused_equations = None
        if not self.topology.external_groups:
            if self.articulated and not self._python_groups:
                self._fused = (tuple(self.topology.arrays), merged)
            self._fused_equations = (tuple(self.topology.arrays), merged, self.constraints.cut_arrays)
        nb1 = self.topology.n_bodies + 1
        self._no_loads = (np.zeros((nb1, 3)), np.zeros((nb1, 3)), np.zeros(self.n_coords))
        self._no_powers = np.zeros(0)

    def _trial(self):
        """Evaluate every force element once so bad input fails at build time."""
        x = np.zeros(self.n_coords)
        kin = self.kinematics(0.0, x, x)
        for cls, elements in self.forces.groups:
            for e in elements:
                try:
                    cls.apply_all([e], kin, Loads(kin))
                    cls.potential_all([e], kin)
                except ModelError as exc:
                    raise ModelError(f"force element {e.name!r}: {exc}") from exc
                except Exception as exc:  # a user element failing on the reference state
                    raise ModelError(
                        f"force element {e.name!r} ({type(e).__name__}) failed on the reference state: "
                        f"{type(exc).__name__}: {exc}"
                    ) from exc

    # -- what a run calibrates: new systems, this one unchanged
    @property
    def rank_limit(self) -> int | None:
        """Largest rank of psi used by :meth:`complement` (None: no cap).

        :func:`~flexmb.simulate` runs on a :meth:`calibrated` copy whose limit is
        the rank at the assembled initial state.
        """
        return self._rank_limit

    @property
    def sigma_ref(self) -> float | None:
        """Smallest nonzero singular value of psi at the assembled initial state (None: not judged).

        Scales the strategy's ``singular_window`` (:meth:`singular_window`).
        """
        return self._sigma_ref

    def calibrated(self, rank_limit: int | None, sigma_ref: float | None = None) -> "System":
        """This system with the rank of psi capped and the singular-position filter scaled.

        Parameters
        ----------
        rank_limit : int or None
            Largest rank of psi used by :meth:`complement` (None: no cap).
            Off the constraint manifold (an integrator's stage states)
            redundant rows would otherwise look independent.
        sigma_ref : float, optional
            Smallest nonzero singular value of psi at the reference state;
            scales ``singular_window`` (None: no filter).

        Returns
        -------
        System
            A new system sharing this one's compiled model; this one is
            unchanged.
        """
        new = copy.copy(self)
        new._rank_limit = rank_limit
        new._sigma_ref = sigma_ref
        return new

    def with_complement(self, complement) -> "System":
        """This system with another orthogonal complement strategy.

        Parameters
        ----------
        complement : str or ComplementStrategy
            ``"svd"``, ``"eigen"``, ``"qr"``, ``"auto"``, a registered
            plugin's name, a class or an instance.

        Returns
        -------
        System
            A new system sharing this one's compiled model; this one is
            unchanged.
        """
        new = copy.copy(self)
        new.strategy = get_complement(complement)
        return new

    # -- evaluation
    def kinematics(self, t: float, x: np.ndarray, xd: np.ndarray) -> Kinematics:
        """Kinematics of all bodies at a state (eqs. 6-18).

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.

        Returns
        -------
        Kinematics
            Rotations, positions, velocities and partial velocities.
        """
        # writable, contiguous float arrays: the kernels are compiled for that one layout (a
        # read-only view, as SUNDIALS hands out, would otherwise compile them all a second time)
        return Kinematics(self.topology, t, _plain(x), _plain(xd))

    def index(self, body) -> int:
        """Row of a body in per-body arrays.

        Parameters
        ----------
        body : Body or str
            A body of the model or the ground, or its name (a flexible body
            gives the row of its first segment).

        Returns
        -------
        int
            Row index (-1 for the ground).

        Raises
        ------
        ModelError
            If the body is not in the model.
        """
        if isinstance(body, str):
            body = self.model.element(body, Body)
        try:
            return self.topology.index[body]
        except KeyError:
            raise ModelError(f"body {getattr(body, 'name', body)!r} is not in the model") from None

    def coordinate_slice(self, joint) -> slice:
        """Slice of x holding a joint's coordinates.

        Parameters
        ----------
        joint : Joint or str
            A tree (not cut) joint of the model, or its name.

        Returns
        -------
        slice
            Its coordinates' positions in x.
        """
        return self.topology.coordinate_slice(self.model.element(joint, Joint))

    def complement(self, psi):
        """Orthogonal complement of psi by the system's strategy (eqs. 30-37).

        With ``rank_limit`` set, a numerically higher rank is truncated to it
        (:meth:`Complement.truncated`): redundant constraints stay redundant
        at states slightly off the constraint manifold.

        Parameters
        ----------
        psi : ndarray, shape (m, n)
            Constraint Jacobian (eq. 29).

        Returns
        -------
        Complement
            T (n x p) with ``psi T = 0``, ``T^T T = I``, and the particular
            solver.
        """
        self.n_complements += 1
        c = self.strategy.complement(psi)
        if self.rank_limit is not None:
            c = c.truncated(self.rank_limit)
        return c

    def equations(self, t, x, xd, powers=None):
        """All the pieces of the equations of motion at one state.

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.
        powers : ndarray, shape (n_groups,), optional
            If given, filled with each force-element class's power
            (:meth:`ForceAssembler.group_powers`) from the same evaluation.

        Returns
        -------
        kin : Kinematics
            Kinematics at the state (eqs. 6-18).
        A : ndarray, shape (n, n)
            Generalized mass matrix (eq. 2).
        f : ndarray, shape (n,)
            Force array (eq. 3).
        phi, psi, b, gamma : ndarray
            Constraint residual, Jacobian and right-hand sides (eqs. 28-29).
        """
        kin = self.kinematics(t, x, xd)
        A = mass_matrix(kin)
        f = self.forces.force_array(kin, powers)
        phi, psi, b, gamma = self.constraints.evaluate(kin)
        return kin, A, f, phi, psi, b, gamma

    def reduced_parts(self, t, y, powers=None):
        """A, f, psi and gamma at the state ``y = (x, xd, ...)``: what the reduced equations need.

        One compiled call (:func:`~flexmb.kernels.equations.tree_equations`)
        when the model's joints and force elements are all compiled, else
        :meth:`equations`; the drivers' rows are added here.

        Parameters
        ----------
        t : float
            Time, s.
        y : ndarray, shape (>= 2 n,)
            Coordinates and speeds first.
        powers : ndarray, shape (n_groups,), optional
            If given, filled with each force-element class's power.

        Returns
        -------
        A : ndarray, shape (n, n)
            Generalized mass matrix (eq. 2).
        f : ndarray, shape (n,)
            Force array (eq. 3).
        psi : ndarray, shape (m, n)
            Constraint Jacobian (eq. 29).
        gamma : ndarray, shape (m,)
            Right-hand side of ``psi xdd = gamma``.
        """
        n = self.n_coords
        if self._fused_equations is None:
            _, A, f, _, psi, _, gamma = self.equations(t, y[:n], y[n : 2 * n], powers)
            return A, f, psi, gamma
        y = _plain(y)
        if powers is None:
            powers = self._no_powers
        else:
            powers[:] = 0.0
        loads = self._no_loads
        if self._python_groups:  # plugins: called back with the kinematics, their loads added in the kernel
            kin = self.kinematics(t, y[:n], y[n : 2 * n])
            acc = Loads(kin)
            for g, cls, elements in self._python_groups:
                cls.apply_all(elements, kin, acc)
                if powers.shape[0]:
                    powers[g] = _power(kin, acc) - sum(powers[h] for h, _, _ in self._python_groups if h < g)
            loads = (acc.force, acc.torque, acc.generalized)
        A, f, _, psi, gamma = tree_equations(*self._fused_equations, y, n, powers, *loads)
        if self.constraints.drivers:
            psi_d, gamma_d = self.constraints.driver_rows(t, n)
            m = psi.shape[0]
            full = np.empty((m + psi_d.shape[0], n))
            full[:m], full[m:] = psi, psi_d
            psi, gamma = full, np.concatenate((gamma, gamma_d))
        return A, f, psi, gamma

    def _rows(self, t, x, xd):
        """phi, psi and b at a state (all rows: cut joints, then drivers), compiled where it can be."""
        if self._fused_equations is None:
            return self.constraints.evaluate(self.kinematics(t, x, xd), level=1)
        tree, _, cuts = self._fused_equations
        phi, psi = cut_rows_at(tree, cuts, np.concatenate([x, xd]), self.n_coords)
        drivers = self.constraints.drivers
        if not drivers:
            return phi, psi, np.zeros(phi.shape[0])
        cols = self.constraints.driver_cols
        m = phi.shape[0]
        full = np.empty((m + len(drivers), self.n_coords))
        full[:m], full[m:] = psi, self.constraints.driver_rows(t, self.n_coords)[0]
        phi_d = np.array([x[c] - d.position(t) for d, c in zip(drivers, cols)])
        b = np.concatenate((np.zeros(m), [d.velocity(t) for d in drivers]))
        return np.concatenate((phi, phi_d)), full, b

    def constraint_residuals(self, t, x, xd) -> tuple[float, float]:
        """The largest position and velocity residuals of the constraints, ``max |phi|`` and ``max |psi xd - b|``.

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.

        Returns
        -------
        position, velocity : float
            The residuals (eqs. 28-29; 0 without constraints).
        """
        if self._fused_equations is None:
            phi, psi, b = self.constraints.evaluate(self.kinematics(t, x, xd), level=1)
            if not phi.size:
                return 0.0, 0.0
            return float(np.max(np.abs(phi))), float(np.max(np.abs(psi @ xd - b)))
        tree, _, cuts = self._fused_equations
        position, velocity = cut_residual(tree, cuts, np.concatenate([x, xd]), self.n_coords)
        for d, c in zip(self.constraints.drivers, self.constraints.driver_cols):
            position = max(position, abs(x[c] - d.position(t)))
            velocity = max(velocity, abs(xd[c] - d.velocity(t)))
        return float(position), float(velocity)

    def constraint_residual(self, t, x, xd) -> float:
        """The largest constraint residual at a state: ``max(|phi|, |psi xd - b|)`` (eqs. 28-29).

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.

        Returns
        -------
        float
            The residual (m or rad, and per second); 0 without constraints.
        """
        return max(self.constraint_residuals(t, x, xd))

    def accelerations(self, t, x, xd) -> np.ndarray:
        """Generalized accelerations from the reduced equations (eqs. 36-39).

        With ``xdd = T zd + xdd_p`` (``psi T = 0``, ``psi xdd_p = gamma``),
        ``T^T A T zd = T^T (f - A xdd_p)``; the constraint forces drop out.

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.

        Returns
        -------
        ndarray, shape (n,)
            xdd.

        Raises
        ------
        AssemblyError
            If the reduced mass matrix is not positive definite.
        """
        if self.articulated:  # open tree: A is never formed
            return self._articulated(t, x, xd)
        if self.n_constraints or self._fused_equations is not None:
            A, f, psi, gamma = self.reduced_parts(t, np.concatenate([x, xd]))
        else:  # an open tree: no constraints to evaluate
            kin = self.kinematics(t, x, xd)
            A, f = mass_matrix(kin), self.forces.force_array(kin)
            psi = gamma = np.zeros((0,))
        if not (np.all(np.isfinite(f)) and np.all(np.isfinite(A))):
            self._raise_non_finite(t, x, xd, A, f)
        return self._solve(t, A, f, psi, gamma)

    def _articulated(self, t, x, xd):
        """Accelerations of an open tree by the articulated-body recursion (O(n))."""
        if self._fused is not None:
            return self.state_rate(t, np.concatenate([x, xd]))[self.n_coords :]
        kin = self.kinematics(t, x, xd)
        loads = self.forces.loads(kin)
        topo = self.topology
        xdd, bad = open_tree_accelerations(topo.parent, topo.coord_start, kin.R, kin.r, kin.omega, kin.alpha_bias,
                                           kin.a_bias, kin.mass, topo.inertia, kin.Sw, kin.Sv, loads.force,
                                           loads.torque, loads.generalized, self._no_armature)
        if bad < 0 and np.isfinite(xdd).all():  # the common case: one check
            return xdd
        self._articulated_failure(t, x, xd, kin, xdd, bad)

    def _articulated_failure(self, t, x, xd, kin, xdd, bad):
        """Raise the AssemblyError that names why an open tree's accelerations failed."""
        topo = self.topology
        if not (np.isfinite(kin.R).all() and np.isfinite(kin.r).all()):
            self._raise_non_finite(t, x, xd, None, xdd)
        if bad >= 0:
            raise AssemblyError(
                f"the mass matrix is singular at t = {t:.6g} s: joint {topo.tree_joints[bad].name!r} moves no "
                "mass or inertia along one of its freedoms (a body without mass or inertia on a freedom?)"
            )
        self._raise_non_finite(t, x, xd, np.zeros((1, 1)), xdd)
        return xdd

    def state_rate(self, t, y) -> np.ndarray:
        """The first-order form's derivative ``(xd, xdd)`` at a state ``y = (x, xd)``.

        An open tree whose joints and force elements are all compiled is
        evaluated by one kernel call
        (:func:`~flexmb.kernels.articulated.open_tree_rhs`); any other
        model by :meth:`accelerations`.

        Parameters
        ----------
        t : float
            Time, s.
        y : ndarray, shape (2 n,)
            Coordinates and speeds.

        Returns
        -------
        ndarray, shape (2 n,)
            ``(xd, xdd)``, finite.

        Raises
        ------
        AssemblyError
            If the equations are singular or not finite (naming the cause).
        """
        n = self.n_coords
        if self._fused is not None:
            ydot, status = open_tree_rhs(*self._fused, _plain(y), self._no_armature)
            if status == -1:
                return ydot
            x, xd = y[:n], y[n : 2 * n]
            self._articulated_failure(t, x, xd, self.kinematics(t, x, xd), ydot[n:], status)
        x, xd = y[:n], y[n : 2 * n]
        xdd = self.accelerations(t, x, xd)
        if not np.all(np.isfinite(xdd)):
            bad = [self.coordinate_names[i] for i in np.flatnonzero(~np.isfinite(xdd))[:5]]
            err = AssemblyError(f"at t = {t:.9g} s: accelerations became non-finite ({', '.join(bad)})")
            err.t = t
            raise err
        return np.concatenate([xd, xdd])

    def _raise_non_finite(self, t, x, xd, A, f):
        err = AssemblyError(f"at t = {t:.9g} s: {self._diagnose(t, x, xd, A, f)}")
        err.t = t
        raise err

    def _diagnose(self, t, x, xd, A, f):
        """Name what made the equations non-finite."""
        kin = self.kinematics(t, x, xd)

        for cls, elements in self.forces.groups:
            for e in elements:
                loads = Loads(kin)
                cls.apply_all([e], kin, loads)
                if not (np.all(np.isfinite(loads.force)) and np.all(np.isfinite(loads.torque))
                        and np.all(np.isfinite(loads.generalized))):
                    return f"force element {e.name!r} ({type(e).__name__}) gave a non-finite load"
        if A is None or not np.all(np.isfinite(A)):
            return "the mass matrix is not finite (non-finite coordinates?)"
        return "the force array is not finite (non-finite speeds?)"

    def _solve(self, t, A, f, psi, gamma, multipliers=False):
        """xdd from the reduced equations; with ``multipliers``, ``(xdd, lambda)`` (the reactions)."""
        if self._svd_kernel:
            # the default strategy: decomposition, particular solution and reduced solve in one call
            self.n_complements += psi.shape[0] > 0
            xdd, lam, status = svd_reduced_solve(
                A, f, _plain(psi).reshape(psi.shape[0], self.n_coords), _plain(gamma), self.strategy.tol, PSI_ZERO,
                -1 if self._rank_limit is None else self._rank_limit, self.singular_window())
            if status == 2:
                raise AssemblyError("constraint Jacobian psi is not finite")
            if status == 1:
                raise AssemblyError(
                    f"reduced mass matrix T^T A T is not positive definite at t = {t:.6g} s "
                    "(a body without mass or inertia on a freedom?)"
                )
            return (xdd, lam) if multipliers else xdd
        if psi.shape[0] == 0:  # an open tree: T = I, no complement needed
            xdd = self._cholesky_solve(t, A, f)
            return (xdd, np.zeros(0)) if multipliers else xdd
        c = self.complement(psi)
        T = c.T
        xdd = xdd_p = self._particular(c, gamma)
        if T.shape[1]:
            M = T.T @ A @ T
            rhs = T.T @ (f - A @ xdd_p)
            xdd = T @ self._cholesky_solve(t, M, rhs) + xdd_p
        if multipliers:
            return xdd, c.multipliers(A @ xdd - f)
        return xdd

    @property
    def _svd_kernel(self) -> bool:
        """Whether the reduced equations are solved by the compiled SVD route (the default strategy)."""
        return type(self.strategy) is SVDComplement and not self.strategy.singular_rtol

    def _particular(self, c, rhs):
        """``psi^+ rhs`` with the strategy's treatment of singular positions.

        Singular values of psi below ``singular_window * sigma_ref`` are
        filtered (:meth:`Complement.particular`); with the opt-in
        ``singular_rtol``, those below ``singular_rtol`` times the largest
        are left out. Near a singular position (a flattened parallelogram)
        ``gamma / sigma`` would otherwise throw the motion onto the other
        branch (docs/stability.md, section 2).
        """
        srtol = getattr(self.strategy, "singular_rtol", 0.0)
        if srtol and c.rank:
            c = c.truncated(int(np.sum(c.scale > srtol * np.max(c.scale))))
        if not c.rank:
            return np.zeros(self.n_coords)
        return c.particular(rhs, window=self.singular_window())

    def singular_window(self) -> float:
        """Singular values of psi below this are filtered in particular solutions (0: none).

        Returns
        -------
        float
            ``strategy.singular_window * sigma_ref`` (see
            :class:`~flexmb.complements.ComplementStrategy`).
        """
        if not self.sigma_ref:
            return 0.0
        return getattr(self.strategy, "singular_window", 0.0) * self.sigma_ref

    @staticmethod
    def _cholesky_solve(t, M, rhs):
        """Solve ``M z = rhs`` for the symmetric positive definite (reduced) mass matrix."""
        # LAPACK potrf/potrs directly: scipy's cho_factor/cho_solve wrappers
        # cost more than the factorization itself at a few dozen coordinates
        if M.shape[0] == 0:
            return np.zeros_like(rhs)
        c, info = _potrf(M, lower=False, clean=False)
        if info == 0:
            z, info = _potrs(c, rhs, lower=False)
        if info != 0:
            raise AssemblyError(
                f"reduced mass matrix T^T A T is not positive definite at t = {t:.6g} s "
                "(a body without mass or inertia on a freedom?)"
            )
        return z

    def state_jacobian(self, t, x, xd, geometric: bool = True) -> np.ndarray | None:
        """Jacobian of the state derivative for implicit integrators.

        ``J = [[0, I], [P (G - K), -P C]]`` with ``P = T (T^T A T)^-1 T^T`` at
        the current state, K the diagonal spring constants on coordinates
        (segment joints, joint springs), C their dampers plus
        ``-sum V_P^T (dF/dv) V_P`` of velocity-dependent point forces
        (friction), and G the geometric stiffness of the loads and of the
        inertia forces (:func:`flexmb.assembly.geometric_stiffness`). It
        follows the state, costs about two right-hand sides instead of 2n,
        and leaves out the changes of the velocity-product terms and of the
        constraint forces (the integrator's Newton iteration absorbs them).

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.
        geometric : bool
            Include G (default); without it, ``J[n:, :n] = -P K``.

        Returns
        -------
        ndarray, shape (2n, 2n) or None
            None if no element contributes a coordinate stiffness.
        """
        kin = self.kinematics(t, x, xd)
        parts = [cls.tangent_all(el, kin) for cls, el in self.forces.groups]
        parts = [p for p in parts if p is not None]
        vparts = [cls.velocity_tangent_all(el, kin) for cls, el in self.forces.groups]
        vparts = [p for p in vparts if p is not None]
        if not parts and not vparts:
            return None
        n = self.n_coords
        K = np.zeros(n)
        C = np.zeros((n, n))
        for cols, k, c in parts:
            np.add.at(K, cols, k)
            C[cols, cols] += c
        for rows, p, D in vparts:
            VP = kin.point_partials(rows, p)
            C -= np.einsum("min,mij,mjk->nk", VP, D, VP)
        # X = [G - K, -C]; J[n:] = P X, by solves with the factorization (no explicit P)
        X = np.zeros((n, 2 * n))
        X[:, :n] = -np.diag(K)
        X[:, n:] = -C
        # dense even where accelerations use the articulated-body recursion: the
        # Jacobian is dense, and its 2n right-hand sides share one factorization
        A = mass_matrix(kin)
        _, psi, _, gamma = self.constraints.evaluate(kin)
        if self.n_constraints == 0:
            cho = sla.cho_factor(A, check_finite=False)
            solve = lambda rhs: sla.cho_solve(cho, rhs, check_finite=False)  # noqa: E731
        else:
            T = self.complement(psi).T
            cho = sla.cho_factor(T.T @ A @ T, check_finite=False)
            solve = lambda rhs: T @ sla.cho_solve(cho, T.T @ rhs, check_finite=False)  # noqa: E731
        if geometric:
            f = self.forces.force_array(kin)
            xdd = solve(f) if self.n_constraints == 0 else self._solve(t, A, f, psi, gamma)
        if geometric:
            loads = self.forces.loads(kin)
            X[:, :n] += geometric_stiffness(kin, xdd, loads.force[:-1], loads.torque[:-1])
        J = np.zeros((2 * n, 2 * n))
        J[:n, n:] = np.eye(n)
        J[n:] = solve(X)
        return J

    def newton_preconditioner(self) -> "NewtonPreconditioner":
        """An O(n) approximate solver of an implicit integrator's Newton matrix, for open trees.

        Returns
        -------
        NewtonPreconditioner
            See :class:`NewtonPreconditioner`.

        Raises
        ------
        ModelError
            If the model has loops or driver constraints (the articulated-body
            recursion needs an open tree).
        """
        if self.n_constraints or not self.articulated:
            raise ModelError("the O(n) Newton preconditioner needs an open tree solved by the articulated-body "
                             "recursion (no loops or drivers, sparse not False)")
        return NewtonPreconditioner(self)

    def highest_frequency(self, t, x, xd) -> float:
        """Estimate of the highest natural angular frequency from the coordinate springs, rad/s.

        ``sqrt(max eig(P K))`` (see :meth:`state_jacobian`); 0 if no element
        puts a stiffness on coordinates.

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.

        Returns
        -------
        float
            Angular frequency, rad/s.
        """
        return self._rates(t, x, xd)[0]

    def fastest_rate(self, t, x, xd) -> float:
        """The fastest time scale of the coordinate springs and dampers, rad/s.

        The larger of :meth:`highest_frequency` and the highest damping rate
        ``max |eig(P C)|``: an overdamped mode decays at about that rate, and
        limits the step of an explicit method just as a frequency does. Used
        by ``method='auto'`` and the :class:`~flexmb.StiffnessWarning`.

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.

        Returns
        -------
        float
            Rate, rad/s (1/s for a damping rate).
        """
        return max(self._rates(t, x, xd))

    def _rates(self, t, x, xd) -> tuple[float, float]:
        if self.articulated and self.n_coords > DENSE_RATES_MAX:
            rates = self._rates_iterative(t, x, xd)
            if rates is not None:
                return rates
        J = self.state_jacobian(t, x, xd, geometric=False)
        if J is None:
            return 0.0, 0.0
        n = self.n_coords
        stiff = np.linalg.eigvals(-J[n:, :n])
        damp = np.linalg.eigvals(-J[n:, n:])
        rates = (float(np.sqrt(max(np.max(stiff.real), 0.0))), float(np.max(np.abs(damp))))
        return tuple(r if np.isfinite(r) else np.inf for r in rates)

    def _rates_iterative(self, t, x, xd):
        """The largest eigenvalues of ``A^-1 K`` and ``A^-1 C`` by Arnoldi iteration, O(n) per product.

        For open trees whose coordinate springs and dampers are diagonal
        (None if a velocity-dependent element, such as friction, couples
        coordinates: the dense path then applies).
        """
        kin = self.kinematics(t, x, xd)
        if any(cls.velocity_tangent_all(el, kin) is not None for cls, el in self.forces.groups):
            return None
        from scipy.sparse.linalg import ArpackNoConvergence, LinearOperator, eigs

        pre = NewtonPreconditioner(self)
        pre.setup(t, x, xd)
        topo, n = self.topology, self.n_coords
        spatial, Sw, Sv, r = pre._state
        zeros = np.zeros((topo.n_bodies + 1, 3))

        def largest(diag):
            if not np.any(diag):
                return 0.0

            def apply(v):
                z, _ = articulated_accelerations(topo.parent, topo.coord_start, spatial, Sw, Sv, r, zeros, zeros,
                                                 diag * np.ravel(v), self._no_armature)
                return z

            op = LinearOperator((n, n), matvec=apply, dtype=float)
            try:
                return float(np.max(np.abs(eigs(op, k=1, which="LM", tol=1e-3, return_eigenvectors=False))))
            except ArpackNoConvergence as exc:
                return float(np.max(np.abs(exc.eigenvalues))) if len(exc.eigenvalues) else np.inf

        rates = (float(np.sqrt(largest(pre.stiffness))), largest(pre.damping))
        return tuple(v if np.isfinite(v) else np.inf for v in rates)

    def reactions(self, t, x, xd, xdd=None):
        """Constraint reactions (Lagrange multipliers) at a state.

        ``A xdd = f + psi^T lambda``; lambda is the minimum-norm solution
        (unique for independent rows). A driver's row gives the torque or
        force it supplies; a cut joint's point rows give the force it
        transmits to its parent body (inertial axes, N).

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.
        xdd : ndarray, shape (n,), optional
            Accelerations at the state (default: solved here).

        Returns
        -------
        ndarray, shape (m,)
            One multiplier per constraint row, labelled by
            ``self.constraints.labels``.
        """
        _, A, f, _, psi, _, gamma = self.equations(t, x, xd)
        if xdd is None:
            xdd = self._solve(t, A, f, psi, gamma)
        if psi.shape[0] == 0:
            return np.zeros(0)
        lam, *_ = np.linalg.lstsq(psi.T, A @ xdd - f, rcond=None)
        return lam

    def shape(self, body, x, t: float = 0.0) -> np.ndarray:
        """Deformed centre line of a flexible body at one configuration.

        Parameters
        ----------
        body : FlexibleBody or str
            A flexible body of the model, or its name.
        x : ndarray, shape (n,)
            Coordinates.
        t : float
            Time, s.

        Returns
        -------
        ndarray, shape (n_segments + 1, 3)
            Root, segment joints and tip, inertial, m.
        """
        body = self.model.element(body, FlexibleBody)
        if body not in self.topology.flexible:
            raise ModelError(f"{getattr(body, 'name', body)!r} is not a flexible body of the model")
        kin = self.kinematics(t, x, np.zeros_like(x))
        rows = np.array([self.topology.index[s] for s in self.topology.flexible[body][1]])
        tip = kin.origin[rows[-1]] + kin.R[rows[-1], :, 0] * body.segment_length
        return np.vstack([kin.origin[rows], tip])

    def energy(self, t, x, xd) -> tuple[float, float]:
        """Kinetic and potential energy at a state.

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.

        Returns
        -------
        kinetic, potential : float
            Energies, J.
        """
        kin = self.kinematics(t, x, xd)
        return kin.kinetic_energy(), self.forces.potential_energy(kin)

    def dof(self, t=0.0, x=None) -> int:
        """Degrees of freedom p = n - rank(psi) at a configuration.

        Parameters
        ----------
        t : float
            Time, s.
        x : ndarray, shape (n,), optional
            Coordinates (default: the reference configuration, zeros).

        Returns
        -------
        int
            Number of independent speeds p.
        """
        if not self.n_constraints:
            return self.n_coords
        x = np.zeros(self.n_coords) if x is None else x
        _, psi, _ = self.constraints.evaluate(self.kinematics(t, x, np.zeros_like(x)), level=1)
        return self.strategy.complement(psi).p

    # -- constraint satisfaction
    def _min_norm(self, a, rhs, rcond=1e-12):
        """Minimum-norm least-squares solution of ``a x = rhs``, rank capped at ``rank_limit``.

        Like ``np.linalg.lstsq(a, rhs, rcond)``, except that singular values
        beyond ``rank_limit`` count as zero: near (not on) the constraint
        manifold a redundant row would otherwise be inverted through a
        singular value of the size of the violation.
        """
        U, s, Vt = np.linalg.svd(a, full_matrices=False)
        r = int(np.sum(s > rcond * s[0])) if s.size else 0
        if self.rank_limit is not None:
            r = min(r, self.rank_limit)
        return Vt[:r].T @ ((U[:, :r].T @ rhs) / s[:r])

    def project(self, t, x, xd, tol=1e-12, max_iter=50, fixed=None, max_step=0.5, speeds="min-norm"):
        """Project a state onto the constraints (Newton, minimum-norm steps).

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            State to correct.
        tol : float
            Target for max ``|phi|`` (m or rad).
        max_iter : int
            Newton iterations allowed.
        fixed : ndarray of bool, shape (n,), optional
            Coordinates to leave unchanged.
        max_step : float
            Largest change of any coordinate in one Newton step (rad or m),
            so that rough guesses do not jump to a far branch.
        speeds : {'min-norm', 'mass'}
            How the speeds are corrected: the minimum-norm correction of the
            free speeds (default), or the mass-orthogonal projection onto
            ``psi xd = b`` (``fixed`` must be None): the correction is
            A-orthogonal to the consistent speeds, so it changes the kinetic
            energy only to second order (Bayo & Ledesma's mass-orthogonal
            projection), also near a singular position where the minimum-norm
            correction is a large multiple of the residual.

        Returns
        -------
        x, xd : ndarray
            Corrected state with ``phi = 0`` and ``psi xd = b``.

        Raises
        ------
        AssemblyError
            If the constraints cannot be closed; the message names the
            constraint rows with the largest residual.
        """
        x = np.array(x, dtype=float)
        xd = np.array(xd, dtype=float)
        if self.n_constraints == 0:
            return x, xd
        free = np.ones(self.n_coords, bool) if fixed is None else ~np.asarray(fixed, bool)
        for _ in range(max_iter):
            phi, psi, _ = self._rows(t, x, xd)
            if np.max(np.abs(phi)) <= tol:
                break
            step = self._min_norm(psi[:, free], phi)
            big = np.max(np.abs(step))
            x[free] -= step * min(1.0, max_step / big) if big > 0 else step
        else:
            kin = self.kinematics(t, x, xd)
            phi = self.constraints.evaluate(kin, level=0)
            worst = np.argsort(-np.abs(phi))[:3]
            rows = ", ".join(f"{self.constraints.labels[i]} = {phi[i]:.3g}" for i in worst)
            raise AssemblyError(
                f"the constraints cannot be closed at t = {t:.6g} s: residual {np.max(np.abs(phi)):.3g} "
                f"after {max_iter} Newton steps (largest: {rows})"
            )
        phi, psi, b = self._rows(t, x, xd)
        if speeds == "mass" and fixed is None:
            return x, self._mass_orthogonal_speeds(self.kinematics(t, x, xd), psi, b, xd)
        step = self._min_norm(psi[:, free], psi @ xd - b)
        xd[free] -= step
        return x, xd

    def _mass_orthogonal_speeds(self, kin, psi, b, xd, c=None):
        """``xd_p + T (T^T A T)^-1 T^T A (xd - xd_p)`` with ``xd_p = psi^+ b``: the consistent speeds
        nearest to ``xd`` in the kinetic-energy metric (``c``: the complement to use)."""
        if c is None and self._svd_kernel:  # the compiled reduced solve with f = A xd, gamma = b
            A = mass_matrix(kin)
            v, _, status = svd_reduced_solve(A, A @ xd, _plain(psi).reshape(psi.shape[0], self.n_coords),
                                             _plain(b), self.strategy.tol, PSI_ZERO,
                                             -1 if self._rank_limit is None else self._rank_limit,
                                             self.singular_window())
            if status == 0:
                self.n_complements += 1
                return v
        c = self.complement(psi) if c is None else c
        vp = self._particular(c, b)
        T = c.T
        if T.shape[1] == 0:
            return vp
        A = mass_matrix(kin)
        return vp + T @ self._cholesky_solve(kin.t, T.T @ A @ T, T.T @ (A @ (xd - vp)))


class NewtonPreconditioner:
    """Solves ``(I - gamma J) z = r`` approximately in O(n), for the implicit integration of an open tree.

    With ``y = (x, xd)`` and ``J ~ [[0, I], [-A^-1 K, -A^-1 C]]`` (K and C
    the diagonal coordinate springs and dampers: segment joints, joint
    springs), the second block row of the system becomes
    ``(A + gamma C + gamma^2 K) z2 = A r2 - gamma K r1`` and
    ``z1 = r1 + gamma z2``: one product with A
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
        n = system.n_coords
        kin = system.kinematics(0.0, np.zeros(n), np.zeros(n))
        self.stiffness = np.zeros(n)
        self.damping = np.zeros(n)
        for cls, elements in system.forces.groups:
            part = cls.tangent_all(elements, kin)
            if part is not None:
                cols, k, c = part
                np.add.at(self.stiffness, cols, k)
                np.add.at(self.damping, cols, c)
        self._state = None
        self._zeros = np.zeros((system.topology.n_bodies + 1, 3))
        self.n_setups = 0

    def setup(self, t, x, xd) -> None:
        """Take the mass distribution at a state (positions matter only).

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            Coordinates and speeds.
        """
        kin = self.system.kinematics(t, x, xd)
        self._state = (kin.spatial_inertia(), kin.Sw, kin.Sv, kin.r)
        self.n_setups += 1

    def solve(self, r1, r2, gamma):
        """``z`` with ``(I - gamma J) z ~ r``, in two halves.

        Parameters
        ----------
        r1, r2 : ndarray, shape (n,)
            The right-hand side's position and speed halves.
        gamma : float
            The integrator's coefficient (step size times its method's
            constant).

        Returns
        -------
        z1, z2 : ndarray, shape (n,)
            The solution's halves.
        """
        topo = self.system.topology
        spatial, Sw, Sv, r = self._state
        rhs = mass_times(topo.parent, topo.coord_start, topo.coord_body, spatial, Sw, Sv, _plain(r2))
        rhs -= gamma * self.stiffness * r1
        armature = gamma * self.damping + gamma * gamma * self.stiffness
        z2, bad = articulated_accelerations(topo.parent, topo.coord_start, spatial, Sw, Sv, r, self._zeros,
                                            self._zeros, rhs, armature)
        if bad >= 0:
            raise AssemblyError(f"the Newton preconditioner is singular at joint {topo.tree_joints[bad].name!r}")
        return r1 + gamma * z2, z2
