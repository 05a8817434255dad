"""SUNDIALS CVODE (BDF and Adams) and IDA as flexmb integrators, and the integrator capability interface.

References come from outside the integrator under test: energy
conservation of an undamped pendulum, closed forms (a damped linear
oscillator, a pendulum's small oscillations), scipy's DOP853 or Radau at
tight tolerances on the same model (a B1 cantilever of BENCHMARKS.md, a
four-bar loop that needs constraint projection), and exact counts.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.integrate import BDF, DOP853, LSODA, RK23, RK45, Radau, solve_ivp

import flexmb as fm
from flexmb.integrators import (IDA, CVODEAdams, CVODEBDF, Capabilities, SecondOrderBDF, SecondOrderRadau, adapt,
                                capabilities)

from conftest import fourbar, fourbar_initial

CVODES = ["CVODE_BDF", "CVODE_Adams"]
SUNDIALS = [*CVODES, "IDA"]
G = 9.81


def pendulum():
    model = fm.Model("pendulum")
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0.0, -G, 0.0)))
    return model


def cantilever(n_segments=4, damped=True):
    """B1 of BENCHMARKS.md: aluminium 1 m x 20 mm x 5 mm, clamped, bending under gravity (one angle a segment)."""
    model = fm.Model("B1")
    beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material(70e9, 2700.0, 0.33),
                           n_segments, keep=("bend_y",), damping=7.7398e-4 if damped else 0.0)
    model.add(fm.Fixed("clamp", model.ground, beam), fm.Gravity((0.0, 0.0, -G)))
    return model


# ----------------------------------------------------------------------------- registration


@pytest.mark.parametrize("name, cls", [("CVODE_BDF", CVODEBDF), ("CVODE_Adams", CVODEAdams), ("IDA", IDA)])
def test_cvode_is_registered_by_name(name, cls):
    assert fm.registry.get("integrators", name) is cls
    assert fm.INTEGRATORS[name] is cls
    assert name in [p.name for p in fm.plugins("integrators") if p.status == "ok"]


def test_unknown_integrator_lists_the_sundials_ones():
    with pytest.raises(fm.ModelError, match=r"or, from SUNDIALS, \['CVODE_Adams', 'CVODE_BDF', 'IDA'\]"):
        fm.simulate(pendulum(), 0.1, method="Euler")


def test_cvode_works_under_solve_ivp():
    for cls in (CVODEBDF, CVODEAdams, IDA):
        t_eval = np.linspace(0.0, 2.0, 7)
        sol = solve_ivp(lambda t, y: [y[1], -y[0]], (0.0, 2.0), [1.0, 0.0], method=cls, rtol=1e-10, atol=1e-12,
                        t_eval=t_eval)
        assert sol.status == 0
        assert np.abs(sol.y[0] - np.cos(t_eval)).max() < 1e-8


# ----------------------------------------------------------------------------- capabilities


def test_scipy_solvers_get_their_capabilities_from_the_table():
    for cls in (RK45, RK23, DOP853):
        assert capabilities(cls) == Capabilities(explicit=True)
    for cls in (Radau, BDF):
        assert capabilities(cls) == Capabilities(uses_jacobian=True)
    assert capabilities(LSODA) == Capabilities()

    class MyRK(RK45):
        pass

    assert capabilities(MyRK).explicit  # through its base
    assert adapt(Radau) is SecondOrderRadau and adapt(BDF) is SecondOrderBDF and adapt(MyRK) is MyRK


def test_flexmb_integrators_declare_their_capabilities():
    assert capabilities(SecondOrderRadau) == Capabilities(uses_jacobian=True, second_order=True)
    assert capabilities(CVODEBDF) == Capabilities(uses_jacobian=True, uses_preconditioner=True, cheap_restart=False,
                                                  advances=True, finds_roots=True, limits_order=True)
    assert capabilities(CVODEAdams) == Capabilities(uses_jacobian=True, cheap_restart=False, advances=True,
                                                    finds_roots=True)
    assert capabilities(IDA) == Capabilities(uses_jacobian=True, uses_preconditioner=True, cheap_restart=False,
                                             advances=True, finds_roots=True)


def test_declared_capability_decides_what_simulate_passes():
    """A plugin declaring ``uses_jacobian`` gets the analytic Jacobian, with no identity test in simulate."""
    seen = {}

    class Spy(CVODEBDF):
        def __init__(self, fun, t0, y0, t_bound, *, jac=None, **options):
            seen["jac"] = jac
            super().__init__(fun, t0, y0, t_bound, jac=jac, **options)

    class Blind(Spy):
        uses_jacobian = False

    system = cantilever(4).build()
    res = fm.simulate(system, 0.05, method=Spy, rtol=1e-6, n_out=3)  # a class: nothing left in the registry
    assert callable(seen["jac"]) and res.n_jac > 0 and res.method == "Spy"
    res = fm.simulate(system, 0.05, method=Blind, rtol=1e-6, n_out=3)
    assert seen["jac"] is None and res.n_jac == 0


def test_declared_explicit_integrator_gets_the_stiffness_warning():
    class Explicit(CVODEAdams):
        explicit = True

    with warnings.catch_warnings():
        warnings.simplefilter("error", fm.StiffnessWarning)  # so that the run stops at once
        with pytest.raises(fm.StiffnessWarning, match="stiff for Explicit"):
            fm.simulate(cantilever(8).build(), 10.0, method=Explicit)


def test_integrator_without_dense_output_is_refused():
    class NoDense(CVODEBDF):
        has_dense_output = False

    with pytest.raises(fm.ModelError, match="no dense output"):
        fm.simulate(pendulum(), 0.1, method=NoDense)


# ----------------------------------------------------------------------------- accuracy


@pytest.mark.parametrize("method", SUNDIALS)
def test_pendulum_energy_and_reference(method):
    """Undamped pendulum released horizontal (90 deg from hanging; at ``pin = pi/2`` it stands upright and
    stays): energy conserved, angle against DOP853 at rtol 1e-12."""
    kw = dict(positions={"pin": 0.0}, n_out=51)
    ref = fm.simulate(pendulum(), 2.0, method="DOP853", rtol=1e-12, atol=1e-14, **kw)
    assert np.ptp(ref.x) > 3.0  # it swings through the bottom to the other side
    res = fm.simulate(pendulum(), 2.0, method=method, rtol=1e-10, atol=1e-12, **kw)
    assert res.status == "finished" and res.method == method
    drift = np.abs(res.energy - res.energy[0]).max() / np.abs(res.potential).max()
    assert drift < 1e-7
    assert np.abs(res.x - ref.x).max() < 1e-7
    assert np.abs(res.xd - ref.xd).max() < 1e-6


@pytest.fixture(scope="module")
def b1_reference():
    system = cantilever(4).build()
    return system, fm.simulate(system, 0.5, method="Radau", rtol=1e-11, atol=1e-13, n_out=11)


@pytest.mark.parametrize("method", SUNDIALS)
def test_b1_tip_matches_radau_and_counters_are_filled(b1_reference, method):
    system, ref = b1_reference
    res = fm.simulate(system, 0.5, method=method, rtol=1e-9, atol=1e-11, n_out=11)
    tip, tip_ref = res.shape("beam")[:, -1], ref.shape("beam")[:, -1]
    assert np.abs(tip - tip_ref).max() < 1e-7
    assert np.abs(tip_ref[:, 2]).max() > 1e-3  # it really moves
    # the analytic Jacobian is used, and every counter is filled
    assert res.n_jac > 0
    assert res.n_steps > 0 and res.n_rhs > res.n_steps // 2 and res.wall_time > 0
    assert res.n_projections == 0 and res.n_dof == 4


@pytest.mark.parametrize("method", ["CVODE_BDF", "IDA"])
def test_output_times_do_not_change_the_steps(b1_reference, method):
    """Dense output (the solver's interpolant) must not disturb the integration: same steps, same end state."""
    system, _ = b1_reference
    few = fm.simulate(system, 0.5, method=method, rtol=1e-8, n_out=2)
    many = fm.simulate(system, 0.5, method=method, rtol=1e-8, n_out=101)
    assert few.n_steps == many.n_steps and few.n_rhs == many.n_rhs
    assert np.abs(few.x[-1] - many.x[-1]).max() < 1e-13


def test_cvode_own_loop_takes_the_steps_of_the_one_step_loop(b1_reference):
    """Between output times CVODE steps in its own loop (``advance``); the steps it counts there (by its root
    function) and the solution are those of stepping it one step at a time from Python."""
    system, _ = b1_reference

    class OneStepBDF(CVODEBDF):
        advances = False

    # the work terms keep the run on scikit-sundae's CVODE (open trees without them step in compiled code:
    # tests/test_cvode_direct.py compares that path with this one)
    own = fm.simulate(system, 0.5, method="CVODE_BDF", rtol=1e-8, n_out=11, track_work=True)
    one = fm.simulate(system, 0.5, method=OneStepBDF, rtol=1e-8, n_out=11, track_work=True)
    assert own.n_steps == one.n_steps > 50 and own.n_rhs == one.n_rhs
    assert np.abs(own.x - one.x).max() < 1e-13 and np.abs(own.xd - one.xd).max() < 1e-12


@pytest.mark.parametrize("method", CVODES)
def test_fourbar_loop_with_projection(method):
    """A four-bar released at rest: the loop stays closed through projections and restarts."""
    kw = dict(positions=fourbar_initial(np.pi / 4), fixed=["A"], n_out=21)
    ref = fm.simulate(fourbar(), 1.0, method="DOP853", rtol=1e-12, atol=1e-14, **kw)
    res = fm.simulate(fourbar(), 1.0, method=method, rtol=1e-9, atol=1e-11, projection_tol=1e-11, **kw)
    assert res.status == "finished"
    # the restart from a projected state is exercised (BDF); Adams' drift stays below the bound on
    # CVODE's own state (RESTART_ATOL_FACTOR * atol) over this second
    assert res.n_projections > 0 or method == "CVODE_Adams"
    assert res.residual.max() < 1e-10
    drift = np.abs(res.energy - res.energy[0]).max() / np.abs(res.potential).max()
    assert drift < 1e-6
    assert np.ptp(ref.x[:, 0]) > 1.0
    assert np.abs(res.x - ref.x).max() < 1e-6


def test_multistep_restarts_are_rationed():
    """Projecting CVODE's state at projection_tol restarts it every few steps (order one each time) and a four-bar
    second took minutes; its own state is projected past RESTART_ATOL_FACTOR * atol (at most RESTART_TOL_MAX)."""
    from flexmb.stepping import RESTART_ATOL_FACTOR, RESTART_TOL_MAX

    assert RESTART_ATOL_FACTOR * 1e-11 <= RESTART_TOL_MAX
    kw = dict(positions=fourbar_initial(np.pi / 4), fixed=["A"], n_out=21)
    res = fm.simulate(fourbar(), 1.0, method="CVODE_BDF", rtol=1e-9, atol=1e-11, projection_tol=1e-11, **kw)
    assert res.status == "finished" and res.n_steps < 5000 and res.n_projections < 10


@pytest.mark.parametrize("path", ["sksundae", "compiled"])
def test_restart_after_a_projection_that_excites_stiff_modes(monkeypatch, path):
    """CVODE restarted from a projected state chooses its own first step.

    The drifted state of B6 damped with 256 segments (tests/data/b6_restart_state.npz, written by
    make_b6_restart_state.py) is projected onto the constraints, which excites the rod's overdamped segment
    modes; restarted at order one with the last step (1.4e-4 s) as its first, CVODE's error test failed seven
    times down to 3.5e-11 s (flag -3) and the 1 s run stopped at t = 0.956 s. Restarted by simulate's rule it
    steps on: a millisecond further, its steps are back above 1e-6 s and the loop closed. Through
    scikit-sundae (the path of models the compiled loop does not take) and stepped in compiled code
    (flexmb.integrators.cvode_direct_loops, B6's own path)."""
    import os
    import sys
    from types import SimpleNamespace

    from flexmb.integrators import direct_choice
    from flexmb.simulate import _calibrated
    from flexmb.stepping import Run

    if path == "sksundae":
        monkeypatch.setattr(direct_choice, "compiled_loop", lambda *args: None)

    here = os.path.dirname(os.path.abspath(__file__))
    sys.path.insert(0, os.path.join(os.path.dirname(here), "benchmarks"))
    import scenes

    data = np.load(os.path.join(here, "data", "b6_restart_state.npz"))
    t, y, step = float(data["t"]), np.array(data["y"]), float(data["step"])
    model, positions = scenes.b6(True, int(data["n_segments"]))
    system = model.build(complement="articulated")
    x, xd = fm.initial_state(system, 0.0, positions=positions)
    system = _calibrated(system, 0.0, x, xd)
    n = system.n_coords
    run = Run(system, CVODEBDF, "CVODE_BDF", np.array([0.0, 1.0]), t0=0.0, t_end=1.0, rtol=1e-8, atol=1e-10,
              max_step=np.inf, projection_tol=1e-10, track_work=False, progress=False, auto=False)
    run._set_options(x, xd)
    # GMRES with the loops' Newton preconditioner, as simulate runs it (in Python, or compiled)
    assert run.preconditioner is not None if path == "sksundae" else run.options["krylov"]
    run.t_now = t
    assert system.constraint_residual(t, y[:n], y[n:]) > run.state_tol  # the restart is due
    solver = run._restart_if_drifted(SimpleNamespace(t=t, y=y, step_size=step))
    assert run.n_proj == 1 and solver.t == t
    while solver.t < t + 1e-3:
        if path == "compiled":  # raises if CVODE fails
            solver.step_on(t + 1e-3, np.inf)
            continue
        message = solver.step()
        assert solver.status != "failed", message
    assert solver.t - solver.t_old > 1e-6
    assert system.constraint_residual(solver.t, solver.y[:n], solver.y[n:]) < run.state_tol


# ----------------------------------------------------------------------------- IDA


def oscillator(stiffness, damping, mass=1.0):
    """A rigid slider on a prismatic joint held by a spring-damper: ``m x'' + c x' + k x = 0``."""
    model = fm.Model("oscillator")
    body = fm.RigidBody.slender_bar("slider", mass=mass, length=0.1)
    slide = fm.Prismatic("slide", model.ground, body, axis=(1.0, 0.0, 0.0))
    model.add(slide, fm.JointSpringDamper("spring", slide, stiffness=stiffness, damping=damping))
    return model


def test_ida_iteration_matrix_is_cj_minus_the_jacobian():
    """IDA is given dF/dy + cj dF/dy' of its residual F = y' - f(t, y): compared with differences of F."""
    A = np.array([[0.0, 1.0], [-4.0, -0.3]])
    solver = IDA(lambda t, y: A @ y, 0.0, [1.0, 0.0], 1.0, jac=A)
    jacfn = solver._jacfn(lambda t, y: A)
    y, yp, cj, h = np.array([0.3, -0.2]), np.array([0.1, 0.5]), 250.0, 1e-6
    JJ = np.zeros((2, 2))
    jacfn(0.0, y, yp, None, cj, JJ)

    def F(y, yp):
        return yp - A @ y

    fd = np.column_stack([(F(y + h * e, yp + cj * h * e) - F(y, yp)) / h for e in np.eye(2)])
    assert np.abs(JJ - fd).max() < 1e-6 * cj
    assert solver.njev == 1


def test_ida_damped_oscillator_matches_the_closed_form():
    """``x = x0 exp(-zeta wn t) (cos wd t + zeta wn / wd sin wd t)`` over three periods, with the analytic
    Jacobian. A BDF code keeps each step's local error below rtol (relative to the amplitude); over the few
    hundred steps of this linear, damped motion they add up without growing, to some ten rtol: bounded by
    100 rtol."""
    k, c, x0, rtol = 4 * np.pi**2, 0.4, 0.1, 1e-10
    wn, zeta = np.sqrt(k), c / (2 * np.sqrt(k))
    wd = wn * np.sqrt(1 - zeta**2)
    res = fm.simulate(oscillator(k, c), 3.0, method="IDA", positions={"slide": x0}, rtol=rtol,
                      atol=1e-3 * rtol, n_out=61)
    exact = x0 * np.exp(-zeta * wn * res.t) * (np.cos(wd * res.t) + zeta * wn / wd * np.sin(wd * res.t))
    assert res.status == "finished" and res.method == "IDA"
    assert res.n_jac > 0  # the analytic Jacobian, through cj I - J
    assert np.abs(res.x[:, 0] - exact).max() < 100 * rtol * x0


def test_ida_pendulum_small_oscillations_match_the_closed_form():
    """A bar pendulum 1e-4 rad off the vertical: ``theta = theta0 cos(w t)``, ``w^2 = 3 g / (2 L)``. The
    closed form's own error (the period grows by theta0^2 / 16) is 5e-9 theta0 over 2 s; the local errors
    at rtol 1e-10 (relative to theta0: atol is far below it) add up over a few hundred steps to well below
    1e-7 theta0, the bound. No spring, so no analytic Jacobian: IDA's own difference quotients."""
    theta0, w = 1e-4, np.sqrt(1.5 * G)
    res = fm.simulate(pendulum(), 2.0, method="IDA", positions={"pin": -np.pi / 2 + theta0}, rtol=1e-10,
                      atol=1e-16, n_out=41)
    assert res.status == "finished" and res.n_jac == 0
    assert np.abs(res.x[:, 0] + np.pi / 2 - theta0 * np.cos(w * res.t)).max() < 1e-7 * theta0


def test_ida_newton_converges_with_the_analytic_jacobian():
    """B1 (N = 8: stiff segment springs) over 0.5 s. With the right iteration matrix ``cj I - J`` IDA's
    Newton iteration converges in about one right-hand side a step and needs no difference quotients
    (2n right-hand sides each); a wrong one fails its iterations, shrinks the steps and evaluates again."""

    class Blind(IDA):
        uses_jacobian = False

    system = cantilever(8).build()
    res = fm.simulate(system, 0.5, method="IDA", rtol=1e-6, n_out=11)
    blind = fm.simulate(system, 0.5, method=Blind, rtol=1e-6, n_out=11)
    assert res.n_jac > 0 and blind.n_jac == 0
    assert res.n_rhs < 1.5 * res.n_steps
    assert res.n_rhs < blind.n_rhs


def sprung_fourbar():
    """The four-bar with a torsion spring-damper at the crank pivot: a closed loop with an analytic Jacobian."""
    model = fourbar()
    model.add(fm.JointSpringDamper("crank spring", model["A"], stiffness=0.5, damping=0.005, rest=np.pi / 4))
    return model


def test_ida_fourbar_matches_radau_and_cvode_bdf():
    """A closed loop, driven by the spring, with the analytic Jacobian. At rtol 1e-9 a BDF code keeps each
    local error below rtol (relative to angles of order one); over the thousand-odd steps of this second
    they add up, partly cancelling, to tens of rtol: each of IDA and CVODE_BDF is bounded by 100 rtol
    against Radau at rtol 1e-12 (a reference a thousand times closer), and so the two by 200 rtol of each
    other."""
    rtol = 1e-9
    kw = dict(positions=fourbar_initial(0.0), fixed=["A"], n_out=21)
    ref = fm.simulate(sprung_fourbar(), 1.0, method="Radau", rtol=1e-12, atol=1e-14, **kw)
    ida = fm.simulate(sprung_fourbar(), 1.0, method="IDA", rtol=rtol, atol=rtol / 100, **kw)
    bdf = fm.simulate(sprung_fourbar(), 1.0, method="CVODE_BDF", rtol=rtol, atol=rtol / 100, **kw)
    assert ida.status == "finished" and ida.n_jac > 0
    assert np.ptp(ref.x[:, 0]) > 0.5  # it really swings
    assert ida.residual.max() < 1e-10
    assert np.abs(ida.x - ref.x).max() < 100 * rtol and np.abs(bdf.x - ref.x).max() < 100 * rtol
    assert np.abs(ida.x - bdf.x).max() < 200 * rtol


def test_ida_restarts_after_projections():
    """The four-bar released at rest at a loose tolerance: IDA's state drifts off the loop, is projected and
    IDA restarted from it; the loop stays closed and the energy (no damping) is kept to about rtol."""
    rtol = 1e-7
    kw = dict(positions=fourbar_initial(np.pi / 4), fixed=["A"], n_out=21)
    res = fm.simulate(fourbar(), 1.0, method="IDA", rtol=rtol, atol=rtol / 100, **kw)
    assert res.status == "finished"
    assert res.n_projections > 0
    assert res.residual.max() < 1e-10
    drift = np.abs(res.energy - res.energy[0]).max() / np.abs(res.potential).max()
    assert drift < 100 * rtol


# ----------------------------------------------------------------------------- failures


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize("method", SUNDIALS)
def test_non_finite_state_stops_with_the_time(method):
    model = pendulum()
    model.add(fm.PointForce("kick", model["bar"], lambda t: (0.0, np.nan if t > 0.1 else 1.0, 0.0),
                            point=(1.0, 0.0, 0.0)))
    with pytest.raises(fm.SimulationError) as info:
        fm.simulate(model, 1.0, positions={"pin": 0.3}, method=method)
    err = info.value
    assert err.t == pytest.approx(0.1, abs=0.01)
    assert str(err).startswith(f"simulation failed at t = {err.t:.9g} s")
    assert "non-finite" in str(err)
    res = err.result
    assert res.status == "failed" and 0 < len(res.t) < 201 and res.n_steps > 0 and res.n_rhs > 0


# ----------------------------------------------------------------------------- large open trees: Krylov


def spatial_beam(n_segments):
    """The B2 strip: torsion and both bendings, tilted gravity, damped."""
    model = fm.Model("beam")
    beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material(70e9, 2700.0, 0.33),
                           n_segments, keep=("torsion", "bend_y", "bend_z"), damping=7.7398e-4)
    model.add(fm.Fixed("clamp", model.ground, beam), fm.Gravity((0.0, -5.886, -7.848)))
    return model


