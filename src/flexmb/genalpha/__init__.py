"""Generalized-alpha integration (Chung & Hulbert 1993) with error-controlled steps.

For mechanical state ``y = (x, xd, w)`` with ``xdd = a(t, x, xd)`` (and
``w`` optional first-order states that nothing depends on, such as the
integrated work of ``simulate(..., track_work=True)``). The scheme is the
generalized-alpha method in the form of Arnold & Bruels (2007) [2]_, which
satisfies the equations of motion at every step end and keeps, for
nonlinear problems, the second order of Chung & Hulbert [1]_::

    x1 = x0 + h xd0 + h^2 (1/2 - beta) abar0 + h^2 beta abar1
    xd1 = xd0 + h (1 - gamma) abar0 + h gamma abar1
    (1 - alpha_m) abar1 + alpha_m abar0 = (1 - alpha_f) a1 + alpha_f a0
    a1 = a(t1, x1, xd1)

``abar`` is the algorithmic acceleration, a filtered ``a`` that lags by
``(alpha_m - alpha_f) h``. The unknown is ``a1``; Newton's method on
``r(a1) = a1 - a(t1, x1, xd1)`` uses the iteration matrix
``I - gamma' h Jv - beta' h^2 Jx`` with ``beta' = beta (1 - alpha_f) / (1 -
alpha_m)``, ``gamma' = gamma (1 - alpha_f) / (1 - alpha_m)`` and the blocks
of the state Jacobian ``[[0, I], [Jx, Jv]]``, reused over steps until
Newton fails with it (modified Newton: a failure with a Jacobian taken at
an earlier step takes a new one and tries the step again; a Newton
iteration that converges slowly converges all the same, to the same
``a1``, and a Jacobian costs on looped models about ten right-hand
sides). The iteration matrix is factorised again whenever the step
changes (reusing the factors of a step up to 10-20 % different made
Newton fail more often, costing more Jacobians than the factorisations it
saved: docs/benchmarks.md). For a large model with an O(n) Newton
preconditioner (:meth:`flexmb.System.newton_preconditioner`, given by
``simulate`` from ``GeneralizedAlpha.krylov_min_coords`` speeds on) no
matrix is formed: the preconditioner's O(n) solve of ``A^-1 (A + gamma'
h C + beta' h^2 K)``, set up at a step's start and kept as the Jacobian
is, takes the iteration matrix's place, and once Newton fails with it the
corrections are solved by GMRES with products by differences of the
right-hand side at the iterate, preconditioned by it
(:mod:`flexmb.genalpha.krylov`). Newton stops when its update is small against the
position tolerance ``atol + rtol |x|`` in ``x1`` and against that
tolerance divided by the step in ``xd1`` (the speed error that moves the
positions by the tolerance over a step; derived in
:func:`flexmb.kernels.genalpha.newton_update`). After a Newton failure
the step is halved, and the steps that follow grow back to what the error
control asks for by at most 5 % a step.

The step size follows a local error estimate of the positions,
``(1/6 - beta - (alpha_m - alpha_f) / 2) h^2 (abar1 - abar0)`` (the
Zienkiewicz-Xie estimate written for generalized-alpha: the leading term
of the local error when ``abar`` lags ``a`` by ``(alpha_m - alpha_f) h``),
under a PI controller (exponents 0.7/3 and 0.4/3). It is built from the
algorithmic accelerations, and filtered by the iteration matrix as Radau
filters its estimate, so a mode far above ``1 / h`` counts far less than
its true acceleration would make it. That is not enough when modes a few
times above the motion are excited (they are partly resolved, and their
error is real): ``f_max`` then projects the estimate onto the modes of
``Jx`` below ``f_max``, and the modes above are integrated stably and
dissipated, not resolved. Projecting is not enough either when such a
mode is only a few times above the steps' resolution: the estimate of a
mode integrated at ``h omega`` of about 0.1 is thousands of times the
tolerance, the projector (built from a Jacobian that lags the state) lets
a fraction of it through, and a mode that is partly resolved is not
dissipated at all (the spectral radius is 1 to within ``(h omega)^4``).
``min_step`` then keeps the error control from reducing the step below
it: every mode above ``1 / (2 pi min_step)`` Hz is integrated at ``h omega
>= 1`` and damped by the amplification factor of that step (see
:func:`numerical_damping`); a step taken at ``min_step`` is accepted even
when its error estimate exceeds the tolerance. The energy this removes is
for the caller to report (``simulate(..., track_work=True)``: driver work minus the change
of kinetic and elastic energy minus the dampers' work).

The step's arithmetic is compiled (:mod:`flexmb.kernels.genalpha`, numba):
per Newton iteration, Python calls the right-hand side and one kernel that
updates ``a1``, tests convergence and gives the next iterate or the step's
end; per step, one kernel predicts and one estimates the error and sets
the next step size. Python keeps the bookkeeping (Jacobians, LU factors,
restarts, counts). The right-hand side (:meth:`flexmb.System.state_rate`,
compiled kernels with Python glue) is not called from compiled code.

A model with joints in Euler parameters (``rotation='quaternion'``, whose
speeds are angular velocities, not coordinate rates) is stepped on the
rotation group (Bruls & Cardona 2010): the same compiled step in the chart
``R = R0 exp([x]x)`` centred at each step's start, the chart moved to the
step's end after it (:mod:`flexmb.genalpha.chart`); every other model is
stepped in its own coordinates, as before, to the same bits.

The solver is in :mod:`flexmb.genalpha.solver` (its interpolant in
:mod:`flexmb.genalpha.dense`, configured classes in
:mod:`flexmb.genalpha.configured`), the method's parameters and
amplification in :mod:`flexmb.genalpha.parameters`; their public names are
importable from here. The solver's are imported on first use (PEP 562): it
is a :class:`scipy.integrate.OdeSolver`, and a run of another integrator
reads only the parameters (the resolution monitor's damping figures).

References
----------
.. [1] J. Chung, G. M. Hulbert, J. Appl. Mech. 60 (1993) 371-375.
.. [2] M. Arnold, O. Bruels, Multibody Syst. Dyn. 18 (2007) 185-202.
"""

from .._lazy import lazy_names as _lazy_names
from .parameters import DEFAULT_RHO_INF, alpha_parameters, amplification_matrix, numerical_damping

__all__ = ["GeneralizedAlpha", "generalized_alpha", "alpha_parameters", "amplification_matrix",
           "numerical_damping", "DEFAULT_RHO_INF"]

#: public names imported from their module on first use: the solver imports scipy.integrate and scipy.linalg
_LAZY = {"generalized_alpha": ".configured", "GeneralizedAlpha": ".solver", "GeneralizedAlphaDenseOutput": ".solver"}


__getattr__, __dir__ = _lazy_names(globals(), _LAZY)
