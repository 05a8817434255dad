"""Where a step of the compiled loops' CVODE goes on B6 damped (issue 28): counts x least CPU per call.

    OPENBLAS_NUM_THREADS=1 python benchmarks/probe_b6_step.py --n 8 32 128 --rounds 5

For each N: ``fm.simulate(system, 0.5, method="CVODE_BDF", rtol=3e-3,
atol=rtol / 100, n_out=101, complement="articulated")`` (the settings of
``peers/cpu_b6.py``; kernels warm; least CPU of ``--rounds``), its exact
counts (steps, right-hand sides, Jacobians or preconditioner set-ups,
the preconditioner's factorisations and solves, projections: CVODE's
counters read from :class:`~flexmb.integrators.cvode_direct_loops.DirectLoopCVODE`
before it is closed), and the parts timed per call, each in a loop, least
CPU of the rounds, at the run's initial state:

* the right-hand side :func:`~flexmb.kernels.loops.loop_rhs_into` as its C
  callback calls it (one work array), and its parts (the rows into given arrays, the others their allocating
  forms), each cumulated in a compiled loop: the tree's kinematics and loads (``loaded_state``), the rows' wrenches
  (``_rows_into``), the factors (the articulated factorisation, ``K = psi A^-1
  psi^T`` by m recursions and its factorisation: ``_constrained_factor``),
  and the solve (``a0`` by the recursion, the m x m solve, the response:
  ``_constrained_apply``);
* the dense Jacobian (below ``KRYLOV_MIN_COORDS``): ``System.state_jacobian``
  from Python (what the run called before) and the compiled
  :func:`~flexmb.kernels.loop_jacobian.loop_state_jacobian` (what its C
  callback calls now, where ``compiled_jacobian`` says it applies);
* with GMRES (from ``KRYLOV_MIN_COORDS``), the preconditioner's
  factorisation (``loop_newton_factor``) and solve (``loop_newton_solve``),
  and the compiled ``J v`` (:mod:`flexmb.kernels.loop_jtimes`, where the run
  takes it: ``jtimes`` counted): the terms of G (made once per new Jacobian
  where G is lagged) and the product;
* the step loop's drift check after every step (the cut joints'
  residuals, ``tree_equations(..., RESIDUALS)``); where CVODE projects
  (``project=True``: the loop's drift check is skipped after a step the
  projection kept or moved) CVODE's projection callback instead, called on
  every attempt of a step
  (:func:`~flexmb.kernels.step_projection.step_projection`): at the run's
  state (kept: the residuals' one kinematic pass), and with its speeds, or
  its positions and speeds, moved off the constraints by 1e-5 (projected);
  the run's counts of moved and refused projections are CVODE's
  (``projections``, ``projections_refused``).

The run's CPU is split into the time inside the compiled step loop
(``loop_outputs.advance_storing``: CVODE, the callbacks, the checks, the
outputs' interpolation and projection; ``returns``: its calls from
Python), the Result's quantities (``output_quantities.evaluate_states``,
``result_s``) and the rest (Python: the run's bookkeeping, restarts,
the Result's construction); CVODE's own work (its linear algebra, error
test, interpolation) is the time inside the loop less the callbacks'
counts x per-call costs (the outputs' projections included in it).
One JSON line per N goes to ``--out`` (``benchmarks/results/probe_b6_step.jsonl``, appended).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import scenes  # noqa: E402

import flexmb as fm  # noqa: E402
from flexmb import output_quantities, result as result_module  # noqa: E402
from flexmb.integrators import cvode_direct, cvode_direct_loops  # noqa: E402
from flexmb.kernels import loop_outputs  # noqa: E402
from flexmb.kernels.cache import njit  # noqa: E402
from flexmb.kernels.constraints import ROWS_SCRATCH  # noqa: E402
from flexmb.kernels.equations import RESIDUALS, loaded_state, tree_equations  # noqa: E402
from flexmb.kernels.loop_jacobian import loop_state_jacobian  # noqa: E402
from flexmb.kernels.loop_jtimes import jtimes_size, keep_factors, prepare, state_jacobian_times  # noqa: E402
from flexmb.kernels.step_projection import step_projection  # noqa: E402
from flexmb.kernels.loops import (_arrays, _constrained_apply, _constrained_factor, _minus_bias_wrenches,  # noqa: E402
                                  _rows_into, loop_newton_factor, loop_newton_solve, loop_rhs_factors_into,
                                  loop_rhs_into, loop_rhs_work_size)

SPAN, RTOL = 0.5, 3e-3


@njit
def _time_rhs(packed, layout, y, n, gamma_d, tol, window, rank_limit, reps, upto):
    """``reps`` right-hand sides cut after part ``upto`` (0 kinematics and loads, 1 rows, 2 factors, 3 all)."""
    s = 0.0
    m = layout.row_coord.shape[0]
    W, gamma, phi, scratch = np.empty((m, 2, 6)), np.empty(m), np.empty(m), np.empty(ROWS_SCRATCH)
    body = layout.row_body
    for _ in range(reps):
        zeros = np.zeros((layout.root_of.shape[0] + 1, 3))
        tree, cuts, kin, spatial, fw, tw, generalized = loaded_state(packed, y, n, np.zeros(0), zeros, zeros,
                                                                      np.zeros(n))
        if upto == 0:
            s += spatial[0, 0, 0]
            continue
        R, origin, r, omega, v, alpha, acc, jp, Sw, Sv = kin
        nb = tree.parent.shape[0]
        _rows_into(tree, cuts, R, origin, r, omega, v, alpha, acc, gamma_d, W, gamma, phi, scratch, body[:0])
        if upto == 1:
            s += gamma[0]
            continue
        arrays = _arrays(layout)
        factors = _constrained_factor(tree.parent, tree.coord_start, Sw, Sv, spatial, W, body, layout.row_coord,
                                      arrays, layout.band, tol, window, rank_limit, np.zeros(n))
        if upto == 2:
            s += factors[5][0]
            continue
        x, lam, kept, smallest, status = _constrained_apply(tree.parent, tree.coord_start, Sw, Sv, W, body,
                                                            layout.row_coord, arrays[6], layout.band, factors,
                                                            _minus_bias_wrenches(nb, r, fw, tw), generalized, gamma)
        s += x[0]
    return s


@njit
def _time_loop_rhs(packed, layout, y, n, gamma_d, tol, window, rank_limit, reps):
    """``reps`` calls of loop_rhs_into as the C callback makes them (one work array for all the calls)."""
    s = 0.0
    nb, m = layout.root_of.shape[0], layout.row_coord.shape[0]
    zeros = np.zeros((nb + 1, 3))
    work, xdd, lam, generalized0 = np.empty(loop_rhs_work_size(nb, n, m)), np.empty(n), np.empty(m), np.zeros(n)
    for _ in range(reps):
        loop_rhs_into(packed, layout, y, n, np.zeros(0)[:0], zeros, zeros, generalized0, gamma_d, tol, window,
                      rank_limit, xdd, lam, work)
        s += xdd[0]
    return s


@njit
def _time_newton(packed, layout, x, armature, tol, rank_limit, load, reps, solve):
    """``reps`` factorisations (solve False) or solves (True) of the loops' Newton preconditioner."""
    s = 0.0
    factored = loop_newton_factor(packed, layout, x.copy(), armature, tol, rank_limit)
    for _ in range(reps):
        if solve:
            s += loop_newton_solve(factored, packed, layout, load)[0][0]
        else:
            s += loop_newton_factor(packed, layout, x.copy(), armature, tol, rank_limit)[0][0, 0]
    return s


