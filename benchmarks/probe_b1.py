"""Issue 31's probe: B1 by hand in numba, integrated by CVODE's own loop, against ``fm.simulate`` in one run.

    OPENBLAS_NUM_THREADS=1 python benchmarks/probe_b1.py               # N = 8, 7 rounds
    OPENBLAS_NUM_THREADS=1 python benchmarks/probe_b1.py --rounds 9 --rtol 2e-5

**The probe.** B1 (benchmarks/scenes.py) as a planar chain in its N
relative bending angles ``eta`` (absolute angles ``theta = S eta``, S the
lower triangle of ones), written by hand, with no flexmb kernel: its data
(masses, centres of mass, central inertias about y, joint points, and the
coordinate springs and dampers) are read from the built system
(``system.topology``, ``system.coordinate_terms``) and the gravity element,
and the equations are Lagrange's in the absolute angles, in closed form:

* ``a_ij`` = the lever of body i's velocity on ``thetad_j`` (the joint
  point ``p_j`` of body j's child for ``j < i``, body i's centre ``c_i`` for
  ``j = i``, 0 beyond), ``mu_jk = sum_i m_i a_ij a_ik``;
* ``M_theta = mu o cos(theta_j - theta_k) + diag(J)``, velocity products
  ``sum_k mu_jk sin(theta_j - theta_k) thetad_k^2``, gravity
  ``gamma_j (-g_x sin theta_j - g_z cos theta_j)`` with
  ``gamma_j = sum_i m_i a_ij``;
* ``M = S^T M_theta S``, ``f = S^T f_theta - K eta - C etad``, and
  ``etadd`` by a hand-written Cholesky solve.

:func:`chain_rate` (numba) is checked against ``System.state_rate`` at
random states to 1e-12 relative (:func:`check`, run first; and
tests/test_probe_b1.py). CVODE is SUNDIALS' own, through the ctypes
binding :mod:`flexmb.integrators.cvode_library`: BDF, the dense linear
solver with CVODE's difference-quotient Jacobian, the right-hand side a
``numba.cfunc``, ``CVode(..., CV_NORMAL)`` once per output time (CVODE's
own step loop), the stop time and step bound flexmb gives it.

**The measurement.** One process, alternating rounds, least CPU time
(``time.process_time``) of each: ``fm.simulate(system, 1.0,
method="CVODE_BDF", rtol, atol = rtol / 100, n_out=2)`` (the compiled
loop; kernels warm) and a whole probe run (CVODE created, integrated,
freed), at rtol 2e-5 (B1 N = 8's robust rtol in benchmarks/cvode_direct.py,
docs/benchmarks.md) and at each one's robust rtol, found first on
cvode_direct.py's grid, target and atol perturbations (:func:`robust_rtols`).
The error of both is the tip's distance at t = 1 s to
``work_precision.reference`` (Radau, rtol 1e-9). The breakdown then
times the parts per call, each in a loop: the right-hand sides (compiled
loops calling the probe's ``chain_rate`` and flexmb's ``open_tree_rhs_into`` as CVODE's callback calls it),
the Jacobians (flexmb's ``System.state_jacobian`` from Python, and the
compiled one CVODE's callback calls where
``flexmb.integrators.cvode_direct.compiled_jacobian`` says so; the probe's
is 2 n right-hand sides inside CVODE) and each run's fixed cost (both
integrated to t = 1e-9 s: set-up, first step, output handling).

One JSON line per timed run and one per breakdown go to ``--out``
(default ``benchmarks/results/probe_b1.jsonl``, appended).
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import sys
import time
from ctypes import byref, c_double, c_void_p

import numpy as np
from numba import carray, cfunc, njit, types
from numba.core import cgutils
from numba.extending import intrinsic
from llvmlite import ir

HERE = os.path.dirname(os.path.abspath(__file__))
if HERE not in sys.path:
    sys.path.insert(0, HERE)

import flexmb as fm  # noqa: E402
from flexmb.integrators.cvode_library import FLAGS, sundials  # noqa: E402
from flexmb.integrators.cvode_options import MAX_STEPS  # noqa: E402

CV_BDF, CV_NORMAL = 2, 1
RESULTS = os.path.join(HERE, "results")


# ----------------------------------------------------------------------------- the model's data

def chain_data(system) -> np.ndarray:
    """The packed parameters of :func:`chain_rate` for a planar chain built by flexmb.

    Parameters
    ----------
    system : System
        A serial chain of bodies, each on a revolute coordinate about its
        y axis at a point on its parent's x axis, frames aligned, centres on
        the x axes (B1 with ``keep=("bend_y",)``).

    Returns
    -------
    ndarray
        ``(mu (n*n), gamma (n), J (n), K (n*n), C (n*n), g_x, g_z)``.
    """
    top, n = system.topology, system.n_coords
    body = np.asarray(top.coord_body)
    if not (np.array_equal(body, np.arange(1, n + 1)) and np.array_equal(top.parent[1:], np.arange(n))
            and np.all(np.asarray(top.coord_axis) == 1) and system.layout.identity):
        raise ValueError(f"{system}: not a serial chain of one y rotation per body")
    for name in ("parent_frame", "child_frame"):
        if not np.allclose(getattr(top, name)[1:], np.eye(3), rtol=0, atol=0):
            raise ValueError(f"{system}: {name} not the identity")
    com, pp = np.asarray(top.com)[1:], np.asarray(top.parent_point)[1:]
    if np.any(com[:, 1:]) or np.any(pp[:, 1:]) or np.any(np.asarray(top.child_point)[1:]):
        raise ValueError(f"{system}: a centre or joint point off the bodies' x axes")
    m, c = np.asarray(top.mass)[1:], com[:, 0]
    J = np.asarray(top.inertia)[1:, 1, 1]
    p = np.append(pp[1:, 0], 0.0)  # p_j: body j's child joint on its x axis
    a = np.zeros((n, n))
    for i in range(n):
        a[i, :i], a[i, i] = p[:i], c[i]
    mu, gamma = a.T @ (m[:, None] * a), a.T @ m
    K, C = system.coordinate_terms(system.kinematics(0.0, np.zeros(n), np.zeros(n)))
    g = np.zeros(3)
    for f in system.model.forces:
        if isinstance(f, fm.Gravity):
            g += np.asarray(f.g if hasattr(f, "g") else f.gravity, float)
    return np.concatenate([mu.ravel(), gamma, J, np.asarray(K, float).ravel(), np.asarray(C, float).ravel(),
                           [g[0], g[2]]])


# ----------------------------------------------------------------------------- the right-hand side

@njit(cache=True)
def chain_rate(y, p, n, out, work):
    """``out = (etad, etadd)`` of the planar chain at ``y = (eta, etad)`` (parameters ``p``: :func:`chain_data`).

    ``work`` holds at least ``n * n + 4 n`` floats.
    """
    nn = n * n
    gx, gz = p[3 * nn + 2 * n], p[3 * nn + 2 * n + 1]
    A = work[:nn]
    th, thd, cs, sn = work[nn:nn + n], work[nn + n:nn + 2 * n], work[nn + 2 * n:nn + 3 * n], work[nn + 3 * n:]
    acc_t, acc_d = 0.0, 0.0
    for j in range(n):
        acc_t += y[j]
        acc_d += y[n + j]
        th[j], thd[j] = acc_t, acc_d
        cs[j], sn[j] = np.cos(acc_t), np.sin(acc_t)
    f = out[n:]
    for j in range(n):
        fj = p[nn + j] * (-gx * sn[j] - gz * cs[j])
        for k in range(n):
            mu = p[j * n + k]
            A[j * n + k] = mu * (cs[j] * cs[k] + sn[j] * sn[k])
            fj -= mu * (sn[j] * cs[k] - cs[j] * sn[k]) * thd[k] * thd[k]
        A[j * n + j] += p[nn + n + j]
        f[j] = fj
    # S^T A S and S^T f: sums from the tip down, over rows, then columns
    for j in range(n - 2, -1, -1):
        f[j] += f[j + 1]
        for k in range(n):
            A[j * n + k] += A[(j + 1) * n + k]
    for j in range(n):
        for k in range(n - 2, -1, -1):
            A[j * n + k] += A[j * n + k + 1]
    kk, cc = nn + 2 * n, 2 * nn + 2 * n
    for j in range(n):
        s = 0.0
        for k in range(n):
            s += p[kk + j * n + k] * y[k] + p[cc + j * n + k] * y[n + k]
        f[j] -= s
        out[j] = y[n + j]
    # Cholesky, lower triangle in place, then the two triangular solves
    for j in range(n):
        d = A[j * n + j]
        for k in range(j):
            d -= A[j * n + k] * A[j * n + k]
        d = np.sqrt(d)
        A[j * n + j] = d
        for i in range(j + 1, n):
            s = A[i * n + j]
            for k in range(j):
                s -= A[i * n + k] * A[j * n + k]
            A[i * n + j] = s / d
    for i in range(n):
        s = f[i]
        for k in range(i):
            s -= A[i * n + k] * f[k]
        f[i] = s / A[i * n + i]
    for i in range(n - 1, -1, -1):
        s = f[i]
        for k in range(i + 1, n):
            s -= A[k * n + i] * f[k]
        f[i] = s / A[i * n + i]


def rate(p, n, y) -> np.ndarray:
    """:func:`chain_rate` from Python: the state rate at ``y``."""
    out = np.empty(2 * n)
    chain_rate(np.ascontiguousarray(y, dtype=float), p, n, out, np.empty(n * n + 4 * n))
    return out


def check(system, p, n_states=5, seed=0, rtol=1e-12) -> float:
    """The largest relative distance of :func:`rate` to ``system.state_rate`` at random states (asserted <= rtol)."""
    rng, n, worst = np.random.default_rng(seed), system.n_coords, 0.0
    for _ in range(n_states):
        # large angles (the chain curls over) and fast rates: the velocity products matter
        y = np.concatenate([rng.normal(0.0, 0.4, n), rng.normal(0.0, 3.0, n)])
        ref = system.state_rate(0.0, y)
        worst = max(worst, float(np.linalg.norm(rate(p, n, y) - ref) / np.linalg.norm(ref)))
    assert worst <= rtol, f"probe's right-hand side differs from flexmb's by {worst:.2e} (relative)"
    return worst


# ----------------------------------------------------------------------------- CVODE's callback

@intrinsic
def _voidp(typingctx, addr):
    """The integer ``addr`` as a ``void*``."""
    def codegen(context, builder, sig, args):
        return builder.inttoptr(args[0], cgutils.voidptr_t)
    return types.voidptr(addr), codegen


@intrinsic
def _call_p_p(typingctx, fn, arg):
    """``((void* (*)(void*)) fn)(arg)``: N_VGetArrayPointer through its address."""
    def codegen(context, builder, sig, args):
        fnty = ir.FunctionType(cgutils.voidptr_t, [cgutils.voidptr_t])
        return builder.call(builder.inttoptr(args[0], fnty.as_pointer()), [args[1]])
    return types.voidptr(fn, arg), codegen


#: user_data slots (int64): N_VGetArrayPointer, n, parameters (address, size), work (address, size), rhs count
UD_GETPTR, UD_N, UD_P, UD_NP, UD_W, UD_NW, UD_RHS = range(7)


@cfunc(types.int32(types.float64, types.voidptr, types.voidptr, types.voidptr), cache=True)
def cvode_rhs(t, y, ydot, user_data):
    """CVRhsFn: ``ydot`` = :func:`chain_rate` at ``y``."""
    ud = carray(user_data, (7,), np.int64)
    n = ud[UD_N]
    yv = carray(_call_p_p(ud[UD_GETPTR], y), (2 * n,), np.float64)
    out = carray(_call_p_p(ud[UD_GETPTR], ydot), (2 * n,), np.float64)
    p = carray(_voidp(ud[UD_P]), (ud[UD_NP],), np.float64)
    w = carray(_voidp(ud[UD_W]), (ud[UD_NW],), np.float64)
    ud[UD_RHS] += 1
    chain_rate(yv, p, n, out, w)
    return 0


def _ck(flag, what):
    if flag < 0:
        raise RuntimeError(f"{what}: {FLAGS.get(flag, flag)}")


def probe_run(p, n, t_out, rtol, atol) -> dict:
    """B1 from rest by CVODE (BDF, dense, difference-quotient Jacobian), ``CVode(CV_NORMAL)`` per output time.

    Returns
    -------
    dict
        ``y`` (states at ``t_out[1:]``, shape (len - 1, 2 n)) and CVODE's counters.
    """
    S, m = sundials(), 2 * n
    work = np.zeros(n * n + 4 * n)
    ud = np.array([ctypes.cast(S.N_VGetArrayPointer, c_void_p).value, n, p.ctypes.data, p.size, work.ctypes.data,
                   work.size, 0], dtype=np.int64)
    ctx, mem = c_void_p(), c_void_p()
    _ck(S.SUNContext_Create(0, byref(ctx)), "SUNContext_Create")
    y = S.N_VNew_Serial(m, ctx)
    yv = np.ctypeslib.as_array((c_double * m).from_address(S.N_VGetArrayPointer(y)))
    yv[:] = 0.0
    mem.value = S.CVodeCreate(CV_BDF, ctx)
    A = S.SUNDenseMatrix(m, m, ctx)
    ls = S.SUNLinSol_Dense(y, A, ctx)
    try:
        _ck(S.CVodeInit(mem, cvode_rhs.address, float(t_out[0]), y), "CVodeInit")
        _ck(S.CVodeSetUserData(mem, ud.ctypes.data), "CVodeSetUserData")
        _ck(S.CVodeSStolerances(mem, rtol, atol), "CVodeSStolerances")
        _ck(S.CVodeSetLinearSolver(mem, ls, A), "CVodeSetLinearSolver")
        _ck(S.CVodeSetMaxNumSteps(mem, MAX_STEPS), "CVodeSetMaxNumSteps")
        _ck(S.CVodeSetStopTime(mem, float(t_out[-1])), "CVodeSetStopTime")
        tret, ys = c_double(), np.empty((len(t_out) - 1, m))
        for i, t in enumerate(t_out[1:]):
            _ck(S.CVode(mem, float(t), y, byref(tret), CV_NORMAL), f"CVode to t = {t}")
            ys[i] = yv
        stats = {}
        for key, name in (("steps", "NumSteps"), ("rhs", "NumRhsEvals"), ("rhs_dq", "NumLinRhsEvals"),
                          ("jac", "NumJacEvals"), ("setups", "NumLinSolvSetups"), ("newton", "NumNonlinSolvIters")):
            v = ctypes.c_long()
            getattr(S, f"CVodeGet{name}")(mem, byref(v))
            stats[key] = v.value
        stats["rhs_calls"] = int(ud[UD_RHS])
        return {"y": ys, **stats}
    finally:
        S.CVodeFree(byref(mem))
        S.SUNLinSolFree(ls)
        S.SUNMatDestroy(A)
        S.N_VDestroy(y)
        S.SUNContext_Free(byref(ctx))


# ----------------------------------------------------------------------------- measurements

def _tip(system, y) -> np.ndarray:
    """The beam's tip at the state ``y`` (flexmb's shape: the probe's output, not timed)."""
    beam = next(iter(system.topology.flexible))
    return np.asarray(system.shape(beam, y[: system.n_coords])[-1], float)


