"""Where a cold run's compilation goes: CPU per compiled function, from numba's compile events, in one process.

    OPENBLAS_NUM_THREADS=1 NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/compile_profile.py wiper --label branch
    OPENBLAS_NUM_THREADS=1 NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/compile_profile.py pendulum --label branch

Runs ``flexmb run wiper`` (through ``flexmb.cli.main``) or the README's
pendulum snippet in this process, with whatever cache ``NUMBA_CACHE_DIR``
names (empty: everything compiles). numba broadcasts a ``"numba:compile"``
event around each compilation (never around a load from the cache): a
function's *inclusive* CPU is the time between its start and end events,
its *exclusive* CPU that minus the compilations nested in it (the callees
compiled on the way). An entry kernel's exclusive time is therefore its own
code plus LLVM re-optimising and generating the machine code of every
callee linked into its module. The CPU spent holding LLVM's lock (the
``"numba:llvm_lock"`` event: building, optimising and emitting machine
code) is summed over the run; the rest of the compile time is numba's own
front end (typing, rewrites, lowering to IR) in Python.

Writes one JSON line to ``--out`` (default
``benchmarks/results/compile_profile.jsonl``, appended): the label, the
command, total CPU, compile CPU, LLVM CPU and the functions (exclusive,
inclusive, count) costing at least 0.1 s; prints the top 30.
"""

from __future__ import annotations

import argparse
import json
import os
import runpy
import sys
import tempfile
import time

from numba.core import event

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

_stack: list[list] = []
_excl: dict[str, float] = {}
_incl: dict[str, float] = {}
_count: dict[str, int] = {}
_llvm = {"total": 0.0, "depth": 0, "start": 0.0}


def _name(dispatcher) -> str:
    py = dispatcher.py_func
    return f"{py.__module__.rsplit('.', 1)[-1]}.{py.__name__}"


class _Compiles(event.Listener):
    def on_start(self, ev):
        _stack.append([_name(ev.data["dispatcher"]), time.process_time(), 0.0])

    def on_end(self, ev):
        name, t0, nested = _stack.pop()
        dt = time.process_time() - t0
        _excl[name] = _excl.get(name, 0.0) + dt - nested
        _incl[name] = _incl.get(name, 0.0) + dt
        _count[name] = _count.get(name, 0) + 1
        if _stack:
            _stack[-1][2] += dt


class _Llvm(event.Listener):
    def on_start(self, ev):
        if _llvm["depth"] == 0:
            _llvm["start"] = time.process_time()
        _llvm["depth"] += 1

    def on_end(self, ev):
        _llvm["depth"] -= 1
        if _llvm["depth"] == 0:
            _llvm["total"] += time.process_time() - _llvm["start"]


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    p.add_argument("command", choices=["wiper", "pendulum"])
    p.add_argument("--label", default="this")
    p.add_argument("--out", default=os.path.join(HERE, "results", "compile_profile.jsonl"))
    args = p.parse_args(argv)
    event.register("numba:compile", _Compiles())
    event.register("numba:llvm_lock", _Llvm())
    t0 = time.process_time()
    with tempfile.TemporaryDirectory(prefix="flexmb-profile-") as work:
        if args.command == "wiper":
            from flexmb.cli import main as flexmb_main

            flexmb_main(["run", "wiper", "--out", os.path.join(work, "out"), "--quiet", "--overwrite"])
        else:
            from cold_start import pendulum_snippet

            script = os.path.join(work, "pendulum.py")
            with open(script, "w", encoding="utf-8") as f:
                f.write(pendulum_snippet(os.path.dirname(HERE)))
            runpy.run_path(script, run_name="__main__")
    total = time.process_time() - t0
    rows = sorted(_excl.items(), key=lambda kv: -kv[1])
    record = {"label": args.label, "command": args.command, "date": time.strftime("%Y-%m-%d %H:%M", time.gmtime()),
              "loadavg_1min": round(os.getloadavg()[0], 2), "cpu_s": round(total, 2),
              "compile_cpu_s": round(sum(_excl.values()), 2), "llvm_cpu_s": round(_llvm["total"], 2),
              "functions": [{"name": k, "exclusive_s": round(v, 2), "inclusive_s": round(_incl[k], 2),
                             "count": _count[k]} for k, v in rows if v >= 0.1]}
    with open(args.out, "a", encoding="utf-8") as f:
        f.write(json.dumps(record) + "\n")
    print(f"CPU {total:.1f} s, compiling {record['compile_cpu_s']} s, of it LLVM {record['llvm_cpu_s']} s",
          file=sys.stderr)
    for k, v in rows[:30]:
        print(f"{v:7.2f} exclusive {_incl[k]:7.2f} inclusive x{_count[k]} {k}", file=sys.stderr)
    sys.stderr.flush()
    os._exit(0)  # as the flexmb command leaves (no interpreter clean-up to time)


if __name__ == "__main__":
    main()
