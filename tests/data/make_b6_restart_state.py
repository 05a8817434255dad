"""Write b6_restart_state.npz: a drifted state of B6 damped at 256 segments where CVODE's restart failed.

``fm.simulate`` of B6 damped (benchmarks/scenes.py, 256 segments, the
articulated strategy, the defaults: CVODE_BDF by GMRES with the loops'
Newton preconditioner) projects CVODE's own state when the constraint
residual passes ``RESTART_TOL_MAX`` and restarts CVODE there. Up to commit
0958ca3 the restart took the last step as its first; at the fourth
projection (t = 0.956 s, last step 1.4e-4 s) the error test then failed
seven times, down to a step of 3.5e-11 s (flag -3). This script runs that
rule (:func:`_restart_with_the_last_step`) and writes
the state before the projection whose restart failed, the time and the
last step; tests/test_loops.py restarts from it by the current rule.

    OPENBLAS_NUM_THREADS=1 python tests/data/make_b6_restart_state.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent / "benchmarks"))

import flexmb as fm  # noqa: E402
import scenes  # noqa: E402
from flexmb import stepping  # noqa: E402

N_SEGMENTS = 256


def _restart_with_the_last_step(run, solver):
    """Run._restart_if_drifted of 0958ca3: the restarted solver's first step is the last one."""
    n, t_now = run.n, run.t_now
    xs, vs = solver.y[:n], solver.y[n : 2 * n]
    if run.system.constraint_residual(t_now, xs, vs) <= run.state_tol:
        return solver
    run.restarts.append((t_now, solver.y.copy(), solver.step_size))
    xs, vs = run.system.project(t_now, xs, vs, tol=min(1e-12, run.projection_tol), speeds="mass")
    run.n_proj += 1
    step = solver.step_size
    first = min(max(step, 1e-14), run.t_end - t_now) if step else None
    return run._make(t_now, np.concatenate([xs, vs, solver.y[2 * n :]]), first_step=first)


def main():
    restarts = []

    def hook(run, solver):
        run.restarts = restarts
        return _restart_with_the_last_step(run, solver)

    stepping.Run._restart_if_drifted = hook
    model, positions = scenes.b6(True, N_SEGMENTS)
    try:
        fm.simulate(model, 1.0, positions=positions, complement="articulated", progress=False)
    except fm.SimulationError as exc:
        t, y, step = restarts[-1]
        if abs(exc.t - t) > 1e-12:
            raise RuntimeError(f"the run failed at t = {exc.t}, not at a restart ({t})") from exc
        np.savez_compressed(HERE / "b6_restart_state.npz", n_segments=N_SEGMENTS, t=t, y=y, step=step)
        print(f"restart at t = {t:.9g} s after a step of {step:.3e} s: written")
        return
    raise RuntimeError("the run finished: no failing restart to record")


if __name__ == "__main__":
    main()
