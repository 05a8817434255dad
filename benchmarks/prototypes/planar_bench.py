"""The planar recursion prototype (planar.py) against flexmb's spatial kernels: agreement, cost per call, estimates.

    OPENBLAS_NUM_THREADS=1 python benchmarks/prototypes/planar_bench.py --check
    OPENBLAS_NUM_THREADS=1 python benchmarks/prototypes/planar_bench.py --rounds 7

``--check`` (also run before any timing): the state rate of B1 N = 8 and
B6 damped N = 8 / 32 (benchmarks/scenes.py), the prototype's against
flexmb's: for B1 ``System.state_rate``, for B6 the compiled ``loop_rhs``
of ``complement="articulated"`` (called as probe_b6_step.py calls it) and
``System.state_rate`` (the built system's default complement); the
largest distance of the accelerations relative to the largest one any
load alone gives (:func:`term_scale`), asserted <= 1e-12, and the plain
``max |a - b| / max |b|`` reported beside it. Three kinds of
planar states: "run" (5 states of a run, :func:`run_states`), "moderate"
(random: bending angles of 0.01 rad, the other joint angles anywhere,
speeds of the run's size) and "wild" (random: every angle 0.3 rad, speeds
1-3 rad/s per segment). The distance between flexmb's own two routes
(``flexmb_routes``) is the reference's round-off floor.

Timing: each right-hand side in a compiled loop (least CPU of ``--rounds``
alternating rounds, one BLAS thread), flexmb's as CVODE's callbacks call it
(``open_tree_rhs_into`` for B1 on the open-tree buffers; ``loop_rhs_into``
for B6, with probe_b6_step.py's ``_time_loop_rhs``), and the prototype's
parts cumulated (kinematics, loads, rows, factors, solve: planar.py's
``planar_rhs_into(..., upto)``), next to flexmb's parts (probe_b6_step.py's
``_time_rhs``). Then the estimates (:func:`estimates`): today's runs'
counts and parts (``--b6-counts``, probe_b6_step.py's rows; probe_b1.jsonl's
breakdown) with the right-hand side's cost scaled by the measured
planar / spatial ratio, alone and with every per-step kinematic consumer
(projection, drift check, Jacobian, preconditioner) scaled alike.
One JSON line per measurement goes to ``--out``
(``benchmarks/results/planar_prototype.jsonl``, appended).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np
from numba import carray, njit

HERE = os.path.dirname(os.path.abspath(__file__))
BENCH = os.path.dirname(HERE)
sys.path[:0] = [HERE, BENCH]

import scenes  # noqa: E402
import probe_b6_step  # noqa: E402
from planar import make_work, pack_planar, planar_model, planar_rhs_into, planar_rhs_packed  # noqa: E402
from flexmb.kernels.articulated import open_tree_rhs_into, rhs_work_size  # noqa: E402
from flexmb.kernels.cvode_callbacks import _voidp  # noqa: E402
from flexmb.kernels.loops import loop_rhs  # noqa: E402

TOL = 1e-12
#: today's flexmb / tuned Exudyn on B6 damped (issue 28, this session's measurement: the brief)
B6_EXUDYN_RATIO = {8: 1.1, 32: 0.59, 128: 0.51, 512: 0.49}


def build(scene, n_seg):
    """A built system, its planar model and the drivers' gamma."""
    if scene == "B1":
        system = scenes.b1(n_seg).build()
    else:
        system = scenes.b6(damped=True, n_segments=n_seg)[0].build()
    ints, floats = planar_model(system)
    return system, ints, floats, np.zeros(len(system.constraints.drivers))


def random_state(scene, n, rng, wild):
    """A random planar state ``y = (x, xd)`` (see the module's docstring)."""
    if wild:
        return np.concatenate([rng.normal(0.0, 0.3, n), rng.normal(0.0, 1.0 if scene == "B1" else 3.0, n)])
    if scene == "B1":
        return np.concatenate([rng.normal(0.0, 0.01, n), rng.normal(0.0, 1.0, n)])
    x = np.concatenate([[rng.uniform(-np.pi, np.pi), 0.5 + rng.normal(0.0, 0.05), rng.normal(0.0, 0.3)],
                        rng.normal(0.0, 0.01, n - 3)])
    xd = np.concatenate([[31.4 + rng.normal(0.0, 3.0), rng.normal(0.0, 3.0), rng.normal(0.0, 10.0)],
                         rng.normal(0.0, 1.0, n - 3)])
    return np.concatenate([x, xd])


