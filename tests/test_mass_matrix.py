"""Tests of the generalized mass matrix A (eq. 2) and the force array f (eqs. 3, 5).

What is checked
---------------
For random open trees mixing every joint type (several seeds, branched and
unbranched):

* ``A = mass_matrix(kin)`` equals the Hessian of the kinetic energy with
  respect to the speeds, computed without ``V`` or ``W``: body velocities
  come from finite differences of the mass-centre positions
  ``origin + R com`` and of the rotations ``R`` (``omega`` = vee of
  ``Rdot R^T``) along ``x + u t``, the kinetic energy
  ``KE(u) = 1/2 sum m |v|^2 + 1/2 omega^T R I R^T omega`` uses the masses,
  central inertias and mass centres of the body objects, and since ``KE``
  is quadratic in ``u`` the Hessian follows by polarization:
  ``A_ii = 2 KE(e_i)``, ``A_ij = KE(e_i + e_j) - KE(e_i) - KE(e_j)``;
* ``A`` is symmetric and positive definite (Cholesky), and
  ``kin.kinetic_energy() = xd^T A xd / 2``;
* for a conservative model (gravity, undamped joint springs and undamped
  point-to-point springs with and without rest length) the generalized
  active force equals ``-dU/dx`` (``U = forces.potential_energy``) at
  ``xd = 0`` and at random speeds; with dampers added the extra force only
  dissipates: ``F_damp . xd = -sum c_j qd_j^2 - sum c (dl/dt)^2``;
* the force array satisfies Lagrange's equations,
  ``f = F - (d/dt A) xd + dT/dx`` with ``T = xd^T A(x) xd / 2``, both
  derivatives by finite differences of ``A``; at ``xd = 0``, ``f = F``.

Tolerances
----------
Fourth-order central differences with ``h = 1e-3`` have truncation
``~1e-12`` and round-off ``~eps |f| / h ~ 1e-13`` relative; results are
asserted to ``1e-8`` relative to the largest entry (observed errors are
below ``1e-10``). Symmetry and the energy identity are exact up to
round-off and asserted to ``1e-13``/``1e-12``.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import JOINT_TYPES, random_chain

import flexmb as fm
from flexmb.assembly import mass_matrix

H = 1e-3
OFFSETS = (-2, -1, 1, 2)
D1 = np.array([1.0, -8.0, 8.0, -1.0]) / (12.0 * H)
TOL = 1e-8


def vee(S):
    A = 0.5 * (S - np.swapaxes(S, -1, -2))
    return np.stack([A[..., 2, 1], A[..., 0, 2], A[..., 1, 0]], axis=-1)


def fd(system, x, u, fn, t=0.0):
    """d/ds fn(kinematics at x + u s) at s = 0 (fourth order)."""
    return sum(w * np.asarray(fn(system.kinematics(t, x + o * H * u, u)))
               for w, o in zip(D1, OFFSETS))


def assert_close(actual, expected, tol, what=""):
    scale = max(1.0, float(np.max(np.abs(expected), initial=0.0)))
    err = float(np.max(np.abs(np.asarray(actual) - np.asarray(expected)), initial=0.0))
    assert err <= tol * scale, f"{what}: max error {err:.3e} > {tol:.1e} * {scale:.3g}"


def chain(seed):
    rng = np.random.default_rng(seed)
    if seed % 2:
        types = list(rng.choice(np.array(JOINT_TYPES + [fm.PlanarRevolute], dtype=object), 8))
        model = random_chain(rng, types=types, branch=bool(seed % 3))
    else:
        model = random_chain(rng)
    return model, rng


SEEDS = [0, 1, 2, 3, 5]


class IndependentEnergy:
    """Kinetic energy from differenced positions/rotations and the body objects' data."""

    def __init__(self, system, x):
        self.system, self.x = system, x
        bodies = system.topology.bodies
        self.mass = np.array([b.mass for b in bodies])
        self.inertia = np.array([b.inertia for b in bodies])
        self.com = np.array([b.com for b in bodies])
        self.R = system.kinematics(0.0, x, np.zeros_like(x)).R[:-1]

    def _pose(self, kin):
        R = kin.R[:-1]
        return np.concatenate([(kin.origin[:-1] + np.einsum("kij,kj->ki", R, self.com)).ravel(), R.ravel()])

    def __call__(self, u):
        nb = len(self.mass)
        d = fd(self.system, self.x, u, self._pose)
        v = d[: 3 * nb].reshape(nb, 3)
        R_dot = d[3 * nb:].reshape(nb, 3, 3)
        w = vee(R_dot @ np.swapaxes(self.R, 1, 2))
        I_world = self.R @ self.inertia @ np.swapaxes(self.R, 1, 2)
        return 0.5 * np.sum(self.mass * np.sum(v * v, axis=1)) + 0.5 * np.einsum("ki,kij,kj->", w, I_world, w)