def _scene_tip(res) -> np.ndarray:
    """The tip at t_end of a flexmb result, as work_precision's B1 scene reads it."""
    import work_precision as wp

    return np.asarray(wp.scenes()["B1"].output(res), float)


def run_flexmb(system, t_end, rtol, n_out=2):
    """``fm.simulate`` on CVODE_BDF (the compiled loop): (result, CPU s)."""
    c0 = time.process_time()
    res = fm.simulate(system, t_end, method="CVODE_BDF", rtol=rtol, atol=rtol / 100, n_out=n_out, progress=False)
    return res, time.process_time() - c0


def run_probe(p, n, t_end, rtol, n_out=2):
    """A whole probe run: (its dict, CPU s)."""
    c0 = time.process_time()
    out = probe_run(p, n, np.linspace(0.0, t_end, n_out), rtol, rtol / 100)
    return out, time.process_time() - c0


def duel(system, p, rtol, ref, rounds, t_end=1.0) -> list[dict]:
    """Alternating rounds of flexmb and the probe: one row per run (CPU s, counts, error at t_end)."""
    n, rows = system.n_coords, []
    run_flexmb(system, t_end, rtol)  # warm: kernels and callbacks loaded
    run_probe(p, n, t_end, rtol)
    for k in range(rounds):
        res, cpu = run_flexmb(system, t_end, rtol)
        rows.append({"kind": "flexmb", "rtol": rtol, "cpu_s": cpu, "steps": int(res.n_steps), "rhs": int(res.n_rhs),
                     "jac": int(res.n_jac), "error_m": float(np.linalg.norm(_scene_tip(res) - ref)),
                     "round": k})
        out, cpu = run_probe(p, n, t_end, rtol)
        rows.append({"kind": "probe", "rtol": rtol, "cpu_s": cpu, "steps": out["steps"], "rhs": out["rhs"],
                     "rhs_dq": out["rhs_dq"], "jac": out["jac"], "setups": out["setups"],
                     "error_m": float(np.linalg.norm(_tip(system, out["y"][-1]) - ref)), "round": k})
    return rows


