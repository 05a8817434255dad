"""Constraint elements: rows a model adds beside its cut joints and drivers (plugin group ``flexmb.constraints``).

Built-ins: :class:`KnifeEdge` (one velocity row), :class:`RollingDisc`
(a contact position row and two no-slip velocity rows) and
:class:`GearPair` (one position row). A user's element subclasses
:class:`ConstraintElement` (docs/plugins.md).
"""

from .base import ConstraintElement, velocity_rows
from .gear_pair import GearPair
from .knife_edge import KnifeEdge
from .rolling_disc import RollingDisc

__all__ = ["ConstraintElement", "velocity_rows", "GearPair", "KnifeEdge", "RollingDisc"]
