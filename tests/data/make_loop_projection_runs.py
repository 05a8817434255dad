"""Write loop_projection_runs.npz: the compiled loops' CVODE runs and CVODE's projection before its fused pass.

Generated with branch h-looprhs at dd2ab3e (main 7e2e2bb with the loops' rhs arithmetic of
session 9, whose last bits move the four-bars' and B7's steps; otherwise main's code: ``cvode_loop_callbacks.project``
evaluating the residuals by ``tree_equations(..., RESIDUALS)`` and then
projecting by ``loop_phi``, ``loop_min_norm`` and ``loop_speeds``, each
making its own kinematic pass; the run checking the drift again in Python
after a return whose last step CVODE projected);
tests/test_loop_projection_runs.py checks that the runs take the same
steps (counts exact, CVODE's own counters too) to the same states, and that
the projection gives the same corrections at perturbed states. Rerun only
to add cases, from a checkout of that commit (or of main 7e2e2bb, to compare
with the arithmetic before it):

    python tests/data/make_loop_projection_runs.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parent.parent / "benchmarks"))

import flexmb as fm  # noqa: E402
import scenes  # noqa: E402
from conftest import fourbar, fourbar_initial  # noqa: E402
from flexmb.integrators import cvode_direct_loops  # noqa: E402

#: CVODE's counters stored per run (DirectLoopCVODE.stats)
STATS = ("steps", "rhs", "jac", "err_test_fails", "newton_iters", "lin_setups", "psolves", "factors", "projections",
         "projections_refused")


def b6(n, rtol, planar=False):
    model, positions = scenes.b6(True, n)
    return model.build(complement="articulated", planar=planar), dict(positions=positions, rtol=rtol, atol=rtol / 100)


def spinning_fourbar():
    """The four-bar's crank turning over and over (restarts and offset moves; CVODE does not project)."""
    return fourbar().build(complement="articulated", planar=False), dict(positions=fourbar_initial(), speeds={"A": 30.0},
                                                          rtol=1e-8, atol=1e-10)


def b7(n):
    model, initial = scenes.b7(n)
    return model.build(complement="articulated", planar=False), dict(initial, rtol=1e-6, atol=1e-8)


#: name -> (system and options, span s, outputs)
RUNS = {"b6_8_3e-3": (lambda: b6(8, 3e-3), 0.2, 41), "b6_8_1e-4": (lambda: b6(8, 1e-4), 0.1, 21),
        "b6_32_1e-3": (lambda: b6(32, 1e-3), 0.05, 11), "fourbar_spinning": (spinning_fourbar, 3.0, 21),
        "b7_4": (lambda: b7(4), 2.0, 21)}
#: the stored projections (``cvode_loop_callbacks.project`` at perturbed states): models, perturbations,
#: the residual from which the state is projected; the models on the spatial path (planar=False: the stored
#: bits are its; the planar twin is tests/test_planar_projection.py's, against this path)
PROJECTION_MODELS = {"b6_8": lambda: b6(8, 3e-3, False),
                     "fourbar": lambda: (fourbar().build(complement="articulated", planar=False),
                                         dict(positions=fourbar_initial(), rtol=1e-6, atol=1e-8))}
PERTURB = (1e-7, 3e-6, 1e-4)
PROJ_TOL = 1e-6


def run(name):
    """One run: its counts, CVODE's counters, the outputs, the solver's user_data for the projections."""
    make, span, n_out = RUNS[name]
    system, kw = make()
    seen = {}
    close = cvode_direct_loops.DirectLoopCVODE.close

    def keep(self):
        if getattr(self, "_mem", None):
            seen.update(self.stats())
        close(self)

    cvode_direct_loops.DirectLoopCVODE.close = keep
    try:
        res = fm.simulate(system, span, method="CVODE_BDF", n_out=n_out, progress=False, **kw)
    finally:
        cvode_direct_loops.DirectLoopCVODE.close = close
    assert res.status == "finished", res.message
    counts = [res.n_steps, res.n_rhs, res.n_jac, res.n_projections, res.n_rebases] + [seen[k] for k in STATS]
    return np.array(counts, dtype=np.int64), res.x, res.xd