@njit
def _time_jtimes(packed, layout, y, n, K, C, gamma_d, tol, window, rank_limit, reps, product):
    """``reps`` makings of the compiled J v's terms of G (product False) or products (with G's terms lagged)."""
    nb, mr, band, m = layout.root_of.shape[0], layout.row_coord.shape[0], layout.band, y.shape[0]
    work, xdd, lam = np.empty(loop_rhs_work_size(nb, n, mr)), np.empty(n), np.empty(mr)
    zeros = np.zeros((nb + 1, 3))
    factors = loop_rhs_factors_into(packed, layout, y, n, np.zeros(0), zeros, zeros, np.zeros(n), gamma_d, tol, window,
                                    rank_limit, xdd, lam, work)[3]
    jt, terms = np.zeros(jtimes_size(n, m, mr, band, mr * mr)), np.zeros(21 * n)
    keep_factors(jt, y, xdd, n, m, mr, band, factors)
    prepare(packed, jt, terms, work, n, m)
    v, Jv = np.linspace(-1.0, 1.0, m), np.empty(m)
    s = 0.0
    for _ in range(reps):
        if product:
            s += state_jacobian_times(packed, layout, jt, terms, work, n, m, K, C, v, Jv)[1] + Jv[n]
        else:
            prepare(packed, jt, terms, work, n, m)
            s += terms[-1]
    return s


