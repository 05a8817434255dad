"""flexmb side by side with its peers on the same scenes, in one run (BENCHMARKS.md, "Peers").

For each scene (B1, B2) and N: flexmb runs here (this interpreter, the
project's venv) through ``work_precision.run_config``; each peer runs in the
peers' venv by subprocess (``exudyn_beam.py``, ``mujoco_beam.py``,
``pydy_beam.py``), given flexmb's reference tip position of the same N so
that every tool's error is the integration error against the same model at
the tightest settings.

Timing follows the house rule "ratios from alternating repeats (min of >=
3)" (``rounds.py``): ``--repeat`` rounds, each running every flexmb
configuration once and then each peer's configurations once (the peer
processes wait between rounds, driven over stdin); a configuration's time is
its least wall time over the rounds, all of them kept in ``wall_rounds``.
Model setup is timed apart as before (``setup_s``, also the least over the
rounds; PyDy derives its model once, in the first round).
OPENBLAS_NUM_THREADS is 1 unless the caller set it; the peers get the same
value, and every row records the value its process saw
(``openblas_num_threads``).

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
import queue
import subprocess
import sys
import tempfile
import threading
import time

if __name__ == "__main__":  # before numpy loads OpenBLAS: one BLAS thread unless the caller chose otherwise
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
BENCH = os.path.dirname(HERE)
sys.path.insert(0, BENCH)

import work_precision as wp  # noqa: E402
from plot import best_wall_at, fit_exponent  # noqa: E402

sys.path.insert(0, HERE)
from rounds import merge_rounds  # noqa: E402

RESULTS = os.path.join(BENCH, "results")


def peer_env() -> dict:
    """The peers' environment: this one, with this process's OPENBLAS_NUM_THREADS (1 by default)."""
    return dict(os.environ, OPENBLAS_NUM_THREADS=os.environ.get("OPENBLAS_NUM_THREADS", "1"))


def _show(cmd) -> str:
    return "  $ " + " ".join(os.path.basename(c) if i < 2 else c for i, c in enumerate(cmd))


def peer_rows(python, script, args, timeout, log=print) -> list:
    """Run a peer script in the peers' venv; its JSON lines, or one failure row."""
    cmd = [python, os.path.join(HERE, script), *map(str, args)]
    log(_show(cmd))
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd="/", env=peer_env())
    except subprocess.TimeoutExpired:
        return [{"status": f"timeout after {timeout:g} s"}]
    rows = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    if proc.returncode != 0:
        rows.append({"status": f"exit {proc.returncode}: {proc.stderr.strip().splitlines()[-1:]}"})
    return rows


class Peer:
    """A peer script started with ``--rounds-from-stdin``: it runs each of its configurations once per round.

    The process is started (and its imports done) before the first round;
    :meth:`round` asks for one round and returns the rows of its runs;
    :meth:`close` ends it. ``timeout`` bounds the whole life of the process:
    past it the process is killed and :meth:`close` returns one failure row,
    as does an early exit.
    """

    def __init__(self, cmd, timeout: float, env=None, log=print):
        cmd = [*map(str, cmd), "--rounds-from-stdin"]
        log(_show(cmd))
        self.timeout = timeout
        self.deadline = time.monotonic() + timeout
        self.status = None  # why the process is gone early (the failure row's status)
        self._err = tempfile.TemporaryFile("w+")
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=self._err, text=True, cwd="/", env=env)
        self._lines = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        self._until("ready")

    def _read(self):
        for line in self.proc.stdout:
            self._lines.put(line)
        self._lines.put(None)

    def _until(self, mark: str) -> list:
        """The JSON rows up to the line holding ``mark``; on exit or timeout, those read and ``status`` set."""
        rows = []
        while self.status is None:
            try:
                line = self._lines.get(timeout=max(self.deadline - time.monotonic(), 0.0))
            except queue.Empty:
                self.proc.kill()
                self.proc.wait()
                self.status = f"timeout after {self.timeout:g} s"
                break
            if line is None:
                code = self.proc.wait()
                self._err.seek(0)
                self.status = f"exit {code}: {self._err.read().strip().splitlines()[-1:]}"
                break
            if line.startswith("{"):
                row = json.loads(line)
                if mark in row:
                    break
                rows.append(row)
        return rows

    def round(self) -> list:
        """Run every configuration once; the rows of these runs."""
        if self.status is not None:
            return []
        try:
            self.proc.stdin.write("round\n")
            self.proc.stdin.flush()
        except OSError:  # gone: _until reads its end
            pass
        return self._until("round_end")

    def close(self) -> list:
        """End the process: ``[]``, or one failure row (``status`` only) if it exited early or timed out."""
        if self.status is None:
            try:
                self.proc.stdin.close()
                self.proc.wait(timeout=60)
            except (OSError, subprocess.TimeoutExpired):
                self.proc.kill()
                self.proc.wait()
        self._err.close()
        return [] if self.status is None else [{"status": self.status}]


