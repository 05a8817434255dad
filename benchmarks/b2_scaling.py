"""B2 cost against N: wall time per simulated second at integration error <= 1e-6 m.

For every N, flexmb runs with ``--integrator`` (default Radau) at a few
tolerances (the least of ``--repeat`` runs each), and each run's
integration error is measured against the cached reference of the same
model (``--ref-method`` at ``--ref-rtol``, ``work_precision.reference``;
Radau's reference at N = 256 takes several CPU minutes once, CVODE_BDF's
reaches N = 1024)::

    python benchmarks/b2_scaling.py --n 64 128 256 512 1024 --integrator CVODE_BDF --ref-method CVODE_BDF \
        --rtols 1e-5 3e-6 1e-6 --out /tmp/b2 The least wall time with error <= ``--target`` per N gives
the curve and its fitted exponent (``np.polyfit`` on log-log, as
``plot.py``), and the local exponents between neighbouring N.

Writes ``results/flexmb_B2_scaling.jsonl`` (BENCHMARKS.md fields plus
``cpu_s``) and ``results/scaling_B2_to256.png``, and prints a table.

Run: ``python benchmarks/b2_scaling.py`` (defaults: N = 8 ... 256, rtol 1e-3
and 1e-4, 3 repeats; about 15 minutes with the references cached, which a first run computes:
about 10 CPU minutes at N = 128 and 256).
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import flexmb as fm  # noqa: E402
import plot  # noqa: E402
import work_precision as wp  # noqa: E402


def run(n, rtol, repeat, scene, ref, method="Radau"):
    """Least wall and CPU time of ``repeat`` runs, and the error of the last one."""
    walls, cpus = [], []
    for _ in range(repeat):
        setup, wall, cpu, res, system = wp.run_once(scene, n, method, rtol)
        walls.append(wall)
        cpus.append(cpu)
    err = float(np.linalg.norm(np.asarray(scene.output(res)) - ref["output"]))
    return {"tool": "flexmb", "scene": "B2", "variant": scene.variant, "n_segments": n,
            "n_coords": system.n_coords, "n_dof": res.n_dof, "integrator": method, "rtol": rtol, "h": None,
            "setup_s": setup, "wall_s": min(walls), "cpu_s": min(cpus), "load_avg_1min": os.getloadavg()[0],
            "steps": res.n_steps, "rhs_evals": res.n_rhs, "jac_evals": res.n_jac, "error": err,
            "error_kind": "integration", "reference": f"flexmb {ref['method']} rtol={ref['rtol']:g} same N",
            "sparse": system.articulated, "status": res.status, "t_end": scene.t_end}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", nargs="+", type=int, default=[8, 16, 32, 64, 128, 256])
    ap.add_argument("--rtols", nargs="+", type=float, default=[1e-3, 1e-4])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--ref-rtol", type=float, default=1e-9)
    ap.add_argument("--integrator", default="Radau")
    ap.add_argument("--ref-method", default="Radau", help="integrator of the references (CVODE_BDF for large N)")
    ap.add_argument("--target", type=float, default=1e-6)
    ap.add_argument("--out", default=wp.RESULTS)
    args = ap.parse_args(argv)
    scene = wp.scenes()["B2"]
    rows = []
    for n in args.n:
        ref = wp.reference(scene, n, args.ref_rtol, method=args.ref_method)
        loose = wp.reference(scene, n, 10 * args.ref_rtol, method=args.ref_method)  # the reference's own error
        unc = float(np.linalg.norm(ref["output"] - loose["output"]))
        for rtol in args.rtols:
            row = run(n, rtol, args.repeat, scene, ref, args.integrator)
            row["ref_uncertainty"] = unc
            rows.append(row)
            print(json.dumps(row), flush=True)
    os.makedirs(args.out, exist_ok=True)
    wp.write_jsonl(rows, os.path.join(args.out, "flexmb_B2_scaling.jsonl"))

    best = plot.best_wall_at(rows, args.target)
    ns = sorted(n for (_, n) in best)
    walls = [best[("flexmb", n)][0] / scene.t_end for n in ns]
    print(f"\nB2, {args.integrator}, least wall time per simulated second at error <= {args.target:g} m (flexmb {fm.__version__})")
    print("| N | n | rtol | error m | reference's error m | wall s | CPU s | steps | rhs | jac | local exponent |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for i, n in enumerate(ns):
        r = best[("flexmb", n)][1]
        local = f"{np.log(walls[i] / walls[i - 1]) / np.log(n / ns[i - 1]):.2f}" if i else "—"
        print(f"| {n} | {r['n_coords']} | {r['rtol']:g} | {r['error']:.1e} | {r['ref_uncertainty']:.0e} "
              f"| {r['wall_s']:.3g} | {r['cpu_s']:.3g} | {r['steps']} | {r['rhs_evals']} | {r['jac_evals']} "
              f"| {local} |")
    p = plot.fit_exponent(ns, walls)
    print(f"fitted exponent over N = {ns[0]}..{ns[-1]}: {p:.2f}" if p is not None else "no fit")
    missing = [n for n in args.n if n not in ns]
    if missing:
        print(f"no run reached error <= {args.target:g} at N = {missing}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    name = "scaling_B2_to256.png" if args.integrator == "Radau" else f"scaling_B2_{args.integrator}.png"
    path, _ = plot.plot_scaling(plt, rows, "B2", args.out, args.target, name=name)
    print("wrote", path)


if __name__ == "__main__":
    main()
