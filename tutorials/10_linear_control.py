"""
Linear models: a Campbell diagram and a PD controller
=====================================================

Two uses of the model linearised about a state (:func:`flexmb.state_space`,
``docs/linear.md``).

1. Vibration: the spin-up beam of benchmark B3 (L = 10 m, E I = 1.4e4 N m^2,
   rho A = 1.2 kg/m) on a hub turning steadily at Omega, bending in the
   plane of rotation. Its first three bending frequencies rise with the
   rate (:func:`flexmb.campbell`), as Southwell's estimate
   ``w^2 = w0^2 + K Omega^2`` says.
2. Control: a flexible arm, a hub driven by a motor torque carrying a 1 m
   aluminium blade that bends in the plane of rotation. Its open-loop state
   space gives the poles and the Bode diagram from the hub torque to the tip
   (:func:`flexmb.frequency_response`). A PD controller on the hub angle is
   designed for the rigid mode, its closed-loop poles come from
   ``ss.feedback``, and it is checked by simulating the nonlinear model
   with the controller as a force element written in Python.

The numbers to expect. Southwell's coefficient of the first mode is
K1 = 1.1933 (Southwell & Gough 1921), and in the plane of rotation
K1 - 1 = 0.1933. The 16-segment model stays below the estimate: by 0.01 % at
1 rad/s, 0.84 % at 4 rad/s and 2.8 % at 6 rad/s, where w1 = 4.489 rad/s.
Modes 2 and 3 follow their own coefficients (6.478 - 1 and 17.860 - 1) to
0.05 %. The arm has a double pole at 0 (the rigid rotation, inertia
0.15418 kg m^2) and its first flexible mode at 6.88 Hz. A PD law with
kp = 6.087 N m/rad and kd = 1.356 N m s/rad (1 Hz, 0.7 of critical) damps the
rigid mode at 0.68 of critical and the first flexible mode at 0.20. The
same law read off the tip instead of the hub makes that mode unstable. For a
1 mrad step the simulation and the linear prediction agree to 2e-7 of the
response. For a 1 rad step the tip's path departs by 18 % (the tip moves on
a circle, not along its tangent), but the blade's bending in the hub frame
departs by only 0.2 %. Run as a script, it saves the Campbell diagram, the
deviation from Southwell, the Bode diagram and the two steps in
``results/10_linear_control_*.png``.
"""

import numpy as np
import scipy.linalg
import scipy.signal
from attrs import frozen
from scipy.integrate import quad

import flexmb as fm

# %%
# Part 1: the spinning beam
# -------------------------
# The B3 beam is clamped to a hub that a driver turns at a constant rate
# about z. ``keep=("bend_z",)`` keeps one bending angle per segment, about
# the segment's z axis: bending in the plane of rotation. The segments are
# slender bars, with no rotary inertia, as B3 prescribes.
#
# :func:`flexmb.campbell` calls ``build(rate)`` once per rate. It needs the
# system and the state to linearise about: here steady spinning, the beam
# straight and the hub turning at the rate. At a moving state the
# centrifugal and gyroscopic terms change with the state, so K and C come
# from central differences of the equations of motion
# (``ss.linearization.method == "fd"``). Each mode is followed from one rate
# to the next by the modal assurance criterion (MAC) of its shape.

L_B3, N_B3 = 10.0, 16
B3_SECTION = fm.Section(area=1e-3, Iy=1e-6, Iz=1e-6, J=2e-6, name="B3")  # rho A = 1.2 kg/m, E I = 1.4e4 N m^2
B3_MATERIAL = fm.Material(E=1.4e10, density=1200.0, name="B3")


def spinning_beam(rate):
    """The B3 beam on a hub driven at ``rate`` (rad/s), and the steadily spinning state."""
    model = fm.Model("B3 spinning")
    beam = fm.FlexibleBody("beam", L_B3, B3_SECTION, B3_MATERIAL, N_B3, keep=("bend_z",), rotary_inertia=False)
    hub = fm.Revolute("hub", model.ground, beam, axis=(0, 0, 1))
    system = model.add(hub, fm.Driver.constant_speed("spin", hub, rate)).build()
    xd0 = np.zeros(system.n_coords)
    xd0[system.coordinate_slice(hub)] = rate
    return system, (np.zeros(system.n_coords), xd0)


