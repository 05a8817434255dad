"""Whole runs of the looped benchmark scenes (B6 damped, B7) per N: wall time, cost per step, memory, residual.

    OPENBLAS_NUM_THREADS=1 python benchmarks/loops_scaling.py --scene B6 --n 32 64 128 256 512 --t-end 0.05
    OPENBLAS_NUM_THREADS=1 python benchmarks/loops_scaling.py --scene B7 --n 64 256 1024 --t-end 1.0

Each (scene, N) runs in its own process (``--one``), so that the peak
memory (``ru_maxrss``) is that run's; the kernels are loaded from the cache
by a warm-up run at the smallest N first. ``simulate()`` is called with the
default settings except ``--complement`` (default 'articulated'),
``--method`` and ``--rtol`` if given. Reported per run: wall and CPU time
(process_time, less sensitive to other work on the machine) of
``simulate``, right-hand sides, steps, Jacobian or preconditioner setups,
the largest loop residual of the stored states, the end state's slider
position (B6) or first rod's top (B7), the relative energy drift (B7, no
dampers) and the peak memory; and, over the N given, the exponent of a
least-squares fit ``wall ~ N^p`` (and ``cpu ~ N^p``). With ``--repeats k``
the sweep over N runs k times, the N taking turns, and the fits are of each
N's minimum. With ``--reference-rtol R`` each run is
repeated at rtol R (CVODE_BDF, not timed) and the row gets the largest
difference over the output times of the slider position (B6) or of the
first rod's top (B7): the error of the timed run. B7 rows also get
``error_closed_form_m``, the same against the chain's one-degree-of-freedom
equation (``scenes.b7_closed_form``), which is tighter than the reference
run. Rows go to stdout as JSON
lines.

    OPENBLAS_NUM_THREADS=1 python benchmarks/loops_scaling.py --scene B6 --n 32 128 512 --t-end 1.0 \
        --reference-rtol 1e-11
    OPENBLAS_NUM_THREADS=1 python benchmarks/loops_scaling.py --scene B6 --n 32 64 128 256 512 --t-end 1.0 \
        --repeats 3
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)


def _watched(scene, res):
    """What the error is measured on: the slider's position (B6), the first rod's top (B7); (nt, k)."""
    import scenes

    if scene == "B6":
        return res.coordinate("rail")[:, None]
    return scenes.b7_tip(res)[:, :2]


def one(scene: str, n: int, t_end: float, complement: str, method: str, rtol: float | None,
        reference_rtol: float | None = None) -> dict:
    """Run one (scene, N) in this process and return its row."""
    import flexmb as fm
    import scenes

    if scene == "B6":
        model, positions = scenes.b6(True, n)
        initial = {"positions": positions}
    else:
        model, initial = scenes.b7(n)
    options = {"complement": complement, "method": method, "progress": False}
    if rtol is not None:
        options["rtol"] = rtol
    t0, c0 = time.perf_counter(), time.process_time()
    res = fm.simulate(model, t_end, **initial, **options)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    row = {"tool": "flexmb", "scene": scene, "n_segments": n, "n_coords": int(res.x.shape[1]), "t_end": t_end,
           "complement": complement, "method": res.method, "rtol": rtol, "status": res.status, "wall_s": wall, "cpu_s": cpu,
           "n_rhs": int(res.n_rhs), "n_steps": int(res.n_steps), "n_jac": int(res.n_jac),
           "wall_per_step_ms": 1e3 * wall / max(res.n_steps, 1), "max_residual": float(np.max(res.residual)),
           "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
           "load_avg_1min": os.getloadavg()[0]}
    if reference_rtol is not None:
        ref = fm.simulate(model, t_end, **initial, complement=complement, method="CVODE_BDF", rtol=reference_rtol,
                          atol=reference_rtol / 100, progress=False)
        row["reference_rtol"] = reference_rtol
        row["error_m"] = float(np.max(np.linalg.norm(_watched(scene, res) - _watched(scene, ref), axis=1)))
    if scene == "B6":
        row["slider_end_m"] = float(res.coordinate("rail")[-1])
    else:
        row["rod_top_end_m"] = scenes.b7_tip(res)[-1, :2].tolist()
        # against the chain's own one-degree-of-freedom equation, independent of flexmb's integrators
        row["error_closed_form_m"] = float(np.max(np.linalg.norm(
            scenes.b7_tip(res)[:, :2] - scenes.b7_closed_form(res.t, n), axis=1)))
        energy = res.kinetic + res.potential
        row["energy_drift_rel"] = float(np.max(np.abs(energy - energy[0])) / max(abs(energy[0]), 1e-300))
    return row


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", choices=["B6", "B7"], default="B6")
    p.add_argument("--n", type=int, nargs="+", default=[32, 64, 128])
    p.add_argument("--t-end", type=float, default=0.05)
    p.add_argument("--complement", default="articulated")
    p.add_argument("--method", default="auto")
    p.add_argument("--rtol", type=float, default=None)
    p.add_argument("--reference-rtol", type=float, default=None,
                   help="also run at this rtol (CVODE_BDF) and report the timed run's error against it")
    p.add_argument("--repeats", type=int, default=1, help="times the sweep over N runs, the N taking turns")
    p.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.one:
        print(json.dumps(one(a.scene, a.n[0], a.t_end, a.complement, a.method, a.rtol, a.reference_rtol)),
              flush=True)
        return
    base = [sys.executable, os.path.abspath(__file__), "--one", "--scene", a.scene, "--t-end", str(a.t_end),
            "--complement", a.complement, "--method", a.method] + ([] if a.rtol is None else ["--rtol", str(a.rtol)])
    warm = list(base)
    if a.reference_rtol is not None:
        base += ["--reference-rtol", str(a.reference_rtol)]
    subprocess.run(warm + ["--n", str(min(a.n)), "--t-end", str(min(a.t_end, 1e-3))], check=True,
                   stdout=subprocess.DEVNULL)  # the kernels compiled or loaded before any timing
    wall = {n: np.inf for n in a.n}
    cpu = dict(wall)
    for repeat in range(a.repeats):
        for n in a.n:
            out = subprocess.run(base + ["--n", str(n)], check=True, capture_output=True, text=True).stdout
            row = json.loads(out.strip().splitlines()[-1])
            if a.repeats > 1:
                row["repeat"] = repeat
            wall[n], cpu[n] = min(wall[n], row["wall_s"]), min(cpu[n], row["cpu_s"])
            print(json.dumps(row), flush=True)
    if len(a.n) > 1:
        logn = np.log(np.asarray(a.n, float))
        summary = {"summary": "wall ~ N^p", "scene": a.scene, "complement": a.complement, "n": a.n,
                   "fitted_exponent": float(np.polyfit(logn, np.log([wall[n] for n in a.n]), 1)[0]),
                   "fitted_exponent_cpu": float(np.polyfit(logn, np.log([cpu[n] for n in a.n]), 1)[0])}
        if a.repeats > 1:
            summary.update(repeats=a.repeats, min_wall_s=[wall[n] for n in a.n], min_cpu_s=[cpu[n] for n in a.n])
        print(json.dumps(summary))


if __name__ == "__main__":
    main()
