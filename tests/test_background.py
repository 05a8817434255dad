"""Writing files in a forked child while the caller computes on (flexmb._background)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from flexmb._background import in_background

linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the child is a fork on Linux only")


def test_the_work_is_done_when_waited_for(tmp_path):
    target = tmp_path / "out.txt"
    job = in_background(lambda: target.write_text("written"))
    assert job.wait()
    assert target.read_text() == "written"


@linux
def test_it_runs_in_another_process(tmp_path):
    target = tmp_path / "pid.txt"
    job = in_background(lambda: target.write_text(str(os.getpid())))
    assert job.pid is not None and job.pid != os.getpid()
    job.wait()
    assert int(target.read_text()) != os.getpid()


@linux
def test_a_failed_child_raises_its_error_here(tmp_path, capfd):
    calls = tmp_path / "calls"
    calls.mkdir()

    def fail():
        (calls / str(os.getpid())).touch()
        raise ValueError("disk full")

    job = in_background(fail)
    with pytest.raises(ValueError, match="disk full"):
        job.wait()
    assert len(list(calls.iterdir())) == 2  # the child, then again here
    assert "ValueError: disk full" in capfd.readouterr().err  # the child's traceback


@linux
def test_the_child_finishes_through_ctrl_c(tmp_path):
    target = tmp_path / "done.txt"

    def slow():
        time.sleep(0.3)
        target.write_text("done")

    job = in_background(slow)
    time.sleep(0.05)
    os.kill(job.pid, signal.SIGINT)
    assert job.wait(rerun_on_failure=False)
    assert target.read_text() == "done"


@linux
def test_the_child_dies_with_its_parent(tmp_path):
    marker = tmp_path / "child.pid"
    script = textwrap.dedent(f"""
        import os, signal, time
        from flexmb._background import in_background
        job = in_background(lambda: time.sleep(30))
        open({str(marker)!r}, "w").write(str(job.pid))
        os.kill(os.getpid(), signal.SIGKILL)
    """)
    subprocess.run([sys.executable, "-c", script], timeout=60)
    child = int(marker.read_text())
    for _ in range(100):  # the kernel delivers the parent-death signal at once; allow for a slow machine
        try:
            os.kill(child, 0)
        except ProcessLookupError:
            break
        with open(f"/proc/{child}/stat") as fh:
            if fh.read().split()[2] == "Z":  # a zombie waiting for init: dead
                break
        time.sleep(0.05)
    else:
        pytest.fail("the child outlived its killed parent")
