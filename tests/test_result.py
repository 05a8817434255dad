"""Results are saved without loss (:meth:`flexmb.Result.save`, :meth:`flexmb.Result.load`)."""

from __future__ import annotations

import pathlib

import attrs
import numpy as np

import flexmb as fm

TUTORIALS = pathlib.Path(__file__).resolve().parents[1] / "tutorials"


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
