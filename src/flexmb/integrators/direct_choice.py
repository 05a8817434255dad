"""Which runs of CVODE step in compiled code: :func:`compiled_loop`.

:class:`flexmb.stepping.Run` asks :func:`compiled_loop` for the class that
replaces scikit-sundae's CVODE on a run: the open trees' one
(:mod:`flexmb.integrators.cvode_direct`), the loops' one
(:mod:`flexmb.integrators.cvode_direct_loops`), or None, and the run then
steps through scikit-sundae as before (the tests patch it to None to
compare the two paths). With numba's JIT disabled (``NUMBA_DISABLE_JIT=1``:
the kernels run as Python, :mod:`flexmb.kernels.interpreted`) every run
steps through scikit-sundae.
"""

from __future__ import annotations

__all__ = ["compiled_loop", "FAMILIES"]

#: the integrators replaced: the import path of scikit-sundae's class -> CVODE's method
FAMILIES = {"flexmb.integrators.sundials:CVODEBDF": "BDF", "flexmb.integrators.sundials:CVODEAdams": "Adams"}


def compiled_loop(system, solver_cls, track_work: bool, events) -> type | None:
    """The compiled-loop class for a run of ``solver_cls`` on ``system``, or None where it does not apply.

    Parameters
    ----------
    system : System
        The model.
    solver_cls : type or str
        The integrator chosen, or the import path (``module:qualname``) it is
        registered under (:func:`flexmb.registry.path`): scikit-sundae's
        CVODEBDF and CVODEAdams are replaced, by their path, so that a run
        looked up by name never imports them.
    track_work : bool
        Whether the run integrates the work terms (computed in Python: not replaced).
    events : ContactEvents or None
        The run's contact events (located by scikit-sundae's root finding: not replaced).

    Returns
    -------
    type or None
        None with ``NUMBA_DISABLE_JIT=1``; else
        :class:`~flexmb.integrators.cvode_direct.DirectCVODEBDF` or
        :class:`~flexmb.integrators.cvode_direct.DirectCVODEAdams` (open trees),
        :class:`~flexmb.integrators.cvode_direct_loops.DirectLoopCVODEBDF` or
        :class:`~flexmb.integrators.cvode_direct_loops.DirectLoopCVODEAdams`
        (loops, :func:`~flexmb.integrators.cvode_direct_loops.loop_class`).
    """
    from ..kernels import interpreted

    if interpreted.disabled():  # NUMBA_DISABLE_JIT=1: the compiled callbacks cannot exist, step in Python
        return None
    path = solver_cls if isinstance(solver_cls, str) else f"{solver_cls.__module__}:{solver_cls.__qualname__}"
    family = FAMILIES.get(path)
    # work terms are computed in Python, contact events located by scikit-sundae's root finding, and the
    # callbacks take qd = u only (no Euler parameters): those runs stay on scikit-sundae
    if family is None or track_work or events is not None or not system.layout.identity:
        return None
    if system._packed_open is not None:  # an open tree, joints and force elements all compiled
        from .cvode_direct import REPLACES

        return REPLACES[path]
    if system.n_constraints:  # loops: see loop_class for what they need
        from .cvode_direct_loops import loop_class

        return loop_class(system, family)
    return None  # an open tree with force elements or joints evaluated in Python
