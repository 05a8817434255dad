"""State-space models, frequency responses and Campbell diagrams (flexmb.analysis).

The references come from outside the code:

* a rigid pendulum hanging under gravity, torque at the pivot, angle out:
  ``G(s) = 1 / (I s^2 + c s + m g d)`` (I about the pivot, d from the pivot
  to the mass centre, c a viscous damper on the pivot);
* a clamped beam: its poles against the model's own modes (:func:`fm.modes`),
  its static gain against :func:`fm.linear_statics` read with the
  small-angle tip formula ``w = -sum eta_j (L - x_j)``, and its root moment
  against statics (``M = P L``);
* the B3 beam (L = 10 m, E I = 1.4e4 N m^2, rho A = 1.2 kg/m) spinning about
  the axis through its clamp, bending in the plane of rotation, against
  Southwell's ``w^2 = w0^2 + (K1 - 1) Omega^2`` (Southwell & Gough, "The free
  transverse vibration of airscrew blades", ARC R&M 766, 1921). K1 = 1.193 is
  the classical Southwell coefficient of a uniform cantilever's first mode
  with zero hub radius, out of the plane of rotation: the Rayleigh quotient
  ``int N phi'^2 / (Omega^2 int rho A phi^2)`` of the centrifugal tension
  ``N = rho A Omega^2 (L^2 - x^2) / 2`` with the non-rotating mode phi (so the
  exact slope of w^2 against Omega^2 at Omega = 0, by first-order
  perturbation), recomputed below by quadrature: 1.19334. In the plane of
  rotation the spin softening ``-Omega^2`` subtracts 1: K1 - 1 = 0.19334;
* a PD-controlled flexible arm simulated with the nonlinear model against
  ``scipy.signal.lsim`` of the closed-loop state space.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.signal as sig
from attrs import frozen
from scipy.integrate import quad

import flexmb as fm
from flexmb.analysis import tangent_gap

G_ACC = 9.81


# ----------------------------------------------------------------------------- models

def pendulum(m=2.0, d=0.5, ic=0.04, c=0.3):
    """A rigid pendulum on a pin about x, its mass centre d below the pin, a damper c on the pin."""
    model = fm.Model("pendulum")
    bob = fm.RigidBody("bob", m, (ic, ic, ic), com=(0.0, 0.0, -d))
    pin = fm.Revolute("pin", model.ground, bob, axis=(1, 0, 0))
    model.add(pin, fm.Gravity((0.0, 0.0, -G_ACC)), fm.JointSpringDamper("damper", pin, 0.0, c))
    return model


def clamped_beam(n=8, damping=0.0):
    model = fm.Model("cantilever")
    beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(), n,
                           keep=("bend_y",), damping=damping)
    model.add(fm.Fixed("clamp", model.ground, beam))
    return model, beam


B3_SECTION = fm.Section(area=1e-3, Iy=1e-6, Iz=1e-6, J=2e-6, name="B3")  # rho A = 1.2 kg/m, E I = 1.4e4 N m^2
B3_MATERIAL = fm.Material(E=1.4e10, density=1200.0, name="B3")


def spinning_b3(n):
    """``build(rate)`` for :func:`fm.campbell`: the B3 beam on a hub driven at a constant rate, in-plane bending."""

    def build(rate):
        model = fm.Model("B3 spinning")
        beam = fm.FlexibleBody("beam", 10.0, B3_SECTION, B3_MATERIAL, n, keep=("bend_z",), rotary_inertia=False)
        hub = fm.Revolute("hub", model.ground, beam, axis=(0, 0, 1))
        system = model.add(hub, fm.Driver.constant_speed("spin", hub, rate)).build()
        xd0 = np.zeros(system.n_coords)
        xd0[system.coordinate_slice(hub)] = rate
        return system, (np.zeros(system.n_coords), xd0)

    return build


def southwell_k1() -> float:
    """Southwell coefficient of a uniform cantilever's first mode (zero hub radius), by quadrature."""
    b = 1.8751040687119611
    s = (np.cosh(b) + np.cos(b)) / (np.sinh(b) + np.sin(b))
    phi = lambda x: np.cosh(b * x) - np.cos(b * x) - s * (np.sinh(b * x) - np.sin(b * x))  # noqa: E731
    dphi = lambda x: b * (np.sinh(b * x) + np.sin(b * x) - s * (np.cosh(b * x) - np.cos(b * x)))  # noqa: E731
    num = quad(lambda x: 0.5 * (1 - x * x) * dphi(x) ** 2, 0, 1, epsabs=1e-14)[0]
    return num / quad(lambda x: phi(x) ** 2, 0, 1, epsabs=1e-14)[0]