def captured(system, kw):
    """The user_data of a short run's DirectLoopCVODE (its buffers kept alive), the projection's settings fixed."""
    from flexmb.output_projection import OUTPUT_PROJECTION_GAIN

    got = {}
    close = cvode_direct_loops.DirectLoopCVODE.close

    def keep(self):
        if getattr(self, "_mem", None) and not got:
            got.update(ud=self._ud, arrays=self._arrays, cb=self._cb)
        close(self)

    cvode_direct_loops.DirectLoopCVODE.close = keep
    try:
        fm.simulate(system, 0.01, method="CVODE_BDF", n_out=2, progress=False, **kw)
    finally:
        cvode_direct_loops.DirectLoopCVODE.close = close
    cb, real = got["cb"], got["arrays"]["real"]
    real[cb.R_PROJ_TOL], real[cb.R_NEWTON_TOL], real[cb.R_GAIN] = PROJ_TOL, 1e-12, OUTPUT_PROJECTION_GAIN
    return got


def states(res, seed):
    """Perturbed states along a run: positions only, speeds only, both, at each size of PERTURB."""
    rng = np.random.default_rng(seed)
    ts, ys = [], []
    for k in range(1, len(res.t), max(1, len(res.t) // 4)):
        y = np.concatenate([res.x[k], res.xd[k]])
        n = res.x.shape[1]
        for eps in PERTURB:
            for part in ((0, n), (n, 2 * n), (0, 2 * n)):
                z = y.copy()
                z[part[0]:part[1]] += eps * rng.normal(size=part[1] - part[0])
                ts.append(float(res.t[k]))
                ys.append(z)
    return np.array(ts), np.array(ys)


def old_projection(cb, ud, t, y):
    """What ``cvode_loop_callbacks.project`` gave at 7e2e2bb: (0 kept / 1 moved / -1 refused, correction)."""
    n = int(ud[cb.N])
    real = cb._f1(ud[cb.A_REAL], cb.N_REAL)
    tol = real[cb.R_PROJ_TOL]
    position, velocity = cb._residuals(ud, t, y)
    corr = np.zeros(len(y))
    if not (position > tol or velocity > tol):
        return 0, corr
    x, v, converged = cb._projected(ud, t, y, position > tol)
    big = max(np.max(np.abs(x - y[:n])), np.max(np.abs(v - y[n:2 * n])))
    if not (converged and np.all(np.isfinite(x)) and np.all(np.isfinite(v))
            and big <= real[cb.R_GAIN] * max(position, velocity)):
        return -1, corr
    corr[:n], corr[n:2 * n] = x - y[:n], v - y[n:2 * n]
    return 1, corr


def projection_cases():
    """The projection at perturbed states of B6 N = 8 and the four-bar (PROJECTION_MODELS)."""
    out = {}
    for name, make in PROJECTION_MODELS.items():
        system, kw = make()
        res = fm.simulate(system, 0.2, method="CVODE_BDF", n_out=9, progress=False, **kw)
        got = captured(system, kw)
        ts, ys = states(res, 7)
        codes, corrs = [], []
        for t, y in zip(ts, ys):
            code, corr = old_projection(got["cb"], got["ud"], t, y)
            codes.append(code)
            corrs.append(corr)
        out[f"proj_{name}/t"], out[f"proj_{name}/y"] = ts, ys
        out[f"proj_{name}/code"], out[f"proj_{name}/corr"] = np.array(codes), np.array(corrs)
        print(name, np.unique(codes, return_counts=True))
    return out


def main():
    out = {}
    for name in RUNS:
        counts, x, xd = run(name)
        out[f"{name}/counts"], out[f"{name}/x"], out[f"{name}/xd"] = counts, x, xd
        print(name, counts)
    out.update(projection_cases())
    np.savez_compressed(HERE / "loop_projection_runs.npz", **out)


if __name__ == "__main__":
    main()
