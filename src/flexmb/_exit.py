"""The interpreter's exit without the final collections' pass over every library object still alive.

At exit, after the ``atexit`` handlers, CPython's finalization runs the
cyclic garbage collector over every object still tracked, several times
(before and while it tears the modules down). A process that has imported
flexmb holds about 10^5 such objects (numba's typing and lowering
registries, the loaded kernels' types and environments, numpy's and
flexmb's modules): those passes are most of the exit's CPU, and a
noticeable share of a short run's (docs/benchmarks.md, "Start-up").

:func:`install` registers, once, an ``atexit`` handler that collects the
garbage as the interpreter's first exit collection would (every object
unreachable at that point is finalized: ``__del__``, weak reference
callbacks, files flushed), then moves everything still alive to the
collector's permanent generation (``gc.freeze``), which the later passes
skip. What changes: a reference cycle that is still *reachable* when the
handlers run (held by a module's global, say) is not collected when the
modules are torn down, so its objects' ``__del__`` does not run; the
language does not promise that for objects alive at exit (the data model's
``object.__del__``). Handlers registered before flexmb's import run after
this one (``atexit`` runs them last-in, first-out): what they leave
behind is collected as usual.
"""

from __future__ import annotations

import atexit
import gc

__all__ = ["install"]

_installed = False


def _freeze_survivors() -> None:
    """Collect the garbage, then exempt what is still alive from the exit's collections."""
    gc.collect()
    gc.freeze()


def install() -> None:
    """Register the exit handler (once per process)."""
    global _installed
    if not _installed:
        _installed = True
        atexit.register(_freeze_survivors)