# ----------------------------------------------------------------------------- 1. the analytic tangent

def _free_body():
    model = fm.Model()
    bob = fm.RigidBody("bob", 2.0, (0.01, 0.02, 0.03), com=(0.1, 0.05, -0.5))
    joint = fm.Free("joint", model.ground, bob)
    model.add(joint, fm.Gravity((0, 0, -G_ACC)), fm.JointSpringDamper("springs", joint, 0.5, 0.3),
              fm.PointForce("push", bob, (1.0, 2.0, 3.0), point=(0.3, 0.2, 0.1)),
              fm.PointForce("thrust", bob, (-1.0, 0.5, 2.0), point=(0.0, 0.3, 0.1), frame="body"),
              fm.BodyTorque("twist", bob, (0.3, -0.2, 1.0), frame="body"))
    return model.build(), np.array([0.1, 0.2, 0.3, 0.2, -0.3, 0.1])


def _spatial_beam():
    model = fm.Model()
    beam = fm.FlexibleBody("beam", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(), 6,
                           keep=("torsion", "bend_y", "bend_z"), damping=1e-3)
    tip = fm.RigidBody("tip", 0.05, (1e-5, 1e-5, 1e-5))
    model.add(fm.Fixed("clamp", model.ground, beam), fm.Fixed("weld", beam, tip, parent_point=(1.0, 0.02, 0.0)),
              fm.Gravity((0.0, -0.6 * G_ACC, -0.8 * G_ACC)),
              fm.PointForce("side", beam, (0.0, 3.0, -2.0), point=(0.5, 0.01, 0.0), frame="body"))
    system = model.build()
    return system, 0.01 * np.random.default_rng(1).standard_normal(system.n_coords)


def _spherical():
    model = fm.Model()
    bob = fm.RigidBody("bob", 2.0, (0.01, 0.02, 0.03), com=(0.1, 0.05, -0.5))
    joint = fm.Spherical("ball", model.ground, bob)
    model.add(joint, fm.Gravity((0, 0, -G_ACC)), fm.JointSpringDamper("springs", joint, 0.5, 0.3))
    return model.build(), np.array([0.2, -0.3, 0.1])


@pytest.mark.parametrize("make", [_free_body, _spatial_beam, _spherical], ids=["free", "spatial-beam", "ball"])
def test_analytic_linearization_equals_finite_differences(make):
    """At rest, away from equilibrium, K and C from the tangent equal the old central differences."""
    system, x0 = make()
    xd0 = np.zeros_like(x0)
    assert tangent_gap(system, x0, xd0) == ""
    a = fm.linearize(system, x0, xd0)
    b = fm.linearize(system, x0, xd0, method="fd")
    assert (a.method, b.method) == ("analytic", "fd")
    # the differences' accuracy, their rounding eps |f| / h with h = 1e-6 (measured: K 2e-10 of its largest
    # entry; C up to 6e-7 of its largest, on the spatial beam whose torsion is stiff)
    assert np.max(np.abs(a.K - b.K)) < 1e-8 * np.max(np.abs(b.K))
    assert np.max(np.abs(a.C - b.C)) < 5e-6 * max(np.max(np.abs(b.C)), 1.0)
    assert np.array_equal(a.M, b.M) and np.array_equal(a.F, b.F)


def test_linearize_falls_back_to_differences_and_says_why():
    system, _ = spinning_b3(4)(3.0)
    x0, xd0 = _
    lin = fm.linearize(system, x0, xd0)
    assert lin.method == "fd" and "moves" in lin.reason
    with pytest.raises(fm.ModelError, match="not exact here.*moves"):
        fm.linearize(system, x0, xd0, method="analytic")
    with pytest.raises(fm.ModelError, match="unknown method 'newton'.*'auto', 'analytic', 'fd'"):
        fm.linearize(system, x0, xd0, method="newton")
    model = pendulum()
    model.add(PD("pd", "pin", 1.0, 0.1))
    assert "PD" in fm.linearize(model.build()).reason
    assert fm.linearize(pendulum().build()).method == "analytic"


