"""flexmb runs its solvers with BLAS_THREADS BLAS threads and restores the caller's limits."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest
from attrs import field, frozen

import flexmb as fm
from flexmb import threads

threadpoolctl = pytest.importorskip("threadpoolctl")


def _blas_threads():
    info = [p for p in threadpoolctl.threadpool_info() if p["user_api"] == "blas"]
    if not info:
        pytest.skip("no BLAS library reported by threadpoolctl")
    return {p["num_threads"] for p in info}


def _pendulum():
    model = fm.Model("pendulum")
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0.0, -9.81, 0.0)))
    return model


@frozen(eq=False)
class _Probe(fm.ForceElement):
    """A force element that records the BLAS threads seen during evaluation."""

    seen: list = field(factory=list)

    def apply(self, state, loads):
        self.seen.append(frozenset(_blas_threads()))


def test_simulate_runs_with_one_blas_thread_and_restores():
    with threadpoolctl.threadpool_limits(limits=2, user_api="blas"):
        before = _blas_threads()
        seen = []
        model = _pendulum()
        model.add(_Probe("probe", seen))
        res = fm.simulate(model, 0.05, positions={"pin": 0.3}, n_out=3)
        assert res.status == "finished"
        assert seen and all(s == {threads.BLAS_THREADS} for s in seen)
        assert _blas_threads() == before


def test_nested_blocks_restore_once():
    with threadpoolctl.threadpool_limits(limits=2, user_api="blas"):
        before = _blas_threads()
        with threads.blas_threads(1):
            with threads.blas_threads(1):
                assert _blas_threads() == {1}
            assert _blas_threads() == {1}, "an inner block must not restore the outer one's limit"
        assert _blas_threads() == before


def test_linear_analyses_are_limited():
    seen = []
    model = _pendulum()
    model.add(_Probe("probe", seen))
    system = model.build()
    seen.clear()  # the build's trial evaluation runs outside any solver
    with threadpoolctl.threadpool_limits(limits=2, user_api="blas"):
        fm.static_equilibrium(system, x0=np.array([0.1]))
    assert seen and all(s == {threads.BLAS_THREADS} for s in seen)


def test_bad_environment_value_is_refused():
    code = textwrap.dedent("""
        import flexmb
    """)
    out = subprocess.run([sys.executable, "-c", code], env={"FLEXMB_BLAS_THREADS": "zero", "PATH": ""},
                         capture_output=True, text=True)
    assert out.returncode != 0
    assert "FLEXMB_BLAS_THREADS must be an integer >= 1, got 'zero'" in out.stderr