@pytest.mark.parametrize("seed", SEEDS)
def test_mass_matrix_is_kinetic_energy_hessian(seed):
    model, rng = chain(seed)
    system = model.build()
    n = system.n_coords
    assert n > 0
    x = rng.uniform(-1, 1, n)
    xd = rng.normal(size=n)
    kin = system.kinematics(0.0, x, xd)
    A = mass_matrix(kin)
    assert A.shape == (n, n)

    ke = IndependentEnergy(system, x)
    E = np.eye(n)
    diag = np.array([ke(E[i]) for i in range(n)])
    hess = np.diag(2.0 * diag)
    for i in range(n):
        for j in range(i + 1, n):
            hess[i, j] = hess[j, i] = ke(E[i] + E[j]) - diag[i] - diag[j]
    assert_close(A, hess, TOL, "A vs KE Hessian")
    # and the quadratic form at an arbitrary speed
    assert_close(0.5 * xd @ A @ xd, ke(xd), TOL, "KE(xd)")


@pytest.mark.parametrize("seed", SEEDS)
def test_mass_matrix_symmetric_positive_definite(seed):
    model, rng = chain(seed)
    system = model.build()
    n = system.n_coords
    for _ in range(3):
        x = rng.uniform(-1.5, 1.5, n)
        xd = rng.normal(size=n)
        kin = system.kinematics(0.0, x, xd)
        A = mass_matrix(kin)
        scale = np.abs(A).max()
        assert np.max(np.abs(A - A.T)) <= 1e-13 * scale
        L = np.linalg.cholesky(0.5 * (A + A.T))  # raises if not positive definite
        assert np.all(np.diag(L) > 0)
        ke = kin.kinetic_energy()
        assert ke > 0
        assert abs(ke - 0.5 * xd @ A @ xd) <= 1e-12 * max(1.0, ke)
        # equations() hands back the same matrix
        np.testing.assert_array_equal(system.equations(0.0, x, xd)[1], A)


def test_mass_matrix_of_single_bodies():
    """Hand-computed A: a slider has A = m; a free body at x = 0 has A = diag(m I, I_c)."""
    model = fm.Model()
    b = fm.RigidBody("b", mass=2.5, inertia=(0.3, 0.4, 0.5), com=(0.1, -0.2, 0.3))
    model.add(fm.Prismatic("p", model.ground, b, axis=(1.0, 2.0, 2.0)))
    system = model.build()
    A = mass_matrix(system.kinematics(0.0, np.array([0.7]), np.zeros(1)))
    assert_close(A, [[2.5]], 1e-15, "prismatic")

    model = fm.Model()
    b = fm.RigidBody("b", mass=2.0, inertia=(0.3, 0.4, 0.5))
    model.add(fm.Free("f", model.ground, b))
    system = model.build()
    A = mass_matrix(system.kinematics(0.0, np.zeros(6), np.zeros(6)))
    expected = np.zeros((6, 6))
    expected[:3, :3] = 2.0 * np.eye(3)
    expected[3:, 3:] = np.diag([0.3, 0.4, 0.5])  # Bryant rates = body rates at zero angles
    assert_close(A, expected, 1e-14, "free body")


def test_mass_matrix_without_coordinates():
    """A model whose bodies are all welded has n = 0: A is 0 x 0 and the equations still evaluate."""
    model = fm.Model()
    b, c = fm.RigidBody("b", mass=1.0, inertia=(1.0, 1.0, 1.0)), fm.RigidBody("c", mass=1.0, inertia=(1.0, 1.0, 1.0))
    model.add(fm.Fixed("f", model.ground, b, parent_point=(1, 0, 0)), fm.Fixed("g", b, c, parent_point=(0, 1, 0)),
              fm.Gravity((0.0, -9.81, 0.0)))
    system = model.build()
    z = np.zeros(0)
    kin = system.kinematics(0.0, z, z)
    assert mass_matrix(kin).shape == (0, 0)
    assert system.accelerations(0.0, z, z).shape == (0,)