# ----------------------------------------------------------------------------- 2. the pendulum in closed form

def test_pendulum_poles_and_transfer_function_in_closed_form():
    m, d, ic, c = 2.0, 0.5, 0.04, 0.3
    ss = fm.state_space(pendulum(m, d, ic, c).build(), inputs=["pin"], outputs=["pin"])
    inertia, k = ic + m * d * d, m * G_ACC * d
    poles = np.roots([inertia, c, k])
    assert np.allclose(np.sort_complex(ss.poles()), np.sort_complex(poles), rtol=1e-8, atol=0)
    s = 1j * np.array([0.0, 0.5, 2.0, np.sqrt(k / inertia), 10.0, 100.0])
    exact = 1.0 / (inertia * s**2 + c * s + k)
    H = ss.response(s)[:, 0, 0]
    err = np.max(np.abs(H - exact) / np.abs(exact))
    assert err < 1e-8, f"transfer function off by {err:.2e}"
    fr = fm.frequency_response(ss, w=s.imag)
    assert np.allclose(fr.magnitude[:, 0], np.abs(exact), rtol=1e-8)
    assert np.allclose(fr.phase[:, 0], np.degrees(np.unwrap(np.angle(exact))), atol=1e-6)
    # scipy's own conversion of the same model: numerator / denominator = 1 / (I s^2 + c s + k)
    num, den = sig.ss2tf(ss.A, ss.B, ss.C, ss.D)
    assert np.allclose(den, [1.0, c / inertia, k / inertia], rtol=1e-8)
    assert np.allclose(num[0][-1], 1.0 / inertia, rtol=1e-8) and np.allclose(num[0][:-1], 0.0, atol=1e-8)
    assert isinstance(ss.to_scipy(), sig.StateSpace)
    assert ss.static_gain()[0, 0] == pytest.approx(1.0 / k, rel=1e-10)
    assert ss.linearization.method == "analytic"


def test_pendulum_torque_at_a_point_and_velocity_and_acceleration_outputs():
    """A force at the bob's mass centre, and the speed and acceleration of the angle and of the point."""
    m, d, ic, c = 2.0, 0.5, 0.04, 0.3
    inertia, k = ic + m * d * d, m * G_ACC * d
    push = fm.Input.point_force("bob", (0.0, 0.0, -d), (0.0, 1.0, 0.0))  # +y at the bob: torque -d about x?
    outs = [fm.Output.coordinate("pin", derivative=1), fm.Output.coordinate("pin.angle", derivative=2),
            fm.Output.point("bob", (0.0, 0.0, -d), (0.0, 1.0, 0.0)),
            fm.Output.point("bob", (0.0, 0.0, -d), (0.0, 1.0, 0.0), derivative=2)]
    ss = fm.state_space(pendulum(m, d, ic, c).build(), [push], outs)
    s = 1j * np.array([0.3, 3.0, 30.0])
    # a force F along +y at (0, 0, -d) gives the torque (r x F)_x = d F about x: input gain d
    g = d / (inertia * s**2 + c * s + k)
    H = ss.response(s)[:, :, 0]
    assert np.allclose(H[:, 0], s * g, rtol=1e-8)
    assert np.allclose(H[:, 1], s**2 * g, rtol=1e-8)
    assert np.allclose(H[:, 2], d * g, rtol=1e-8)  # the bob moves along +y by d theta
    assert np.allclose(H[:, 3], d * s**2 * g, rtol=1e-8)
    assert ss.D[1, 0] == pytest.approx(d / inertia, rel=1e-10)  # accelerations feed the input through


# ----------------------------------------------------------------------------- 3. the clamped beam

def test_beam_poles_are_the_models_modes():
    model, beam = clamped_beam(8)
    system = model.build()
    ss = fm.state_space(system)
    f, _ = fm.modes(system)
    w = np.sort(ss.poles().imag[ss.poles().imag > 0])
    assert np.max(np.abs(ss.poles().real)) < 1e-8 * np.max(w)
    assert np.allclose(w, 2 * np.pi * f, rtol=1e-8, atol=0)