rates = np.linspace(0.0, 6.0, 13)
campbell_b3 = fm.campbell(spinning_beam, rates, n_modes=3, label="spin rate (rad/s)")
omega = 2 * np.pi * campbell_b3.frequencies  # rad/s, (rates, modes)
print(f"B3, N = {N_B3}: w1..w3 at rest {omega[0].round(4)} rad/s, at 6 rad/s {omega[-1].round(4)} rad/s; "
      f"smallest MAC from one rate to the next {campbell_b3.mac.min():.4f}")

# %%
# Southwell's estimate
# --------------------
# Southwell and Gough (1921) estimated the frequencies of a rotating blade by
# Rayleigh's quotient with the mode shape phi of the blade at rest. Spinning
# at Omega stretches the blade with the centrifugal tension
# ``N(x) = rho A Omega^2 (L^2 - x^2) / 2`` (no hub radius), which adds
# ``int N phi'^2 dx`` to the strain energy. So ``w^2 = w0^2 + K1 Omega^2``,
# with
#
# ``K1 = int_0^1 (1 - s^2) phi'(s)^2 ds / (2 int_0^1 phi(s)^2 ds)``,
#
# for bending out of the plane of rotation. In the plane of rotation the
# centrifugal force also pulls a displaced point outwards, away from the
# axis. This softens every mode by ``Omega^2``, so ``K = K1 - 1``. Reference:
# R. V. Southwell and B. S. Gough, "The free transverse vibration of
# airscrew blades", ARC R&M 766 (1921), whose coefficient for the first mode
# of a uniform cantilever is 1.193. The quadrature below gives it for the
# first three cantilever modes: ``phi`` is the Euler-Bernoulli cantilever
# mode, with ``beta_i L`` the roots of ``cos b cosh b = -1``.
#
# With the non-rotating shape, Rayleigh's quotient gives the slope of
# ``w^2`` against ``Omega^2`` at rest exactly. At higher rates the shape
# changes, and the estimate lies above the model's first frequency, as a
# Rayleigh quotient lies above the lowest eigenvalue. The estimate below
# starts from the model's own ``w0``. The model's frequencies at rest are
# 0.2 to 1 % below Euler-Bernoulli's, and this difference stays out of the
# comparison.

beta_L = np.array([1.8751040687119611, 4.6940911329741745, 7.8547574382376126])


def southwell_coefficient(b):
    """Southwell's coefficient K1 of the uniform cantilever mode with ``beta L = b`` (no hub radius)."""
    s = (np.cosh(b) + np.cos(b)) / (np.sinh(b) + np.sin(b))

    def phi(x):
        return np.cosh(b * x) - np.cos(b * x) - s * (np.sinh(b * x) - np.sin(b * x))

    def dphi(x):
        return b * (np.sinh(b * x) + np.sin(b * x) - s * (np.cosh(b * x) - np.cos(b * x)))

    stretch = quad(lambda x: 0.5 * (1 - x * x) * dphi(x) ** 2, 0.0, 1.0, epsabs=1e-13, limit=200)[0]
    return stretch / quad(lambda x: phi(x) ** 2, 0.0, 1.0, epsabs=1e-13, limit=200)[0]


K_southwell = np.array([southwell_coefficient(b) for b in beta_L])  # out of the plane of rotation
K_in_plane = K_southwell - 1.0
omega0_euler_bernoulli = beta_L**2 * np.sqrt(1.4e4 / (1.2 * L_B3**4))
southwell = np.sqrt(omega[0] ** 2 + K_in_plane * rates[:, None] ** 2)
deviation = 100 * (omega / southwell - 1)  # per cent
print(f"Southwell's coefficients K1 = {K_southwell.round(4)}; in the plane of rotation K = K1 - 1 = "
      f"{K_in_plane.round(4)}")
