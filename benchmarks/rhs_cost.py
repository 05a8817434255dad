"""CPU cost of one right-hand side (System.state_rate, what the integrators call) of the benchmark scenes, per N.

    OPENBLAS_NUM_THREADS=1 python benchmarks/rhs_cost.py --scene B1 --n 8 16 64
    OPENBLAS_NUM_THREADS=1 python benchmarks/rhs_cost.py --scene B7 --n 4 16 64 --complement qr

B1 and B2 are timed at a small random state; the closed-loop scenes (B6
damped, N = the rod's segments; B7, N = its loops; the wiper) at their
assembled initial state. ``--complement`` is the orthogonal complement
strategy the system is built with (``Model.build(complement=...)``).

CPU time (process_time) per call over many calls, after a warm-up call
(the kernels compiled or loaded from the cache): the figure that explains a
wall time together with the number of right-hand sides an integrator needs.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import scenes  # noqa: E402


def cost(fn, calls):
    fn()
    t = time.process_time()
    for _ in range(calls):
        fn()
    return (time.process_time() - t) / calls


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", choices=["B1", "B2", "B6", "B7", "wiper"], default="B1",
                   help="B6: the damped flexible slider-crank (N = the rod's segments); B7: the chain of N "
                        "parallelogram four-bars (N = its loops); wiper: the main job's flexible wiper (closed "
                        "loops, a friction plugin; N = its segments)")
    p.add_argument("--n", type=int, nargs="+", default=[8, 16, 64])
    p.add_argument("--calls", type=int, default=5000)
    p.add_argument("--complement", default="svd",
                   help="orthogonal complement strategy: svd, eigen, qr, auto or a plugin's name (default svd)")
    a = p.parse_args(argv)
    for n in a.n:
        if a.scene in ("B6", "B7", "wiper"):
            from flexmb import initial_state

            if a.scene == "B6":
                model, initial = scenes.b6(True, n)
                initial = {"positions": initial}
            elif a.scene == "B7":
                model, initial = scenes.b7(n)
            else:
                from flexmb.scenes.wiper import WiperOptions, wiper

                model, positions = wiper(WiperOptions(flexible=True, n_segments=n))
                initial = {"positions": positions}
            system = model.build(complement=a.complement)
            x, xd = initial_state(system, 0.0, **initial)
        else:
            system = getattr(scenes, a.scene.lower())(n).build(complement=a.complement)
            rng = np.random.default_rng(0)
            x, xd = 0.01 * rng.normal(size=system.n_coords), 0.01 * rng.normal(size=system.n_coords)
        y = np.concatenate([x, xd])
        row = {"tool": "flexmb", "scene": a.scene, "n_segments": n, "n_coords": system.n_coords,
               "n_constraints": system.n_constraints, "complement": a.complement,
               "rhs_cpu_us": 1e6 * cost(lambda: system.state_rate(0.0, y), a.calls),
               "kinematics_cpu_us": 1e6 * cost(lambda: system.kinematics(0.0, x, xd), a.calls),
               "load_avg_1min": os.getloadavg()[0]}
        print(json.dumps(row))


if __name__ == "__main__":
    main()
