"""PyDy peer: the finite-segment beam of B1 / B2 by sympy's KanesMethod and PyDy code generation.

The model is derived symbolically with ``sympy.physics.mechanics``: a chain
of N block segments, each turned from its inner neighbour by the kept
angles of the sequence Rx Ry Rz about moving axes (one intermediate frame
per angle, so that each joint spring/damper torque acts about its own axis
between two frames, as action and reaction), u = q', gravity on each mass
centre, B2's tip particle at (l, 0.02, 0) in the last segment. ``KanesMethod``
forms Kane's equations; PyDy's ``System.generate_ode_function`` generates the
right-hand side (``generator='cython'`` as PyDy recommends for speed, falling
back to ``'lambdify'`` if no compiler works), and scipy's ``solve_ivp`` with a
stiff-capable method integrates it: LSODA by default (it switches to BDF when
the problem turns stiff; in a probe at B1 N = 4, rtol 1e-6, it needed 1779
right-hand sides where Radau with its finite-difference Jacobian needed
237 534), Radau or BDF on request.

The symbolic derivation and code generation are counted in ``setup_s`` (PyDy
must redo them for every new model, so a peer's total is ``setup_s +
wall_s``). A setup still running after ``--budget`` seconds is interrupted;
that N and all larger ones are reported with ``status = "skipped: ..."``.

Run in the peers' venv::

    /work/venv-peers/bin/python benchmarks/peers/pydy_beam.py --scene B1 --n 4 8 --rtols 1e-4 1e-6
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from beam_data import beam, emit, row  # noqa: E402
from rounds import drive  # noqa: E402


def derive(scene: str, n: int, generator: str = "cython"):
    """Derive and generate the model: (rhs(x, t, p), tip(x), params, n_coords, generator used)."""
    import sympy as sm
    import sympy.physics.mechanics as me
    from pydy.system import System

    d = beam(scene, n)
    axes = d["axes"]
    nc = n * len(axes)
    q = me.dynamicsymbols(f"q0:{nc}")
    u = me.dynamicsymbols(f"u0:{nc}")
    l, m, g0 = sm.symbols("l m g0")
    Ix, Iy, Iz = sm.symbols("Ix Iy Iz")
    ks = sm.symbols(f"k0:{len(axes)}")  # interior joint stiffness per kept axis
    beta, mt = sm.symbols("beta mt")
    gvec = [float(v) for v in d["gravity"] / 9.81]
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    g = g0 * (gvec[0] * N.x + gvec[1] * N.y + gvec[2] * N.z)
    bodies, loads = [], []
    parent, joint = N, O
    unit = {0: lambda F: F.x, 1: lambda F: F.y, 2: lambda F: F.z}
    k = 0
    for i in range(n):
        if i > 0:
            inner = joint
            joint = inner.locatenew(f"P{i}", l * parent.x)
            joint.v2pt_theory(inner, N, parent)
        frame = parent
        for a in axes:
            child = me.ReferenceFrame(f"F{i}_{a}")
            axis = unit[a](frame)
            child.orient_axis(frame, axis, q[k])
            child.set_ang_vel(frame, u[k] * axis)
            kk = ks[axes.index(a)] * (2 if i == 0 else 1)
            torque = (-kk * q[k] - beta * kk * u[k]) * axis
            loads += [(child, torque), (frame, -torque)]
            frame = child
            k += 1
        G = joint.locatenew(f"G{i}", l / 2 * frame.x)
        G.v2pt_theory(joint, N, frame)
        body = me.RigidBody(f"S{i}", G, frame, m, (me.inertia(frame, Ix, Iy, Iz), G))
        bodies.append(body)
        loads.append((G, m * g))
        parent = frame
    tip_point = parent.x * l + float(d["tip_point"][1]) * parent.y
    if d["tip_mass"]:
        T = joint.locatenew("T", tip_point)
        T.v2pt_theory(joint, N, parent)
        bodies.append(me.Particle("tip", T, mt))
        loads.append((T, mt * g))
    else:
        T = joint.locatenew("T", l * parent.x)
    kd = [qi.diff() - ui for qi, ui in zip(q, u)]
    kane = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
    kane.kanes_equations(bodies, loads)
    consts = {l: d["l"], m: d["m"], g0: 9.81, Ix: d["inertia"][0], Iy: d["inertia"][1], Iz: d["inertia"][2],
              beta: float(d["c"][0, 0] / d["k"][0, 0])}
    for a_i, a in enumerate(axes):
        consts[ks[a_i]] = float(d["k"][0, a_i] / 2)
    if d["tip_mass"]:
        consts[mt] = d["tip_mass"]
    system = System(kane)
    consts = {c: v for c, v in consts.items() if c in system.constants_symbols}
    system.constants = consts
    used = generator
    try:
        kw = {"tmp_dir": tempfile.mkdtemp(prefix="pydy-codegen-")} if generator == "cython" else {}
        rhs = system.generate_ode_function(generator=generator, force_c_contiguous=True, **kw)
    except Exception:  # noqa: BLE001 - no compiler: PyDy's pure-Python fallback
        used = "lambdify"
        rhs = system.generate_ode_function(generator="lambdify")
    tip_expr = T.pos_from(O).to_matrix(N).subs(consts)
    tip_f = sm.lambdify([q], tip_expr, "numpy")
    p = dict(consts)  # PyDy maps a {symbol: value} dict onto its generated argument order
    return rhs, (lambda x: np.asarray(tip_f(x[:nc]), float).ravel()), p, nc, used, system.constants_symbols


class _OverBudget(Exception):
    pass


def _with_budget(seconds, fn, *args):
    """Call fn(*args), interrupting it (SIGALRM) after ``seconds`` of wall time."""
    import signal

    def alarm(signum, frame):
        raise _OverBudget()

    old = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        return fn(*args)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="B1", choices=["B1", "B2"])
    ap.add_argument("--n", type=int, nargs="+", default=[4, 8])
    ap.add_argument("--rtols", type=float, nargs="+", default=[1e-4, 1e-6])
    ap.add_argument("--method", nargs="+", default=["LSODA"], choices=["Radau", "BDF", "LSODA"],
                    help="scipy methods run at every --rtols")
    ap.add_argument("--configs", nargs="+", help="METHOD:RTOL pairs to run instead of the grid --method x --rtols")
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--repeat", type=int, default=3,
                    help="rounds (each runs every configuration once, the model derived in the first); the least "
                         "wall time is reported")
    ap.add_argument("--budget", type=float, default=300.0,
                    help="setup (derivation + code generation) wall-time budget, s: a setup that has not finished "
                         "by then is interrupted and recorded as skipped, and larger N are skipped too")
    ap.add_argument("--generator", default="cython", choices=["cython", "lambdify", "theano"])
    ap.add_argument("--reference", type=float, nargs="*", action="append",
                    help="reference tip position per N, in the order of --n")
    ap.add_argument("--reference-label", default="")
    ap.add_argument("--rounds-from-stdin", action="store_true",
                    help="driven by compare.py: one round per line 'round' on stdin, one JSON row per run")
    args = ap.parse_args(argv)
    from scipy.integrate import solve_ivp

    if args.configs:
        pairs = [(c.split(":")[0], float(c.split(":")[1])) for c in args.configs]
    else:
        pairs = [(method, rtol) for method in args.method for rtol in args.rtols]
    models = {}  # n -> (derived model or the status of a skipped N, setup seconds)
    state = {"over": False}  # a setup overran the budget: larger N are skipped
    failed = set()

    def model(n):
        if n in models:
            return models[n]
        if state["over"]:
            models[n] = (f"skipped: budget ({args.budget:g} s of setup) exceeded at smaller N", None)
            return models[n]
        t0 = time.perf_counter()
        try:
            derived = _with_budget(args.budget, derive, args.scene, n, args.generator)
        except _OverBudget:
            models[n] = (f"skipped: symbolic derivation + code generation not done within the "
                         f"{args.budget:g} s budget (interrupted)", time.perf_counter() - t0)
            state["over"] = True
            return models[n]
        setup = time.perf_counter() - t0
        state["over"] = setup > args.budget
        models[n] = (derived, setup)
        return models[n]

    def run_round(r):
        rows = []
        for i_n, n in enumerate(args.n):
            ref = args.reference[i_n] if args.reference and i_n < len(args.reference) else None
            derived, setup = model(n)
            if isinstance(derived, str):
                rows += [row("pydy", args.scene, n, integrator=method, rtol=rtol, setup_s=setup, status=derived)
                         for method, rtol in pairs]
                continue
            rhs, tip, p, nc, used, _ = derived
            for method, rtol in pairs:
                if (n, method, rtol) in failed:  # a failed solve is not repeated
                    continue
                counter = {"rhs": 0}

                def f(t, x):
                    counter["rhs"] += 1
                    return rhs(x, t, p)

                t0, c0 = time.perf_counter(), time.process_time()
                sol = solve_ivp(f, (0.0, args.t_end), np.zeros(2 * nc), method=method, rtol=rtol,
                                atol=rtol / 100, t_eval=[args.t_end])
                wall, cpu = time.perf_counter() - t0, time.process_time() - c0
                if not sol.success or np.shape(sol.y)[-1:] != (1,):
                    rows.append(row("pydy", args.scene, n, n_coords=nc, n_dof=nc, rtol=rtol, setup_s=setup,
                                    integrator=f"scipy {method} (pydy {used})", status=f"failed: {sol.message}"))
                    failed.add((n, method, rtol))
                    continue
                out = tip(np.asarray(sol.y)[:, -1])
                err = float(np.linalg.norm(out - np.asarray(ref))) if ref else None
                rows.append(row("pydy", args.scene, n, n_coords=nc, n_dof=nc,
                                integrator=f"scipy {method} (pydy {used})", rtol=rtol, setup_s=setup,
                                wall_s=wall, cpu_s=cpu, steps=None, rhs_evals=int(sol.nfev), jac_evals=int(sol.njev),
                                error=err, reference=args.reference_label or None, output=out.tolist(),
                                status="finished", atol=rtol / 100, t_end=args.t_end))
        return rows

    drive(run_round, args.repeat, args.rounds_from_stdin, emit)

if __name__ == "__main__":
    main()
