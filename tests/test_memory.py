"""Memory estimates (:mod:`flexmb.memory`): too large a model or output is refused before anything is allocated.

Issue 18 section 3: ``n_segments = 100000`` raised an uncaught MemoryError
(74.5 GiB requested in ``topology.py``), and ``n_out = 1e8`` grew without
limit. The estimate works from counts; the reference values below come from
the formula in the module docstring.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np
import pytest

import flexmb as fm
from flexmb import memory
from flexmb.memory import Counts

SECTION = fm.Section.rectangular(0.02, 0.005)


def beam_model(n_segments, keep=("bend_y", "bend_z", "torsion")):
    model = fm.Model("beam")
    beam = fm.FlexibleBody("beam", 1.0, SECTION, fm.Material.aluminium(), n_segments=n_segments, keep=keep)
    model.add(beam, fm.Fixed("clamp", model.ground, beam), fm.Gravity((0.0, 0.0, -9.81)))
    return model


def pendulum():
    model = fm.Model("pendulum")
    bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0.0, -9.81, 0.0)))
    return model


def test_counts_from_definitions_match_the_built_system():
    for n_seg, keep in ((4, ("bend_y",)), (6, ("bend_y", "bend_z", "torsion"))):
        model = beam_model(n_seg, keep)
        c = memory.counts(model)
        system = model.build()
        # clamp frame + segments; the Fixed joint has no coordinates
        assert c == memory.counts(system) == Counts(n_seg + 1, n_seg * len(keep), 0)


def test_counts_of_a_loop_bound_the_constraint_rows():
    from conftest import fourbar

    model = fourbar()
    c, system = memory.counts(model), model.build()
    assert c.n_bodies == system.topology.n_bodies
    assert c.n_coords >= system.n_coords and c.n_rows >= system.n_constraints


def test_estimate_follows_the_documented_formula():
    nb, n, m, nt = 11, 30, 2, 7
    expected = (8 * (memory.DENSE_NN * n * n + memory.DENSE_MN * m * n) + memory.PER_BODY * nb
                + memory.PER_COORD * n
                + 8 * nt * (memory.OUTPUT_N * n + memory.OUTPUT_B * nb + m + memory.OUTPUT_FIXED))
    assert memory.estimate(Counts(nb, n, m), n_out=nt) == expected


def test_huge_flexible_body_is_refused_before_allocation(monkeypatch):
    """n_segments = 100000 gave an uncaught MemoryError (exit 1) after trying to allocate 74.5 GiB."""
    model = beam_model(100_000)
    if memory.estimate(model) > memory.limit():  # today's dense arrays: terabytes
        t = time.perf_counter()
        with pytest.raises(fm.ModelError, match=r"needs about [\d.]+ [TG]iB of memory .*100,001 bodies after "
                                                r"segmenting, 300,000 coordinates.* is available") as info:
            model.build()
        assert time.perf_counter() - t < 5.0
        assert "Model 'beam' is invalid" in str(info.value)
    # machine-independent (and core-independent: 100,001 segment objects alone need more)
    monkeypatch.setenv("FLEXMB_MEMORY_LIMIT", "64M")
    with pytest.raises(fm.ModelError, match=r"Model 'beam' is invalid:\n  - needs about .* but 64 MiB is available"):
        model.build()
    with pytest.raises(fm.ModelError, match=r"Model 'beam': needs about"):
        from flexmb.system import System

        System(model)


def test_simulate_refuses_outputs_that_cannot_fit(monkeypatch):
    """n_out = 1e8 grew without limit."""
    monkeypatch.setenv("FLEXMB_MEMORY_LIMIT", "8G")  # 1e8 output times need more, whatever the machine
    with pytest.raises(fm.ModelError, match=r"simulate: needs about [\d.]+ GiB of memory \([\d.]+ GiB for "
                                            r"100,000,000 output times"):
        fm.simulate(pendulum(), 1.0, n_out=1e8)
    monkeypatch.setenv("FLEXMB_MEMORY_LIMIT", "1M")
    with pytest.raises(fm.ModelError, match=r"for 100,000 output times.* but 1 MiB is available"):
        fm.simulate(pendulum(), 1.0, n_out=100_000)
    assert fm.simulate(pendulum(), 0.1, n_out=11).status == "finished"


@pytest.mark.parametrize("text, expected", [("2G", 2 * 2**30), ("1500", 1500), ("0.5M", 2**19), ("3 GiB", 3 * 2**30)])
def test_memory_limit_environment_variable(monkeypatch, text, expected):
    monkeypatch.setattr(memory, "available", lambda: 2**50)
    monkeypatch.setenv("FLEXMB_MEMORY_LIMIT", text)
    assert memory.limit() == expected
    monkeypatch.setenv("FLEXMB_MEMORY_LIMIT", "lots")
    with pytest.raises(fm.ModelError, match=r"FLEXMB_MEMORY_LIMIT must be a size"):
        memory.limit()


def test_available_is_positive():
    assert memory.available() > 0


SCENE = """
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
n_segments = {n}

