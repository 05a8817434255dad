"""The finite-segment beam of BENCHMARKS.md as plain numbers, for the peer scripts.

Written from BENCHMARKS.md alone (no flexmb import: the peers run in their
own virtual environment). Used by ``exudyn_beam.py`` and ``pydy_beam.py``.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np

L, B, H = 1.0, 0.02, 0.005
E, NU, RHO = 70e9, 0.33, 2700.0
BETA = 7.7398e-4  # s, 1 % of critical in the first bending mode
TIP_MASS, TIP_OFFSET = 0.05, np.array([0.0, 0.02, 0.0])  # B2: at (L, 0.02, 0) in the straight state
GRAVITY = {"B1": np.array([0.0, 0.0, -9.81]), "B2": 9.81 * np.array([0.0, -0.6, -0.8])}
#: kept angles per scene: 0 = Rx (torsion), 1 = Ry (bending in x-z), 2 = Rz (bending in x-y)
AXES = {"B1": (1,), "B2": (0, 1, 2)}


def beam(scene: str, n: int, damped: bool = True) -> dict:
    """Segment mass properties and joint springs of scene B1 or B2 with N segments.

    Returns
    -------
    dict
        ``l`` segment length, ``m`` segment mass, ``inertia`` (3,) central
        principal moments of a block segment, ``com`` (3,) its mass centre in
        the segment frame, ``axes`` kept rotation axes, ``k`` and ``c`` (n, len(axes))
        spring and damper constants (clamp joint 2k), ``gravity`` (3,),
        ``tip_mass`` and ``tip_point`` (in the last segment's frame) for B2.
    """
    A, Iy, Iz = B * H, B * H**3 / 12, H * B**3 / 12
    r = H / B
    J = B * H**3 * (1 / 3 - 0.21 * r * (1 - r**4 / 12))
    G = E / (2 * (1 + NU))
    l = L / n
    m = RHO * A * l
    inertia = np.array([m * (B**2 + H**2) / 12, m * (l**2 + H**2) / 12, m * (l**2 + B**2) / 12])
    per_axis = np.array([G * J, E * Iy, E * Iz]) / l
    axes = AXES[scene]
    k = np.tile(per_axis[list(axes)], (n, 1))
    k[0] *= 2.0
    c = BETA * k if damped else 0.0 * k
    out = {"l": l, "m": m, "inertia": inertia, "com": np.array([l / 2, 0.0, 0.0]), "axes": axes, "k": k, "c": c,
           "gravity": GRAVITY[scene], "tip_mass": 0.0, "tip_point": np.array([l, 0.0, 0.0])}
    if scene == "B2":
        out["tip_mass"] = TIP_MASS
        out["tip_point"] = np.array([l, 0.0, 0.0]) + TIP_OFFSET
    return out


def emit(row: dict) -> None:
    """Print one JSON line (the protocol between compare.py and the peer scripts)."""
    sys.stdout.write(json.dumps(row) + "\n")
    sys.stdout.flush()


def row(tool: str, scene: str, n: int, **kw) -> dict:
    """A result row with every BENCHMARKS.md field, and OPENBLAS_NUM_THREADS as this process sees it."""
    base = {"tool": tool, "scene": scene, "variant": "dynamics damped", "n_segments": n,
            "n_coords": None, "n_dof": None, "integrator": None, "rtol": None, "h": None,
            "setup_s": None, "wall_s": None, "steps": None, "rhs_evals": None, "jac_evals": None,
            "error": None, "error_kind": "integration", "reference": None,
            "openblas_num_threads": os.environ.get("OPENBLAS_NUM_THREADS")}
    base.update(kw)
    return base