def test_beam_static_gain_equals_linear_statics():
    """Tip force in, tip displacement and section moments out: K^-1 against linear_statics."""
    model, beam = clamped_beam(8, damping=1e-3)
    L = beam.length
    tip = ((L, 0.0, 0.0), (0.0, 0.0, 1.0))
    outs = [fm.Output.point("beam", *tip)] + [fm.Output.section_load("beam", j, "My") for j in range(beam.n_joints)]
    ss = fm.state_space(model.build(), [fm.Input.point_force("beam", *tip)], outs)
    gain = ss.static_gain()[:, 0]
    loaded, _ = clamped_beam(8, damping=1e-3)
    loaded.add(fm.PointForce("P", "beam", (0.0, 0.0, 1.0), point=(L, 0.0, 0.0)))
    system = loaded.build()
    eta = fm.linear_statics(system)[system.topology.elastic_columns(system.model.element("beam"))]
    x_j = np.arange(beam.n_joints) * beam.segment_length
    w_tip = -float(np.sum(eta * (L - x_j)))  # small-angle tip deflection of the chain of segments
    assert gain[0] == pytest.approx(w_tip, rel=1e-8)
    ei = beam.material.E * beam.section.Iy
    assert gain[0] == pytest.approx(L**3 / (3 * ei) * (1 + 1 / (2 * 8**2)), rel=1e-8)  # the N-segment chain
    # the section moment of a unit upward tip force: My = -(L - x), statics of the outboard part
    assert np.allclose(gain[1:], -(L - x_j), rtol=1e-8)


# ----------------------------------------------------------------------------- 4. Campbell diagram of B3

def test_southwell_coefficient():
    assert southwell_k1() == pytest.approx(1.1933, abs=1e-4)


def test_campbell_of_the_spinning_beam_follows_southwell():
    """First in-plane bending frequency of B3 about steady spin, 0..6 rad/s (N = 16).

    Southwell's estimate, ``w^2 = w0^2 + (K1 - 1) Omega^2`` with the model's
    own w0, is the Rayleigh quotient with the non-rotating mode shape: an
    upper bound of the first frequency, good to a few per cent while Omega
    is not far above w0 (3.79 rad/s here). Measured: 0.01, 0.1, 0.3, 0.8,
    1.7, 2.8 % below it at 1..6 rad/s.
    """
    k_in_plane = southwell_k1() - 1.0
    rates = np.arange(7.0)
    c = fm.campbell(spinning_b3(16), rates, n_modes=2, label="spin rate (rad/s)")
    w = 2 * np.pi * c.frequencies[:, 0]
    assert np.all(np.diff(w) > 0), f"the first frequency must rise with the rate: {w}"
    southwell = np.sqrt(w[0] ** 2 + k_in_plane * rates**2)
    dev = w / southwell - 1
    assert np.all(dev <= 1e-9) and np.all(dev > -0.03), f"deviation from Southwell {dev}"
    assert np.min(c.mac) > 0.99
    assert np.all(np.abs(c.damping) < 1e-6)  # undamped, gyroscopic: the poles stay on the axis
    # the second mode rises too, and stays the second
    assert np.all(np.diff(c.frequencies[:, 1]) > 0) and np.all(c.frequencies[:, 1] > c.frequencies[:, 0])
    nearest = fm.campbell(spinning_b3(16), rates, n_modes=2, track="nearest")
    assert np.allclose(nearest.frequencies, c.frequencies, rtol=1e-12)


def test_campbell_slope_at_low_rate_converges_to_southwell_coefficient():
    """``(w^2 - w0^2) / Omega^2`` at 0.5 rad/s, N = 32: within 1 % of K1 - 1 = 0.1933 (measured 0.5 % below)."""
    c = fm.campbell(spinning_b3(32), [0.0, 0.5], n_modes=1)
    w = 2 * np.pi * c.frequencies[:, 0]
    slope = (w[1] ** 2 - w[0] ** 2) / 0.5**2
    assert slope == pytest.approx(southwell_k1() - 1.0, rel=0.01)


# ----------------------------------------------------------------------------- 5. closed loop

@frozen(eq=False)
class PD(fm.ForceElement):
    """A PD controller on a joint coordinate, plus a constant command torque: ``-kp q - kd qd + u``."""

    joint: fm.Joint = fm.reference(fm.Joint)
    kp: float = 0.0
    kd: float = 0.0
    u: float = 0.0

    def apply(self, state, loads):
        c = state.coordinate_slice(self.joint).start
        loads.generalized[c] += -self.kp * state.x[c] - self.kd * state.xd[c] + self.u


