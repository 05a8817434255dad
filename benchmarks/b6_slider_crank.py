"""B6, the flexible slider-crank (BENCHMARKS.md): the default settings; generalized-alpha against tight references.

Default settings (``--auto``, issue 19): ``fm.simulate(system, 1.0,
positions=initial)`` on the undamped variant, timed (least CPU and wall
time of ``--repeat`` runs), then once more with ``track_work=True`` for the
energy balance; what ``method='auto'`` chose and why
(``Result.method_reason``: the spectral radius and step floor of the
generalized-alpha method, and the damping it adds to the rod's modes) goes
into the row. The damped variant over ``--damped-t-end`` with the default
settings: its crank torque against the tight reference. ``--rho-scan``
runs the undamped variant over 1 s with the generalized-alpha method
'auto' configures, for several spectral radii, and compares its crank
torque and mid-span deflection from 0.5 s on with the damped variant's
(CVODE_BDF at rtol 1e-10, cached): once the ringing is dissipated, both are
the forced response of the mechanism.

Undamped variant: 1 s with ``GeneralizedAlpha`` (spectral radius
``--rho``, error control resolving the motion below ``--f-max`` Hz),
reporting wall time, cost per right-hand side and per step, the energy
balance and the energy the integrator removed::

    numerical dissipation = driver work - (change of kinetic + elastic energy) - physical dissipation

(the physical dissipation is zero in the undamped variant, which has no
dampers; in the damped one it is the dampers' work, ``-(work of the segment
springs and dampers) - change of elastic energy``). The driver work is the
integrated ``track_work`` record, the energies are evaluated at the stored
states. With GeneralizedAlpha the works are integrated by the trapezoidal
rule on the step-end powers: the spring power of modes left unresolved is
aliased, which is why the undamped variant's physical dissipation is set to
zero rather than computed.

Damped variant: the crank torque over [0, ``--damped-t-end``] s (0.2 s:
the rod's vibration has died out by then; a 1 s reference at rtol 1e-9 or
1e-10 takes over half an hour of CPU with today's right-hand side) against
Radau at ``--ref-rtol`` (cached in ``results/b6_reference_damped_*.npz``,
checked against Radau at 10 x that tolerance), error = max |torque -
reference| / max |reference|, for generalized-alpha and, with
``--damped-integrators GeneralizedAlpha Radau``, for Radau.

Writes ``results/flexmb_B6.jsonl`` (BENCHMARKS.md fields plus the energy
terms). Run with one BLAS thread::

    OPENBLAS_NUM_THREADS=1 python benchmarks/b6_slider_crank.py --damped-integrators GeneralizedAlpha Radau
    OPENBLAS_NUM_THREADS=1 python benchmarks/b6_slider_crank.py --auto-short   # 'auto' for 0.02 s
    OPENBLAS_NUM_THREADS=1 python benchmarks/b6_slider_crank.py --auto         # the default settings, 1 s
    OPENBLAS_NUM_THREADS=1 python benchmarks/b6_slider_crank.py --rho-scan 0.4 0.5 0.6 0.7 0.8 0.9
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


def run(damped, method, rtol, t_end, n_out=1001):
    """One B6 run; returns (result, wall s, setup s, system, CPU s of the integration)."""
    t0 = time.perf_counter()
    model, initial = scenes.b6(damped=damped)
    system = model.build()
    setup = time.perf_counter() - t0
    t0, c0 = time.perf_counter(), time.process_time()
    res = fm.simulate(system, t_end, positions=initial, method=method, rtol=rtol, n_out=n_out,
                      track_work=True, progress=False)
    return res, time.perf_counter() - t0, setup, system, time.process_time() - c0


def energy_terms(res, damped=True):
    """Driver work, changes of kinetic and elastic energy, physical and numerical dissipation at t_end, J."""
    w_drv = res.work["driver motor"]
    springs = [v for k, v in res.work.items() if not k.startswith("driver ")]
    d_kin = res.kinetic - res.kinetic[0]
    d_el = res.potential - res.potential[0]  # no gravity: the potential is the rod's elastic energy
    phys = -sum(springs) - d_el if (springs and damped) else np.zeros_like(d_kin)
    num = w_drv - d_kin - d_el - phys
    return {"driver_work_J": float(w_drv[-1]), "delta_kinetic_J": float(d_kin[-1]),
            "delta_elastic_J": float(d_el[-1]), "physical_dissipation_J": float(phys[-1]),
            "numerical_dissipation_J": float(num[-1]),
            "max_abs_energy_balance_J": float(np.max(np.abs(num))),
            "initial_kinetic_J": float(res.kinetic[0])}


def outputs(res):
    """Slider position, crank torque and rod mid-span deflection at t_end."""
    return {"slider_m": float(res.coordinate("rail")[-1]), "torque_N_m": float(res.driver_effort("motor")[-1]),
            "midspan_deflection_m": float(scenes.b6_midspan_deflection(res)[-1])}


def row(res, wall, setup, system, cpu, variant, integrator, rtol, t_end, rho=None, f_max=None):
    """A BENCHMARKS.md row with B6's energy terms and costs."""
    r = {"tool": "flexmb", "scene": "B6", "variant": variant, "n_segments": 8, "n_coords": system.n_coords,
         "n_dof": res.n_dof, "integrator": integrator, "rtol": rtol, "h": None, "setup_s": setup, "wall_s": wall, "cpu_s": cpu,
         "steps": res.n_steps, "rhs_evals": res.n_rhs, "jac_evals": res.n_jac,
         "projections": res.n_projections, "cvode_projections": res.n_cvode_projections, "t_end": t_end, "status": res.status,
         "rho_inf": rho, "f_max_hz": f_max,
         "cpu_per_rhs_ms": 1e3 * cpu / max(res.n_rhs, 1), "cpu_per_step_ms": 1e3 * cpu / max(res.n_steps, 1),
         "load_avg_1min": os.getloadavg()[0]}
    r.update(energy_terms(res, variant == "damped"))
    r.update(outputs(res))
    return r


