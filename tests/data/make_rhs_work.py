"""Write rhs_work.npz: open trees' state rates and Jacobians from main before the work-array right-hand side.

Generated with main at commit 2ad8ab4 (``open_tree_rhs`` allocating its
arrays per call, numba's reshape in ``unpack``);
tests/test_rhs_work.py checks that :func:`flexmb.kernels.articulated.open_tree_rhs_into`
with one work array reused across states (and ``System.state_rate``,
``System.state_jacobian``) give the same values to 1e-10. Rerun only to
add cases, from a checkout of that commit:

    python tests/data/make_rhs_work.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent / "benchmarks"))

import flexmb as fm  # noqa: E402
import scenes  # noqa: E402


def floating_arm():
    """A body on a free joint (Euler parameters), an arm on a universal joint, a sprung elbow: nq > n, 2-dof joints."""
    model = fm.Model("floating arm")
    base = fm.RigidBody("base", 2.0, (0.1, 0.2, 0.3), (0.0, 0.0, 0.0))
    arm = fm.RigidBody("arm", 0.5, (0.01, 0.05, 0.05), (0.3, 0.0, 0.0))
    tip = fm.RigidBody("tip", 0.2, (0.002, 0.003, 0.004), (0.1, 0.02, 0.0))
    elbow = fm.Revolute("elbow", arm, tip, axis=(0, 1, 0), parent_point=(0.6, 0.0, 0.0))
    model.add(fm.Free("float", model.ground, base, rotation="quaternion"),
              fm.Universal("shoulder", base, arm, axis=(0, 0, 1), axis2=(0, 1, 0), parent_point=(0.1, 0.0, 0.0)),
              elbow, fm.JointSpringDamper("spring", elbow, 3.0, 0.1), fm.Gravity((0.0, 0.0, -9.81)))
    return model


#: name -> model
MODELS = {"b1_8": lambda: scenes.b1(8), "b1_64": lambda: scenes.b1(64), "b2_16": lambda: scenes.b2(16),
          "floating_arm": floating_arm}
#: the models whose Jacobian at the first state is stored too
JACOBIANS = ("b1_8", "floating_arm")
#: random states per model
STATES = 4


def states(system, seed):
    """Random states ``(q, u)`` of ``system`` (Euler parameters normalised by the layout's own draw)."""
    rng = np.random.default_rng(seed)
    nq, n = system.layout.nq, system.n_speeds
    out = []
    for _ in range(STATES):
        y = np.concatenate([0.4 * rng.normal(size=nq), 0.8 * rng.normal(size=n)])
        out.append(y)
    return np.array(out)


def main():
    data = {}
    for k, (name, make) in enumerate(MODELS.items()):
        system = make().build(planar=False)  # the spatial route (the planar one is held to it by its own tests)
        ys = states(system, k)
        nq = system.layout.nq
        data[f"{name}_y"] = ys
        data[f"{name}_rate"] = np.array([system.state_rate(0.0, y) for y in ys])
        if name in JACOBIANS:
            data[f"{name}_jac"] = system.state_jacobian(0.0, ys[0][:nq], ys[0][nq:])
    np.savez_compressed(HERE / "rhs_work.npz", **data)


if __name__ == "__main__":
    main()
