"""The planar loops' right-hand side (flexmb.kernels.planar_loops) against the spatial one, and its dispatch.

Each planar model is built twice, as it takes the planar path (the
default) and with ``planar=False``; :func:`flexmb.kernels.loops.loop_rhs`
(the dispatch every caller goes through) must give the same
accelerations and reactions to round-off (relative to the largest), the
same rank and status, at the assembled state and at random states on the
constraints: B6 damped (N = 8, 32), B7 (N = 4, 40, also at a flat,
singular position where the rank filter drops rows) and the planar
four-bar. Models that are not planar (the four-bar closed by a spatial
revolute, Bricard, the wiper) keep the spatial path. Whole runs of B6
(CVODE_BDF and generalized-alpha, the compiled loops) agree with their
spatial twins to the run's tolerance.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import flexmb as fm
from flexmb.kernels.loops import loop_rhs, loop_rhs_factors_into, loop_rhs_work_size
from flexmb.kernels.packing import is_planar, unpack_planar
from flexmb.kernels.planar_loops import HANDOFF, planar_loop_rhs_into, planar_loop_work_size
from flexmb.scenes.fourbar import fourbar
from flexmb.simulate import _calibrated

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "benchmarks"))

import scenes  # noqa: E402
import test_hard_cases as hc  # noqa: E402


def _b6(n):
    model, initial = scenes.b6(damped=True, n_segments=n)
    return model, {"positions": initial}


def _fourbar():
    model, initial, fixed = fourbar()
    return model, {"positions": initial, "fixed": fixed}


MODELS = {"b6_8": lambda: _b6(8), "b6_32": lambda: _b6(32), "b7_4": lambda: scenes.b7(4),
          "b7_40": lambda: scenes.b7(40), "fourbar": _fourbar}
#: the agreement asked, relative to the largest acceleration and reaction (the spatial path's round-off grows with N)
AGREE = {"b6_32": 1e-11}


@pytest.fixture(scope="module", params=sorted(MODELS))
def pair(request):
    """The model built on the planar path and on the spatial one, calibrated at the assembled state."""
    model, initial = MODELS[request.param]()
    planar = model.build(complement="articulated")
    spatial = model.build(complement="articulated", planar=False)
    assert planar.planar and is_planar(planar._packed)
    assert not spatial.planar and not is_planar(spatial._packed)
    x, xd = fm.initial_state(planar, 0.0, **initial)
    return request.param, _calibrated(planar, 0.0, x, xd), _calibrated(spatial, 0.0, x, xd), x, xd


def _rhs(system, t, x, xd, window=None):
    """``loop_rhs`` as the system calls it: (xdd, lam, kept, smallest, status)."""
    n = system.n_speeds
    zeros = np.zeros((system.topology.n_bodies + 1, 3))
    gamma_d = np.array([d.acceleration(t) for d in system.constraints.drivers], dtype=float)
    rank_limit = -1 if system._rank_limit is None else system._rank_limit
    return loop_rhs(system._packed, system._loop_layout, np.concatenate([x, xd]), n, np.zeros(0), zeros, zeros,
                    np.zeros(n), gamma_d, system._loop_tol, system.singular_window() if window is None else window,
                    rank_limit)


def _consistent_states(system, x0, xd0, k=4, seed=3):
    """k states on the constraints: random positions and speeds near the assembled ones, projected, at times t."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(k):
        t = 0.05 * (i + 1)
        x = x0 + 0.05 * rng.normal(size=x0.shape)
        xd = xd0 + rng.normal(size=xd0.shape)
        out.append((t, *system.project(t, x, xd, speeds="mass")))
    return out


def _term_scale(system, t, x, xd, xdd):
    """The largest of the accelerations and of the open tree's ``a0 = A^-1 f`` (dense: A, f of the spatial system).

    The accelerations are ``a0`` plus the constraints' response, and much
    smaller than either where they balance (B7 moves slowly against
    gravity): the round-off of either path is relative to these terms.
    """
    A, f, _, _ = system.reduced_parts(t, np.concatenate([x, xd]))
    return max(np.max(abs(xdd)), np.max(abs(np.linalg.solve(A, f))))


def test_planar_equals_spatial_at_consistent_states(pair):
    """Accelerations relative to the terms' largest (:func:`_term_scale`), reactions to their largest, over the states."""
    name, planar, spatial, x0, xd0 = pair
    tol = AGREE.get(name, 1e-12)
    states = [(0.0, x0, xd0), *_consistent_states(spatial, x0, xd0)]
    pairs = [(_rhs(planar, t, x, xd), _rhs(spatial, t, x, xd)) for t, x, xd in states]
    xdd_scale = max(_term_scale(spatial, *state, b[0]) for state, (_, b) in zip(states, pairs))
    lam_scale = max(np.max(abs(b[1])) for _, b in pairs)
    for a, b in pairs:
        assert a[4] == b[4] == 0
        assert a[2] == b[2]
        assert np.max(abs(a[0] - b[0])) <= tol * xdd_scale
        assert np.max(abs(a[1] - b[1])) <= tol * lam_scale
        assert abs(a[3] - b[3]) <= 1e-10 * b[3]


