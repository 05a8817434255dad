"""The 3-D viewer page (flexmb.viz.viewer, ``result.view()``, ``flexmb view``): its data against the Result.

The page's JavaScript is exercised in a real browser by ``test_viewer_browser.py``; here its embedded
data is read back and checked against closed forms: a pendulum's pivot, tip and tip speed, a cantilever's
root stress under its own weight, the frames kept under the size bounds.
"""

from __future__ import annotations

import base64
import json
import pathlib
import shutil

import numpy as np
import pytest

import flexmb as fm
from flexmb.cli import main
from flexmb.errors import ExportError
from flexmb.viz import View, view_html, write_view

TUTORIALS = pathlib.Path(__file__).resolve().parents[1] / "tutorials"
PENDULUM = TUTORIALS / "01_pendulum.toml"
F32 = np.finfo(np.float32).eps


def page_data(text: str) -> dict:
    """The JSON the page embeds (``const DATA = ...;``)."""
    start = text.index("const DATA = ") + len("const DATA = ")
    return json.loads(text[start:text.index(";\n", start)])


def floats(b64: str) -> np.ndarray:
    return np.frombuffer(base64.b64decode(b64), dtype="<f4").astype(float)


def positions(run: dict) -> np.ndarray:
    return floats(run["positions"]).reshape(len(run["t"]), run["n_points"], 3)


def field(run: dict, name: str) -> np.ndarray:
    return floats(run["fields"][name]["values"]).reshape(len(run["t"]), run["n_points"])


def pivot_and_tip(run: dict) -> tuple[int, int]:
    """The bar's line ends (point indices): the one at the joint point, and the other."""
    P, joint = positions(run)[0], run["joints"][0]
    a, b = run["lines"][0][:2]
    return (a, b) if np.linalg.norm(P[a] - P[joint]) < np.linalg.norm(P[b] - P[joint]) else (b, a)


def pendulum(length=1.0):
    model = fm.Model("pendulum")
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=length)  # frame at one end, bar along x
    model.add(bar, fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)), fm.Gravity((0.0, -9.81, 0.0)))
    return model


@pytest.fixture(scope="module")
def swing():
    model = pendulum(0.8)
    return model, fm.simulate(model, 0.5, positions={"pin": 0.5}, n_out=26, progress=False)


def test_pendulum_page_holds_every_output_with_pivot_tip_and_tip_speed(swing):
    model, res = swing
    run = page_data(view_html(res, system=model))["runs"][0]
    assert run["t"] == pytest.approx(res.t.tolist(), abs=0.0) and run["outputs"] == list(range(26))
    assert run["bodies"] == ["bar"] and len(run["lines"]) == 1 and len(run["joints"]) == 1
    P, speed = positions(run), field(run, "velocity")
    (a, b, body), joint = run["lines"][0], run["joints"][0]
    assert body == 0
    pivot, tip = pivot_and_tip(run)
    q, qd = res.x[:, 0], res.xd[:, 0]
    # the pivot stays at the origin, the tip at 0.8 m along the bar's angle from +x, at speed L |qd|
    np.testing.assert_allclose(P[:, [pivot, joint]], 0.0, atol=1e-12)
    np.testing.assert_allclose(P[:, tip], 0.8 * np.column_stack([np.cos(q), np.sin(q), 0 * q]), rtol=0, atol=4 * F32)
    np.testing.assert_allclose(P[:, [a, b]].mean(axis=1), res.positions[:, 0], rtol=0, atol=4 * F32)
    np.testing.assert_allclose(speed[:, tip], 0.8 * np.abs(qd), rtol=4 * F32, atol=4 * F32)
    np.testing.assert_allclose(speed[:, pivot], 0.0, atol=4 * F32)
    assert run["fields"]["velocity"]["max"] == pytest.approx(0.8 * np.abs(qd).max(), rel=1e-12)
    assert "von_mises" not in run["fields"]  # a rigid model has no stresses to colour by


def test_without_the_system_a_body_is_its_line_from_frame_origin_through_mass_centre(swing):
    _, res = swing
    run = page_data(view_html(res))["runs"][0]
    P = positions(run)
    (a, b, _), = run["lines"]
    assert run["joints"] == []
    np.testing.assert_allclose(P[:, a], res.origins[:, 0], atol=4 * F32)
    np.testing.assert_allclose((P[:, a] + P[:, b]) / 2, res.positions[:, 0], atol=4 * F32)


