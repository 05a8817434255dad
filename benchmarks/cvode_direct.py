"""CVODE without Python in the step loop: ctypes on SUNDIALS and numba C callbacks against ``simulate()`` (issue 31).

    OPENBLAS_NUM_THREADS=1 python benchmarks/cvode_direct.py                 # in-process, the four cases
    OPENBLAS_NUM_THREADS=1 python benchmarks/cvode_direct.py --processes     # one process per run, B1 N = 8

A feasibility study for issue 31's "take Python out of the step loop". The
prototype (:mod:`sundials_direct`, :mod:`cvode_callbacks`) calls CVODE
directly through ctypes on the SUNDIALS libraries that scikit-sundae's wheel
bundles, with the right-hand side, the dense Jacobian and the Newton
preconditioner as numba C callbacks calling flexmb's kernels, and CVODE's
step loop between two output times compiled: one Python call per output.

**In-process** (default): for each case ``SCENE:N:RTOL`` (the robust rtols of
the side-by-side run, docs/benchmarks.md, atol = rtol / 100, t_end = 1 s,
two outputs), in alternating rounds (``--repeat``, least CPU time of each):

* ``simulate``: ``fm.simulate(system, 1.0, method="CVODE_BDF", ...)``, flexmb
  today (scikit-sundae, a Python call per step and per evaluation);
* ``direct``: the prototype with its compiled callbacks;
* ``direct_pyjac`` (dense cases only): the prototype with flexmb's own
  ``state_jacobian`` called from Python as the Jacobian, which must take
  exactly flexmb's steps (counts equal, final states equal): the check that
  the loop is CVODE driven as flexmb drives it;
* ``direct_pyrhs`` (dense cases only): the right-hand side from Python too
  (``System._state_rate`` as a ctypes callback), the step loop still
  compiled: what the binding would cost a model whose loads are not all
  compiled;
* ``exudyn``: Exudyn's tuned setting of that run (its own timing of
  ``SolveSystem``, a process of the peers' venv per round, ``--peers-python``).

The error is the distance of the tip at t = 1 s to the reference of
``work_precision.py`` (Radau at ``--ref-rtol``, cached in results/refs).

**One process per run** (``--processes``): B1 N = 8 as a script doing it
this way (imports flexmb and the prototype, builds, runs, prints the tip),
without and with flexmb's resolution monitor (whose import brings
``flexmb.integrators``: scipy.integrate and scikit-sundae), against
flexmb's script of ``startup.py``, Exudyn's, and a script that only imports
flexmb and builds the model; CPU time of the whole process, warm caches,
least of ``--repeat`` alternating rounds. The direct scripts report their
phases and which of scipy's and scikit-sundae's modules they imported.

One JSON line per run goes to ``--out`` (default
``benchmarks/results/cvode_direct.jsonl``, appended).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import flexmb as fm  # noqa: E402
import work_precision as wp  # noqa: E402
from peers.picks import robust_setting  # noqa: E402
from startup import EXUDYN_RUN, FLEXMB_RUN, PEERS, _env  # noqa: E402
from sundials_direct import KRYLOV_DIM, DirectCVODE  # noqa: E402

#: Exudyn's tuned setting per case (docs/benchmarks.md, "Side by side, honestly"): Newton rtol, steps
EXUDYN_TUNED = {("B1", 8): (1e-5, 4000), ("B1", 16): (1e-5, 5600), ("B1", 64): (1e-5, 5600), ("B2", 16): (1e-4, 4000)}
DEFAULT_CASES = ["B1:8:2e-5", "B1:16:5e-6", "B1:64:5e-6", "B2:16:1e-5"]
#: the rtol grid of the side-by-side run, the atol perturbations a robust rtol must pass under, the target (m)
RTOLS = (1e-4, 5e-5, 2e-5, 1e-5, 5e-6, 2e-6, 1e-6)
PERTURBATIONS = (0.0, 1e-12, -1e-12)
TARGET = 1e-6

#: the prototype's run as a user's script: B1 N = 8 at rtol 2e-5, what startup.py's FLEXMB_RUN does; {monitor}
#: chooses whether flexmb's resolution monitor is given the steps (importing it imports flexmb.integrators, whose
#: package imports scipy.integrate and scikit-sundae's integrator classes)
DIRECT_RUN = """
import sys, time, json
sys.path.insert(0, {bench!r})
t = {{"start": time.process_time()}}
import numpy as np
import flexmb as fm
from scenes import b1
from sundials_direct import DirectCVODE
t["imports"] = time.process_time()
system = b1(8).build()
t["build"] = time.process_time()
n = system.n_speeds
mon = None
if {monitor}:
    from flexmb.integrators.monitor import ResolutionMonitor
    mon = ResolutionMonitor(system, 0.0, 1.0, 2e-5, 2e-7, "CVODE_BDF")
