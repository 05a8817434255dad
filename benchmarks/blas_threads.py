"""B2 N = 64, Radau at rtol 1e-4, with the default BLAS threads and with OPENBLAS_NUM_THREADS=1.

Each configuration runs in its own process (the BLAS reads the variable at
start), alternating, min of ``--repeats``. With flexmb deciding its BLAS
threads (flexmb.threads) both must take the same time within noise, idle
or loaded; ``--load`` starts that many busy processes for the duration.

    python benchmarks/blas_threads.py --n 64 --repeats 3 --load 2
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent

RUN = """
import sys, time
sys.path.insert(0, {here!r})
import flexmb as fm, scenes
model = scenes.b2({n})
t = time.perf_counter()
res = fm.simulate(model, 1.0, method="Radau", rtol=1e-4, n_out=11)
print(time.perf_counter() - t, res.n_steps, res.n_rhs)
"""


def _busy(stop_at):
    while time.time() < stop_at:
        pass


def one(n, threads_one):
    env = dict(os.environ)
    env.pop("OPENBLAS_NUM_THREADS", None)
    env.pop("OMP_NUM_THREADS", None)
    if threads_one:
        env["OPENBLAS_NUM_THREADS"] = "1"
    out = subprocess.run([sys.executable, "-c", RUN.format(here=str(HERE), n=n)], env=env,
                         capture_output=True, text=True, check=True)
    wall, steps, rhs = out.stdout.split()
    return float(wall), int(steps), int(rhs)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=64)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--load", type=int, default=0, help="busy processes to run meanwhile")
    p.add_argument("--out", default=str(HERE / "results" / "blas_threads.jsonl"))
    a = p.parse_args(argv)
    procs = [mp.Process(target=_busy, args=(time.time() + 3600,)) for _ in range(a.load)]
    for q in procs:
        q.start()
    try:
        walls = {"default": [], "OPENBLAS_NUM_THREADS=1": []}
        for _ in range(a.repeats):
            for key in walls:
                walls[key].append(one(a.n, key != "default"))
    finally:
        for q in procs:
            q.terminate()
    rows = []
    for key, runs in walls.items():
        row = {"tool": "flexmb", "scene": "B2", "n_segments": a.n, "integrator": "Radau", "rtol": 1e-4,
               "environment": key, "load": a.load, "cpus": os.cpu_count(),
               "wall_s": min(r[0] for r in runs), "walls_s": [r[0] for r in runs],
               "steps": runs[0][1], "rhs_evals": runs[0][2]}
        rows.append(row)
        print(json.dumps(row))
    with open(a.out, "a") as fh:
        for row in rows:
            fh.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