@njit(cache=True)
def _loop_probe(y, p, n, reps):
    out, work, s = np.empty(2 * n), np.empty(n * n + 4 * n), 0.0
    for _ in range(reps):
        chain_rate(y, p, n, out, work)
        s += out[-1]
    return s


def per_call(system, p, reps=20000) -> dict:
    """Least CPU per call (s) of 5: the two right-hand sides in compiled loops, flexmb's Jacobians.

    ``jac_flexmb_s`` is the one the run calls: the compiled one (in a compiled loop, where it exists and
    ``compiled_jacobian`` says so), else ``System.state_jacobian`` from Python (``jac_python_s``).

    flexmb's right-hand side is timed as CVODE's callback calls it: ``open_tree_rhs_into`` on the packed
    buffers seen through raw pointers (numba arrays without a reference count, as ``carray`` gives them in
    the callback) with one work array for all calls.
    """
    from numba import carray

    from flexmb.kernels.articulated import open_tree_rhs_into, rhs_work_size
    from flexmb.kernels.cvode_callbacks import _voidp

    n = system.n_coords
    y = np.concatenate([np.random.default_rng(1).normal(0.0, 0.01, n), np.zeros(n)])
    fl, it, fg, ix = system._packed_open
    work, ydot, armature = np.zeros(rhs_work_size(system.topology.n_bodies, n)), np.zeros(2 * n), np.zeros(n)
    arrays = (fl, it, fg, ix, work, y, ydot, armature)
    addr = np.array([a.ctypes.data for a in arrays] + [a.shape[0] for a in arrays], dtype=np.int64)

    @njit
    def loop_flexmb(a, n, reps):
        k = 8
        packed = (carray(_voidp(a[0]), (a[k],), np.float64), carray(_voidp(a[1]), (a[k + 1],), np.int64),
                  carray(_voidp(a[2]), (a[k + 2],), np.bool_), carray(_voidp(a[3]), (a[k + 3], 4), np.int64))
        work = carray(_voidp(a[4]), (a[k + 4],), np.float64)
        y = carray(_voidp(a[5]), (a[k + 5],), np.float64)
        ydot = carray(_voidp(a[6]), (a[k + 6],), np.float64)
        armature = carray(_voidp(a[7]), (a[k + 7],), np.float64)
        s = 0.0
        for _ in range(reps):
            open_tree_rhs_into(packed, y, n, armature, ydot, work)
            s += ydot[-1]
        return s

    def least(f, count):
        f()
        best = np.inf
        for _ in range(5):
            c0 = time.process_time()
            f()
            best = min(best, time.process_time() - c0)
        return best / count

    out = {"rhs_probe_s": least(lambda: _loop_probe(y, p, n, reps), reps),
           "rhs_flexmb_s": least(lambda: loop_flexmb(addr, n, reps), reps),
           "jac_python_s": least(lambda: [system.state_jacobian(0.0, y[:n], y[n:]) for _ in range(200)], 200)}
    out["jac_flexmb_s"] = out["jac_python_s"]
    compiled = _compiled_jacobian_loop(system)
    if compiled is not None:
        out["jac_compiled_s"] = least(lambda: compiled(y, 200), 200)
        from flexmb.integrators.cvode_direct import compiled_jacobian

        if compiled_jacobian(system):
            out["jac_flexmb_s"] = out["jac_compiled_s"]
    return out


