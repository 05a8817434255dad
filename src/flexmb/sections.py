"""Beam cross-sections and materials for flexible bodies."""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from ._validate import label, name_check, positive
from .errors import ModelError

__all__ = ["Section", "Material", "BeamProfile", "BEAM_PROPERTIES"]


def _non_negative(instance, attribute, value):
    if not np.isfinite(value) or value < 0:
        raise ModelError(f"{label(instance)}: {attribute.name} must be finite and >= 0, got {value!r}")


@frozen(eq=False)
class Section:
    """Cross-section properties of a beam (beam axis along the body x axis).

    Parameters
    ----------
    area : float
        A, m^2.
    Iy : float
        Second moment about the section's y axis (bending in the x-z plane), m^4.
    Iz : float
        Second moment about the section's z axis (bending in the x-y plane), m^4.
    J : float
        Torsion constant (Saint-Venant), m^4.
    Ip : float, optional
        Polar second moment ``Iy + Iz`` (for the segments' rotary inertia), m^4.
    c_y, c_z : float
        Outer-fibre distances along y and z, m (for stresses).
    name : str
        Label for messages.
    kind : str
        ``"rectangular"``, ``"circular"``, ``"tube"`` or ``"general"``.

    Examples
    --------
    >>> from flexmb import Section
    >>> s = Section.rectangular(0.02, 0.005)
    >>> round(s.Iy * 1e12, 6)
    208.333333
    """

    area: float = field(converter=float, validator=positive)
    Iy: float = field(converter=float, validator=positive)
    Iz: float = field(converter=float, validator=positive)
    J: float = field(converter=float, validator=positive)
    Ip: float | None = field(default=None)
    c_y: float = field(default=0.0, converter=float, validator=_non_negative)
    c_z: float = field(default=0.0, converter=float, validator=_non_negative)
    name: str = field(default="section", validator=name_check)
    kind: str = field(default="general")

    @property
    def polar(self) -> float:
        """Polar second moment (``Ip`` or ``Iy + Iz``), m^4."""
        return self.Iy + self.Iz if self.Ip is None else float(self.Ip)

    @classmethod
    def rectangular(cls, b: float, h: float) -> "Section":
        """Solid rectangle, width b along y and thickness h along z.

        Parameters
        ----------
        b, h : float
            Width and thickness, m.

        Returns
        -------
        Section
            ``A = b h``, ``Iy = b h^3/12``, ``Iz = h b^3/12`` and the torsion
            constant ``J = b t^3 (1/3 - 0.21 (t/w)(1 - (t/w)^4/12))`` with
            t = min(b, h), w = max(b, h) (Roark).
        """
        if not (b > 0 and h > 0):
            raise ModelError(f"Section.rectangular: b and h must be > 0, got b={b!r}, h={h!r}")
        t, w = min(b, h), max(b, h)
        r = t / w
        J = w * t**3 * (1.0 / 3.0 - 0.21 * r * (1.0 - r**4 / 12.0))
        return cls(b * h, b * h**3 / 12.0, h * b**3 / 12.0, J, None, b / 2, h / 2, f"rect {b}x{h}", "rectangular")

    @classmethod
    def circular(cls, d: float) -> "Section":
        """Solid circle of diameter d: ``J = Ip = pi d^4 / 32``.

        Parameters
        ----------
        d : float
            Diameter, m.

        Returns
        -------
        Section
            ``A = pi d^2 / 4``, ``Iy = Iz = pi d^4 / 64`` and
            ``J = Ip = pi d^4 / 32``.

        Raises
        ------
        ModelError
            If ``d <= 0``.
        """
        if not d > 0:
            raise ModelError(f"Section.circular: d must be > 0, got {d!r}")
        I = np.pi * d**4 / 64.0
        return cls(np.pi * d * d / 4.0, I, I, 2 * I, 2 * I, d / 2, d / 2, f"circle {d}", "circular")

    @classmethod
    def tube(cls, d_out: float, d_in: float) -> "Section":
        """Circular tube.

        Parameters
        ----------
        d_out, d_in : float
            Outer and inner diameters, m (``d_in = 0`` gives a solid circle).

        Returns
        -------
        Section
            ``A = pi (d_out^2 - d_in^2) / 4``,
            ``Iy = Iz = pi (d_out^4 - d_in^4) / 64`` and ``J = Ip = Iy + Iz``.

        Raises
        ------
        ModelError
            Unless ``d_out > d_in >= 0``.
        """
        if not (d_out > d_in >= 0):
            raise ModelError(f"Section.tube: need d_out > d_in >= 0, got {d_out!r}, {d_in!r}")
        I = np.pi * (d_out**4 - d_in**4) / 64.0
        A = np.pi * (d_out**2 - d_in**2) / 4.0
        return cls(A, I, I, 2 * I, 2 * I, d_out / 2, d_out / 2, f"tube {d_out}/{d_in}", "tube")

    def torsion_modulus(self) -> float:
        """Torsional section modulus W_t, m^3: the largest shear stress is ``T / W_t``.

        Returns
        -------
        float
            * circle: ``J / r`` (``tau = T r / J``, r = d / 2);
            * tube: ``J / r_o`` (``tau = T r_o / J``, outer radius);
            * rectangle, long side w and short side t:
              ``alpha w t^2`` with ``alpha = 1 / (3 + 1.8 t / w)``, i.e.
              ``tau = T (3 w + 1.8 t) / (w^2 t^2)`` (Roark's formulas,
              Young & Budynas, Table 10.1; alpha = 0.208 for a square,
              1/3 for a thin strip), the stress at the middle of the long
              sides;
            * general: ``J / max(c_y, c_z)``, exact only for circles.

        Raises
        ------
        ModelError
            If the outer-fibre distances are not given.
        """
        c = max(self.c_y, self.c_z)
        if not c > 0:
            raise ModelError(f"{label(self)}: no outer-fibre distances c_y, c_z (needed for stresses)")
        if self.kind == "rectangular":
            w, t = 2.0 * c, 2.0 * min(self.c_y, self.c_z)
            return w * w * t * t / (3.0 * w + 1.8 * t)
        return self.J / c


