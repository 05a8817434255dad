"""One process per simulation, warm cache: B1 N = 8 in flexmb against Exudyn, and where flexmb's start-up goes.

    OPENBLAS_NUM_THREADS=1 python benchmarks/startup.py \
        --venv base=/work/venv-start-base --venv branch=/work/venv-start --repeat 5
    OPENBLAS_NUM_THREADS=1 python benchmarks/startup.py --breakdown --venv branch=/work/venv-start
    python benchmarks/startup.py --summary

**Alternating runs** (the default): every run is a new process, as a
script, a test or a study case runs; each round runs B1 N = 8 once per
flexmb venv and once in Exudyn (the peers' venv, ``--peers-python``),
in turn, so that the machine's load drifts over all of them alike. The
figure is the CPU time (user + system) of the whole process and of the
children it waited for (``getrusage(RUSAGE_CHILDREN)``), from the
interpreter's start to its exit: imports, the model's build, the kernels'
loading, the simulation, the clean-up. The kernels' cache must be warm
(each venv's flexmb is run once, untimed, before the rounds).

* flexmb: the script ``import flexmb``, ``benchmarks/scenes.py``'s
  ``b1(8).build()`` and ``simulate(system, 1.0, method="CVODE_BDF",
  rtol=2e-5, atol=2e-7, n_out=2, progress=False)``: the configuration the
  in-process side-by-side run (``benchmarks/peers/compare.py``) picks as
  flexmb's fastest at error <= 1e-6 m (docs/benchmarks.md, "Side by side
  with Exudyn").
* Exudyn: ``benchmarks/peers/exudyn_beam.py``'s ``run("B1", 8, 4000)``:
  the same beam, generalized-alpha with h = 2.5e-4 s, the pick of that run.
* The dependencies alone (in the last venv given): a process that only
  imports numpy, numba and scipy.linalg, what flexmb's CVODE run (stepped
  in compiled code, CVODE called through ctypes) could not do without
  until session 9 (the dense Jacobian's Cholesky factor; numba's ``np.dot``
  and ``np.all`` imported scipy.linalg too). Since then the run compiles
  its Jacobian and loads only scipy's ``cython_blas`` and ``cython_lapack``
  (``flexmb._blas``): its floor is ``--floor``'s numpy and numba; the row
  is kept so that its figures compare with the earlier ones.

Both print the beam tip's position at t = 1 s; they must agree to 1e-5 m
(each is within 1e-6 m of the reference). One JSON line per run goes to
``--out`` (default ``benchmarks/results/startup.jsonl``, appended);
``--summary`` prints the least CPU per venv and the ratios flexmb/Exudyn.
With ``--parts`` each round also times, per venv, a process that only
imports flexmb and one that imports it and builds the model.

**The floor** (``--floor``): processes that only import numpy and numba, and numpy alone, against
Exudyn's run, alternating (rows to ``--out`` as tools ``floor_numpy_numba``, ``floor_numpy``).

**The exit** (``--exit``): the run as it is, ending with ``gc.freeze()``
and ending with ``os._exit`` (:data:`EXIT_ENDINGS`), alternating: what the
interpreter's clean-up costs, and how much of it is the cyclic garbage
collector's final collections over every object still alive. Written to
``--exit-out`` (default ``benchmarks/results/startup_exit.jsonl``).

**Breakdown** (``--breakdown``): one new process per venv, repeated
``--repeat`` times (the least of each figure is kept), timing with
``time.process_time`` the interpreter's start, the imports a run needs
(numpy, numba, scipy.linalg, then flexmb itself),
the first ``build()`` and ``simulate()`` and the same again in the same
process (warm: the kernels loaded), and numba's cache loads inside the first
ones: how many, and their CPU split into the index lookup (reading the
kernel's index and finding the signature), reading and unpickling the entry,
rebuilding the machine code (LLVM: parsing the bitcode kept for linking into
later compilations, of it ``of_it_parse_bitcode_s``, loading the object code,
resolving its symbols), numba's target refresh (numba loads its
compiler's registries before a cache load) and numba's runtime compiled
(``runtime_s``: ``rtsys.initialize``, which flexmb's loader called before
its first load until session 10). ``n`` counts the loads asked of flexmb's
kernel cache (shipped entries included); where flexmb reads an entry itself
(``lazy_bitcode.load_entry``, session 10) its read and unpickling includes
the index lookup. Written to ``--breakdown-out``
(default ``benchmarks/results/startup_breakdown.jsonl``, appended).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
PEERS = os.path.join(HERE, "peers")
RESULTS = os.path.join(HERE, "results")

#: flexmb's run as a user's script; {bench} is this folder (for scenes.py)
FLEXMB_RUN = """
import sys
sys.path.insert(0, {bench!r})
import flexmb as fm
from scenes import b1
system = b1(8).build()
res = fm.simulate(system, 1.0, method="CVODE_BDF", rtol=2e-5, atol=2e-7, n_out=2, progress=False)
print([float(v) for v in res.shape("beam")[-1, -1]])
"""

#: the parts of it: importing flexmb alone, and importing it and building the model (what every script pays
#: before it simulates); they print no tip
PARTS = {
    "import": "import flexmb\nprint('[]')\n",
    "import_build": "import sys\nsys.path.insert(0, {bench!r})\nimport flexmb\nfrom scenes import b1\n"
                    "system = b1(8).build()\nprint('[]')\n",
}

#: the exit (``--exit``): the same run ending as it does, with ``gc.freeze()`` as its last line (the
#: interpreter's final collections then skip every object alive), and with ``os._exit`` (no clean-up at all,
#: the standard streams flushed first); the run also prints the objects the collector tracks at its end
EXIT_ENDINGS = {
    "normal": "",
    "gc_freeze": "import gc\ngc.freeze()\n",
    "os_exit": "import os\nsys.stdout.flush()\nsys.stderr.flush()\nos._exit(0)\n",
}
TRACKED = "import gc\nprint(len(gc.get_objects()), file=sys.stderr)\n"

#: Exudyn's run, the peer script's own function (its harness, as compare.py times it)
EXUDYN_RUN = """
import sys
sys.path.insert(0, {peers!r})
import exudyn_beam
setup, wall, tip, counters, nc = exudyn_beam.run("B1", 8, 4000, 1.0)
assert counters["ok"], counters
print([float(v) for v in tip])
"""

#: the floor of flexmb's CVODE run until session 9: importing numba for the kernels and scipy.linalg for the dense
#: Jacobian's factor, and the interpreter's exit (kept for comparison with the earlier rows)
DEPENDENCIES_RUN = """
import numpy, numba, scipy.linalg
print("[]")
"""

#: the floor of any run that loads its kernels through numba (``--floor``): the interpreter, numpy and numba,
#: imported and left; and numpy alone (what a run whose machine code loads without numba could not avoid)
FLOOR_RUNS = {
    "floor_numpy_numba": "import numpy, numba\nprint('[]')\n",
    "floor_numpy": "import numpy\nprint('[]')\n",
}

#: the breakdown, in one new process of the venv's Python
BREAKDOWN = """
import time
t_start = time.process_time()
import json, sys
sys.path.insert(0, {bench!r})
out = {{"interpreter_s": t_start}}
t = time.process_time()
import numpy
out["import_numpy_s"] = time.process_time() - t
t = time.process_time()
import numba
out["import_numba_s"] = time.process_time() - t
t = time.process_time()
import scipy.linalg
out["import_scipy_linalg_s"] = time.process_time() - t
t = time.process_time()
import flexmb as fm
out["import_flexmb_s"] = time.process_time() - t
out["dispatchers_at_import"] = sum(
    1 for name, mod in list(sys.modules.items()) if name.startswith("flexmb.") and mod is not None
    for obj in vars(mod).values()
    if type(obj).__name__ == "CPUDispatcher" and getattr(obj, "__module__", "") == name)
