"""TOML scene files: the shipped scenes build the Python models, errors name the key path.

The scenes in ``tutorials/*.toml`` are checked against the models the Python
tutorials and built-in scenes build (same coordinates, bodies and constraint
rows; the same mass matrix, force array and constraint Jacobian at a random
state to 1e-12; the same short simulation), and against closed forms. Every
kind of mistake in a scene file gives a :class:`~flexmb.SceneError` whose
message starts with the file and the key path.
"""

from __future__ import annotations

import pathlib
import textwrap

import attrs
import numpy as np
import pytest
from attrs import field, frozen

import flexmb as fm
from flexmb import registry
from flexmb.forces import ForceElement
from flexmb.scenes.fourbar import fourbar
from flexmb.scenes.wiper import WiperOptions, wiper

TUTORIALS = pathlib.Path(__file__).resolve().parents[1] / "tutorials"


# ----------------------------------------------------------------------------- the Python references


def pendulum():
    model = fm.Model("pendulum")
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)), fm.Gravity((0.0, -9.81, 0.0)))
    return model, {"pin": np.radians(120.0) - np.pi / 2}, None, {}


def fourbar_ref():
    model, initial, fixed = fourbar()
    return model, initial, fixed, {"rtol": 1e-10}


def cantilever():
    model = fm.Model("cantilever N=8")
    beam = fm.FlexibleBody.uniform_beam("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(),
                                        8, keep=("bend_y",), damping_ratio=0.01)
    model.add(fm.Fixed("clamp", model.ground, beam), fm.Gravity((0.0, 0.0, -9.81)))
    return model, {}, None, {"rtol": 1e-6}


def export_cantilever():
    model = fm.Model("cantilever")
    beam = fm.FlexibleBody.uniform_beam("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(),
                                        8, keep=("bend_y",))
    model.add(fm.Fixed("clamp", model.ground, beam), fm.Gravity((0.0, 0.0, -9.81)))
    return model, {}, None, {"rtol": 1e-6}


def wiper_ref(flexible):
    def build():
        model, initial = wiper(WiperOptions(flexible=flexible))
        return model, initial, None, {"rtol": 1e-6, "track_work": True}

    return build


SCENES = {
    "01_pendulum.toml": pendulum,
    "02_fourbar.toml": fourbar_ref,
    "03_cantilever.toml": cantilever,
    "06_export_paraview.toml": export_cantilever,
    "04_wiper.toml": wiper_ref(True),
    "04_wiper_rigid.toml": wiper_ref(False),
}


# tutorials without a scene file of their own, and why
NO_SCENE_FILE = {
    # its scene is a string inside the script: it uses the element classes the script defines
    "05_custom_elements.py",
    # its models are built in Python for a sweep (a spin rate per model) and with a controller the script defines
    "10_linear_control.py",
}
# tutorials that use another tutorial's model: 07 measures tutorial 03's beam, 08 varies the wiper's scene files,
# 09 shows the four-bar in a notebook
REUSES_SCENE = {"07_speed_vs_error.py": "03_cantilever.toml", "08_parameter_study.py": "04_wiper.toml",
                "09_notebook.py": "02_fourbar.toml"}


def test_every_tutorial_has_a_scene_file():
    shipped = sorted(p.name for p in TUTORIALS.glob("*.toml"))
    assert shipped == sorted(SCENES)
    for py in TUTORIALS.glob("[0-9][0-9]_*.py"):
        if py.name in NO_SCENE_FILE:
            continue
        if py.name in REUSES_SCENE:
            assert REUSES_SCENE[py.name] in shipped, py.name
            continue
        assert any(name.startswith(py.stem) for name in shipped), py.name


def _close(a, b, tol=1e-12):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape
    scale = max(1.0, np.abs(b).max(initial=0.0))
    assert np.abs(a - b).max(initial=0.0) <= tol * scale


@pytest.mark.parametrize("name", sorted(SCENES))
def test_scene_builds_the_python_model(name):
    scene = fm.load_scene(TUTORIALS / name)
    model, _, _, _ = SCENES[name]()
    s, r = scene.system(), model.build()
    assert s.coordinate_names == r.coordinate_names
    assert s.body_names == r.body_names
    assert s.constraints.labels == r.constraints.labels
    assert [type(f) for f in scene.model.forces] == [type(f) for f in model.forces]
    rng = np.random.default_rng(7)
    x, xd = rng.normal(scale=0.2, size=s.n_coords), rng.normal(size=s.n_coords)
    for got, want in zip(s.equations(0.3, x, xd)[1:], r.equations(0.3, x, xd)[1:]):
        _close(got, want)  # A, f, phi, psi, b, gamma
    _close(s.energy(0.3, x, xd), r.energy(0.3, x, xd))


