"""Study specs (:mod:`flexmb.study.spec`): values, lists and ranges, the grid of cases and their ids."""

from __future__ import annotations


import pytest

from flexmb.errors import FlexmbError
from flexmb.study import Distribution, case_id, parse_spec, parse_value

from pendulum_study import scene_file, _study  # noqa: F401  (fixtures: scene_file)


# ----------------------------------------------------------------------------- specs


def test_specs_lists_ranges_and_types():
    assert parse_spec("1,2,3") == [1, 2, 3]
    assert parse_spec("1.0, 2.5") == [1.0, 2.5]
    assert parse_spec("lin:2:8:4") == [2, 4, 6, 8] and all(type(v) is int for v in parse_spec("lin:2:8:4"))
    assert parse_spec("lin:0:1:5") == pytest.approx([0.0, 0.25, 0.5, 0.75, 1.0], abs=0)
    assert parse_spec("log:1e-3:1e1:5") == pytest.approx([1e-3, 1e-2, 1e-1, 1.0, 10.0], rel=1e-15)
    assert parse_spec('"svd","eigen"') == ["svd", "eigen"]
    assert parse_spec("[1,0,0],[0,1,0]") == [[1, 0, 0], [0, 1, 0]]
    assert parse_value("Radau") == "Radau" and parse_value("7") == 7 and parse_value("7.") == 7.0
    assert parse_spec("loguniform:1e9:1e11") == Distribution("loguniform", 1e9, 1e11)
    for bad in ("lin:0:1", "log:0:1:3", "uniform:2:1", "normal:0:-1", "lin:a:b:3", "uniform:1"):
        with pytest.raises(FlexmbError):
            parse_spec(bad)


def test_grid_order_and_case_ids(scene_file):
    cases = _study(scene_file).cases()
    assert len(cases) == 6
    # last parameter fastest
    assert [c["bodies.bar.length"] for c in cases] == [0.5, 0.5, 1.0, 1.0, 2.0, 2.0]
    ids = [case_id(c) for c in cases]
    assert len(set(ids)) == 6 and all(len(i) == 16 for i in ids)
    assert case_id({"a": 1.0, "b": 2}) == case_id({"b": 2, "a": 1.0})
