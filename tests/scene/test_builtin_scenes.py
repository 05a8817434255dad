"""The built-in scenes (``flexmb run wiper``, ``flexmb run fourbar``) are scene files, run by the one scene route.

The reference is the other route to the same file: ``flexmb run wiper`` and
``flexmb run <path of the shipped wiper.toml>`` must write the same
``summary.json``, value by value (all but the measured wall times, the
paths, compared relative to their output folder, and ``scene``, which names
what the user typed); and each run of the built-in wiper must report what
the tutorial scene files of the same model report.
"""

from __future__ import annotations

import json
from importlib import resources

import pytest

import flexmb as fm

from flexmb.cli import main
from flexmb.scene import builtin_scenes, load_builtin

WIPER = resources.files("flexmb.scene") / "builtin" / "wiper.toml"
T_END = "0.05"


def _normal(value):
    """A summary with the measured wall times left out (its paths are relative to its folder already)."""
    if isinstance(value, dict):
        return {k: _normal(v) for k, v in value.items() if k != "wall_time_s"}
    if isinstance(value, list):
        return [_normal(v) for v in value]
    return value


def _run(scene, out, capsys) -> dict:
    assert main(["run", str(scene), "--out", str(out), "--t-end", T_END, "--quiet"]) == 0
    capsys.readouterr()
    return json.loads((out / "summary.json").read_text())


def test_builtin_scenes_are_the_shipped_files():
    assert builtin_scenes() == ["bicycle", "fourbar", "wiper"]
    assert WIPER.is_file()
    scene = load_builtin("wiper")
    assert scene.source == "wiper" and list(scene.runs) == ["rigid", "flexible"]
    # the defaults of the one route: the scene file's [solver]
    assert (scene.solver.n_out, scene.solver.rtol, scene.solver.t_end) == (501, 1e-6, 1.0)


def test_both_routes_of_the_wiper_write_the_same_summary(tmp_path, capsys):
    by_name = _run("wiper", tmp_path / "name", capsys)
    by_file = _run(WIPER, tmp_path / "file", capsys)
    assert by_name.pop("scene") == "wiper" and by_file.pop("scene") == str(WIPER)
    assert by_name["rigid"]["wall_time_s"] > 0 and by_file["flexible"]["wall_time_s"] > 0
    a, b = _normal(by_name), _normal(by_file)
    assert a == b
    assert a["status"] == "finished" and a["files"]["plot"] == "wiper.png"
    for label in ("rigid", "flexible"):
        assert a[label]["t_end"] == pytest.approx(float(T_END))


def test_each_run_reports_what_its_tutorial_scene_file_reports(tmp_path, capsys):
    builtin = _run("wiper", tmp_path / "wiper", capsys)
    for label, tutorial in (("rigid", "tutorials/04_wiper_rigid.toml"), ("flexible", "tutorials/04_wiper.toml")):
        single = _run(tutorial, tmp_path / label, capsys)
        run = builtin[label]
        shared = set(single) - {"scene", "model", "wall_time_s", "vtk", "files"}
        assert shared <= set(run)
        assert {k: run[k] for k in shared} == {k: single[k] for k in shared}, label


@pytest.mark.parametrize("edit, expected", [
    (("[runs.flexible]", "[runs.flex]"), "w.toml: output.figure: figure 'wiper' draws the [runs] of a scene "
                                         "(rigid, flexible); this one has rigid, flex"),
    (('figure = "wiper"', 'figure = "plot"'), "w.toml: output.figure: unknown figure 'plot'; pick one of"),
    (('"bodies.right_blade" =', '"bodies.right_blades.mass" ='), "w.toml: runs.rigid: bodies.right_blades: no such "
                                                                 "table in the scene (key of run 'rigid'"),
    (('"bodies.left_blade" = { shape = "box", mass = 0.03925',
      '"bodies.left_blade" = { shape = "box", mass = -1.0'), "w.toml: runs.rigid: bodies.left_blade.mass: must be > 0"),
    (('"peak_effort:motor"', '"peak_effort:crank"'), "w.toml: output.metrics.peak_crank_torque_N_m: output "
                                                     "'peak_effort:crank': write peak_effort:<driver>"),
])
def test_runs_figure_and_metrics_errors_name_the_key(edit, expected):
    text = WIPER.read_text()
    assert edit[0] in text
    with pytest.raises(fm.SceneError) as err:
        fm.loads_scene(text.replace(*edit), source="w.toml")
    assert str(err.value).startswith(expected)


def test_the_wiper_figure_is_the_one_drawn_in_process(tmp_path, capsys):
    """wiper.png, drawn by the worker child, holds the curves of figures.wiper_figure drawn here."""
    pytest.importorskip("matplotlib")
    from matplotlib import image

    from flexmb.scene import figures

    _run("wiper", tmp_path, capsys)
    scene = load_builtin("wiper")
    done = {label: (run, fm.Result.load(tmp_path / f"wiper_{label}.npz"), run.system())
            for label, run in scene.runs.items()}
    here = tmp_path / "here.png"
    figures.draw_wiper(figures.wiper_data(*_wiper_args(done))).savefig(here, format="png", dpi=120)
    drawn, expected = image.imread(tmp_path / "wiper.png"), image.imread(here)
    assert drawn.shape == expected.shape
    assert abs(drawn - expected).max() < 0.02  # the same pixels, up to the npz round trip's last digits


def _wiper_args(done):
    """figures.wiper_data's arguments from {label: (scene, result, system)}."""
    from flexmb.post.motion import point_motion

    results = {label: res for label, (_, res, _) in done.items()}
    systems = {label: system for label, (_, _, system) in done.items()}
    tips = {label: point_motion(results[label], "right_blade", (0.25, 0.0, 0.0), (0, 1), systems[label])
            for label in done}
    return results, systems, tips


def test_without_matplotlib_the_wiper_writes_everything_but_the_plot(tmp_path, capsys, monkeypatch, caplog):
    import importlib.util

    from flexmb.scene import outputs

    real = importlib.util.find_spec
    monkeypatch.setattr(outputs.importlib.util, "find_spec",
                        lambda name, *a: None if name == "matplotlib" else real(name, *a))
    with caplog.at_level("WARNING", logger="flexmb"):
        summary = _run("wiper", tmp_path, capsys)
    assert "matplotlib is not installed" in caplog.text
    assert "plot" not in summary["files"] and not (tmp_path / "wiper.png").exists()
    assert {"result_rigid", "result_flexible", "vtk_rigid", "vtk_flexible"} <= set(summary["files"])
