"""Flexible bodies by finite segments (section 2 of the paper).

A :class:`FlexibleBody` is a beam along the x axis of its body frame, cut
into N rigid :class:`Segment` s joined by elastic segment joints. Each
segment joint carries only the elastic coordinates the body keeps: up to
three small rotations (torsion, bending about y, bending about z; applied
in the sequence Rx Ry Rz, which agrees with eq. 6 to first order) and up to
three translations (axial, two shears). The joint springs come from beam
theory (eqs. 25-27)::

    rotational:     (G J, E I_y, E I_z) / l
    translational:  (E A / l, 3 E I_z / l^3, 3 E I_y / l^3)

Each interior joint lumps half a segment of flexibility on either side; a
clamped root joint sees only half a segment, so its spring is 2k. With that
the tip deflection and frequencies of a cantilever converge to
Euler-Bernoulli as 1/N^2.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from attrs import field, frozen

from ._validate import as_count, count, label, positive
from .bodies import Body
from .errors import ModelError
from .joints import Joint
from .sections import Material, Section

__all__ = ["FlexibleBody", "Segment", "SegmentJoint", "ELASTIC_COORDINATES"]

#: kept-coordinate name -> (kind, axis): "t" translation, "r" rotation
ELASTIC_COORDINATES = {
    "axial": ("t", 0),
    "shear_y": ("t", 1),
    "shear_z": ("t", 2),
    "torsion": ("r", 0),
    "bend_y": ("r", 1),
    "bend_z": ("r", 2),
}


def _keep(value):
    if isinstance(value, str):
        value = (value,)
    return tuple(value)


@frozen(eq=False)
class Segment(Body):
    """One rigid segment of a flexible body (created by the topology).

    Parameters
    ----------
    name : str
        ``"body[i]"`` (or ``"body.base"`` for the massless clamp frame).
    mass : float
        kg (0 for the clamp frame).
    inertia : ndarray, shape (3, 3)
        Central inertia in the segment frame, kg m^2.
    com : ndarray, shape (3,)
        Mass centre in the segment frame (mid-segment), m.
    owner : FlexibleBody
        The flexible body it belongs to.
    index : int
        Segment number from the root (-1 for the clamp frame).
    """

    mass: float = 0.0
    inertia: np.ndarray = field(factory=lambda: np.zeros((3, 3)))
    com: np.ndarray = field(factory=lambda: np.zeros(3))
    owner: "FlexibleBody | None" = None
    index: int = 0


@frozen(eq=False)
class SegmentJoint(Joint):
    """Elastic joint between two segments; subclasses fix the kept coordinates.

    Parameters
    ----------
    name, parent, child, parent_point, child_point, parent_frame, child_frame, cut
        As for :class:`~flexmb.Joint`; :class:`FlexibleBody` creates these
        joints between its segments.
    """

    cut_point: ClassVar[bool] = False


_JOINT_CLASSES: dict = {}


def segment_joint_class(keep: tuple[str, ...]) -> type:
    """The SegmentJoint subclass carrying exactly the kept coordinates.

    Parameters
    ----------
    keep : tuple of str
        Kept elastic coordinates (keys of ``ELASTIC_COORDINATES``).

    Returns
    -------
    type
        A :class:`SegmentJoint` subclass; one per kept set, so that all
        segment joints with the same freedoms are evaluated in one batch.
    """
    trans = tuple(sorted(ELASTIC_COORDINATES[k][1] for k in keep if ELASTIC_COORDINATES[k][0] == "t"))
    rots = tuple(sorted(ELASTIC_COORDINATES[k][1] for k in keep if ELASTIC_COORDINATES[k][0] == "r"))
    key = (trans, rots)
    if key not in _JOINT_CLASSES:
        inv = {v: k for k, v in ELASTIC_COORDINATES.items()}
        names = tuple(inv[("t", a)] for a in trans) + tuple(inv[("r", a)] for a in rots)
        _JOINT_CLASSES[key] = type(
            "SegmentJoint_" + "_".join(names),
            (SegmentJoint,),
            {"translation_axes": trans, "rotation_axes": rots, "coordinate_names": names,
             "__module__": __name__},
        )
    return _JOINT_CLASSES[key]


def _check_keep(instance, attribute, value):
    if not value:
        raise ModelError(f"{label(instance)}: keep at least one elastic coordinate, "
                         f"from {sorted(ELASTIC_COORDINATES)}")
    bad = [k for k in value if k not in ELASTIC_COORDINATES]
    if bad:
        raise ModelError(f"{label(instance)}: unknown elastic coordinate(s) {bad}; pick from "
                         f"{sorted(ELASTIC_COORDINATES)}")
    if len(set(value)) != len(value):
        raise ModelError(f"{label(instance)}: keep lists a coordinate twice: {list(value)}")


def _non_negative(instance, attribute, value):
    if not np.isfinite(value) or value < 0:
        raise ModelError(f"{label(instance)}: {attribute.name} must be finite and >= 0, got {value!r}")


@frozen(eq=False)
class FlexibleBody(Body):
    """A beam modelled by finite rigid segments with elastic joints.

    The body frame sits at the root of the beam, which runs along +x to
    ``x = length``. Joints and force elements attach to any point of it
    (given in the body frame) exactly as to a rigid body: the point is
    carried by the segment that contains its x.

    Parameters
    ----------
    name : str
        Unique name.
    length : float
        L, m.
    section : Section
        Cross-section.
    material : Material
        Material.
    n_segments : int
        N, number of rigid segments (>= 1; a whole float such as ``4.0`` is
        taken as 4).
    keep : tuple of str
        Elastic coordinates each segment joint carries, any of ``"torsion"``,
        ``"bend_y"`` (bending in the x-z plane), ``"bend_z"`` (in the x-y
        plane), ``"axial"``, ``"shear_y"``, ``"shear_z"``. Only these enter
        the model.
    damping : float
        Stiffness-proportional damping beta, s: every joint damper is
        ``c = beta k`` (internal friction, eq. 5).
    clamped : bool
        If True (a cantilever root) the first segment is joined to the body
        frame by an elastic joint of stiffness 2k; attach the body frame to
        its parent with a :class:`~flexmb.Fixed` (or driven) joint. If False
        (a pinned or free root) the first segment is the body frame itself.
    rotary_inertia : bool
        Include the section's rotary inertia (``rho l I``) in the segment
        inertia; False gives slender bars (``m l^2 / 12`` transverse only).

    Examples
    --------
    >>> import flexmb as fm
    >>> beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005),
    ...                        fm.Material.aluminium(), n_segments=8, keep=("bend_y",))
    >>> beam.n_joints, beam.n_elastic
    (8, 8)
    """

    length: float = field(default=1.0, converter=float, validator=positive)
    section: Section = field(default=None)
    material: Material = field(default=None)
    n_segments: int = field(default=8, converter=as_count, validator=count)
    keep: tuple = field(default=("bend_y", "bend_z", "torsion"), converter=_keep, validator=_check_keep)
    damping: float = field(default=0.0, converter=float, validator=_non_negative)
    clamped: bool = field(default=True, converter=bool)
    rotary_inertia: bool = field(default=True, converter=bool)

    @section.validator
    def _check_section(self, attribute, value):
        if not isinstance(value, Section):
            raise ModelError(f"{label(self)}: section must be a Section, got {type(value).__name__}")

    @material.validator
    def _check_material(self, attribute, value):
        if not isinstance(value, Material):
            raise ModelError(f"{label(self)}: material must be a Material, got {type(value).__name__}")

    def __attrs_post_init__(self):
        if not self.clamped and self.n_segments < 2:
            raise ModelError(f"{label(self)}: an unclamped flexible body needs n_segments >= 2 (one segment has "
                             "no elastic joint); use a RigidBody, or clamped = True")

    @classmethod
    def uniform_beam(cls, name: str, length: float, section: Section, material: Material,
                     n_segments: int, keep=("bend_y",), damping_ratio: float = 0.0,
                     frequency: float | None = None, **kw) -> "FlexibleBody":
        """Beam with damping given as a ratio of critical in one mode.

        Parameters
        ----------
        name, length, section, material, n_segments, keep
            As for the class.
        damping_ratio : float
            zeta; with stiffness-proportional damping ``beta = 2 zeta / omega``.
        frequency : float, optional
            The mode's frequency f (Hz) where zeta applies; default: the
            Euler-Bernoulli first cantilever bending frequency about the
            kept bending axis (about y if both are kept).
        **kw
            Other fields (``clamped``, ``rotary_inertia``).

        Returns
        -------
        FlexibleBody
            The beam.
        """
        beta = 0.0
        if damping_ratio:
            if frequency is None:
                I = section.Iz if ("bend_z" in keep and "bend_y" not in keep) else section.Iy
                frequency = 1.8751040687119611**2 / (2 * np.pi) * np.sqrt(
                    material.E * I / (material.density * section.area * length**4))
            beta = 2.0 * damping_ratio / (2.0 * np.pi * frequency)
        return cls(name, length, section, material, n_segments, keep, beta, **kw)

    # -- derived data
    @property
    def segment_length(self) -> float:
        """Segment length l = L / N, m."""
        return self.length / self.n_segments

    @property
    def n_joints(self) -> int:
        """Number of elastic joints (N if clamped, else N - 1)."""
        return self.n_segments if self.clamped else self.n_segments - 1

    @property
    def n_elastic(self) -> int:
        """Number of elastic coordinates the body adds."""
        return self.n_joints * len(self.keep)

    @property
    def mass(self) -> float:
        """Total mass rho A L, kg."""
        return self.material.density * self.section.area * self.length

    def segment_mass_properties(self) -> tuple[float, np.ndarray, np.ndarray]:
        """Mass, central inertia (segment frame) and mass centre of one segment.

        Returns
        -------
        m : float
            ``rho A l``, kg.
        inertia : ndarray, shape (3, 3)
            ``diag(rho l Ip, rho l Iy + m l^2/12, rho l Iz + m l^2/12)``; for a
            rectangle this is the solid block ``m (b^2 + h^2)/12`` etc.
        com : ndarray, shape (3,)
            ``(l/2, 0, 0)``.
        """
        l, rho, s = self.segment_length, self.material.density, self.section
        m = rho * s.area * l
        if self.rotary_inertia:
            moments = np.array([rho * l * s.polar, rho * l * s.Iy + m * l * l / 12, rho * l * s.Iz + m * l * l / 12])
        else:
            moments = np.array([0.0, m * l * l / 12, m * l * l / 12])
        return m, np.diag(moments), np.array([l / 2, 0.0, 0.0])

    def joint_stiffness(self) -> np.ndarray:
        """Spring constants of the kept coordinates per joint (eqs. 25-27).

        Returns
        -------
        ndarray, shape (n_joints, len(keep))
            In the order of the joint coordinates (translations, then
            rotations); the clamped root joint has 2k.
        """
        l, E, G, s = self.segment_length, self.material.E, self.material.G, self.section
        per = {"torsion": G * s.J / l, "bend_y": E * s.Iy / l, "bend_z": E * s.Iz / l,
               "axial": E * s.area / l, "shear_y": 3 * E * s.Iz / l**3, "shear_z": 3 * E * s.Iy / l**3}
        names = segment_joint_class(self.keep).coordinate_names
        k = np.tile([per[c] for c in names], (self.n_joints, 1))
        if self.clamped:
            k[0] *= 2.0
        return k

    def expand(self):
        """Create the segments and elastic joints.

        Returns
        -------
        root : Segment
            The body frame's carrier (the clamp frame or the first segment).
        segments : list of Segment
            The N segments, root to tip.
        joints : list of SegmentJoint
            The elastic joints, root to tip.
        """
        m, inertia, com = self.segment_mass_properties()
        segs = [Segment(f"{self.name}[{i}]", m, inertia, com, self, i) for i in range(self.n_segments)]
        cls = segment_joint_class(self.keep)
        l = self.segment_length
        joints = []
        if self.clamped:
            root = Segment(f"{self.name}.base", 0.0, np.zeros((3, 3)), np.zeros(3), self, -1)
            joints.append(cls(f"{self.name}.j0", root, segs[0]))
        else:
            root = segs[0]
        for i in range(1, self.n_segments):
            joints.append(cls(f"{self.name}.j{i}", segs[i - 1], segs[i], parent_point=(l, 0.0, 0.0)))
        return root, segs, joints

    def locate(self, point) -> tuple[int, np.ndarray]:
        """Segment number carrying a body-frame point and the point in that segment's frame.

        Parameters
        ----------
        point : array_like, shape (3,)
            Point in the body frame, m.

        Returns
        -------
        index : int
            Segment number (0 at the root).
        local : ndarray, shape (3,)
            The point in the segment frame.
        """
        p = np.asarray(point, dtype=float)
        l = self.segment_length
        i = int(np.clip(np.floor(p[0] / l + 1e-9), 0, self.n_segments - 1))
        return i, p - np.array([i * l, 0.0, 0.0])
