"""Bodies: the ground, rigid bodies, and markers (points and frames on bodies).

A body carries its mass data in its own body frame. Where that frame sits in
space is decided by the joints: in the reference configuration (all joint
coordinates zero) each joint's child frame coincides with its parent frame.
"""

from __future__ import annotations

import numpy as np
from attrs import converters, field, frozen, validators

from ._validate import flag, in_range, name_check, positive_value
from .errors import ModelError
from .fields import as_array, as_count, as_float, label, matrix33, positive, vector3

__all__ = ["Body", "Ground", "RigidBody", "Marker"]


@frozen(eq=False)
class Body:
    """Base class of everything joints and forces attach to.

    Subclasses must:

    1. give a ``name``;
    2. provide ``mass`` (kg), ``inertia`` (central inertia tensor in the body
       frame, kg m^2, shape (3, 3)) and ``com`` (mass centre in the body
       frame, m, shape (3,)).

    Parameters
    ----------
    name : str
        Unique name.
    """

    name: str = field(validator=name_check)

    def marker(self, position=(0.0, 0.0, 0.0), frame=None) -> "Marker":
        """Return a marker fixed on this body.

        Parameters
        ----------
        position : array_like, shape (3,)
            Position in the body frame, m.
        frame : array_like, shape (3, 3), optional
            Orientation in the body frame (columns: marker axes).

        Returns
        -------
        Marker
            The marker.
        """
        return Marker(self, position, np.eye(3) if frame is None else frame)


@frozen(eq=False)
class Ground(Body):
    """The inertial frame. Every model has exactly one, ``model.ground``.

    Parameters
    ----------
    name : str
        Name (default ``"ground"``).
    mass : float
        Mass, kg; 0 (the ground does not move, its mass never enters).
    inertia : ndarray, shape (3, 3)
        Inertia tensor, kg m^2; zeros.
    com : ndarray, shape (3,)
        Mass centre in the ground frame, m; the origin.
    """

    name: str = field(default="ground", validator=name_check)
    mass: float = 0.0
    inertia: np.ndarray = field(factory=lambda: as_array(np.zeros((3, 3))))
    com: np.ndarray = field(factory=lambda: as_array(np.zeros(3)))


def _check_inertia(instance, attribute, value):
    matrix33(instance, attribute, value)
    scale = max(np.abs(value).max(), np.finfo(float).tiny)
    if not np.allclose(value, value.T, rtol=0, atol=1e-12 * scale):
        raise ModelError(f"{label(instance)}: inertia must be symmetric, got {value.tolist()}")
    ev = np.linalg.eigvalsh(value)
    if ev[0] < -1e-12 * scale:
        raise ModelError(
            f"{label(instance)}: inertia must be positive (semi-)definite, "
            f"principal moments {ev.tolist()}"
        )
    if ev[2] > ev[0] + ev[1] + 1e-9 * scale:
        raise ModelError(
            f"{label(instance)}: inertia breaks the triangle inequality "
            f"(largest principal moment {ev[2]:.6g} > sum of the others {ev[0] + ev[1]:.6g}); "
            "no mass distribution has it"
        )


def _given(instance, attribute, value):
    """Mass and inertia have no defaults: a body without them is refused (it took 1 kg and unit inertia)."""
    missing = [a for a in ("mass", "inertia") if getattr(instance, a) is None]
    if missing:
        raise ModelError(
            f"{label(instance)}: give its {' and '.join(missing)} (mass in kg, central inertia in kg m^2: "
            "RigidBody(name, mass, inertia, com)), or build it from its dimensions with RigidBody.slender_bar, "
            ".bar or .box")


def _as_inertia(value):
    return as_array(np.diag(value) if np.ndim(value) == 1 else value)


