"""What simulate()'s default tolerances cost and how accurate they are, scene by scene (issue 28).

    OPENBLAS_NUM_THREADS=1 python benchmarks/default_tolerances.py
    OPENBLAS_NUM_THREADS=1 python benchmarks/default_tolerances.py --scenes B7-40 --settings defaults

Every scene runs under ``method='auto'`` with each of ``--settings``:
``defaults`` (no rtol or atol given: whatever ``simulate()`` does by
default) or an explicit ``rtol`` (``atol = rtol / 100``), so that candidate
defaults are measured beside today's. For each scene and setting the row
has the integrator 'auto' took, the exact counts (steps, right-hand sides,
Jacobians), the least CPU time (``time.process_time``) of ``--repeat``
runs taken in alternation with the other settings in one process, and the
error against a tight reference: the largest distance, over the output
times, of the scene's output from the reference's.

References: B7 against the chain's own one-degree-of-freedom equation
(``scenes.b7_closed_form``, scipy's DOP853 at rtol 1e-13, independent of
flexmb); every other scene against flexmb's own run of the same model at
``REF_RTOL`` (CVODE_BDF where 'auto' takes an implicit method, DOP853
where it takes DOP853), whose own uncertainty is its distance from the run
at ten times ``REF_RTOL`` (``ref_uncertainty``). Rows go to
``benchmarks/results/default_tolerances.jsonl``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import flexmb as fm  # noqa: E402
import scenes  # noqa: E402

RESULTS = os.path.join(HERE, "results")
REF_RTOL = 1e-12


def _b1(n):
    return lambda: (scenes.b1(n).build(), {}, 1.0, lambda r: r.shape("beam")[:, -1], "beam tip position, m")


def _b2(n):
    return lambda: (scenes.b2(n).build(), {}, 1.0, lambda r: r.body_position("tip"), "tip mass position, m")


def _b6(n):
    def build():
        model, initial = scenes.b6(damped=True, n_segments=n)
        system = model.build()
        rail = system.coordinate_names.index("rail.slide")
        return (system, {"positions": initial}, 0.5,
                lambda r: np.column_stack([r.x[:, rail], scenes.b6_midspan_deflection(r)]),
                "slider position and rod mid-span deflection, m")
    return build


def _b7(n, t_end):
    def build():
        model, initial = scenes.b7(n)
        return model.build(), initial, t_end, lambda r: scenes.b7_tip(r)[:, :2], "first rod's top, m"
    return build


def _fourbar():
    from flexmb.scenes.fourbar import fourbar

    model, initial, fixed = fourbar()
    system = model.build()
    return (system, {"positions": initial, "fixed": fixed}, 5.0,
            lambda r: r.x[:, [system.coordinate_names.index("A.angle")]] * 0.1, "crank tip arc (0.1 m x angle), m")


def _wiper_rigid():
    from flexmb.scenes.wiper import WiperOptions, wiper

    model, initial = wiper(WiperOptions(flexible=False))
    system = model.build()
    k = system.body_names.index("right_blade")
    return (system, {"positions": initial}, 1.0,
            lambda r: r.origins[:, k] + r.rotations[:, k, :, 0] * 0.25, "right blade tip, m")


def _pendulum():
    model = fm.Model("pendulum")
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0.0, -9.81, 0.0)))
    return (model.build(), {"speeds": {"pin": 10.0}}, 10.0, lambda r: np.column_stack([np.cos(r.x[:, 0]),
                                                                                        np.sin(r.x[:, 0])]),
            "bar tip (1 m), m")


#: name -> builder returning (system, simulate keywords, t_end, output(result) -> (nt, k), output description)
SCENES = {
    "B1-8": _b1(8), "B1-64": _b1(64), "B2-16": _b2(16), "B6d-8": _b6(8),
    "B7-40": _b7(40, 20.0), "B5-fourbar": _fourbar, "B4-rigid": _wiper_rigid, "pendulum": _pendulum,
}


def _options(setting: str) -> dict:
    return {} if setting == "defaults" else {"rtol": float(setting), "atol": float(setting) / 100}


def _run(system, kw, t_end, setting, **extra):
    c0 = time.process_time()
    res = fm.simulate(system, t_end, progress=False, **kw, **_options(setting), **extra)
    return res, time.process_time() - c0


def _distance(a, b) -> float:
    return float(np.max(np.linalg.norm(np.asarray(a) - np.asarray(b), axis=1)))


def reference(name, system, kw, t_end, output, method):
    """The scene's tight output history and its uncertainty (B7: the closed form, uncertainty None)."""
    t = np.linspace(0.0, t_end, 201)
    if name.startswith("B7"):
        return scenes.b7_closed_form(t, int(name.split("-")[1])), None, "one-degree-of-freedom equation, DOP853 1e-13"
    method = "DOP853" if method == "DOP853" else "CVODE_BDF"
    runs = [fm.simulate(system, t_end, progress=False, method=method, rtol=r, atol=r / 100, **kw)
            for r in (REF_RTOL, 10 * REF_RTOL)]
    return output(runs[0]), _distance(output(runs[0]), output(runs[1])), f"flexmb {method} rtol {REF_RTOL:g}"


def measure(name, settings, repeat):
    """Rows of one scene: every setting, alternating, least CPU of ``repeat`` runs."""
    system, kw, t_end, output, what = SCENES[name]()
    first = {s: _run(system, kw, t_end, s) for s in settings}  # also warms the kernels
    cpu = {s: [first[s][1]] for s in settings}
    for _ in range(repeat - 1):
        for s in settings:
            cpu[s].append(_run(system, kw, t_end, s)[1])
    ref, unc, ref_name = reference(name, system, kw, t_end, output, first[settings[0]][0].method)
    rows = []
    for s in settings:
        res = first[s][0]
        rows.append({"scene": name, "t_end": t_end, "setting": s, "method": str(res.method),
                     "rtol": res.rtol if hasattr(res, "rtol") else None, "status": res.status,
                     "steps": int(res.n_steps), "rhs": int(res.n_rhs), "jac": int(res.n_jac),
                     "cpu_s": min(cpu[s]), "repeats": repeat, "error_m": _distance(output(res), ref),
                     "output": what, "reference": ref_name, "ref_uncertainty": unc})
    return rows


def main(argv=None):
    """Measure the scenes and write benchmarks/results/default_tolerances.jsonl (or ``--out``)."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    p.add_argument("--settings", nargs="+", default=["defaults", "1e-8", "1e-9", "5e-10"])
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--out", default=os.path.join(RESULTS, "default_tolerances.jsonl"))
    args = p.parse_args(argv)
    rows = []
    for name in args.scenes:
        for row in measure(name, args.settings, args.repeat):
            print(json.dumps(row), flush=True)
            rows.append(row)
    with open(args.out + ".tmp", "w") as fh:
        fh.writelines(json.dumps(r) + "\n" for r in rows)
    os.replace(args.out + ".tmp", args.out)


if __name__ == "__main__":
    main()
