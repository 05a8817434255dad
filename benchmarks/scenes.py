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
