"""A flexible cantilever striking a rigid stop (#30): convergence with N and with the tolerance, no tunnelling.

The B1 strip (aluminium, 1 m, 20 x 5 mm, 1 % damping in its first mode),
clamped level and released straight under gravity, falls onto a stop
20 mm below its tip: a sphere of 5 mm on the tip against a rigid plane
(``SpherePlaneContact``), Hunt-Crossley law ``K delta^1.5 (1 + alpha
delta_dot)`` with K = 1e8 N/m^1.5 and alpha = 0.5 s/m (a hard pad on the
stop). The tip bounces on the stop a few times over 0.5 s.

Outputs, at 2001 times over [0, 0.5] s: the tip's height and the contact's
normal force. The error of a run is the largest difference from a
reference over those times (tip height in m, force relative to the
reference's peak force):

* ``--sweep n``: N = 8, 16, 32, 64 (and ``--n-ref``, 128) at a tight rtol,
  against the largest N: the discretisation error;
* ``--sweep rtol``: N = 64 at rtol 1e-3 ... 1e-8, against rtol 1e-10: the
  integration error and the cost (work-precision);
* every run reports its contact events (onsets, separations, the first
  touch's time and speed), the steps refused for carrying the tip through
  the pad, the largest penetration, and whether it tunnelled: the
  penetration exceeding the sphere's radius at an output, or the tip below
  the stop's far side, or fewer onsets than separations (a touch missed).

The runs locate the contact's onsets and separations as events (the
default of ``simulate``, ``flexmb.contact_events``: the integrator restarts
at each touch, and a step through the pad is refused). With ``max_step`` =
``--max-step`` (default 1e-4 s: about a third of the contact time ``3
delta_max / v_in``, 3.3e-4 s here with delta_max = 57 um at v_in = 0.53
m/s) the steps resolve each impact's force history; ``--no-max-step``
runs the tolerance sweep without the bound, where the events alone keep
the steps from crossing a touch: what the bound costs and what it buys.

Run::

    OPENBLAS_NUM_THREADS=1 python benchmarks/contact_stop.py --sweep n rtol
    OPENBLAS_NUM_THREADS=1 python benchmarks/contact_stop.py --sweep rtol --no-max-step

One JSON line per run in ``results/contact_stop.jsonl``.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

import flexmb as fm
from scenes import B1_B, B1_H, B1_L, b1

HERE = os.path.dirname(os.path.abspath(__file__))
GAP, RADIUS = 0.02, 0.005
K_PAD, ALPHA_PAD = 1e8, 0.5
T_END = 0.5
T_OUT = np.linspace(0.0, T_END, 2001)


def model(n: int) -> fm.Model:
    """B1 with N segments, damped, under gravity, and the stop under its tip."""
    m = b1(n)
    beam = m.element("beam")
    # the sphere's centre on the tip's lower face; the stop's face GAP below the sphere
    m.add(fm.SpherePlaneContact("stop", beam, RADIUS, fm.HuntCrossleyLaw(K_PAD, ALPHA_PAD),
                                centre=(B1_L, 0.0, -B1_H / 2 + RADIUS),
                                plane_point=(B1_L, 0.0, -B1_H / 2 - GAP)))
    return m


def run(n: int, rtol: float, max_step: float | None):
    system = model(n).build()
    t0 = time.perf_counter()
    cpu0 = time.process_time()
    res = fm.simulate(system, T_END, t_eval=T_OUT, method="CVODE_BDF", rtol=rtol, atol=rtol * 1e-3,
                      max_step=np.inf if max_step is None else max_step, progress=False)
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    tip = res.shape("beam")[:, -1, 2]
    h = res.contact_history("stop")
    return res, tip, h, wall, cpu


def row(n, rtol, max_step, res, tip, h, wall, cpu, ref=None, kind=""):
    onsets = [e for e in res.contact_events if e[2] == "onset"]
    out = {"scene": "cantilever on a stop", "date": time.strftime("%Y-%m-%d"), "contact_events": True, "n_segments": n, "integrator": "CVODE_BDF", "rtol": rtol,
           "max_step": max_step, "status": res.status, "wall_s": wall, "cpu_s": cpu, "steps": res.n_steps,
           "rhs_evals": res.n_rhs, "jacobians": res.n_jac, "peak_force_n": float(h.normal_force.max()),
           "max_penetration_m": float(h.penetration.max()), "onsets": len(onsets),
           "separations": res.n_contact_separations, "refused_steps": res.n_refused,
           "tunnelled": bool(h.penetration.max() > RADIUS or tip.min() < -B1_H / 2 - GAP - RADIUS
                             or res.n_contact_separations > len(onsets)),
           "first_touch_s": onsets[0][0] if onsets else None, "impact_speed_m_s": onsets[0][3] if onsets else None,
           "tip_min_m": float(tip.min())}
    if ref is not None:
        tip_r, f_r = ref
        out.update({"error_kind": kind, "tip_error_m": float(np.abs(tip - tip_r).max()),
                    "force_error_rel": float(np.abs(h.normal_force - f_r).max() / f_r.max())})
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sweep", nargs="+", choices=("n", "rtol"), default=["n", "rtol"])
    p.add_argument("--ns", nargs="+", type=int, default=[8, 16, 32, 64])
    p.add_argument("--n-ref", type=int, default=128)
    p.add_argument("--rtols", nargs="+", type=float, default=[1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8])
    p.add_argument("--rtol-ref", type=float, default=1e-10)
    p.add_argument("--rtol-n", type=float, default=1e-8, help="rtol of the N sweep")
    p.add_argument("--max-step", type=float, default=1e-4)
    p.add_argument("--no-max-step", action="store_true", help="the rtol sweep without the step bound")
    p.add_argument("--out", default=os.path.join(HERE, "results", "contact_stop.jsonl"))
    a = p.parse_args()
    max_step = None if a.no_max_step else a.max_step
    rows = []
    if "n" in a.sweep:
        res, tip, h, wall, cpu = run(a.n_ref, a.rtol_n, a.max_step)
        ref = (tip, h.normal_force)
        rows.append(row(a.n_ref, a.rtol_n, a.max_step, res, tip, h, wall, cpu))
        print(f"N sweep, rtol {a.rtol_n:g}, against N = {a.n_ref}")
        for n in a.ns:
            rows.append(row(n, a.rtol_n, a.max_step, *run(n, a.rtol_n, a.max_step), ref=ref,
                            kind=f"discretisation (N = {a.n_ref})"))
            r = rows[-1]
            print(f"  N {n:4d}: tip error {r['tip_error_m']:.3e} m, force error {r['force_error_rel']:.3e}, "
                  f"peak {r['peak_force_n']:.4g} N, max pen {r['max_penetration_m']:.3e} m, "
                  f"onsets {r['onsets']}, steps {r['steps']}, cpu {r['cpu_s']:.2f} s")
    if "rtol" in a.sweep:
        res, tip, h, wall, cpu = run(64, a.rtol_ref, a.max_step)
        ref = (tip, h.normal_force)
        rows.append(row(64, a.rtol_ref, a.max_step, res, tip, h, wall, cpu))
        print(f"rtol sweep, N = 64, max_step {max_step}, against rtol {a.rtol_ref:g} (with max_step {a.max_step})")
        for rtol in a.rtols:
            rows.append(row(64, rtol, max_step, *run(64, rtol, max_step), ref=ref,
                            kind=f"integration (rtol {a.rtol_ref:g})"))
            r = rows[-1]
            print(f"  rtol {rtol:.0e}: tip error {r['tip_error_m']:.3e} m, force error {r['force_error_rel']:.3e}, "
                  f"max pen {r['max_penetration_m']:.3e} m, tunnelled {r['tunnelled']}, onsets {r['onsets']}, "
                  f"refused {r['refused_steps']}, steps {r['steps']}, cpu {r['cpu_s']:.2f} s")
    with open(a.out, "a") as f:
        for r in rows:
            f.write(json.dumps(r) + "\n")


if __name__ == "__main__":
    main()
