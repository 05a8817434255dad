"""Constraint elements: rows a model adds beside its cut joints and drivers (plugin group ``flexmb.constraints``).

Built-ins: :class:`KnifeEdge` (one velocity row), :class:`RollingDisc`
(a contact position row and two no-slip velocity rows), :class:`GearPair`
and :class:`Distance` (one position row each), and a body point on a curve
fixed in another body, :class:`PointOnLine`, :class:`PointOnCircle` or a
user's :class:`PointOnCurve` (two position rows; :class:`CurveConstraint`
is their base). A user's element subclasses
:class:`ConstraintElement` (docs/plugins.md).
"""

from .base import ConstraintElement, velocity_rows
from .distance import Distance
from .gear_pair import GearPair
from .knife_edge import KnifeEdge
from .point_on_curve import CurveConstraint, PointOnCircle, PointOnCurve, PointOnLine
from .rolling_disc import RollingDisc

__all__ = ["ConstraintElement", "velocity_rows", "CurveConstraint", "Distance", "GearPair", "KnifeEdge", "PointOnCircle",
           "PointOnCurve", "PointOnLine", "RollingDisc"]
