"""Write loop_outputs.npz: the Results of compiled-loop CVODE runs from main before their outputs were compiled.

Generated with branch h-looprhs at dd2ab3e (main 7e2e2bb with the loops' rhs arithmetic of
session 9, whose last bits move the four-bars' and B7's steps; otherwise main's code: each output interpolated,
projected and evaluated from Python: ``Run._store``, ``project_output``,
``flexmb.result._evaluate_states``); tests/test_loop_outputs.py runs the same
simulations and checks that every array the Result holds and every counter
are the same to 1e-10. Rerun only to add cases, from a checkout of that
commit:

    python tests/data/make_loop_outputs.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parent.parent / "benchmarks"))

import flexmb as fm  # noqa: E402
import scenes  # noqa: E402
from flexmb import output_projection  # noqa: E402
from conftest import fourbar, fourbar_initial  # noqa: E402

#: the Result's arrays compared
ARRAYS = ("t", "x", "xd", "xdd", "positions", "origins", "rotations", "kinetic", "potential", "residual",
          "velocity_residual", "reactions")
#: the Result's counters compared
COUNTS = ("n_steps", "n_rhs", "n_jac", "n_projections", "n_rebases", "n_complements")


def _b6(n, rtol, span):
    model, positions = scenes.b6(damped=True, n_segments=n)
    return model, dict(positions=positions, complement="articulated", rtol=rtol, atol=rtol / 100, n_out=101), span


#: name -> (model, simulate's keywords, span): CVODE_BDF stepped in compiled code on each
CASES = {
    "b6_8": lambda: _b6(8, 3e-3, 0.5),  # CVODE projects (BDF held to order 3)
    "b6_8_tight": lambda: _b6(8, 1e-6, 0.05),  # the run projects and restarts
    "b6_32": lambda: _b6(32, 3e-3, 0.2),
    "fourbar": lambda: (fourbar(), dict(positions=fourbar_initial(), n_out=41), 2.0),
    "fourbar_spatial_cut": lambda: (fourbar(fm.Revolute), dict(positions=fourbar_initial(), n_out=41), 2.0),
    "fourbar_spinning": lambda: (fourbar(), dict(positions=fourbar_initial(), speeds={"A": 30.0},
                                                 complement="articulated", n_out=51), 1.0),
    "b7_4": lambda: (*scenes.b7(4), 2.0),
    # OUTPUT_PROJECTION_GAIN patched to 5: 14 of the 40 outputs' projections move the state by more than five times
    # its residual and are refused, those outputs projected in the well-conditioned directions only
    "fourbar_refused": lambda: (fourbar(), dict(positions=fourbar_initial(), n_out=41, gain=5.0), 2.0),
}


def run(name):
    """The Result of case ``name`` (CVODE_BDF, no progress bar)."""
    model, kw, span = CASES[name]()
    kw = dict(kw)
    kw.update(method="CVODE_BDF", progress=False)
    gain = kw.pop("gain", None)
    saved = output_projection.OUTPUT_PROJECTION_GAIN
    if gain is not None:
        output_projection.OUTPUT_PROJECTION_GAIN = gain
    try:
        return fm.simulate(model.build(complement=kw.pop("complement", "auto"), planar=False), span, **kw)
    finally:
        output_projection.OUTPUT_PROJECTION_GAIN = saved


def main():
    data = {}
    for name in CASES:
        res = run(name)
        assert res.status == "finished", (name, res.message)
        for key in ARRAYS:
            data[f"{name}_{key}"] = np.asarray(getattr(res, key))
        data[f"{name}_counts"] = np.array([getattr(res, key) for key in COUNTS])
        print(name, res.method, {key: getattr(res, key) for key in COUNTS})
    np.savez_compressed(HERE / "loop_outputs.npz", **data)


if __name__ == "__main__":
    main()
