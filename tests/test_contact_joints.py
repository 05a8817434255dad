"""Contact elements (#30, stage 2): the revolute clearance joint and a block stick-slipping on a belt.

Closed forms and references used below:

* A pin launched from the centre of a fixed bearing, across the
  clearance, with ``F = K delta^n (1 + chi delta_dot / v_in)``: the
  rebound ratio ``restitution_of_hysteresis(chi)`` (the 1-dof impact of
  ``tests/test_contact.py``), at every direction across the axis; the
  penetration is ``|e| - c`` along ``-e / |e|``.
* A block of mass m on a spring k, pressed with the normal force N on a
  belt moving at v_b, Stribeck friction
  ``mu(v) = mu_k + (mu_s - mu_k) exp(-(v / v_st)^2)``: the limit cycle of
  ``m x'' = -k x - N mu(|x' - v_b|) sign(x' - v_b)`` with sticking
  (``x' = v_b`` while ``|k x| <= mu_s N``), integrated independently
  with scipy's ``solve_ivp`` (DOP853, rtol 1e-12) from event to event
  (the end of a slip: the relative speed through 0; the end of a stick:
  ``k x = mu_s N``, in closed form). Its period is compared with flexmb's
  regularised friction on a point-on-plane contact whose plane is a
  driven body (the belt).
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb as fm
from flexmb.errors import ModelError
from flexmb.forces.contact import restitution_of_hysteresis

R_PIN, R_HOLE = 0.0095, 0.0100
CLEAR = R_HOLE - R_PIN


def _pin_in_ground(law, angle=0.0, friction=None):
    model = fm.Model()
    pin = fm.RigidBody("pin", mass=0.2, inertia=np.eye(3) * 1e-5)
    gap = fm.JournalBearingContact("gap", pin, R_PIN, model.ground, R_HOLE, law, friction=friction,
                                   bearing_axis=(0, 0, 1))
    model.add(fm.Free("free", model.ground, pin), gap)
    return model, gap


def test_journal_geometry_and_normal():
    """Penetration ``|e| - c`` across the axis (the axial offset ignored), force back towards the centre."""
    model, gap = _pin_in_ground(fm.LinearContactLaw(1e6))
    system = model.build()
    e = np.array([0.0003, 0.0004, 0.02])  # 0.5 mm across, 20 mm along the axis
    kin = system.kinematics(0.0, np.r_[e, 0, 0, 0], np.zeros(6))
    delta, rate, fn, energy, point, normal, force, slip = type(gap).states_all([gap], kin)
    assert delta[0] == pytest.approx(0.0005 - CLEAR, abs=1e-15)
    assert np.allclose(normal[0], [-0.6, -0.8, 0.0])
    assert fn[0] == pytest.approx(1e6 * (0.0005 - CLEAR))
    assert np.allclose(point[0], e + (R_PIN - delta[0] / 2) * np.array([0.6, 0.8, 0.0]))
    assert energy[0] == pytest.approx(0.5e6 * (0.0005 - CLEAR) ** 2)
    inside = system.kinematics(0.0, np.array([0.0002, 0.0, 0.0, 0, 0, 0]), np.zeros(6))
    assert type(gap).states_all([gap], inside)[2][0] == 0.0


def test_journal_friction_from_the_pins_spin():
    """Pressed on the wall and spinning, the pin's surface slides at ``w r_pin``: Coulomb friction opposes it."""
    model, gap = _pin_in_ground(fm.LinearContactLaw(1e6), friction=fm.CoulombLaw(0.2, smoothing_speed=1e-6))
    system = model.build()
    kin = system.kinematics(0.0, np.array([CLEAR + 1e-4, 0, 0, 0, 0, 0]), np.array([0, 0, 0, 0, 0, 50.0]))
    _, _, fn, _, point, normal, force, slip = type(gap).states_all([gap], kin)
    lever = R_PIN - 0.5e-4
    assert slip[0] == pytest.approx([0.0, 50.0 * lever, 0.0])
    assert force[0] == pytest.approx([-fn[0], -0.2 * fn[0] * 50 * lever / np.hypot(50 * lever, 1e-6), 0.0])


@pytest.mark.parametrize("angle", [0.0, 2.0])
def test_journal_impact_rebound_ratio(angle):
    """A free pin crossing the clearance rebounds off the wall at ``restitution_of_hysteresis(chi)``, any direction."""
    s = (1 - 0.3 ** 2) / 207e9
    K = 4.0 / (3.0 * 2.0 * s) * np.sqrt(R_PIN * R_HOLE / CLEAR)
    law = fm.FloresLaw(K, 0.7)
    model, gap = _pin_in_ground(law)
    v_in = 0.5
    d = np.array([np.cos(angle), np.sin(angle), 0.0])
    res = fm.simulate(model, 3 * CLEAR / v_in, x0=np.zeros(6), xd0=np.r_[v_in * d, 0, 0, 0], method="DOP853",
                      rtol=1e-10, atol=1e-14, max_step=2e-6, progress=False, n_out=11)
    assert res.status == "finished"
    e = -res.xd[-1, :3] @ d / v_in
    assert e == pytest.approx(restitution_of_hysteresis(law.chi), rel=1e-7)
    assert np.allclose(res.xd[-1, :3] - (res.xd[-1, :3] @ d) * d, 0.0, atol=1e-9 * v_in)