@pytest.mark.parametrize("method", ["CVODE_BDF", "IDA"])
def test_open_tree_from_krylov_size_on_is_solved_without_matrices(method):
    """From KRYLOV_MIN_COORDS on, CVODE_BDF and IDA get the O(n) Newton preconditioner (GMRES) instead of a
    dense Jacobian, and reach the same tip as Radau at a tight tolerance (the B2 beam, 20 ms)."""
    from flexmb.stepping import KRYLOV_MIN_COORDS

    system = spatial_beam(KRYLOV_MIN_COORDS // 3).build()
    assert system.n_coords >= KRYLOV_MIN_COORDS
    ref = fm.simulate(system, 0.02, method="Radau", rtol=1e-11, atol=1e-13, n_out=3)
    res = fm.simulate(system, 0.02, method=method, rtol=1e-8, atol=1e-10, n_out=3)
    assert res.status == "finished" and res.n_jac > 0  # preconditioner set-ups
    assert np.abs(res.x[-1] - ref.x[-1]).max() < 1e-7 * np.abs(ref.x[-1]).max()
    # below the threshold, the dense Jacobian route
    small = spatial_beam(4).build()
    res_small = fm.simulate(small, 0.02, method=method, rtol=1e-8, n_out=3)
    assert res_small.status == "finished" and res_small.n_jac > 0


def test_cvode_restarting_every_few_steps_raises_its_drift_bound():
    """From rtol 1e-6 up, the capped bound on CVODE's own loop drift (RESTART_TOL_MAX) is within reach of its
    order-one steps after a restart: released at 3 rad/s, the four-bar restarted 9,554 times in 2 s at rtol 1e-5
    (11,225 steps). Restarts within RESTART_MIN_STEPS steps of each other raise the run's bound, and it stops
    cycling; the stored states are still projected onto the loop, and the motion is that of a tight run."""
    kw = dict(positions=fourbar_initial(np.pi / 4), speeds={"A": 3.0}, n_out=41)
    ref = fm.simulate(fourbar(), 2.0, method="CVODE_BDF", rtol=1e-11, **kw)
    res = fm.simulate(fourbar(), 2.0, method="CVODE_BDF", rtol=1e-5, **kw)
    assert res.status == "finished"
    assert res.n_projections < 100 and res.n_steps < 2000, (res.n_projections, res.n_steps)
    assert res.residual.max() < 1e-10
    assert np.abs(res.x - ref.x).max() < 0.1  # rtol 1e-5 over some 6 crank turns (the fixed bound: 0.31 rad)
