"""CVODE stepped in compiled code on models with loops (flexmb.integrators.cvode_direct_loops) runs as scikit-sundae did.

``simulate(..., method="CVODE_BDF")`` (and ``"CVODE_Adams"``) on a model whose
loops the articulated strategy closes (``complement="articulated"`` or ``"auto"``), with compiled force elements and
constant-speed drivers, now steps CVODE in compiled code and returns to the
run only after the steps it must act on (outputs, drift past the bound,
winding offsets). The old results are the test: scikit-sundae's path
(selected by patching :func:`~flexmb.integrators.direct_choice.compiled_loop`
to return None, as for the models it does not cover) must give the same
step, right-hand side, Jacobian (or preconditioner set-up) and projection
counts and the same states to 1e-10, except for BDF held to order 3
(flexible bodies in loops, rtol >= 1e-4): CVODE then projects the state onto the
constraints itself (``CVodeSetProjFn``) instead of being restarted, its
steps differ, and its runs are held to scikit-sundae's accuracy against a
tight reference, with no restart.
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
from conftest import fourbar, fourbar_initial
from flexmb.integrators import cvode_direct, cvode_direct_loops, direct_choice
from flexmb.integrators.cvode_direct_loops import DirectLoopCVODEAdams, DirectLoopCVODEBDF

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
sys.path.insert(0, BENCH)

scenes = pytest.importorskip("scenes")

BDF = fm.registry.get("integrators", "CVODE_BDF")
ADAMS = fm.registry.get("integrators", "CVODE_Adams")


def _sksundae(monkeypatch):
    """Make simulate() take scikit-sundae's CVODE (main's path) for every model."""
    monkeypatch.setattr(direct_choice, "compiled_loop", lambda *args: None)


@pytest.fixture
def python_jacobian(monkeypatch):
    """The compiled loops' CVODE with the Python Jacobian, as scikit-sundae's CVODE is given it (the compiled
    one agrees to 1e-13, not to the last bit, which moves the steps: its test is tests/test_loop_jacobian.py)."""
    monkeypatch.setattr(cvode_direct_loops, "compiled_jacobian", lambda system: False)


def _wiper():
    pytest.importorskip("flexmb_friction")
    from flexmb.scenes.wiper import WiperOptions, wiper

    model, positions = wiper(WiperOptions(flexible=True, n_segments=6))
    return model, {"positions": positions}


#: model, initial state, span (s)
MODELS = {
    "fourbar": (lambda: (fourbar(), {"positions": fourbar_initial()}), 2.0),
    "fourbar_spatial_cut": (lambda: (fourbar(fm.Revolute), {"positions": fourbar_initial()}), 2.0),
    "b6_8": (lambda: (lambda m, p: (m, {"positions": p}))(*scenes.b6(True, 8)), 0.2),
    "b7_4": (lambda: scenes.b7(4), 2.0),
    "b7_40": (lambda: scenes.b7(40), 0.2),
}


def _counts(res):
    return res.n_steps, res.n_rhs, res.n_jac, res.n_projections, res.n_rebases


def _same(new, old):
    assert new.status == old.status == "finished", (new.message, old.message)
    assert _counts(new) == _counts(old)
    assert np.max(np.abs(new.x - old.x)) <= 1e-10 and np.max(np.abs(new.xd - old.xd)) <= 1e-10


def _error(res, ref):
    return max(np.max(np.abs(res.x - ref.x)), np.max(np.abs(res.xd - ref.xd)))


def _projected_as_accurate(new, old, ref, atol):
    """CVODE's projection: no restart, outputs on the constraints, states as near a tight reference as the
    restarting run's (within a factor 2, or atol)."""
    assert new.status == old.status == "finished", (new.message, old.message)
    assert new.n_projections == 0 and new.n_rebases == old.n_rebases
    assert np.max(new.residual) <= 1e-10 and np.max(new.velocity_residual) <= 1e-10
    assert _error(new, ref) <= max(2.0 * _error(old, ref), atol), (_error(new, ref), _error(old, ref))


