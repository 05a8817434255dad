"""Parameter studies (:mod:`flexmb.study`): specs, closed-form outputs, three executors, failures, resuming.

The study scene is a uniform slender bar (mass m, length L) pinned at one end
and released from rest at angle q0 above the horizontal, under gravity g. Energy
conservation gives its tip speed at the bottom, the peak over the swing,

    v_tip = L omega,  omega^2 = 3 g (1 + sin q0) / L,

independent of m: the reference the study's outputs are checked against.
The same 6 cases run serially, on the local process pool and on a real
``dask.distributed.LocalCluster`` (2 worker processes on loopback) and must
give the same table.
"""

from __future__ import annotations

import inspect
import json
import logging
import os
import pathlib
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from scipy import stats
from scipy.stats import qmc

import flexmb as fm
from flexmb.cli import main
from flexmb.errors import FlexmbError, SceneError
from flexmb.study import Distribution, Study, case_id, parse_spec, parse_value

G = 9.81

PENDULUM = """
[model]
name = "pendulum"

[bodies.bar]
shape = "slender_bar"
mass = 1.0
length = 1.0

[joints.pin]
type = "revolute"
parent = "ground"
child = "bar"
axis = [0.0, 0.0, 1.0]

[forces.gravity]
type = "gravity"
g = [0.0, -9.81, 0.0]

[initial]
positions = { pin = 0.0 }
speeds = { pin = 0.0 }

[solver]
t_end = 1.0
rtol = 1e-8
n_out = 1001

[output.points.tip]
body = "bar"
point = [1.0, 0.0, 0.0]
"""

OUTPUTS = ["peak_speed:tip", "final:pin", "energy_balance", "n_rhs"]
LENGTHS = [0.5, 1.0, 2.0]  # with 2 release angles: 6 cases, each reaching the bottom before t = 1 s


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("scene") / "pendulum.toml"
    path.write_text(PENDULUM)
    return path


def _study(scene_file, **kw):
    kw.setdefault("outputs", OUTPUTS)
    return Study.from_file(scene_file, {"bodies.bar.length": LENGTHS, "initial.positions.pin": [0.0, np.pi / 6]},
                           fixed={"solver.t_end": 1.0}, **kw)


def _comparable(result):
    """The table without the columns that depend on the machine (wall time, worker)."""
    return [[c for c, name in zip(cells, result.columns) if name not in ("wall_time_s", "worker")]
            for cells in result.table()]


def _assert_same_table(a, b):
    """Same columns, same rows, same text cells, floats equal to 1e-12 (relative)."""
    assert a.columns == b.columns
    ta, tb = _comparable(a), _comparable(b)
    assert len(ta) == len(tb)
    for ra, rb in zip(ta, tb):
        for x, y in zip(ra, rb):
            if isinstance(x, float):
                assert x == pytest.approx(y, rel=1e-12, abs=1e-300)
            else:
                assert x == y


@pytest.fixture(scope="module")
def serial(scene_file, tmp_path_factory):
    return _study(scene_file).run(tmp_path_factory.mktemp("serial"), executor="serial", progress=False)


# ----------------------------------------------------------------------------- specs


def test_specs_lists_ranges_and_types():
    assert parse_spec("1,2,3") == [1, 2, 3]
    assert parse_spec("1.0, 2.5") == [1.0, 2.5]
    assert parse_spec("lin:2:8:4") == [2, 4, 6, 8] and all(type(v) is int for v in parse_spec("lin:2:8:4"))
    assert parse_spec("lin:0:1:5") == pytest.approx([0.0, 0.25, 0.5, 0.75, 1.0], abs=0)
    assert parse_spec("log:1e-3:1e1:5") == pytest.approx([1e-3, 1e-2, 1e-1, 1.0, 10.0], rel=1e-15)
    assert parse_spec('"svd","eigen"') == ["svd", "eigen"]
    assert parse_spec("[1,0,0],[0,1,0]") == [[1, 0, 0], [0, 1, 0]]
    assert parse_value("Radau") == "Radau" and parse_value("7") == 7 and parse_value("7.") == 7.0
    assert parse_spec("loguniform:1e9:1e11") == Distribution("loguniform", 1e9, 1e11)
    for bad in ("lin:0:1", "log:0:1:3", "uniform:2:1", "normal:0:-1", "lin:a:b:3", "uniform:1"):
        with pytest.raises(FlexmbError):
            parse_spec(bad)


def test_grid_order_and_case_ids(scene_file):
    cases = _study(scene_file).cases()
    assert len(cases) == 6
    # last parameter fastest
    assert [c["bodies.bar.length"] for c in cases] == [0.5, 0.5, 1.0, 1.0, 2.0, 2.0]
    ids = [case_id(c) for c in cases]
    assert len(set(ids)) == 6 and all(len(i) == 16 for i in ids)
    assert case_id({"a": 1.0, "b": 2}) == case_id({"b": 2, "a": 1.0})


