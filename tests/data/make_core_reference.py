"""Write core_reference.npz: the numpy implementation's evaluations, the compiled core's test.

Generated once with the numpy evaluation path that the compiled kernels
replaced (commit 44462a0); tests/test_core_reference.py checks the
compiled path against it to 1e-10. Rerun only to add cases, from a
checkout of that commit:

    python tests/data/make_core_reference.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import flexmb as fm  # noqa: E402
from conftest import JOINT_TYPES, fourbar, fourbar_initial, random_chain  # noqa: E402


def cases():
    """(name, model, x, xd) for every model and state in the reference."""
    rng = np.random.default_rng(2026)
    for i in range(4):
        model = random_chain(rng, types=JOINT_TYPES * 2, branch=True)
        n = model.build().n_coords
        yield f"random_tree_{i}", model, rng.normal(scale=0.7, size=n), rng.normal(size=n)
    model = random_chain(rng, types=JOINT_TYPES, branch=False)
    n = model.build().n_coords
    yield "random_chain", model, rng.normal(scale=0.7, size=n), rng.normal(size=n)
    # a flexible body: B2-like spatial beam with a tip mass and gravity
    model = fm.Model("beam")
    beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(), 6,
                           keep=("torsion", "bend_y", "bend_z"), damping=7.7398e-4)
    tip = fm.RigidBody("tip", 0.05, np.eye(3) * 1e-6)
    model.add(fm.Fixed("clamp", model.ground, beam),
              fm.Fixed("tip_mass", beam, tip, parent_point=(1.0, 0.02, 0.0)),
              fm.Gravity((0.0, -9.81 * 0.6, -9.81 * 0.8)))
    n = model.build().n_coords
    yield "beam", model, rng.normal(scale=0.05, size=n), rng.normal(scale=0.5, size=n)
    # closed loops: planar and spatial four-bar, away from the constraint manifold too
    for cut in (fm.PlanarRevolute, fm.Revolute):
        model = fourbar(cut)
        system = model.build()
        x0, _ = fm.initial_state(system, positions=fourbar_initial())
        yield f"fourbar_{cut.__name__}", model, x0, rng.normal(size=system.n_coords)
        yield f"fourbar_{cut.__name__}_off", model, x0 + rng.normal(scale=1e-3, size=x0.size), \
            rng.normal(size=system.n_coords)
    # the wiper with flexible blades and tip friction (a velocity-dependent tangent)
    from flexmb.scenes.wiper import WiperOptions, wiper

    model, initial = wiper(WiperOptions(flexible=True))
    system = model.build()
    x0, xd0 = fm.initial_state(system, positions=initial)
    xd0 = xd0 + rng.normal(scale=0.3, size=xd0.size)
    yield "wiper", model, x0 + rng.normal(scale=1e-2, size=x0.size), xd0


def evaluate(model, x, xd, t=0.3):
    """The quantities the compiled path must reproduce."""
    system = model.build()
    kin, A, f, phi, psi, b, gamma = system.equations(t, x, xd)
    out = dict(R=kin.R, origin=kin.origin, r=kin.r, omega=kin.omega, v=kin.v, alpha_bias=kin.alpha_bias,
               a_bias=kin.a_bias, Sw=kin.Sw, Sv=kin.Sv, W=kin.W, V=kin.V, A=A, f=f, phi=phi, psi=psi, b=b,
               gamma=gamma, x=x, xd=xd, kinetic=kin.kinetic_energy(),
               potential=system.forces.potential_energy(kin))
    out["xdd"] = system.accelerations(t, x, xd)
    J = system.state_jacobian(t, x, xd)
    if J is not None:
        out["J"] = J
    return out


def main():
    data = {}
    for name, model, x, xd in cases():
        for key, value in evaluate(model, x, xd).items():
            data[f"{name}/{key}"] = np.asarray(value)
    np.savez_compressed(HERE / "core_reference.npz", **data)
    print(f"{len(data)} arrays")


if __name__ == "__main__":
    main()
