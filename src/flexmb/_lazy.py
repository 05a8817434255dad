"""A module imported where one of its names is first used, not where it is named.

Every process that runs flexmb pays for what ``import flexmb`` and a run
import: scipy.linalg alone imports some 85 modules of scipy (its array-API
layer imports numpy.f2py, numpy.random and numpy.testing). A module that
calls a few of scipy's functions on some paths only (a closed loop's
factorization, an analysis) names the module with :class:`LazyModule` and
calls through it; the import happens at the first call.
"""

from __future__ import annotations

import importlib

__all__ = ["LazyModule"]


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
