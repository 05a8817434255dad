"""The study of the tests in this folder: a pinned slender bar released from rest, with its closed form.

The study scene is a uniform slender bar (mass m, length L) pinned at one end
and released from rest at angle q0 above the horizontal, under gravity g. Energy
conservation gives its tip speed at the bottom, the peak over the swing,

    v_tip = L omega,  omega^2 = 3 g (1 + sin q0) / L,

independent of m: the reference the study's outputs are checked against.
The same 6 cases run serially, on the local process pool and on a real
``dask.distributed.LocalCluster`` (2 worker processes on loopback) and must
give the same table.
"""

from __future__ import annotations

import numpy as np
import pytest

from flexmb.study import Study

G = 9.81

PENDULUM = """
[model]
name = "pendulum"

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

[initial]
positions = { pin = 0.0 }
speeds = { pin = 0.0 }

[solver]
t_end = 1.0
rtol = 1e-8
n_out = 1001

[output.points.tip]
body = "bar"
point = [1.0, 0.0, 0.0]
"""

OUTPUTS = ["peak_speed:tip", "final:pin", "energy_balance", "n_rhs"]
LENGTHS = [0.5, 1.0, 2.0]  # with 2 release angles: 6 cases, each reaching the bottom before t = 1 s


def _study(scene_file, **kw):
    kw.setdefault("outputs", OUTPUTS)
    return Study.from_file(scene_file, {"bodies.bar.length": LENGTHS, "initial.positions.pin": [0.0, np.pi / 6]},
                           fixed={"solver.t_end": 1.0}, **kw)


def _comparable(result):
    """The table without the columns that depend on the machine (wall time, worker)."""
    return [[c for c, name in zip(cells, result.columns) if name not in ("wall_time_s", "worker")]
            for cells in result.table()]


def _assert_same_table(a, b):
    """Same columns, same rows, same text cells, floats equal to 1e-12 (relative)."""
    assert a.columns == b.columns
    ta, tb = _comparable(a), _comparable(b)
    assert len(ta) == len(tb)
    for ra, rb in zip(ta, tb):
        for x, y in zip(ra, rb):
            if isinstance(x, float):
                assert x == pytest.approx(y, rel=1e-12, abs=1e-300)
            else:
                assert x == y


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("scene") / "pendulum.toml"
    path.write_text(PENDULUM)
    return path


@pytest.fixture(scope="module")
def serial(scene_file, tmp_path_factory):
    return _study(scene_file).run(tmp_path_factory.mktemp("serial"), executor="serial", progress=False)