def test_journal_refuses_no_clearance():
    with pytest.raises(ModelError, match="'gap'.*bearing_radius must exceed pin_radius"):
        fm.JournalBearingContact("gap", "a", 0.01, "b", 0.01, fm.LinearContactLaw(1e6))


# ----------------------------------------------------------------------------- the belt

M_BLOCK, K_SPRING, N_LOAD, V_BELT = 1.0, 100.0, 10.0, 0.1
MU_S, MU_K, V_ST = 0.4, 0.25, 0.05
K_NORMAL = 1e6
LEVEL = 0.02  # the period is timed between the block's upward crossings of this height (during a stick)


def _stribeck(v):
    return MU_K + (MU_S - MU_K) * np.exp(-(v / V_ST) ** 2)


def reference_crossings(t_end):
    """The nonsmooth 1-dof block on the belt from rest at x = 0: times of its upward crossings of LEVEL."""
    from scipy.integrate import solve_ivp

    t, y, crossings = 0.0, np.array([0.0, 0.0]), []
    stick = False
    while t < t_end:
        if stick:  # carried by the belt until the spring reaches the breakaway force
            x_break = MU_S * N_LOAD / K_SPRING
            if y[0] < LEVEL <= x_break:
                crossings.append(t + (LEVEL - y[0]) / V_BELT)
            t += (x_break - y[0]) / V_BELT
            y, stick = np.array([x_break, V_BELT]), False
            continue
        # slipping: the sign of the relative speed holds until it passes 0 (from a stick: the spring pulls back)
        sign = np.sign(y[1] - V_BELT) if y[1] != V_BELT else -1.0

        def rhs(_, z, sign=sign):
            return [z[1], (-K_SPRING * z[0] - sign * N_LOAD * _stribeck(abs(z[1] - V_BELT))) / M_BLOCK]

        def relative(_, z):
            return z[1] - V_BELT

        def level(_, z):
            return z[0] - LEVEL

        relative.terminal, relative.direction, level.direction = True, -sign, 1
        sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=1e-12, atol=1e-14, events=(relative, level))
        crossings += list(sol.t_events[1])
        t, y = sol.t[-1], sol.y[:, -1].copy()
        if sol.status == 1:
            y[1] = V_BELT
            stick = abs(K_SPRING * y[0]) <= MU_S * N_LOAD
    return np.array(crossings)


def belt_model(smoothing_speed):
    """The block on a prismatic rail and a spring, a point on it pressed into the plane of a driven belt."""
    model = fm.Model()
    belt = fm.RigidBody("belt", mass=1.0, inertia=np.eye(3))
    block = fm.RigidBody("block", mass=M_BLOCK, inertia=np.eye(3) * 1e-3)
    drive = fm.Prismatic("drive", model.ground, belt, axis=(1, 0, 0))
    # the rail holds the point N / k_n into the belt's plane: the normal force is N at all times
    rail = fm.Prismatic("rail", model.ground, block, axis=(1, 0, 0), parent_point=(0, 0, -N_LOAD / K_NORMAL))
    pad = fm.SpherePlaneContact("pad", block, 0.0, fm.LinearContactLaw(K_NORMAL), plane_body=belt,
                                friction=fm.StribeckLaw(MU_S, MU_K, V_ST, smoothing_speed=smoothing_speed))
    model.add(drive, rail, fm.JointSpringDamper("spring", rail, stiffness=K_SPRING), pad,
              fm.Driver.constant_speed("motor", drive, V_BELT))
    return model


def upward_crossings(t, x, v, level):
    """Times where x passes level upwards, by cubic Hermite interpolation of (x, x') between outputs."""
    out = []
    for i in np.nonzero((x[:-1] < level) & (x[1:] >= level))[0]:
        h = t[i + 1] - t[i]
        lo, hi = 0.0, 1.0
        for _ in range(60):
            s = 0.5 * (lo + hi)
            p = ((2 * s ** 3 - 3 * s ** 2 + 1) * x[i] + (s ** 3 - 2 * s ** 2 + s) * h * v[i]
                 + (3 * s ** 2 - 2 * s ** 3) * x[i + 1] + (s ** 3 - s ** 2) * h * v[i + 1])
            lo, hi = (s, hi) if p < level else (lo, s)
        out.append(t[i] + h * 0.5 * (lo + hi))
    return np.array(out)


