"""Winding angles and the error control: runs with and without the offsets of flexmb.stepping, against closed forms.

    OPENBLAS_NUM_THREADS=1 python benchmarks/winding.py --scene pendulum --t-end 10 30 90
    OPENBLAS_NUM_THREADS=1 python benchmarks/winding.py --scene B7 --n 40 --t-end 20 \\
        --complement svd articulated --method auto CVODE_BDF

Each run is made twice in the same process: as simulate() runs it (the
integrator holds ``y - c``, the angles' offsets ``c`` moving by whole turns,
``flexmb.stepping``) and with the offsets disabled
(``stepping.WINDING_BOUND = inf``: the integrator holds ``y`` itself and
weighs an angle's error by ``rtol |angle| + atol``, as before the offsets).
The pendulum is a 1 m, 1 kg slender bar on a pin under gravity, thrown at
10 rad/s from hanging along +x, so that it goes over the top (about 1.3
turns a second); its reference is its own equation
``theta'' = -(3 g / 2 L) cos(theta)`` by scipy's DOP853 at rtol 1e-13, and
its row has the error of the end angle, optionally after starting
``--turns`` whole turns on (the same motion). B7 runs with
``simulate()``'s defaults but the complement and method given; its row has
the largest distance over the output times of the first rod's top from the
chain's one-degree-of-freedom equation (``scenes.b7_closed_form``). Rows
(JSON lines) give the error, steps, right-hand sides, projections, moves of
the offsets (``n_rebases``) and the wall time of ``simulate``.
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

PENDULUM_W0 = 10.0
G = 9.81


def _pendulum_reference(t_end):
    from scipy.integrate import solve_ivp

    sol = solve_ivp(lambda t, y: [y[1], -1.5 * G * np.cos(y[0])], (0.0, t_end), [0.0, PENDULUM_W0],
                    method="DOP853", rtol=1e-13, atol=1e-14)
    return sol.y[0, -1]


def pendulum_row(method: str, t_end: float, turns: int, offsets: bool, rtol: float | None) -> dict:
    """One pendulum run: the end angle's error against the bar's own equation."""
    import flexmb as fm

    model = fm.Model("pendulum")
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0.0, -G, 0.0)))
    options = {} if rtol is None else {"rtol": rtol}
    res = fm.simulate(model, t_end, positions={"pin": 2 * np.pi * turns}, speeds={"pin": PENDULUM_W0},
                      method=method, n_out=11, progress=False, **options)
    return {"scene": "pendulum", "method": method, "t_end": t_end, "turns": turns, "offsets": offsets,
            "rtol": rtol, "status": res.status, "end_angle_rad": float(res.x[-1, 0]),
            "error_rad": float(abs(res.x[-1, 0] - 2 * np.pi * turns - _pendulum_reference(t_end))),
            "n_steps": int(res.n_steps), "n_rhs": int(res.n_rhs), "n_rebases": int(res.n_rebases),
            "wall_s": res.wall_time}


def b7_row(n: int, t_end: float, complement: str, method: str, offsets: bool, rtol: float | None) -> dict:
    """One B7 run: the first rod's top against the closed form."""
    import flexmb as fm
    import scenes

    model, initial = scenes.b7(n)
    options = {} if rtol is None else {"rtol": rtol}
    t0 = time.perf_counter()
    try:
        res = fm.simulate(model, t_end, **initial, complement=complement, method=method, progress=False, **options)
        message = res.message
    except fm.SimulationError as exc:  # the outputs up to the failure
        res, message = exc.result, str(exc)
    wall = time.perf_counter() - t0
    err = np.linalg.norm(scenes.b7_tip(res)[:, :2] - scenes.b7_closed_form(res.t, n), axis=1)
    return {"scene": "B7", "n_segments": n, "t_end": t_end, "complement": complement, "method": res.method,
            "asked": method, "offsets": offsets, "rtol": rtol, "status": res.status, "message": message,
            "t_reached": float(res.t[-1]), "error_closed_form_m": float(err.max()),
            "n_steps": int(res.n_steps), "n_rhs": int(res.n_rhs), "n_projections": int(res.n_projections),
            "n_rebases": int(res.n_rebases), "wall_s": wall, "load_avg_1min": os.getloadavg()[0]}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", choices=["pendulum", "B7"], default="pendulum")
    p.add_argument("--t-end", type=float, nargs="+", default=[10.0])
    p.add_argument("--n", type=int, nargs="+", default=[40], help="B7's loops")
    p.add_argument("--complement", nargs="+", default=["svd"], help="B7's complement strategies")
    p.add_argument("--method", nargs="+", default=None,
                   help="integrators (default: B7 'auto'; the pendulum every one simulate offers)")
    p.add_argument("--turns", type=int, nargs="+", default=[0], help="pendulum: whole turns added at the start")
    p.add_argument("--rtol", type=float, default=None)
    a = p.parse_args(argv)
    from flexmb import stepping

    bound = stepping.WINDING_BOUND
    for offsets in (True, False):
        stepping.WINDING_BOUND = bound if offsets else np.inf
        if a.scene == "pendulum":
            methods = a.method or ["DOP853", "RK45", "Radau", "BDF", "LSODA", "CVODE_BDF", "CVODE_Adams", "IDA",
                                   "GeneralizedAlpha"]
            for t_end in a.t_end:
                for method in methods:
                    for turns in a.turns:
                        print(json.dumps(pendulum_row(method, t_end, turns, offsets, a.rtol)), flush=True)
        else:
            for n in a.n:
                for t_end in a.t_end:
                    for complement in a.complement:
                        for method in a.method or ["auto"]:
                            print(json.dumps(b7_row(n, t_end, complement, method, offsets, a.rtol)), flush=True)
    stepping.WINDING_BOUND = bound


if __name__ == "__main__":
    main()
