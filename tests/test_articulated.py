"""The articulated-body recursion of open trees against the dense Cholesky path (an independent formulation of eq. 2)."""

import numpy as np
import pytest
from conftest import JOINT_TYPES, random_chain
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from strategies import build_tree, states, tree_specs

import flexmb as fm
from flexmb.assembly import mass_matrix


def _pair(model):
    return model.build(sparse=False), model.build(sparse=True)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(specs=tree_specs(max_joints=6), data=st.data())
def test_random_trees_sparse_equals_dense(specs, data):
    dense, sparse = _pair(build_tree(specs)[0])
    assert not dense.articulated and sparse.articulated
    x, xd = data.draw(states(dense.n_coords, scale=1.2))
    a_d = dense.accelerations(0.3, x, xd)
    a_s = sparse.accelerations(0.3, x, xd)
    A = mass_matrix(dense.kinematics(0.3, x, xd))
    # both solve A xdd = f: compare through the residual scale of A
    scale = np.abs(A).max() * max(np.abs(a_d).max(), 1.0)
    assert np.abs(A @ (a_s - a_d)).max() <= 1e-10 * scale


@pytest.mark.parametrize("branch", [False, True])
def test_chains_of_all_joint_types(rng, branch):
    dense, sparse = _pair(random_chain(rng, JOINT_TYPES * 3, branch=branch))
    n = dense.n_coords
    x, xd = 0.4 * rng.normal(size=n), rng.normal(size=n)
    a_d, a_s = dense.accelerations(0.0, x, xd), sparse.accelerations(0.0, x, xd)
    assert np.abs(a_s - a_d).max() <= 1e-9 * np.abs(a_d).max()


def _beam(n_segments):
    """The B2 strip: torsion and both bendings, tilted gravity."""
    model = fm.Model("beam")
    beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material(70e9, 2700.0, 0.33),
                           n_segments, keep=("torsion", "bend_y", "bend_z"), damping=7.7e-4)
    model.add(fm.Fixed("clamp", model.ground, beam), fm.Gravity((0.0, -5.886, -7.848)))
    return model


def test_flexible_beam_run_is_the_same():
    """A 3-angle beam over 20 ms: same trajectory, Jacobian and step sequence within the conditioning."""
    dense, sparse = _pair(_beam(12))
    runs = [fm.simulate(s, 0.02, method="Radau", rtol=1e-6, n_out=5) for s in (dense, sparse)]
    assert runs[0].status == runs[1].status == "finished"
    assert np.abs(runs[0].x - runs[1].x).max() <= 1e-9


def test_default_is_the_recursion_for_open_trees_only():
    from conftest import fourbar

    assert _beam(4).build().articulated and _beam(101).build().articulated
    assert not fourbar().build().articulated


def test_sparse_refused_with_loops():
    from conftest import fourbar

    with pytest.raises(fm.ModelError, match="sparse=True needs an open tree"):
        fourbar().build(sparse=True)


def test_point_mass_on_a_pin_is_a_clear_error():
    model = fm.Model("massless")
    bar = fm.RigidBody("bar", 1.0, np.diag([0.1, 0.1, 0.1]))
    tip = fm.RigidBody("tip", 1.0, (0.0, 0.0, 0.0))  # a point mass pinned at its centre: no inertia on tip_pin
    model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)))
    model.add(fm.Revolute("tip_pin", bar, tip, parent_point=(1, 0, 0), axis=(0, 0, 1)))
    # refused at build time, naming the joint, the body and the axis (issue #32)
    with pytest.raises(fm.ModelError, match=r"joint 'tip_pin' \(Revolute\) turns body 'tip' about the axis "
                                            r"\[0.0, 0.0, 1.0\].*no inertia"):
        model.build(sparse=True)
    # and the recursion's own diagnosis, for what the build cannot see, says the same at run time
    system = fm.System(model, sparse=True)
    with pytest.raises(fm.AssemblyError, match="singular at t = 0 s: joint 'tip_pin' moves no mass"):
        system.accelerations(0.0, np.zeros(2), np.zeros(2))


