"""The README's test command, cold against warm: how much of it is compiling (issue 31).

    OPENBLAS_NUM_THREADS=1 python benchmarks/test_command_compile.py \
        --venv base=/work/venv-ct-base --venv now=/work/venv-ct-now --rounds 1

Each venv holds an editable install of flexmb (``pip install -e "CHECKOUT[test]"``).
The README's test command, ``python -m pytest`` in the venv's checkout (with
``-q -p no:cacheprovider --basetemp=...``), runs as a new process at
``nice -n 10``: *cold*, with ``NUMBA_CACHE_DIR`` a new, empty folder and no
numba cache files in the checkout's ``__pycache__`` folders (a new
installation's state), then *warm*, the same command with the same folder.
The compile time of the command is cold - warm. Within a round the runs
alternate (first venv cold, second venv cold, first warm, second warm), so
a drifting load falls on both alike.

Each run also gets a ``TMPDIR`` of its own (the same folder for a venv's cold
and warm run of a round): the per-user fallback cache a test may reach
(``<tmp>/flexmb-numba-<uid>``, no writable home) starts empty as well, and
no other session's cache is read or touched.

Recorded per run (one JSON line in ``--out``, default
``benchmarks/results/test_command_compile.jsonl``): CPU (user + system of
the process and the children it waited for, orphans adopted, from
``getrusage(RUSAGE_CHILDREN)``), wall, pytest's counts (passed, skipped,
failed, ...), the machine's load average (1 min) sampled every 10 s during
the run (min, mean, max), and the compiles it saved, which do not depend on
the load: index files (``.nbi``: kernels) created or rewritten and data
files (``.nbc``: compiled signatures) created, in ``NUMBA_CACHE_DIR``, in
the checkout's ``__pycache__`` folders and in the run's ``TMPDIR``
(``shared``), and in pytest's ``--basetemp`` (``probes``: caches of the
tests' own probe kernels, new in every run, cold or warm). ``--summary``
prints the table of ``--out``.

The process and cache handling is :mod:`cold_start`'s (this folder).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cold_start import _adopt_orphans, _checkout, _commit, _env, _reap, purge_in_tree, shipped  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
COUNTS = re.compile(r"(\d+) (passed|failed|skipped|errors?|xfailed|xpassed|deselected|warnings?)")


def cache_files(*tops: str) -> dict[str, tuple]:
    """numba's cache files (``.nbi``, ``.nbc``) under ``tops``: path -> (size, mtime)."""
    out = {}
    for top in tops:
        for dirpath, _, files in os.walk(top):
            for name in files:
                if name.endswith((".nbi", ".nbc")):
                    path = os.path.join(dirpath, name)
                    try:
                        st = os.stat(path)
                    except OSError:
                        continue
                    out[path] = (st.st_size, st.st_mtime_ns)
    return out


def saved(before: dict, after: dict) -> dict:
    """Index files created or rewritten, data files created, between two :func:`cache_files`."""
    return {"nbi": sum(1 for k, v in after.items() if k.endswith(".nbi") and before.get(k) != v),
            "nbc": sum(1 for k in after if k.endswith(".nbc") and k not in before)}


class LoadSampler(threading.Thread):
    """The 1-minute load average every ``every`` seconds while a run lasts."""

    def __init__(self, every: float = 10.0):
        super().__init__(daemon=True)
        self.every, self.samples, self.stop = every, [os.getloadavg()[0]], threading.Event()

    def run(self):
        while not self.stop.wait(self.every):
            self.samples.append(os.getloadavg()[0])

    def result(self) -> dict:
        self.stop.set()
        self.join()
        s = self.samples + [os.getloadavg()[0]]
        return {"load_min": round(min(s), 2), "load_mean": round(sum(s) / len(s), 2), "load_max": round(max(s), 2)}


def run_tests(python: str, checkout: str, cache: str, tmp: str, basetemp: str, tests: list[str]) -> dict:
    """One run of the README's test command in ``checkout`` (only ``tests`` if given): CPU, wall, pytest's counts,
    load, compiles saved."""
    argv = [python, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"--basetemp={basetemp}", *tests]
    env = dict(_env(cache), TMPDIR=tmp)
    shared = (cache, os.path.join(checkout, "src"), os.path.join(checkout, "plugins"), tmp)
    files = cache_files(*shared)
    sampler = LoadSampler()
    sampler.start()
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(argv, capture_output=True, text=True, env=env, cwd=checkout,
                          preexec_fn=lambda: os.nice(10))
    _reap()
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    load = sampler.result()
    tail = [ln for ln in proc.stdout.splitlines() if ln.strip()]
    last = tail[-1] if tail else ""
    counts = {word.rstrip("s") if word != "passed" else word: int(n) for n, word in COUNTS.findall(last)}
    return {"cpu_s": round((after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), 2),
            "wall_s": round(wall, 1), "status": proc.returncode, "counts": counts, "summary_line": last,
            "failures": [ln for ln in tail if ln.startswith(("FAILED", "ERROR"))][:20],
            "shared": saved(files, cache_files(*shared)), "probes": saved({}, cache_files(basetemp)), **load}


