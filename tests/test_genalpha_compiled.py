"""Generalized-alpha stepped in compiled code (flexmb.genalpha.compiled) runs as the Python step did.

``simulate(..., method="GeneralizedAlpha")`` on an open tree whose force
elements are all compiled, with the dense iteration matrix, now takes its
steps between output times in compiled code. The old results are the test:
the runs of the per-step Python loop stored by
``tests/data/make_genalpha_compiled.py`` (before the compiled loop existed)
must be met with the same steps, right-hand sides (one per Newton iteration
and one at the start, so the same Newton iterations) and Jacobians, and the
same states to 1e-10; what ``simulate()`` does around the steps (the
monitor, the winding offsets, signals, failures) still happens.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import flexmb as fm
from flexmb.genalpha import GeneralizedAlpha, compiled, generalized_alpha
from flexmb.integrators import cvode_direct

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "data"))
sys.path.insert(0, str(HERE.parent / "benchmarks"))

import make_genalpha_compiled as ref  # noqa: E402

scenes = pytest.importorskip("scenes")
STORED = np.load(HERE / "data" / "genalpha_compiled.npz")
CASES = {name: (make, t_end, kw) for name, make, t_end, kw in ref.cases()}


def _python_step(monkeypatch):
    """Make simulate() take the Python step of GeneralizedAlpha for every model (as before the compiled loop)."""
    monkeypatch.setattr(compiled, "compiled_genalpha", lambda *args: None)


def _counting(monkeypatch):
    """Count the calls of the compiled loop (``calls[0]``)."""
    from flexmb.kernels import genalpha_loop

    calls = [0]
    original = genalpha_loop.advance

    def counted(*args):
        calls[0] += 1
        return original(*args)

    monkeypatch.setattr(genalpha_loop, "advance", counted)
    return calls


@pytest.mark.parametrize("name", sorted(CASES))
def test_stored_python_runs_are_met(monkeypatch, name):
    """B1 N = 8 and 64, B2 N = 16, a winding pendulum; max_step, t_eval, rho_inf 0.6, a fixed step; the dense
    iteration matrix stepped in compiled code, the Krylov one (B1 N = 64 by default) still in Python."""
    calls = _counting(monkeypatch)
    make, t_end, kw = CASES[name]
    new = ref.run(name, make, t_end, kw)
    for key in ("steps", "rhs", "jac", "rebases"):
        assert new[key] == int(STORED[f"{name}/{key}"]), key
    assert np.array_equal(new["t"], STORED[f"{name}/t"])
    assert np.max(np.abs(new["x"] - STORED[f"{name}/x"])) <= 1e-10
    assert np.max(np.abs(new["xd"] - STORED[f"{name}/xd"])) <= 1e-10
    assert (calls[0] == 0) == name.endswith("krylov")
    if name == "b1_8_default":  # 2564 steps: back in Python at the 10 outputs, the monitor's 5 checkpoints, the
        assert calls[0] <= 17  # Jacobian (the LU factors of each new step size are LAPACK's, called from the loop)


def test_chosen_where_the_rhs_is_compiled():
    b1 = scenes.b1(8).build()
    ga = GeneralizedAlpha
    cls = compiled.compiled_genalpha(b1, ga, False, None, False)
    assert issubclass(cls, compiled.CompiledGeneralizedAlpha) and issubclass(cls, ga) and cls.steps_in_compiled_code
    configured = generalized_alpha(0.6)
    assert compiled.compiled_genalpha(b1, configured, False, None, False).rho_inf == 0.6
    assert compiled.compiled_genalpha(b1, ga, True, None, False) is None  # work rates: Python
    assert compiled.compiled_genalpha(b1, ga, False, object(), False) is None  # contact events
    assert compiled.compiled_genalpha(b1, ga, False, None, True) is None  # matrix-free Newton solves
    own = type("Own", (ga,), {"_newton": lambda self, t1, h: ga._newton(self, t1, h)})
    assert compiled.compiled_genalpha(b1, own, False, None, False) is None  # a step of its own
    assert compiled.compiled_genalpha(b1, fm.registry.get("integrators", "Radau"), False, None, False) is None
    from flexmb.scenes.fourbar import fourbar

    assert compiled.compiled_genalpha(fourbar()[0].build(), ga, False, None, False) is None  # loops, dense
    import rotations

    top = rotations.flexmb_model("top").build()  # Euler parameters: the rotation chart steps in Python
    assert compiled.compiled_genalpha(top, ga, False, None, False) is None
    assert compiled.compiled_genalpha(b1, cls, False, None, False) is cls
    assert compiled.compiled_genalpha(top, cls, False, None, False) is None
    with pytest.raises(ValueError, match="open tree"):
        cls(None, 0.0, np.zeros(top.layout.size), 1.0, system=top)


def test_monitor_gets_every_step(monkeypatch):
    """The resolution monitor counts every step and judges at its checkpoints, fed by the compiled loop."""
    from flexmb.integrators import monitor

    made = []
    original = monitor.ResolutionMonitor.for_run.__func__

    def keep(cls, *args, **kwargs):
        made.append(original(cls, *args, **kwargs))
        return made[-1]

    monkeypatch.setattr(monitor.ResolutionMonitor, "for_run", classmethod(keep))
    system = scenes.b1(8).build()
    kw = dict(method="GeneralizedAlpha", rtol=1e-6, n_out=3, progress=False)
    with monkeypatch.context() as m:
        _python_step(m)
        old = fm.simulate(system, 0.5, **kw)
    new = fm.simulate(system, 0.5, **kw)
    assert made[1].n_steps == made[0].n_steps == new.n_steps == old.n_steps > 400
    assert made[1].next_check == made[0].next_check and made[1].steps == made[0].steps


def test_paused_calls_take_the_same_steps(monkeypatch):
    system = scenes.b1(8).build()
    kw = dict(method="GeneralizedAlpha", rtol=1e-6, n_out=5, progress=False)
    res = fm.simulate(system, 0.5, **kw)
    monkeypatch.setattr(cvode_direct, "STEPS_PER_CALL", 7)  # back in Python every 7 steps (signals handled there)
    calls = _counting(monkeypatch)
    few = fm.simulate(system, 0.5, **kw)
    assert calls[0] > res.n_steps // 7
    assert (few.n_steps, few.n_rhs, few.n_jac) == (res.n_steps, res.n_rhs, res.n_jac)
    assert np.array_equal(few.x, res.x) and np.array_equal(few.xd, res.xd)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_non_finite_rates_stop_with_time_and_cause(monkeypatch):
    """Accelerations that overflow stop the run with flexmb's diagnosis, at the time the Python step stopped."""
    model = scenes.b1(4)
    model.add(fm.PointForce("push", "beam", (0.0, 0.0, -1e300), point=(1.0, 0.0, 0.0)))
    system = model.build()
    kw = dict(method="GeneralizedAlpha", progress=False)
    with monkeypatch.context() as m:
        _python_step(m)
        with pytest.raises(fm.SimulationError) as old:
            fm.simulate(system, 1.0, **kw)
    with pytest.raises(fm.SimulationError, match=r"at t = 1e-12 s: the state overflowed: .* 'push'") as new:
        fm.simulate(system, 1.0, **kw)
    assert str(new.value) == str(old.value) and new.value.t == old.value.t
    assert new.value.result.status == "failed"


