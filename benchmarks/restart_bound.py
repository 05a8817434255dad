"""The bound on CVODE's own loop drift before a projection and restart (``stepping.RESTART_TOL_MAX``).

CVODE (no cheap restart) projects its own state only when the loop residual
passes ``min(RESTART_ATOL_FACTOR * atol, RESTART_TOL_MAX)`` (the stored
outputs are projected to ``projection_tol`` in any case). This runs looped
scenes with CVODE_BDF at loose to medium rtol under each bound given and
reports steps, projections, the wall time and the error against a tight run
(CVODE_BDF at rtol 1e-11, same strategy), one JSON line per run:

    OPENBLAS_NUM_THREADS=1 python benchmarks/restart_bound.py --bounds 1e-6 1e-4 1e-3 --no-adaptive
    OPENBLAS_NUM_THREADS=1 python benchmarks/restart_bound.py --bounds 1e-6

(the first: fixed caps; the second: simulate's rule, the cap raised tenfold
whenever CVODE restarts within ``RESTART_MIN_STEPS`` steps of the last
restart, up to ``RESTART_TOL_CEILING``).

Errors are the largest difference over 101 output times of: B6's slider
position (m), B7's first rod angle (rad), the four-bar's crank angle (rad,
released with a crank speed, no driver).
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
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tests"))

import flexmb as fm  # noqa: E402
from flexmb import stepping  # noqa: E402
from scenes import b6, b7  # noqa: E402


def _cases():
    from conftest import fourbar, fourbar_initial

    m, i = b6(damped=True, n_segments=32)
    yield "B6 damped N=32", m, {"positions": i}, 0.5, lambda r: r.coordinate("rail")
    m, i = b7(8)
    yield "B7 N=8", m, i, 4.0, lambda r: r.x[:, 0]
    yield ("four-bar", fourbar(), {"positions": fourbar_initial(), "speeds": {"A": 3.0}}, 2.0,
           lambda r: r.x[:, 0])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bounds", type=float, nargs="+", default=[1e-6, 1e-4])
    parser.add_argument("--rtols", type=float, nargs="+", default=[1e-4, 1e-5, 1e-6])
    parser.add_argument("--complements", nargs="+", default=["articulated", "svd"])
    parser.add_argument("--no-adaptive", action="store_true",
                        help="keep the bound fixed (no tenfold raise after restarts within RESTART_MIN_STEPS steps)")
    args = parser.parse_args(argv)
    if args.no_adaptive:
        stepping.RESTART_MIN_STEPS = 0
    for name, model, init, t_end, out in _cases():
        for comp in args.complements:
            system = model.build(complement=comp)
            t_eval = np.linspace(0.0, t_end, 101)
            ref = fm.simulate(system, t_end, method="CVODE_BDF", rtol=1e-11, t_eval=t_eval, **init)
            for rtol in args.rtols:
                for bound in args.bounds:  # alternating the bounds per rtol
                    stepping.RESTART_TOL_MAX = bound
                    t0 = time.perf_counter()
                    res = fm.simulate(system, t_end, method="CVODE_BDF", rtol=rtol, t_eval=t_eval, **init)
                    wall = time.perf_counter() - t0
                    err = float(np.abs(out(res) - out(ref)).max()) if res.status == "finished" else None
                    print(json.dumps({"scene": name, "complement": comp, "rtol": rtol, "bound": bound,
                                      "wall_s": round(wall, 4), "steps": res.n_steps, "rhs": res.n_rhs,
                                      "projections": res.n_projections, "error": err, "status": res.status,
                                      "adaptive": not args.no_adaptive,
                                      "max_residual": float(res.residual.max())}), flush=True)


if __name__ == "__main__":
    main()
