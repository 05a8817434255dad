"""Write linearize_loops_reference.npz: linearisations of looped models before they avoided n x n arrays.

Generated on main at commit 2ad8ab4, where :func:`flexmb.linearize` of a
model closed by the articulated strategy formed A, psi and T (psi's
dense SVD); tests/test_linearize_loops.py checks the O(p n m) path against
it. T's basis is arbitrary (the SVD's, now p constrained solves), so what
is stored is what does not depend on it: ``T M^-1 T^T``, ``T M^-1 K T^T``,
``T M^-1 C T^T`` and ``T M^-1 F`` (n x n and n, in the coordinates
x), and of :func:`flexmb.state_space` with the last coordinate as input
and output, its poles, ``D`` and the transfer function at ``s = 3j``.
Each model at its assembled state, at rest and moving. Rerun only to
add cases, from a checkout of that commit:

    python tests/data/make_linearize_loops_reference.py
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parent.parent / "benchmarks"))

import flexmb as fm  # noqa: E402
import scenes  # noqa: E402
import test_hard_cases as hc  # noqa: E402
from conftest import fourbar, fourbar_initial  # noqa: E402
from flexmb.simulate import _calibrated  # noqa: E402

#: name: (model, initial_state's arguments at rest, speeds of the moving state)
MODELS = {
    "fourbar": lambda: (fourbar(), {"positions": fourbar_initial()}, {"A": 2.0}),
    "fourbar_revolute_cut": lambda: (fourbar(fm.Revolute), {"positions": fourbar_initial()}, {"A": 2.0}),
    "bricard": lambda: (hc.bricard(), {}, {"R0": 1.0}),
    "b6_8": lambda: (lambda m, i: (m, {"positions": i}, None))(*scenes.b6(True, 8)),
    "b7_4": lambda: (lambda m, i: (m, {"positions": i["positions"]}, i["speeds"]))(*scenes.b7(4)),
    "b7_40": lambda: (lambda m, i: (m, {"positions": i["positions"]}, i["speeds"]))(*scenes.b7(40)),
}


def case(name):
    """The articulated system and its states ``{'rest': (x, xd), 'moving': (x, xd)}``."""
    model, initial, speeds = MODELS[name]()
    system = model.build(complement="articulated", planar=False)
    x, xd = fm.initial_state(system, 0.0, **initial, speeds=speeds)
    system = _calibrated(system, 0.0, x, xd)
    return system, {"rest": (x, np.zeros_like(xd)), "moving": (x, xd)}


def invariants(system, x, xd):
    """What of the linearisation at (x, xd) does not depend on T's basis."""
    lin = fm.linearize(system, x, xd)
    T, Mi = lin.T, np.linalg.inv(lin.M)
    name = system.coordinate_names[-1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ss = fm.state_space(system, [name], [name], about=(x, xd))
    return {"P": T @ Mi @ T.T, "K": T @ Mi @ lin.K @ T.T, "C": T @ Mi @ lin.C @ T.T, "F": T @ Mi @ lin.F,
            "poles": np.sort_complex(ss.poles()), "D": ss.D, "response": ss.response(3j)[0], "x": x, "xd": xd}


def main():
    out = {}
    for name in MODELS:
        system, states = case(name)
        for tag, (x, xd) in states.items():
            for key, value in invariants(system, x, xd).items():
                out[f"{name}/{tag}/{key}"] = value
    np.savez_compressed(HERE / "linearize_loops_reference.npz", **out)


if __name__ == "__main__":
    main()
