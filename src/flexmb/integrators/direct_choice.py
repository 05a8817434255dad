"""Which runs of CVODE step in compiled code: :func:`compiled_loop`.

:class:`flexmb.stepping.Run` asks :func:`compiled_loop` for the class that
replaces scikit-sundae's CVODE on a run: the open trees' one
(:mod:`flexmb.integrators.cvode_direct`), the loops' one
(:mod:`flexmb.integrators.cvode_direct_loops`), or None, and the run then
steps through scikit-sundae as before (the tests patch it to None to
compare the two paths).
"""

from __future__ import annotations

__all__ = ["compiled_loop"]


def compiled_loop(system, solver_cls, track_work: bool, events) -> type | None:
    """The compiled-loop class for a run of ``solver_cls`` on ``system``, or None where it does not apply.

    Parameters
    ----------
    system : System
        The model.
    solver_cls : type
        The integrator chosen (scikit-sundae's CVODEBDF or CVODEAdams are replaced).
    track_work : bool
        Whether the run integrates the work terms (computed in Python: not replaced).
    events : ContactEvents or None
        The run's contact events (located by scikit-sundae's root finding: not replaced).

    Returns
    -------
    type or None
        :class:`~flexmb.integrators.cvode_direct.DirectCVODEBDF` or
        :class:`~flexmb.integrators.cvode_direct.DirectCVODEAdams` (open trees),
        :class:`~flexmb.integrators.cvode_direct_loops.DirectLoopCVODEBDF` or
        :class:`~flexmb.integrators.cvode_direct_loops.DirectLoopCVODEAdams`
        (loops, :func:`~flexmb.integrators.cvode_direct_loops.loop_class`).
    """
    from .sundials import CVODEAdams, CVODEBDF

    family = {CVODEBDF: "BDF", CVODEAdams: "Adams"}.get(solver_cls)
    # work terms are computed in Python, contact events located by scikit-sundae's root finding, and the
    # callbacks take qd = u only (no Euler parameters): those runs stay on scikit-sundae
    if family is None or track_work or events is not None or not system.layout.identity:
        return None
    if system._packed_open is not None:  # an open tree, joints and force elements all compiled
        from .cvode_direct import DirectCVODEAdams, DirectCVODEBDF

        return {"BDF": DirectCVODEBDF, "Adams": DirectCVODEAdams}[family]
    if system.n_constraints:  # loops: see loop_class for what they need
        from .cvode_direct_loops import loop_class

        return loop_class(system, family)
    return None  # an open tree with force elements or joints evaluated in Python
