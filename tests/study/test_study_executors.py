"""Executors (:mod:`flexmb.study.executors`): serial, process pool and Dask give one table; a dead worker; time limits; orphans."""

from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from flexmb.cli import main
from flexmb.errors import FlexmbError
from flexmb.study import Study

from pendulum_study import _assert_same_table, LENGTHS, OUTPUTS, scene_file, serial, _study  # noqa: F401  (fixtures: scene_file, serial)


# ----------------------------------------------------------------------------- three executors, one table


def test_process_pool_and_dask_give_the_serial_table(scene_file, serial, tmp_path):
    pool = _study(scene_file).run(tmp_path / "pool", executor="process", workers=2, progress=False)
    _assert_same_table(pool, serial)
    assert len(pool.rows) == 6
    assert all(r["worker"].split(":")[1] != str(os.getpid()) for r in pool.rows)

    pytest.importorskip("distributed")
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster, Client(cluster) as client:
        dask = _study(scene_file).run(tmp_path / "dask", client=client, progress=False)
        # the command line, pointed at the same cluster by its address
        args = ["study", str(scene_file), "--vary", "bodies.bar.length=0.5,1.0,2.0", "--vary",
                f"initial.positions.pin=0.0,{np.pi / 6!r}", "--set", "solver.t_end=1.0", "--quiet",
                "--out", str(tmp_path / "cli")]
        for o in OUTPUTS:
            args += ["--output", o]
        assert main(args + ["--scheduler", cluster.scheduler_address]) == 0
    _assert_same_table(dask, serial)
    _assert_same_table(dask, pool)
    cli = Study.from_file(scene_file, {"bodies.bar.length": LENGTHS, "initial.positions.pin": [0.0, np.pi / 6]},
                          outputs=OUTPUTS, fixed={"solver.t_end": 1.0}).run(tmp_path / "cli", progress=False)
    assert cli.ran == [] and cli.skipped == 6  # same study: found done, read back from the case files
    _assert_same_table(cli, serial)
    assert all(r["worker"].split(":")[1] != str(os.getpid()) for r in dask.rows)

def _exit_for_heavy_bars(scene, result):
    """An output that kills its worker process for the 3 kg bar (a crashing extension module)."""
    if scene.model["bar"].mass == 3.0:
        os._exit(13)
    return float(result.t[-1])


def test_dead_worker_process_is_recorded_and_the_others_finish(scene_file, tmp_path):
    study = Study.from_file(scene_file, {"bodies.bar.mass": [1.0, 3.0, 2.0]},
                            outputs=[("t_end", _exit_for_heavy_bars)], fixed={"solver.t_end": 0.2})
    res = study.run(tmp_path, executor="process", workers=2, progress=False)
    status = {r["parameters"]["bodies.bar.mass"]: (r["status"], r["error"]) for r in res.rows}
    assert status[3.0] == ("failed", "worker process died while running this case")
    assert [status[m][0] for m in (1.0, 2.0)] == ["finished"] * 2
    assert res.column("t_end")[[0, 2]] == pytest.approx([0.2] * 2, rel=1e-14)

# ----------------------------------------------------------------------------- issue 18 section 4: time limits, orphans

#: t_end of the case that "never ends": at max_step 1e-3 it would take days
ENDLESS = 1.0e5  # 1e8 steps of 1 ms: under simulate's max_steps, for hours
#: seconds per case; the short cases take well under a second of CPU (but the test machine may be loaded)
LIMIT = 5.0


def _limited(scene_file, **kw):
    return Study.from_file(scene_file, {"solver.t_end": [0.01, ENDLESS, 0.02]}, outputs=["final:pin"],
                           fixed={"solver.max_step": 1e-3}, **kw)


def _assert_only_the_endless_case_failed(res, limit):
    status = {r["parameters"]["solver.t_end"]: (r["status"], r["error"]) for r in res.rows}
    assert status[ENDLESS] == ("failed", f"exceeded the time limit of {limit:g} s per case; stopped")
    assert [status[t][0] for t in (0.01, 0.02)] == ["finished"] * 2
    wall = {r["parameters"]["solver.t_end"]: r["wall_time_s"] for r in res.rows}
    assert limit <= wall[ENDLESS] < limit + 30.0


