"""The study table (:mod:`flexmb.study.table`): its files."""

from __future__ import annotations

import numpy as np
import pytest

from pendulum_study import scene_file, serial  # noqa: F401  (fixtures: scene_file, serial)


def test_table_files(serial):
    out = serial.out
    for name in ("table.csv", "table.npz", "study.json", "summary.txt", "study.png"):
        assert (out / name).is_file(), name
    lines = (out / "table.csv").read_text().splitlines()
    assert lines[0].split(",") == serial.columns
    assert len(lines) == 7
    npz = np.load(out / "table.npz")
    assert np.array_equal(npz["peak_speed:tip"], serial.column("peak_speed:tip"))
    assert list(npz["status"]) == ["finished"] * 6
    assert len(list((out / "cases").glob("*.json"))) == 6
    # a float written to the CSV reads back exactly
    first = dict(zip(lines[0].split(","), lines[1].split(",")))
    assert float(first["peak_speed:tip"]) == serial.column("peak_speed:tip")[0]


DRIVEN = """
[bodies.bar]
shape = "slender_bar"
mass = 1.0
length = 1.0

[bodies.block]
shape = "box"
mass = 2.0
size = [0.1, 0.1, 0.1]

[joints.pin]
type = "revolute"
parent = "ground"
child = "bar"

[joints.slide]
type = "prismatic"
parent = "ground"
child = "block"
axis = [1.0, 0.0, 0.0]

[forces.gravity]
type = "gravity"
g = [0.0, -9.81, 0.0]

[drivers.motor]
joint = "pin"
speed = 2.0

[drivers.actuator]
joint = "slide"
kind = "harmonic"
amplitude = 0.1
frequency = 2.0

[solver]
t_end = 0.2
n_out = 21
"""


def test_the_plot_gives_a_driver_effort_its_unit(tmp_path):
    """The study plot's torque axis read 'peak_effort:motor (-)' (issue #32): the unit of a driver's effort is fixed
    by its joint, which the column's name does not say; the study reads it from its scene."""
    from flexmb.study import Study

    scene = tmp_path / "driven.toml"
    scene.write_text(DRIVEN)
    study = Study.from_file(scene, {"bodies.bar.mass": [1.0, 2.0]},
                            outputs=["peak_effort:motor", "peak_effort:actuator", "energy_balance"])
    result = study.run(tmp_path / "out", executor="serial", progress=False)
    assert [r["status"] for r in result.rows] == ["finished"] * 2
    assert (result.unit("peak_effort:motor"), result.unit("peak_effort:actuator")) == ("N m", "N")
    # at constant speed the motor holds the weight of the bar (from horizontal, up to 0.4 rad): m g L / 2 at t = 0
    assert result.column("peak_effort:motor") == pytest.approx([9.81 / 2, 9.81], rel=1e-3)
    labels = [ax.get_ylabel() for ax in result.figure().axes]
    assert labels == ["peak_effort:motor (N m)", "peak_effort:actuator (N)", "energy_balance (-)"]
