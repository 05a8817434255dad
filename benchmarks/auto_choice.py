"""Which integrator ``method='auto'`` should pick: every candidate on the benchmark scenes, timed.

For each scene (B1 N = 8 and 64, B2 N = 16 over 1 s; the flexible wiper
over 0.5 s at the default rtol and at the 1e-6 of its scene file; the
damped B6 slider-crank over 0.2 s; and, for the explicit branch, the
rigid four-bar B5 over 5 s and the soft B1 N = 2 and N = 4, whose
explicit stability limit is near ``AUTO_IMPLICIT_STEPS``), each candidate
integrator (``--methods``, default DOP853, Radau, CVODE_BDF and
CVODE_Adams at the scene's rtol, and CVODE_BDF and CVODE_Adams at a tenth
of it, written ``NAME@0.1``, to compare at equal error; scipy's BDF is left
out: on the four-bar at rtol 1e-8 it did not finish within 120 s) and
``'auto'`` itself are run ``--repeat`` times, alternating
between the candidates so that they see the same load, with one BLAS
thread; the least CPU time (``time.process_time``) and the least wall
time are kept. An explicit candidate is skipped where it would need more
than ``--explicit-limit`` steps just to stay stable.

The error of each run is measured against a reference of the same model
(Radau at ``--ref-rtol``, cached in ``results/refs/``): the largest
deviation of the coordinate histories (201 output times) relative to the
largest coordinate magnitude, and for B6 the crank torque error of
``b6_slider_crank.torque_error`` against its own cached reference.

Run with one BLAS thread::

    OPENBLAS_NUM_THREADS=1 python benchmarks/auto_choice.py
    OPENBLAS_NUM_THREADS=1 python benchmarks/auto_choice.py --scenes B1-8 B6-damped --repeat 1   # quick

One JSON line per scene and integrator goes to ``results/auto_choice.jsonl``
(the file is rewritten); a Markdown table to ``results/auto_choice.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import flexmb as fm  # noqa: E402
import scenes  # noqa: E402

RESULTS = os.path.join(HERE, "results")
REFS = os.path.join(RESULTS, "refs")
N_OUT = 201


def _b6_damped():
    model, initial = scenes.b6(damped=True)
    return model.build(), {"positions": initial}


def _wiper():
    from flexmb.scenes.wiper import WiperOptions, wiper

    model, initial = wiper(WiperOptions(flexible=True))
    return model.build(), {"positions": initial}


def _fourbar():
    from flexmb.scenes.fourbar import fourbar

    model, initial, fixed = fourbar()
    return model.build(), {"positions": initial, "fixed": fixed}


#: key -> (description, build() -> (system, simulate kwargs), t_end, rtol)
SCENES = {
    "B1-8": ("B1 N=8, 1 s", lambda: (scenes.b1(8).build(), {}), 1.0, 1e-8),
    "B1-64": ("B1 N=64, 1 s", lambda: (scenes.b1(64).build(), {}), 1.0, 1e-8),
    "B2-16": ("B2 N=16, 1 s", lambda: (scenes.b2(16).build(), {}), 1.0, 1e-8),
    "wiper": ("flexible wiper, 0.5 s", _wiper, 0.5, 1e-8),
    "wiper-1e-6": ("flexible wiper, 0.5 s, rtol 1e-6 (its scene file)", _wiper, 0.5, 1e-6),
    "B6-damped": ("B6 damped, 0.2 s", _b6_damped, 0.2, 1e-8),
    "B5": ("B5 rigid four-bar, 5 s", _fourbar, 5.0, 1e-8),
    "B1-2": ("B1 N=2, 1 s", lambda: (scenes.b1(2).build(), {}), 1.0, 1e-8),
    "B1-4": ("B1 N=4, 1 s", lambda: (scenes.b1(4).build(), {}), 1.0, 1e-8),
}
EXPLICIT = ("DOP853", "RK45", "RK23", "CVODE_Adams")


def simulate(system, kw, t_end, method, rtol):
    """One run: (result, wall s, CPU s)."""
    w0, c0 = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = fm.simulate(system, t_end, method=method, rtol=rtol, n_out=N_OUT, progress=False, **kw)
    return res, time.perf_counter() - w0, time.process_time() - c0


def reference(key, system, kw, t_end, ref_rtol):
    """Radau at ``ref_rtol`` (B6: the benchmark's own cached reference), cached as a Result file."""
    if key == "B6-damped":
        import b6_slider_crank

        return b6_slider_crank.reference(1e-9, t_end, N_OUT)
    path = os.path.join(REFS, f"auto_choice_{key}_Radau_{ref_rtol:g}_{t_end:g}.npz")
    if os.path.exists(path):
        return fm.Result.load(path)
    res, wall, cpu = simulate(system, kw, t_end, "Radau", ref_rtol)
    print(f"  reference {key}: Radau rtol {ref_rtol:g}, {cpu:.1f} s CPU", flush=True)
    os.makedirs(REFS, exist_ok=True)
    res.save(path)
    return res


def error(key, res, ref):
    """Deviation from the reference: coordinate histories (relative), or B6's crank torque."""
    if key == "B6-damped":
        import b6_slider_crank

        return b6_slider_crank.torque_error(res, ref), "crank torque, max relative"
    return float(np.max(np.abs(res.x - ref.x)) / np.max(np.abs(ref.x))), "coordinates, max relative"


def stable_steps(system, kw, t_end):
    """Steps an explicit method needs over ``t_end`` just to stay stable (``t_end * omega / 3``)."""
    x, xd = fm.initial_state(system, 0.0, kw.get("positions"), fixed=kw.get("fixed"))
    return t_end * system.fastest_rate(0.0, x, xd) / 3.0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    ap.add_argument("--methods", nargs="+",
                    default=["DOP853", "Radau", "CVODE_BDF", "CVODE_Adams", "CVODE_BDF@0.1", "CVODE_Adams@0.1"],
                    help="integrator names, NAME@f for NAME at f times the scene's rtol")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--ref-rtol", type=float, default=1e-10)
    ap.add_argument("--explicit-limit", type=float, default=20000.0,
                    help="skip explicit candidates needing more stable steps than this")
    ap.add_argument("--out", default=os.path.join(RESULTS, "auto_choice.jsonl"))
    args = ap.parse_args(argv)
    stamp = time.strftime("%Y-%m-%d %H:%M", time.gmtime())
    rows = []
    for key in args.scenes:
        label, build, t_end, rtol = SCENES[key]
        system, kw = build()
        steps = stable_steps(system, kw, t_end)
        ref = reference(key, system, kw, t_end, args.ref_rtol)
        methods = [m for m in args.methods
                   if not (m.split("@")[0] in EXPLICIT and steps > args.explicit_limit)] + ["auto"]
        skipped = [m for m in args.methods if m not in methods]
        best = {m: {"wall_s": np.inf, "cpu_s": np.inf} for m in methods}
        loads = []
        for _ in range(args.repeat):
            for m in methods:  # alternating: every candidate sees the same load
                name, _, factor = m.partition("@")
                res, wall, cpu = simulate(system, kw, t_end, name, rtol * float(factor or 1.0))
                loads.append(os.getloadavg()[0])
                b = best[m]
                b["wall_s"], b["cpu_s"] = min(b["wall_s"], wall), min(b["cpu_s"], cpu)
                err, kind = error(key, res, ref)
                b.update(picked=res.method, status=res.status, steps=res.n_steps, rhs_evals=res.n_rhs,
                         jac_evals=res.n_jac, error=err, error_kind=kind)
        for m in methods:
            row = {"scene": key, "description": label, "n_coords": system.n_coords, "t_end": t_end,
                   "rtol": rtol * float(m.partition("@")[2] or 1.0),
                   "integrator": m, "repeats": args.repeat, "explicit_stable_steps": steps,
                   "reference": "b6_slider_crank Radau rtol=1e-09" if key == "B6-damped"
                   else f"Radau rtol={args.ref_rtol:g}", "skipped": skipped,
                   "load_avg_1min_mean": float(np.mean(loads)), "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
                   "run": stamp}
            row.update(best[m])
            rows.append(row)
            print(json.dumps(row), flush=True)
    with open(args.out, "w") as fh:
        fh.writelines(json.dumps(r) + "\n" for r in rows)
    write_table(rows, os.path.splitext(args.out)[0] + ".md")
    return rows


def write_table(rows, path):
    """A Markdown table: CPU (wall) seconds and error per scene and candidate; the fastest marked."""
    methods = list(dict.fromkeys(r["integrator"] for r in rows))
    lines = ["| scene | rtol | explicit stable steps | " + " | ".join(methods) + " |",
             "|---" * (len(methods) + 3) + "|"]
    for key in dict.fromkeys(r["scene"] for r in rows):
        mine = {r["integrator"]: r for r in rows if r["scene"] == key}
        cand = {m: r for m, r in mine.items() if m != "auto" and r["status"] == "finished"}
        fastest = min(cand, key=lambda m: cand[m]["cpu_s"]) if cand else None
        cells = []
        for m in methods:
            r = mine.get(m)
            if r is None:
                cells.append("skipped")
                continue
            cell = f"{r['cpu_s']:.3g} ({r['wall_s']:.3g}), err {r['error']:.1g}"
            if m == "auto":
                cell += f" -> {r['picked']}"
            if m == fastest:
                cell = f"**{cell}**"
            cells.append(cell)
        first = mine["auto"]
        lines.append(f"| {first['description']} | {first['rtol']:g} | {first['explicit_stable_steps']:.3g} | "
                     + " | ".join(cells) + " |")
    first = rows[0]
    lines += ["", f"CPU s (wall s) of one run, least of {first['repeats']} alternating repeats, one BLAS thread, "
              f"mean 1-min load {np.mean([r['load_avg_1min_mean'] for r in rows]):.2f}, run {first['run']} UTC; "
              "err: largest deviation from the reference (coordinates relative to their largest magnitude; "
              "B6: crank torque); bold: the fastest candidate; NAME@0.1: at a tenth of the scene's rtol."]
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