def spatial_rate(system, y, gamma_d):
    """flexmb's state rate: ``System.state_rate``, and for loops also the compiled ``loop_rhs`` (articulated)."""
    n = system.n_speeds
    out = {"state_rate": np.asarray(system.state_rate(0.0, y))[: 2 * n]}
    lay = system._loop_layout
    if lay is not None and lay.row_coord.shape[0]:
        zeros = np.zeros((system.topology.n_bodies + 1, 3))
        rank_limit = -1 if system.rank_limit is None else system.rank_limit
        xdd = loop_rhs(system._packed, lay, y, n, np.zeros(0), zeros, zeros, np.zeros(n), gamma_d, system._loop_tol,
                       system.singular_window(), rank_limit)[0]
        out["loop_rhs"] = np.concatenate([y[n:2 * n], xdd])
    return out


def run_states(system, scene, n_states):
    """States on a run: B6 damped over 0.5 s (probe_b6_step.py's settings), B1 over 1 s from its rest shape."""
    import flexmb as fm

    kw = dict(method="CVODE_BDF", rtol=3e-3, atol=3e-5, n_out=n_states + 1, progress=False)
    if scene == "B6":
        res = fm.simulate(system, 0.5, positions={"rail": scenes.B6_R + scenes.B6_L}, complement="articulated", **kw)
    else:
        res = fm.simulate(system, 1.0, **kw)
    return [np.concatenate([res.x[i], res.xd[i]]) for i in range(1, n_states + 1)]


def term_scale(ints, floats, y, n, gamma_d, work):
    """The largest acceleration any one load gives alone at y: springs (and dampers), gravity, velocity products.

    The state rate is their sum, and near a balance (B1 hanging, the run's
    states) it is much smaller than its terms: the round-off of either
    evaluation is relative to the terms, so the distances are divided by
    this scale (the plain ``max |a - b| / max |b|`` is reported as well).
    """
    out, zero_g, zeros = np.zeros(2 * n), np.zeros(2), np.zeros_like(floats[6])
    yx0 = np.concatenate([y[:n], np.zeros(n)])
    best = 0.0
    for yy, g, k, c in ((yx0, zero_g, floats[6], zeros), (y, zero_g, zeros, floats[7]), (yx0, floats[5], zeros, zeros),
                        (y, zero_g, zeros, zeros)):
        parts = (*floats[:5], g, k, c, *floats[8:])
        planar_rhs_into(ints, parts, yy, n, gamma_d, out, work, 5)
        best = max(best, float(np.max(abs(out[n:]))))
    return best


def _extended_kernels():
    """planar.py's kernels and flexmb.kernels.planar's, which it imports, run as Python (numba's ``njit`` made
    the identity), for np.longdouble arrays."""
    import planar
    from flexmb.kernels import planar as core

    ident = "def njit(*a, **k):\n    return a[0] if a and callable(a[0]) else (lambda f: f)\n"
    core_src = (open(core.__file__).read()
                .replace("from numba.extending import register_jitable\n", "")
                .replace("from .cache import njit\n", ident + "register_jitable = njit\n")
                .replace("from .packing import", "from flexmb.kernels.packing import")
                .replace("from .views import", "from flexmb.kernels.views import"))
    space = {"__name__": "planar_core_extended"}
    exec(compile(core_src, "planar_core_extended", "exec"), space)
    names = ("_rot", "backward", "factor", "forward", "inertias", "kinematics", "loads")
    src = open(planar.__file__).read().replace("from numba import njit\n", ident).replace(
        f"from flexmb.kernels.planar import {', '.join(names)}\n", "")
    proto = {"__name__": "planar_extended", **{k: space[k] for k in names}}
    exec(compile(src, "planar_extended", "exec"), proto)
    return proto["planar_rhs_into"]


def extended_rate(rhs, ints, floats, y, n, gamma_d):
    """The planar equations' state rate in extended precision (x86's 80-bit long double, 64-bit mantissa)."""
    ld = np.longdouble
    work = tuple(np.asarray(a, dtype=ld) for a in make_work(ints, n))
    out = np.zeros(2 * n, dtype=ld)
    rhs(ints, tuple(np.asarray(f, dtype=ld) for f in floats), np.asarray(y, dtype=ld), n, np.asarray(gamma_d, ld),
        out, work, 5)
    return out


#: bound of the check per scene: at B6 N = 32 flexmb's own float64 evaluations are up to 4e-12
#: (articulated) and 5e-11 (state_rate's default complement) from the extended-precision evaluation
#: (round-off grows with the rod's stiffness, i.e. with N); at B1 N = 8 and B6 N = 8 all are within 1e-12
BOUND = {("B1", 8): TOL, ("B6", 8): TOL, ("B6", 32): 1e-11}


