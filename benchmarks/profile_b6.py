"""Where a B6 damped run's time goes, per part of a step (cProfile; issue 28).

    OPENBLAS_NUM_THREADS=1 python benchmarks/profile_b6.py --n 32 --method GeneralizedAlpha:1e-4 auto:1e-4

Runs ``scenes.b6(damped=True, n_segments=N)`` over 0.5 s as
``benchmarks/peers/compare_b6.py`` does (articulated complement, atol =
rtol / 100, 101 outputs), once unprofiled (wall time, counts) and once
under cProfile, and splits the profiled time by the cumulative time of:

- ``rhs``: the right-hand side the integrator calls (``stepping`` rhs:
  ``System.state_rate``), and within it the compiled loop kernel
  ``kernels.loops.loop_rhs``;
- ``jacobian``: the state Jacobian (``stepping`` _jac);
- ``factorisation``: generalized-alpha's iteration matrix and its LU
  (``GeneralizedAlpha._factor``; CVODE factorises inside SUNDIALS and is
  counted in ``integrator_other``);
- ``newton_kernels``: generalized-alpha's compiled step arithmetic
  (``predict``, ``newton_update``, ``error_control``);
- ``precond_setup``, ``precond_solve``: CVODE's Newton preconditioner
  (GMRES from ``KRYLOV_MIN_COORDS`` coordinates on; ``system/tangent.py``),
  within the solve the compiled kernel (``precond_kernel``: ``loop_newton``,
  or ``loop_newton_factor`` and ``loop_newton_solve``) and of it the
  factorisation (``precond_factor``); a solve is one GMRES iteration (or
  the first of a Newton iteration), so their calls count them;
- ``drift``: the constraint check after every step and, past the bound,
  the projection and the new solver (``stepping`` _restart_if_drifted);
- ``integrator_other``: the integrator's ``step`` less the above
  (generalized-alpha's Python step loop; CVODE's own work and its Python
  wrapper);
- ``rest``: everything else (output interpolation and projection, the
  winding offsets, simulate's loop).

Profiling inflates Python-heavy parts; the shares are of the profiled
total. Writes ``benchmarks/results/profile_b6.jsonl`` (one row per run).
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import pstats
import sys
import time

if __name__ == "__main__":
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import scenes  # noqa: E402

import flexmb as fm  # noqa: E402

#: part -> (file suffix, function name) whose cumulative time it is
PARTS = {
    "rhs": [("flexmb/stepping.py", "rhs")],
    "rhs_loop_kernel": [("flexmb/kernels/loops.py", "loop_rhs")],
    "jacobian": [("flexmb/stepping.py", "_jac")],
    "factorisation": [("flexmb/genalpha/solver.py", "_factor")],
    "newton_kernels": [("flexmb/kernels/genalpha.py", name) for name in ("predict", "newton_update",
                                                                         "error_control")],
    "precond_setup": [("flexmb/system/tangent.py", "setup")],
    "precond_solve": [("flexmb/system/tangent.py", "solve")],
    "precond_kernel": [("flexmb/kernels/loops.py", name) for name in ("loop_newton", "loop_newton_solve",
                                                                      "loop_newton_factor")],
    "precond_factor": [("flexmb/kernels/loops.py", "loop_newton_factor")],
    "drift": [("flexmb/stepping.py", "_restart_if_drifted")],
    "drift_projection": [("flexmb/system/projection.py", "project")],
    "integrator_step": [("scipy/integrate/_ivp/base.py", "step"), ("flexmb/integrators/sundials.py", "advance")],
    "total": [("flexmb/simulate.py", "simulate")],
}


def _cumulative(stats, targets) -> tuple:
    """Summed cumulative time and calls of the functions ``targets`` in ``stats``."""
    time_s, calls = 0.0, 0
    for (path, _, name), (_, n_calls, _, cum, _) in stats.stats.items():
        if any(path.endswith(suffix) and name == fn for suffix, fn in targets):
            time_s += cum
            calls += n_calls
    return time_s, calls


def profile(n: int, method: str, rtol: float) -> dict:
    """One unprofiled and one profiled run: wall time, counts and the split of the profiled time."""
    model, positions = scenes.b6(damped=True, n_segments=n)
    system = model.build()
    kw = dict(positions=positions, complement="articulated", method=method, rtol=rtol, atol=rtol / 100, n_out=101,
              progress=False)
    fm.simulate(system, 0.01, **kw)  # kernels compiled or loaded
    t0 = time.perf_counter()
    res = fm.simulate(system, 0.5, **kw)
    wall = time.perf_counter() - t0
    prof = cProfile.Profile()
    prof.enable()
    fm.simulate(system, 0.5, **kw)
    prof.disable()
    stats = pstats.Stats(prof)
    parts = {key: _cumulative(stats, targets) for key, targets in PARTS.items()}
    total = parts["total"][0]
    step = parts["integrator_step"][0]
    inside = sum(parts[k][0] for k in ("rhs", "jacobian", "factorisation", "newton_kernels"))
    split = {k: parts[k][0] for k in ("rhs", "rhs_loop_kernel", "jacobian", "factorisation", "newton_kernels",
                                      "precond_setup", "precond_solve", "precond_kernel", "precond_factor",
                                      "drift", "drift_projection")}
    split["integrator_other"] = step - inside - parts["precond_setup"][0] - parts["precond_solve"][0]
    split["rest"] = total - step - parts["drift"][0]
    return {"scene": "B6 damped", "n_segments": n, "t_end": 0.5, "method": method, "method_used": res.method,
            "rtol": rtol, "wall_s": wall, "steps": int(res.n_steps), "rhs_evals": int(res.n_rhs),
            "jac_evals": int(res.n_jac), "projections": int(res.n_projections), "profiled_total_s": total,
            "split_s": split, "calls": {k: parts[k][1] for k in PARTS},
            "openblas_num_threads": os.environ.get("OPENBLAS_NUM_THREADS"), "load_avg_1min": os.getloadavg()[0],
            "started": time.strftime("%Y-%m-%d %H:%M:%S")}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[32])
    ap.add_argument("--method", nargs="+", default=["GeneralizedAlpha:1e-4", "auto:1e-4"],
                    help="METHOD:RTOL pairs")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "profile_b6.jsonl"))
    args = ap.parse_args(argv)
    rows = []
    for n in args.n:
        for spec in args.method:
            method, rtol = spec.split(":")
            row = profile(n, method, float(rtol))
            rows.append(row)
            total = row["profiled_total_s"]
            print(f"B6 damped N = {n}, {method} rtol {rtol}: wall {row['wall_s']:.2f} s unprofiled, "
                  f"{row['steps']} steps, {row['rhs_evals']} rhs, {row['jac_evals']} Jacobians, "
                  f"{row['projections']} projections; profiled {total:.2f} s:")
            for key, value in row["split_s"].items():
                print(f"  {key:18s} {value:7.2f} s  {100 * value / total:5.1f} %")
    with open(args.out + ".tmp", "w") as fh:
        fh.writelines(json.dumps(r) + "\n" for r in rows)
    os.replace(args.out + ".tmp", args.out)


if __name__ == "__main__":
    main()
