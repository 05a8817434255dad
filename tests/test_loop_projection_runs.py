"""CVODE's projection on the compiled loops in one kinematic pass per position, and the run's drift check left to it.

The old results are the test (tests/data/loop_projection_runs.npz, written
by tests/data/make_loop_projection_runs.py at main 7e2e2bb, where
``cvode_loop_callbacks.project`` made a kinematic pass for the residuals
and one more in each of ``loop_phi``, ``loop_min_norm`` and
``loop_speeds``, and the run checked the drift again in Python after
returns whose last step CVODE projected):
:func:`~flexmb.kernels.step_projection.step_projection` gives the same
corrections at perturbed states, and the runs take the same steps (CVODE's
counters exact) to the same states: B6 with CVODE projecting
(``project=True``), the spinning four-bar and B7 N = 4 without (restarts and
offset moves as before).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import flexmb as fm

DATA = Path(__file__).resolve().parent / "data"
sys.path.insert(0, str(DATA))
sys.path.insert(0, str(DATA.parent.parent / "benchmarks"))
pytest.importorskip("scenes")

import make_loop_projection_runs as ref  # noqa: E402

STORED = np.load(DATA / "loop_projection_runs.npz")


def _new_projection(cb, ud, t, y):
    """What ``project`` gives now at ``(t, y)``: (0 kept / 1 moved / -1 refused, correction), as the old one's."""
    from flexmb.kernels.step_projection import KEPT, MOVED, REFUSED, step_projection

    n, nd = int(ud[cb.N]), int(ud[cb.N_DRV])
    real = cb._f1(ud[cb.A_REAL], cb.N_REAL)
    drv = cb._drivers(ud)
    cols = np.array([int(drv[k, 0]) for k in range(nd)], dtype=np.int64)
    p_d = np.array([cb.driver(drv, k, t)[0] for k in range(nd)])
    v_d = np.array([cb.driver(drv, k, t)[1] for k in range(nd)])
    what, position, velocity, x, v = step_projection(cb._packed(ud), cb._layout(ud), y, n, cols, p_d, v_d,
                                                     real[cb.R_PROJ_TOL], real[cb.R_NEWTON_TOL], real[cb.R_GAIN],
                                                     real[cb.R_TOL], real[cb.R_WINDOW], ud[cb.RANK_LIMIT])
    assert (position, velocity) == cb._residuals(ud, t, y)  # the step loop's drift check, the same arithmetic
    corr = np.zeros(len(y))
    if what == MOVED:
        corr[:n], corr[n:2 * n] = x - y[:n], v - y[n:2 * n]
    return {KEPT: 0, MOVED: 1, REFUSED: -1}[what], corr


@pytest.mark.parametrize("name", sorted(ref.PROJECTION_MODELS))
def test_projection_gives_the_old_corrections(name):
    """Kept, speeds only and positions and speeds, at perturbations of 1e-7 to 1e-4: the old decision and the
    old correction, bit for bit (the positions' rows do not read the speeds; phi is the rows' own)."""
    system, kw = ref.PROJECTION_MODELS[name]()
    got = ref.captured(system, kw)
    codes = STORED[f"proj_{name}/code"]
    assert set(codes) == {0, 1}
    for t, y, code, corr in zip(STORED[f"proj_{name}/t"], STORED[f"proj_{name}/y"], codes,
                                STORED[f"proj_{name}/corr"]):
        new_code, new_corr = _new_projection(got["cb"], got["ud"], t, y)
        assert new_code == code
        assert np.array_equal(new_corr, corr)


@pytest.mark.parametrize("name", sorted(ref.RUNS))
def test_runs_take_the_old_steps(name):
    """The same steps, right-hand sides, Jacobians, error-test failures, Newton iterations, projections (CVODE's
    and the run's restarts) and offset moves, to the same states."""
    counts, x, xd = ref.run(name)
    assert counts.tolist() == STORED[f"{name}/counts"].tolist()
    assert np.max(np.abs(x - STORED[f"{name}/x"])) <= 1e-12 and np.max(np.abs(xd - STORED[f"{name}/xd"])) <= 1e-10


def test_the_run_checks_the_drift_after_moved_states_only(monkeypatch):
    """B6 N = 8 at rtol 3e-3 (CVODE projecting): the run's own drift check (Python) is not evaluated after any
    return: the step loop checked the last state, or CVODE's projection kept it (within half the bound) or moved
    it onto the constraints (then the loop's compiled ``drift`` evaluates it at the return)."""
    from flexmb.stepping import Run

    calls = []
    check = Run._restart_if_drifted

    def counted(self, solver):
        calls.append(solver.t)
        return check(self, solver)

    monkeypatch.setattr(Run, "_restart_if_drifted", counted)
    counts, x, xd = ref.run("b6_8_3e-3")
    assert counts.tolist() == STORED["b6_8_3e-3/counts"].tolist()
    assert calls == []
