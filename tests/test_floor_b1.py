"""The hand-written B1 floor (benchmarks/floor_b1.py) is the same model as flexmb's B1.

An independent formulation: the planar chain's mass matrix and velocity
products in closed form (Lagrange's equations in the absolute angles)
against flexmb's Kane equations of the general spatial machinery. At random
states the accelerations must agree to rounding, the tip positions exactly,
and the damped release from the straight state must end, after 1 s, at
the tip position of flexmb's tight reference.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
sys.path.insert(0, BENCH)

floor = pytest.importorskip("floor_b1")
scenes = pytest.importorskip("scenes")


@pytest.mark.parametrize("n", [4, 8])
@pytest.mark.parametrize("damped", [True, False])
def test_accelerations_equal_flexmb_at_random_states(n, damped):
    system = scenes.b1(n, damped=damped).build()
    chain = floor.model(n, damped=damped)
    assert system.n_coords == n
    rng = np.random.default_rng(n)
    for _ in range(5):
        # large angles (the chain curls over) and fast rates: velocity products matter
        eta, etad = rng.normal(0.0, 0.4, n), rng.normal(0.0, 3.0, n)
        a_fm = system.accelerations(0.0, eta, etad)
        a_fl = chain.accelerations(eta, etad)
        assert np.linalg.norm(a_fl - a_fm) <= 1e-10 * np.linalg.norm(a_fm)


@pytest.mark.parametrize("n", [4, 8])
def test_tip_and_straight_state_jacobian(n):
    system = scenes.b1(n).build()
    chain = floor.model(n)
    beam = next(iter(system.topology.flexible))
    eta = np.random.default_rng(0).normal(0.0, 0.4, n)
    assert np.allclose(chain.tip(eta), system.shape(beam, eta)[-1], rtol=0, atol=1e-14)
    # the constant Jacobian is the derivative of the accelerations at the straight state, at rest
    jac = chain.jacobian0()
    fx = lambda y: chain.rhs(0.0, y)  # noqa: E731
    eps = 1e-6
    num = np.column_stack([(fx(e) - fx(-e)) / (2 * eps) for e in eps * np.eye(2 * n)])
    assert np.allclose(jac, num, rtol=1e-6, atol=1e-6 * np.abs(num).max())


#: B1 tip position at t = 1 s, flexmb's reference of the same N (benchmarks/work_precision.py: Radau,
#: rtol 1e-9, atol 1e-11; its distance to the rtol 1e-8 reference is 8e-13 (N = 4) and 1e-12 (N = 8))
FLEXMB_B1_TIP = {4: np.array([0.9999873407309906, 0.0, -0.00493488970818613]),
                 8: np.array([0.9999705492825168, 0.0, -0.00733234094471377])}


@pytest.mark.parametrize("n", [4, 8])
def test_tip_at_one_second_agrees_with_flexmb_reference(n):
    tip, sol = floor.model(n).simulate("Radau", rtol=1e-7)
    assert sol.t[-1] == 1.0
    # the floor's own integration error at rtol 1e-7 is about 3e-11 m; dropping h^2 from the segments'
    # inertia moves the tip by 1.4e-8 m, a plain spring (k, not 2k) at the clamp by 4e-2 m
    assert np.linalg.norm(tip - FLEXMB_B1_TIP[n]) < 1e-9
    if n == 4:  # and Exudyn's independent value (tests/test_benchmarks_harness.py)
        assert np.linalg.norm(tip - np.array([0.9999873407310742, 0.0, -0.004934889692223662])) < 1e-8
