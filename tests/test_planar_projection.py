"""CVODE's projection onto the loops on 3-vectors (flexmb.kernels.planar_projection) against the spatial one.

Each planar model is built twice, as it takes the planar path (the
default) and with ``planar=False``;
:func:`flexmb.kernels.step_projection.step_projection` (the dispatch
``cvode_loop_callbacks.project`` calls) must decide the same (kept, moved,
refused) at states perturbed off the constraints along a short run
(positions only, speeds only, both; 1e-7 to 1e-4), with the same residuals
and the same projected positions and speeds to round-off: B6 damped (N =
8, 32), B7 (N = 4, 40) and the planar four-bar.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import flexmb as fm
from flexmb.kernels.packing import is_planar, unpack, unpack_planar
from flexmb.kernels.planar_loops import HANDOFF
from flexmb.kernels.planar_projection import planar_step_projection
from flexmb.kernels.step_projection import MOVED, step_projection
from flexmb.scenes.fourbar import fourbar

DATA = Path(__file__).resolve().parent / "data"
sys.path.insert(0, str(DATA))
sys.path.insert(0, str(DATA.parent.parent / "benchmarks"))
pytest.importorskip("scenes")

import make_loop_projection_runs as ref  # noqa: E402
import scenes  # noqa: E402


def _b6(n):
    model, positions = scenes.b6(damped=True, n_segments=n)
    return model, dict(positions=positions, rtol=3e-3, atol=3e-5)


def _b7(n):
    model, initial = scenes.b7(n)
    return model, dict(initial, rtol=1e-6, atol=1e-8)


def _fourbar():
    model, initial, fixed = fourbar()
    return model, dict(positions=initial, fixed=fixed, rtol=1e-6, atol=1e-8)


MODELS = {"b6_8": lambda: _b6(8), "b6_32": lambda: _b6(32), "b7_4": lambda: _b7(4), "b7_40": lambda: _b7(40),
          "fourbar": _fourbar}
#: the agreement asked, relative to the state's largest coordinate and speed (at least 1)
AGREE = {"b6_32": 1e-11}


def _args(cb, ud, t):
    """step_projection's arguments after the state, as ``cvode_loop_callbacks._step_projection`` makes them."""
    nd = int(ud[cb.N_DRV])
    real = cb._f1(ud[cb.A_REAL], cb.N_REAL)
    drv = cb._drivers(ud)
    cols = np.array([int(drv[k, 0]) for k in range(nd)], dtype=np.int64)
    p_d = np.array([cb.driver(drv, k, t)[0] for k in range(nd)])
    v_d = np.array([cb.driver(drv, k, t)[1] for k in range(nd)])
    return (int(ud[cb.N]), cols, p_d, v_d, real[cb.R_PROJ_TOL], real[cb.R_NEWTON_TOL], real[cb.R_GAIN],
            real[cb.R_TOL], real[cb.R_WINDOW], ud[cb.RANK_LIMIT])


@pytest.fixture(scope="module", params=sorted(MODELS))
def pair(request):
    """The solver's user_data of the planar and the spatial build, and perturbed states along a short run."""
    model, kw = MODELS[request.param]()
    planar = model.build(complement="articulated")
    spatial = model.build(complement="articulated", planar=False)
    assert planar.planar and is_planar(planar._packed) and not is_planar(spatial._packed)
    got = ref.captured(planar, kw), ref.captured(spatial, kw)
    res = fm.simulate(spatial, 0.05, method="CVODE_BDF", n_out=5, progress=False, **kw)
    return request.param, got, ref.states(res, 7)


def _project(got, t, y):
    cb, ud = got["cb"], got["ud"]
    return step_projection(cb._packed(ud), cb._layout(ud), y, *_args(cb, ud, t))


def test_planar_projection_equals_spatial(pair):
    """The same decision, residuals and projected state, to round-off, at every perturbed state; some move."""
    name, (planar, spatial), (ts, ys) = pair
    tol = AGREE.get(name, 1e-12)
    moved = 0
    for t, y in zip(ts, ys):
        a, b = _project(planar, t, y), _project(spatial, t, y)
        n = len(a[3])
        assert a[0] == b[0]
        assert abs(a[1] - b[1]) <= tol * max(1.0, np.max(abs(y[:n])))
        assert abs(a[2] - b[2]) <= tol * max(1.0, np.max(abs(y[n:2 * n])))
        assert np.max(abs(a[3] - b[3])) <= tol * max(1.0, np.max(abs(y[:n])))
        assert np.max(abs(a[4] - b[4])) <= tol * max(1.0, np.max(abs(y[n:2 * n])))
        moved += a[0] == MOVED
    assert moved >= len(ts) // 2


def test_the_dispatch_takes_the_planar_path(pair):
    """step_projection on a planar model is planar_step_projection's to the bit (none handed back here)."""
    name, (planar, _), (ts, ys) = pair
    cb, ud = planar["cb"], planar["ud"]
    packed = cb._packed(ud)
    ints, floats = unpack_planar(packed)
    tree = unpack(packed)[0]
    for t, y in list(zip(ts, ys))[::3]:
        direct = planar_step_projection(tree, ints, floats, tree.coord_body, cb._layout(ud), y, *_args(cb, ud, t))
        assert direct[0] != HANDOFF
        got = _project(planar, t, y)
        assert direct[:3] == got[:3]
        np.testing.assert_array_equal(direct[3], got[3])
        np.testing.assert_array_equal(direct[4], got[4])
