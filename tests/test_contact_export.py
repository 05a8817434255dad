"""Contact elements in scene files and in the VTK export (#30): laws as tables, contact forces as point data.

References: the contact history of the same result (:func:`flexmb.post.contact_history`),
computed by the elements themselves; and a ball resting on a linear floor,
whose contact force is its weight.
"""

from __future__ import annotations

import glob
import json

import meshio
import numpy as np
import pytest

import flexmb as fm
from flexmb.cli import main
from flexmb.errors import ModelError, SceneError
from flexmb.export import vtk

SCENE = """
[model]
name = "ball"

[bodies.ball]
mass = 1.0
inertia = [1e-3, 1e-3, 1e-3]

[joints.drop]
type = "prismatic"
parent = "ground"
child = "ball"
axis = [0.0, 0.0, 1.0]

[forces.gravity]
type = "gravity"
g = [0.0, 0.0, -9.81]

[forces.floor]
type = "sphere_plane_contact"
body = "ball"
radius = 0.05
normal_law = { type = "hunt_crossley", stiffness = 1e7, damping = 0.5 }
friction = { type = "coulomb", mu = 0.3 }

[solver]
t_end = 0.3
n_out = 31
method = "CVODE_BDF"
max_step = 1e-4

[initial.positions]
drop = 0.1
"""


def _ball():
    model = fm.Model()
    ball = fm.RigidBody("ball", mass=1.0, inertia=np.eye(3) * 1e-3)
    floor = fm.SpherePlaneContact("floor", ball, 0.05, fm.LinearContactLaw(1e5, 100.0))
    model.add(fm.Prismatic("drop", model.ground, ball, axis=(0, 0, 1)), floor, fm.Gravity((0, 0, -9.81)))
    return model


def test_laws_as_tables():
    law = {"type": "flores", "stiffness": 1e9, "restitution": 0.5}
    c = fm.SpherePlaneContact("floor", "ball", 0.1, law, friction={"type": "stribeck", "mu_static": 0.5,
                                                                  "mu_kinetic": 0.3, "stribeck_speed": 0.01})
    assert c.normal_law == fm.FloresLaw(1e9, 0.5)
    assert c.friction == fm.StribeckLaw(0.5, 0.3, 0.01)
    with pytest.raises(ModelError, match=r"'floor'.*normal_law: a law's table needs type = one of 'flores', "
                                         r"'hunt_crossley', 'lankarani_nikravesh', 'linear', got 'hertz'"):
        fm.SpherePlaneContact("floor", "ball", 0.1, {"type": "hertz"})
    with pytest.raises(ModelError, match=r"'gap'.*friction: 'coulomb' law: .*unexpected keyword argument 'mu_s'"):
        fm.JournalBearingContact("gap", "a", 0.01, "b", 0.02, {"type": "linear", "stiffness": 1e6},
                                 friction={"type": "coulomb", "mu_s": 0.1})
    with pytest.raises(ModelError, match=r"'floor'.*normal_law: FloresLaw: restitution must be in \(0, 1\]"):
        fm.SpherePlaneContact("floor", "ball", 0.1, {"type": "flores", "stiffness": 1e9, "restitution": 2.0})


def test_a_bad_law_in_a_scene_names_its_key():
    with pytest.raises(SceneError, match="forces.floor"):
        fm.loads_scene(SCENE.replace('type = "hunt_crossley"', 'type = "hertz"'), "ball.toml")


def test_contact_points_and_forces_in_the_meshes():
    model = _ball()
    res = fm.simulate(model, 0.2, x0=[0.05 - 9.81e-5], xd0=[0.0], progress=False, n_out=5)
    h = res.contact_history("floor")
    for i in range(5):
        mesh = vtk.to_meshio(res, i, system=model)
        contact = [b.data[p == vtk.PARTS.index("contact")] for b, p in zip(mesh.cells, mesh.cell_data["part_id"])]
        (k,) = np.concatenate([c.ravel() for c in contact])  # the contact's vertex
        assert vtk.table_names(mesh.field_data, "contact") == ["floor"]
        assert np.concatenate(mesh.cell_data["contact_id"]).tolist().count(0) == 1
        np.testing.assert_allclose(mesh.points[k], h.point[i], atol=1e-15)
        np.testing.assert_allclose(mesh.point_data["contact_force"][k], h.force[i], atol=1e-12)
        assert mesh.point_data["contact_force"][k][2] == pytest.approx(9.81, rel=1e-6)  # the run's rtol
        assert mesh.point_data["contact_penetration"][k] == pytest.approx(h.penetration[i], abs=1e-18)
        others = np.delete(np.arange(len(mesh.points)), k)
        assert not mesh.point_data["contact_force"][others].any()


def test_flexmb_run_writes_contact_forces_to_the_vtk(tmp_path, capsys):
    scene = tmp_path / "ball.toml"
    scene.write_text(SCENE)
    assert main(["run", str(scene), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    capsys.readouterr()
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["status"] == "finished"
    files = sorted(glob.glob(str(tmp_path / "out" / "vtk" / "*.vtu")))
    assert len(files) == 31
    scene_model = fm.load_scene(str(scene)).model
    res = fm.Result.load(tmp_path / "out" / "ball.npz")
    h = res.contact_history("floor", system=scene_model)
    forces = []
    for f in files:
        mesh = meshio.read(f)
        assert "contact" in vtk.table_names(mesh.field_data, "part")
        forces.append(mesh.point_data["contact_force"][-1])
    forces = np.array(forces)
    # the ball falls 50 mm onto the floor and bounces: the VTK carries what the contact did at each output
    assert (h.normal_force > 0).any() and (h.normal_force == 0).any()
    np.testing.assert_allclose(forces, h.force, rtol=0, atol=1e-9 * np.abs(h.force).max())
