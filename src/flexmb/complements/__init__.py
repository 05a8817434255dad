"""Orthogonal complement strategies, selectable by name or instance."""

from __future__ import annotations

from ..errors import ModelError
from .base import Complement, ComplementStrategy
from .eigen import EigenComplement
from .svd import SVDComplement

__all__ = ["Complement", "ComplementStrategy", "EigenComplement", "SVDComplement", "COMPLEMENTS", "get_complement"]

COMPLEMENTS = {"eigen": EigenComplement, "svd": SVDComplement}


def get_complement(strategy) -> ComplementStrategy:
    """Return a strategy instance from a name, a class or an instance.

    Parameters
    ----------
    strategy : str, type or ComplementStrategy
        ``"eigen"``, ``"svd"``, a subclass, or an instance.

    Returns
    -------
    ComplementStrategy
        The strategy.

    Raises
    ------
    ModelError
        For an unknown name (the message lists the valid ones).
    """
    if isinstance(strategy, ComplementStrategy):
        return strategy
    if isinstance(strategy, type) and issubclass(strategy, ComplementStrategy):
        return strategy()
    try:
        return COMPLEMENTS[strategy]()
    except (KeyError, TypeError):
        raise ModelError(
            f"unknown complement strategy {strategy!r}; pick one of {sorted(COMPLEMENTS)}"
        ) from None