def _compiled_jacobian_loop(system):
    """``f(y, reps)``: the compiled open-tree Jacobian called ``reps`` times in a compiled loop (None before it)."""
    try:
        from flexmb.kernels.tree_jacobian import tree_state_jacobian
    except ImportError:
        return None
    from flexmb.system.tangent import NewtonPreconditioner

    n = system.n_coords
    K, C = NewtonPreconditioner.diagonal_terms(system)
    packed, J = system._packed_open, np.zeros((2 * n, 2 * n))

    @njit
    def loop(packed, y, n, K, C, J, reps):
        s = 0.0
        for _ in range(reps):
            tree_state_jacobian(packed, y, n, K, C, J)
            s += J[-1, 0]
        return s

    return lambda y, reps: loop(packed, y, n, K, C, J, reps)


def breakdown(system, p, rows, rounds, t_short=1e-9) -> dict:
    """Counts x per-call costs, and each run's fixed cost (integrated to ``t_short``: set-up, output handling).

    The evaluations of the short runs are part of their fixed cost and are
    not counted again; what the counts and the fixed costs leave is CVODE's
    own work (steps, LU, error tests) and, for flexmb, its loop's returns
    to Python (``rest``).
    """
    n, rtol = system.n_coords, rows[0]["rtol"]
    costs = per_call(system, p)
    fixed = {"flexmb": np.inf, "probe": np.inf}
    for _ in range(rounds):
        res, cpu = run_flexmb(system, t_short, rtol)
        fixed["flexmb"], fx_short = min(fixed["flexmb"], cpu), (res.n_rhs, res.n_jac)
        out, cpu = run_probe(p, n, t_short, rtol)
        fixed["probe"], pr_short = min(fixed["probe"], cpu), out["rhs"] + out["rhs_dq"]
    fx = min((r for r in rows if r["kind"] == "flexmb"), key=lambda r: r["cpu_s"])
    pr = min((r for r in rows if r["kind"] == "probe"), key=lambda r: r["cpu_s"])
    out = {"kind": "breakdown", "rtol": rtol, **costs, "fixed_flexmb_s": fixed["flexmb"],
           "fixed_probe_s": fixed["probe"], "short_flexmb_rhs_jac": list(map(int, fx_short)),
           "short_probe_rhs": int(pr_short), "flexmb_cpu_s": fx["cpu_s"], "probe_cpu_s": pr["cpu_s"]}
    out["flexmb_rhs_total_s"] = (fx["rhs"] - fx_short[0]) * costs["rhs_flexmb_s"]
    out["flexmb_jac_total_s"] = (fx["jac"] - fx_short[1]) * costs["jac_flexmb_s"]
    out["probe_rhs_total_s"] = (pr["rhs"] + pr["rhs_dq"] - pr_short) * costs["rhs_probe_s"]
    for who in ("flexmb", "probe"):
        known = out[f"{who}_rhs_total_s"] + out.get(f"{who}_jac_total_s", 0.0) + out[f"fixed_{who}_s"]
        out[f"{who}_rest_s"] = out[f"{who}_cpu_s"] - known
    return out


