"""How much memory a model and its outputs need, checked before the big arrays are allocated.

A model too large for the machine (``n_segments = 100000``) or an output
request too long (``n_out = 1e8``) is refused at once with a
:class:`~flexmb.errors.ModelError` that says how much it needs and how much
there is, instead of failing later with an uncaught :class:`MemoryError`,
or swapping.

The estimate works from counts only (:class:`Counts`), so that it can be
made before anything is allocated: the number of bodies after the flexible
bodies are cut into segments ``nb``, the number of coordinates ``n``, the
number of constraint rows ``m`` and the number of output times ``nt``. In
bytes, with 8-byte floats::

    model   = 8 (DENSE_NN n^2 [m > 0] + DENSE_MN m n) + PER_BODY nb + PER_COORD n     (loops="dense")
    model   = 8 LOOP_MN m n + PER_BODY nb + PER_COORD n                                (loops="articulated")
    outputs = 8 nt (OUTPUT_N n + OUTPUT_B nb + m + OUTPUT_FIXED)

The compiled core builds and evaluates an open tree in O(n) memory (no
array grows as n^2: ``benchmarks/large_structures.py``); a model with loops
(m > 0) closed by a complement T (``loops="dense"``: the 'svd', 'eigen' and
'qr' strategies) forms the dense mass matrix and the reduced one with their
factors (the ``DENSE_NN`` term) and the constraint Jacobian psi (the
``DENSE_MN`` term). Closed through the articulated-body recursion
(``loops="articulated"``: the 'articulated' and 'auto' strategies) it forms
no n x n array; the model term is then ``8 LOOP_MN m n`` instead: the
subtrees each row's column visits and the rows' sparse entries on their
paths, at most n each (reached when every row's path spans the structure,
as a flexible rod in one loop; a chain of loops needs far less). ``PER_BODY`` and ``PER_COORD`` bound what was measured
on B1 up to 100,000 segments (about 3.2 kB per segment with its
coordinate, the packed copy of the tree's arrays included). Not counted: the dense state Jacobian ``(2n)^2`` of an
implicit integrator that uses one (Radau, BDF, CVODE with a dense linear
solver), formed when a run starts.

The limit is the memory available now (``MemAvailable`` of
``/proc/meminfo``, else ``os.sysconf`` free pages), capped by the
environment variable ``FLEXMB_MEMORY_LIMIT`` (bytes, or with a suffix
``K``, ``M``, ``G``, ``T``) when it is set. Without that variable a need of
at most ``ALWAYS_FITS`` bytes (the outputs of a small model's run) is taken
to fit without reading the memory available.
"""

from __future__ import annotations

import os
import re

from attrs import frozen

from .errors import ModelError

__all__ = ["Counts", "counts", "estimate", "available", "limit", "check", "DENSE_NN", "DENSE_MN", "LOOP_MN", "PER_BODY", "PER_COORD", "OUTPUT_N", "OUTPUT_B", "OUTPUT_FIXED", "ALWAYS_FITS"]

#: floats per n^2 of a model with loops: the mass matrix and its factor, the reduced mass
#: matrix and the products with the complement
DENSE_NN = 4
#: floats per m * n: the constraint Jacobian psi, its complement work arrays
DENSE_MN = 4
#: words per m * n, loops closed by the articulated strategy: the visited subtrees and the sparse rows (worst case)
LOOP_MN = 2
#: bytes that fit whatever the machine has left (a process that cannot find them fails anyway): a need this small
#: is not compared with the memory available (``/proc/meminfo`` is not read), unless ``FLEXMB_MEMORY_LIMIT`` is set
ALWAYS_FITS = 2**20
#: bytes per body: the Segment and joint objects, names, per-body arrays and tree tables
PER_BODY = 4096
#: bytes per coordinate: names, index arrays, state vectors
PER_COORD = 512
#: floats per coordinate per output time: x, xd (stored, copied, collected: 6) and xdd (1)
OUTPUT_N = 7
#: floats per body per output time: positions (3), origins (3), rotations (9)
OUTPUT_B = 15
#: floats per output time besides: time, energies, residuals (8) and the header of the stored state
#: array (about 130 bytes: 16)
OUTPUT_FIXED = 24

_FLOAT = 8


@frozen
class Counts:
    """The sizes that set the memory a model needs.

    Parameters
    ----------
    n_bodies : int
        Bodies after the flexible bodies are cut into segments (and clamp frames).
    n_coords : int
        Generalized coordinates n.
    n_rows : int
        Constraint rows m (loop closures and drivers).

    Examples
    --------
    >>> from flexmb.memory import Counts, estimate
    >>> estimate(Counts(1, 1, 0)) < 10_000
    True
    """

    n_bodies: int
    n_coords: int
    n_rows: int = 0


def counts(obj) -> Counts:
    """The counts of a model, a compiled system or a :class:`Counts`.

    Parameters
    ----------
    obj : Model, System or Counts
        For a :class:`~flexmb.Model` the counts come from the definitions
        alone (nothing is expanded or allocated): a flexible body gives its
        segments (and a clamp frame) and its elastic coordinates; the
        coordinates of every joint are counted (an upper bound: a joint that
        closes a loop has none); each joint beyond a spanning tree (and each
        joint marked ``cut``) is counted as 6 constraint rows, each driver
        as one.

    Returns
    -------
    Counts
        The counts.
    """
    if isinstance(obj, Counts):
        return obj
    topology = getattr(obj, "topology", None)
    if topology is not None:  # a System
        return Counts(int(topology.n_bodies), int(obj.n_coords), int(obj.n_constraints))
    from .flexible import FlexibleBody

    nb = n = 0
    for b in obj.bodies:
        if isinstance(b, FlexibleBody):
            nb += b.n_segments + bool(b.clamped)
            n += b.n_elastic
        else:
            nb += 1
    cut = sum(1 for j in obj.joints if getattr(j, "cut", False))
    tree = len(obj.joints) - cut
    n += sum(int(getattr(j, "n_coords", 6)) for j in obj.joints)
    rows = 6 * (cut + max(0, tree - len(obj.bodies))) + len(obj.drivers)
    return Counts(nb, n, rows)


