"""CPU time of B6 damped in flexmb (one or more source trees) and Exudyn, alternating runs (issue 28).

    OPENBLAS_NUM_THREADS=1 python benchmarks/peers/cpu_b6.py --n 8 32 \\
        --src before=/tmp/old/src after=src --flexmb GeneralizedAlpha:3e-4 auto:1e-4 --exudyn 4000:1e-4

On a machine shared with other jobs a run's wall time is mostly waiting
for a core (at a load of 15 on 2 cores a 0.8 s run took 10 s of wall
time), so this script measures the CPU time of the process while it
simulates (``time.process_time`` around ``fm.simulate`` and Exudyn's
``SolveSystem``; building the model is not counted, nor a warm-up run of
the same settings over ``--warmup`` s, 0.05 by default, whose counts each row
keeps under ``warmup``). Every configuration
runs in its own process (``--src`` puts another flexmb source tree first
on ``PYTHONPATH``, to compare versions), in ``--repeat`` alternating rounds
(each round every flexmb configuration of every source, then every Exudyn
one); a configuration's time is its least CPU time over the rounds. The
model, span, error and settings are those of ``compare_b6.py`` (0.5 s,
articulated complement, atol = rtol / 100; the error is the largest slider
difference at 100 times from the cached CVODE_BDF reference at rtol 1e-11,
which compare_b6.py writes to ``results/refs``: run it first for each N).
Besides the time, each flexmb row has the run's exact counts (steps, right-hand
sides, Jacobians or preconditioner set-ups, ``projections``: the drift check's,
each a restart, and ``cvode_projections``: CVODE's own, ``Result.n_cvode_projections``,
null for a source tree older than that counter). CVODE_BDF on B6
steps in compiled code (``flexmb.integrators.cvode_direct_loops``) since
issue 28's prototype moved into flexmb; ``--src before=PATH`` times an
older source tree beside it. Writes ``--out``
(``benchmarks/results/cpu_b6.jsonl``).

An Exudyn row says whether its run kept the configured fixed steps
(``fixed_steps``): where its Newton fails, Exudyn's step control shortens
steps and refreshes the Jacobian, and the run is not the configuration
asked for. That happens on B6 at N = 512 with the Newton tolerance 1e-4
(2,638 steps and 8,859 Jacobians instead of 401 and 8 over 0.05 s, 31 x the
CPU): use 1e-5 there (``--exudyn 4000:1e-4:128 4000:1e-5``), as its
tolerance that converges at every N.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
BENCH = os.path.dirname(HERE)
REFS = os.path.join(BENCH, "results", "refs")
#: the span of each flexmb process's warm-up run (the timed run's settings), s: on B6 at N = 8 and 32 it takes
#: Jacobians, stores outputs and projects (generalized-alpha at rtol 1e-3: 2 and 8 projections; CVODE_BDF at
#: 3e-3: ~470 of its own), so every kernel and first call of the timed run is made before it (0.01 s did not
#: project: some were loaded inside the timed run)
WARMUP = 0.05

FLEXMB_CHILD = """
import json, sys, time
import numpy as np
sys.path.insert(0, {bench!r})
import scenes, flexmb as fm
n, method, rtol = {n}, {method!r}, {rtol}
model, positions = scenes.b6(damped=True, n_segments=n)
system = model.build()
kw = dict(positions=positions, complement="articulated", method=method, rtol=rtol, atol=rtol / 100, n_out=101,
          progress=False)
# the kernels loaded, and the first calls made, by a run of the same settings over {warm} s: it takes a
# Jacobian, stores outputs and projects (generalized-alpha's drift, CVODE's own), as the timed run does
warm = fm.simulate(system, {warm}, **kw)
c0, w0 = time.process_time(), time.perf_counter()
res = fm.simulate(system, 0.5, **kw)
cpu, wall = time.process_time() - c0, time.perf_counter() - w0
ref = np.asarray(json.load(open({ref!r})), float)
err = float(np.max(np.abs(np.asarray(res.coordinate("rail"), float)[1:] - ref)))
print(json.dumps(dict(cpu_s=cpu, wall_s=wall, error=err, steps=int(res.n_steps), rhs_evals=int(res.n_rhs),
                      jac_evals=int(res.n_jac), projections=int(res.n_projections),
                      cvode_projections=getattr(res, "n_cvode_projections", None), method_used=res.method,
                      flexmb=fm.__file__, warmup=dict(span=float({warm}), steps=int(warm.n_steps),
                      jac_evals=int(warm.n_jac), projections=int(warm.n_projections),
                      cvode_projections=getattr(warm, "n_cvode_projections", None)))))
"""

EXUDYN_CHILD = """
import json, sys, time
sys.path.insert(0, {here!r})
import numpy as np
import exudyn_b6 as e
d = json.load(open({data!r}))
ref = np.asarray(json.load(open({ref!r})), float)
calls = []
original = e.exu.MainSolverImplicitSecondOrder.SolveSystem
def timed(self, *a, **k):
    c0 = time.process_time()
    out = original(self, *a, **k)
    calls.append(time.process_time() - c0)
    return out