def flexible_arm(controller=None):
    """A hub on a motor (revolute about z) carrying a 1 m aluminium strip bending in the plane."""
    model = fm.Model("flexible arm")
    hub = fm.RigidBody("hub", 1.0, (0.03, 0.03, 0.05))
    arm = fm.FlexibleBody("arm", 1.0, fm.Section.rectangular(0.02, 0.005), fm.Material.aluminium(), 6,
                          keep=("bend_z",), damping=2e-4)
    motor = fm.Revolute("motor", model.ground, hub, axis=(0, 0, 1))
    model.add(motor, fm.Fixed("clamp", hub, arm, parent_point=(0.05, 0.0, 0.0)))
    if controller is not None:
        model.add(controller)
    return model


def test_closed_loop_simulation_agrees_with_the_linear_prediction():
    """A step command of 0.01 N m into a PD loop (kp = 20 N m/rad, kd = 2 N m s/rad), 2 s.

    The nonlinear simulation (the controller a Python force element) and
    ``lsim`` of the closed loop built from the open-loop state space agree
    to 1e-6 of the response (measured: hub angle 2e-12, tip 5e-8).
    """
    kp, kd, u0 = 20.0, 2.0, 1e-2
    tip = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    ss = fm.state_space(flexible_arm().build(), ["motor"],
                        ["motor", fm.Output.coordinate("motor", derivative=1), fm.Output.point("arm", *tip)])
    closed = ss.feedback([[kp, kd, 0.0]])
    assert np.all(closed.poles().real < 0)
    t = np.linspace(0.0, 2.0, 401)
    _, y, _ = sig.lsim(closed.to_scipy(), np.full(t.shape, u0), t)
    system = flexible_arm(PD("pd", "motor", kp, kd, u0)).build()
    res = fm.simulate(system, 2.0, t_eval=t, rtol=1e-10, atol=1e-18)
    assert res.status == "finished"
    hub = res.coordinate("motor")
    kin0 = system.kinematics(0.0, res.x[0], res.xd[0])
    k, local = kin0.locate(system.model.element("arm"), tip[0])
    y_tip = np.array([system.kinematics(0.0, x, 0 * x).point_position(k, local)[1] for x in res.x])
    y_tip -= y_tip[0]
    assert np.max(np.abs(y[:, 0])) == pytest.approx(u0 / kp, rel=0.3)  # it settles near u0 / kp
    for sim, lin in ((hub, y[:, 0]), (y_tip, y[:, 2])):
        err = np.max(np.abs(sim - lin)) / np.max(np.abs(lin))
        assert err < 1e-6, f"closed loop vs linear: {err:.2e}"


# ----------------------------------------------------------------------------- 6. API

def test_loads_across_a_joint():
    """A torque across a revolute about its axis is the joint's generalized force; a force there does nothing.

    Across the Fixed joint that clamps the arm to the hub, a torque about z
    is the generalized force of the arm's root bending coordinate.
    """
    system = pendulum().build()
    ss = fm.state_space(system, [fm.Input.joint_load("pin", (1.0, 0, 0)), "pin",
                                 fm.Input.joint_load("pin", (0, 1.0, 1.0), torque=False)], ["pin"])
    assert np.allclose(ss.B[:, 0], ss.B[:, 1], rtol=1e-14, atol=0) and np.any(ss.B[:, 0])
    assert np.allclose(ss.B[:, 2], 0.0, atol=1e-14)
    arm = flexible_arm().build()
    ss = fm.state_space(arm, [fm.Input.joint_load("clamp", (0, 0, 1.0)), "arm.j0.bend_z",
                              fm.Input.joint_load("clamp", (0, 1.0, 0), torque=False)], [])
    assert np.allclose(ss.B[:, 0], ss.B[:, 1], rtol=1e-12, atol=1e-12 * np.max(np.abs(ss.B)))
    assert np.allclose(ss.B[:, 2], 0.0, atol=1e-12 * np.max(np.abs(ss.B)))