out["modules_at_import"] = len(sys.modules)

from numba.core import caching
from numba.core.base import BaseContext
loads = {{"n": 0, "index_s": 0.0, "read_unpickle_s": 0.0, "rebuild_s": 0.0, "of_it_parse_bitcode_s": 0.0,
          "refresh_s": 0.0, "runtime_s": 0.0}}
def timed(key, f):
    def wrapper(*a, **k):
        t = time.process_time()
        try:
            return f(*a, **k)
        finally:
            loads[key] += time.process_time() - t
    return wrapper
caching.IndexDataCacheFile._load_index = timed("index_s", caching.IndexDataCacheFile._load_index)
caching.IndexDataCacheFile._load_data = timed("read_unpickle_s", caching.IndexDataCacheFile._load_data)
caching.CompileResultCacheImpl.rebuild = timed("rebuild_s", caching.CompileResultCacheImpl.rebuild)
from flexmb.kernels import cache as flexmb_cache, lazy_bitcode
if "rebuild" in vars(flexmb_cache._KernelCacheImpl):  # flexmb's own rebuild (the bitcode parsed lazily)
    flexmb_cache._KernelCacheImpl.rebuild = timed("rebuild_s", flexmb_cache._KernelCacheImpl.rebuild)
if hasattr(lazy_bitcode, "load_entry"):  # flexmb's own read of an entry (session 10)
    lazy_bitcode.load_entry = timed("read_unpickle_s", lazy_bitcode.load_entry)
