"""CVODE stepped in compiled code (flexmb.integrators.cvode_direct) runs open trees as scikit-sundae's CVODE did.

``simulate(..., method="CVODE_BDF")`` (and ``"CVODE_Adams"``) on an open tree
whose force elements are all compiled now steps CVODE in compiled code.
The old results are the test: scikit-sundae's path (selected here by
patching :func:`~flexmb.integrators.cvode_direct.compiled_loop` to return
None, as for the models it does not cover) with the same Jacobian must
give the same counts and states; the compiled Jacobian equals
``System.state_jacobian``; what ``simulate()`` does around the steps (the
monitor, signals, non-finite states, the winding offsets, max_steps) still
happens.
"""

from __future__ import annotations

import os
import signal
import sys
import time

import numpy as np
import pytest

import flexmb as fm
from flexmb.integrators import cvode_direct
from flexmb.integrators.cvode_library import NEEDED, libraries

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
sys.path.insert(0, BENCH)

scenes = pytest.importorskip("scenes")


def _sksundae(monkeypatch):
    """Make simulate() take scikit-sundae's CVODE (main's path) for every model."""
    monkeypatch.setattr(cvode_direct, "compiled_loop", lambda *args: None)


def _final(res):
    return np.concatenate([res.x[-1], res.xd[-1]])


def _direct(system, y0, rtol, **kw):
    from flexmb.integrators.monitor import ResolutionMonitor

    mon = ResolutionMonitor(system, 0.0, 1.0, rtol, rtol / 100, "CVODE_BDF")
    with cvode_direct.DirectCVODEBDF(None, 0.0, y0, 1.0, rtol=rtol, atol=rtol / 100, system=system, monitor=mon,
                                     **kw) as cv:
        y1 = cv.advance(1.0)
        stats = cv.stats()
    return y1, stats, mon


def test_libraries_found_without_importing_sksundae():
    info = libraries()
    assert set(info["paths"]) == set(NEEDED)
    assert all(os.path.exists(p) for p in info["paths"].values())
    assert info["version"].startswith("7.")


def test_simulate_steps_in_compiled_code_on_open_trees():
    system = scenes.b1(4).build()
    res = fm.simulate(system, 0.1, method="CVODE_BDF", n_out=3, progress=False)
    assert res.status == "finished" and res.method == "CVODE_BDF"
    assert cvode_direct.compiled_loop(system, fm.registry.get("integrators", "CVODE_BDF"), False, None) \
        is cvode_direct.DirectCVODEBDF
    assert cvode_direct.compiled_loop(system, fm.registry.get("integrators", "CVODE_BDF"), True, None) is None
    assert cvode_direct.compiled_loop(system, fm.registry.get("integrators", "IDA"), False, None) is None


def test_same_steps_as_sksundae_with_flexmb_jacobian(monkeypatch):
    """With flexmb's Jacobian from Python the compiled loop takes scikit-sundae's very steps (rounding: 1e-10)."""
    system = scenes.b1(8).build()
    with monkeypatch.context() as m:
        _sksundae(m)
        res = fm.simulate(system, 1.0, method="CVODE_BDF", rtol=2e-5, atol=2e-7, n_out=2, progress=False)
    y0 = np.concatenate([res.x[0], res.xd[0]])
    y1, stats, mon = _direct(system, y0, 2e-5,
                             jacobian=lambda t, y: system.state_jacobian(t, *system.layout.split(y)))
    assert (stats["steps"], stats["rhs"], stats["jac"]) == (res.n_steps, res.n_rhs, res.n_jac)
    assert stats["rhs"] == stats["rhs_cvode"] + stats["rhs_ls"]
    assert np.max(np.abs(y1 - _final(res))) <= 1e-10
    assert mon.n_steps == res.n_steps  # every step reached the resolution monitor


