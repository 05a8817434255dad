"""Parameter-study speed-up: 8 wiper cases on 1 and 2 local workers, and the Dask path's overhead.

The study is the flexible-blade wiper (``tutorials/04_wiper.toml``, 6-segment
blades, Radau, t_end = 0.5 s by default) with the tip friction's normal load
(both blades, 4 values) crossed with the blades' Young's modulus (2 values).
It runs

1. on the local process pool with 1 worker,
2. on the local process pool with 2 workers,
3. on a ``dask.distributed.LocalCluster`` with 2 worker processes (if
   ``dask[distributed]`` is installed; the cluster's start-up is timed
   apart),

each into a fresh folder, and reports the wall time of each, the speed-up
``T(1 worker) / T(2 workers)``, and the overhead per case of each path: the
time beyond the cases' own work, ``(workers * T - sum of case times) / n``,
and the Dask path's extra time per case over the process pool's; then 150
tiny cases (a pendulum for 0.01 s) on the pool and on Dask, where the
overhead per case is all that is left. A JSON line
per run goes to ``benchmarks/results/study_speedup.jsonl``.

Run: ``python benchmarks/study_speedup.py [--t-end 0.5] [--repeat 1] [--overhead-only]``. It
takes a few minutes. The machine's load (``os.getloadavg``) is printed: on a
shared machine the speed-up is lower than the cores allow.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time

import numpy as np

from flexmb.study import Study

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = os.path.join(HERE, "..", "tutorials", "04_wiper.toml")
FRICTION = "forces.right_blade_friction.normal_load+forces.left_blade_friction.normal_load"


def make_study(t_end: float) -> Study:
    """The 8-case wiper sweep: normal load 2, 4, 6, 8 N x E 150, 210 GPa."""
    return Study.from_file(SCENE, {FRICTION: [2.0, 4.0, 6.0, 8.0], "materials.spring_steel.E": [1.5e11, 2.1e11]},
                           outputs=["peak_speed:right_tip", "peak_effort:motor", "energy_balance", "n_rhs"],
                           fixed={"solver.t_end": t_end, "solver.method": "Radau", "solver.n_out": 101})


def timed(study: Study, **kw):
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        res = study.run(out, progress=False, **kw)
        wall = time.perf_counter() - t0
    assert not res.failed, res.summary()
    return wall, res


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--t-end", type=float, default=0.5)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--tiny", type=int, default=150, help="number of tiny cases for the overhead")
    parser.add_argument("--overhead-only", action="store_true", help="only the tiny-case overhead")
    args = parser.parse_args()
    if args.overhead_only:
        tiny_case_overhead(args.tiny)
        return
    study = make_study(args.t_end)
    n = len(study.cases())
    print(f"{n} wiper cases, t_end {args.t_end} s; CPUs {os.cpu_count()}, load average before "
          f"{os.getloadavg()[0]:.2f}")
    runs = []
    reference = None
    for rep in range(args.repeat):
        for label, kw, workers in (("process pool", dict(executor="process", workers=1), 1),
                                   ("process pool", dict(executor="process", workers=2), 2)):
            wall, res = timed(study, **kw)
            runs.append((label, workers, wall, res, 0.0))
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            print("dask.distributed is not installed (pip install -e '.[dask]'): no Dask run")
            continue
        t0 = time.perf_counter()
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address=None) as cluster, Client(cluster) as client:
            startup = time.perf_counter() - t0
            wall, res = timed(study, client=client)
        runs.append(("dask LocalCluster", 2, wall, res, startup))
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    load = os.getloadavg()[0]
    lines = []
    print(f"{'executor':<20} {'workers':>7} {'wall [s]':>9} {'sum cases [s]':>13} {'overhead/case [s]':>17}")
    for label, workers, wall, res, startup in runs:
        case_sum = float(np.nansum(res.column("wall_time_s")))
        overhead = (workers * wall - case_sum) / n
        outputs = np.array([res.column(o) for o in res.outputs], dtype=float)
        if reference is None:
            reference = outputs
        diff = float(np.max(np.abs(outputs - reference) / np.maximum(np.abs(reference), 1e-300)))
        same = diff == 0.0
        print(f"{label:<20} {workers:>7} {wall:9.2f} {case_sum:13.2f} {overhead:17.3f}"
              + (f"   (cluster start-up {startup:.2f} s, not counted)" if startup else "")
              + ("" if same else f"   outputs differ from the first run by {diff:.1e} (relative)"))
        lines.append({"tool": "flexmb", "scene": "wiper study", "variant": label, "workers": workers,
                      "n_cases": n, "t_end": args.t_end, "wall_s": wall, "case_sum_s": case_sum,
                      "overhead_per_case_s": overhead, "startup_s": startup, "load_average": load,
                      "max_rel_difference": diff})
    one = [r[2] for r in runs if r[0] == "process pool" and r[1] == 1]
    two = [r[2] for r in runs if r[0] == "process pool" and r[1] == 2]
    dask = [r[2] for r in runs if r[0].startswith("dask")]
    print(f"speed-up on 2 workers: {np.median(one) / np.median(two):.2f}x (load average now {load:.2f})")
    if dask:
        print(f"Dask path minus process pool (2 workers each): "
              f"{(np.median(dask) - np.median(two)) / n * 2:+.3f} s per case (worker time)")
    lines += tiny_case_overhead(args.tiny)
    with open(os.path.join(HERE, "results", "study_speedup.jsonl"), "a") as fh:
        for line in lines:
            fh.write(json.dumps(line) + "\n")


def tiny_case_overhead(n: int) -> list:
    """Overhead on tiny cases (a pendulum for 0.01 s), pool and Dask with 2 workers each.

    Each path runs ``n`` and ``2 n`` cases; the worker time not spent in the
    cases, ``2 wall - sum of case times``, is fitted as ``start-up + n *
    per case``, so the pool's start-up (starting the processes, importing
    flexmb) is apart from the cost of each case (sending the task and the
    result, writing the case file).
    """
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        Client = None
    out = []
    print(f"overhead on tiny cases (pendulum, 0.01 s), 2 workers, {n} and {2 * n} cases:")
    for label in ["process pool"] + (["dask LocalCluster"] if Client else []):
        idle = []
        for m in (n, 2 * n):
            study = Study.from_file(os.path.join(HERE, "..", "tutorials", "01_pendulum.toml"),
                                    {"bodies.bar.mass": f"lin:1:2:{m}"}, outputs=["final:pin"],
                                    fixed={"solver.t_end": 0.01, "solver.n_out": 2})
            if label == "process pool":
                wall, res = timed(study, executor="process", workers=2)
            else:
                with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster, Client(cluster) as client:
                    wall, res = timed(study, client=client)
            idle.append(2 * wall - float(np.nansum(res.column("wall_time_s"))))
        per_case = (idle[1] - idle[0]) / n
        startup = idle[0] - n * per_case
        print(f"  {label:<20} {per_case * 1e3:6.1f} ms per case, start-up {startup:5.2f} s of worker time"
              + (" (cluster started beforehand)" if label.startswith("dask") else ""))
        out.append({"tool": "flexmb", "scene": "pendulum tiny cases", "variant": label, "workers": 2, "n_cases": n,
                    "overhead_per_case_s": per_case, "startup_s": startup, "load_average": os.getloadavg()[0]})
    return out


if __name__ == "__main__":
    main()
