"""CVODE stepped in compiled code (flexmb.integrators.cvode_direct) against scikit-sundae's CVODE and Exudyn (issue 31).

    OPENBLAS_NUM_THREADS=1 python benchmarks/cvode_direct.py                  # in-process, six cases
    OPENBLAS_NUM_THREADS=1 python benchmarks/cvode_direct.py --compile-time   # first use of the callbacks, cold

**In-process** (default): for each case ``SCENE:N:RTOL`` (the robust rtols of
the side-by-side run, docs/benchmarks.md, atol = rtol / 100, t_end = 1 s,
two outputs), in alternating rounds (``--repeat``, least CPU time of each):

* ``main``: ``fm.simulate(system, 1.0, method="CVODE_BDF", ...)`` on
  scikit-sundae's CVODE (a Python call per step and per evaluation), main's
  path, selected by patching ``direct_choice.compiled_loop`` to return None
  (what happens for the models the compiled loop does not cover);
* ``simulate``: the same call, now CVODE stepped in compiled code;
* ``simulate_robust``: the same at its own robust rtol, where that differs
  (dense cases: the compiled Jacobian changes the last bits, and with them
  the step sequence; the GMRES cases take main's very steps);
* ``exudyn``: Exudyn's tuned setting of that run (its own CPU time of
  ``SolveSystem``, a process of the peers' venv per round, ``--peers-python``).

The error is the distance of the tip at t = 1 s to a reference
(``work_precision.reference``: ``--ref-method`` at ``--ref-rtol``, cached in
results/refs). A robust rtol is the loosest of :data:`RTOLS` from which every
tighter one passes :data:`TARGET` at atol x (1, 1 + 1e-12, 1 - 1e-12).

**Compile time** (``--compile-time``): a new process with an empty
``NUMBA_CACHE_DIR`` runs B1 N = 4 on main's path first (the open-tree
kernels compile), then through the compiled loop twice: the first run's CPU
less the second's is what the callbacks cost on first use.

One JSON line per run goes to ``--out`` (default
``benchmarks/results/cvode_direct.jsonl``, appended).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import flexmb as fm  # noqa: E402
import work_precision as wp  # noqa: E402
from flexmb.integrators import cvode_direct, direct_choice  # noqa: E402
from peers.picks import robust_setting  # noqa: E402
from startup import PEERS, _env  # noqa: E402

#: Exudyn's tuned setting per case (docs/benchmarks.md, "Side by side, honestly"): Newton rtol, steps
EXUDYN_TUNED = {("B1", 8): (1e-5, 4000), ("B1", 16): (1e-5, 5600), ("B1", 64): (1e-5, 5600), ("B2", 16): (1e-4, 4000),
                ("B2", 32): (1e-4, 4000), ("B2", 64): (1e-4, 4000)}
DEFAULT_CASES = ["B1:8:2e-5", "B1:16:5e-6", "B1:64:5e-6", "B2:16:1e-5", "B2:32:2e-5", "B2:64:5e-6"]
#: the rtol grid of the side-by-side run, the atol perturbations a robust rtol must pass under, the target (m)
RTOLS = (1e-4, 5e-5, 2e-5, 1e-5, 5e-6, 2e-6, 1e-6)
PERTURBATIONS = (0.0, 1e-12, -1e-12)
TARGET = 1e-6

COMPILE_RUN = """
import sys, time, json
sys.path.insert(0, {bench!r})
import flexmb as fm
from flexmb.integrators import cvode_direct, direct_choice
from scenes import b1
system = b1(4).build()
kw = dict(method="CVODE_BDF", rtol=1e-6, n_out=2, progress=False)
orig = direct_choice.compiled_loop
direct_choice.compiled_loop = lambda *a: None
c = [time.process_time()]
fm.simulate(system, 0.1, **kw)
c.append(time.process_time())
direct_choice.compiled_loop = orig
fm.simulate(system, 0.1, **kw)
c.append(time.process_time())
fm.simulate(system, 0.1, **kw)
c.append(time.process_time())
print(json.dumps({{"main_first_s": c[1] - c[0], "direct_first_s": c[2] - c[1], "direct_second_s": c[3] - c[2]}}))
"""


def parse_case(text: str) -> tuple[str, int, float]:
    """``"B1:8:2e-5"`` -> ``("B1", 8, 2e-5)``."""
    scene, n, rtol = text.split(":")
    return scene, int(n), float(rtol)


def run_simulate(system, rtol, main=False, atol=None):
    """simulate() on the compiled loop, or on main's path: (result, cpu s, wall s)."""
    orig = direct_choice.compiled_loop
    if main:
        direct_choice.compiled_loop = lambda *args: None
    try:
        c0, t0 = time.process_time(), time.perf_counter()
        res = fm.simulate(system, 1.0, method="CVODE_BDF", rtol=rtol, atol=rtol / 100 if atol is None else atol,
                          n_out=2, progress=False)
        return res, time.process_time() - c0, time.perf_counter() - t0
    finally:
        direct_choice.compiled_loop = orig


