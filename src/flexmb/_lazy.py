"""A module imported where one of its names is first used, not where it is named.

Every process that runs flexmb pays for what ``import flexmb`` and a run
import: scipy.linalg alone imports some 85 modules of scipy (its array-API
layer imports numpy.f2py, numpy.random and numpy.testing). A module that
calls a few of scipy's functions on some paths only (a closed loop's
factorization, an analysis) names the module with :class:`LazyModule` and
calls through it; the import happens at the first call. A package whose
public names live in modules that import much names them in a table and
gets its module-level ``__getattr__`` and ``__dir__`` from :func:`lazy_names`.
"""

from __future__ import annotations

import importlib

__all__ = ["LazyModule", "lazy_names"]


class LazyModule:
    """A stand-in for the module ``name``, imported at the first attribute read.

    Each name read is then kept on the stand-in itself, so that later reads
    cost what a module attribute costs.

    Parameters
    ----------
    name : str
        The module's absolute name, e.g. ``"scipy.linalg"``.

    Examples
    --------
    >>> import sys
    >>> from flexmb._lazy import LazyModule
    >>> shlex = LazyModule("shlex")
    >>> shlex.quote("a b")
    "'a b'"
    >>> "quote" in vars(shlex)
    True
    """

    def __init__(self, name: str):
        self._lazy_name = name

    def __getattr__(self, attr: str):
        if attr.startswith("__"):  # copy, pickle and doctest probe dunders: never import for them
            raise AttributeError(attr)
        value = getattr(importlib.import_module(self._lazy_name), attr)
        setattr(self, attr, value)
        return value

    def __repr__(self) -> str:
        return f"<LazyModule {self._lazy_name!r}>"


def lazy_names(namespace: dict, table: dict):
    """A package's ``__getattr__`` and ``__dir__`` (PEP 562) for public names imported on first use.

    Parameters
    ----------
    namespace : dict
        The package's ``globals()``: each name imported is kept there, so
        later reads cost what a module attribute costs.
    table : dict
        Public name -> the module defining it, relative to the package
        (``".solver"``).

    Returns
    -------
    tuple
        ``(__getattr__, __dir__)``, to assign at the package's module level.

    Examples
    --------
    >>> from flexmb._lazy import lazy_names
    >>> ns = {"__name__": "json"}
    >>> getattr_, dir_ = lazy_names(ns, {"JSONDecoder": ".decoder"})
    >>> getattr_("JSONDecoder").__name__, "JSONDecoder" in ns, "JSONDecoder" in dir_()
    ('JSONDecoder', True, True)
    """
    package = namespace["__name__"]

    def __getattr__(name):
        module = table.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module, package), name)
        namespace[name] = value
        return value

    def __dir__():
        return sorted(set(namespace) | set(table))

    return __getattr__, __dir__