t["monitor"] = time.process_time()
with DirectCVODE(system, np.zeros(2 * n), 0.0, 1.0, rtol=2e-5, atol=2e-7, monitor=mon) as cv:
    y = cv.advance(1.0)
t["run"] = time.process_time()
res = fm.Result.from_states(system, y[:n], y[n:], t=1.0)
tip = [float(v) for v in res.shape("beam")[-1, -1]]
mods = sorted(m for m in sys.modules if m.split(".")[0] in ("scipy", "sksundae"))
print(json.dumps({{"phases": t, "modules": mods}}), file=sys.stderr)
print(tip)
"""

#: what every flexmb script of B1 N = 8 pays before it integrates: the imports and the build
BUILD_RUN = """
import sys
sys.path.insert(0, {bench!r})
import flexmb as fm
from scenes import b1
system = b1(8).build()
print([])
"""


def parse_case(text: str) -> tuple[str, int, float]:
    """``"B1:8:2e-5"`` -> ``("B1", 8, 2e-5)``."""
    scene, n, rtol = text.split(":")
    return scene, int(n), float(rtol)


def run_simulate(system, rtol):
    """flexmb today: (result, cpu s, wall s)."""
    c0, t0 = time.process_time(), time.perf_counter()
    res = fm.simulate(system, 1.0, method="CVODE_BDF", rtol=rtol, atol=rtol / 100, n_out=2, progress=False)
    return res, time.process_time() - c0, time.perf_counter() - t0


def run_direct(system, y0, rtol, python_jacobian=False, atol=None, python_rhs=False):
    """The prototype, as simulate() would run it (monitor, Krylov from 48 coordinates): (y1, stats, cpu, wall)."""
    from flexmb.integrators.monitor import ResolutionMonitor
    from flexmb.stepping import KRYLOV_MIN_COORDS

    c0, t0 = time.process_time(), time.perf_counter()
    layout = system.layout
    jac = (lambda t, y: system.state_jacobian(t, *layout.split(y))) if python_jacobian else None  # noqa: E731
    atol = rtol / 100 if atol is None else atol
    mon = ResolutionMonitor(system, 0.0, 1.0, rtol, atol, "CVODE_BDF")
    rhs = system._state_rate if python_rhs else None
    with DirectCVODE(system, y0, 0.0, 1.0, rtol=rtol, atol=atol, monitor=mon, jacobian=jac, rhs=rhs,
                     krylov=system.n_speeds >= KRYLOV_MIN_COORDS) as cv:
        y1 = cv.advance(1.0)
        stats = cv.stats()
    return y1, stats, time.process_time() - c0, time.perf_counter() - t0


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


def _tip(system, scene, y):
    n = system.n_speeds
    res = fm.Result.from_states(system, y[:n], y[n:], t=1.0)
    return np.asarray(wp.scenes()[scene].output(res), float)


def robust_rtol(system, scene, n, y0, ref, kind, out) -> float | None:
    """The loosest rtol of :data:`RTOLS` from which every tighter one passes at every perturbed atol.

    ``kind`` is ``"simulate"`` or ``"direct"`` (compiled callbacks); the
    runs are written to ``out`` (``kind`` suffixed ``_scan``).
    """
    rows = []
    for rtol in RTOLS:
        for p in PERTURBATIONS:
            atol = rtol / 100 * (1.0 + p)
            if kind == "simulate":
                res = fm.simulate(system, 1.0, method="CVODE_BDF", rtol=rtol, atol=atol, n_out=2, progress=False)
                y1, status = np.concatenate([res.x[-1], res.xd[-1]]), res.status
            else:
                y1, _, _, _ = run_direct(system, y0, rtol, atol=atol)
                status = "finished"
            row = {"kind": f"{kind}_scan", "scene": scene, "n_segments": n,
                   "rtol": rtol, "atol": atol, "atol_perturbation": p, "status": status,
                   "error": float(np.linalg.norm(_tip(system, scene, y1) - ref))}
            _write(out, row)
            rows.append(row)
    return robust_setting({r: [x for x in rows if x["rtol"] == r] for r in RTOLS}, TARGET)


def in_process(args, out) -> list[dict]:
    """The alternating in-process rounds of every case; the rows written."""
    rows = []
    for case in args.cases:
        scene, n, rtol = parse_case(case)
        sc = wp.scenes()[scene]
        ref = wp.reference(sc, n, args.ref_rtol)["output"]
        system = sc.build(n)[0]
        res, _, _ = run_simulate(system, rtol)  # warm-up: kernels loaded, callbacks compiled or loaded
        y0 = np.concatenate([res.x[0], res.xd[0]])
        y_sim = np.concatenate([res.x[-1], res.xd[-1]])
        dense = system.n_speeds < 48
        robust = {k: robust_rtol(system, scene, n, y0, ref, k, out) for k in ("simulate", "direct")}
        print(f"{case}: robust rtol (target {TARGET:g} m, atol x (1 +- 1e-12)): {robust}")
        kinds = ["simulate", "direct"] + (["direct_pyjac", "direct_pyrhs"] if dense else [])
        if robust["direct"] not in (None, rtol):
            kinds.append("direct_robust")
        if robust["simulate"] not in (None, rtol):
            kinds.append("simulate_robust")
        kinds += ["exudyn"] if args.peers_python else []
        for kind in [k for k in kinds if k in ("direct", "direct_pyjac", "direct_pyrhs")]:  # warm-up
            run_direct(system, y0, rtol, python_jacobian=kind in ("direct_pyjac", "direct_pyrhs"),
                       python_rhs=kind == "direct_pyrhs")
        best: dict = {}
        for r in range(args.repeat):
            for kind in kinds:
                r_tol = robust[kind.split("_")[0]] if kind.endswith("_robust") else rtol
                row = _one(kind, system, scene, n, r_tol, y0, y_sim, ref, args)
                row.update(round=r, case=case, date=time.strftime("%Y-%m-%d %H:%M", time.gmtime()),
                           loadavg_1min=round(os.getloadavg()[0], 2))
                _write(out, row)
                if kind not in best or row["cpu_s"] < best[kind]["cpu_s"]:
                    best[kind] = row
        rows += list(best.values())
        _print_case(case, best)
    return rows


def _one(kind, system, scene, n, rtol, y0, y_sim, ref, args) -> dict:
    if kind == "exudyn":
        r = run_exudyn(args.peers_python, scene, n)
        return {"kind": kind, "cpu_s": r["cpu_s"], "wall_s": r["wall_s"], "steps": r.get("steps"),
                "error_m": float(np.linalg.norm(np.asarray(r["output"] if "output" in r else r.get("tip"), float)
                                                - ref)) if ("output" in r or "tip" in r) else None,
                "setting": f"Newton {EXUDYN_TUNED[(scene, n)][0]:g}, {EXUDYN_TUNED[(scene, n)][1]} steps"}
    if kind.startswith("simulate"):
        res, cpu, wall = run_simulate(system, rtol)
        y1 = np.concatenate([res.x[-1], res.xd[-1]])
        counts = {"steps": res.n_steps, "rhs": res.n_rhs, "jac": res.n_jac}
    else:
        y1, stats, cpu, wall = run_direct(system, y0, rtol, python_jacobian=kind in ("direct_pyjac", "direct_pyrhs"),
                                          python_rhs=kind == "direct_pyrhs")
        counts = {k: stats[k] for k in ("steps", "rhs", "jac", "rhs_ls", "err_test_fails", "newton_iters",
                                         "lin_iters")}
    return {"kind": kind, "scene": scene, "n_segments": n, "rtol": rtol, "atol": rtol / 100, "cpu_s": round(cpu, 5),
            "wall_s": round(wall, 5), **counts, "error_m": float(np.linalg.norm(_tip(system, scene, y1) - ref)),
            "state_vs_simulate": float(np.max(np.abs(y1 - y_sim))),
            "linear_solver": "dense" if system.n_speeds < 48 else f"GMRES({KRYLOV_DIM}) + O(n) preconditioner"}


def _print_case(case, best) -> None:
    sim = best["simulate"]
    print(f"{case}:")
    for kind, row in best.items():
        ratio = row["cpu_s"] / sim["cpu_s"]
        counts = f"steps {row.get('steps')} rhs {row.get('rhs')} jac {row.get('jac')}"
        err = row.get("error_m")
        print(f"  {kind:13s} cpu {row['cpu_s']:.4f} s  /simulate {ratio:.3f}  {counts}  error "
              f"{err if err is None else f'{err:.2e}'} m  vs simulate {row.get('state_vs_simulate')}")
    d_rob = best.get("direct_robust", best["direct"])
    s_rob = best.get("simulate_robust", sim)
    print(f"  robust against robust (this run's scan): direct / simulate {d_rob['cpu_s'] / s_rob['cpu_s']:.3f}")
    if "exudyn" in best:
        ex = best["exudyn"]["cpu_s"]
        print(f"  / exudyn tuned (CPU): direct {best['direct']['cpu_s'] / ex:.3f}, direct at its robust rtol "
              f"{d_rob['cpu_s'] / ex:.3f}, simulate {sim['cpu_s'] / ex:.3f}")


def run_process(python: str, code: str) -> dict:
    """One new process running ``code``: its CPU (user + system), wall, status, last lines of stdout and stderr."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([python, "-c", code], capture_output=True, text=True, env=_env(), cwd=HERE)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    out, err = proc.stdout.strip().splitlines(), proc.stderr.strip().splitlines()
    return {"cpu_s": round(cpu, 4), "wall_s": round(wall, 4), "status": proc.returncode,
            "output": out[-1] if out else "", "stderr_last": err[-1] if err else ""}


