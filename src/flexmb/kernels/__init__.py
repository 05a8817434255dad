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
give the measured time), later runs load the machine code. A compilation says so, once per
family of kernels, on stderr (:mod:`flexmb.kernels.compiling`).
"""

#: coordinate kinds in ``Topology.coord_kind`` (one per speed): a translation or a rotation
#: of the generic joint motion, a coordinate of a joint whose class computes its own motion
#: (called back from Python), or one of the three angular speeds of a set of Euler parameters
#: (:mod:`flexmb.quaternions`: its ``qx, qy, qz`` share their indices, ``coord_axis`` holds
#: the index of its ``qw``)
TRANSLATION, ROTATION, EXTERNAL, QUATERNION = 0, 1, 2, 3

__all__ = ["TRANSLATION", "ROTATION", "EXTERNAL", "QUATERNION"]

from . import compiling as _compiling

_compiling.install()  # one line on stderr when a family of kernels compiles; progress bars' clocks skip it

from .._blas import load as _load_blas

_load_blas()  # the BLAS and LAPACK the compiled code calls, without scipy.linalg's Python interface
