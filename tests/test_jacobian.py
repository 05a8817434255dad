"""The state Jacobian of implicit integrators against finite differences.

``System.state_jacobian`` builds ``d xdd / d x = A^-1 (G - K)`` from the
geometric stiffness G of :func:`flexmb.assembly.geometric_stiffness`. With
zero speeds, G is exact for trees of every joint type under gravity (loads
of fixed direction at moving points, and the inertia forces of the
accelerations); at speed, only the changes of the velocity-product terms
are left out, which the tests bound.
"""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest
from conftest import JOINT_TYPES, random_chain

import flexmb as fm
from flexmb.assembly import geometric_stiffness, mass_matrix
from flexmb.system import System


def d_accel_dx(system, t, x, xd, h=1e-6):
    """Central differences of the accelerations with respect to the coordinates."""
    n = system.n_coords
    J = np.zeros((n, n))
    for i in range(n):
        e = np.zeros(n)
        e[i] = h
        J[:, i] = (system.accelerations(t, x + e, xd) - system.accelerations(t, x - e, xd)) / (2 * h)
    return J


def geometric(system, t, x, xd):
    kin = system.kinematics(t, x, xd)
    loads = system.forces.loads(kin)
    xdd = system.accelerations(t, x, xd)
    return mass_matrix(kin), geometric_stiffness(kin, xdd, loads.force[:-1], loads.torque[:-1])


@pytest.mark.parametrize("seed", range(6))
def test_geometric_stiffness_is_exact_at_rest(seed):
    rng = np.random.default_rng(seed)
    types = list(rng.choice(np.array(JOINT_TYPES + [fm.PlanarRevolute], dtype=object), 7)) if seed % 2 else None
    system = random_chain(rng, types=types, branch=bool(seed % 3)).build()
    x = rng.normal(scale=0.5, size=system.n_coords)
    xd = np.zeros(system.n_coords)
    A, G = geometric(system, 0.0, x, xd)
    fd = d_accel_dx(system, 0.0, x, xd)
    # d xdd / dx = A^-1 G with no coordinate springs
    assert np.abs(A @ fd - G).max() <= 1e-6 * max(1.0, np.abs(G).max())
    # and it is not trivially zero where the accelerations do depend on the configuration
    # (a chain of free joints under gravity does not: its G vanishes)
    if np.abs(A @ fd).max() > 1e-3:
        assert np.abs(G).max() > 1e-3


@pytest.mark.parametrize("seed", range(3))
def test_geometric_stiffness_at_speed_leaves_out_only_velocity_terms(seed):
    rng = np.random.default_rng(10 + seed)
    system = random_chain(rng).build()
    x = rng.normal(scale=0.5, size=system.n_coords)
    A, G = geometric(system, 0.0, x, np.zeros(system.n_coords))
    for speed in (1e-2, 1e-1):
        xd = speed * rng.normal(size=system.n_coords)
        A, G = geometric(system, 0.0, x, xd)
        miss = np.abs(A @ d_accel_dx(system, 0.0, x, xd) - G).max() / np.abs(G).max()
        # the velocity-product terms grow as speed^2
        assert miss < 20 * speed**2


def spatial_beam(n_segments):
    """The B2 beam of BENCHMARKS.md: torsion and two bendings per segment, an offset tip mass."""
    model = fm.Model("B2")
    beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material(70e9, 2700.0, 0.33),
                           n_segments, keep=("torsion", "bend_y", "bend_z"), damping=7.7398e-4)
    tip = fm.RigidBody("tip", 0.05, (0.0, 0.0, 0.0), (0.0, 0.02, 0.0))
    model.add(fm.Fixed("clamp", model.ground, beam), fm.Fixed("tip_mount", beam, tip, parent_point=(1.0, 0.0, 0.0)),
              fm.Gravity((0.0, -0.6 * 9.81, -0.8 * 9.81)))
    return model.build()


def test_state_jacobian_of_the_spatial_beam():
    system = spatial_beam(6)
    n = system.n_coords
    res = fm.simulate(system, 0.03, rtol=1e-8, n_out=2, method="Radau")
    x, xd = res.x[-1], res.xd[-1]
    fd = d_accel_dx(system, 0.03, x, xd, h=1e-7)
    full = system.state_jacobian(0.03, x, xd)[n:, :n]
    springs_only = system.state_jacobian(0.03, x, xd, geometric=False)[n:, :n]
    err_full = np.abs(full - fd).max()
    err_springs = np.abs(springs_only - fd).max()
    # the geometric terms matter (torsion has a tiny inertia) and G captures them
    assert err_springs > 1e-3 * np.abs(fd).max()
    assert err_full < 1e-4 * err_springs


def test_the_jacobian_saves_newton_iterations(monkeypatch):
    """Radau on the spatial beam: with G, Newton converges where the springs-only Jacobian stalls."""
    counts = {}
    for geometric in (True, False):
        system = spatial_beam(6)
        if not geometric:
            monkeypatch.setattr(system, "state_jacobian", partial(System.state_jacobian, system, geometric=False))
        res = fm.simulate(system, 0.1, rtol=1e-6, method="Radau", n_out=2)
        assert res.status == "finished"
        counts[geometric] = (res.n_rhs, res.n_jac)
    # counts, not times: fewer evaluations and far fewer Jacobians
    assert counts[True][0] < counts[False][0]
    assert counts[True][1] < 0.75 * counts[False][1]


@pytest.mark.parametrize("frame", ["ground", "body"])
def test_state_jacobian_turns_constant_loads_with_their_bodies(frame):
    """A constant force off the mass centre (and a body-axis torque) turns with its body: exact at rest."""
    model = fm.Model()
    box = fm.RigidBody.box("box", 2.0, (1.0, 0.2, 0.1), com=(0.5, 0.0, 0.0))
    arm = fm.FlexibleBody("arm", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(), 4,
                          keep=("bend_y", "bend_z"))
    model.add(fm.Spherical("ball", model.ground, box), fm.Fixed("clamp", box, arm, parent_point=(1.0, 0.0, 0.0)),
              fm.PointForce("tip", arm, (3.0, -20.0, 40.0), point=(1.0, 0.01, 0.0), frame=frame),
              fm.PointForce("side", box, (0.0, 5.0, -8.0), point=(0.3, 0.1, 0.05), frame=frame),
              fm.BodyTorque("twist", box, (0.5, 0.2, -0.3), frame=frame))
    system = model.build()
    n = system.n_coords
    rng = np.random.default_rng(3)
    x, xd = 0.2 * rng.standard_normal(n), np.zeros(n)
    fd = d_accel_dx(system, 0.0, x, xd)
    J = system.state_jacobian(0.0, x, xd)[n:, :n]
    assert np.abs(J - fd).max() < 1e-6 * np.abs(fd).max()