def test_a_time_limit_that_lands_as_a_kernel_returns_is_still_the_time_limit(monkeypatch):
    """The serial executor's time limit is an exception raised in the case's thread; raised just as a compiled
    kernel returns, numba turns it into 'SystemError: CPUDispatcher(...) returned a result with an exception set',
    which the step loop records as a failed simulation (seen under load: the case read 'simulation failed at
    t = 20.47 s: SystemError: ...' instead of the time limit). A case that fails after the limit fired is the
    time limit's."""
    from flexmb.study import cases

    def run_case(task):  # the step loop's record of such a failure, once the limit has fired
        end = time.monotonic() + 30.0
        while time.monotonic() < end:
            try:
                time.sleep(0.01)
            except cases._CaseTimeout as exc:  # what numba's SystemError wraps; the step loop catches that
                return {**cases._failed_row(task, f"SimulationError: simulation failed: SystemError: {exc!r}"),
                        "wall_time_s": 0.1}
        return {**cases._failed_row(task, "the limit never fired"), "status": "finished"}

    monkeypatch.setattr(cases, "_run_case", run_case)
    task = {"case": 0, "case_id": "c", "parameters": {}, "time_limit": 0.2}
    row = cases._run_case_limited(task)
    assert (row["status"], row["error"]) == ("failed", "exceeded the time limit of 0.2 s per case; stopped")
    assert row["wall_time_s"] >= 0.2


@pytest.mark.parametrize("executor", ["serial", "process"])
def test_a_case_past_its_time_limit_is_recorded_and_the_study_goes_on(scene_file, tmp_path, executor):
    """One case that never ends used to hang the whole study."""
    t = time.perf_counter()
    res = _limited(scene_file).run(tmp_path, executor=executor, workers=2, progress=False, time_limit=LIMIT)
    assert time.perf_counter() - t < 120.0
    _assert_only_the_endless_case_failed(res, LIMIT)
    assert "exceeded the time limit of 5 s per case" in (tmp_path / "table.csv").read_text()
    # a timed-out case is a failed case: rerun only with retry_failed
    again = _limited(scene_file).run(tmp_path, executor="serial", progress=False, time_limit=LIMIT)
    assert again.ran == []


def test_time_limit_on_dask(scene_file, tmp_path):
    pytest.importorskip("distributed")
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=2, processes=True, host="127.0.0.1", dashboard_address=None) \
            as cluster, Client(cluster) as client:
        # the worker loads flexmb and its compiled kernels before the clock of a case starts (on a
        # loaded machine that alone can take seconds; see the session notes)
        client.run(_warm_up)
        res = _limited(scene_file).run(tmp_path, client=client, progress=False, time_limit=LIMIT)
    _assert_only_the_endless_case_failed(res, LIMIT)


def _warm_up():
    import flexmb as fm

    model = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0.0, -9.81, 0.0)))
    return fm.simulate(model, 0.01, n_out=2).status


def test_time_limit_from_the_scene_and_the_cli(scene_file, tmp_path, capsys):
    text = scene_file.read_text() + "\n[study]\ntime_limit = 4.5\n"
    path = tmp_path / "limited.toml"
    path.write_text(text)
    study = Study.from_file(path, {"solver.t_end": [0.01, ENDLESS, 0.02]}, outputs=["final:pin"],
                            fixed={"solver.max_step": 1e-3})
    _assert_only_the_endless_case_failed(study.run(tmp_path / "scene", executor="serial", progress=False), 4.5)
    code = main(["study", str(scene_file), "--vary", f"solver.t_end=0.01,{ENDLESS},0.02", "--set",
                 "solver.max_step=1e-3", "--output", "final:pin", "--time-limit", "4", "--workers", "2", "--quiet",
                 "--out", str(tmp_path / "cli")])
    assert code == 4  # some case failed
    assert "exceeded the time limit of 4 s per case; stopped" in capsys.readouterr().out
    with pytest.raises(FlexmbError, match=r"time_limit must be a finite number of seconds > 0, got -1"):
        _limited(scene_file).run(tmp_path / "bad", executor="serial", progress=False, time_limit=-1)


def _descendants(pid: int) -> set[int]:
    """Process ids below ``pid`` (children, grandchildren, ...), from /proc."""
    parent = {}
    for d in pathlib.Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            parent[int(d.name)] = int(stat.rsplit(")", 1)[1].split()[1])
    out, todo = set(), [pid]
    while todo:
        p = todo.pop()
        kids = [c for c, pp in parent.items() if pp == p]
        out.update(kids)
        todo += kids
    return out


