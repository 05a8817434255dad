"""Beam properties per unit length along a flexible body, and the segment data integrated from them.

Section 2 of the paper gives each finite segment "data from analytical
solutions, or experimental modal analysis". A :class:`BeamProfile` holds the
properties per unit length as functions of the arclength s (tapered or
stepped beams); :func:`segment_data` integrates them into each segment's
mass, mass centre and inertia and each elastic joint's stiffness from the
flexibility of its span.
"""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from ._validate import name_check
from .errors import ModelError
from .fields import label
from .sections import Material, Section

__all__ = ["BeamProfile", "BEAM_PROPERTIES", "segment_data"]


#: stiffnesses E A (N), G J, E I_y, E I_z (N m^2); mass rho A (kg/m) and rotary inertias rho I_p, rho I_y,
#: rho I_z (kg m)
BEAM_PROPERTIES = ("EA", "GJ", "EIy", "EIz", "rhoA", "rhoIp", "rhoIy", "rhoIz")
_STIFFNESS = ("EA", "GJ", "EIy", "EIz")


def _row(section, material) -> np.ndarray:
    """The :data:`BEAM_PROPERTIES` of a section in a material."""
    E, G, rho = material.E, material.G, material.density
    return np.array([E * section.area, G * section.J, E * section.Iy, E * section.Iz, rho * section.area,
                     rho * section.polar, rho * section.Iy, rho * section.Iz])


def _at(value, kind: type, what: str, s: float):
    """``value`` itself, or ``value(s)`` checked to be a ``kind``; errors name ``what`` and s."""
    if isinstance(value, kind):
        return value
    try:
        out = value(s)
    except ModelError as exc:
        raise ModelError(f"{what} at s = {s:.6g} m: {exc}") from exc
    except Exception as exc:  # a user's function: any failure becomes a model error naming s
        raise ModelError(f"{what} failed at s = {s:.6g} m: {type(exc).__name__}: {exc}") from exc
    if not isinstance(out, kind):
        raise ModelError(f"{what} returned {type(out).__name__} at s = {s:.6g} m, expected a {kind.__name__}")
    return out


class _SectionFunctions:
    """Properties from a section and a material, each fixed or a function of s (a picklable callable)."""

    def __init__(self, section, material):
        self.section, self.material = section, material

    def __repr__(self):
        return f"<section {self.section!r}, material {self.material!r}>"

    def __call__(self, s: np.ndarray) -> np.ndarray:
        rows = [_row(_at(self.section, Section, "section", si), _at(self.material, Material, "material", si))
                for si in np.asarray(s, dtype=float).ravel()]
        return np.array(rows).reshape(-1, len(BEAM_PROPERTIES))


class _PropertyFunctions:
    """Properties each a number or a function of s (scalar s; vectorised use is tried first)."""

    def __init__(self, columns: dict):
        self.columns = columns

    def __repr__(self):
        return f"<functions of s: {', '.join(self.columns)}>"

    def __call__(self, s: np.ndarray) -> np.ndarray:
        s = np.asarray(s, dtype=float).ravel()
        out = np.zeros((s.size, len(BEAM_PROPERTIES)))
        for j, name in enumerate(BEAM_PROPERTIES):
            f = self.columns.get(name, np.nan if name in _STIFFNESS else 0.0)
            out[:, j] = self._column(f, name, s)
        return out

    @staticmethod
    def _column(f, name, s):
        if not callable(f):
            return float(f)
        try:
            v = np.asarray(f(s), dtype=float)
            if v.shape in ((), s.shape):
                return v
        except Exception:  # a scalar-only function: call it point by point below
            pass
        vals = np.empty(s.size)
        for i, si in enumerate(s):
            try:
                vals[i] = float(f(float(si)))
            except Exception as exc:
                raise ModelError(f"{name}(s) failed at s = {si:.6g} m: {type(exc).__name__}: {exc}") from exc
        return vals


class _Table:
    """Properties tabulated at stations: linear interpolation, or constant on each interval ('step')."""

    def __init__(self, stations: np.ndarray, values: np.ndarray, interpolation: str):
        self.stations, self.values, self.interpolation = stations, values, interpolation

    def __repr__(self):
        return f"<{self.interpolation} table, {self.stations.size} stations>"

    def __call__(self, s: np.ndarray) -> np.ndarray:
        s = np.asarray(s, dtype=float).ravel()
        st, v = self.stations, self.values
        if self.interpolation == "step":
            i = np.clip(np.searchsorted(st, s, side="right") - 1, 0, len(v) - 1)
            return v[i]
        return np.stack([np.interp(s, st, v[:, j]) for j in range(v.shape[1])], axis=1)


