"""scipy's BLAS and LAPACK for numba's compiled code, loaded without the rest of ``scipy.linalg``.

Compiled code that multiplies matrices (numba's ``@``) or factors them
(``np.linalg``) calls BLAS and LAPACK through the function tables of
``scipy.linalg.cython_blas`` and ``scipy.linalg.cython_lapack``. Imported
the ordinary way, those two extension modules first run
``scipy.linalg``'s ``__init__`` (its whole Python interface, a large part
of a short script's start-up) although only their tables are read.
:func:`load` loads the two modules by themselves under their own names;
``import scipy.linalg`` later (flexmb's Python linear algebra, a user's
script) works as before and finds them loaded.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import os
import sys

__all__ = ["load"]

#: the extension modules numba's linear algebra reads its function tables from
MODULES = ("scipy.linalg.cython_blas", "scipy.linalg.cython_lapack")


def load() -> bool:
    """Load scipy's ``cython_blas`` and ``cython_lapack`` without ``scipy.linalg``'s ``__init__``.

    Nothing happens where they are loaded already; where scipy's files are
    not found as expected (another layout, a frozen application), nothing
    is loaded and the ordinary import does it when numba asks.

    Returns
    -------
    bool
        True if both modules are loaded.
    """
    if all(name in sys.modules for name in MODULES):
        return True
    spec = importlib.util.find_spec("scipy")
    if spec is None or not spec.submodule_search_locations:
        return False
    folder = os.path.join(list(spec.submodule_search_locations)[0], "linalg")
    loaded = []
    try:
        for name in MODULES:
            if name in sys.modules:
                continue
            path = _extension(folder, name.rpartition(".")[2])
            if path is None:
                raise ImportError(name)
            module_spec = importlib.util.spec_from_file_location(name, path)
            module = importlib.util.module_from_spec(module_spec)
            sys.modules[name] = module
            loaded.append(name)
            module_spec.loader.exec_module(module)
    except Exception:  # noqa: BLE001 - any failure: leave it to the ordinary import
        for name in loaded:
            sys.modules.pop(name, None)
        return False
    return True


def _extension(folder, stem):
    """The path of the extension module ``stem`` in ``folder``, or None."""
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        path = os.path.join(folder, stem + suffix)
        if os.path.isfile(path):
            return path
    return None