def _alive(pid: int) -> bool:
    try:
        state = pathlib.Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_case_processes_end_when_the_study_is_killed(scene_file, tmp_path):
    """After SIGKILL of `flexmb study`, two pool workers, the forkserver and the resource tracker stayed alive."""
    args = [sys.executable, "-m", "flexmb", "study", str(scene_file), "--vary", f"solver.t_end={ENDLESS},{2 * ENDLESS}",
            "--set", "solver.max_step=1e-3", "--output", "final:pin", "--workers", "2", "--quiet",
            "--out", str(tmp_path / "out")]
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        below: set[int] = set()
        for _ in range(600):  # the cases are running: resource tracker, fork server and 2 cases (at least)
            below = _descendants(proc.pid)
            if len(below) >= 4 or proc.poll() is not None:
                break
            time.sleep(0.1)
        assert len(below) >= 4, f"the study did not start its cases: {below}"
        time.sleep(0.5)
        below = _descendants(proc.pid)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline and any(_alive(p) for p in below):
        time.sleep(0.1)
    left = [p for p in below if _alive(p)]
    for p in left:  # leave nothing behind, even when the test fails
        os.kill(p, signal.SIGKILL)
    assert not left, f"processes left after the study was killed: {left}"


_HOLDING_CASE = """
import ctypes, sys
from flexmb.study.cases import _watch_study
_watch_study(int(sys.argv[1]))
print("ready", flush=True)
ctypes.PyDLL(None).sleep(600)  # C code that keeps the GIL, as a compiled kernel stuck in a loop does
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_a_case_stuck_in_compiled_code_ends_with_the_study(tmp_path):
    """Seen: two case processes spinning in a kernel ran on for 1.75 h after their study was killed.

    The watchdog was a thread of the case, which needs the GIL to run: a
    kernel that holds it (numba without ``nogil``, any C call made with the
    GIL held) kept the case alive forever once its study was gone.
    """
    study = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
    case = subprocess.Popen([sys.executable, "-c", _HOLDING_CASE, str(study.pid)], stdout=subprocess.PIPE, text=True)
    try:
        assert case.stdout.readline().strip() == "ready"
        time.sleep(0.3)  # inside the C call
        assert case.poll() is None
        os.kill(study.pid, signal.SIGKILL)
        study.wait()
        case.wait(timeout=10)  # TimeoutExpired: the case outlived its study
        assert case.returncode != 0
    finally:
        for p in (study, case):
            if p.poll() is None:
                p.kill()
                p.wait()


# ----------------------------------------------------------------------------- a study in a plain script (issue #32)


_SCRIPT = """
import flexmb as fm
{extra}
print("top level of the script ran")
res = fm.run_study({scene!r}, {{"bodies.bar.mass": [1.0, 2.0]}}, "study", outputs={outputs},
                   fixed={{"solver.t_end": 0.05, "solver.n_out": 6}}, workers=2, progress=False)
print(res.summary())
"""


def _script(tmp_path, scene_file, extra="", outputs=("final:pin",)):
    path = tmp_path / "plain_script.py"
    text = repr(list(outputs)).replace("'@swing@'", "swing")  # a function of the script, by its name
    path.write_text(_SCRIPT.format(scene=str(scene_file), extra=extra, outputs=text))
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    return subprocess.run([sys.executable, str(path)], capture_output=True, text=True, timeout=600, cwd=tmp_path,
                          env=env)


def test_a_study_at_the_top_level_of_a_plain_script_runs_on_the_process_pool(scene_file, tmp_path):
    """No `if __name__ == "__main__":` guard: the case processes do not import the script again, so every
    case finishes and the script's top level runs once (it ran in every case process: "worker process died",
    tutorial 08's summary printed 13 times)."""
    proc = _script(tmp_path, scene_file)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.count("top level of the script ran") == 1, proc.stdout
    assert "2 cases: 2 finished, 0 failed; 2 run now" in proc.stdout, proc.stdout + proc.stderr[-3000:]


