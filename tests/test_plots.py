"""Plots an engineer reads: every axis carries a unit, one unit per axis (issue #20, section 2).

The figures are inspected as matplotlib objects (axes, labels, line data),
never as pixels:

* ``Result.plot`` puts each kind of coordinate on its own axis, labelled
  with its unit: joint angles (rad), joint translations (m), elastic
  rotations (rad) and elastic displacements (m);
* the plot of a scene-file run, ``fourbar.png`` and ``study.png`` label
  every axis with one unit (``'-'`` in a study where the name does not
  fix it).

The wiper's figure (``wiper.png``) and its exact tip speed are tested in
``tests/test_wiper.py``, next to the wiper's fixtures.
"""

from __future__ import annotations

import re
from types import SimpleNamespace

import numpy as np
import pytest

pytest.importorskip("matplotlib")

import flexmb as fm  # noqa: E402
from flexmb import viz  # noqa: E402
from flexmb.scene import figures  # noqa: E402
from flexmb.study import StudyResult  # noqa: E402

from conftest import fourbar, fourbar_initial  # noqa: E402

UNIT = re.compile(r"\(([^()]+)\)$")


def _unit(label: str) -> str:
    """The unit in parentheses at the end of an axis label; fails if there is none."""
    m = UNIT.search(label)
    assert m, f"axis label {label!r} has no unit"
    return m.group(1)


@pytest.fixture(scope="module")
def mixed():
    """A slide-and-turn joint (m and rad) and a flexible beam bending and stretching (rad and m)."""
    model = fm.Model("mixed")
    block = fm.RigidBody.box("block", 1.0, (0.1, 0.1, 0.1))
    beam = fm.FlexibleBody("beam", 0.5, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(), 2,
                           keep=("bend_y", "axial"))
    model.add(fm.Cylindrical("rail", model.ground, block, axis=(0.0, 0.0, 1.0)),
              fm.Fixed("clamp", model.ground, beam, parent_point=(1.0, 0.0, 0.0)),
              fm.Gravity((0.0, 0.0, -9.81)))
    return fm.simulate(model, 0.01, n_out=5)


def test_coordinate_units_from_the_names():
    res = SimpleNamespace(coordinate_names=["pin.angle", "rail.slide", "ball.rx", "beam.j0.bend_y",
                                            "beam.j1.axial", "other.j0.bend_y", "custom.q"],
                          flexible={"beam": ([0, 1], 0.25)})
    assert viz.coordinate_units(res) == [
        ("joint angle", "rad"), ("joint translation", "m"), ("joint angle", "rad"), ("elastic rotation", "rad"),
        ("elastic displacement", "m"),
        # not a flexible body of the result, and a name no joint class declares: unit unknown
        ("coordinate", "-"), ("coordinate", "-")]


def test_result_plot_makes_one_axis_per_kind_and_unit(mixed, tmp_path):
    fig = mixed.plot(path=tmp_path / "all.png")
    assert (tmp_path / "all.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == ["joint angle (rad)", "joint translation (m)", "elastic rotation (rad)",
                      "elastic displacement (m)"]
    kinds = dict(zip(mixed.coordinate_names, viz.coordinate_units(mixed)))
    plotted = []
    for ax in fig.axes:
        unit = _unit(ax.get_ylabel())
        for line in ax.lines:
            # every coordinate sits on the axis of its unit, with its own data
            assert kinds[line.get_label()][1] == unit
            k = mixed.coordinate_names.index(line.get_label())
            np.testing.assert_array_equal(line.get_ydata(), mixed.x[:, k])
            plotted.append(line.get_label())
    assert sorted(plotted) == sorted(mixed.coordinate_names)
    assert fig.axes[-1].get_xlabel() == "time (s)"


