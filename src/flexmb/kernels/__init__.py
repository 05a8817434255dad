"""Compiled kernels of the evaluation path (numba, ``cache=True``).

The model's tree is laid out as flat arrays once
(:class:`flexmb.topology.Topology`): bodies in breadth-first order (a parent
before its children, the ground as the extra last row), each tree joint's
coordinates contiguous in ``x``, and per coordinate its kind (translation
or rotation of the generic joint motion, or a joint whose class computes
its own motion in Python) and axis. The kernels walk that layout with
plain loops: one pass from the ground out for the kinematics, one pass
from the leaves in for subtree sums, so that an evaluation costs O(n) time
and memory for an open tree (the dense mass matrix of a model with loops
costs O(n depth)).

Compiled code is cached beside these sources (``cache=True``, :mod:`flexmb.kernels.cache`): the
first run of a new installation compiles (the README and ``docs/benchmarks.md``
give the measured time), later runs load the machine code.
"""

#: coordinate kinds in ``Topology.coord_kind``: a translation or a rotation
#: of the generic joint motion, or a coordinate of a joint whose class
#: computes its own motion (called back from Python)
TRANSLATION, ROTATION, EXTERNAL = 0, 1, 2

__all__ = ["TRANSLATION", "ROTATION", "EXTERNAL", "cached_on_disk"]

#: what the first run of an installation costs, said before it compiles (README; docs/benchmarks.md)
FIRST_RUN_NOTE = ("flexmb: first run of this installation: compiling the numba kernels (about 40 s of CPU, "
                  "once; later runs load them from the cache)")


def cached_on_disk() -> bool:
    """Whether the kernels' machine code is in numba's cache for these sources (else the next run compiles).

    Judged by the kinematics kernel, which every run needs: its cache
    index must exist and match the source file. If numba's cache cannot be
    read for another reason, True (nothing to announce).

    Returns
    -------
    bool
        True if the kernels load from the cache.
    """
    from .tree import tree_kinematics

    try:
        return bool(tree_kinematics._cache._cache_file._load_index())  # numba's index, {} if absent or stale
    except Exception:  # numba's private cache layout changed: say nothing
        return True
