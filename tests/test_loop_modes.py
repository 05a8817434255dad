"""The lowest modes of a looped model without a dense eigenproblem (flexmb.analysis.loop_modes).

What is checked
---------------
* On every looped model of the tests closed by the articulated strategy
  (planar four-bar, the four-bar with a spatial revolute cut, Bricard's
  linkage, the flexible wiper, B6 with 8 and 64 segments, B7 with N = 4
  and 40 and with spatial cuts), at the assembled state: the eigenvalues
  ``w^2`` and mode shapes of both routes (a basis of the whole tangent
  space for small p, preconditioned Davidson iteration for large p) equal
  those of the dense linearisation (:func:`flexmb.linearize`, T from the
  SVD of psi). Both difference the accelerations (h = 1e-6) along other
  directions, so they agree to the differences' noise, not to round-off:
  1e-7 of the largest eigenvalue found (B6 N = 64: the dense path's
  lowest eigenvalue is itself 2.4e-8 off the exact one, below).
* B6 at rest (no gravity, no constraint force): the stiffness is exactly
  that of the rod's segment springs, ``K = T^T K_d T``; Davidson gives its
  eigenvalues (an independent formulation) to 1e-8, the basis route to
  1e-7.
* B6 with its rod under an axial load (gravity along it; the constraint
  forces' geometric stiffness, which the preconditioner lacks), loaded
  below and beyond buckling (a negative eigenvalue, found as the lowest):
  Davidson equals the dense path to 1e-8 of the largest eigenvalue.
* :func:`flexmb.modes` takes the sparse path by itself past
  SPARSE_MODES_MIN coordinates with a number of modes asked for, and
  its result equals the dense one there; with a Linearization, the dense
  path.
* A state that is not an equilibrium (a bent rod: a stiffness that is not
  symmetric) is refused by Davidson with a message naming the dense path.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest
import scipy.linalg as sla

import flexmb as fm
from conftest import fourbar, fourbar_initial
from flexmb.analysis import loop_modes as lm
from flexmb.simulate import _calibrated

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "benchmarks"))

import scenes  # noqa: E402
import test_hard_cases as hc  # noqa: E402


def _wiper():
    pytest.importorskip("flexmb_friction")
    from flexmb.scenes.wiper import WiperOptions, wiper

    model, positions = wiper(WiperOptions(flexible=True, n_segments=6))
    return model, {"positions": positions}


MODELS = {
    "fourbar": lambda: (fourbar(), {"positions": fourbar_initial()}),
    "fourbar_revolute_cut": lambda: (fourbar(fm.Revolute), {"positions": fourbar_initial()}),
    "bricard": lambda: (hc.bricard(), {}),
    "wiper": _wiper,
    "b6_8": lambda: (lambda m, i: (m, {"positions": i}))(*scenes.b6(True, 8)),
    "b6_64": lambda: (lambda m, i: (m, {"positions": i}))(*scenes.b6(True, 64)),
    "b7_4": lambda: scenes.b7(4),
    "b7_40": lambda: scenes.b7(40),
    "b7_4_spatial_cuts": lambda: scenes.b7(4, planar_cuts=False),
}


def _assembled(name):
    model, initial = MODELS[name]()
    system = model.build(complement="articulated")
    x, xd = fm.initial_state(system, 0.0, **initial)
    return _calibrated(system, 0.0, x, xd), x


def _dense(system, x):
    lin = fm.linearize(system.with_complement("svd"), x)  # T from psi's SVD (the articulated one: p solves)
    w2, phi = sla.eigh(0.5 * (lin.K + lin.K.T), lin.M)
    return w2, lin.T @ phi, lin


def _same_shapes(a, b, tol):
    """Columns equal up to scale and sign (where two entries tie for the largest, the normalisation may differ)."""
    for u, v in zip(a.T, b.T):
        u, v = u / np.linalg.norm(u), v / np.linalg.norm(v)
        assert min(np.max(np.abs(u - v)), np.max(np.abs(u + v))) < tol


@pytest.mark.parametrize("name", sorted(MODELS))
def test_both_routes_equal_the_dense_modes(name, monkeypatch):
    system, x = _assembled(name)
    w2_dense, shapes, lin = _dense(system, x)
    p = lin.T.shape[1]
    scale = np.max(np.abs(w2_dense))
    ops = lm.LoopModes(system, x, np.zeros(system.n_speeds), 0.0, 1e-6)
    w2, v = ops.subspace(p)
    assert p == system.dof(0.0, x) and ops.n_rhs == 2 * p
    np.testing.assert_allclose(w2, w2_dense, rtol=0, atol=1e-7 * scale)
    np.testing.assert_allclose(system.constraints.evaluate(system.kinematics(0.0, x, np.zeros(system.n_speeds)),
                                                           level=1).psi @ v, 0.0, atol=1e-9 * np.abs(v).max())
    k = 6
    if p > max(lm.SUBSPACE_MAX, 4 * (k + 2)):  # Davidson
        w2, v = ops.lowest(k)
        np.testing.assert_allclose(w2, w2_dense[:k], rtol=0, atol=1e-7 * scale)
        _same_shapes(v, shapes[:, :k], 1e-5)


@pytest.mark.parametrize("n_segments", [8, 64])
def test_b6_at_rest_equals_its_segment_springs(n_segments):
    model, positions = scenes.b6(False, n_segments)
    system = model.build(complement="articulated")
    x, xd = fm.initial_state(system, 0.0, positions=positions)
    system = _calibrated(system, 0.0, x, xd)
    ops = lm.LoopModes(system, x, np.zeros(system.n_speeds), 0.0, 1e-6)
    lin = fm.linearize(system, x)
    exact = sla.eigh(lin.T.T @ np.diag(ops.stiffness) @ lin.T, lin.M, eigvals_only=True)
    k = 6
    if lin.T.shape[1] > lm.SUBSPACE_MAX:
        np.testing.assert_allclose(ops.lowest(k)[0], exact[:k], rtol=1e-8)
    np.testing.assert_allclose(ops.subspace(lin.T.shape[1])[0][:k], exact[:k], rtol=1e-7)
    assert exact[0] == pytest.approx((2 * np.pi * scenes.b6_rod_frequency()) ** 2, rel=1e-2)


def test_modes_takes_the_sparse_path_past_its_size(monkeypatch):
    model, positions = scenes.b6(True, 256)
    system = model.build(complement="articulated")
    x, xd = fm.initial_state(system, 0.0, positions=positions)
    system = _calibrated(system, 0.0, x, xd)
    assert system.n_speeds >= lm.SPARSE_MODES_MIN
    calls = []
    real = lm.LoopModes.lowest
    monkeypatch.setattr(lm.LoopModes, "lowest", lambda self, *a: calls.append(a) or real(self, *a))
    f, shapes = fm.modes(system, 3, x0=x)
    assert len(calls) == 1 and shapes.shape == (system.n_speeds, 3)
    w2, dense_shapes, lin = _dense(system, x)
    np.testing.assert_allclose((2 * np.pi * f) ** 2, w2[:3], rtol=0, atol=1e-7 * np.max(np.abs(w2)))
    _same_shapes(shapes, dense_shapes[:, :3], 1e-5)
    f_all, _ = fm.modes(lin, 3)  # a Linearization: the dense path
    np.testing.assert_allclose(f, f_all, rtol=1e-6)
    assert len(calls) == 1


def test_a_state_off_equilibrium_is_refused():
    model, positions = scenes.b6(False, 64)
    system = model.build(complement="articulated")
    x, _ = fm.initial_state(system, 0.0, positions=positions)
    rng = np.random.default_rng(3)
    x = x + 0.05 * rng.normal(size=x.shape)
    x, _ = fm.initial_state(system, 0.0, positions=dict(zip(system.coordinate_names, x)))
    ops = lm.LoopModes(system, x, np.zeros(system.n_speeds), 0.0, 1e-6)
    with pytest.raises(fm.ModelError, match="Davidson .*not an equilibrium.*the dense path"):
        ops.lowest(4)


@pytest.mark.parametrize("g", [2e4, 3e5])
def test_a_loaded_rod_below_and_beyond_buckling_equals_the_dense_modes(g):
    """B6 with its rod under an axial load (gravity along it): the constraint forces' stiffness changes the modes."""
    model, positions = scenes.b6(False, 64)
    model.add(fm.Gravity((-g, 0.0, 0.0)))
    system = model.build(complement="articulated")
    x, xd = fm.initial_state(system, 0.0, positions=positions)
    system = _calibrated(system, 0.0, x, xd)
    assert np.max(np.abs(system.accelerations(0.0, x, np.zeros(system.n_speeds)))) == 0.0  # an equilibrium
    w2_dense, _, _ = _dense(system, x)
    w2, _ = lm.loop_modes(system, 6, x, np.zeros(system.n_speeds), 0.0, 1e-6)
    np.testing.assert_allclose(w2, w2_dense[:6], rtol=0, atol=1e-8 * np.max(np.abs(w2_dense[:6])))
    unloaded = (2 * np.pi * scenes.b6_rod_frequency()) ** 2
    assert (w2[0] < 0) == (g > 1e5) and w2[0] < unloaded  # beyond buckling the straight rod is unstable