def test_the_dispatch_takes_the_planar_path(pair):
    """loop_rhs on a planar model is planar_loop_rhs_into's to the bit; the spatial twin's is the spatial kernel's."""
    name, planar, spatial, x0, xd0 = pair
    n, m, nb = planar.n_speeds, planar.n_constraints, planar.topology.n_bodies
    assert planar_loop_work_size(nb, n, m) <= loop_rhs_work_size(nb, n, m)
    t, x, xd = _consistent_states(spatial, x0, xd0, k=1)[0]
    y = np.concatenate([x, xd])
    gamma_d = np.array([d.acceleration(t) for d in planar.constraints.drivers], dtype=float)
    rank_limit = -1 if planar._rank_limit is None else planar._rank_limit
    xdd, lam = np.empty(n), np.empty(m)
    ints, floats = unpack_planar(planar._packed)
    kept, smallest, status = planar_loop_rhs_into(ints, floats, planar.topology.arrays.coord_body, planar._loop_layout,
                                                  y, n, np.zeros(n), gamma_d, planar._loop_tol,
                                                  planar.singular_window(), rank_limit, xdd, lam,
                                                  np.full(loop_rhs_work_size(nb, n, m), np.nan))
    got = _rhs(planar, t, x, xd)
    assert (kept, status) == (got[2], got[4]) and smallest == got[3]
    np.testing.assert_array_equal(got[0], xdd)
    np.testing.assert_array_equal(got[1], lam)
    zeros = np.zeros((nb + 1, 3))
    out = np.empty(n), np.empty(m)
    loop_rhs_factors_into(spatial._packed, spatial._loop_layout, y, n, np.zeros(0), zeros, zeros, np.zeros(n),
                          gamma_d, spatial._loop_tol, spatial.singular_window(), rank_limit, *out,
                          np.empty(loop_rhs_work_size(nb, n, m)))
    spat = _rhs(spatial, t, x, xd)
    np.testing.assert_array_equal(spat[0], out[0])
    np.testing.assert_array_equal(spat[1], out[1])


def _b7_flat(n_loops, offset):
    """B7 on the planar and the spatial path, calibrated, and a state with every rod at pi / 2 + offset."""
    model, initial = scenes.b7(n_loops)
    planar = model.build(complement="articulated")
    spatial = model.build(complement="articulated", planar=False)
    x0, xd0 = fm.initial_state(spatial, 0.0, **initial)
    planar, spatial = _calibrated(planar, 0.0, x0, xd0), _calibrated(spatial, 0.0, x0, xd0)
    theta = np.pi / 2 + offset
    names = spatial.coordinate_names
    x = np.array([theta if c.startswith("pin") else -theta for c in names])
    xd = np.array([-1.0 if c.startswith("pin") else 1.0 for c in names])
    return planar, spatial, x, xd


@pytest.mark.parametrize("window", [0.0, None])
def test_b7_at_a_flat_singular_position(window):
    """N = 4, rods flat: each loop's rows along the rods vanish; K's eigenvalues drop them, in both paths alike."""
    planar, spatial, x, xd = _b7_flat(4, 0.0)
    a, b = _rhs(planar, 0.0, x, xd, window), _rhs(spatial, 0.0, x, xd, window)
    assert a[4] == b[4] == 0
    assert a[2] == b[2] == spatial.n_constraints // 2
    assert np.max(abs(a[0] - b[0])) <= 1e-12 * _term_scale(spatial, 0.0, x, xd, b[0])
    assert np.max(abs(a[1] - b[1])) <= 1e-12 * np.max(abs(b[1]))


@pytest.mark.parametrize("offset", [0.0, 1e-4, 1e-3])
def test_b7_40_near_its_flat_position(offset):
    """N = 40 (K factored as L D L^T) at and near the flat position: the same rows kept; near it the same solution.

    Near it both paths' round-off is amplified by 1 / smallest (the
    smallest mass-weighted singular value, ~1.2 offset): asked to agree
    within 1e-14 / smallest of the terms. At the flat position itself the
    rows along the rods vanish, which the relative pivot ``d_j / K_jj`` of
    :func:`~flexmb.kernels.constraint_matrix._band_ldl` does not see (both
    paths keep every row, the smallest pivot at round-off size): the
    accelerations there are round-off of either path, not compared.
    """
    planar, spatial, x, xd = _b7_flat(40, offset)
    a, b = _rhs(planar, 0.0, x, xd), _rhs(spatial, 0.0, x, xd)
    assert a[4] == b[4] == 0
    assert a[2] == b[2]
    assert abs(a[3] - b[3]) <= 1e-10 * b[3] + 1e-15
    if offset:
        scale = _term_scale(spatial, 0.0, x, xd, b[0])
        assert np.max(abs(a[0] - b[0])) <= 1e-14 / b[3] * scale


