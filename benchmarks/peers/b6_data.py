"""B6 damped (the flexible slider-crank) as plain numbers, for the Exudyn peer script.

Runs in flexmb's venv: the numbers are read from flexmb's own model of
``scenes.b6(damped=True, n_segments=N)`` (segment mass data, joint springs
and dampers, the driver, the consistent initial state of
:func:`flexmb.initial_state`) and written to a small JSON file that
``exudyn_b6.py`` reads in the peers' venv (which has no flexmb)::

    python benchmarks/peers/b6_data.py --n 8 --out /tmp/b6_N8.json

:func:`initial_bodies` turns those joint coordinates into the bodies' planar
states; it needs numpy only, so that the peer script imports it from here.
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


def initial_bodies(d: dict):
    """Planar positions and velocities of crank, segments and slider from flexmb's joint coordinates.

    Parameters
    ----------
    d : dict
        The data of ``b6_data.py``.

    Returns
    -------
    list of tuple
        ``(x, y, phi, vx, vy, omega)`` of the crank's and each segment's mass
        centre, then ``(x, y, 0, vx, vy, 0)`` of the slider.
    """
    names, x, xd = d["coordinate_names"], np.asarray(d["x0"]), np.asarray(d["xd0"])
    at = {name: i for i, name in enumerate(names)}
    n, l, r = d["n_segments"], d["segment_length"], d["crank_length"]
    th, w = x[at["crank_pin.angle"]], xd[at["crank_pin.angle"]]
    out = []

    def unit(a):
        return np.array([np.cos(a), np.sin(a)])

    def perp(a):
        return np.array([-np.sin(a), np.cos(a)])

    c, v = d["crank_com"] * unit(th), d["crank_com"] * w * perp(th)
    out.append((*c, th, *v, w))
    p, vp = r * unit(th), r * w * perp(th)  # crank tip: the rod's first end
    a, wa = th + x[at["rod_pin.angle"]], w + xd[at["rod_pin.angle"]]
    for j in range(n):
        if j > 0:
            a += x[at[f"rod.j{j}.bend_z"]]
            wa += xd[at[f"rod.j{j}.bend_z"]]
        c, v = p + d["segment_com"] * unit(a), vp + d["segment_com"] * wa * perp(a)
        out.append((*c, a, *v, wa))
        p, vp = p + l * unit(a), vp + l * wa * perp(a)
    s, sd = x[at["rail.slide"]], xd[at["rail.slide"]]
    out.append((s, 0.0, 0.0, sd, 0.0, 0.0))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, required=True)
    ap.add_argument("--out", required=True)
    a = ap.parse_args(argv)
    with open(a.out, "w") as fh:
        json.dump(b6_data(a.n), fh, indent=1)


if __name__ == "__main__":
    main()