def test_looped_models_with_compiled_elements_step_in_compiled_code():
    model, initial = MODELS["fourbar"][0]()
    system = model.build(complement="articulated")
    assert direct_choice.compiled_loop(system, BDF, False, None) is DirectLoopCVODEBDF
    assert direct_choice.compiled_loop(model.build(complement="auto"), BDF, False, None) is DirectLoopCVODEBDF
    assert direct_choice.compiled_loop(system, ADAMS, False, None) is DirectLoopCVODEAdams
    assert direct_choice.compiled_loop(system, BDF, True, None) is None  # work terms: computed in Python
    assert direct_choice.compiled_loop(model.build(complement="svd"), BDF, False, None) is None  # a dense strategy
    model, initial = scenes.b6(True, 8)
    system = model.build(complement="articulated")
    assert direct_choice.compiled_loop(system, BDF, False, None) is DirectLoopCVODEBDF  # a constant-speed driver


def test_drivers_known_only_to_python_stay_on_sksundae():
    """A driver given only by its Python callables (no ``law``): the run stays on scikit-sundae's path."""
    model = fourbar()
    model.add(fm.Driver("ramp", "A", position=lambda t: np.pi / 4 + t * t, velocity=lambda t: 2 * t,
                        acceleration=lambda t: 2.0))
    system = model.build(complement="articulated")
    assert direct_choice.compiled_loop(system, BDF, False, None) is None
    res = fm.simulate(system, 0.2, positions=fourbar_initial(), method="CVODE_BDF", n_out=3, progress=False)
    assert res.status == "finished"


def test_harmonic_drivers_step_in_compiled_code_as_before(monkeypatch):
    """A harmonic driver (``Driver.law``) is evaluated in compiled code with its callables' arithmetic: the
    four-bar's crank driven back and forth takes scikit-sundae's steps, with projections, to its states."""
    model = fourbar()
    model.add(fm.Driver.harmonic("wobble", "A", amplitude=0.3, frequency=2.0, offset=np.pi / 4))
    system = model.build(complement="articulated")
    assert direct_choice.compiled_loop(system, BDF, False, None) is DirectLoopCVODEBDF
    for rtol in (1e-5, 1e-9):
        kw = dict(positions=fourbar_initial(), method="CVODE_BDF", rtol=rtol, atol=rtol / 100, n_out=21,
                  progress=False)
        with monkeypatch.context() as m:
            _sksundae(m)
            old = fm.simulate(system, 1.0, **kw)
        new = fm.simulate(system, 1.0, **kw)
        _same(new, old)
        assert np.ptp(new.coordinate("A")) > 0.5


@pytest.mark.parametrize("name", sorted(MODELS))
def test_runs_are_sksundae_runs(monkeypatch, python_jacobian, name):
    """Counts and states of scikit-sundae's runs (dense Jacobian from Python below 48 coordinates, the loops'
    compiled preconditioner with GMRES from there: B7 N = 40), BDF at two tolerances and Adams."""
    build, span = MODELS[name]
    model, initial = build()
    system = model.build(complement="articulated")
    for method, rtol in (("CVODE_BDF", 1e-5), ("CVODE_BDF", 1e-9), ("CVODE_Adams", 1e-7)):
        kw = dict(initial, method=method, rtol=rtol, atol=rtol / 100, n_out=21, progress=False)
        with monkeypatch.context() as m:
            _sksundae(m)
            old = fm.simulate(system, span, **kw)
        new = fm.simulate(system, span, **kw)
        _same(new, old)


