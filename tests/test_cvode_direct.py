"""The direct CVODE prototype (benchmarks/sundials_direct.py, cvode_callbacks.py) drives CVODE as flexmb does.

Independent of its timing (benchmarks/cvode_direct.py): with flexmb's own
Jacobian called from Python, or with the Newton preconditioner, the ctypes
loop must take exactly the steps, right-hand sides and Jacobians of
``simulate(..., method="CVODE_BDF")`` through scikit-sundae and end in the
same state; the compiled Jacobian must equal ``System.state_jacobian``; a
failure must be a clear error; and the memory must be freed once.
Slow: the C callbacks compile on first use (about 40 s).
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import flexmb as fm

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
sys.path.insert(0, BENCH)

pytestmark = pytest.mark.slow

scenes = pytest.importorskip("scenes")


@pytest.fixture(scope="module")
def direct():
    import sundials_direct

    return sundials_direct


def _simulate(system, rtol):
    res = fm.simulate(system, 1.0, method="CVODE_BDF", rtol=rtol, atol=rtol / 100, n_out=2, progress=False)
    assert res.status == "finished"
    return res, np.concatenate([res.x[0], res.xd[0]]), np.concatenate([res.x[-1], res.xd[-1]])


def _run(direct, system, y0, rtol, **kw):
    from flexmb.integrators.monitor import ResolutionMonitor

    mon = ResolutionMonitor(system, 0.0, 1.0, rtol, rtol / 100, "CVODE_BDF")
    with direct.DirectCVODE(system, y0, 0.0, 1.0, rtol=rtol, atol=rtol / 100, monitor=mon, **kw) as cv:
        y1 = cv.advance(1.0)
        stats = cv.stats()
    return y1, stats, mon


def test_libraries_found_without_importing_sksundae(direct):
    info = direct.libraries()
    assert set(info["paths"]) == set(direct.NEEDED)
    assert all(os.path.exists(p) for p in info["paths"].values())
    assert info["version"].startswith("7.")


def test_same_steps_as_simulate_with_flexmb_jacobian(direct):
    system = scenes.b1(8).build()
    res, y0, y_end = _simulate(system, 2e-5)
    y1, stats, mon = _run(direct, system, y0, 2e-5,
                          jacobian=lambda t, y: system.state_jacobian(t, *system.layout.split(y)))
    assert (stats["steps"], stats["rhs"], stats["jac"]) == (res.n_steps, res.n_rhs, res.n_jac)
    assert stats["rhs"] == stats["rhs_cvode"] + stats["rhs_ls"]
    assert np.max(np.abs(y1 - y_end)) <= 1e-10
    assert mon.n_steps == res.n_steps  # every step reached the resolution monitor


def test_python_callbacks_take_the_same_steps_and_raise_through(direct):
    system = scenes.b1(8).build()
    res, y0, y_end = _simulate(system, 1e-6)
    jac = lambda t, y: system.state_jacobian(t, *system.layout.split(y))  # noqa: E731
    y1, stats, _ = _run(direct, system, y0, 1e-6, rhs=system._state_rate, jacobian=jac)
    assert (stats["steps"], stats["rhs"], stats["jac"]) == (res.n_steps, res.n_rhs, res.n_jac)
    assert np.max(np.abs(y1 - y_end)) <= 1e-10

    def failing(t, y):
        if t > 0.5:
            raise ZeroDivisionError("a plugin's load failed")
        return system._state_rate(t, y)

    with pytest.raises(ZeroDivisionError, match="plugin"):
        _run(direct, system, y0, 1e-6, rhs=failing, jacobian=jac)


def test_paused_calls_take_the_same_steps(direct, monkeypatch):
    system = scenes.b1(8).build()
    res, y0, y_end = _simulate(system, 1e-6)
    monkeypatch.setattr(direct, "STEPS_PER_CALL", 7)  # back in Python every 7 steps (signals handled there)
    jac = lambda t, y: system.state_jacobian(t, *system.layout.split(y))  # noqa: E731
    y1, stats, mon = _run(direct, system, y0, 1e-6, jacobian=jac)
    assert (stats["steps"], stats["rhs"], stats["jac"]) == (res.n_steps, res.n_rhs, res.n_jac)
    assert mon.n_steps == res.n_steps
    assert np.max(np.abs(y1 - y_end)) <= 1e-10


def test_a_signal_stops_a_long_interval(direct):
    import signal
    import time

    system = scenes.b1(8).build()

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGALRM, interrupt)
    cv = direct.DirectCVODE(system, np.zeros(2 * system.n_speeds), 0.0, 1e5, rtol=1e-8, atol=1e-10)
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.2)
        t0 = time.perf_counter()
        with pytest.raises(KeyboardInterrupt):
            cv.advance(1e5)  # millions of steps: minutes, were it not for the paused calls
        assert time.perf_counter() - t0 < 10.0
        assert 0.0 < cv.t < 1e5
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, old)
        cv.close()


def test_same_steps_as_simulate_with_newton_preconditioner(direct):
    system = scenes.b1(48).build()  # 48 coordinates: flexmb's GMRES with the O(n) preconditioner
    res, y0, y_end = _simulate(system, 1e-5)
    y1, stats, _ = _run(direct, system, y0, 1e-5, krylov=True)
    assert (stats["steps"], stats["rhs"], stats["jac"]) == (res.n_steps, res.n_rhs, res.n_jac)
    assert stats["lin_iters"] > 0
    assert np.max(np.abs(y1 - y_end)) <= 1e-10


@pytest.mark.parametrize("build", [lambda: scenes.b1(8), lambda: scenes.b2(4)])
def test_compiled_jacobian_is_the_state_jacobian(build):
    import cvode_callbacks as cb
    from flexmb.system.tangent import NewtonPreconditioner

    system = build().build()
    n = system.n_speeds
    K, C = NewtonPreconditioner.diagonal_terms(system)
    rng = np.random.default_rng(3)
    for _ in range(4):
        y = np.concatenate([rng.normal(0.0, 0.05, n), rng.normal(0.0, 0.5, n)])
        J, ok = cb.open_tree_jacobian(system._packed_open, y, K, C)
        J_ref = system.state_jacobian(0.0, y[:n], y[n:])
        assert ok
        assert np.max(np.abs(J - J_ref)) <= 1e-12 * np.max(np.abs(J_ref))


def test_compiled_jacobian_run_agrees_at_tight_tolerance(direct):
    system = scenes.b1(8).build()
    _, y0, y_end = _simulate(system, 1e-10)
    y1, _, _ = _run(direct, system, y0, 1e-10)
    assert np.max(np.abs(y1 - y_end)) <= 1e-8


def test_non_finite_state_is_a_clear_error(direct):
    system = scenes.b1(4).build()
    y0 = np.zeros(2 * system.n_speeds)
    y0[1] = np.nan
    with pytest.raises(direct.CVODEError, match=r"CV_FIRST_RHSFUNC_ERR.*non-finite"):
        _run(direct, system, y0, 1e-6)


def test_refuses_what_it_cannot_run(direct):
    model = fm.Model("pendulum")
    bar = fm.RigidBody("bar", 1.0, (0.1, 0.1, 0.1), (0.5, 0.0, 0.0))
    model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)), fm.Gravity((0.0, -9.81, 0.0)))
    system = model.build()
    with pytest.raises(ValueError, match="angle coordinates"):
        direct.DirectCVODE(system, np.zeros(2), 0.0, 1.0, rtol=1e-6, atol=1e-8)
    model = scenes.b1(4)
    model.add(fm.PointForce("push", "beam", (0.0, 0.0, -1.0), point=(1.0, 0.0, 0.0)))
    system = model.build()
    with pytest.raises(ValueError, match="point forces"):
        direct.DirectCVODE(system, np.zeros(2 * system.n_speeds), 0.0, 1.0, rtol=1e-6, atol=1e-8)


def test_closed_once_and_refused_after(direct):
    system = scenes.b1(4).build()
    cv = direct.DirectCVODE(system, np.zeros(2 * system.n_speeds), 0.0, 1.0, rtol=1e-6, atol=1e-8)
    cv.advance(0.1)
    cv.close()
    cv.close()
    with pytest.raises(direct.CVODEError, match="closed"):
        cv.advance(0.2)
