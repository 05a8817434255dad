"""Write state_split_reference.npz: runs and analyses before the state became (q, u).

Generated once on main at commit a8859b4, before the state was split
into coordinates q and speeds u (``qd = W(q) u``, issue #29 item 1);
tests/test_state_split.py checks that every model whose joints have
``W = I`` gives the same results to 1e-10. Rerun only to add cases, from
a checkout of that commit:

    python tests/data/make_state_split_reference.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import flexmb as fm  # noqa: E402
from conftest import fourbar, fourbar_initial, random_chain  # noqa: E402


def heavy_top():
    """A heavy top on a Spherical joint (Bryant angles), tilted 30 deg and spinning."""
    model = fm.Model("top")
    top = fm.RigidBody("top", 1.0, np.diag([0.02, 0.02, 0.01]), com=(0.0, 0.0, 0.1))
    model.add(fm.Spherical("pivot", model.ground, top), fm.Gravity((0.0, 0.0, -9.81)))
    return model, dict(positions={"pivot.rx": np.radians(30.0)}, speeds={"pivot.rz": 40.0})


def free_body():
    """An asymmetric body on a Free joint, tumbling under gravity."""
    model = fm.Model("free")
    body = fm.RigidBody("body", 2.0, np.diag([0.1, 0.2, 0.3]))
    model.add(fm.Free("float", model.ground, body), fm.Gravity((0.0, 0.0, -9.81)))
    return model, dict(speeds={"float.x": 1.0, "float.rx": 0.3, "float.ry": 2.0, "float.rz": 0.2})


def runs():
    """(name, model, simulate keyword arguments) of the runs in the reference."""
    model, ic = heavy_top()
    yield "top_dop853", model, dict(t_end=0.5, method="DOP853", rtol=1e-9, **ic)
    yield "top_cvode", model, dict(t_end=0.5, method="CVODE_BDF", rtol=1e-8, **ic)
    model, ic = free_body()
    yield "free_rk45", model, dict(t_end=1.0, method="RK45", rtol=1e-8, **ic)
    yield "fourbar_radau", fourbar(), dict(t_end=0.5, method="Radau", rtol=1e-8, positions=fourbar_initial(),
                                           track_work=True)
    yield "fourbar_ga", fourbar(fm.Revolute), dict(t_end=0.3, method="GeneralizedAlpha", rtol=1e-6,
                                                   positions=fourbar_initial())
    rng = np.random.default_rng(29)
    yield "chain_ida", random_chain(rng, branch=True), dict(t_end=0.2, method="IDA", rtol=1e-7)
    from flexmb.scenes.bicycle import benchmark_bicycle, upright_state

    model = benchmark_bicycle()
    x0, xd0 = upright_state(model.build(), 4.6)
    xd0[list(model.build().coordinate_names).index("frame.lean")] = 0.5
    yield "bicycle_bdf", model, dict(t_end=0.2, method="CVODE_BDF", rtol=1e-8, x0=x0, xd0=xd0)


def run(model, kwargs):
    """The arrays of a run that must not change."""
    res = fm.simulate(model, n_out=21, progress=False, **kwargs)
    out = dict(t=res.t, x=res.x, xd=res.xd, xdd=res.xdd, steps=np.array(res.n_steps))
    if res.work:
        out.update({f"work.{k}": v for k, v in res.work.items()})
    return out


def analyses():
    """Linearisation and statics of models with W = I."""
    model, _ = heavy_top()
    system = model.build()
    x0 = np.zeros(system.n_coords)
    x0[0] = 0.2
    lin = fm.linearize(system, x0, np.zeros(system.n_coords))
    yield "top_linearize", dict(M=lin.M, C=lin.C, K=lin.K)
    model = fourbar()
    model.add(fm.JointSpringDamper("spring", model.element("A"), stiffness=2.0))
    system = model.build()
    x0, _ = fm.initial_state(system, positions=fourbar_initial())
    yield "fourbar_statics", dict(x=fm.static_equilibrium(system, x0))
    from flexmb.scenes.bicycle import benchmark_bicycle, upright_eigenvalues

    yield "bicycle_eigenvalues", dict(ev=upright_eigenvalues(benchmark_bicycle().build(), 4.6))


def main():
    data = {}
    for name, model, kwargs in runs():
        for key, value in run(model, kwargs).items():
            data[f"{name}/{key}"] = value
    for name, values in analyses():
        for key, value in values.items():
            data[f"{name}/{key}"] = value
    np.savez_compressed(HERE / "state_split_reference.npz", **data)


if __name__ == "__main__":
    main()
