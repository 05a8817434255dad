"""Machine code shipped with the sources: the kernels precompiled for a portable CPU, read-only.

A new installation would otherwise compile its kernels on first use (tens of
seconds of CPU, docs/benchmarks.md "Cold and warm first runs"). The folder
``_prebuilt/<interpreter>-<machine>/`` beside these sources holds numba cache
entries of the kernels (numba's own index and data files, one pair per
kernel) compiled by ``python -m flexmb.kernels.prebuild`` for a baseline CPU
(``x86-64-v3``: AVX2 and FMA, no AVX-512), and ``manifest.json``, which says
what they were built from. :class:`flexmb.kernels.cache.KernelCache` reads a
kernel's entry from there first, never writes there, and falls back to its
own cache (load, else compile and save) for whatever the folder does not
serve. The folder is used only when all of this holds:

* its manifest's stamp is :func:`flexmb.kernels.cache.sources_stamp` (a
  kernel edited since the build makes the whole folder stale: the kernels
  then compile as without it);
* numba and llvmlite are the versions it was built with (numba's index also
  refuses another numba version);
* the CPU runs the baseline's code (it has every feature the baseline
  assumes), on the same target triple;
* numba's code generation is not set by the user (``NUMBA_CPU_NAME``,
  ``NUMBA_CPU_FEATURES``: then the user asked for other machine code) and
  ``FLEXMB_PREBUILT`` is not ``0``.

Where it is present but unusable, the compilation's one-line notice
(:mod:`flexmb.kernels.compiling`) says why (:func:`unusable_reason`). This module reads the shipped folder only; the
stamp it compares comes from its caller (:mod:`flexmb.kernels.cache`).
"""

from __future__ import annotations

import functools
import json
import os
import platform
import sys

import numba
from numba.core import config
from numba.core.caching import IndexDataCacheFile

__all__ = ["BASELINES", "folder", "read_manifest", "usable", "unusable_reason", "entry_file", "magic_tuple"]

#: the CPU features (LLVM's names) each baseline's code may use: a host must have all of them
BASELINES = {
    "x86-64": ["64bit", "cmov", "cx8", "fxsr", "mmx", "sse", "sse2"],
    "x86-64-v2": ["64bit", "cmov", "cx8", "fxsr", "mmx", "sse", "sse2", "cx16", "sahf", "popcnt", "sse3", "sse4.1",
                  "sse4.2", "ssse3"],
    "x86-64-v3": ["64bit", "cmov", "cx8", "fxsr", "mmx", "sse", "sse2", "cx16", "sahf", "popcnt", "sse3", "sse4.1",
                  "sse4.2", "ssse3", "avx", "avx2", "bmi", "bmi2", "f16c", "fma", "lzcnt", "movbe", "xsave"],
}

#: the folder of all shipped builds, one sub-folder per interpreter and machine
ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "_prebuilt")


def folder() -> str:
    """This interpreter's and machine's folder of shipped entries.

    Returns
    -------
    str
        ``<ROOT>/cpython-311-x86_64-linux`` for CPython 3.11 on Linux x86-64.
    """
    return os.path.join(ROOT, f"{sys.implementation.cache_tag}-{platform.machine().lower()}-{sys.platform}")


def read_manifest(path: str | None = None) -> dict | None:
    """The manifest of a folder of shipped entries (this interpreter's by default), None where there is none.

    Parameters
    ----------
    path : str, optional
        The folder.

    Returns
    -------
    dict or None
        ``stamp``, ``numba``, ``llvmlite``, ``cpu`` (the baseline's name),
        ``magic_tuple`` (numba's codegen key of the entries), ``features``,
        ``kernels`` (the entries' file names).
    """
    try:
        with open(os.path.join(path or folder(), "manifest.json"), encoding="utf-8") as f:
            return json.load(f)
    except (OSError, ValueError):
        return None


def _host_features() -> set[str]:
    import llvmlite.binding as ll

    return {name for name, on in ll.get_host_cpu_features().items() if on}


@functools.lru_cache(maxsize=None)
def unusable_reason(stamp: str) -> str | None:
    """Why this process does not use the shipped entries (None where it does, or where none are shipped).

    Parameters
    ----------
    stamp : str
        The kernels' sources' stamp (:func:`flexmb.kernels.cache.sources_stamp`).

    Returns
    -------
    str or None
        A short clause for the compilation's notice ("the shipped machine
        code is for numba 0.68.1, this is 0.69.0").
    """
    manifest = read_manifest()
    if manifest is None or os.environ.get("FLEXMB_PREBUILT", "1") == "0":
        return None
    import llvmlite

    if manifest.get("stamp") != stamp:
        return "the shipped machine code predates an edit of the kernels"
    for name, have in (("numba", numba.__version__), ("llvmlite", llvmlite.__version__)):
        if manifest.get(name) != have:
            return f"the shipped machine code is for {name} {manifest.get(name)}, this is {have}"
    if config.CPU_NAME is not None or config.CPU_FEATURES is not None:
        return "NUMBA_CPU_NAME or NUMBA_CPU_FEATURES asks for other machine code than the shipped one"
    missing = sorted(set(manifest.get("features", [])) - _host_features())
    if missing:
        return f"this CPU lacks {', '.join(missing)}, which the shipped machine code ({manifest.get('cpu')}) uses"
    return None


@functools.lru_cache(maxsize=None)
def usable(stamp: str) -> bool:
    """Whether this process loads kernels from the shipped entries (see the module's conditions).

    Parameters
    ----------
    stamp : str
        The kernels' sources' stamp.

    Returns
    -------
    bool
        True where a manifest is present and every condition holds.
    """
    return (read_manifest() is not None and os.environ.get("FLEXMB_PREBUILT", "1") != "0"
            and unusable_reason(stamp) is None)


def magic_tuple(triple: str, stamp: str) -> tuple | None:
    """The codegen key (numba's) of the shipped entries, where they are usable on ``triple`` (the host's).

    Parameters
    ----------
    triple : str
        The target triple of this process's code generator.
    stamp : str
        The kernels' sources' stamp.

    Returns
    -------
    tuple or None
        ``(triple, cpu name, features)`` as numba's index keys hold it.
    """
    if not usable(stamp):
        return None
    magic = tuple(read_manifest()["magic_tuple"])
    return magic if magic[0] == triple else None


def entry_file(filename_base: str, source_stamp: str) -> IndexDataCacheFile | None:
    """The index-and-data file (numba's) of one kernel in the shipped folder, None where it ships none.

    Parameters
    ----------
    filename_base : str
        The kernel's cache file stem (``"tree.tree_kinematics-120.py311"``).
    source_stamp : str
        The stamp its index must carry.

    Returns
    -------
    IndexDataCacheFile or None
        None also where the shipped entries are not usable
        (:func:`usable`). Read only: :class:`flexmb.kernels.cache.KernelCache` never saves
        through it.
    """
    path = folder()
    if not usable(source_stamp) or not os.path.exists(os.path.join(path, filename_base + ".nbi")):
        return None
    return IndexDataCacheFile(cache_path=path, filename_base=filename_base, source_stamp=source_stamp)
