"""Plots of the benchmark JSON lines (BENCHMARKS.md): work-precision, scaling with N, discretisation.

Reads every ``*.jsonl`` in ``benchmarks/results/`` (or the files given),
except the runs that have figures of their own (``OWN_FIGURES``), and
writes, next to them:

- ``wp_<scene>.png``: integration error against wall time (log-log), one
  panel per N, one line per tool + integrator (work-precision diagram);
- ``scaling_<scene>.png`` (scenes with several N): wall time per simulated
  second to reach an integration error <= ``--target`` against N, per tool,
  with the exponent fitted by ``np.polyfit`` on log-log;
- ``disc_<scene>.png``: discretisation error against N (its own figure:
  the two kinds of error are never mixed in one figure).

Run: ``python benchmarks/plot.py [files...] [--target 1e-6] [--out benchmarks/results]``.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
from collections import defaultdict

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
RESULTS = os.path.join(HERE, "results")

#: result files left out by default: other runs of the same tools (one figure
#: shows one run) that have their own tables and figures
OWN_FIGURES = {"compare_first_run.jsonl", "floor_B1.jsonl", "flexmb_B2_scaling.jsonl",
               "compare_best_pick.jsonl",  # the run of 2026-11-26, before issue 31 (best picks)
               "compare_processes.jsonl"}  # one process per simulation: CPU of whole processes, no work-precision


def load(paths) -> list:
    """All rows of the given JSON-lines files; a configuration met twice keeps its last row.

    So a side-by-side run (``compare.jsonl``, read last) replaces flexmb's rows
    of the same scene, N, integrator and tolerance from ``flexmb_<scene>.jsonl``.
    """
    rows = {}
    for p in paths:
        with open(p) as fh:
            for line in fh:
                if line.strip():
                    r = json.loads(line)
                    key = tuple(str(r.get(k)) for k in ("tool", "scene", "variant", "n_segments", "integrator",
                                                         "rtol", "h", "error_kind"))
                    rows.pop(key, None)
                    rows[key] = r
    return list(rows.values())


def _ok(r) -> bool:
    return (r.get("error") is not None and r.get("wall_s") is not None and r["error"] > 0
            and str(r.get("status", "finished")).startswith("finished"))


def _tidy_log_axes(ax):
    """Minor tick labels of short log axes only at 2, (3,) 5 times a power of ten."""
    from matplotlib.ticker import FuncFormatter, NullFormatter

    def label(v, _, marks):
        mant = v / 10 ** np.floor(np.log10(v))
        if round(mant) not in marks or abs(mant - round(mant)) > 1e-6:
            return ""
        return f"{v:.0e}" if v < 1e-2 else f"{v:g}"

    for axis, (lo, hi) in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
        marks = (2, 3, 5) if hi / lo < 10 else (2, 5)
        axis.set_minor_formatter(FuncFormatter(lambda v, pos, marks=marks: label(v, pos, marks))
                                 if hi / lo < 100 else NullFormatter())


def _n_ticks(ax, ns):
    """Label the x axis at the segment counts that were run."""
    from matplotlib.ticker import NullFormatter

    ax.set_xticks(ns)
    ax.set_xticklabels([str(n) for n in ns])
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlim(min(ns) / 1.3, max(ns) * 1.3)


def _line_key(r) -> str:
    integ = str(r.get("integrator"))
    if integ.startswith(r["tool"] + " "):
        integ = integ[len(r["tool"]) + 1:]
    return f"{r['tool']} {integ}"


def best_wall_at(rows, target: float) -> dict:
    """Least wall time (s) among integration runs with error <= target, by (tool, N).

    Returns
    -------
    dict
        ``{(tool, n): (wall_s, row)}``.
    """
    best = {}
    for r in rows:
        if r.get("error_kind") != "integration" or not _ok(r) or r["error"] > target:
            continue
        key = (r["tool"], r["n_segments"])
        if key not in best or r["wall_s"] < best[key][0]:
            best[key] = (r["wall_s"], r)
    return best


def fit_exponent(ns, walls) -> float | None:
    """Slope of log(wall) against log(N) (np.polyfit degree 1); None with fewer than 2 points."""
    ns, walls = np.asarray(ns, float), np.asarray(walls, float)
    if len(ns) < 2 or len(set(ns)) < 2:
        return None
    return float(np.polyfit(np.log(ns), np.log(walls), 1)[0])


def plot_work_precision(plt, rows, scene, out):
    rows = [r for r in rows if r["scene"] == scene and r.get("error_kind") == "integration" and _ok(r)]
    if not rows:
        return None
    ns = sorted({r["n_segments"] for r in rows})
    variants = sorted({r.get("variant", "") for r in rows})
    panels = [(n, v) for n in ns for v in variants if any(r["n_segments"] == n and r.get("variant", "") == v
                                                          for r in rows)]
    cols = min(len(panels), 3)
    nrows = int(np.ceil(len(panels) / cols))
    fig, axes = plt.subplots(nrows, cols, figsize=(8.2 * cols, 4.3 * nrows), squeeze=False)
    for ax, (n, v) in zip(axes.flat, panels):
        lines = defaultdict(list)
        for r in rows:
            if r["n_segments"] == n and r.get("variant", "") == v:
                lines[_line_key(r)].append(r)
        for i, (key, rs) in enumerate(sorted(lines.items())):
            rs.sort(key=lambda r: (r["rtol"] if r.get("rtol") is not None else -(r.get("h") or 0)), reverse=True)
            style = "-o" if rs[0]["tool"] == "flexmb" else "--s"
            ax.loglog([r["wall_s"] for r in rs], [r["error"] for r in rs], style, ms=4, label=key, color=f"C{i % 10}")
        ax.axhline(1e-6, color="0.6", lw=0.8, ls=":")
        title = f"{scene} N = {n}" if n else f"{scene}"
        ax.set_title(f"{title}\n{v}", fontsize=9)
        ax.set_xlabel("wall time [s] (median)")
        ax.set_ylabel(f"integration error [{'rad' if scene == 'B5' else 'm'}]")
        _tidy_log_axes(ax)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    for ax in list(axes.flat)[len(panels):]:
        ax.set_visible(False)
    fig.suptitle(f"Work-precision, {scene}: integration error against\nthe same model at the tightest settings",
                 fontsize=10)
    fig.tight_layout()
    path = os.path.join(out, f"wp_{scene}.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_scaling(plt, rows, scene, out, target, name=None):
    rows = [r for r in rows if r["scene"] == scene and (r.get("n_segments") or 0) > 0]
    best = best_wall_at(rows, target)
    tools = sorted({t for t, _ in best})
    if not best or max(len([1 for t, _ in best if t == tool]) for tool in tools) < 2:
        return None, {}
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    exps = {}
    for i, tool in enumerate(tools):
        pts = sorted((n, w / (r.get("t_end") or 1.0)) for (t, n), (w, r) in best.items() if t == tool)
        ns, ws = zip(*pts)
        p = fit_exponent(ns, ws)
        exps[tool] = p
        lab = f"{tool}" + (f": exponent {p:.2f}" if p is not None else "")
        ax.loglog(ns, ws, "-o" if tool == "flexmb" else "--s", label=lab, color=f"C{i}")
        if p is not None:
            c = np.polyfit(np.log(ns), np.log(ws), 1)
            nn = np.array([min(ns), max(ns)], float)
            ax.loglog(nn, np.exp(np.polyval(c, np.log(nn))), ":", color=f"C{i}", lw=1)
    ax.set_xlabel("N (segments)")
    ax.set_ylabel(f"wall time per simulated second [s/s]\nat integration error <= {target:g}")
    ax.set_title(f"{scene}: cost against N (best integrator and tolerance per N)", fontsize=10)
    _tidy_log_axes(ax)
    _n_ticks(ax, sorted({n for _, n in best}))
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = os.path.join(out, name or f"scaling_{scene}.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path, exps


def plot_discretisation(plt, rows, scene, out):
    rows = [r for r in rows if r["scene"] == scene and r.get("error_kind") == "discretisation" and _ok(r)]
    if len(rows) < 1:
        return None
    fig, ax = plt.subplots(figsize=(6.0, 4.4))
    by = defaultdict(list)
    for r in rows:
        by[(r["tool"], r.get("reference"))].append(r)
    for i, ((tool, ref), rs) in enumerate(sorted(by.items())):
        rs.sort(key=lambda r: r["n_segments"])
        ns = [r["n_segments"] for r in rs]
        es = [r["error"] for r in rs]
        p = fit_exponent(ns, es)
        lab = f"{tool} vs {ref}" + (f": order {-p:.2f}" if p is not None else "")
        ax.loglog(ns, es, "-o", label=lab, color=f"C{i}")
    ax.set_xlabel("N (segments)")
    ax.set_ylabel("discretisation error [m]")
    ax.set_title(f"{scene}: discretisation error against N", fontsize=10)
    _tidy_log_axes(ax)
    _n_ticks(ax, sorted({r["n_segments"] for r in rows}))
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    path = os.path.join(out, f"disc_{scene}.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="*")
    ap.add_argument("--target", type=float, default=1e-6)
    ap.add_argument("--out", default=RESULTS)
    args = ap.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    os.makedirs(args.out, exist_ok=True)
    files = args.files or sorted((p for p in glob.glob(os.path.join(RESULTS, "*.jsonl"))
                                  if os.path.basename(p) not in OWN_FIGURES),
                                 key=lambda p: (os.path.basename(p) == "compare.jsonl", p))
    rows = load(files)
    for scene in sorted({r["scene"] for r in rows}):
        for path in (plot_work_precision(plt, rows, scene, args.out),
                     plot_scaling(plt, rows, scene, args.out, args.target)[0],
                     plot_discretisation(plt, rows, scene, args.out)):
            if path:
                print("wrote", path)


if __name__ == "__main__":
    main()