# -- forces ----------------------------------------------------------------

def springy(seed, damped=False):
    """A random tree with gravity, joint springs on every joint and three point springs."""
    model, rng = chain(seed)
    def c():  # always draw, so that damped and undamped models share their geometry
        return rng.uniform(0.5, 2.0) * damped
    for j in list(model.joints):
        if j.n_coords:
            model.add(fm.JointSpringDamper(f"js-{j.name}", j, stiffness=rng.uniform(1, 5, j.n_coords),
                                           damping=[c() for _ in range(j.n_coords)],
                                           rest=rng.normal(size=j.n_coords)))
    bodies = model.bodies
    b1, b2, b3 = (bodies[i] for i in rng.choice(len(bodies), 3, replace=False))
    model.add(
        fm.SpringDamper("s-rest", b1, rng.normal(size=3), b2, rng.normal(size=3), stiffness=7.0,
                        damping=c(), rest_length=0.4),
        fm.SpringDamper("s-zero", b2, rng.normal(size=3), b3, rng.normal(size=3), stiffness=3.0, damping=c()),
        fm.SpringDamper("s-ground", model.ground, rng.normal(size=3), b3, rng.normal(size=3), stiffness=5.0,
                        damping=c(), rest_length=1.1),
    )
    return model, rng


@pytest.mark.parametrize("seed", SEEDS)
def test_conservative_force_is_minus_potential_gradient(seed):
    model, rng = springy(seed)
    system = model.build()
    n = system.n_coords
    x = rng.uniform(-1, 1, n)
    gradU = np.array([fd(system, x, e, system.forces.potential_energy) for e in np.eye(n)])
    assert np.abs(gradU).max() > 1.0  # the check is not vacuous
    for xd in (np.zeros(n), rng.normal(size=n)):
        kin = system.kinematics(0.0, x, xd)
        F = system.forces.active_force(kin)
        assert_close(F, -gradU, TOL, "F = -dU/dx")
    # at zero speed there are no velocity-dependent inertia forces: f = F
    kin0 = system.kinematics(0.0, x, np.zeros(n))
    assert_close(system.forces.force_array(kin0), system.forces.active_force(kin0), 1e-14, "f(xd=0)")


@pytest.mark.parametrize("seed", SEEDS[:3])
def test_dampers_only_dissipate(seed):
    damped, rng = springy(seed, damped=True)
    undamped, _ = springy(seed, damped=False)
    sd, su = damped.build(), undamped.build()
    n = sd.n_coords
    x = rng.uniform(-1, 1, n)
    xd = rng.normal(size=n)
    kd, ku = sd.kinematics(0.0, x, xd), su.kinematics(0.0, x, xd)
    F_damp = sd.forces.active_force(kd) - su.forces.active_force(ku)
    power = 0.0
    for e in damped.forces:
        if isinstance(e, fm.JointSpringDamper):
            s = sd.coordinate_slice(e.joint)
            power -= np.sum(e.damping * xd[s] ** 2)
        elif isinstance(e, fm.SpringDamper):
            def length(k, e=e):
                i, j = k.index(e.body1), k.index(e.body2)
                return np.linalg.norm(k.point_position(j, e.point2) - k.point_position(i, e.point1))
            power -= e.damping * fd(sd, x, xd, length) ** 2
    assert power < -1e-3
    assert abs(F_damp @ xd - power) <= TOL * max(1.0, abs(power))


@pytest.mark.parametrize("seed", SEEDS)
def test_force_array_satisfies_lagrange_equations(seed):
    """f = F - (d/dt A) xd + dT/dx: Kane's inertia forces are Lagrange's."""
    model, rng = springy(seed, damped=True)
    system = model.build()
    n = system.n_coords
    x = rng.uniform(-1, 1, n)
    xd = rng.normal(size=n)
    kin = system.kinematics(0.0, x, xd)
    F = system.forces.active_force(kin)
    f = system.forces.force_array(kin)
    A_dot_xd = fd(system, x, xd, mass_matrix) @ xd
    dT_dx = np.array([0.5 * xd @ fd(system, x, e, mass_matrix) @ xd for e in np.eye(n)])
    assert np.abs(F - f).max() > 1e-2  # inertia forces are really present
    assert_close(f, F - A_dot_xd + dT_dx, TOL, "Lagrange")