print(f"w0: model {omega[0].round(4)}, Euler-Bernoulli {omega0_euler_bernoulli.round(4)} rad/s")
print(f"{'Omega':>6} {'w1 model':>9} {'Southwell':>10} {'diff %':>8} {'w2 diff %':>10} {'w3 diff %':>10}")
for i in range(0, len(rates), 2):
    print(f"{rates[i]:6.1f} {omega[i, 0]:9.4f} {southwell[i, 0]:10.4f} {deviation[i, 0]:8.3f} "
          f"{deviation[i, 1]:10.4f} {deviation[i, 2]:10.4f}")

# %%
# The first mode meets the first-order excitation line ``w = Omega``: an
# imbalance that turns with the hub would excite it at that rate.

gap = omega[:, 0] - rates
i_cross = int(np.argmax(gap < 0))
order1_crossing = rates[i_cross - 1] + gap[i_cross - 1] * (rates[i_cross] - rates[i_cross - 1]) / (
    gap[i_cross - 1] - gap[i_cross])
print(f"mode 1 crosses w = Omega near {order1_crossing:.2f} rad/s")

# %%
# Where the differences come from. Near rest they are the model's own: with
# 16 segments its slope of ``w^2`` against ``Omega^2``, read between 0 and
# 0.5 rad/s, differs from K by a per cent or two for mode 1 and less for
# modes 2 and 3. That difference falls as 1/N^2 (``docs/linear.md``). Mode 1
# then falls further below the estimate as the rate approaches and passes
# its frequency at rest (3.79 rad/s), where the shape at rest no longer
# describes the mode. Modes 2 and 3 are far stiffer than the rate, and they
# follow their coefficients to a few hundredths of a per cent.

slope = (omega[1] ** 2 - omega[0] ** 2) / rates[1] ** 2
print(f"slope of w^2 against Omega^2 at {rates[1]} rad/s: {slope.round(4)}, "
      f"{(100 * (slope / K_in_plane - 1)).round(2)} % from K")

# %%
# Part 2: a flexible arm
# ----------------------
# A hub (1 kg, 0.05 kg m^2 about its axis) turns about the vertical z on a
# :class:`~flexmb.Revolute` joint named ``motor``. Clamped to it 5 cm from
# the axis is an aluminium blade, 1 m long, 5 mm thick (along y) and 20 mm
# tall (along z), in 8 segments. It bends in the plane of rotation
# (``bend_z``, the blade's soft direction), like the classic laboratory
# flexible arm. Its damping is 0.5 % of critical at the clamped blade's
# first frequency. The damping is stiffness-proportional, so it grows with
# the frequency.

R0, L_ARM, N_ARM = 0.05, 1.0, 8
ARM_SECTION = fm.Section.rectangular(0.005, 0.02)  # b = 5 mm along y, h = 20 mm along z
ARM_MATERIAL = fm.Material.aluminium()


def flexible_arm(*controllers):
    """The hub on its motor joint, the blade clamped to it, and any extra force elements."""
    model = fm.Model("flexible arm")
    hub = fm.RigidBody("hub", 1.0, (0.03, 0.03, 0.05))
    arm = fm.FlexibleBody.uniform_beam("arm", L_ARM, ARM_SECTION, ARM_MATERIAL, N_ARM, keep=("bend_z",),
                                       damping_ratio=0.005)
    motor = fm.Revolute("motor", model.ground, hub, axis=(0, 0, 1))
    model.add(motor, fm.Fixed("clamp", hub, arm, parent_point=(R0, 0.0, 0.0)), *controllers)
    return model


# %%
# The open loop: the short form
# -----------------------------
# The input is the torque on the ``motor`` joint (a joint's name as an input
# is the generalized force on its coordinate). The outputs are the hub
# angle, its rate, and the tip's displacement along y. The tip is a point of
# the arm's frame (1 m along x), and on a flexible body it moves with its
# segment. The model at rest, in an open tree and with built-in elements
# only, is linearised by its analytic tangent.