def test_fixed_step_newton_failure_as_before(monkeypatch):
    """A fixed step too long for Newton fails with the Python step's message and time."""
    system = ref.spinning_pendulum()
    kw = dict(method=generalized_alpha(0.8, fixed_step=0.5), speeds={"pin": 40.0}, progress=False)
    with monkeypatch.context() as m:
        _python_step(m)
        with pytest.raises(fm.SimulationError) as old:
            fm.simulate(system, 5.0, **kw)
    calls = _counting(monkeypatch)
    with pytest.raises(fm.SimulationError, match="Newton's method failed at t = .* with the fixed step") as new:
        fm.simulate(system, 5.0, **kw)
    assert calls[0] > 0
    assert str(new.value) == str(old.value) and new.value.t == old.value.t


def test_ctrl_c_stops_a_long_interval():
    """Ctrl-C while the compiled loop steps stops the run at the loop's next return."""
    # undamped: the steps stay small (the damped beam settles, its steps grow, and on the planar path it runs
    # the 1e5 s below in about the longest delay)
    system = scenes.b1(8, damped=False).build()
    kw = dict(method="GeneralizedAlpha", rtol=1e-8, n_out=2, progress=False)
    fm.simulate(system, 1e-3, **kw)  # compiled first: the signal is to come while the loop steps
    # at different moments of the loop; not so early that a loaded machine is still setting up the run (at 0.02 s
    # tests/test_cvode_direct.py's run was interrupted before its first step under a load of 9 on 2 cores)
    for delay in (0.2, 0.45, 0.8):
        sender = subprocess.Popen(["sh", "-c", f"sleep {delay}; kill -INT {os.getpid()}"])
        t0 = time.perf_counter()
        try:
            res = fm.simulate(system, 1e5, **kw)  # millions of steps: far longer than the delay
        finally:
            sender.wait()
        assert time.perf_counter() - t0 < 20.0
        assert res.status == "interrupted" and res.message.startswith("interrupted by") and res.n_steps > 0, \
            (res.status, res.message)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
