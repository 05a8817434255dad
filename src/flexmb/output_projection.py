"""The output states of a run with constraints, projected onto them (eqs. 28-29) unless that is ill-conditioned.

The integrator's interpolant leaves the constraints by about rtol between
steps; :class:`flexmb.stepping.Run` stores each output state projected by
:func:`project_output`, by the rule its steps follow.
"""

from __future__ import annotations

import numpy as np

from .complements.articulated import ArticulatedComplement
from .errors import AssemblyError

__all__ = ["project_output", "LoopOutputs"]

#: largest ratio of an output projection's correction to the residual it removes
OUTPUT_PROJECTION_GAIN = 1e3


def project_output(system, t, x, xd, tol):
    """An output state projected onto the constraints, unless that is ill-conditioned.

    Near a singular position (a flattened four-bar) the minimum-norm
    correction divides the residual by a tiny singular value of psi; such a
    correction, larger than ``OUTPUT_PROJECTION_GAIN`` times the residual,
    is refused, and the state is projected in the well-conditioned
    directions only (:func:`_project_partial`). Speeds are projected
    mass-orthogonally, as after the steps.

    Parameters
    ----------
    system : System
        The system.
    t : float
        Time, s.
    x, xd : ndarray, shape (nq,) and (n,)
        The state: coordinates q and speeds u.
    tol : float
        Residual below which the state is kept as it is.

    Returns
    -------
    x, xd : ndarray, shape (nq,) and (n,)
        The projected state.
    """
    res = max(system._constraint_residuals(t, x, xd))  # (the run's states are checked: finite, of their sizes)
    if res <= tol:
        return x, xd
    try:
        xp, vp = system._project(t, x, xd, tol=min(1e-12, tol), speeds="mass")
    except AssemblyError:
        return _project_partial(system, t, x, xd, res)
    if max(np.max(np.abs(xp - x)), np.max(np.abs(vp - xd))) > OUTPUT_PROJECTION_GAIN * res:
        return _project_partial(system, t, x, xd, res)
    return xp, vp


def _project_partial(system, t, x, xd, res, n_iter=3):
    """Project a state near a singular position in the well-conditioned directions only.

    The rows of psi along singular values below ``system.singular_window()``
    are left out (on the flattened parallelogram the violation along them is
    of second order in the state's error, and correcting it would move the
    state along the other branch); the speeds are projected
    mass-orthogonally onto what remains. The positions and the speeds are
    judged apart: each correction is kept only if it reduces its own
    residual (``|phi|``, ``|psi xd - b|``) and is no larger than
    ``OUTPUT_PROJECTION_GAIN`` times the state's residual.

    Loops closed by the articulated strategy take
    :mod:`flexmb.partial_projection` (psi sparse, the left-out rows reached
    by a rational filter of ``psi psi^T``, no n x n array); the other
    strategies this dense form, since they cut by their own complement's
    scale (the pivoted QR's ``|diag R|`` for 'qr', and for 'auto' where it
    takes QR), which only that complement gives, and they form psi and T
    at every evaluation anyway. The two agree to 1e-10 where both apply
    (tests/test_statics_loops.py).
    """
    window = system.singular_window()
    if window <= 0.0:
        return x, xd
    if system._loop_kernel and type(system.strategy) is ArticulatedComplement:
        return _project_partial_loops(system, t, x, xd, res, window, n_iter)
    return _project_partial_dense(system, t, x, xd, res, window, n_iter)


def _project_partial_loops(system, t, x, xd, res, window, n_iter):
    """:func:`_project_partial` for loops closed by the articulated strategy, in O(n) memory."""
    from .partial_projection import KeptRows, LoopRows, partial_speeds

    limit_rank = -1 if system.rank_limit is None else system.rank_limit

    def kept(rows):
        return KeptRows(rows.psi, window, system.strategy.tol, limit_rank)

    limit = OUTPUT_PROJECTION_GAIN * res
    first = rows = LoopRows(system, t, x)
    xp = np.array(x, dtype=float)
    for i in range(n_iter):  # the positions (all the kernels' rows are position rows)
        rows = first if i == 0 else LoopRows(system, t, xp)
        c = kept(rows)
        if c.k:
            xp = system.layout.displace(xp, -(rows.psi.T @ c.inverse(rows.phi)))
    rows = LoopRows(system, t, xp)
    if np.max(np.abs(rows.phi)) >= np.max(np.abs(first.phi)) or np.max(np.abs(xp - x)) > limit:
        xp, rows = np.array(x, dtype=float), first  # the positions are kept
    vp = partial_speeds(rows, kept(rows), rows.mass_solver(system, t), xd)
    psi, b = rows.psi, rows.b
    if np.max(np.abs(psi @ vp - b)) >= np.max(np.abs(psi @ xd - b)) or np.max(np.abs(vp - xd)) > limit:
        vp = np.array(xd, dtype=float)
    return xp, vp