def test_bdf_projects_in_cvode_instead_of_restarting(monkeypatch):
    """BDF held to order 3 (a flexible body in a loop, rtol >= 1e-4: B6 N = 8): CVODE's projection (a compiled
    CVProjFn) keeps the state on the constraints, no restart, the outputs on them, the states as near a tight
    reference as scikit-sundae's restarting run (rtol 1e-4, 1e-3, 3e-3: the benchmarks'), in fewer steps from
    1e-3 on."""
    build, span = MODELS["b6_8"]
    model, initial = build()
    system = model.build(complement="articulated")
    kw = dict(initial, method="CVODE_BDF", n_out=21, progress=False)
    with monkeypatch.context() as m:
        _sksundae(m)
        ref = fm.simulate(system, span, **dict(kw, rtol=1e-11, atol=1e-13))
        olds = {rtol: fm.simulate(system, span, **dict(kw, rtol=rtol, atol=rtol / 100)) for rtol in (1e-4, 1e-3, 3e-3)}
    for rtol, old in olds.items():
        new = fm.simulate(system, span, **dict(kw, rtol=rtol, atol=rtol / 100))
        _projected_as_accurate(new, old, ref, rtol / 100)
        if rtol >= 1e-3:  # (at 1e-4 it takes more: 3,217 against 2,859 steps, 2 restarts)
            assert old.n_projections >= 20 and new.n_steps < 0.95 * old.n_steps, (rtol, new.n_steps, old.n_steps)


def _spinning_fourbar():
    """The four-bar with its crank (the shortest bar: a crank-rocker) turning over and over: its angles wind up."""
    return fourbar().build(complement="articulated"), dict(positions=fourbar_initial(), speeds={"A": 30.0})


def test_winding_offsets_move_as_before(monkeypatch):
    """The crank's and the coupler's angles wind past their bound: the offsets move after the same steps as on
    scikit-sundae's path (each a restart), between the projections, and the runs agree."""
    system, initial = _spinning_fourbar()
    kw = dict(initial, method="CVODE_BDF", rtol=1e-8, atol=1e-10, n_out=21, progress=False)
    with monkeypatch.context() as m:
        _sksundae(m)
        old = fm.simulate(system, 3.0, **kw)
    new = fm.simulate(system, 3.0, **kw)
    _same(new, old)
    assert new.n_rebases >= 3 and new.n_projections >= 1 and abs(new.x[-1, 0]) > 6 * np.pi


def test_drift_left_to_the_step_loop_where_it_checked(monkeypatch):
    """The run re-evaluates the drift only after a return whose last step the compiled loop did not check
    (``DirectLoopCVODE.within_bound``): the four-bar (no CVODE projection: every step checked by the loop;
    restarts and offset moves on the way) and B6 N = 8 (CVODE projects) take the very steps, restarts and
    states of a run that re-evaluates it after every return, and the four-bar's run checks less than half as often
    (there after the offset moves and the restarts)."""
    from flexmb.integrators.cvode_direct_loops import DirectLoopCVODE
    from flexmb.stepping import Run

    calls = []
    check = Run._restart_if_drifted

    def counted(self, solver):
        calls.append(solver.t)
        return check(self, solver)

    model, positions = scenes.b6(True, 8)
    spinning, initial = _spinning_fourbar()
    runs = [(spinning, 3.0, dict(initial, rtol=1e-8, atol=1e-10)),
            (model.build(complement="articulated"), 0.2, dict(positions=positions, rtol=3e-3, atol=3e-5))]
    for system, span, kw in runs:
        kw = dict(kw, method="CVODE_BDF", n_out=41, progress=False)
        monkeypatch.setattr(Run, "_restart_if_drifted", counted)
        new = fm.simulate(system, span, **kw)
        n_new = len(calls)
        monkeypatch.setattr(DirectLoopCVODE, "within_bound", lambda self, code: False)
        old = fm.simulate(system, span, **kw)
        monkeypatch.undo()
        _same(new, old)
        assert new.n_rebases == old.n_rebases and n_new <= len(calls) - n_new
        if system is spinning:
            assert new.n_projections >= 1 and new.n_rebases >= 3 and n_new < 0.5 * (len(calls) - n_new), (n_new, len(calls))
        calls.clear()


