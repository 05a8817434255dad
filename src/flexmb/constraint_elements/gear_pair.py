"""A gear pair or a rack and pinion: two joint coordinates in a fixed ratio (one position row)."""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from .._names import reference
from ..errors import ModelError
from ..fields import as_float, finite_number, label
from ..joints import Joint
from ..constraints import ConstraintRows
from .base import ConstraintElement

__all__ = ["GearPair"]


def _index(instance, attribute, value):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ModelError(f"{label(instance)}: {attribute.name} must be a coordinate index >= 0, got {value!r}")


@frozen(eq=False)
class GearPair(ConstraintElement):
    """``q1 = ratio q2 + offset``: a gear pair (two revolutes), a rack and pinion (a prismatic and a revolute).

    The relation is kept at position level (one row ``phi = q1 - ratio q2
    - offset``, closed by the assembly and the projections), so the angles
    do not drift apart over a long run as a speed relation alone would let
    them.

    Parameters
    ----------
    name : str
        Unique name.
    joint1, joint2 : Joint or str
        The two tree joints.
    ratio : float
        ``dq1/dq2``: ``-r2 / r1`` for external spur gears of pitch radii r1
        and r2 (they turn opposite ways), ``+r2 / r1`` for an internal gear;
        the pinion's pitch radius (m/rad) for a rack (joint1 the rack's
        prismatic, joint2 the pinion's revolute).
    offset : float
        ``q1 - ratio q2`` held (rad or m).
    coordinate1, coordinate2 : int
        Which coordinate of each joint (default the first).
    """

    joint1: Joint = reference(Joint)
    joint2: Joint = reference(Joint)
    ratio: float = field(default=-1.0, converter=as_float, validator=finite_number)
    offset: float = field(default=0.0, converter=as_float, validator=finite_number)
    coordinate1: int = field(default=0, validator=_index)
    coordinate2: int = field(default=0, validator=_index)

    n_position = 1

    def row_names(self) -> list[str]:
        """Names of the rows.

        Returns
        -------
        list of str
            ``['ratio']``.
        """
        return ["ratio"]

    def check(self, model) -> list[str]:
        """List the problems with this element in ``model``: coordinates beyond the joints', a zero ratio.

        Parameters
        ----------
        model : Model
            The model the element belongs to.

        Returns
        -------
        list of str
            One message per problem, naming the element.
        """
        out = []
        for j, c, which in ((self.joint1, self.coordinate1, "coordinate1"), (self.joint2, self.coordinate2,
                                                                                "coordinate2")):
            if isinstance(j, Joint) and c >= j.n_coords:
                out.append(f"constraint element {self.name!r}: {which} = {c}, but joint {j.name!r} has "
                           f"{j.n_coords} coordinate(s)")
        if self.ratio == 0.0:
            out.append(f"constraint element {self.name!r}: ratio must be nonzero (it would fix {self.joint1!r})")
        return out

    def rows(self, state):
        """The rows at a state (see :meth:`ConstraintElement.rows`).

        Parameters
        ----------
        state : Kinematics
            The current kinematic state.

        Returns
        -------
        ConstraintRows
            ``phi``, ``psi``, ``b`` and ``gamma``.
        """
        i = state.coordinate_slice(self.joint1).start + self.coordinate1
        j = state.coordinate_slice(self.joint2).start + self.coordinate2
        if i == j:
            raise ModelError(f"constraint element {self.name!r}: joint1 and joint2 name the same coordinate")
        psi = np.zeros((1, state.xd.shape[0]))
        psi[0, i], psi[0, j] = 1.0, -self.ratio
        phi = state.x[i] - self.ratio * state.x[j] - self.offset  # a revolute's or slider's speed: its rate
        return ConstraintRows(np.array([phi]), psi, np.zeros(1), np.zeros(1))
