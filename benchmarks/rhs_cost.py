"""CPU cost of one right-hand side (System.state_rate, what the integrators call) of the benchmark scenes, per N.

    OPENBLAS_NUM_THREADS=1 python benchmarks/rhs_cost.py --scene B1 --n 8 16 64
    OPENBLAS_NUM_THREADS=1 python benchmarks/rhs_cost.py --scene B7 --n 4 16 64 --complement qr
    OPENBLAS_NUM_THREADS=1 python benchmarks/rhs_cost.py --scene B1 B6 --n 512 --complement articulated --repeats 3
    OPENBLAS_NUM_THREADS=1 python benchmarks/rhs_cost.py --scene B7 --n 64 128 256 512 1024 \
        --complement articulated --repeats 3 --calls 200

B1 and B2 are timed at a small random state; the closed-loop scenes (B6
damped, N = the rod's segments; B7, N = its loops; the wiper) at their
assembled initial state, on the system as a run calibrates it (the rank of
psi and the scale of the singular-position filter judged there).
``--complement`` is the orthogonal complement strategy the system is built
with (``Model.build(complement=...)``; open trees ignore it).

CPU time (process_time) per call over many calls, after a warm-up call
(the kernels compiled or loaded from the cache): the figure that explains a
wall time together with the number of right-hand sides an integrator needs.
With ``--repeats k`` every (scene, N) is timed k times, the scenes taking
turns, and the summary gives each one's minimum, the ratio of each scene's
minimum to the first scene's at the same N, and the exponent of a
least-squares fit ``cost ~ N^p`` over the N given.
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


def build(scene, n, complement):
    """The system of a scene at N (calibrated as a run calibrates it) and its state."""
    from flexmb import initial_state
    from flexmb.simulate import _calibrated

    if scene in ("B6", "B7", "wiper"):
        if scene == "B6":
            model, initial = scenes.b6(True, n)
            initial = {"positions": initial}
        elif scene == "B7":
            model, initial = scenes.b7(n)
        else:
            from flexmb.scenes.wiper import WiperOptions, wiper

            model, positions = wiper(WiperOptions(flexible=True, n_segments=n))
            initial = {"positions": positions}
        system = model.build(complement=complement)
        x, xd = initial_state(system, 0.0, **initial)
        system = _calibrated(system, 0.0, x, xd)
    else:
        system = getattr(scenes, scene.lower())(n).build(complement=complement)
        rng = np.random.default_rng(0)
        x, xd = 0.01 * rng.normal(size=system.n_coords), 0.01 * rng.normal(size=system.n_coords)
    return system, x, xd


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", choices=["B1", "B2", "B6", "B7", "wiper"], nargs="+", default=["B1"],
                   help="B6: the damped flexible slider-crank (N = the rod's segments); B7: the chain of N "
                        "parallelogram four-bars (N = its loops); wiper: the main job's flexible wiper (closed "
                        "loops, a friction plugin; N = its segments)")
    p.add_argument("--n", type=int, nargs="+", default=[8, 16, 64])
    p.add_argument("--calls", type=int, default=5000)
    p.add_argument("--repeats", type=int, default=1, help="times each (scene, N) is timed, the scenes alternating")
    p.add_argument("--complement", default="svd",
                   help="orthogonal complement strategy: svd, eigen, qr, auto, articulated or a plugin's name "
                        "(default svd)")
    a = p.parse_args(argv)
    systems = {(scene, n): build(scene, n, a.complement) for n in a.n for scene in a.scene}
    best: dict = {}
    for _ in range(a.repeats):
        for n in a.n:
            for scene in a.scene:
                system, x, xd = systems[scene, n]
                y = np.concatenate([x, xd])
                row = {"tool": "flexmb", "scene": scene, "n_segments": n, "n_coords": system.n_coords,
                       "n_constraints": system.n_constraints, "complement": a.complement,
                       "rhs_cpu_us": 1e6 * cost(lambda: system.state_rate(0.0, y), a.calls),
                       "kinematics_cpu_us": 1e6 * cost(lambda: system.kinematics(0.0, x, xd), a.calls),
                       "load_avg_1min": os.getloadavg()[0]}
                best[scene, n] = min(best.get((scene, n), np.inf), row["rhs_cpu_us"])
                print(json.dumps(row), flush=True)
    if a.repeats > 1 or len(a.scene) > 1 or len(a.n) > 1:
        summary = {"summary": "min rhs_cpu_us over repeats", "repeats": a.repeats, "complement": a.complement,
                   "min_rhs_cpu_us": {f"{s} N={n}": best[s, n] for s in a.scene for n in a.n}}
        if len(a.scene) > 1:
            summary["ratio_to_first_scene"] = {f"{s} N={n}": best[s, n] / best[a.scene[0], n]
                                               for s in a.scene[1:] for n in a.n}
        if len(a.n) > 1:
            logn = np.log(np.asarray(a.n, dtype=float))
            summary["fitted_exponent"] = {s: float(np.polyfit(logn, np.log([best[s, n] for n in a.n]), 1)[0])
                                          for s in a.scene}
        print(json.dumps(summary))


if __name__ == "__main__":
    main()
