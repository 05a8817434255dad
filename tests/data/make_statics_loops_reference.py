"""Write statics_loops_reference.npz: statics, reactions and output projections of the looped models on main.

The consumers of the equations that formed the complement T (or A, psi)
densely for models whose loops the articulated strategy closes
(issue 28 item 2): :func:`flexmb.static_equilibrium` (its Newton
iteration), :meth:`flexmb.System.reactions` with given accelerations and
the output projection near singular positions
(:func:`flexmb.output_projection.project_output`). This script ran on main
(c8547ff, their dense forms: run with PYTHONPATH=<main>/src); tests/test_statics_loops.py asks the O(n m)
forms to give the same to 1e-10.

    OPENBLAS_NUM_THREADS=1 python tests/data/make_statics_loops_reference.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parent.parent / "benchmarks"))

import flexmb as fm  # noqa: E402
import test_statics_loops as case  # noqa: E402


def main():
    out = {}
    for name in case.STATICS:
        system, x0 = case.statics_case(name)
        out[f"statics/{name}"] = fm.static_equilibrium(system, x0, continuation=False)
        print(name, out[f"statics/{name}"][:3])
    for name in case.REACTIONS:
        for i, (system, t, x, xd, xdd) in enumerate(case.reaction_states(name)):
            out[f"reactions/{name}/{i}"] = system.reactions(t, x, xd, xdd)
    for name in case.PARTIAL:
        for i, (system, t, x, xd, res) in enumerate(case.partial_states(name)):
            xp, vp = case.project_partial(system, t, x, xd, res)
            out[f"partial/{name}/{i}/x"], out[f"partial/{name}/{i}/xd"] = xp, vp
    np.savez(HERE / "statics_loops_reference.npz", **out)


if __name__ == "__main__":
    main()
