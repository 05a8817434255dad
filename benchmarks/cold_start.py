"""Cold and warm first runs: CPU time of a whole process with an empty and with a filled kernel cache.

    OPENBLAS_NUM_THREADS=1 python benchmarks/cold_start.py \
        --venv branch=/work/venv-compile --venv base=/work/venv-compile-base \
        --commands wiper pendulum --repeat 3

Each command runs as a new process of the venv's Python (so each venv runs
the flexmb installed in it): *cold* with ``NUMBA_CACHE_DIR`` set to a new,
empty folder, then *warm*, the same command again with that folder
(``--warm-runs`` times). The
venvs take turns within each repeat (cold and warm of one, then of the
next), so a machine's load drifts over all of them alike. The figure is the
CPU time (user + system) of the process and the children it waited for,
from ``getrusage(RUSAGE_CHILDREN)``, with the descendants orphaned on the
way (a study's case processes, children of multiprocessing's forkserver)
adopted and waited for; wall time is recorded too.

Commands:

* ``wiper``: ``flexmb run wiper --out DIR --quiet`` (the main job).
* ``pendulum``: the README's "A model in a few lines" snippet, read from
  the README of the venv's checkout, run as a script.
* ``tutorial:NAME``: ``tutorials/NAME.py`` of that checkout, run as a
  script with a non-interactive matplotlib backend.
* ``tests``: the README's test command, ``python -m pytest`` on that
  checkout's tests (``-q``, no pytest cache).
* ``compile``: ``python -m flexmb compile`` (where the venv's flexmb has
  that command).

Where the branch ships its kernels' machine code (:mod:`flexmb.kernels.prebuilt`),
a cold run loads it: ``NUMBA_CACHE_DIR`` empty, and no numba cache files in
the checkout's ``__pycache__`` folders (deleted before each cold run: a
subprocess run without ``NUMBA_CACHE_DIR`` caches there), is a new
installation's state. Each row records the kernels the run compiled
(``compiled``: index files it created or rewrote in ``NUMBA_CACHE_DIR``)
and the shipped folder's build (``shipped``). ``--warm-runs 0`` runs the cold runs only.

One JSON line per run goes to ``--out`` (default
``benchmarks/results/cold_start.jsonl``, appended): venv label, commit,
command, ``cache`` (``cold``/``warm``), repeat, ``cpu_s``, ``wall_s``,
exit status and the first line of its stderr; ``--summary`` prints the
table (min over repeats) of the lines in ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def _checkout(python: str) -> str:
    """The source checkout of the flexmb installed in this venv (editable install)."""
    out = subprocess.run([python, "-c", "import flexmb, os; print(os.path.dirname(flexmb.__file__))"],
                         capture_output=True, text=True, check=True, env=_env(None)).stdout.strip()
    return os.path.dirname(os.path.dirname(out))  # .../src/flexmb -> checkout


def _commit(checkout: str) -> str:
    r = subprocess.run(["git", "-C", checkout, "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    dirty = subprocess.run(["git", "-C", checkout, "status", "--porcelain", "--untracked-files=no"],
                           capture_output=True, text=True).stdout.strip()
    return r.stdout.strip() + ("+dirty" if dirty else "")


def pendulum_snippet(checkout: str) -> str:
    """The first Python block under the README's "A model in a few lines"."""
    with open(os.path.join(checkout, "README.md"), encoding="utf-8") as f:
        text = f.read()
    section = text.split("## A model in a few lines", 1)[1]
    match = re.search(r"```python\n(.*?)```", section, re.S)
    if match is None:
        raise SystemExit("no Python block under 'A model in a few lines' in the README")
    return match.group(1)


def _env(cache: str | None) -> dict:
    env = dict(os.environ)
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    env["MPLBACKEND"] = "Agg"
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = cache
    return env


