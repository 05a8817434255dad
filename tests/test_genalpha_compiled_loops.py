"""Generalized-alpha stepped in compiled code on looped models (CompiledLoopGeneralizedAlpha) as the Python step.

``simulate(..., method="GeneralizedAlpha")`` on a model whose loops CVODE's
compiled loops serve (articulated complement, compiled loads, drivers with
a closed form) now steps, stores its outputs and projects its drifted
state in compiled code. With the Jacobian from Python in both (the solver's
own, as the Python step forms it), the runs are those of the Python step:
the same steps, right-hand sides, Jacobians and projections, the same
states to 1e-10. The Jacobian formed in the loop (the compiled
``System.state_jacobian``) moves the last bits, so those runs are held to
agree with the others to the tolerance. Failures and returns to Python
(winding offsets, the budget of steps, a failed right-hand side) act as in
the Python step.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import flexmb as fm
from flexmb.genalpha import GeneralizedAlpha, compiled
from flexmb.genalpha.compiled import CompiledLoopGeneralizedAlpha
from flexmb.integrators import cvode_direct
from flexmb.scenes.fourbar import fourbar

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
scenes = pytest.importorskip("scenes")


def _python_step(m):
    """Make simulate() take the Python step of GeneralizedAlpha (as before the compiled loops)."""
    m.setattr(compiled, "compiled_genalpha", lambda *args: None)


def _counting(m):
    """Count the calls of the loops' compiled loop (``calls[0]``)."""
    from flexmb.kernels import genalpha_loops

    calls = [0]
    original = genalpha_loops.advance

    def counted(*args):
        calls[0] += 1
        return original(*args)

    m.setattr(genalpha_loops, "advance", counted)
    return calls


def _b6(n=8):
    # on the spatial path (planar=False): the Python step projects with the spatial kernels, and the compiled loop
    # meets it to the bit there; the planar projection's agreement is tests/test_planar_projection.py's
    model, positions = scenes.b6(damped=True, n_segments=n)
    return model.build(planar=False), dict(positions=positions)


def _fourbar():
    model, initial, fixed = fourbar()
    return model.build(), dict(positions=initial, fixed=fixed)


CASES = {  # model, span, settings (B6: its crank winds past the bound: the offsets move in the run)
    "b6_8": (_b6, 0.5, dict(rtol=1e-3, atol=1e-5, n_out=101)),
    "b6_8_tight": (_b6, 0.1, dict(rtol=1e-5, atol=1e-7, n_out=11)),
    "fourbar": (_fourbar, 1.0, dict(rtol=1e-6, atol=1e-8, n_out=21)),
}


def _run(name, **extra):
    make, t_end, kw = CASES[name]
    system, where = make()
    return fm.simulate(system, t_end, **dict(dict(method="GeneralizedAlpha", complement="articulated", progress=False),
                                             **where, **kw, **extra))


def _same(new, old):
    for key in ("n_steps", "n_rhs", "n_jac", "n_projections", "n_rebases"):
        assert getattr(new, key) == getattr(old, key), key
    assert np.array_equal(new.t, old.t)
    assert np.max(np.abs(new.x - old.x)) <= 1e-10
    assert np.max(np.abs(new.xd - old.xd)) <= 1e-10


@pytest.mark.parametrize("name", sorted(CASES))
def test_the_python_step_is_met(monkeypatch, name):
    """With the Python Jacobian, the compiled loop takes the Python step's steps, Jacobians and projections."""
    with monkeypatch.context() as m:
        _python_step(m)
        old = _run(name)
    monkeypatch.setattr(CompiledLoopGeneralizedAlpha, "jacobian_in_loop", False)
    calls = _counting(monkeypatch)
    new = _run(name)
    assert calls[0] > 0 and new.status == old.status == "finished"
    _same(new, old)
    assert old.n_projections > 0 or name == "fourbar"
    if name == "b6_8":
        assert new.n_rebases > 0  # the crank wound past the bound: the run moved the offsets
        assert calls[0] <= 2 * new.n_jac + new.n_rebases + 10  # back in Python for those, not per step or output