tip = fm.Output.point("arm", (L_ARM, 0.0, 0.0), (0.0, 1.0, 0.0), name="tip")
ss = fm.state_space(flexible_arm().build(), inputs=["motor"],
                    outputs=["motor", fm.Output.coordinate("motor", derivative=1), tip])
open_poles = ss.poles()
order = np.argsort(np.abs(open_poles))
rigid_poles = open_poles[order[:2]]
flexible_poles = open_poles[order[2:]][open_poles[order[2:]].imag > 0]
f_flexible = np.abs(flexible_poles) / (2 * np.pi)
open_damping = -flexible_poles.real / np.abs(flexible_poles)
print(f"\nflexible arm: {ss.A.shape[0]} states {ss.states[:2]} ...; inputs {ss.inputs}, outputs {ss.outputs}; "
      f"linearised by {ss.linearization.method}")
print(f"open-loop poles: two rigid at 0 (largest |p| {np.abs(rigid_poles).max():.0e} 1/s); "
      f"flexible modes {f_flexible[:3].round(3)} Hz ..., damping ratios {open_damping[:3].round(4)}")

# %%
# The double pole at 0 is the free rotation of the whole arm: torque to
# angle is ``1 / (J s^2)`` at low frequency. J can be read from the
# response at a low frequency. It equals the hub's 0.05 kg m^2 plus the
# blade's inertia about the axis, ``rho A ((R0 + L)^3 - R0^3) / 3`` plus
# the small ``m b^2 / 12`` of the segments' thickness.

w_low = 1e-3
J_rigid = 1.0 / (w_low**2 * fm.frequency_response(ss, w=[w_low], pairs=[("motor", "motor")]).magnitude[0, 0])
print(f"rigid inertia about the axis, from the response at {w_low} rad/s: J = {J_rigid:.6f} kg m^2")

# %%
# Bode diagram and zeros
# ----------------------
# The frequency response from the hub torque to the tip, and to the hub
# angle, is drawn in the plotting block below
# (``fm.frequency_response(ss, ...).plot()``). The zeros explain its shape.
# They are the finite generalized eigenvalues of the Rosenbrock pencil
# ``[[A, B], [C, D]]``.
#
# * Torque to hub angle is *collocated*: the actuator and the sensor are at
#   the same place. Its zeros are the modes of the blade with the hub held
#   still, i.e. a clamped 1 m cantilever, whose first frequency is 4.11 Hz
#   (Euler-Bernoulli, as in tutorial 03). They alternate with the poles, so
#   the phase stays between -180 degrees (the rigid body's) and 0, and a PD
#   law can only add damping.
# * Torque to tip is not collocated. It has a real zero in the right half
#   plane, so it is *non-minimum phase*: a torque first pulls the tip
#   backwards (see the small dip at the start of the step below). No zero
#   pair gives back the 180 degrees that each flexible mode takes, and the
#   phase falls far below the rigid body's. (The unwrapped phase starts at
#   +180 degrees, which is the same angle as -180.)

frequencies = np.logspace(-1, 2, 600)
bode = fm.frequency_response(ss, f=frequencies, pairs=[("motor", "tip"), ("motor", "motor")])


def transmission_zeros(ss, output, input="motor"):
    """Finite zeros of one input-output channel of a state-space model, 1/s."""
    i, j = ss.index(input, "input"), ss.index(output, "output")
    n = ss.A.shape[0]
    pencil = np.block([[ss.A, ss.B[:, [i]]], [ss.C[[j]], ss.D[[j]][:, [i]]]])
    E = np.zeros_like(pencil)
    E[:n, :n] = np.eye(n)
    z = scipy.linalg.eigvals(pencil, E)
    return z[np.isfinite(z) & (np.abs(z) < 1e8)]


