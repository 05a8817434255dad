"""What limits CVODE's step on B6 damped, and what lets it take fewer (issue 28).

    OPENBLAS_NUM_THREADS=1 python benchmarks/b6_steps.py --n 8 32 --rtol 3e-3 --remedy base maxord3 stald

Runs the direct CVODE prototype of loops (``cvode_loop_direct.py``,
unchanged) with one CVODE option or flexmb setting changed at a time (the
remedies of :data:`REMEDIES`), B6 damped over 0.5 s, atol = rtol / 100
unless the remedy says otherwise, and records exact counts: steps, error-test
and Newton failures, restarts, steps per BDF order, the components that
dominate CVODE's local error estimate (``--trace``: CVODE's weighted local
error after every step, ``CVodeGetEstLocalErrors`` x ``CVodeGetErrWeights``,
the largest term's component tallied by group) and the slider's error
against compare_b6.py's cached reference. Counts only, no timing (the
trace steps one step per call); ``peers/cpu_b6.py --steps`` times the
remedies against Exudyn.

Rows go to ``--out`` (``results/b6_steps.jsonl``). ``--stability`` prints
where BDF2-5 are unstable on the rod's first bending modes.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from ctypes import CFUNCTYPE, byref, c_double, c_int, c_long, c_void_p

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import cvode_loop_direct as direct  # noqa: E402

REFS = os.path.join(HERE, "results", "refs")

#: remedy name -> options of :class:`Probe` (a missing key keeps the prototype's setting)
REMEDIES = {
    "base": {},
    "maxord2": {"max_order": 2}, "maxord3": {"max_order": 3}, "maxord4": {"max_order": 4},
    "stald": {"stab_lim": True},
    "atolu10": {"atol_speed_factor": 10.0}, "atolu100": {"atol_speed_factor": 100.0},
    "atolu1000": {"atol_speed_factor": 1000.0},
    "bound1e-5": {"bound": 1e-5}, "bound1e-4": {"bound": 1e-4}, "bound1e-3": {"bound": 1e-3},
    "projfn": {"project": True},
}

_PROJ = CFUNCTYPE(c_int, c_double, c_void_p, c_void_p, c_double, c_void_p, c_void_p)


class Probe(direct.DirectLoopCVODE):
    """The prototype with one remedy applied and, optionally, a trace of every step.

    Parameters
    ----------
    max_order : int
        CVODE's largest BDF order (``CVodeSetMaxOrd``).
    stab_lim : bool
        CVODE's BDF stability-limit detection (``CVodeSetStabLimDet``).
    atol_speed_factor : float
        The speeds' atol is this times the positions' (``CVodeSVtolerances``).
    bound : float or None
        The restart bound (the residual past which the state is projected
        and CVODE restarted) instead of the prototype's.
    project : bool
        CVODE projects onto the constraints after each step
        (``CVodeSetProjFn``: ``System.project``, mass-orthogonal speeds;
        no error projection) instead of restarting.
    trace : bool
        Record order, step and the dominant error component after each step.
    """

    def __init__(self, system, y0, t0, t_bound, *, rtol, atol, max_order=5, stab_lim=False, atol_speed_factor=1.0,
                 bound=None, project=False, trace=False, **kw):
        self.opts = dict(max_order=max_order, stab_lim=stab_lim, atol_speed_factor=atol_speed_factor,
                         project=project)
        self.trace, self._atol_vec, self._proj, self.atol_scalar = trace, None, None, atol
        self.orders, self.etf_by_order, self.dominant = {}, {}, {}
        self.n_proj_calls = 0
        super().__init__(system, y0, t0, t_bound, rtol=rtol, atol=atol, **kw)
        if bound is not None:
            self.state_tol = bound
            self._arrays["real"][self._cb.R_BOUND] = bound
        self._est = self._S.N_VNew_Serial(self.m, self._ctx)
        self._w = self._S.N_VNew_Serial(self.m, self._ctx)

    def _setup(self, rtol, atol):
        super()._setup(rtol, atol)
        S, mem, o, ck = self._S, self._mem, self.opts, self._check
        ck(S.CVodeSetMaxOrd(mem, o["max_order"]), "CVodeSetMaxOrd")
        if o["stab_lim"]:
            ck(S.CVodeSetStabLimDet(mem, 1), "CVodeSetStabLimDet")
        if o["atol_speed_factor"] != 1.0:
            self._atol_vec = S.N_VNew_Serial(self.m, self._ctx)
            v = self._data(self._atol_vec)
            v[: self.n], v[self.n:] = atol, atol * o["atol_speed_factor"]
            ck(S.CVodeSVtolerances(mem, float(rtol), self._atol_vec), "CVodeSVtolerances")
        if o["project"]:
            self._proj = _PROJ(self._project)
            ck(S.CVodeSetProjFn(mem, self._proj), "CVodeSetProjFn")
            ck(S.CVodeSetProjErrEst(mem, 0), "CVodeSetProjErrEst")

    def _project(self, t, ycur, corr, eps, err, user_data):
        """CVProjFn: ``corr`` = the projected state minus ``ycur`` (System.project, mass-orthogonal speeds)."""
        try:
            self.n_proj_calls += 1
            y, n = self._data(ycur), self.n
            xs, vs = self.system.project(t, y[:n].copy(), y[n:].copy(), tol=min(1e-12, self.projection_tol),
                                         speeds="mass")
            c = self._data(corr)
            c[:n], c[n:] = xs - y[:n], vs - y[n:]
            return 0
        except Exception:  # noqa: BLE001 - nothing may cross into C; CVODE counts a projection failure
            return 1

    def advance(self, t_stop: float) -> np.ndarray:
        """As the prototype's, one step per compiled call when tracing (the steps are the same)."""
        if not self.trace:
            return super().advance(t_stop)
        cb, t_stop = self._cb, min(float(t_stop), self.t_bound)
        none = np.empty(0)
        while True:
            code, k = cb.advance(self._lp, self._ud, t_stop, self.t_bound, none, 1)
            self.n_steps += k
            self.t = float(self._tret[0])
            if k:
                self._record()
            if code < 0:
                raise direct.CVODEError(f"CVODE failed at t = {self.t:.9g} s: flag {code}")
            if code == cb.REACHED:
                return self._data(self._out).copy()
            if code == cb.DRIFTED_PAST:
                y_stop = self._data(self._out).copy()
                self._drifted()
                return y_stop
            if code == cb.DRIFTED:
                self._drifted()

    def _record(self):
        """The step just taken: its order, the error-test failures since the last, the dominant component."""
        S, mem = self._S, self._mem
        q, fails = c_int(), c_long()
        S.CVodeGetLastOrder(mem, byref(q))
        S.CVodeGetNumErrTestFails(mem, byref(fails))
        order = q.value
        self.orders[order] = self.orders.get(order, 0) + 1
        new = fails.value - getattr(self, "_fails_seen", 0)
        self._fails_seen = fails.value
        if new > 0:
            self.etf_by_order[order] = self.etf_by_order.get(order, 0) + new
        S.CVodeGetEstLocalErrors(mem, self._est)
        S.CVodeGetErrWeights(mem, self._w)
        e = (self._data(self._est) * self._data(self._w)) ** 2
        i = int(np.argmax(e))
        key = component_group(self.system, i)
        self.dominant[key] = self.dominant.get(key, 0) + 1

    def _drifted(self):
        super()._drifted()
        self._fails_seen = 0  # CVodeReInit zeroes CVODE's counters

    def proj_counts(self) -> dict:
        """CVODE's projection counters (``CVodeGetNumProjEvals``, ``CVodeGetNumProjFails``)."""
        out = {}
        for key, name in (("proj_evals", "CVodeGetNumProjEvals"), ("proj_fails", "CVodeGetNumProjFails")):
            v = c_long()
            getattr(self._S, name)(self._mem, byref(v))
            out[key] = v.value
        return out

    def close(self) -> None:
        S = getattr(self, "_S", None)
        if S is not None:
            for v in (self._atol_vec, getattr(self, "_est", None), getattr(self, "_w", None)):
                if v:
                    S.N_VDestroy(v)
            self._atol_vec = self._est = self._w = None
        super().close()


