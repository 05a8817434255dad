"""The planar geometric stiffness and the planar open tree's state Jacobian (flexmb.kernels.planar_tangent).

Two independent checks of G on 3-vectors:

* the spatial one: :func:`flexmb.kernels.tangent.geometric_stiffness` of the
  same state (the model built with ``planar=False``), to 1e-12 of its largest
  entry, at random states and accelerations, on B1 N = 8 / 32, B6 N = 8 (its
  tree: G does not involve the rows) and the README's pendulum;
* a central difference of the planar right-hand side
  (:func:`flexmb.kernels.planar.planar_open_rhs_into`) at rest, where the
  velocity-product terms G leaves out vanish: ``G = A dxdd/dx + K``, with
  springs of moderate stiffness, off-rest lengths and a tilted gravity put
  into a copy of the planar data (so that every model has accelerations and
  loads to turn), to 1e-6 of G's largest entry (the difference's error).

Then the whole J of :func:`flexmb.kernels.tree_jacobian.tree_state_jacobian`,
which takes the planar route for a planar packed model: against the difference
of the planar right-hand side at rest, and against the spatial route's J at
B1 N = 8, 32 and the pendulum, to 1e-12 of J's largest entry where n <= 8 and,
entry by entry, to 1e-12 of the componentwise round-off scale of ``A^-1``
(``|A^-1| |A| |A^-1|``, times ``|G - K|`` or C) everywhere: at N = 32 A's
condition number is ~4e6 and the two routes' round-off reaches 1-4e-12 of
J's largest entry (the dense route's own distance to the spatial one is
1-3e-11), 1e-14 of that scale.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import flexmb as fm
from flexmb.kernels.dynamics import composite_inertias, spatial_inertias
from flexmb.kernels.loads import apply_load_tables
from flexmb.kernels.packing import is_planar, unpack, unpack_planar
from flexmb.kernels.planar import kinematics, planar_open_rhs_into, planar_work_size
from flexmb.kernels.planar_tangent import (planar_geometric_stiffness, planar_gravity_loads,
                                           planar_tree_jacobian_parts)
from flexmb.kernels.tangent import geometric_stiffness
from flexmb.kernels.tree import tree_state
from flexmb.kernels.tree_jacobian import tree_state_jacobian
from flexmb.system.tangent import NewtonPreconditioner

BENCH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks")
sys.path.insert(0, BENCH)
scenes = pytest.importorskip("scenes")


def _readme_pendulum():
    """The README's model in a few lines: a bar on a pin about z, gravity along -y."""
    model = fm.Model("pendulum")
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)), fm.Gravity((0.0, -9.81, 0.0)))
    return model


MODELS = {"b1_8": lambda: scenes.b1(8), "b1_32": lambda: scenes.b1(32),
          "b6_8": lambda: scenes.b6(damped=True, n_segments=8)[0], "pendulum": _readme_pendulum}


def _spatial_G(system, x, xd, xdd):
    """The spatial kernel's G at ``(x, xd)`` and accelerations ``xdd`` (as tree_state_jacobian calls it)."""
    tree, tables, _ = unpack(system._packed)
    n = x.shape[0]
    R, origin, r, omega, v, alpha, acc, _, Sw, Sv = tree_state(tree, x, xd)
    nb = tree.parent.shape[0]
    force, torque = np.zeros((nb + 1, 3)), np.zeros((nb + 1, 3))
    apply_load_tables(tables, tree.mass, R, origin, r, omega, v, x, xd, force, torque, np.zeros(n), np.zeros(0))
    Iw, spatial = spatial_inertias(R, r, tree.mass, tree.inertia)
    return geometric_stiffness(tree.parent, tree.coord_start, tree.coord_body, tree.coord_kind, Sw, Sv, xdd, r, omega,
                               v, alpha, acc, Iw, tree.mass, composite_inertias(tree.parent, spatial), force, torque)


def _planar_G(ints, floats, x, xd, xdd):
    """The planar kernel's G at ``(x, xd)`` and accelerations ``xdd``, gravity its applied loads."""
    nb = ints[0].shape[0]
    Kin = np.empty((nb + 1, 20))
    kinematics(ints, floats, x, xd, Kin)
    force, torque = np.empty((nb, 2)), np.empty(nb)
    planar_gravity_loads(floats, force, torque)
    return planar_geometric_stiffness(ints, floats, Kin, xdd, force, torque)


@pytest.mark.parametrize("name", list(MODELS))
def test_the_planar_G_is_the_spatial_one(name):
    planar, spatial = MODELS[name]().build(), MODELS[name]().build(planar=False)
    assert planar.planar and is_planar(planar._packed) and not is_planar(spatial._packed)
    ints, floats = unpack_planar(planar._packed)
    n = planar.n_speeds
    rng = np.random.default_rng(31)
    for _ in range(4):
        x, xd, xdd = rng.normal(0.0, 0.3, n), rng.normal(0.0, 2.0, n), rng.normal(0.0, 10.0, n)
        old = _spatial_G(spatial, x, xd, xdd)
        new = _planar_G(ints, floats, x, xd, xdd)
        assert np.max(np.abs(old)) > 0
        assert np.max(np.abs(new - old)) <= 1e-12 * np.max(np.abs(old))


