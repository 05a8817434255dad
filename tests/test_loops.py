"""The 'articulated' strategy: loops closed through the articulated-body recursion (flexmb.kernels.loops).

What is checked
---------------
* On every looped model of the tests (planar four-bar, the four-bar with a
  full revolute cut (zero rows), Bricard's linkage (Gruebler zero, one
  freedom: rows dependent on the manifold only), the flattened
  parallelogram and the chain of two (away from their flattened, singular
  positions: there the filters of the two strategies, each in its own
  metric, differ by design; tests/test_hard_cases.py runs this strategy
  through them), the flexible wiper (massless spins
  closed by its loops: A singular), B6 and B7 with N = 4 and 40), calibrated
  as a run calibrates them, at the assembled state and at states off the
  constraint manifold: the state rate and the reactions equal those of the
  SVD strategy (the dense reduced equations, eqs. 36-39) to 1e-10, and the
  mass-orthogonal speed projection equals the SVD's. Off the manifold
  Bricard's redundant row looks independent by the size of the violation;
  both strategies drop one direction (the SVD the smallest singular one,
  this one the row of the smallest pivot), and gamma, inconsistent by the
  speeds' violation, is met in the least-squares sense by the one and
  exactly on the rows kept by the other, so there they agree to the size
  of the violation (positions and speeds 1e-9 off: 1e-7).
* The rank it keeps equals psi's (redundant rows dropped), at the
  assembled state and under the calibrated rank limit.
* Simulations with it equal the SVD's to 1e-9 at tight tolerances
  (positions, speeds, reactions) and keep the loops closed.
* K's layout: B7's chain of loops is banded with a band that does not grow
  with N; a model with one subtree has one dense block.
* A freedom that moves no mass and that no loop fixes is refused with a
  message naming the joint.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import flexmb as fm
from conftest import fourbar, fourbar_initial
from flexmb.simulate import _calibrated

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "benchmarks"))

import scenes  # noqa: E402
import test_hard_cases as hc  # noqa: E402


def _wiper():
    pytest.importorskip("flexmb_friction")
    from flexmb.scenes.wiper import WiperOptions, wiper

    return wiper(WiperOptions(flexible=True, n_segments=6))


def _b7(n):
    model, initial = scenes.b7(n)
    return model, initial


def _driven_hub():
    """A clamped beam on a driven hub about its own root bending axis: A is singular, only the driver fixes it."""
    model = fm.Model("driven hub")
    beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.steel(), 4,
                           keep=("bend_z",))
    hub = fm.Revolute("hub", model.ground, beam, axis=(0, 0, 1))
    model.add(hub, fm.Driver.constant_speed("spin", hub, speed=2.0))
    return model, {"positions": {"beam.j1": 0.01}}


MODELS = {
    "driven_hub": _driven_hub,
    "fourbar": lambda: (fourbar(), {"positions": fourbar_initial()}),
    "fourbar_revolute_cut": lambda: (fourbar(fm.Revolute), {"positions": fourbar_initial()}),
    "bricard": lambda: (hc.bricard(), {}),
    "parallelogram": lambda: (hc.parallelogram(), {"positions": {"A": 0.5, "B": -0.5, "D": 0.5}}),
    "parallelogram_chain": lambda: (hc.parallelogram_chain(),
                                    {"positions": {"A": 0.5, "B": -0.5, "D": 0.5, "E": -0.5, "F": 0.5}}),
    "wiper": lambda: (lambda m, i: (m, {"positions": i}))(*_wiper()),
    "b6_8": lambda: (lambda m, i: (m, {"positions": i}))(*scenes.b6(True, 8)),
    "b6_32": lambda: (lambda m, i: (m, {"positions": i}))(*scenes.b6(True, 32)),
    "b7_4": lambda: _b7(4),
    "b7_40": lambda: _b7(40),
    "b7_4_spatial_cuts": lambda: scenes.b7(4, planar_cuts=False),
}


#: how far off the manifold the states are, and the agreement asked there
OFF = {"bricard": (1e-9, 1e-7)}


def _states(system, initial, k=3, seed=1, off=1e-3):
    """The assembled state and ``k`` states ``off`` the manifold near it (speeds off by up to 0.1)."""
    x, xd = fm.initial_state(system, 0.0, **initial)
    rng = np.random.default_rng(seed)
    n = system.n_coords
    out = [(0.0, x, xd)]
    for i in range(k):
        out.append((0.1 * (i + 1), x + off * rng.normal(size=n), xd + min(0.1, off) * rng.normal(size=n)))
    return out


@pytest.fixture(scope="module", params=sorted(MODELS))
def pair(request):
    model, initial = MODELS[request.param]()
    systems = [model.build(), model.build(complement="articulated")]
    x, xd = fm.initial_state(systems[0], 0.0, **initial)
    return (request.param, *(_calibrated(s, 0.0, x, xd) for s in systems), initial)


def _rel(a, b):
    return np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(a)))


def test_state_rate_and_reactions_equal_the_svd_strategy(pair):
    name, svd, art, initial = pair
    assert art._loop_kernel and not svd._loop_kernel
    off, agree = OFF.get(name, (1e-3, 1e-10))
    for i, (t, x, xd) in enumerate(_states(svd, initial, off=off)):
        tol = 1e-10 if i == 0 else agree
        y = np.concatenate([x, xd])
        A, f, psi, gamma = svd.reduced_parts(t, y)
        xdd, lam = svd._solve(t, A, f, psi, gamma, multipliers=True)
        xdd2, lam2 = art._loop_solve(t, y, multipliers=True)
        assert _rel(xdd, xdd2) < tol, name
        assert _rel(lam, lam2) < tol, name
        assert _rel(svd.state_rate(t, y), art.state_rate(t, y)) < tol, name
        # the reactions are the multipliers of A xdd = f + psi^T lambda
        assert _rel(A @ xdd2 - f, psi.T @ lam2) < 1e-9, name


def test_mass_orthogonal_speeds_equal_the_svd_strategy(pair):
    name, svd, art, initial = pair
    for t, x, xd in _states(svd, initial, off=OFF.get(name, (1e-3,))[0])[1:]:
        rows = svd._rows(t, x, xd)
        kin = svd.kinematics(t, x, xd)
        v1 = svd._mass_orthogonal_speeds(kin, rows.psi, rows.b, xd)
        v2 = art._mass_orthogonal_speeds(kin, rows.psi, rows.b, xd)
        assert _rel(v1, v2) < OFF.get(name, (0, 1e-10))[1], name
        assert np.max(np.abs(rows.psi @ v2 - rows.b)) < 1e-10


def test_rank_equals_that_of_psi(pair):
    name, svd, art, initial = pair
    t, x, xd = _states(svd, initial, k=0)[0]
    c = svd.strategy.complement(svd._rows(t, x, xd).psi)
    rank, smallest = art._loop_calibration(t, x, xd)
    assert rank == c.rank == svd.rank_limit == art.rank_limit, name
    assert smallest == art.sigma_ref > 0
    assert art.dof(t, x) == svd.dof(t, x) == svd.n_coords - c.rank


def test_chain_of_loops_is_banded_with_a_band_independent_of_n():
    bands = [fm.Model.build(scenes.b7(n)[0], complement="articulated")._loop_layout.band for n in (4, 40, 200)]
    assert bands[0] == bands[1] == bands[2] <= 3
    layout = scenes.b6(True, 16)[0].build(complement="articulated")._loop_layout
    assert layout.band == 2  # three rows sharing one subtree: one dense 3 x 3 block


@pytest.mark.parametrize("name, t_end, rtol, method, stiff", [("b7_4", 0.7, 1e-11, "DOP853", 1e-9),
                                                              ("bricard", 1.0, 1e-11, "DOP853", 1e-9),
                                                              ("b6_8", 0.01, 1e-10, "CVODE_BDF", 1e-8)])
def test_simulation_equals_the_svd_strategy(name, t_end, rtol, method, stiff):
    """Away from singular positions (B7's rods lie flat near t = 0.8 s), at tight tolerances.

    B6's rod is stiff: from initial states equal to round-off the two CVODE
    runs take different steps (2297 and 2267 over 0.01 s), and its segments'
    speeds and forces, the reactions, differ by about 1e-9 of their size
    where the positions agree to 1e-11 (each evaluation agrees to
    round-off: test_state_rate_and_reactions_equal_the_svd_strategy).
    """
    model, initial = MODELS[name]()
    runs = [fm.simulate(model, t_end, complement=c, rtol=rtol, progress=False, method=method, **initial)
            for c in ("svd", "articulated")]
    a, b = runs
    assert b.status == "finished"
    assert np.max(np.abs(a.x - b.x)) < 1e-9
    assert np.max(np.abs(a.xd - b.xd)) < stiff * max(1.0, np.max(np.abs(a.xd)))
    assert _rel(a.reactions, b.reactions) < stiff
    assert np.max(b.residual) < 1e-10


def test_chain_of_loops_passes_its_flat_position_on_its_branch():
    """B7 (N = 4) over 2 s: the rods pass their flat position near t = 0.8 s, where psi loses four ranks.

    The branch is kept (every rod at the same angle), the loops stay closed;
    the SVD strategy, whose filter acts on psi's singular values where this
    one's acts on K's, follows the same motion to 1e-7.
    """
    model, initial = scenes.b7(4)
    a, b = (fm.simulate(model, 2.0, complement=c, rtol=1e-11, progress=False, method="DOP853", **initial)
            for c in ("svd", "articulated"))
    rods = np.stack([b.coordinate(f"pin_{k}.angle") for k in range(5)])
    assert rods[0, -1] < -np.pi / 2  # past the flat position
    assert np.max(np.abs(rods - rods[0])) < 1e-8
    assert np.max(b.residual) < 1e-10
    assert np.max(np.abs(a.x - b.x)) < 1e-7 and np.max(np.abs(a.xd - b.xd)) < 1e-7
    assert b.n_steps <= 1.2 * a.n_steps


def test_a_massless_freedom_no_loop_fixes_is_refused_by_name():
    """A slender bar spinning about its own axis moves no mass; here no loop fixes the spin."""
    model = fm.Model("massless")
    bar = fm.RigidBody.slender_bar("bar", 1.0, 1.0)
    ghost = fm.RigidBody.slender_bar("ghost", 1.0, 1.0)
    block = fm.RigidBody.box("block", 1.0, (0.1, 0.1, 0.1))
    model.add(fm.Revolute("pin", model.ground, bar),
              fm.Revolute("spin", bar, ghost, parent_point=(1.0, 0.0, 0.0), axis=(1.0, 0.0, 0.0)),
              fm.Prismatic("rail", model.ground, block, axis=(1.0, 0.0, 0.0)),
              fm.PlanarRevolute("close", bar, block, parent_point=(1.0, 0.0, 0.0), cut=True),
              fm.Gravity((0.0, -9.81, 0.0)))
    # refused at build time, naming the joint, the body and the axis (issue #32) ...
    with pytest.raises(fm.ModelError, match=r"joint 'spin' \(Revolute\) turns body 'ghost' about the axis "
                                            r"\[1.0, 0.0, 0.0\].*no inertia"):
        model.build(complement="articulated")
    system = fm.System(model, complement="articulated")  # ... and by the recursion, for what the build cannot see
    x = np.array([0.3, 0.0, np.cos(0.3)])
    with pytest.raises(fm.AssemblyError, match="joint 'spin' moves no mass"):
        system.accelerations(0.0, x, np.zeros(3))


def test_strategy_by_name_and_singular_rtol_refused():
    assert isinstance(fm.get_complement("articulated"), fm.ArticulatedComplement)
    with pytest.raises(fm.ModelError, match="singular_rtol"):
        fm.ArticulatedComplement(singular_rtol=1e-6)


@pytest.mark.parametrize("name", ["b6_8", "b6_32", "b7_4"])
def test_newton_preconditioner_solves_the_newton_matrix_of_the_loops(name):
    """``(I - gamma J) z = r`` with ``J = [[0, I], [-P K, -P C]]`` (the state Jacobian without G), exactly.

    On models whose springs and dampers are diagonal on the coordinates (the
    wiper's friction couples them: there the preconditioner leaves that out).
    """
    model, initial = MODELS[name]()
    system = model.build(complement="articulated")
    x, xd = fm.initial_state(system, 0.0, **initial)
    system = _calibrated(system, 0.0, x, xd)
    pre = system.newton_preconditioner()
    pre.setup(0.0, x, xd)
    n = system.n_coords
    J = model.build().state_jacobian(0.0, x, xd, geometric=False)
    if J is None:  # no coordinate springs or dampers: J = [[0, I], [0, 0]]
        J = np.zeros((2 * n, 2 * n))
        J[:n, n:] = np.eye(n)
    rng = np.random.default_rng(3)
    for gamma in (1e-4, 1e-2):
        r = rng.normal(size=2 * n)
        z = np.concatenate(pre.solve(r[:n], r[n:], gamma))
        # to round-off of the terms (gamma P K reaches 1e8 on the stiff rod of B6)
        scale = np.max(np.abs(gamma * J)) * np.max(np.abs(z)) + np.max(np.abs(r))
        np.testing.assert_allclose((np.eye(2 * n) - gamma * J) @ z, r, rtol=0, atol=1e-13 * scale)


def test_newton_preconditioner_keeps_its_factors_per_gamma_and_drops_them_at_a_new_setup():
    """The factors made at one gamma serve that gamma's later solves only, and only until the next set-up.

    Solves alternating between two gammas, and a set-up at other positions
    in between, equal those of a preconditioner set up afresh for each one
    (to 1e-13 of the solution: the same arithmetic).
    """
    model, initial = MODELS["b6_8"]()
    system = model.build(complement="articulated")
    x, xd = fm.initial_state(system, 0.0, **initial)
    system = _calibrated(system, 0.0, x, xd)
    n = system.n_coords
    rng = np.random.default_rng(5)
    x2 = x + 1e-2 * rng.normal(size=n)
    pre = system.newton_preconditioner()

    def fresh(at, r, gamma):
        p = system.newton_preconditioner()
        p.setup(0.0, at, xd)
        return np.concatenate(p.solve(r[:n], r[n:], gamma))

    for at in (x, x2, x):
        pre.setup(0.0, at, xd)
        for gamma in (1e-4, 1e-2, 1e-4, 1e-4, 1e-2):
            r = rng.normal(size=2 * n)
            z = np.concatenate(pre.solve(r[:n], r[n:], gamma))
            np.testing.assert_allclose(z, fresh(at, r, gamma), rtol=0, atol=1e-13 * np.max(np.abs(z)))


def test_cvode_with_the_loops_preconditioner_equals_the_dense_jacobian():
    """B6 with 64 segments (past KRYLOV_MIN_COORDS): CVODE_BDF by GMRES and the O(n m) preconditioner."""
    model, positions = scenes.b6(True, 64)
    a, b = (fm.simulate(model, 0.01, positions=positions, complement=c, method="CVODE_BDF", rtol=1e-10,
                        progress=False) for c in ("svd", "articulated"))
    assert b.status == "finished" and b.n_jac > 0
    assert np.max(np.abs(a.x - b.x)) < 1e-8
    assert np.max(b.residual) < 1e-10


def test_fastest_rates_of_a_large_loop_by_arnoldi_equal_the_dense_ones():
    """B6 with 256 segments (past DENSE_RATES_MAX): the rates 'auto' and the stiffness warning judge by."""
    from flexmb.system.rates import DENSE_RATES_MAX

    model, positions = scenes.b6(True, 256)
    dense, sparse = (model.build(complement=c) for c in ("svd", "articulated"))
    assert sparse.n_coords > DENSE_RATES_MAX
    x, xd = fm.initial_state(dense, 0.0, positions=positions)
    dense, sparse = (_calibrated(s, 0.0, x, xd) for s in (dense, sparse))
    np.testing.assert_allclose(sparse._rates(0.0, x, xd), dense._rates(0.0, x, xd), rtol=1e-3)


@pytest.mark.parametrize("name", ["fourbar", "bricard", "wiper", "b6_32", "b7_40", "b7_4_spatial_cuts",
                                  "parallelogram_chain"])
def test_projection_equals_the_svd_strategy(pair_of, name):
    """System.project (Newton with minimum-norm steps; speeds minimum-norm or mass-orthogonal), psi kept sparse."""
    svd, art, initial = pair_of(name)
    x, xd = fm.initial_state(svd, 0.0, **initial)
    rng = np.random.default_rng(7)
    n = svd.n_coords
    x1, xd1 = x + 1e-4 * rng.normal(size=n), xd + 1e-3 * rng.normal(size=n)
    fixed = np.zeros(n, bool)
    fixed[-1] = True  # not a driven coordinate
    for options in ({}, {"speeds": "mass"}, {"fixed": fixed}):
        a = svd.project(0.0, x1, xd1, **options)
        b = art.project(0.0, x1, xd1, **options)
        assert np.max(np.abs(a[0] - b[0])) < 1e-10, (name, options)
        assert np.max(np.abs(a[1] - b[1])) < 1e-10 * max(1.0, np.max(np.abs(a[1]))), (name, options)
        assert art.constraint_residual(0.0, *b) < 1e-10


@pytest.fixture(scope="module")
def pair_of():
    def make(name):
        model, initial = MODELS[name]()
        systems = [model.build(), model.build(complement="articulated")]
        x, xd = fm.initial_state(systems[0], 0.0, **initial)
        return (*(_calibrated(s, 0.0, x, xd) for s in systems), initial)

    return make


@pytest.mark.parametrize("name", ["fourbar", "bricard", "wiper", "b6_8", "b7_4_spatial_cuts"])
def test_cut_residual_from_the_wrenches_equals_the_dense_rows(name):
    """max |phi| and max |psi xd| of the cut joints, psi xd read from the bodies' spatial velocities."""
    from flexmb.kernels.equations import RESIDUALS, tree_equations

    model, initial = MODELS[name]()
    system = model.build()
    rng = np.random.default_rng(0)
    x, xd = fm.initial_state(system, 0.0, **initial)
    x, xd = x + 1e-3 * rng.normal(size=x.size), xd + rng.normal(size=x.size)
    rows = system.constraints.evaluate(system.kinematics(0.0, x, xd), level=1)
    m_cut = system.n_constraints - len(system.constraints.drivers)
    position, velocity = tree_equations(system._packed, np.concatenate([x, xd]), system.n_coords, RESIDUALS,
                                        system._no_powers, *system._no_loads)[2]
    assert position == np.max(np.abs(rows.phi[:m_cut]))
    assert velocity == pytest.approx(np.max(np.abs(rows.psi[:m_cut] @ xd)), rel=1e-13)


def test_work_of_a_driven_loop_equals_the_svd_strategy():
    """track_work: the driver's work (its reaction times its speed) and the dampers' work, as with the SVD."""
    model, positions = scenes.b6(True, 8)
    a, b = (fm.simulate(model, 0.01, positions=positions, complement=c, method="CVODE_BDF", rtol=1e-10,
                        track_work=True, progress=False) for c in ("svd", "articulated"))
    assert sorted(a.work) == sorted(b.work) and "driver motor" in b.work
    for name in a.work:
        scale = max(1e-12, np.max(np.abs(a.work[name])))
        assert np.max(np.abs(a.work[name] - b.work[name])) < 1e-7 * scale, name
    # the balance: all works add up to the change of kinetic energy
    total = sum(b.work.values())
    assert np.max(np.abs(total - (b.kinetic - b.kinetic[0]))) < 1e-6 * np.max(np.abs(b.kinetic))