def test_non_finite_state_is_refused():
    """A non-finite state given to the public method is bad input, named before any kernel runs (#33)."""
    system = _beam(3).build(sparse=True)
    x = np.zeros(system.n_coords)
    x[1] = np.nan
    with pytest.raises(fm.ModelError, match=r"System.accelerations: x must be finite, got x\[1\] = nan"):
        system.accelerations(0.0, x, np.zeros_like(x))


def test_mass_times_and_armature_against_dense(rng):
    """``A u`` in O(n), and ``(A + diag(armature)) z = r`` by the recursion, against the dense A."""
    from flexmb.kernels.articulated import articulated_accelerations, mass_times

    system = random_chain(rng, JOINT_TYPES * 2, branch=True).build(sparse=False)
    n = system.n_coords
    kin = system.kinematics(0.0, 0.4 * rng.normal(size=n), rng.normal(size=n))
    topo = system.topology
    A = mass_matrix(kin)
    u = rng.normal(size=n)
    Au = mass_times(topo.parent, topo.coord_start, topo.coord_body, kin.spatial_inertia(), kin.Sw, kin.Sv, u)
    np.testing.assert_allclose(Au, A @ u, rtol=1e-12, atol=1e-12 * np.abs(A).max() * np.abs(u).max())
    armature = rng.uniform(0.0, 5.0, size=n)
    zeros = np.zeros((topo.n_bodies + 1, 3))
    z, bad = articulated_accelerations(topo.parent, topo.coord_start, kin.spatial_inertia(), kin.Sw, kin.Sv, kin.r,
                                       zeros, zeros, u, armature)
    assert bad == -1
    np.testing.assert_allclose((A + np.diag(armature)) @ z, u, rtol=0, atol=1e-10 * np.abs(u).max())


def test_newton_preconditioner_solves_the_spring_part_exactly(rng):
    """(I - gamma J0) z = r with J0 = [[0, I], [-A^-1 K, -A^-1 C]] (the diagonal springs and dampers), in O(n)."""
    system = _beam(5).build()
    n = system.n_coords
    x, xd = 0.05 * rng.normal(size=n), rng.normal(size=n)
    pre = system.newton_preconditioner()
    pre.setup(0.1, x, xd)
    A = mass_matrix(system.kinematics(0.1, x, xd))
    K, C = np.diag(pre.stiffness), np.diag(pre.damping)
    assert np.all(pre.stiffness > 0) and np.all(pre.damping > 0)  # every coordinate is a segment joint
    J0 = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(A, K), -np.linalg.solve(A, C)]])
    gamma = 3e-4
    r = rng.normal(size=2 * n)
    z1, z2 = pre.solve(r[:n], r[n:], gamma)
    np.testing.assert_allclose((np.eye(2 * n) - gamma * J0) @ np.concatenate([z1, z2]), r, rtol=0, atol=1e-9)


def test_newton_preconditioner_needs_an_open_tree():
    from conftest import fourbar

    with pytest.raises(fm.ModelError, match="needs an open tree"):
        fourbar().build().newton_preconditioner()


def test_fastest_rates_by_iteration_match_the_dense_eigenvalues(rng):
    """Large open trees estimate the highest frequency and damping rate with O(n) products (Arnoldi)."""
    system = _beam(20).build()
    n = system.n_coords
    x = 0.01 * rng.normal(size=n)
    dense = np.asarray(system.state_jacobian(0.0, x, 0 * x, geometric=False))
    stiff = np.sqrt(np.max(np.linalg.eigvals(-dense[n:, :n]).real))
    damp = np.max(np.abs(np.linalg.eigvals(-dense[n:, n:])))
    w, c = system._rates_iterative(0.0, x, 0 * x)
    assert w == pytest.approx(stiff, rel=1e-3) and c == pytest.approx(damp, rel=1e-3)