@pytest.mark.parametrize("sampling", ["lhs", "mc"])
def test_random_parameters_are_seeded_and_latin_hypercube_stratified(scene_file, sampling):
    vary = {"bodies.bar.mass": "uniform:1:3", "bodies.bar.length": Distribution("loguniform", 0.1, 10.0),
            "initial.positions.pin": [0.0, 0.5]}
    study = Study.from_file(scene_file, vary, samples=50, seed=7, sampling=sampling)
    cases = study.cases()
    assert len(cases) == 100
    assert cases == Study.from_file(scene_file, vary, samples=50, seed=7, sampling=sampling).cases()
    assert cases != Study.from_file(scene_file, vary, samples=50, seed=8, sampling=sampling).cases()
    m = np.array([c["bodies.bar.mass"] for c in cases[:50]])
    L = np.array([c["bodies.bar.length"] for c in cases[:50]])
    assert np.all((1 <= m) & (m <= 3)) and np.all((0.1 <= L) & (L <= 10))
    strata_m = np.sort(np.floor((m - 1) / 2 * 50).astype(int))
    strata_L = np.sort(np.floor((np.log(L) - np.log(0.1)) / np.log(100) * 50).astype(int))
    if sampling == "lhs":  # exactly one sample in each of the 50 equal-probability strata
        assert np.array_equal(strata_m, np.arange(50)) and np.array_equal(strata_L, np.arange(50))
    else:
        assert len(set(strata_m)) < 50
    with pytest.raises(FlexmbError, match="need samples"):
        Study.from_file(scene_file, vary)


def test_normal_distribution_lhs_matches_its_moments(scene_file):
    study = Study.from_file(scene_file, {"bodies.bar.mass": "normal:5:0.5"}, samples=2000, seed=1)
    m = np.array([c["bodies.bar.mass"] for c in study.cases()])
    # stratified sampling: the mean and spread are far closer than Monte Carlo's 0.5 / sqrt(2000) = 0.011
    assert abs(m.mean() - 5.0) < 2e-3
    assert abs(m.std() - 0.5) < 5e-3


@pytest.mark.parametrize("sampling", ["lhs", "mc"])
def test_samples_follow_their_distributions(scene_file, sampling):
    """Each marginal passes a Kolmogorov-Smirnov test against its scipy.stats distribution."""
    vary = {"bodies.bar.mass": "uniform:1:3", "bodies.bar.length": "loguniform:0.1:10",
            "initial.positions.pin": "normal:0.2:0.05"}
    cases = Study.from_file(scene_file, vary, samples=400, seed=3, sampling=sampling).cases()
    dists = {"bodies.bar.mass": stats.uniform(loc=1, scale=2), "bodies.bar.length": stats.loguniform(0.1, 10),
             "initial.positions.pin": stats.norm(loc=0.2, scale=0.05)}
    for key, dist in dists.items():
        values = np.array([c[key] for c in cases])
        assert stats.kstest(values, dist.cdf).pvalue > 0.01, key
        if sampling == "lhs":  # one sample in each of the 400 equal-probability strata of every parameter
            assert np.array_equal(np.sort(np.floor(dist.cdf(values) * 400)), np.arange(400)), key


def test_latin_hypercube_is_scipy_qmc_with_the_seed(scene_file):
    vary = {"bodies.bar.mass": "uniform:1:3", "bodies.bar.length": "uniform:0.5:2.5"}
    cases = Study.from_file(scene_file, vary, samples=16, seed=11).cases()
    # the study's generator: numpy's default_rng(seed), handed to scipy.stats.qmc.LatinHypercube
    key = "rng" if "rng" in inspect.signature(qmc.LatinHypercube).parameters else "seed"
    u = qmc.LatinHypercube(2, **{key: np.random.default_rng(11)}).random(16)
    np.testing.assert_allclose([c["bodies.bar.mass"] for c in cases], 1 + 2 * u[:, 0], rtol=1e-15)
    np.testing.assert_allclose([c["bodies.bar.length"] for c in cases], 0.5 + 2 * u[:, 1], rtol=1e-15)


# ----------------------------------------------------------------------------- outputs against closed forms


def test_outputs_match_energy_conservation(serial):
    assert [r["status"] for r in serial.rows] == ["finished"] * 6
    L = serial.column("bodies.bar.length")
    q0 = serial.column("initial.positions.pin")
    # the tracked point stays at x = 1 m in the body frame (beyond the tip for L = 0.5, mid-bar for L = 2):
    # its speed is 1 m times omega
    omega = np.sqrt(3 * G * (1 + np.sin(q0)) / L)
    v_ref = 1.0 * omega
    assert serial.column("peak_speed:tip") == pytest.approx(v_ref, rel=2e-4)
    assert np.all(serial.column("energy_balance") < 1e-7)
    assert np.all(serial.column("n_rhs") > 0)
    assert serial.skipped == 0 and len(serial.ran) == 6


