"""One state Jacobian of an open tree, planar route against spatial route (issues 28, 31; session 11).

    OPENBLAS_NUM_THREADS=1 python benchmarks/planar_jacobian.py --rounds 7

For B1 N = 8 and 32 (benchmarks/scenes.py), built twice (``planar=None``:
the planar path; ``planar=False``: the spatial one), the compiled
:func:`flexmb.kernels.tree_jacobian.tree_state_jacobian` as CVODE's dense
``jac`` callback calls it (the same packed arguments), in a compiled loop of
``reps`` calls (no Python per call), at a state of a run (``t = 0.05 s``).
Alternating rounds, planar and spatial in turn (the order swapped each
round); the least CPU time per call of each. Beside it the planar parts
alone (:func:`flexmb.kernels.planar_tangent.planar_tree_jacobian_parts`:
``A^-1`` and G, without the n x n product that assembles J) and the two
geometric stiffnesses alone (each with the kinematics, loads and
inertias it needs). One JSON line per model goes to ``--out``
(default ``benchmarks/results/planar_jacobian_s11.jsonl``, appended).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np
from numba import njit

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import flexmb as fm  # noqa: E402
import scenes  # noqa: E402
from flexmb.kernels.dynamics import composite_inertias, spatial_inertias  # noqa: E402
from flexmb.kernels.loads import apply_load_tables  # noqa: E402
from flexmb.kernels.packing import unpack, unpack_planar  # noqa: E402
from flexmb.kernels.planar import kinematics  # noqa: E402
from flexmb.kernels.planar_tangent import (planar_geometric_stiffness, planar_gravity_loads,  # noqa: E402
                                           planar_tree_jacobian_parts)
from flexmb.kernels.tangent import geometric_stiffness  # noqa: E402
from flexmb.kernels.tree import tree_state  # noqa: E402
from flexmb.kernels.tree_jacobian import tree_state_jacobian  # noqa: E402
from flexmb.system.tangent import NewtonPreconditioner  # noqa: E402


@njit
def _jacobians(packed, y, n, K, C, J, reps):
    """``reps`` state Jacobians (the dispatching kernel, as the C callback calls it)."""
    s = 0
    for _ in range(reps):
        s += tree_state_jacobian(packed, y, n, K, C, J)[0]
    return s


@njit
def _planar_parts(packed, y, n, reps):
    """``reps`` planar ``A^-1`` and G, without J's assembly."""
    ints, floats = unpack_planar(packed)
    s = 0.0
    for _ in range(reps):
        P, G, _ = planar_tree_jacobian_parts(ints, floats, y, n)
        s += P[0, 0] + G[0, 0]
    return s


@njit
def _planar_G(packed, y, n, xdd, reps):
    """``reps`` planar geometric stiffnesses at ``(y, xdd)`` (kinematics included)."""
    ints, floats = unpack_planar(packed)
    nb = ints[0].shape[0]
    Kin = np.empty((nb + 1, 20))
    force, torque = np.empty((nb, 2)), np.empty(nb)
    s = 0.0
    for _ in range(reps):
        kinematics(ints, floats, y[:n], y[n:2 * n], Kin)
        planar_gravity_loads(floats, force, torque)
        s += planar_geometric_stiffness(ints, floats, Kin, xdd, force, torque)[0, 0]
    return s


@njit
def _spatial_G(packed, y, n, xdd, reps):
    """``reps`` spatial geometric stiffnesses at ``(y, xdd)`` (kinematics, loads and inertias included)."""
    tree, tables, _ = unpack(packed)
    x, xd = y[:n], y[n:2 * n]
    nb = tree.parent.shape[0]
    s = 0.0
    for _ in range(reps):
        R, origin, r, omega, v, alpha, acc, _, Sw, Sv = tree_state(tree, x, xd)
        force, torque = np.zeros((nb + 1, 3)), np.zeros((nb + 1, 3))
        apply_load_tables(tables, tree.mass, R, origin, r, omega, v, x, xd, force, torque, np.zeros(n), np.zeros(0))
        Iw, spatial = spatial_inertias(R, r, tree.mass, tree.inertia)
        s += geometric_stiffness(tree.parent, tree.coord_start, tree.coord_body, tree.coord_kind, Sw, Sv, xdd, r,
                                 omega, v, alpha, acc, Iw, tree.mass, composite_inertias(tree.parent, spatial), force,
                                 torque)[0, 0]
    return s


def _cpu_per_call(fn, reps):
    """CPU seconds per call of ``fn(reps)``."""
    t0 = time.process_time()
    fn(reps)
    return (time.process_time() - t0) / reps


def measure(n_seg, rounds):
    """The per-call CPU times of one model (a dict, one JSON line)."""
    planar, spatial = scenes.b1(n_seg).build(), scenes.b1(n_seg).build(planar=False)
    assert planar.planar and not spatial.planar
    res = fm.simulate(spatial, 0.05, method="CVODE_BDF", rtol=1e-7, n_out=2, progress=False)
    n = planar.n_speeds
    y = np.concatenate([res.x[-1], res.xd[-1]])
    K, C = NewtonPreconditioner.diagonal_terms(planar)
    J = np.zeros((2 * n, 2 * n))
    xdd = spatial.state_rate(res.t[-1], y)[n:]
    reps = max(50, 200000 // (n * n))
    calls = {"planar": lambda r: _jacobians(planar._packed_open, y, n, K, C, J, r),
             "spatial": lambda r: _jacobians(spatial._packed_open, y, n, K, C, J, r),
             "planar_parts": lambda r: _planar_parts(planar._packed_open, y, n, r),
             "planar_G": lambda r: _planar_G(planar._packed_open, y, n, xdd, r),
             "spatial_G": lambda r: _spatial_G(spatial._packed_open, y, n, xdd, r)}
    for fn in calls.values():
        fn(2)
    best = dict.fromkeys(calls, np.inf)
    for k in range(rounds):
        for name in (list(calls) if k % 2 == 0 else list(calls)[::-1]):
            best[name] = min(best[name], _cpu_per_call(calls[name], reps))
    return {"scene": "B1", "N": n_seg, "n": n, "reps": reps, "rounds": rounds,
            **{f"{name}_us": 1e6 * t for name, t in best.items()},
            "spatial_over_planar": best["spatial"] / best["planar"],
            "G_spatial_over_planar": best["spatial_G"] / best["planar_G"],
            "load1": os.getloadavg()[0], "when": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}


def main(argv=None):
    """Measure B1 N = 8 and 32 and append the JSON lines."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--sizes", default="8,32")
    parser.add_argument("--out", default=os.path.join(HERE, "results", "planar_jacobian_s11.jsonl"))
    args = parser.parse_args(argv)
    for n_seg in (int(s) for s in args.sizes.split(",")):
        row = measure(n_seg, args.rounds)
        print(json.dumps(row))
        with open(args.out, "a") as fh:
            fh.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