def component_group(system, i: int) -> str:
    """``'q <kind>'`` or ``'u <kind>'`` of state index i, kind the rod's bending, the slider, crank or rod pin."""
    n = system.n_speeds
    name = system.speed_names[i % n]
    kind = "rod bend" if name.startswith("rod.") else name
    return f"{'q' if i < n else 'u'} {kind}"


def run(system, y0, slider, rtol, remedy: dict, *, trace=False, t_end=0.5, n_out=100, projection_tol=1e-10):
    """The probe over ``t_end`` with the outputs projected as simulate's: (slider x at the outputs, counts)."""
    from flexmb.output_projection import project_output

    n = system.n_speeds
    out = np.empty(n_out)
    with Probe(system, y0, 0.0, t_end, rtol=rtol, atol=rtol / 100, krylov=n >= 48, projection_tol=projection_tol,
               trace=trace, **remedy) as cv:
        for i, t in enumerate(np.linspace(0.0, t_end, n_out + 1)[1:]):
            y = cv.advance(t)
            x, _ = project_output(system, t, y[:n], y[n:], projection_tol)
            out[i] = x[slider]
        stats = cv.stats()
        if remedy.get("stab_lim"):
            v = c_long()
            cv._S.CVodeGetNumStabLimOrderReds(cv._mem, byref(v))
            stats["stald_order_reductions"] = v.value  # since the last restart
        if remedy.get("project"):
            stats.update(cv.proj_counts(), proj_calls=cv.n_proj_calls)
        if trace:
            stats.update(orders={str(k): v for k, v in sorted(cv.orders.items())},
                         err_test_fails_by_order={str(k): v for k, v in sorted(cv.etf_by_order.items())},
                         dominant=dict(sorted(cv.dominant.items(), key=lambda kv: -kv[1])))
    return out, stats