def test_names_resolve_and_bad_names_are_listed():
    system = pendulum().build()
    a = fm.state_space(system, [fm.Input.joint(system.model.element("pin"))], ["pin.angle"])
    b = fm.state_space(system, ["pin"], [fm.Output.coordinate("pin", "angle")])
    assert np.array_equal(a.B, b.B) and np.array_equal(a.C, b.C)
    assert a.states == ["pin.angle", "pin.angle'"] and a.inputs == ["pin"] and a.outputs == ["pin.angle"]
    with pytest.raises(fm.ModelError, match="no joint named 'pivot'.*'pin'"):
        fm.state_space(system, ["pivot"])
    with pytest.raises(fm.ModelError, match="no coordinate 'tilt'.*'angle'"):
        fm.state_space(system, [], [fm.Output.coordinate("pin", "tilt")])
    with pytest.raises(fm.ModelError, match="no body named 'rod'"):
        fm.state_space(system, [fm.Input.point_force("rod", (0, 0, 0), (1, 0, 0))])
    with pytest.raises(fm.ModelError, match="names must be unique"):
        fm.state_space(system, ["pin", "pin"])
    with pytest.raises(fm.ModelError, match="derivative must be 0, 1 or 2"):
        fm.Output.coordinate("pin", derivative=3)
    with pytest.raises(fm.ModelError, match="no output named 'tip'"):
        a.index("tip", "output")
    model, beam = clamped_beam(4)
    with pytest.raises(fm.ModelError, match="does not keep 'bend_z'.*reaction"):
        fm.state_space(model.build(), [], [fm.Output.section_load("beam", 0, "Mz")])
    with pytest.raises(fm.ModelError, match="no station 4"):
        fm.state_space(model.build(), [], [fm.Output.section_load(beam, 4)])


def test_about_a_result_time_and_the_equilibrium_warning():
    system = pendulum().build()
    res = fm.simulate(system, 1.0, positions={"pin": 0.3}, n_out=11, rtol=1e-10)
    with pytest.warns(UserWarning, match="not an equilibrium"):
        ss = fm.state_space(system, ["pin"], ["pin"], about=(res, 0.5))
    lin = ss.linearization
    assert lin.t == pytest.approx(0.5) and np.array_equal(lin.x0, res.x[5]) and lin.method == "fd"
    # the constant term: the independent acceleration at the state, as the equations of motion give it
    assert ss.affine[1] == pytest.approx(system.accelerations(0.5, res.x[5], res.xd[5])[0], rel=1e-10)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fm.state_space(system, ["pin"], ["pin"], about=(np.zeros(1), np.zeros(1), 0.0))
    with pytest.raises(fm.ModelError, match="about must be"):
        fm.state_space(system, about=np.zeros(2))


def test_feedback_and_frequency_response_plot(tmp_path):
    pytest.importorskip("matplotlib")
    ss = fm.state_space(pendulum().build(), ["pin"], ["pin", fm.Output.coordinate("pin", derivative=1)])
    closed = ss.feedback([[5.0, 1.0]])
    inertia, c, k = 0.04 + 0.5, 0.3, G_ACC
    assert np.allclose(np.sort_complex(closed.poles()), np.sort_complex(np.roots([inertia, c + 1.0, k + 5.0])))
    with pytest.raises(fm.ModelError, match="gain must have shape"):
        ss.feedback([[1.0]])
    fr = fm.frequency_response(ss, pairs=[("pin", "pin")])
    assert fr.response.shape == (400, 1) and fr.f[0] < np.sqrt(k / inertia) / (2 * np.pi) < fr.f[-1]
    assert np.array_equal(fr.pair("pin", "pin"), fr.response[:, 0])
    fig = fr.plot(tmp_path / "bode.png")
    assert (tmp_path / "bode.png").stat().st_size > 0 and len(fig.axes) == 2
    with pytest.raises(fm.ModelError, match="not both"):
        fm.frequency_response(ss, w=[1.0], f=[1.0])


def test_campbell_plot_and_errors(tmp_path):
    pytest.importorskip("matplotlib")
    c = fm.campbell(spinning_b3(4), [0.0, 2.0, 4.0], n_modes=2, label="spin rate (rad/s)")
    fig = c.plot(tmp_path / "campbell.png", orders=(1, 2))
    assert (tmp_path / "campbell.png").stat().st_size > 0 and len(fig.axes) == 2
    assert c.shapes.shape == (3, 5, 2) and np.allclose(np.linalg.norm(c.shapes, axis=1), 1.0)
    with pytest.raises(fm.ModelError, match="unknown track"):
        fm.campbell(spinning_b3(4), [0.0], track="closest")
    with pytest.raises(fm.ModelError, match="fewer than n_modes"):
        fm.campbell(spinning_b3(2), [0.0], n_modes=3)