e.exu.MainSolverImplicitSecondOrder.SolveSystem = timed
setup, wall, y, counters, nc, crank = e.run(d, {steps}, 0.5, 100, {newton}, "symbolic")
print(json.dumps(dict(cpu_s=calls[-1], wall_s=wall, error=float(np.max(np.abs(y - ref))), steps=counters["steps"],
                      jac_evals=counters["jac"], newton=counters["newton"],
                      fixed_steps=counters["output_on_steps"] and counters["steps"] == {steps} + 1)))
"""


def _child(python, code, env) -> dict:
    out = subprocess.run([python, "-c", code], capture_output=True, text=True, env=env, timeout=3600)
    lines = [ln for ln in out.stdout.splitlines() if ln.startswith("{")]
    if out.returncode or not lines:
        return {"status": f"failed: {out.stderr[-300:]}"}
    return dict(json.loads(lines[-1]), status="finished")


def _upto(specs, n) -> list:
    """The specs ``A:B[:MAX_N]`` that apply at N (all, or those whose MAX_N >= N)."""
    return [s for s in specs if len(s.split(":")) < 3 or n <= int(s.split(":")[2])]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[8, 32])
    ap.add_argument("--src", nargs="+", default=["installed="], help="LABEL=PATH of flexmb source trees ('' for the "
                                                                      "installed one)")
    ap.add_argument("--flexmb", nargs="+", default=["GeneralizedAlpha:1e-4", "auto:1e-4"], help="METHOD:RTOL[:MAX_N]")
    ap.add_argument("--exudyn", nargs="+", default=["4000:1e-4"], help="STEPS:NEWTON_RTOL[:MAX_N]")
    ap.add_argument("--peers-python", default="/work/venv-peers/bin/python")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--warmup", type=float, default=WARMUP, help="span of the warm-up run of the same settings, s")
    ap.add_argument("--out", default=os.path.join(BENCH, "results", "cpu_b6.jsonl"))
    args = ap.parse_args(argv)
    env = dict(os.environ, OPENBLAS_NUM_THREADS=os.environ.get("OPENBLAS_NUM_THREADS", "1"))
    rows = []
    for n in args.n:
        ref_json = os.path.join(REFS, f"B6damped_N{n}_T0.5_out100_ref.json")
        data = os.path.join(REFS, f"B6damped_N{n}_data.json")
        best = {}
        for rnd in range(args.repeat):
            runs = []
            for src in args.src:
                label, path = src.split("=", 1)
                cenv = dict(env, PYTHONPATH=os.path.abspath(path)) if path else env
                for spec in _upto(args.flexmb, n):
                    method, rtol = spec.split(":")[:2]
                    code = FLEXMB_CHILD.format(bench=BENCH, n=n, method=method, rtol=float(rtol), ref=ref_json,
                                               warm=args.warmup)
                    runs.append((("flexmb", label, method, float(rtol)), sys.executable, code, cenv))
            for spec in _upto(args.exudyn, n):
                steps, newton = spec.split(":")[:2]
                code = EXUDYN_CHILD.format(here=HERE, data=data, ref=ref_json, steps=int(steps), newton=float(newton))
                runs.append((("exudyn", "", int(steps), float(newton)), args.peers_python, code, env))
            for key, python, code, cenv in runs:
                row = _child(python, code, cenv)
                print(f"N = {n} round {rnd + 1}: {key}: {row.get('cpu_s', float('nan')):.3f} s CPU, "
                      f"{row.get('wall_s', float('nan')):.2f} s wall, error {row.get('error', float('nan')):.2e}"
                      + ("" if row.get("fixed_steps", True) else ", NOT at its fixed steps (Newton failures)"),
                      flush=True)
                old = best.get(key)
                rounds = (old["cpu_rounds"] if old else []) + [row.get("cpu_s")]
                if old is None or (row.get("cpu_s") is not None and (old.get("cpu_s") is None
                                                                     or row["cpu_s"] < old["cpu_s"])):
                    best[key] = dict(row)
                best[key]["cpu_rounds"] = rounds
        for (tool, label, setting, tol), row in best.items():
            rows.append(dict(row, tool=tool, source=label, n_segments=n, t_end=0.5,
                             setting=setting, tol=tol, load_avg_1min=os.getloadavg()[0],
                             openblas_num_threads=env["OPENBLAS_NUM_THREADS"],
                             started=time.strftime("%Y-%m-%d %H:%M:%S")))
        with open(args.out + ".tmp", "w") as fh:
            fh.writelines(json.dumps(r) + "\n" for r in rows)
        os.replace(args.out + ".tmp", args.out)


if __name__ == "__main__":
    main()
