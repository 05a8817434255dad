"""Initial point and angular velocities in scene files (``[initial.point_velocities]``, ``[initial.angular_velocities]``).

IFToMM A02 (the parallelogram four-bar, benchmarks/scenes.py B7 with N = 1)
starts with the crank's tip at 1 m/s along +x: given so in a scene, the run
is the Python API's run with :class:`flexmb.PointVelocity`, and both are the
run started from the crank's angle rate (-1 rad/s, the closed-form
inversion). Keys are checked at load with their paths; a point velocity
that contradicts a driver is refused at load naming both.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import flexmb as fm

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "benchmarks")
sys.path.insert(0, BENCH)
scenes = pytest.importorskip("scenes")

A02 = """
[model]
name = "A02"

[bodies.rod_0]
shape = "slender_bar"
mass = 1.0
length = 1.0
axis = 1
[bodies.rod_1]
shape = "slender_bar"
mass = 1.0
length = 1.0
axis = 1
[bodies.coupler_0]
shape = "slender_bar"
mass = 1.0
length = 1.0

[joints.pin_0]
type = "revolute"
parent = "ground"
child = "rod_0"
[joints.pin_1]
type = "revolute"
parent = "ground"
child = "rod_1"
parent_point = [1.0, 0.0, 0.0]
[joints.hinge_0]
type = "revolute"
parent = "rod_0"
child = "coupler_0"
parent_point = [0.0, 1.0, 0.0]
[joints.cut_0]
type = "planar_revolute"
parent = "coupler_0"
child = "rod_1"
parent_point = [1.0, 0.0, 0.0]
child_point = [0.0, 1.0, 0.0]
cut = true

[forces.gravity]
type = "gravity"
g = [0.0, -9.81, 0.0]

[initial.point_velocities.crank_tip]
body = "rod_0"
point = [0.0, 1.0, 0.0]
velocity = [1.0, 0.0, 0.0]

