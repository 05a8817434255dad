"""Beam cross-sections and materials for flexible bodies."""

from __future__ import annotations

import numpy as np
from attrs import field, frozen

from ._validate import name_check, number, positive_value
from .errors import ModelError
from .fields import as_float, finite_number, label, positive

__all__ = ["Section", "Material"]


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

    area: float = field(converter=as_float, validator=[finite_number, positive])
    Iy: float = field(converter=as_float, validator=[finite_number, positive])
    Iz: float = field(converter=as_float, validator=[finite_number, positive])
    J: float = field(converter=as_float, validator=[finite_number, positive])
    Ip: float | None = field(default=None)
    c_y: float = field(default=0.0, converter=as_float, validator=[finite_number, _non_negative])
    c_z: float = field(default=0.0, converter=as_float, validator=[finite_number, _non_negative])
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
        # numpy floats: a product beyond the largest float is inf (refused by the fields), not an OverflowError
        b, h = (np.float64(positive_value("Section.rectangular", what, v)) for what, v in (("b", b), ("h", h)))
        t, w = min(b, h), max(b, h)
        r = t / w
        J = w * t * t * t * (1.0 / 3.0 - 0.21 * r * (1.0 - r**4 / 12.0))
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
        d = np.float64(positive_value("Section.circular", "d", d))
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
        d_out = np.float64(positive_value("Section.tube", "d_out", d_out))
        d_in = np.float64(number("Section.tube", "d_in", d_in, minimum=0.0, strict=False))
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

    E: float = field(converter=as_float, validator=[finite_number, positive])
    density: float = field(converter=as_float, validator=[finite_number, positive])
    nu: float | None = field(default=0.3)
    G_: float | None = field(default=None, alias="G")
    name: str = field(default="material", validator=name_check)

    def __attrs_post_init__(self):
        if self.G_ is None and (self.nu is None or not -1.0 < number(label(self), "nu", self.nu) < 0.5):
            raise ModelError(f"{label(self)}: Poisson's ratio must be in (-1, 0.5), got {self.nu!r}")
        if self.G_ is not None:
            number(label(self), "G", self.G_, minimum=0.0)

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