def processes(args, out) -> None:
    """One process per run, alternating: the prototype's script, flexmb's, Exudyn's."""
    codes = {"direct": (sys.executable, DIRECT_RUN.format(bench=HERE, monitor=False)),
             "direct_monitor": (sys.executable, DIRECT_RUN.format(bench=HERE, monitor=True)),
             "flexmb": (sys.executable, FLEXMB_RUN.format(bench=HERE)),
             "build_only": (sys.executable, BUILD_RUN.format(bench=HERE))}
    if args.peers_python:
        codes["exudyn"] = (args.peers_python, EXUDYN_RUN.format(peers=PEERS))
    for python, code in codes.values():  # warm the caches
        run_process(python, code)
    best: dict = {}
    for r in range(args.repeat):
        for label, (python, code) in codes.items():
            res = run_process(python, code)
            if res["status"] != 0:
                raise RuntimeError(f"{label}: exit {res['status']}: {res['stderr_last']}")
            row = {"kind": f"process_{label}", "round": r, **res,
                   "date": time.strftime("%Y-%m-%d %H:%M", time.gmtime()), "loadavg_1min": round(os.getloadavg()[0], 2)}
            if label.startswith("direct"):
                info = json.loads(row.pop("stderr_last"))
                p = info["phases"]
                row.update(modules=info["modules"], phases={k: round(p[k] - p["start"], 4) for k in p})
            _write(out, row)
            if label not in best or row["cpu_s"] < best[label]["cpu_s"]:
                best[label] = row
    for label, row in best.items():
        extra = f"  phases {row.get('phases')}  scipy/sksundae modules: {len(row.get('modules', []))}" \
            if label.startswith("direct") else ""
        print(f"{label:14s} least CPU {row['cpu_s']:.3f} s  tip {row['output']}{extra}")
    if "exudyn" in best:
        for label in ("direct", "direct_monitor", "flexmb", "build_only"):
            print(f"{label} / exudyn: {best[label]['cpu_s'] / best['exudyn']['cpu_s']:.2f}")


def _write(out, row) -> None:
    with open(out, "a") as f:
        f.write(json.dumps(row) + "\n")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="+", default=DEFAULT_CASES, help="SCENE:N:RTOL (atol = rtol / 100)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--ref-rtol", type=float, default=1e-9)
    ap.add_argument("--peers-python", default="/work/venv-peers/bin/python" if os.path.exists(
        "/work/venv-peers/bin/python") else None, help="the peers' venv's python (Exudyn); none: no Exudyn runs")
    ap.add_argument("--processes", action="store_true", help="one process per run, B1 N = 8")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "cvode_direct.jsonl"))
    args = ap.parse_args(argv)
    if args.processes:
        processes(args, args.out)
    else:
        in_process(args, args.out)


if __name__ == "__main__":
    main()
