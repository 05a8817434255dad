"""Orthogonal complement strategies, selectable by name or instance."""

from __future__ import annotations

from .. import registry
from ..errors import ModelError
from .base import Complement, ComplementStrategy
from .eigen import EigenComplement
from .svd import SVDComplement
from .qr import QRComplement
from .auto import AutoComplement
from .articulated import ArticulatedComplement

__all__ = ["Complement", "ComplementStrategy", "EigenComplement", "SVDComplement", "COMPLEMENTS", "get_complement",
           "QRComplement", "AutoComplement", "ArticulatedComplement"]

#: the built-in strategies by name: a read-only view of flexmb's ``flexmb.complements`` entry points
COMPLEMENTS = registry.builtin_table("complements")


def get_complement(strategy) -> ComplementStrategy:
    """Return a strategy instance from a name, a class or an instance.

    Parameters
    ----------
    strategy : str, type or ComplementStrategy
        ``"eigen"``, ``"svd"``, ``"qr"``, ``"auto"``, ``"articulated"``, a plugin's name (entry-point group
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
    # names come from the plugin registry (entry points, the built-ins of COMPLEMENTS among them)
    if isinstance(strategy, str) and strategy in registry.names("complements"):
        return registry.get("complements", strategy)()
    raise ModelError(f"unknown complement strategy {strategy!r}; pick one of {registry.names('complements')}")