@pytest.mark.parametrize("name", ["b6_8_tight", "fourbar"])
def test_jacobian_in_the_loop_agrees(monkeypatch, name):
    """The Jacobian formed in the loop (compiled) moves last bits only: the runs agree to their tolerance."""
    new = _run(name)
    monkeypatch.setattr(CompiledLoopGeneralizedAlpha, "jacobian_in_loop", False)
    old = _run(name)
    rtol = CASES[name][2]["rtol"]
    assert abs(new.n_steps - old.n_steps) <= 0.05 * old.n_steps
    assert np.max(np.abs(new.x - old.x)) <= 100 * rtol * max(1.0, np.max(np.abs(old.x)))
    assert np.max(new.residual) <= 1e-10 and np.max(old.residual) <= 1e-10


def test_chosen_where_the_loops_are_compiled():
    ga = GeneralizedAlpha
    dense, _ = _fourbar()
    if not dense._loop_kernel:  # a dense complement strategy: the Python step
        assert compiled.compiled_genalpha(dense, ga, False, None, False) is None
    b6 = _b6()[0].with_complement("articulated")
    cls = compiled.compiled_genalpha(b6, ga, False, None, False)
    assert cls is not None and issubclass(cls, CompiledLoopGeneralizedAlpha) and issubclass(cls, ga)
    assert compiled.compiled_genalpha(b6, ga, True, None, False) is None  # work rates: Python
    assert compiled.compiled_genalpha(b6, ga, False, object(), False) is None  # contact events
    assert compiled.compiled_genalpha(b6, ga, False, None, True) is None  # matrix-free Newton solves
    assert compiled.compiled_genalpha(b6, cls, False, None, False) is cls
    b1 = scenes.b1(8).build()
    assert compiled.compiled_genalpha(b1, cls, False, None, False) is None  # the loops' class on an open tree
    with pytest.raises(TypeError, match="step_on"):
        cls.advance(object.__new__(cls), 1.0)
    with pytest.raises(ValueError, match="loops closed by the articulated strategy"):
        cls(None, 0.0, np.zeros(b1.layout.size), 1.0, system=b1)


def test_paused_calls_take_the_same_steps(monkeypatch):
    res = _run("b6_8_tight")
    monkeypatch.setattr(cvode_direct, "STEPS_PER_CALL", 7)  # back in Python every 7 steps (signals handled there)
    calls = _counting(monkeypatch)
    few = _run("b6_8_tight")
    assert calls[0] > res.n_steps // 7
    _same(few, res)


def test_progress_marks_take_the_same_steps():
    res = _run("b6_8_tight")
    marked = _run("b6_8_tight", progress=True)
    _same(marked, res)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_failed_rates_stop_as_the_python_step(monkeypatch):
    """A right-hand side that fails in the loop stops the run with flexmb's diagnosis, where the Python step did."""
    def make():
        model, positions = scenes.b6(damped=True, n_segments=8)
        model.add(fm.PointForce("push", "crank", (0.0, 1e300, 0.0), point=(0.1, 0.0, 0.0)))
        return model.build(), dict(positions=positions)

    kw = dict(method="GeneralizedAlpha", complement="articulated", rtol=1e-3, atol=1e-5, progress=False)
    system, where = make()
    with monkeypatch.context() as m:
        _python_step(m)
        with pytest.raises(fm.SimulationError) as old:
            fm.simulate(system, 0.1, **where, **kw)
    calls = _counting(monkeypatch)
    system, where = make()
    with pytest.raises(fm.SimulationError) as new:
        fm.simulate(system, 0.1, **where, **kw)
    assert calls[0] > 0
    assert str(new.value) == str(old.value) and new.value.t == old.value.t
    assert new.value.result.status == "failed"
