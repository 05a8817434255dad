"""B6 with the default settings: what the generalized-alpha integrator's own work costs per step.

``fm.simulate(system, 1.0, positions=initial)`` on the undamped B6
slider-crank ('auto' takes the generalized-alpha method with rho_inf 0.5
and a step floor), ``--repeat`` timed runs (least wall and CPU time kept),
then ``--repeat`` runs with the integrator instrumented: the CPU time spent
inside ``GeneralizedAlpha.step`` and ``GeneralizedAlpha.__init__`` (a new
solver after every projection), minus the time in the right-hand side,
the Jacobian, the LU factorisations and the eigen-decompositions they
call, is the integrator's own work (its Python and its compiled step
arithmetic, scipy's ``OdeSolver`` bookkeeping included); the least of the
runs is kept, per step. The first run of a session is an untimed warm-up
(numba's cache is loaded then).

To compare with another version of flexmb, run this script with that
version's sources first on the path, for instance the numpy step loop of
commit 5fe978b::

    git archive 5fe978b src plugins | tar -x -C /tmp/before
    OPENBLAS_NUM_THREADS=1 PYTHONPATH=/tmp/before/src python benchmarks/genalpha_loop.py --label "numpy loop"
    OPENBLAS_NUM_THREADS=1 python benchmarks/genalpha_loop.py --label "compiled loop"

``--compile`` instead times the first generalized-alpha solve of a
session (an oscillator) against a second one: with an empty numba cache,
the kernels' compilation (``flexmb.kernels.genalpha``)::

    NUMBA_CACHE_DIR=$(mktemp -d) OPENBLAS_NUM_THREADS=1 python benchmarks/genalpha_loop.py --compile

Appends a row to ``results/genalpha_loop.jsonl``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import flexmb as fm  # noqa: E402
import flexmb.genalpha as genalpha  # noqa: E402
import scenes  # noqa: E402

RESULTS = os.path.join(HERE, "results")


class OwnTime:
    """CPU time inside the solver minus its callees (rhs, Jacobian, LU factors, eig), accumulated."""

    def __init__(self):
        self.acc = dict.fromkeys(("solver", "rhs", "jac", "lu", "eig"), 0.0)
        self._wrapped = {}

    def reset(self):
        for key in self.acc:
            self.acc[key] = 0.0

    @property
    def own(self):
        a = self.acc
        return a["solver"] - a["rhs"] - a["jac"] - a["lu"] - a["eig"]

    def timed(self, f, key):
        """``f`` with its CPU time added to ``key`` (the same wrapper for the same ``f``: solvers remember by it)."""
        hit = self._wrapped.get((id(f), key))
        if hit is not None and hit[0] is f:
            return hit[1]
        clock, acc = time.process_time, self.acc

        def g(*args, **kw):
            t0 = clock()
            try:
                return f(*args, **kw)
            finally:
                acc[key] += clock() - t0

        self._wrapped[(id(f), key)] = (f, g)
        return g

    def install(self):
        """Instrument GeneralizedAlpha and the scipy.linalg functions flexmb's modules imported."""
        cls, own = genalpha.GeneralizedAlpha, self
        init, step = cls.__init__, cls.step

        def __init__(solver, fun, t0, y0, t_bound, **kw):
            if callable(kw.get("jac")):
                kw["jac"] = own.timed(kw["jac"], "jac")
            own.timed(init, "solver")(solver, own.timed(fun, "rhs"), t0, y0, t_bound, **kw)

        cls.__init__ = __init__
        cls.step = lambda solver: own.timed(step, "solver")(solver)
        for name, module in list(sys.modules.items()):
            if name.startswith("flexmb") and module is not None:
                for attr, key in (("lu_factor", "lu"), ("eig", "eig")):
                    f = getattr(module, attr, None)
                    if f is not None and getattr(f, "__module__", "").startswith("scipy"):
                        setattr(module, attr, self.timed(f, key))


def first_run():
    """Wall and CPU time of the first and of a second generalized-alpha solve of an oscillator."""
    import numpy as np
    from scipy.integrate import solve_ivp

    def solve():
        w0, c0 = time.perf_counter(), time.process_time()
        solve_ivp(lambda t, y: np.array([y[1], -4.0 * y[0]]), (0.0, 1.0), [1.0, 0.0], method=genalpha.GeneralizedAlpha,
                  jac=lambda t, y: np.array([[0.0, 1.0], [-4.0, 0.0]]), rtol=1e-6)
        return time.perf_counter() - w0, time.process_time() - c0

    (w1, c1), (w2, c2) = solve(), solve()
    return {"scene": "oscillator", "what": "first generalized-alpha solve of a session against a second",
            "numba_cache_dir": os.environ.get("NUMBA_CACHE_DIR"), "first_wall_s": w1, "first_cpu_s": c1,
            "second_wall_s": w2, "second_cpu_s": c2}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--label", default="")
    ap.add_argument("--compile", action="store_true", help="only time the first solve of a session (see above)")
    ap.add_argument("--out", default=os.path.join(RESULTS, "genalpha_loop.jsonl"))
    args = ap.parse_args(argv)
    if args.compile:
        return emit(dict(first_run(), label=args.label, flexmb=fm.__file__), args.out)
    model, initial = scenes.b6(damped=False)
    system = model.build()
    fm.simulate(system, 0.05, positions=initial, progress=False)  # warm-up
    walls, cpus = [], []
    for _ in range(args.repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        res = fm.simulate(system, 1.0, positions=initial, progress=False)
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    own = OwnTime()
    own.install()
    owns, rhs = [], []
    for _ in range(args.repeat):
        own.reset()
        again = fm.simulate(system, 1.0, positions=initial, progress=False)
        assert again.n_steps == res.n_steps and again.n_rhs == res.n_rhs  # the instrumented run is the same run
        owns.append(own.own)
        rhs.append(own.acc["rhs"])
    row = {"scene": "B6", "variant": "undamped", "t_end": 1.0, "label": args.label, "flexmb": fm.__file__,
           "method": res.method, "steps": res.n_steps, "rhs_evals": res.n_rhs, "jac_evals": res.n_jac,
           "projections": res.n_projections, "repeats": args.repeat,
           "wall_s": min(walls), "cpu_s": min(cpus), "wall_s_all": walls, "cpu_s_all": cpus,
           "own_cpu_s": min(owns), "own_cpu_us_per_step": 1e6 * min(owns) / res.n_steps,
           "own_cpu_s_all": owns, "rhs_cpu_us_per_call": 1e6 * min(rhs) / res.n_rhs}
    return emit(row, args.out)


def emit(row, out):
    """Print a row and append it to ``out``."""
    row["load_avg_1min"] = os.getloadavg()[0]
    row["date"] = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    print(json.dumps(row), flush=True)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    with open(out, "a") as fh:
        fh.write(json.dumps(row) + "\n")
    return row


if __name__ == "__main__":
    main()