def test_paused_calls_take_the_same_steps(monkeypatch):
    system = scenes.b1(8).build()
    res = fm.simulate(system, 1.0, method="CVODE_BDF", rtol=1e-6, n_out=5, progress=False)
    monkeypatch.setattr(cvode_direct, "STEPS_PER_CALL", 7)  # back in Python every 7 steps (signals handled there)
    few = fm.simulate(system, 1.0, method="CVODE_BDF", rtol=1e-6, n_out=5, progress=False)
    assert (few.n_steps, few.n_rhs, few.n_jac) == (res.n_steps, res.n_rhs, res.n_jac)
    assert np.max(np.abs(few.x - res.x)) == 0.0 and np.max(np.abs(few.xd - res.xd)) == 0.0


@pytest.mark.parametrize("n_segments", [16, 24])
def test_krylov_runs_are_sksundae_runs(monkeypatch, n_segments):
    """From KRYLOV_MIN_COORDS on (B2 N = 16: 48 coordinates) the compiled preconditioner takes scikit-sundae's
    steps, right-hand sides and set-ups, and ends in its state, at every output."""
    system = scenes.b2(n_segments).build()
    with monkeypatch.context() as m:
        _sksundae(m)
        old = fm.simulate(system, 0.2, method="CVODE_BDF", rtol=1e-5, atol=1e-7, n_out=5, progress=False)
    new = fm.simulate(system, 0.2, method="CVODE_BDF", rtol=1e-5, atol=1e-7, n_out=5, progress=False)
    assert (new.n_steps, new.n_rhs, new.n_jac) == (old.n_steps, old.n_rhs, old.n_jac) and new.n_jac > 0
    assert np.max(np.abs(new.x - old.x)) <= 1e-10 and np.max(np.abs(new.xd - old.xd)) <= 1e-10


@pytest.mark.parametrize("build", [lambda: scenes.b1(8), lambda: scenes.b2(4)])
def test_compiled_jacobian_is_the_state_jacobian(build):
    from flexmb.kernels.cvode_callbacks import open_tree_jacobian
    from flexmb.system.tangent import NewtonPreconditioner

    system = build().build()
    n = system.n_speeds
    K, C = NewtonPreconditioner.diagonal_terms(system)
    rng = np.random.default_rng(3)
    for _ in range(4):
        y = np.concatenate([rng.normal(0.0, 0.05, n), rng.normal(0.0, 0.5, n)])
        J, ok = open_tree_jacobian(system._packed_open, y, K, C)
        J_ref = system.state_jacobian(0.0, y[:n], y[n:])
        assert ok
        assert np.max(np.abs(J - J_ref)) <= 1e-12 * np.max(np.abs(J_ref))


@pytest.mark.parametrize("method", ["CVODE_BDF", "CVODE_Adams"])
def test_compiled_jacobian_runs_agree_with_sksundae(monkeypatch, method):
    """The compiled Jacobian differs from flexmb's in the last bits only: the runs agree to the tolerance."""
    system = scenes.b1(8).build()
    kw = dict(rtol=1e-10, atol=1e-12, n_out=11, progress=False)
    with monkeypatch.context() as m:
        _sksundae(m)
        old = fm.simulate(system, 0.5, method=method, **kw)
    new = fm.simulate(system, 0.5, method=method, **kw)
    assert new.status == old.status == "finished"
    assert abs(new.n_steps - old.n_steps) <= 0.05 * old.n_steps
    assert np.max(np.abs(new.x - old.x)) <= 1e-8 and np.max(np.abs(new.xd - old.xd)) <= 1e-7


def _spinning_pendulum():
    model = fm.Model("pendulum")
    bar = fm.RigidBody("bar", 1.0, (0.01, 0.1, 0.1), (0.5, 0.0, 0.0))
    model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)), fm.Gravity((0.0, -9.81, 0.0)))
    return model.build()


