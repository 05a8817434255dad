"""``simulate()``'s fixed cost on B1 N = 8 (issue 31): one process per round, two installations alternating.

    OPENBLAS_NUM_THREADS=1 python benchmarks/simulate_fixed.py --base /work/venv/bin/python --pairs 3

Each round is one process of one installation (``--base``'s interpreter,
then this one's, alternating ``--pairs`` times); each process builds B1
N = 8 (benchmarks/scenes.py), warms it up and takes the least CPU time
(``time.process_time``) over ``--rounds`` rounds of:

* ``short_bdf``: ``fm.simulate(system, 1e-9, method="CVODE_BDF", rtol=2e-5,
  atol=2e-7, n_out=2)`` (5 calls a round): the run's set-up and tear-down
  with one step;
* ``integrator_short``: the compiled loop's integrator alone (``DirectCVODEBDF``
  built with the arguments ``simulate`` gives it, advanced to 1e-9 s,
  closed; 5 calls a round): its own Python and CVODE's set-up;
* ``fixed = short_bdf - integrator_short``: ``simulate``'s fixed cost as
  benchmarks/probe_b1_rest.py defines it;
* ``short_auto``: as ``short_bdf`` with ``method="auto"`` (DOP853 over so
  short a span);
* ``whole_bdf``, ``whole_auto``: the whole run to 1 s (721 steps);
* ``whole_bdf_201``: ``whole_bdf`` at simulate's default ``n_out=201``.

One JSON line per process goes to stdout and, with ``--out``, is appended
there (with ``--label``'s and ``--base-label``'s labels).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))

CASES = (("short_bdf", 1e-9, "CVODE_BDF", 2), ("short_auto", 1e-9, "auto", 2), ("whole_bdf", 1.0, "CVODE_BDF", 2),
         ("whole_auto", 1.0, "auto", 2), ("integrator_short", 1e-9, None, 2), ("whole_bdf_201", 1.0, "CVODE_BDF", 201))


def measure(rounds: int) -> dict:
    """This process's least CPU times (ms) of :data:`CASES` (see the module docstring)."""
    sys.path.insert(0, HERE)
    import flexmb as fm
    import flexmb.integrators.cvode_direct as cd
    from scenes import b1

    system = b1(8).build()

    def simulate(t, method, n_out=2):
        return fm.simulate(system, t, method=method, rtol=2e-5, atol=2e-7, n_out=n_out, progress=False)

    captured, init = {}, cd.DirectCVODE.__init__

    def spy(self, *args, **kwargs):
        captured.update(args=args, kwargs=kwargs)
        init(self, *args, **kwargs)

    cd.DirectCVODE.__init__ = spy
    try:
        simulate(1.0, "CVODE_BDF")
    finally:
        cd.DirectCVODE.__init__ = init

    def integrator_short():
        solver = cd.DirectCVODEBDF(*captured["args"], **dict(captured["kwargs"], counters={}))
        try:
            solver.advance(1e-9)
        finally:
            solver.close()

    def run(t, method, n_out):
        return integrator_short() if method is None else simulate(t, method, n_out)

    for _ in range(3):
        for _, t, method, n_out in CASES:
            run(t, method, n_out)
    best = {name: float("inf") for name, _, _, _ in CASES}
    for _ in range(rounds):
        for name, t, method, n_out in CASES:
            inner = 5 if t < 1e-3 else 1
            c0 = time.process_time()
            for _ in range(inner):
                run(t, method, n_out)
            best[name] = min(best[name], (time.process_time() - c0) / inner)
    best["fixed"] = best["short_bdf"] - best["integrator_short"]
    return {"flexmb": os.path.dirname(fm.__file__), **{k: round(v * 1e3, 4) for k, v in best.items()}}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--base", help="the other installation's Python interpreter (alternated with this one)")
    ap.add_argument("--pairs", type=int, default=3)
    ap.add_argument("--rounds", type=int, default=20)
    ap.add_argument("--label", default="this", help="label of this installation's rows")
    ap.add_argument("--base-label", default="base", help="label of --base's rows")
    ap.add_argument("--out", help="a JSON-lines file the rows are appended to")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(measure(args.rounds)))
        return
    rows = []
    for _ in range(args.pairs):
        for python, label in ((args.base, args.base_label), (sys.executable, args.label)):
            if python is None:
                continue
            out = subprocess.run([python, os.path.abspath(__file__), "--child", "--rounds", str(args.rounds)],
                                 check=True, capture_output=True, text=True).stdout
            row = {"kind": "simulate_fixed", "scene": "B1", "n_segments": 8, "rtol": 2e-5, "atol": 2e-7, "n_out": 2,
                   "flexmb_build": label, "date": time.strftime("%Y-%m-%d %H:%M"),
                   "loadavg_1min": os.getloadavg()[0], **json.loads(out.strip().splitlines()[-1])}
            rows.append(row)
            print(json.dumps(row), flush=True)
    if args.out:
        with open(args.out, "a", encoding="utf-8") as fh:
            fh.write("".join(json.dumps(r) + "\n" for r in rows))


if __name__ == "__main__":
    main()