@frozen(eq=False)
class Material:
    """Linear elastic isotropic material.

    Parameters
    ----------
    E : float
        Young's modulus, Pa.
    density : float
        Density, kg/m^3.
    nu : float, optional
        Poisson's ratio (gives ``G = E / (2 (1 + nu))``).
    G : float, optional
        Shear modulus, Pa (overrides ``nu``).
    name : str
        Label.

    Examples
    --------
    >>> import flexmb as fm
    >>> steel = fm.Material(210e9, 7850.0, nu=0.3, name="steel")
    >>> round(steel.G / 1e9, 4)  # E / (2 (1 + nu)), GPa
    80.7692
    >>> fm.Material.aluminium().E
    70000000000.0
    """

    E: float = field(converter=float, validator=positive)
    density: float = field(converter=float, validator=positive)
    nu: float | None = field(default=0.3)
    G_: float | None = field(default=None, alias="G")
    name: str = field(default="material", validator=name_check)

    def __attrs_post_init__(self):
        if self.G_ is None and (self.nu is None or not -1.0 < float(self.nu) < 0.5):
            raise ModelError(f"{label(self)}: Poisson's ratio must be in (-1, 0.5), got {self.nu!r}")
        if self.G_ is not None and not float(self.G_) > 0:
            raise ModelError(f"{label(self)}: G must be > 0, got {self.G_!r}")

    @property
    def G(self) -> float:
        """Shear modulus, Pa."""
        return float(self.G_) if self.G_ is not None else self.E / (2.0 * (1.0 + float(self.nu)))

    @classmethod
    def aluminium(cls) -> "Material":
        """E = 70 GPa, nu = 0.33, rho = 2700 kg/m^3 (benchmark B1)."""
        return cls(70e9, 2700.0, 0.33, name="aluminium")

    @classmethod
    def steel(cls) -> "Material":
        """E = 210 GPa, nu = 0.3, rho = 7850 kg/m^3."""
        return cls(210e9, 7850.0, 0.3, name="steel")


#: the beam properties a :class:`BeamProfile` gives per unit length, in this order:
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
