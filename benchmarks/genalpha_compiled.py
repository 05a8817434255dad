"""CPU of generalized-alpha stepped in compiled code against the Python step, in one process (issue 31).

    OPENBLAS_NUM_THREADS=1 python benchmarks/genalpha_compiled.py --rounds 3 --label after

Runs B1 (N = 8, 16, 64) and B2 (N = 16, 32) over ``--t-end`` s with 101
outputs, ``method="GeneralizedAlpha"``, at its default tolerance and at the
rtols of ``benchmarks/genalpha_counts.py`` (3e-4, 1e-4, 3e-5; atol = rtol /
100), each run twice per round: stepped in compiled code
(:mod:`flexmb.genalpha.compiled`, "after") and by the Python step of
:class:`~flexmb.genalpha.GeneralizedAlpha` (the compiled loop switched off
as for the models it does not serve, "before"), alternating, the least CPU
time (``time.process_time``) of the rounds kept. GA solves by Krylov from
64 speeds (B1 N = 64, B2 N = 32: Python in both columns); ``--dense`` adds
those sizes with the dense iteration matrix forced (a subclass with a
higher ``krylov_min_coords``). Also the CPU of ``Run.execute`` alone (the
step loop and the outputs; without simulate's set-up and the Result's
evaluation, which both paths share). Counts (steps, right-hand sides, Jacobians)
are checked identical and the states equal between the two. Appends to
``benchmarks/results/genalpha_compiled.jsonl``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

if __name__ == "__main__":
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import numpy as np  # noqa: E402

import scenes  # noqa: E402

import flexmb as fm  # noqa: E402
from flexmb import stepping  # noqa: E402
from flexmb.genalpha import GeneralizedAlpha, compiled  # noqa: E402

#: GeneralizedAlpha with the dense iteration matrix at every size
DenseGA = type("DenseGA", (GeneralizedAlpha,), {"krylov_min_coords": 10**6, "__module__": __name__})
_CHOOSE = compiled.compiled_genalpha
#: CPU spent in Run.execute (the step loop and the outputs, without simulate's set-up and the Result's evaluation)
_EXECUTE = [0.0]
_execute = stepping.Run.execute


def _timed_execute(self, x, xd):
    c0 = time.process_time()
    try:
        return _execute(self, x, xd)
    finally:
        _EXECUTE[0] += time.process_time() - c0


stepping.Run.execute = _timed_execute


def _run(system, t_end, method, rtol, python_step):
    compiled.compiled_genalpha = (lambda *args: None) if python_step else _CHOOSE
    try:
        kw = dict(method=method, n_out=101, progress=False)
        if rtol is not None:
            kw.update(rtol=rtol, atol=rtol / 100)
        c0, _EXECUTE[0] = time.process_time(), 0.0
        res = fm.simulate(system, t_end, **kw)
        return time.process_time() - c0, _EXECUTE[0], res
    finally:
        compiled.compiled_genalpha = _CHOOSE


def case(scene, n, rtol, dense, t_end, rounds):
    """One case: least CPU of each path over ``rounds`` alternating rounds, the counts, the states' difference."""
    system = (scenes.b1 if scene == "B1" else scenes.b2)(n).build()
    method = DenseGA if dense else "GeneralizedAlpha"
    for python_step in (False, True):  # kernels loaded, the first-use costs paid
        _run(system, min(t_end, 0.01), method, rtol, python_step)
    best = {True: np.inf, False: np.inf}
    loop = {True: np.inf, False: np.inf}
    out = {}
    for _ in range(rounds):
        for python_step in (True, False):
            cpu, cpu_loop, res = _run(system, t_end, method, rtol, python_step)
            best[python_step] = min(best[python_step], cpu)
            loop[python_step] = min(loop[python_step], cpu_loop)
            out[python_step] = res
    old, new = out[True], out[False]
    counts = [(r.n_steps, r.n_rhs, r.n_jac) for r in (old, new)]
    if counts[0] != counts[1] or old.status != "finished" or new.status != "finished":
        raise AssertionError(f"{scene} N = {n} rtol {rtol}: {counts}, {old.status}, {new.status}")
    diff = float(max(np.max(np.abs(new.x - old.x)), np.max(np.abs(new.xd - old.xd))))
    return {"scene": scene, "n_segments": n, "n_speeds": system.n_speeds, "t_end": t_end, "n_out": 101,
            "rtol": rtol or "default", "matrix": "dense" if dense or system.n_speeds < 64 else "krylov",
            "steps": new.n_steps, "rhs_evals": new.n_rhs, "jac_evals": new.n_jac, "max_state_diff": diff,
            "cpu_python_step_s": best[True], "cpu_compiled_s": best[False], "ratio": best[False] / best[True],
            "cpu_loop_python_step_s": loop[True], "cpu_loop_compiled_s": loop[False],
            "loop_ratio": loop[False] / loop[True],
            "rounds": rounds, "started": time.strftime("%Y-%m-%d %H:%M:%S")}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="+", default=["B1:8", "B1:16", "B1:64", "B2:16", "B2:32"])
    ap.add_argument("--rtol", type=float, nargs="+", default=[0.0, 3e-4, 1e-4, 3e-5], help="0: GA's default")
    ap.add_argument("--dense", action="store_true", help="also the Krylov sizes with the dense matrix forced")
    ap.add_argument("--t-end", type=float, default=0.5)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--label", default="")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "genalpha_compiled.jsonl"))
    args = ap.parse_args(argv)
    for spec in args.cases:
        scene, n = spec.split(":")
        n_speeds = (1 if scene == "B1" else 3) * int(n)
        for dense in (False, True) if args.dense and n_speeds >= 64 else (False,):
            for rtol in args.rtol:
                row = dict(case(scene, int(n), rtol or None, dense, args.t_end, args.rounds), label=args.label)
                print(f"{scene} N = {n:>3} {row['matrix']:6} rtol {row['rtol']!s:8}: {row['steps']} steps, "
                      f"{row['rhs_evals']} rhs, {row['jac_evals']} Jacobians; CPU Python step "
                      f"{row['cpu_python_step_s']:.4f} s, compiled {row['cpu_compiled_s']:.4f} s, ratio "
                      f"{row['ratio']:.3f}; Run.execute {row['cpu_loop_python_step_s']:.4f} / "
                      f"{row['cpu_loop_compiled_s']:.4f} s, ratio {row['loop_ratio']:.3f} (states differ by "
                      f"{row['max_state_diff']:.1e})", flush=True)
                with open(args.out, "a") as fh:
                    fh.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
