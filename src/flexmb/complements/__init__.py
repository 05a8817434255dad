"""Orthogonal complement strategies, selectable by name or instance."""

from __future__ import annotations

from .. import registry
from ..errors import ModelError
from .base import Complement, ComplementStrategy
from .eigen import EigenComplement
from .svd import SVDComplement
from .qr import QRComplement
from .auto import AutoComplement

__all__ = ["Complement", "ComplementStrategy", "EigenComplement", "SVDComplement", "COMPLEMENTS", "get_complement",
           "QRComplement", "AutoComplement"]

COMPLEMENTS = {"eigen": EigenComplement, "svd": SVDComplement, "qr": QRComplement, "auto": AutoComplement}


def get_complement(strategy) -> ComplementStrategy:
    """Return a strategy instance from a name, a class or an instance.

    Parameters
    ----------
    strategy : str, type or ComplementStrategy
        ``"eigen"``, ``"svd"``, ``"qr"``, ``"auto"``, a plugin's name (entry-point group
        ``flexmb.complements``), a subclass, or an instance.

    Returns
    -------
    ComplementStrategy
        The strategy.

    Raises
    ------
    ModelError
        For an unknown name (the message lists the valid ones).
    PluginError
        If the named plugin is broken or claimed by two distributions.
    """
    if isinstance(strategy, ComplementStrategy):
        return strategy
    if isinstance(strategy, type) and issubclass(strategy, ComplementStrategy):
        return strategy()
    # names come from the plugin registry (entry points, COMPLEMENTS' built-ins among them)
    if isinstance(strategy, str) and strategy in registry.names("complements"):
        return registry.get("complements", strategy)()
    raise ModelError(f"unknown complement strategy {strategy!r}; pick one of {registry.names('complements')}")
