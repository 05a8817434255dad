"""The compiled loops' outputs and the Result's quantities compiled are main's (tests/data/loop_outputs.npz).

The stored Results were computed by main before the change
(tests/data/make_loop_outputs.py, commit 7e2e2bb: each output interpolated,
projected by ``project_output`` and stored from Python after the step loop
returned); here the same simulations, whose outputs
:func:`~flexmb.kernels.loop_outputs.advance_storing` stores, must give every
array of the Result (states, positions, rotations, energies, residuals,
accelerations, reactions) to 1e-10 and every counter exactly: B6 N = 8
(CVODE projecting; and at rtol 1e-6, the run restarting), B6 N = 32, the
four-bars planar and spatial, spinning (winding offsets), B7 N = 4, and the
four-bar with projections refused (``OUTPUT_PROJECTION_GAIN`` patched: those
outputs go to the run's partial projection in Python). The Result's
quantities are evaluated in one compiled call
(:func:`flexmb.kernels.loop_states.loop_state_quantities`): they are also
compared with the system's routes state by state (the Python loop
``flexmb.output_quantities`` keeps for other models), bit for bit but the
kinetic energy (its sums in another order).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "data"))

import make_loop_outputs  # noqa: E402
import flexmb as fm  # noqa: E402
from flexmb import output_projection, output_quantities, stepping  # noqa: E402
from flexmb.integrators import cvode_direct_loops  # noqa: E402

DATA = np.load(HERE / "data" / "loop_outputs.npz")


def _compare(res, name):
    assert res.status == "finished", res.message
    for key in make_loop_outputs.ARRAYS:
        np.testing.assert_allclose(np.asarray(getattr(res, key)), DATA[f"{name}_{key}"], rtol=1e-10, atol=1e-10,
                                   err_msg=f"{name}: {key}")
    counts = [getattr(res, key) for key in make_loop_outputs.COUNTS]
    # main did not count the compiled right-hand sides in n_complements (each one loop solve; issue 31)
    counts[make_loop_outputs.COUNTS.index("n_complements")] -= res.n_rhs
    assert counts == list(DATA[f"{name}_counts"])


class _Counted:
    """Counts DirectLoopCVODE.step_on's returns and the outputs projected from Python (``project_output``)."""

    def __init__(self, monkeypatch):
        self.returns = self.python = 0
        step_on, project = cvode_direct_loops.DirectLoopCVODE.step_on, stepping.project_output

        def counted_step_on(solver, *args):
            self.returns += 1
            return step_on(solver, *args)

        def counted_project(*args):
            self.python += 1
            return project(*args)

        monkeypatch.setattr(cvode_direct_loops.DirectLoopCVODE, "step_on", counted_step_on)
        monkeypatch.setattr(stepping, "project_output", counted_project)


@pytest.mark.parametrize("name", list(make_loop_outputs.CASES))
def test_results_are_mains(monkeypatch, name):
    counted = _Counted(monkeypatch)
    res = make_loop_outputs.run(name)
    _compare(res, name)
    assert counted.returns > 0  # stepped by the compiled loops' CVODE
    n_out = len(res.t) - 1
    if name == "fourbar_refused":  # the refused ones (and only they) projected from Python
        assert 0 < counted.python < n_out
    else:
        assert counted.python == 0
        assert counted.returns < n_out / 2  # from output to output without returning (B6 N = 8: 7 for 100)


def test_the_comparison_can_fail():
    """A run whose outputs are not projected (projection_tol 1) differs from main's stored states."""
    model, kw, span = make_loop_outputs.CASES["fourbar"]()
    res = fm.simulate(model.build(), span, method="CVODE_BDF", progress=False, projection_tol=1.0, **kw)
    with pytest.raises(AssertionError):
        _compare(res, "fourbar")


