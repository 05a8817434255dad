"""The study table (:mod:`flexmb.study.table`): its files."""

from __future__ import annotations

import numpy as np

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