hub_zeros = transmission_zeros(ss, "motor")
f_hub_zeros = np.sort(np.abs(hub_zeros[hub_zeros.imag > 0])) / (2 * np.pi)
tip_zeros = transmission_zeros(ss, "tip")
tip_zero_rhp = float(np.min(tip_zeros.real[(tip_zeros.real > 0) & (np.abs(tip_zeros.imag) < 1e-6)]))
tip_phase_drop = float(bode.phase[0, 0] - bode.phase[:, 0].min())
print(f"torque -> hub angle: zeros at {f_hub_zeros[:3].round(3)} Hz ... (clamped blade; Euler-Bernoulli 4.113 Hz), "
      f"phase between {bode.phase[:, 1].min():.1f} and {bode.phase[:, 1].max():.1f} deg")
print(f"torque -> tip: a real zero at +{tip_zero_rhp:.2f} 1/s (right half plane); the phase falls "
      f"{tip_phase_drop:.1f} deg below its low-frequency value by {frequencies[-1]:g} Hz")

# %%
# Design of the PD controller
# ---------------------------
# The law is ``tau = kp (theta_ref - theta) - kd theta'``, on the hub angle.
# On the rigid arm it gives ``J s^2 + kd s + kp``. Choose the bandwidth
# ``w_c`` well below the first flexible mode (1 Hz against 6.9 Hz) and 0.7 of
# critical damping: ``kp = J w_c^2``, ``kd = 2 zeta J w_c``.
#
# ``ss.feedback(G)`` closes the loop ``u = v - G y``. Here G is one row over
# the outputs ``(motor, motor', tip)``: ``[[kp, kd, 0]]``. The new input is
# ``v = kp theta_ref``. The closed-loop poles show the rigid mode where it
# was designed, and the flexible modes damped more than in the open loop.
# No damping is lowered, as collocation promises. The closed loop's static
# gain from v to the hub angle is ``1 / kp``, so the arm settles at
# ``theta_ref``.

w_c, zeta = 2 * np.pi * 1.0, 0.7
kp, kd = J_rigid * w_c**2, 2 * zeta * J_rigid * w_c
closed = ss.feedback([[kp, kd, 0.0]])
closed_poles = closed.poles()
by_size = closed_poles[np.argsort(np.abs(closed_poles))]
by_size = by_size[by_size.imag >= 0]
closed_damping = -by_size.real / np.abs(by_size)
print(f"\nPD: kp = {kp:.4f} N m/rad, kd = {kd:.4f} N m s/rad")
print(f"closed-loop poles: rigid {by_size[0]:.4f} 1/s (damping ratio {closed_damping[0]:.3f}); "
      f"flexible {(np.abs(by_size[1:4]) / (2 * np.pi)).round(3)} Hz, damping ratios {closed_damping[1:4].round(4)}")
print(f"largest real part {closed_poles.real.max():.4f} 1/s; static gain v -> (hub, tip) "
      f"{closed.static_gain()[[0, 2], 0].round(6)} (1/kp = {1 / kp:.6f})")

# %%
# The same law, with the angle read off the tip (``tip / (R0 + L)``)
# instead of the hub, shows why collocation matters. The loop goes around
# the right-half-plane zero, and the first flexible mode becomes unstable,
# at every bandwidth from 0.25 to 3 Hz.

tip_rate = fm.Output.point("arm", (L_ARM, 0.0, 0.0), (0.0, 1.0, 0.0), derivative=1, name="tip'")
ss_tip = fm.state_space(flexible_arm().build(), ["motor"], [tip, tip_rate])
bandwidths = np.array([0.25, 0.5, 1.0, 2.0, 3.0])  # Hz
tip_feedback_growth = []
for f_c in bandwidths:
    gain = J_rigid * (2 * np.pi * f_c) ** np.array([2.0, 1.0]) * np.array([1.0, 2 * zeta]) / (R0 + L_ARM)
    tip_feedback_poles = ss_tip.feedback([gain]).poles()
    tip_feedback_growth.append(tip_feedback_poles.real.max())
    if f_c == 1.0:
        unstable = tip_feedback_poles[np.argmax(tip_feedback_poles.real)]
