"""Friction force elements for flexmb, shipped as a plugin.

Friction at a body point sliding on a plane: the velocity-weakening tip
friction of the windshield wiper (Fig. 4 of Amirouche & Huston 1988),
regularised Coulomb friction and viscous friction. flexmb finds them
through the ``flexmb.forces`` entry-point group, as it would a third
party's plugin.
"""

from .friction import (
    DEFAULT_SMOOTHING_SPEED,
    CoulombFriction,
    SlidingFriction,
    VelocityWeakeningFriction,
    ViscousFriction,
)

__all__ = ["SlidingFriction", "VelocityWeakeningFriction", "CoulombFriction", "ViscousFriction",
           "DEFAULT_SMOOTHING_SPEED"]