def test_progress_and_reused_systems_change_nothing(monkeypatch, python_jacobian):
    """The progress bar's marks (more returns to Python) and earlier runs on the same System object leave the
    counts and states as on a fresh object; B6 N = 8 restarts (projections) on the way."""
    model, positions = scenes.b6(True, 8)
    kw = dict(positions=positions, method="CVODE_BDF", rtol=1e-5, atol=1e-7, n_out=21)
    fresh = fm.simulate(model.build(complement="articulated"), 0.2, progress=False, **kw)
    assert fresh.n_projections >= 2
    system = model.build(complement="articulated")
    fm.simulate(system, 0.05, progress=False, **dict(kw, rtol=3e-3, atol=3e-5))
    fm.simulate(system, 0.05, progress=False, method="CVODE_Adams", positions=positions)
    again = fm.simulate(system, 0.2, progress=True, **kw)
    _same(again, fresh)
    with monkeypatch.context() as m:
        _sksundae(m)
        _same(fm.simulate(system, 0.2, progress=False, **kw), fresh)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_non_finite_rates_stop_with_time_and_cause(monkeypatch):
    """Accelerations that overflow stop the run with flexmb's diagnosis, its time and status, as on
    scikit-sundae's path."""
    model = fourbar()
    model.add(fm.PointForce("push", "coupler", (0.0, -1e300, 0.0), point=(0.15, 0.0, 0.0)))
    system = model.build(complement="articulated")
    assert direct_choice.compiled_loop(system, BDF, False, None) is DirectLoopCVODEBDF
    kw = dict(positions=fourbar_initial(), method="CVODE_BDF", progress=False)
    with monkeypatch.context() as m:
        _sksundae(m)
        with pytest.raises(fm.SimulationError) as old:
            fm.simulate(system, 1.0, **kw)
    # (the loop kernel names the overflow a freedom without mass, on both paths: its pivots are not finite)
    with pytest.raises(fm.SimulationError, match=r"at t = 0 s, joint 'B' moves no mass") as new:
        fm.simulate(system, 1.0, **kw)
    assert str(new.value) == str(old.value) and new.value.t == old.value.t
    assert new.value.result.status == "failed"


def test_max_steps_refuses_a_looped_run_before_it_starts():
    system, initial = _spinning_fourbar()
    with pytest.raises(fm.ModelError, match="max_steps"):
        fm.simulate(system, 1e4, method="CVODE_BDF", max_steps=1e3, progress=False, **initial)


def test_ctrl_c_stops_a_looped_run():
    """Ctrl-C while CVODE steps a looped model (dense Jacobian: B6 N = 8) stops the run at the loop's
    next return, as interrupted, with the outputs so far."""
    model, positions = scenes.b6(True, 8)
    system = model.build(complement="articulated")
    kw = dict(positions=positions, method="CVODE_BDF", rtol=1e-8, n_out=2, progress=False)
    fm.simulate(system, 1e-3, **kw)  # compiled first: the signal is to come while CVODE steps
    for delay in (0.05, 0.2):
        sender = subprocess.Popen(["sh", "-c", f"sleep {delay}; kill -INT {os.getpid()}"])
        t0 = time.perf_counter()
        try:
            res = fm.simulate(system, 1e3, **kw)  # millions of steps: far longer than the delay
        finally:
            sender.wait()
        assert time.perf_counter() - t0 < 30.0
        assert res.status == "interrupted" and res.message.startswith("interrupted by") and res.n_steps > 0, \
            (res.status, res.message)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_only_the_runs_loop_steps_it():
    """The loops' class steps only under the run's checks (step_on), and is restarted in place after a projection."""
    model, positions = scenes.b6(True, 8)
    system = model.build(complement="articulated")
    x, xd = fm.initial_state(system, 0.0, positions=positions)
    cv = DirectLoopCVODEBDF(None, 0.0, np.concatenate([x, xd]), 0.1, rtol=1e-6, atol=1e-8, system=system)
    with pytest.raises(TypeError, match="step_on"):
        cv.advance(0.05)
    code = cv.step_on(0.05, 1e-6)
    assert cv.t > 0 and cv.n_steps > 0 and code in (0, 2, 4)  # reached 0.05, paused, or drifted past 1e-6
    steps = cv.stats()["steps"]
    cv.restart(cv.y.copy())
    while cv.status == "running":
        cv.step_on(0.1, 1.0)
    assert cv.t >= 0.1 and cv.stats()["steps"] == cv.n_steps > steps
    cv.close()
