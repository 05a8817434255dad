"""CVODE without Python in the step loop for a model with loops: B6 damped against ``simulate()`` (issue 28 prototype).

    OPENBLAS_NUM_THREADS=1 python benchmarks/cvode_loop_direct.py --n 8 32 128 --rtol 1e-5

:class:`DirectLoopCVODE` drives CVODE (BDF) through ctypes on the SUNDIALS
libraries of scikit-sundae's wheel (:mod:`flexmb.integrators.cvode_library`) with the numba
C callbacks of :mod:`cvode_loop_callbacks`: the loops' right-hand side
(``loop_rhs``), GMRES with the loops' Newton preconditioner (its factors
kept per gamma) or, for a small model, the dense Jacobian from Python
(``System.state_jacobian``, what flexmb gives CVODE below
``KRYLOV_MIN_COORDS`` coordinates), CVODE's step loop compiled with the
constraint check after each step. The loops' drift is handled as
``flexmb.stepping.Run`` handles it for CVODE: past the bound
``max(projection_tol, min(RESTART_ATOL_FACTOR atol, RESTART_TOL_MAX))``
the state is projected (``System.project``, mass-orthogonal speeds) and
CVODE restarted from it (``CVodeReInit``: order one, its own first step),
the bound raised tenfold (to ``RESTART_TOL_CEILING``) when restarts come
within ``RESTART_MIN_STEPS`` steps of each other; the outputs are
projected to ``projection_tol`` (``flexmb.output_projection``).

Limits of the prototype: every force element compiled, drivers at
constant speed (no ramp), no Euler parameters, no work terms, no winding
offsets, no resolution monitor (simulate's StiffnessWarning).

``--scan`` runs the prototype alone over an rtol grid with atol = rtol /
100 times (1, 1 + 1e-12, 1 - 1e-12), compare.py's robustness rule, or
(``--restart-bound``) with other values of ``RESTART_TOL_MAX``: errors and
counts, no timing.

The script runs B6 damped (0.5 s, 100 outputs, atol = rtol / 100) by
``simulate`` (CVODE_BDF, articulated) and by the prototype in alternating
rounds in this process, CPU time, least of ``--repeat``, with the slider
error against compare_b6.py's cached reference (run it, or
``cpu_b6.py``'s reference maker, first). Rows go to ``--out``.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import sys
import time
from ctypes import byref, c_double, c_int, c_void_p

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from flexmb.integrators.cvode_direct import CV_BDF, STEPS_PER_CALL, SUN_PREC_LEFT, _addr  # noqa: E402
from flexmb.integrators.cvode_library import FLAGS, CVODEError, sundials  # noqa: E402
from flexmb.integrators.sundials import KRYLOV_DIM, MAX_STEPS  # noqa: E402

REFS = os.path.join(HERE, "results", "refs")
#: the counts printed
COUNTS = ("steps", "rhs", "jac", "psolves", "factors", "setups", "restarts", "projections", "lin_iters")


def _reinit(S):
    """``CVodeReInit`` declared on the loaded libraries (flexmb.integrators.cvode_library does not declare it)."""
    for lib in S._libs:
        if hasattr(lib, "CVodeReInit"):
            f = lib.CVodeReInit
            f.restype, f.argtypes = c_int, [c_void_p, c_double, c_void_p]
            return f
    raise AttributeError("no bundled SUNDIALS library defines CVodeReInit")


def constant_speed_drivers(system) -> np.ndarray:
    """``[[column, p0, w], ...]`` of the system's drivers; ValueError unless each is ``p0 + w t``."""
    rows = []
    for d, c in zip(system.constraints.drivers, system.constraints.driver_cols):
        p0, w = float(d.position(0.0)), float(d.velocity(0.0))
        for t in (0.013, 0.37, 1.9):
            if abs(d.position(t) - (p0 + w * t)) > 1e-12 * (1 + abs(p0 + w * t)) or d.acceleration(t) != 0.0:
                raise ValueError(f"driver {getattr(d, 'name', c)!r} is not at constant speed: not in this prototype")
        rows.append((c, p0, w))
    return np.array(rows, dtype=float).reshape(-1, 3)


