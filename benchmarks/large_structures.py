"""Large structures: build time, one right-hand side and peak memory of B1 and B2 with many segments.

Each N runs in its own process so that its peak resident memory is its
own (``ru_maxrss``, which includes the interpreter and the compiled
kernels: the baseline before building is reported beside it).

    python benchmarks/large_structures.py --scene B1 --n 1000 10000
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent

CHILD = r"""
import json, resource, sys, time
sys.path.insert(0, {here!r})
import numpy as np
import flexmb as fm
import scenes

def rss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0

warm = scenes.{fn}(4).build()  # compile (or load) the kernels before measuring
warm.accelerations(0.0, np.zeros(warm.n_coords), np.zeros(warm.n_coords))
base = rss_mb()
t0 = time.perf_counter()
model = scenes.{fn}({n})
system = model.build()
build = time.perf_counter() - t0
x = np.zeros(system.n_coords)
rng = np.random.default_rng(0)
x = 1e-3 * rng.normal(size=system.n_coords)
xd = 1e-2 * rng.normal(size=system.n_coords)
t0 = time.perf_counter()
xdd = system.accelerations(0.0, x, xd)
first = time.perf_counter() - t0
walls = []
for _ in range(5):
    t0 = time.perf_counter()
    system.accelerations(0.0, x, xd)
    walls.append(time.perf_counter() - t0)
print(json.dumps({{"tool": "flexmb", "scene": {scene!r}, "n_segments": {n}, "n_coords": system.n_coords,
                  "n_bodies": system.topology.n_bodies, "build_s": build, "rhs_first_s": first,
                  "rhs_s": min(walls), "finite": bool(np.all(np.isfinite(xdd))),
                  "rss_baseline_mb": base, "rss_peak_mb": rss_mb()}}))
"""


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", choices=["B1", "B2"], default="B1")
    p.add_argument("--n", type=int, nargs="+", default=[1000, 10000])
    p.add_argument("--out", default=str(HERE / "results" / "large_structures.jsonl"))
    a = p.parse_args(argv)
    rows = []
    for n in a.n:
        code = CHILD.format(here=str(HERE), fn=a.scene.lower(), n=n, scene=a.scene)
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        if out.returncode:
            print(out.stderr[-2000:], file=sys.stderr)
            continue
        row = json.loads(out.stdout.strip().splitlines()[-1])
        rows.append(row)
        print(json.dumps(row))
    with open(a.out, "a") as fh:
        for row in rows:
            fh.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
