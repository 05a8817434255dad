"""Joints: how a child body moves relative to its parent.

A joint joins a marker on the parent body (``parent_point``, ``parent_frame``)
to a marker on the child body (``child_point``, ``child_frame``). With all its
coordinates zero the two markers coincide. A joint contributes exactly the
coordinates of its own freedoms: first translations along fixed axes of the
parent marker frame, then successive rotations about moving axes.

A joint in the spanning tree supplies coordinates; a joint that closes a
loop (a *cut joint*) supplies constraint equations instead (eq. 28), built
from three primitives declared as class data:

* ``cut_point``: the two marker points coincide (3 rows);
* ``cut_directions``: the child point stays on the plane/line of the parent
  marker axes not listed (one row per listed parent axis);
* ``cut_perpendicular``: pairs ``(i, j)`` with parent axis i perpendicular to
  child axis j (one row each).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from attrs import converters, field, frozen, validators

from ._names import reference
from ._validate import name_check
from .bodies import Body
from .errors import ModelError
from .fields import as_array, as_bool, boolean, label, rotation_matrix, vector3
from .kernels import QUATERNION, ROTATION, TRANSLATION
from .kernels.tree import joint_motions
from .rotations import frame_from_axis

__all__ = [
    "Joint",
    "Revolute",
    "PlanarRevolute",
    "Prismatic",
    "Cylindrical",
    "Universal",
    "Spherical",
    "Fixed",
    "Free",
    "SphericalQuaternion",
    "FreeQuaternion",
    "ROTATIONS",
]


def _axis(instance, attribute, value):
    vector3(instance, attribute, value)
    if np.linalg.norm(value) < 1e-12:
        raise ModelError(f"{label(instance)}: {attribute.name} must not be a zero-length vector")


@frozen(eq=False)
class Joint:
    """Base class of joints.

    Subclasses must:

    1. set the class data ``translation_axes`` and ``rotation_axes`` (indices
       of parent-marker axes: translations along fixed axes come first in the
       joint's coordinates, then rotations about successive moving axes),
       and ``coordinate_names``;
    2. set ``cut_point``, ``cut_directions`` and ``cut_perpendicular`` to say
       which constraints the joint imposes when it closes a loop;
    3. for coordinates that are not the integrals of the speeds, list each
       set of Euler parameters in ``quaternions``: the positions of
       ``(qx, qy, qz, qw)`` among the joint's coordinates and of the
       angular speeds ``(wx, wy, wz)`` (in the child marker's axes) among
       its speeds (:class:`SphericalQuaternion`; ``n_coords``,
       ``n_speeds`` and ``speed_names`` follow); the joint's first
       ``n_speeds`` coordinates share their speeds' places in the state
       (:mod:`flexmb.state_layout`). The generic (compiled) motion takes
       one set, as the joint's last freedoms (``qx, qy, qz`` after the
       translations and rotations, ``qw`` the last coordinate); a class
       with other sets overrides ``motion()``, which takes them apart;
    4. optionally override ``_default_frame()`` (the parent marker
       orientation when ``parent_frame`` is not given) or ``motion()`` for a
       motion that is not a translation/rotation sequence.

    Parameters
    ----------
    name : str
        Unique name.
    parent, child : Body or str
        The bodies joined, or their names (resolved when the model is
        built); the tree is grown from the ground along parent -> child.
    parent_point : array_like, shape (3,)
        Joint point in the parent body frame, m.
    child_point : array_like, shape (3,)
        Joint point in the child body frame, m.
    parent_frame : array_like, shape (3, 3), optional
        Joint frame orientation in the parent body frame (columns = axes).
    child_frame : array_like, shape (3, 3), optional
        Joint frame orientation in the child body frame; defaults to
        ``parent_frame`` (right when both body frames are parallel in the
        reference configuration).
    cut : bool
        Force this joint to be a cut joint (closing a loop).

    Examples
    --------
    A joint is mostly data. A slide along the joint frame's x, pushed by
    4 N, moves a 2 kg block at ``F / m = 2`` m/s^2:

    >>> import numpy as np
    >>> import flexmb as fm
    >>> class SlideX(fm.Joint):
    ...     # a translation along the joint frame's x (coordinate: x, m)
    ...     translation_axes = (0,)
    ...     coordinate_names = ("x",)
    >>> model = fm.Model()
    >>> block = fm.RigidBody.box("block", 2.0, (0.1, 0.1, 0.1))
    >>> rail = SlideX("rail", model.ground, block)
    >>> system = model.add(rail, fm.PointForce("push", block, (4.0, 0.0, 0.0))).build()
    >>> system.coordinate_names
    ['rail.x']
    >>> system.accelerations(0.0, np.zeros(1), np.zeros(1))
    array([2.])
    """

    translation_axes: ClassVar[tuple[int, ...]] = ()
    rotation_axes: ClassVar[tuple[int, ...]] = ()
    coordinate_names: ClassVar[tuple[str, ...]] = ()
    cut_point: ClassVar[bool] = True
    cut_directions: ClassVar[tuple[int, ...]] = ()
    cut_perpendicular: ClassVar[tuple[tuple[int, int], ...]] = ()
    quaternions: ClassVar[tuple[tuple[tuple[int, int, int, int], tuple[int, int, int]], ...]] = ()

    name: str = field(validator=name_check)
    parent: Body = reference(Body)
    child: Body = reference(Body)
    parent_point: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    child_point: np.ndarray = field(default=(0.0, 0.0, 0.0), converter=as_array, validator=vector3)
    parent_frame: np.ndarray | None = field(
        default=None, converter=converters.optional(as_array), validator=validators.optional(rotation_matrix))
    child_frame: np.ndarray | None = field(
        default=None, converter=converters.optional(as_array), validator=validators.optional(rotation_matrix))
    cut: bool = field(default=False, converter=as_bool, validator=boolean)

    def __attrs_post_init__(self):
        if self.parent is self.child or (isinstance(self.parent, str) and self.parent == self.child):
            name = getattr(self.parent, "name", self.parent)
            raise ModelError(f"{label(self)}: parent and child are the same body {name!r}")

    @property
    def n_coords(self) -> int:
        """Number of coordinates the joint contributes (four per set of Euler parameters)."""
        return len(self.translation_axes) + len(self.rotation_axes) + 4 * len(self.quaternions)

    @property
    def n_speeds(self) -> int:
        """Number of generalized speeds the joint contributes (:mod:`flexmb.state_layout`).

        One per coordinate (its rate), three per set of Euler parameters
        (the angular velocity).
        """
        return self.n_coords - len(self.quaternions)

    @property
    def speed_names(self) -> tuple[str, ...]:
        """Names of the joint's speeds: its coordinates' names, ``wx, wy, wz`` for a set of Euler parameters."""
        names = list(self.coordinate_names[: self.n_speeds])
        for _, speeds in self.quaternions:
            for p, axis in zip(speeds, "xyz"):
                names[p] = "w" + axis
        return tuple(names)

    def _default_frame(self) -> np.ndarray:
        return np.eye(3)

    def frames(self) -> tuple[np.ndarray, np.ndarray]:
        """Return the joint frame in the parent and in the child body frame.

        Returns
        -------
        parent_frame, child_frame : ndarray, shape (3, 3)
            Orientation matrices (columns = joint axes).
        """
        fp = self.parent_frame if self.parent_frame is not None else self._default_frame()
        fc = self.child_frame if self.child_frame is not None else fp
        return np.asarray(fp), np.asarray(fc)

    @classmethod
    def motion(cls, q: np.ndarray, qd: np.ndarray):
        """Relative motion of the child marker in the parent marker frame.

        Parameters
        ----------
        q : ndarray, shape (m, n_coords)
            Coordinates of m joints of this class.
        qd : ndarray, shape (m, n_speeds)
            Their speeds (the coordinates' rates, unless the class lists
            ``quaternions``).

        Returns
        -------
        R : ndarray, shape (m, 3, 3)
            Rotation of the child marker frame.
        d : ndarray, shape (m, 3)
            Position of the child marker point.
        Hw, Hv : ndarray, shape (m, 3, n_speeds)
            Partial angular velocities and partial velocities of the child
            marker (at its point), in the parent marker frame.
        aw, av : ndarray, shape (m, 3)
            Velocity-dependent angular and linear acceleration terms
            (``Hdot @ qd``), in the parent marker frame.
        """
        # the compiled generic motion (flexmb.kernels.tree.joint_motions), for m joints laid out
        # one after the other: their speeds' coordinates, then their qw
        q = np.asarray(q, dtype=float)
        m = q.shape[0]
        kind, axes = cls.generic_motion()
        ns = len(kind)
        axes = np.tile(np.array(axes, dtype=np.int64), m)
        extra = q.shape[1] - ns
        if extra:  # a set of Euler parameters: coord_axis holds the index of each joint's qw
            axes[np.tile(np.array(kind) == QUATERNION, m)] = np.repeat(m * ns + np.arange(m), 3)
        x = np.concatenate([q[:, :ns].ravel(), q[:, ns:].ravel()])
        R, d, aw, av = np.empty((m, 3, 3)), np.empty((m, 3)), np.empty((m, 3)), np.empty((m, 3))
        hw, hv = np.empty((m * ns, 3)), np.empty((m * ns, 3))
        joint_motions(x, np.ascontiguousarray(np.reshape(qd, m * ns), dtype=float),
                      np.arange(0, m * ns + 1, max(ns, 1), dtype=np.int64)[: m + 1]
                      if ns else np.zeros(m + 1, dtype=np.int64), np.tile(np.array(kind, dtype=np.int64), m),
                      axes, np.zeros(m, dtype=np.bool_), R, d, hw, hv, aw, av)
        Hw = hw.reshape(m, ns, 3).transpose(0, 2, 1)
        Hv = hv.reshape(m, ns, 3).transpose(0, 2, 1)
        return R, d, Hw, Hv, aw, av

    @classmethod
    def generic_motion(cls) -> tuple[list[int], list[int]]:
        """The kind and axis of each speed of the generic motion (:func:`flexmb.kernels.tree.joint_motions`).

        Translations, rotations, then at most one set of Euler parameters
        (kind :data:`flexmb.kernels.QUATERNION`, its axis the position of
        ``qw`` among the joint's coordinates).

        Returns
        -------
        kind, axis : list of int
            One entry per speed.

        Raises
        ------
        ModelError
            If the class lists Euler parameters the generic motion cannot
            take (more than one set, or not its last freedoms) and does not
            override ``motion()``.
        """
        nt, nr = len(cls.translation_axes), len(cls.rotation_axes)
        kind = [TRANSLATION] * nt + [ROTATION] * nr
        axis = list(cls.translation_axes) + list(cls.rotation_axes)
        if not cls.quaternions:
            return kind, axis
        p = nt + nr
        if tuple(map(tuple, cls.quaternions)) != (((p, p + 1, p + 2, p + 3), (p, p + 1, p + 2)),):
            raise ModelError(
                f"joint class {cls.__name__}: the generic motion takes one set of Euler parameters as the joint's last "
                f"freedoms (quaternions = ((({p}, {p + 1}, {p + 2}, {p + 3}), ({p}, {p + 1}, {p + 2})),)), got "
                f"{cls.quaternions!r}; override motion() for another layout")
        return kind + [QUATERNION] * 3, axis + [p + 3] * 3


@frozen(eq=False)
class _AxisJoint(Joint):
    axis: np.ndarray = field(default=(0.0, 0.0, 1.0), converter=as_array, validator=_axis)

    def _default_frame(self) -> np.ndarray:
        return frame_from_axis(self.axis)


@frozen(eq=False)
class Revolute(_AxisJoint):
    """One rotation about ``axis`` (coordinate: angle, rad).

    Parameters
    ----------
    name, parent, child, parent_point, child_point, parent_frame, child_frame, cut
        As for :class:`Joint`: the unique name, the parent and child bodies,
        the joint point (m) and frame in each body frame, and whether the
        joint is forced to be a cut joint.
    axis : array_like, shape (3,)
        Rotation axis in the parent body frame (the joint frame's z).

    Examples
    --------
    >>> import flexmb as fm
    >>> m = fm.Model()
    >>> bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    >>> j = fm.Revolute("pin", m.ground, bar, axis=(0, 0, 1))
    >>> j.n_coords
    1
    """

    rotation_axes = (2,)
    coordinate_names = ("angle",)
    cut_perpendicular = ((2, 0), (2, 1))


@frozen(eq=False)
class PlanarRevolute(Revolute):
    """A revolute joint that, as a cut joint, imposes only the two in-plane rows.

    In the tree it is a :class:`Revolute`. Closing a planar loop it keeps
    the joint points together in the plane normal to ``axis`` (2 rows),
    where a spatial revolute writes 5 rows, 3 of them redundant.

    Parameters
    ----------
    name, parent, child, parent_point, child_point, parent_frame, child_frame, cut
        As for :class:`Joint`: the unique name, the parent and child bodies,
        the joint point (m) and frame in each body frame, and whether the
        joint is forced to be a cut joint.
    axis : array_like, shape (3,)
        Rotation axis in the parent body frame (the joint frame's z); the
        plane of the loop is normal to it.
    """

    cut_point = False
    cut_directions = (0, 1)
    cut_perpendicular = ()


@frozen(eq=False)
class Prismatic(_AxisJoint):
    """One translation along ``axis`` (coordinate: slide, m).

    Parameters
    ----------
    name, parent, child, parent_point, child_point, parent_frame, child_frame, cut
        As for :class:`Joint`: the unique name, the parent and child bodies,
        the joint point (m) and frame in each body frame, and whether the
        joint is forced to be a cut joint.
    axis : array_like, shape (3,)
        Slide direction in the parent body frame (the joint frame's z).

    Examples
    --------
    A block sliding down a vertical rail falls freely, at g:

    >>> import numpy as np
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> block = fm.RigidBody.box("block", 1.0, (0.1, 0.1, 0.1))
    >>> rail = fm.Prismatic("rail", model.ground, block, axis=(0, 0, 1))
    >>> system = model.add(rail, fm.Gravity((0.0, 0.0, -9.81))).build()
    >>> system.accelerations(0.0, np.zeros(1), np.zeros(1))
    array([-9.81])
    """

    translation_axes = (2,)
    coordinate_names = ("slide",)
    cut_point = False
    cut_directions = (0, 1)
    cut_perpendicular = ((0, 1), (1, 2), (2, 0))


@frozen(eq=False)
class Cylindrical(_AxisJoint):
    """Translation along and rotation about ``axis`` (coordinates: slide m, angle rad).

    Parameters
    ----------
    name, parent, child, parent_point, child_point, parent_frame, child_frame, cut
        As for :class:`Joint`: the unique name, the parent and child bodies,
        the joint point (m) and frame in each body frame, and whether the
        joint is forced to be a cut joint.
    axis : array_like, shape (3,)
        Slide direction and rotation axis in the parent body frame (the
        joint frame's z).
    """

    translation_axes = (2,)
    rotation_axes = (2,)
    coordinate_names = ("slide", "angle")
    cut_point = False
    cut_directions = (0, 1)
    cut_perpendicular = ((2, 0), (2, 1))


@frozen(eq=False)
class Universal(Joint):
    """Rotation about ``axis`` (fixed in the parent), then about ``axis2`` (fixed in the child).

    Parameters
    ----------
    name, parent, child, parent_point, child_point, parent_frame, child_frame, cut
        As for :class:`Joint`: the unique name, the parent and child bodies,
        the joint point (m) and frame in each body frame, and whether the
        joint is forced to be a cut joint.
    axis : array_like, shape (3,)
        First axis, in the parent body frame (joint frame x).
    axis2 : array_like, shape (3,)
        Second axis, in the child body frame, perpendicular to ``axis`` in
        the reference configuration (joint frame y).

    Examples
    --------
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> shaft = fm.RigidBody.slender_bar("shaft", 1.0, 0.5)
    >>> joint = fm.Universal("cardan", model.ground, shaft, axis=(1, 0, 0), axis2=(0, 1, 0))
    >>> joint.n_coords, joint.coordinate_names
    (2, ('angle1', 'angle2'))
    """

    rotation_axes = (0, 1)
    coordinate_names = ("angle1", "angle2")
    cut_perpendicular = ((0, 1),)

    axis: np.ndarray = field(default=(1.0, 0.0, 0.0), converter=as_array, validator=_axis)
    axis2: np.ndarray = field(default=(0.0, 1.0, 0.0), converter=as_array, validator=_axis)

    def __attrs_post_init__(self):
        super().__attrs_post_init__()
        c = abs(self.axis @ self.axis2) / np.linalg.norm(self.axis) / np.linalg.norm(self.axis2)
        if c > 1e-9:
            raise ModelError(f"{label(self)}: axis and axis2 must be perpendicular (cos = {c:.3g})")

    def _default_frame(self) -> np.ndarray:
        z = np.cross(self.axis, self.axis2)
        f = frame_from_axis(z, second=self.axis)
        return f


@frozen(eq=False)
class Fixed(Joint):
    """No relative motion (no coordinates); welds the child to the parent.

    Parameters
    ----------
    name, parent, child, parent_point, child_point, parent_frame, child_frame, cut
        As for :class:`Joint`: the unique name, the parent and child bodies,
        the joint point (m) and frame in each body frame, and whether the
        joint is forced to be a cut joint.
    """

    cut_perpendicular = ((0, 1), (1, 2), (2, 0))


def _rotation_kind(instance, attribute, value):
    if value not in ROTATIONS:
        raise ModelError(f"{label(instance)}: rotation must be one of {list(ROTATIONS)}, got {value!r}")
    if value == "quaternion" and not instance.quaternions:
        raise ModelError(f"{label(instance)}: rotation='quaternion' is not available for the subclass "
                         f"{type(instance).__name__} (Spherical and Free make their Euler-parameter variants)")


#: how a Spherical or Free joint's rotation is described: Bryant angles, or Euler parameters
ROTATIONS = ("bryant", "quaternion")


class _RotationChoice:
    """``rotation='quaternion'`` makes the Euler-parameter variant of the class (its ``_quaternion_class``)."""

    __slots__ = ()

    def __new__(cls, *args, rotation="bryant", **kwargs):
        if rotation == "quaternion" and cls._quaternion_class() is not None:
            cls = cls._quaternion_class()
        return object.__new__(cls)

    @classmethod
    def _quaternion_class(cls):
        return None


@frozen(eq=False)
class Spherical(_RotationChoice, Joint):
    """Three rotations about the joint frame axes: Bryant angles, or Euler parameters.

    ``rotation='bryant'`` (the default): the angles rx, ry, rz (rad) of
    ``Rx Ry Rz``, their rates the speeds; singular where ry reaches
    +-90 deg. ``rotation='quaternion'``: the Euler parameters ``qx, qy, qz,
    qw`` (scalar last, unit length) as coordinates and the angular velocity
    ``wx, wy, wz`` (rad/s) of the child marker frame relative to the parent
    marker frame, in the child marker's axes, as speeds
    (:mod:`flexmb.quaternions`): no singular position. As a cut joint
    (three point rows) neither has a limit.

    Parameters
    ----------
    name, parent, child, parent_point, child_point, parent_frame, child_frame, cut
        As for :class:`Joint`: the unique name, the parent and child bodies,
        the joint point (m) and frame in each body frame, and whether the
        joint is forced to be a cut joint.
    rotation : {'bryant', 'quaternion'}
        How the rotation is described (keyword only).

    Examples
    --------
    >>> import flexmb as fm
    >>> model = fm.Model()
    >>> top = fm.RigidBody("top", 1.0, (0.02, 0.02, 0.01), com=(0, 0, 0.1))
    >>> j = fm.Spherical("pivot", model.ground, top, rotation="quaternion")
    >>> j.coordinate_names, j.speed_names
    (('qx', 'qy', 'qz', 'qw'), ('wx', 'wy', 'wz'))
    """

    rotation_axes = (0, 1, 2)
    coordinate_names = ("rx", "ry", "rz")

    rotation: str = field(default="bryant", kw_only=True, validator=_rotation_kind)

    @classmethod
    def _quaternion_class(cls):
        return SphericalQuaternion if cls is Spherical else None


@frozen(eq=False)
class SphericalQuaternion(Spherical):
    """:class:`Spherical` in Euler parameters (``Spherical(..., rotation='quaternion')`` makes one).

    Parameters
    ----------
    name, parent, child, parent_point, child_point, parent_frame, child_frame, cut
        As for :class:`Joint`.
    rotation : {'quaternion'}
        Always 'quaternion'.
    """

    rotation_axes = ()
    coordinate_names = ("qx", "qy", "qz", "qw")
    quaternions = (((0, 1, 2, 3), (0, 1, 2)),)

    rotation: str = field(default="quaternion", kw_only=True, validator=validators.in_(("quaternion",)))

@frozen(eq=False)
class Free(_RotationChoice, Joint):
    """Six freedoms: translations x, y, z (m), then the rotation as in :class:`Spherical`.

    ``rotation='bryant'`` (the default): Bryant angles rx, ry, rz (rad).
    ``rotation='quaternion'``: coordinates ``x, y, z, qx, qy, qz, qw`` and
    speeds ``x, y, z`` (the translations' rates, m/s) and ``wx, wy, wz``
    (the angular velocity in the child marker's axes, rad/s).

    Parameters
    ----------
    name, parent, child, parent_point, child_point, parent_frame, child_frame, cut
        As for :class:`Joint`: the unique name, the parent and child bodies,
        the joint point (m) and frame in each body frame, and whether the
        joint is forced to be a cut joint.
    rotation : {'bryant', 'quaternion'}
        How the rotation is described (keyword only).
    """

    translation_axes = (0, 1, 2)
    rotation_axes = (0, 1, 2)
    coordinate_names = ("x", "y", "z", "rx", "ry", "rz")
    cut_point = False

    rotation: str = field(default="bryant", kw_only=True, validator=_rotation_kind)

    @classmethod
    def _quaternion_class(cls):
        return FreeQuaternion if cls is Free else None


@frozen(eq=False)
class FreeQuaternion(Free):
    """:class:`Free` in Euler parameters (``Free(..., rotation='quaternion')`` makes one).

    Parameters
    ----------
    name, parent, child, parent_point, child_point, parent_frame, child_frame, cut
        As for :class:`Joint`.
    rotation : {'quaternion'}
        Always 'quaternion'.
    """

    rotation_axes = ()
    coordinate_names = ("x", "y", "z", "qx", "qy", "qz", "qw")
    quaternions = (((3, 4, 5, 6), (3, 4, 5)),)

    rotation: str = field(default="quaternion", kw_only=True, validator=validators.in_(("quaternion",)))
