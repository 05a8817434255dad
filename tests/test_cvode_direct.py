"""CVODE stepped in compiled code (flexmb.integrators.cvode_direct) runs open trees as scikit-sundae's CVODE did.

``simulate(..., method="CVODE_BDF")`` (and ``"CVODE_Adams"``) on an open tree
whose force elements are all compiled now steps CVODE in compiled code.
The old results are the test: scikit-sundae's path (selected here by
patching :func:`~flexmb.integrators.direct_choice.compiled_loop` to return
None, as for the models it does not cover) must give the same counts and
states to 1e-10; what ``simulate()`` does around the steps (the monitor,
signals, non-finite states, the winding offsets, max_step, t_eval,
max_steps) still happens.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import flexmb as fm
from flexmb.integrators import cvode_direct, direct_choice
from flexmb.integrators.cvode_library import NEEDED, libraries

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
sys.path.insert(0, BENCH)

scenes = pytest.importorskip("scenes")


def _sksundae(monkeypatch):
    """Make simulate() take scikit-sundae's CVODE (main's path) for every model."""
    monkeypatch.setattr(direct_choice, "compiled_loop", lambda *args: None)


@pytest.fixture
def python_jacobian(monkeypatch):
    """The compiled loop's CVODE with the Python Jacobian, as scikit-sundae's CVODE is given it (the compiled one
    agrees to 1e-10, not to the last bit, which moves the steps: its test is tests/test_tree_jacobian.py)."""
    monkeypatch.setattr(cvode_direct, "compiled_jacobian", lambda system: False)


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
    assert direct_choice.compiled_loop(system, fm.registry.get("integrators", "CVODE_BDF"), False, None) \
        is cvode_direct.DirectCVODEBDF
    assert direct_choice.compiled_loop(system, fm.registry.get("integrators", "CVODE_BDF"), True, None) is None
    assert direct_choice.compiled_loop(system, fm.registry.get("integrators", "IDA"), False, None) is None


@pytest.mark.parametrize("method", ["CVODE_BDF", "CVODE_Adams"])
def test_dense_runs_are_sksundae_runs(monkeypatch, python_jacobian, method):
    """Below KRYLOV_MIN_COORDS (dense LU, flexmb's Jacobian from Python) the compiled loop takes scikit-sundae's very
    steps, right-hand sides and Jacobians, and ends in its states (B1 N = 8 at the robust rtol, and tight)."""
    system = scenes.b1(8).build()
    for rtol in (2e-5, 1e-10):
        kw = dict(method=method, rtol=rtol, atol=rtol / 100, n_out=11, progress=False)
        with monkeypatch.context() as m:
            _sksundae(m)
            old = fm.simulate(system, 0.5, **kw)
        new = fm.simulate(system, 0.5, **kw)
        assert (new.n_steps, new.n_rhs, new.n_jac) == (old.n_steps, old.n_rhs, old.n_jac) and new.n_jac > 0
        assert np.max(np.abs(new.x - old.x)) <= 1e-10 and np.max(np.abs(new.xd - old.xd)) <= 1e-10


def test_monitor_gets_every_step():
    system = scenes.b1(8).build()
    y0 = np.zeros(2 * system.n_speeds)
    y1, stats, mon = _direct(system, y0, 2e-5,
                             jacobian=lambda t, y: system.state_jacobian(t, *system.layout.split(y)))
    assert mon.n_steps == stats["steps"] > 500  # CHECK_STEPS = 100: checkpoints at 100, 200, 400
    assert stats["rhs"] == stats["rhs_cvode"] + stats["rhs_ls"] and stats["jac"] > 0


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


def _spinning_pendulum():
    model = fm.Model("pendulum")
    bar = fm.RigidBody("bar", 1.0, (0.01, 0.1, 0.1), (0.5, 0.0, 0.0))
    model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)), fm.Gravity((0.0, -9.81, 0.0)))
    return model.build()


def test_winding_angles_move_their_offsets_as_before(monkeypatch):
    """A pendulum spinning over its top (angle coordinates, compiled gravity): its offsets move after the same steps
    as on scikit-sundae's path, and the runs agree."""
    system = _spinning_pendulum()
    kw = dict(speeds={"pin": 12.0}, rtol=1e-10, atol=1e-12, n_out=21, progress=False)
    with monkeypatch.context() as m:
        _sksundae(m)
        old = fm.simulate(system, 5.0, method="CVODE_BDF", **kw)
    new = fm.simulate(system, 5.0, method="CVODE_BDF", **kw)
    assert new.n_rebases == old.n_rebases >= 3 and (new.n_steps, new.n_rhs) == (old.n_steps, old.n_rhs)
    assert np.max(np.abs(new.x - old.x)) <= 1e-10 and abs(new.x[-1, 0]) > 6 * np.pi


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


def _interrupted_after(system, delay, kw):
    """A long run sent SIGINT from another process after ``delay`` seconds, as a user's Ctrl-C (it arrives whatever
    this process runs, mostly compiled code)."""
    sender = subprocess.Popen(["sh", "-c", f"sleep {delay}; kill -INT {os.getpid()}"])
    t0 = time.perf_counter()
    try:
        res = fm.simulate(system, 1e5, **kw)  # far longer than the delay
    finally:
        sender.wait()
    assert time.perf_counter() - t0 < 20.0
    assert res.status == "interrupted" and res.message.startswith("interrupted by"), (res.status, res.message)
    return res


@pytest.mark.parametrize("linear", ["dense", "gmres"])
def test_ctrl_c_stops_a_long_interval(linear):
    """Ctrl-C while CVODE steps (the dense runs call flexmb's Jacobian from Python: a Ctrl-C raised inside that
    ctypes callback was lost, and the run went on to its end) stops the run at the loop's next return.

    On a loaded machine the signal can land before the first step (the run then stops before stepping, also
    correct): the same delay is then tried doubled, until the signal lands among the steps.
    """
    system = scenes.b1(8 if linear == "dense" else 64).build()
    kw = dict(method="CVODE_BDF", rtol=1e-10, n_out=2, progress=False)  # about 2e5 steps at B1 N = 8
    fm.simulate(system, 1e-3, **kw)  # compiled first: the signal is to come while CVODE steps
    for delay in (0.02, 0.05, 0.11):  # at different moments of the loop
        for attempt in range(3):
            res = _interrupted_after(system, delay * 2 ** attempt, kw)
            if res.n_steps > 0:
                break
        assert res.n_steps > 0, (delay, attempt)


def test_max_step_and_outputs_as_on_sksundae(monkeypatch, python_jacobian):
    """max_step bounds the steps, and t_eval's output times are CVODE's interpolant there, as on scikit-sundae."""
    system = scenes.b1(8).build()
    t_eval = np.linspace(0.0, 0.2, 7)
    kw = dict(method="CVODE_BDF", rtol=1e-10, atol=1e-12, max_step=1e-3, t_eval=t_eval, progress=False)
    with monkeypatch.context() as m:
        _sksundae(m)
        old = fm.simulate(system, 0.2, **kw)
    new = fm.simulate(system, 0.2, **kw)
    assert new.n_steps == old.n_steps >= 200
    assert np.array_equal(new.t, t_eval) and np.array_equal(old.t, t_eval)
    assert np.max(np.abs(new.x - old.x)) <= 1e-10 and np.max(np.abs(new.xd - old.xd)) <= 1e-10


def test_max_steps_refuses_the_run_before_it_starts():
    with pytest.raises(fm.ModelError, match="max_steps"):
        fm.simulate(_spinning_pendulum(), 1e3, speeds={"pin": 1e3}, method="CVODE_BDF", max_steps=1e4,
                    progress=False)


def test_closed_once_and_refused_after():
    system = scenes.b1(4).build()
    cv = cvode_direct.DirectCVODEBDF(None, 0.0, np.zeros(2 * system.n_speeds), 1.0, rtol=1e-6, atol=1e-8,
                                     system=system)
    cv.advance(0.1)
    cv.close()
    cv.close()
    with pytest.raises(cvode_direct.CVODEError, match="closed"):
        cv.advance(0.2)


def test_callbacks_go_through_flexmbs_kernel_cache():
    """The C callbacks' machine code is cached, and served, as the kernels' (flexmb.kernels.cache, prebuilt)."""
    from flexmb.kernels import cvode_callbacks as cb
    from flexmb.kernels.cache import KernelCache, sources_stamp

    for callback in (cb.rhs, cb.jac, cb.psetup, cb.psolve):
        assert callback.address
        assert isinstance(callback._cf._cache, KernelCache)
        assert callback._cf._cache._impl.locator.get_source_stamp() == sources_stamp()


def _monitors(monkeypatch):
    """The resolution monitors the runs make, in order."""
    from flexmb.integrators import monitor

    made, original = [], monitor.ResolutionMonitor.for_run.__func__

    def keep(cls, *args, **kwargs):
        made.append(original(cls, *args, **kwargs))
        return made[-1]

    monkeypatch.setattr(monitor.ResolutionMonitor, "for_run", classmethod(keep))
    return made


def test_quiet_checkpoints_pass_in_the_compiled_loop(monkeypatch, python_jacobian):
    """The checkpoints at which the monitor finds nothing to analyse pass in the compiled loop, which steps through
    all the outputs in one call: the monitor ends as the one scikit-sundae's path feeds step by step."""
    made, calls = _monitors(monkeypatch), []
    step_through = cvode_direct.DirectCVODE.step_through

    def counted(self, *args):
        calls.append(args[2])
        return step_through(self, *args)

    monkeypatch.setattr(cvode_direct.DirectCVODE, "step_through", counted)
    system = scenes.b1(8).build()
    kw = dict(method="CVODE_BDF", rtol=2e-5, atol=2e-7, n_out=201, progress=False)
    with monkeypatch.context() as m:
        _sksundae(m)
        old = fm.simulate(system, 1.0, **kw)
    new = fm.simulate(system, 1.0, **kw)
    assert made[1].n_steps == made[0].n_steps == new.n_steps == old.n_steps > 4 * 100
    assert made[1].next_check == made[0].next_check > 400 and made[1].steps == made[0].steps
    assert calls == [0]  # one call for the 200 outputs and the checkpoints at 100, 200, 400 steps
    assert np.array_equal(new.x, old.x) and np.array_equal(new.xd, old.xd)


def test_progress_marks_and_outputs_between_them(monkeypatch):
    """With a progress bar the loop returns at each mark; the outputs are those of a run without one."""
    system = scenes.b1(8).build()
    kw = dict(method="CVODE_BDF", rtol=1e-6, n_out=7, t_eval=None)
    quiet = fm.simulate(system, 0.5, progress=False, **kw)
    shown = fm.simulate(system, 0.5, progress=True, **kw)
    assert np.array_equal(quiet.t, shown.t) and np.array_equal(quiet.x, shown.x) and quiet.n_steps == shown.n_steps


def test_a_checkpoint_with_something_to_judge_returns(monkeypatch):
    """With the monitor's step limit lowered, every checkpoint is judged in Python (the loop returns there)."""
    from flexmb.integrators import monitor

    monkeypatch.setattr(monitor, "RESOLVE_STEP_LIMIT", 10)
    judged = []
    step = monitor.ResolutionMonitor.step

    def counted(self, solver):
        judged.append(self.n_steps + 1)
        return step(self, solver)

    monkeypatch.setattr(monitor.ResolutionMonitor, "step", counted)
    res = fm.simulate(scenes.b1(8).build(), 1.0, method="CVODE_BDF", rtol=2e-5, atol=2e-7, n_out=3, progress=False)
    assert res.status == "finished" and judged == [100, 200, 400]
