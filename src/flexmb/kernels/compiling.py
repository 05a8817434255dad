"""Saying when the kernels compile, and keeping compilation off the progress bars' clocks.

numba compiles a kernel at its first call with new argument types, unless
its machine code is in the cache (:mod:`flexmb.kernels.cache`); it reports
each compilation, never a load from the cache, as a ``"numba:compile"``
event. The listener registered here, when :mod:`flexmb.kernels` is
imported, watches the events of flexmb's own kernels:

* The first time a family of kernels compiles in a process (what open
  trees need, what loops add, the generalized-alpha step), it prints one line on
  stderr, whichever route the run took (the ``flexmb`` command, a script,
  a notebook): ``flexmb: compiling flexmb's kernels for loops, once: ~N s
  (later runs load them from the cache)``. ``N`` is the family's cold cost
  measured by ``benchmarks/cold_start.py`` (:data:`ESTIMATE_S`); a warm
  cache prints nothing.
* It adds up the wall time spent compiling (:func:`compile_seconds`):
  :class:`flexmb.progress.Progress` takes it off its clock, so that a bar
  appears only once the kernels have compiled and its rate and remaining
  time are those of the simulation, not of the compiler.
"""

from __future__ import annotations

import sys
import threading
import time

from numba.core import event

__all__ = ["FAMILIES", "ESTIMATE_S", "compile_seconds", "family_of", "install"]

#: the family of a kernel, by the module it is defined in (``flexmb.kernels.<module>``): what an open tree
#: needs (its kinematics, the built-in force elements, the articulated-body solve, the Jacobians), what loops
#: add, and the generalized-alpha step
FAMILIES = {
    **dict.fromkeys(("tree", "dynamics", "articulated", "packing", "loads", "contact", "friction", "tangent"),
                    "open trees"),
    **dict.fromkeys(("equations", "constraints", "loops", "loop_layout", "loop_projection", "loop_statics", "reduced",
                     "constraint_matrix"), "loops"),
    "genalpha": "generalized-alpha",
    "cvode_callbacks": "CVODE's compiled loop",
}

#: about how many seconds of CPU each family takes to compile (``benchmarks/cold_start.py`` on a 2-core machine,
#: docs/benchmarks.md "Cold and warm first runs": the README's pendulum cold less warm for open trees, the main
#: job's cold less warm less that for loops); a family not measured is announced without a figure
ESTIMATE_S = {"open trees": 30, "loops": 15}

_PACKAGE = __name__.rsplit(".", 1)[0] + "."
_lock = threading.Lock()
_told: set[str] = set()
_state = threading.local()  # per thread: depth of nested flexmb compilations, start of the outermost
_total = [0.0]  # wall seconds spent compiling flexmb's kernels in this process, all threads


def family_of(dispatcher) -> str | None:
    """The family of a flexmb kernel (:data:`FAMILIES`), None for any other compiled function.

    Parameters
    ----------
    dispatcher : numba Dispatcher
        The function being compiled.

    Returns
    -------
    str or None
        The family's name.
    """
    module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
    if not module.startswith(_PACKAGE):
        return None
    return FAMILIES.get(module[len(_PACKAGE):].split(".")[0], "other models")


def compile_seconds() -> float:
    """Wall seconds spent so far in this process compiling flexmb's kernels (outermost compilations only).

    Returns
    -------
    float
        The total, growing as kernels compile.
    """
    with _lock:
        total = _total[0]
    depth = getattr(_state, "depth", 0)
    if depth:  # called from inside a compilation (this thread's): count it up to now
        total += time.perf_counter() - _state.start
    return total


class _Listener(event.Listener):
    def on_start(self, ev):
        family = family_of(ev.data.get("dispatcher"))
        if family is None:
            return
        depth = getattr(_state, "depth", 0)
        _state.depth = depth + 1
        if depth:
            return
        _state.start = time.perf_counter()
        with _lock:
            new = family not in _told
            _told.add(family)
        if new:
            from .cache import sources_stamp
            from .prebuilt import unusable_reason

            estimate = ESTIMATE_S.get(family)
            about = f": ~{estimate} s" if estimate else ""
            why = unusable_reason(sources_stamp())
            print(f"flexmb: compiling flexmb's kernels for {family}, once{about} ({why + '; ' if why else ''}later "
                  "runs load them from the cache)", file=sys.stderr, flush=True)

    def on_end(self, ev):
        if family_of(ev.data.get("dispatcher")) is None or not getattr(_state, "depth", 0):
            return
        _state.depth -= 1
        if not _state.depth:
            with _lock:
                _total[0] += time.perf_counter() - _state.start


_listener = _Listener()


def install() -> None:
    """Register the listener with numba (once per process; :mod:`flexmb.kernels` does it on import)."""
    with _lock:
        if getattr(install, "done", False):
            return
        install.done = True
    event.register("numba:compile", _listener)