def check(rng_seed=0, n_states=5) -> list[dict]:
    """The agreement rows, asserted <= BOUND: planar (float64), flexmb's routes, each against the others.

    ``truth`` is the planar equations in extended precision
    (:func:`extended_rate`); distances are of the accelerations, divided
    by the largest acceleration a load gives alone (:func:`term_scale`).
    """
    rows, rhs_ext = [], _extended_kernels()
    for scene, n_seg in (("B1", 8), ("B6", 8), ("B6", 32)):
        system, ints, floats, gamma_d = build(scene, n_seg)
        n = system.n_speeds
        work, out = make_work(ints, n), np.zeros(2 * n)
        rng = np.random.default_rng(rng_seed)
        for kind in ("run", "moderate", "wild"):
            worst = {}
            states = (run_states(system, scene, n_states) if kind == "run" else
                      [random_state(scene, n, rng, kind == "wild") for _ in range(n_states)])
            for y in states:
                scale = term_scale(ints, floats, y, n, gamma_d, work)
                planar_rhs_into(ints, floats, y, n, gamma_d, out, work, 5)
                refs = spatial_rate(system, y, gamma_d)
                assert all(np.array_equal(out[:n], ref[:n]) for ref in refs.values())
                rates = dict(planar=out[n:].copy(), truth=extended_rate(rhs_ext, ints, floats, y, n, gamma_d)[n:],
                             **{k: v[n:] for k, v in refs.items()})
                for a, b in (("planar", "truth"), *((k, "truth") for k in refs), *(("planar", k) for k in refs)):
                    d = float(np.max(abs(rates[a] - rates[b]))) / scale
                    worst[f"{a}_vs_{b}"] = max(worst.get(f"{a}_vs_{b}", 0.0), d)
            row = dict(kind="check", scene=scene, n_segments=n_seg, states=kind, n_states=n_states, **worst)
            rows.append(row)
            print(json.dumps(row), flush=True)
            bound = BOUND[(scene, n_seg)]
            # at B6 N = 32 state_rate's default complement is itself 2e-11-5e-11 from the truth: reported only
            asserted = [v for k, v in worst.items() if k.startswith("planar_vs") and (n_seg < 32 or "state_rate" not in k)]
            assert max(asserted) <= bound, row
    return rows


@njit
def _loop_planar(ints, floats, y, n, gamma_d, ydot, work, upto, reps):
    s = 0.0
    for _ in range(reps):
        planar_rhs_into(ints, floats, y, n, gamma_d, ydot, work, upto)
        s += ydot[-1] + work[0][0, 0]
    return s


@njit
def _loop_planar_inplace(a, n, upto, reps):
    """As CVODE's callback would call it: the buffers seen through raw pointers (no reference counts)."""
    k = 7
    fbuf, ibuf = carray(_voidp(a[0]), (a[k],), np.float64), carray(_voidp(a[1]), (a[k + 1],), np.int64)
    wbuf, ix = carray(_voidp(a[2]), (a[k + 2],), np.float64), carray(_voidp(a[3]), (a[k + 3], 4), np.int64)
    y, ydot = carray(_voidp(a[4]), (a[k + 4],), np.float64), carray(_voidp(a[5]), (a[k + 5],), np.float64)
    gamma_d = carray(_voidp(a[6]), (a[k + 6],), np.float64)
    s = 0.0
    for _ in range(reps):
        planar_rhs_packed(fbuf, ibuf, wbuf, ix, y, n, gamma_d, ydot, upto)
        s += ydot[-1]
    return s


def inplace_timer(ints, floats, y, n, gamma_d, upto=5):
    """A timer ``f(reps)`` of :func:`_loop_planar_inplace`, and the buffers it reads (keep them alive)."""
    fbuf, ibuf, wbuf, ix = pack_planar(ints, floats, n)
    arrays = (fbuf, ibuf, wbuf, ix, np.ascontiguousarray(y), np.zeros(2 * n), np.append(gamma_d, 0.0))
    addr = np.array([a.ctypes.data for a in arrays] + [a.shape[0] for a in arrays], dtype=np.int64)
    addr[-1] -= 1  # gamma_d without the padding (an empty array's address is not always valid)
    return (lambda r: _loop_planar_inplace(addr, n, upto, r)), arrays, addr


@njit
def _loop_open(packed, y, n, armature, ydot, work, reps):
    s = 0.0
    for _ in range(reps):
        open_tree_rhs_into(packed, y, n, armature, ydot, work)
        s += ydot[-1]
    return s


