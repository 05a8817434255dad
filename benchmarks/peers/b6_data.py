"""B6 damped (the flexible slider-crank) as plain numbers, for the Exudyn peer script.

Runs in flexmb's venv: the numbers are read from flexmb's own model of
``scenes.b6(damped=True, n_segments=N)`` (segment mass data, joint springs
and dampers, the driver, the consistent initial state of
:func:`flexmb.initial_state`) and written to a small JSON file that
``exudyn_b6.py`` reads in the peers' venv (which has no flexmb)::

    python benchmarks/peers/b6_data.py --n 8 --out /tmp/b6_N8.json
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))


def b6_data(n: int) -> dict:
    """The discrete B6 damped model with ``n`` segments, as JSON-ready numbers.

    Parameters
    ----------
    n : int
        Number of rod segments N (>= 2).

    Returns
    -------
    dict
        ``n_segments``; ``crank_length``, ``crank_mass``, ``crank_inertia``
        (central, about z) and ``crank_com`` (distance of the mass centre from
        the ground pin along the crank); ``segment_length``,
        ``segment_mass``, ``segment_inertia`` (central, about z),
        ``segment_com`` (from the segment's first end); ``k`` and ``c``
        (N - 1 elastic joints: rotational springs, N m/rad, and dampers,
        N m s/rad); ``slider_mass``; ``speed`` (the driver's rate, rad/s:
        crank angle = speed t, ``Driver.constant_speed``); ``coordinate_names``
        with ``x0`` and ``xd0``, flexmb's consistent initial coordinates and
        speeds (``initial_state``, minimum-norm speeds).
    """
    import flexmb as fm
    import scenes

    model, positions = scenes.b6(damped=True, n_segments=n)
    system = model.build()
    rod = next(b for b in model.bodies if b.name == "rod")
    crank = next(b for b in model.bodies if b.name == "crank")
    slider = next(b for b in model.bodies if b.name == "slider")
    motor = next(d for d in model.drivers if d.name == "motor")
    m, inertia, com = rod.segment_mass_properties(0)
    k = rod.joint_stiffness()[:, 0]
    x0, xd0 = fm.initial_state(system, positions=positions)
    return {
        "n_segments": int(n),
        "crank_length": float(scenes.B6_R), "crank_mass": float(crank.mass),
        "crank_inertia": float(np.asarray(crank.inertia)[2, 2]) if np.ndim(crank.inertia) == 2
        else float(np.asarray(crank.inertia)[2]),
        "crank_com": float(np.asarray(crank.com)[0]),
        "segment_length": float(rod.segment_length), "segment_mass": float(m),
        "segment_inertia": float(inertia[2, 2]), "segment_com": float(com[0]),
        "k": k.tolist(), "c": (rod.damping * k).tolist(),
        "slider_mass": float(slider.mass),
        "speed": float(motor.velocity(0.0)),
        "coordinate_names": list(system.coordinate_names), "x0": np.asarray(x0).tolist(),
        "xd0": np.asarray(xd0).tolist(),
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, required=True)
    ap.add_argument("--out", required=True)
    a = ap.parse_args(argv)
    with open(a.out, "w") as fh:
        json.dump(b6_data(a.n), fh, indent=1)


if __name__ == "__main__":
    main()
