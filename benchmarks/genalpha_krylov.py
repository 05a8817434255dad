"""Generalized-alpha on large models: the dense Newton solves against the matrix-free ones (issue 28).

    git archive main src plugins | tar -x -C /tmp/before
    OPENBLAS_NUM_THREADS=1 python benchmarks/genalpha_krylov.py --src before=/tmp/before/src after=src \\
        --case b6:32:0.02 b6:128:0.02 b6:512:0.01 b1:128:0.01 b1:512:0.01 --repeat 3

Each configuration (a flexmb source tree, a scene, its size and span, and
a Newton path: ``default`` as ``simulate`` picks it, ``dense`` or
``krylov`` forced through ``GeneralizedAlpha.krylov_min_coords`` and
``krylov_min_loop_coords``) runs in
its own process, in ``--repeat`` alternating rounds; a configuration's CPU
time (``time.process_time`` around ``fm.simulate``; building the model and
a first short run, which loads the kernels, are not counted) is its least
over the rounds. B6 damped (``scenes.b6``) and B1 (``scenes.b1``) run with
``method="GeneralizedAlpha"``, ``rtol`` (default 1e-4) and ``atol = rtol
/ 100``; B6 with the articulated complement. The counts are exact: steps,
right-hand sides (those of the Krylov products included), Jacobians or
preconditioner set-ups, LU factorisations, GMRES iterations, Newton
iterations; the peak resident memory of the process is reported
(``ru_maxrss``). The last output's slider position (B6) or tip (B1) is
reported, to compare the paths. Appends rows to
``results/genalpha_krylov.jsonl``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
RESULTS = os.path.join(HERE, "results")

CHILD = """
import json, resource, sys, time
import numpy as np
sys.path.insert(0, {here!r})
import scenes, flexmb as fm
from flexmb.genalpha import GeneralizedAlpha
scene, n_seg, t_end, rtol, mode = {scene!r}, {n}, {t_end}, {rtol}, {mode!r}
if mode != "default":
    GeneralizedAlpha.krylov_min_coords = GeneralizedAlpha.krylov_min_loop_coords = 0 if mode == "krylov" else 10**9
solvers = []
init = GeneralizedAlpha.__init__
def __init__(self, *a, **k):
    solvers.append(self)
    init(self, *a, **k)
GeneralizedAlpha.__init__ = __init__
if scene == "b6":
    model, positions = scenes.b6(damped=True, n_segments=n_seg)
    system = model.build(complement="articulated")
    kw = dict(positions=positions)
else:
    system = scenes.b1(n_seg).build()
    kw = dict()
kw.update(method="GeneralizedAlpha", rtol=rtol, atol=rtol / 100, n_out=11, progress=False)
fm.simulate(system, min(t_end, 1e-3), **kw)  # kernels loaded
solvers.clear()
c0 = time.process_time()
res = fm.simulate(system, t_end, **kw)
cpu = time.process_time() - c0
end = float(res.coordinate("rail")[-1]) if scene == "b6" else float(res.x[-1, -1])
print(json.dumps(dict(cpu_s=cpu, status=res.status, n=int(system.n_speeds), steps=int(res.n_steps),
                      rhs=int(res.n_rhs), jac=int(res.n_jac), lu=sum(s.nlu for s in solvers),
                      krylov=sum(getattr(s, "n_krylov", 0) for s in solvers), newton=sum(s.n_newton for s in solvers),
                      rejected=sum(s.n_rejected for s in solvers), end=end,
                      peak_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)))
"""


def _child(python, code, env) -> dict:
    out = subprocess.run([python, "-c", code], capture_output=True, text=True, env=env, timeout=7200)
    lines = [ln for ln in out.stdout.splitlines() if ln.startswith("{")]
    if out.returncode or not lines:
        return {"status": f"failed: {out.stderr[-400:]}"}
    return json.loads(lines[-1])


def main(argv=None) -> None:
    """Run the configurations in alternating rounds and append their rows."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--src", nargs="+", default=["after=" + os.path.join(os.path.dirname(HERE), "src")],
                    help="label=path of a flexmb source tree, put first on PYTHONPATH")
    ap.add_argument("--case", nargs="+", default=["b6:32:0.02"], help="scene:N:t_end (scene b6 or b1)")
    ap.add_argument("--mode", nargs="+", default=["default"], help="default, dense or krylov")
    ap.add_argument("--rtol", type=float, default=1e-4)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(RESULTS, "genalpha_krylov.jsonl"))
    args = ap.parse_args(argv)
    sources = [s.split("=", 1) for s in args.src]
    configs = [(label, path, case, mode) for case in args.case for label, path in sources for mode in args.mode]
    rows = {c: [] for c in configs}
    started = time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime())
    for _ in range(args.repeat):
        for config in configs:
            label, path, case, mode = config
            scene, n, t_end = case.split(":")
            env = dict(os.environ, PYTHONPATH=os.path.abspath(path), OPENBLAS_NUM_THREADS="1")
            code = CHILD.format(here=HERE, scene=scene, n=int(n), t_end=float(t_end), rtol=args.rtol, mode=mode)
            rows[config].append(_child(sys.executable, code, env))
    with open(args.out, "a") as fh:
        for (label, path, case, mode), runs in rows.items():
            done = [r for r in runs if "cpu_s" in r]
            row = dict(min(done, key=lambda r: r["cpu_s"])) if done else dict(runs[-1])
            scene, n, t_end = case.split(":")
            row.update(source=label, scene=scene, n_segments=int(n), t_end=float(t_end), mode=mode, rtol=args.rtol,
                       cpu_rounds=[r.get("cpu_s") for r in runs], openblas_num_threads="1", started=started,
                       load_avg_1min=os.getloadavg()[0])
            if "cpu_s" in row and row.get("steps"):
                row["cpu_per_step_ms"] = 1e3 * row["cpu_s"] / row["steps"]
            print(json.dumps(row))
            fh.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