class DirectLoopCVODE:
    """CVODE (BDF) on a model with loops with compiled callbacks: one Python call per output time (and restart).

    Parameters
    ----------
    system : flexmb.System
        Calibrated (``flexmb.simulate._calibrated``), loops closed by the
        articulated strategy, every force element compiled, drivers at
        constant speed, no Euler parameters.
    y0 : ndarray, shape (2 n,)
        The initial state ``(q, u)``, consistent.
    t0, t_bound : float
        Start and end (CVODE's stop time).
    rtol, atol : float
        Tolerances.
    krylov : bool
        GMRES with the compiled loop preconditioner; else the dense
        Jacobian from Python (``System.state_jacobian``).
    projection_tol : float
        simulate's ``projection_tol``.
    """

    def __init__(self, system, y0, t0, t_bound, *, rtol, atol, krylov=True, projection_tol=1e-10):
        import cvode_loop_callbacks as cb
        from flexmb.stepping import RESTART_ATOL_FACTOR, RESTART_TOL_MAX

        if not system._loop_kernel or system._python_groups or not system.layout.identity:
            raise ValueError("DirectLoopCVODE needs loops closed by the articulated strategy, compiled force "
                             "elements only, and no Euler parameters")
        self._cb, self.system, self._S = cb, system, sundials()
        self._reinit_fn = _reinit(self._S)
        self.t, self.t_bound, self.n_steps, self.n_restarts = float(t0), float(t_bound), 0, 0
        self.projection_tol, self.krylov = projection_tol, krylov
        self.state_tol = max(projection_tol, min(RESTART_ATOL_FACTOR * atol, RESTART_TOL_MAX))
        self.last_restart = -10**9
        self._counted: dict = {}
        self._mem = self._ls = self._A = self._y = self._out = None
        self._ctx = c_void_p()
        n, m = system.n_speeds, len(y0)
        if m != 2 * n:
            raise ValueError("the state must be (q, u): no work terms in this prototype")
        self.n, self.m = n, m
        self._ud = self._user_data(system, n, m)
        S = self._S
        self._check(S.SUNContext_Create(0, byref(self._ctx)), "SUNContext_Create")
        S.SUNContext_ClearErrHandlers(self._ctx)
        self._y, self._out = S.N_VNew_Serial(m, self._ctx), S.N_VNew_Serial(m, self._ctx)
        self.y = self._data(self._y)
        self.y[:] = y0
        self._mem = S.CVodeCreate(CV_BDF, self._ctx)
        self._py_jac = None if krylov else self._python_jacobian()
        self._setup(rtol, atol)
        self._tret = np.array([self.t])
        self._lp = np.array([_addr(S.CVode), _addr(S.CVodeGetDky), self._mem, self._y, self.y.ctypes.data, self._out,
                             self._tret.ctypes.data, m, _addr(S.N_VGetArrayPointer)], dtype=np.int64)

    def _user_data(self, system, n, m):
        from flexmb.system.tangent import NewtonPreconditioner

        cb, S = self._cb, self._S
        fl, it, fg, ix = system._packed
        lay = system._loop_layout
        K, C = NewtonPreconditioner.diagonal_terms(system)
        nb, mr, band = system.topology.n_bodies, lay.row_coord.shape[0], int(lay.band)
        a = self._arrays = {"fl": fl, "it": it, "fg": fg, "ix": ix, "K": np.ascontiguousarray(K, float),
                            "C": np.ascontiguousarray(C, float), "x": np.zeros(n),
                            "drv": np.ascontiguousarray(constant_speed_drivers(system)).reshape(-1),
                            "real": np.zeros(8), "Sw": np.zeros(n * 3), "Sv": np.zeros(n * 3), "W": np.zeros(mr * 12),
                            "body": np.zeros(mr * 2, np.int64), "U": np.zeros(n * 6), "DUT": np.zeros(n * 6),
                            "Dinv": np.zeros(n * 6), "lift": np.zeros(n), "Kb": np.zeros(mr * (band + 1)),
                            "d": np.zeros(mr), "df": np.zeros(mr), "V": np.zeros(mr * mr)}
        for f in lay._fields[:-1]:
            a[f] = np.ascontiguousarray(getattr(lay, f), dtype=np.int64)
        ud = np.zeros(cb.UD_SIZE, dtype=np.int64)
        ud[cb.A_GETPTR], ud[cb.A_MATDATA] = _addr(S.N_VGetArrayPointer), _addr(S.SUNDenseMatrix_Data)
        ud[cb.N], ud[cb.M], ud[cb.NB], ud[cb.MROWS], ud[cb.BAND] = n, m, nb, mr, band
        for slot, size, key in ((cb.A_FL, cb.N_FL, "fl"), (cb.A_IT, cb.N_IT, "it"), (cb.A_FG, cb.N_FG, "fg")):
            ud[slot], ud[size] = a[key].ctypes.data, a[key].size
        ud[cb.A_IX], ud[cb.N_IX] = ix.ctypes.data, ix.shape[0]
        ud[cb.N_VISIT], ud[cb.N_ROOTS], ud[cb.N_ROOT_ROWS] = a["visit"].size, a["root_ptr"].size - 1, \
            a["root_rows"].size
        slots = {"row_body": cb.A_ROW_BODY, "row_coord": cb.A_ROW_COORD, "root_of": cb.A_ROOT_OF,
                 "row_roots": cb.A_ROW_ROOTS, "visit_ptr": cb.A_VISIT_PTR, "visit": cb.A_VISIT,
                 "root_ptr": cb.A_ROOT_PTR, "root_rows": cb.A_ROOT_ROWS, "order": cb.A_ORDER,
                 "position": cb.A_POSITION, "K": cb.A_K, "C": cb.A_C, "x": cb.A_X, "drv": cb.A_DRV,
                 "real": cb.A_REAL, "Sw": cb.A_SW, "Sv": cb.A_SV, "W": cb.A_W, "body": cb.A_BODY, "U": cb.A_U,
                 "DUT": cb.A_DUT, "Dinv": cb.A_DINV, "lift": cb.A_LIFT, "Kb": cb.A_KB, "d": cb.A_D, "df": cb.A_DF,
                 "V": cb.A_V}
        for key, slot in slots.items():
            ud[slot] = a[key].ctypes.data
        ud[cb.N_DRV] = a["drv"].size // 3
        ud[cb.RANK_LIMIT] = -1 if system.rank_limit is None else system.rank_limit
        a["real"][cb.R_TOL], a["real"][cb.R_WINDOW] = system._loop_tol, system.singular_window()
        a["real"][cb.R_BOUND] = self.state_tol
        ud[cb.STATUS], ud[cb.NONFINITE_FLAG] = -1, 1
        return ud

    def _setup(self, rtol, atol):
        """CVODE's options as flexmb's CVODE_BDF gives them (scikit-sundae's order)."""
        S, cb, mem, ck = self._S, self._cb, self._mem, self._check
        ck(S.CVodeSetUserData(mem, self._ud.ctypes.data), "CVodeSetUserData")
        ck(S.CVodeInit(mem, cb.rhs.address, self.t, self._y), "CVodeInit")
        ck(S.CVodeSStolerances(mem, float(rtol), float(atol)), "CVodeSStolerances")
        if self.krylov:
            self._ls = S.SUNLinSol_SPGMR(self._y, SUN_PREC_LEFT, KRYLOV_DIM, self._ctx)
        else:
            self._A = S.SUNDenseMatrix(self.m, self.m, self._ctx)
            self._ls = S.SUNLinSol_Dense(self._y, self._A, self._ctx)
        ck(S.CVodeSetLinearSolver(mem, self._ls, self._A), "CVodeSetLinearSolver")
        if self.krylov:
            ck(S.CVodeSetPreconditioner(mem, cb.psetup.address, cb.psolve.address), "CVodeSetPreconditioner")
        else:
            ck(S.CVodeSetJacFn(mem, _addr(self._py_jac)), "CVodeSetJacFn")
        ck(S.CVodeSetMaxNonlinIters(mem, 3), "CVodeSetMaxNonlinIters")
        ck(S.CVodeSetMaxConvFails(mem, 10), "CVodeSetMaxConvFails")
        ck(S.CVodeSetInitStep(mem, 0.0), "CVodeSetInitStep")
        ck(S.CVodeSetMinStep(mem, 0.0), "CVodeSetMinStep")
        ck(S.CVodeSetMaxStep(mem, 0.0), "CVodeSetMaxStep")
        ck(S.CVodeSetMaxOrd(mem, 5), "CVodeSetMaxOrd")
        ck(S.CVodeSetMaxNumSteps(mem, MAX_STEPS), "CVodeSetMaxNumSteps")
        ck(S.CVodeSetStopTime(mem, self.t_bound), "CVodeSetStopTime")

    def _python_jacobian(self):
        """A ctypes CVLsJacFn: ``System.state_jacobian`` (dense) into CVODE's matrix; -1 if it raises."""
        proto = ctypes.CFUNCTYPE(c_int, c_double, c_void_p, c_void_p, c_void_p, c_void_p, c_void_p, c_void_p,
                                 c_void_p)
        system, n, m = self.system, self.n, self.m

        def jac(t, y, fy, J, user_data, tmp1, tmp2, tmp3):
            try:
                self._ud[self._cb.SETUPS] += 1
                yv = self._data(y)
                data = np.ctypeslib.as_array((c_double * (m * m)).from_address(self._S.SUNDenseMatrix_Data(J)))
                data.reshape((m, m), order="F")[:] = system.state_jacobian(t, yv[:n], yv[n:])
                return 0
            except Exception:  # noqa: BLE001 - nothing may cross into C; CVODE reports CV_LSETUP_FAIL
                return -1

        return proto(jac)

    def _data(self, v) -> np.ndarray:
        return np.ctypeslib.as_array((c_double * self.m).from_address(self._S.N_VGetArrayPointer(v)))

    @staticmethod
    def _check(flag, what):
        if flag < 0:
            raise CVODEError(f"{what} failed: {FLAGS.get(flag, flag)}")

    def advance(self, t_stop: float) -> np.ndarray:
        """Step until ``t_stop`` (compiled; back in Python at restarts); the state there.

        Raises
        ------
        CVODEError
            If CVODE fails.
        """
        cb, t_stop = self._cb, min(float(t_stop), self.t_bound)
        none = np.empty(0)
        while True:
            code, k = cb.advance(self._lp, self._ud, t_stop, self.t_bound, none, STEPS_PER_CALL)
            self.n_steps += k
            self.t = float(self._tret[0])
            if code < 0:
                raise CVODEError(f"CVODE failed at t = {self.t:.9g} s: {FLAGS.get(code, code)} "
                                 f"(callback status {int(self._ud[cb.STATUS])})")
            if code == cb.REACHED:
                return self._data(self._out).copy()
            if code == cb.DRIFTED_PAST:
                y_stop = self._data(self._out).copy()
                self._drifted()
                return y_stop
            if code == cb.DRIFTED:
                self._drifted()

    def _drifted(self):
        """As ``Run._restart_if_drifted`` for CVODE: raise the bound if restarts crowd, else project and restart."""
        from flexmb.stepping import RESTART_MIN_STEPS, RESTART_TOL_CEILING

        cb, n, S = self._cb, self.n, self._S
        residual = float(cb.drift(self._ud, self.t, self.y))
        if self.n_steps - self.last_restart < RESTART_MIN_STEPS and self.state_tol < RESTART_TOL_CEILING:
            self.state_tol = min(10.0 * self.state_tol, max(RESTART_TOL_CEILING, self.projection_tol))
            self._arrays["real"][cb.R_BOUND] = self.state_tol
            if residual <= self.state_tol:
                return
        xs, vs = self.system.project(self.t, self.y[:n].copy(), self.y[n:].copy(),
                                     tol=min(1e-12, self.projection_tol), speeds="mass")
        self.y[:n], self.y[n:] = xs, vs
        for key, value in self._cvode_counts().items():  # CVodeReInit zeroes them
            self._counted[key] = self._counted.get(key, 0) + value
        self._check(self._reinit_fn(self._mem, self.t, self._y), "CVodeReInit")
        self._check(S.CVodeSetInitStep(self._mem, 0.0), "CVodeSetInitStep")
        self._check(S.CVodeSetStopTime(self._mem, self.t_bound), "CVodeSetStopTime")
        self._ud[cb.F_VALID] = 0
        self.n_restarts += 1
        self.last_restart = self.n_steps

    def _cvode_counts(self) -> dict:
        """CVODE's counters since its last (re)initialisation."""
        from ctypes import c_long

        S, out = self._S, {}
        for key, name in (("cvode_steps", "NumSteps"), ("rhs_cvode", "NumRhsEvals"), ("lin_iters", "NumLinIters"),
                          ("newton_iters", "NumNonlinSolvIters"), ("lin_setups", "NumLinSolvSetups"),
                          ("err_test_fails", "NumErrTestFails"), ("newton_fails", "NumNonlinSolvConvFails")):
            v = c_long()
            self._check(getattr(S, f"CVodeGet{name}")(self._mem, byref(v)), f"CVodeGet{name}")
            out[key] = v.value
        return out

    def stats(self) -> dict:
        """CVODE's counters over the run (summed over restarts) and the callbacks' own."""
        cb = self._cb
        out = {k: v + self._counted.get(k, 0) for k, v in self._cvode_counts().items()}
        out.update(steps=self.n_steps, rhs=int(self._ud[cb.RHS]), setups=int(self._ud[cb.SETUPS]),
                   psolves=int(self._ud[cb.PSOLVES]), factors=int(self._ud[cb.FACTORS]), restarts=self.n_restarts)
        return out

    def close(self) -> None:
        """Free everything SUNDIALS allocated (once)."""
        S = getattr(self, "_S", None)
        if S is None:
            return
        if self._mem:
            S.CVodeFree(byref(c_void_p(self._mem)))
        if self._ls:
            S.SUNLinSolFree(self._ls)
        if self._A:
            S.SUNMatDestroy(self._A)
        for v in (self._y, self._out):
            if v:
                S.N_VDestroy(v)
        if self._ctx:
            S.SUNContext_Free(byref(self._ctx))
        self._mem = self._ls = self._A = self._y = self._out = self.y = self._S = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        self.close()


