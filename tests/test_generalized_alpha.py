"""GeneralizedAlpha: order, energy, dissipation against Chung & Hulbert's theory, step control, mechanisms."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import flexmb as fm
from flexmb.genalpha import GeneralizedAlpha, alpha_parameters, amplification_matrix, generalized_alpha
from flexmb.scenes.fourbar import fourbar


def oscillator(omega):
    """xdd = -omega^2 x for each omega (uncoupled), y = (x, xd)."""
    w2 = np.asarray(omega, dtype=float) ** 2
    n = w2.size

    def fun(t, y):
        return np.concatenate([y[n:], -w2 * y[:n]])

    def jac(t, y):
        J = np.zeros((2 * n, 2 * n))
        J[:n, n:] = np.eye(n)
        J[n:, :n] = -np.diag(w2)
        return J

    return fun, jac


def chung_hulbert_matrix(rho, h_omega):
    """Amplification matrix of the original Chung-Hulbert form (alpha-weighted equation of motion), closed form.

    ``(1 - am) a1 + am a0 + w^2 ((1 - af) x1 + af x0) = 0`` with Newmark's
    updates, state ``(x, h v, h^2 a)``; written here independently of the
    Arnold-Bruels form the integrator uses (the two agree on linear problems).
    """
    rho = float(rho)
    am, af = (2 * rho - 1) / (rho + 1), rho / (rho + 1)
    g = 0.5 - am + af
    b = 0.25 * (1 - am + af) ** 2
    w2 = h_omega**2
    lhs = np.array([[1.0, 0.0, -b], [0.0, 1.0, -g], [(1 - af) * w2, 0.0, 1 - am]])
    rhs = np.array([[1.0, 1.0, 0.5 - b], [0.0, 1.0, 1 - g], [-af * w2, 0.0, -am]])
    return np.linalg.solve(lhs, rhs)


def spectral_radius(A):
    return float(np.max(np.abs(np.linalg.eigvals(A))))


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.8, 1.0])
def test_parameters_are_second_order_and_reach_rho_inf(rho):
    am, af, b, g = alpha_parameters(rho)
    assert g == pytest.approx(0.5 - am + af)  # second order (Chung & Hulbert eq. 17)
    assert spectral_radius(chung_hulbert_matrix(rho, 1e7)) == pytest.approx(rho, abs=1e-4)
    assert spectral_radius(amplification_matrix(rho, 1e7)) == pytest.approx(rho, abs=1e-4)
    for hw in (0.1, 1.0, 10.0, 100.0):
        assert spectral_radius(amplification_matrix(rho, hw)) == pytest.approx(
            spectral_radius(chung_hulbert_matrix(rho, hw)), rel=1e-9)


@pytest.mark.parametrize("rho", [1.0, 0.8, 0.3])
def test_second_order_convergence_at_fixed_step(rho):
    w, t_end = 2.0, 3.0
    fun, jac = oscillator([w])
    hs = t_end / np.array([40, 80, 160, 320])
    errs = []
    for h in hs:
        sol = solve_ivp(fun, (0, t_end), [1.0, 0.0], method=generalized_alpha(rho, fixed_step=h), jac=jac)
        errs.append(abs(sol.y[0, -1] - np.cos(w * t_end)) + abs(sol.y[1, -1] + w * np.sin(w * t_end)) / w)
        assert sol.t.size == round(t_end / h) + 1
    order = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert order == pytest.approx(2.0, abs=0.1)


def test_rho_one_conserves_the_energy_of_a_linear_oscillator():
    w = 3.0
    fun, jac = oscillator([w])
    h = 0.3  # h omega = 0.9: coarse, the phase is wrong but no energy is lost
    sol = solve_ivp(fun, (0, 300.0), [1.0, 0.5], method=generalized_alpha(1.0, fixed_step=h), jac=jac)
    energy = 0.5 * sol.y[1] ** 2 + 0.5 * w**2 * sol.y[0] ** 2
    assert np.max(np.abs(energy / energy[0] - 1)) < 1e-10
    # while rho_inf < 1 dissipates, at the same step
    sol = solve_ivp(fun, (0, 300.0), [1.0, 0.5], method=generalized_alpha(0.5, fixed_step=h), jac=jac)
    energy = 0.5 * sol.y[1] ** 2 + 0.5 * w**2 * sol.y[0] ** 2
    assert energy[-1] < 0.5 * energy[0]


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.8])
def test_high_mode_decays_as_the_spectral_radius_low_mode_kept(rho):
    w_low, w_high, h = 1.0, 1e4, 0.01
    fun, jac = oscillator([w_low, w_high])
    n_steps = 120
    sol = solve_ivp(fun, (0, n_steps * h), [1.0, 1.0, 0.0, 0.0], method=generalized_alpha(rho, fixed_step=h),
                    jac=jac)
    x, v = sol.y[:2], sol.y[2:]
    energy = 0.5 * v**2 + 0.5 * np.array([[w_low**2], [w_high**2]]) * x**2
    amp = np.sqrt(energy[1])
    # amplitude ratio per step, after the start-up transient, against the closed form at h omega = 100
    k0, k1 = 40, 100
    measured = (amp[k1] / amp[k0]) ** (1.0 / (k1 - k0)) if amp[k1] > 0 else 0.0
    theory = spectral_radius(chung_hulbert_matrix(rho, h * w_high))
    if rho > 0:
        assert measured == pytest.approx(theory, rel=0.03)
    else:
        assert amp[k1] < 1e-12 * amp[0]
    # the low mode (h omega = 0.01) keeps its energy to the method's O((h omega)^3) dissipation
    assert abs(energy[0, -1] / energy[0, 0] - 1) < 1e-4


def test_step_control_reacts_to_rtol():
    w = 2.0
    fun, jac = oscillator([w])
    steps, errs = [], []
    for rtol in (1e-4, 1e-6, 1e-8):
        sol = solve_ivp(fun, (0, 5.0), [1.0, 0.0], method=GeneralizedAlpha, rtol=rtol, atol=rtol, jac=jac)
        steps.append(sol.t.size - 1)
        errs.append(abs(sol.y[0, -1] - np.cos(w * 5.0)))
    assert steps[0] < steps[1] < steps[2]
    assert errs[0] > errs[1] > errs[2]
    # local error of order 3: about 10^(2/3) = 4.6 times the steps per two decades of rtol
    assert 3.0 < steps[1] / steps[0] < 7.0 and 3.0 < steps[2] / steps[1] < 7.0
    assert errs[2] < 5e-5


def _hard_pair(t, y):
    """A forced pair with a strong cubic spring: Newton fails on steps of a few hundredths of a second."""
    x, v = y[:2], y[2:]
    return np.concatenate([v, [-2e4 * x[0] ** 3 - 10 * x[0] + 5 * np.sin(20 * t) + 100 * (x[1] - x[0]),
                               -100 * (x[1] - x[0]) - 1e3 * x[1] * abs(x[1])]])


def _run_logging_newton_failures(regrowth, monkeypatch):
    """The hard pair at a step floor Newton fails on: (solver, steps halved by failures, steps bounded)."""
    import flexmb.genalpha.solver as solver_module

    monkeypatch.setattr(solver_module, "NEWTON_REGROWTH", regrowth)
    solver = generalized_alpha(0.5, min_step=0.02)(_hard_pair, 0.0, np.array([0.3, -0.2, 0.0, 1.0]), 1.0,
                                                   rtol=1e-6, atol=1e-8)
    halved = []  # the steps a Newton failure with a current Jacobian halved to
    newton = solver._newton

    def logged(t1, h):
        out = newton(t1, h)
        if out[0] is None and solver.jac_current:
            halved.append(0.5 * abs(h))
        return out

    solver._newton = logged
    since, n_failed, held = 0, 0, 0  # steps accepted since the last failure; failures; steps the bound set
    while solver.status == "running":
        solver.step()
        if len(halved) > n_failed:
            n_failed, since = len(halved), 0
        if n_failed:
            bound = halved[-1] * regrowth**since
            assert solver.step_size <= bound * (1 + 1e-12), (solver.t, solver.step_size, bound)
            held += solver.step_size > bound * (1 - 1e-9)
        since += 1
    assert solver.status == "finished"
    return solver, halved, held


def test_after_a_newton_failure_the_step_grows_back_by_at_most_newton_regrowth(monkeypatch):
    from flexmb.genalpha.solver import NEWTON_REGROWTH

    solver, halved, held = _run_logging_newton_failures(NEWTON_REGROWTH, monkeypatch)
    assert halved and held > 20, "Newton failed, and the bound set the step after it (the floor asked for more)"
    # without the bound the steps go straight back to the floor and Newton fails there again and again
    unbounded, halved_unbounded, _ = _run_logging_newton_failures(1e300, monkeypatch)
    assert len(halved_unbounded) > 5 * len(halved)
    assert solver.nfev < unbounded.nfev


def test_f_max_lets_the_steps_skip_a_stiff_mode_and_keeps_the_slow_one():
    fun, jac = oscillator([1.0, 1000.0])
    y0 = [1.0, 1e-3, 0.0, 0.0]
    full = solve_ivp(fun, (0, 1.0), y0, method=GeneralizedAlpha, rtol=1e-5, atol=1e-7, jac=jac)
    cut = solve_ivp(fun, (0, 1.0), y0, method=generalized_alpha(0.8, f_max=10.0), rtol=1e-5, atol=1e-7, jac=jac)
    assert cut.t.size < full.t.size / 10
    assert abs(cut.y[0, -1] - np.cos(1.0)) < 1e-3
    assert abs(cut.y[1, -1]) < 1e-4  # the fast mode is dissipated, not resolved


def test_min_step_keeps_the_steps_above_it_and_dissipates_a_fast_mode_at_the_predicted_rate():
    from flexmb.genalpha import numerical_damping

    fun, jac = oscillator([1.0, 300.0])
    h = 1.0 / 300.0  # h omega = 1 for the fast mode
    sol = solve_ivp(fun, (0, 1.0), [1.0, 1e-3, 0.0, 0.0], method=generalized_alpha(0.5, f_max=10.0, min_step=h),
                    rtol=1e-8, atol=1e-10, jac=jac)
    steps = np.diff(sol.t)
    assert steps[0] == pytest.approx(h) and np.all(steps[:-1] >= h * (1 - 1e-12))
    # each step of size h_i takes exp(-zeta(h_i omega) h_i omega) of the fast mode's amplitude
    hw = 300.0 * steps
    predicted = 1e-3 * np.exp(-np.sum(numerical_damping(0.5, hw) * hw))
    assert predicted < 1e-5  # a real loss ...
    # ... as predicted (the phase at t = 1 s makes hypot(x, v / omega) a rough amplitude at h omega of 1 to 3)
    assert np.hypot(sol.y[1, -1], sol.y[3, -1] / 300.0) == pytest.approx(predicted, rel=0.15)
    # the slow mode (h omega <= 1 / 100) is integrated at rtol by the error control above the floor
    assert abs(sol.y[0, -1] - np.cos(1.0)) < 1e-5


def test_finite_difference_jacobian_and_first_order_extra_states():
    # y = (x, v, w) with w' = v^2 (a work-like integral nothing depends on): no jac, n_second given
    w = 1.5

    def fun(t, y):
        return np.array([y[1], -w * w * y[0], y[1] ** 2])

    sol = solve_ivp(fun, (0, 2 * np.pi / w), [1.0, 0.0, 0.0], method=GeneralizedAlpha, n_second=1, rtol=1e-8,
                    atol=1e-10, dense_output=True)
    # over one period, int v^2 dt = w^2 * pi / w = pi w
    assert sol.y[2, -1] == pytest.approx(np.pi * w, rel=1e-5)
    t = np.linspace(0, 2 * np.pi / w, 37)
    assert np.max(np.abs(sol.sol(t)[0] - np.cos(w * t))) < 1e-5
    assert np.max(np.abs(sol.sol(t)[1] + w * np.sin(w * t))) < 3e-5


def test_invalid_options():
    with pytest.raises(ValueError, match="rho_inf"):
        generalized_alpha(1.5)
    with pytest.raises(ValueError, match="fixed_step"):
        generalized_alpha(0.8, fixed_step=-1.0)
    with pytest.raises(ValueError, match="f_max"):
        generalized_alpha(0.8, f_max=0.0)
    with pytest.raises(ValueError, match="min_step"):
        generalized_alpha(0.8, min_step=-1e-3)
    with pytest.raises(ValueError, match="min_step"):
        GeneralizedAlpha(lambda t, y: -y, 0.0, np.zeros(2), 1.0, min_step=0.0)
    with pytest.raises(ValueError, match="n_second"):
        GeneralizedAlpha(lambda t, y: y, 0.0, np.zeros(3), 1.0)


def test_registered_by_name_and_configurable():
    assert fm.INTEGRATORS["GeneralizedAlpha"] is GeneralizedAlpha
    cls = fm.generalized_alpha(rho_inf=0.6)
    assert issubclass(cls, GeneralizedAlpha) and cls.rho_inf == 0.6 and GeneralizedAlpha.rho_inf == 0.8


def test_pendulum_against_a_tight_dop853_reference():
    model = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", mass=1.0, length=1.0)
    model.add(fm.Revolute("pin", model.ground, bar), fm.Gravity((0, -9.81, 0)))
    ref = fm.simulate(model, 1.0, positions={"pin": 0.5}, method="DOP853", rtol=1e-12, n_out=21)
    res = fm.simulate(model, 1.0, positions={"pin": 0.5}, method="GeneralizedAlpha", rtol=1e-8, n_out=21)
    assert res.method == "GeneralizedAlpha"
    assert np.max(np.abs(res.x - ref.x)) < 2e-5
    assert np.max(np.abs(res.energy - res.energy[0])) < 1e-5 * np.max(np.abs(res.kinetic))


def test_b1_against_a_tight_dop853_reference():
    model = fm.Model("B1 N=4")
    beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(), 4,
                           keep=("bend_y",), damping=7.7398e-4)
    model.add(fm.Fixed("clamp", model.ground, beam), fm.Gravity((0.0, 0.0, -9.81)))
    ref = fm.simulate(model, 0.1, method="DOP853", rtol=1e-12, n_out=11)
    res = fm.simulate(model, 0.1, method="GeneralizedAlpha", rtol=1e-7, n_out=11)
    tip, tip_ref = res.shape("beam")[:, -1, 2], ref.shape("beam")[:, -1, 2]
    assert np.max(np.abs(tip - tip_ref)) < 1e-6
    assert res.n_jac <= 5  # the analytic Jacobian is reused over the steps
    assert res.n_rhs < 3.5 * res.n_steps + 20


def test_fourbar_with_constraint_projection():
    model, initial, fixed = fourbar()
    ref = fm.simulate(model, 0.3, positions=initial, fixed=fixed, method="DOP853", rtol=1e-12, n_out=11)
    res = fm.simulate(model, 0.3, positions=initial, fixed=fixed, method="GeneralizedAlpha", rtol=1e-6, n_out=11)
    assert res.n_projections > 0  # restarted after each projection, from the previous instance's memory
    assert np.max(res.residual) <= 1e-10
    assert np.max(np.abs(res.x[:, 0] - ref.x[:, 0])) < 2e-4
    assert np.max(np.abs(res.energy - res.energy[0])) < 5e-4 * np.max(res.kinetic)
    assert res.n_steps < 600


def test_work_balance_of_a_driven_oscillator_without_dissipation():
    # a driven crank with a torsion spring: the work (trapezoidal rule on the powers) balances
    # the change of kinetic energy to the method's second-order error
    model = fm.Model()
    hub = fm.RigidBody.slender_bar("hub", 1.0, 0.2)
    arm = fm.RigidBody.slender_bar("arm", 0.5, 0.3)
    drive = fm.Revolute("drive", model.ground, hub)
    hinge = fm.Revolute("hinge", hub, arm, parent_point=(0.2, 0, 0))
    model.add(drive, hinge, fm.JointSpringDamper("spring", hinge, stiffness=20.0),
              fm.Driver.constant_speed("motor", drive, speed=2.0))
    errors = []
    for rtol in (1e-4, 1e-6):
        res = fm.simulate(model, 0.3, positions={"hinge": 0.5}, method=fm.generalized_alpha(1.0), rtol=rtol,
                          track_work=True, n_out=11)
        assert np.max(np.abs(res.work["driver motor"])) > 0.1
        balance = sum(res.work.values()) - (res.kinetic - res.kinetic[0])
        errors.append(np.max(np.abs(balance)) / np.max(np.abs(res.work["driver motor"])))
    assert errors[1] < 3e-3 and errors[1] < errors[0] / 10


def test_b6_scene_modes_and_a_short_dissipative_run():
    import os
    import sys

    sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
    b6 = pytest.importorskip("b6_slider_crank")
    model, initial = b6.scenes.b6()
    system = model.build()
    assert system.n_coords == 10 and system.n_constraints == 3  # crank, slider, rod pin, 7 bends; loop + driver
    # the rod's first in-plane mode in the mechanism is the pinned-pinned Euler-Bernoulli one (293.2 Hz)
    x, xd = fm.initial_state(system, 0.0, initial)
    w2 = np.sort(np.abs(np.linalg.eigvals(system.state_jacobian(0.0, x, 0 * xd)[10:, :10])))
    assert np.sqrt(w2[3]) / (2 * np.pi) == pytest.approx(b6.scenes.b6_rod_frequency(), rel=2e-3)
    res, wall, setup, system, cpu = b6.run(False, fm.generalized_alpha(0.8, f_max=600.0), 1e-3, 0.01, 11)
    terms = b6.energy_terms(res, damped=False)
    assert terms["physical_dissipation_J"] == 0.0
    # the integrator removes some of the impulsively excited segment modes' energy, a small part of the total
    assert 0.0 < terms["numerical_dissipation_J"] < 0.01 * terms["initial_kinetic_J"]
    assert res.n_steps < 200
    assert abs(b6.scenes.b6_midspan_deflection(res)[-1]) < 1e-2


def _pendulum_with_drag(t, y):
    """A nonlinear pendulum with drag, ``xdd = -sin x - 0.3 xd |xd|`` (a Jacobian that changes along the motion)."""
    return np.array([y[1], -np.sin(y[0]) - 0.3 * y[1] * abs(y[1])])


def _pendulum_jacobian(t, y):
    return np.array([[0.0, 1.0], [-np.cos(y[0]), -0.6 * abs(y[1])]])


@pytest.mark.parametrize("with_jacobian", [True, False])
def test_move_to_makes_the_accelerations_consistent_and_keeps_their_lag(with_jacobian):
    solver = GeneralizedAlpha(_pendulum_with_drag, 0.0, np.array([1.0, 0.5]), 10.0, n_second=1, rtol=1e-6, atol=1e-8,
                              jac=_pendulum_jacobian)
    for _ in range(20):
        solver.step()
    lag = solver.abar - solver.a
    assert abs(lag[0]) > 1e-6  # abar lags a: something to keep
    if with_jacobian:  # one taken at the step's end, so that the correction is exact to first order
        J = _pendulum_jacobian(solver.t, solver.y)
        solver.J = (J[1:, :1].copy(), J[1:, 1:].copy())
    else:
        solver.J = None  # a Jacobian is due: the accelerations are evaluated at the moved state
    y_end, t = solver.y.copy(), solver.t
    errors = []
    for size in (1e-3, 1e-4):
        probe = GeneralizedAlpha(_pendulum_with_drag, 0.0, np.array([1.0, 0.5]), 10.0, n_second=1, rtol=1e-6,
                                 atol=1e-8, jac=_pendulum_jacobian)
        probe.__dict__.update({k: v.copy() if isinstance(v, np.ndarray) else v for k, v in solver.__dict__.items()})
        moved = y_end + size * np.array([1.0, -2.0])
        probe.move_to(moved)
        assert probe.t == t and np.array_equal(probe.y, moved)
        np.testing.assert_allclose(probe.abar - probe.a, lag, rtol=0, atol=1e-15)  # the lag is kept
        errors.append(abs(probe.a[0] - _pendulum_with_drag(t, moved)[1]))
    if with_jacobian:  # a + Jx dx + Jv dxd: second order in the move
        assert errors[1] < 0.02 * errors[0] and errors[0] < 1e-5
    else:
        assert errors == [0.0, 0.0]
    probe.step()  # and the integration goes on from there
    assert probe.status == "running" and probe.t > t


def test_generalized_alpha_projects_its_state_past_its_tolerance_only():
    """Projections rationed to the drift past atol (in place) leave the outputs as accurate as one per step."""
    import os
    import sys

    sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
    import scenes

    class EveryStep(GeneralizedAlpha):
        """The integrator as simulate ran it before: projected past projection_tol, a new solver each time."""

        moves = False

    model, positions = scenes.b6(damped=True, n_segments=4)
    system = model.build(complement="articulated")
    kw = dict(positions=positions, n_out=51, progress=False)
    tight = fm.simulate(system, 0.1, method="CVODE_BDF", rtol=1e-11, atol=1e-13, **kw)
    new, old = (fm.simulate(system, 0.1, method=cls, rtol=1e-4, atol=1e-6, **kw)
                for cls in (GeneralizedAlpha, EveryStep))
    assert old.n_projections > 0.9 * old.n_steps  # the drift exceeds projection_tol after nearly every step
    assert new.n_projections < 0.2 * new.n_steps
    for res in (new, old):
        assert res.status == "finished" and np.max(res.residual) <= 1e-10  # outputs projected all the same
    rail = np.asarray(tight.coordinate("rail"))
    slider = [np.max(np.abs(np.asarray(r.coordinate("rail")) - rail)) for r in (new, old)]
    assert slider[0] <= slider[1] + 1e-6, slider  # no less accurate, to the position tolerance atol
    assert slider[0] < 2e-6