@pytest.mark.parametrize("name, t_end", [("01_pendulum.toml", 0.5), ("02_fourbar.toml", 0.3),
                                         ("03_cantilever.toml", 0.02), ("04_wiper_rigid.toml", 0.1)])
def test_scene_simulates_like_the_python_model(name, t_end):
    scene = fm.load_scene(TUTORIALS / name)
    model, positions, fixed, kw = SCENES[name]()
    got = scene.simulate(t_end=t_end, n_out=11)
    want = fm.simulate(model, t_end, positions=positions, fixed=fixed, n_out=11, **kw)
    assert got.status == want.status == "finished"
    assert got.method == want.method
    _close(got.x, want.x, 1e-9)
    _close(got.xd, want.xd, 1e-8)


def test_pendulum_scene_conserves_energy_and_starts_at_30_degrees():
    res = fm.load_scene(TUTORIALS / "01_pendulum.toml").simulate(t_end=0.5, n_out=11)
    assert res.x[0, 0] == pytest.approx(np.pi / 6, abs=1e-15)
    # released from rest: E = m g (L/2) sin(q0) = 9.81 * 0.5 * 0.5
    assert res.energy[0] == pytest.approx(9.81 * 0.25, rel=1e-12)
    assert np.ptp(res.energy) < 1e-7 * 9.81 * 0.25


def test_fourbar_scene_closes_its_loop():
    scene = fm.load_scene(TUTORIALS / "02_fourbar.toml")
    system = scene.system()
    x0, _ = scene.initial_state(system)
    a, b, d = (x0[system.coordinate_names.index(f"{j}.angle")] for j in "ABD")
    assert a == pytest.approx(np.pi / 4, abs=1e-15)  # A held
    crank_tip = 0.1 * np.array([np.cos(a), np.sin(a)])
    coupler_end = crank_tip + 0.3 * np.array([np.cos(a + b), np.sin(a + b)])
    rocker_end = np.array([0.3, 0.0]) + 0.25 * np.array([np.cos(d), np.sin(d)])
    assert np.abs(coupler_end - rocker_end).max() < 1e-12


def test_wiper_driver_rpm_and_tracked_tip():
    scene = fm.load_scene(TUTORIALS / "04_wiper_rigid.toml")
    (driver,) = scene.model.drivers
    assert driver.velocity(0.0) == pytest.approx(2 * np.pi)  # 60 rpm
    res = scene.simulate(t_end=0.05, n_out=6)
    tips = scene.track(res)
    k = res.body_names.index("right_blade")
    np.testing.assert_allclose(tips["right_tip"], res.origins[:, k] + res.rotations[:, k, :, 0] * 0.25,
                               rtol=0, atol=1e-15)
    assert res.coordinate("RJ1")[-1] == pytest.approx(2 * np.pi * 0.05, abs=1e-8)


def test_flexible_tip_tracking_matches_shape():
    scene = fm.load_scene(TUTORIALS / "03_cantilever.toml")
    res = scene.simulate(t_end=0.01, n_out=3)
    np.testing.assert_allclose(scene.track(res)["tip"], res.shape("beam")[:, -1], rtol=0, atol=1e-15)


# ----------------------------------------------------------------------------- results are saved without loss


def test_result_save_load_round_trips_every_field(tmp_path):
    res = fm.load_scene(TUTORIALS / "03_cantilever.toml").simulate(t_end=0.01, n_out=5, track_work=True)
    assert res.work and res.flexible
    res.message = "r\u00e9sum\u00e9 with unicode"
    res.save(tmp_path / "r.npz")
    back = fm.Result.load(tmp_path / "r.npz")
    assert res.system is not None and back.system is None  # the compiled model is kept, not saved
    for f in attrs.fields(fm.Result):
        if f.name == "system":
            continue
        a, b = getattr(res, f.name), getattr(back, f.name)
        if isinstance(a, np.ndarray):
            assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b), f.name
        elif isinstance(a, dict):
            assert list(a) == list(b) or sorted(a) == sorted(b), f.name
            for k in a:
                if f.name == "work":
                    assert np.array_equal(a[k], b[k]), (f.name, k)
                else:
                    assert tuple(a[k][0]) == tuple(b[k][0]) and a[k][1] == b[k][1], (f.name, k)
        else:
            assert a == b and type(a) is type(b), f.name