def flexmb_round(scene, n, configs, prep, failed: set, log=print) -> list:
    """One round of flexmb: every configuration ``(method, rtol)`` once (those in ``failed`` skipped)."""
    rows = []
    for method, rtol in configs:
        if (method, rtol) in failed:  # a failed run is not repeated
            continue
        row = wp.run_config(scene, n, method, rtol, prep)
        row["openblas_num_threads"] = os.environ.get("OPENBLAS_NUM_THREADS")
        rows.append(row)
        if row["status"] != "finished":
            failed.add((method, rtol))
            log(f"  flexmb {method:9s} rtol {rtol:7.0e}  {row['status']}")
        else:
            log(f"  flexmb {method:9s} rtol {rtol:7.0e}  wall {row['wall_s']:8.3f} s  error {row['error']:9.2e}")
    return rows


def timed_rounds(flexmb, peers: dict, repeat: int, log=print) -> dict:
    """Alternating rounds: per round ``flexmb()`` once, then ``peer.round()`` of each peer in turn.

    Parameters
    ----------
    flexmb : callable
        Runs every flexmb configuration once; returns the rows.
    peers : dict of str to Peer
        The peers by tool name, each with a ``round()``.
    repeat : int
        Number of rounds.

    Returns
    -------
    dict of str to list of dict
        Per tool (``"flexmb"`` and the peers' names), the merged rows: one
        per configuration, its least wall time over the rounds
        (:func:`rounds.merge_rounds`).
    """
    per = {tool: [] for tool in ("flexmb", *peers)}
    for r in range(repeat):
        log(f"-- round {r + 1} of {repeat}")
        per["flexmb"].append(flexmb())
        for tool, peer in peers.items():
            rows = peer.round()
            for row in rows:
                if row.get("wall_s") is not None:
                    h = f"h {row['h']:g}" if row.get("h") else f"rtol {row.get('rtol', 0):g}"
                    log(f"  {tool} {h}  wall {row['wall_s']:8.3f} s  error {_fmt(row.get('error'), '9.2e')}")
            per[tool].append(rows)
    return {tool: merge_rounds(rounds) for tool, rounds in per.items()}


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
    ap.add_argument("--repeat", type=int, default=3,
                    help="alternating rounds (every flexmb configuration, then each peer's, once per round); the "
                         "least wall time of the rounds is reported (the house rule asks for at least 3)")
    ap.add_argument("--ref-rtol", type=float, default=1e-9)
    ap.add_argument("--target", type=float, default=1e-6)
    ap.add_argument("--verify-steps", type=int, default=16000,
                    help="Exudyn steps S of the Richardson pair (S, 2S) checked against flexmb's reference")
    ap.add_argument("--out", default=RESULTS, help="folder of compare.jsonl, compare_agreement.json, summary.md")
    ap.add_argument("--summary-only", action="store_true",
                    help="rewrite summary.md from compare.jsonl and compare_agreement.json, running nothing")
    args = ap.parse_args(argv)
    if args.summary_only:
        with open(os.path.join(args.out, "compare.jsonl")) as fh:
            rows = [json.loads(line) for line in fh if line.strip()]
        agreement = {}
        path = os.path.join(args.out, "compare_agreement.json")
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
    env = peer_env()
    py = args.peers_python
    for name, ns in (("B1", args.b1), ("B2", args.b2)):
        sc = table[name]
        for n in ns:
            print(f"== {name} N = {n}")
            prep = wp.prepare(sc, n, args.integrators, args.ref_rtol)
            ref = prep["ref"]
            ref_out = [f"{v:.17g}" for v in np.asarray(ref["output"])]
            label = f"flexmb Radau rtol={args.ref_rtol:g} same N"
            common = ["--scene", name, "--n", n, "--reference", *ref_out, "--reference-label", label]
            peers = {}
            if "exudyn" in args.peers:
                ver = peer_rows(py, "exudyn_beam.py", ["--scene", name, "--n", n, "--richardson", args.verify_steps],
                                3600)
                if ver and "output" in ver[0]:
                    agreement[("exudyn", name, n)] = float(np.linalg.norm(np.asarray(ver[0]["output"])
                                                                          - np.asarray(ref["output"])))
                peers["exudyn"] = Peer([py, os.path.join(HERE, "exudyn_beam.py"), *common,
                                        "--steps", *args.exudyn_steps], 3600, env)
            if "mujoco" in args.peers:
                peers["mujoco"] = Peer([py, os.path.join(HERE, "mujoco_beam.py"), *common,
                                        "--steps", *args.mujoco_steps], 3600, env)
            if "pydy" in args.peers:
                if pydy_over.get(name):
                    rows.append(dict(wp._row(sc, n, tool="pydy"),
                                     status=f"skipped: setup at N = {pydy_over[name]} exceeded "
                                            f"{args.pydy_budget:g} s"))
                else:
                    peers["pydy"] = Peer([py, os.path.join(HERE, "pydy_beam.py"), *common,
                                          "--rtols", *args.pydy_rtols, "--budget", args.pydy_budget],
                                         3 * args.pydy_budget + 600, env)
            configs = [(m, rtol) for m in prep["methods"] for rtol in args.rtols]
            failed = set()
            try:
                merged = timed_rounds(lambda: flexmb_round(sc, n, configs, prep, failed), peers, args.repeat)
            finally:
                ends = {tool: peer.close() for tool, peer in peers.items()}
            rows += merged.pop("flexmb")
            for tool, out in merged.items():
                out = [dict(r, reference=label) if "tool" in r else dict(wp._row(sc, n, tool=tool), **r)
                       for r in out + ends[tool]]
                rows += out
                done = [r for r in out if r.get("error") is not None]
                if tool in ("mujoco", "pydy") and done:
                    agreement[(tool, name, n)] = min(r["error"] for r in done)
                if tool == "pydy" and (not done or any((r.get("setup_s") or 0) > args.pydy_budget for r in out)):
                    pydy_over[name] = n
            save(rows, agreement, args, started)  # after every scene and N: an interrupted run keeps its results
    print(save(rows, agreement, args, started))