def _sprung_copy(system, rng):
    """A copy of the packed planar model with moderate springs, off-rest lengths and a tilted gravity."""
    packed = tuple(b.copy() for b in system._packed)
    ints, floats = unpack_planar(packed)
    n = system.n_speeds
    cols = np.arange(n)
    # every coordinate gets a spring of its own: cols are the packed springs' columns, one per coordinate here
    if ints[3].shape[0] == n and np.array_equal(np.sort(ints[3]), cols):
        floats[6][:] = rng.uniform(0.5, 2.0, n)
        floats[8][:] = rng.normal(0.0, 0.3, n)
    floats[5][:] = (3.0, -9.81)
    stiffness = np.zeros(n)
    np.add.at(stiffness, ints[3], floats[6])
    damping = np.zeros(n)
    np.add.at(damping, ints[3], floats[7])
    return packed, ints, floats, stiffness, damping


def _planar_rate(packed, y, n):
    """The planar open tree's state rate at ``y`` (its compiled right-hand side)."""
    nb = unpack_planar(packed)[0][0].shape[0]
    ydot = np.empty(2 * n)
    assert planar_open_rhs_into(packed, y, n, np.zeros(n), ydot, np.empty(planar_work_size(nb, n))) == -1
    return ydot


def _difference(packed, y, n, h=1e-6):
    """Central difference of the planar state rate in every component of ``y``."""
    D = np.empty((2 * n, 2 * n))
    for j in range(2 * n):
        yp, ym = y.copy(), y.copy()
        yp[j] += h
        ym[j] -= h
        D[:, j] = (_planar_rate(packed, yp, n) - _planar_rate(packed, ym, n)) / (2 * h)
    return D


@pytest.mark.parametrize("name", list(MODELS))
def test_the_planar_G_and_J_are_the_planar_rhs_difference(name):
    system = MODELS[name]().build()
    rng = np.random.default_rng(28)
    packed, ints, floats, stiffness, damping = _sprung_copy(system, rng)
    n = system.n_speeds
    y = np.concatenate([rng.normal(0.0, 0.3, n), np.zeros(n)])  # at rest: no velocity-product terms
    D = _difference(packed, y, n)
    P, G, bad = planar_tree_jacobian_parts(ints, floats, y, n)
    assert bad == -1 and np.max(np.abs(G)) > 0
    by_difference = np.linalg.inv(P) @ D[n:, :n] + np.diag(stiffness)
    assert np.max(np.abs(G - by_difference)) <= 1e-6 * np.max(np.abs(G))
    assert n == 1 or np.max(np.abs(G - G.T)) > 1e-3 * np.max(np.abs(G))  # not symmetric: inertia terms in it
    J = np.full((2 * n, 2 * n), np.nan)
    assert tree_state_jacobian(packed, y, n, stiffness, damping, J) == (0, -1)
    assert np.max(np.abs(J - D)) <= 1e-6 * np.max(np.abs(J))


@pytest.mark.parametrize("name", ["b1_8", "b1_32", "pendulum"])
def test_the_planar_J_is_the_spatial_one(name):
    planar, spatial = MODELS[name]().build(), MODELS[name]().build(planar=False)
    assert planar._packed_open is not None and spatial._packed_open is not None
    n = planar.n_speeds
    K, C = NewtonPreconditioner.diagonal_terms(planar)
    rng = np.random.default_rng(11)
    for _ in range(4):
        y = np.concatenate([rng.normal(0.0, 0.05, n), rng.normal(0.0, 1.0, n)])
        old, new = np.full((2 * n, 2 * n), np.nan), np.full((2 * n, 2 * n), np.nan)
        assert tree_state_jacobian(spatial._packed_open, y, n, K, C, old) == (0, -1)
        assert tree_state_jacobian(planar._packed_open, y, n, K, C, new) == (0, -1)
        assert np.array_equal(new[:n], old[:n])
        P, G, _ = planar_tree_jacobian_parts(*unpack_planar(planar._packed), y, n)
        skeel = np.abs(P) @ np.abs(np.linalg.inv(P)) @ np.abs(P)  # round-off scale of A^-1, entry by entry
        scales = skeel @ np.abs(G - np.diag(K)), skeel * C[None, :]
        for block, scale in zip((np.s_[n:, :n], np.s_[n:, n:]), scales):
            assert np.all(np.abs(new[block] - old[block]) <= 1e-12 * scale)
        if n <= 8:
            assert np.max(np.abs(new - old)) <= 1e-12 * np.max(np.abs(old))


def test_a_planar_freedom_without_mass_is_reported():
    system = _readme_pendulum().build()
    packed = tuple(b.copy() for b in system._packed)
    _, floats = unpack_planar(packed)
    floats[3][:] = 0.0  # the bar's mass and inertia in the planar data: its pin moves nothing
    floats[4][:] = 0.0
    J = np.zeros((2, 2))
    assert tree_state_jacobian(packed, np.zeros(2), 1, np.zeros(1), np.zeros(1), J) == (1, 0)


def test_the_planar_G_at_the_loops_accelerations():
    # what loop_state_jacobian passes the spatial G: the constrained solve's accelerations, the applied loads only
    planar, spatial = MODELS["b6_8"]().build(), MODELS["b6_8"]().build(planar=False)
    res = fm.simulate(spatial, 0.02, method="CVODE_BDF", rtol=1e-7, n_out=3, progress=False,
                      positions=scenes.b6(damped=True, n_segments=8)[1])
    n = spatial.n_speeds
    ints, floats = unpack_planar(planar._packed)
    for k in range(1, len(res.t)):
        x, xd = res.x[k], res.xd[k]
        xdd = spatial.state_rate(res.t[k], np.concatenate([x, xd]))[n:]
        old, new = _spatial_G(spatial, x, xd, xdd), _planar_G(ints, floats, x, xd, xdd)
        assert np.max(np.abs(old)) > 0
        assert np.max(np.abs(new - old)) <= 1e-12 * np.max(np.abs(old))
