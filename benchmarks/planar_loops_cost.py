"""One right-hand side of the planar loops (B6 damped, B7) on the planar path against the spatial one (issue 28).

    OPENBLAS_NUM_THREADS=1 python benchmarks/planar_loops_cost.py
    OPENBLAS_NUM_THREADS=1 python benchmarks/planar_loops_cost.py --b6 8 32 --b7 64 --repeat 7

Each model is built twice, on the planar path (the default for a planar
model) and with ``planar=False``, and :func:`flexmb.kernels.loops.loop_rhs_into`
(the dispatch that ``System.state_rate``, the compiled CVODE callback
and generalized-alpha's loop call) is timed in a compiled loop at one
random state, with one work array for all the calls as the C callback
makes them: ``--repeat`` alternating rounds (planar, spatial, planar, ...),
each the CPU time of enough calls for ~0.2 s; a path's cost is its least
per call over the rounds. One JSON line per model and N goes to ``--out``
(``benchmarks/results/planar_loops_s11.jsonl``, appended).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np
from numba import njit

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import scenes  # noqa: E402
from flexmb.kernels.loops import loop_rhs_into, loop_rhs_work_size  # noqa: E402


@njit
def _calls(packed, layout, y, n, gamma_d, tol, window, rank_limit, reps):
    """``reps`` calls of loop_rhs_into as the C callback makes them; returns a sum (so nothing is left out)."""
    nb, m = layout.root_of.shape[0], layout.row_coord.shape[0]
    zeros = np.zeros((nb + 1, 3))
    work, xdd, lam, generalized0 = np.empty(loop_rhs_work_size(nb, n, m)), np.empty(n), np.empty(m), np.zeros(n)
    s = 0.0
    for _ in range(reps):
        loop_rhs_into(packed, layout, y, n, np.zeros(0), zeros, zeros, generalized0, gamma_d, tol, window,
                      rank_limit, xdd, lam, work)
        s += xdd[0]
    return s


def _args(system, y):
    gamma_d = np.zeros(len(system.constraints.drivers))
    return (system._packed, system._loop_layout, y, system.n_speeds, gamma_d, system._loop_tol, 0.0, -1)


def measure(scene, n_seg, repeat):
    """Least CPU time per call of each path, in s, and the calls per round."""
    model = scenes.b6(damped=True, n_segments=n_seg)[0] if scene == "B6" else scenes.b7(n_seg)[0]
    systems = {"planar": model.build(complement="articulated"),
               "spatial": model.build(complement="articulated", planar=False)}
    assert systems["planar"].planar and not systems["spatial"].planar
    n = systems["planar"].n_speeds
    rng = np.random.default_rng(0)
    y = np.concatenate([rng.normal(0.0, 0.1, n), rng.normal(0.0, 1.0, n)])
    args = {k: _args(s, y) for k, s in systems.items()}
    for a in args.values():
        _calls(*a, 1)
    t0 = time.process_time()
    _calls(*args["spatial"], 10)
    reps = max(5, int(0.2 / max((time.process_time() - t0) / 10, 1e-7)))
    best = {k: np.inf for k in args}
    for _ in range(repeat):
        for k, a in args.items():
            t0 = time.process_time()
            _calls(*a, reps)
            best[k] = min(best[k], (time.process_time() - t0) / reps)
    return best, reps, n, systems["planar"].n_constraints


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--b6", type=int, nargs="*", default=[8, 32, 128, 512], help="B6 damped: the rod's segments")
    ap.add_argument("--b7", type=int, nargs="*", default=[64, 128, 256, 512, 1024], help="B7: its loops")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", default=os.path.join(HERE, "results", "planar_loops_s11.jsonl"))
    args = ap.parse_args(argv)
    load = os.getloadavg()[0]
    with open(args.out, "a") as fh:
        for scene, ns in (("B6", args.b6), ("B7", args.b7)):
            for n_seg in ns:
                best, reps, n, m = measure(scene, n_seg, args.repeat)
                row = dict(bench="planar_loops_rhs", scene=scene, N=n_seg, n=n, m=m, planar_us=best["planar"] * 1e6,
                           spatial_us=best["spatial"] * 1e6, ratio=best["spatial"] / best["planar"], calls=reps,
                           repeat=args.repeat, load=load, time=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()))
                print(json.dumps(row), flush=True)
                fh.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
