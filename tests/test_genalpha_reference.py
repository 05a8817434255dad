"""The compiled generalized-alpha step loop reproduces the numpy loop it replaced.

``tests/data/genalpha_reference.npz`` holds the numpy loop's runs (written
by ``tests/data/make_genalpha_reference.py``): oscillators with adaptive,
backward, fixed, ``f_max`` and ``min_step`` steps, a nonlinear pair with a
finite-difference Jacobian and an extra first-order state, cases that
reject steps on the error test and on Newton failures (with a current and
with a stale Jacobian), and ``simulate`` runs (pendulum, B1, the four-bar
with projections and restarts, a driven crank with work records, B6 with
'auto' and with ``f_max``). The counts (steps, right-hand sides, Jacobians,
LU factorisations, Newton iterations, rejections) must be equal, and the
states, dense output and work records equal to 1e-10.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

DATA = Path(__file__).resolve().parent / "data"
sys.path.insert(0, str(DATA))

import make_genalpha_reference as ref  # noqa: E402

REFERENCE = np.load(DATA / "genalpha_reference.npz")
SOLVER_CASES = {case[0]: case[1:] for case in ref.solver_cases()}
SIMULATE_CASES = dict(ref.simulate_cases())


def assert_matches(name, new):
    keys = sorted(k.split("/", 1)[1] for k in REFERENCE if k.startswith(name + "/"))
    assert set(keys) == set(new), "the same quantities exist"
    np.testing.assert_array_equal(new["counts"], REFERENCE[f"{name}/counts"], err_msg=f"{name}: counts")
    for key in keys:
        old = REFERENCE[f"{name}/{key}"]
        assert np.shape(new[key]) == old.shape, f"{name}: {key}"
        scale = max(1.0, float(np.max(np.abs(old)))) if old.size else 1.0
        np.testing.assert_allclose(new[key], old, rtol=1e-10, atol=1e-10 * scale, err_msg=f"{name}: {key}")


@pytest.mark.parametrize("name", sorted(SOLVER_CASES))
def test_solver_matches_numpy_reference(name):
    assert_matches(name, ref.drive(*SOLVER_CASES[name]))


@pytest.mark.parametrize("name", sorted(SIMULATE_CASES))
def test_simulate_matches_numpy_reference(name):
    assert_matches(name, ref.summarise(SIMULATE_CASES[name]()))


@pytest.mark.parametrize("n", [1, 7, 8, 13, 128, 129, 300, 1031, 5000])
def test_mean_sums_as_numpy(n):
    from flexmb.kernels.genalpha import mean

    rng = np.random.default_rng(n)
    a = rng.normal(size=n) ** 2 * 10.0 ** rng.uniform(-8, 8, size=n)
    assert mean(a) == np.mean(a)  # to the bit: the step-size decisions are the numpy loop's


def test_lu_solve_with_row_interchanges():
    from scipy.linalg import lu_factor

    from flexmb.kernels.genalpha import lu_solve

    rng = np.random.default_rng(7)
    S = rng.normal(size=(9, 9))
    S[0, 0] = 1e-9  # pivoting needed
    lu, piv = lu_factor(S)
    assert np.any(piv != np.arange(9))
    b, out = rng.normal(size=9), np.empty(9)
    lu_solve(np.ascontiguousarray(lu), piv, b, out)
    np.testing.assert_allclose(out, np.linalg.solve(S, b), rtol=1e-10, atol=1e-12)
