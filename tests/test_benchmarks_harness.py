"""The flexmb side of the benchmark harness (benchmarks/work_precision.py, benchmarks/plot.py).

B1 with N = 4 at loose tolerances: the JSON rows carry the BENCHMARKS.md
fields, the integration error shrinks with rtol, and the reference agrees
with an independent formulation (Exudyn's minimal-coordinate kinematic tree,
generalized-alpha with 32000 and 64000 steps, Richardson-extrapolated; the
number is stored here, Exudyn is not needed). Then compare.py's timing in
alternating rounds (benchmarks/peers/rounds.py): the merge that keeps each
configuration's least wall time, the order of the tools within a round,
and the stdin protocol with a peer process, played by a fake peer script.
Last, what compare.py reports (benchmarks/peers/picks.py, issue 31): the
robust rtol (never a lucky one that passes while a tighter one fails, or
that fails when atol moves in its last bits), the tuning loop's choice of a
peer's setting, the runs it times, and one process per simulation. No
timing is asserted: the times in these tables are made up.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np
import pytest

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
sys.path.insert(0, BENCH)

wp = pytest.importorskip("work_precision")
plot = pytest.importorskip("plot")

FIELDS = {"tool", "scene", "variant", "n_segments", "n_coords", "n_dof", "integrator", "rtol", "h", "setup_s",
          "wall_s", "steps", "rhs_evals", "jac_evals", "error", "error_kind", "reference"}

#: B1, N = 4, tip position at t = 1 s from Exudyn 1.13.6 (ObjectKinematicTree, benchmarks/peers/exudyn_beam.py
#: --scene B1 --n 4 --richardson 32000); PyDy's KanesMethod model gives -0.0049348897081 at rtol 1e-6
EXUDYN_B1_N4_TIP = np.array([0.9999873407310742, 0.0, -0.004934889692223662])


@pytest.fixture(scope="module")
def b1_rows(tmp_path_factory):
    refdir = str(tmp_path_factory.mktemp("refs"))
    scene = wp.scenes()["B1"]
    rows = wp.run_scene(scene, [4], integrators=("Radau",), rtols=(1e-2, 1e-5), repeat=1, ref_rtol=1e-7,
                        refdir=refdir, log=lambda *a: None)
    return scene, refdir, rows


def test_rows_have_the_benchmark_fields(b1_rows, tmp_path):
    _, _, rows = b1_rows
    assert len(rows) == 2
    for r in rows:
        assert FIELDS <= set(r)
        assert r["tool"] == "flexmb" and r["scene"] == "B1" and r["n_segments"] == 4
        assert r["n_coords"] == 4 and r["n_dof"] == 4
        assert r["error_kind"] == "integration" and r["integrator"] == "Radau"
        assert r["setup_s"] > 0 and r["wall_s"] > 0 and r["rhs_evals"] > r["steps"] > 0
    path = tmp_path / "rows.jsonl"
    wp.write_jsonl(rows, str(path))
    back = [json.loads(line) for line in path.read_text().splitlines()]
    assert back == json.loads(json.dumps(rows))


def test_error_shrinks_with_rtol(b1_rows):
    _, _, rows = b1_rows
    loose, tight = sorted(rows, key=lambda r: -r["rtol"])
    assert loose["rtol"] == 1e-2 and tight["rtol"] == 1e-5
    assert tight["error"] < loose["error"] / 10
    # the reference (rtol 1e-7) is far tighter than the runs it judges
    assert tight["ref_uncertainty"] < tight["error"]


def test_reference_is_cached_and_agrees_with_an_independent_formulation(b1_rows):
    scene, refdir, _ = b1_rows
    files = sorted(os.listdir(refdir))
    assert len(files) == 2 and all(f.endswith(".npz") for f in files)  # rtol 1e-7 and its 10x check
    ref = wp.reference(scene, 4, 1e-7, refdir)  # read back, not recomputed
    assert sorted(os.listdir(refdir)) == files
    assert np.linalg.norm(ref["output"] - EXUDYN_B1_N4_TIP) < 1e-8


def test_fit_exponent_and_best_wall():
    ns = np.array([8, 16, 32, 64])
    assert plot.fit_exponent(ns, 0.3 * ns**1.7) == pytest.approx(1.7)
    assert plot.fit_exponent([8], [1.0]) is None
    rows = [{"tool": "a", "n_segments": 8, "error": e, "wall_s": w, "error_kind": "integration"}
            for e, w in ((1e-5, 0.1), (1e-7, 0.5), (1e-8, 0.9))]
    assert plot.best_wall_at(rows, 1e-6)[("a", 8)][0] == 0.5


def test_b2_scaling_row_measures_the_error_against_the_reference(tmp_path):
    b2s = pytest.importorskip("b2_scaling")
    import dataclasses

    scene = dataclasses.replace(wp.scenes()["B2"], t_end=0.1)
    ref = wp.reference(scene, 2, 1e-8, refdir=str(tmp_path))
    row = b2s.run(2, 1e-4, 1, scene, ref)
    assert FIELDS <= set(row) and row["n_coords"] == 6 and row["status"] == "finished"
    assert row["cpu_s"] > 0 and row["sparse"]  # an open tree: the articulated-body recursion
    assert 0 < row["error"] < 1e-5  # rtol 1e-4 against the same model at 1e-8


# ----------------------------------------------------------------------------- alternating rounds (compare.py)

PEERS = os.path.join(BENCH, "peers")
sys.path.insert(0, PEERS)
rounds = pytest.importorskip("rounds")


def _run(tool, wall, integrator="Radau", rtol=1e-6, h=None, status="finished", **kw):
    return dict(tool=tool, scene="B1", variant="dynamics damped", n_segments=8, integrator=integrator, rtol=rtol,
                h=h, setup_s=wall / 10, wall_s=wall, error=1e-7, error_kind="integration", status=status, **kw)


def test_merge_rounds_takes_the_least_wall_time_of_each_configuration():
    per_round = [[_run("flexmb", 0.30), _run("flexmb", 0.50, rtol=1e-7), _run("flexmb", 0.2, integrator="auto")],
                 [_run("flexmb", 0.10), _run("flexmb", 0.70, rtol=1e-7),
                  _run("flexmb", 0.3, integrator="auto (Radau)")],
                 [_run("flexmb", 0.20), _run("flexmb", 0.60, rtol=1e-7), _run("flexmb", 0.1, integrator="auto")]]
    merged = rounds.merge_rounds(per_round)
    assert [(r["rtol"], r["integrator"]) for r in merged] == [(1e-6, "Radau"), (1e-7, "Radau"), (1e-6, "auto")]
    assert [r["wall_s"] for r in merged] == [0.10, 0.50, 0.1]
    assert merged[0]["wall_rounds"] == [0.30, 0.10, 0.20]
    assert merged[0]["setup_s"] == pytest.approx(0.01) and merged[0]["error"] == 1e-7
    assert per_round[0][0]["wall_s"] == 0.30 and "wall_rounds" not in per_round[0][0]  # inputs untouched
    # the same rounds with the median, as work_precision.run_scene reports back-to-back repeats
    import statistics

    assert rounds.merge_rounds(per_round, stat=statistics.median)[1]["wall_s"] == 0.60


def test_merge_rounds_keeps_a_failure_and_a_skipped_configuration():
    failed = _run("mujoco", 0.0, h=1e-3, rtol=None, integrator="mujoco RK4", status="failed: unstable step")
    failed["wall_s"] = None
    skipped = dict(_run("pydy", 0.0, integrator="LSODA", status="skipped: budget"), wall_s=None)
    merged = rounds.merge_rounds([[_run("mujoco", 0.2, h=1e-4, rtol=None, integrator="mujoco RK4"), failed,
                                   skipped], [_run("mujoco", 0.1, h=1e-4, rtol=None, integrator="mujoco RK4"),
                                              skipped]])
    assert [r["status"] for r in merged] == ["finished", "failed: unstable step", "skipped: budget"]
    assert merged[0]["wall_s"] == 0.1 and "wall_rounds" not in merged[1]


compare = pytest.importorskip("compare")


class _FakePeer:
    def __init__(self, name, walls, order):
        self.name, self.walls, self.order, self.r = name, walls, order, 0

    def round(self):
        self.order.append(self.name)
        w = self.walls[self.r]
        self.r += 1
        return [_run(self.name, w, h=1e-3, rtol=None, integrator="generalized-alpha")]


def test_timed_rounds_alternate_the_tools_and_report_the_minimum():
    order = []
    flex_walls = iter([0.5, 0.2, 0.4])

    def flexmb():
        order.append("flexmb")
        return [_run("flexmb", next(flex_walls))]

    peers = {"exudyn": _FakePeer("exudyn", [0.3, 0.6, 0.25], order),
             "pydy": _FakePeer("pydy", [2.0, 1.0, 3.0], order)}
    merged = compare.timed_rounds(flexmb, peers, 3, log=lambda *a: None)
    assert order == ["flexmb", "exudyn", "pydy"] * 3
    assert merged["flexmb"][0]["wall_s"] == 0.2 and merged["flexmb"][0]["wall_rounds"] == [0.5, 0.2, 0.4]
    assert merged["exudyn"][0]["wall_s"] == 0.25 and merged["pydy"][0]["wall_s"] == 1.0


FAKE_PEER = '''
import json, os, sys
sys.path.insert(0, {peers!r})
from rounds import drive

mode = sys.argv[1]

def run_round(r):
    if mode == "exit" and r == 1:
        sys.exit("fake peer broke in round 2")
    if mode == "hang" and r == 1:
        import time; time.sleep(60)
    return [dict(tool="fake", scene="B1", variant="v", n_segments=4, integrator="x", rtol=None, h=h,
                 setup_s=0.0, wall_s=[0.3, 0.1, 0.2][r] * h * 1e3, status="finished",
                 openblas_num_threads=os.environ.get("OPENBLAS_NUM_THREADS")) for h in (1e-3, 2e-3)]

drive(run_round, 3, "--rounds-from-stdin" in sys.argv, lambda row: print(json.dumps(row), flush=True))
'''


@pytest.fixture
def fake_peer(tmp_path):
    path = tmp_path / "fake_peer.py"
    path.write_text(FAKE_PEER.format(peers=PEERS))
    return path


def test_peer_process_runs_one_round_per_request(fake_peer):
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    peer = compare.Peer([sys.executable, fake_peer, "ok"], 60, env, log=lambda *a: None)
    per_round = [peer.round() for _ in range(3)]
    assert peer.close() == []
    assert [len(rows) for rows in per_round] == [2, 2, 2]
    merged = rounds.merge_rounds(per_round)
    assert [r["wall_s"] for r in merged] == pytest.approx([0.1, 0.2])
    assert merged[0]["wall_rounds"] == pytest.approx([0.3, 0.1, 0.2])
    assert {r["openblas_num_threads"] for r in merged} == {"1"}


def test_peer_process_that_exits_or_hangs_gives_a_failure_row(fake_peer):
    peer = compare.Peer([sys.executable, fake_peer, "exit"], 60, log=lambda *a: None)
    assert len(peer.round()) == 2 and peer.round() == [] and peer.round() == []
    (end,) = peer.close()
    assert end["status"].startswith("exit 1") and "round 2" in end["status"]
    peer = compare.Peer([sys.executable, fake_peer, "hang"], 5, log=lambda *a: None)
    assert len(peer.round()) == 2 and peer.round() == []
    assert peer.close() == [{"status": "timeout after 5 s"}]


def test_peer_script_alone_reports_the_minimum_of_its_rounds(fake_peer):
    import subprocess

    out = subprocess.run([sys.executable, str(fake_peer), "ok"], capture_output=True, text=True, check=True).stdout
    rows = [json.loads(line) for line in out.splitlines()]
    assert [r["wall_s"] for r in rows] == pytest.approx([0.1, 0.2]) and len(rows[0]["wall_rounds"]) == 3


# ----------------------------------------------------------------------------- what compare.py reports (picks.py)

picks = pytest.importorskip("picks")
TARGET = 1e-6


def _flex(rtol, error, wall=None, perturbation=0.0, status="finished", setting="grid", integrator="CVODE_BDF"):
    return dict(tool="flexmb", scene="B1", variant="dynamics damped", n_segments=64, integrator=integrator,
                rtol=rtol, h=None, atol=rtol / 100 * (1 + perturbation), atol_perturbation=perturbation,
                error=error, wall_s=wall, status=status, setting=setting, error_kind="integration")


#: B1 N = 64 as the issue found it: rtol 5e-5 passes (luckily), 2e-5 and 1e-5 fail, from 5e-6 on all pass;
#: 1e-4 fails; at 2e-6 the nominal run passes but atol x (1 + 1e-12) does not.
LUCKY_TABLE = {1e-4: (3e-6, 3e-6), 5e-5: (7.7e-8, 9e-8), 2e-5: (1.4e-6, 4e-7), 1e-5: (2.0e-6, 2.2e-6),
               5e-6: (4e-7, 5e-7), 2e-6: (8e-8, 1.1e-6), 1e-6: (3e-8, 2e-8)}


def _lucky_rows(walls=None):
    rows = []
    for rtol, (nominal, perturbed) in LUCKY_TABLE.items():
        wall = (walls or {}).get(rtol, 0.01 / rtol ** 0.2)
        rows += [_flex(rtol, nominal, wall), _flex(rtol, perturbed, None, 1e-12), _flex(rtol, nominal, None, -1e-12)]
    return rows


def test_the_robust_rtol_is_never_a_lucky_one():
    by = picks.settings_of(_lucky_rows())["CVODE_BDF"]
    # 5e-5 passes with both atols, but 2e-5 and 1e-5 fail; 2e-6 fails only with its perturbed atol
    assert all(picks.run_passes(r, TARGET) for r in by[5e-5])
    assert picks.robust_setting(by, TARGET) == 1e-6
    assert picks.robust_chain(by, TARGET) == [1e-6]
    rob = picks.robust_rows(_lucky_rows(), TARGET)["CVODE_BDF"]
    assert rob["rtol"] == 1e-6 and rob["atol_perturbation"] == 0.0  # the nominal run is the one timed
    # the best pick is the fastest passing run: the lucky 5e-5 (what the harness used to report)
    assert picks.best_pick(_lucky_rows(), TARGET)["rtol"] == 5e-5
    # with the perturbed twin of 2e-6 passing too, the chain reaches 5e-6 and stops below the failing 1e-5
    fixed = [dict(r, error=1e-7) if r["rtol"] == 2e-6 else r for r in _lucky_rows()]
    assert picks.robust_setting(picks.settings_of(fixed)["CVODE_BDF"], TARGET) == 5e-6


def test_a_failed_run_breaks_the_chain_and_rows_without_a_setting_are_ignored():
    rows = [_flex(1e-6, 1e-8, 0.3), _flex(1e-5, None, None, status="failed: too much work"), _flex(1e-4, 1e-7, 0.1),
            {"tool": "flexmb", "status": "timeout after 60 s"}]
    by = picks.settings_of(rows)["CVODE_BDF"]
    assert sorted(by) == [1e-6, 1e-5, 1e-4]
    assert picks.robust_setting(by, TARGET) == 1e-6
    assert picks.robust_setting({1e-6: [_flex(1e-6, 2e-6, 0.3)]}, TARGET) is None


def _exu(newton, steps, error, wall, status="finished"):
    return dict(tool="exudyn", scene="B1", variant="dynamics damped", n_segments=8,
                integrator="generalized-alpha (rho_inf 0.9, modified Newton)", rtol=None, newton_rtol=newton,
                h=1.0 / steps, t_end=1.0, error=error, wall_s=wall, status=status, error_kind="integration")


#: Exudyn's tuning grid: (Newton tolerance, steps) -> (error, wall). With Newton 1e-4 the loose steps pass by
#: luck (the Newton error cancels the step's) and 4000 steps fail; 1e-5 passes from 2000 steps on; 1e-8 from 2000.
EXUDYN_TABLE = {(1e-4, 1000): (9e-7, 0.010), (1e-4, 2000): (9.5e-7, 0.018), (1e-4, 4000): (1.3e-6, 0.030),
                (1e-4, 8000): (8e-7, 0.055), (1e-5, 1000): (2.5e-6, 0.015), (1e-5, 2000): (6e-7, 0.025),
                (1e-5, 4000): (2e-7, 0.045), (1e-5, 8000): (5e-8, 0.085), (1e-8, 1000): (2.5e-6, 0.030),
                (1e-8, 2000): (6e-7, 0.050), (1e-8, 4000): (2e-7, 0.090), (1e-8, 8000): (5e-8, 0.170)}


def _exudyn_rows():
    return [_exu(nt, steps, e, w) for (nt, steps), (e, w) in EXUDYN_TABLE.items()]


def test_the_tuning_loop_takes_the_fastest_robust_newton_tolerance():
    rows = _exudyn_rows()
    robust = {r["newton_rtol"]: round(1 / r["h"]) for r in picks.robust_rows(rows, TARGET).values()}
    assert robust == {1e-4: 8000, 1e-5: 2000, 1e-8: 2000}  # 1e-4: 4000 steps fail, so its loose steps are luck
    tuned = picks.tuned(rows, TARGET)
    assert (tuned["newton_rtol"], round(1 / tuned["h"])) == (1e-5, 2000)  # 0.025 s; not 1e-4 at 1000 (0.010 s)
    assert picks.best_pick(rows, TARGET)["wall_s"] == 0.010
    out = compare.peer_picks("exudyn", rows, TARGET)
    assert out["tuned"] is tuned and out["newton 1e-08"]["wall_s"] == 0.050
    # a tolerance none of whose settings is robust drops out; none at all: no tuned setting
    assert picks.tuned([r for r in rows if r["newton_rtol"] == 1e-4 and r["h"] > 1 / 8000], TARGET) is None


def test_the_candidates_timed_are_the_robust_settings_and_the_lucky_ones():
    cands = compare.candidates(_exudyn_rows(), TARGET)
    got = sorted((r["newton_rtol"], round(1 / r["h"])) for r in cands)
    # per tolerance the robust setting and the passing ones looser than it; never a failing one
    assert got == [(1e-8, 2000), (1e-5, 2000), (1e-4, 1000), (1e-4, 2000), (1e-4, 8000)]
    assert [compare.peer_config("exudyn", r) for r in cands if r["newton_rtol"] == 1e-5] == ["1e-05:2000"]
    flex = _lucky_rows() + [_flex(1e-8, 1e-10, 0.5, setting="default", integrator="auto (CVODE_BDF)")]
    timed = compare.candidates(flex, TARGET, every_passing=True)
    assert sorted(r["rtol"] for r in timed) == [1e-8, 1e-6, 5e-6, 5e-5]  # nominal runs of passing settings
    assert all(r["atol_perturbation"] == 0.0 for r in timed)


def test_flexmb_is_reported_robust_default_and_best_side_by_side():
    rows = _lucky_rows() + [_flex(1e-8, 1e-10, 0.5, setting="default", integrator="auto (CVODE_BDF)")]
    fx = compare.flexmb_picks(rows, TARGET)
    assert fx["robust"]["rtol"] == 1e-6 and fx["best"]["rtol"] == 5e-5 and fx["default"]["rtol"] == 1e-8
    # the scan's untimed runs never win a pick on a time they do not have
    scan = [dict(r, wall_s=0.001) for r in rows]
    timed = [dict(r, wall_s=0.2, wall_rounds=[0.3, 0.2, 0.25]) for r in rows if r["rtol"] == 1e-6
             and not r["atol_perturbation"]]
    joined = compare.join(scan, timed)
    assert [r["wall_s"] for r in joined if r["timed"]] == [0.2]
    assert {r["scan_wall_s"] for r in joined} == {0.001}
    assert compare.flexmb_picks(joined, TARGET)["best"]["rtol"] == 1e-6


def test_flexmb_grid_has_perturbed_twins_and_simulates_defaults():
    import inspect

    import flexmb as fm

    configs = compare.flexmb_configs(["CVODE_BDF"], [1e-5, 1e-6])
    grid = [c for c in configs if c["setting"] == "grid"]
    assert len(grid) == 2 * (1 + len(compare.ATOL_PERTURBATIONS))
    twins = sorted(c["atol"] for c in grid if c["rtol"] == 1e-5)
    assert twins[0] < 1e-7 < twins[-1] and twins[-1] / twins[0] - 1 < 1e-11
    (default,) = [c for c in configs if c["setting"] == "default"]
    params = inspect.signature(fm.simulate).parameters
    assert (default["method"], default["rtol"], default["atol"]) == (params["method"].default,
                                                                     params["rtol"].default, None)


def test_one_process_per_run_reports_the_last_json_row_and_the_exit(tmp_path):
    script = tmp_path / "child.py"
    script.write_text("import json, sys\nprint('a banner')\nprint(json.dumps({'output': [1.0, 2.0]}))\n"
                      "sys.exit(int(sys.argv[1]))\n")
    ok = compare.process_run([sys.executable, script, 0], dict(os.environ), 60)
    assert ok["returncode"] == 0 and ok["row"] == {"output": [1.0, 2.0]} and ok["cpu_s"] >= 0.0
    bad = compare.process_run([sys.executable, script, 3], dict(os.environ), 60)
    assert bad["returncode"] == 3
    jobs = [("fake", "tuned", [sys.executable, script, 0]), ("fake", "newton 1e-08", [sys.executable, script, 0]),
            ("fake", "broken", [sys.executable, script, 3])]
    rows = compare.process_rounds(jobs, 2, [1.0, 2.5], dict(os.environ), log=lambda *a: None)
    assert [(r["pick"], r["status"]) for r in rows] == [("tuned", "finished"), ("newton 1e-08", "finished"),
                                                       ("broken", "failed: exit 3: []")]
    assert rows[0]["error"] == pytest.approx(0.5) and len(rows[0]["cpu_rounds"]) == 2  # one command, run once a round


def test_summary_shows_robust_default_and_best_beside_tuned_exudyn():
    import argparse

    args = argparse.Namespace(target=TARGET, ref_rtol=1e-9, newton_rtols=[1e-4, 1e-5, 1e-8], peers=["exudyn"])
    rows = [dict(r, wall_rounds=[1.0, 1.0, 1.0], cpu_s=r["wall_s"] and r["wall_s"] / 2, openblas_num_threads="1")
            for r in
            _lucky_rows({1e-6: 0.05, 5e-5: 0.01}) + _exudyn_rows()] + [
        dict(_flex(1e-8, 1e-10, 0.1, setting="default", integrator="auto (CVODE_BDF)"), wall_rounds=[0.1] * 3,
             openblas_num_threads="1")]
    for r in rows:
        r.update(scene="B1", n_segments=64)
    procs = [dict(tool="flexmb", pick="robust", status="finished", cpu_s=1.1, cpu_rounds=[1.2, 1.1, 1.3],
                  import_s=0.7, build_s=0.2, simulate_s=0.15, scene="B1", n_segments=64),
             dict(tool="exudyn", pick="tuned", status="finished", cpu_s=0.2, cpu_rounds=[0.2, 0.3, 0.2], scene="B1",
                  n_segments=64)]
    md = compare.summary(rows, procs, {}, args, "now")
    assert "min of 3 alternating rounds" in md and "OPENBLAS_NUM_THREADS = 1 for flexmb and exudyn" in md
    line = next(x for x in md.splitlines() if x.startswith("| B1 | 64 | 0.05 s"))
    cells = [c.strip() for c in line.split("|")[1:-1]]
    assert "rtol 1e-06" in cells[2] and "auto (CVODE_BDF), rtol 1e-08" in cells[3] and "rtol 5e-05" in cells[4]
    assert "Newton 1e-05, h 0.0005 s" in cells[5] and "Newton 1e-08" in cells[6]
    # robust / tuned = 0.05 / 0.025; default / tuned = 0.1 / 0.025; best / tuned; best / Exudyn at 1e-8
    assert cells[7] == "**2**" and cells[9] == "4" and cells[10] == "0.4" and cells[11] == "0.2"
    proc = next(x for x in md.splitlines() if x.startswith("| B1 | 64 | 1.1 s"))
    assert "| **5.5** |" in proc and "| 1.08 (0.70, 0.200, 0.150) |" in proc  # start-up CPU: 1.1 - 0.05 / 2
    assert "| B1 | 64 | CVODE_BDF | 3.0e-06 x |" in md and "| 1e-06 | 5e-05, 5e-06 |" in md  # the lucky rtols named
