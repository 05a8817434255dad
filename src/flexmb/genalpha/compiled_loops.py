"""Generalized-alpha stepped in compiled code on looped models: :class:`CompiledLoopGeneralizedAlpha`.

For a model whose loops CVODE's compiled loops serve (the articulated
strategy closes them, force elements compiled, drivers with a closed form,
``qd = u``: :func:`~flexmb.integrators.cvode_direct_loops.loop_class`), on
the dense Newton path (below ``krylov_min_loop_coords`` speeds), without
work terms or contact events, :func:`flexmb.genalpha.compiled.compiled_genalpha`
mixes this class into the run's. Its steps run in
:func:`flexmb.kernels.genalpha_loops.advance` with the loops' right-hand side
on the loops' user data (:func:`flexmb.loop_user_data.loop_user_data`, as
CVODE's compiled loops), and so do the run's outputs (stored projected) and
the projections of its drifted state (continued in place, as ``move_to``):
the same steps, Newton iterations, Jacobians, projections and states as the
Python step (tests/test_genalpha_compiled_loops.py). The run drives it as it
drives CVODE's compiled loops (:func:`flexmb.own_loop.advance_checking`,
through :meth:`CompiledLoopGeneralizedAlpha.step_on` and
:meth:`~CompiledLoopGeneralizedAlpha.within_bound`); the loop returns to
Python for a Jacobian (the solver's own, as on open trees), a singular
iteration matrix, a failure, an output or a projection it leaves to the run,
a watch, the monitor's checkpoints and a budget of steps.
"""

from __future__ import annotations

import numpy as np

from .._signals import act_on_deferred
from .compiled import CompiledGeneralizedAlpha, _serves_loops
from .solver import _NO_LOW_PASS

__all__ = ["CompiledLoopGeneralizedAlpha"]