BaseContext.refresh = timed("refresh_s", BaseContext.refresh)
from numba.core.runtime import rtsys
type(rtsys).initialize = timed("runtime_s", type(rtsys).initialize)  # numba's runtime compiled
from llvmlite import binding as ll
ll.parse_bitcode = timed("of_it_parse_bitcode_s", ll.parse_bitcode)
count = flexmb_cache.KernelCache.load_overload
def counted(self, *a, **k):
    loads["n"] += 1
    return count(self, *a, **k)
flexmb_cache.KernelCache.load_overload = counted

from scenes import b1
def run():
    t = time.process_time()
    system = b1(8).build()
    t1 = time.process_time()
    res = fm.simulate(system, 1.0, method="CVODE_BDF", rtol=2e-5, atol=2e-7, n_out=2, progress=False)
    return t1 - t, time.process_time() - t1
out["first_build_s"], out["first_simulate_s"] = run()
out["cache_loads"] = dict(loads)
out["warm_build_s"], out["warm_simulate_s"] = run()
out["modules_after_run"] = len(sys.modules)
print(json.dumps(out))
"""


def _env() -> dict:
    env = dict(os.environ)
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # a user's interpreter reads and writes the bytecode cache
    return env


def _checkout(python: str) -> str:
    out = subprocess.run([python, "-c", "import flexmb, os; print(os.path.dirname(flexmb.__file__))"],
                         capture_output=True, text=True, check=True, env=_env()).stdout.strip()
    return os.path.dirname(os.path.dirname(out))


def _commit(checkout: str) -> str:
    r = subprocess.run(["git", "-C", checkout, "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    dirty = subprocess.run(["git", "-C", checkout, "status", "--porcelain", "--untracked-files=no"],
                           capture_output=True, text=True).stdout.strip()
    return r.stdout.strip() + ("+dirty" if dirty else "")


def run_process(python: str, code: str, cwd: str) -> dict:
    """One new process running ``code``: its CPU (user + system, waited-for children), wall, status, output."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([python, "-c", code], capture_output=True, text=True, env=_env(), cwd=cwd)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    lines = proc.stdout.strip().splitlines()
    return {"cpu_s": round(cpu, 4), "wall_s": round(wall, 4), "status": proc.returncode,
            "output": lines[-1] if lines else "", "stderr_tail": proc.stderr.strip().splitlines()[-1:]}


def _row(tool, label, commit, r, extra) -> dict:
    return {"tool": tool, "venv": label, "commit": commit, "round": r,
            "date": time.strftime("%Y-%m-%d %H:%M", time.gmtime()), "loadavg_1min": round(os.getloadavg()[0], 2),
            **extra}


def measure(venvs: dict[str, str], peers_python: str, repeat: int, out: str, parts: bool = False) -> None:
    """Alternating rounds: each flexmb venv, then Exudyn, one new process each, ``repeat`` times.

    With ``parts``, each venv's round also runs :data:`PARTS` (``import flexmb`` alone; it and the build).
    """
    info = {}
    for label, venv in venvs.items():
        python = os.path.join(venv, "bin", "python")
        checkout = _checkout(python)
        info[label] = (python, _commit(checkout))
        print(f"{label}: {checkout} at {info[label][1]}", file=sys.stderr)
    flexmb_code = FLEXMB_RUN.format(bench=HERE)
    exudyn_code = EXUDYN_RUN.format(peers=PEERS)
    with tempfile.TemporaryDirectory(prefix="flexmb-startup-") as work:
        for label, (python, _) in info.items():  # warm each venv's kernel cache (untimed)
            r = run_process(python, flexmb_code, work)
            if r["status"]:
                raise SystemExit(f"{label}: the flexmb run failed: {r['stderr_tail']}")
        run_process(peers_python, exudyn_code, work)
        for r in range(repeat):
            tips = {}
            for label, (python, commit) in info.items():
                res = run_process(python, flexmb_code, work)
                tips[label] = res["output"]
                _write(out, _row("flexmb", label, commit, r, res))
                if parts:
                    for part, code in PARTS.items():
                        _write(out, _row(part, label, commit, r, run_process(python, code.format(bench=HERE), work)))
            res = run_process(peers_python, exudyn_code, work)
            tips["exudyn"] = res["output"]
            _write(out, _row("exudyn", "peers", "", r, res))
            _check_tips(tips)
            label, (python, commit) = list(info.items())[-1]
            _write(out, _row("dependencies", label, commit, r, run_process(python, DEPENDENCIES_RUN, work)))


