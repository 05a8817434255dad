"""Exudyn peer: B6 damped, the flexible slider-crank, in redundant planar coordinates with a sparse solver.

The same discrete model as flexmb's ``scenes.b6(damped=True, n_segments=N)``,
read from the JSON that ``b6_data.py`` writes on flexmb's side (segment
mass data, joint springs and dampers, driver rate, consistent initial
state), built with Exudyn's public API as its documentation recommends for
constrained systems of rigid bodies: every body in redundant planar
coordinates (``NodeRigidBody2D`` + ``ObjectRigidBody2D``: crank and the N
rod segments, mass centre as reference point; the slider a
``NodePoint2D`` + ``ObjectMassPoint2D``), joined by ``RevoluteJoint2D``
(ground - crank, crank tip - first segment, segment ends, last segment end
- slider); the rail holds the slider's y coordinate at 0 by a
``CoordinateConstraint``; each elastic joint of the rod is a
``CoordinateSpringDamper`` between the rotation coordinates of the two
segments (moment ``k (phi_j+1 - phi_j) + c (phi_j+1 - phi_j)'``, the linear
rotational spring and damper of flexmb's ``bend_z`` joint); the driver is a
``CoordinateConstraint`` on the crank's rotation coordinate with offset
``speed * t`` (``--driver python``: a Python ``offsetUserFunction``;
``symbolic``: the same function as an Exudyn symbolic user function, run in
C++). The equations are solved by Exudyn's implicit generalized-alpha
solver (default spectral radius 0.9, modified Newton) with the sparse
linear solver (``linearSolver.solverType = EigenSparse``), fixed steps, the
fast module (``sys.exudynFast = True``), one thread, no output files.

The watched output is the slider's position x at ``--n-out`` equally spaced
times in (0, t_end] (a sensor stored internally); the error is the largest
difference from flexmb's reference at the same times (``--reference FILE``,
a JSON list). Prints one JSON line per configuration ``(steps, Newton
relative tolerance)``; ``--repeat`` rounds each run every configuration once
and the least wall time is reported (``rounds.py``; with
``--rounds-from-stdin``, ``compare_b6.py`` drives the rounds and alternates
them with flexmb's). Run in the peers' venv::

    /work/venv-peers/bin/python benchmarks/peers/exudyn_b6.py --data /tmp/b6_N8.json --steps 1000 2000
    /work/venv-peers/bin/python benchmarks/peers/exudyn_b6.py --data /tmp/b6_N8.json --richardson 64000

``--richardson S`` prints the Richardson extrapolation of the runs with S
and 2S steps (the converged solution, compared with flexmb's reference to
show that both tools solve the same equations).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

sys.exudynFast = True  # Exudyn's recommended fast module (no range checks)
import exudyn as exu  # noqa: E402
import exudyn.itemInterface as eii  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from b6_data import initial_bodies  # noqa: E402
from beam_data import emit, row  # noqa: E402
from rounds import drive  # noqa: E402


def build(d: dict, driver: str = "symbolic"):
    """The Exudyn system of B6 damped: (SystemContainer, mbs, (slider node, crank node), ODE2 size, keep-alive list)."""
    n, l = d["n_segments"], d["segment_length"]
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(eii.ObjectGround(referencePosition=[0.0, 0.0, 0.0]))
    ground_node = mbs.AddNode(eii.NodePointGround(referenceCoordinates=[0.0, 0.0, 0.0]))
    ground_coord = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=ground_node, coordinate=0))
    states = initial_bodies(d)
    # rigid bodies: the coordinates are absolute (reference 0, initial values = the state), so that the
    # coordinate spring-dampers and the driver act on absolute angles
    nodes, bodies = [], []
    specs = [(d["crank_mass"], d["crank_inertia"])] + [(d["segment_mass"], d["segment_inertia"])] * n
    for (mass, inertia), (x, y, phi, vx, vy, om) in zip(specs, states[:-1]):
        node = mbs.AddNode(eii.NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0],
                                               initialCoordinates=[x, y, phi],
                                               initialVelocities=[vx, vy, om],
                                               visualization=eii.VNodeRigidBody2D(show=False)))
        nodes.append(node)
        bodies.append(mbs.AddObject(eii.ObjectRigidBody2D(mass=mass, inertia=inertia,
                                                          nodeNumber=node,
                                                          visualization=eii.VObjectRigidBody2D(show=False))))
    x, y, _, vx, vy, _ = states[-1]
    slider_node = mbs.AddNode(eii.NodePoint2D(referenceCoordinates=[0.0, 0.0], initialCoordinates=[x, y],
                                              initialVelocities=[vx, vy],
                                              visualization=eii.VNodePoint2D(show=False)))
    slider = mbs.AddObject(eii.ObjectMassPoint2D(mass=d["slider_mass"], nodeNumber=slider_node,
                                                 visualization=eii.VObjectMassPoint2D(show=False)))

    def point(body, local):
        return mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=body, localPosition=[local, 0.0, 0.0]))

    def pin(m0, m1):
        mbs.AddObject(eii.ObjectJointRevolute2D(markerNumbers=[m0, m1],
                                                visualization=eii.VObjectJointRevolute2D(show=False)))

    crank, segs = bodies[0], bodies[1:]
    cc, sc = d["crank_com"], d["segment_com"]
    pin(mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=ground, localPosition=[0.0, 0.0, 0.0])), point(crank, -cc))
    pin(point(crank, d["crank_length"] - cc), point(segs[0], -sc))
    for j in range(1, n):
        pin(point(segs[j - 1], l - sc), point(segs[j], -sc))
    pin(point(segs[-1], l - sc), mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=slider,
                                                                       localPosition=[0.0, 0.0, 0.0])))
    # the rail: slider y = 0
    mbs.AddObject(eii.ObjectConnectorCoordinate(
        markerNumbers=[ground_coord, mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=slider_node, coordinate=1))],
        visualization=eii.VObjectConnectorCoordinate(show=False)))
    # the rod's elastic joints: linear rotational springs and dampers on the relative angle
    phis = [mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=node, coordinate=2)) for node in nodes]
    for j in range(1, n):
        mbs.AddObject(eii.ObjectConnectorCoordinateSpringDamper(
            markerNumbers=[phis[j], phis[j + 1]], stiffness=d["k"][j - 1], damping=d["c"][j - 1],
            visualization=eii.VObjectConnectorCoordinateSpringDamper(show=False)))
    # the driver: crank angle = speed * t
    speed = d["speed"]
    motor = mbs.AddObject(eii.ObjectConnectorCoordinate(markerNumbers=[ground_coord, phis[0]],
                                                        visualization=eii.VObjectConnectorCoordinate(show=False)))
    keep = []
    if driver == "python":
        mbs.SetObjectParameter(motor, "offsetUserFunction", lambda mbs, t, item, offset: speed * t)
    elif driver == "symbolic":
        esym = exu.symbolic

        def offset_uf(mbs, t, itemNumber, lOffset):
            return esym.Real(speed) * t

        from exudyn.utilities import CreateSymbolicUserFunction
        uf = CreateSymbolicUserFunction(mbs, offset_uf, "offsetUserFunction", itemIndex=motor)
        mbs.SetObjectParameter(motor, "offsetUserFunction", uf)
        keep.append(uf)  # the symbolic function must outlive the simulation
    else:
        raise ValueError(f"unknown driver {driver!r}")
    mbs.Assemble()
    return SC, mbs, (slider_node, nodes[0]), mbs.systemData.ODE2Size(), keep


def settings(t_end: float, steps: int, newton_rtol: float) -> "exu.SimulationSettings":
    """Implicit generalized-alpha, sparse linear solver, no output files, sensors at every step end."""
    s = exu.SimulationSettings()
    s.timeIntegration.endTime = t_end
    s.timeIntegration.numberOfSteps = int(steps)
    s.timeIntegration.verboseMode = 0
    s.timeIntegration.newton.useModifiedNewton = True
    s.timeIntegration.newton.relativeTolerance = newton_rtol
    s.timeIntegration.generalizedAlpha.spectralRadius = 0.9
    s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    s.solution.file.write = False
    s.solution.sensors.writePeriod = 0.5 * t_end / steps  # every step end
    s.show.computationTime = False
    s.show.statistics = False
    return s


def run(d: dict, steps: int, t_end: float, n_out: int, newton_rtol: float, driver: str):
    """One simulation: (setup_s, wall_s, slider x at the n_out times, counters, ODE2 size, crank angle at t_end)."""
    t0 = time.perf_counter()
    SC, mbs, (slider_node, crank_node), nc, keep = build(d, driver)
    sensor = mbs.AddSensor(eii.SensorNode(nodeNumber=slider_node, outputVariableType=exu.OutputVariableType.Position,
                                          writeToFile=False, storeInternal=True))
    mbs.Assemble()
    sim = settings(t_end, steps, newton_rtol)
    solver = exu.MainSolverImplicitSecondOrder()
    setup = time.perf_counter() - t0
    t0 = time.perf_counter()
    ok = solver.SolveSystem(mbs, sim)
    wall = time.perf_counter() - t0
    data = np.asarray(mbs.GetSensorStoredData(sensor), float)
    times = t_end * np.arange(1, n_out + 1) / n_out
    # the sensor stores every step end; with fixed steps dividing n_out the output times are among them.
    # If Exudyn's step control reduced steps (Newton failures) they may not be: then the row says so and the
    # output is interpolated linearly between step ends
    idx = np.searchsorted(data[:, 0], times - 1e-9 * t_end)
    idx = np.minimum(idx, len(data) - 1)
    exact = bool(np.all(np.abs(data[idx, 0] - times) <= 1e-9 * t_end))
    y = data[idx, 1] if exact else np.interp(times, data[:, 0], data[:, 1])
    crank = float(mbs.GetNodeOutput(crank_node, exu.OutputVariableType.Coordinates)[2])
    counters = {"steps": int(solver.it.currentStepIndex), "newton": int(solver.it.newtonStepsCount),
                "jac": int(solver.it.newtonJacobiCount), "ok": bool(ok), "output_on_steps": exact}
    del keep
    return setup, wall, y, counters, nc, crank


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True, help="JSON of b6_data.py (one N)")
    ap.add_argument("--steps", type=int, nargs="+", default=[1000, 2000, 4000, 8000])
    ap.add_argument("--newton-rtol", type=float, nargs="+", default=[1e-8],
                    help="Newton relative tolerances (timeIntegration.newton.relativeTolerance)")
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--n-out", type=int, default=100)
    ap.add_argument("--driver", default="symbolic", choices=["symbolic", "python"])
    ap.add_argument("--repeat", type=int, default=3,
                    help="rounds (each runs every configuration once); the least wall time is reported")
    ap.add_argument("--reference", help="JSON list: flexmb's slider x at the n_out output times (m)")
    ap.add_argument("--reference-label", default="")
    ap.add_argument("--richardson", type=int,
                    help="print the Richardson extrapolation of S and 2S steps (at the first --newton-rtol)")
    ap.add_argument("--rounds-from-stdin", action="store_true",
                    help="driven by compare_b6.py: one round per line 'round' on stdin, one JSON row per run")
    args = ap.parse_args(argv)
    with open(args.data) as fh:
        d = json.load(fh)
    n = d["n_segments"]
    ref = None
    if args.reference:
        with open(args.reference) as fh:
            ref = np.asarray(json.load(fh), float)
    base = {"version": exu.config.Version(), "t_end": args.t_end, "n_out": args.n_out, "driver": args.driver,
            "linear_solver": "EigenSparse"}
    if args.richardson:
        nt = args.newton_rtol[0]
        s1, w1, y1, c1, nc, _ = run(d, args.richardson, args.t_end, args.n_out, nt, args.driver)
        s2, w2, y2, c2, nc, _ = run(d, 2 * args.richardson, args.t_end, args.n_out, nt, args.driver)
        y = y2 + (y2 - y1) / 3.0
        out = {"tool": "exudyn", "scene": "B6", "n_segments": n, "richardson_steps": args.richardson,
               "output": y.tolist(), "change": float(np.max(np.abs(y2 - y1))), "wall_s": w1 + w2,
               "newton_rtol": nt, "finished": bool(c1["ok"] and c2["ok"]), **base}
        if ref is not None:
            out["agreement"] = float(np.max(np.abs(y - ref)))
            out["agreement_fine"] = float(np.max(np.abs(y2 - ref)))
        emit(out)
        return
    configs = [(steps, nt) for nt in args.newton_rtol for steps in args.steps]
    failed = set()

    def run_round(r):
        rows = []
        for steps, nt in configs:
            if (steps, nt) in failed:  # a failed run is not repeated
                continue
            try:
                s, w, y, cnt, nc, crank = run(d, steps, args.t_end, args.n_out, nt, args.driver)
            except Exception as exc:  # noqa: BLE001 - Exudyn raises on Newton failure: a failure row
                failed.add((steps, nt))
                rows.append(row("exudyn", "B6", n, integrator=f"generalized-alpha newton-rtol {nt:g}",
                                h=args.t_end / steps, status=f"failed: {type(exc).__name__}: {exc}"[:300], **base))
                continue
            err = float(np.max(np.abs(y - ref))) if ref is not None else None
            rows.append(row("exudyn", "B6", n, n_coords=nc, n_dof=1 + (n - 1),
                            integrator=f"generalized-alpha newton-rtol {nt:g} (rho_inf 0.9, modified Newton)",
                            rtol=None, h=args.t_end / steps, newton_rtol=nt, setup_s=s, wall_s=w,
                            steps=cnt["steps"], rhs_evals=cnt["newton"], jac_evals=cnt["jac"], error=err,
                            reference=args.reference_label or None, output_end=float(y[-1]), crank_end=crank,
                            output_on_steps=cnt["output_on_steps"],
                            status="finished" if cnt["ok"] else "failed", **base))
            if not cnt["ok"] or not cnt["output_on_steps"]:
                # failed, or Exudyn's step control had to shorten steps (Newton failures): such a run is not
                # the configured fixed step and can take minutes; kept with this round's time, not repeated
                failed.add((steps, nt))
        return rows

    drive(run_round, args.repeat, args.rounds_from_stdin, emit)


if __name__ == "__main__":
    main()
