"""Exact work counts of generalized-alpha on B6 damped, and its slider error (issue 28).

    OPENBLAS_NUM_THREADS=1 python benchmarks/genalpha_counts.py --n 8 32 128 --label after
    OPENBLAS_NUM_THREADS=1 PYTHONPATH=/path/to/other/src python benchmarks/genalpha_counts.py --label before

Runs ``scenes.b6(damped=True, n_segments=N)`` over 0.5 s as
``benchmarks/peers/compare_b6.py`` does (articulated complement, atol =
rtol / 100, 101 outputs) with ``GeneralizedAlpha`` at its robust rtols
(3e-4, 1e-4, 3e-5 by default) and counts, exactly and independently of the
machine's load: steps, right-hand sides, Jacobians, LU factorisations of
the iteration matrix (calls of ``GeneralizedAlpha._factor``), projections
of the integrator's state, and new solvers made by the run
(``Run._make``). The error is the largest slider difference at 100 times
from the cached CVODE_BDF reference at rtol 1e-11 that compare_b6.py
writes to ``results/refs`` (run it first for each N). ``PYTHONPATH``
selects the flexmb source tree, so that two versions can be counted with
the same script. Appends to ``benchmarks/results/genalpha_counts.jsonl``.

``--undamped T`` runs undamped B6 instead, with ``simulate``'s default
settings ('auto' takes generalized-alpha with ``f_max`` and ``min_step``,
rtol 1e-8) over T s, and reports the same counts and its CPU time (no
error: its distance from a tight run is the vibration it dissipates).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

if __name__ == "__main__":
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import numpy as np  # noqa: E402

import scenes  # noqa: E402

import flexmb as fm  # noqa: E402
from flexmb import stepping  # noqa: E402
from flexmb.genalpha import solver as ga_solver  # noqa: E402

REFS = os.path.join(HERE, "results", "refs")


def _counting(cls, name, counts, key):
    """Wrap ``cls.name`` so that each call adds one to ``counts[key]``."""
    original = getattr(cls, name)

    def wrapped(self, *args, **kwargs):
        counts[key] += 1
        return original(self, *args, **kwargs)

    setattr(cls, name, wrapped)


COUNTS = {"lu": 0, "solvers": 0}
_counting(ga_solver.GeneralizedAlpha, "_factor", COUNTS, "lu")
_counting(stepping.Run, "_make", COUNTS, "solvers")


def run(n: int, method: str, rtol: float) -> dict:
    """One run of B6 damped at N over 0.5 s: counts, error and CPU time."""
    model, positions = scenes.b6(damped=True, n_segments=n)
    system = model.build()
    kw = dict(positions=positions, complement="articulated", method=method, rtol=rtol, atol=rtol / 100, n_out=101,
              progress=False)
    fm.simulate(system, 0.01, **kw)  # kernels compiled or loaded
    COUNTS.update(lu=0, solvers=0)
    c0 = time.process_time()
    res = fm.simulate(system, 0.5, **kw)
    cpu = time.process_time() - c0
    with np.load(os.path.join(REFS, f"B6damped_N{n}_T0.5_out100_rtol1e-11.npz")) as z:
        ref = z["output"]
    err = float(np.max(np.abs(np.asarray(res.coordinate("rail"), float)[1:] - ref)))
    return {"scene": "B6 damped", "n_segments": n, "t_end": 0.5, "method": method, "rtol": rtol, "atol": rtol / 100,
            "status": res.status, "steps": int(res.n_steps), "rhs_evals": int(res.n_rhs), "jac_evals": int(res.n_jac),
            "lu": COUNTS["lu"], "projections": int(res.n_projections), "solvers": COUNTS["solvers"],
            "slider_error": err, "cpu_s": cpu, "flexmb": os.path.dirname(fm.__file__),
            "started": time.strftime("%Y-%m-%d %H:%M:%S")}


def run_undamped(n: int, t_end: float) -> dict:
    """Undamped B6 at N with the default settings over ``t_end``: counts and CPU time."""
    model, positions = scenes.b6(damped=False, n_segments=n)
    system = model.build()
    fm.simulate(system, 0.002, positions=positions, progress=False)  # kernels compiled or loaded
    COUNTS.update(lu=0, solvers=0)
    c0 = time.process_time()
    res = fm.simulate(system, t_end, positions=positions, track_work=True, progress=False)
    cpu = time.process_time() - c0
    return {"scene": "B6 undamped", "n_segments": n, "t_end": t_end, "method": res.method, "status": res.status,
            "steps": int(res.n_steps), "rhs_evals": int(res.n_rhs), "jac_evals": int(res.n_jac), "lu": COUNTS["lu"],
            "projections": int(res.n_projections), "solvers": COUNTS["solvers"], "cpu_s": cpu,
            "flexmb": os.path.dirname(fm.__file__), "started": time.strftime("%Y-%m-%d %H:%M:%S")}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[8, 32, 128])
    ap.add_argument("--rtol", type=float, nargs="+", default=[3e-4, 1e-4, 3e-5])
    ap.add_argument("--method", default="GeneralizedAlpha")
    ap.add_argument("--label", default="")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "genalpha_counts.jsonl"))
    ap.add_argument("--undamped", type=float, default=None, help="undamped B6 with the default settings over T s")
    args = ap.parse_args(argv)
    if args.undamped is not None:
        for n in args.n:
            row = dict(run_undamped(n, args.undamped), label=args.label)
            print(f"{args.label} undamped N = {n}: {row['steps']} steps, {row['rhs_evals']} rhs, {row['jac_evals']} "
                  f"Jacobians, {row['lu']} LU, {row['projections']} projections, CPU {row['cpu_s']:.3f} s", flush=True)
            with open(args.out, "a") as fh:
                fh.write(json.dumps(row) + "\n")
        return
    for n in args.n:
        for rtol in args.rtol:
            row = dict(run(n, args.method, rtol), label=args.label)
            print(f"{args.label} N = {n:4d} rtol {rtol:g}: {row['steps']} steps, {row['rhs_evals']} rhs, "
                  f"{row['jac_evals']} Jacobians, {row['lu']} LU, {row['projections']} projections, "
                  f"{row['solvers']} solvers, error {row['slider_error']:.2e} m, CPU {row['cpu_s']:.2f} s",
                  flush=True)
            with open(args.out, "a") as fh:
                fh.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