def b6_setup(n_segments: int):
    """B6 damped, calibrated as simulate calibrates it: (system, y0, index of the slider's coordinate)."""
    import flexmb as fm
    import scenes
    from flexmb.simulate import _calibrated

    model, positions = scenes.b6(damped=True, n_segments=n_segments)
    system = model.build(complement="articulated")
    x0, xd0 = fm.initial_state(system, 0.0, positions=positions)
    system = _calibrated(system, 0.0, x0, xd0)
    return system, np.concatenate([x0, xd0]), list(system.speed_names).index("rail.slide")


def run_direct(system, y0, slider, rtol, t_end=0.5, n_out=100, krylov=True, projection_tol=1e-10, atol_factor=1.0):
    """The prototype over ``t_end``, outputs projected as simulate projects them: (slider x at the outputs, stats).

    atol is ``rtol / 100 * atol_factor`` (the pick rule perturbs it by 1e-12 relative).
    """
    from flexmb.output_projection import project_output

    n = system.n_speeds
    out = np.empty(n_out)
    with DirectLoopCVODE(system, y0, 0.0, t_end, rtol=rtol, atol=rtol / 100 * atol_factor, krylov=krylov,
                         projection_tol=projection_tol) as cv:
        for i, t in enumerate(np.linspace(0.0, t_end, n_out + 1)[1:]):
            y = cv.advance(t)
            x, _ = project_output(system, t, y[:n], y[n:], projection_tol)
            out[i] = x[slider]
        stats = cv.stats()
    return out, stats


