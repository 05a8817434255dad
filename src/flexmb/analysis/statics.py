"""Nonlinear static equilibrium: Newton's method, then load continuation where it fails.

:func:`static_equilibrium` solves ``T^T g(x) = 0`` on ``phi(x) = 0``
(eqs. 5, 28-39) from a starting state; when Newton's method alone does not
converge it follows Newton's homotopy ``R(x) - (1 - lambda) R(x0) = 0``
from ``lambda = 0`` to 1 with the path follower of
:mod:`flexmb.analysis.path_following` (from an unloaded state with dead
loads this is load stepping).
"""

from __future__ import annotations

import numpy as np

from .._validate import number, whole
from ..errors import AssemblyError
from ..threads import limited_blas
from .loop_paths import LoopPathEquations
from .path_following import _Equations, _follow, _newton, _NotConverged, _start
from .paths import PathOptions

__all__ = ["static_equilibrium"]


@limited_blas
def static_equilibrium(system, x0=None, t: float = 0.0, tol: float = 1e-10, max_iter: int = 50, *,
                       continuation: bool = True, options: PathOptions | None = None, full_output: bool = False):
    """Nonlinear static equilibrium (gravity sag, large deflections), with automatic load continuation.

    Solves ``T^T g(x) = 0`` on ``phi(x) = 0``, g the generalized active
    force at rest, starting from ``x0``: first by Newton's method; if that
    fails (the residual grows, or no convergence in ``max_iter`` steps), by
    following the load path of Newton's homotopy ``g(x) - (1 - lambda)
    g(x0)`` from ``lambda = 0`` (where ``x0`` solves it) to 1 with
    :func:`load_path`, which adapts its steps and passes limit points.

    Parameters
    ----------
    system : System
        Compiled model.
    x0 : ndarray, shape (n,), optional
        Starting configuration (default zeros).
    t : float
        Time, s.
    tol : float
        Convergence: the largest Newton step (rad or m) below ``tol``.
    max_iter : int
        Newton iterations allowed from ``x0``, before continuation.
    continuation : bool
        Fall back on load continuation when Newton's method from ``x0``
        fails (default); False gives Newton's method alone.
    options : PathOptions, optional
        Step control of the continuation.
    full_output : bool
        Also return the load path (None if Newton's method from ``x0``
        converged).

    Returns
    -------
    x : ndarray, shape (n,)
        Equilibrium coordinates.
    path : LoadPath or None
        Only with ``full_output``.

    Raises
    ------
    AssemblyError
        If no equilibrium is found; the message names the load step, the
        load factor reached and the remaining force residual, and the
        error's ``path`` attribute holds the partial load path.

    Notes
    -----
    Newton's method from ``x0`` is given up as soon as the largest force
    residual grows from one iteration to the next (unless the step is
    already within ``1000 tol``): from a far start it would wander, and the
    continuation is cheap. Where it converges, the result is the one
    Newton's method alone gives.

    For loops closed by the articulated strategy (``complement='articulated'``
    or ``'auto'``) Newton's method forms no n x n array: each step is a
    GMRES solve in the null space of psi, preconditioned by the loops'
    constrained articulated solve with the springs as armature, O(n m) per
    product (:class:`~flexmb.analysis.loop_statics.LoopEquations`; the same
    equilibria as the dense route); its residual is ``g + psi^T mu``, its
    step ``max |dx|``. So does the continuation
    (:class:`~flexmb.analysis.loop_paths.LoopPathEquations`).

    Newton's homotopy at an unstressed ``x0`` (straight beams, springs at
    their free lengths) starts from the loads alone, so the continuation is
    load stepping of all the loads at once, with no need to tell loads from
    elastic forces; to scale chosen loads only, use :func:`load_path`. From
    a stressed ``x0`` the path is still a valid homotopy, though its
    intermediate states are not physical.

    Examples
    --------
    A cantilever bent by a tip force ``P = 20 E I / L^2``, beyond the
    reach of Newton's method from the straight beam: the tip ends about
    0.87 L below the clamp (the elastica, Bisshopp and Drucker 1945:
    0.8687 L).

    >>> import numpy as np
    >>> import flexmb as fm
    >>> section, steel = fm.Section.rectangular(0.02, 0.005), fm.Material.steel()
    >>> beam = fm.FlexibleBody("beam", 1.0, section, steel, n_segments=16, keep=("bend_y",))
    >>> m = fm.Model()
    >>> _ = m.add(fm.Fixed("clamp", m.ground, beam),
    ...           fm.PointForce("P", beam, (0, 0, -20 * steel.E * section.Iy), point=(1, 0, 0)))
    >>> system = m.build()
    >>> x, path = fm.static_equilibrium(system, full_output=True)
    >>> round(float(np.sum(np.sin(np.cumsum(x))) / 16), 2)
    0.87
    >>> path.reached, len(path.limit_points)
    (True, 0)
    """
    tol = number("static_equilibrium", "tol", tol, minimum=0.0)
    max_iter = whole("static_equilibrium", "max_iter", max_iter)
    x = _start(system, x0)
    x, _ = system.project(t, x, np.zeros(system.n_speeds))
    # loops closed by the articulated strategy: Newton's iteration in O(n m), T never formed (loop_statics.py)
    eq = LoopPathEquations(system, t, None, x) if system._loop_kernel else _Equations(system, t, None, x)
    counts = {"iterations": 0, "tangents": 0}
    try:
        x_eq, _ = _newton(eq, x, 1.0, tol, max_iter, counts, monotone=continuation)
        return (x_eq, None) if full_output else x_eq
    except _NotConverged as exc:
        if not continuation:
            if exc.why.startswith("no convergence"):
                raise AssemblyError(
                    f"static equilibrium did not converge in {max_iter} Newton steps: last step {exc.step:.3g}, "
                    f"force residual {exc.residual:.3g}") from None
            hint = " (a mechanism with an unloaded free motion?)" if "singular" in exc.why else ""
            raise AssemblyError(
                f"static equilibrium: Newton's method stopped at step {exc.iterations + 1}: {exc.why}{hint}; "
                f"last step {exc.step:.3g}, force residual {exc.residual:.3g}") from None
    path = _follow(eq, x, 0.0, 1.0, PathOptions() if options is None else options, tol, "static equilibrium")
    path.n_iterations += counts["iterations"]
    path.n_tangents += counts["tangents"]
    return (path.x[-1].copy(), path) if full_output else path.x[-1].copy()