def _project_partial_dense(system, t, x, xd, res, window, n_iter):
    """:func:`_project_partial` by the system's dense complement (SVD, QR) of psi."""

    def well_conditioned(psi):
        c = system.complement(psi)
        return c.truncated(int(np.sum(c.scale >= window)))

    limit = OUTPUT_PROJECTION_GAIN * res
    xp = np.array(x, dtype=float)
    for _ in range(n_iter):  # the positions: by the position rows (a velocity row has no position form)
        rows = system.constraints.position_rows(system.constraints.evaluate(system.kinematics(t, xp, xd), level=1))
        c = well_conditioned(rows.psi)
        if c.rank:
            xp = system.layout.displace(xp, -c.particular(rows.phi))
    kin = system.kinematics(t, xp, xd)
    rows = system.constraints.evaluate(kin, level=1)
    phi0 = system.constraints.evaluate(system.kinematics(t, x, xd), level=0).phi
    if np.max(np.abs(rows.phi)) >= np.max(np.abs(phi0)) or np.max(np.abs(xp - x)) > limit:
        xp = np.array(x, dtype=float)  # the positions are kept
        kin = system.kinematics(t, xp, xd)
        rows = system.constraints.evaluate(kin, level=1)
    psi, b = rows.psi, rows.b
    # the speeds, judged apart: a speed residual along the singular direction
    # (not corrected) must not veto the positions' correction
    vp = system._mass_orthogonal_speeds(kin, psi, b, xd, c=well_conditioned(psi))
    if np.max(np.abs(psi @ vp - b)) >= np.max(np.abs(psi @ xd - b)) or np.max(np.abs(vp - xd)) > limit:
        vp = np.array(xd, dtype=float)
    return xp, vp


class LoopOutputs:
    """The outputs of a run of the compiled loops' CVODE, stored by its step loop by :func:`project_output`'s rule.

    :meth:`flexmb.integrators.cvode_direct_loops.DirectLoopCVODE.step_on`
    has :func:`flexmb.kernels.loop_outputs.advance_storing` store the
    outputs its steps pass into :attr:`Y` (interpolated, offsets added,
    projected: :func:`~flexmb.kernels.loop_outputs.output_projected`); an
    output it leaves (not finite, a projection refused or not closed) is
    stored by ``Run._store`` from Python, as every output was before.

    Parameters
    ----------
    times : ndarray
        The run's output times.
    k : int
        The index of the next output to store.
    m : int
        The state's size.
    tol : float
        The run's ``projection_tol`` (:func:`project_output`'s ``tol``).
    once : bool
        The step loop returns after its first stop (a run with a progress bar, whose marks are stops).
    """

    def __init__(self, times, k, m, tol, once):
        self.times, self.k = np.ascontiguousarray(times, dtype=float), int(k)
        self.Y = np.empty((len(self.times), m))
        self.tol, self.newton_tol, self.gain = float(tol), min(1e-12, float(tol)), OUTPUT_PROJECTION_GAIN
        self.once = bool(once)
        self.made = 0  # the projections made since the last hand_over
        self.moved = 0  # the integrator's own state projected since then (generalized-alpha's compiled loops)

    def hand_over(self, run) -> None:
        """Give ``run`` the outputs stored since the last call (``out_y``, ``k_out``) and count the projections.

        Parameters
        ----------
        run : flexmb.stepping.Run
            The run (its ``k_out`` where this store's was at the last call).
        """
        for i in range(run.k_out, self.k):
            run.out_y.append(self.Y[i])
        run.k_out = self.k
        # one mass-orthogonal speed projection each (System._loop_speeds')
        run.system.n_complements += self.made + self.moved
        if self.moved:
            run.n_proj += self.moved
        self.made = self.moved = 0
