"""flexmb side by side with its peers on the same scenes, in one run (BENCHMARKS.md, "Peers").

For each scene (B1, B2) and N: flexmb runs here (this interpreter, the
project's venv) through ``work_precision.run_scene``; each peer runs in the
peers' venv by subprocess (``exudyn_beam.py``, ``pydy_beam.py``), given
flexmb's reference tip position of the same N so that every tool's error is
the integration error against the same model at the tightest settings.

Before timing, each peer's solution at small steps / tight tolerance is
compared with flexmb's reference (the "agreement" column): a peer that does
not agree to about 1e-8 solves a different model and its ratio is void.

Writes ``benchmarks/results/compare.jsonl`` (all rows, BENCHMARKS.md fields)
and ``benchmarks/results/summary.md`` (best wall time at integration error
<= ``--target`` per tool, the ratios flexmb/peer, the agreement, the target
checks). Run from the project's venv::

    python benchmarks/peers/compare.py --b1 8 16 --b2 4 8 --peers exudyn pydy

Takes minutes at these N (flexmb's references dominate the first run; they
are cached in ``benchmarks/results/refs/``).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
BENCH = os.path.dirname(HERE)
sys.path.insert(0, BENCH)

import work_precision as wp  # noqa: E402
from plot import best_wall_at, fit_exponent  # noqa: E402

RESULTS = os.path.join(BENCH, "results")


def peer_rows(python, script, args, timeout, log=print) -> list:
    """Run a peer script in the peers' venv; its JSON lines, or one failure row."""
    cmd = [python, os.path.join(HERE, script), *map(str, args)]
    log("  $ " + " ".join(os.path.basename(c) if i < 2 else c for i, c in enumerate(cmd)))
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd="/")
    except subprocess.TimeoutExpired:
        return [{"status": f"timeout after {timeout:g} s"}]
    rows = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    if proc.returncode != 0:
        rows.append({"status": f"exit {proc.returncode}: {proc.stderr.strip().splitlines()[-1:]}"})
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--b1", type=int, nargs="*", default=[8, 16])
    ap.add_argument("--b2", type=int, nargs="*", default=[4, 8])
    ap.add_argument("--peers", nargs="*", default=["exudyn", "mujoco", "pydy"])
    ap.add_argument("--peers-python", default="/work/venv-peers/bin/python")
    ap.add_argument("--rtols", type=float, nargs="+", default=[1e-4, 1e-5, 1e-6])
    ap.add_argument("--integrators", nargs="+", default=["Radau", "BDF", "DOP853"],
                    help="flexmb methods ('auto' resolves to Radau or DOP853, so it is not repeated here)")
    ap.add_argument("--exudyn-steps", type=int, nargs="+", default=[500, 1000, 2000, 4000, 8000, 16000])
    ap.add_argument("--mujoco-steps", type=int, nargs="+", default=[2000, 4000, 8000, 16000, 32000, 64000])
    ap.add_argument("--pydy-rtols", type=float, nargs="+", default=[1e-5, 1e-6, 1e-7, 1e-8])
    ap.add_argument("--pydy-budget", type=float, default=240.0, help="setup seconds after which N stops growing")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--ref-rtol", type=float, default=1e-9)
    ap.add_argument("--target", type=float, default=1e-6)
    ap.add_argument("--verify-steps", type=int, default=16000,
                    help="Exudyn steps S of the Richardson pair (S, 2S) checked against flexmb's reference")
    ap.add_argument("--summary-only", action="store_true",
                    help="rewrite summary.md from compare.jsonl and compare_agreement.json, running nothing")
    args = ap.parse_args(argv)
    if args.summary_only:
        with open(os.path.join(RESULTS, "compare.jsonl")) as fh:
            rows = [json.loads(line) for line in fh if line.strip()]
        agreement = {}
        path = os.path.join(RESULTS, "compare_agreement.json")
        if os.path.exists(path):
            with open(path) as fh:
                for a in json.load(fh):
                    agreement[(a["tool"], a["scene"], a["n_segments"])] = a["agreement"]
        started = f"rewritten {time.strftime('%Y-%m-%d %H:%M:%S')} from compare.jsonl"
        print(save(rows, agreement, args, started))
        return
    table = wp.scenes()
    rows, agreement = [], {}
    started = time.strftime("%Y-%m-%d %H:%M:%S")
    pydy_over = {}
    for name, ns in (("B1", args.b1), ("B2", args.b2)):
        sc = table[name]
        for n in ns:
            print(f"== {name} N = {n}")
            rows += wp.run_scene(sc, [n], args.integrators, args.rtols, args.repeat, args.ref_rtol)
            ref = wp.reference(sc, n, args.ref_rtol)
            ref_out = [f"{v:.17g}" for v in np.asarray(ref["output"])]
            label = f"flexmb Radau rtol={args.ref_rtol:g} same N"
            if "exudyn" in args.peers:
                ver = peer_rows(args.peers_python, "exudyn_beam.py",
                                ["--scene", name, "--n", n, "--richardson", args.verify_steps], 3600)
                if ver and "output" in ver[0]:
                    agreement[("exudyn", name, n)] = float(np.linalg.norm(np.asarray(ver[0]["output"])
                                                                          - np.asarray(ref["output"])))
                rows += [dict(r, reference=label) if "tool" in r else
                         dict(wp._row(sc, n, tool="exudyn"), **r) for r in peer_rows(
                             args.peers_python, "exudyn_beam.py",
                             ["--scene", name, "--n", n, "--repeat", args.repeat, "--steps", *args.exudyn_steps,
                              "--reference", *ref_out, "--reference-label", label], 3600)]
            if "mujoco" in args.peers:
                out = peer_rows(args.peers_python, "mujoco_beam.py",
                                ["--scene", name, "--n", n, "--repeat", args.repeat, "--steps", *args.mujoco_steps,
                                 "--reference", *ref_out, "--reference-label", label], 3600)
                out = [dict(r, reference=label) if "tool" in r else dict(wp._row(sc, n, tool="mujoco"), **r)
                       for r in out]
                rows += out
                done = [r for r in out if r.get("error") is not None]
                if done:
                    agreement[("mujoco", name, n)] = min(r["error"] for r in done)
            if "pydy" in args.peers:
                if pydy_over.get(name):
                    rows.append(dict(wp._row(sc, n, tool="pydy"),
                                     status=f"skipped: setup at N = {pydy_over[name]} exceeded "
                                            f"{args.pydy_budget:g} s"))
                else:
                    out = peer_rows(args.peers_python, "pydy_beam.py",
                                    ["--scene", name, "--n", n, "--repeat", args.repeat, "--rtols", *args.pydy_rtols,
                                     "--budget", args.pydy_budget, "--reference", *ref_out,
                                     "--reference-label", label], 3 * args.pydy_budget + 600)
                    out = [dict(r, reference=label) if "tool" in r else dict(wp._row(sc, n, tool="pydy"), **r)
                           for r in out]
                    rows += out
                    done = [r for r in out if r.get("error") is not None]
                    if done:
                        agreement[("pydy", name, n)] = min(r["error"] for r in done)
                    if not done or any((r.get("setup_s") or 0) > args.pydy_budget for r in out):
                        pydy_over[name] = n
            save(rows, agreement, args, started)  # after every scene and N: an interrupted run keeps its results
    print(save(rows, agreement, args, started))