def _argv(python: str, checkout: str, command: str, work: str) -> list[str]:
    bindir = os.path.dirname(python)
    if command == "wiper":
        return [os.path.join(bindir, "flexmb"), "run", "wiper", "--out", os.path.join(work, "out"),
                "--quiet", "--overwrite"]
    if command == "pendulum":
        script = os.path.join(work, "pendulum.py")
        with open(script, "w", encoding="utf-8") as f:
            f.write(pendulum_snippet(checkout))
        return [python, script]
    if command.startswith("tutorial:"):
        return [python, os.path.join(checkout, "tutorials", command.split(":", 1)[1] + ".py")]
    if command == "tests":
        return [python, "-m", "pytest", "-q", "-p", "no:cacheprovider", os.path.join(checkout, "tests")]
    if command == "compile":
        return [python, "-m", "flexmb", "compile"]
    raise SystemExit(f"unknown command {command!r}")


def _entries(cache: str) -> dict[str, tuple]:
    """The numba index files under ``cache`` (relative path -> size and mtime): what has been saved there."""
    out = {}
    for dirpath, _, files in os.walk(cache):
        for name in files:
            if name.endswith(".nbi"):
                st = os.stat(os.path.join(dirpath, name))
                out[os.path.relpath(os.path.join(dirpath, name), cache)] = (st.st_size, st.st_mtime_ns)
    return out


def purge_in_tree(checkout: str) -> int:
    """Delete numba's cache files from the ``__pycache__`` folders of the checkout's sources (a new installation's
    state: a subprocess run without ``NUMBA_CACHE_DIR`` caches there); the number deleted."""
    n = 0
    for top in ("src", "plugins"):
        for dirpath, _, files in os.walk(os.path.join(checkout, top)):
            if os.path.basename(dirpath) == "__pycache__":
                for name in files:
                    if name.endswith((".nbi", ".nbc")):
                        os.remove(os.path.join(dirpath, name))
                        n += 1
    return n


def shipped(checkout: str) -> str | None:
    """The checkout's shipped machine code for this interpreter (its manifest's build time and file count), if any."""
    import glob

    found = sorted(glob.glob(os.path.join(checkout, "src", "flexmb", "kernels", "_prebuilt", "*", "manifest.json")))
    if not found:
        return None
    with open(found[0], encoding="utf-8") as f:
        manifest = json.load(f)
    return f"{manifest.get('built')}, {len(manifest.get('kernels', []))} files"


def _adopt_orphans() -> bool:
    """Make this process the reaper of its descendants whose parent exits (Linux ``PR_SET_CHILD_SUBREAPER``).

    A study's case processes are children of multiprocessing's forkserver,
    which the script that started it never waits for: adopted here and
    waited for (:func:`_reap`), their CPU counts in the run's.
    """
    try:
        import ctypes

        return ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0) == 0  # PR_SET_CHILD_SUBREAPER
    except (OSError, AttributeError):
        return False


