"""SIGTERM and SIGHUP are answered as Ctrl-C is (issue #33, section 4).

A batch system at its time limit, ``docker stop``, systemd and a dropped SSH
session stop a process with SIGTERM or SIGHUP; their default action killed
``flexmb run`` on the spot (exit 143/129, nothing written, the staging folder
and the lock left behind). Now the run stops where it is, writes what it
computed and exits with 128 + the signal, without a traceback.
"""

from __future__ import annotations

import json
import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest

import flexmb as fm
from conftest import with_default_signals

TUTORIALS = pathlib.Path(__file__).resolve().parents[1] / "tutorials"
PENDULUM = str(TUTORIALS / "01_pendulum.toml")

pytestmark = pytest.mark.skipif(not hasattr(signal, "SIGHUP"), reason="POSIX signals")


def _start(args, tmp_path):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    return subprocess.Popen(with_default_signals([sys.executable, "-m", "flexmb", *args]), cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _wait_for(path: pathlib.Path, proc, timeout=120.0):
    """Until ``path`` exists (the run has begun to simulate), or the process ends."""
    end = time.monotonic() + timeout
    while time.monotonic() < end and proc.poll() is None:
        if path.exists():
            return
        time.sleep(0.05)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGHUP])
def test_a_run_stopped_by_a_signal_writes_what_it_computed(tmp_path, sig):
    out = tmp_path / "out"
    # a long run (a day of pendulum motion) with a progress bar: its first line shows that it simulates
    proc = _start(["run", PENDULUM, "--out", str(out), "--t-end", "86400", "--n-out", "2001"], tmp_path)
    end = time.monotonic() + 120
    seen = ""
    while time.monotonic() < end and proc.poll() is None and "simulating" not in seen:
        seen += os.read(proc.stderr.fileno(), 4096).decode(errors="replace")
    assert proc.poll() is None, "the run ended before the signal"
    time.sleep(0.5)
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=120)
    stderr = seen + stderr
    assert proc.returncode == 128 + sig, (proc.returncode, stderr[-2000:])
    assert "Traceback" not in stderr and "interrupted" in stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and signal.Signals(sig).name in summary["message"]
    res = fm.Result.load(out / "pendulum.npz")
    assert res.status == "interrupted" and 0 < res.t[-1] < 86400
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == ["out"], left  # no staging folder beside it
    assert not (out / ".flexmb.lock").exists() or not any(out.glob(".flexmb-staging*"))


def test_a_study_stopped_by_sigterm_keeps_its_cases_and_exits_143(tmp_path):
    out = tmp_path / "study"
    proc = _start(["study", PENDULUM, "--vary", "solver.t_end=0.01,0.02,86400,86400", "--serial", "--out",
                   str(out), "--quiet"], tmp_path)
    _wait_for(out / "cases", proc)
    time.sleep(3.0)
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 143, (proc.returncode, stderr[-2000:])
    assert "Traceback" not in stderr and "interrupted" in stderr


class _Stop(BaseException):
    """What a study's timer raises in a case's thread (a BaseException, like study.cases._CaseTimeout)."""


def test_a_base_exception_raised_as_a_kernel_returns_goes_on_as_itself(monkeypatch):
    # raised in the thread while a compiled kernel returns, it comes out as numba's SystemError, itself the cause;
    # main recorded the run as failed ("SystemError: CPUDispatcher(...) returned a result with an exception set"),
    # so a serial study's time limit was now and then recorded as that failure instead
    model = fm.Model("p")
    bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)), fm.Gravity((0.0, -9.81, 0.0)))
    system = model.build()
    real, calls = type(system)._state_rate, []

    def rate(self, t, y):
        calls.append(t)
        if len(calls) == 20:
            raise SystemError("CPUDispatcher(<function rhs>) returned a result with an exception set") from _Stop()
        return real(self, t, y)

    monkeypatch.setattr(type(system), "_state_rate", rate)
    with pytest.raises(_Stop):
        fm.simulate(system, 1.0, positions={"pin": 0.5}, progress=False)


@pytest.mark.skipif(not hasattr(signal, "SIGHUP"), reason="POSIX signals")
def test_deferred_interruptions_act_where_the_loop_checks_and_at_the_end():
    from flexmb._signals import act_on_deferred, deferred

    def tick():  # give the interpreter every chance to run a handler here
        for _ in range(1000):
            time.sleep(0)

    with pytest.raises(KeyboardInterrupt):
        with deferred():
            os.kill(os.getpid(), signal.SIGINT)
            tick()  # recorded, not raised
            with deferred():  # nested: changes nothing
                tick()
            act_on_deferred()  # raised here
            pytest.fail("act_on_deferred did not raise")
    with pytest.raises(KeyboardInterrupt):  # not acted on inside: raised as the block ends
        with deferred():
            os.kill(os.getpid(), signal.SIGINT)
            tick()
            done = True
    assert done
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # the handlers are back
    with deferred():
        act_on_deferred()  # nothing recorded: nothing happens


#: the tests that send Ctrl-C to the test process itself (a compiled loop's run among them)
SELF_INTERRUPTING = ["tests/test_signals.py::test_deferred_interruptions_act_where_the_loop_checks_and_at_the_end",
                     "tests/test_background.py::test_an_interrupted_wait_kills_the_children_before_it_is_raised",
                     "tests/test_genalpha_compiled.py::test_ctrl_c_stops_a_long_interval"]


@pytest.mark.skipif(not hasattr(signal, "SIGHUP"), reason="POSIX signals")
def test_ctrl_c_tests_hold_in_a_test_run_started_in_the_background(tmp_path):
    """A shell without job control starts a background command (``nohup python -m pytest ... &``) with SIGINT
    ignored, and Python keeps it ignored: those full-suite runs failed the Ctrl-C tests together (the Ctrl-C was
    never seen) and hung in test_background's interrupted wait (pytest in waitpid, a child waiting on for ever).
    The suite answers Ctrl-C as a foreground run does (conftest); the tests' children end by themselves."""
    root = pathlib.Path(__file__).resolve().parents[1]
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:randomly",
           f"--basetemp={tmp_path / 'bt'}", *SELF_INTERRUPTING]
    # `trap '' INT` is what the shell does to a background command: SIGINT ignored, kept through exec
    proc = subprocess.Popen(["sh", "-c", 'trap "" INT; exec "$@"', "sh", *cmd], cwd=root, start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        out, _ = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:  # hung: end the run and the children it forked
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
    assert proc.returncode == 0, out[-3000:]
    assert f"{len(SELF_INTERRUPTING)} passed" in out, out[-3000:]