def save(rows, agreement, args, started) -> str:
    """Write compare.jsonl and summary.md (atomically); returns the markdown."""
    from flexmb._files import atomic_write

    out = getattr(args, "out", RESULTS)
    os.makedirs(out, exist_ok=True)
    wp.write_jsonl(rows, os.path.join(out, "compare.jsonl"))
    with open(os.path.join(out, "compare_agreement.json"), "w") as fh:
        json.dump([{"tool": t, "scene": s, "n_segments": n, "agreement": v} for (t, s, n), v in agreement.items()],
                  fh, indent=1)
    md = summary(rows, agreement, args, started)

    def write(tmp):
        with open(tmp, "w") as fh:
            fh.write(md)

    atomic_write(os.path.join(out, "summary.md"), write)
    return md


def _fmt(x, spec=".3g"):
    return "—" if x is None else format(x, spec)


def timing_note(rows) -> str:
    """How the times were taken, read from the rows (rows from before the alternating rounds have no wall_rounds)."""
    timed = [r for r in rows if r.get("wall_s") is not None and r.get("error_kind", "integration") == "integration"]
    counts = [len(r["wall_rounds"]) for r in timed if "wall_rounds" in r]
    if not counts:
        return "Times are medians of back-to-back repeats per configuration (rows written before compare.py " \
               "timed in alternating rounds)"
    k = max(counts)
    note = (f"Times are the min of {k} alternating round{'s' if k != 1 else ''} (each round runs every flexmb "
            "configuration once, then each peer's; every round's time is in compare.jsonl, wall_rounds)")
    if k < 3:
        note += " - fewer than the 3 rounds the house rule asks of a ratio"
    if min(counts) < k:
        note += f"; some configurations have fewer rounds (down to {min(counts)})"
    if len(counts) < len(timed):
        note += "; rows without wall_rounds (an older run) are medians of back-to-back repeats"
    return note


def blas_note(rows) -> str:
    """OPENBLAS_NUM_THREADS as each tool's process saw it (recorded per row)."""
    seen = {}
    for r in rows:
        if "openblas_num_threads" in r and r.get("tool"):
            seen.setdefault(r["tool"], set()).add(r["openblas_num_threads"] or "unset")
    if not seen:
        return "OPENBLAS_NUM_THREADS not recorded (rows from before it was)"
    values = set().union(*seen.values())
    if len(values) == 1:
        return f"OPENBLAS_NUM_THREADS = {values.pop()} for " + " and ".join(seen)
    return "OPENBLAS_NUM_THREADS: " + "; ".join(f"{t} {', '.join(sorted(v))}" for t, v in seen.items())


def summary(rows, agreement, args, started) -> str:
    """The markdown summary: best time at the target error per tool, ratios flexmb/peer, checks."""
    target = args.target
    lines = [f"# flexmb and peers, side by side ({started}, one run of `benchmarks/peers/compare.py`)", "",
             f"Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
             f"shared with other jobs (load average at the end: "
             f"{', '.join(f'{v:.1f}' for v in os.getloadavg())}). {timing_note(rows)}; "
             f"{blas_note(rows)}. Absolute times are hints, ratios from this same run are the facts.", "",
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