def test_a_progress_bar_changes_nothing(monkeypatch):
    """With a progress bar the loop returns at its marks too (one stop per call); the Result is the same."""
    model, kw, span = make_loop_outputs.CASES["b6_8"]()
    kw = dict(kw)
    res = fm.simulate(model.build(complement=kw.pop("complement"), planar=False), span, method="CVODE_BDF", progress=True, **kw)
    _compare(res, "b6_8")


def test_outputs_store_handed_over(monkeypatch):
    """LoopOutputs gives the run its rows once each and counts the projections into the system's counter."""

    class Run:
        k_out, out_y = 1, []

        class system:
            n_complements = 5

    store = output_projection.LoopOutputs(np.linspace(0.0, 1.0, 5), 1, 3, 1e-10, False)
    store.Y[:] = np.arange(15.0).reshape(5, 3)
    store.k, store.made = 3, 2
    store.hand_over(Run)
    store.hand_over(Run)
    assert Run.k_out == 3 and Run.system.n_complements == 7
    assert [list(r) for r in Run.out_y] == [[3.0, 4.0, 5.0], [6.0, 7.0, 8.0]]
    assert store.newton_tol == 1e-12 and store.gain == output_projection.OUTPUT_PROJECTION_GAIN


@pytest.mark.parametrize("name", ["fourbar_spatial_cut", "b6_8_tight", "b7_4"])
def test_compiled_quantities_are_the_systems_routes(monkeypatch, name):
    """``Result.from_states`` at a run's states: the compiled call against the state-by-state routes (the
    spatial revolute closing the planar four-bar leaves redundant rows: their reactions the system's)."""
    res = make_loop_outputs.run(name)
    system = res.system
    assert output_quantities._compiled(system)
    redundant = []
    with_reactions = type(system)._with_reactions

    def counted(self, *args, **kwargs):
        redundant.append(args[0])
        return with_reactions(self, *args, **kwargs)

    monkeypatch.setattr(type(system), "_with_reactions", counted)
    start = system.n_complements
    compiled = fm.Result.from_states(system, res.x, res.xd, t=res.t)
    used = system.n_complements - start
    assert (len(redundant) > 0) == (name == "fourbar_spatial_cut")
    monkeypatch.setattr(output_quantities, "_compiled", lambda system: False)
    start = system.n_complements
    python = fm.Result.from_states(system, res.x, res.xd, t=res.t)
    assert system.n_complements - start == used
    for key in make_loop_outputs.ARRAYS:
        a, b = getattr(compiled, key), getattr(python, key)
        if key == "kinetic":
            np.testing.assert_allclose(a, b, rtol=1e-13, atol=0.0)
        else:
            assert np.array_equal(a, b), key


@pytest.mark.parametrize("method", ["CVODE_BDF", "GeneralizedAlpha"])
def test_compiled_right_hand_sides_are_counted_as_solves(method):
    """Each right-hand side of the compiled loops (CVODE's callback, generalized-alpha's loop) is one loop solve, as
    ``System._loop_solve`` counts it from Python: ``n_complements`` holds them (an open tree still has none)."""
    model, kw, span = make_loop_outputs.CASES["b6_8"]()
    kw = dict(kw)
    system = model.build(complement=kw.pop("complement"))
    kw["method"] = method
    calls = []
    loop_solve = type(system)._loop_solve

    def counted(self, *args, **kwargs):
        calls.append(1)
        return loop_solve(self, *args, **kwargs)

    type(system)._loop_solve = counted
    try:
        res = fm.simulate(system, span, progress=False, **kw)
    finally:
        type(system)._loop_solve = loop_solve
    assert res.status == "finished" and res.n_rhs > 10 * len(calls)  # the right-hand sides: compiled
    assert res.n_complements >= res.n_rhs
    b1 = fm.simulate(_b1(), 0.1, method=method, progress=False)
    assert b1.n_rhs > 0 and b1.n_complements == 0


def _b1():
    sys.path.insert(0, str(HERE.parent / "benchmarks"))
    from scenes import b1

    return b1(4).build()
