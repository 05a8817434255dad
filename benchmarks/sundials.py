"""SUNDIALS CVODE (BDF) against scipy's Radau and BDF on B1 and B2 (issue 19, item 3).

For each case (B1 N = 16, B1 N = 64, B2 N = 16 by default), each
integrator's rtol grid (half decades, ``atol = rtol / 100``) is scanned
from the loosest, once per rtol, until the tip error at t = 1 s against
the cached reference of the same model (``work_precision.reference``:
Radau at ``--ref-rtol``, its own uncertainty from a second reference at
10x) is <= ``--target``. Then the chosen setting of every integrator is
run ``--repeat`` times, alternating between the integrators so that they
see the same machine load, and the least wall and CPU times are kept.

Besides the times, each row has the costs per step and per right-hand
side, and the integrator's own cost per step: the run's CPU time minus
its right-hand sides and Jacobians at their separately measured unit cost
(``rhs_unit_s``, ``jac_unit_s``: min over a few hundred evaluations on
the initial state), divided by the steps. The right-hand side is still
flexmb's numpy one, so today the gain of CVODE is that per-step
overhead (scipy's Radau and BDF run their step logic in Python).

Run with one BLAS thread::

    OPENBLAS_NUM_THREADS=1 python benchmarks/sundials.py
    OPENBLAS_NUM_THREADS=1 python benchmarks/sundials.py --cases B1:16 --repeat 1   # quick

One JSON line per integrator and case goes to ``benchmarks/results/sundials.jsonl``.
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

import flexmb as fm  # noqa: E402
import work_precision as wp  # noqa: E402

RTOLS = (1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 3e-7, 1e-7, 3e-8, 1e-8)


def run(system, scene, method, rtol):
    """One simulation; returns (wall_s, cpu_s, result)."""
    w0, c0 = time.perf_counter(), time.process_time()
    res = fm.simulate(system, scene.t_end, method=method, rtol=rtol, atol=wp.atol_for(rtol), n_out=2,
                      progress=False)
    return time.perf_counter() - w0, time.process_time() - c0, res


def unit_costs(system, n_eval=200):
    """Least CPU time of one right-hand side and of one state Jacobian on the initial (straight) state."""
    n = system.n_coords
    rng = np.random.default_rng(1)
    x, xd = 1e-3 * rng.standard_normal(n), 1e-2 * rng.standard_normal(n)
    best_rhs = best_jac = np.inf
    for _ in range(5):
        c0 = time.process_time()
        for _ in range(n_eval):
            system.accelerations(0.1, x, xd)
        best_rhs = min(best_rhs, (time.process_time() - c0) / n_eval)
        c0 = time.process_time()
        for _ in range(max(n_eval // 10, 5)):
            system.state_jacobian(0.1, x, xd)
        best_jac = min(best_jac, (time.process_time() - c0) / max(n_eval // 10, 5))
    return best_rhs, best_jac


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="+", default=["B1:16", "B1:64", "B2:16"])
    ap.add_argument("--integrators", nargs="+", default=["CVODE_BDF", "Radau", "BDF"])
    ap.add_argument("--target", type=float, default=1e-6, help="tip error to reach, m")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--ref-rtol", type=float, default=1e-9)
    ap.add_argument("--out", default=os.path.join(wp.RESULTS, "sundials.jsonl"))
    args = ap.parse_args(argv)
    table = wp.scenes()
    rows = []
    stamp = time.strftime("%Y-%m-%d %H:%M", time.gmtime())
    for case in args.cases:
        key, n = case.split(":")
        n = int(n)
        scene = table[key]
        system, _ = scene.build(n)
        ref = wp.reference(scene, n, args.ref_rtol)
        loose = wp.reference(scene, n, args.ref_rtol * 10)
        unc = float(np.linalg.norm(ref["output"] - loose["output"]))
        rhs_unit, jac_unit = unit_costs(system)
        print(f"{key} N={n}: reference uncertainty {unc:.1e} m; rhs {1e6 * rhs_unit:.0f} us, "
              f"Jacobian {1e6 * jac_unit:.0f} us", flush=True)
        chosen = {}
        for method in args.integrators:
            for rtol in RTOLS:
                wall, cpu, res = run(system, scene, method, rtol)
                err = float(np.linalg.norm(scene.output(res) - ref["output"]))
                print(f"  scan {method:9s} rtol {rtol:7.0e}  error {err:8.1e}  wall {wall:6.2f} s", flush=True)
                if err <= args.target:
                    chosen[method] = (rtol, err)
                    break
        best = {m: None for m in chosen}
        for _ in range(args.repeat):
            for method, (rtol, err) in chosen.items():
                wall, cpu, res = run(system, scene, method, rtol)  # the counts are the same every run
                if best[method] is not None:
                    wall, cpu = min(wall, best[method][0]), min(cpu, best[method][1])
                best[method] = (wall, cpu, res)
        for method, (wall, cpu, res) in best.items():
            rtol, err = chosen[method]
            overhead = (cpu - res.n_rhs * rhs_unit - res.n_jac * jac_unit) / res.n_steps
            row = wp._row(scene, n, n_coords=system.n_coords, n_dof=int(res.n_dof), integrator=method, rtol=rtol,
                          wall_s=wall, cpu_s=cpu, steps=int(res.n_steps), rhs_evals=int(res.n_rhs),
                          jac_evals=int(res.n_jac), error=err, status=res.status, atol=wp.atol_for(rtol),
                          t_end=scene.t_end, ref_uncertainty=unc, repeats=args.repeat,
                          reference=f"flexmb Radau rtol={args.ref_rtol:g} same N",
                          cpu_per_step_us=1e6 * cpu / res.n_steps, cpu_per_rhs_us=1e6 * cpu / res.n_rhs,
                          rhs_unit_us=1e6 * rhs_unit, jac_unit_us=1e6 * jac_unit,
                          integrator_overhead_per_step_us=1e6 * overhead, run=stamp,
                          blas_threads=os.environ.get("OPENBLAS_NUM_THREADS", "default"))
            rows.append(row)
            print(f"  {method:9s} rtol {rtol:7.0e} error {err:8.1e}  wall {wall:6.3f} s  cpu {cpu:6.3f} s  "
                  f"steps {res.n_steps:5d}  rhs {res.n_rhs:6d}  jac {res.n_jac:3d}  "
                  f"cpu/step {1e6 * cpu / res.n_steps:6.0f} us  cpu/rhs {1e6 * cpu / res.n_rhs:5.0f} us  "
                  f"overhead/step {1e6 * overhead:6.0f} us", flush=True)
        wp.write_jsonl(rows, args.out)
    print(f"wrote {len(rows)} lines to {args.out}")


if __name__ == "__main__":
    main()
