"""Write genalpha_reference.npz: the numpy step loop's runs, the compiled step loop's test.

Generated once with the generalized-alpha step loop written in numpy that
the compiled kernels (``flexmb.kernels.genalpha``) replaced (commit
5fe978b); tests/test_genalpha_reference.py checks the compiled loop against
it: the same steps, rejections, Newton iterations and right-hand sides,
and the same states to 1e-10. Rerun only to add cases, from a checkout of
that commit:

    python tests/data/make_genalpha_reference.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent / "benchmarks"))
sys.path.insert(0, str(HERE.parent))  # the tests: the oscillator of test_generalized_alpha

import flexmb as fm  # noqa: E402
from flexmb.genalpha import GeneralizedAlpha, generalized_alpha  # noqa: E402
from flexmb.scenes.fourbar import fourbar  # noqa: E402
from test_generalized_alpha import oscillator  # noqa: E402


def duffing(t, y):
    """A forced, stiffening pair (nonlinear, so Newton iterates) with a work-like extra state."""
    x, v = y[:2], y[2:4]
    a = np.array([-4.0 * x[0] - 30.0 * x[0] ** 3 + 2.0 * (x[1] - x[0]) + np.sin(3.0 * t),
                  -900.0 * x[1] - 2.0 * (x[1] - x[0]) - 50.0 * x[1] ** 3])
    return np.concatenate([v, a, [v @ v]])


def kick(t, y):
    """A damped oscillator whose load jumps at t = 1 (the error test rejects steps there)."""
    return np.array([y[1], -4.0 * y[0] + (40.0 if t > 1.0 else 0.0) - 0.3 * y[1]])


def hard(t, y):
    """A forced pair with a strong cubic spring (Newton fails on long steps and with stale Jacobians)."""
    x, v = y[:2], y[2:]
    a = np.array([-2e4 * x[0] ** 3 - 10 * x[0] + 5 * np.sin(20 * t) + 100 * (x[1] - x[0]),
                  -100 * (x[1] - x[0]) - 1e3 * x[1] * abs(x[1])])
    return np.concatenate([v, a])


def solver_cases():
    """(name, solver class, fun, t0, y0, t_bound, options) driven step by step."""
    fun1, jac1 = oscillator([2.0])
    fun2, jac2 = oscillator([1.0, 1000.0])
    fun3, jac3 = oscillator([1.0, 300.0])
    fun4, jac4 = oscillator([1.0, 1e4])
    yield "adaptive", GeneralizedAlpha, fun1, 0.0, [1.0, 0.0], 5.0, {"rtol": 1e-6, "atol": 1e-6, "jac": jac1}
    yield "backward", GeneralizedAlpha, fun1, 0.0, [1.0, 0.3], -3.0, {"rtol": 1e-5, "atol": 1e-7, "jac": jac1}
    yield "fixed", generalized_alpha(0.8, fixed_step=3.0 / 80), fun1, 0.0, [1.0, 0.0], 3.0, {"jac": jac1}
    yield "fixed_rho0", generalized_alpha(0.0, fixed_step=0.01), fun4, 0.0, [1.0, 1.0, 0.0, 0.0], 1.2, {"jac": jac4}
    yield ("f_max", generalized_alpha(0.8, f_max=10.0), fun2, 0.0, [1.0, 1e-3, 0.0, 0.0], 1.0,
           {"rtol": 1e-5, "atol": 1e-7, "jac": jac2})
    yield ("min_step", generalized_alpha(0.5, f_max=10.0, min_step=1.0 / 300.0), fun3, 0.0, [1.0, 1e-3, 0.0, 0.0],
           1.0, {"rtol": 1e-8, "atol": 1e-10, "jac": jac3})
    yield ("duffing_fd", generalized_alpha(0.6), duffing, 0.0, [0.5, 0.05, 0.0, 0.0, 0.0], 1.0,
           {"rtol": 1e-6, "atol": 1e-8, "n_second": 2})
    yield "kick", GeneralizedAlpha, kick, 0.0, [1.0, 0.0], 3.0, {"rtol": 1e-5, "atol": 1e-7}
    # Newton fails with a current Jacobian: the step is halved
    yield ("newton_halving", generalized_alpha(0.7), hard, 0.0, [0.3, -0.2, 0.0, 1.0], 1.0,
           {"rtol": 1e-4, "atol": 1e-6, "first_step": 0.2})
    yield ("newton_floor", generalized_alpha(0.5, min_step=2e-3), hard, 0.0, [0.3, -0.2, 0.0, 1.0], 1.0,
           {"rtol": 1e-6, "atol": 1e-8, "first_step": 0.2})
    # Newton fails with a stale Jacobian: a new one, and the step again
    yield ("newton_stale", generalized_alpha(0.3, min_step=1e-2), hard, 0.0, [0.3, -0.2, 0.0, 1.0], 1.0,
           {"rtol": 1e-5, "atol": 1e-7})


def drive(cls, fun, t0, y0, t_bound, options):
    """Step a solver to its end: arrays of step ends, states, dense output at mid-steps, and its counters."""
    solver = cls(fun, t0, np.asarray(y0, dtype=float), t_bound, **options)
    ts, ys, dense = [solver.t], [solver.y.copy()], []
    while solver.status == "running":
        solver.step()
        ts.append(solver.t)
        ys.append(solver.y.copy())
        if solver.status != "failed":
            dense.append(solver.dense_output()(0.5 * (solver.t_old + solver.t)))
    counts = [solver.nfev, solver.njev, solver.nlu, solver.n_newton, solver.n_rejected, solver.status == "finished"]
    return {"t": np.array(ts), "y": np.array(ys), "dense": np.array(dense), "counts": np.array(counts, dtype=int)}


def b6_scene():
    """The B6 undamped slider-crank of benchmarks/scenes.py."""
    import scenes

    return scenes.b6(damped=False)


def simulate_cases():
    """(name, thunk) running ``fm.simulate`` with a generalized-alpha method."""
    def pendulum():
        model = fm.Model()
        bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
        model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0, -9.81, 0)))
        return fm.simulate(model, 1.0, positions={"pin": 0.5}, method="GeneralizedAlpha", rtol=1e-8, n_out=21,
                           progress=False)

    def b1():
        model = fm.Model("B1 N=4")
        beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(), 4,
                               keep=("bend_y",), damping=7.7398e-4)
        model.add(fm.Fixed("clamp", model.ground, beam), fm.Gravity((0.0, 0.0, -9.81)))
        return fm.simulate(model, 0.1, method="GeneralizedAlpha", rtol=1e-7, n_out=11, progress=False)

    def fourbar_projected():
        model, initial, fixed = fourbar()
        return fm.simulate(model, 0.3, positions=initial, fixed=fixed, method="GeneralizedAlpha", rtol=1e-6,
                           n_out=11, progress=False)

    def driven_crank():
        model = fm.Model()
        hub = fm.RigidBody.slender_bar("hub", 1.0, 0.2)
        arm = fm.RigidBody.slender_bar("arm", 0.5, 0.3)
        drive_joint = fm.Revolute("drive", model.ground, hub)
        hinge = fm.Revolute("hinge", hub, arm, parent_point=(0.2, 0, 0))
        model.add(drive_joint, hinge, fm.JointSpringDamper("spring", hinge, stiffness=20.0),
                  fm.Driver.constant_speed("motor", drive_joint, speed=2.0))
        return fm.simulate(model, 0.3, positions={"hinge": 0.5}, method=fm.generalized_alpha(1.0), rtol=1e-4,
                           track_work=True, n_out=11, progress=False)

    def b6_auto():
        model, initial = b6_scene()
        return fm.simulate(model.build(), 0.05, positions=initial, track_work=True, n_out=26, progress=False)

    def b6_f_max():
        model, initial = b6_scene()
        return fm.simulate(model.build(), 0.01, positions=initial, method=fm.generalized_alpha(0.8, f_max=600.0),
                           rtol=1e-3, track_work=True, n_out=11, progress=False)

    yield "pendulum", pendulum
    yield "b1", b1
    yield "fourbar", fourbar_projected
    yield "driven_crank", driven_crank
    yield "b6_auto", b6_auto
    yield "b6_f_max", b6_f_max


def summarise(res):
    """The arrays of a Result that the reference keeps, and its counters."""
    out = {"t": res.t, "x": res.x, "xd": res.xd,
           "counts": np.array([res.n_steps, res.n_rhs, res.n_jac, res.n_projections], dtype=int)}
    for key in sorted(res.work):
        out[f"work:{key}"] = res.work[key]
    return out


def main():
    arrays = {}
    for name, cls, fun, t0, y0, t_bound, options in solver_cases():
        for key, value in drive(cls, fun, t0, y0, t_bound, options).items():
            arrays[f"{name}/{key}"] = value
    for name, thunk in simulate_cases():
        res = thunk()
        assert "GeneralizedAlpha" in res.method, res.method
        for key, value in summarise(res).items():
            arrays[f"{name}/{key}"] = value
    np.savez_compressed(HERE / "genalpha_reference.npz", **arrays)
    for key in sorted(k for k in arrays if k.endswith("/counts")):
        print(key, arrays[key].tolist())


if __name__ == "__main__":
    main()