class CompiledLoopGeneralizedAlpha(CompiledGeneralizedAlpha):
    """:class:`~flexmb.genalpha.compiled.CompiledGeneralizedAlpha` for looped models (see the module docstring).

    Parameters
    ----------
    fun, t0, y0, t_bound
        As for :class:`~flexmb.genalpha.GeneralizedAlpha`.
    state_tol : float
        The run's drift bound (``Run.state_tol``).
    projection_tol : float
        The run's ``projection_tol`` (a drifted state's projection closes
        the loops to ``min(1e-12, projection_tol)``).
    **options
        As for :class:`~flexmb.genalpha.compiled.CompiledGeneralizedAlpha`.
    """

    checks_constraints = True
    advances = False  # stepped by step_on (flexmb.own_loop.advance_checking)
    _needs = ("loops closed by the articulated strategy, force elements all compiled, drivers with a closed form "
              "(Driver.law), and qd = u")
    _serves = staticmethod(_serves_loops)
    #: the loop forms the Jacobian itself where the compiled one is the model's (``compiled_jacobian``)
    jacobian_in_loop = True

    def __init__(self, fun, t0, y0, t_bound, *, state_tol=1e-10, projection_tol=1e-10, **options):
        super().__init__(fun, t0, y0, t_bound, **options)
        from ..kernels import cvode_loop_callbacks, genalpha_loops
        from ..loop_user_data import loop_user_data

        self._cb, self._loops = cvode_loop_callbacks, genalpha_loops
        self.m = len(self.z)  # the state's size (advance_checking's outputs)
        self._ud, self._ud_arrays = loop_user_data(self.system, len(self.z), None, 0)
        self._st, self._ct = np.zeros(genalpha_loops.N_LOOP_ST), np.zeros(genalpha_loops.N_LOOP_CT, dtype=np.int64)
        self._state_tol, self._newton_tol = float(state_tol), min(1e-12, float(projection_tol))
        self._checked = False
        n = self.n_pos
        self._Jx, self._Jv = np.zeros((n, n)), np.zeros((n, n))  # the Jacobian's blocks, formed in the loop
        self._jac_in_loop = self.jacobian_in_loop and self._jac_fun is not None and self.f_max is None
        if self._jac_in_loop:
            from ..integrators.cvode_direct import compiled_jacobian

            self._jac_in_loop = compiled_jacobian(self.system)

    def advance(self, t_stop: float, on_step=None):
        """Refused: a looped model's steps need the run's checks (see :meth:`step_on`).

        Parameters
        ----------
        t_stop : float
            Time to reach.
        on_step : callable, optional
            Not used.

        Raises
        ------
        TypeError
            Always.
        """
        raise TypeError(f"{type(self).__name__} is stepped by step_on (flexmb.own_loop.advance_checking)")

    def step_on(self, t_stop: float, bound: float, outputs=None) -> int:
        """Step until a step needs the run's attention, or to ``t_stop`` (``outputs.once``) or the run's end.

        Parameters
        ----------
        t_stop : float
            The next output time or progress mark.
        bound : float
            The run's drift bound as :func:`~flexmb.own_loop.advance_checking`
            gives it (not used: the loop applies ``state_tol``, the run's own).
        outputs : flexmb.output_projection.LoopOutputs, optional
            The run's outputs, stored there as the steps pass them (None:
            one stop, nothing stored).

        Returns
        -------
        int
            :mod:`~flexmb.kernels.cvode_loop_callbacks`'s code: REACHED,
            CHECKPOINT, PAUSED, WATCH, DRIFTED (a projection or an output
            left to the run), NOT_FINITE.

        Raises
        ------
        RuntimeError, AssemblyError
            As :meth:`CompiledGeneralizedAlpha.advance`.
        """
        from ..output_projection import LoopOutputs

        K, L, cb = self._kernel, self._loops, self._cb
        out = LoopOutputs(np.zeros(0), 0, len(self.z), 0.0, True) if outputs is None else outputs
        total = 0
        while True:
            code, k = self._call(float(t_stop), out)
            total += k
            if code == K.NEED_JACOBIAN:
                self._new_jacobian(self.t, self.z)
            elif code == K.NEED_FACTOR:  # singular: scipy's factors and its warning, as the Python step
                self._factor(float(self._st[K.H_FACTOR]))
            elif code in (K.RHS_FAILED, K.TOO_SMALL, K.FIXED_FAILED):
                self._failed(code)
            else:
                break
        if self.t >= self.t_bound:
            self.status = "finished"
        self._checked = total > 0 and code in (K.REACHED, K.CHECKPOINT, K.PAUSED)
        return {K.REACHED: cb.REACHED, K.CHECKPOINT: cb.CHECKPOINT, K.PAUSED: cb.PAUSED, K.WATCH: cb.WATCH,
                K.NONFINITE_STATE: cb.NOT_FINITE}.get(code, cb.DRIFTED)

    def _call(self, t_stop, out):
        """One call of the compiled loop: (its code, the steps taken)."""
        L, mon, st, ct = self._loops, self.monitor, self._st, self._ct
        live = mon is not None and not mon.warned
        times = np.empty(max(mon.next_check - mon.n_steps, 1) if live else 0)
        t_entry = self.t
        gimbal = self._gimbal if self.gimbal is not None and not self.gimbal.warned else self._gimbal[:0]
        self._enter()
        st[L.MIN_STEP] = self.min_step or 0.0
        ct[L.N_PROJ] = ct[L.N_MADE] = 0
        ct[L.K_OUT], ct[L.JAC_IN_LOOP], ct[L.N_JAC] = out.k, self._jac_in_loop, 0
        Jx, Jv = self._Jx, self._Jv
        if self.J is not None and self.J[0] is not Jx:  # formed in Python
            Jx[:], Jv[:] = self.J
        try:
            code, k = L.advance(self._ud, self._offset, *self._arrays, self._getrf, Jx, Jv, self._lu, self._piv,
                                _NO_LOW_PASS if self.low_pass is None else self.low_pass, self._par, self.atol, st,
                                ct, t_stop, out.once, times, self._budget, self._angles, self._bound, gimbal,
                                self._limit, self._fail_y, out.times, out.Y, out.tol, out.newton_tol, out.gain,
                                self._state_tol)
        finally:
            out.k = int(ct[L.K_OUT])
            out.made += int(ct[L.N_MADE])
            out.moved += int(ct[L.N_PROJ])
        jacobians = int(ct[L.N_JAC])
        if jacobians:  # formed by the loop (GeneralizedAlpha._new_jacobian's, no low-pass projector)
            self.J, self.low_pass = (Jx, Jv), None
            self.njev += jacobians
            if self._counters is not None:
                self._counters["jac"] = self._counters.get("jac", 0) + jacobians
        self._leave(k)
        act_on_deferred()  # a Ctrl-C recorded meanwhile
        if live and k:
            self._feed(self, mon, np.concatenate(([t_entry], times[: min(k, len(times))])))
        return code, k

    def within_bound(self, code: int) -> bool:
        """Whether the last :meth:`step_on` checked its last step's drift itself (and projected it if needed).

        Parameters
        ----------
        code : int
            What that :meth:`step_on` returned.

        Returns
        -------
        bool
            True where the compiled loop made the run's drift check after
            the last step (the run need not make it again).
        """
        return self._checked and self.t < self.t_bound
