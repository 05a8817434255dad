"""The Study (:mod:`flexmb.study.study`): failures, resuming, checks before any case runs, the command line."""

from __future__ import annotations

import json
import logging
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from flexmb.cli import main
from flexmb.errors import FlexmbError, SceneError
from flexmb.study import Study, case_id

from pendulum_study import PENDULUM, G, scene_file  # noqa: F401  (fixtures: scene_file)


# ----------------------------------------------------------------------------- failures and resuming


def test_failing_case_is_recorded_and_the_others_finish(scene_file, tmp_path):
    res = Study.from_file(scene_file, {"bodies.bar.mass": [1.0, -1.0, 2.0]}, outputs=["final:pin"],
                          fixed={"solver.t_end": 0.3}).run(tmp_path, executor="serial", progress=False)
    assert [r["status"] for r in res.rows] == ["finished", "failed", "finished"]
    assert "bodies.bar.mass: must be > 0, got -1.0" in res.rows[1]["error"]
    assert np.isnan(res.column("final:pin")[1]) and np.all(np.isfinite(res.column("final:pin")[[0, 2]]))
    assert "bodies.bar.mass: must be > 0" in (tmp_path / "table.csv").read_text()
    assert "1 failed" in res.summary()
    # a failed case is done: running again runs nothing, unless asked to retry the failures
    again = Study.from_file(scene_file, {"bodies.bar.mass": [1.0, -1.0, 2.0]}, outputs=["final:pin"],
                            fixed={"solver.t_end": 0.3}).run(tmp_path, executor="serial", progress=False)
    assert again.ran == [] and again.skipped == 3
    retry = Study.from_file(scene_file, {"bodies.bar.mass": [1.0, -1.0, 2.0]}, outputs=["final:pin"],
                            fixed={"solver.t_end": 0.3}).run(tmp_path, executor="serial", progress=False,
                                                             retry_failed=True)
    assert retry.ran == [case_id({"bodies.bar.mass": -1.0})]

def test_interrupted_study_resumes_with_only_the_missing_cases(scene_file, tmp_path):
    out = tmp_path / "out"
    masses = [1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5]
    args = [sys.executable, "-m", "flexmb", "study", str(scene_file), "--vary",
            "bodies.bar.mass=" + ",".join(map(str, masses)), "--output", "final:pin", "--set", "solver.t_end=0.6",
            "--serial", "--quiet", "--out", str(out)]
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        for _ in range(6000):  # kill it as soon as two cases are written
            if len(list((out / "cases").glob("*.json"))) >= 2 or proc.poll() is not None:
                break
            time.sleep(0.01)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
    before = {p.name: p.read_bytes() for p in (out / "cases").glob("*.json")}
    assert not any(p.name.startswith(".") for p in (out / "cases").iterdir() if p.suffix == ".json")
    assert 2 <= len(before) < len(masses), "the study finished before it could be killed"
    res = Study.from_file(scene_file, {"bodies.bar.mass": masses}, outputs=["final:pin"],
                          fixed={"solver.t_end": 0.6}).run(out, executor="serial", progress=False)
    # only the missing cases ran, and the files of the others are untouched
    assert len(res.ran) == len(masses) - len(before)
    assert set(res.ran).isdisjoint({n[:-5] for n in before})
    assert res.skipped == len(before)
    assert {n: (out / "cases" / n).read_bytes() for n in before} == before
    assert [r["status"] for r in res.rows] == ["finished"] * len(masses)
    # the swing does not depend on the mass
    assert np.ptp(res.column("final:pin")) < 1e-8


def test_changed_study_does_not_reuse_case_files(scene_file, tmp_path):
    kw = dict(outputs=["final:pin"], fixed={"solver.t_end": 0.2})
    Study.from_file(scene_file, {"bodies.bar.mass": [1.0]}, **kw).run(tmp_path, executor="serial", progress=False)
    res = Study.from_file(scene_file, {"bodies.bar.mass": [1.0, 2.0]}, **kw).run(tmp_path, executor="serial",
                                                                                   progress=False)
    assert len(res.ran) == 1 and res.skipped == 1
    res = Study.from_file(scene_file, {"bodies.bar.mass": [1.0, 2.0]}, outputs=["final:pin"],
                          fixed={"solver.t_end": 0.3}).run(tmp_path, executor="serial", progress=False)
    assert len(res.ran) == 2 and res.skipped == 0


