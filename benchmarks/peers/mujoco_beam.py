"""MuJoCo peer: the finite-segment beam of B1 / B2 as a chain of MJCF bodies with hinge joints.

Each segment is a body at the end of its inner neighbour (``pos = (l, 0, 0)``;
the first at the clamp) carrying one hinge per kept angle, declared in the
order x, y, z: MuJoCo composes the joints of a body in declaration order
about the already-turned axes, which is the Rx Ry Rz sequence about moving
axes of BENCHMARKS.md. The springs and dampers are the hinges' own
``stiffness`` (``springref = 0``) and ``damping``; the block's mass
properties are an explicit ``<inertial>``; B2's tip mass is merged into the
last segment's inertial (``fullinertia``, parallel-axis theorem); gravity
is the model option. No geoms, so no contacts. MuJoCo integrates with
fixed steps; tuned as its documentation allows: the time step and the
integrator, RK4 (its accurate explicit integrator), ``implicitfast`` (its
recommended default, implicit in the damping) or ``implicit`` (also the
Coriolis and centripetal terms), ``Euler`` (semi-implicit).
``--configs INTEGRATOR:STEPS ...`` runs just those pairs instead of the
grid ``--integrator`` x ``--steps``.

Prints one JSON line per configuration (least wall time of ``--repeat``
rounds), like ``exudyn_beam.py``. Run in the peers' venv::

    /work/venv-peers/bin/python benchmarks/peers/mujoco_beam.py --scene B1 --n 8 --steps 20000 40000
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from beam_data import beam, emit, row  # noqa: E402
from rounds import drive  # noqa: E402


def _merge_tip(m, inertia, com, tip_mass, tip_point):
    I = np.diag(inertia)
    if tip_mass == 0.0:
        return m, I, com
    M = m + tip_mass
    c = (m * com + tip_mass * tip_point) / M

    def shift(mass, d):
        return mass * (d @ d * np.eye(3) - np.outer(d, d))

    return M, I + shift(m, com - c) + shift(tip_mass, tip_point - c), c


def mjcf(scene: str, n: int, h: float, integrator: str = "RK4") -> str:
    """The MJCF text of scene B1 or B2 with N segments and time step h."""
    d = beam(scene, n)
    g = " ".join(f"{v:.17g}" for v in d["gravity"])
    names = "xyz"
    out = [f'<mujoco model="{scene} N={n}">',
           f'  <option timestep="{h:.17g}" gravity="{g}" integrator="{integrator}"/>',
           "  <worldbody>"]
    for i in range(n):
        pos = "0 0 0" if i == 0 else f"{d['l']:.17g} 0 0"
        out.append("  " * (i + 2) + f'<body name="s{i}" pos="{pos}">')
        for j, a in enumerate(d["axes"]):
            axis = " ".join("1" if a == q else "0" for q in range(3))
            out.append("  " * (i + 3) + f'<joint name="j{i}{names[a]}" type="hinge" axis="{axis}" pos="0 0 0" '
                       f'stiffness="{d["k"][i, j]:.17g}" damping="{d["c"][i, j]:.17g}" springref="0"/>')
        tip = (d["tip_mass"], d["tip_point"]) if i == n - 1 else (0.0, d["tip_point"])
        M, I, c = _merge_tip(d["m"], d["inertia"], d["com"], *tip)
        full = " ".join(f"{v:.17g}" for v in (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]))
        out.append("  " * (i + 3) + f'<inertial pos="{" ".join(f"{v:.17g}" for v in c)}" mass="{M:.17g}" '
                   f'fullinertia="{full}"/>')
        if i == n - 1:
            p = " ".join(f"{v:.17g}" for v in d["tip_point"])
            out.append("  " * (i + 3) + f'<site name="tip" pos="{p}"/>')
    for i in reversed(range(n)):
        out.append("  " * (i + 2) + "</body>")
    out += ["  </worldbody>", "</mujoco>"]
    return "\n".join(out)


def run(scene: str, n: int, steps: int, t_end: float = 1.0, integrator: str = "RK4"):
    """One simulation: (setup_s, wall_s, cpu_s, tip position at t_end, n_coords, finite)."""
    import mujoco

    t0 = time.perf_counter()
    model = mujoco.MjModel.from_xml_string(mjcf(scene, n, t_end / steps, integrator))
    data = mujoco.MjData(model)
    setup = time.perf_counter() - t0
    t0, c0 = time.perf_counter(), time.process_time()
    step = mujoco.mj_step
    for _ in range(steps):
        step(model, data)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    tip = np.array(data.site("tip").xpos, float)
    # MuJoCo resets the state when the accelerations blow up (an unstable step): count that as a failure
    reset = data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0
    return setup, wall, cpu, tip, model.nq, bool(np.all(np.isfinite(data.qpos))) and not reset


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="B1", choices=["B1", "B2"])
    ap.add_argument("--n", type=int, nargs="+", default=[8])
    ap.add_argument("--steps", type=int, nargs="+", default=[2000, 4000, 8000, 16000, 32000, 64000])
    ap.add_argument("--integrator", nargs="+", default=["RK4"], help="RK4, implicitfast, implicit, Euler")
    ap.add_argument("--configs", nargs="+", help="INTEGRATOR:STEPS pairs to run instead of the grid")
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--repeat", type=int, default=3,
                    help="rounds (each runs every configuration once); the least wall time is reported")
    ap.add_argument("--reference", type=float, nargs="*")
    ap.add_argument("--reference-label", default="")
    ap.add_argument("--rounds-from-stdin", action="store_true",
                    help="driven by compare.py: one round per line 'round' on stdin, one JSON row per run")
    args = ap.parse_args(argv)
    import mujoco

    if args.configs:
        pairs = [(c.split(":")[0], int(c.split(":")[1])) for c in args.configs]
    else:
        pairs = [(integ, steps) for integ in args.integrator for steps in args.steps]
    configs = [(n, integ, steps) for n in args.n for integ, steps in pairs]
    failed = set()

    def run_round(r):
        rows = []
        for n, integ, steps in configs:
            if (n, integ, steps) in failed:  # an unstable step size stays unstable: not repeated
                continue
            s, w, cpu, tip, nq, finite = run(args.scene, n, steps, args.t_end, integ)
            err = float(np.linalg.norm(tip - np.asarray(args.reference))) if args.reference and finite else None
            rows.append(row("mujoco", args.scene, n, n_coords=nq, n_dof=nq, integrator=f"mujoco {integ}",
                            h=args.t_end / steps, setup_s=s, wall_s=w, cpu_s=cpu, steps=steps,
                            rhs_evals=steps * (4 if integ == "RK4" else 1), jac_evals=None, error=err,
                            reference=args.reference_label or None, output=tip.tolist() if finite else None,
                            status="finished" if finite else "failed: unstable step (state reset or non-finite)",
                            version=mujoco.__version__, t_end=args.t_end))
            if not finite:
                failed.add((n, integ, steps))
        return rows

    drive(run_round, args.repeat, args.rounds_from_stdin, emit)

if __name__ == "__main__":
    main()
