"""The named results of post-processing: section fields, their envelopes, joint loads.

Sign convention (:mod:`flexmb.post`): a load is the one the outboard side
(the child, with everything it carries) exerts on the inboard side (the
parent) at the joint point.
"""

from __future__ import annotations

import numpy as np
from attrs import frozen

from .._names import name_of
from ..errors import FlexmbError
from ..joints import Joint

__all__ = ["SectionField", "Envelope", "JointLoads", "LOAD_COMPONENTS", "STRAIN_COMPONENTS", "STRESS_COMPONENTS"]

#: section-load component -> (kept elastic coordinate, unit)
LOAD_COMPONENTS = {"N": ("axial", "N"), "Vy": ("shear_y", "N"), "Vz": ("shear_z", "N"),
                   "Mx": ("torsion", "N m"), "My": ("bend_y", "N m"), "Mz": ("bend_z", "N m")}
_COORD_COMPONENT = {coord: comp for comp, (coord, _) in LOAD_COMPONENTS.items()}

#: strain component -> (kept elastic coordinate, unit)
STRAIN_COMPONENTS = {"strain_axial": ("axial", "1"), "twist": ("torsion", "rad/m"),
                     "kappa_y": ("bend_y", "1/m"), "kappa_z": ("bend_z", "1/m")}

#: stress components, all in Pa
STRESS_COMPONENTS = ("sigma_axial", "sigma_bend_y", "sigma_bend_z", "tau_torsion", "sigma_max", "von_mises")


@frozen(eq=False)
class Envelope:
    """Largest absolute value over time, per station and component.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    peak : ndarray, shape (n_stations, n_components)
        ``max_t |value|``.
    value : ndarray, shape (n_stations, n_components)
        The signed value at that time.
    time : ndarray, shape (n_stations, n_components)
        When it occurs (the first output time if several), s.
    index : ndarray of int, shape (n_stations, n_components)
        Output index of that time.
    stations : ndarray, shape (n_stations,)
        Station positions along the body, m.
    components : tuple of str
        Component names.
    """

    peak: np.ndarray
    value: np.ndarray
    time: np.ndarray
    index: np.ndarray
    stations: np.ndarray
    components: tuple

    def component(self, name: str) -> np.ndarray:
        """Peak of one component along the body.

        Parameters
        ----------
        name : str
            Component name.

        Returns
        -------
        ndarray, shape (n_stations,)
            ``max_t |value|`` at each station.
        """
        return self.peak[:, _component_index(self.components, name)]


def _component_index(components, name) -> int:
    try:
        return list(components).index(name)
    except ValueError:
        raise FlexmbError(f"no component {name!r}; components are {list(components)}") from None


@frozen(eq=False)
class SectionField:
    """A quantity along a flexible body over time: loads, strains or stresses.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    body : str
        Name of the flexible body.
    t : ndarray, shape (nt,)
        Output times, s.
    stations : ndarray, shape (n_stations,)
        Positions of the segment joints along the undeformed body (body
        frame x), m.
    components : tuple of str
        Component names (see :data:`LOAD_COMPONENTS`, :data:`STRAIN_COMPONENTS`,
        :data:`STRESS_COMPONENTS`).
    units : tuple of str
        Unit of each component.
    values : ndarray, shape (nt, n_stations, n_components)
        The values.
    """

    body: str
    t: np.ndarray
    stations: np.ndarray
    components: tuple
    units: tuple
    values: np.ndarray

    def component(self, name: str) -> np.ndarray:
        """History of one component at every station, shape (nt, n_stations).

        Parameters
        ----------
        name : str
            Component name.

        Returns
        -------
        ndarray, shape (nt, n_stations)
            Its values.

        Raises
        ------
        FlexmbError
            If there is no such component.
        """
        return self.values[:, :, _component_index(self.components, name)]

    def at(self, t) -> np.ndarray:
        """Values at given times, linearly interpolated between output times.

        Parameters
        ----------
        t : float or array_like, shape (m,)
            Times within ``[t[0], t[-1]]``, s.

        Returns
        -------
        ndarray, shape (n_stations, n_components) or (m, n_stations, n_components)
            The values (exact at the output times).

        Raises
        ------
        FlexmbError
            If a time is outside the result.
        """
        tq = np.asarray(t, dtype=float)
        _check_times(self.t, tq)
        if len(self.t) == 1:
            return np.broadcast_to(self.values[0], tq.shape + self.values.shape[1:]).copy()
        i = np.clip(np.searchsorted(self.t, tq, side="right") - 1, 0, len(self.t) - 2)
        w = ((tq - self.t[i]) / (self.t[i + 1] - self.t[i]))[..., None, None]
        return (1.0 - w) * self.values[i] + w * self.values[i + 1]

    def envelope(self) -> Envelope:
        """Largest absolute value over time at each station, and when it occurs.

        Returns
        -------
        Envelope
            Peaks, signed values, times and output indices, per station and
            component.
        """
        i = np.argmax(np.abs(self.values), axis=0)
        value = np.take_along_axis(self.values, i[None], axis=0)[0]
        return Envelope(np.abs(value), value, self.t[i], i, self.stations, self.components)


@frozen(eq=False)
class JointLoads:
    """Force and moment transmitted by every joint over time.

    Each parameter is kept as the attribute of the same name.

    Parameters
    ----------
    t : ndarray, shape (nt,)
        Output times, s.
    names : list of str
        Joint names: the tree joints (user joints and segment joints
        ``"<body>.j<i>"``) in body order, then the cut joints.
    force : ndarray, shape (nt, n_joints, 3)
        Force the child side exerts on the parent side, N, in the joint's
        child marker frame (``R_child @ child_frame``; for a segment joint,
        the outboard segment's frame).
    moment : ndarray, shape (nt, n_joints, 3)
        Moment the child side exerts on the parent side about the joint
        point (the child's joint point), N m, same frame.
    """

    t: np.ndarray
    names: list
    force: np.ndarray
    moment: np.ndarray

    def joint(self, name) -> tuple[np.ndarray, np.ndarray]:
        """Force and moment histories of one joint, each shape (nt, 3).

        Parameters
        ----------
        name : str or Joint
            The joint or its name.

        Returns
        -------
        force, moment : ndarray, shape (nt, 3)
            N and N m, in the joint's child marker frame.

        Raises
        ------
        FlexmbError
            If there is no such joint.
        """
        name = name_of(name, Joint, "JointLoads.joint")
        try:
            i = self.names.index(name)
        except ValueError:
            raise FlexmbError(f"no joint {name!r}; joints are {self.names}") from None
        return self.force[:, i], self.moment[:, i]


def _check_times(t, tq):
    if tq.size and (np.any(~np.isfinite(tq)) or tq.min() < t[0] or tq.max() > t[-1]):
        bad = tq[(tq < t[0]) | (tq > t[-1]) | ~np.isfinite(tq)].ravel()
        raise FlexmbError(f"time {float(bad[0])!r} s is outside the result, which covers [{t[0]:.9g}, {t[-1]:.9g}] s")
