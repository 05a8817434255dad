"""Write genalpha_compiled.npz: simulate's generalized-alpha runs stepped in Python, the compiled loop's test.

Generated with the per-step Python loop of
:class:`flexmb.genalpha.GeneralizedAlpha` (commit f1ea890, before the
compiled step loop of :mod:`flexmb.genalpha.compiled`);
tests/test_genalpha_compiled.py checks that the compiled loop takes the
same steps, right-hand sides (one per Newton iteration, and one at the
start) and Jacobians, and ends in the same states to 1e-10. Rerun only to
add cases, from a checkout of that commit:

    python tests/data/make_genalpha_compiled.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent / "benchmarks"))

import flexmb as fm  # noqa: E402
import scenes  # noqa: E402
from flexmb.genalpha import GeneralizedAlpha, generalized_alpha  # noqa: E402

#: GeneralizedAlpha with the dense iteration matrix at every size (the Krylov solves from 64 speeds otherwise)
DenseGA = type("DenseGA", (GeneralizedAlpha,), {"krylov_min_coords": 10**6, "__module__": __name__})


def spinning_pendulum():
    """A bar on a pin spinning over its top (its angle winds: the run moves its offsets)."""
    model = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)), fm.Gravity((0.0, -9.81, 0.0)))
    return model.build()


def cases():
    """(name, system maker, t_end, simulate's keywords)."""
    t_eval = np.linspace(0.0, 0.2, 7)
    yield "b1_8_default", lambda: scenes.b1(8).build(), 0.2, dict(method="GeneralizedAlpha", n_out=11)
    yield "b1_8_maxstep_teval", lambda: scenes.b1(8).build(), 0.2, dict(
        method="GeneralizedAlpha", rtol=1e-4, atol=1e-6, max_step=2e-3, t_eval=t_eval)
    yield "b1_8_rho06", lambda: scenes.b1(8).build(), 0.2, dict(method=generalized_alpha(0.6), rtol=3e-5,
                                                                atol=3e-7, n_out=5)
    yield "b1_8_fixed", lambda: scenes.b1(8).build(), 0.05, dict(
        method=generalized_alpha(0.8, fixed_step=1e-3), n_out=6)
    yield "b1_64_dense", lambda: scenes.b1(64).build(), 0.05, dict(method=DenseGA, rtol=1e-4, atol=1e-6, n_out=6)
    yield "b1_64_krylov", lambda: scenes.b1(64).build(), 0.05, dict(method="GeneralizedAlpha", rtol=1e-4,
                                                                    atol=1e-6, n_out=6)
    yield "b2_16", lambda: scenes.b2(16).build(), 0.2, dict(method="GeneralizedAlpha", rtol=3e-5, atol=3e-7,
                                                            n_out=11)
    yield "b2_16_maxstep", lambda: scenes.b2(16).build(), 0.1, dict(method="GeneralizedAlpha", rtol=1e-4,
                                                                    atol=1e-6, max_step=5e-4, n_out=4)
    yield "pendulum_winding", spinning_pendulum, 5.0, dict(method="GeneralizedAlpha", speeds={"pin": 12.0},
                                                           rtol=1e-8, atol=1e-10, n_out=21)


def run(name, make, t_end, kw):
    """One case's counts and outputs."""
    res = fm.simulate(make(), t_end, progress=False, **kw)
    assert res.status == "finished", (name, res.message)
    return dict(steps=res.n_steps, rhs=res.n_rhs, jac=res.n_jac, rebases=res.n_rebases, t=np.asarray(res.t),
                x=np.asarray(res.x), xd=np.asarray(res.xd))


def main():
    out = {}
    for name, make, t_end, kw in cases():
        r = run(name, make, t_end, kw)
        print(name, r["steps"], r["rhs"], r["jac"], r["rebases"], flush=True)
        for key, value in r.items():
            out[f"{name}/{key}"] = value
    np.savez_compressed(HERE / "genalpha_compiled.npz", **out)


if __name__ == "__main__":
    main()
