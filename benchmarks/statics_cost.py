"""CPU cost of static equilibrium of the looped scenes B6 and B7 per N, this checkout against another (main).

    OPENBLAS_NUM_THREADS=1 python benchmarks/statics_cost.py --n 64 256 1024 --repeats 3 \
        --before /path/to/main/src > benchmarks/results/statics_cost.jsonl

:func:`flexmb.static_equilibrium` (Newton's method alone,
``continuation=False``) of two scenes built with
``complement='articulated'``: B6 damped with gravity 9.81 m/s^2 along -y
added (N rod segments, from the straight rod: it sags), and B7 (N loops)
from every rod tilted by 0.4 rad (it stands up again). Two worker
processes, one importing flexmb from this checkout, one from ``--before``
(prepended to PYTHONPATH), each build the systems once and solve once to
warm up (kernels compiled or loaded); then every (scene, N) is timed
``--repeats`` times, the two workers taking turns (CPU time, process_time,
of one call). Each timing is a JSON line; the summary gives each side's
minimum, their ratio, the Newton iterations, the exponent of a
least-squares fit ``cost ~ N^p`` and, at the largest N, the peak of
traced memory (tracemalloc, one more call) and its ratio to one n x n
array of floats.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.path.join(os.path.dirname(HERE), "src")
SCENES = ("B6", "B7")


def _case(scene, n):
    """The system and the start of a statics case."""
    sys.path.insert(0, HERE)
    import flexmb as fm
    import scenes

    if scene == "B6":
        model, positions = scenes.b6(True, n)
        model.add(fm.Gravity((0.0, -9.81, 0.0)))
    else:
        model, initial = scenes.b7(n)
        positions = {k: (0.4 if k.startswith("pin") else -0.4) for k in initial["positions"]}
    system = model.build(complement="articulated")
    x, _ = fm.initial_state(system, 0.0, positions=positions)
    return system, x


def _worker():
    """Answer ``scene n [memory]`` lines with a JSON line: CPU s, iterations, n, peak bytes."""
    import tracemalloc

    import flexmb as fm
    from flexmb.analysis import path_following

    cases = {}
    calls = {"k": 0}
    newton = path_following._newton

    def counted(*args, **kwargs):
        out = newton(*args, **kwargs)
        calls["k"] = args[5]["iterations"]
        return out

    path_following._newton = counted
    import flexmb.analysis.statics as statics

    statics._newton = counted
    for line in sys.stdin:
        scene, n, *memory = line.split()
        key = (scene, int(n))
        if key not in cases:
            cases[key] = _case(*key)
            fm.static_equilibrium(*cases[key], continuation=False)  # warm-up
        system, x = cases[key]
        peak = None
        if memory:
            tracemalloc.start()
        t0 = time.process_time()
        x_eq = fm.static_equilibrium(system, x, continuation=False)
        cpu = time.process_time() - t0
        if memory:
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
        print(json.dumps({"cpu_s": cpu, "iterations": calls["k"], "n": system.n_speeds, "peak_bytes": peak,
                          "x_digest": float(np.sum(np.abs(x_eq)))}), flush=True)


def _start(src):
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=os.pathsep.join(
        [src] + ([os.environ["PYTHONPATH"]] if os.environ.get("PYTHONPATH") else [])))
    return subprocess.Popen([sys.executable, os.path.abspath(__file__), "--worker"], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, env=env)


def _ask(proc, scene, n, memory=False):
    proc.stdin.write(f"{scene} {n}{' memory' if memory else ''}\n")
    proc.stdin.flush()
    return json.loads(proc.stdout.readline())


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, nargs="+", default=[64, 256, 1024])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--before", default=None, help="src folder of the other checkout (e.g. main's)")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        _worker()
        return
    sides = {"after": _start(SRC)}
    if args.before:
        sides["before"] = _start(args.before)
    best = {}
    for rep in range(args.repeats):
        for scene in SCENES:
            for n in args.n:
                for side, proc in (sides.items() if rep % 2 == 0 else reversed(sides.items())):
                    row = {"scene": scene, "N": n, "side": side, "repeat": rep, **_ask(proc, scene, n)}
                    print(json.dumps(row), flush=True)
                    key = (scene, n, side)
                    if key not in best or row["cpu_s"] < best[key]["cpu_s"]:
                        best[key] = row
    for scene in SCENES:
        for side, proc in sides.items():
            mins = [best[(scene, n, side)]["cpu_s"] for n in args.n]
            slope = float(np.polyfit(np.log(args.n), np.log(mins), 1)[0]) if len(args.n) > 1 else None
            big = _ask(proc, scene, args.n[-1], memory=True)
            print(json.dumps({"summary": scene, "side": side, "N": args.n, "min_cpu_s": mins, "exponent": slope,
                              "iterations": [best[(scene, n, side)]["iterations"] for n in args.n],
                              "n": [best[(scene, n, side)]["n"] for n in args.n],
                              "peak_bytes_largest_N": big["peak_bytes"],
                              "peak_over_n2_floats": big["peak_bytes"] / (8.0 * big["n"] ** 2)}), flush=True)
        if "before" in sides:
            print(json.dumps({"summary": scene, "ratio_after_over_before": [
                best[(scene, n, "after")]["cpu_s"] / best[(scene, n, "before")]["cpu_s"] for n in args.n]}),
                flush=True)
    for proc in sides.values():
        proc.stdin.close()
        proc.wait()


if __name__ == "__main__":
    main()