def measure_floor(python: str, peers_python: str, repeat: int, out: str) -> None:
    """The floor (:data:`FLOOR_RUNS`) against Exudyn's run, alternating, ``repeat`` rounds, in ``python``'s venv."""
    exudyn_code = EXUDYN_RUN.format(peers=PEERS)
    with tempfile.TemporaryDirectory(prefix="flexmb-startup-") as work:
        run_process(peers_python, exudyn_code, work)
        best: dict = {}
        for r in range(repeat):
            for tool, code in [("exudyn", exudyn_code), *FLOOR_RUNS.items()]:
                res = run_process(peers_python if tool == "exudyn" else python, code, work)
                if res["status"]:
                    raise SystemExit(f"{tool}: {res['stderr_tail']}")
                _write(out, _row(tool, "peers" if tool == "exudyn" else "floor", "", r, res))
                best.setdefault(tool, []).append(res["cpu_s"])
    for tool, cpus in best.items():
        print(f"{tool:18s} least CPU {min(cpus):.3f} s over {len(cpus)}, / Exudyn {min(cpus) / min(best['exudyn']):.2f}")


def measure_exit(venvs: dict[str, str], repeat: int, out: str) -> None:
    """The exit's share: :data:`EXIT_ENDINGS` of flexmb's run, alternating, ``repeat`` rounds, per venv."""
    info = {label: os.path.join(venv, "bin", "python") for label, venv in venvs.items()}
    codes = {k: FLEXMB_RUN.format(bench=HERE) + TRACKED + v for k, v in EXIT_ENDINGS.items()}
    with tempfile.TemporaryDirectory(prefix="flexmb-startup-") as work:
        for python in info.values():
            run_process(python, codes["normal"], work)
        best: dict = {}
        for r in range(repeat):
            for label, python in info.items():
                for ending, code in codes.items():
                    res = run_process(python, code, work)
                    if res["status"]:
                        raise SystemExit(f"{label} {ending}: {res['stderr_tail']}")
                    _write(out, _row("exit_" + ending, label, _commit(_checkout(python)), r, res))
                    best.setdefault((label, ending), []).append(res["cpu_s"])
    for (label, ending), cpus in best.items():
        print(f"{label:10s} {ending:10s} least CPU {min(cpus):.3f} s over {len(cpus)}")


def _check_tips(tips: dict) -> None:
    values = {k: json.loads(v) for k, v in tips.items() if v.startswith("[")}
    if len(values) != len(tips):
        raise SystemExit(f"a run printed no tip position: {tips}")
    ref = values["exudyn"]
    for k, v in values.items():
        if max(abs(a - b) for a, b in zip(v, ref)) > 1e-5:
            raise SystemExit(f"{k}'s tip {v} differs from Exudyn's {ref} by more than 1e-5 m")


def _write(out: str, row: dict) -> None:
    print(json.dumps(row), file=sys.stderr)
    with open(out, "a", encoding="utf-8") as f:
        f.write(json.dumps(row) + "\n")


def breakdown(venvs: dict[str, str], repeat: int, out: str) -> None:
    """The breakdown per venv (least of ``repeat`` new processes per figure), one JSON line each."""
    code = BREAKDOWN.format(bench=HERE)
    with tempfile.TemporaryDirectory(prefix="flexmb-startup-") as work:
        runs: dict[str, list] = {label: [] for label in venvs}
        for label, venv in venvs.items():  # warm the cache (untimed)
            run_process(os.path.join(venv, "bin", "python"), code, work)
        for _ in range(repeat):
            for label, venv in venvs.items():
                res = run_process(os.path.join(venv, "bin", "python"), code, work)
                if res["status"]:
                    raise SystemExit(f"{label}: the breakdown failed: {res['stderr_tail']}")
                runs[label].append({**json.loads(res["output"]), "process_cpu_s": res["cpu_s"]})
        for label, venv in venvs.items():
            python = os.path.join(venv, "bin", "python")
            best = _least(runs[label])
            row = {"venv": label, "commit": _commit(_checkout(python)), "runs": len(runs[label]),
                   "date": time.strftime("%Y-%m-%d %H:%M", time.gmtime()),
                   "loadavg_1min": round(os.getloadavg()[0], 2), **best}
            _write(out, row)


