"""B1 convergence: statics, frequencies and dynamics against N (BENCHMARKS.md).

Prints the convergence tables and writes JSON lines to
``benchmarks/results/b1_convergence.jsonl``.

Run: ``python benchmarks/b1_convergence.py [--dynamic] [--nmax 64]``.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

import flexmb as fm
from scenes import b1, b1_reference

HERE = os.path.dirname(os.path.abspath(__file__))


def tip_linear(x, n):
    """Linear tip deflection (z) from the bending angles: -sum eta_j (L - x_j)."""
    xj = np.arange(n) / n
    return -np.sum(x * (1.0 - xj))


def statics_and_modes(ns):
    static_ref, f_ref = b1_reference()
    rows = []
    print(f"{'N':>5} {'static err %':>13} {'f1 err %':>10} {'f2 err %':>10} {'f3 err %':>10} {'time s':>8}")
    for n in ns:
        t0 = time.perf_counter()
        x = fm.linear_statics(b1(n).build())
        static = -tip_linear(x, n)
        f, _ = fm.modes(b1(n, gravity=False).build(), 3)
        wall = time.perf_counter() - t0
        err = [(static - static_ref) / static_ref, *((f - f_ref) / f_ref)]
        rows.append({"tool": "flexmb", "scene": "B1", "variant": "linear statics + modes", "n_segments": n,
                     "n_coords": n, "static_tip_m": static, "freqs_hz": f.tolist(), "rel_errors": err,
                     "error_kind": "discretisation", "reference": "Euler-Bernoulli", "wall_s": wall})
        print(f"{n:5d} " + " ".join(f"{100 * e:10.4f}   " for e in err) + f"{wall:8.2f}")
    errs = np.array([r["rel_errors"] for r in rows])
    order = -np.diff(np.log2(np.abs(errs)), axis=0)
    print("observed order between successive N (static, f1, f2, f3):")
    for n, o in zip(ns[1:], order):
        print(f"  {n:5d}: " + " ".join(f"{v:5.2f}" for v in o))
    return rows


def dynamics(ns, n_ref, rtol):
    rows = []
    ref = {}

    def run(n, tol):
        sys_ = b1(n).build()
        t0 = time.perf_counter()
        res = fm.simulate(sys_, 1.0, method="Radau", rtol=tol, atol=tol * 1e-3, t_eval=np.linspace(0, 1, 1001))
        wall = time.perf_counter() - t0
        tip = res.shape("beam")[:, -1, 2]
        return tip[-1], tip.min(), wall, res

    z_ref, zmin_ref, _, _ = run(n_ref, 1e-9)
    print(f"\nB1 dynamics, damped, 1 s (Radau rtol {rtol}); discretisation error against N = {n_ref}")
    print(f"{'N':>5} {'tip z(1) m':>14} {'min tip z m':>14} {'err z(1)':>10} {'err min':>10} {'int. err':>10} "
          f"{'wall s':>8} {'rhs':>7}")
    for n in ns:
        z, zmin, wall, res = run(n, rtol)
        zt, _, _, _ = run(n, 1e-10)
        row = {"tool": "flexmb", "scene": "B1", "variant": "dynamics damped", "n_segments": n, "n_coords": n,
               "n_dof": n, "integrator": "Radau", "rtol": rtol, "wall_s": wall, "steps": res.n_steps,
               "rhs_evals": res.n_rhs, "tip_z": z, "tip_z_min": zmin,
               "discretisation_error": abs(z - z_ref), "integration_error": abs(z - zt),
               "reference": f"N={n_ref}"}
        rows.append(row)
        print(f"{n:5d} {z:14.8f} {zmin:14.8f} {abs(z - z_ref):10.2e} {abs(zmin - zmin_ref):10.2e} "
              f"{abs(z - zt):10.2e} {wall:8.2f} {res.n_rhs:7d}")
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--dynamic", action="store_true", help="also run the dynamic table")
    ap.add_argument("--nmax", type=int, default=128)
    ap.add_argument("--rtol", type=float, default=1e-6)
    args = ap.parse_args()
    ns = [n for n in (4, 8, 16, 32, 64, 128) if n <= args.nmax]
    rows = statics_and_modes(ns)
    if args.dynamic:
        rows += dynamics([n for n in ns if n <= 32], 64, args.rtol)
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    with open(os.path.join(HERE, "results", "b1_convergence.jsonl"), "w") as fh:
        for r in rows:
            fh.write(json.dumps(r) + "\n")


if __name__ == "__main__":
    main()
