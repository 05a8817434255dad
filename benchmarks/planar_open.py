"""One open-tree right-hand side, planar against spatial: B1 at N = 8 and 512 (session 11, issue 31).

    OPENBLAS_NUM_THREADS=1 python benchmarks/planar_open.py --rounds 7

The same model built twice, ``build()`` (the planar path: the packed model
carries its planar data and ``open_tree_rhs_into`` dispatches to
:func:`flexmb.kernels.planar.planar_open_rhs_into`) and
``build(planar=False)`` (the spatial recursion); each right-hand side is
called as CVODE's callback calls it (``open_tree_rhs_into`` on the open
tree's buffers and a preallocated work array), in a compiled loop, at a
random planar state. Rounds alternate planar and spatial; each round's CPU
time (``time.process_time``) per call, least of ``--rounds``. The state
rates are checked equal first (relative to the largest acceleration). One
JSON line per size to ``--out`` (default
``benchmarks/results/planar_open_s11.jsonl``, appended).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np
from numba import njit

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import scenes  # noqa: E402
from flexmb.kernels.articulated import open_tree_rhs_into, rhs_work_size  # noqa: E402


@njit(cache=False)
def _loop(packed, y, nq, armature, ydot, work, reps):
    """``reps`` right-hand sides, as CVODE's callback makes them."""
    s = 0
    for _ in range(reps):
        s += open_tree_rhs_into(packed, y, nq, armature, ydot, work)
    return s


def _timed(system, y, reps):
    """CPU time per call of ``reps`` calls."""
    n = system.n_coords
    ydot, work = np.empty(2 * n), np.empty(rhs_work_size(system.topology.n_bodies, n))
    arm = np.zeros(n)
    t0 = time.process_time()
    _loop(system._packed_open, y, n, arm, ydot, work, reps)
    return (time.process_time() - t0) / reps, ydot


def measure(n_seg, rounds, rng):
    """The least CPU time per call of both paths and their ratio."""
    planar, spatial = scenes.b1(n_seg).build(), scenes.b1(n_seg).build(planar=False)
    assert planar.planar and not spatial.planar
    n = planar.n_coords
    y = np.concatenate([rng.normal(0.0, 0.01, n), rng.normal(0.0, 1.0, n)])
    _, a = _timed(planar, y, 1)
    _, b = _timed(spatial, y, 1)
    agreement = float(np.max(abs(a - b)) / np.max(abs(b[n:])))
    one, _ = _timed(spatial, y, 10)
    reps = max(10, int(0.05 / max(one, 1e-9)))
    times = {"planar": [], "spatial": []}
    for _ in range(rounds):
        for name, system in (("planar", planar), ("spatial", spatial)):
            times[name].append(_timed(system, y, reps)[0])
    best = {k: min(v) for k, v in times.items()}
    return {"planar_us": 1e6 * best["planar"], "spatial_us": 1e6 * best["spatial"],
            "spatial_over_planar": best["spatial"] / best["planar"], "reps": reps, "agreement": agreement}


def main(argv=None):
    """Measure and append the JSON lines."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[8, 512])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--out", default=os.path.join(HERE, "results", "planar_open_s11.jsonl"))
    args = parser.parse_args(argv)
    rev = subprocess.run(["git", "-C", HERE, "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout
    rng = np.random.default_rng(0)
    with open(args.out, "a", encoding="utf-8") as f:
        for n_seg in args.sizes:
            row = {"kind": "rhs", "scene": "B1", "n_segments": n_seg, "rounds": args.rounds,
                   "date": time.strftime("%Y-%m-%d %H:%M", time.gmtime()), "loadavg_1min": os.getloadavg()[0],
                   "commit": rev.strip(), **measure(n_seg, args.rounds, rng)}
            print(json.dumps(row))
            f.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
