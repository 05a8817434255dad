"""flexmb and Exudyn side by side on B6 damped (the flexible slider-crank), in one run (issue 28).

For each N: flexmb's model ``scenes.b6(damped=True, n_segments=N)`` is
written as numbers by ``b6_data.py`` and rebuilt in Exudyn by
``exudyn_b6.py`` (peers' venv: redundant planar coordinates, Exudyn's
sparse solver). The watched output is the slider's position x at
``--n-out`` equally spaced times in (0, t_end]; a run's error is the largest
difference from flexmb's reference at those times (CVODE_BDF, the
articulated strategy, rtol ``--ref-rtol``, atol rtol / 100; its own error
is estimated against rtol 10x looser: ``ref_uncertainty``). Before timing,
Exudyn's converged solution (Richardson extrapolation of generalized-alpha
with ``--verify-steps`` S and 2S steps) is compared with that reference
(``agreement``): both tools must solve the same equations.

flexmb runs here (this interpreter, the project's venv) with
``complement='articulated'`` at the rtols (atol = rtol / 100) given for
each method of ``--flexmb`` (some only up to a given N); Exudyn at each of ``--exudyn-steps`` (fixed steps)
for each Newton relative tolerance of ``--newton-rtols``. Timing follows
the house rule (``rounds.py``): ``--repeat`` alternating rounds, each running
every flexmb configuration once and then every Exudyn configuration once;
a configuration's time is its least wall time over the rounds.
OPENBLAS_NUM_THREADS is 1 unless the caller set it, on both sides.

The default grids are those of docs/benchmarks.md, "B6 side by side after
session 10's merges": a finer step ladder than the earlier 2,000 / 2,800 /
4,000 / 5,600 (settings between 2,800 and 4,000 pass at every N) and
Exudyn's Newton tolerance 1e-3 where it converges (N <= 32).

Robust choice (issue 31): per tool and family (flexmb: the method; Exudyn:
the Newton tolerance) a setting is robust when its error is <= ``--target``
*and* every tighter one of the grid (smaller rtol or step) also passes; the
tool's time is the least wall time among its robust settings. The best
pick (least wall time of any passing run) is reported beside it.

Writes ``benchmarks/results/compare_b6.jsonl`` (all rows) and
``benchmarks/results/summary_b6.md``. Run from the project's venv::

    python benchmarks/peers/compare_b6.py --n 8 32 128 512 --t-end 0.5
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

if __name__ == "__main__":  # before numpy loads OpenBLAS: one BLAS thread unless the caller chose otherwise
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
BENCH = os.path.dirname(HERE)
sys.path.insert(0, BENCH)
sys.path.insert(0, HERE)

import picks  # noqa: E402
import scenes  # noqa: E402
from b6_data import b6_data  # noqa: E402
from compare import Peer, peer_env, peer_rows, timed_rounds  # noqa: E402

import flexmb as fm  # noqa: E402

RESULTS = os.path.join(BENCH, "results")
REFS = os.path.join(RESULTS, "refs")


def slider_at(res) -> np.ndarray:
    """The slider's position x at the output times after t0, m."""
    return np.asarray(res.coordinate("rail"), float)[1:]


def flexmb_run(n: int, t_end: float, n_out: int, method: str, rtol: float):
    """Build and simulate B6 damped once: (setup_s, wall_s, Result)."""
    t0 = time.perf_counter()
    model, positions = scenes.b6(damped=True, n_segments=n)
    system = model.build()
    setup = time.perf_counter() - t0
    t0 = time.perf_counter()
    res = fm.simulate(system, t_end, positions=positions, complement="articulated", method=method, rtol=rtol,
                      atol=rtol / 100, n_out=n_out + 1, progress=False)
    return setup, time.perf_counter() - t0, res


def reference(n: int, t_end: float, n_out: int, rtol: float, log=print) -> dict:
    """flexmb's reference slider positions (cached in results/refs): CVODE_BDF at rtol and at 10 rtol."""
    path = os.path.join(REFS, f"B6damped_N{n}_T{t_end:g}_out{n_out}_rtol{rtol:g}.npz")
    if os.path.exists(path):
        with np.load(path) as z:
            return {k: z[k] for k in z.files}
    out = {}
    for key, r in (("output", rtol), ("check", 10 * rtol)):
        log(f"  reference: flexmb CVODE_BDF rtol {r:g}, N = {n}, {t_end:g} s")
        _, wall, res = flexmb_run(n, t_end, n_out, "CVODE_BDF", r)
        if res.status != "finished":
            raise RuntimeError(f"B6 N = {n}: the reference at rtol {r:g} failed: {res.message}")
        out[key] = slider_at(res)
        out[f"{key}_wall_s"] = np.array(wall)
        out[f"{key}_steps"] = np.array(res.n_steps)
    os.makedirs(REFS, exist_ok=True)
    np.savez(path, **out)
    return out


