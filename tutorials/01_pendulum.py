r"""
A pendulum with Kane's equations
================================

A uniform slender bar (1 kg, 1 m) hangs from a revolute joint at one end and
swings under gravity. This first tutorial builds the model, simulates it in
three lines, and then opens up what :func:`flexmb.simulate` does at every
step: the generalized coordinate, the partial velocity arrays V and W
(eqs. 7 and 17 of Amirouche & Huston 1988), the mass matrix A (eq. 2) and the
force array f (eq. 3) of Kane's equations ``A xdd = f`` (eq. 1).

It ends by releasing the bar from rest at 120 degrees from the downward
vertical and comparing the simulated period with the exact one from the
complete elliptic integral of the first kind,

.. math:: T = \frac{4 K(k)}{\omega_0}, \quad k = \sin\frac{\theta_0}{2},
   \quad \omega_0^2 = \frac{m g L / 2}{I_O} = \frac{3 g}{2 L}.

The number to expect: T = 2.248705 s, and the simulated period agrees to a
relative error below 1e-6 (about 1e-11 with the tolerance used here).
"""

import numpy as np
from scipy.interpolate import CubicHermiteSpline
from scipy.special import ellipk

import flexmb as fm
from flexmb.assembly import mass_matrix

# %%
# The model
# ---------
# A body, a joint that attaches it to the ground, and gravity.
# ``RigidBody.slender_bar`` puts the body frame at one end of the bar, with
# the bar along the body x axis, so its mass centre is at ``(L/2, 0, 0)``
# and its central inertia is ``m L^2 / 12`` about y and z. The
# :class:`~flexmb.Revolute` joint turns the bar about the ground's z axis;
# gravity points along -y, so the bar hangs straight down when the joint
# angle is -90 degrees.

m, L, g = 1.0, 1.0, 9.81

model = fm.Model("pendulum")
bar = fm.RigidBody.slender_bar("bar", mass=m, length=L)
pin = fm.Revolute("pin", model.ground, bar, axis=(0, 0, 1))
model.add(pin, fm.Gravity((0.0, -g, 0.0)))

# %%
# The short form
# --------------
# :func:`flexmb.simulate` compiles the model, integrates it and returns a
# :class:`~flexmb.Result`. Initial conditions are given by joint (or
# coordinate) name. The joint angle q is measured from +x, so a release at
# ``theta0`` from the downward vertical is ``q0 = theta0 - 90 deg``.

theta0 = np.radians(120.0)
q0 = theta0 - np.pi / 2

res = fm.simulate(model, t_end=1.0, positions={"pin": q0})
print(f"short form: {res.status}, q(1 s) = {res.coordinate('pin')[-1]:.6f} rad, "
      f"energy drift {np.ptp(res.energy):.2e} J")

# %%
# The long form: coordinates
# --------------------------
# ``model.build()`` validates the model and compiles it into a
# :class:`~flexmb.System`: the tree of bodies, the numbering of the
# generalized coordinates x, the force assembler and the constraints (none
# here). Each joint adds exactly the coordinates of its own freedoms; a
# revolute adds one angle, named ``"<joint>.angle"``.

system = model.build()
print(f"n = {system.n_coords} coordinate(s): {system.coordinate_names}; bodies: {system.body_names}")

# %%
# Partial velocities V and W
# --------------------------
# Kane's method writes every body's angular velocity and mass-centre
# velocity as linear in the generalized speeds ``xd``:
#
# * eq. 7: ``omega_k = W_k xd`` (W_k, shape (3, n): the partial angular
#   velocities, column l is the angular velocity body k would have if
#   ``xd_l = 1`` and all other speeds were 0);
# * eq. 17: ``v_k = V_k xd`` (V_k, shape (3, n): the partial velocities of
#   the mass centre).
#
# ``system.kinematics(t, x, xd)`` computes them for all bodies at once,
# stacked along the first axis: ``kin.V`` and ``kin.W`` have shape
# ``(n_bodies + 1, 3, n)`` (the last row is the ground). For the bar, turning
# about z at the origin with its mass centre at ``r = (L/2)(cos q, sin q, 0)``:
# ``W = e_z`` and ``V = e_z x r = (L/2)(-sin q, cos q, 0)``.

q, qd = np.radians(30.0), 2.0
x, xd = np.array([q]), np.array([qd])
kin = system.kinematics(0.0, x, xd)
k = system.index(bar)
V, W = kin.V[k], kin.W[k]
V_exact = np.array([[-np.sin(q)], [np.cos(q)], [0.0]]) * L / 2
W_exact = np.array([[0.0], [0.0], [1.0]])
partials_error = max(np.abs(V - V_exact).max(), np.abs(W - W_exact).max())
print(f"V_bar = {V.ravel()}   (L/2)(-sin q, cos q, 0) = {V_exact.ravel()}")
print(f"W_bar = {W.ravel()}   e_z = {W_exact.ravel()}")
print(f"v = V xd = {(V @ xd)}, omega = W xd = {(W @ xd)}; kin.v, kin.omega: {kin.v[k]}, {kin.omega[k]}")