def reference(rtol, t_end, n_out):
    """Radau at ``rtol`` on the damped variant, cached as a Result file."""
    path = os.path.join(RESULTS, f"b6_reference_damped_{rtol:g}_{t_end:g}.npz")
    if os.path.exists(path):
        return fm.Result.load(path)
    res, wall, _, _, _ = run(True, "Radau", rtol, t_end, n_out)
    print(f"reference Radau rtol={rtol:g}: {wall:.1f} s, {res.n_steps} steps", flush=True)
    os.makedirs(RESULTS, exist_ok=True)
    res.save(path)
    return res


def torque_error(res, ref):
    """max |torque - reference| / max |reference| over the common output times."""
    tq, tr = res.driver_effort("motor"), ref.driver_effort("motor")
    return float(np.max(np.abs(tq - tr)) / np.max(np.abs(tr)))


def timed(system, t_end, initial, **kw):
    """One run of ``fm.simulate`` with its wall and CPU time."""
    w0, c0 = time.perf_counter(), time.process_time()
    res = fm.simulate(system, t_end, positions=initial, progress=False, **kw)
    return res, time.perf_counter() - w0, time.process_time() - c0


def damped_reference_1s(n_out=1001):
    """The damped variant over 1 s, CVODE_BDF at rtol 1e-10 (cached): the forced response to compare with."""
    path = os.path.join(RESULTS, "b6_damped_CVODE_BDF_1e-10_1.npz")
    if os.path.exists(path):
        return fm.Result.load(path)
    model, initial = scenes.b6(damped=True)
    res, wall, cpu = timed(model.build(), 1.0, initial, method="CVODE_BDF", rtol=1e-10, n_out=n_out)
    print(f"damped reference CVODE_BDF rtol=1e-10, 1 s: {cpu:.1f} s CPU, {res.n_steps} steps", flush=True)
    res.save(path)
    return res