def _row(n, **kw) -> dict:
    base = {"tool": "flexmb", "scene": "B6", "variant": "dynamics damped", "n_segments": n, "n_coords": None,
            "n_dof": None, "integrator": None, "rtol": None, "h": None, "setup_s": None, "wall_s": None,
            "steps": None, "rhs_evals": None, "jac_evals": None, "error": None, "error_kind": "integration",
            "reference": None, "openblas_num_threads": os.environ.get("OPENBLAS_NUM_THREADS")}
    base.update(kw)
    return base


def flexmb_round(n, t_end, n_out, configs, ref, label, failed: set, log=print) -> list:
    """One round of flexmb: every configuration ``(method, rtol)`` once (those in ``failed`` skipped)."""
    rows = []
    for method, rtol in configs:
        if (method, rtol) in failed:
            continue
        try:
            s, w, res = flexmb_run(n, t_end, n_out, method, rtol)
        except fm.SimulationError as exc:
            failed.add((method, rtol))
            rows.append(_row(n, integrator=method, rtol=rtol, status=f"failed: {exc}"[:300], t_end=t_end))
            log(f"  flexmb {method} rtol {rtol:g}  failed: {str(exc)[:120]}")
            continue
        if res.status != "finished":
            failed.add((method, rtol))
            rows.append(_row(n, integrator=method, rtol=rtol, status=f"failed: {res.message}"[:300], t_end=t_end))
            log(f"  flexmb {method} rtol {rtol:g}  failed: {res.message[:120]}")
            continue
        err = float(np.max(np.abs(slider_at(res) - ref)))
        rows.append(_row(n, n_coords=int(res.x.shape[1]), n_dof=int(res.n_dof),
                         integrator=method if method != "auto" else f"auto ({res.method})", rtol=rtol,
                         atol=rtol / 100, complement="articulated", setup_s=s, wall_s=w, steps=int(res.n_steps),
                         rhs_evals=int(res.n_rhs), jac_evals=int(res.n_jac), error=err, reference=label,
                         status="finished", t_end=t_end, n_out=n_out, output_end=float(slider_at(res)[-1]),
                         version=fm.__version__))
        log(f"  flexmb {method} rtol {rtol:g}  wall {w:8.3f} s  steps {res.n_steps}  error {err:9.2e}")
    return rows


def flexmb_configs(specs, n: int) -> list:
    """The ``(method, rtol)`` pairs of the ``--flexmb`` specs ``METHOD:RTOL,RTOL,...[:MAX_N]`` that apply at N."""
    out = []
    for spec in specs:
        parts = spec.split(":")
        if len(parts) == 3 and n > int(parts[2]):
            continue
        out += [(parts[0], float(r)) for r in parts[1].split(",")]
    return out


def newton_rtols(specs, n: int) -> list:
    """The Newton tolerances of the ``--newton-rtols`` specs ``TOL[:MAX_N]`` that apply at N, as strings."""
    return [s.split(":")[0] for s in specs if ":" not in s or n <= int(s.split(":")[1])]


def robust_pick(rows, target):
    """The fastest robust setting and the fastest passing one: (row or None, row or None).

    A setting is robust when it passes (error <= ``target``) and so does
    every tighter setting of its family (flexmb: the method; Exudyn: the
    Newton tolerance; ``picks.py``); a failed run passes nothing.
    """
    return picks.tuned(rows, target, which="fastest"), picks.best_pick(rows, target)


def _fmt(x, spec=".3g"):
    return "—" if x is None else format(x, spec)


def _conf(r):
    if r is None:
        return "none passes"
    k = len(r.get("wall_rounds") or [])
    rounds = f" ({k} round{'s' if k != 1 else ''} only)" if k < 3 else ""
    if r["tool"] == "flexmb":
        return f"{r['integrator']}, rtol {r['rtol']:g}{rounds}"
    return f"{r['integrator'].split(' (')[0]}, h {r['h']:g} s{rounds}"


