"""A run's watch on Bryant angles near gimbal lock: one warning, naming the joint and the remedy.

A :class:`~flexmb.Spherical` or :class:`~flexmb.Free` joint in Bryant angles
(``rotation='bryant'``, the default) is singular where its middle angle ry
reaches +-90 deg: the angles' rates grow without bound near there, and an
integrator's steps shrink until the run seems to stall. Nothing fails, so
without a word a user would only see a run that does not end.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from .errors import GimbalLockWarning

__all__ = ["GimbalWatch", "GIMBAL_MARGIN_DEG"]

#: a joint whose ry comes within this many degrees of +-90 deg is named, once per run
GIMBAL_MARGIN_DEG = 1.0


class GimbalWatch:
    """The middle Bryant angles of a system's spherical and free joints, checked after each step.

    Parameters
    ----------
    names : list of str
        The joints' names.
    index : ndarray of int
        Each joint's ry in the state.
    """

    def __init__(self, names, index):
        self.names, self.index = names, np.asarray(index, dtype=np.intp)
        self.small = [int(i) for i in self.index]
        self.limit = np.sin(np.radians(GIMBAL_MARGIN_DEG))
        self.warned = False

    @classmethod
    def of(cls, system):
        """The watch of ``system``'s tree joints in Bryant angles, or None if it has none.

        Parameters
        ----------
        system : System
            The system.

        Returns
        -------
        GimbalWatch or None
            The watch.
        """
        names, index = [], []
        for joint in system.topology.tree_joints:
            if getattr(joint, "rotation", None) == "bryant" and "ry" in joint.coordinate_names:
                names.append(joint.name)
                index.append(system.coordinate_indices(joint)[joint.coordinate_names.index("ry")])
        return cls(names, index) if names else None

    def check(self, t, y) -> None:
        """Warn (once) if a joint's ry is within ``GIMBAL_MARGIN_DEG`` of +-90 deg.

        Parameters
        ----------
        t : float
            Time, s.
        y : ndarray
            The integrator's state (angles may be offset by whole turns).
        """
        if self.warned:
            return
        if len(self.index) <= 8:  # a few joints (the common case): cheaper than numpy's calls, after every step
            if all(abs(math.cos(y[i])) >= self.limit for i in self.small):
                return
        c = np.abs(np.cos(y[self.index]))
        k = int(np.argmin(c))
        if c[k] < self.limit:
            self.warned = True
            ry = np.degrees(np.arctan2(np.sin(y[self.index[k]]), np.cos(y[self.index[k]])))
            warnings.warn(f"at t = {t:.6g} s joint {self.names[k]!r} is {np.degrees(np.arcsin(c[k])):.2g} deg from "
                          f"gimbal lock (ry = {ry:.4g} deg): its Bryant angles' rates grow without bound there and "
                          "the steps shrink; describe its rotation by Euler parameters (rotation='quaternion')",
                          GimbalLockWarning, stacklevel=2)
