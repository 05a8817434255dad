"""The flexmb side of the benchmark harness (benchmarks/work_precision.py, benchmarks/plot.py).

B1 with N = 4 at loose tolerances: the JSON rows carry the BENCHMARKS.md
fields, the integration error shrinks with rtol, and the reference agrees
with an independent formulation (Exudyn's minimal-coordinate kinematic tree,
generalized-alpha with 32000 and 64000 steps, Richardson-extrapolated; the
number is stored here, Exudyn is not needed). Then compare.py's timing in
alternating rounds (benchmarks/peers/rounds.py): the merge that keeps each
configuration's least wall time, the order of the tools within a round,
and the stdin protocol with a peer process, played by a fake peer script.
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


def test_summary_says_how_the_times_were_taken():
    import argparse

    args = argparse.Namespace(target=1e-6, ref_rtol=1e-9, verify_steps=16000, peers=["exudyn"])
    new = [dict(_run("flexmb", 0.2), error=1e-7, wall_rounds=[0.3, 0.2, 0.25], openblas_num_threads="1"),
           dict(_run("exudyn", 0.4, h=1e-3, rtol=None, integrator="generalized-alpha"), error=5e-7,
                wall_rounds=[0.4, 0.5, 0.45], openblas_num_threads="1")]
    md = compare.summary(new, {}, args, "now")
    assert "min of 3 alternating rounds" in md and "median" not in md
    assert "OPENBLAS_NUM_THREADS = 1 for flexmb and exudyn" in md
    assert "| 0.5 |" in md  # the ratio flexmb/exudyn of the minima
    old = [{k: v for k, v in r.items() if k not in ("wall_rounds", "openblas_num_threads")} for r in new]
    md = compare.summary(old, {}, args, "now")
    assert "medians of back-to-back repeats" in md and "OPENBLAS_NUM_THREADS not recorded" in md
    assert "| 0.5 |" in md
    mixed = [new[0], dict(new[1], openblas_num_threads=None)]
    assert compare.blas_note(mixed) == "OPENBLAS_NUM_THREADS: flexmb 1; exudyn unset"
