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

A body whose section or material varies along it (a tapered or stepped
beam) takes a :class:`~flexmb.BeamProfile`: segment j's mass, mass centre
and inertia are integrated over the segment, and joint i's spring is the
flexibility of its span, the half segments on either side::

    1 / k_i = integral over [s_i - l/2, s_i + l/2] of ds / EI(s)

(over ``[0, l/2]`` at a clamped root), which is ``EI / l`` for a uniform
beam and ``2 EI / l`` at its clamp. Measured data enters through
per-joint and per-segment scale factors (``stiffness_scale``,
``mass_scale``), which :func:`flexmb.calibrate` fits to natural
frequencies.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from attrs import converters, field, frozen

from .bodies import Body
from ._validate import in_range, number, positive_value
from .errors import ModelError
from .fields import as_array, as_bool, as_count, as_float, boolean, count, finite_number, label, positive
from .joints import Joint
from .profiles import BeamProfile, _at, _PerSegment, segment_data
from .sections import Material, Section, _non_negative

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


def _keep(value):  # a name, or a list of names; anything else for _check_keep to name
    return (value,) if isinstance(value, str) else tuple(value) if isinstance(value, (list, tuple)) else value


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
    if not isinstance(value, tuple):
        raise ModelError(f"{label(instance)}: keep must be a list of elastic coordinate names, got {value!r:.60}")
    if not value:
        raise ModelError(f"{label(instance)}: keep at least one elastic coordinate, "
                         f"from {sorted(ELASTIC_COORDINATES)}")
    bad = [k for k in value if not isinstance(k, str) or k not in ELASTIC_COORDINATES]
    if bad:
        raise ModelError(f"{label(instance)}: unknown elastic coordinate(s) {bad}; pick from "
                         f"{sorted(ELASTIC_COORDINATES)}")
    if len(set(value)) != len(value):
        raise ModelError(f"{label(instance)}: keep lists a coordinate twice: {list(value)}")