def test_a_resumed_study_logs_what_was_done_before(scene_file, tmp_path, caplog, capsys):
    kw = dict(outputs=["final:pin"], fixed={"solver.t_end": 0.2})
    Study.from_file(scene_file, {"bodies.bar.mass": [1.0]}, **kw).run(tmp_path, executor="serial", progress=False)
    with caplog.at_level(logging.INFO, logger="flexmb"):
        Study.from_file(scene_file, {"bodies.bar.mass": [1.0, 2.0]}, **kw).run(tmp_path, executor="serial",
                                                                               progress=False)
    [record] = [r for r in caplog.records if r.name == "flexmb.study"]
    assert record.levelno == logging.INFO
    assert record.getMessage() == "study: 1 of 2 cases done before, running the other 1"
    assert "done before" not in capsys.readouterr().err  # a library prints nothing of it


# ----------------------------------------------------------------------------- checked before any case runs


def test_bad_key_path_fails_before_any_case_runs(scene_file, tmp_path):
    with pytest.raises(SceneError, match=r"bodies\.blade: no such table .* tables here: bar"):
        Study.from_file(scene_file, {"bodies.blade.E": [1.0, 2.0]}).run(tmp_path, executor="serial")
    with pytest.raises(SceneError, match=r"bodies\.bar\.stiffness: unknown key"):
        Study.from_file(scene_file, {"bodies.bar.stiffness": [1.0]}).run(tmp_path, executor="serial")
    with pytest.raises(FlexmbError, match="unknown output 'peak'; pick one of peak_speed"):
        Study.from_file(scene_file, {"bodies.bar.mass": [1.0]}, outputs=["peak"]).run(tmp_path)
    with pytest.raises(FlexmbError, match="points of this scene: tip"):
        Study.from_file(scene_file, {"bodies.bar.mass": [1.0]}, outputs=["peak_speed:toe"]).run(tmp_path)
    with pytest.raises(FlexmbError, match="both varied and fixed"):
        Study.from_file(scene_file, {"solver.t_end": [1.0]}, fixed={"solver.t_end": 2.0})
    assert not (tmp_path / "cases").exists()


def test_linked_keys_set_one_value(scene_file, tmp_path):
    # a+b sets the release angle and the initial speed to one value w: omega_bottom^2 = 3 g (1 + sin w) / L + w^2
    w = np.array([0.25, 0.5])
    res = Study.from_file(scene_file, {"initial.positions.pin+initial.speeds.pin": w.tolist()},
                          outputs=["peak_speed:tip"]).run(tmp_path, executor="serial", progress=False)
    assert res.parameters == ["initial.positions.pin+initial.speeds.pin"]
    assert res.column("peak_speed:tip") == pytest.approx(np.sqrt(3 * G * (1 + np.sin(w)) + w**2), rel=2e-4)
    # the tracked point moved with the bar's length: the true tip, v = L omega
    res = Study.from_file(scene_file, {"bodies.bar.length": [2.0]}, fixed={"output.points.tip.point": [2.0, 0, 0]},
                          outputs=["peak_speed:tip"]).run(tmp_path / "b", executor="serial", progress=False)
    assert res.column("peak_speed:tip")[0] == pytest.approx(2.0 * np.sqrt(3 * G / 2.0), rel=2e-4)