def save(rows, agreement, args, started) -> str:
    """Write compare.jsonl and summary.md (atomically); returns the markdown."""
    from flexmb._files import atomic_write

    os.makedirs(RESULTS, exist_ok=True)
    wp.write_jsonl(rows, os.path.join(RESULTS, "compare.jsonl"))
    with open(os.path.join(RESULTS, "compare_agreement.json"), "w") as fh:
        json.dump([{"tool": t, "scene": s, "n_segments": n, "agreement": v} for (t, s, n), v in agreement.items()],
                  fh, indent=1)
    md = summary(rows, agreement, args, started)

    def write(tmp):
        with open(tmp, "w") as fh:
            fh.write(md)

    atomic_write(os.path.join(RESULTS, "summary.md"), write)
    return md


def _fmt(x, spec=".3g"):
    return "—" if x is None else format(x, spec)


def summary(rows, agreement, args, started) -> str:
    """The markdown summary: best time at the target error per tool, ratios flexmb/peer, checks."""
    target = args.target
    lines = [f"# flexmb and peers, side by side ({started}, one run of `benchmarks/peers/compare.py`)", "",
             f"Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
             f"shared with other jobs (load average at the end: "
             f"{', '.join(f'{v:.1f}' for v in os.getloadavg())}). Times are medians of {args.repeat} runs; "
             "absolute times are hints, ratios from this same run are the facts.", "",
             f"Error: integration error of the tip position at t = 1 s (Euclidean norm, m) against flexmb's "
             f"Radau solution of the same model at rtol {args.ref_rtol:g}. \"Agreement\" is the distance of the "
             "peer's own converged solution (Exudyn: Richardson extrapolation of generalized-alpha with "
             f"{args.verify_steps} and {2 * args.verify_steps} steps; MuJoCo: its best RK4 run; PyDy: its best "
             "run) to that reference: "
             "it shows that the peer solves the same equations.", "",
             f"Best = least wall time among the runs with error <= {target:g}. PyDy's total includes its symbolic "
             "derivation and code generation (setup_s), which it must redo for every new model.", "",
             "| scene | N | tool | best configuration | error | setup s | wall s | total s | flexmb/peer (wall) "
             "| flexmb/peer (total) | agreement |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    ratio_log = {}
    for scene in ("B1", "B2"):
        srows = [r for r in rows if r.get("scene") == scene and r.get("error_kind", "integration") == "integration"]
        best = best_wall_at(srows, target)
        for n in sorted({r["n_segments"] for r in srows}):
            fx = best.get(("flexmb", n))
            tools = ["flexmb"] + [t for t in ("exudyn", "mujoco", "pydy") if t in args.peers]
            for tool in tools:
                b = best.get((tool, n))
                status = next((r.get("status") for r in srows if r.get("tool") == tool and r["n_segments"] == n
                               and str(r.get("status", "")).startswith(("skipped", "timeout", "exit", "failed"))),
                              None)
                if b is None:
                    # a setup interrupted at its budget still bounds the ratio: flexmb/peer < flexmb / budget
                    spent = max((r.get("setup_s") or 0.0 for r in srows if r.get("tool") == tool
                                 and r["n_segments"] == n), default=0.0)
                    bound = f"< {fx[0] / spent:.3g}" if fx is not None and spent > 0 else ""
                    if bound:
                        ratio_log[(tool, scene, n)] = (None, fx[0] / spent)
                    lines.append(f"| {scene} | {n} | {tool} | {status or f'no run reached {target:g}'} | | "
                                 f"{_fmt(spent or None)} | | > {spent:.3g} | | {bound} | "
                                 f"{_fmt(agreement.get((tool, scene, n)), '.1e')} |")
                    continue
                w, r = b
                total = (r.get("setup_s") or 0.0) + w if tool == "pydy" else w
                conf = (f"{r['integrator']}, rtol {r['rtol']:g}" if r.get("rtol") is not None
                        else f"{r['integrator']}, h {r['h']:g} s")
                rw = rt = None
                if tool != "flexmb" and fx is not None:
                    rw = fx[0] / w
                    rt = fx[0] / total
                    ratio_log[(tool, scene, n)] = (rw, rt)
                lines.append(f"| {scene} | {n} | {tool} | {conf} | {r['error']:.1e} | {_fmt(r.get('setup_s'))} | "
                             f"{w:.3g} | {total:.3g} | {_fmt(rw)} | {_fmt(rt)} | "
                             f"{_fmt(agreement.get((tool, scene, n)), '.1e')} |")
    lines += ["", "## Targets of issue 6", ""]
    b2 = best_wall_at([r for r in rows if r.get("scene") == "B2"], target)
    ns_fx = sorted(n for t, n in b2 if t == "flexmb")
    p = fit_exponent(ns_fx, [b2[("flexmb", n)][0] for n in ns_fx]) if ns_fx else None
    r64 = ratio_log.get(("exudyn", "B2", 64))
    lines.append(f"- B2, N = 64, error <= 1e-6, flexmb at most as slow as Exudyn: "
                 + (f"flexmb/Exudyn = {r64[0]:.3g} ({'met' if r64[0] <= 1 else 'not met'})" if r64
                    else "not measured in this run (N = 64 not run)"))
    lines.append(f"- B2 wall time per simulated second grows as N^p with p <= 2 up to N = 256: fitted p = "
                 f"{_fmt(p, '.2f')} over N = {ns_fx} (" + ("the target's range not covered" if not ns_fx or
                                                            max(ns_fx) < 256 else "covered") + ")")
    pyd = {k: v for k, v in ratio_log.items() if k[0] == "pydy" and k[2] >= 8}
    lines.append("- flexmb at least 10x faster than PyDy (totals) from N = 8 up: " + (
        "; ".join(f"{s} N={n}: flexmb/PyDy {'<' if v[0] is None else '='} {v[1]:.3g} "
                  f"({'met' if v[1] <= 0.1 else 'not met'})"
                  for (_, s, n), v in sorted(pyd.items())) if pyd else "no PyDy run at N >= 8 reached the target"))
    ex = {k: v for k, v in ratio_log.items() if k[0] == "exudyn" and v[0] is not None}
    if ex:
        lines.append("- flexmb/Exudyn (wall) at the other N: " + "; ".join(
            f"{s} N={n}: {v[0]:.3g}" for (_, s, n), v in sorted(ex.items())))
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