def atol_spread(system, p, rtol, ref, perturbations=None) -> dict:
    """Both errors (m) at atol = rtol / 100 x (1 + e), e in ``perturbations`` (not timed)."""
    from cvode_direct import PERTURBATIONS

    perturbations = PERTURBATIONS if perturbations is None else perturbations
    n, out = system.n_coords, {"kind": "atol_spread", "rtol": rtol, "perturbations": list(perturbations)}
    fx, pr = [], []
    for e in perturbations:
        atol = rtol / 100 * (1.0 + e)
        res = fm.simulate(system, 1.0, method="CVODE_BDF", rtol=rtol, atol=atol, n_out=2, progress=False)
        fx.append(float(np.linalg.norm(_scene_tip(res) - ref)))
        y = probe_run(p, n, np.array([0.0, 1.0]), rtol, atol)["y"][-1]
        pr.append(float(np.linalg.norm(_tip(system, y) - ref)))
    out["flexmb_error_m"], out["probe_error_m"] = fx, pr
    return out


def robust_rtols(system, p, ref) -> tuple[dict, list]:
    """Each one's robust rtol on benchmarks/cvode_direct.py's grid, target and atol perturbations.

    Returns
    -------
    robust : dict
        ``{"flexmb": rtol or None, "probe": rtol or None}``: the loosest
        rtol from which every tighter one passes at every perturbed atol.
    spreads : list of dict
        The :func:`atol_spread` rows of the grid.
    """
    from cvode_direct import RTOLS, TARGET
    from peers.picks import robust_setting

    spreads = [atol_spread(system, p, r, ref) for r in RTOLS]
    robust = {who: robust_setting({s["rtol"]: [{"error": e} for e in s[f"{who}_error_m"]] for s in spreads}, TARGET)
              for who in ("flexmb", "probe")}
    return robust, spreads


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=8)
    ap.add_argument("--rtol", nargs="+", type=float, default=None,
                    help="rtols of the timed rounds (atol = rtol / 100); default: 2e-5 (B1 N = 8's robust rtol "
                         "of benchmarks/cvode_direct.py) and each one's robust rtol found here")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--ref-rtol", type=float, default=1e-9)
    ap.add_argument("--out", default=os.path.join(RESULTS, "probe_b1.jsonl"))
    args = ap.parse_args(argv)
    import work_precision as wp
    from scenes import b1

    system = b1(args.n).build()
    p = chain_data(system)
    print(f"B1 N={args.n}: probe's right-hand side = flexmb's state_rate to {check(system, p):.1e} (relative)")
    ref = np.asarray(wp.reference(wp.scenes()["B1"], args.n, args.ref_rtol)["output"], float)
    stamp = {"scene": "B1", "n_segments": args.n, "atol": "rtol / 100", "t_end": 1.0, "n_out": 2,
             "reference": f"flexmb Radau rtol {args.ref_rtol:g}", "date": time.strftime("%Y-%m-%d %H:%M"),
             "loadavg_1min": os.getloadavg()[0]}
    robust, spreads = robust_rtols(system, p, ref)
    print(f"robust rtols (target 1e-6 m, atol perturbed by 1e-12): {robust}")
    lines, best = [{**stamp, **s} for s in spreads] + [{**stamp, "kind": "robust_rtol", **robust}], {}
    for rtol in args.rtol or sorted({r for r in (2e-5, *robust.values()) if r is not None}, reverse=True):
        rows = duel(system, p, rtol, ref, args.rounds)
        bd = breakdown(system, p, rows, args.rounds)
        lines += [{**stamp, **r} for r in rows + [bd]]
        fx = min((r for r in rows if r["kind"] == "flexmb"), key=lambda r: r["cpu_s"])
        pr = min((r for r in rows if r["kind"] == "probe"), key=lambda r: r["cpu_s"])
        print(f"rtol {rtol:g}: flexmb {fx['cpu_s'] * 1e3:.2f} ms CPU ({fx['steps']} steps, {fx['rhs']} rhs, "
              f"{fx['jac']} jac, error {fx['error_m']:.2e} m); probe {pr['cpu_s'] * 1e3:.2f} ms ({pr['steps']} steps, "
              f"{pr['rhs']} + {pr['rhs_dq']} rhs, {pr['jac']} jac, error {pr['error_m']:.2e} m); "
              f"flexmb / probe = {fx['cpu_s'] / pr['cpu_s']:.2f}")
        best.update({("flexmb", rtol): fx["cpu_s"], ("probe", rtol): pr["cpu_s"]})
        print("  breakdown (us): " + ", ".join(f"{k} {v * 1e6:.2f}" for k, v in bd.items()
                                              if k.endswith("_s") and isinstance(v, float)))
    if all(("flexmb" if i == 0 else "probe", robust[w]) in best for i, w in enumerate(("flexmb", "probe"))):
        ratio = best[("flexmb", robust["flexmb"])] / best[("probe", robust["probe"])]
        lines.append({**stamp, "kind": "ratio_at_robust_rtols", **robust, "flexmb_over_probe": ratio})
        print(f"each at its robust rtol (flexmb {robust['flexmb']:g}, probe {robust['probe']:g}): "
              f"flexmb / probe = {ratio:.2f}")
    with open(args.out, "a", encoding="utf-8") as fh:
        fh.write("".join(json.dumps(r) + "\n" for r in lines))
    print(f"appended {len(lines)} lines to {args.out}")


if __name__ == "__main__":
    main()