def bdf_unstable(order: int, z: complex) -> bool:
    """Whether BDF of ``order`` is unstable at ``z = h lambda``: a root of its characteristic polynomial outside 1."""
    from numpy.polynomial import polynomial as P

    c = np.zeros(order + 1, complex)  # sum_j (x - 1)^j x^(k - j) / j - z x^k, coefficients from x^0 up
    for j in range(1, order + 1):
        c += P.polymul(P.polypow([-1.0, 1.0], j), P.polypow([0.0, 1.0], order - j))[: order + 1] / j
    c[order] -= z
    return bool(np.max(np.abs(np.roots(c[::-1]))) > 1.0 + 1e-12)


def stability_table(h_max=6e-4, n_h=3000) -> list:
    """The steps h at which BDF2-5 are unstable on the B6 rod's first four bending modes (pinned-pinned, scenes).

    Mode k: ``k^2 f1`` with ``k^2 zeta1`` of critical damping (stiffness-proportional, scenes.B6_ZETA).
    """
    import scenes

    f1, rows = scenes.b6_rod_frequency(), []
    for k in (1, 2, 3, 4):
        w, zeta = 2 * np.pi * f1 * k * k, scenes.B6_ZETA * k * k
        lam = w * (-zeta + 1j * np.sqrt(1.0 - zeta * zeta))
        row = {"mode": k, "f_hz": round(w / (2 * np.pi), 1), "zeta": zeta}
        for order in (2, 3, 4, 5):
            bad = [h for h in np.linspace(h_max / n_h, h_max, n_h) if bdf_unstable(order, h * lam)]
            row[f"bdf{order}_unstable_h"] = [min(bad), max(bad)] if bad else None
        rows.append(row)
    return rows


def remedy(name: str) -> dict:
    """The options of the remedies named in ``name`` (joined by '+'); KeyError names an unknown one."""
    out = {}
    for part in name.split("+"):
        if part not in REMEDIES:
            raise KeyError(f"unknown remedy {part!r}: one of {sorted(REMEDIES)}")
        out.update(REMEDIES[part])
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[8, 32])
    ap.add_argument("--rtol", type=float, nargs="+", default=[3e-3])
    ap.add_argument("--remedy", nargs="+", default=["base"],
                    help=f"names of {sorted(REMEDIES)}, or several joined by '+' (applied together)")
    ap.add_argument("--trace", action="store_true")
    ap.add_argument("--stability", action="store_true", help="print where BDF2-5 are unstable on the rod's modes")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "b6_steps.jsonl"))
    args = ap.parse_args(argv)
    if args.stability:
        for row in stability_table():
            print(json.dumps(row))
        return
    for n in args.n:
        ref = np.load(os.path.join(REFS, f"B6damped_N{n}_T0.5_out100_rtol1e-11.npz"))["output"]
        for rtol in args.rtol:
            for name in args.remedy:
                system, y0, slider = direct.b6_setup(n)  # fresh: a run's counts depend on the System's history
                xs, stats = run(system, y0, slider, rtol, remedy(name), trace=args.trace)
                row = dict(n_segments=n, rtol=rtol, remedy=name, trace=args.trace,
                           error=float(np.max(np.abs(xs - ref))), **stats)
                print(json.dumps(row), flush=True)
                with open(args.out, "a") as fh:
                    fh.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
