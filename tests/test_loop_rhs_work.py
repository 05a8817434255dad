"""The loops' right-hand side and Jacobians are main's to 1e-10 (tests/data/loop_rhs_work.npz, main at 8c13991).

The loops' right-hand side as the compiled CVODE callback calls it
(:func:`flexmb.kernels.loops.loop_rhs`: accelerations, reactions, rank,
smallest pivot, status), ``System.state_rate``, ``System.state_jacobian``
and the compiled Jacobian (:func:`flexmb.kernels.loop_jacobian.loop_state_jacobian`)
at random states of B6 damped (N = 8, 32), the planar, spatial and sprung
four-bars and B7 (N = 4, 40), against the values stored from main before
the loops' kernels wrote into work arrays. They were equal to the bit
while the arithmetic was main's; since ``K = psi A^-1 psi^T`` is summed
subtree by subtree from multi-column sweeps
(:func:`flexmb.kernels.constrained._loop_matrix`), K's entries, and so
the accelerations, reactions, smallest pivot, state rate and both
Jacobians, differ from main's in the last bits: those are compared to
1e-10 relative (to each array's largest entry), the rank and status
still exactly. The cases are evaluated in turn so that any state left
in a reused work array would show.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "data"))

import make_loop_rhs_work as make  # noqa: E402

DATA = np.load(HERE / "data" / "loop_rhs_work.npz")


def assert_close(actual, desired):
    """Equal to 1e-10 relative to the array's largest entry (K's arithmetic changed: last bits only)."""
    desired = np.asarray(desired)
    scale = np.max(np.abs(desired)) if desired.size else 0.0
    np.testing.assert_allclose(actual, desired, rtol=1e-10, atol=1e-10 * scale)


def assert_info(info, desired):
    """Rank and status exactly, the smallest pivot (last) to 1e-10."""
    np.testing.assert_array_equal(np.asarray(info)[:-1], np.asarray(desired)[:-1])
    assert_close(np.asarray(info)[-1:], np.asarray(desired)[-1:])


@pytest.mark.parametrize("name", list(make.MODELS))
def test_loop_rhs_is_mains(name):
    system = make.build(name)
    gamma_d = DATA[f"{name}_gamma_d"]
    for k, y in enumerate(DATA[f"{name}_y"]):
        xdd, lam, info = make.callback_rhs(system, y, gamma_d)
        assert_close(xdd, DATA[f"{name}_xdd"][k])
        assert_close(lam, DATA[f"{name}_lam"][k])
        assert_info(info, DATA[f"{name}_info"][k])
        assert_close(system.state_rate(make.T, y), DATA[f"{name}_rate"][k])


@pytest.mark.parametrize("name", list(make.MODELS))
def test_loop_jacobians_are_mains(name):
    system = make.build(name)
    y = DATA[f"{name}_y"][0]
    J, info = make.compiled_jacobian(system, y, DATA[f"{name}_gamma_d"])
    assert_close(J, DATA[f"{name}_jac"])
    np.testing.assert_array_equal(info, DATA[f"{name}_jac_info"])
    key = f"{name}_state_jacobian"
    if key in DATA.files:
        nq = system.layout.nq
        assert_close(system.state_jacobian(make.T, y[:nq], y[nq:]), DATA[key])


@pytest.mark.parametrize("name", list(make.MODELS))
def test_loop_rhs_into_a_reused_work_array_is_mains(name):
    """One NaN-filled work array, never cleared, across the states: nothing read before it is written."""
    from flexmb.kernels.loops import loop_rhs_into, loop_rhs_work_size

    system = make.build(name)
    n, nb = system.n_speeds, system.topology.n_bodies
    m = system._loop_layout.row_coord.shape[0]
    work = np.full(loop_rhs_work_size(nb, n, m), np.nan)
    zeros = np.zeros((nb + 1, 3))
    gamma_d = DATA[f"{name}_gamma_d"]
    for k, y in enumerate(DATA[f"{name}_y"]):
        xdd, lam = np.full(n, np.nan), np.full(m, np.nan)
        kept, smallest, status = loop_rhs_into(system._packed, system._loop_layout, y, n, np.zeros(0), zeros, zeros,
                                               np.zeros(n), gamma_d, system._loop_tol, system.singular_window(), -1,
                                               xdd, lam, work)
        assert_close(xdd, DATA[f"{name}_xdd"][k])
        assert_close(lam, DATA[f"{name}_lam"][k])
        assert_info([kept, status, smallest], DATA[f"{name}_info"][k])
