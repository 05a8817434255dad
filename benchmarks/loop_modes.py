"""The lowest modes of large looped models, dense against the O(n m) path, and the memory of a large looped run.

    OPENBLAS_NUM_THREADS=1 python benchmarks/loop_modes.py modes --n 64 256 1024 --k 6 --repeats 3
    OPENBLAS_NUM_THREADS=1 python benchmarks/loop_modes.py memory --n 512 2048 --t-end 0.1

``modes``: per scene (B6 damped, B7) and N, ``flexmb.modes(system, k)`` at
the assembled state (speeds zero) by the dense path (what main does: T
from the SVD of psi, the linearisation's p columns of differences, the
p x p eigenproblem) and by the sparse one
(``flexmb.analysis.loop_modes``), each forced through
``flexmb.analysis.loop_modes.SPARSE_MODES_MIN`` (the row says which one
``modes`` takes by default at that size), the two taking turns ``--repeats`` times in one process: CPU time
(process_time, least of the repeats), solves of the equations
(``System.n_complements``), tracemalloc's
peak, and the largest difference of ``w^2`` relative to the largest
``w^2`` found. Then the exponent of a least-squares fit ``cpu ~ n^p`` per
scene and path.

``memory``: per N, a B6 damped run (build, ``initial_state``, three
right-hand sides, both projections, ``--t-end`` of ``simulate`` with 5
outputs), each N in its own process: tracemalloc's peak (numpy's arrays,
Python's objects), the process's peak resident set (VmHWM) and that beyond
the resident set at the start of the run (VmHWM after
``/proc/self/clear_refs``; the compiled kernels' own arrays included) and ``flexmb.memory.estimate(system, 5,
loops='articulated')``.

Rows go to stdout as JSON lines.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
import tracemalloc

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)


def _system(scene, n):
    """The assembled scene (articulated strategy, calibrated as a run does) and its coordinates."""
    import flexmb as fm
    import scenes
    from flexmb.simulate import _calibrated

    if scene == "B6":
        model, positions = scenes.b6(True, n)
        initial = {"positions": positions}
    else:
        model, initial = scenes.b7(n)
    system = model.build(complement="articulated")
    x, xd = fm.initial_state(system, 0.0, **initial)
    return _calibrated(system, 0.0, x, xd), x


def _modes(system, x, k, dense):
    """(cpu s, solves counted by n_complements, tracemalloc peak bytes, w^2) of one call of flexmb.modes."""
    import flexmb as fm
    from flexmb.analysis import loop_modes

    keep = loop_modes.SPARSE_MODES_MIN
    loop_modes.SPARSE_MODES_MIN = 10**12 if dense else 0
    rhs0 = system.n_complements
    tracemalloc.start()
    t0 = time.process_time()
    try:
        f, _ = fm.modes(system, k, x0=x)
        cpu = time.process_time() - t0
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
        loop_modes.SPARSE_MODES_MIN = keep
    return cpu, system.n_complements - rhs0, peak, (2 * np.pi * f) ** 2


def n_sparse(system):
    """Whether flexmb.modes takes the sparse path for this system by default."""
    from flexmb.analysis.loop_modes import SPARSE_MODES_MIN

    return system.n_speeds >= SPARSE_MODES_MIN


def modes_rows(ns, k, repeats):
    """The rows of the modes comparison, then the fits."""
    rows = []
    for scene in ("B6", "B7"):
        _modes(*_system(scene, 4), k, True)  # kernels loaded
        _modes(*_system(scene, 4), k, False)
        for n in ns:
            system, x = _system(scene, n)
            best = {True: None, False: None}
            for _ in range(repeats):
                for dense in (True, False):
                    run = _modes(system, x, k, dense)
                    if best[dense] is None or run[0] < best[dense][0]:
                        best[dense] = run
            d, s = best[True], best[False]
            scale = max(float(np.max(np.abs(d[3]))), 1e-300)
            row = {"bench": "loop_modes", "scene": scene, "N": n, "n": system.n_speeds, "k": k,
                   "p": system.dof(0.0, x), "default_path": "sparse" if n_sparse(system) else "dense",
                   "cpu_dense_s": d[0], "cpu_sparse_s": s[0], "speedup": d[0] / s[0],
                   "solves_dense": d[1], "solves_sparse": s[1],
                   "peak_dense_MB": d[2] / 1e6, "peak_sparse_MB": s[2] / 1e6,
                   "w2_dense": d[3].tolist(), "w2_sparse": s[3].tolist(),
                   "w2_difference_rel": float(np.max(np.abs(d[3] - s[3]))) / scale, "repeats": repeats}
            rows.append(row)
            print(json.dumps(row), flush=True)
    for scene in ("B6", "B7"):
        sel = [r for r in rows if r["scene"] == scene]
        if len(sel) >= 2:
            n = np.log([r["n"] for r in sel])
            fit = {"bench": "loop_modes_fit", "scene": scene, "N": [r["N"] for r in sel]}
            for path in ("dense", "sparse"):
                fit[f"exponent_{path}"] = float(np.polyfit(n, np.log([r[f"cpu_{path}_s"] for r in sel]), 1)[0])
            print(json.dumps(fit), flush=True)


def _hwm_kb():
    """VmHWM and VmRSS of this process, kB."""
    out = {}
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(("VmHWM", "VmRSS")):
                out[line.split(":")[0]] = int(line.split()[1])
    return out["VmHWM"], out["VmRSS"]


def memory_one(n, t_end):
    """One B6 damped run at N = n over ``t_end`` s in this process: its row."""
    import flexmb as fm
    import scenes
    from flexmb import memory

    def run(size):
        model, positions = scenes.b6(True, size)
        system = model.build(complement="articulated")
        x, xd = fm.initial_state(system, 0.0, positions=positions)
        y = system.layout.join(x, xd)
        for _ in range(3):
            system.state_rate(0.0, y)
        system.project(0.0, x + 1e-7, xd)
        system.project(0.0, x + 1e-7, xd, speeds="mass")
        fm.simulate(system, t_end if size == n else 1e-4, positions=positions, n_out=5, progress=False)
        return system

    run(4)  # kernels loaded
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")  # resets VmHWM to the current resident set
    rss0 = _hwm_kb()[1]
    tracemalloc.start()
    t0 = time.process_time()
    system = run(n)
    cpu = time.process_time() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    hwm = _hwm_kb()[0]
    return {"bench": "loop_memory", "scene": "B6 damped", "N": n, "t_end_s": t_end, "rss_peak_MB": hwm / 1e3,
            "n": system.n_speeds, "m": system.n_constraints,
            "cpu_s": cpu, "tracemalloc_peak_MB": peak / 1e6, "rss_peak_over_start_MB": (hwm - rss0) / 1e3,
            "estimate_MB": memory.estimate(system, 5, loops="articulated") / 1e6,
            "eight_n_squared_MB": 8 * system.n_speeds ** 2 / 1e6}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("what", choices=("modes", "memory"))
    p.add_argument("--n", type=int, nargs="+", default=[64, 256, 1024])
    p.add_argument("--k", type=int, default=6)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--t-end", type=float, default=1e-4, help="memory: the simulated time, s")
    p.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.what == "modes":
        modes_rows(a.n, a.k, a.repeats)
    elif a.one:
        print(json.dumps(memory_one(a.n[0], a.t_end)), flush=True)
    else:
        for n in a.n:
            subprocess.run([sys.executable, __file__, "memory", "--one", "--n", str(n), "--t-end", str(a.t_end)],
                           check=True)


if __name__ == "__main__":
    main()