def test_frames_are_bounded_evenly_spaced_with_first_and_last():
    model = pendulum()
    res = fm.Result.from_states(model, np.linspace(0.0, 1.0, 2001)[:, None], t=np.linspace(0.0, 2.0, 2001))
    run = page_data(view_html(res, system=model, max_frames=100))["runs"][0]
    expected = np.unique(np.round(np.linspace(0, 2000, 100)).astype(int))
    assert len(run["t"]) == 100 and run["outputs"] == expected.tolist() and run["n_outputs"] == 2001
    assert run["outputs"][0] == 0 and run["outputs"][-1] == 2000
    np.testing.assert_allclose(run["t"], res.t[expected], rtol=0, atol=0)
    np.testing.assert_allclose(positions(run)[:, run["joints"][0]], 0.0, atol=1e-12)
    # the byte bound: 3 points (the bar's ends, the joint) x (3 coordinates + 1 speed) x 4 bytes = 48 a frame
    run = page_data(view_html(res, system=model, max_bytes=48 * 37.5))["runs"][0]
    assert run["n_points"] == 3 and len(run["t"]) == 37
    assert len(base64.b64decode(run["positions"])) + len(base64.b64decode(run["fields"]["velocity"]["values"])) \
        <= 48 * 37.5
    with pytest.raises(ExportError, match="one frame of this scene takes 48 bytes, more than max_bytes=47"):
        view_html(res, system=model, max_bytes=47)
    with pytest.raises(ExportError, match="max_frames must be an integer >= 1, got 0"):
        view_html(res, max_frames=0)


def test_cantilever_root_stress_is_the_weight_moment_and_rigid_bodies_have_none():
    b, h, length = 0.02, 0.01, 1.0
    section, material = fm.Section.rectangular(b, h), fm.Material.aluminium()

    def model(with_bar):
        model = fm.Model("cantilever")
        beam = fm.FlexibleBody("beam", length, section, material, n_segments=4, keep=("bend_y", "bend_z"))
        model.add(fm.Fixed("clamp", model.ground, beam), fm.Gravity((0.0, 0.0, -9.81)))
        if with_bar:
            bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=0.5)
            model.add(fm.Revolute("pin", model.ground, bar, parent_point=(0, 1, 0)))
        return model.build()

    beam_alone, system = model(False), model(True)
    sag = dict(zip(beam_alone.coordinate_names, fm.linear_statics(beam_alone)))
    x = np.array([[0.0] * system.n_coords, [sag.get(c, 0.3) for c in system.coordinate_names]])
    res = fm.Result.from_states(system, x, xdd=np.zeros_like(x))
    run = page_data(view_html(res, system=system))["runs"][0]
    stress = field(run, "von_mises")
    # linear statics: the root carries the beam's weight at half its length, sigma = M (h / 2) / (b h^3 / 12)
    mass = material.density * b * h * length
    sigma = (mass * 9.81 * length / 2) * 6 / (b * h ** 2)
    assert np.nanmax(stress[0]) == 0.0
    assert np.nanmax(stress[1]) == pytest.approx(sigma, rel=1e-6)
    assert run["fields"]["von_mises"]["max"] == pytest.approx(sigma, rel=1e-6)
    beam_row, bar_row = run["bodies"].index("beam"), run["bodies"].index("bar")
    bar_points = {p for item in run["lines"] + run["faces"] for p in item[:-1] if item[-1] == bar_row}
    beam_points = {p for item in run["faces"] for p in item[:-1] if item[-1] == beam_row}
    assert bar_points and beam_points and not bar_points & beam_points
    assert np.isnan(stress[:, sorted(bar_points)]).all() and np.isfinite(stress[:, sorted(beam_points)]).all()
    assert run["fields"]["von_mises"]["partial"] is True


def test_page_is_self_contained_and_view_shows_it_inline(swing, tmp_path):
    model, res = swing
    page = res.view(tmp_path / "sub" / "pendulum.html", title="a </script> title")
    assert isinstance(page, View) and page == tmp_path / "sub" / "pendulum.html"
    text = page.read_text(encoding="utf-8")
    assert "http://" not in text and "https://" not in text and "<script src" not in text
    assert text.count("</script>") == 1 and "<title>a &lt;/script&gt; title</title>" in text
    assert page_data(text)["title"] == "a </script> title"
    assert len(page_data(text)["runs"][0]["joints"]) == 1  # the result's own system: drawn through its joint
    html = page._repr_html_()
    assert html.startswith("<iframe srcdoc=\"") and "&lt;canvas id=&quot;canvas&quot;&gt;" in html
    default = res.view()
    assert default.name == "view.html" and default.is_file()
    default.unlink()
    default.parent.rmdir()


