"""The compiled system: topology, assembler, constraints and the reduced equations."""

from __future__ import annotations

import copy

import numpy as np

from .. import memory
from ..assembly import ForceAssembler, _power, apply_group, mass_matrix
from ..forces import Loads
from ..complements import ArticulatedComplement, AutoComplement, get_complement
from ..constraints import ConstraintRows, Constraints
from ..bodies import Body
from ..errors import AssemblyError, ModelError
from ..joints import Joint
from ..kinematics import Kinematics
from ..state_layout import StateLayout
from ..topology import Topology
from ..forces.tables import class_tables, merge
from ..kernels.packing import pack
from ..planar_data import planar_choice
from .checks import StateChecks
from .equations import Equations
from .projection import Projection
from .quantities import StateQuantities, _equations  # the equations' kernels, imported at first use
from .rates import Rates
from .loops import LoopSolve
from .solve import ReducedSolve, _plain
from .tangent import Tangent
from ..kernels.articulated import open_tree_accelerations, open_tree_rhs


__all__ = ["System"]


class System(ReducedSolve, LoopSolve, Tangent, Rates, StateQuantities, Projection, StateChecks):
    """A model compiled for evaluation: ``A(x, t) xdd = f`` with ``psi xd = b``.

    Parameters
    ----------
    model : Model
        A validated model.
    complement : str or ComplementStrategy
        Orthogonal complement strategy (``"svd"``, ``"eigen"``, ``"qr"``,
        ``"auto"``, ``"articulated"`` or a registered plugin's name).
    sparse : bool or None
        Solve the equations of an open tree by the articulated-body
        recursion (:mod:`flexmb.kernels.articulated`: O(n) per evaluation,
        A never formed) rather than by a dense Cholesky factorization of A
        (False). None (default): the recursion for every open tree. Models
        with loops use their strategy (``"articulated"``: O(n m), A never
        formed).
    planar : bool or None
        None (default): the planar evaluation path (3-vectors,
        :mod:`flexmb.kernels.planar`) where the model moves in one plane
        (:mod:`flexmb.planar_data`); False: the spatial path for every
        model; True: as None, but a model that is not planar is refused.
    _topology : Topology, optional
        The model's tree, if already built (:meth:`flexmb.Model.build`
        passes the one its validation built); private.

    Attributes
    ----------
    n_coords : int
        Number of generalized coordinates q.
    n_speeds : int
        Number of generalized speeds u (Kane's equations, A, f, psi and the
        accelerations are per speed; equal to ``n_coords`` while every
        joint's speeds are its coordinates' rates).
    layout : StateLayout
        Where q and u sit in a state ``y`` and how q follows u
        (``qd = W(q) u``, :mod:`flexmb.state_layout`).
    n_constraints : int
        Number of constraint rows m.
    coordinate_names : list of str
        ``"joint.coordinate"`` per coordinate.
    speed_names : list of str
        ``"joint.speed"`` per speed (the coordinates' names where the
        speeds are their rates).
    n_complements : int
        Count of complement computations so far.
    articulated : bool
        Whether the accelerations come from the articulated-body recursion.
    planar : bool
        Whether the planar path evaluates the model.
    planar_reason : str
        Why it does not ('' if it does).
    """

    def __repr__(self) -> str:
        from .._describe import one_line

        return one_line(self)

    def __str__(self) -> str:
        from .._describe import GENERIC, describe, generic_state

        return "\n".join([repr(self)[1:-1], *describe(self, *generic_state(self), where=GENERIC)])

    def __init__(self, model, complement="svd", sparse=None, *, planar=None, _topology=None):
        if model.resolve():  # an element names one the model lacks: raise every problem
            model.validate()
        self.model = model
        strategy = get_complement(complement)
        loops = "articulated" if isinstance(strategy, (ArticulatedComplement, AutoComplement)) else "dense"
        memory.check(model, what=f"Model {model.name!r}", loops=loops)  # before Topology allocates its arrays
        # the tree Model.build's validation built (the model has not changed since), or a new one
        self.topology = Topology(model) if _topology is None else _topology
        from ..forces.elastic import BeamElasticity

        elastic = [BeamElasticity(f"{b.name}.elasticity", b) for b in self.topology.flexible]
        self.forces = ForceAssembler(list(model.forces) + elastic)
        self.constraints = Constraints(self.topology, model.drivers, model.constraints)
        self._refuse_articulated(strategy)
        self.strategy = strategy
        self.n_coords = self.topology.n_coords
        self.n_speeds = self.topology.n_speeds
        self.layout = StateLayout(self.n_coords, self.n_speeds, self.topology.quaternions)
        self.n_constraints = self.constraints.n_rows
        self.coordinate_names = self.topology.coordinate_names
        self.speed_names = self.topology.speed_names
        self.body_names = [b.name for b in self.topology.bodies]
        self.n_complements = 0
        self._shared: dict = {}  # what is built lazily once per model, shared by the calibrated copies
        if sparse and self.n_constraints:
            raise ModelError("sparse=True needs an open tree: this model has loop or driver constraints")
        if sparse is None:
            sparse = self.n_constraints == 0
        self.articulated = bool(sparse)
        self._no_armature = np.zeros(self.n_speeds)
        self._rank_limit: int | None = None
        self._sigma_ref: float | None = None
        self._trial()
        # joints and force elements all compiled: one kernel call per evaluation
        tables = [class_tables(cls, elements, self.topology) for cls, elements in self.forces.groups]
        compiled = [g for g, t in enumerate(tables) if t is not None]
        # force-element classes evaluated in Python (plugins), with their group index
        self._python_groups = [(g, *self.forces.groups[g]) for g, t in enumerate(tables) if t is None]
        merged = tuple(merge([tables[g] for g in compiled], compiled))
        # the constant arrays packed once (four buffers: what the kernels' dispatch reads fastest);
        # _packed_open: the same, for open trees whose right-hand side is one kernel call
        self._packed = self._packed_open = None
        data = planar_choice(self, merged, planar)  # sets planar and planar_reason
        if not self.topology.external_groups:
            self._packed = pack(self.topology.arrays, merged, self.constraints.cut_arrays, data)
            if self.articulated and not self._python_groups:
                self._packed_open = self._packed
        nb1 = self.topology.n_bodies + 1
        self._no_loads = (np.zeros((nb1, 3)), np.zeros((nb1, 3)), np.zeros(self.n_speeds))
        self._no_powers = np.zeros(0)

    def _trial(self):
        """Evaluate every force and constraint element once so bad input fails at build time."""
        kin = self._kinematics(0.0, self.layout.reference(), np.zeros(self.n_speeds))
        for e in self.constraints.elements:
            try:
                e.checked_rows(kin)
            except AssemblyError as exc:
                raise ModelError(f"{str(exc).removeprefix('at t = 0 s: ')} (on the reference state x = 0)") from exc
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

        Raises
        ------
        ModelError
            If the strategy is 'articulated' and the model has constraint
            elements (the loop kernel cannot take their rows).
        """
        strategy = get_complement(complement)
        self._refuse_articulated(strategy)
        new = copy.copy(self)
        new.strategy = strategy
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
        t, x, xd = self._state("System.kinematics", t, x=x, xd=xd)
        return self._kinematics(t, x, xd)

    def _kinematics(self, t, x, xd) -> Kinematics:
        """:meth:`kinematics` of a state already checked (or being diagnosed: it may be non-finite)."""
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
        """Slice of xd holding a joint's speeds, and of x its first ``n_speeds`` coordinates.

        For every joint whose speeds are its coordinates' rates, the slice
        of all its coordinates in x; a joint in Euler parameters has one
        coordinate more per quaternion (:meth:`coordinate_indices`).

        Parameters
        ----------
        joint : Joint or str
            A tree (not cut) joint of the model, or its name.

        Returns
        -------
        slice
            Its speeds' (and coordinates') positions.
        """
        return self.topology.coordinate_slice(self.model.element(joint, Joint))

    def coordinate_indices(self, joint) -> np.ndarray:
        """Indices in x of a joint's coordinates, in the joint's order (:mod:`flexmb.state_layout`).

        Parameters
        ----------
        joint : Joint or str
            A tree (not cut) joint of the model, or its name.

        Returns
        -------
        ndarray of int, shape (joint.n_coords,)
            The first ``n_speeds`` at their speeds' indices, the rest (``qw``) after all of those.
        """
        joint = self.model.element(joint, Joint)
        self.coordinate_slice(joint)  # refuses a cut joint or one not in the model, naming it
        return self.topology.joint_coordinates(self.topology.joint_map.get(joint, joint))

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

    def equations(self, t, x, xd, powers=None) -> Equations:
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
        Equations
            The kinematics (eqs. 6-18), A (eq. 2), f (eq. 3) and the
            constraint rows phi, psi, b, gamma (eqs. 28-29).
        """
        t, x, xd = self._state("System.equations", t, x=x, xd=xd)
        return self._equations(t, x, xd, powers)

    def _equations(self, t, x, xd, powers=None) -> Equations:
        """:meth:`equations` at a checked state."""
        kin = self._kinematics(t, x, xd)
        rows = self.constraints.evaluate(kin)
        return Equations(kin, mass_matrix(kin), self.forces.force_array(kin, powers), *rows)

    def reduced_parts(self, t, y, powers=None):
        """A, f, psi and gamma at the state ``y = (x, xd, ...)``: what the reduced equations need.

        One compiled call (:func:`~flexmb.kernels.equations.tree_equations`)
        when the model's joints and force elements are all compiled, else
        :meth:`equations`; the drivers' rows are added here.

        Parameters
        ----------
        t : float
            Time, s.
        y : ndarray, shape (>= nq + n,)
            Coordinates q and speeds u first.
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
        t, y = self._state("System.reduced_parts", t, y_long=y)
        return self._reduced_parts(t, y, powers)

    def _reduced_parts(self, t, y, powers=None):
        """:meth:`reduced_parts` at a checked state."""
        if self._packed is None:
            eq = self._equations(t, *self.layout.split(y), powers)
            A, f, psi, gamma = eq.A, eq.f, eq.psi, eq.gamma
            return A, f, psi, gamma
        y = _plain(y)
        if powers is None:
            powers = self._no_powers
        else:
            powers[:] = 0.0
        loads = self._python_loads(t, y, powers)
        eq = _equations
        A, f, _, psi, gamma = eq.tree_equations(self._packed, y, self.n_coords, eq.EQUATIONS, powers, *loads)
        if self.constraints.elements:
            rows = self.constraints.element_rows(self._kinematics(t, *self.layout.split(y)))
            psi, gamma = np.vstack((psi, rows.psi)), np.concatenate((gamma, rows.gamma))
        if self.constraints.drivers:
            psi_d, gamma_d = self.constraints.driver_rows(t, self.n_speeds)
            m = psi.shape[0]
            full = np.empty((m + psi_d.shape[0], self.n_speeds))
            full[:m], full[m:] = psi, psi_d
            psi, gamma = full, np.concatenate((gamma, gamma_d))
        return A, f, psi, gamma

    def _python_loads(self, t, y, powers):
        """Force, torque and generalized loads of the force elements evaluated in Python (plugins) at ``y``.

        Their powers go into ``powers`` (if not empty) at their groups' entries; zeros without such elements.
        """
        if not self._python_groups:
            return self._no_loads
        kin = self._kinematics(t, *self.layout.split(y))
        acc = Loads(kin)
        for g, cls, elements in self._python_groups:
            apply_group(cls, elements, kin, acc)
            if powers.shape[0]:
                powers[g] = _power(kin, acc) - sum(powers[h] for h, _, _ in self._python_groups if h < g)
        return acc.force, acc.torque, acc.generalized

    def _rows(self, t, x, xd) -> ConstraintRows:
        """phi, psi and b at a state (all rows: cut joints, elements, then drivers), compiled where it can be."""
        if self._packed is None:
            return self.constraints.evaluate(self._kinematics(t, x, xd), level=1)
        _, _, phi, psi, _ = _equations.tree_equations(self._packed, self.layout.join(x, xd), self.n_coords,
                                                      _equations.ROWS, self._no_powers, *self._no_loads)
        b = np.zeros(phi.shape[0])
        if self.constraints.elements:
            rows = self.constraints.element_rows(self._kinematics(t, x, xd))
            phi, psi, b = np.concatenate((phi, rows.phi)), np.vstack((psi, rows.psi)), np.concatenate((b, rows.b))
        drivers = self.constraints.drivers
        if not drivers:
            return ConstraintRows(phi, psi, b)
        cols = self.constraints.driver_cols
        m = phi.shape[0]
        full = np.empty((m + len(drivers), self.n_speeds))
        full[:m], full[m:] = psi, self.constraints.driver_rows(t, self.n_speeds)[0]
        phi_d = np.array([x[c] - d.position(t) for d, c in zip(drivers, cols)])
        b = np.concatenate((b, [d.velocity(t) for d in drivers]))
        return ConstraintRows(np.concatenate((phi, phi_d)), full, b)

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
        t, x, xd = self._state("System.accelerations", t, x=x, xd=xd)
        return self._accelerations(t, x, xd)

    def _accelerations(self, t, x, xd) -> np.ndarray:
        """:meth:`accelerations` at a checked state; a state past the range of floats is named as the cause."""
        try:
            return self._accelerations_unchecked(t, x, xd)
        except AssemblyError as exc:
            overflow = self._overflow(t, x, xd)
            if overflow is None or str(exc).endswith("(an unstable force, or a negative stiffness?)"):
                raise
            err = AssemblyError(overflow)
            err.t = t
            raise err from exc

    def _accelerations_unchecked(self, t, x, xd) -> np.ndarray:
        if self.articulated:  # open tree: A is never formed
            return self._articulated(t, x, xd)
        if self._loop_kernel:  # loops closed through the recursion: A, psi and T never formed
            return self._loop_solve(t, self.layout.join(x, xd))
        if self.n_constraints or self._packed is not None:
            A, f, psi, gamma = self._reduced_parts(t, self.layout.join(x, xd))
        else:  # an open tree: no constraints to evaluate
            kin = self._kinematics(t, x, xd)
            A, f = mass_matrix(kin), self.forces.force_array(kin)
            psi = gamma = np.zeros((0,))
        if not (np.all(np.isfinite(f)) and np.all(np.isfinite(A))):
            self._raise_non_finite(t, x, xd, A, f)
        return self._solve(t, A, f, psi, gamma)

    def _articulated(self, t, x, xd):
        """Accelerations of an open tree by the articulated-body recursion (O(n))."""
        if self._packed_open is not None:
            return self.layout.speeds(self._state_rate(t, self.layout.join(x, xd)))
        kin = self._kinematics(t, x, xd)
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
        if not (np.isfinite(kin.R).all() and np.isfinite(kin.r).all()) or self._overflow(t, x, xd) is not None:
            self._raise_non_finite(t, x, xd, None, xdd)
        if bad >= 0:
            raise AssemblyError(
                f"the mass matrix is singular at t = {t:.6g} s: joint {topo.tree_joints[bad].name!r} moves no "
                "mass or inertia along one of its freedoms (a body without mass or inertia on a freedom?)"
            )
        self._raise_non_finite(t, x, xd, np.zeros((1, 1)), xdd)
        return xdd

    def state_rate(self, t, y) -> np.ndarray:
        """The first-order form's derivative ``(qd, ud)`` at a state ``y = (q, u)``.

        ``qd = W(q) u`` by the kinematic equations (``System.layout``;
        ``qd = u`` for joints whose speeds are their coordinates' rates),
        ``ud`` from the reduced equations.

        An open tree whose joints and force elements are all compiled is
        evaluated by one kernel call
        (:func:`~flexmb.kernels.articulated.open_tree_rhs`); any other
        model by :meth:`accelerations`.

        Parameters
        ----------
        t : float
            Time, s.
        y : ndarray, shape (nq + n,)
            Coordinates q and speeds u.

        Returns
        -------
        ndarray, shape (nq + n,)
            ``(qd, ud)``, finite.

        Raises
        ------
        AssemblyError
            If the equations are singular or not finite (naming the cause).
        """
        t, y = self._state("System.state_rate", t, y=y)
        return self._state_rate(t, y)

    def _state_rate(self, t, y) -> np.ndarray:
        """:meth:`state_rate` at a checked state (the integrators' right-hand side: no checks)."""
        if self._packed_open is not None:
            ydot, status = open_tree_rhs(self._packed_open, _plain(y), self.n_coords, self._no_armature)
            if status == -1:
                return ydot
            x, xd = self.layout.split(y)
            self._articulated_failure(t, x, xd, self._kinematics(t, x, xd), self.layout.speeds(ydot), status)
        x, xd = self.layout.split(y)
        xdd = self._accelerations(t, x, xd)
        if not np.all(np.isfinite(xdd)):
            bad = [self.speed_names[i] for i in np.flatnonzero(~np.isfinite(xdd))[:5]]
            err = AssemblyError(f"at t = {t:.9g} s: accelerations became non-finite ({', '.join(bad)})")
            err.t = t
            raise err
        return self.layout.join(self.layout.coordinate_rates(x, xd), xdd)
