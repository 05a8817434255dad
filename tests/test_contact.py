"""Contact elements (#30, stage 1): laws, geometry, energy, and closed-form validations.

Closed forms used below (a ball of mass m on a plane, or two balls, no
gravity unless said; v_in the impact speed, e the rebound ratio
``-v_out / v_in`` of the approach speed):

* ``F = K delta^n (1 + alpha delta_dot)`` (Hunt-Crossley, and the
  Lankarani-Nikravesh and Flores laws with ``alpha = chi / v_in``):
  ``m v dv / (1 + alpha v) = -K delta^n d delta`` integrates over the
  impact to ``u - ln(1 + u) = -e u - ln(1 - e u)``, ``u = alpha v_in``
  (:func:`flexmb.forces.contact.restitution_of_hysteresis`), for any n.
* ``F = max(k delta + c delta_dot, 0)``: the damped oscillation
  ``delta = (v_in / w_d) exp(-zeta w t) sin(w_d t)`` until the force
  vanishes, at ``w_d t_s = pi - atan(2 zeta sqrt(1 - zeta^2) / (1 - 2 zeta^2))``.
* A solid sphere (``I = 2/5 m r^2``) launched sliding at v0 without spin
  on a plane with Coulomb friction: the slip ``u = v - rho omega`` (rho the
  lever of the contact force) falls at ``a = mu g (1 + m rho^2 / I)``
  until it rolls, at ``2 v0 / (7 mu g)`` for rho = r, with the speed
  ``5/7 v0`` (the angular momentum about the contact line is kept). The
  regularised law ``-mu N u / sqrt(u^2 + eps^2)`` reaches the slip u at
  ``(G(v0) - G(u)) / a``, ``G(u) = sqrt(u^2 + eps^2) - eps ln((eps + sqrt(u^2 + eps^2)) / u)``.
* Hertz's static penetration under a weight: ``(m g / K)^(2/3)``.
"""

from __future__ import annotations

import numpy as np
import pytest

import flexmb as fm
from flexmb.export import vtk
from flexmb.forces.contact import restitution_of_hysteresis
from flexmb.kernels.contact import hysteresis_invariant, impact_speed

M, R = 1.0, 0.05
K_STEEL = fm.hertz_stiffness(R, 2.0e11, 0.3)  # steel ball on a rigid plane, N/m^1.5
G_ACC = 9.81
#: impact speeds: five decades and more, m/s
SPEEDS = (1e-3, 1e-2, 1e-1, 1.0, 1e1, 1e2)


def _report(name, **values):
    print(f"\n[contact] {name}: " + ", ".join(f"{k} = {v:.6g}" for k, v in values.items()))


def _ball(name="ball", mass=M, radius=R):
    return fm.RigidBody(name, mass=mass, inertia=np.eye(3) * 0.4 * mass * radius ** 2)


def _impact(law, v_in, exponent):
    """A free ball launched at v_in onto the floor (no gravity); returns (e, ledger error, result, element)."""
    model = fm.Model()
    ball = _ball()
    floor = fm.SpherePlaneContact("floor", ball, R, law)
    model.add(fm.Free("free", model.ground, ball), floor)
    stiffness = law.stiffness
    d_max = ((exponent + 1) * M * v_in ** 2 / (2 * stiffness)) ** (1 / (exponent + 1))  # undamped
    t_c = 3.3 * d_max / v_in  # about the Hertz contact time (2.94 d_max / v_in)
    gap = 0.5 * v_in * t_c
    res = fm.simulate(model, gap / v_in + 15 * t_c, x0=np.array([0, 0, R + gap, 0, 0, 0.0]),
                      xd0=np.array([0, 0, -v_in, 0, 0, 0.0]), method="DOP853", rtol=1e-10, atol=1e-10 * d_max,
                      max_step=t_c / 5, track_work=True, progress=False, n_out=51)
    assert res.status == "finished"
    e = res.xd[-1, 2] / v_in
    work = sum(w[-1] for w in res.work.values())
    ledger = (res.kinetic[-1] - res.kinetic[0] - work) / res.kinetic[0]
    return e, ledger, res, floor


# ----------------------------------------------------------------------------- laws at one state

def _touching(law, friction=None, z=R - 1e-3, vz=0.0, vy=0.0, wx=0.0):
    model = fm.Model()
    ball = _ball()
    floor = fm.SpherePlaneContact("floor", ball, R, law, friction=friction)
    system = model.add(fm.Free("free", model.ground, ball), floor).build()
    kin = system.kinematics(0.0, np.array([0, 0, z, 0, 0, 0.0]), np.array([0, vy, vz, wx, 0, 0.0]))
    return system, floor, kin