def _cpu(f, reps):
    c0 = time.process_time()
    f(reps)
    return (time.process_time() - c0) / reps


def per_call(scene, n_seg, rounds) -> dict:
    """Least CPU per call (us) of the prototype's parts and flexmb's right-hand side (and parts), alternating."""
    system, ints, floats, gamma_d = build(scene, n_seg)
    n = system.n_speeds
    y = random_state(scene, n, np.random.default_rng(1), False)
    work, ydot = make_work(ints, n), np.zeros(2 * n)
    reps = max(200, 200000 // (n + 8))
    timers = {f"planar_upto{k}": (lambda r, k=k: _loop_planar(ints, floats, y, n, gamma_d, ydot, work, k, r))
              for k in range(5)}
    timers["planar"] = lambda r: _loop_planar(ints, floats, y, n, gamma_d, ydot, work, 5, r)
    timers["planar_inplace"], keep, _ = inplace_timer(ints, floats, y, n, gamma_d)
    if system._loop_layout is None or system._loop_layout.row_coord.shape[0] == 0:  # an open tree (B1)
        nb = system.topology.n_bodies
        w, yd, arm = np.zeros(rhs_work_size(nb, n)), np.zeros(2 * n), np.zeros(n)
        timers["flexmb"] = lambda r: _loop_open(system._packed_open, y, n, arm, yd, w, r)
    else:
        packed, layout = system._packed, system._loop_layout
        tol, window = system._loop_tol, system.singular_window()
        rl = -1 if system.rank_limit is None else system.rank_limit
        timers["flexmb"] = lambda r: probe_b6_step._time_loop_rhs(packed, layout, y, n, gamma_d, tol, window, rl, r)
        for k in range(4):
            timers[f"flexmb_upto{k}"] = (lambda r, k=k: probe_b6_step._time_rhs(packed, layout, y, n, gamma_d, tol,
                                                                               window, rl, r, k))
    best = {}
    for f in timers.values():
        f(1)
    for _ in range(rounds):
        for name, f in timers.items():
            best[name] = min(best.get(name, np.inf), _cpu(f, reps))
    us = {k: v * 1e6 for k, v in best.items()}
    row = dict(kind="per_call", scene=scene, n_segments=n_seg, n=n, reps=reps, rounds=rounds,
               planar_us=us["planar"], flexmb_us=us["flexmb"], ratio=us["flexmb"] / us["planar"],
               planar_inplace_us=us["planar_inplace"],
               planar_parts_us=dict(kinematics=us["planar_upto0"], loads=us["planar_upto1"] - us["planar_upto0"],
                                    rows=us["planar_upto2"] - us["planar_upto1"],
                                    factors=us["planar_upto3"] - us["planar_upto2"],
                                    solve=us["planar"] - us["planar_upto3"]))
    if scene == "B1":  # as probe_b1.py times them: flexmb's rhs in place (raw pointers), the closed-form probe
        import probe_b1

        b1 = probe_b1.per_call(system, probe_b1.chain_data(system), reps=reps)
        row.update(flexmb_inplace_us=b1["rhs_flexmb_s"] * 1e6, probe_us=b1["rhs_probe_s"] * 1e6,
                   ratio_inplace=b1["rhs_flexmb_s"] * 1e6 / us["planar_inplace"])
    if "flexmb_upto0" in us:
        row["flexmb_parts_us"] = dict(kinematics_loads=us["flexmb_upto0"], rows=us["flexmb_upto1"] - us["flexmb_upto0"],
                                      factors=us["flexmb_upto2"] - us["flexmb_upto1"],
                                      solve=us["flexmb_upto3"] - us["flexmb_upto2"])
    return row


def _last_rows(path, key="n_segments"):
    rows = {}
    if os.path.exists(path):
        for line in open(path):
            r = json.loads(line)
            rows[r[key]] = r
    return rows


def estimate_b6(probe_row, ratio) -> dict:
    """B6's run with the rhs scaled by 1 / ratio; and with every per-step kinematic consumer scaled alike."""
    rhs_s = probe_row["rhs"] * probe_row["rhs_us"] * 1e-6
    consumers = 0.0
    s = probe_row["solver"]
    if "projection_kept_us" in probe_row:
        attempts = probe_row.get("projection_calls", s["steps"] + s.get("err_test_fails", 0))
        consumers += (attempts * probe_row["projection_kept_us"]
                      + s.get("projections", 0) * (probe_row["projection_speeds_us"] - probe_row["projection_kept_us"]))
    else:
        consumers += probe_row["steps"] * probe_row["drift_us"]
    if "jacobian_compiled_us" in probe_row:
        consumers += probe_row["jac"] * probe_row["jacobian_compiled_us"]
    else:
        consumers += s.get("factors", 0) * probe_row["newton_factor_us"] + s.get("psolves", 0) * probe_row[
            "newton_solve_us"]
    consumers *= 1e-6
    cpu = probe_row["cpu_s"]
    # the parts' per-call times come from loops beside the run: where their sum exceeds the time inside the
    # compiled step loop, they are scaled down to it (the run's own share of them)
    fit = min(1.0, probe_row["inside_s"] / (rhs_s + consumers))
    rhs_s, consumers = rhs_s * fit, consumers * fit
    rhs_only = cpu - rhs_s * (1.0 - 1.0 / ratio)
    everything = rhs_only - consumers * (1.0 - 1.0 / ratio)
    return dict(cpu_s=cpu, rhs_s=rhs_s, consumers_s=consumers, fit=fit, est_rhs_only_s=rhs_only, est_all_s=everything)


def estimates(per, b6_counts, b1_rows) -> list[dict]:
    """Rows of the estimated runs (B6 at each measured N, B1 N = 8)."""
    out = []
    counts = _last_rows(b6_counts)
    for row in per:
        if row["scene"] == "B6" and row["n_segments"] in counts:
            e = estimate_b6(counts[row["n_segments"]], row["ratio"])
            today = B6_EXUDYN_RATIO.get(row["n_segments"])
            if today:
                e.update(exudyn_ratio_today=today, exudyn_ratio_rhs_only=today * e["est_rhs_only_s"] / e["cpu_s"],
                         exudyn_ratio_all=today * e["est_all_s"] / e["cpu_s"])
            out.append(dict(kind="estimate", scene="B6", n_segments=row["n_segments"], ratio=row["ratio"],
                            counts_from=counts[row["n_segments"]].get("label", ""), **e))
    b1 = next((r for r in per if r["scene"] == "B1" and r["n_segments"] == 8), None)
    bd = [r for r in b1_rows if r.get("kind") == "breakdown" and r.get("rtol") == 2e-5]
    if b1 and bd:
        r = bd[-1]
        rhs, jac = r["flexmb_rhs_total_s"], r["flexmb_jac_total_s"]
        ratio = b1.get("ratio_inplace", b1["ratio"])  # the run's rhs is the in-place one: the smaller ratio
        new_rhs = r["flexmb_cpu_s"] - rhs * (1.0 - 1.0 / ratio)
        new_all = new_rhs - jac * (1.0 - 1.0 / ratio)
        out.append(dict(kind="estimate", scene="B1", n_segments=8, ratio=ratio, cpu_s=r["flexmb_cpu_s"],
                        probe_cpu_s=r["probe_cpu_s"], est_rhs_only_s=new_rhs, est_all_s=new_all,
                        probe_ratio_today=r["flexmb_cpu_s"] / r["probe_cpu_s"],
                        probe_ratio_rhs_only=new_rhs / r["probe_cpu_s"], probe_ratio_all=new_all / r["probe_cpu_s"],
                        fixed_flexmb_s=r["fixed_flexmb_s"], rest_s=r["flexmb_rest_s"]))
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--check", action="store_true", help="only the agreement check")
    p.add_argument("--rounds", type=int, default=7)
    p.add_argument("--b1", type=int, nargs="*", default=[8, 64])
    p.add_argument("--b6", type=int, nargs="*", default=[8, 32, 128, 512])
    p.add_argument("--b6-counts", default=os.path.join(BENCH, "results", "probe_b6_step.jsonl"))
    p.add_argument("--label", default="")
    p.add_argument("--out", default=os.path.join(BENCH, "results", "planar_prototype.jsonl"))
    a = p.parse_args(argv)
    rows = check()
    if not a.check:
        per = []
        for scene, sizes in (("B1", a.b1), ("B6", a.b6)):
            for n_seg in sizes:
                per.append(per_call(scene, n_seg, a.rounds))
                print(json.dumps(per[-1]), flush=True)
        b1_rows = [json.loads(x) for x in open(os.path.join(BENCH, "results", "probe_b1.jsonl"))]
        est = estimates(per, a.b6_counts, b1_rows)
        for e in est:
            print(json.dumps(e), flush=True)
        rows += per + est
    stamp = dict(label=a.label, load=os.getloadavg()[0], when=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()))
    with open(a.out, "a") as fh:
        for r in rows:
            fh.write(json.dumps({**r, **stamp}) + "\n")


if __name__ == "__main__":
    main()