def test_result_round_trip_with_constraints_and_no_work(tmp_path):
    res = fm.load_scene(TUTORIALS / "02_fourbar.toml").simulate(t_end=0.05, n_out=3)
    res.save(tmp_path / "f.npz")
    back = fm.Result.load(tmp_path / "f.npz")
    assert np.array_equal(back.reactions, res.reactions) and back.constraint_labels == res.constraint_labels
    assert back.work == {} and back.flexible == {} and back.status == "finished"


# ----------------------------------------------------------------------------- plugins by name


@frozen(eq=False)
class SpinTorque(ForceElement):
    """A test plugin: constant torque ``tau`` about z on a body."""

    body: fm.Body = field()
    tau: float = field(converter=float)

    def apply(self, state, loads):
        k, _ = state.locate(self.body, (0.0, 0.0, 0.0))
        loads.add_torque(k, np.array([0.0, 0.0, self.tau]))


@pytest.fixture
def spin_plugin(monkeypatch):
    monkeypatch.setattr(registry, "_session", {})
    fm.register("forces", "spin_torque", SpinTorque)


BAR = """
[bodies.bar]
shape = "slender_bar"
mass = 2.0
length = 0.5
[joints.pin]
type = "revolute"
parent = "ground"
child = "bar"
[solver]
t_end = 1.0
"""


def test_a_third_party_force_plugin_is_usable_by_name(spin_plugin):
    scene = fm.loads_scene(BAR + '[forces.motor]\ntype = "spin_torque"\nbody = "bar"\ntau = 0.3\n')
    assert isinstance(scene.model.forces[0], SpinTorque) and scene.model.forces[0].body is scene.model["bar"]
    system = scene.system()
    xdd = system.accelerations(0.0, np.zeros(1), np.zeros(1))
    assert xdd[0] == pytest.approx(0.3 / (2.0 * 0.5**2 / 3), rel=1e-12)  # tau / (m L^2 / 3)


def test_plugin_errors_name_the_key(spin_plugin):
    with pytest.raises(fm.SceneError, match=r"^<scene>: forces\.motor\.tau: must be a number, got a string"):
        fm.loads_scene(BAR + '[forces.motor]\ntype = "spin_torque"\nbody = "bar"\ntau = "big"\n')
    with pytest.raises(fm.SceneError, match=r"^<scene>: forces\.motor: missing key 'tau'"):
        fm.loads_scene(BAR + '[forces.motor]\ntype = "spin_torque"\nbody = "bar"\n')


# ----------------------------------------------------------------------------- errors point at the key


def _error(text, tmp_path=None) -> str:
    path = (tmp_path or pathlib.Path(".")) / "scene.toml"
    if tmp_path is None:
        with pytest.raises(fm.SceneError) as info:
            fm.loads_scene(textwrap.dedent(text), source="scene.toml")
    else:
        path.write_text(textwrap.dedent(text))
        with pytest.raises(fm.SceneError) as info:
            fm.load_scene(path)
    return str(info.value)


GOOD = """
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
[solver]
t_end = 1.0
"""


def test_the_good_scene_loads():
    scene = fm.loads_scene(GOOD)
    assert scene.solver.t_end == 1.0 and scene.system().coordinate_names == ["pin.angle"]