def _as_stations(stations, where: str) -> np.ndarray:
    try:
        st = np.array(stations, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: stations must be numbers, got {stations!r}") from None
    if st.ndim != 1 or st.size < 2 or not np.all(np.isfinite(st)) or np.any(np.diff(st) <= 0):
        raise ModelError(f"{where}: stations must be at least 2 finite, strictly increasing arclengths s (m), "
                         f"got {np.asarray(stations).tolist()}")
    return st


@frozen(eq=False)
class BeamProfile:
    """Section and material data along a beam, as functions of its arclength s.

    A :class:`~flexmb.FlexibleBody` given a profile (a tapered or stepped
    beam) integrates its segments' mass and inertia and its segment joints'
    flexibility over s; build one with the named constructors
    :meth:`from_sections`, :meth:`from_functions` or :meth:`table`.

    Parameters
    ----------
    function : callable
        ``function(s)`` maps arclengths, ndarray shape (n,), to the
        properties :data:`BEAM_PROPERTIES`, ndarray shape (n, 8):
        ``EA, GJ, EIy, EIz`` (N, N m^2), ``rhoA`` (kg/m) and the rotary
        inertias ``rhoIp, rhoIy, rhoIz`` (kg m). A stiffness the body does
        not use may be NaN.
    domain : tuple of float
        ``(s_min, s_max)``: where the data is defined, m (a body must lie
        within it).
    breaks : ndarray, shape (k,)
        Arclengths where the data jumps or has a kink, m (the quadrature
        over segments and joint spans is split there, so that it stays
        exact to high order for stepped and piecewise-linear data).
    name : str
        Label for messages.

    Examples
    --------
    >>> import flexmb as fm
    >>> p = fm.BeamProfile.table([0.0, 1.0], EIy=[20.0, 10.0], rhoA=[0.4, 0.2])
    >>> p.at(0.5)["EIy"], round(p.at(0.5)["rhoA"], 12)  # linear between the stations
    (15.0, 0.3)
    """

    function: object = field()
    domain: tuple = field(default=(-np.inf, np.inf), converter=lambda d: (float(d[0]), float(d[1])))
    breaks: np.ndarray = field(factory=lambda: np.zeros(0), converter=lambda b: np.unique(np.array(b, dtype=float)))
    name: str = field(default="profile", validator=name_check)

    @function.validator
    def _check_function(self, attribute, value):
        if not callable(value):
            raise ModelError(f"{label(self)}: function must be callable, got {type(value).__name__}")

    def evaluate(self, s) -> np.ndarray:
        """The properties at arclengths s.

        Parameters
        ----------
        s : array_like, shape (n,)
            Arclengths, m.

        Returns
        -------
        ndarray, shape (n, 8)
            Columns in the order of :data:`BEAM_PROPERTIES`.

        Raises
        ------
        ModelError
            If a user function fails or returns the wrong kind or shape.
        """
        s = np.atleast_1d(np.asarray(s, dtype=float))
        out = np.asarray(self.function(s), dtype=float)
        if out.shape != (s.size, len(BEAM_PROPERTIES)):
            raise ModelError(f"{label(self)}: function returned shape {out.shape}, expected "
                             f"{(s.size, len(BEAM_PROPERTIES))}")
        return out

    def at(self, s: float) -> dict:
        """The properties at one arclength, by name.

        Parameters
        ----------
        s : float
            Arclength, m.

        Returns
        -------
        dict
            ``{name: value}`` for the names of :data:`BEAM_PROPERTIES`.
        """
        return dict(zip(BEAM_PROPERTIES, (float(v) for v in self.evaluate([s])[0])))

    @classmethod
    def from_sections(cls, section, material, breaks=(), name: str = "profile") -> "BeamProfile":
        """Profile from a section and a material, each fixed or a function of s.

        Parameters
        ----------
        section : Section or callable
            A :class:`Section`, or ``section(s)`` returning one (s in m).
        material : Material or callable
            A :class:`Material`, or ``material(s)`` returning one.
        breaks : sequence of float
            Where the functions jump or kink, m (a stepped beam's steps).
        name : str
            Label.

        Returns
        -------
        BeamProfile
            Defined for all s; the functions are called once per quadrature
            point when a body is built (never during a simulation).

        Examples
        --------
        >>> import flexmb as fm
        >>> p = fm.BeamProfile.from_sections(lambda s: fm.Section.rectangular(0.02, 0.005 * (1 - s / 2)),
        ...                                  fm.Material.aluminium())
        >>> round(p.at(1.0)["EIy"] / p.at(0.0)["EIy"], 6)  # h^3: a half-thickness tip is 8 times softer
        0.125
        """
        return cls(_SectionFunctions(section, material), breaks=breaks, name=name)

    @classmethod
    def from_functions(cls, breaks=(), name: str = "profile", **properties) -> "BeamProfile":
        """Profile from the beam properties, each a number or a function of s.

        Parameters
        ----------
        breaks : sequence of float
            Where the functions jump or kink, m.
        name : str
            Label.
        **properties
            Any of :data:`BEAM_PROPERTIES` (``EIy=lambda s: ...``,
            ``rhoA=0.27``); a function may take an array of s or one s at a
            time. Missing rotary inertias are 0 (slender bars); a missing
            stiffness is NaN, refused by a body that keeps its coordinate.

        Returns
        -------
        BeamProfile
            Defined for all s.

        Raises
        ------
        ModelError
            If a name is not one of :data:`BEAM_PROPERTIES`.
        """
        _known(properties, "BeamProfile.from_functions")
        return cls(_PropertyFunctions(dict(properties)), breaks=breaks, name=name)

    @classmethod
    def table(cls, stations, sections=None, materials=None, interpolation: str = "linear", name: str = "profile",
              **properties) -> "BeamProfile":
        """Profile tabulated at stations along the beam.

        Parameters
        ----------
        stations : array_like, shape (k,)
            Increasing arclengths, m; a body must lie within
            ``[stations[0], stations[-1]]``.
        sections : sequence of Section, optional
            One per station (``'linear'``) or per interval (``'step'``).
        materials : Material or sequence of Material, optional
            One for all, or one per section; required with ``sections``.
        interpolation : {'linear', 'step'}
            ``'linear'``: each property varies linearly between stations;
            ``'step'``: constant on each interval ``[s_i, s_i+1)`` (a stepped
            beam; per-segment data is the step table on the segment ends).
        name : str
            Label.
        **properties
            Instead of sections: columns of :data:`BEAM_PROPERTIES`, each
            with one value per station (or per interval), e.g. from a
            structural analysis; missing rotary inertias are 0, a missing
            stiffness NaN.

        Returns
        -------
        BeamProfile
            Defined on ``[stations[0], stations[-1]]``, with breaks at the
            stations.

        Raises
        ------
        ModelError
            On bad stations, an unknown interpolation or property name, or
            columns of the wrong length.

        Examples
        --------
        >>> import flexmb as fm
        >>> a, b = fm.Section.rectangular(0.02, 0.006), fm.Section.rectangular(0.02, 0.004)
        >>> stepped = fm.BeamProfile.table([0.0, 0.5, 1.0], [a, b], fm.Material.steel(), interpolation="step")
        >>> stepped.at(0.75)["EIy"] == fm.Material.steel().E * b.Iy
        True
        """
        where = f"BeamProfile {name!r}"
        st = _as_stations(stations, where)
        if interpolation not in ("linear", "step"):
            raise ModelError(f"{where}: interpolation must be 'linear' or 'step', got {interpolation!r}")
        n = st.size if interpolation == "linear" else st.size - 1
        if sections is not None:
            if properties:
                raise ModelError(f"{where}: give sections or property columns, not both")
            sections = list(sections)
            mats = list(materials) if isinstance(materials, (list, tuple)) else [materials] * len(sections)
            if len(sections) != n or len(mats) != n:
                raise ModelError(f"{where}: {interpolation!r} needs {n} sections and materials for {st.size} "
                                 f"stations, got {len(sections)} and {len(mats)}")
            bad = [i for i in range(n) if not (isinstance(sections[i], Section) and isinstance(mats[i], Material))]
            if bad:
                raise ModelError(f"{where}: entry {bad[0]} is not a Section and a Material "
                                 f"({type(sections[bad[0]]).__name__}, {type(mats[bad[0]]).__name__})")
            values = np.array([_row(s, m) for s, m in zip(sections, mats)])
        else:
            _known(properties, where)
            if not properties:
                raise ModelError(f"{where}: give sections (and materials) or property columns "
                                 f"({', '.join(BEAM_PROPERTIES)})")
            values = np.zeros((n, len(BEAM_PROPERTIES)))
            for j, prop in enumerate(BEAM_PROPERTIES):
                col = properties.get(prop, np.nan if prop in _STIFFNESS else 0.0)
                try:
                    col = np.broadcast_to(np.array(col, dtype=float), (n,))
                except (TypeError, ValueError):
                    raise ModelError(f"{where}: {prop} must be {n} numbers (one per "
                                     f"{'station' if interpolation == 'linear' else 'interval'}), "
                                     f"got {col!r}") from None
                values[:, j] = col
        return cls(_Table(st, values, interpolation), domain=(st[0], st[-1]), breaks=st, name=name)


def _known(properties: dict, where: str):
    bad = sorted(set(properties) - set(BEAM_PROPERTIES))
    if bad:
        raise ModelError(f"{where}: unknown beam propert{'y' if len(bad) == 1 else 'ies'} {bad}; pick from "
                         f"{list(BEAM_PROPERTIES)}")


_STIFFNESS_OF = {"torsion": "GJ", "bend_y": "EIy", "bend_z": "EIz", "axial": "EA", "shear_y": "EIz",
                 "shear_z": "EIy"}
#: Gauss-Legendre points per quadrature piece (exact for polynomials of degree 7)
_N_GAUSS = 4


class _PerSegment:
    """One item per segment as a function of the arclength s (a step function; picklable)."""

    def __init__(self, stations: np.ndarray, items: tuple):
        self.stations, self.items = stations, items

    def __repr__(self):
        return f"<one per segment: {len(self.items)} {type(self.items[0]).__name__}>"

    def __call__(self, s: float):
        i = int(np.clip(np.searchsorted(self.stations, s, side="right") - 1, 0, len(self.items) - 1))
        return self.items[i]


def _pieces(cuts: np.ndarray, breaks: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """The points cutting [lo, hi] into quadrature pieces: ``cuts`` and the breaks strictly inside."""
    inner = breaks[(breaks > lo) & (breaks < hi)]
    pts = np.union1d(cuts, inner)
    tol = 1e-12 * (hi - lo)
    return pts[np.concatenate([[True], np.diff(pts) > tol])]


def _quadrature(points: np.ndarray, bounds: np.ndarray):
    """Gauss points, weights and owning interval of the pieces between ``points``.

    Returns s, w with shape (n_pieces, _N_GAUSS) and, per piece, the index
    of the interval of ``bounds`` (increasing) that holds it.
    """
    a, b = points[:-1], points[1:]
    xi, wi = np.polynomial.legendre.leggauss(_N_GAUSS)
    mid, half = 0.5 * (a + b), 0.5 * (b - a)
    owner = np.clip(np.searchsorted(bounds, mid) - 1, 0, len(bounds) - 2)
    return mid[:, None] + half[:, None] * xi, half[:, None] * wi, owner


def segment_data(p, length: float, n_segments: int, clamped: bool, rotary_inertia: bool, coordinate_names,
                 who: str) -> dict:
    """Segment mass data and joint springs of a body integrated over its profile.

    Each segment's mass, mass centre and inertia are integrated over it
    (Gauss-Legendre, split at the profile's breaks); each elastic joint's
    stiffness is ``1 / k = int ds / P`` over its span ``[s_i - l/2, s_i +
    l/2]`` (``[0, l/2]`` at a clamped root), shear springs ``3 P_h / l^3``
    with ``P_h`` the span's harmonic mean. The data are checked on the way.

    Parameters
    ----------
    p : BeamProfile
        The profile.
    length : float
        Body length L, m.
    n_segments : int
        Number of equal segments N.
    clamped : bool
        Whether the root joint is elastic (clamped).
    rotary_inertia : bool
        Whether the rotary inertias per length are added.
    coordinate_names : tuple of str
        The elastic coordinates each joint keeps.
    who : str
        The body, for error messages.

    Returns
    -------
    dict
        ``mass`` (N,), ``inertia`` (N, 3), ``com`` (N, 3) and ``stiffness``
        (n_joints, n_keep).

    Raises
    ------
    ModelError
        If the profile does not cover the body, or a property is not finite
        and positive where it is needed.
    """
    n_joints = n_segments if clamped else n_segments - 1
    L, N = length, n_segments
    l = L / N
    lo, hi = p.domain
    if lo > 1e-9 * L or hi < L * (1 - 1e-9):
        raise ModelError(f"{who}: its profile {p.name!r} covers s in [{lo:g}, {hi:g}] m, not the "
                         f"whole body [0, {L:g}] m")
    # segments: m = int rho A ds, first and second moments of rho A about the segment start
    bounds = np.linspace(0.0, L, N + 1)
    cuts = _pieces(bounds, p.breaks, 0.0, L)
    s, w, seg = _quadrature(cuts, bounds)
    vals = _evaluate(p, who, s)
    # checked at the piece ends too (the Gauss points miss them): data that vanishes at a station
    for where, v in ((s, vals), (cuts, _evaluate(p, who, cuts))):
        _check_values(who, where, v[..., BEAM_PROPERTIES.index("rhoA")], "rhoA (mass per length)", True)
        for name in ("rhoIp", "rhoIy", "rhoIz") if rotary_inertia else ():
            _check_values(who, where, v[..., BEAM_PROPERTIES.index(name)],
                               f"{name} (rotary inertia per length)", False)
    col = {name: vals[..., j] for j, name in enumerate(BEAM_PROPERTIES)}
    local = s - bounds[seg][:, None]

    def per_segment(f):
        return np.bincount(seg, weights=np.sum(w * f, axis=1), minlength=N)

    m = per_segment(col["rhoA"])
    c = per_segment(col["rhoA"] * local) / m
    second = per_segment(col["rhoA"] * local**2) - m * c**2  # about the mass centre
    moments = np.zeros((N, 3))
    moments[:, 1:] = second[:, None]
    if rotary_inertia:
        moments += np.stack([per_segment(col["rhoIp"]), per_segment(col["rhoIy"]), per_segment(col["rhoIz"])], 1)
    # joint spans: [s_i - l/2, s_i + l/2], [0, l/2] at a clamped root
    spans = (np.arange(N) + 0.5) * l
    if clamped:
        spans = np.concatenate([[0.0], spans])
    cuts = _pieces(spans, p.breaks, spans[0], spans[-1])
    s, w, joint = _quadrature(cuts, spans)
    vals = _evaluate(p, who, s)
    ends = _evaluate(p, who, cuts)
    names = coordinate_names
    k = np.zeros((n_joints, len(names)))
    for j, coord in enumerate(names):
        prop = _STIFFNESS_OF[coord]
        stiff = vals[..., BEAM_PROPERTIES.index(prop)]
        for where, v in ((s, stiff), (cuts, ends[:, BEAM_PROPERTIES.index(prop)])):
            _check_values(who, where, v, f"{prop} (needed by {coord!r})", strict=True)
        flex = np.bincount(joint, weights=np.sum(w / stiff, axis=1), minlength=n_joints)
        if coord in ("shear_y", "shear_z"):
            k[:, j] = 3.0 * np.diff(spans) / flex / l**3  # 3 EI / l^3 with the span's harmonic-mean EI
            if clamped:
                k[0, j] *= 2.0
        else:
            k[:, j] = 1.0 / flex
    com = np.zeros((N, 3))
    com[:, 0] = c
    return {"mass": m, "inertia": moments, "com": com, "stiffness": k}


def _evaluate(profile, who: str, s: np.ndarray) -> np.ndarray:
    try:
        vals = profile.evaluate(s.ravel())
    except ModelError as exc:
        raise ModelError(f"{who}: profile {profile.name!r}: {exc}") from exc
    return vals.reshape(*s.shape, len(BEAM_PROPERTIES))


def _check_values(who: str, s, values, what: str, strict: bool):
    bad = ~np.isfinite(values) | ((values <= 0) if strict else (values < 0))
    if np.any(bad):
        i = np.flatnonzero(bad.ravel())[0]
        raise ModelError(f"{who}: {what} must be finite and {'>' if strict else '>='} 0 along the "
                         f"body, got {float(values.ravel()[i]):.6g} at s = {float(s.ravel()[i]):.6g} m")
