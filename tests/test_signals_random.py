"""100 random SIGINT, SIGTERM and SIGHUP deliveries to ``flexmb run`` and ``flexmb study`` (issue #33, section 4).

Each delivery starts the installed ``flexmb`` script (a run of the pendulum,
or a small study, serial or on the process pool) and sends it one signal at
a random moment of its life from the instant its entry point answers
signals (before, the interpreter itself is starting): while flexmb imports,
while the kernels load, while it simulates, while it writes, as it exits.
Two lanes of 50 deliveries run side by side, each into its own run folder
and study folder, so that every delivery meets the folder the previous ones
left. After each: no crash (a negative status), no traceback, status 128 +
the signal (0 if the command had ended before it), and a consistent folder:
no staging folder, commit or lock left, and a ``summary.json`` or
``study.json`` only beside the complete set of files it describes.
"""

from __future__ import annotations

import json
import os
import pathlib
import random
import shutil
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import flexmb as fm
from conftest import with_default_signals

TUTORIALS = pathlib.Path(__file__).resolve().parents[1] / "tutorials"
PENDULUM = str(TUTORIALS / "01_pendulum.toml")
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP) if hasattr(signal, "SIGHUP") else ()
#: a study's masses, alternating, so that a mix of two studies' files shows
STUDIES = ("1,2,3", "4,5")

pytestmark = [pytest.mark.slow, pytest.mark.skipif(not SIGNALS, reason="POSIX signals")]


def _script() -> list[str]:
    script = pathlib.Path(sys.executable).with_name("flexmb")
    if not script.exists():
        pytest.skip("the flexmb script is not installed beside this Python")
    return [str(script)]


def _command(kind: str, i: int, out: pathlib.Path) -> list[str]:
    if kind == "run":
        return ["run", PENDULUM, "--out", str(out), "--t-end", "0.5", "--n-out", "51", "--quiet"]
    executor = ["--workers", "2"] if i % 3 == 2 else ["--serial"]
    return ["study", PENDULUM, "--vary", f"bodies.bar.mass={STUDIES[i % 2]}", "--output", "final:pin", "--set",
            "solver.t_end=0.3", "--quiet", "--out", str(out), *executor]


def _leftovers(out: pathlib.Path) -> list[str]:
    return sorted(p.name for p in out.iterdir() if p.name.startswith((".flexmb.lock", ".flexmb-staging",
                                                                      ".flexmb-commit"))) if out.exists() else []


def _check_run(out: pathlib.Path) -> str | None:
    """None if ``out`` holds no run or one complete run, else what is wrong."""
    if not (out / "summary.json").exists():
        return "a manifest without summary.json" if (out / ".flexmb-run.json").exists() else None
    summary = json.loads((out / "summary.json").read_text())
    missing = [p for p in summary["files"].values() if not (out / p).is_file()]  # relative to the folder
    if missing:
        return f"summary.json names missing files {missing}"
    res = fm.Result.load(out / "pendulum.npz")
    if (summary["n_out"], summary["status"]) != (len(res.t), res.status):
        return f"summary.json {summary['n_out'], summary['status']} beside a result {len(res.t), res.status}"
    vtus = len(list((out / "vtk").glob("pendulum_*.vtu")))
    if vtus != len(res.t):
        return f"{vtus} VTU files beside a result of {len(res.t)} outputs"
    return None


def _check_study(out: pathlib.Path) -> str | None:
    """None if ``out`` holds no study or one whose study.json and table describe one study, else what is wrong."""
    have = [n for n in ("study.json", "table.csv", "table.npz", "summary.txt") if (out / n).exists()]
    if not have:
        return None
    if len(have) < 4:
        return f"only {have} of a study's files"
    specs = json.loads((out / "study.json").read_text())["specs"]["bodies.bar.mass"]
    lines = (out / "table.csv").read_text().splitlines()
    column = lines[0].split(",").index("bodies.bar.mass")
    values = [float(line.split(",")[column]) for line in lines[1:]]
    if values != specs:
        return f"study.json of masses {specs} beside a table of {values}"
    if not np.array_equal(np.load(out / "table.npz")["bodies.bar.mass"], values):
        return "table.npz and table.csv differ"
    return None