[joints.clamp]
type = "fixed"
parent = "ground"
child = "beam"

[solver]
t_end = 0.01
n_out = {n_out}
"""


@pytest.mark.parametrize("command", ["info", "run"])
def test_cli_refuses_a_huge_scene_with_exit_3(tmp_path, command):
    """`flexmb info` of 10,000 segments reached 10 GB RSS; 100,000 crashed with a MemoryError (exit 1)."""
    path = tmp_path / "huge.toml"
    path.write_text(SCENE.format(n=100_000, n_out=11))
    args = [sys.executable, "-m", "flexmb", command, str(path)] + (["--out", str(tmp_path / "o")]
                                                                  if command == "run" else [])
    env = dict(os.environ, FLEXMB_MEMORY_LIMIT="256M")  # too little for 100,001 segments, whatever the core
    proc = subprocess.run(args, capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 3, proc.stderr  # an input error
    assert "MemoryError" not in proc.stderr and "Traceback" not in proc.stderr
    assert "flexmb: error: " in proc.stderr and "needs about" in proc.stderr and "is available" in proc.stderr
    assert "huge.toml: bodies.beam.n_segments: Model 'huge': needs about" in proc.stderr


def test_scene_refuses_outputs_that_cannot_fit(monkeypatch):
    monkeypatch.setenv("FLEXMB_MEMORY_LIMIT", "8G")
    with pytest.raises(fm.SceneError, match=r"huge.toml: solver.n_out: 100000000 output times: needs about"):
        fm.loads_scene(SCENE.format(n=2, n_out=100_000_000), "huge.toml")


def test_loops_closed_through_the_recursion_need_no_n_squared(monkeypatch):
    """B6 with 5,000 segments: the dense complement's n x n arrays (about 0.8 GB) refused under a 500 MB
    limit; the same model built with complement='articulated' or 'auto' (no n x n array) fits."""
    import os
    import sys

    sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
    import scenes

    nb, n, m = 11, 30, 2
    assert memory.estimate(Counts(nb, n, m), loops="articulated") == (
        8 * memory.LOOP_MN * m * n + memory.PER_BODY * nb + memory.PER_COORD * n)
    model, _ = scenes.b6(True, 5000)
    assert memory.estimate(model, loops="dense") > 500 * 2**20 > 10 * memory.estimate(model, loops="articulated")
    monkeypatch.setenv("FLEXMB_MEMORY_LIMIT", "500M")
    with pytest.raises(fm.ModelError, match=r"needs about .* for the dense arrays of the loops"):
        model.build()
    for strategy in ("articulated", "auto"):
        assert model.build(complement=strategy).n_coords == 5002
    with pytest.raises(ValueError, match="loops must be one of"):
        memory.estimate(model, loops="sparse")