@frozen(eq=False)
class RigidBody(Body):
    """A rigid body.

    Parameters
    ----------
    name : str
        Unique name.
    mass : float
        Mass, kg (> 0). Required: there is no default mass.
    inertia : array_like, shape (3, 3) or (3,)
        Central inertia tensor in the body frame, kg m^2; a 3-vector is taken
        as the diagonal. Symmetric, positive semi-definite, and obeying the
        triangle inequality. Required (``(0, 0, 0)`` for a point mass);
        :meth:`slender_bar`, :meth:`bar` and :meth:`box` compute it from the
        dimensions.
    com : array_like, shape (3,)
        Mass-centre location in the body frame, m.

    Examples
    --------
    >>> import flexmb as fm
    >>> bar = fm.RigidBody.slender_bar("bar", mass=0.3, length=0.3)
    >>> float(bar.inertia[2, 2])
    0.00225
    """

    # None: not given, refused (after the checks of what was given) naming the body, not with attrs' TypeError
    mass: float = field(default=None, converter=converters.optional(as_float), validator=validators.optional(positive))
    inertia: np.ndarray = field(default=None, converter=converters.optional(_as_inertia),
                                validator=validators.optional(_check_inertia))
    com: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=[vector3, _given])

    @classmethod
    def slender_bar(cls, name: str, mass: float, length: float, axis: int = 0, centred: bool = False):
        """A uniform slender bar along a body axis.

        Parameters
        ----------
        name : str
            Body name.
        mass : float
            Mass, kg.
        length : float
            Length, m (finite, > 0).
        axis : {0, 1, 2}
            Body axis along the bar.
        centred : bool
            If True the body frame sits at the mass centre, else at one end
            (the bar runs from 0 to ``length`` along ``axis``).

        Returns
        -------
        RigidBody
            Central inertia ``m l^2 / 12`` about the two transverse axes.

        Raises
        ------
        ModelError
            If the length is not a finite number > 0 (or so large that the
            inertia overflows), the axis is not 0, 1 or 2, or ``centred`` is
            not True or False.
        """
        where = f"RigidBody.slender_bar {name!r}"
        length = positive_value(where, "length", length)
        index = as_count(axis) if not isinstance(axis, (bool, np.bool_)) else axis
        if not isinstance(index, int) or isinstance(index, bool) or index not in (0, 1, 2):
            raise ModelError(f"{where}: axis must be 0, 1 or 2, got {axis!r}")
        centred = flag(where, "centred", centred)
        mass = as_float(mass)  # anything else: the mass validator names it
        moment = (mass if isinstance(mass, float) else 0.0) * length * length / 12.0
        in_range(where, {"transverse inertia m l^2 / 12": moment}, f" (length = {length!r} m)")
        moments = np.full(3, moment)
        moments[index] = 0.0
        com = np.zeros(3)
        if not centred:
            com[index] = length / 2
        return cls(name, mass, moments, com)

    @classmethod
    def bar(cls, name: str, mass: float, vector):
        """A uniform slender bar from the body origin to ``vector``, along any direction.

        Parameters
        ----------
        name : str
            Body name.
        mass : float
            Mass, kg.
        vector : array_like, shape (3,)
            The bar's far end in the body frame, m.

        Returns
        -------
        RigidBody
            Mass centre at ``vector / 2``, central inertia
            ``m L^2 / 12 (I - e e^T)`` with ``L = |vector|``, ``e = vector / L``.

        Raises
        ------
        ModelError
            If ``vector`` does not have 3 components or has length zero.

        See Also
        --------
        slender_bar : A bar along a body axis.

        Examples
        --------
        >>> import flexmb as fm
        >>> fm.RigidBody.bar("link", 2.0, (0.0, 0.3, 0.4)).com
        array([0.  , 0.15, 0.2 ])
        """
        try:
            if isinstance(vector, (str, bytes)) or np.iscomplexobj(vector):
                raise TypeError
            v = np.asarray(vector, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise ModelError(f"RigidBody.bar {name!r}: vector must be 3 numbers, got {vector!r:.60}") from None
        if v.shape != (3,):
            raise ModelError(f"vector must have 3 components, got {v.size}")
        L = np.linalg.norm(v)
        if not L > 0:
            raise ModelError("vector must not be a zero-length vector")
        e = v / L
        return cls(name, mass, mass * L * L / 12.0 * (np.eye(3) - np.outer(e, e)), v / 2)

    @classmethod
    def box(cls, name: str, mass: float, size, com=(0.0, 0.0, 0.0)):
        """A uniform solid block.

        Parameters
        ----------
        name : str
            Body name.
        mass : float
            Mass, kg.
        size : array_like, shape (3,)
            Edge lengths along the body axes, m (finite, > 0).
        com : array_like, shape (3,)
            Mass-centre location in the body frame, m.

        Returns
        -------
        RigidBody
            Central inertia ``m (b^2 + c^2) / 12`` etc.

        Raises
        ------
        ModelError
            If ``size`` is not three finite edge lengths > 0.
        """
        where = f"RigidBody.box {name!r}"
        try:
            edges = np.array(size, dtype=float)
        except (TypeError, ValueError, OverflowError):
            edges = None
        if edges is None or edges.shape != (3,) or not np.all(np.isfinite(edges)) or not np.all(edges > 0):
            raise ModelError(f"{where}: size must be 3 finite edge lengths > 0, got {size!r}")
        a, b, c = edges
        mass = as_float(mass)
        moments = (mass if isinstance(mass, float) else 0.0) / 12.0 * np.array([b * b + c * c, a * a + c * c,
                                                                                  a * a + b * b])
        return cls(name, mass, moments, com)


@frozen(eq=False)
class Marker:
    """A point and frame fixed on a body.

    Parameters
    ----------
    body : Body
        The body it is fixed on.
    position : array_like, shape (3,)
        Position in the body frame, m.
    frame : array_like, shape (3, 3)
        Orientation in the body frame (columns: the marker's axes).
    """

    body: Body
    position: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    frame: np.ndarray = field(factory=lambda: np.eye(3), converter=as_array, validator=matrix33)

    @property
    def name(self) -> str:
        """Name for messages."""
        return f"{self.body.name}@{self.position.tolist()}"