def _wait_for_handlers(proc) -> None:
    """Until the entry point has installed its handlers (SIGTERM among the caught signals), or it ended.

    A signal before that moment meets the interpreter starting up, before
    any of flexmb's code: its default action (or Python's KeyboardInterrupt
    within ``site``) is out of flexmb's reach. Without ``/proc``: 0.2 s.
    """
    status = pathlib.Path(f"/proc/{proc.pid}/status")
    if not status.exists():
        time.sleep(0.2)
        return
    end = time.monotonic() + 60
    while proc.poll() is None and time.monotonic() < end:
        try:
            caught = next(int(line.split()[1], 16) for line in status.read_text().splitlines()
                          if line.startswith("SigCgt:"))
        except (OSError, StopIteration, ValueError):
            return
        if caught >> (signal.SIGTERM - 1) & 1:
            return
        time.sleep(0.001)


def _deliver(lane: int, i: int, root: pathlib.Path, rng: random.Random) -> tuple[int, str | None]:
    """Start one command, signal it at a random moment; return its exit status and what is wrong (or None)."""
    code, problem = _deliver_one(lane, i, root, rng)
    return code, problem


def _deliver_one(lane: int, i: int, root: pathlib.Path, rng: random.Random):
    kind = "run" if i % 2 == 0 else "study"
    sig = SIGNALS[(i // 2 + lane) % len(SIGNALS)]
    out = root / f"lane{lane}" / kind
    delay = rng.uniform(0.0, 6.0)
    env = dict(os.environ, PYTHONFAULTHANDLER="1")  # a crash prints where each thread was
    proc = subprocess.Popen(with_default_signals(_script() + _command(kind, i // 2, out)), stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, cwd=root, env=env)
    _wait_for_handlers(proc)
    try:
        proc.wait(delay)
        sent = False
    except subprocess.TimeoutExpired:
        proc.send_signal(sig)
        sent = True
    try:
        _, err = proc.communicate(timeout=300)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
        return None, f"lane {lane} #{i} {kind} {sig.name} at {delay:.2f} s: still running 300 s after the signal"
    what = f"lane {lane} #{i} {kind} {sig.name} at {delay:.2f} s: exit {proc.returncode}"
    if proc.returncode < 0 or any(s in err for s in ("Traceback", "Exception ignored", "Fatal Python error")):
        return proc.returncode, f"{what}: {err[-2000:]}"
    allowed = {128 + sig, 0} if sent else {0}
    if proc.returncode not in allowed:
        return proc.returncode, f"{what}: {err[-2000:]}"
    if _leftovers(out):
        return proc.returncode, f"{what}: left {_leftovers(out)}"
    problem = _check_run(out) if kind == "run" else _check_study(out)
    return proc.returncode, (f"{what}: {problem}" if problem else None)


def test_100_random_signals_leave_no_crash_no_traceback_and_consistent_folders(tmp_path):
    seed = int(os.environ.get("FLEXMB_SIGNAL_SEED", time.time_ns() % 2**32))
    n = 50  # per lane: 25 runs and 25 studies

    def lane(k):
        rng = random.Random(seed + k)
        return [_deliver(k, i, tmp_path, rng) for i in range(n)]

    with ThreadPoolExecutor(2) as pool:
        outcomes = [o for found in pool.map(lane, range(2)) for o in found]
    problems = [p for _, p in outcomes if p]
    codes = sorted({c for c, _ in outcomes if c is not None})
    print(f"seed {seed}: exit statuses {[(c, sum(o[0] == c for o in outcomes)) for c in codes]}")
    assert not problems, f"seed {seed} (FLEXMB_SIGNAL_SEED):\n" + "\n".join(problems)
    shutil.rmtree(tmp_path, ignore_errors=True)