@njit
def _time_jacobian(packed, layout, y, n, K, C, gamma_d, tol, window, rank_limit, reps):
    """``reps`` compiled Jacobians (as the C callback ``jac`` makes them)."""
    s = 0.0
    for _ in range(reps):
        J = np.empty((2 * n, 2 * n))
        loop_state_jacobian(packed, layout, y, n, K, C, gamma_d, tol, window, rank_limit, J)
        s += J[n, 0]
    return s


@njit
def _time_drift(packed, y, n, nb, reps):
    """``reps`` drift checks of the step loop (the cut joints' residuals, ``tree_equations(..., RESIDUALS)``)."""
    s = 0.0
    for _ in range(reps):
        zeros = np.zeros((nb + 1, 3))
        s += tree_equations(packed, y, n, RESIDUALS, np.zeros(0), zeros, zeros, np.zeros(n))[2][0]
    return s


@njit
def _time_projection(packed, layout, y, n, cols, p_d, v_d, tol, rank_tol, window, rank_limit, reps):
    """``reps`` calls of CVODE's projection callback's work (:func:`step_projection`) at ``y``."""
    s = 0.0
    for _ in range(reps):
        s += step_projection(packed, layout, y, n, cols, p_d, v_d, tol, 0.1 * tol, 1e3, rank_tol, window,
                             rank_limit)[1]
    return s


def _least(f, reps, rounds):
    best = np.inf
    for _ in range(rounds):
        c0 = time.process_time()
        f(reps)
        best = min(best, time.process_time() - c0)
    return best / reps


def run_once(system, positions):
    """One timed simulate; its CPU, error-free counts and the solver's own counters."""
    from flexmb.integrators import cvode_direct_loops as cdl

    seen = {}
    close = cdl.DirectLoopCVODE.close

    def keep(self):
        if getattr(self, "_mem", None):
            seen.update(self.stats())
        close(self)

    cdl.DirectLoopCVODE.close = keep
    inside, returns, result = [0.0], [0], [0.0]
    advance, evaluate = loop_outputs.advance_storing, output_quantities.evaluate_states

    def timed(*args):
        c0 = time.process_time()
        try:
            return advance(*args)
        finally:
            inside[0] += time.process_time() - c0
            returns[0] += 1

    def timed_result(*args):
        c0 = time.process_time()
        try:
            return evaluate(*args)
        finally:
            result[0] += time.process_time() - c0

    loop_outputs.advance_storing, result_module.evaluate_states = timed, timed_result
    try:
        kw = dict(positions=positions, complement="articulated", method="CVODE_BDF", rtol=RTOL, atol=RTOL / 100,
                  n_out=101, progress=False)
        c0 = time.process_time()
        res = fm.simulate(system, SPAN, **kw)
        cpu = time.process_time() - c0
    finally:
        cdl.DirectLoopCVODE.close = close
        loop_outputs.advance_storing, result_module.evaluate_states = advance, evaluate
    counts = dict(steps=int(res.n_steps), rhs=int(res.n_rhs), jac=int(res.n_jac), projections=int(res.n_projections),
                  cvode_projections=int(res.n_cvode_projections))
    seen.update(inside_s=inside[0], returns=returns[0], result_s=result[0])
    return cpu, counts, seen, res