def test_to_control():
    control = pytest.importorskip("control", reason="python-control is optional: pip install 'flexmb[control]'")
    ss = fm.state_space(pendulum().build(), ["pin"], ["pin"])
    cs = ss.to_control()
    assert isinstance(cs, control.StateSpace)
    assert cs.input_labels == ["pin"] and cs.output_labels == ["pin"]
    assert np.allclose(np.sort_complex(control.poles(cs)), np.sort_complex(ss.poles()))
    assert control.dcgain(cs) == pytest.approx(1.0 / G_ACC, rel=1e-10)


def test_point_outputs_about_a_moving_state():
    """A bar of length L turning freely at Omega about z, at angle 0: tip velocity and acceleration.

    With the tip at ``L (cos q, sin q)``: ``v_x = -L sin q qd`` gives
    ``dv_x/dq = -L Omega``; ``a_x = -L (cos q qd^2 + sin q qdd)`` gives
    ``da_x/dqd = -2 L Omega``; ``a_y = L (cos q qdd - sin q qd^2)`` gives
    ``da_y/dq = -L Omega^2`` and, through ``qdd = u / I``, ``D = L / I``.
    """
    L, omega = 1.0, 3.0
    model = fm.Model()
    bar = fm.RigidBody.slender_bar("bar", 1.0, L)
    system = model.add(fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1))).build()
    outs = [fm.Output.point("bar", (L, 0, 0), (1, 0, 0), derivative=1, name="vx"),
            fm.Output.point("bar", (L, 0, 0), (1, 0, 0), derivative=2, name="ax"),
            fm.Output.point("bar", (L, 0, 0), (0, 1, 0), derivative=2, name="ay")]
    ss = fm.state_space(system, ["pin"], outs, about=(np.zeros(1), np.array([omega])))
    inertia = 1.0 * L**2 / 3
    assert ss.linearization.method == "fd"
    assert np.allclose(ss.C, [[-L * omega, 0.0], [0.0, -2 * L * omega], [-L * omega**2, 0.0]], atol=1e-8)
    assert np.allclose(ss.D[:, 0], [0.0, 0.0, L / inertia], rtol=1e-10, atol=1e-12)


def test_state_space_of_a_closed_loop_mechanism():
    """The four-bar has one degree of freedom: one state pair, named z0 (T mixes the coordinates)."""
    from conftest import fourbar, fourbar_initial

    system = fourbar().build()
    x0, xd0 = fm.initial_state(system, positions=fourbar_initial())
    with pytest.warns(UserWarning, match="not an equilibrium"):
        ss = fm.state_space(system, ["A"], ["A"], about=(x0, 0 * xd0))
    assert ss.states == ["z0", "z0'"] and ss.linearization.method == "fd"
    assert "closed loops" in ss.linearization.reason
    assert ss.A.shape == (2, 2)


def test_to_control_with_the_default_names():
    """python-control refuses '.' in signal names; flexmb's default names have it: '.' becomes '_'."""
    control = pytest.importorskip("control", reason="python-control is optional: pip install 'flexmb[control]'")
    tip = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    ss = fm.state_space(flexible_arm().build(), ["motor", fm.Input.point_force("arm", *tip)],
                        ["motor.angle", fm.Output.point("arm", *tip), fm.Output.section_load("arm", 0, "Mz")])
    assert all("." in name for name in ss.outputs)
    cs = ss.to_control()
    assert cs.input_labels == [n.replace(".", "_") for n in ss.inputs]
    assert cs.output_labels == ["motor_angle", "arm@(1, 0, 0)_(0, 1, 0)", "arm_j0_Mz"]
    assert cs.state_labels == ss.states
    assert np.array_equal(cs.A, ss.A) and np.array_equal(cs.D, ss.D)
    same = fm.state_space(pendulum().build(), ["pin"], ["pin.angle", fm.Output.coordinate("pin", name="pin_angle")])
    with pytest.raises(fm.ModelError, match="not unique once '.' becomes '_'"):
        same.to_control()