#: the property of a BeamProfile that sets each kept coordinate's spring
def _scale_factors(instance, attribute, value):
    if value is None:
        return
    if not (isinstance(value, np.ndarray) and value.dtype == float and value.ndim in (1, 2)):
        raise ModelError(f"{label(instance)}: {attribute.name} must be an array of numbers, got {value!r}")
    if not np.all(np.isfinite(value)) or np.any(value <= 0):
        raise ModelError(f"{label(instance)}: {attribute.name} must be finite and > 0, got {value.tolist()}")


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
    profile : BeamProfile, optional
        Section and material data varying along the body (a tapered or
        stepped beam; :meth:`varying_beam` builds one from functions or
        tables). The segments' mass data and the joint springs then come
        from it (:meth:`segment_properties`, :meth:`joint_stiffness`), and
        ``section`` and ``material`` only serve as a reference (drawing,
        default damping frequency). It must cover ``[0, length]``; its
        stiffness for every kept coordinate and its ``rhoA`` must be finite
        and > 0 there.
    stiffness_scale : array_like, shape (n_joints,) or (n_joints, len(keep)), optional
        Factors (> 0) on the joint springs (and so on their dampers), e.g.
        fitted by :func:`flexmb.calibrate`.
    mass_scale : array_like, shape (N,), optional
        Factors (> 0) on each segment's mass and inertia.

    Examples
    --------
    >>> import flexmb as fm
    >>> beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005),
    ...                        fm.Material.aluminium(), n_segments=8, keep=("bend_y",))
    >>> beam.n_joints, beam.n_elastic
    (8, 8)
    """

    length: float = field(default=1.0, converter=as_float, validator=[finite_number, positive])
    section: Section = field(default=None)
    material: Material = field(default=None)
    n_segments: int = field(default=8, converter=as_count, validator=count)
    keep: tuple = field(default=("bend_y", "bend_z", "torsion"), converter=_keep, validator=_check_keep)
    damping: float = field(default=0.0, converter=as_float, validator=[finite_number, _non_negative])
    clamped: bool = field(default=True, converter=as_bool, validator=boolean)
    rotary_inertia: bool = field(default=True, converter=as_bool, validator=boolean)
    profile: BeamProfile | None = field(default=None)
    stiffness_scale: np.ndarray | None = field(
        default=None, converter=converters.optional(as_array), validator=_scale_factors)
    mass_scale: np.ndarray | None = field(
        default=None, converter=converters.optional(as_array), validator=_scale_factors)
    _data: dict | None = field(default=None, init=False, repr=False)

    @section.validator
    def _check_section(self, attribute, value):
        if not isinstance(value, Section):
            raise ModelError(f"{label(self)}: section must be a Section, got {type(value).__name__}")

    @material.validator
    def _check_material(self, attribute, value):
        if not isinstance(value, Material):
            raise ModelError(f"{label(self)}: material must be a Material, got {type(value).__name__}")

    @profile.validator
    def _check_profile(self, attribute, value):
        if value is not None and not isinstance(value, BeamProfile):
            raise ModelError(f"{label(self)}: profile must be a BeamProfile or None, got {type(value).__name__}")

    def __attrs_post_init__(self):
        if not self.clamped and self.n_segments < 2:
            raise ModelError(f"{label(self)}: an unclamped flexible body needs n_segments >= 2 (one segment has "
                             "no elastic joint); use a RigidBody, or clamped = True")
        for name, scale, shapes in (("stiffness_scale", self.stiffness_scale,
                                     [(self.n_joints,), (self.n_joints, len(self.keep))]),
                                    ("mass_scale", self.mass_scale, [(self.n_segments,)])):
            if scale is not None and scale.shape not in shapes:
                raise ModelError(f"{label(self)}: {name} must have shape "
                                 f"{' or '.join(str(s) for s in shapes)}, got {scale.shape}")
        if self.profile is not None:
            object.__setattr__(self, "_data", self._integrate_profile())
        self._check_range()

    def _check_range(self):
        """Refuse segment data that overflow (or a mass underflowing to 0) from extreme section or material values."""
        with np.errstate(all="ignore"):
            (mass, inertia, _), k = (self.segment_properties(), self.joint_stiffness()) if self.varying else \
                (self._uniform_segment(), self.joint_stiffness(rows=1))
            data = {"segment mass": mass, "segment inertia": inertia, "joint stiffness": k,
                    "joint damping": self.damping * k}
        in_range(label(self), data, hint := f"; check the length ({self.length:g} m), section, material and damping")
        if not np.all(mass > 0):
            raise ModelError(f"{label(self)}: its segment mass rho A l underflows to 0{hint}")

    def _integrate_profile(self) -> dict:
        """Segment mass data and joint springs integrated over the profile; checks the data on the way."""
        return segment_data(self.profile, self.length, self.n_segments, self.clamped, self.rotary_inertia,
                            segment_joint_class(self.keep).coordinate_names, label(self))

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
            The mode's frequency f (Hz, finite, > 0) where zeta applies; default: the
            Euler-Bernoulli first cantilever bending frequency about the
            kept bending axis (about y if both are kept).
        **kw
            Other fields (``clamped``, ``rotary_inertia``).

        Returns
        -------
        FlexibleBody
            The beam.

        Raises
        ------
        ModelError
            For a ``damping_ratio`` < 0, a ``frequency`` <= 0, or a refused field.
        """
        where = f"FlexibleBody {name!r}"
        damping_ratio = number(where, "damping_ratio", damping_ratio, minimum=0.0, strict=False)
        if frequency is not None:
            frequency = positive_value(where, "frequency", frequency)
        if damping_ratio and frequency is None and isinstance(section, Section) and isinstance(material, Material):
            length, bend_z = positive_value(where, "length", length), "bend_z" in keep and "bend_y" not in keep
            with np.errstate(all="ignore"):
                frequency = 1.8751040687119611**2 / (2 * np.pi) * np.sqrt(material.E * (
                    section.Iz if bend_z else section.Iy) / (material.density * section.area * np.float64(length) ** 4))
            if not (np.isfinite(frequency) and frequency > 0):  # not from input refused above: overflow
                raise ModelError(f"{where}: its first bending frequency ({frequency:g} Hz) is out of range")
        beta = 2.0 * damping_ratio / (2.0 * np.pi * frequency) if damping_ratio and frequency else 0.0
        return cls(name, length, section, material, n_segments, keep, beta, **kw)

    @classmethod
    def varying_beam(cls, name: str, length: float, section, material, n_segments: int, keep=("bend_y",),
                     breaks=(), **kw) -> "FlexibleBody":
        """Beam whose section or material varies along it (tapered or stepped).

        Parameters
        ----------
        name, length, n_segments, keep
            As for the class.
        section : Section, callable or sequence of Section
            Fixed; ``section(s)`` returning a :class:`~flexmb.Section` at
            arclength s (m) from the root; or one per segment (a beam
            stepped at the segment ends).
        material : Material, callable or sequence of Material
            Likewise.
        breaks : sequence of float
            Arclengths where a function jumps or kinks (steps inside
            segments), m; the integrals over segments and joint spans are
            split there.
        **kw
            Other fields (``damping``, ``clamped``, ``rotary_inertia``,
            ``stiffness_scale``, ``mass_scale``).

        Returns
        -------
        FlexibleBody
            With ``profile = BeamProfile.from_sections(section, material)``;
            its ``section`` and ``material`` are those at the root (s = 0).

        Raises
        ------
        ModelError
            Naming the body and the problem: a function that fails or
            returns something else than a Section (Material), a list of the
            wrong length, non-positive stiffness or mass.

        Examples
        --------
        >>> import flexmb as fm
        >>> beam = fm.FlexibleBody.varying_beam(
        ...     "taper", 1.0, lambda s: fm.Section.rectangular(0.02, 0.005 * (1 - s / 2)),
        ...     fm.Material.aluminium(), 4)
        >>> beam.joint_stiffness().ravel().round(3)  # 1 / int ds / EI over each joint's span
        array([105.847,  38.681,  24.269,  13.958])
        >>> round(beam.mass, 6)  # rho b h0 (1 - 1/4) L
        0.2025
        """
        where = f"FlexibleBody {name!r}"
        n = as_count(n_segments)
        stations = np.linspace(0.0, float(length), n + 1) if isinstance(n, int) and n >= 1 else None
        parts = []
        for what, value, kind in (("section", section, Section), ("material", material, Material)):
            if isinstance(value, (list, tuple)):
                if stations is None or len(value) != n or not all(isinstance(v, kind) for v in value):
                    raise ModelError(f"{where}: {what} as a list needs one {kind.__name__} per segment "
                                     f"({n_segments!r}), got {len(value)} items")
                value = _PerSegment(stations, tuple(value))
                breaks = tuple(breaks) + tuple(stations)
            elif not (isinstance(value, kind) or callable(value)):
                raise ModelError(f"{where}: {what} must be a {kind.__name__}, a function of s returning one, "
                                 f"or a list with one per segment; got {type(value).__name__}")
            parts.append(value)
        profile = BeamProfile.from_sections(*parts, breaks=breaks, name=f"{name} profile")
        root = []
        for what, value, kind in (("section", parts[0], Section), ("material", parts[1], Material)):
            try:
                root.append(_at(value, kind, what, 0.0))
            except ModelError as exc:
                raise ModelError(f"{where}: {exc}") from exc
        return cls(name, length, root[0], root[1], n_segments, keep, profile=profile, **kw)

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
        """Total mass, kg: rho A L, or the sum of the segment masses of a varying or scaled body."""
        if self.profile is None and self.mass_scale is None:
            return self.material.density * self.section.area * self.length
        return float(np.sum(self.segment_properties()[0]))

    @property
    def varying(self) -> bool:
        """Whether the body has a profile or scale factors (its segments or joints differ)."""
        return self.profile is not None or self.stiffness_scale is not None or self.mass_scale is not None

    def segment_properties(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mass, central inertia and mass centre of every segment.

        Returns
        -------
        mass : ndarray, shape (N,)
            kg; with a profile ``int rho A ds`` over each segment.
        inertia : ndarray, shape (N, 3, 3)
            Central inertia in the segment frame, kg m^2; with a profile,
            ``diag(int rho Ip, int rho Iy + rho A (s - c)^2, int rho Iz +
            rho A (s - c)^2)`` over the segment (the rotary terms only if
            ``rotary_inertia``).
        com : ndarray, shape (N, 3)
            Mass centre in the segment frame, m: ``(l/2, 0, 0)`` for a
            uniform body, the centroid of rho A along the segment with a
            profile.

        Notes
        -----
        The integrals use 4-point Gauss-Legendre quadrature on each
        segment, split at the profile's breaks: exact for piecewise-linear
        tables and stepped data, and far more accurate than the O(l^2)
        error of the segment model itself for smooth functions.
        ``mass_scale`` multiplies mass and inertia (it scales the density).
        """
        N = self.n_segments
        if self._data is None:
            m, inertia, com = self._uniform_segment()
            mass = np.full(N, m)
            inertia = np.broadcast_to(inertia, (N, 3, 3)).copy()
            com = np.broadcast_to(com, (N, 3)).copy()
        else:
            mass = self._data["mass"].copy()
            inertia = np.zeros((N, 3, 3))
            inertia[:, [0, 1, 2], [0, 1, 2]] = self._data["inertia"]
            com = self._data["com"].copy()
        if self.mass_scale is not None:
            mass = mass * self.mass_scale
            inertia = inertia * self.mass_scale[:, None, None]
        return mass, inertia, com

    def segment_mass_properties(self, index: int = 0) -> tuple[float, np.ndarray, np.ndarray]:
        """Mass, central inertia (segment frame) and mass centre of one segment.

        Parameters
        ----------
        index : int
            Segment number from the root (all segments of a uniform,
            unscaled body are alike).

        Returns
        -------
        m : float
            kg.
        inertia : ndarray, shape (3, 3)
            kg m^2.
        com : ndarray, shape (3,)
            m.

        See Also
        --------
        segment_properties : All segments at once, and what they hold.
        """
        if not self.varying:
            return self._uniform_segment()
        m, inertia, com = self.segment_properties()
        return float(m[index]), inertia[index], com[index]

    def _uniform_segment(self) -> tuple[float, np.ndarray, np.ndarray]:
        """Mass, central inertia and mass centre of a segment of the uniform beam of ``section``, ``material``.

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

    def joint_stiffness(self, rows=None) -> np.ndarray:
        """Spring constants of the kept coordinates per joint (eqs. 25-27).

        Returns
        -------
        ndarray, shape (n_joints, len(keep))
            In the order of the joint coordinates (translations, then
            rotations); the clamped root joint has 2k. With a profile,
            rotational and axial springs are ``1 / int ds / P(s)`` over the
            joint's span (the half segments on either side, ``[0, l/2]`` at a
            clamped root; P the matching ``GJ``, ``EIy``, ``EIz``, ``EA``),
            the flexibility of that piece of beam; shear springs are
            ``3 P_h / l^3`` with P_h the harmonic mean of ``EIz`` or ``EIy``
            over the span (doubled at a clamp). Each is multiplied by
            ``stiffness_scale``.

        Parameters
        ----------
        rows : None or 1
            1: only the root joint's row of a uniform unscaled body.
        """
        l, E, G, s = np.float64(self.segment_length), self.material.E, self.material.G, self.section
        per = {"torsion": G * s.J / l, "bend_y": E * s.Iy / l, "bend_z": E * s.Iz / l,
               "axial": E * s.area / l, "shear_y": 3 * E * s.Iz / (l * l * l), "shear_z": 3 * E * s.Iy / (l * l * l)}
        names = segment_joint_class(self.keep).coordinate_names
        if self._data is not None:
            k = self._data["stiffness"].copy()
        else:  # the root joint alone where _check_range asks for one (n_segments may be huge)
            k = np.tile([per[c] for c in names], (1 if rows == 1 else self.n_joints, 1))
            k[0] *= 2.0 if self.clamped else 1.0
        if self.stiffness_scale is not None:
            k = k * (self.stiffness_scale if self.stiffness_scale.ndim == 2 else self.stiffness_scale[:, None])
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
        if self.varying:
            m, inertia, com = self.segment_properties()
            segs = [Segment(f"{self.name}[{i}]", float(m[i]), inertia[i], com[i], self, i)
                    for i in range(self.n_segments)]
        else:
            m, inertia, com = self._uniform_segment()
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