def test_mass_does_not_change_the_swing(scene_file, tmp_path):
    res = Study.from_file(scene_file, {"bodies.bar.mass": [0.5, 4.0]}, outputs=["final:pin", "peak_speed:tip"],
                          fixed={"solver.t_end": 0.7}).run(tmp_path, executor="serial", progress=False)
    a, b = res.rows
    assert a["outputs"]["final:pin"] == pytest.approx(b["outputs"]["final:pin"], rel=1e-8)
    assert a["outputs"]["peak_speed:tip"] == pytest.approx(b["outputs"]["peak_speed:tip"], rel=1e-8)


def test_table_files(serial):
    out = serial.out
    for name in ("table.csv", "table.npz", "study.json", "summary.txt", "study.png"):
        assert (out / name).is_file(), name
    lines = (out / "table.csv").read_text().splitlines()
    assert lines[0].split(",") == serial.columns
    assert len(lines) == 7
    npz = np.load(out / "table.npz")
    assert np.array_equal(npz["peak_speed:tip"], serial.column("peak_speed:tip"))
    assert list(npz["status"]) == ["finished"] * 6
    assert len(list((out / "cases").glob("*.json"))) == 6
    # a float written to the CSV reads back exactly
    first = dict(zip(lines[0].split(","), lines[1].split(",")))
    assert float(first["peak_speed:tip"]) == serial.column("peak_speed:tip")[0]


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


# ----------------------------------------------------------------------------- command line


def test_cli_study(scene_file, tmp_path, capsys):
    out = tmp_path / "cli"
    code = main(["study", str(scene_file), "--vary", "bodies.bar.mass=1.0,-2.0", "--vary",
                 "initial.positions.pin=lin:0:0.5:2", "--set", "solver.t_end=0.2", "--output", "final:pin",
                 "--serial", "--quiet", "--out", str(out)])
    assert code == 1  # one mass is invalid
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
    assert main(["study", str(scene_file), "--vary", "bodies.bar.mass", "--out", str(tmp_path / "x")]) == 2
    assert "write KEY=VALUE" in capsys.readouterr().err
    # the command shows the flexmb loggers' messages on stderr, one line each, and not with --quiet
    again = ["study", str(scene_file), "--vary", "bodies.bar.mass=1.0,2.0,3.0", "--set", "solver.t_end=0.2",
             "--serial", "--out", str(tmp_path / "ok")]
    assert main(again + ["--quiet"]) == 0
    assert "done before" not in capsys.readouterr().err
    (tmp_path / "ok" / "cases" / next(p.name for p in (tmp_path / "ok" / "cases").glob("*.json"))).unlink()
    assert main(again) == 0
    assert "study: 2 of 3 cases done before, running the other 1\n" in capsys.readouterr().err


def test_time_series_outputs(scene_file, tmp_path):
    res = Study.from_file(scene_file, {"bodies.bar.mass": [1.0, -1.0, 2.0]},
                          outputs=["final:pin", "history:pin", "time"],
                          fixed={"solver.t_end": 0.2, "solver.n_out": 11}).run(tmp_path, executor="serial",
                                                                             progress=False)
    history, t = res.column("history:pin"), res.column("time")
    assert history.shape == t.shape == (3, 11)
    assert np.all(np.isnan(history[1])) and t[0] == pytest.approx(np.linspace(0, 0.2, 11), abs=1e-15)
    assert history[[0, 2], -1] == pytest.approx(res.column("final:pin")[[0, 2]], abs=0)
    # released from rest at the horizontal: q = -(3 g / 2 L) t^2 / 2 for small t (angular acceleration 3 g / 2 L)
    assert history[0, 1] == pytest.approx(-0.75 * G * 0.02**2, rel=1e-4)
    assert res.scalar_outputs == ["final:pin"]
    npz = np.load(tmp_path / "table.npz")
    assert npz["history:pin"].shape == (3, 11)
    assert (tmp_path / "study.png").is_file()
    header, first = (tmp_path / "table.csv").read_text().splitlines()[:2]
    assert json.loads(next(c for c in first.split('"') if c.startswith("[")))[-1] == history[0, -1]


# ----------------------------------------------------------------------------- issue 18 section 4: time limits, orphans

#: t_end of the case that "never ends": at max_step 1e-3 it would take days
ENDLESS = 1.0e7
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
    assert code == 1
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