def run_exudyn(python, scene, n):
    """Exudyn's tuned run in a process of its venv: its own (cpu s, wall s) of SolveSystem, and its tip."""
    newton, steps = EXUDYN_TUNED[(scene, n)]
    cmd = [python, os.path.join(PEERS, "exudyn_beam.py"), "--scene", scene, "--n", str(n), "--configs",
           f"{newton:g}:{steps}", "--repeat", "1"]
    out = subprocess.run(cmd, capture_output=True, text=True, env=_env(), cwd=PEERS)
    rows = [json.loads(line) for line in out.stdout.splitlines() if line.startswith("{")]
    if not rows:
        raise RuntimeError(f"exudyn_beam.py gave no row: {out.stderr[-500:]}")
    return rows[-1]


def _error(scene, res, ref) -> float:
    return float(np.linalg.norm(np.asarray(wp.scenes()[scene].output(res), float) - ref))


def robust_rtol(system, scene, n, ref, main, out) -> float | None:
    """The loosest rtol of :data:`RTOLS` from which every tighter one passes at every perturbed atol."""
    rows = []
    for rtol in RTOLS:
        for p in PERTURBATIONS:
            atol = rtol / 100 * (1.0 + p)
            res, _, _ = run_simulate(system, rtol, main=main, atol=atol)
            row = {"kind": f"{'main' if main else 'simulate'}_scan", "scene": scene, "n_segments": n, "rtol": rtol,
                   "atol": atol, "atol_perturbation": p, "status": res.status, "error": _error(scene, res, ref),
                   "steps": res.n_steps}
            _write(out, row)
            rows.append(row)
    return robust_setting({r: [x for x in rows if x["rtol"] == r] for r in RTOLS}, TARGET)


def in_process(args, out) -> None:
    """The alternating in-process rounds of every case."""
    for case in args.cases:
        scene, n, rtol = parse_case(case)
        sc = wp.scenes()[scene]
        ref = wp.reference(sc, n, args.ref_rtol, method=args.ref_method)["output"]
        system = sc.build(n)[0]
        run_simulate(system, rtol, main=True)  # warm-up: kernels and callbacks loaded
        run_simulate(system, rtol)
        dense = system.n_speeds < 48
        robust = robust_rtol(system, scene, n, ref, False, out) if dense and args.scan else rtol
        kinds = ["main", "simulate"] + (["simulate_robust"] if robust not in (None, rtol) else [])
        kinds += ["exudyn"] if args.peers_python else []
        best: dict = {}
        for r in range(args.repeat):
            for kind in kinds:
                row = _one(kind, system, scene, n, robust if kind == "simulate_robust" else rtol, ref, args)
                row.update(round=r, case=case, date=time.strftime("%Y-%m-%d %H:%M", time.gmtime()),
                           loadavg_1min=round(os.getloadavg()[0], 2))
                _write(out, row)
                if kind not in best or row["cpu_s"] < best[kind]["cpu_s"]:
                    best[kind] = row
        _print_case(case, best, robust)