@pytest.mark.parametrize("edit, expected", [
    # wrong shape, with the key path of the brief's example
    (("axis = [0.0, 0.0, 1.0]", "axis = [0.0, 1.0]"), "scene.toml: joints.pin.axis: must have 3 components, got 2"),
    # wrong type
    (("mass = 1.0", 'mass = "heavy"'), "scene.toml: bodies.bar.mass: must be a number, got a string 'heavy'"),
    (("t_end = 1.0", 't_end = "1 s"'), "scene.toml: solver.t_end: must be a number, got a string '1 s'"),
    # missing key
    (('child = "bar"\n', ""), "scene.toml: joints.pin: missing key 'child'"),
    (("t_end = 1.0", "rtol = 1e-6"), "scene.toml: solver: missing key 't_end'"),
    # unknown keys
    (("axis = [0.0, 0.0, 1.0]", "axes = [0.0, 0.0, 1.0]"),
     "scene.toml: joints.pin.axes: unknown key for joint type 'revolute'; allowed keys: parent, child"),
    (("t_end = 1.0", "t_end = 1.0\nrelative_tolerance = 1e-6"),
     "scene.toml: solver.relative_tolerance: unknown key; allowed keys: t_end, method, rtol"),
    # unknown plugin name
    (('type = "revolute"', 'type = "hinge"'),
     "scene.toml: joints.pin.type: no joints plugin named 'hinge'; pick one of ["),
    (('type = "gravity"', 'type = "gravitation"'), "scene.toml: forces.gravity.type: no forces plugin named"),
    # unknown references
    (('child = "bar"', 'child = "rod"'), "scene.toml: joints.pin.child: unknown body 'rod'; known: bar, ground"),
    # validation errors of the class, moved to the key
    (("mass = 1.0", "mass = -1.0"), "scene.toml: bodies.bar.mass: must be > 0, got -1.0"),
    (("shape = \"slender_bar\"", "shape = \"sphere\""),
     "scene.toml: bodies.bar.shape: unknown shape 'sphere' for rigid_body; pick one of bar, box, slender_bar"),
    (("t_end = 1.0", "t_end = 1.0\nmethod = \"Euler\""), "scene.toml: solver.method: unknown integrator 'Euler'"),
    (("t_end = 1.0", "t_end = 1.0\ncomplement = \"lu\""),
     "scene.toml: solver.complement: unknown complement strategy 'lu'; pick one of auto, eigen, qr, svd"),
])
def test_bad_scene_names_the_key_path(edit, expected):
    old, new = edit
    assert old in GOOD
    assert _error(GOOD.replace(old, new, 1)).startswith(expected)


def test_unknown_section_and_bad_initial_names():
    assert _error(GOOD + "[gravity]\ng = 1\n").startswith(
        "scene.toml: gravity: unknown section; allowed: model, materials")
    assert _error(GOOD + "[initial]\npositions = { hinge = 0.1 }\n").startswith(
        "scene.toml: initial.positions.hinge: no coordinate or joint named 'hinge'; coordinates: pin.angle")
    assert _error(GOOD + "[initial]\nspeeds = { pin = [1.0, 2.0] }\n").startswith(
        "scene.toml: initial.speeds.pin: must have 1 values")
    assert _error(GOOD + "[output.points.tip]\nbody = \"rod\"\n").startswith(
        "scene.toml: output.points.tip.body: unknown body 'rod'")


def test_driver_errors():
    drv = GOOD + "[drivers.motor]\njoint = \"pin\"\nrpm = 60.0\n"
    scene = fm.loads_scene(drv)
    assert scene.model.drivers[0].velocity(0.0) == pytest.approx(2 * np.pi, rel=1e-15)
    assert _error(drv.replace('joint = "pin"', 'joint = "hinge"')).startswith(
        "scene.toml: drivers.motor.joint: unknown joint 'hinge'; known: pin")
    assert _error(drv + "speed = 1.0\n").startswith("scene.toml: drivers.motor.rpm: give speed")
    assert _error(drv + 'kind = "ramp"\n').startswith(
        "scene.toml: drivers.motor.kind: unknown driver kind 'ramp'; pick one of constant_speed, harmonic")
    assert _error(drv + 'coordinate = "slide"\n').startswith(
        "scene.toml: drivers.motor.coordinate: joint 'pin' has no coordinate 'slide'; its coordinates: angle")
    harmonic = GOOD + "[drivers.shake]\njoint = \"pin\"\nkind = \"harmonic\"\namplitude = 0.2\nfrequency = 2.0\n"
    d = fm.loads_scene(harmonic).model.drivers[0]
    assert d.position(0.125) == pytest.approx(0.2)  # sin(2 pi 2 0.125) = 1


def test_flexible_body_errors():
    flex = """
    [materials.al]
    preset = "aluminium"
    [sections.strip]
    kind = "rectangular"
    b = 0.02
    h = 0.005
    [bodies.beam]
    type = "flexible_body"
    length = 1.0
    section = "strip"
    material = "al"
    n_segments = 4
    keep = ["bend_y"]
    [joints.clamp]
    type = "fixed"
    parent = "ground"
    child = "beam"
    [solver]
    t_end = 0.1
    """
    assert fm.loads_scene(textwrap.dedent(flex)).system().n_coords == 4
    assert _error(flex.replace('"bend_y"', '"bend_x"')).startswith(
        "scene.toml: bodies.beam.keep: unknown elastic coordinate(s) ['bend_x']")
    assert _error(flex.replace('section = "strip"', 'section = "strap"')).startswith(
        "scene.toml: bodies.beam.section: unknown section 'strap'; known: strip")
    assert _error(flex.replace('kind = "rectangular"', 'kind = "oval"')).startswith(
        "scene.toml: sections.strip.kind: unknown section kind 'oval'")
    assert _error(flex.replace("h = 0.005", "t = 0.005")).startswith("scene.toml: sections.strip.t: unknown key")
    assert _error(flex.replace('preset = "aluminium"', 'preset = "wood"')).startswith(
        "scene.toml: materials.al.preset: unknown preset 'wood'")


