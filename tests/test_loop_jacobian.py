"""The compiled state Jacobian of looped models (flexmb.kernels.loop_jacobian) is System.state_jacobian's.

The old implementation is the test: ``System.state_jacobian`` (dense mass
matrix, SVD complement, Cholesky of the reduced mass matrix) and
:func:`~flexmb.kernels.loop_jacobian.loop_state_jacobian` (the loops'
O(n m) constrained solves, one per column of P) agree to 1e-10 of the
Jacobian's largest entry, on and off the constraint manifold, with
gravity (the loads' geometric stiffness) and without; the compiled loops'
CVODE calls it instead of the Python one (the runs then differ from
scikit-sundae's in the last bits of the Jacobian, so their counts are not
those of tests/test_cvode_direct_loops.py, which runs that path with the
Python Jacobian) and ends within the run's accuracy of the run with the
Python Jacobian.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import flexmb as fm
from conftest import fourbar, fourbar_initial
from flexmb.integrators import cvode_direct, cvode_direct_loops
from flexmb.kernels.loop_jacobian import loop_state_jacobian
from flexmb.system.tangent import NewtonPreconditioner

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
scenes = pytest.importorskip("scenes")


def _sprung_fourbar():
    """The four-bar under gravity with springs and dampers on its three pins (a Jacobian, with loads)."""
    model = fourbar()
    model.add(fm.JointSpringDamper("kA", "A", 3.0, 0.2), fm.JointSpringDamper("kB", "B", 1.5, 0.05),
              fm.JointSpringDamper("kD", "D", 2.0, 0.1))
    return model.build(complement="articulated"), dict(positions=fourbar_initial())


def _b6(n, planar=None):
    model, positions = scenes.b6(True, n)
    return model.build(complement="articulated", planar=planar), dict(positions=positions)


def _compiled(system, t, x, xd):
    n = system.n_speeds
    K, C = NewtonPreconditioner.diagonal_terms(system)
    J = np.full((2 * n, 2 * n), np.nan)
    gamma_d = np.zeros(len(system.constraints.drivers))  # constant-speed drivers
    status, body = loop_state_jacobian(system._packed, system._loop_layout, np.concatenate([x, xd]), n, K, C, gamma_d,
                                       system._loop_tol, system.singular_window(), -1, J)
    assert (status, body) == (0, -1)
    return J


@pytest.mark.parametrize("build", [_sprung_fourbar, lambda: _b6(8), lambda: _b6(32)], ids=["fourbar", "b6_8", "b6_32"])
def test_the_compiled_jacobian_is_state_jacobians(build):
    system, initial = build()
    assert cvode_direct.compiled_jacobian(system)
    res = fm.simulate(system, 0.05, method="CVODE_BDF", rtol=1e-7, n_out=3, progress=False, **initial)
    rng = np.random.default_rng(7)
    n = system.n_speeds
    for k in range(len(res.t)):
        for scale in (0.0, 1e-3):  # on the manifold (the outputs are projected), and off it
            x = res.x[k] + scale * rng.standard_normal(n)
            xd = res.xd[k] + 100 * scale * rng.standard_normal(n)
            old = system.state_jacobian(res.t[k], x, xd)
            new = _compiled(system, res.t[k], x, xd)
            assert np.max(np.abs(new - old)) <= 1e-10 * np.max(np.abs(old))
            assert np.max(np.abs(new[n:, :n])) > 0 and np.max(np.abs(new[n:, n:])) > 0


def test_which_models_get_it():
    """Springs between points, constant point forces (their arm turns) and Python-only terms keep the Python one."""
    assert cvode_direct.compiled_jacobian(_sprung_fourbar()[0])
    model = fourbar()
    model.add(fm.JointSpringDamper("kA", "A", 3.0, 0.2),
              fm.SpringDamper("sd", "crank", (0.1, 0, 0), "rocker", (0.25, 0, 0), stiffness=5.0,
                              rest_length=0.2))
    assert not cvode_direct.compiled_jacobian(model.build(complement="articulated"))
    model = fourbar()
    model.add(fm.JointSpringDamper("kA", "A", 3.0, 0.2), fm.PointForce("push", "coupler", (0.0, -1.0, 0.0),
                                                                       point=(0.15, 0.0, 0.0)))
    assert not cvode_direct.compiled_jacobian(model.build(complement="articulated"))


@pytest.mark.parametrize("build", [_sprung_fourbar, lambda: _b6(8)], ids=["fourbar", "b6_8"])
def test_runs_with_it_end_where_the_python_jacobians_do(monkeypatch, build):
    """The compiled loops' CVODE evaluates it in C (counted as Jacobians) and its runs agree with the runs
    that call the Python one to well within their tolerance."""
    system, initial = build()
    kw = dict(initial, method="CVODE_BDF", rtol=1e-9, atol=1e-11, n_out=11, progress=False)
    calls = []
    original = cvode_direct_loops.DirectLoopCVODE._python_jacobian

    def spy(self, jacobian):
        out = original(self, jacobian)
        calls.append(self._compiled_jac)
        return out

    monkeypatch.setattr(cvode_direct_loops.DirectLoopCVODE, "_python_jacobian", spy)
    new = fm.simulate(system, 0.2, **kw)
    assert calls and all(calls) and new.n_jac > 0
    monkeypatch.setattr(cvode_direct, "compiled_jacobian", lambda system: False)
    old = fm.simulate(system, 0.2, **kw)
    assert new.status == old.status == "finished"
    assert np.max(np.abs(new.x - old.x)) <= 1e-6 and np.max(np.abs(new.xd - old.xd)) <= 1e-4
