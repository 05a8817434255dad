"""Study outputs (the named outputs of :mod:`flexmb.scene.metrics`) against the pendulum's closed form; time-series outputs."""

from __future__ import annotations

import json

import numpy as np
import pytest

from flexmb.study import Study

from pendulum_study import G, scene_file, serial  # noqa: F401  (fixtures: scene_file, serial)


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


def test_time_series_of_vectors(scene_file, tmp_path):
    """A point's velocity and a body's angular velocity per case: (n_cases, n_t, 3) arrays, NaN for a failed case."""
    res = Study.from_file(scene_file, {"bodies.bar.mass": [1.0, -1.0]},
                          outputs=["velocity:tip", "angular_velocity:bar", "peak_angular_speed:bar"],
                          fixed={"solver.t_end": 0.2, "solver.n_out": 11}).run(tmp_path, executor="serial",
                                                                             progress=False)
    v, w = res.column("velocity:tip"), res.column("angular_velocity:bar")
    assert v.shape == w.shape == (2, 11, 3) and np.all(np.isnan(v[1]))
    # the tip 1 m along the bar pinned about z: v = omega x r, |v| = |omega_z| 1 m, omega along z only
    assert np.abs(w[0, :, :2]).max() == 0.0 and np.abs(w[0, -1, 2]) > 0.5
    np.testing.assert_allclose(np.linalg.norm(v[0], axis=1), np.abs(w[0, :, 2]), rtol=1e-12)
    assert res.column("peak_angular_speed:bar")[0] == pytest.approx(np.abs(w[0, :, 2]).max(), rel=1e-14)
    assert res.scalar_outputs == ["peak_angular_speed:bar"]
    npz = np.load(tmp_path / "table.npz")
    assert npz["velocity:tip"].shape == (2, 11, 3)
