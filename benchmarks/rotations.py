"""Rotations without gimbal lock: flexmb's Euler parameters against a hand-written quaternion model (#29).

    OPENBLAS_NUM_THREADS=1 python benchmarks/rotations.py --scene top --t-end 5 --rtol 1e-8
    OPENBLAS_NUM_THREADS=1 python benchmarks/rotations.py --scene tumbling --periods 1000 --rtol 1e-8
    OPENBLAS_NUM_THREADS=1 python benchmarks/rotations.py --scene tumbling --periods 1000 --rtol 1e-6 --method GeneralizedAlpha

Two scenes, each run by flexmb (``Spherical``/``Free`` with
``rotation='quaternion'``, ``simulate(method='DOP853')``) and by the hand
model written here (the rigid body's Euler equations in body axes and
``qd = 1/2 q * (w, 0)``, by scipy's ``solve_ivp`` with the same method and
tolerances; :func:`hand_model`; ``--method`` runs flexmb with another
integrator, e.g. ``GeneralizedAlpha``, against the same DOP853 hand run):

* ``top``: a heavy top on a fixed point (1 kg, mass centre 0.1 m up its
  axis, central inertia diag(0.02, 0.02, 0.01) kg m^2, gravity 9.81 m/s^2)
  started at ``--tilt`` (default 100 deg, beyond the horizontal) in the
  x-z plane, spinning at ``--spin`` (default 40 rad/s) about its axis;
  with ``--bryant`` flexmb's Bryant-angle joint runs too, for comparison
  (its angles are singular where the axis passes the inertial x axis, ry =
  90 deg: ``--tilt 80 --spin 10`` nutates through the horizontal close by
  it);
* ``tumbling``: a torque-free asymmetric body (1 kg, inertia diag(1, 2, 3)
  kg m^2) on a Free joint, started at w = (0.05, 1, 0.05) rad/s in body
  axes: near the intermediate axis, so that it tumbles (flips about once
  per rotation period), run over ``--periods`` periods ``2 pi / |w0|``.

Each row (JSON, one per line, to stdout and ``--out``): the steps and
right-hand sides, the wall and CPU times (``process_time``; flexmb's also
as a ratio to the hand model's; after one short run of each flexmb model,
which loads the compiled kernels), the largest drift of the energy
(relative) and of the angular momentum (relative; the top: its vertical
component and the spin component along the axis, both conserved), and
the largest distance of flexmb's rotation matrices from the hand model's
at the output times.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

G = 9.81
TOP_MASS, TOP_COM, TOP_INERTIA, TOP_SPIN = 1.0, np.array([0.0, 0.0, 0.1]), np.diag([0.02, 0.02, 0.01]), 40.0
BODY_MASS, BODY_INERTIA, BODY_W0 = 1.0, np.diag([1.0, 2.0, 3.0]), np.array([0.05, 1.0, 0.05])


def _quat_rates(q, w):
    """``1/2 q * (w, 0)``, scalar last (written out here: the hand model shares no code with flexmb)."""
    v, s = q[:3], q[3]
    return 0.5 * np.array([s * w[0] + v[1] * w[2] - v[2] * w[1], s * w[1] + v[2] * w[0] - v[0] * w[2],
                           s * w[2] + v[0] * w[1] - v[1] * w[0], -v @ w])


def _matrix(q):
    x, y, z, s = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - s * z), 2 * (x * z + s * y)],
                     [2 * (x * y + s * z), 1 - 2 * (x * x + z * z), 2 * (y * z - s * x)],
                     [2 * (x * z - s * y), 2 * (y * z + s * x), 1 - 2 * (x * x + y * y)]])


def hand_model(scene: str):
    """``(rhs, inertia about the fixed point or the mass centre)`` of the hand quaternion model of a scene."""
    if scene == "top":
        J = TOP_INERTIA + TOP_MASS * (TOP_COM @ TOP_COM * np.eye(3) - np.outer(TOP_COM, TOP_COM))
        weight = np.array([0.0, 0.0, -TOP_MASS * G])
    else:
        J, weight = BODY_INERTIA, None
    Jinv = np.linalg.inv(J)

    def rhs(t, y):
        q, w = y[:4], y[4:]
        torque = np.zeros(3) if weight is None else np.cross(TOP_COM, _matrix(q).T @ weight)
        return np.concatenate([_quat_rates(q, w), Jinv @ (torque - np.cross(w, J @ w))])

    return rhs, J


def initial_state(scene: str, tilt_deg: float, spin: float = TOP_SPIN):
    """``(q0, w0)``: the top tilted about y by ``tilt_deg`` and spinning at ``spin``; the body at ``BODY_W0``."""
    if scene == "top":
        a = np.radians(tilt_deg)
        return np.array([0.0, np.sin(a / 2), 0.0, np.cos(a / 2)]), np.array([0.0, 0.0, spin])
    return np.array([0.0, 0.0, 0.0, 1.0]), BODY_W0.copy()


def flexmb_model(scene: str, rotation: str = "quaternion"):
    """The scene as a flexmb model."""
    import flexmb as fm

    model = fm.Model(scene)
    if scene == "top":
        top = fm.RigidBody("body", TOP_MASS, TOP_INERTIA, com=tuple(TOP_COM))
        model.add(fm.Spherical("pivot", model.ground, top, rotation=rotation), fm.Gravity((0.0, 0.0, -G)))
    else:
        body = fm.RigidBody("body", BODY_MASS, BODY_INERTIA)
        model.add(fm.Free("float", model.ground, body, rotation=rotation))
    return model


def _flexmb_initial(scene, rotation, q0, w0):
    """``positions, speeds`` for simulate: the Euler parameters and w, or the Bryant angles and their rates."""
    from flexmb.quaternions import bryant_angles

    joint = "pivot" if scene == "top" else "float"
    if rotation == "quaternion":
        return ({f"{joint}.q{c}": q0[i] for i, c in enumerate("xyzw")},
                {f"{joint}.w{c}": w0[i] for i, c in enumerate("xyz")})
    angles = bryant_angles(_matrix(q0))
    rx, ry, rz = angles
    # the Bryant rates of a body angular velocity w: w = E(angles) rates
    E = np.array([[np.cos(ry) * np.cos(rz), np.sin(rz), 0.0], [-np.cos(ry) * np.sin(rz), np.cos(rz), 0.0],
                  [np.sin(ry), 0.0, 1.0]])
    rates = np.linalg.solve(E, w0)
    return ({f"{joint}.r{c}": angles[i] for i, c in enumerate("xyz")},
            {f"{joint}.r{c}": rates[i] for i, c in enumerate("xyz")})


def _drifts(scene, R, w, J):
    """Largest relative drift of the energy and of the conserved angular momentum over the outputs."""
    if scene == "top":
        com = np.einsum("tij,j->ti", R, TOP_COM)
        energy = 0.5 * np.einsum("ti,ij,tj->t", w, J, w) + TOP_MASS * G * com[:, 2]
        H = np.einsum("tij,jk,tk->ti", R, J, w)
        conserved = np.stack([H[:, 2], (J @ w.T).T[:, 2]], axis=1)  # vertical, and along the symmetry axis
    else:
        energy = 0.5 * np.einsum("ti,ij,tj->t", w, J, w)
        conserved = np.einsum("tij,jk,tk->ti", R, J, w)
    e = float(np.max(np.abs(energy - energy[0])) / abs(energy[0]))
    h = float(np.max(np.linalg.norm(conserved - conserved[0], axis=1)) / np.linalg.norm(conserved[0]))
    return e, h


def run(scene: str, t_end: float, rtol: float, tilt_deg: float = 100.0, n_out: int = 201,
        rotations=("quaternion", "bryant"), spin: float = TOP_SPIN, method: str = "DOP853") -> list[dict]:
    """The rows of one scene: the hand model, then flexmb with each rotation description."""
    from scipy.integrate import solve_ivp

    import flexmb as fm

    atol = rtol / 100
    times = np.linspace(0.0, t_end, n_out)
    q0, w0 = initial_state(scene, tilt_deg, spin)
    rhs, J = hand_model(scene)
    start, cpu = time.perf_counter(), time.process_time()
    sol = solve_ivp(rhs, (0.0, t_end), np.concatenate([q0, w0]), method="DOP853", rtol=rtol, atol=atol,
                    dense_output=True)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    Y = sol.sol(times).T
    R_hand = np.array([_matrix(q) for q in Y[:, :4]])
    base = {"scene": scene, "t_end": t_end, "rtol": rtol, "atol": atol, "method": "DOP853"}
    if scene == "top":
        base["tilt_deg"], base["spin"] = tilt_deg, spin
    rows = [dict(base, tool="hand quaternion model (solve_ivp)", steps=len(sol.t) - 1, rhs=int(sol.nfev),
                 wall_s=wall, cpu_s=cpu,
                 **dict(zip(("energy_drift", "momentum_drift"), _drifts(scene, R_hand, Y[:, 4:], J))))]
    for rotation in rotations:
        model = flexmb_model(scene, rotation)
        positions, speeds = _flexmb_initial(scene, rotation, q0, w0)
        start, cpu = time.perf_counter(), time.process_time()
        try:
            res = fm.simulate(model, t_end, positions=positions, speeds=speeds, method=method, rtol=rtol,
                              atol=atol, t_eval=times, progress=False)
        except fm.FlexmbError as exc:
            rows.append(dict(base, tool=f"flexmb ({rotation})", method=method, error=str(exc)))
            continue
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu
        R = res.rotations[:, 0]
        w = res.angular_velocity("body", frame="body")
        rows.append(dict(base, tool=f"flexmb ({rotation})", method=method, steps=int(res.n_steps), rhs=int(res.n_rhs),
                         wall_s=wall, cpu_s=cpu, cpu_ratio=cpu / rows[0]["cpu_s"],
                         steps_ratio=res.n_steps / rows[0]["steps"],
                         rotation_error=float(np.max(np.abs(R - R_hand))),
                         **dict(zip(("energy_drift", "momentum_drift"), _drifts(scene, R, w, J)))))
    return rows


def _warm_up(scene, rotations):
    """One short run of each flexmb model first: the compiled kernels load (start-up: benchmarks/startup.py)."""
    import flexmb as fm

    q0, w0 = initial_state(scene, 30.0)
    for rotation in rotations:
        positions, speeds = _flexmb_initial(scene, rotation, q0, w0)
        fm.simulate(flexmb_model(scene, rotation), 1e-3, positions=positions, speeds=speeds, method="DOP853",
                    n_out=2, progress=False)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scene", choices=("top", "tumbling"), default="top")
    p.add_argument("--t-end", type=float, default=5.0, help="top: run length, s")
    p.add_argument("--periods", type=float, default=1000.0, help="tumbling: run length in periods 2 pi / |w0|")
    p.add_argument("--tilt", type=float, default=100.0, help="top: initial tilt from the vertical, deg")
    p.add_argument("--spin", type=float, default=TOP_SPIN, help="top: initial spin about its axis, rad/s")
    p.add_argument("--rtol", type=float, nargs="+", default=[1e-8])
    p.add_argument("--bryant", action="store_true", help="also run the Bryant-angle joint")
    p.add_argument("--method", default="DOP853", help="flexmb's integrator (the hand model keeps DOP853)")
    p.add_argument("--out", default=None, help="append the rows (JSON lines) to this file")
    a = p.parse_args(argv)
    t_end = a.t_end if a.scene == "top" else a.periods * 2 * np.pi / np.linalg.norm(BODY_W0)
    rotations = ("quaternion", "bryant") if a.bryant else ("quaternion",)
    _warm_up(a.scene, rotations)
    for rtol in a.rtol:
        for row in run(a.scene, t_end, rtol, a.tilt, rotations=rotations, spin=a.spin, method=a.method):
            line = json.dumps(row)
            print(line, flush=True)
            if a.out:
                with open(a.out, "a") as f:
                    f.write(line + "\n")


if __name__ == "__main__":
    main()
