"""flexmb as one process per simulation: import, build, simulate B1 or B2 once, print one JSON row.

How a script, a test or a study case runs flexmb: a new interpreter
imports flexmb (scipy, numba, the kernels' dispatchers), builds the model
(the first ``build()`` of a process), simulates it once (the first
``simulate`` loads the compiled kernels from numba's cache) and exits.
``compare.py`` starts this script in the project's venv and measures the
CPU time of the whole process (``os.wait4``); the row printed here splits
the wall time inside the process into ``import_s``, ``build_s`` and
``simulate_s`` (the peers' scripts run the same way with ``--repeat 1``).

Run::

    python benchmarks/peers/flexmb_beam.py --scene B1 --n 8 --method CVODE_BDF --rtol 2e-5
    python benchmarks/peers/flexmb_beam.py --scene B1 --n 8 --default     # simulate()'s default settings
"""

from __future__ import annotations

import time

T0 = time.perf_counter()

import argparse  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import sys  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="B1", choices=["B1", "B2"])
    ap.add_argument("--n", type=int, default=8)
    ap.add_argument("--method", default="CVODE_BDF")
    ap.add_argument("--rtol", type=float, default=1e-5)
    ap.add_argument("--atol", type=float, help="default: rtol / 100 (simulate's default)")
    ap.add_argument("--default", action="store_true",
                    help="simulate()'s default integrator settings (method, rtol, atol); only n_out = 2 set")
    ap.add_argument("--t-end", type=float, default=1.0)
    args = ap.parse_args(argv)
    t_args = time.perf_counter()
    import flexmb as fm

    sys.path.insert(0, os.path.dirname(HERE))
    import scenes

    t_import = time.perf_counter()
    model = scenes.b1(args.n) if args.scene == "B1" else scenes.b2(args.n)
    system = model.build()
    t_build = time.perf_counter()
    kw = {} if args.default else {"method": args.method, "rtol": args.rtol, "atol": args.atol}
    res = fm.simulate(system, args.t_end, n_out=2, progress=False, **kw)
    t_sim = time.perf_counter()
    out = res.shape("beam")[-1, -1] if args.scene == "B1" else res.body_position("tip")[-1]
    print(json.dumps({"tool": "flexmb", "scene": args.scene, "n_segments": args.n, "integrator": res.method,
                      "rtol": None if args.default else args.rtol, "default": args.default,
                      "status": res.status, "output": [float(v) for v in out], "steps": int(res.n_steps),
                      "import_s": t_import - t_args, "build_s": t_build - t_import, "simulate_s": t_sim - t_build,
                      "in_process_s": t_sim - T0, "version": fm.__version__,
                      "openblas_num_threads": os.environ.get("OPENBLAS_NUM_THREADS")}), flush=True)


if __name__ == "__main__":
    main()