def test_a_top_level_study_whose_outputs_live_in_the_script_says_what_to_add(scene_file, tmp_path):
    """Outputs defined in the script make each case process import it: without the guard that would run the
    study again in each, so the study is refused before any case runs, saying what to add."""
    extra = "def swing(scene, result):\n    return float(result.x[-1, 0])\n"
    proc = _script(tmp_path, scene_file, extra=extra, outputs=("final:pin", ("swing", "@swing@")))
    assert proc.returncode != 0
    assert 'if __name__ == "__main__":' in proc.stderr and "plain_script.py, line" in proc.stderr
    assert "swing" in proc.stderr and "executor='serial'" in proc.stderr
    assert not list((tmp_path / "study").glob("cases/*.json"))  # no case ran


def test_a_rerun_says_which_failures_are_from_an_earlier_run(scene_file, tmp_path):
    """A failed case is not run again without retry_failed, and the summary says so instead of reporting it
    as if it had just failed."""
    study = Study.from_file(scene_file, {"bodies.bar.mass": [1.0, -1.0]}, outputs=["final:pin"],
                            fixed={"solver.t_end": 0.05, "solver.n_out": 6})
    first = study.run(tmp_path, executor="serial", progress=False)
    assert "(in an earlier run" not in first.summary() and len(first.failed) == 1
    again = study.run(tmp_path, executor="serial", progress=False)
    text = again.summary()
    assert "0 run now, 2 done before" in text
    assert "failed (in an earlier run, not run again)" in text and "--retry-failed" in text
    assert study.run(tmp_path, executor="serial", progress=False, retry_failed=True).ran == [first.failed[0]["case_id"]]


@pytest.mark.parametrize("address, why", [("garbage", "missing port number in address 'garbage'"),
                                           ("tcp://127.0.0.1:1", "Timed out trying to connect")])
def test_an_unreachable_scheduler_is_one_line_and_writes_nothing(scene_file, tmp_path, capsys, address, why):
    """``--scheduler garbage`` or an address nobody answers printed a traceback and left the folder begun."""
    pytest.importorskip("distributed")
    import dask

    out = tmp_path / "unreachable"
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        code = main(["study", str(scene_file), "--vary", "bodies.bar.length=0.5,1.0", "--output", "final:pin",
                     "--scheduler", address, "--quiet", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 3 and "Traceback" not in err
    assert f"flexmb: error: Study: cannot reach the Dask scheduler {address!r}: " in err and why in err
    assert not out.exists()  # reached before the folder is made


@pytest.mark.parametrize("broken", [{"outputs": 5}, {"parameters": [1, 2]}, {"case": "0"}, {"case_id": None}])
def test_a_case_file_of_the_wrong_shape_is_run_again_on_resume(scene_file, serial, tmp_path, broken):
    """A case file of valid JSON but the wrong shape crashed every resume (AttributeError: 'int' ... 'get')."""
    import json

    out = tmp_path / "resume"
    _study(scene_file).run(out, executor="serial", progress=False)
    path = sorted((out / "cases").glob("*.json"))[0]
    row = json.loads(path.read_text())
    row.update(broken)
    path.write_text(json.dumps(row))
    again = _study(scene_file).run(out, executor="serial", progress=False)
    _assert_same_table(again, serial)
    assert isinstance(json.loads(path.read_text())["outputs"], dict)  # the case ran again and wrote its row


@pytest.mark.parametrize("stage", ["_build", "_evaluate"])
def test_an_interruption_as_a_kernel_returns_outside_the_run_stops_the_study(monkeypatch, stage):
    """A SIGTERM as a compiled kernel returned while a case was built (numba's SystemError) was a failed case:
    the study went on and exited 4."""
    from flexmb._signals import Terminated
    from flexmb.study import cases

    def interrupted(*args, **kwargs):
        try:
            raise Terminated(signal.SIGTERM)
        except Terminated as exc:
            raise SystemError("CPUDispatcher(<function tree_kinematics>) returned a result with an exception set") \
                from exc

    monkeypatch.setattr(cases, stage, interrupted)
    if stage == "_evaluate":
        monkeypatch.setattr(cases, "_build", lambda *a: type("Scene", (), {"simulate": lambda self, progress:
                                                                            type("R", (), {"status": "finished"})()})())
    task = {"case": 0, "case_id": "c", "parameters": {}, "data": {}, "source": "", "fixed": {}, "outputs": ["x"]}
    with pytest.raises(Terminated):
        cases._run_case(task)
