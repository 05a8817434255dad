"""Physics validation of the dynamics against independent references.

Every test compares flexmb with something it does not compute itself:
closed-form results (the exact period of a physical pendulum, inverse
dynamics of a driven pendulum, the loop-closure angle of an RSSR linkage),
equations of motion written out by hand and integrated by scipy (double
pendulum, Euler's equations of a free top), conservation laws (energy,
angular momentum, linear momentum), the work-energy theorem for drivers, and
agreement between formulations that share no code path (eigen vs SVD
complement, planar vs spatial cut joint).

Conventions used below: a Revolute about z with gravity along -y; in the
reference configuration (all coordinates zero) each joint's child frame
coincides with its parent frame.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import cumulative_simpson, solve_ivp
from scipy.interpolate import CubicHermiteSpline
from scipy.optimize import brentq
from scipy.special import ellipk

import flexmb as fm

from conftest import fourbar, fourbar_initial, slender_pendulum_chain

G = 9.81


def _report(name, **values):
    """Print measured errors (visible with ``pytest -s`` / in failure output)."""
    print(f"[{name}] " + ", ".join(f"{k} = {v:.3e}" for k, v in values.items()))


def _power_balance(t, power, energy):
    """Errors of the work-energy balance ``dE/dt = P``.

    Primary check (used for the 1e-6 bound): integrate the power with
    composite Simpson (4th order, ``cumulative_simpson``) and compare the work
    ``W(t)`` with ``E(t) - E(0)``. Integrating is robust: the energy samples
    carry the solver's dense-output noise (~rtol), which a finite difference
    divides by the step ``h`` but a quadrature does not amplify.

    Secondary check: the 4th-order central difference
    ``(E[i-2] - 8E[i-1] + 8E[i+1] - E[i+2]) / 12h`` against P pointwise, which
    catches a wrong effort at isolated instants that could integrate out.

    Returns
    -------
    work_err : float
        ``max |W - (E - E0)| / (P_peak * duration)``.
    rate_err : float
        ``max |dE/dt - P| / P_peak`` on the interior points.
    """
    p_peak = np.abs(power).max()
    work = cumulative_simpson(power, x=t, initial=0.0)
    work_err = np.abs(work - (energy - energy[0])).max() / (p_peak * (t[-1] - t[0]))
    h = t[1] - t[0]
    assert np.allclose(np.diff(t), h), "the difference formula needs equal steps"
    dE = (energy[:-4] - 8 * energy[1:-3] + 8 * energy[3:-1] - energy[4:]) / (12 * h)
    rate_err = np.abs(dE - power[2:-2]).max() / p_peak
    return work_err, rate_err


# ----------------------------------------------------------------------------------------------
# 1. Physical pendulum at large amplitude: exact period from the complete elliptic integral
# ----------------------------------------------------------------------------------------------

def test_physical_pendulum_period_matches_elliptic_integral():
    m, L = 1.3, 0.8
    # a uniform bar hanging along -y from the pivot: the angle is measured from the downward vertical
    bar = fm.RigidBody("bar", m, (m * L**2 / 12, 0.0, m * L**2 / 12), com=(0.0, -L / 2, 0.0))
    model = fm.Model("pendulum")
    model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1)), fm.Gravity((0.0, -G, 0.0)))

    theta0 = np.radians(120.0)
    I_O, d = m * L**2 / 3, L / 2
    k = np.sin(theta0 / 2)
    T_exact = 4 * np.sqrt(I_O / (m * G * d)) * ellipk(k**2)  # scipy's ellipk takes the parameter m = k^2
    # sanity: the large-amplitude period is much longer than the small-angle one
    assert T_exact > 1.3 * 2 * np.pi * np.sqrt(I_O / (m * G * d))

    res = fm.simulate(model, 2.2 * T_exact, positions={"pin": theta0}, rtol=1e-12, atol=1e-14, n_out=2001)
    assert res.status == "finished"
    # rest points: roots of the angular speed, located on the cubic Hermite interpolant built from the
    # speed and acceleration samples (4th order in the 1.1 ms sample spacing, far below 1e-8 T)
    w, a = res.xd[:, 0], res.xdd[:, 0]
    roots = CubicHermiteSpline(res.t, w, a).roots(extrapolate=False)
    roots = roots[roots > 0.1 * T_exact]
    assert len(roots) == 4  # T/2, T, 3T/2, 2T
    half_period_err = abs(roots[0] - T_exact / 2) / (T_exact / 2)
    period_errs = np.abs(roots / (np.arange(1, 5) * T_exact / 2) - 1)
    # first return to rest is on the other side, at -120 deg
    i = np.argmin(np.abs(res.t - roots[0]))
    _report("pendulum period", half_period_rel=half_period_err, all_rel=period_errs.max(),
            angle_at_first_rest=abs(res.x[i, 0] + theta0))
    assert half_period_err < 1e-8
    assert period_errs.max() < 1e-8
    assert abs(res.x[i, 0] + theta0) < 1e-3  # coarse: the sample nearest the root


# ----------------------------------------------------------------------------------------------
# 2. Conservative double pendulum: energy over 10 s, and the trajectory vs Lagrange's equations
# ----------------------------------------------------------------------------------------------

DP_T = np.linspace(0.0, 10.0, 1001)
DP_INIT = dict(positions={"pin0": 0.0, "pin1": 1.0}, speeds={"pin1": 0.0})  # both bars horizontal-ish: chaotic


@pytest.fixture(scope="module")
def double_pendulum():
    model = slender_pendulum_chain(2)  # m = 1 kg, L = 1 m per bar
    return fm.simulate(model, 10.0, **DP_INIT, rtol=1e-10, atol=1e-12, t_eval=DP_T)


def test_double_pendulum_energy_drift(double_pendulum):
    res = double_pendulum
    assert res.status == "finished"
    scale = np.abs(res.potential).max()  # = 2 m g L here
    drift = np.abs(res.energy - res.energy[0]).max() / scale
    # the motion is far from trivial: large swings of both links
    assert np.ptp(res.x[:, 1]) > 2.0 and np.ptp(res.x[:, 0]) > 1.0
    _report("double pendulum", energy_drift_rel=drift, scale_J=scale, wall_s=res.wall_time)
    assert drift < 1e-8


def _double_pendulum_lagrange(t, y, m=1.0, L=1.0):
    """Two uniform bars, absolute angles p1, p2 from +x, gravity -y (derived by hand)."""
    p1, p2, w1, w2 = y
    c, s = m * L * L / 2, np.sin(p1 - p2)
    M = np.array([[4.0 / 3.0 * m * L * L, c * np.cos(p1 - p2)], [c * np.cos(p1 - p2), m * L * L / 3.0]])
    Q = np.array([-1.5 * m * G * L * np.cos(p1) - c * s * w2**2, -0.5 * m * G * L * np.cos(p2) + c * s * w1**2])
    return [w1, w2, *np.linalg.solve(M, Q)]


def test_double_pendulum_matches_lagrange_equations(double_pendulum):
    res = double_pendulum
    y0 = [0.0, 0.0 + 1.0, 0.0, 0.0]
    ref = solve_ivp(_double_pendulum_lagrange, (0.0, 10.0), y0, method="DOP853", rtol=1e-13, atol=1e-13,
                    t_eval=DP_T)
    absolute = np.column_stack([res.x[:, 0], res.x[:, 0] + res.x[:, 1]])
    early = DP_T <= 3.0  # chaotic: compare before the 1e-10 differences grow
    err = np.abs(absolute[early] - ref.y[:2].T[early]).max()
    _report("double pendulum vs Lagrange", max_angle_err_rad_3s=err)
    assert err < 1e-7


# ----------------------------------------------------------------------------------------------
# 3. Free asymmetric top: energy, angular momentum, mass-centre motion, Euler's equations
# ----------------------------------------------------------------------------------------------

def test_free_asymmetric_top_conserves_momenta():
    J = np.array([1.0, 2.0, 3.0])
    mass = 2.0
    model = fm.Model("top")
    top = fm.RigidBody("top", mass, J)
    model.add(fm.Free("free", model.ground, top))
    system = model.build()
    omega0 = np.array([0.1, -0.15, 2.0])  # mostly about the major axis (stable), with a visible wobble
    v0 = np.array([0.3, -0.2, 0.5])
    # at zero angles the Bryant rates are the inertial angular velocity components
    speeds = dict(zip(["free.x", "free.y", "free.z", "free.rx", "free.ry", "free.rz"], [*v0, *omega0]))
    res = fm.simulate(system, 10.0, speeds=speeds, rtol=1e-10, atol=1e-12, n_out=501)
    assert res.status == "finished"

    k = system.index(top)
    H = np.empty((len(res.t), 3))
    w_body = np.empty((len(res.t), 3))
    for i, (t, x, xd) in enumerate(zip(res.t, res.x, res.xd)):
        kin = system.kinematics(t, x, xd)
        R, w = kin.R[k], kin.omega[k]
        H[i] = R @ np.diag(J) @ R.T @ w  # from the definition, not from flexmb's inertia_world
        w_body[i] = R.T @ w
    T0 = 0.5 * mass * v0 @ v0 + 0.5 * omega0 @ (J * omega0)
    H_err = np.abs(H - J * omega0).max() / np.linalg.norm(J * omega0)
    ke_err = np.abs(res.kinetic - T0).max() / T0
    # mass centre: straight line at constant velocity
    com_err = np.abs(res.body_position("top") - res.t[:, None] * v0).max()

    # Euler's equations in body axes, integrated independently
    def euler(t, w):
        return [(J[1] - J[2]) * w[1] * w[2] / J[0], (J[2] - J[0]) * w[2] * w[0] / J[1],
                (J[0] - J[1]) * w[0] * w[1] / J[2]]

    ref = solve_ivp(euler, (0.0, 10.0), omega0, method="DOP853", rtol=1e-13, atol=1e-14, t_eval=res.t)
    euler_err = np.abs(w_body - ref.y.T).max() / np.linalg.norm(omega0)
    _report("free top", H_rel=H_err, kinetic_rel=ke_err, com_abs_m=com_err, euler_rel=euler_err,
            wall_s=res.wall_time)
    # the body axes really wobble (otherwise the conservation checks are trivial)
    assert np.ptp(w_body[:, 0]) > 0.3
    assert H_err < 1e-8
    assert ke_err < 1e-8
    assert com_err < 1e-9
    assert euler_err < 1e-8


# ----------------------------------------------------------------------------------------------
# 4. Benchmark B5 four-bar: planar/spatial cut, eigen/SVD complement
# ----------------------------------------------------------------------------------------------

FB_T = np.linspace(0.0, 2.0, 401)
FB_CASES = [(fm.PlanarRevolute, "svd"), (fm.PlanarRevolute, "eigen"), (fm.Revolute, "svd"), (fm.Revolute, "eigen")]


@pytest.fixture(scope="module")
def fourbar_runs():
    out = {}
    for cut, comp in FB_CASES:
        system = fourbar(cut).build(complement=comp)
        res = fm.simulate(system, 2.0, positions=fourbar_initial(np.pi / 4), fixed=["A"], rtol=1e-10,
                          atol=1e-12, t_eval=FB_T)  # speeds default to zero: released at rest
        out[cut.__name__, comp] = (system, res)
    return out


FB_IDS = [f"{c.__name__}-{s}" for c, s in FB_CASES]


@pytest.mark.parametrize("case", FB_CASES, ids=FB_IDS)
def test_fourbar_loop_closure_energy_and_dof(fourbar_runs, case):
    system, res = fourbar_runs[case[0].__name__, case[1]]
    assert res.status == "finished"
    assert system.n_constraints == (2 if case[0] is fm.PlanarRevolute else 5)
    dof = system.dof(res.t[0], res.x[0])
    scale = np.abs(res.potential).max()
    drift = np.abs(res.energy - res.energy[0]).max() / scale
    _report(f"fourbar {FB_IDS[FB_CASES.index(case)]}", residual=res.residual.max(),
            velocity_residual=res.velocity_residual.max(), energy_drift_rel=drift,
            projections=res.n_projections, wall_s=res.wall_time)
    assert dof == 1
    assert np.allclose(res.x[0, 0], np.pi / 4, atol=1e-14)  # crank held during assembly
    assert np.abs(res.xd[0]).max() < 1e-14
    assert np.ptp(res.x[:, 0]) > 1.0  # it really swings
    assert res.residual.max() < 1e-9
    assert drift < 1e-8


def test_fourbar_eigen_and_svd_agree(fourbar_runs):
    for cut in ("PlanarRevolute", "Revolute"):
        a, b = fourbar_runs[cut, "svd"][1], fourbar_runs[cut, "eigen"][1]
        dx = np.abs(a.x - b.x).max()
        dv = np.abs(a.xd - b.xd).max() / np.abs(a.xd).max()
        _report(f"fourbar {cut}: eigen vs svd", x_abs_rad=dx, xd_rel=dv)
        assert dx < 1e-8
        assert dv < 1e-8


def test_fourbar_planar_and_spatial_cut_agree(fourbar_runs):
    for comp in ("svd", "eigen"):
        a, b = fourbar_runs["PlanarRevolute", comp][1], fourbar_runs["Revolute", comp][1]
        dx = np.abs(a.x - b.x).max()
        dv = np.abs(a.xd - b.xd).max() / np.abs(a.xd).max()
        _report(f"fourbar {comp}: planar vs spatial", x_abs_rad=dx, xd_rel=dv)
        assert dx < 1e-8
        assert dv < 1e-8


def test_fourbar_with_frequent_projections_conserves_energy():
    """Projecting after (almost) every step must keep the loop closed without spoiling energy.

    Also guards the solver restart after a projection near t_end (the first
    step must not overshoot t_end; scipy raised 'first_step exceeds bounds'
    before commit e13bb9a).
    """
    res = fm.simulate(fourbar(), 0.3, positions=fourbar_initial(np.pi / 4), fixed=["A"], rtol=1e-8,
                      projection_tol=1e-13, n_out=61)
    drift = np.abs(res.energy - res.energy[0]).max() / np.abs(res.potential).max()
    _report("fourbar, frequent projections", projections=res.n_projections, residual=res.residual.max(),
            energy_drift_rel=drift)
    assert res.n_projections > 10
    assert res.residual.max() < 1e-8
    assert drift < 1e-7


# ----------------------------------------------------------------------------------------------
# 5. Driver power balance: driver effort x driven speed = d/dt (kinetic + potential)
# ----------------------------------------------------------------------------------------------

DRIVE_T = np.linspace(0.0, 1.0, 2001)  # one crank turn at 2 pi rad/s, h = 0.5 ms


def test_fourbar_driven_crank_power_balance_kinematic():
    """Rigid four-bar with the crank driven: a kinematically driven mechanism (p = 0)."""
    model = fourbar()
    model.add(fm.Driver.constant_speed("motor", model["A"], speed=2 * np.pi, start=np.pi / 4))
    system = model.build()
    res = fm.simulate(system, 1.0, positions=fourbar_initial(np.pi / 4), rtol=1e-10, atol=1e-12, t_eval=DRIVE_T)
    assert res.status == "finished"
    assert system.dof(res.t[0], res.x[0]) == 0
    assert res.residual.max() < 1e-9
    assert np.abs(res.coordinate("A") - (np.pi / 4 + 2 * np.pi * res.t)).max() < 1e-9
    work_err, rate_err = _power_balance(res.t, res.driver_effort("motor") * res.xd[:, 0], res.energy)
    _report("driven fourbar (p = 0)", work_rel=work_err, rate_rel=rate_err)
    assert work_err < 1e-6 and rate_err < 1e-6


def test_fourbar_driven_crank_with_flywheel_power_balance():
    """The driven four-bar plus a spring-mounted flywheel on the coupler (p = 1), under gravity.

    The flywheel on a torsion spring (a JointSpringDamper, conservative) keeps
    one free degree of freedom that exchanges energy with the driven linkage,
    so the driver torque carries genuine dynamics, not only inverse kinematics.
    """
    model = fourbar()
    crank_joint = model["A"]
    wheel = fm.RigidBody("flywheel", 0.2, (1e-4, 1e-4, 2e-4))
    hub = fm.Revolute("W", model["coupler"], wheel, parent_point=(0.15, 0, 0), axis=(0, 0, 1))
    model.add(hub, fm.JointSpringDamper("torsion", hub, stiffness=0.05),
              fm.Driver.constant_speed("motor", crank_joint, speed=2 * np.pi, start=np.pi / 4))
    system = model.build()
    res = fm.simulate(system, 1.0, positions=fourbar_initial(np.pi / 4), speeds={"W": 3.0}, rtol=1e-10,
                      atol=1e-12, t_eval=DRIVE_T)
    assert res.status == "finished"
    assert system.dof(res.t[0], res.x[0]) == 1
    crank_speed = res.xd[:, res.coordinate_names.index("A.angle")]
    power = res.driver_effort("motor") * crank_speed
    work_err, rate_err = _power_balance(res.t, power, res.energy)
    _report("driven fourbar + flywheel", work_rel=work_err, rate_rel=rate_err,
            crank_err=np.abs(res.coordinate("A") - (np.pi / 4 + 2 * np.pi * res.t)).max(),
            residual=res.residual.max(), P_peak_W=np.abs(power).max())
    assert np.ptp(res.coordinate("W")) > 0.1  # the flywheel really moves on its spring
    assert np.abs(res.coordinate("A") - (np.pi / 4 + 2 * np.pi * res.t)).max() < 1e-9
    assert np.abs(crank_speed - 2 * np.pi).max() < 1e-8
    assert res.residual.max() < 1e-9
    assert work_err < 1e-6
    assert rate_err < 1e-6


# --- spatial RSSR: crank about z at the origin, rocker about x at D, coupler with two ball joints

RSSR_A, RSSR_B, RSSR_C = 0.1, 0.4, 0.25  # crank, coupler, rocker lengths, m
RSSR_D = np.array([0.2, 0.0, 0.25])  # rocker pivot, m; coupler length stays inside [0.30, 0.51] m


def _rssr_rocker_angles(theta):
    """All rocker angles closing the loop at crank angle theta (independent loop-closure solve).

    Crank tip B = a (cos, sin, 0); rocker tip C = D + c (0, cos phi, sin phi); |C - B| = b.
    """
    B = RSSR_A * np.array([np.cos(theta), np.sin(theta), 0.0])

    def f(phi):
        return np.linalg.norm(RSSR_D + RSSR_C * np.array([0.0, np.cos(phi), np.sin(phi)]) - B) - RSSR_B

    grid = np.linspace(-np.pi, np.pi, 361)
    vals = np.linalg.norm(RSSR_D + RSSR_C * np.column_stack([0 * grid, np.cos(grid), np.sin(grid)]) - B,
                          axis=1) - RSSR_B
    idx = np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))
    return np.array([brentq(f, grid[i], grid[i + 1], xtol=1e-15) for i in idx])


def test_rssr_spatial_linkage_driven_power_balance():
    a, b, c = RSSR_A, RSSR_B, RSSR_C
    model = fm.Model("rssr")
    crank = fm.RigidBody.slender_bar("crank", 0.2, a)
    mc, radius = 0.4, 0.01  # the coupler is a thin rod with axial inertia: its spin is an idle freedom
    coupler = fm.RigidBody("coupler", mc, (mc * radius**2 / 2, mc * b**2 / 12, mc * b**2 / 12),
                           com=(b / 2, 0.0, 0.0))
    rocker = fm.RigidBody.slender_bar("rocker", 0.25, c, axis=1)  # along +y in the reference configuration
    # Bryant angles of the tree ball joint: first axis = crank z, third axis = coupler axis (the spin).
    # They are singular only if the coupler lies along the crank z axis, which this geometry never reaches.
    Fp = np.column_stack([[0.0, 0, 1], [1.0, 0, 0], [0.0, 1, 0]])
    Fc = np.column_stack([[0.0, 1, 0], [0.0, 0, 1], [1.0, 0, 0]])
    motor_joint = fm.Revolute("A", model.ground, crank, axis=(0, 0, 1))
    model.add(
        motor_joint,
        fm.Spherical("B", crank, coupler, parent_point=(a, 0, 0), parent_frame=Fp, child_frame=Fc),
        fm.Revolute("D", model.ground, rocker, parent_point=RSSR_D, axis=(1, 0, 0)),
        fm.Spherical("C", coupler, rocker, parent_point=(b, 0, 0), child_point=(0, c, 0)),
        fm.Gravity((0.0, 0.0, -G)),
        fm.Driver.constant_speed("motor", motor_joint, speed=2 * np.pi),
    )
    system = model.build()
    assert system.constraints.labels == ["C.point.x", "C.point.y", "C.point.z", "driver motor"]

    # initial guess: the upper closure branch, coupler direction from Bryant angles with zero spin angle
    phi0 = _rssr_rocker_angles(0.0).max()
    u = (RSSR_D + c * np.array([0.0, np.cos(phi0), np.sin(phi0)]) - np.array([a, 0.0, 0.0])) / b
    w = Fp.T @ u  # = Rx(alpha) Ry(beta) e3
    guess = {"A": 0.0, "D": phi0, "B.rx": np.arctan2(-w[1], w[2]), "B.ry": np.arcsin(w[0]), "B.rz": 0.0}
    res = fm.simulate(system, 1.0, positions=guess, fixed=["A"], rtol=1e-10, atol=1e-12, t_eval=DRIVE_T)
    assert res.status == "finished"
    assert system.dof(res.t[0], res.x[0]) == 1  # the idle spin of the coupler
    assert np.abs(res.coordinate("B.ry")).max() < 1.3  # well away from the Bryant singularity

    # independent kinematics: the rocker angle from the loop-closure equation, following the branch
    phi_ref, prev = np.empty(len(res.t)), phi0
    for i, th in enumerate(res.coordinate("A")):
        roots = _rssr_rocker_angles(th)
        prev = roots[np.argmin(np.abs(np.angle(np.exp(1j * (roots - prev)))))]
        phi_ref[i] = prev
    rocker_err = np.abs(np.angle(np.exp(1j * (res.coordinate("D") - phi_ref)))).max()

    # spin of the axisymmetric coupler about its own axis is conserved (no axial torque)
    k = system.index(coupler)
    spin = np.array([(lambda kin: kin.omega[k] @ kin.R[k][:, 0])(system.kinematics(t, x, xd))
                     for t, x, xd in zip(res.t[::50], res.x[::50], res.xd[::50])])

    power = res.driver_effort("motor") * res.xd[:, res.coordinate_names.index("A.angle")]
    work_err, rate_err = _power_balance(res.t, power, res.energy)
    _report("RSSR", work_rel=work_err, rate_rel=rate_err, rocker_err_rad=rocker_err,
            residual=res.residual.max(), spin_drift=np.ptp(spin), P_peak_W=np.abs(power).max())
    assert np.ptp(res.coordinate("D")) > 0.5  # the rocker really swings
    assert res.residual.max() < 1e-9
    assert rocker_err < 1e-8
    assert np.ptp(spin) < 1e-8
    assert work_err < 1e-6
    assert rate_err < 1e-6


# ----------------------------------------------------------------------------------------------
# 6. Rheonomic: harmonically driven pendulum carrying a free flywheel
# ----------------------------------------------------------------------------------------------

def test_harmonically_driven_pendulum_follows_and_torque_matches_closed_form():
    """Pendulum arm driven by theta(t) = offset + A sin(2 pi f t), carrying a free wheel at its tip.

    The wheel (pinned at its own mass centre, no torque about its axis) keeps
    its absolute spin, so it loads the arm like a point mass m_w at distance l:

        tau = (I_O + m_w l^2) theta'' + (m d + m_w l) g sin(theta),

    theta measured from the downward vertical, I_O = I_zz,c + m d^2; and its
    relative angle is psi(t) = psi0 + (theta'(0) + psi'(0)) t - (theta(t) - theta(0)).
    The wheel is the model's one free degree of freedom, so the driven arm
    carries a body with its own dynamics, checked by the closed form for psi.
    """
    m, d, Izz = 1.2, 0.35, 0.05  # arm: mass, pivot-to-centre distance, central inertia about z
    mw, ell, Jw = 0.5, 0.6, 4e-3  # wheel: mass, pivot-to-hub distance, axial inertia
    amp, freq, offset = 0.9, 0.8, 0.3
    arm = fm.RigidBody("arm", m, (0.04, 0.01, Izz), com=(0.0, -d, 0.0))
    wheel = fm.RigidBody("wheel", mw, (Jw / 2, Jw / 2, Jw))
    model = fm.Model("driven pendulum")
    pin = fm.Revolute("pin", model.ground, arm, axis=(0, 0, 1))
    hub = fm.Revolute("hub", arm, wheel, parent_point=(0.0, -ell, 0.0), axis=(0, 0, 1))
    model.add(pin, hub, fm.Gravity((0.0, -G, 0.0)),
              fm.Driver.harmonic("motor", pin, amplitude=amp, frequency=freq, offset=offset))
    psi0, psid0 = 0.2, 5.0
    res = fm.simulate(model, 2.0, positions={"hub": psi0}, speeds={"hub": psid0}, rtol=1e-10, atol=1e-12,
                      n_out=401)
    assert res.status == "finished"
    t = res.t
    wt = 2 * np.pi * freq
    theta = offset + amp * np.sin(wt * t)
    theta_dd = -amp * wt**2 * np.sin(wt * t)
    I_O = Izz + m * d**2
    tau_ref = (I_O + mw * ell**2) * theta_dd + (m * d + mw * ell) * G * np.sin(theta)
    tau = res.driver_effort("motor")
    psi_ref = psi0 + (amp * wt + psid0) * t - (theta - offset)

    theta_err = np.abs(res.coordinate("pin") - theta).max()
    tau_err = np.abs(tau - tau_ref).max() / np.abs(tau_ref).max()
    psi_err = np.abs(res.coordinate("hub") - psi_ref).max()
    _report("driven pendulum", theta_err_rad=theta_err, torque_rel=tau_err, wheel_angle_err_rad=psi_err,
            tau_peak_Nm=np.abs(tau_ref).max())
    assert np.isclose(res.xd[0, res.coordinate_names.index("hub.angle")], psid0)  # the held initial wheel rate
    assert theta_err < 1e-9
    assert psi_err < 1e-8
    assert tau_err < 1e-6
