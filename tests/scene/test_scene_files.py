"""The shipped scene files build the Python models.

The scenes in ``tutorials/*.toml`` are checked against the models the Python
tutorials and built-in scenes build (same coordinates, bodies and constraint
rows; the same mass matrix, force array and constraint Jacobian at a random
state to 1e-12; the same short simulation), and against closed forms.
"""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

import flexmb as fm
from flexmb.scenes.fourbar import fourbar
from flexmb.scenes.wiper import WiperOptions, wiper

TUTORIALS = pathlib.Path(__file__).resolve().parents[2] / "tutorials"


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


def beam_stop():
    model = fm.Model("beam_stop")
    beam = fm.FlexibleBody.uniform_beam("beam", 0.5, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(),
                                        8, keep=("bend_y",), damping_ratio=0.01, clamped=False)
    phi = np.radians(60.0)
    stop = fm.SpherePlaneContact("stop", beam, 0.005, fm.HuntCrossleyLaw(1e8, 0.5), centre=(0.5, 0.0, 0.0),
                                 plane_normal=(np.sin(phi), 0.0, np.cos(phi)))
    model.add(fm.Revolute("pin", model.ground, beam, axis=(0, 1, 0)), fm.Gravity((0.0, 0.0, -9.81)), stop)
    return model, {}, None, {"rtol": 1e-8, "track_work": True}


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
    "11_contact.toml": beam_stop,
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