#: how a model's loops are closed, for the estimate: by a dense complement T, or through the recursion
LOOPS = ("dense", "articulated")


def _parts(obj, n_out: int = 0, loops: str = "dense") -> tuple[int, int, int]:
    if loops not in LOOPS:
        raise ValueError(f"loops must be one of {LOOPS}, got {loops!r}")
    c = counts(obj)
    nb, n, m = c.n_bodies, c.n_coords, c.n_rows
    if loops == "dense":
        dense = _FLOAT * (DENSE_NN * n * n * (m > 0) + DENSE_MN * m * n)
    else:
        dense = _FLOAT * LOOP_MN * m * n
    rest = PER_BODY * nb + PER_COORD * n
    outputs = _FLOAT * int(n_out) * (OUTPUT_N * n + OUTPUT_B * nb + m + OUTPUT_FIXED)
    return dense, rest, outputs


def estimate(obj, n_out: int = 0, loops: str = "dense") -> int:
    """Bytes a model needs to be built and simulated, with ``n_out`` output times.

    Parameters
    ----------
    obj : Model, System or Counts
        What to estimate (see :func:`counts`).
    n_out : int
        Number of output times (0: the model alone).
    loops : {'dense', 'articulated'}
        How the loops are closed (see the module docstring).

    Returns
    -------
    int
        The estimate, bytes (the formula is in the module docstring).

    Examples
    --------
    >>> from flexmb.memory import Counts, estimate
    >>> estimate(Counts(n_bodies=100_001, n_coords=300_000)) < 2**30  # 100,000 segments: about 0.6 GB
    True
    """
    return sum(_parts(obj, n_out, loops))


def available() -> int:
    """Memory available to a new allocation now, bytes.

    Returns
    -------
    int
        ``MemAvailable`` of ``/proc/meminfo`` (Linux); else the free pages
        times the page size (``os.sysconf``); else a large number (no
        limit known).
    """
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return 2**62


_UNITS = {"": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}


def limit() -> int:
    """The most a model may need: :func:`available`, capped by ``FLEXMB_MEMORY_LIMIT``.

    Returns
    -------
    int
        Bytes.

    Raises
    ------
    ModelError
        If ``FLEXMB_MEMORY_LIMIT`` is set but is not a size such as ``2G``.
    """
    free = available()
    text = os.environ.get("FLEXMB_MEMORY_LIMIT", "").strip()
    if not text:
        return free
    match = re.fullmatch(r"(\d+(?:\.\d+)?)\s*([KMGT]?)i?B?", text, flags=re.IGNORECASE)
    if not match:
        raise ModelError(f"FLEXMB_MEMORY_LIMIT must be a size in bytes such as 2000000000 or 2G, got {text!r}")
    return min(free, int(float(match.group(1)) * _UNITS[match.group(2).upper()]))


def _size(nbytes: float) -> str:
    for unit, scale in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if nbytes >= scale:
            return f"{nbytes / scale:.3g} {unit}"
    return f"{int(nbytes)} B"


def check(obj, n_out: int = 0, what: str = "", model: bool = True, loops: str = "dense") -> int:
    """Refuse a model (and outputs) that would not fit in memory.

    Parameters
    ----------
    obj : Model, System or Counts
        What to check (see :func:`counts`).
    n_out : int
        Number of output times (0: the model alone).
    what : str
        Who asks, the start of the message (``"simulate"``).
    model : bool
        Count the model itself; False counts the outputs only (for a model
        that is built already, whose arrays are no longer available memory).
    loops : {'dense', 'articulated'}
        How the loops are closed (see the module docstring).

    Returns
    -------
    int
        The estimate, bytes, when it fits.

    Raises
    ------
    ModelError
        If :func:`estimate` exceeds :func:`limit`; the message gives both
        and the counts behind the estimate.
    """
    dense, rest, outputs = _parts(obj, n_out, loops)
    if not model:
        dense = rest = 0
    need = dense + rest + outputs
    if need <= ALWAYS_FITS and not os.environ.get("FLEXMB_MEMORY_LIMIT", "").strip():
        return need
    room = limit()
    if need <= room:
        return need
    c = counts(obj)
    parts = []
    if model:
        parts.append(f"{_size(rest)} for the bodies and coordinates")
        if dense:
            parts.append(f"{_size(dense)} for the dense arrays of the loops" if loops == "dense"
                         else f"{_size(dense)} for the loops")
    if n_out:
        parts.append(f"{_size(outputs)} for {int(n_out):,} output times")
    raise ModelError(
        f"{what + ': ' if what else ''}needs about {_size(need)} of memory ({', '.join(parts)}; "
        f"{c.n_bodies:,} bodies after "
        f"segmenting, {c.n_coords:,} coordinates, {c.n_rows:,} constraint rows), but {_size(room)} is "
        f"available; use fewer segments or coordinates, or fewer output times"
    )