def test_result_plot_selection_and_energy(mixed, tmp_path):
    fig = mixed.plot(["rail.angle", "beam.j0"], path=tmp_path / "some.png", energy=True)
    assert [ax.get_ylabel() for ax in fig.axes] == ["joint angle (rad)", "elastic rotation (rad)",
                                                    "elastic displacement (m)", "energy (J)"]
    assert [line.get_label() for line in fig.axes[1].lines] == ["beam.j0.bend_y"]
    # a single unit: a single axis
    fig = mixed.plot(["rail.slide"], path=tmp_path / "one.png")
    assert [ax.get_ylabel() for ax in fig.axes] == ["joint translation (m)"]


def test_scene_plot_labels_every_axis_with_one_unit(tmp_path):
    scene = fm.load_scene("tutorials/04_wiper_rigid.toml")
    res = scene.simulate(t_end=0.05, n_out=11, progress=False)
    tracks = scene.track(res)
    speeds = {k: np.linalg.norm(np.gradient(p, res.t, axis=0), axis=1) for k, p in tracks.items()}
    fig = figures._scene_figure(scene, res, tracks, speeds)
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels[0] == "joint angle (rad)"
    assert "energy change (J)" in labels and "point speed (m/s)" in labels
    assert "driver torque (N m)" in labels  # the crank motor drives a revolute joint
    for label in labels:
        _unit(label)
    assert fig.axes[-1].get_xlabel() == "time (s)"


def test_fourbar_plot_labels():
    res = fm.simulate(fourbar(), 0.05, positions=fourbar_initial(), n_out=6)
    fig = figures._fourbar_figure(res)
    assert [ax.get_ylabel() for ax in fig.axes] == ["joint angle (rad)", "energy drift (J)", "loop residual (m)"]
    assert [line.get_label() for line in fig.axes[0].lines] == res.coordinate_names


def _study(rows_params, outputs):
    rows = [{"case": i, "case_id": str(i), "parameters": p, "outputs": o, "status": "finished", "error": None,
             "wall_time_s": 0.1, "worker": "w"} for i, (p, o) in enumerate(zip(rows_params, outputs))]
    return StudyResult(list(rows_params[0]), list(outputs[0]), rows)


def test_study_plot_labels_parameters_and_outputs_with_units(tmp_path):
    params = [{"bodies.bar.mass": m, "drivers.motor.rpm": r} for m in (1.0, 2.0) for r in (60.0, 90.0)]
    outputs = [{"peak_speed:tip": 0.1 * p["drivers.motor.rpm"], "final:pin.angle": p["bodies.bar.mass"],
                "peak_effort:motor": 2.0, "energy_balance": 1e-9} for p in params]
    study = _study(params, outputs)
    fig = study.figure()
    axes = np.array(fig.axes).reshape(4, 2)
    assert [ax.get_xlabel() for ax in axes[-1]] == ["bodies.bar.mass (kg)", "drivers.motor.rpm (rev/min)"]
    assert [ax.get_ylabel() for ax in axes[:, 0]] == [
        "peak_speed:tip (m/s)", "final:pin.angle (rad)",
        # a driver's effort is N m or N by its joint: a table built without its study's scene (units) does not know
        "peak_effort:motor (-)", "energy_balance (-)"]
    path = study.plot(tmp_path / "study.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("name, unit", [
    ("materials.spring_steel.E", "Pa"), ("sections.blade.b", "m"), ("bodies.blade.damping", "s"),
    ("forces.right_blade_friction.normal_load+forces.left_blade_friction.normal_load", "N"),
    ("forces.spring.stiffness", "-"), ("bodies.bar.mass+forces.f.normal_load", "-"), ("solver.t_end", "s"),
    ("max_displacement:tip", "m"), ("driver_work:motor", "J"), ("max:beam.j0.axial", "m"), ("final:pin", "-"),
    ("n_rhs", "-"), ("my_output", "-")])
def test_study_units_from_names(name, unit):
    assert StudyResult([], [], []).unit(name) == unit
