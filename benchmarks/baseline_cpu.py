"""The warm path on machine code for the shipped baseline CPU (x86-64-v3) against code for this host's CPU.

    OPENBLAS_NUM_THREADS=1 python benchmarks/baseline_cpu.py --rounds 4

flexmb ships its kernels compiled for a portable baseline
(:mod:`flexmb.kernels.prebuilt`); this measures what that costs a run whose
CPU could do more (AVX-512, its own scheduling model). Two kernel caches,
one filled by numba generating code for ``x86-64-v3`` (``NUMBA_CPU_NAME``,
``NUMBA_CPU_FEATURES`` empty: the same code as the shipped build), one for
the host; each round runs, for each in turn (the order alternating), a new
process of ``benchmarks/rhs_cost.py --scene B1 wiper B6 --n 8 --repeats 3``
(CPU per right-hand side, least of its repeats) and the main job ``flexmb
run wiper`` (CPU of the whole process). The first round of each fills its
cache and is not counted when ``--cache-root`` was empty. One JSON line per
run to ``--out`` (default ``benchmarks/results/prebuilt_warm_path.jsonl``,
appended); the summary prints each figure's least over the rounds and the
ratio baseline / host.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
LABELS = {"v3": {"NUMBA_CPU_NAME": "x86-64-v3", "NUMBA_CPU_FEATURES": ""}, "host": {}}


def _run(label: str, argv: list[str], cache_root: str):
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_CPU")}
    env.update(OPENBLAS_NUM_THREADS="1", NUMBA_DISABLE_INTEL_SVML="1", MPLBACKEND="Agg", FLEXMB_PREBUILT="0",
               NUMBA_CACHE_DIR=os.path.join(cache_root, label), **LABELS[label])
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(argv, env=env, capture_output=True, text=True, cwd=cache_root)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    return proc, cpu, time.perf_counter() - t0


def one_round(r: int, cache_root: str, out: str) -> None:
    """Both labels, in turn (alternating order by round): rhs_cost and the warm main job."""
    bindir = os.path.dirname(sys.executable)
    for label in (("v3", "host") if r % 2 == 0 else ("host", "v3")):
        proc, _, _ = _run(label, [sys.executable, os.path.join(HERE, "rhs_cost.py"), "--scene", "B1", "wiper", "B6",
                                  "--n", "8", "--calls", "3000", "--repeats", "3"], cache_root)
        summary = [json.loads(ln) for ln in proc.stdout.splitlines() if ln.startswith("{") and "summary" in ln]
        rows = [{"what": "rhs", "label": label, "round": r, "load": os.getloadavg()[0],
                 "min_rhs_cpu_us": summary[0]["min_rhs_cpu_us"] if summary else proc.stderr[-500:],
                 "compiled": "compiling" in proc.stderr}]
        proc, cpu, wall = _run(label, [os.path.join(bindir, "flexmb"), "run", "wiper", "--out",
                                       os.path.join(cache_root, f"out-{label}"), "--quiet", "--overwrite"], cache_root)
        rows.append({"what": "wiper_warm", "label": label, "round": r, "load": os.getloadavg()[0],
                     "cpu_s": round(cpu, 3), "wall_s": round(wall, 2), "status": proc.returncode,
                     "compiled": "compiling" in proc.stderr})
        with open(out, "a", encoding="utf-8") as f:
            for row in rows:
                print(json.dumps(row), flush=True)
                f.write(json.dumps(row) + "\n")


def summary(out: str) -> str:
    """Least over the rounds (runs that compiled left out), per figure and label, and the ratio v3 / host."""
    rows = [json.loads(ln) for ln in open(out, encoding="utf-8") if ln.strip()]
    best: dict[tuple, float] = {}
    for row in rows:
        if row.get("compiled"):
            continue
        figures = row["min_rhs_cpu_us"] if row["what"] == "rhs" else {"wiper warm CPU s": row["cpu_s"]}
        for name, value in figures.items():
            key = (name, row["label"])
            best[key] = min(best.get(key, float("inf")), value)
    lines = ["| figure | v3 | host | v3 / host |", "|---|---|---|---|"]
    for name in dict.fromkeys(n for n, _ in best):
        v3, host = best.get((name, "v3")), best.get((name, "host"))
        if v3 and host:
            lines.append(f"| {name} | {v3:.3g} | {host:.3g} | {v3 / host:.2f} |")
    return "\n".join(lines)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    p.add_argument("--rounds", type=int, default=4)
    p.add_argument("--cache-root", default=os.path.join("/tmp", "flexmb-baseline-cpu"),
                   help="holds the two caches (kept between runs: a second run starts warm)")
    p.add_argument("--out", default=os.path.join(HERE, "results", "prebuilt_warm_path.jsonl"))
    p.add_argument("--summary", action="store_true", help="only print the table of --out")
    args = p.parse_args(argv)
    if not args.summary:
        os.makedirs(args.cache_root, exist_ok=True)
        for r in range(args.rounds):
            one_round(r, args.cache_root, args.out)
    print(summary(args.out))


if __name__ == "__main__":
    main()