def test_normal_laws_at_a_state():
    """Each law's force at delta = 1 mm, approaching at 0.2 m/s, against its formula."""
    d, rate = 1e-3, 0.2
    cases = [(fm.LinearContactLaw(1e5, 30.0), 1e5 * d + 30.0 * rate),
             (fm.HuntCrossleyLaw(1e8, 0.5), 1e8 * d ** 1.5 * (1 + 0.5 * rate)),
             (fm.HuntCrossleyLaw(1e6, 0.5, exponent=1.0), 1e6 * d * (1 + 0.5 * rate))]
    flores = fm.FloresLaw(1e8, 0.6)
    v_in = impact_speed(d, rate, 1e8, 1.5, flores.chi, M)
    cases.append((flores, 1e8 * d ** 1.5 * (1 + flores.chi * rate / v_in)))
    for law, expected in cases:
        system, floor, kin = _touching(law, z=R - d, vz=-rate)
        f = system.forces.active_force(kin)
        assert f[2] == pytest.approx(expected, rel=1e-12), type(law).__name__
        assert np.allclose(f[[0, 1, 3, 4, 5]], 0.0, atol=1e-9 * expected)


def test_impact_speed_inverts_the_first_integral():
    """v_in from (delta, rate) puts the state on the invariant of the impact that started at v_in."""
    chi, stiffness, n, m = 0.8, 1e9, 1.5, 2.0
    for s in (0.9, 0.3, 0.0, -0.2, -0.4):
        v_in = 3.0
        # the penetration of the state with rate s v_in on that impact
        delta = ((n + 1) * m * v_in ** 2 * hysteresis_invariant(s, chi) / stiffness) ** (1 / (n + 1))
        assert impact_speed(delta, s * v_in, stiffness, n, chi, m) == pytest.approx(v_in, rel=1e-12)
    # the series and the closed form of h agree where they meet
    for s in (-0.5, 0.2, 0.9):
        chi = 1e-3 / (1 + abs(s))
        assert hysteresis_invariant(s, chi * (1 - 1e-9)) == pytest.approx(hysteresis_invariant(s, chi * (1 + 1e-9)),
                                                                            rel=1e-10)


def test_no_force_when_separated_and_none_pulling():
    """A gap gives nothing; a fast separation whose damping would pull gives nothing either."""
    law = fm.LinearContactLaw(1e5, 1e3)
    system, floor, kin = _touching(law, friction=fm.CoulombLaw(0.5), z=R + 1e-6, vz=-1.0, vy=2.0)
    assert np.all(system.forces.active_force(kin) == 0.0)
    assert floor.potential(kin) == 0.0
    # delta = 1 mm, separating at 1 m/s: k delta + c delta_dot = 100 - 1000 < 0
    system, floor, kin = _touching(law, friction=fm.CoulombLaw(0.5), vz=1.0, vy=2.0)
    assert np.all(system.forces.active_force(kin) == 0.0)
    assert floor.potential(kin) == pytest.approx(0.5 * 1e5 * 1e-6)


@pytest.mark.parametrize("friction, mu_of", [
    (fm.CoulombLaw(0.4, smoothing_speed=1e-3), lambda N, v: 0.4 * N * v / np.hypot(v, 1e-3)),
    (fm.ViscousLaw(3.0), lambda N, v: 3.0 * v),
    (fm.VelocityWeakeningLaw(0.5, 0.1, 0.2, smoothing_speed=1e-3),
     lambda N, v: N * max(0.5 - 0.1 * v, 0.2) * v / np.hypot(v, 1e-3)),
    (fm.StribeckLaw(0.6, 0.3, 0.05, exponent=2.0, viscous=0.7, smoothing_speed=1e-3),
     lambda N, v: N * (0.3 + 0.3 * np.exp(-(v / 0.05) ** 2)) * v / np.hypot(v, 1e-3) + 0.7 * v),
])
def test_friction_laws_and_the_slip_of_the_contact_point(friction, mu_of):
    """Friction against the contact point's own slip: a ball moving at 0.3 m/s along y spinning at wx.

    The point ``c - rho n`` moves at ``v_y + rho w_x`` along y (rho = r - delta / 2):
    with ``w_x = -4 rad/s`` it slips at 0.3 - 4 rho; the force is the law's,
    opposite to the slip, and its torque about the centre turns the spin.
    """
    law = fm.LinearContactLaw(1e5)
    d = 1e-3
    rho = R - d / 2
    for wx in (-4.0, -10.0):
        slip = 0.3 + wx * rho
        system, floor, kin = _touching(law, friction=friction, z=R - d, vy=0.3, wx=wx)
        loads = system.forces.loads(kin)
        f = loads.force[0]
        N = 1e5 * d
        assert f[2] == pytest.approx(N, rel=1e-12)
        assert f[1] == pytest.approx(-np.sign(slip) * mu_of(N, abs(slip)), rel=1e-12)
        assert loads.torque[0] == pytest.approx([f[1] * rho, 0, 0], rel=1e-12)  # (-rho e_z) x (f_y e_y)
        delta, rate, fn, energy, point, normal, force, sl = type(floor).states_all([floor], kin)
        assert sl[0] == pytest.approx([0, slip, 0], abs=1e-14)
        assert point[0] == pytest.approx([0, 0, R - d - rho], abs=1e-15)


