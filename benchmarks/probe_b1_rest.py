"""Where a compiled CVODE run of B1 goes, part by part, with the callbacks replayed (issue 31).

    OPENBLAS_NUM_THREADS=1 python benchmarks/probe_b1_rest.py              # N = 8, rtol 2e-5, 5 rounds

``fm.simulate(system, 1.0, method="CVODE_BDF", rtol, atol = rtol / 100, n_out=2)`` on B1 (the compiled
loop, :class:`flexmb.integrators.cvode_direct.DirectCVODE`) is taken apart by running the same
integrator, with the options ``simulate`` gives it, in variants that take the very same steps:

* ``direct``: the integrator alone (built, ``advance(0.5)``, ``advance(1.0)``, closed; no monitor);
* ``replay``: the same, with the right-hand side and the Jacobian replaced by C callbacks that copy the
  values the real ones returned at the same call of a recorded run (a deterministic run asks for the
  same values in the same order): what is left is CVODE's own work, the compiled step loop and the
  integrator's Python;
* ``replay_normal``: ``replay`` with ``CVode(..., CV_NORMAL)`` to t = 1 (CVODE's own loop, one call)
  instead of the compiled one-step loop;
* ``replay_rhs`` / ``replay_jac``: only one of the two replayed (the other's cost in place, as CVODE
  calls it: caches cold after CVODE's own code);
* ``short``: the integrator built, advanced to 1e-9 s and closed (its fixed Python);
* ``simulate``, ``simulate_short`` (to 1e-9 s) and ``simulate_nomon`` (no resolution monitor).

Each variant's step, right-hand side and Jacobian counts are printed (the replays must equal the
real run's); then the least CPU time (``time.process_time``) of each over alternating rounds, and the
parts: right-hand sides in place = direct - replay_rhs, Jacobians in place = direct - replay_jac,
CVODE's own work = replay_normal - short, the one-step loop = replay - replay_normal, simulate's
Python around the integrator = simulate - direct, the monitor = simulate - simulate_nomon.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from ctypes import byref, c_double

import numpy as np
from numba import carray, cfunc, njit, types

HERE = os.path.dirname(os.path.abspath(__file__))
if HERE not in sys.path:
    sys.path.insert(0, HERE)

import flexmb as fm  # noqa: E402
from flexmb.integrators import cvode_direct as cd  # noqa: E402
from flexmb.integrators import monitor as monitor_module  # noqa: E402
from flexmb.kernels import cvode_callbacks as cb  # noqa: E402
from scenes import b1  # noqa: E402

RHS_SIG = types.int32(types.float64, types.voidptr, types.voidptr, types.voidptr)
JAC_SIG = types.int32(types.float64, types.voidptr, types.voidptr, types.voidptr, types.voidptr, types.voidptr,
                      types.voidptr, types.voidptr)


class _Address:
    """What DirectCVODE reads of a callback: its ``address``."""

    def __init__(self, f):
        self.address = f.address


def replay_callbacks(m, max_rhs=100_000, max_jac=1000):
    """C callbacks that record the real right-hand side's and Jacobian's values, and ones that replay them.

    Returns
    -------
    dict
        ``rhs_rec``, ``jac_rec``, ``rhs_play``, ``jac_play`` (objects with ``address``) and ``reset()``
        (the call counters to zero, before each run).
    """
    rec = np.zeros((max_rhs, m))
    jrec = np.zeros((max_jac, m * m))
    count = np.zeros(2, np.int64)
    ra, ja, ca = rec.ctypes.data, jrec.ctypes.data, count.ctypes.data  # frozen into the callbacks below
    real_rhs, real_jac = njit(cb.rhs.__wrapped__), njit(cb.jac.__wrapped__)
    floats, voidp, vector, ud_of, call_p_p = cb._floats, cb._voidp, cb._vector, cb._ud, cb._call_p_p

    @njit
    def counters():
        return carray(voidp(ca), (2,), np.int64)

    @cfunc(RHS_SIG)
    def rhs_rec(t, y, ydot, ud):
        flag = real_rhs(t, y, ydot, ud)
        c = counters()
        floats(ra + 8 * m * c[0], m)[:] = vector(ud_of(ud), ydot, m)
        c[0] += 1
        return flag

    @cfunc(RHS_SIG)
    def rhs_play(t, y, ydot, ud):
        c = counters()
        vector(ud_of(ud), ydot, m)[:] = floats(ra + 8 * m * c[0], m)
        c[0] += 1
        return 0

    @cfunc(JAC_SIG)
    def jac_rec(t, y, fy, J, ud, t1, t2, t3):
        flag = real_jac(t, y, fy, J, ud, t1, t2, t3)
        c = counters()
        floats(ja + 8 * m * m * c[1], m * m)[:] = carray(call_p_p(ud_of(ud)[cb.A_MATDATA], J), (m * m,), np.float64)
        c[1] += 1
        return flag

    @cfunc(JAC_SIG)
    def jac_play(t, y, fy, J, ud, t1, t2, t3):
        c = counters()
        carray(call_p_p(ud_of(ud)[cb.A_MATDATA], J), (m * m,), np.float64)[:] = floats(ja + 8 * m * m * c[1], m * m)
        c[1] += 1
        return 0

    out = {name: _Address(f) for name, f in (("rhs_rec", rhs_rec), ("rhs_play", rhs_play), ("jac_rec", jac_rec),
                                             ("jac_play", jac_play))}
    out["keep"] = (rec, jrec, count)

    def reset():
        count[:] = 0

    out["reset"] = reset
    return out


def variants(system, rtol):
    """The variants of the module's docstring: name -> callable returning counts.

    ``simulate``'s return (steps, right-hand sides, Jacobians); the integrator's, CVODE's own (steps,
    right-hand sides, linear solver set-ups), equal in every variant that integrates to t = 1.
    """
    captured = {}
    init = cd.DirectCVODE.__init__

    def spy(self, *args, **kwargs):
        captured.update(args=args, kwargs=kwargs)
        init(self, *args, **kwargs)

    def simulate(t_end=1.0):
        res = fm.simulate(system, t_end, method="CVODE_BDF", rtol=rtol, atol=rtol / 100, n_out=2, progress=False)
        return res.n_steps, res.n_rhs, res.n_jac

    cd.DirectCVODE.__init__ = spy
    try:
        simulate()
    finally:
        cd.DirectCVODE.__init__ = init
    args = captured["args"]
    kwargs = dict(captured["kwargs"], monitor=None, counters={})
    cls = cd.DirectCVODEBDF
    cbs = replay_callbacks(len(args[2]))

    def integrate(normal=False, t_end=1.0):
        solver = cls(*args, **kwargs)
        try:
            if normal:
                tret = c_double()
                flag = solver._S.CVode(solver._mem, t_end, solver._y, byref(tret), 1)
                assert flag >= 0, flag
            else:
                for t in ((t_end / 2, t_end) if t_end == 1.0 else (t_end,)):
                    solver.advance(t)
            st = solver.stats()
        finally:
            solver.close()
        return st["steps"], st["rhs_cvode"], st["lin_setups"]  # CVODE's own counts (a replay calls no real one)

    def with_callbacks(rhs, jac, f):
        def run():
            saved = cb.rhs, cb.jac
            cb.rhs, cb.jac = rhs or saved[0], jac or saved[1]
            cbs["reset"]()
            try:
                return f()
            finally:
                cb.rhs, cb.jac = saved
        return run

    def no_monitor():
        saved = monitor_module.ResolutionMonitor.for_run
        monitor_module.ResolutionMonitor.for_run = classmethod(lambda c, *a, **k: None)
        try:
            return simulate()
        finally:
            monitor_module.ResolutionMonitor.for_run = saved

    with_callbacks(cbs["rhs_rec"], cbs["jac_rec"], integrate)()  # the values to replay
    return {"direct": integrate,
            "replay": with_callbacks(cbs["rhs_play"], cbs["jac_play"], integrate),
            "replay_normal": with_callbacks(cbs["rhs_play"], cbs["jac_play"], lambda: integrate(normal=True)),
            "replay_rhs": with_callbacks(cbs["rhs_play"], None, integrate),
            "replay_jac": with_callbacks(None, cbs["jac_play"], integrate),
            "short": lambda: integrate(t_end=1e-9),
            "simulate": simulate, "simulate_short": lambda: simulate(1e-9), "simulate_nomon": no_monitor}


def least(f, rounds, inner=5) -> float:
    """Least CPU time of ``inner`` calls of ``f``, over ``rounds`` tries, per call."""
    best = np.inf
    for _ in range(rounds):
        c0 = time.process_time()
        for _ in range(inner):
            f()
        best = min(best, (time.process_time() - c0) / inner)
    return best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=8)
    ap.add_argument("--rtol", type=float, default=2e-5)
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args(argv)
    system = b1(args.n).build()
    runs = variants(system, args.rtol)
    for name, f in runs.items():
        print(f"{name:16s} counts: {f()}")
    best = dict.fromkeys(runs, np.inf)
    for _ in range(args.rounds):
        for name, f in runs.items():
            best[name] = min(best[name], least(f, 5))
    for name, value in best.items():
        print(f"{name:16s} {value * 1e3:7.3f} ms")
    _, rhs, jac = runs["simulate"]()
    ms = {k: v * 1e3 for k, v in best.items()}
    parts = {"right-hand sides in place": ms["direct"] - ms["replay_rhs"],
             "Jacobians in place": ms["direct"] - ms["replay_jac"],
             "CVODE's own work (CV_NORMAL)": ms["replay_normal"] - ms["short"],
             "the compiled one-step loop": ms["replay"] - ms["replay_normal"],
             "the integrator's Python (short run)": ms["short"],
             "simulate's Python around it": ms["simulate"] - ms["direct"],
             "of which the monitor": ms["simulate"] - ms["simulate_nomon"]}
    for name, value in parts.items():
        print(f"  {name:38s} {value:7.3f} ms")
    print(f"  per right-hand side in place {parts['right-hand sides in place'] / rhs * 1e3:.2f} us ({rhs} calls); "
          f"per Jacobian {parts['Jacobians in place'] / jac * 1e3:.1f} us ({jac} calls)")


if __name__ == "__main__":
    main()