def _reap(timeout: float = 60.0) -> None:
    """Wait for adopted descendants (a forkserver ends once its script has) so that their CPU is counted."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            time.sleep(0.05)


def run_once(python: str, checkout: str, command: str, cache: str, work: str) -> dict:
    """One process: CPU (user + system, with waited-for children) and wall seconds, status, stderr's first line,
    and the kernels it compiled into ``cache`` (index files new or rewritten: ``compiled``)."""
    argv = _argv(python, checkout, command, work)
    saved = _entries(cache)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    # the README's test command runs in the checkout (tests read tutorials/ relative to it)
    proc = subprocess.run(argv, capture_output=True, text=True, env=_env(cache),
                          cwd=checkout if command == "tests" else work)
    _reap()
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    out = [ln for ln in proc.stdout.splitlines() if ln.strip()]
    compiled = sorted(os.path.basename(k).rsplit("-", 1)[0] for k, v in _entries(cache).items() if saved.get(k) != v)
    return {"cpu_s": round(cpu, 3), "wall_s": round(wall, 3), "status": proc.returncode,
            "stderr_first": lines[0] if lines else "", "stderr_tail": lines[-1] if proc.returncode and lines else "",
            "stdout_tail": out[-1] if out else "", "compiled_n": len(compiled), "compiled": compiled[:40]}


def measure(venvs: dict[str, str], commands: list[str], repeat: int, out: str, warm_runs: int = 1) -> None:
    info = {}
    if not _adopt_orphans():
        print("cannot adopt orphaned descendants here: a study's case processes are not counted", file=sys.stderr)
    for label, venv in venvs.items():
        python = os.path.join(venv, "bin", "python")
        checkout = _checkout(python)
        info[label] = (python, checkout, _commit(checkout), shipped(checkout))
        print(f"{label}: {checkout} at {info[label][2]}, shipped machine code: {info[label][3]}", file=sys.stderr)
    for r in range(repeat):
        for command in commands:
            for label, (python, checkout, commit, ship) in info.items():
                with tempfile.TemporaryDirectory(prefix="flexmb-cold-") as work:
                    cache = os.path.join(work, "numba-cache")
                    os.mkdir(cache)
                    purge_in_tree(checkout)
                    for i, kind in enumerate(("cold",) + ("warm",) * warm_runs):
                        run_dir = os.path.join(work, f"run-{i}")  # each run's outputs anew (a study resumes)
                        os.mkdir(run_dir)
                        row = {"venv": label, "commit": commit, "shipped": ship, "command": command, "cache": kind,
                               "repeat": r,
                               "date": time.strftime("%Y-%m-%d %H:%M", time.gmtime()),
                               "loadavg_1min": round(os.getloadavg()[0], 2),
                               **run_once(python, checkout, command, cache, run_dir)}
                        print(json.dumps(row), file=sys.stderr)
                        with open(out, "a", encoding="utf-8") as f:
                            f.write(json.dumps(row) + "\n")


def summary(out: str, base: str = "base") -> str:
    """Markdown table: per command and venv, min CPU over repeats cold and warm, their ratio, and against ``base``."""
    rows = [json.loads(ln) for ln in open(out, encoding="utf-8") if ln.strip()]
    best: dict[tuple, dict] = {}
    for row in rows:
        if row["status"] != 0:
            continue
        key = (row["command"], row["venv"], row["commit"])
        b = best.setdefault(key, {"n": 0})
        b[row["cache"]] = min(b.get(row["cache"], float("inf")), row["cpu_s"])
        b["n"] += row["cache"] == "cold"
    lines = [f"| command | venv | commit | cold runs | cold CPU s | warm CPU s | cold/warm | cold / {base}'s | "
             f"warm / {base}'s |", "|---|---|---|---|---|---|---|---|---|"]
    for (command, venv, commit), b in sorted(best.items()):
        if "cold" not in b or "warm" not in b:
            continue
        ref = [v for (c, lab, _), v in best.items() if c == command and lab == base and "cold" in v and "warm" in v]
        vs = (f"{b['cold'] / ref[-1]['cold']:.2f} | {b['warm'] / ref[-1]['warm']:.2f}" if ref else "- | -")
        lines.append(f"| {command} | {venv} | {commit} | {b['n']} | {b['cold']:.1f} | {b['warm']:.2f} | "
                     f"{b['cold'] / b['warm']:.1f} | {vs} |")
    return "\n".join(lines)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    p.add_argument("--venv", action="append", default=[], metavar="LABEL=PATH",
                   help="a venv with flexmb installed (editable), repeatable; they take turns")
    p.add_argument("--commands", nargs="+", default=["wiper", "pendulum"])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--warm-runs", type=int, default=1, help="warm runs after each cold one (the least counts)")
    p.add_argument("--out", default=os.path.join(HERE, "results", "cold_start.jsonl"))
    p.add_argument("--summary", action="store_true", help="only print the table of --out")
    args = p.parse_args(argv)
    if not args.summary:
        venvs = dict(v.split("=", 1) for v in args.venv) or {"this": sys.prefix}
        measure(venvs, args.commands, args.repeat, args.out, args.warm_runs)
    print(summary(args.out))


if __name__ == "__main__":
    main()