tip_feedback_growth = np.array(tip_feedback_growth)
print(f"PD on the tip, 1 Hz: a pole at {unstable.real:+.3f} {abs(unstable.imag):+.3f}j 1/s "
      f"({abs(unstable.imag) / (2 * np.pi):.2f} Hz); largest real part at {bandwidths} Hz: "
      f"{tip_feedback_growth.round(3)} 1/s")

# %%
# The controller as a force element
# ---------------------------------
# To check the design on the nonlinear model, the controller becomes a
# force element written in Python, as in tutorial 05. It is a frozen attrs
# class that refers to its joint and adds its torque to the joint's
# generalized force. ``theta_ref`` is a step at t = 0.


@frozen(eq=False)
class PD(fm.ForceElement):
    """A PD controller on a joint coordinate: ``tau = kp (theta_ref - q) - kd qd``."""

    joint: fm.Joint = fm.reference(fm.Joint)
    kp: float = 0.0
    kd: float = 0.0
    theta_ref: float = 0.0

    def apply(self, state, loads):
        """Add the controller's torque to the joint's generalized force."""
        c = state.coordinate_slice(self.joint).start
        loads.generalized[c] += self.kp * (self.theta_ref - state.x[c]) - self.kd * state.xd[c]


# %%
# Simulation against the linear prediction
# ----------------------------------------
# Each step is simulated for 3 s with tight tolerances, and the closed loop
# is run through ``scipy.signal.lsim`` with ``v = kp theta_ref``. Three
# signals are compared: the hub angle, the tip's displacement along y, and
# the blade's bending at the tip in the hub frame,
# ``w = -sin(theta) x_tip + cos(theta) y_tip``. To first order ``w`` is
# ``tip - (R0 + L) theta``. A difference is the largest distance between
# the two curves over the largest linear value.

T_END = 3.0
t = np.linspace(0.0, T_END, 301)


def step(theta_ref):
    """Nonlinear and linear responses to a step of the reference angle: (result, {signal: (nonlinear, linear)})."""
    _, y, _ = scipy.signal.lsim(closed.to_scipy(), np.full(t.shape, kp * theta_ref), t)
    res = fm.simulate(flexible_arm(PD("pd", "motor", kp, kd, theta_ref)).build(), T_END, t_eval=t,
                      rtol=1e-10, atol=1e-14)
    theta = res.coordinate("motor")
    tip_xyz = res.shape("arm")[:, -1, :]  # the tip: last point of the centre line
    bending = -np.sin(theta) * tip_xyz[:, 0] + np.cos(theta) * tip_xyz[:, 1]
    signals = {"hub angle": (theta, y[:, 0]), "tip y": (tip_xyz[:, 1] - tip_xyz[0, 1], y[:, 2]),
               "tip bending": (bending - bending[0], y[:, 2] - (R0 + L_ARM) * y[:, 0])}
    return res, signals


def differences(signals):
    """Largest difference of each signal over its largest linear value."""
    return {k: float(np.max(np.abs(a - b)) / np.max(np.abs(b))) for k, (a, b) in signals.items()}


res_small, small = step(1e-3)
small_step_error = differences(small)
print(f"\n1 mrad step ({res_small.method}, {res_small.n_rhs} right-hand sides): nonlinear against linear, "
      + ", ".join(f"{k} {v:.1e}" for k, v in small_step_error.items()))

# %%
# For a 1 mrad step the two agree to 2e-7, and the agreement is limited by
# the kinematics. The tip moves on a circle, ``(R0 + L) sin(theta)``, not
# along its tangent ``(R0 + L) theta``. That relative difference is
# ``theta^2 / 6``, here 2e-7. The dynamics (hub angle, bending) agree to
# 1e-9 or better.
#
# A large step
# ------------
# A 1 rad step (57 degrees) with the same controller. The linear model
# moves the tip along the tangent, so its ``tip y`` departs from the
# simulation by 18 %. Of the final value, it departs by ``1 - sin(1) = 16 %``,
# and by a little more at the overshoot. That is a geometric effect of the
# large rotation. The bending in the hub
# frame, which the linear model describes, departs far less. Its remaining
# 0.2 % comes from the forces of the large motion that the linear model
# drops: the centrifugal stiffening of the blade at the peak hub rate
# (3.3 rad/s) and the Coriolis forces.

