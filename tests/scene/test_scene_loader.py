"""The scene loader (:mod:`flexmb.scene.loader`): plugins by name, and errors that name the key path.

Every kind of mistake in a scene file gives a :class:`~flexmb.SceneError`
whose message starts with the file and the key path.
"""

from __future__ import annotations

import pathlib
import textwrap

import numpy as np
import pytest
from attrs import field, frozen

import flexmb as fm
from flexmb import registry
from flexmb.forces import ForceElement



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
     "scene.toml: solver.complement: unknown complement strategy 'lu'; pick one of articulated, auto, eigen, qr, svd"),
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
