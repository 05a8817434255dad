"""CPU cost of one call of each piece of a B6 damped step, per N (issue 28).

    OPENBLAS_NUM_THREADS=1 python benchmarks/loop_kernel_costs.py --n 8 32 128 512

At B6 damped's consistent initial state (calibrated as simulate calibrates
it), the CPU time of one call of: the compiled right-hand side of the loops
(``kernels.loops.loop_rhs``) and the same through Python
(``System._state_rate``, what scikit-sundae's CVODE calls); the Newton
preconditioner's factorisation (``loop_newton_factor``) and solve
(``loop_newton_solve``) and the solve through Python
(``LoopNewtonPreconditioner.solve`` with its factors kept); the constraint
check after a step (``tree_equations`` RESIDUALS and through Python
``System._constraint_residuals``); the dense state Jacobian from Python
(``System.state_jacobian``, what CVODE took below KRYLOV_MIN_COORDS before
its compiled form: ``probe_b6_step.py`` times both) up to N = 128; the mass-orthogonal projection (``System.project``). Each is the
least over ``--repeat`` blocks of calls, in microseconds. Multiplied by a
run's exact counts, these split its time. Writes ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

if __name__ == "__main__":
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)


def _per_call(f, calls: int, repeat: int) -> float:
    """Least CPU microseconds per call of ``f()`` over ``repeat`` blocks of ``calls``."""
    f()
    best = np.inf
    for _ in range(repeat):
        c0 = time.process_time()
        for _ in range(calls):
            f()
        best = min(best, (time.process_time() - c0) / calls)
    return 1e6 * best


def b6_setup(n_segments: int):
    """B6 damped, calibrated as simulate calibrates it: (system, y0, index of the slider's coordinate)."""
    import scenes

    import flexmb as fm
    from flexmb.simulate import _calibrated

    model, positions = scenes.b6(damped=True, n_segments=n_segments)
    system = model.build(complement="articulated")
    x0, xd0 = fm.initial_state(system, 0.0, positions=positions)
    system = _calibrated(system, 0.0, x0, xd0)
    return system, np.concatenate([x0, xd0]), list(system.speed_names).index("rail.slide")


def costs(n_segments: int, repeat: int) -> dict:
    """Per-call CPU microseconds of each piece at B6 damped's initial state."""
    from flexmb.kernels.equations import RESIDUALS, tree_equations
    from flexmb.kernels.loops import loop_newton_factor, loop_newton_solve, loop_rhs

    system, y0, _ = b6_setup(n_segments)
    n, nb = system.n_speeds, system.topology.n_bodies
    packed, lay, tol, window = system._packed, system._loop_layout, system._loop_tol, system.singular_window()
    limit = -1 if system.rank_limit is None else system.rank_limit
    zeros, gn = np.zeros((nb + 1, 3)), np.zeros(n)
    gd = np.zeros(len(system.constraints.drivers))
    calls = max(20, int(20000 / n))
    pre = system.newton_preconditioner()
    pre.setup(0.0, y0[:n], y0[n:])
    gamma = 1e-5
    E = gamma * (gamma * pre.stiffness + pre.damping)
    factored = loop_newton_factor(packed, lay, y0[:n].copy(), E, tol, limit)
    r = np.random.default_rng(0).normal(size=2 * n)
    load = r[n:].copy()
    out = {
        "loop_rhs": _per_call(lambda: loop_rhs(packed, lay, y0, n, np.zeros(0), zeros, zeros, gn, gd, tol, window,
                                               limit), calls, repeat),
        "state_rate_python": _per_call(lambda: system._state_rate(0.0, y0), calls, repeat),
        "loop_newton_factor": _per_call(lambda: loop_newton_factor(packed, lay, y0[:n].copy(), E, tol, limit), calls,
                                        repeat),
        "loop_newton_solve": _per_call(lambda: loop_newton_solve(factored, packed, lay, load), calls, repeat),
        "precond_solve_python": _per_call(lambda: pre.solve(r[:n], r[n:], gamma), calls, repeat),
        "residuals": _per_call(lambda: tree_equations(packed, y0, n, RESIDUALS, np.zeros(0), zeros, zeros, gn),
                               calls, repeat),
        "residuals_python": _per_call(lambda: system._constraint_residuals(0.0, y0[:n], y0[n:]), calls, repeat),
        "project": _per_call(lambda: system.project(0.0, y0[:n] + 1e-7, y0[n:], tol=1e-12, speeds="mass"),
                             max(5, calls // 20), repeat),
    }
    if n_segments <= 128:
        out["state_jacobian_dense"] = _per_call(lambda: system.state_jacobian(0.0, y0[:n], y0[n:]),
                                                max(3, calls // 50), repeat)
    return {"scene": "B6 damped", "n_segments": n_segments, "n_coords": n, "rows": int(lay.row_coord.shape[0]),
            "us_per_call": {k: round(v, 2) for k, v in out.items()}, "load_avg_1min": round(os.getloadavg()[0], 2),
            "openblas_num_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
            "date": time.strftime("%Y-%m-%d %H:%M", time.gmtime())}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[8, 32, 128, 512])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", default=os.path.join(HERE, "results", "loop_kernel_costs.jsonl"))
    args = ap.parse_args(argv)
    rows = []
    for n in args.n:
        row = costs(n, args.repeat)
        rows.append(row)
        print(f"N = {n}: " + ", ".join(f"{k} {v:.1f}" for k, v in row["us_per_call"].items()) + " us", flush=True)
    with open(args.out + ".tmp", "w") as fh:
        fh.writelines(json.dumps(r) + "\n" for r in rows)
    os.replace(args.out + ".tmp", args.out)


if __name__ == "__main__":
    main()