def auto_rows(repeat, damped_t_end, ref_rtol):
    """The default settings on both variants (see the module docstring)."""
    import warnings

    rows = []
    model, initial = scenes.b6(damped=False)
    system = model.build()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        runs = [timed(system, 1.0, initial) for _ in range(repeat)]
        res, _, _ = timed(system, 1.0, initial, track_work=True, n_out=1001)
    first = runs[0][0]
    r = row(res, min(w for _, w, _ in runs), None, system, min(c for _, _, c in runs), "undamped", first.method,
            1e-8, 1.0)
    r.update(method_asked="auto (default settings)", method_reason=first.method_reason, repeats=repeat,
             wall_s_all=[w for _, w, _ in runs], cpu_s_all=[c for _, _, c in runs],
             steps=first.n_steps, rhs_evals=first.n_rhs, jac_evals=first.n_jac, projections=first.n_projections,
             cvode_projections=first.n_cvode_projections,
             rho_inf=_parameter(first.method, "rho_inf"), min_step_s=_parameter(first.method, "min_step"),
             warnings=[str(w.message) for w in caught],
             error=r["max_abs_energy_balance_J"],
             error_kind="energy balance (J): numerical dissipation, the model has none",
             reference="energy conservation", energy_run="track_work=True, n_out=1001 (not timed)")
    rows.append(r)
    n_out = int(round(damped_t_end * 1000)) + 1
    ref = reference(ref_rtol, damped_t_end, n_out)
    model, initial = scenes.b6(damped=True)
    system = model.build()
    runs = [timed(system, damped_t_end, initial, n_out=n_out) for _ in range(repeat)]
    res = runs[0][0]
    r = {"tool": "flexmb", "scene": "B6", "variant": "damped", "n_segments": 8, "n_coords": system.n_coords,
         "integrator": res.method, "method_asked": "auto (default settings)", "method_reason": res.method_reason,
         "rtol": 1e-8, "t_end": damped_t_end, "wall_s": min(w for _, w, _ in runs),
         "cpu_s": min(c for _, _, c in runs), "repeats": repeat, "steps": res.n_steps, "rhs_evals": res.n_rhs,
         "jac_evals": res.n_jac, "projections": res.n_projections, "cvode_projections": res.n_cvode_projections,
         "status": res.status,
         "error": torque_error(res, ref), "error_kind": "integration (crank torque, max relative)",
         "reference": f"flexmb Radau rtol={ref_rtol:g} same N", "load_avg_1min": os.getloadavg()[0]}
    rows.append(r)
    return rows


def _parameter(label, key):
    """A parameter ``key=value`` of a configured integrator's name, as a float (None if absent)."""
    for part in label.replace("(", ",").replace(")", ",").split(","):
        k, _, v = part.strip().partition("=")
        if k == key:
            return float(v)
    return None