def summary(rows, agreement, args, started) -> str:
    """Markdown: per N the robust and best configurations of both tools and the ratios flexmb/Exudyn."""
    target = args.target
    lines = [f"# B6 damped: flexmb and Exudyn side by side ({started}, one run of "
             "`benchmarks/peers/compare_b6.py`)", "",
             f"Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, shared "
             f"with other jobs (load average at the end: {', '.join(f'{v:.1f}' for v in os.getloadavg())}). "
             f"Times: the min of {args.repeat} alternating rounds (every flexmb configuration, then every "
             "Exudyn one, per round); OPENBLAS_NUM_THREADS = "
             f"{os.environ.get('OPENBLAS_NUM_THREADS')} on both sides.", "",
             f"Error: the largest difference of the slider position x at {args.n_out} equally spaced times in "
             f"(0, {args.t_end:g}] s from flexmb's CVODE_BDF solution of the same N at rtol {args.ref_rtol:g} "
             "(articulated strategy). Agreement: Exudyn's Richardson-extrapolated solution "
             f"({args.verify_steps} and {2 * args.verify_steps} steps) against that reference. Robust: a setting that "
             "passes with every tighter one of its family (flexmb method, Exudyn Newton tolerance) passing too "
             f"(target {target:g} m); the tool's time is its fastest robust setting.", "",
             "| N | flexmb robust | error | wall s | Exudyn robust | error | wall s | flexmb/Exudyn (robust) "
             "| flexmb/Exudyn (best picks) | agreement m | reference uncertainty m |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    timed = [r for r in rows if r.get("error_kind", "integration") == "integration"]
    for n in sorted({r["n_segments"] for r in timed}):
        fx = [r for r in timed if r["n_segments"] == n and r["tool"] == "flexmb"]
        ex = [r for r in timed if r["n_segments"] == n and r["tool"] == "exudyn"]
        (fr, fb), (er, eb) = robust_pick(fx, target), robust_pick(ex, target)
        ratio = fr["wall_s"] / er["wall_s"] if fr and er else None
        ratio_b = fb["wall_s"] / eb["wall_s"] if fb and eb else None
        unc = next((r.get("ref_uncertainty") for r in fx if r.get("ref_uncertainty") is not None), None)
        lines.append(f"| {n} | {_conf(fr)} | {_fmt(fr and fr['error'], '.1e')} | {_fmt(fr and fr['wall_s'])} "
                     f"| {_conf(er)} | {_fmt(er and er['error'], '.1e')} | {_fmt(er and er['wall_s'])} "
                     f"| {_fmt(ratio)} | {_fmt(ratio_b)} | {_fmt(agreement.get(n), '.1e')} | {_fmt(unc, '.1e')} |")
    lines += ["", "Per flexmb method: its fastest robust setting against Exudyn's.", "",
              "| N | flexmb method | robust setting | error | wall s | steps | rhs | Jacobians | flexmb/Exudyn |",
              "|---|---|---|---|---|---|---|---|---|"]
    for n in sorted({r["n_segments"] for r in timed}):
        fx = [r for r in timed if r["n_segments"] == n and r["tool"] == "flexmb"]
        er, _ = robust_pick([r for r in timed if r["n_segments"] == n and r["tool"] == "exudyn"], target)
        for fam in sorted({picks.family(r) for r in fx}):
            fr, _ = robust_pick([r for r in fx if picks.family(r) == fam], target)
            ratio = fr["wall_s"] / er["wall_s"] if fr and er else None
            lines.append(f"| {n} | {fam} | {_conf(fr)} | {_fmt(fr and fr['error'], '.1e')} "
                         f"| {_fmt(fr and fr['wall_s'])} | {_fmt(fr and fr['steps'], 'd')} "
                         f"| {_fmt(fr and fr['rhs_evals'], 'd')} | {_fmt(fr and fr['jac_evals'], 'd')} "
                         f"| {_fmt(ratio)} |")
    return "\n".join(lines) + "\n"


def save(rows, agreement, args, started) -> str:
    """Write compare_b6.jsonl and summary_b6.md; returns the markdown."""
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "compare_b6.jsonl"), "w") as fh:
        for r in rows:
            fh.write(json.dumps(r) + "\n")
    md = summary(rows, agreement, args, started)
    with open(os.path.join(args.out, "summary_b6.md"), "w") as fh:
        fh.write(md)
    return md


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[8, 32, 128, 512])
    ap.add_argument("--t-end", type=float, default=0.5)
    ap.add_argument("--n-out", type=int, default=100)
    ap.add_argument("--flexmb", nargs="+", default=["CVODE_BDF:1e-2,5e-3,3e-3,2e-3,1e-3,1e-4",
                                                    "GeneralizedAlpha:1e-3,5e-4,3e-4,1e-4:32"],
                    help="flexmb configurations METHOD:RTOL,RTOL,...[:MAX_N] (the method at these rtols, for "
                         "N <= MAX_N only if given; 'auto' picks CVODE_BDF for B6 damped)")
    ap.add_argument("--exudyn-steps", type=int, nargs="+", default=[2800, 3000, 3400, 3700, 4000, 5600],
                    help="numbers of steps over t_end (multiples of --n-out)")
    ap.add_argument("--newton-rtols", nargs="+", default=["1e-5", "1e-4", "1e-3:32"],
                    help="Exudyn's Newton relative tolerances TOL[:MAX_N] (for N <= MAX_N only if given: 1e-3 "
                         "converges at N <= 32 only, and where it does not, Exudyn's step control runs for minutes)")
    ap.add_argument("--peers-python", default="/work/venv-peers/bin/python")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--ref-rtol", type=float, default=1e-11)
    ap.add_argument("--target", type=float, default=1e-6)
    ap.add_argument("--verify-steps", type=int, default=8000)
    ap.add_argument("--verify-newton-rtol", type=float, default=1e-10,
                    help="Exudyn's Newton relative tolerance in the Richardson pair (at N = 512 the Newton "
                         "iteration does not reach 1e-8: use 1e-6)")
    ap.add_argument("--out", default=RESULTS)
    ap.add_argument("--summary-only", action="store_true", help="rewrite summary_b6.md from compare_b6.jsonl")
    args = ap.parse_args(argv)
    started = time.strftime("%Y-%m-%d %H:%M:%S")
    if args.summary_only:
        with open(os.path.join(args.out, "compare_b6.jsonl")) as fh:
            rows = [json.loads(line) for line in fh if line.strip()]
        agreement = {r["n_segments"]: r["agreement"] for r in rows if r.get("agreement") is not None}
        print(save(rows, agreement, args, f"rewritten {started} from compare_b6.jsonl"))
        return
    rows, agreement = [], {}
    py, env = args.peers_python, peer_env()
    for n in args.n:
        print(f"== B6 damped N = {n}, {args.t_end:g} s", flush=True)
        data_path = os.path.join(REFS, f"B6damped_N{n}_data.json")
        ref_path = os.path.join(REFS, f"B6damped_N{n}_T{args.t_end:g}_out{args.n_out}_ref.json")
        os.makedirs(REFS, exist_ok=True)
        with open(data_path, "w") as fh:
            json.dump(b6_data(n), fh)
        ref = reference(n, args.t_end, args.n_out, args.ref_rtol)
        unc = float(np.max(np.abs(ref["check"] - ref["output"])))
        with open(ref_path, "w") as fh:
            json.dump(ref["output"].tolist(), fh)
        label = f"flexmb CVODE_BDF rtol={args.ref_rtol:g} articulated, same N"
        common = ["--data", data_path, "--t-end", args.t_end, "--n-out", args.n_out, "--reference", ref_path,
                  "--reference-label", label]
        ver = peer_rows(py, "exudyn_b6.py", [*common, "--richardson", args.verify_steps,
                                             "--newton-rtol", args.verify_newton_rtol], 7200)
        if ver and "agreement" in ver[0]:
            agreement[n] = ver[0]["agreement"]
            rows.append(dict(ver[0], scene="B6", error_kind="agreement"))
            print(f"  agreement of Exudyn's converged solution: {agreement[n]:.2e} m "
                  f"(reference uncertainty {unc:.1e} m)", flush=True)
        else:
            print(f"  Exudyn verification failed: {ver}", flush=True)
        peer = Peer([py, os.path.join(HERE, "exudyn_b6.py"), *common, "--steps", *args.exudyn_steps,
                     "--newton-rtol", *newton_rtols(args.newton_rtols, n)], 7200, env)
        configs = flexmb_configs(args.flexmb, n)
        failed = set()
        try:
            merged = timed_rounds(lambda: flexmb_round(n, args.t_end, args.n_out, configs, ref["output"], label,
                                                       failed), {"exudyn": peer}, args.repeat)
        finally:
            end = peer.close()
        for r in merged["flexmb"]:
            r["ref_uncertainty"] = unc
        rows += merged["flexmb"] + merged["exudyn"] + [dict(_row(n, tool="exudyn"), **r) for r in end]
        print(save(rows, agreement, args, started), flush=True)  # after every N: an interrupted run keeps its rows
    print(save(rows, agreement, args, started))


if __name__ == "__main__":
    main()
