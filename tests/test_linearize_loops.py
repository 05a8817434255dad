"""The linearisation of looped models without n x n arrays (issue 28 items 2-3).

What is checked
---------------
* On every looped model of the tests closed by the articulated strategy
  (planar four-bar, the four-bar with a spatial revolute cut, Bricard's
  linkage with its redundant row, B6 with 8 segments, B7 with N = 4 and
  40), at rest and moving: :func:`flexmb.linearize` and
  :func:`flexmb.state_space` equal main's dense results (T from psi's SVD;
  tests/data/linearize_loops_reference.npz, written at 2ad8ab4). T's basis
  is arbitrary, so what is compared does not depend on it:
  ``T M^-1 T^T`` and ``T M^-1 F`` to 1e-10 (no differences in them),
  ``T M^-1 K T^T``, ``T M^-1 C T^T``, the poles and the transfer function
  at s = 3j to 1e-8 of their largest entry (K and C difference the
  accelerations along T's columns, a different basis: the differences'
  noise, about 1e-16 / h relative, measured up to 4.5e-9 on B6's C while
  moving), D to 1e-10.
* T has orthonormal columns on the loops' tangent space (``psi T = 0``),
  and as many as the degrees of freedom.
* The dense strategy (``svd``) still takes the dense path and gives the
  same invariants at rest (an independent formulation: its accelerations
  by the dense complement) to 1e-7 (the differences' noise; C against
  ``sqrt`` of K's scale where it vanishes). Not while moving: there the
  differences along T leave the speeds off the loops, which the two
  strategies' accelerations treat differently (the four-bar's K: 0.6 %).
* A coordinate no row holds (a chain with a driven middle joint, built
  with ``articulated``: the loop kernel's path) keeps its own column of
  T and its name in the states, as with ``svd``; poles and static gain
  equal svd's to 1e-8.
"""

from __future__ import annotations

import os
import sys
import warnings

import numpy as np
import pytest

import flexmb as fm

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "data"))

import make_linearize_loops_reference as ref  # noqa: E402

STORED = np.load(os.path.join(HERE, "data", "linearize_loops_reference.npz"))
#: tolerance, relative to the largest entry, per invariant: exact ones, and those from differences
TOL = {"P": 1e-10, "F": 1e-10, "D": 1e-10, "K": 1e-8, "C": 1e-8, "poles": 1e-8, "response": 1e-8}


def _close(name, key, got, want):
    scale = max(float(np.max(np.abs(want))), 1.0 if key == "F" else 1e-300)  # F: accelerations, near 0 at rest
    err = float(np.max(np.abs(got - want))) if want.size else 0.0
    assert err <= TOL[key] * scale, (name, key, err, scale)


@pytest.fixture(scope="module", params=sorted(ref.MODELS))
def case(request):
    return request.param, *ref.case(request.param)


@pytest.mark.parametrize("tag", ["rest", "moving"])
def test_equals_the_dense_linearisation(case, tag):
    name, system, states = case
    x, xd = states[tag]
    np.testing.assert_array_equal(x, STORED[f"{name}/{tag}/x"])
    np.testing.assert_array_equal(xd, STORED[f"{name}/{tag}/xd"])
    got = ref.invariants(system, x, xd)
    for key in TOL:
        _close(name, key, got[key], STORED[f"{name}/{tag}/{key}"])


def test_the_basis_is_orthonormal_on_the_tangent_space(case):
    name, system, states = case
    x, _ = states["rest"]
    lin = fm.linearize(system, x)
    T = lin.T
    psi = system.constraints.evaluate(system.kinematics(0.0, x, np.zeros(system.n_speeds)), level=1).psi
    assert T.shape == (system.n_speeds, system.dof(0.0, x))
    np.testing.assert_allclose(T.T @ T, np.eye(T.shape[1]), rtol=0, atol=1e-13)
    np.testing.assert_allclose(psi @ T, 0.0, rtol=0, atol=1e-10)


def test_the_dense_strategy_agrees_at_rest(case):
    """At rest: moving, K holds how each strategy treats the speeds its differences leave off the loops."""
    name, system, states = case
    x, xd = states["rest"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        got, dense = ref.invariants(system, x, xd), ref.invariants(system.with_complement("svd"), x, xd)
    stiff = float(np.max(np.abs(dense["K"])))
    scales = {"P": float(np.max(np.abs(dense["P"]))), "F": max(float(np.max(np.abs(dense["F"]))), 1.0),
              "K": stiff, "C": max(float(np.max(np.abs(dense["C"]))), np.sqrt(stiff))}
    for key, scale in scales.items():
        assert np.max(np.abs(got[key] - dense[key])) <= 1e-7 * scale, (name, key)


def test_coordinates_no_row_holds_keep_their_names():
    """A chain of three bars hanging (gravity along them), its middle joint held: the other two are the states."""
    model = fm.Model("driven chain")
    bars = [fm.RigidBody.slender_bar(name, 1.0, 1.0) for name in "abc"]
    parents, points = [model.ground, *bars[:2]], [(0, 0, 0), (1, 0, 0), (1, 0, 0)]
    for i, (parent, bar, point) in enumerate(zip(parents, bars, points)):
        model.add(fm.Revolute(f"p{i + 1}", parent, bar, parent_point=point, axis=(0, 0, 1)))
    model.add(fm.Driver.constant_speed("drive", "p2", 0.0), fm.Gravity((9.81, 0.0, 0.0)))
    x0 = np.zeros(3)
    models = {c: model.build(complement=c) for c in ("svd", "articulated")}
    assert models["articulated"]._loop_kernel and not models["svd"]._loop_kernel
    ss = {c: fm.state_space(s, ["p1"], ["p3"], about=(x0, np.zeros(3))) for c, s in models.items()}
    assert ss["articulated"].states == ss["svd"].states == ["p1.angle", "p3.angle", "p1.angle'", "p3.angle'"]
    np.testing.assert_array_equal(np.abs(ss["articulated"].linearization.T), [[1, 0], [0, 0], [0, 1]])
    poles = ss["articulated"].poles()  # by frequency
    assert np.all(np.abs(poles.real) < 1e-6) and np.all(np.abs(poles.imag) > 1.0)  # hanging: it swings
    np.testing.assert_allclose(poles, ss["svd"].poles(), rtol=1e-8)
    np.testing.assert_allclose(ss["articulated"].static_gain(), ss["svd"].static_gain(), rtol=1e-8)