res_large, large = step(1.0)
large_step_error = differences(large)
peak_rate = float(np.max(np.abs(res_large.xd[:, res_large.coordinate_names.index("motor.angle")])))
print(f"1 rad step ({res_large.n_rhs} right-hand sides; peak hub rate {peak_rate:.2f} rad/s): "
      + ", ".join(f"{k} {v:.1e}" for k, v in large_step_error.items()))
print(f"peak bending at the tip: {1e3 * np.max(np.abs(large['tip bending'][0])):.2f} mm nonlinear, "
      f"{1e3 * np.max(np.abs(large['tip bending'][1])):.2f} mm linear")

# %%
# Plots
# -----
# The short forms first. ``campbell_b3.plot()`` draws the tracked modes
# (and, by default, their damping ratios), here with the first-order
# excitation line ``w = Omega`` and Southwell's estimate added.
# ``bode.plot()`` draws the Bode diagram from the hub torque
# to the tip and to the hub angle. Then the long form: the deviation from
# Southwell in per cent, and the two steps, simulated and linear.

if __name__ == "__main__":
    import os

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed (pip install -e '.[viz]'): no plot")
    else:
        os.makedirs("results", exist_ok=True)
        fig = campbell_b3.plot(orders=(1,), hz=False, damping=False, figsize=(7.0, 4.5))
        ax = fig.axes[0]
        for i in range(3):
            ax.plot(rates, southwell[:, i], "k:", lw=1.0, label="Southwell" if i == 0 else None)
        ax.legend(fontsize="small", loc="center right")
        ax.set_title("B3 beam at a constant spin rate: in-plane bending")
        fig.tight_layout()
        fig.savefig(os.path.join("results", "10_linear_control_campbell.png"), dpi=120)

        fig, ax = plt.subplots(figsize=(7.0, 3.5))
        for i in range(3):
            ax.plot(rates, deviation[:, i], "o-", ms=3, label=f"mode {i + 1}, K = {K_in_plane[i]:.4f}")
        ax.axvline(omega[0, 0], color="0.6", lw=0.8, ls="--")
        ax.set_xlabel("spin rate (rad/s)")
        ax.set_ylabel("model / Southwell - 1 (%)")
        ax.legend(fontsize="small")
        ax.grid(True, alpha=0.3)
        fig.tight_layout()
        fig.savefig(os.path.join("results", "10_linear_control_southwell.png"), dpi=120)

        fig = bode.plot(figsize=(7.0, 6.0))
        for ax in fig.axes:
            for f in f_flexible[:2]:
                ax.axvline(f, color="0.7", lw=0.8, ls="--")
        fig.axes[0].set_title("flexible arm, open loop: hub torque to tip and to hub angle")
        fig.tight_layout()
        fig.savefig(os.path.join("results", "10_linear_control_bode.png"), dpi=120)

        fig, ax = plt.subplots(2, 2, figsize=(9, 6), sharex=True)
        for col, (label, signals) in enumerate((("1 mrad step", small), ("1 rad step", large))):
            for row, key in enumerate(("tip y", "tip bending")):
                a, b = signals[key]
                ax[row, col].plot(t, 1e3 * a, label="nonlinear simulation")
                ax[row, col].plot(t, 1e3 * b, "--", label="linear (lsim)")
                ax[row, col].set_ylabel(f"{key} [mm]")
                ax[row, col].set_title(f"{label}: {key}, difference {differences(signals)[key]:.1e}", fontsize=9)
            ax[1, col].set_xlabel("t [s]")
        ax[0, 0].legend(fontsize="small")
        fig.tight_layout()
        fig.savefig(os.path.join("results", "10_linear_control_steps.png"), dpi=120)
        print("wrote results/10_linear_control_campbell.png, _southwell.png, _bode.png and _steps.png")