def test_labelled_results_and_bad_inputs(swing, tmp_path):
    model, res = swing
    data = page_data(write_view({"a": res, "b": res}, tmp_path / "v.html", system={"a": model}).read_text())
    assert [r["label"] for r in data["runs"]] == ["a", "b"]
    assert len(data["runs"][0]["joints"]) == 1 and data["runs"][1]["joints"] == []
    with pytest.raises(ExportError, match=r"systems for unknown results \['c'\]"):
        view_html({"a": res}, system={"c": model})
    with pytest.raises(ExportError, match="system must be a mapping"):
        view_html({"a": res}, system=model)
    with pytest.raises(ExportError, match="no results"):
        view_html({})
    with pytest.raises(ExportError, match="pass a flexmb Result"):
        view_html(object())


def _run_pendulum(scene, out):
    assert main(["run", str(scene), "--out", str(out), "--t-end", "0.2", "--n-out", "11", "--quiet"]) == 0


def test_flexmb_view_writes_folder_view_html_with_the_scene_model(tmp_path, capsys):
    out = tmp_path / "out"
    _run_pendulum(PENDULUM, out)
    capsys.readouterr()
    assert main(["view", str(out)]) == 0
    printed, err = capsys.readouterr()
    assert printed.strip() == str(out / "view.html") and err == ""
    run, = page_data((out / "view.html").read_text())["runs"]
    res = fm.Result.load(out / "pendulum.npz")
    assert run["t"] == res.t.tolist() and len(run["joints"]) == 1
    tip = pivot_and_tip(run)[1]
    np.testing.assert_allclose(positions(run)[:, tip], res.origins[:, 0] + res.rotations[:, 0, :, 0],
                               atol=4 * F32)
    assert main(["view", str(out), "--out", str(tmp_path / "few.html"), "--max-frames", "3"]) == 0
    assert page_data((tmp_path / "few.html").read_text())["runs"][0]["outputs"] == [0, 5, 10]


def test_flexmb_view_of_runs_and_of_a_moved_scene(tmp_path, capsys):
    scene = tmp_path / "two.toml"
    scene.write_text(PENDULUM.read_text() + '\n[runs.short]\n"bodies.bar.length" = 0.5\n[runs.long]\n')
    out = tmp_path / "out"
    _run_pendulum(scene, out)
    scene.unlink()  # the scene file is gone: the page is drawn without the models, and says so
    capsys.readouterr()
    assert main(["view", str(out)]) == 0
    printed, err = capsys.readouterr()
    assert err.count("drawn without its model") == 2 and "is not found (moved?)" in err
    runs = page_data((out / "view.html").read_text())["runs"]
    assert [r["label"] for r in runs] == ["short", "long"] and all(r["joints"] == [] for r in runs)
    shutil.copy(PENDULUM, scene)
    scene.write_text(PENDULUM.read_text() + '\n[runs.short]\n"bodies.bar.length" = 0.5\n[runs.long]\n')
    assert main(["view", str(out)]) == 0
    runs = page_data((out / "view.html").read_text())["runs"]
    assert all(len(r["joints"]) == 1 for r in runs)
    ends = positions(runs[0])[:, runs[0]["lines"][0][:2]]
    np.testing.assert_allclose(np.linalg.norm(ends[:, 0] - ends[:, 1], axis=1), 0.5, rtol=4 * F32)


def test_flexmb_view_refuses_a_folder_without_results(tmp_path, capsys):
    assert main(["view", str(tmp_path / "none")]) == 3
    assert "no such folder" in capsys.readouterr().err
    assert main(["view", str(tmp_path)]) == 3
    assert "no summary.json and no .npz result" in capsys.readouterr().err


def test_browser_failures_are_export_errors(swing, tmp_path, monkeypatch):
    from flexmb.viz import _browser

    page = write_view(swing[1], tmp_path / "v.html")
    with pytest.raises(ExportError, match="failed on file://"):
        _browser.screenshot(page, tmp_path / "x.png", browser=shutil.which("false"))
    with pytest.raises(ExportError, match="wrote no screenshot"):
        _browser.screenshot(page, tmp_path / "x.png", browser=shutil.which("true"))
    assert not (tmp_path / "x.png").exists()
    monkeypatch.setattr(_browser, "find_chromium", lambda: None)
    with pytest.raises(ExportError, match="no Chromium on the PATH"):
        _browser.dom(page)