[solver]
t_end = 0.5
rtol = 1e-10
n_out = 11
"""

TIP = fm.PointVelocity("rod_0", (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))


def _rates(names, xd):
    """The rates of pin_0, pin_1 (the rods) and hinge_0 (the coupler relative to the crank)."""
    return [xd[list(names).index(f"{j}.angle")] for j in ("pin_0", "pin_1", "hinge_0")]


def _error(text):
    with pytest.raises(fm.SceneError) as info:
        fm.loads_scene(text, source="a02.toml")
    return str(info.value)


def test_a02_crank_tip_velocity_in_a_scene_reproduces_the_api_run():
    scene = fm.loads_scene(A02)
    assert list(scene.initial.point_velocities) == ["crank_tip"]
    res = scene.simulate()
    model, initial = scenes.b7(1)
    api = fm.simulate(model, 0.5, positions=initial["positions"], speeds=[TIP], rtol=1e-10, n_out=11)
    assert res.coordinate_names == api.coordinate_names
    np.testing.assert_allclose(res.x, api.x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.xd, api.xd, rtol=0, atol=1e-12)
    # the tip starts at +1 m/s along x: the crank at -1 rad/s, the coupler translating
    np.testing.assert_allclose(res.point_velocity("rod_0", (0.0, 1.0, 0.0))[0], (1.0, 0.0, 0.0), atol=1e-12)
    np.testing.assert_allclose(_rates(res.coordinate_names, res.xd[0]), [-1.0, -1.0, 1.0], atol=1e-12)
    # and the run from the crank rate (benchmarks/scenes.py's b7 start) is the same run
    by_rate = fm.simulate(model, 0.5, rtol=1e-10, n_out=11, **initial)
    np.testing.assert_allclose(res.x, by_rate.x, rtol=0, atol=1e-10)


def test_angular_velocity_in_body_and_inertial_axes():
    for frame in ("inertial", "body"):
        text = A02.replace("[initial.point_velocities.crank_tip]", "[initial.angular_velocities.crank]").replace(
            'point = [0.0, 1.0, 0.0]\nvelocity = [1.0, 0.0, 0.0]', f'omega = [0.0, 0.0, -2.0]\nframe = "{frame}"')
        scene = fm.loads_scene(text)
        assert scene.initial.angular_velocities["crank"].frame == frame
        x, xd = scene.initial_state()
        np.testing.assert_allclose(_rates(scene.system().coordinate_names, xd), [-2.0, -2.0, 2.0], atol=1e-12)
        # planar: z is z in both frames


def test_only_some_directions_are_held():
    # the x component alone fixes the one freedom; the y component given (wrong) is ignored
    text = A02.replace("velocity = [1.0, 0.0, 0.0]", "velocity = [1.0, 5.0, 0.0]\ndirections = [1.0, 0.0, 0.0]")
    scene = fm.loads_scene(text)
    x, xd = scene.initial_state()
    np.testing.assert_allclose(_rates(scene.system().coordinate_names, xd), [-1.0, -1.0, 1.0], atol=1e-12)
    text = A02.replace("velocity = [1.0, 0.0, 0.0]", "velocity = [1.0, 5.0, 0.0]\ndirections = [[1.0, 0.0, 0.0]]")
    np.testing.assert_allclose(fm.loads_scene(text).initial_state()[1], xd, atol=1e-15)


def test_a_point_velocity_that_contradicts_a_driver_is_refused_at_load_naming_both():
    driven = A02.replace("[initial.", '[drivers.motor]\njoint = "pin_0"\nspeed = -2.0\n\n[initial.', 1)
    msg = _error(driven)
    assert msg.startswith("a02.toml: initial: the initial speeds given (the velocity of point (0.0, 1.0, 0.0) of "
                          "'rod_0' (initial.point_velocities.crank_tip)) contradict ")
    assert "driver motor" in msg and "set hold_speeds = false in [initial]" in msg
    # the driver wins if the scene says so: the tip then moves at the driver's 2 m/s
    scene = fm.loads_scene(driven.replace("[initial.point", "[initial]\nhold_speeds = false\n\n[initial.point"))
    x, xd = scene.initial_state()
    np.testing.assert_allclose(_rates(scene.system().coordinate_names, xd), [-2.0, -2.0, 2.0], atol=1e-12)
    # a coordinate speed and a point velocity that contradict each other (no driver): both named
    both = A02.replace("[initial.point", "[initial]\nspeeds = { pin_0 = -3.0 }\n\n[initial.point")
    msg = _error(both)
    assert "pin_0.angle, the velocity of point (0.0, 1.0, 0.0) of 'rod_0' (initial.point_velocities.crank_tip)" in msg
    assert "contradict one another or the joints' motion" in msg
    # a point velocity no motion of the joints has (the crank's tip moving along the crank)
    msg = _error(A02.replace("velocity = [1.0, 0.0, 0.0]", "velocity = [1.0, 1.0, 0.0]"))
    assert "(initial.point_velocities.crank_tip)) contradict the joints' motion" in msg


@pytest.mark.parametrize("old, new, message", [
    ('body = "rod_0"', 'body = "rod_9"', "initial.point_velocities.crank_tip.body: unknown body 'rod_9'; known: "),
    ('body = "rod_0"', 'body = "ground"', "initial.point_velocities.crank_tip.body: the ground does not move"),
    ("point = [0.0, 1.0, 0.0]", "point = [0.0, 1.0]",
     "initial.point_velocities.crank_tip.point: must be 3 numbers (m, in the body frame), got 2 values"),
    ("velocity = [1.0, 0.0, 0.0]", 'velocity = "fast"',
     "initial.point_velocities.crank_tip.velocity: must be 3 numbers (m/s, in inertial axes), got a string 'fast'"),
    ("velocity = [1.0, 0.0, 0.0]", "velocity = [1.0, nan, 0.0]",
     "initial.point_velocities.crank_tip.velocity: must be finite"),
    ("velocity = [1.0, 0.0, 0.0]", "velocity = [1.0, 0.0, 0.0]\ndirections = [0.0, 0.0, 0.0]",
     "initial.point_velocities.crank_tip.directions: a direction must not be zero"),
    ("velocity = [1.0, 0.0, 0.0]", "velocity = [1.0, 0.0, 0.0]\ndirections = [[1.0, 0.0, 0.0], [1.0, 0.0]]",
     "initial.point_velocities.crank_tip.directions[1]: must be 3 numbers"),
    ("velocity = [1.0, 0.0, 0.0]", "velocity = [1.0, 0.0, 0.0]\nspeed = 2.0",
     "initial.point_velocities.crank_tip.speed: unknown key; allowed keys: body, point, velocity, directions"),
    ("velocity = [1.0, 0.0, 0.0]\n", "",
     "initial.point_velocities.crank_tip: missing key 'velocity'"),
    ("[initial.point_velocities.crank_tip]", "[initial.point_velocity.crank_tip]",
     "initial.point_velocity: unknown key; allowed keys: positions, speeds, fixed, hold_speeds, point_velocities, "
     "angular_velocities"),
])
def test_bad_point_velocities_are_named_by_key(old, new, message):
    at = A02.index("[initial.")
    assert A02[at:].count(old) == 1
    assert _error(A02[:at] + A02[at:].replace(old, new)).startswith(f"a02.toml: {message}")


@pytest.mark.parametrize("table, message", [
    ('body = "rod_0"\nomega = [0.0, 0.0, 1.0]\nframe = "world"',
     "initial.angular_velocities.w.frame: must be 'inertial' or 'body' (the axes of omega), got 'world'"),
    ('body = "rod_0"\nomega = [0.0, 0.0]', "initial.angular_velocities.w.omega: must be 3 numbers (rad/s, in inertial"),
    ('body = "coupler_9"\nomega = [0.0, 0.0, 1.0]', "initial.angular_velocities.w.body: unknown body 'coupler_9'"),
    ('omega = [0.0, 0.0, 1.0]', "initial.angular_velocities.w: missing key 'body'"),
    ('body = "rod_0"\nomega = [0.0, 0.0, 1.0]\npoint = [0.0, 1.0, 0.0]',
     "initial.angular_velocities.w.point: unknown key; allowed keys: body, omega, frame, directions"),
])
def test_bad_angular_velocities_are_named_by_key(table, message):
    text = A02.split("[initial.")[0] + f"[initial.angular_velocities.w]\n{table}\n\n[solver]\nt_end = 0.1\n"
    assert _error(text).startswith(f"a02.toml: {message}")


def test_cli_run_takes_a_point_velocity(tmp_path, capsys):
    from flexmb.cli import main

    path = tmp_path / "a02.toml"
    path.write_text(A02.replace("n_out = 11", "n_out = 3").replace("t_end = 0.5", "t_end = 0.05"))
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    data = np.load(tmp_path / "out" / "A02.npz")
    np.testing.assert_allclose(_rates(list(data["coordinate_names"]), data["xd"][0]), [-1.0, -1.0, 1.0], atol=1e-12)
    driven = path.read_text().replace("[initial.", '[drivers.motor]\njoint = "pin_0"\nspeed = -2.0\n\n[initial.', 1)
    path.write_text(driven)
    assert main(["run", str(path), "--out", str(tmp_path / "out2"), "--quiet"]) == 3  # an input error
    err = capsys.readouterr().err
    assert "initial: the initial speeds given" in err and "initial.point_velocities.crank_tip" in err
    assert "driver motor" in err and not (tmp_path / "out2").exists()


def test_a_key_path_indexes_an_array():
    import tomllib

    from flexmb.scene.keys import set_key

    doc = tomllib.loads(A02)
    set_key(doc, "initial.point_velocities.crank_tip.velocity[0]", 2.0, "a02.toml")
    set_key(doc, "forces.gravity.g[1]", -1.62, "a02.toml")
    assert doc["initial"]["point_velocities"]["crank_tip"]["velocity"] == [2.0, 0.0, 0.0]
    assert doc["forces"]["gravity"]["g"] == [0.0, -1.62, 0.0]
    scene = fm.scene_from_dict(doc, "a02.toml")
    np.testing.assert_allclose(_rates(scene.system().coordinate_names, scene.initial_state()[1]), [-2.0, -2.0, 2.0],
                               atol=1e-12)
    for path, message in [
        ("initial.point_velocities.crank_tip.velocity[3]", "initial.point_velocities.crank_tip.velocity[3]: index out "
                                                           "of range in the scene (varied key '{}'); the array has 3"),
        ("initial.point_velocities.crank_tip.body[0]", "initial.point_velocities.crank_tip.body: not an array"),
        ("initial.point_velocities.crank_tip.velocity[0].x", "initial.point_velocities.crank_tip.velocity[0]: not a "
                                                             "table in the scene"),
        ("initial.point_velocities.tip.velocity[0]", "initial.point_velocities.tip: no such table in the scene "
                                                     "(varied key '{}'); tables here: crank_tip"),
        ("forces.gravity.g[x]", "forces.gravity.g[x]: not a key path (varied key): write table.key or "
                                "table.key[index], got the part 'g[x]'"),
    ]:
        with pytest.raises(fm.SceneError) as info:
            set_key(doc, path, 1.0, "a02.toml")
        assert str(info.value).startswith("a02.toml: " + message.format(path)), str(info.value)