def _one(kind, system, scene, n, rtol, ref, args) -> dict:
    if kind == "exudyn":
        r = run_exudyn(args.peers_python, scene, n)
        newton, steps = EXUDYN_TUNED[(scene, n)]
        return {"kind": kind, "scene": scene, "n_segments": n, "cpu_s": r["cpu_s"], "wall_s": r["wall_s"],
                "setting": f"Newton {newton:g}, {steps} steps"}
    res, cpu, wall = run_simulate(system, rtol, main=kind == "main")
    return {"kind": kind, "scene": scene, "n_segments": n, "rtol": rtol, "atol": rtol / 100, "cpu_s": round(cpu, 5),
            "wall_s": round(wall, 5), "steps": res.n_steps, "rhs": res.n_rhs, "jac": res.n_jac,
            "error_m": _error(scene, res, ref),
            "linear_solver": "dense" if system.n_speeds < 48 else "GMRES + O(n) preconditioner"}


def _print_case(case, best, robust) -> None:
    main = best["main"]
    print(f"{case} (robust rtol of the compiled loop: {robust}):")
    for kind, row in best.items():
        counts = f"steps {row.get('steps')} rhs {row.get('rhs')} jac {row.get('jac')}"
        err = row.get("error_m")
        print(f"  {kind:16s} cpu {row['cpu_s']:.4f} s  /main {row['cpu_s'] / main['cpu_s']:.3f}  {counts}  error "
              f"{err if err is None else f'{err:.2e}'} m")
    if "exudyn" in best:
        ex = best["exudyn"]["cpu_s"]
        sim = best.get("simulate_robust", best["simulate"])
        print(f"  / exudyn tuned (CPU): simulate at its robust rtol {sim['cpu_s'] / ex:.3f}, main {main['cpu_s'] / ex:.3f}")


def compile_time(args, out) -> None:
    """The callbacks' first use with an empty cache, in new processes (``--repeat`` of them)."""
    for r in range(args.repeat):
        with tempfile.TemporaryDirectory() as cache:
            env = dict(_env(), NUMBA_CACHE_DIR=cache)
            proc = subprocess.run([sys.executable, "-c", COMPILE_RUN.format(bench=HERE)], capture_output=True,
                                  text=True, env=env, cwd=HERE)
        if proc.returncode:
            raise RuntimeError(proc.stderr[-1000:])
        row = {"kind": "compile_time", "round": r, **json.loads(proc.stdout.strip().splitlines()[-1]),
               "date": time.strftime("%Y-%m-%d %H:%M", time.gmtime()), "loadavg_1min": round(os.getloadavg()[0], 2)}
        row["callbacks_first_use_s"] = row["direct_first_s"] - row["direct_second_s"]
        _write(out, row)
        print(json.dumps(row))


def _write(out, row) -> None:
    with open(out, "a") as f:
        f.write(json.dumps(row) + "\n")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="+", default=DEFAULT_CASES, help="SCENE:N:RTOL (atol = rtol / 100)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--ref-rtol", type=float, default=1e-9)
    ap.add_argument("--ref-method", default="Radau")
    ap.add_argument("--no-scan", dest="scan", action="store_false", help="no robust-rtol scan of the dense cases")
    ap.add_argument("--peers-python", default="/work/venv-peers/bin/python" if os.path.exists(
        "/work/venv-peers/bin/python") else None, help="the peers' venv's python (Exudyn); none: no Exudyn runs")
    ap.add_argument("--compile-time", action="store_true", help="the callbacks' first use, cold cache")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "cvode_direct.jsonl"))
    args = ap.parse_args(argv)
    if args.compile_time:
        compile_time(args, args.out)
    else:
        in_process(args, args.out)


if __name__ == "__main__":
    main()