def test_initial_point_and_angular_velocities_are_varied_by_key_path(tmp_path, capsys):
    # the bar released level with its tip pushed down at v: at the bottom omega^2 = 3 g / L + (v / L)^2; the peak is
    # sampled every 1 ms, so it may fall short by (v''/v)(dt/2)^2/2 = (3 g / 2 L)(dt/2)^2/2 = 1.8e-6 (relative)
    text = PENDULUM.replace("speeds = { pin = 0.0 }\n", "") + (
        "\n[initial.point_velocities.push]\nbody = \"bar\"\npoint = [1.0, 0.0, 0.0]\nvelocity = [0.0, -1.0, 0.0]\n")
    path = tmp_path / "pushed.toml"
    path.write_text(text)
    v = np.array([0.5, 2.0])
    key = "initial.point_velocities.push.velocity"
    res = Study.from_file(path, {key: [[0.0, -w, 0.0] for w in v]}, outputs=["peak_speed_exact:tip"]).run(
        tmp_path / "py", executor="serial", progress=False)
    assert res.column("peak_speed_exact:tip") == pytest.approx(np.sqrt(3 * G + v**2), rel=2e-6)
    # the same from the command line, and an angular velocity in the bar's own axes
    assert main(["study", str(path), "--vary", f"{key}=[0.0,-0.5,0.0],[0.0,-2.0,0.0]", "--output",
                 "peak_speed_exact:tip", "--serial", "--quiet", "--out", str(tmp_path / "cli")]) == 0
    table = (tmp_path / "cli" / "table.csv").read_text()
    assert '"[0.0, -2.0, 0.0]"' in table
    text = text.replace("[initial.point_velocities.push]", "[initial.angular_velocities.push]").replace(
        "point = [1.0, 0.0, 0.0]\nvelocity = [0.0, -1.0, 0.0]", "omega = [0.0, 0.0, -1.0]\nframe = \"body\"")
    path.write_text(text)
    res = Study.from_file(path, {"initial.angular_velocities.push.omega": [[0.0, 0.0, -w] for w in v]},
                          outputs=["peak_speed_exact:tip"]).run(tmp_path / "w", executor="serial", progress=False)
    assert res.column("peak_speed_exact:tip") == pytest.approx(np.sqrt(3 * G + v**2), rel=2e-6)
    # one component by its index: a range of tip speeds, the table's column in m/s
    path.write_text(text.replace("[initial.angular_velocities.push]", "[initial.point_velocities.push]").replace(
        "omega = [0.0, 0.0, -1.0]\nframe = \"body\"", "point = [1.0, 0.0, 0.0]\nvelocity = [0.0, -1.0, 0.0]"))
    assert main(["study", str(path), "--vary", f"{key}[1]=lin:-0.5:-2.0:2", "--output", "peak_speed_exact:tip",
                 "--serial", "--quiet", "--out", str(tmp_path / "component")]) == 0
    res = Study.from_file(path, {f"{key}[1]": [-0.5, -2.0]}, outputs=["peak_speed_exact:tip"]).run(
        tmp_path / "component", executor="serial", progress=False)
    assert res.ran == [] and res.column(f"{key}[1]").tolist() == [-0.5, -2.0]  # the command line's cases
    assert res.column("peak_speed_exact:tip") == pytest.approx(np.sqrt(3 * G + v**2), rel=2e-6)
    assert res.unit(f"{key}[1]") == "m/s"
    path.write_text(text)
    # a case whose velocity the pin does not allow fails with the key's name; the others finish
    res = Study.from_file(path, {"initial.angular_velocities.push.omega": [[0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]},
                          outputs=["peak_speed_exact:tip"]).run(tmp_path / "bad", executor="serial", progress=False)
    assert [r["status"] for r in res.rows] == ["finished", "failed"]
    assert "initial.angular_velocities.push" in res.rows[1]["error"] and "contradict" in res.rows[1]["error"]


# ----------------------------------------------------------------------------- command line


def test_cli_study(scene_file, tmp_path, capsys):
    out = tmp_path / "cli"
    code = main(["study", str(scene_file), "--vary", "bodies.bar.mass=1.0,-2.0", "--vary",
                 "initial.positions.pin=lin:0:0.5:2", "--set", "solver.t_end=0.2", "--output", "final:pin",
                 "--serial", "--quiet", "--out", str(out)])
    assert code == 4  # one mass is invalid: some case failed
    text = capsys.readouterr().out
    assert "4 cases: 2 finished, 2 failed" in text
    assert "bodies.bar.mass: must be > 0, got -2.0" in text
    manifest = json.loads((out / "study.json").read_text())
    assert manifest["parameters"] == ["bodies.bar.mass", "initial.positions.pin"]
    assert main(["study", str(scene_file), "--vary", "bodies.bar.mass=1.0,2.0", "--set", "solver.t_end=0.2",
                 "--serial", "--out", str(tmp_path / "ok")]) == 0
    captured = capsys.readouterr()
    # the progress goes to a log as whole lines, every half minute only (flexmb.progress); the summary stays
    assert "2 cases: 2 finished" in captured.out and "\r" not in captured.err
    assert main(["study", str(scene_file), "--vary", "bodies.bar.mass", "--out", str(tmp_path / "x")]) == 3
    assert "write KEY=VALUE" in capsys.readouterr().err
    # the command shows the flexmb loggers' messages on stderr, one line each, and not with --quiet
    again = ["study", str(scene_file), "--vary", "bodies.bar.mass=1.0,2.0,3.0", "--set", "solver.t_end=0.2",
             "--serial", "--out", str(tmp_path / "ok")]
    assert main(again + ["--quiet"]) == 0
    assert "done before" not in capsys.readouterr().err
    (tmp_path / "ok" / "cases" / next(p.name for p in (tmp_path / "ok" / "cases").glob("*.json"))).unlink()
    assert main(again) == 0
    assert "study: 2 of 3 cases done before, running the other 1\n" in capsys.readouterr().err


# ----------------------------------------------------------------------------- one study per folder, whole (#33, 3)


def _masses_study(scene_file, masses, t_end=0.2):
    return Study.from_file(scene_file, {"bodies.bar.mass": masses}, outputs=["final:pin"],
                           fixed={"solver.t_end": t_end})


def _study_set(out) -> tuple:
    """The study ``study.json`` describes and the parameter values of the table beside it."""
    manifest = json.loads((out / "study.json").read_text())
    lines = (out / "table.csv").read_text().splitlines()
    column = lines[0].split(",").index("bodies.bar.mass")
    return manifest["specs"]["bodies.bar.mass"], [float(line.split(",")[column]) for line in lines[1:]]


def test_a_study_into_a_busy_folder_is_refused_before_any_case_runs(scene_file, tmp_path, capsys):
    from flexmb._files import OutputFolder

    with OutputFolder(tmp_path):
        code = main(["study", str(scene_file), "--vary", "bodies.bar.mass=1,2", "--set", "solver.t_end=0.1",
                     "--serial", "--quiet", "--out", str(tmp_path)])
    assert code == 3  # main ran the study: two studies into one folder both exited 0, their files mixed
    assert f"in use by another flexmb run (pid {os.getpid()}" in capsys.readouterr().err
    assert not (tmp_path / "cases").exists() and not (tmp_path / "study.json").exists()


HOLD = """
import os, sys, time
import flexmb.scene as scene
simulate = scene.Scene.simulate
def held(self, *args, **kw):
    open(sys.argv[1], "w").close()  # started its first case: the study holds its folder
    while not os.path.exists(sys.argv[2]):
        time.sleep(0.01)
    return simulate(self, *args, **kw)
scene.Scene.simulate = held
from flexmb.cli import main
sys.exit(main(sys.argv[3:]))
"""


def test_a_second_study_while_one_runs_is_refused_and_nothing_mixes(scene_file, tmp_path):
    out, started, go = tmp_path / "out", tmp_path / "started", tmp_path / "go"
    argv = [["study", str(scene_file), "--vary", f"bodies.bar.mass={masses}", "--output", "final:pin", "--set",
             "solver.t_end=0.2", "--serial", "--quiet", "--out", str(out)] for masses in ("1,2,3", "4,5")]
    first = subprocess.Popen([sys.executable, "-c", HOLD, str(started), str(go), *argv[0]],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        end = time.monotonic() + 120
        while not started.exists():
            assert first.poll() is None and time.monotonic() < end, first.communicate()
            time.sleep(0.01)
        second = subprocess.run([sys.executable, "-m", "flexmb", *argv[1]], capture_output=True, text=True,
                                timeout=300)
    finally:
        go.touch()
        first.communicate(timeout=300)
    # main: both exited 0, the second's study.json beside the first's table (the first ended last)
    assert (first.returncode, second.returncode) == (0, 3), second.stderr
    assert f"in use by another flexmb run (pid {first.pid}" in second.stderr and "Traceback" not in second.stderr
    assert _study_set(out) == ([1.0, 2.0, 3.0], [1.0, 2.0, 3.0])


def test_an_interrupted_study_leaves_the_previous_study_whole(scene_file, tmp_path, monkeypatch):
    from flexmb.study import study as study_module

    _masses_study(scene_file, [1.0, 2.0]).run(tmp_path, executor="serial", progress=False)
    real = study_module._execute

    def interrupted(executor, tasks, record, *args):
        real(executor, tasks[:1], record, *args)  # one case ends, then Ctrl-C (or a kill)
        raise KeyboardInterrupt

    monkeypatch.setattr(study_module, "_execute", interrupted)
    with pytest.raises(KeyboardInterrupt):
        _masses_study(scene_file, [3.0, 4.0, 5.0]).run(tmp_path, executor="serial", progress=False)
    # main left the new study.json beside the old table
    assert _study_set(tmp_path) == ([1.0, 2.0], [1.0, 2.0])
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == [".flexmb-run.json"]
    monkeypatch.setattr(study_module, "_execute", real)
    res = _masses_study(scene_file, [3.0, 4.0, 5.0]).run(tmp_path, executor="serial", progress=False)
    assert (len(res.ran), res.skipped) == (2, 1)  # resumed
    assert _study_set(tmp_path) == ([3.0, 4.0, 5.0], [3.0, 4.0, 5.0])


def test_a_study_and_a_run_do_not_replace_each_other_unasked(scene_file, tmp_path, capsys):
    out = str(tmp_path)
    study = ["study", str(scene_file), "--vary", "bodies.bar.mass=1,2", "--set", "solver.t_end=0.1", "--serial",
             "--quiet", "--out", out]
    run = ["run", str(scene_file), "--out", out, "--t-end", "0.1", "--n-out", "3", "--quiet"]
    assert main(study) == 0
    assert main(run) == 3
    assert "holds the outputs of a study of" in capsys.readouterr().err
    assert (tmp_path / "table.csv").exists()
    assert main(run + ["--overwrite"]) == 0
    assert not (tmp_path / "table.csv").exists() and (tmp_path / "summary.json").exists()
    assert (tmp_path / "cases").is_dir()  # the cases are a study's record, never a run's to remove
    assert main(study) == 3
    assert main(study + ["--overwrite"]) == 0
    assert (tmp_path / "table.csv").exists() and not (tmp_path / "summary.json").exists()