def test_sphere_on_a_moving_body_plane_and_power():
    """The plane may be a body's face: the force follows its normal, the pair's power is f . (vA - vB)."""
    model = fm.Model()
    ball, plate = _ball(), fm.RigidBody("plate", mass=2.0, inertia=np.eye(3))
    law = fm.HuntCrossleyLaw(1e8, 0.3)
    # the plate's face x = 0.1 in its frame, normal +x; the ball rolls on it
    contact = fm.SpherePlaneContact("wall", ball, R, law, friction=fm.CoulombLaw(0.2), plane_body=plate,
                                    plane_point=(0.1, 0, 0), plane_normal=(2.0, 0, 0))
    model.add(fm.Free("free", model.ground, ball), fm.Free("plate_free", model.ground, plate), contact)
    system = model.build()
    x = np.zeros(12)
    x[0] = 0.1 + R - 1e-4  # ball centre 0.1 mm inside the face's offset
    xd = np.zeros(12)
    xd[:6] = [-0.5, 0.2, 0.1, 0, 0, 3.0]
    xd[6:] = [0.1, -0.3, 0, 0, 0, 0.7]  # the plate spins about z: its face moves
    kin = system.kinematics(0.0, x, xd)
    powers = system.forces.group_powers(kin)
    delta, rate, fn, energy, point, normal, force, slip = type(contact).states_all([contact], kin)
    vA = kin.point_velocity(np.array([0]), point)[0]
    vB = kin.point_velocity(np.array([1]), point)[0]
    assert powers[0] == pytest.approx(force[0] @ (vA - vB), rel=1e-12)
    assert normal[0] == pytest.approx([1, 0, 0])
    assert rate[0] == pytest.approx(-(vA - vB) @ normal[0], rel=1e-12)
    loads = system.forces.loads(kin)
    assert loads.force[0] + loads.force[1] == pytest.approx(np.zeros(3), abs=1e-9)


# ----------------------------------------------------------------------------- (a) rebound ratios

def test_restitution_relation_against_a_one_dof_integration():
    """The closed form of the rebound ratio against scipy's integration of ``m x'' = -K x^n (1 + chi x' / v)``."""
    from scipy.integrate import solve_ivp

    for chi, n in ((0.05, 1.5), (0.6, 1.5), (2.0, 1.0), (8.0, 1.5)):
        def rhs(t, y):
            return [y[1], -max(y[0], 0.0) ** n * (1 + chi * y[1])]

        def separated(t, y):
            return y[0]

        separated.terminal, separated.direction = True, -1
        sol = solve_ivp(rhs, (0, 100), [0.0, 1.0], method="DOP853", rtol=1e-12, atol=1e-14, events=separated,
                        first_step=1e-6)
        assert -sol.y_events[0][0][1] == pytest.approx(restitution_of_hysteresis(chi), rel=1e-8), chi


@pytest.mark.parametrize("law_cls, e", [(fm.LankaraniNikraveshLaw, 0.95), (fm.LankaraniNikraveshLaw, 0.8),
                                        (fm.FloresLaw, 0.9), (fm.FloresLaw, 0.5), (fm.FloresLaw, 0.2)])
