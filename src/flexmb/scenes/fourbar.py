"""Benchmark B5: a planar four-bar falling under gravity."""

from __future__ import annotations

import numpy as np

from ..bodies import RigidBody
from ..forces import Gravity
from ..joints import PlanarRevolute, Revolute
from ..model import Model

__all__ = ["fourbar"]


def fourbar(spatial: bool = False):
    """The B5 four-bar of BENCHMARKS.md.

    Ground pivots (0, 0) and (0.3, 0); crank 0.1 m, coupler 0.3 m, rocker
    0.25 m; uniform slender bars of 1 kg/m; gravity 9.81 m/s^2 along -y; the
    crank starts at rest at 45 deg with the coupler above the ground line.

    Parameters
    ----------
    spatial : bool
        Close the loop with a spatial revolute (5 rows, 3 redundant) instead
        of a planar one (2 rows).

    Returns
    -------
    model : Model
        The four-bar.
    initial : dict
        Starting guesses for the coordinates.
    fixed : list of str
        Coordinates held during assembly (the crank angle).
    """
    model = Model("fourbar")
    crank = RigidBody.slender_bar("crank", 0.1, 0.1)
    coupler = RigidBody.slender_bar("coupler", 0.3, 0.3)
    rocker = RigidBody.slender_bar("rocker", 0.25, 0.25)
    cut = Revolute if spatial else PlanarRevolute
    model.add(
        Revolute("A", model.ground, crank),
        Revolute("B", crank, coupler, parent_point=(0.1, 0, 0)),
        Revolute("D", model.ground, rocker, parent_point=(0.3, 0, 0)),
        cut("C", coupler, rocker, parent_point=(0.3, 0, 0), child_point=(0.25, 0, 0)),
        Gravity((0.0, -9.81, 0.0)),
    )
    return model, {"A": np.pi / 4, "B": -0.15, "D": 1.5}, ["A"]
