"""The reduced solve of a model with loops by the articulated-body recursion (``complement='articulated'``)."""

from __future__ import annotations

import numpy as np

from ..complements.articulated import ArticulatedComplement
from ..complements.auto import AutoComplement
from ..errors import AssemblyError
from .._lazy import LazyModule
from .solve import _plain

#: the loops' kernels, imported at a model with loops' first use (an open tree needs none of them)
_layout = LazyModule("flexmb.kernels.loop_layout")
_statics = LazyModule("flexmb.kernels.loop_statics")
_loops = LazyModule("flexmb.kernels.loops")


class LoopSolve:
    """Accelerations, reactions and speed projections in O(n m) (mixed into :class:`~flexmb.system.System`)."""

    @property
    def _loop_kernel(self) -> bool:
        """Whether this system's loops are closed by :mod:`flexmb.kernels.loops`.

        With the 'articulated' strategy, and with 'auto', which takes it
        wherever it can: it was the cheaper on every looped model measured,
        from the four-bar (3 coordinates) to B7 (benchmarks/rhs_cost.py;
        docs/benchmarks.md). Not for models whose joints compute their own
        motion (plugins), which the compiled evaluation cannot take, nor for
        models with constraint elements (rows written in Python: 'auto'
        takes the dense complement for them, 'articulated' refuses them).
        """
        return (isinstance(self.strategy, (ArticulatedComplement, AutoComplement)) and self.n_constraints > 0
                and self._packed is not None and not self.constraints.elements)

    @property
    def _loop_tol(self) -> float:
        """The relative zero tolerance of K's eigenvalues and pivots."""
        if isinstance(self.strategy, ArticulatedComplement):
            return self.strategy.tol
        return ArticulatedComplement.default_rank_tol

    @property
    def _loop_layout(self):
        """The rows' :class:`~flexmb.kernels.loop_layout.LoopLayout`, built once per model (shared by its copies)."""
        layout = self._shared.get("loop_layout")
        if layout is None:
            c = self.constraints
            pt_i, _, pt_j, _ = c.pt
            dr_i, _, _, dr_j, _ = c.dr
            pp_i, _, pp_j, _ = c.pp
            pairs = [np.repeat(np.stack([pt_i, pt_j], axis=1).reshape(-1, 2), 3, axis=0),
                     np.stack([dr_i, dr_j], axis=1).reshape(-1, 2), np.stack([pp_i, pp_j], axis=1).reshape(-1, 2)]
            layout = _layout.loop_layout(self.topology.arrays.parent, self.topology.arrays.coord_body,
                                 np.concatenate(pairs).astype(np.int64), c.driver_cols)
            self._shared["loop_layout"] = layout
        return layout

    def _loop_solve(self, t, y, powers=None, multipliers=False):
        """xdd (and with ``multipliers`` the reactions lambda) at ``y = (x, xd, ...)`` by the loop kernel.

        Raises
        ------
        AssemblyError
            If A is singular or the accelerations are not finite (naming the cause).
        """
        n = self.n_coords
        y = _plain(y)
        if powers is None:
            powers = self._no_powers
        else:
            powers[:] = 0.0
        force, torque, generalized = self._python_loads(t, y, powers)
        gamma_d = np.array([d.acceleration(t) for d in self.constraints.drivers], dtype=float)
        xdd, lam, kept, _, status = _loops.loop_rhs(self._packed, self._loop_layout, y, n, powers, force, torque,
                                                    generalized, gamma_d, self._loop_tol, self.singular_window(),
                                                    -1 if self._rank_limit is None else self._rank_limit)
        self.n_complements += 1
        if status:
            x, xd = self.layout.split(y)
            if status in (1, 3):
                raise AssemblyError(self._massless_message(kept, f"at t = {t:.6g} s"))
            A, f, _, _ = self._reduced_parts(t, y)
            if not (np.all(np.isfinite(f)) and np.all(np.isfinite(A))):
                self._raise_non_finite(t, x, xd, A, f)
            err = AssemblyError(f"at t = {t:.9g} s: the constraint rows or the accelerations became non-finite")
            err.t = t
            raise err
        if not multipliers:
            return xdd
        if kept < lam.shape[0]:  # redundant rows: the minimum-norm reactions, as the SVD gives them
            rows = self._rows(t, *self.layout.split(y))
            lam = self.complement(rows.psi).multipliers(rows.psi.T @ lam)
        return xdd, lam

    def _loop_reactions(self, t, x, xd, xdd=None):
        """The reactions at ``(x, xd)`` with the accelerations ``xdd`` (None: solved here) by the loop kernels.

        Raises
        ------
        AssemblyError
            If A is singular on a freedom no loop fixes (naming its joint), or the result is not finite.
        """
        y = _plain(self.layout.join(x, xd))
        if xdd is None:
            xdd = self._loop_solve(t, y)
        force, torque, generalized = self._python_loads(t, y, self._no_powers)
        lam, kept, status = _statics.loop_reactions(self._packed, self._loop_layout, y, self.layout.nq, _plain(xdd),
                                                    force, torque, generalized, self._loop_tol,
                                                    -1 if self._rank_limit is None else self._rank_limit)
        self.n_complements += 1
        if status in (1, 3):
            raise AssemblyError(self._massless_message(kept, f"at t = {t:.6g} s"))
        if status:
            raise AssemblyError(f"at t = {t:.9g} s: the reactions are not finite (the accelerations or the "
                                "constraint rows)")
        if kept < lam.shape[0]:  # redundant rows: the minimum-norm reactions, as the dense route gives them
            psi = self._rows(t, x, xd).psi
            lam = np.linalg.lstsq(psi.T, psi.T @ lam, rcond=None)[0]
        return lam

    def _with_reactions(self, t, y):
        """``(xdd, lambda)`` at ``y = (x, xd)`` by the system's route (the loop kernel, or the reduced solve)."""
        if self._loop_kernel:
            return self._loop_solve(t, y, multipliers=True)
        A, f, psi, gamma = self._reduced_parts(t, y)
        return self._solve(t, A, f, psi, gamma, multipliers=True)

    def _loop_speeds(self, t, x, xd, b):
        """The mass-orthogonal projection of ``xd`` onto ``psi xd = b`` by the loop kernel (None if A is singular)."""
        v, _, status = _loops.loop_speeds(self._packed, self._loop_layout, _plain(x), _plain(xd), _plain(b),
                                   self._loop_tol, self.singular_window(),
                                   -1 if self._rank_limit is None else self._rank_limit)
        self.n_complements += 1
        return v if status == 0 else None

    def _loop_calibration(self, t, x, xd, drivers=True):
        """The rank of psi and its smallest mass-weighted singular value at a state, as the loop kernel sees them.

        Parameters
        ----------
        t : float
            Time, s.
        x, xd : ndarray, shape (n,)
            The (assembled) state.
        drivers : bool
            Count the drivers' rows too.

        Returns
        -------
        rank : int or None
            The rows kept. None without the drivers when a freedom that
            moves no mass is left free by the cut rows (a driver fixes it):
            the cut rows' rank is then below n, not known exactly.
        smallest : float or None
            The smallest ``sqrt(d_j)`` of the kept rows (None if none).
        """
        n = self.n_coords
        y = self.layout.join(x, xd)
        powers = self._no_powers
        force, torque, generalized = self._python_loads(t, y, powers)
        gamma_d = np.zeros(len(self.constraints.drivers))
        layout = self._loop_layout
        if not drivers and len(self.constraints.drivers):
            m_cut = self.n_constraints - len(self.constraints.drivers)
            layout = _layout.loop_layout(self.topology.arrays.parent, self.topology.arrays.coord_body,
                                         layout.row_body[:m_cut], np.zeros(0, dtype=np.int64))
            gamma_d = np.zeros(0)
        _, _, kept, smallest, status = _loops.loop_rhs(self._packed, layout, y, n, powers, force, torque, generalized,
                                                gamma_d, self._loop_tol, 0.0, -1)
        if status == 1 and not drivers:  # the cut rows leave a massless freedom free: rank below n
            return None, None
        if status == 1:  # (status 3, a refinement that did not settle, leaves the rank as it is)
            raise AssemblyError(self._massless_message(kept, "at the initial state"))
        return kept, (float(smallest) if kept else None)

    def _massless_message(self, body, when):
        """Why the articulated strategy cannot close the loops: a freedom of ``body``'s joint moves no mass."""
        joint = self.topology.tree_joints[body].name
        return (f"{when}, joint {joint!r} moves no mass or inertia along one of its freedoms (a body without mass "
                "or inertia on a freedom, or a slender bar's spin) and the loops do not fix that freedom: the "
                "reduced mass matrix is singular")