def test_ball_drop_rebound_ratio_restitution_laws(law_cls, e):
    """(a) The rebound ratio of the restitution laws over six decades of impact speed.

    It is the law's own ``restitution_of_hysteresis(chi(e))`` at every
    speed, to 2e-9 (the integration; the contact holds the impact speed
    recorded at its onset, :mod:`flexmb.impact_speeds`), and the energy
    ledger closes to 1e-9 of the impact energy (the issue asks 1e-6). That ratio differs from the e asked for by the
    law's relation chi(e): Lankarani-Nikravesh by about ``1.5 (1 - e)^2``
    (relative; +0.37 % at e = 0.95, +5.9 % at 0.8, +45 % at 0.5: it claims
    e near 1), Flores by about ``-(1 - e) / 15`` near 1 (-0.68 % at 0.9,
    -5.9 % at 0.5, -22 % at 0.2: closer than Lankarani-Nikravesh below
    e = 0.93 or so, its claim of the whole range).
    """
    law = law_cls(K_STEEL, e)
    ref = restitution_of_hysteresis(law.chi)
    measured = []
    for v in SPEEDS:
        got, ledger, res, _ = _impact(law, v, 1.5)
        measured.append(got)
        assert got == pytest.approx(ref, rel=2e-9), v
        assert abs(ledger) < 1e-9, v
        assert res.contact_events[0][3] == pytest.approx(v, rel=1e-12)  # the speed held
    if law_cls is fm.LankaraniNikraveshLaw:
        assert 1.4 * (1 - e) ** 2 < ref / e - 1 < 1.6 * (1 - e) ** 2
    else:
        assert (1 - e) / 16 < 1 - ref / e < 0.3 * (1 - e)
    _report(f"{law_cls.__name__} e = {e}", rebound=ref, relative_to_e=ref / e - 1,
            spread=max(measured) - min(measured))


#: the drops under gravity: a steel ball of 5 mm on a rigid floor, at five decades of impact speed, m/s
DROP_R = 0.005
DROP_M = 7800.0 * 4.0 / 3.0 * np.pi * DROP_R ** 3
DROP_K = fm.hertz_stiffness(DROP_R, 2.0e11, 0.3)
DROP_SPEEDS = (1e-2, 1e-1, 1.0, 1e1, 1e2, 1e3)


def _drop(law, v, **kw):
    """The ball launched down at v from just above the floor, under gravity; returns (result, contact time)."""
    model = fm.Model()
    ball = _ball(mass=DROP_M, radius=DROP_R)
    floor = fm.SpherePlaneContact("floor", ball, DROP_R, law)
    model.add(fm.Prismatic("drop", model.ground, ball, axis=(0, 0, 1)), floor, fm.Gravity((0, 0, -G_ACC)))
    d_max = (5 * DROP_M * v ** 2 / (4 * DROP_K)) ** 0.4
    t_c = 3.3 * d_max / v
    gap = 0.5 * v * t_c
    res = fm.simulate(model, gap / v + 1.5 * t_c, x0=[DROP_R + gap], xd0=[-v], method="DOP853", rtol=1e-10,
                      atol=1e-10 * d_max, progress=False, n_out=41, track_work=True, **kw)
    assert res.status == "finished"
    return res, t_c


def _one_dof_rebound(law, v_in):
    """Separation speed of ``m d'' = m g - K d^1.5 (1 + chi d' / v_in)`` from ``d = 0, d' = v_in`` (scipy)."""
    from scipy.integrate import solve_ivp

    def rhs(t, y):
        return [y[1], G_ACC - DROP_K * max(y[0], 0.0) ** 1.5 * (1 + law.chi * y[1] / v_in) / DROP_M]

    def separated(t, y):
        return y[0]

    separated.terminal, separated.direction = True, -1
    sol = solve_ivp(rhs, (0, 1), [0.0, v_in], method="DOP853", rtol=1e-13, atol=1e-20, events=separated,
                    first_step=1e-9)
    return -sol.y_events[0][0][1]