# %%
# The mass matrix A
# -----------------
# Eq. 2 sums the bodies' contributions,
# ``A = sum_k m_k V_k^T V_k + W_k^T I_k W_k`` (``I_k`` the central inertia in
# inertial axes), in one vectorised call. For the bar it is
# ``m L^2/4 + m L^2/12 = m L^2/3``, the moment of inertia about the pivot,
# ``I_O`` (the parallel-axis theorem, recovered from the partial velocities).

A = mass_matrix(kin)
translational = m * V.T @ V
rotational = W.T @ kin.inertia_world()[k] @ W
I_O = m * L**2 / 3
mass_matrix_error = abs(A[0, 0] - I_O) / I_O
print(f"A = {A[0, 0]:.12f} = m V^T V + W^T I W = {translational[0, 0]:.6f} + {rotational[0, 0]:.6f};"
      f"  m L^2/3 = {I_O:.12f}  (relative difference {mass_matrix_error:.1e})")

# %%
# The force array f
# -----------------
# Eq. 5 projects the applied loads on the partial velocities,
# ``F_l = sum_k V_kl . force_k + W_kl . torque_k``; eq. 3 subtracts the
# velocity-dependent inertia forces, ``f = F - sum_k [m_k V_k^T (Vdot_k xd)
# + W_k^T (I_k Wdot_k xd + omega_k x I_k omega_k)]``. For the bar, gravity
# gives ``F = V . (m g) = -m g (L/2) cos q``; the centripetal acceleration
# is perpendicular to V and the bar turns about a fixed axis, so the inertia
# terms vanish and ``f = F``. The accelerations then solve ``A xdd = f``.

F = system.forces.active_force(kin)
f = system.forces.force_array(kin)
f_exact = -m * g * L / 2 * np.cos(q)
xdd = system.accelerations(0.0, x, xd)
print(f"F = {F[0]:.12f}, f = {f[0]:.12f}, -m g (L/2) cos q = {f_exact:.12f}")
print(f"xdd = {xdd[0]:.12f} = f / A = {f[0] / A[0, 0]:.12f} rad/s^2")

# %%
# The period of a large swing
# ---------------------------
# The exact period for an amplitude ``theta0`` is ``4 K(k) / omega0`` with
# ``k = sin(theta0 / 2)``; :func:`scipy.special.ellipk` takes the parameter
# ``k^2``. For 120 degrees it is 37 % longer than the small-swing period.

omega0 = np.sqrt(m * g * L / 2 / I_O)
period_exact = 4 * ellipk(np.sin(theta0 / 2) ** 2) / omega0
print(f"small-swing period {2 * np.pi / omega0:.6f} s, exact period at 120 deg {period_exact:.9f} s")

# %%
# We simulate a little over one period with a tight tolerance and find the
# times where the bar passes the bottom (``theta = q + 90 deg = 0``). There
# it moves fastest, so the crossing times are sharp. A cubic Hermite spline
# through the stored angles and speeds interpolates to O(h^4) between the
# output times; its roots are the crossings. The first and the third
# crossing are one period apart.

res = fm.simulate(system, t_end=1.3 * period_exact, positions={"pin": q0}, rtol=1e-11, n_out=401)
theta = res.coordinate("pin") + np.pi / 2
crossings = CubicHermiteSpline(res.t, theta, res.xd[:, 0]).roots(extrapolate=False)
period_simulated = crossings[2] - crossings[0]
period_error = abs(period_simulated - period_exact) / period_exact
energy_drift = np.abs(res.energy - res.energy[0]).max()
print(f"simulated period {period_simulated:.9f} s, exact {period_exact:.9f} s, "
      f"relative error {period_error:.1e}")
print(f"{res.n_steps} steps, {res.n_rhs} right-hand sides, energy drift {energy_drift:.1e} J")

# %%
# Plot
# ----
# The angle from the vertical over one period, and the energy drift.

if __name__ == "__main__":
    import os

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed (pip install -e '.[viz]'): no plot")
    else:
        fig, ax = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
        ax[0].plot(res.t, np.degrees(theta))
        for tc in crossings:
            ax[0].axvline(tc, color="0.7", lw=0.8)
        ax[0].set_ylabel("angle from vertical [deg]")
        ax[0].set_title(f"period {period_simulated:.6f} s (exact {period_exact:.6f} s)")
        ax[1].plot(res.t, res.energy - res.energy[0])
        ax[1].set_ylabel("energy drift [J]")
        ax[1].set_xlabel("t [s]")
        fig.tight_layout()
        os.makedirs("results", exist_ok=True)
        fig.savefig(os.path.join("results", "01_pendulum.png"), dpi=120)
        print("wrote results/01_pendulum.png")
