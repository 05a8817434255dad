"""Issue 31's probe (benchmarks/probe_b1.py) integrates the same model as flexmb's B1.

An independent formulation: the planar chain's Lagrange equations in
closed form (numba, a hand-written Cholesky solve), its data read from the
built system, against flexmb's ``System.state_rate`` (the general spatial
recursion) at random states, to rounding; and the probe's CVODE run (its
own binding, CVODE's difference-quotient Jacobian) ending where flexmb's
tight run ends.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import flexmb as fm

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
sys.path.insert(0, BENCH)

import probe_b1  # noqa: E402
import scenes  # noqa: E402


@pytest.mark.parametrize("n", [4, 8])
@pytest.mark.parametrize("damped", [True, False])
def test_probe_rate_equals_state_rate_at_random_states(n, damped):
    system = scenes.b1(n, damped=damped).build()
    p = probe_b1.chain_data(system)
    assert probe_b1.check(system, p, n_states=5, seed=n) <= 1e-12


def test_the_check_fails_on_a_different_chain():
    """The check can fail: the chain with its masses halved differs from flexmb's."""
    system = scenes.b1(4).build()
    p = probe_b1.chain_data(system)
    n = 4
    p[: n * n + n] *= 0.5  # mu and gamma: half the masses
    with pytest.raises(AssertionError, match="differs"):
        probe_b1.check(system, p)


def test_probe_run_ends_at_flexmb_tight_run():
    system = scenes.b1(4).build()
    p = probe_b1.chain_data(system)
    out = probe_b1.probe_run(p, 4, np.array([0.0, 0.5, 1.0]), 1e-9, 1e-11)
    res = fm.simulate(system, 1.0, method="CVODE_BDF", rtol=1e-9, atol=1e-11, n_out=3, progress=False)
    beam = next(iter(system.topology.flexible))
    for k in (1, 2):
        tip = system.shape(beam, out["y"][k - 1, :4])[-1]
        assert np.linalg.norm(tip - res.shape("beam")[k, -1]) <= 1e-8
    assert out["steps"] > 0 and out["rhs_calls"] == out["rhs"] + out["rhs_dq"]