@pytest.mark.parametrize("name", ["fourbar_revolute_cut", "bricard", "wiper"])
def test_models_that_are_not_planar_keep_the_spatial_path(name):
    if name == "wiper":
        pytest.importorskip("flexmb_friction")
        from flexmb.scenes.wiper import WiperOptions, wiper

        model = wiper(WiperOptions(flexible=True, n_segments=6))[0]
    elif name == "bricard":
        model = hc.bricard()
    else:
        model = fourbar(spatial=True)[0]
    system = model.build(complement="articulated")
    assert not system.planar and not is_planar(system._packed)


def test_a_massless_freedom_is_handed_to_the_spatial_path():
    """A beam on a driven hub about its root bending axis: A singular, the driver fixes it (the spatial path lifts)."""
    model = fm.Model("driven hub")
    beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.steel(), 4,
                           keep=("bend_z",))
    hub = fm.Revolute("hub", model.ground, beam, axis=(0, 0, 1))
    model.add(hub, fm.Driver.constant_speed("spin", hub, speed=2.0))
    planar = model.build(complement="articulated")
    spatial = model.build(complement="articulated", planar=False)
    assert planar.planar
    n, m, nb = planar.n_speeds, planar.n_constraints, planar.topology.n_bodies
    x, xd = np.full(n, 0.01), np.full(n, 0.5)
    ints, floats = unpack_planar(planar._packed)
    out = np.empty(n), np.empty(m)
    status = planar_loop_rhs_into(ints, floats, planar.topology.arrays.coord_body, planar._loop_layout,
                                  np.concatenate([x, xd]), n, np.zeros(n), np.zeros(m), planar._loop_tol, 0.0, -1,
                                  *out, np.empty(loop_rhs_work_size(nb, n, m)))[2]
    a, b = _rhs(planar, 0.0, x, xd, 0.0), _rhs(spatial, 0.0, x, xd, 0.0)
    if status == HANDOFF:  # the spatial path's numbers, to the bit
        np.testing.assert_array_equal(a[0], b[0])
    else:  # the joint inertia is not at round-off size in the plane: the planar path solves it
        assert np.max(abs(a[0] - b[0])) <= 1e-10 * max(np.max(abs(b[0])), 1.0)
    assert a[4] == b[4]


@pytest.fixture(scope="module")
def b6_reference():
    """0.05 s of B6 damped N = 8 at rtol 1e-10 (spatial path): the runs' errors are measured against it."""
    model, initial = scenes.b6(damped=True, n_segments=8)
    system = model.build(complement="articulated", planar=False)
    return fm.simulate(system, 0.05, positions=initial, method="CVODE_BDF", rtol=1e-10, n_out=11, progress=False)


@pytest.mark.parametrize("method, rtol", [("CVODE_BDF", 1e-6), ("GeneralizedAlpha", 1e-4)])
def test_a_b6_run_equals_its_spatial_twin(method, rtol, b6_reference):
    """0.05 s of B6 damped N = 8 by the compiled loops (the planar path in CVODE's and generalized-alpha's rhs).

    The two runs take slightly different steps (round-off); they differ by
    less than twice the spatial run's own error (against the reference).
    """
    model, initial = scenes.b6(damped=True, n_segments=8)
    runs = []
    for planar in (None, False):
        system = model.build(complement="articulated", planar=planar)
        runs.append(fm.simulate(system, 0.05, positions=initial, method=method, rtol=rtol, n_out=11,
                                progress=False))
    a, b = runs
    assert a.t[-1] == b.t[-1] == 0.05
    for field in ("x", "xd"):
        error = np.max(abs(getattr(b, field) - getattr(b6_reference, field)))
        assert np.max(abs(getattr(a, field) - getattr(b, field))) <= 2 * error


def test_cvode_with_the_compiled_jtimes_keeps_the_spatial_rhs():
    """B7 N = 40 (81 coordinates: GMRES with the compiled J v, which reads the spatial factors): the same steps."""
    model, initial = scenes.b7(40)
    runs = [fm.simulate(model.build(complement="articulated", planar=planar), 0.2, method="CVODE_BDF", rtol=1e-6,
                        n_out=5, progress=False, **initial) for planar in (None, False)]
    assert runs[0].n_steps == runs[1].n_steps and runs[0].n_rhs == runs[1].n_rhs
    np.testing.assert_array_equal(runs[0].x, runs[1].x)