def test_winding_angles_move_their_offsets_as_before(monkeypatch):
    """A pendulum spinning over its top (angle coordinates, compiled gravity): its offsets move as often as on
    scikit-sundae's path, and the motion agrees (at rtol 1e-12 both are within 2e-9 rad of DOP853 at 1e-13)."""
    system = _spinning_pendulum()
    kw = dict(speeds={"pin": 12.0}, rtol=1e-12, atol=1e-14, n_out=21, progress=False)
    with monkeypatch.context() as m:
        _sksundae(m)
        old = fm.simulate(system, 5.0, method="CVODE_BDF", **kw)
    new = fm.simulate(system, 5.0, method="CVODE_BDF", **kw)
    assert new.n_rebases == old.n_rebases >= 3
    assert np.max(np.abs(new.x - old.x)) <= 1e-8 and abs(new.x[-1, 0]) > 6 * np.pi


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_non_finite_state_stops_with_time_and_cause(monkeypatch):
    """A state whose rates overflow stops the run at once, with flexmb's diagnosis of it, as on scikit-sundae's path."""
    system = scenes.b1(4).build()
    y0 = np.zeros(2 * system.n_speeds)
    y0[1] = np.nan
    with pytest.raises(fm.AssemblyError, match=r"non-finite"):
        _direct(system, y0, 1e-6)
    model = scenes.b1(4)
    model.add(fm.PointForce("push", "beam", (0.0, 0.0, -1e300), point=(1.0, 0.0, 0.0)))  # accelerations overflow
    system = model.build()
    kw = dict(method="CVODE_BDF", progress=False)
    with monkeypatch.context() as m:
        _sksundae(m)
        with pytest.raises(fm.SimulationError) as old:
            fm.simulate(system, 1.0, **kw)
    with pytest.raises(fm.SimulationError, match=r"at t = 0 s: force element 'push' .* non-finite") as new:
        fm.simulate(system, 1.0, **kw)
    assert str(new.value) == str(old.value) and new.value.t == old.value.t
    assert new.value.result.status == "failed"


def test_a_signal_stops_a_long_interval():
    system = scenes.b1(8).build()

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGALRM, interrupt)
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.5)
        t0 = time.perf_counter()
        res = fm.simulate(system, 1e5, method="CVODE_BDF", rtol=1e-8, n_out=2, progress=False)
        assert time.perf_counter() - t0 < 20.0  # millions of steps in one interval: minutes, were it not paused
        assert res.status == "interrupted" and res.message.startswith("interrupted by") and res.n_steps > 0
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, old)


def test_max_steps_refuses_the_run_before_it_starts():
    with pytest.raises(fm.ModelError, match="max_steps"):
        fm.simulate(_spinning_pendulum(), 1e3, speeds={"pin": 1e3}, method="CVODE_BDF", max_steps=1e4,
                    progress=False)


def test_jacobian_refused_where_the_compiled_one_does_not_hold():
    model = scenes.b1(4)
    model.add(fm.PointForce("push", "beam", (0.0, 0.0, -1.0), point=(1.0, 0.0, 0.0)))
    system = model.build()
    assert not cvode_direct.diagonal_terms_only(system)
    with pytest.raises(ValueError, match="point forces"):
        cvode_direct.DirectCVODEBDF(None, 0.0, np.zeros(2 * system.n_speeds), 1.0, rtol=1e-6, atol=1e-8,
                                    system=system)
    res = fm.simulate(system, 0.05, method="CVODE_BDF", progress=False)  # flexmb's Jacobian from Python then
    assert res.status == "finished" and res.n_jac > 0


def test_closed_once_and_refused_after():
    system = scenes.b1(4).build()
    cv = cvode_direct.DirectCVODEBDF(None, 0.0, np.zeros(2 * system.n_speeds), 1.0, rtol=1e-6, atol=1e-8,
                                     system=system)
    cv.advance(0.1)
    cv.close()
    cv.close()
    with pytest.raises(cvode_direct.CVODEError, match="closed"):
        cv.advance(0.2)
