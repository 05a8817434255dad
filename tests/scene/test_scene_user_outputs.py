"""Outputs in the user's terms (issue #29, item 4): point motions and body angular velocities in a scene's
summary, and each body's angular velocity in the VTK files read back by meshio."""

from __future__ import annotations

import json
import numpy as np
import pytest

import flexmb as fm

# a spinning top (a body on a ball joint at the ground origin) tumbling under gravity: every component moves
TOP = """
[model]
name = "top"

[bodies.top]
mass = 2.0
inertia = [0.05, 0.08, 0.03]
com = [0.1, 0.2, -0.5]

[joints.ball]
type = "spherical"
parent = "ground"
child = "top"

[forces.gravity]
type = "gravity"
g = [0.0, 0.0, -9.81]

[initial]
positions = { ball = [0.3, -0.2, 0.1] }
speeds = { ball = [1.5, -0.5, 3.0] }

[solver]
t_end = 0.5
method = "DOP853"
rtol = 1e-10
atol = 1e-12
n_out = 26

[output]
plots = false

[output.points.tip]
body = "top"
point = [0.1, 0.2, -0.5]

[output.metrics]
tip_position = "position:tip"
tip_velocity = "velocity:tip"
tip_acceleration = "acceleration:tip"
tip_peak_acceleration = "peak_acceleration:tip"
spin = "angular_velocity:top"
spin_body = "body_angular_velocity:top"
peak_spin = "peak_angular_speed:top"
"""


def test_point_motions_and_angular_velocities_in_the_summary_and_the_vtk(tmp_path):
    pytest.importorskip("meshio", reason="the VTK export needs meshio")
    import meshio

    from flexmb.export.vtk import table_names

    scene = fm.loads_scene(TOP)
    summary = scene.run(tmp_path / "out")
    saved = json.loads((tmp_path / "out" / "summary.json").read_text())
    res = fm.Result.load(tmp_path / "out" / summary["files"]["result"])
    system = scene.system()
    p = (0.1, 0.2, -0.5)
    expected = {"tip_position": res.point_position("top", p, system=system),
                "tip_velocity": res.point_velocity("top", p, system=system),
                "tip_acceleration": res.point_acceleration("top", p, system=system),
                "spin": res.angular_velocity("top", system=system),
                "spin_body": res.angular_velocity("top", "body", system=system)}
    for key, value in expected.items():
        assert np.shape(saved[key]) == (26, 3), key
        np.testing.assert_allclose(saved[key], value, rtol=0, atol=1e-13, err_msg=key)
    assert saved["peak_spin"] == pytest.approx(np.linalg.norm(expected["spin"], axis=1).max(), rel=1e-14)
    assert saved["tip_peak_acceleration"] == pytest.approx(
        np.linalg.norm(expected["tip_acceleration"], axis=1).max(), rel=1e-14)
    # independent checks: the velocity is the time derivative of the position, and omega in the body's axes
    # is R^T omega
    v_fd = np.gradient(np.array(saved["tip_position"]), res.t, axis=0, edge_order=2)
    np.testing.assert_allclose(v_fd[1:-1], saved["tip_velocity"][1:-1], rtol=0, atol=2e-2)
    np.testing.assert_allclose(np.einsum("tji,tj->ti", res.rotations[:, 0], saved["spin"]), saved["spin_body"],
                               atol=1e-13)
    assert np.ptp(np.array(saved["spin"]), axis=0).min() > 0.05
    # the VTK: each body's cells carry its angular velocity
    pvd = tmp_path / "out" / summary["files"]["vtk"]
    vtus = sorted(pvd.parent.glob("*.vtu"))
    assert len(vtus) == 26
    for i in (0, 13, 25):
        mesh = meshio.read(vtus[i])
        assert table_names(mesh.field_data) == ["top"]
        ids = np.concatenate(mesh.cell_data["body_id"])
        w = np.concatenate(mesh.cell_data["angular_velocity"])
        np.testing.assert_allclose(w[ids == 0], np.broadcast_to(saved["spin"][i], w[ids == 0].shape), atol=1e-12)


def test_an_output_for_a_body_that_is_not_there_is_named():
    with pytest.raises(fm.SceneError, match=r"output\.metrics\.spin.*angular_velocity:wheel.*bodies of this scene: "
                                            r"top"):
        fm.loads_scene(TOP.replace('"angular_velocity:top"', '"angular_velocity:wheel"'))
