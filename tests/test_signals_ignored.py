"""A signal ignored when ``flexmb`` starts stays ignored: ``nohup flexmb run`` goes on through a hangup.

``nohup`` starts its command with SIGHUP ignored, and a shell without job
control starts a background command (``flexmb run ... &`` in a script) with
SIGINT ignored. flexmb installed its handlers for SIGINT, SIGTERM and
SIGHUP all the same, undoing both: a ``nohup``'d run caught the hangup and
stopped, exit 129, ``"status": "interrupted"``. Now a signal ignored at the
start is never answered; a signal at its default is answered as before
(the run stops where it is and writes what it computed: the same run sent
SIGHUP in ``tests/test_signals.py``, whose processes start with the
signals at their defaults however the suite was started).
"""

from __future__ import annotations

import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import time

import pytest

import flexmb as fm
from conftest import with_default_signals

TUTORIALS = pathlib.Path(__file__).resolve().parents[1] / "tutorials"
PENDULUM = str(TUTORIALS / "01_pendulum.toml")

pytestmark = pytest.mark.skipif(not hasattr(signal, "SIGHUP") or not sys.platform.startswith("linux"),
                                reason="POSIX signals, /proc")

#: how the command is started with the signal ignored: `nohup`, and what a shell does to a background command
IGNORING = {"SIGHUP": ["nohup"], "SIGINT": ["sh", "-c", 'trap "" INT; exec "$@"', "sh"]}


def _flexmb(*args) -> list[str]:
    return [sys.executable, "-m", "flexmb", *args]


def _start(argv, tmp_path) -> subprocess.Popen:
    """``argv`` in a session of its own (a signal to its group reaches no other test), SIGINT, SIGTERM and SIGHUP
    at their defaults unless ``argv`` itself ignores one; stderr read as it comes."""
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    return subprocess.Popen(with_default_signals(argv), cwd=tmp_path, env=env, start_new_session=True,
                            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _ignored(pid: int) -> int:
    """The mask of the signals process ``pid`` ignores (``SigIgn`` in ``/proc/PID/status``)."""
    status = pathlib.Path(f"/proc/{pid}/status").read_text()
    return next(int(line.split()[1], 16) for line in status.splitlines() if line.startswith("SigIgn:"))


def _signal_until_it_ends(proc, sig, group=False, timeout=300.0) -> tuple[int, str, int]:
    """Send ``sig`` every 0.1 s (to the process group if ``group``) until ``proc`` ends; its status, stderr and the
    number of signals sent.

    The signals meet each phase of the command after the first: the
    simulation, the outputs written (forked writers among them), the exit.
    """
    sent, end = 0, time.monotonic() + timeout
    while proc.poll() is None and time.monotonic() < end:
        try:
            os.killpg(proc.pid, sig) if group else proc.send_signal(sig)
            sent += 1
        except ProcessLookupError:
            break
        time.sleep(0.1)
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGKILL)
    _, err = proc.communicate()
    return proc.returncode, err, sent


def _until_locked(out: pathlib.Path, proc, timeout=300.0) -> None:
    """Until the run has locked its output folder (it has begun, within its handlers: it simulates next)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end and proc.poll() is None and not (out / ".flexmb.lock").exists():
        time.sleep(0.02)
    assert proc.poll() is None, ("the run ended before the signal", proc.communicate()[1][-2000:])


@pytest.mark.parametrize("signame", ["SIGHUP", "SIGINT"])
def test_a_run_started_with_a_signal_ignored_goes_on_through_it(tmp_path, signame):
    sig = getattr(signal, signame)
    if not shutil.which(IGNORING[signame][0]):
        pytest.skip(f"no {IGNORING[signame][0]} here")
    out = tmp_path / "out"
    t_end = 600.0  # seconds of simulation: the signals meet it, its writing and its exit
    proc = _start(IGNORING[signame] + _flexmb("run", PENDULUM, "--out", str(out), "--t-end", str(t_end),
                                              "--n-out", "201"), tmp_path)
    _until_locked(out, proc)
    still_ignored = _ignored(proc.pid) >> (sig - 1) & 1  # within flexmb's handlers
    code, err, sent = _signal_until_it_ends(proc, sig)
    # before: exit 129 (130), "interrupted by SIGHUP at t = ..." and a summary saying "interrupted"
    assert code == 0, (code, err[-2000:])
    assert sent > 10, sent  # a second of them at least
    assert still_ignored
    assert "interrupted" not in err and "Traceback" not in err, err[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "finished" and summary["t_end"] == t_end, summary
    assert summary["wall_time_s"] > 0.5  # the signals, sent from before it began to the exit, met the simulation
    res = fm.Result.load(out / "pendulum.npz")
    assert res.status == "finished" and res.t[-1] == t_end and len(res.t) == 201


def test_a_nohup_study_on_the_process_pool_goes_on_through_a_hangup_of_its_group(tmp_path):
    """A hangup reaches the terminal's whole process group: the study, its fork server and its case processes."""
    if not shutil.which("nohup"):
        pytest.skip("no nohup here")
    out = tmp_path / "study"
    t_ends = [60.0, 70.0, 80.0, 90.0]
    proc = _start(["nohup", *_flexmb("study", PENDULUM, "--vary", "solver.t_end=" + ",".join(map(str, t_ends)),
                                     "--output", "final:pin", "--workers", "2", "--out", str(out), "--quiet")],
                  tmp_path)
    end = time.monotonic() + 300
    while proc.poll() is None and time.monotonic() < end and not (out / "cases").exists():
        time.sleep(0.05)
    code, err, sent = _signal_until_it_ends(proc, signal.SIGHUP, group=True)
    # before: exit 129, "interrupted", the cases not yet done left for a later run
    assert code == 0, (code, err[-2000:])
    assert sent > 10, sent
    assert "interrupted" not in err and "Traceback" not in err, err[-2000:]
    rows = [json.loads(p.read_text()) for p in sorted((out / "cases").glob("*.json"))]
    assert sorted(r["parameters"]["solver.t_end"] for r in rows) == t_ends
    assert {r["status"] for r in rows} == {"finished"}


def test_as_interrupts_and_the_entry_point_leave_an_ignored_signal_ignored(signals_answered):
    import flexmb_command
    from flexmb._signals import Terminated, as_interrupts

    before = {s: signal.getsignal(s) for s in flexmb_command.SIGNALS}
    try:
        signal.signal(signal.SIGHUP, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        flexmb_command.install()
        assert signal.getsignal(signal.SIGHUP) == signal.SIG_IGN
        assert signal.getsignal(signal.SIGTERM) is flexmb_command.leave_at_once
        with as_interrupts():
            assert signal.getsignal(signal.SIGHUP) == signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGHUP)  # nothing happens
            for _ in range(1000):
                time.sleep(0)
            with pytest.raises(Terminated):
                os.kill(os.getpid(), signal.SIGTERM)
                for _ in range(1000):
                    time.sleep(0)
        assert signal.getsignal(signal.SIGTERM) is flexmb_command.leave_at_once
    finally:
        for s, handler in before.items():
            signal.signal(s, handler)