def rho_scan_rows(rhos):
    """The undamped variant over 1 s with 'auto''s generalized-alpha configuration at several rho_inf."""
    from flexmb.integrators.monitor import ringing_modes

    ref = damped_reference_1s()
    model, initial = scenes.b6(damped=False)
    system = model.build()
    x, xd = fm.initial_state(system, 0.0, initial)
    modes = ringing_modes(system, 0.0, 1.0, x, xd, 1e-8, 1e-10)
    f_low = float(modes.frequency[modes.ringing()].min())
    late = ref.t >= 0.5
    rows = []
    for rho in rhos:
        method = fm.generalized_alpha(rho, f_max=0.5 * f_low, min_step=1.0 / (2 * np.pi * f_low))
        res, wall, cpu = timed(system, 1.0, initial, method=method, n_out=len(ref.t), track_work=True)
        r = row(res, wall, None, system, cpu, "undamped", "GeneralizedAlpha", 1e-8, 1.0, rho, 0.5 * f_low)
        terms = energy_terms(res, damped=False)
        num = res.work["driver motor"] - (res.kinetic - res.kinetic[0]) - (res.potential - res.potential[0])
        tq, tr = res.driver_effort("motor"), ref.driver_effort("motor")
        d, dr = scenes.b6_midspan_deflection(res), scenes.b6_midspan_deflection(ref)
        r.update(terms, method_asked="rho scan (auto's configuration)", min_step_s=1.0 / (2 * np.pi * f_low),
                 numerical_dissipation_at_0_1_s_J=float(num[np.searchsorted(res.t, 0.1)]),
                 late_torque_vs_damped=float(np.max(np.abs(tq - tr)[late]) / np.max(np.abs(tr))),
                 late_midspan_vs_damped_m=float(np.max(np.abs(d - dr)[late])),
                 comparison="t >= 0.5 s against the damped variant (CVODE_BDF rtol 1e-10): the forced response")
        rows.append(r)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--rho", nargs="+", type=float, default=[0.8])
    ap.add_argument("--f-max", nargs="+", type=float, default=[600.0])
    ap.add_argument("--rtols", nargs="+", type=float, default=[1e-3, 1e-4])
    ap.add_argument("--damped-rtols", nargs="+", type=float, default=[1e-5, 1e-6, 1e-7])
    ap.add_argument("--damped-t-end", type=float, default=0.2)
    ap.add_argument("--damped-integrators", nargs="+", default=["GeneralizedAlpha"],
                    help="GeneralizedAlpha (with each --rho) and/or scipy names such as Radau")
    ap.add_argument("--ref-rtol", type=float, default=1e-9)
    ap.add_argument("--n-out", type=int, default=1001)
    ap.add_argument("--skip", nargs="*", default=[], choices=["undamped", "damped"])
    ap.add_argument("--auto-short", action="store_true",
                    help="only run today's default (method='auto', rtol 1e-8) for 0.02 s, both variants")
    ap.add_argument("--auto", action="store_true", help="only the default settings on both variants (see above)")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs of --auto (least time kept)")
    ap.add_argument("--rho-scan", nargs="+", type=float, default=None,
                    help="only the undamped variant with 'auto''s configuration at these rho_inf")
    ap.add_argument("--out", default=os.path.join(RESULTS, "flexmb_B6.jsonl"))
    args = ap.parse_args(argv)
    rows = []

    def emit(r):
        rows.append(r)
        print(json.dumps(r), flush=True)
        with open(args.out, "a") as fh:
            fh.write(json.dumps(r) + "\n")

    if args.auto or args.rho_scan:
        if args.auto:
            for r in auto_rows(args.repeat, args.damped_t_end, args.ref_rtol):
                emit(r)
        if args.rho_scan:
            for r in rho_scan_rows(args.rho_scan):
                emit(r)
        return rows
    if args.auto_short:
        import warnings

        for damped in (False, True):
            variant = "damped" if damped else "undamped"
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                res, wall, setup, system, cpu = run(damped, "auto", 1e-8, 0.02, 21)
            r = row(res, wall, setup, system, cpu, variant, res.method, 1e-8, 0.02)
            r.update(method_asked="auto", warnings=[str(w.message) for w in caught], error=None, error_kind=None,
                     reference=None)
            emit(r)
        return rows
    if "undamped" not in args.skip:
        for rho in args.rho:
            for f_max in args.f_max:
                for rtol in args.rtols:
                    method = fm.generalized_alpha(rho, f_max=f_max if f_max > 0 else None)
                    res, wall, setup, system, cpu = run(False, method, rtol, args.t_end, args.n_out)
                    r = row(res, wall, setup, system, cpu, "undamped", "GeneralizedAlpha", rtol, args.t_end, rho,
                            f_max if f_max > 0 else None)
                    r["error"] = r["max_abs_energy_balance_J"]
                    r["error_kind"] = "energy balance (J): numerical dissipation, the model has none"
                    r["reference"] = "energy conservation"
                    emit(r)
    if "damped" not in args.skip:
        n_out = int(round(args.damped_t_end / args.t_end * (args.n_out - 1))) + 1
        ref = reference(args.ref_rtol, args.damped_t_end, n_out)
        check = reference(10 * args.ref_rtol, args.damped_t_end, n_out)
        unc = torque_error(check, ref)
        configs = [(name, rho) for name in args.damped_integrators
                   for rho in (args.rho if name == "GeneralizedAlpha" else [None])]
        for name, rho in configs:
            for rtol in args.damped_rtols:
                method = fm.generalized_alpha(rho) if name == "GeneralizedAlpha" else name
                res, wall, setup, system, cpu = run(True, method, rtol, args.damped_t_end, n_out)
                r = row(res, wall, setup, system, cpu, "damped", name, rtol, args.damped_t_end, rho, None)
                r.update(error=torque_error(res, ref), error_kind="integration (crank torque, max relative)",
                         reference=f"flexmb Radau rtol={args.ref_rtol:g} same N", ref_uncertainty=unc,
                         reference_energy=energy_terms(ref))
                emit(r)
    return rows


if __name__ == "__main__":
    main()