def test_model_level_problems_are_reported_on_one_line():
    # a second joint onto the same body makes a loop through a Fixed... fine; two joints with the ground as child is not
    text = GOOD + '[joints.bad]\ntype = "revolute"\nparent = "bar"\nchild = "ground"\n'
    msg = _error(text)
    assert msg.startswith("scene.toml: ") and "ground cannot be a child" in msg and "\n" not in msg


def test_toml_syntax_error_gives_the_line(tmp_path):
    msg = _error(GOOD.replace("mass = 1.0", "mass = = 1.0"), tmp_path)
    assert msg.startswith(f"{tmp_path / 'scene.toml'}: invalid TOML: ")
    assert "line 4" in msg


def test_missing_file_is_a_scene_error(tmp_path):
    with pytest.raises(fm.SceneError, match="cannot read the scene file"):
        fm.load_scene(tmp_path / "nope.toml")


def test_scene_error_is_a_model_error_with_the_key_path():
    with pytest.raises(fm.ModelError) as info:
        fm.loads_scene(GOOD.replace("mass = 1.0", "mass = -1.0"))
    assert isinstance(info.value, fm.SceneError) and info.value.key_path == "bodies.bar.mass"


def test_initial_values_by_dotted_coordinate_names():
    text = GOOD + "[initial]\npositions = { pin.angle = 0.25 }\nspeeds = { \"pin.angle\" = -1.5 }\n"
    scene = fm.loads_scene(text)
    assert scene.initial.positions == {"pin.angle": 0.25} and scene.initial.speeds == {"pin.angle": -1.5}
    res = scene.simulate(t_end=0.01, n_out=2)
    assert (res.x[0, 0], res.xd[0, 0]) == (0.25, -1.5)


# ----------------------------------------------------------------------------- issue 18 section 3: refused at once


@pytest.mark.parametrize("edit, expected", [
    (("t_end = 1.0", "t_end = inf"), "scene.toml: solver.t_end: must be finite, got inf"),
    (("t_end = 1.0", "t_end = nan"), "scene.toml: solver.t_end: must be > 0, got nan"),
    (("t_end = 1.0", "t_end = 1.0\nrtol = inf"), "scene.toml: solver.rtol: must be finite, got inf"),
    (("t_end = 1.0", "t_end = 1.0\nprojection_tol = inf"), "scene.toml: solver.projection_tol: must be finite"),
    (("t_end = 1.0", "t_end = 1.0\nn_out = 0"), "scene.toml: solver.n_out: must be >= 2, got 0"),
    (("t_end = 1.0", "t_end = 1.0\nn_out = 100_000_000"),
     "scene.toml: solver.n_out: 100000000 output times: needs about"),
    (("length = 1.0", "length = -1.0"), "scene.toml: bodies.bar.length: must be a finite number > 0, got -1.0"),
    (("length = 1.0", "length = 0.0"), "scene.toml: bodies.bar.length: must be a finite number > 0, got 0.0"),
])
def test_scene_values_that_cannot_run_are_refused_at_load(edit, expected, monkeypatch):
    """t_end = inf integrated forever; length -1 simulated."""
    monkeypatch.setenv("FLEXMB_MEMORY_LIMIT", "8G")  # 1e8 output times must not fit, whatever the machine
    old, new = edit
    assert _error(GOOD.replace(old, new, 1)).startswith(expected)


def test_scene_max_step_may_be_infinite():
    assert fm.loads_scene(GOOD.replace("t_end = 1.0", "t_end = 1.0\nmax_step = inf")).solver.max_step == np.inf


def test_study_section_holds_the_time_limit():
    assert fm.loads_scene(GOOD + "[study]\ntime_limit = 30\n").solver.t_end == 1.0
    assert _error(GOOD + "[study]\ntime_limit = -1\n").startswith("scene.toml: study.time_limit: must be > 0, got -1")
    assert _error(GOOD + "[study]\ntime_limit = inf\n").startswith("scene.toml: study.time_limit: must be finite")
    assert _error(GOOD + "[study]\ntime_limt = 3\n").startswith(
        "scene.toml: study.time_limt: unknown key; allowed keys: time_limit")