def test_reference_limit_cycle_is_periodic():
    """The reference's stick resets the state: every cycle after the first has the same period."""
    c = reference_crossings(4.0)
    assert len(c) >= 4
    assert np.ptp(np.diff(c)) < 1e-9


def test_block_on_a_belt_stick_slip_period():
    """The stick-slip period of the regularised Stribeck contact matches the nonsmooth reference to 1e-4.

    The regularisation (smoothing speed v_eps) lets the block creep while
    it should stick; the period's error falls with v_eps (-4.4e-4 at
    1e-5 m/s, -7.2e-5 at 1e-6, -1.2e-5 at 1e-7 measured).
    """
    t_end = 2.0
    ref = np.diff(reference_crossings(t_end))[-1]
    errors = []
    for eps in (1e-6, 1e-7):
        model = belt_model(eps)
        system = model.build()
        res = fm.simulate(system, t_end, n_out=2001, method="CVODE_BDF", rtol=1e-10, atol=1e-13, progress=False)
        at = system.coordinate_slice("rail").start
        period = np.diff(upward_crossings(res.t, res.x[:, at], res.xd[:, at], LEVEL))[-1]
        errors.append(period / ref - 1)
        print(f"\n[contact] belt, v_eps = {eps:g} m/s: period {period:.8f} s, reference {ref:.8f} s, "
              f"relative {errors[-1]:.3e}")
    assert abs(errors[-1]) < 1e-4
    assert abs(errors[-1]) < abs(errors[0]) / 3  # converging as v_eps falls


# ----------------------------------------------------------------------------- the implicit integrators' Jacobian

def _d_accel(system, x, xd, wrt, h=1e-7):
    """Central differences of the accelerations with respect to the coordinates (0) or the speeds (1)."""
    n = system.n_coords
    J = np.zeros((n, n))
    for i in range(n):
        e = np.zeros(n)
        e[i] = h
        a = (x + e, xd) if wrt == 0 else (x, xd + e)
        b = (x - e, xd) if wrt == 0 else (x, xd - e)
        J[:, i] = (system.accelerations(0.0, *a) - system.accelerations(0.0, *b)) / (2 * h)
    return J


@pytest.mark.parametrize("law, friction", [
    (fm.HuntCrossleyLaw(1e8, 0.3), fm.CoulombLaw(0.3, smoothing_speed=1e-3)),
    (fm.FloresLaw(1e8, 0.6), fm.StribeckLaw(0.5, 0.3, 0.05, viscous=2.0, smoothing_speed=1e-3)),
    (fm.LinearContactLaw(1e6, 50.0), fm.VelocityWeakeningLaw(0.4, 0.5, 0.1, smoothing_speed=1e-3))])
def test_the_contacts_are_in_the_state_jacobian(law, friction):
    """A ball pressed into the floor and sliding: the Jacobian's speed block is the contact's, to 1e-6.

    A free ball of isotropic inertia without spin (no velocity-product
    terms), so the speed block is the contact's damping and friction alone;
    the position block along the normal is its stiffness (the friction's
    lever ``r - delta / 2`` changes with the penetration, which is left out:
    the rest of the position block within ``delta / r`` of its largest entry).
    """
    model = fm.Model()
    ball = fm.RigidBody("ball", mass=1.0, inertia=np.eye(3) * 1e-3)
    model.add(fm.Free("free", model.ground, ball),
              fm.SpherePlaneContact("floor", ball, 0.05, law, friction=friction))
    system = model.build()
    n = system.n_coords
    x = np.array([0.0, 0.0, 0.05 - 2e-4, 0.0, 0.0, 0.0])
    for vx, vy in ((2e-3, -1e-3), (0.3, 0.1)):  # in the smoothing band and well above it
        xd = np.array([vx, vy, -0.05, 0.0, 0.0, 0.0])
        J = system.state_jacobian(0.0, x, xd)
        fd = _d_accel(system, x, xd, 1)
        assert np.abs(J[n:, n:] - fd).max() < 1e-6 * np.abs(fd).max(), (vx, vy)
        fd_x = _d_accel(system, x, xd, 0)
        assert J[n + 2, 2] == pytest.approx(fd_x[2, 2], rel=1e-6)
        assert np.abs(J[n:, :n] - fd_x).max() < 2e-4 / 0.05 * np.abs(fd_x).max()


def test_a_block_sticking_on_a_belt_takes_few_steps():
    """With the friction in the Jacobian, CVODE steps over the stiff sticking phase (112,435 steps without)."""
    res = fm.simulate(belt_model(1e-5), 0.5, n_out=51, method="CVODE_BDF", rtol=1e-7, atol=1e-10, progress=False)
    assert res.status == "finished" and res.n_steps < 1000