def probe(n_seg: int, rounds: int) -> dict:
    model, positions = scenes.b6(damped=True, n_segments=n_seg)
    system = model.build()
    kw = dict(positions=positions, complement="articulated", method="CVODE_BDF", rtol=RTOL, atol=RTOL / 100,
              n_out=101, progress=False)
    fm.simulate(system, 0.01, **kw)  # kernels loaded, the complement chosen
    cpu, inside, result = np.inf, np.inf, np.inf
    for _ in range(rounds):
        c, counts, solver, res = run_once(system, positions)
        cpu, inside, result = min(cpu, c), min(inside, solver["inside_s"]), min(result, solver["result_s"])
    # the state the parts are timed at: the run's state at 0.25 s
    y = np.concatenate([res.x[50], res.xd[50]])
    n = system.n_speeds
    t = float(res.t[50])
    packed, layout = system._packed, system._loop_layout
    gamma_d = np.zeros(len(system.constraints.drivers))
    tol, window = system._loop_tol, system.singular_window()
    rank_limit = -1 if system.rank_limit is None else system.rank_limit
    reps = max(200, 40000 // n)
    _time_rhs(packed, layout, y, n, gamma_d, tol, window, rank_limit, 1, 3)
    _time_loop_rhs(packed, layout, y, n, gamma_d, tol, window, rank_limit, 1)
    cum = [_least(lambda r, k=k: _time_rhs(packed, layout, y, n, gamma_d, tol, window, rank_limit, r, k), reps, rounds)
           for k in range(4)]
    whole = _least(lambda r: _time_loop_rhs(packed, layout, y, n, gamma_d, tol, window, rank_limit, r), reps, rounds)
    parts = dict(rhs_us=whole * 1e6, kinematics_loads_us=cum[0] * 1e6, rows_us=(cum[1] - cum[0]) * 1e6,
                 factors_us=(cum[2] - cum[1]) * 1e6, solve_us=(cum[3] - cum[2]) * 1e6)
    out = dict(n_segments=n_seg, n=n, rtol=RTOL, cpu_s=cpu, **counts,
               solver={k: solver.get(k) for k in ("steps", "rhs_cvode", "rhs_ls", "newton_iters", "lin_iters",
                                                  "lin_setups", "psolves", "factors", "err_test_fails",
                                                  "projections", "projections_refused", "jtimes", "jtimes_setups",
                                                  "jtimes_rhs")},
               **parts)
    nb = system.topology.n_bodies
    _time_drift(packed, y, n, nb, 1)
    drift = _least(lambda r: _time_drift(packed, y, n, nb, r), reps, rounds)
    out.update(drift_us=drift * 1e6, inside_s=inside, result_s=result, python_s=cpu - inside - result,
               returns=solver["returns"])
    if solver.get("projections", 0) or solver.get("projections_refused", 0):  # CVODE projects: its callback
        spent = counts["rhs"] * whole + _projection_part(system, y, t, reps, rounds, solver, out)
    else:
        spent = counts["rhs"] * whole + counts["steps"] * drift
    if n < fm.stepping.KRYLOV_MIN_COORDS:  # the dense Jacobian (own_loop.compiled_options)
        from flexmb.system.tangent import NewtonPreconditioner

        x, xd = y[:n], y[n:]
        system.state_jacobian(t, x, xd)
        py = _least(lambda r: [system.state_jacobian(t, x, xd) for _ in range(r)], max(20, 2000 // n), rounds)
        K, C = NewtonPreconditioner.diagonal_terms(system)
        _time_jacobian(packed, layout, y, n, K, C, gamma_d, tol, window, rank_limit, 1)
        cj = _least(lambda r: _time_jacobian(packed, layout, y, n, K, C, gamma_d, tol, window, rank_limit, r),
                    max(20, 4000 // n), rounds)
        compiled = cvode_direct.compiled_jacobian(system)
        out.update(jacobian_python_us=py * 1e6, jacobian_compiled_us=cj * 1e6, jacobian_used="compiled" if compiled
                   else "python")
        spent += counts["jac"] * (cj if compiled else py)
    else:
        from flexmb.system.tangent import NewtonPreconditioner

        K, C = NewtonPreconditioner.diagonal_terms(system)
        gamma = 1e-5
        armature = gamma * (gamma * K + C)
        load = np.linspace(-1.0, 1.0, n)
        x = np.ascontiguousarray(y[:n])
        f = [_least(lambda r, s=s: _time_newton(packed, layout, x, armature, tol, rank_limit, load, r, s),
                    max(50, 4000 // n), rounds) for s in (False, True)]
        out.update(newton_factor_us=f[0] * 1e6, newton_solve_us=f[1] * 1e6)
        spent += solver.get("factors", 0) * f[0] + solver.get("psolves", 0) * f[1]
        if solver.get("jtimes"):  # the compiled J v (G lagged: its terms made once per new Jacobian, ``jac``)
            _time_jtimes(packed, layout, y, n, K, C, gamma_d, tol, window, rank_limit, 1, True)
            j = [_least(lambda r, p=p: _time_jtimes(packed, layout, y, n, K, C, gamma_d, tol, window, rank_limit, r, p),
                        max(50, 4000 // n), rounds) for p in (False, True)]
            out.update(jtimes_setup_us=j[0] * 1e6, jtimes_us=j[1] * 1e6)
            spent += counts["jac"] * j[0] + solver["jtimes"] * j[1]
    out["cvode_own_s"] = inside - spent  # CVODE's own work: inside the compiled loop, less the callbacks' parts
    out["rest_s"] = cpu - spent
    return out


def _projection_part(system, y, t, reps, rounds, solver, out):
    """CVODE's projection callback: per call kept / speeds moved / positions and speeds moved; its part of the run."""
    n = system.n_speeds
    packed, layout = system._packed, system._loop_layout
    drivers = system.constraints.drivers
    cols = np.array(system.constraints.driver_cols, dtype=np.int64)
    p_d = np.array([d.position(t) for d in drivers])
    v_d = np.array([d.velocity(t) for d in drivers])
    rank_limit = -1 if system.rank_limit is None else system.rank_limit
    tol = 0.1 * RTOL / 100  # PROJECTION_ATOL_FRACTION x atol
    rng = np.random.default_rng(0)
    states = dict(kept=y, speeds=y + np.concatenate([np.zeros(n), 1e-5 * rng.normal(size=n)]),
                  positions=y + 1e-5 * rng.normal(size=2 * n))
    per = {}
    for key, state in states.items():
        args = (packed, layout, state, n, cols, p_d, v_d, tol, system._loop_tol, system.singular_window(), rank_limit)
        _time_projection(*args, 1)
        per[key] = _least(lambda r: _time_projection(*args, r), max(50, reps // 4), rounds)
    attempts = solver["steps"] + solver.get("err_test_fails", 0)
    moved = solver.get("projections", 0)
    out.update(projection_kept_us=per["kept"] * 1e6, projection_speeds_us=per["speeds"] * 1e6,
               projection_positions_us=per["positions"] * 1e6, projection_calls=attempts)
    # each attempt makes the residuals' pass; a moved one the projection's work on top (speeds moved: the bound)
    return attempts * per["kept"] + moved * (per["speeds"] - per["kept"])


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, nargs="+", default=[8, 32, 128])
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--label", default="")
    p.add_argument("--out", default=os.path.join(HERE, "results", "probe_b6_step.jsonl"))
    a = p.parse_args(argv)
    for n_seg in a.n:
        row = probe(n_seg, a.rounds)
        row.update(label=a.label, load=os.getloadavg()[0], when=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()))
        print(json.dumps(row), flush=True)
        with open(a.out, "a") as fh:
            fh.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
