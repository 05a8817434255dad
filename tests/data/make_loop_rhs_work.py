"""Write loop_rhs_work.npz: the loops' right-hand side and Jacobians from main before the work-array loop_rhs.

Generated with main at commit 8c13991 (``loop_rhs`` allocating its
arrays per call); tests/test_loop_rhs_work.py checks that the loops'
right-hand side as the compiled CVODE callback calls it
(:func:`flexmb.kernels.loops.loop_rhs`), ``System.state_rate`` and the
compiled Jacobian (:func:`flexmb.kernels.loop_jacobian.loop_state_jacobian`)
give the same values to the bit. Rerun only to add cases, from a checkout
of that commit:

    python tests/data/make_loop_rhs_work.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent / "benchmarks"))
sys.path.insert(0, str(HERE.parent))

import flexmb as fm  # noqa: E402
import scenes  # noqa: E402
from conftest import fourbar  # noqa: E402
from flexmb.kernels.loop_jacobian import loop_state_jacobian  # noqa: E402
from flexmb.kernels.loops import loop_rhs  # noqa: E402
from flexmb.system.tangent import NewtonPreconditioner  # noqa: E402


def sprung_fourbar():
    """The planar four-bar under gravity with springs and dampers on its three pins."""
    model = fourbar()
    model.add(fm.JointSpringDamper("kA", "A", 3.0, 0.2), fm.JointSpringDamper("kB", "B", 1.5, 0.05),
              fm.JointSpringDamper("kD", "D", 2.0, 0.1))
    return model


#: name -> model
MODELS = {"b6_8": lambda: scenes.b6(True, 8)[0], "b6_32": lambda: scenes.b6(True, 32)[0],
          "fourbar": fourbar, "fourbar_spatial": lambda: fourbar(fm.Revolute), "fourbar_sprung": sprung_fourbar,
          "b7_4": lambda: scenes.b7(4)[0], "b7_40": lambda: scenes.b7(40)[0]}
#: random states per model
STATES = 3
#: the time of the state rates (the drivers' accelerations)
T = 0.03


def build(name):
    """The model ``name`` built with the articulated (O(n m)) loop strategy."""
    return MODELS[name]().build(complement="articulated")


def states(system, seed):
    """Random states ``(x, xd)`` of ``system``: coordinates 0.3, speeds 0.8 standard deviations."""
    rng = np.random.default_rng(seed)
    nq, n = system.layout.nq, system.n_speeds
    return np.array([np.concatenate([0.3 * rng.normal(size=nq), 0.8 * rng.normal(size=n)]) for _ in range(STATES)])


def callback_rhs(system, y, gamma_d):
    """``loop_rhs`` with the compiled CVODE callback's arguments (compiled loads only): (xdd, lam, kept, status)."""
    n = system.n_speeds
    nb = system.topology.n_bodies
    zeros = np.zeros((nb + 1, 3))
    xdd, lam, kept, smallest, status = loop_rhs(system._packed, system._loop_layout, y, n, np.zeros(0), zeros, zeros,
                                                np.zeros(n), gamma_d, system._loop_tol, system.singular_window(), -1)
    return xdd, lam, np.array([kept, status, smallest])


def compiled_jacobian(system, y, gamma_d):
    """:func:`loop_state_jacobian` at ``y`` with the preconditioner's diagonal terms."""
    n = system.n_speeds
    K, C = NewtonPreconditioner.diagonal_terms(system)
    J = np.full((2 * n, 2 * n), np.nan)
    status, body = loop_state_jacobian(system._packed, system._loop_layout, y, n, K, C, gamma_d, system._loop_tol,
                                       system.singular_window(), -1, J)
    return J, np.array([status, body])


def main():
    data = {}
    for k, name in enumerate(MODELS):
        system = build(name)
        ys = states(system, k)
        n_drv = len(system.constraints.drivers)
        gamma_d = 0.5 + np.arange(n_drv, dtype=float)
        data[f"{name}_y"] = ys
        data[f"{name}_gamma_d"] = gamma_d
        data[f"{name}_rate"] = np.array([system.state_rate(T, y) for y in ys])
        out = [callback_rhs(system, y, gamma_d) for y in ys]
        data[f"{name}_xdd"] = np.array([o[0] for o in out])
        data[f"{name}_lam"] = np.array([o[1] for o in out])
        data[f"{name}_info"] = np.array([o[2] for o in out])
        J, info = compiled_jacobian(system, ys[0], gamma_d)
        data[f"{name}_jac"] = J
        data[f"{name}_jac_info"] = info
        jac = system.state_jacobian(T, ys[0][:system.layout.nq], ys[0][system.layout.nq:])
        if jac is not None:  # None: the Python Jacobian is not needed (no coordinate terms)
            data[f"{name}_state_jacobian"] = jac
    np.savez_compressed(HERE / "loop_rhs_work.npz", **data)


if __name__ == "__main__":
    main()