def _least(rows: list[dict]) -> dict:
    """The least of each number over the runs (nested dicts too)."""
    first = rows[0]
    out = {}
    for k, v in first.items():
        if isinstance(v, dict):
            out[k] = _least([r[k] for r in rows])
        elif isinstance(v, (int, float)):
            out[k] = round(min(r[k] for r in rows), 4)
        else:
            out[k] = v
    return out


def summary(out: str) -> str:
    """Markdown table: least CPU per tool and venv over the rounds, and flexmb/Exudyn per commit."""
    rows = [json.loads(ln) for ln in open(out, encoding="utf-8") if ln.strip()]
    best: dict[tuple, list] = {}
    exudyn = [r["cpu_s"] for r in rows if r["tool"] == "exudyn" and r["status"] == 0]
    for r in rows:
        if r["tool"] == "flexmb" and r["status"] == 0:
            best.setdefault((r["venv"], r["commit"]), []).append(r["cpu_s"])
    ex = min(exudyn) if exudyn else float("nan")
    lines = ["| run | commit | processes | least CPU s | flexmb/Exudyn |", "|---|---|---|---|---|",
             f"| Exudyn | - | {len(exudyn)} | {ex:.3f} | - |"]
    for (venv, commit), cpus in sorted(best.items()):
        lines.append(f"| flexmb ({venv}) | {commit} | {len(cpus)} | {min(cpus):.3f} | {min(cpus) / ex:.2f} |")
    for part in PARTS:
        cpus: dict[tuple, list] = {}
        for r in rows:
            if r["tool"] == part and r["status"] == 0:
                cpus.setdefault((r["venv"], r["commit"]), []).append(r["cpu_s"])
        for (venv, commit), c in sorted(cpus.items()):
            lines.append(f"| only {part.replace('_', ' + ')} ({venv}) | {commit} | {len(c)} | {min(c):.3f} | "
                         f"{min(c) / ex:.2f} |")
    deps = [r["cpu_s"] for r in rows if r["tool"] == "dependencies" and r["status"] == 0]
    if deps:
        lines.append(f"| only importing numpy, numba, scipy.linalg | - | {len(deps)} | "
                     f"{min(deps):.3f} | {min(deps) / ex:.2f} |")
    return "\n".join(lines)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    p.add_argument("--venv", action="append", default=[], metavar="LABEL=PATH",
                   help="a venv with flexmb installed, repeatable; they take turns")
    p.add_argument("--peers-python", default="/work/venv-peers/bin/python", help="the Python of Exudyn's venv")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--out", default=os.path.join(RESULTS, "startup.jsonl"))
    p.add_argument("--breakdown", action="store_true", help="time the phases of one run instead")
    p.add_argument("--breakdown-out", default=os.path.join(RESULTS, "startup_breakdown.jsonl"))
    p.add_argument("--summary", action="store_true", help="only print the table of --out")
    p.add_argument("--exit", action="store_true", help="time the run's exit instead (EXIT_ENDINGS)")
    p.add_argument("--exit-out", default=os.path.join(RESULTS, "startup_exit.jsonl"))
    p.add_argument("--parts", action="store_true", help="also time `import flexmb` alone and with the build")
    p.add_argument("--floor", action="store_true",
                   help="time only importing numpy and numba (and numpy alone) against Exudyn's run instead")
    args = p.parse_args(argv)
    venvs = dict(v.split("=", 1) for v in args.venv) or {"this": sys.prefix}
    if args.breakdown:
        breakdown(venvs, args.repeat, args.breakdown_out)
        return
    if args.exit:
        measure_exit(venvs, args.repeat, args.exit_out)
        return
    if args.floor:
        measure_floor(os.path.join(list(venvs.values())[-1], "bin", "python"), args.peers_python, args.repeat,
                      args.out)
        return
    if not args.summary:
        measure(venvs, args.peers_python, args.repeat, args.out, args.parts)
    print(summary(args.out))


if __name__ == "__main__":
    main()