def measure(venvs: dict[str, str], rounds: int, out: str, tests: list[str]) -> None:
    """``rounds`` rounds: every venv cold, then every venv warm on its own cache of that round."""
    if not _adopt_orphans():
        print("cannot adopt orphaned descendants: processes they leave are not counted", file=sys.stderr)
    info = {}
    for label, venv in venvs.items():
        python = os.path.join(venv, "bin", "python")
        checkout = _checkout(python)
        info[label] = (python, checkout, _commit(checkout), shipped(checkout))
        print(f"{label}: {checkout} at {info[label][2]}, shipped machine code: {info[label][3]}", file=sys.stderr)
    for r in range(rounds):
        work = {label: tempfile.mkdtemp(prefix=f"flexmb-ct-{label}-") for label in info}
        try:
            for label in info:
                os.mkdir(os.path.join(work[label], "numba-cache"))
                os.mkdir(os.path.join(work[label], "tmp"))
                purge_in_tree(info[label][1])
            for kind in ("cold", "warm"):
                for label, (python, checkout, commit, ship) in info.items():
                    basetemp = os.path.join(work[label], f"basetemp-{kind}")
                    row = {"venv": label, "commit": commit, "shipped": ship, "tests": " ".join(tests) or "all",
                           "cache": kind, "round": r,
                           "date": time.strftime("%Y-%m-%d %H:%M", time.gmtime()),
                           **run_tests(python, checkout, os.path.join(work[label], "numba-cache"),
                                       os.path.join(work[label], "tmp"), basetemp, tests)}
                    shutil.rmtree(basetemp, ignore_errors=True)
                    print(json.dumps(row), file=sys.stderr)
                    with open(out, "a", encoding="utf-8") as f:
                        f.write(json.dumps(row) + "\n")
        finally:
            for folder in work.values():
                shutil.rmtree(folder, ignore_errors=True)


def summary(out: str, base: str = "base") -> str:
    """Markdown table, one line per venv and round: cold, warm, compile = cold - warm, against ``base``'s."""
    rows = [json.loads(ln) for ln in open(out, encoding="utf-8") if ln.strip()]
    runs = {(row.get("tests", "all"), row["venv"], row["commit"], row["round"], row["cache"]): row for row in rows}
    lines = [f"| tests | venv | commit | round | cold CPU s | warm CPU s | compile s | compile / {base}'s | cold wall s | "
             "warm wall s | passed / skipped / failed (cold; warm) | kernels / signatures saved cold (warm) | "
             "probes' signatures cold / warm | load 1 min (min-max) |", "|---" * 14 + "|"]
    for (tests, venv, commit, r, kind), cold in sorted(runs.items(), key=lambda kv: (kv[0][0], kv[0][3],
                                                                                       kv[0][1] != base)):
        warm = runs.get((tests, venv, commit, r, "warm"))
        if kind != "cold" or warm is None:
            continue
        ref = [(runs[k], runs.get(k[:4] + ("warm",))) for k in runs
               if k[0] == tests and k[1] == base and k[3] == r and k[4] == "cold"]
        compile_s = cold["cpu_s"] - warm["cpu_s"]
        vs = (f"{compile_s / (ref[0][0]['cpu_s'] - ref[0][1]['cpu_s']):.3f}" if ref and ref[0][1] else "-")
        c = [f"{x['counts'].get('passed', 0)} / {x['counts'].get('skipped', 0)} / {x['counts'].get('failed', 0)}"
             for x in (cold, warm)]
        lines.append(f"| {tests} | {venv} | {commit} | {r} | {cold['cpu_s']:.1f} | {warm['cpu_s']:.1f} | {compile_s:+.1f} | "
                     f"{vs} | {cold['wall_s']:.0f} | {warm['wall_s']:.0f} | {c[0]}; {c[1]} | "
                     f"{cold['shared']['nbi']} / {cold['shared']['nbc']} ({warm['shared']['nbi']} / "
                     f"{warm['shared']['nbc']}) | {cold['probes']['nbc']} / {warm['probes']['nbc']} | "
                     f"{min(cold['load_min'], warm['load_min']):.1f}-{max(cold['load_max'], warm['load_max']):.1f} |")
    return "\n".join(lines)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    p.add_argument("--venv", action="append", default=[], metavar="LABEL=PATH",
                   help="a venv with flexmb installed editable from a checkout, repeatable (the first is the base)")
    p.add_argument("--rounds", type=int, default=1)
    p.add_argument("--tests", nargs="*", default=[],
                   help="only these test files (to time what they compile); default: the whole command")
    p.add_argument("--out", default=os.path.join(HERE, "results", "test_command_compile.jsonl"))
    p.add_argument("--summary", action="store_true", help="only print the table of --out")
    args = p.parse_args(argv)
    venvs = dict(v.split("=", 1) for v in args.venv)
    if not args.summary:
        if not venvs:
            p.error("give --venv LABEL=PATH at least once")
        measure(venvs, args.rounds, args.out, args.tests)
    print(summary(args.out, base=next(iter(venvs), "base")))


if __name__ == "__main__":
    main()