def _append(path, row) -> None:
    with open(path, "a") as fh:
        fh.write(json.dumps(row) + "\n")


def scan(args) -> None:
    """Errors and counts of the prototype over ``--rtol`` x atol = rtol / 100 (1, 1 +- 1e-12) (compare.py's rule).

    With ``--restart-bound``, each run once per value of
    ``flexmb.stepping.RESTART_TOL_MAX`` instead of the perturbed atols.
    """
    import flexmb.stepping as stepping

    for n in args.n:
        ref = np.load(os.path.join(REFS, f"B6damped_N{n}_T0.5_out100_rtol1e-11.npz"))["output"]
        system, y0, slider = b6_setup(n)
        caps = args.restart_bound or [stepping.RESTART_TOL_MAX]
        perturbations = (0.0,) if args.restart_bound else (0.0, 1e-12, -1e-12)
        for cap in caps:
            stepping.RESTART_TOL_MAX = cap
            for rtol in args.rtol:
                for p in perturbations:
                    c0 = time.process_time()
                    xs, stats = run_direct(system, y0, slider, rtol, krylov=n + 2 >= 48, atol_factor=1 + p)
                    row = dict(n_segments=n, rtol=rtol, atol_perturbation=p, restart_tol_max=cap,
                               krylov=n + 2 >= 48, error=float(np.max(np.abs(xs - ref))),
                               cpu_s=round(time.process_time() - c0, 4), **stats)
                    print(json.dumps(row), flush=True)
                    _append(args.out, row)


