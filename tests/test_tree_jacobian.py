"""The compiled state Jacobian of open trees (flexmb.kernels.tree_jacobian) is System.state_jacobian's.

The old implementation is the test: ``System.state_jacobian`` (the dense
mass matrix, its Cholesky factor, ``flexmb.assembly.geometric_stiffness``)
and :func:`~flexmb.kernels.tree_jacobian.tree_state_jacobian` (one
articulated-body solve per column of ``A^-1``) agree to 1e-10 of the
Jacobian's largest entry on B1, B2 (torsion, both bendings, a tip mass off
the axis, tilted gravity), a spatial double pendulum with joint springs and
dampers and a slider on a spring, along a run and off it; the compiled CVODE
loop calls it (a C callback, counted as Jacobians) and its runs agree with
the runs that call the Python one at tight tolerances; models whose
tangent has more keep the Python one (one decision,
:func:`flexmb.integrators.cvode_direct.compiled_jacobian`, as for loops).
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

import flexmb as fm
from flexmb.integrators import cvode_direct
from flexmb.kernels.tree_jacobian import tree_state_jacobian
from flexmb.system.tangent import NewtonPreconditioner

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
sys.path.insert(0, BENCH)
scenes = pytest.importorskip("scenes")


def _pendulum():
    """A spatial double pendulum (two joints about crossed axes) and a slider, with springs, dampers, gravity."""
    model = fm.Model("sprung pendulum")
    a = fm.RigidBody("a", 1.2, (0.02, 0.05, 0.04), (0.3, 0.05, 0.0))
    b = fm.RigidBody("b", 0.7, (0.01, 0.03, 0.02), (0.2, 0.0, 0.1))
    c = fm.RigidBody("c", 0.4, (0.002, 0.002, 0.002), (0.0, 0.0, 0.0))
    model.add(fm.Revolute("p1", model.ground, a, axis=(0, 0, 1)),
              fm.Revolute("p2", a, b, axis=(1, 0, 0), parent_point=(0.6, 0.0, 0.0)),
              fm.Prismatic("s", b, c, axis=(0, 0, 1), parent_point=(0.4, 0.0, 0.0)),
              fm.JointSpringDamper("k1", "p1", 30.0, 0.4), fm.JointSpringDamper("k2", "p2", 12.0, 0.1),
              fm.JointSpringDamper("k3", "s", 200.0, 1.5), fm.Gravity((0.0, -9.81, -2.0)))
    return model.build(), dict(positions={"p1": 0.4, "p2": -0.7, "s": 0.05}, speeds={"p1": 1.5, "p2": -2.0})


def _compiled(system, x, xd):
    n = system.n_speeds
    K, C = NewtonPreconditioner.diagonal_terms(system)
    J = np.full((2 * n, 2 * n), np.nan)
    status, body = tree_state_jacobian(system._packed_open, np.concatenate([x, xd]), n, K, C, J)
    assert (status, body) == (0, -1)
    return J


MODELS = {"b1_8": lambda: (scenes.b1(8).build(), {}), "b1_32": lambda: (scenes.b1(32).build(), {}),
          "b2_8": lambda: (scenes.b2(8).build(), {}), "pendulum": _pendulum}


@pytest.mark.parametrize("name", list(MODELS))
def test_the_compiled_jacobian_is_state_jacobians(name):
    system, initial = MODELS[name]()
    assert system._packed_open is not None and system.layout.identity
    assert cvode_direct.compiled_jacobian(system)
    res = fm.simulate(system, 0.05, method="CVODE_BDF", rtol=1e-7, n_out=3, progress=False, **initial)
    rng = np.random.default_rng(11)
    n = system.n_speeds
    for k in range(len(res.t)):
        for scale in (0.0, 1e-2):  # on the run, and off it
            x = res.x[k] + scale * rng.standard_normal(n)
            xd = res.xd[k] + 100 * scale * rng.standard_normal(n)
            old = system.state_jacobian(res.t[k], x, xd)
            new = _compiled(system, x, xd)
            assert np.max(np.abs(new - old)) <= 1e-10 * np.max(np.abs(old))
            assert np.max(np.abs(new[n:, :n])) > 0 and np.max(np.abs(new[n:, n:])) > 0
            assert np.array_equal(new[:n], old[:n])


def test_the_geometric_stiffness_is_in_it():
    """Without gravity and at rest the tangent is ``-A^-1 K``: gravity and speeds change it (G is there)."""
    system, initial = _pendulum()
    x = system.layout.reference() + 0.3
    n = system.n_speeds
    still = _compiled(system, x, np.zeros(n))
    moving = _compiled(system, x, np.full(n, 2.0))
    assert np.max(np.abs(moving[n:, :n] - still[n:, :n])) > 1e-3 * np.max(np.abs(still[n:, :n]))


def test_which_models_get_it():
    """Springs between points, velocity-dependent point forces and constant point forces keep the Python one."""
    assert cvode_direct.compiled_jacobian(_pendulum()[0])
    model = scenes.b1(4)
    model.add(fm.SpringDamper("sd", "ground", (0.0, 0.0, -0.1), "beam", (0.1, 0.0, 0.0), stiffness=5.0,
                              rest_length=0.1))
    assert not cvode_direct.compiled_jacobian(model.build())
    model = scenes.b1(4)
    model.add(fm.PointForce("push", "beam", (0.0, 0.0, -1.0), point=(0.2, 0.0, 0.0)))
    assert not cvode_direct.compiled_jacobian(model.build())


@pytest.mark.parametrize("name", ["b1_8", "b2_8", "pendulum"])
def test_runs_with_it_end_where_the_python_jacobians_do(monkeypatch, name):
    """The compiled CVODE loop evaluates it in C (counted as Jacobians) and its runs agree with the runs that call
    the Python one to well within their tolerance."""
    system, initial = MODELS[name]()
    kw = dict(initial, method="CVODE_BDF", rtol=1e-9, atol=1e-11, n_out=11, progress=False)
    calls = []
    original = cvode_direct.DirectCVODE._python_jacobian

    def spy(self, jacobian):
        out = original(self, jacobian)
        calls.append((self._compiled_jac, out))
        return out

    monkeypatch.setattr(cvode_direct.DirectCVODE, "_python_jacobian", spy)
    new = fm.simulate(system, 0.5, **kw)
    assert calls and all(c and out is None for c, out in calls) and new.n_jac > 0
    monkeypatch.setattr(cvode_direct, "compiled_jacobian", lambda system: False)
    calls.clear()
    old = fm.simulate(system, 0.5, **kw)
    assert calls and not any(c for c, _ in calls) and old.n_jac > 0
    assert new.status == old.status == "finished"
    scale = max(np.max(np.abs(old.x)), 1e-3)
    assert np.max(np.abs(new.x - old.x)) <= 1e-6 * scale
    assert np.max(np.abs(new.xd - old.xd)) <= 1e-5 * max(np.max(np.abs(old.xd)), 1e-3)


def test_a_non_finite_jacobian_is_refused():
    """Speeds beyond the range of floats: status 2 (the C callback then fails the run with its cause), not a
    matrix with infinities in it."""
    system, _ = _pendulum()
    n = system.n_speeds
    K, C = NewtonPreconditioner.diagonal_terms(system)
    J = np.zeros((2 * n, 2 * n))
    y = np.concatenate([system.layout.reference() + 0.2, np.full(n, 1e200)])
    assert tree_state_jacobian(system._packed_open, y, n, K, C, J) == (2, -1)
    y[n:] = 1.0
    assert tree_state_jacobian(system._packed_open, y, n, K, C, J) == (0, -1)


def test_a_run_loads_no_scipy_linalg_interface():
    """B1 N = 8 with CVODE (the compiled Jacobian, BLAS through scipy's cython_blas loaded alone) in a new process
    imports none of scipy.linalg's Python interface; importing it afterwards works as usual."""
    script = (f"import sys\nsys.path.insert(0, {BENCH!r})\nimport flexmb as fm\nfrom scenes import b1\n"
              "res = fm.simulate(b1(8).build(), 0.2, method='CVODE_BDF', rtol=2e-5, atol=2e-7, n_out=2, "
              "progress=False)\nassert res.n_jac > 0\n"
              "print(sorted(m for m in sys.modules if m.startswith('scipy.linalg')))\n"
              "import numpy as np, scipy.linalg\nfrom scipy.linalg import cython_blas\n"  # still usable after it
              "a = np.array([[4.0, 1.0], [1.0, 3.0]])\n"
              "assert np.allclose(scipy.linalg.cho_solve(scipy.linalg.cho_factor(a), [1.0, 2.0]), "
              "np.linalg.solve(a, [1.0, 2.0]))\nassert cython_blas.__pyx_capi__['dgemm']\n")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600,
                         env=dict(os.environ, OPENBLAS_NUM_THREADS="1"))
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "['scipy.linalg.cython_blas', 'scipy.linalg.cython_lapack']"  # nothing else
