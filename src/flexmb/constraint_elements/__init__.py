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
from .._lazy import lazy_names as _lazy_names

# the built-in elements are imported where one is first named (a model without them never imports them)
_LAZY = {
    "Distance": ".distance",
    "GearPair": ".gear_pair",
    "KnifeEdge": ".knife_edge",
    **dict.fromkeys(("CurveConstraint", "PointOnCircle", "PointOnCurve", "PointOnLine"), ".point_on_curve"),
    "RollingDisc": ".rolling_disc",
}

__getattr__, __dir__ = _lazy_names(globals(), _LAZY)

__all__ = ["ConstraintElement", "velocity_rows", "CurveConstraint", "Distance", "GearPair", "KnifeEdge", "PointOnCircle",
           "PointOnCurve", "PointOnLine", "RollingDisc"]