def main(argv=None):
    import flexmb as fm
    import scenes

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[8, 32, 128])
    ap.add_argument("--rtol", type=float, nargs="+", default=[1e-5])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scan", action="store_true", help="no timing: errors and counts at each rtol and perturbed atol")
    ap.add_argument("--restart-bound", type=float, nargs="*", default=[],
                    help="with --scan: values of RESTART_TOL_MAX to run instead of the perturbed atols")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "cvode_loop_direct.jsonl"))
    args = ap.parse_args(argv)
    if args.scan:
        scan(args)
        return
    for n in args.n:
        ref = np.load(os.path.join(REFS, f"B6damped_N{n}_T0.5_out100_rtol1e-11.npz"))["output"]
        system, y0, slider = b6_setup(n)
        model, positions = scenes.b6(damped=True, n_segments=n)
        built = model.build()
        kinds = ["simulate", "direct_krylov"] + (["direct_pyjac"] if n + 2 < 48 else [])
        for rtol in args.rtol:
            kw = dict(positions=positions, complement="articulated", method="CVODE_BDF", rtol=rtol, atol=rtol / 100,
                      n_out=101, progress=False)
            fm.simulate(built, 0.01, **kw)
            for kind in kinds[1:]:
                run_direct(system, y0, slider, rtol, t_end=0.01, n_out=1, krylov=kind == "direct_krylov")
            best = {}
            for rnd in range(args.repeat):
                for kind in kinds:
                    c0 = time.process_time()
                    if kind == "simulate":
                        res = fm.simulate(built, 0.5, **kw)
                        cpu = time.process_time() - c0
                        xs = np.asarray(res.coordinate("rail"), float)[1:]
                        stats = {"steps": int(res.n_steps), "rhs": int(res.n_rhs), "jac": int(res.n_jac),
                                 "projections": int(res.n_projections)}
                    else:
                        xs, stats = run_direct(system, y0, slider, rtol, krylov=kind == "direct_krylov")
                        cpu = time.process_time() - c0
                    row = dict(kind=kind, n_segments=n, rtol=rtol, atol=rtol / 100, cpu_s=round(cpu, 5),
                               error=float(np.max(np.abs(xs - ref))), round=rnd, **stats,
                               load_avg_1min=round(os.getloadavg()[0], 2),
                               date=time.strftime("%Y-%m-%d %H:%M", time.gmtime()))
                    _append(args.out, row)
                    if kind not in best or cpu < best[kind]["cpu_s"]:
                        best[kind] = row
            for kind, row in best.items():
                counts = {k: v for k, v in row.items() if k in COUNTS}
                print(f"N = {n} rtol {rtol:g} {kind:14s} cpu {row['cpu_s']:.3f} s  /simulate "
                      f"{row['cpu_s'] / best['simulate']['cpu_s']:.3f}  error {row['error']:.2e}  {counts}", flush=True)


if __name__ == "__main__":
    main()
