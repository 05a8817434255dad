"""Exudyn peer: the finite-segment beam of B1 / B2 as an ObjectKinematicTree.

Built with Exudyn's public API as its documentation recommends for chains of
rigid links in minimal coordinates: one ``ObjectKinematicTree`` on a
``NodeGenericODE2``; per segment one revolute joint per kept angle, in the
order Rx, Ry, Rz about the moving axes (massless intermediate links, the
segment's block mass on the last), the joint offset (l, 0, 0) at each
segment end; the joint springs and stiffness-proportional dampers are the
tree's PD vectors (``jointPControlVector = k``, ``jointDControlVector = c``,
zero offsets), gravity the tree's ``gravity``; B2's tip mass is merged into
the last link's rigid-body inertia (parallel-axis theorem). Implicit
generalized-alpha (Exudyn's default spectral radius 0.9, modified Newton),
fixed steps, the fast module (``sys.exudynFast = True``).

Tuned as Exudyn's documentation allows: the Newton iteration's relative
tolerance (``timeIntegration.newton.relativeTolerance``, default 1e-8) is
a setting of each run (``--newton-rtol``); its absolute tolerance
(``newton.absoluteTolerance``, default 1e-10) is ``--newton-atol`` (loosened
to the relative tolerance it changed the CPU time by at most 3 % at B1
N = 8 and B2 N = 16: ``docs/benchmarks.md``, so compare.py keeps the
default).
``--configs NEWTON_RTOL:STEPS ...`` runs just those pairs instead of the
grid ``--newton-rtol`` x ``--steps``.

Prints one JSON line per configuration (BENCHMARKS.md fields plus
``output``, the tip position at t_end, and ``wall_rounds``): ``--repeat``
rounds each run every configuration once, and the least wall time is
reported (``rounds.py``; with ``--rounds-from-stdin``, compare.py drives the
rounds and alternates them with flexmb's). ``error`` is filled when
``--reference X Y Z`` is given (compare.py passes flexmb's reference of the
same N), otherwise null.

Run in the peers' venv::

    /work/venv-peers/bin/python benchmarks/peers/exudyn_beam.py --scene B2 --n 8 --steps 500 1000 2000
    /work/venv-peers/bin/python benchmarks/peers/exudyn_beam.py --scene B1 --n 8 --richardson 64000

``--richardson S`` prints the Richardson extrapolation of the runs with S
and 2S steps (the small-step solution used to verify that Exudyn solves the
same equations as flexmb).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.exudynFast = True  # Exudyn's recommended fast module (no range checks)
import exudyn as exu  # noqa: E402
import exudyn.itemInterface as eii  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from beam_data import beam, emit, row  # noqa: E402
from rounds import drive  # noqa: E402

JOINTS = (exu.JointType.RevoluteX, exu.JointType.RevoluteY, exu.JointType.RevoluteZ)


def _merge_tip(m, inertia, com, tip_mass, tip_point):
    """Mass, central inertia tensor and mass centre of the last segment with a point mass attached."""
    I = np.diag(inertia)
    if tip_mass == 0.0:
        return m, I, com
    M = m + tip_mass
    c = (m * com + tip_mass * tip_point) / M

    def shift(mass, d):
        return mass * (d @ d * np.eye(3) - np.outer(d, d))

    return M, I + shift(m, com - c) + shift(tip_mass, tip_point - c), c


def build(scene: str, n: int, damped: bool = True):
    """The Exudyn system of scene B1 or B2: (SystemContainer, mbs, sensor, n_coords)."""
    d = beam(scene, n, damped)
    axes = d["axes"]
    types, parents, offsets, masses, inertias, coms = [], [], [], [], [], []
    for i in range(n):
        for j, a in enumerate(axes):
            types.append(JOINTS[a])
            parents.append(len(types) - 2)
            offsets.append([d["l"], 0.0, 0.0] if (j == 0 and i > 0) else [0.0, 0.0, 0.0])
            if j == len(axes) - 1:  # the segment's body
                tip = (d["tip_mass"], d["tip_point"]) if i == n - 1 else (0.0, d["tip_point"])
                M, I, c = _merge_tip(d["m"], d["inertia"], d["com"], *tip)
            else:  # intermediate frame of the Rx Ry Rz sequence
                M, I, c = 0.0, np.zeros((3, 3)), np.zeros(3)
            masses.append(M)
            inertias.append(I)
            coms.append(c)
    nc = len(types)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    node = mbs.AddNode(eii.NodeGenericODE2(referenceCoordinates=[0.0] * nc, initialCoordinates=[0.0] * nc,
                                           initialCoordinates_t=[0.0] * nc, numberOfODE2Coordinates=nc))
    tree = mbs.AddObject(eii.ObjectKinematicTree(
        nodeNumber=node, gravity=list(d["gravity"]), baseOffset=[0.0, 0.0, 0.0], jointTypes=types,
        linkParents=parents, jointTransformations=exu.Matrix3DList([np.eye(3)] * nc),
        jointOffsets=exu.Vector3DList(offsets), linkInertiasCOM=exu.Matrix3DList(inertias),
        linkCOMs=exu.Vector3DList(coms), linkMasses=masses,
        jointPositionOffsetVector=[0.0] * nc, jointVelocityOffsetVector=[0.0] * nc,
        jointPControlVector=list(d["k"].ravel()), jointDControlVector=list(d["c"].ravel()),
        visualization=eii.VObjectKinematicTree(show=False)))
    point = d["tip_point"]
    sensor = mbs.AddSensor(eii.SensorKinematicTree(objectNumber=tree, linkNumber=nc - 1, localPosition=list(point),
                                                   outputVariableType=exu.OutputVariableType.Position,
                                                   writeToFile=False, storeInternal=False))
    mbs.Assemble()
    return SC, mbs, sensor, nc


def settings(t_end: float, steps: int, newton_rtol: float = 1e-8,
             newton_atol: float | None = None) -> "exu.SimulationSettings":
    """Implicit generalized-alpha with Exudyn's recommended defaults and the given Newton tolerances, no files.

    ``newton_atol`` None keeps Exudyn's default absolute tolerance.
    """
    s = exu.SimulationSettings()
    s.timeIntegration.endTime = t_end
    s.timeIntegration.numberOfSteps = int(steps)
    s.timeIntegration.verboseMode = 0
    s.timeIntegration.newton.useModifiedNewton = True
    s.timeIntegration.newton.relativeTolerance = newton_rtol
    if newton_atol is not None:
        s.timeIntegration.newton.absoluteTolerance = newton_atol
    s.timeIntegration.generalizedAlpha.spectralRadius = 0.9
    s.solution.file.write = False
    s.solution.sensors.writePeriod = t_end
    s.show.computationTime = False
    s.show.statistics = False
    return s


def run(scene: str, n: int, steps: int, t_end: float = 1.0, newton_rtol: float = 1e-8,
        newton_atol: float | None = None):
    """One simulation: (setup_s, wall_s, tip position at t_end, counters dict, n_coords)."""
    t0 = time.perf_counter()
    SC, mbs, sensor, nc = build(scene, n)
    sim = settings(t_end, steps, newton_rtol, newton_atol)
    solver = exu.MainSolverImplicitSecondOrder()
    setup = time.perf_counter() - t0
    t0, c0 = time.perf_counter(), time.process_time()
    ok = solver.SolveSystem(mbs, sim)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    tip = np.array(mbs.GetSensorValues(sensor), float)
    counters = {"steps": int(solver.it.currentStepIndex), "newton": int(solver.it.newtonStepsCount),
                "jac": int(solver.it.newtonJacobiCount), "ok": bool(ok), "cpu_s": cpu}
    return setup, wall, tip, counters, nc


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="B1", choices=["B1", "B2"])
    ap.add_argument("--n", type=int, nargs="+", default=[8])
    ap.add_argument("--steps", type=int, nargs="+", default=[250, 500, 1000, 2000, 4000, 8000])
    ap.add_argument("--newton-rtol", type=float, nargs="+", default=[1e-8],
                    help="Newton relative tolerances (timeIntegration.newton.relativeTolerance; default 1e-8)")
    ap.add_argument("--newton-atol", type=float,
                    help="Newton absolute tolerance (timeIntegration.newton.absoluteTolerance; default: Exudyn's)")
    ap.add_argument("--configs", nargs="+",
                    help="NEWTON_RTOL:STEPS pairs to run instead of the grid --newton-rtol x --steps")
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--repeat", type=int, default=3,
                    help="rounds (each runs every configuration once); the least wall time is reported")
    ap.add_argument("--reference", type=float, nargs="*", help="reference tip position (m) for the error")
    ap.add_argument("--reference-label", default="")
    ap.add_argument("--richardson", type=int, help="print the Richardson extrapolation of S and 2S steps")
    ap.add_argument("--rounds-from-stdin", action="store_true",
                    help="driven by compare.py: one round per line 'round' on stdin, one JSON row per run")
    args = ap.parse_args(argv)
    if args.richardson:
        for n in args.n:
            _, w1, y1, _, _ = run(args.scene, n, args.richardson, args.t_end)
            _, w2, y2, _, _ = run(args.scene, n, 2 * args.richardson, args.t_end)
            y = y2 + (y2 - y1) / 3.0
            emit({"tool": "exudyn", "scene": args.scene, "n_segments": n, "richardson_steps": args.richardson,
                  "output": y.tolist(), "output_fine": y2.tolist(), "change": float(np.linalg.norm(y2 - y1)),
                  "wall_s": w1 + w2})
        return
    if args.configs:
        pairs = [(float(c.split(":")[0]), int(c.split(":")[1])) for c in args.configs]
    else:
        pairs = [(nt, steps) for nt in args.newton_rtol for steps in args.steps]
    configs = [(n, nt, steps) for n in args.n for nt, steps in pairs]
    failed = set()

    def run_round(r):
        rows = []
        for n, nt, steps in configs:
            if (n, nt, steps) in failed:  # a failed run is not repeated
                continue
            s, w, tip, cnt, nc = run(args.scene, n, steps, args.t_end, nt, args.newton_atol)
            err = float(np.linalg.norm(tip - np.asarray(args.reference))) if args.reference else None
            rows.append(row("exudyn", args.scene, n, n_coords=nc, n_dof=nc,
                            integrator="generalized-alpha (rho_inf 0.9, modified Newton)", rtol=None,
                            newton_rtol=nt, newton_atol=args.newton_atol, h=args.t_end / steps, setup_s=s, wall_s=w, cpu_s=cnt["cpu_s"],
                            steps=cnt["steps"], rhs_evals=cnt["newton"],
                            jac_evals=cnt["jac"], error=err, reference=args.reference_label or None,
                            output=tip.tolist(), status="finished" if cnt["ok"] else "failed",
                            version=exu.config.Version(), t_end=args.t_end))
            if not cnt["ok"]:
                failed.add((n, nt, steps))
        return rows

    drive(run_round, args.repeat, args.rounds_from_stdin, emit)

if __name__ == "__main__":
    main()
