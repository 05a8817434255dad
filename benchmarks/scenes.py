"""Benchmark scenes of BENCHMARKS.md, built with flexmb's public API."""

from __future__ import annotations

import numpy as np

import flexmb as fm

B1_L, B1_B, B1_H = 1.0, 0.02, 0.005
B1_BETA = 7.7398e-4  # 1 % of critical in the first bending mode


def b1_material():
    """Aluminium of B1: E = 70 GPa, nu = 0.33, rho = 2700 kg/m^3."""
    return fm.Material(70e9, 2700.0, 0.33, name="aluminium")


def b1(n_segments: int, gravity: bool = True, damped: bool = True) -> fm.Model:
    """B1: planar cantilever, bending in the x-z plane only (one coordinate per segment)."""
    model = fm.Model(f"B1 N={n_segments}")
    beam = fm.FlexibleBody("beam", B1_L, fm.Section.rectangular(B1_B, B1_H), b1_material(), n_segments,
                           keep=("bend_y",), damping=B1_BETA if damped else 0.0)
    model.add(fm.Fixed("clamp", model.ground, beam))
    if gravity:
        model.add(fm.Gravity((0.0, 0.0, -9.81)))
    return model


def b1_reference():
    """Closed forms: Euler-Bernoulli static tip deflection (m) and f1..f3 (Hz)."""
    mat, sec = b1_material(), fm.Section.rectangular(B1_B, B1_H)
    EI, rhoA = mat.E * sec.Iy, mat.density * sec.area
    static = rhoA * 9.81 * B1_L**4 / (8 * EI)
    beta_l = np.array([1.8751041, 4.6940911, 7.8547574])
    freqs = beta_l**2 / (2 * np.pi) * np.sqrt(EI / (rhoA * B1_L**4))
    return static, freqs


def b2(n_segments: int, damped: bool = True) -> fm.Model:
    """B2: the B1 beam with torsion and both bendings, a 0.05 kg tip mass at (L, 0.02, 0), tilted gravity."""
    model = fm.Model(f"B2 N={n_segments}")
    beam = fm.FlexibleBody("beam", B1_L, fm.Section.rectangular(B1_B, B1_H), b1_material(), n_segments,
                           keep=("torsion", "bend_y", "bend_z"), damping=B1_BETA if damped else 0.0)
    tip = fm.RigidBody("tip", 0.05, (0.0, 0.0, 0.0), (0.0, 0.02, 0.0))
    model.add(fm.Fixed("clamp", model.ground, beam),
              fm.Fixed("tip_mount", beam, tip, parent_point=(B1_L, 0.0, 0.0)),
              fm.Gravity((0.0, -0.6 * 9.81, -0.8 * 9.81)))
    return model


B6_R, B6_L, B6_B, B6_H = 0.1, 0.4, 0.02, 0.005
B6_CRANK_MASS, B6_SLIDER_MASS = 0.5, 0.3
B6_SPEED = 2 * np.pi * 5.0  # 5 rev/s
B6_ZETA = 0.02  # damped variant: 2 % of critical in the rod's first bending mode


def b6_rod_frequency() -> float:
    """First in-plane bending frequency of the B6 rod, Hz: Euler-Bernoulli, pinned at both ends.

    In the mechanism both rod ends are held transversally (the crank tip is
    driven, the slider runs on its rail), so the first bending mode is the
    pinned-pinned one, f1 = (pi / L)^2 sqrt(E I_z / (rho A)) / (2 pi).
    """
    mat, sec = fm.Material.steel(), fm.Section.rectangular(B6_B, B6_H)
    return (np.pi / B6_L) ** 2 * np.sqrt(mat.E * sec.Iz / (mat.density * sec.area)) / (2 * np.pi)


def b6(damped: bool = False, n_segments: int = 8):
    """B6: planar slider-crank with a flexible steel rod, crank driven at 5 rev/s from rest, no gravity.

    Crank: slender bar r = 0.1 m, 0.5 kg, pinned to the ground at the origin
    about z. Rod: steel, L = 0.4 m, b = 0.02 m in the mechanism plane by
    h = 0.005 m, ``n_segments`` segments bending in the plane only
    (``bend_z``), pinned (not clamped) to the crank tip; its last end is
    pinned to the slider by the cut joint that closes the loop. Slider:
    0.3 kg block on a rail along x, starting at x = r + L. Damped variant:
    stiffness-proportional, 2 % of critical in the rod's first (pinned-pinned)
    bending mode.

    Returns
    -------
    model : Model
        The mechanism, with the driver ``"motor"`` on the crank pin.
    initial : dict
        Initial coordinates: everything straight, slider at r + L (the
        speeds are then made consistent with the driver by ``simulate``).
    """
    model = fm.Model(f"B6 {'damped' if damped else 'undamped'} N={n_segments}")
    crank = fm.RigidBody.slender_bar("crank", B6_CRANK_MASS, B6_R)
    rod = fm.FlexibleBody.uniform_beam("rod", B6_L, fm.Section.rectangular(B6_B, B6_H), fm.Material.steel(),
                                       n_segments, keep=("bend_z",), damping_ratio=B6_ZETA if damped else 0.0,
                                       frequency=b6_rod_frequency(), clamped=False)
    slider = fm.RigidBody.box("slider", B6_SLIDER_MASS, (0.04, 0.02, 0.02))
    pin = fm.Revolute("crank_pin", model.ground, crank)
    model.add(pin,
              fm.Revolute("rod_pin", crank, rod, parent_point=(B6_R, 0.0, 0.0)),
              fm.Prismatic("rail", model.ground, slider, axis=(1.0, 0.0, 0.0)),
              fm.PlanarRevolute("slider_pin", rod, slider, parent_point=(B6_L, 0.0, 0.0), cut=True),
              fm.Driver.constant_speed("motor", pin, speed=B6_SPEED))
    return model, {"rail": B6_R + B6_L}


def b6_midspan_deflection(res) -> np.ndarray:
    """Rod mid-span deflection from its chord (signed, in the plane), m, shape (nt,).

    The centre line's point at L / 2 (a segment end when N is even) minus
    its projection on the chord from the rod's first end to its last.
    """
    ends = res.shape("rod")
    a, b = ends[:, 0, :2], ends[:, -1, :2]
    n_seg = ends.shape[1] - 1
    if n_seg % 2 == 0:
        mid = ends[:, n_seg // 2, :2]
    else:
        mid = 0.5 * (ends[:, n_seg // 2, :2] + ends[:, n_seg // 2 + 1, :2])
    chord = b - a
    e = chord / np.linalg.norm(chord, axis=1)[:, None]
    d = mid - a
    return e[:, 0] * d[:, 1] - e[:, 1] * d[:, 0]
