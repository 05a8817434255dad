"""Traced peak memory and CPU of every consumer of the equations on looped models (issue 28, items 2-3).

Each consumer runs alone in a tracemalloc window (after a warm-up of the
same consumer at a small size, so that the kernels are loaded): its peak
beyond what was allocated when it started, and its CPU time
(``time.process_time``). The largest array a quadratic path forms is
named by ``n x n`` = ``8 n^2`` bytes in the rows (``nn_bytes``), so that a
peak near or above it marks a dense consumer. B7 (the chain of N
four-bars, m = 2N rows for n = 2N + 1 coordinates) and B6 damped (one loop,
3 rows), closed by the articulated strategy.

    OPENBLAS_NUM_THREADS=1 python benchmarks/loop_consumers_memory.py [--repeats 3] [b7:256 b7:1024 b6:1024 ...]
    python benchmarks/loop_consumers_memory.py --summary

Rows are appended to benchmarks/results/loop_consumers_memory.jsonl; with
``--repeats k`` each consumer runs k times in a row at each size and its
row gives the least CPU time (the peak is that of the first run). The
summary prints, per consumer, the peaks and CPU times of the latest rows
and their exponents ``log(ratio) / log(n ratio)`` between the smallest and
the largest B7 size (1: linear, 2: quadratic, 3: cubic), and B6's peak.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import flexmb as fm  # noqa: E402
import scenes  # noqa: E402
from flexmb import memory  # noqa: E402
from flexmb.export.vtk import write_vtu  # noqa: E402
from flexmb.output_projection import _project_partial, project_output  # noqa: E402
from flexmb.post.sections import section_loads  # noqa: E402
from flexmb.simulate import _calibrated  # noqa: E402

OUT = HERE / "results" / "loop_consumers_memory.jsonl"


def _b7(n):
    model, initial = scenes.b7(n)
    names = list(initial["positions"])

    def at(theta):
        return {k: (theta if k.startswith("pin") else -theta) for k in names}

    return model, at(0.4), {"pin_0": -1.0}, at(np.pi / 2 - 1e-3), "off"


def _b6(n):
    model, positions = scenes.b6(True, n)
    return model, positions, None, None, "rod"


MODELS = {"b7": _b7, "b6": _b6}
#: the size each model is warmed up at: past the speeds from which CVODE and generalized-alpha solve by Krylov on
#: loops (flexmb.stepping.KRYLOV_MIN_COORDS, flexmb.genalpha.krylov.KRYLOV_MIN_LOOP_COORDS: B7 has 2N + 1 speeds,
#: B6 N + 2), so that the warm-up compiles what the measured size runs and no compilation is traced
WARM_SIZE = {"b7": 80, "b6": 160}

#: B7's consumers, in the order they run (B6 adds ``sections`` and has no singular position to project near)
CONSUMERS = ["build", "assemble", "rhs", "project", "output_projection", "partial_projection", "cvode", "genalpha",
             "statics", "reactions", "modes", "path", "linearize", "state_space", "energy", "vtk", "estimate"]


def _cases(model, positions, speeds, flat, flexible, tmp):
    """(name, callable(ctx)) in order; ctx holds the built system, the assembled state and a result."""
    def build(c):
        c["system"] = model.build(complement="articulated")

    def assemble(c):
        off = {k: (v + 0.02 if isinstance(v, float) else v) for k, v in positions.items()}
        x, xd = fm.initial_state(c["system"], 0.0, positions=off, speeds=speeds)
        c["x"], c["xd"] = fm.initial_state(c["system"], 0.0, positions=positions, speeds=speeds)
        c["system"] = _calibrated(c["system"], 0.0, c["x"], c["xd"])

    def rhs(c):
        y = np.concatenate([c["x"], c["xd"]])
        for _ in range(3):
            c["system"].state_rate(0.0, y)

    def project(c):
        c["system"].project(0.0, c["x"] + 1e-7, c["xd"])
        c["system"].project(0.0, c["x"] + 1e-7, c["xd"], speeds="mass")

    def output_projection(c):
        project_output(c["system"], 0.0, c["x"] + 1e-7, c["xd"] + 1e-7, 1e-12)

    def partial_projection(c):
        x, xd = fm.initial_state(c["system"], 0.0, positions=flat, speeds=speeds)
        x, xd = x + 1e-6, xd + 1e-6
        _project_partial(c["system"], 0.0, x, xd, c["system"].constraint_residual(0.0, x, xd))

    def cvode(c):
        c["res"] = fm.simulate(c["system"], 2e-4, positions=positions, speeds=speeds, method="CVODE_BDF",
                               n_out=3, progress=False)

    def genalpha(c):
        fm.simulate(c["system"], 2e-4, positions=positions, speeds=speeds, method="GeneralizedAlpha", n_out=3,
                    progress=False)

    def statics(c):
        fm.static_equilibrium(c["system"], c["x"], continuation=False)

    def reactions(c):
        c["system"].reactions(0.0, c["x"], c["xd"])

    def sections(c):
        section_loads(c["res"], flexible, c["system"])

    def modes(c):
        fm.modes(c["system"], n_modes=6, x0=c["x"])

    def path(c):
        fm.load_path(c["system"], x0=c["x"], lam_end=0.05, options=fm.PathOptions(step=0.05, max_steps=3))

    def linearize(c):
        fm.linearize(c["system"], c["x"], c["xd"])

    def state_space(c):
        fm.state_space(c["system"], about=(c["x"], c["xd"]))

    def energy(c):
        c["res"].energy
        c["system"].energy(0.0, c["x"], c["xd"])

    def vtk(c):
        write_vtu(c["res"], Path(tmp) / "vtk", system=c["system"])

    def estimate(c):
        memory.estimate(c["system"], n_out=3, loops="articulated")

    cases = [build, assemble, rhs, project, output_projection]
    cases += [partial_projection] if flat is not None else []
    cases += [cvode, genalpha, statics, reactions]
    cases += [sections] if flexible == "rod" else []
    cases += [modes, path, linearize, state_space, energy, vtk, estimate]
    return cases


def _measure(fn, ctx, repeats=1):
    peak, cpu = _traced(fn, ctx)
    for _ in range(repeats - 1):
        cpu = min(cpu, _traced(fn, ctx)[1])
    return peak, cpu


def _traced(fn, ctx):
    tracemalloc.start()
    try:
        start = tracemalloc.get_traced_memory()[0]
        t0 = time.process_time()
        fn(ctx)
        cpu = time.process_time() - t0
        peak = tracemalloc.get_traced_memory()[1] - start
    finally:
        tracemalloc.stop()
    return peak, cpu


def run(name, size, skip=(), tmp=None, repeats=1):
    """Rows of one model at one size (each consumer first warmed up at a smaller size; files under ``tmp``)."""
    make = MODELS[name]
    rows = []
    with tempfile.TemporaryDirectory(dir=tmp) as tmp:
        warm, ctx_w = _cases(*make(min(size, WARM_SIZE[name])), tmp), {}
        big, ctx = _cases(*make(size), tmp), {}
        for w, fn in zip(warm, big):
            w(ctx_w)
            if fn.__name__ in skip:
                continue
            try:
                peak, cpu = _measure(fn, ctx, repeats)
                err = None
            except Exception as e:  # noqa: BLE001 (a row that says so)
                peak, cpu, err = None, None, f"{type(e).__name__}: {e}"[:200]
            s = ctx["system"]
            row = {"model": name, "N": size, "n": s.n_speeds, "m": s.n_constraints, "consumer": fn.__name__,
                   "peak_bytes": peak, "cpu_s": cpu, "nn_bytes": 8 * s.n_speeds ** 2, "error": err}
            print(json.dumps(row), flush=True)
            rows.append(row)
    return rows


def summary(path=OUT):
    """A Markdown table of the latest rows: peaks, CPU and their exponents per consumer."""
    latest = {}
    for line in open(path):
        r = json.loads(line)
        latest[(r["model"], r["N"], r["consumer"])] = r
    b7 = sorted({k[1] for k in latest if k[0] == "b7"})
    b6 = sorted({k[1] for k in latest if k[0] == "b6"})
    lo, hi = b7[0], b7[-1]
    out = [f"| consumer | B7 N = {lo} peak | B7 N = {hi} peak | its / 8 n^2 | memory exponent | CPU N = {lo} | "
           f"CPU N = {hi} | CPU exponent | B6 N = {b6[-1]} peak | its / 8 n^2 |",
           "|---" * 10 + "|"]
    for c in CONSUMERS[:-1] + ["sections"] + CONSUMERS[-1:]:
        a, b, d = latest.get(("b7", lo, c)), latest.get(("b7", hi, c)), latest.get(("b6", b6[-1], c))
        cells = [c]
        if a and b and a["peak_bytes"] is not None and b["peak_bytes"] is not None:
            scale = np.log(b["n"] / a["n"])
            cells += [f"{a['peak_bytes'] / 1e6:.3g} MB", f"{b['peak_bytes'] / 1e6:.3g} MB",
                      f"{b['peak_bytes'] / b['nn_bytes']:.2g}",
                      f"{np.log(b['peak_bytes'] / max(a['peak_bytes'], 1)) / scale:.2f}",
                      f"{a['cpu_s']:.3g} s", f"{b['cpu_s']:.3g} s",
                      f"{np.log(b['cpu_s'] / a['cpu_s']) / scale:.2f}"]
        else:
            cells += ["-"] * 7
        if d and d["peak_bytes"] is not None:
            cells += [f"{d['peak_bytes'] / 1e6:.3g} MB", f"{d['peak_bytes'] / d['nn_bytes']:.2g}"]
        else:
            cells += ["-", "-"]
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def main(argv):
    """Run the given ``model:N`` cases (default: b7:256 b7:1024 b6:1024) and append their rows."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    if argv[:1] == ["--summary"]:
        print(summary())
        return
    repeats = 1
    if argv[:1] == ["--repeats"]:
        repeats, argv = int(argv[1]), argv[2:]
    cases = argv or ["b7:256", "b7:1024", "b6:1024"]
    skip = set(os.environ.get("SKIP", "").split(",")) - {""}
    for case in cases:
        name, size = case.split(":")
        rows = run(name, int(size), skip, repeats=repeats)
        with open(OUT, "a") as f:
            for r in rows:
                f.write(json.dumps(r) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
