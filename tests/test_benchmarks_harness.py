"""The flexmb side of the benchmark harness (benchmarks/work_precision.py, benchmarks/plot.py).

B1 with N = 4 at loose tolerances: the JSON rows carry the BENCHMARKS.md
fields, the integration error shrinks with rtol, and the reference agrees
with an independent formulation (Exudyn's minimal-coordinate kinematic tree,
generalized-alpha with 32000 and 64000 steps, Richardson-extrapolated; the
number is stored here, Exudyn is not needed).
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