@pytest.mark.parametrize("law", [fm.LankaraniNikraveshLaw(DROP_K, 0.9), fm.FloresLaw(DROP_K, 0.5)])
def test_dropped_ball_holds_its_impact_speed(law):
    """(a) Under gravity the law divides by the impact speed held from the onset, not one from the state.

    Over five decades of impact speed, the rebound (the rates at the
    separation and the onset) is that of the one-degree-of-freedom
    equation with v_in fixed at the onset's rate, to 2e-9, the ledger
    closes to 1e-9 of the impact energy, and the ratio tends to the law's
    ``restitution_of_hysteresis(chi)`` as gravity's share ``g t_c / v_in``
    vanishes. The state's speed (the fallback: no events) departs from the
    held one where gravity acts during the impact: by 1e-3 at 1 cm/s.
    The stored outputs (forces of the history, accelerations) are those of
    the speed the run held.
    """
    for v in DROP_SPEEDS:
        res, t_c = _drop(law, v)
        (t_on, _, _, v_in), (_, _, _, rate_off) = res.contact_events
        ref = _one_dof_rebound(law, v_in)
        assert -rate_off == pytest.approx(ref, rel=2e-9), v
        work = sum(w[-1] for w in res.work.values())
        assert abs(res.kinetic[-1] - res.kinetic[0] - work) < 1e-9 * 0.5 * DROP_M * v_in ** 2, v
        if v == DROP_SPEEDS[0]:
            assert -rate_off / v_in < restitution_of_hysteresis(law.chi) * (1 - 1e-3)  # gravity's share
            fallback, _ = _drop(law, v, contact_events=False, max_step=t_c / 50)
            assert abs(fallback.xd[-1, 0] / res.xd[-1, 0] - 1) > 5e-4
            h = res.contact_history("floor")
            inside = (h.penetration > 0) & (res.t > t_on)
            assert inside.sum() > 10
            d, rate = h.penetration[inside], h.penetration_rate[inside]
            force = DROP_K * d ** 1.5 * (1 + law.chi * rate / v_in)
            assert np.allclose(h.normal_force[inside], force, rtol=1e-12, atol=0)
            assert np.allclose(res.xdd[inside, 0], force / DROP_M - G_ACC, rtol=1e-9, atol=0)
            i = np.flatnonzero(inside)[len(force) // 2]
            mesh = vtk.to_meshio(res, i, system=res.system)
            assert mesh.point_data["contact_force"][-1, 2] == pytest.approx(h.normal_force[i], rel=1e-12)
    assert -rate_off / v_in == pytest.approx(restitution_of_hysteresis(law.chi), rel=2e-7)  # g t_c / v_in: 7e-8


def test_each_relation_where_it_claims_accuracy():
    """Lankarani-Nikravesh is second order at e = 1 (closer there), Flores closer away from 1."""
    for e in (0.99, 0.999):
        ln = restitution_of_hysteresis(fm.LankaraniNikraveshLaw(1.0, e).chi)
        flores = restitution_of_hysteresis(fm.FloresLaw(1.0, e).chi)
        assert abs(ln / e - 1) < 1.5 * (1 - e) ** 2 + 1e-12 < abs(flores / e - 1)
    for e in (0.2, 0.5, 0.7, 0.9):
        ln = restitution_of_hysteresis(fm.LankaraniNikraveshLaw(1.0, e).chi)
        flores = restitution_of_hysteresis(fm.FloresLaw(1.0, e).chi)
        assert abs(flores - e) < 0.5 * abs(ln - e)


def test_ball_drop_hunt_crossley_rebound_falls_with_speed():
    """(a) Hunt-Crossley: e = restitution_of_hysteresis(alpha v_in), over six decades of alpha v_in."""
    alpha = 0.5
    for v in SPEEDS:
        got, ledger, _, _ = _impact(fm.HuntCrossleyLaw(K_STEEL, alpha), v, 1.5)
        assert got == pytest.approx(restitution_of_hysteresis(alpha * v), rel=1e-7), v
        assert abs(ledger) < 1e-6


@pytest.mark.parametrize("zeta", [0.05, 0.3])
def test_ball_drop_linear_law(zeta):
    """(a) The linear law: e of the damped oscillator stopped where the clamped force vanishes."""
    k = 1e6
    c = 2 * zeta * np.sqrt(k * M)
    w = np.sqrt(k / M)
    wd = w * np.sqrt(1 - zeta ** 2)
    ts = (np.pi - np.arctan(2 * zeta * np.sqrt(1 - zeta ** 2) / (1 - 2 * zeta ** 2))) / wd
    ref = -np.exp(-zeta * w * ts) * (np.cos(wd * ts) - zeta * w / wd * np.sin(wd * ts))
    for v in SPEEDS:
        got, ledger, _, _ = _impact(fm.LinearContactLaw(k, c), v, 1.0)
        assert got == pytest.approx(ref, rel=1e-7), v
        assert abs(ledger) < 1e-6
    assert ref > np.exp(-zeta * np.pi / np.sqrt(1 - zeta ** 2))  # the clamp ends the contact early


def test_contact_history_of_an_impact():
    """The history from the stored states: penetration, force, energy; separated at the end."""
    law = fm.FloresLaw(K_STEEL, 0.7)
    _, _, res, floor = _impact(law, 1.0, 1.5)
    h = res.contact_history(floor)
    assert h.t.shape == res.t.shape and h.force.shape == (res.t.size, 3)
    touching = h.in_contact
    assert touching.any() and not touching[0] and not touching[-1]
    assert np.all(h.normal_force[~touching] == 0) and np.all(h.normal_force[touching] > 0)
    assert h.penetration[0] < 0  # the gap
    assert np.allclose(h.force[:, 2], h.normal_force) and np.allclose(h.friction_force, 0)
    assert np.allclose(h.elastic_energy[touching], K_STEEL * h.penetration[touching] ** 2.5 / 2.5)
    assert np.allclose(res.potential, h.elastic_energy)
    assert np.allclose(h.slip_speed, 0)
    # the result's own system and one given are the same
    assert np.array_equal(res.contact_history("floor", system=res.system).penetration, h.penetration)
    assert np.array_equal(fm.post.contact_history(res, "floor").normal_force, h.normal_force)
    with pytest.raises(fm.ModelError, match="Revolute|Free 'free' is not a contact element"):
        res.contact_history("free")
    with pytest.raises(fm.ModelError, match="no element named 'wall'"):
        res.contact_history("wall")


def test_sphere_sphere_impact_two_free_balls():
    """(a) Two free balls, central impact: relative rebound as the law says, momentum kept, ledger closed.

    The effective mass is ``m1 m2 / (m1 + m2)``, found from the bodies.
    """
    m1, m2, r1, r2 = 1.0, 3.0, 0.05, 0.08
    law = fm.FloresLaw(fm.hertz_stiffness(r1, 2e11, 0.3, r2, 2e11, 0.3), 0.6)
    a, b = _ball("a", m1, r1), _ball("b", m2, r2)
    hit = fm.SphereSphereContact("hit", a, r1, b, r2, law)
    model = fm.Model().add(fm.Free("fa", "ground", a), fm.Free("fb", "ground", b), hit)
    v = 2.0
    x0 = np.zeros(12)
    x0[6] = r1 + r2 + 1e-4
    xd0 = np.zeros(12)
    xd0[0] = v
    res = fm.simulate(model, 2e-3, x0=x0, xd0=xd0, method="DOP853", rtol=1e-10, atol=1e-16, max_step=2e-5,
                      track_work=True, progress=False, n_out=11)
    v1, v2 = res.xd[-1, 0], res.xd[-1, 6]
    assert (v2 - v1) / v == pytest.approx(restitution_of_hysteresis(law.chi), rel=1e-7)
    assert m1 * v1 + m2 * v2 == pytest.approx(m1 * v, rel=1e-12)
    work = sum(w[-1] for w in res.work.values())
    assert abs(res.kinetic[-1] - res.kinetic[0] - work) < 1e-6 * res.kinetic[0]
    assert res.contact_history(hit).penetration[-1] < 0


# ----------------------------------------------------------------------------- (b) sliding to rolling

def test_sliding_sphere_starts_rolling_at_the_closed_form_time():
    """(b) A ball launched sliding (no spin) on a plane with Coulomb friction rolls from 2 v0 / (7 mu g) at 5/7 v0.

    Stiff Hertz contact (steel on a rigid plane) started at its static
    penetration, Coulomb friction regularised at 1e-5 m/s; the ball slides
    along y, so that it turns about x (the first Bryant angle: no gimbal
    lock, #29). The slip history follows the regularised closed form with
    the contact's lever ``rho = r - delta / 2`` to 1e-6; the rolling time
    and speed the rigid closed forms to 1e-4 (the lever's share, 4e-6,
    and the regularisation's).
    """
    mu, v0, eps = 0.3, 1.0, 1e-5
    d0 = (M * G_ACC / K_STEEL) ** (2 / 3)
    model = fm.Model()
    ball = _ball()
    floor = fm.SpherePlaneContact("floor", ball, R, fm.HuntCrossleyLaw(K_STEEL, 1.0),
                                  friction=fm.CoulombLaw(mu, smoothing_speed=eps))
    model.add(fm.Free("free", model.ground, ball), floor, fm.Gravity((0, 0, -G_ACC)))
    t_roll = 2 * v0 / (7 * mu * G_ACC)
    res = fm.simulate(model, 1.5 * t_roll, x0=np.array([0, 0, R - d0, 0, 0, 0.0]),
                      xd0=np.array([0, v0, 0, 0, 0, 0.0]), method="CVODE_BDF", rtol=1e-10, atol=1e-12,
                      track_work=True, progress=False, n_out=3001)
    assert res.status == "finished"
    h = res.contact_history(floor)
    u = h.slip_speed
    rho = R - d0 / 2
    a = mu * G_ACC * (1 + M * rho ** 2 / (0.4 * M * R ** 2))

    def G(s):
        return np.sqrt(s * s + eps * eps) - eps * np.log((eps + np.sqrt(s * s + eps * eps)) / s)

    for u1 in (0.5, 0.1, 1e-2, 1e-3):
        k = np.nonzero(u < u1)[0][0]
        t1 = res.t[k - 1] + (u1 - u[k - 1]) * (res.t[k] - res.t[k - 1]) / (u[k] - u[k - 1])
        assert t1 == pytest.approx((G(v0) - G(u1)) / a, rel=1e-6), u1
        assert t1 + u1 / (3.5 * mu * G_ACC) == pytest.approx(t_roll, rel=1e-4), u1
    assert res.xd[-1, 1] == pytest.approx(5 / 7 * v0, rel=1e-4)
    assert -res.xd[-1, 3] * rho == pytest.approx(res.xd[-1, 1], rel=1e-4)  # rolling: v = rho omega
    assert h.normal_force == pytest.approx(np.full(res.t.size, M * G_ACC), rel=1e-9)
    work = sum(w[-1] for w in res.work.values())
    assert abs(res.kinetic[-1] - res.kinetic[0] - work) < 1e-6 * res.kinetic[0]
    # rolling at 5/7 v0 keeps m (5/7 v0)^2 (1 + 2/5) / 2 = 5/7 of the launch energy: friction took 2/7
    assert (res.kinetic[0] - res.kinetic[-1]) / res.kinetic[0] == pytest.approx(2 / 7, rel=1e-4)
    _report("rolling", t_roll=t_roll, v_end=res.xd[-1, 1] / v0)


# ----------------------------------------------------------------------------- (c) static penetration

@pytest.mark.parametrize("law", [fm.HuntCrossleyLaw(K_STEEL, 50.0), fm.FloresLaw(K_STEEL, 0.5),
                                 fm.LankaraniNikraveshLaw(K_STEEL, 0.3)])
def test_static_penetration_is_hertz(law):
    """(c) A ball resting on the floor sinks (m g / K)^(2/3): settled from the touch, and by statics."""
    model = fm.Model()
    ball = _ball()
    floor = fm.SpherePlaneContact("floor", ball, R, law)
    model.add(fm.Prismatic("slide", model.ground, ball, axis=(0, 0, 1)), floor, fm.Gravity((0, 0, -G_ACC)))
    d_s = (M * G_ACC / K_STEEL) ** (2 / 3)
    res = fm.simulate(model, 0.3, x0=np.array([R]), xd0=np.zeros(1), method="CVODE_BDF", rtol=1e-10,
                      atol=1e-14, progress=False, n_out=11)
    assert R - res.x[-1, 0] == pytest.approx(d_s, rel=1e-6)
    assert res.contact_history(floor).normal_force[-1] == pytest.approx(M * G_ACC, rel=1e-6)
    x = fm.static_equilibrium(model.build(), x0=np.array([R - 0.5 * d_s]), tol=1e-15)
    assert R - x[0] == pytest.approx(d_s, rel=1e-9)


# ----------------------------------------------------------------------------- the user's mistakes

def test_bad_parameters_are_refused_naming_the_element():
    ball = _ball()
    with pytest.raises(fm.ModelError, match="FloresLaw: restitution must be in \\(0, 1\\]"):
        fm.FloresLaw(1e9, 0.0)
    with pytest.raises(fm.ModelError, match="LankaraniNikraveshLaw: restitution"):
        fm.LankaraniNikraveshLaw(1e9, 1.2)
    with pytest.raises(fm.ModelError, match="HuntCrossleyLaw: stiffness must be a finite number > 0"):
        fm.HuntCrossleyLaw(-1.0)
    with pytest.raises(fm.ModelError, match="HuntCrossleyLaw: exponent"):
        fm.HuntCrossleyLaw(1.0, exponent=0.5)
    with pytest.raises(fm.ModelError, match="StribeckLaw: stribeck_speed"):
        fm.StribeckLaw(0.5, 0.3, 0.0)
    with pytest.raises(fm.ModelError, match="VelocityWeakeningLaw: mu_min"):
        fm.VelocityWeakeningLaw(0.3, 0.1, mu_min=0.5)
    with pytest.raises(fm.ModelError, match="SpherePlaneContact 'floor': radius must be"):
        fm.SpherePlaneContact("floor", ball, -0.1, fm.LinearContactLaw(1.0))
    with pytest.raises(fm.ModelError, match="SpherePlaneContact 'floor': normal_law must be a normal law"):
        fm.SpherePlaneContact("floor", ball, 0.1, fm.CoulombLaw(0.3))
    with pytest.raises(fm.ModelError, match="SphereSphereContact 'hit': friction must be None or a friction law"):
        fm.SphereSphereContact("hit", ball, 0.1, "other", 0.1, fm.LinearContactLaw(1.0), friction=0.3)
    with pytest.raises(fm.ModelError, match="plane_normal"):
        fm.SpherePlaneContact("floor", ball, 0.1, fm.LinearContactLaw(1.0), plane_normal=(0, 0, 0))
    with pytest.raises(fm.ModelError, match="hertz_stiffness: radius1 must be > 0"):
        fm.hertz_stiffness(0.0, 2e11, 0.3)
    with pytest.raises(fm.ModelError, match="hertz_stiffness: poisson_ratio1"):
        fm.hertz_stiffness(0.1, 2e11, 0.7)
    model = fm.Model()
    model.add(fm.Free("free", model.ground, ball), fm.SpherePlaneContact("self", ball, 0.1, fm.LinearContactLaw(1.0),
                                                                         plane_body=ball))
    with pytest.raises(fm.ModelError, match="SpherePlaneContact 'self': both sides are on the body 'ball'"):
        model.build()
    model = fm.Model()
    model.add(fm.Free("free", model.ground, ball), fm.SpherePlaneContact("grounded", "ground", 0.1,
                                                                         fm.LinearContactLaw(1.0)))
    with pytest.raises(fm.ModelError, match="SpherePlaneContact 'grounded': both sides are on the body 'ground'"):
        model.build()


def test_registered_as_contact_plugins_and_named_in_force_tables():
    """The geometries and laws are the group flexmb.contacts; a scene's [forces] table names a geometry."""
    names = {p.name for p in fm.plugins("contacts")}
    assert {"sphere_plane_contact", "sphere_sphere_contact", "journal_bearing_contact", "linear", "flores",
            "stribeck"} <= names
    assert not names & {p.name for p in fm.plugins("forces")}
    scene = fm.loads_scene("""
[bodies.ball]
mass = 1.0
inertia = [1e-3, 1e-3, 1e-3]
[joints.free]
type = "free"
parent = "ground"
child = "ball"
[forces.floor]
type = "sphere_plane_contact"
body = "ball"
radius = 0.1
normal_law = {type = "linear", stiffness = 1e4}
[solver]
t_end = 0.1
""")
    assert isinstance(scene.model.element("floor"), fm.SpherePlaneContact)
    with pytest.raises(fm.SceneError, match=r"forces\.floor\.type.*or a contact geometry: capsule_capsule_contact"):
        fm.loads_scene("[forces.floor]\ntype = 'sphere_plane'\n[solver]\nt_end = 1.0\n")


def test_same_accelerations_by_every_route():
    """The articulated-body recursion of open trees and the reduced equations give the same accelerations.

    A ball rolling and spinning against a plate's face and a second ball,
    on a pendulum: the contacts enter both routes through the same kernel.
    """
    model = fm.Model()
    ball, other = _ball(), _ball("other", 2.0, 0.08)
    arm = fm.RigidBody.slender_bar("arm", mass=0.5, length=0.4)
    model.add(fm.Free("free", model.ground, ball), fm.Revolute("pin", model.ground, arm, parent_point=(0, 0, R), axis=(0, 1, 0)),
              fm.Fixed("weld", arm, other, parent_point=(0.4, 0, 0)), fm.Gravity((0, 0, -G_ACC)),
              fm.SpherePlaneContact("floor", ball, R, fm.FloresLaw(K_STEEL, 0.6),
                                    friction=fm.StribeckLaw(0.5, 0.3, 0.01, viscous=0.1)),
              fm.SphereSphereContact("hit", ball, R, other, 0.08, fm.HuntCrossleyLaw(1e8, 0.4),
                                     friction=fm.CoulombLaw(0.2)))
    x = np.array([0.4 + R + 0.08 - 2e-4, 0.001, R - 1e-5, 0.1, -0.2, 0.3, 0.0])
    xd = np.array([0.3, -0.2, -0.1, 1.0, 2.0, -3.0, 0.5])
    dense, sparse = model.build(sparse=False), model.build(sparse=True)
    kin = dense.kinematics(0.0, x, xd)
    for contact in dense.model.forces[1:]:
        assert type(contact).states_all([contact], kin)[0][0] > 0, contact.name
    a_dense, a_sparse = dense.accelerations(0.0, x, xd), sparse.accelerations(0.0, x, xd)
    assert np.abs(a_dense).max() > 1.0  # both contacts push
    assert a_sparse == pytest.approx(a_dense, rel=1e-10, abs=1e-10 * np.abs(a_dense).max())
