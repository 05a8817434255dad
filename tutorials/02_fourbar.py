"""
A closed loop: the four-bar
===========================

The planar four-bar of benchmark B5: ground pivots at (0, 0) and (0.3, 0),
crank 0.1 m, coupler 0.3 m, rocker 0.25 m, uniform slender bars of 1 kg/m,
gravity along -y, the crank released from rest at 45 degrees with the
coupler above the ground line.

A loop cannot be described by a tree of joint coordinates alone: one joint
is *cut*, and the conditions it imposes become constraint equations
``phi(x) = 0`` with the Jacobian ``psi`` (eqs. 28-29 of Amirouche & Huston
1988). Kane's equations are then reduced with an orthogonal complement T of
psi (``psi T = 0``, eqs. 30-39), which removes the constraint forces. This
tutorial shows which joint is cut and how to choose it, psi, T from the
``'eigen'`` and ``'svd'`` strategies, redundant constraint rows, a free
motion simulated with both strategies, and a motor-driven crank.

The numbers to expect: the loop stays closed to about 1e-11 m, the energy
drifts by about 1e-10 of the peak kinetic energy in 2 s, the two strategies
give trajectories that agree to about 1e-10 rad, and a motor turning the
crank at one revolution per second must supply a peak torque of 0.399 N m.
"""

import numpy as np
from scipy.integrate import cumulative_simpson

import flexmb as fm

# %%
# The model
# ---------
# Each bar's body frame sits at its first end, with the bar along the body
# x axis, and in the reference configuration (all angles zero) every bar
# lies along +x. Revolute joints turn about z by default. The joint ``C``
# between coupler and rocker closes the loop; as a
# :class:`~flexmb.PlanarRevolute` it writes only the two in-plane conditions
# of a pin (more on that below).


def fourbar(closing_joint=fm.PlanarRevolute):
    """Benchmark B5, with the loop closed at C by ``closing_joint``."""
    model = fm.Model("fourbar")
    crank = fm.RigidBody.slender_bar("crank", mass=0.1, length=0.1)
    coupler = fm.RigidBody.slender_bar("coupler", mass=0.3, length=0.3)
    rocker = fm.RigidBody.slender_bar("rocker", mass=0.25, length=0.25)
    model.add(
        fm.Revolute("A", model.ground, crank),
        fm.Revolute("B", crank, coupler, parent_point=(0.1, 0, 0)),
        fm.Revolute("D", model.ground, rocker, parent_point=(0.3, 0, 0)),
        closing_joint("C", coupler, rocker, parent_point=(0.3, 0, 0), child_point=(0.25, 0, 0)),
        fm.Gravity((0.0, -9.81, 0.0)),
    )
    return model


# Rough guesses close enough to the wanted branch (coupler above the
# ground line); the crank angle is held at 45 degrees while the other angles
# are moved by Newton steps until the loop closes.
guess = {"A": np.pi / 4, "B": -0.15, "D": 1.5}

# %%
# The short form
# --------------
# Simulate 2 s of free motion. The default complement strategy is
# ``'svd'``; the tight tolerance keeps the loop closed without projections
# (see below).

t_end = 2.0
res = fm.simulate(fourbar(), t_end, positions=guess, fixed=["A"], rtol=1e-10)
print(f"short form: {res.status}; crank angle at {t_end:g} s {res.coordinate('A')[-1]:.9f} rad, "
      f"max loop residual {res.residual.max():.1e} m")

# %%
# Which joint is cut
# ------------------
# The tree is grown breadth-first from the ground, following each joint
# from its parent to its child: A reaches the crank, D the rocker, B the
# coupler. C leads to the rocker, which the tree already holds, so C closes
# the loop: it is the cut joint and supplies constraint rows instead of a
# coordinate. The coordinates are then the absolute crank and rocker angles
# and the coupler's angle relative to the crank.

model = fourbar()
system = model.build()
x0, xd0 = fm.initial_state(system, positions=guess, fixed=["A"])
kin = system.kinematics(0.0, x0, xd0)
point_C = kin.point_position(system.index(model["coupler"]), (0.3, 0.0, 0.0))
print(f"cut joints: {[j.name for j in system.topology.cut_joints]}; "
      f"coordinates: {system.coordinate_names}; constraint rows: {system.constraints.labels}")
angles = dict(zip(system.coordinate_names, x0))
print("assembled angles: " + ", ".join(f"{name} = {np.degrees(v):.4f} deg" for name, v in angles.items()))
print(f"coupler-rocker pin C at ({point_C[0]:.6f}, {point_C[1]:.6f}) m: above the ground line")

# %%
# Any joint of the loop may be cut; ``cut=True`` chooses. Cutting the
# rocker's ground pivot D instead turns the mechanism into a three-link
# chain A-B-C with the rocker at its end, and D's two conditions close the
# loop. The coordinates change (C now holds the rocker's angle relative to
# the coupler), the mechanism does not: the same configuration closes the
# loop exactly.

chain = fm.Model("fourbar, D cut")
crank = fm.RigidBody.slender_bar("crank", mass=0.1, length=0.1)
coupler = fm.RigidBody.slender_bar("coupler", mass=0.3, length=0.3)
rocker = fm.RigidBody.slender_bar("rocker", mass=0.25, length=0.25)
chain.add(
    fm.Revolute("A", chain.ground, crank),
    fm.Revolute("B", crank, coupler, parent_point=(0.1, 0, 0)),
    fm.PlanarRevolute("D", chain.ground, rocker, parent_point=(0.3, 0, 0), cut=True),
    fm.Revolute("C", coupler, rocker, parent_point=(0.3, 0, 0), child_point=(0.25, 0, 0)),
    fm.Gravity((0.0, -9.81, 0.0)),
)
chain_system = chain.build()
a, b, d = angles["A.angle"], angles["B.angle"], angles["D.angle"]
x_chain = np.array([a, b, d - a - b])  # C: the rocker's angle relative to the coupler
phi_chain = chain_system.constraints.evaluate(chain_system.kinematics(0.0, x_chain, np.zeros(3)), level=0).phi
print(f"D cut: coordinates {chain_system.coordinate_names}, rows {chain_system.constraints.labels}, "
      f"residual of the same configuration {np.abs(phi_chain).max():.1e} m")

# %%
# The constraint Jacobian psi
# ---------------------------
# ``system.constraints.evaluate(kin, level=1)`` returns the residuals phi
# (eq. 28), the Jacobian ``psi = dphi/dx`` and the right-hand side b of the
# speed constraints ``psi xd = b`` (eq. 29; b = 0 without drivers). Each row
# of psi is built from the partial velocities of the two joint points.

phi, psi, b, _ = system.constraints.evaluate(kin, level=1)
print(f"phi = {phi}, b = {b}")
print(f"psi ({psi.shape[0]} rows x {psi.shape[1]} coordinates) =\n{psi}")

# %%
# The orthogonal complement T
# ---------------------------
# The admissible speeds are ``xd = T z`` with T an orthonormal basis of the
# null space of psi, so ``psi T = 0`` and ``T^T T = I``; z holds
# ``p = n - rank(psi)`` independent speeds, one for the four-bar. The
# ``'eigen'`` strategy takes the eigenvectors of ``psi^T psi`` with zero
# eigenvalues (the zero-eigenvalue theorem, eqs. 30-37); the ``'svd'``
# strategy takes the right singular vectors of psi with zero singular
# values. Both use a zero tolerance relative to the largest eigen/singular
# value. Multiplying Kane's equations by ``T^T`` gives
# ``T^T A T zd = T^T (f - A xdd_p)`` (eqs. 36-39): the constraint forces,
# which lie in the row space of psi, drop out.

complements = {}
for strategy in (fm.EigenComplement(), fm.SVDComplement()):
    c = strategy.complement(psi)
    complements[strategy.name] = c.T
    print(f"{strategy.name:>5}: T = {c.T.ravel()}, rank(psi) = {c.rank}, p = {c.p}, "
          f"|psi T| = {np.abs(psi @ c.T).max():.1e}, |T^T T - I| = {np.abs(c.T.T @ c.T - np.eye(c.p)).max():.1e}")

# %%
# A null-space basis is unique only up to an orthogonal change of basis
# (here, a sign), so compare the projectors ``T T^T``:

T_e, T_s = complements["eigen"], complements["svd"]
print(f"|T_eigen T_eigen^T - T_svd T_svd^T| = {np.abs(T_e @ T_e.T - T_s @ T_s.T).max():.1e}")

# %%
# Redundant constraints
# ---------------------
# A spatial :class:`~flexmb.Revolute` as the cut joint writes five rows: the
# two joint points coincide (x, y, z) and the joint axis stays
# perpendicular to the child's x and y axes. In a planar mechanism three of
# them say nothing new (the z row and both perpendicularity rows vanish), so
# psi has 5 rows but rank 2. Methods that invert ``psi psi^T`` fail on such
# a psi; the eigen and SVD complements, with their relative zero tolerance,
# see the rank and give the same T. :class:`~flexmb.PlanarRevolute` writes
# only the two independent rows.

spatial = fourbar(fm.Revolute).build()
psi_spatial = spatial.constraints.evaluate(spatial.kinematics(0.0, x0, xd0), level=1).psi
singular_values = np.linalg.svd(psi_spatial, compute_uv=False)
print(f"spatial revolute cut: rows {spatial.constraints.labels}")
print(f"psi {psi_spatial.shape}, singular values {singular_values}")
for strategy in (fm.EigenComplement(), fm.SVDComplement()):
    c = strategy.complement(psi_spatial)
    print(f"{strategy.name:>5}: rank {c.rank}, p = {c.p}, "
          f"|T T^T - T_planar T_planar^T| = {np.abs(c.T @ c.T.T - T_s @ T_s.T).max():.1e}")

# %%
# Free motion with both strategies
# --------------------------------
# The short form above used the ``'svd'`` strategy; ``complement=`` picks
# another one by name (an instance works too). After every step the loop
# residual is checked, and the state is projected back onto the
# constraints when it exceeds ``projection_tol`` (1e-10 by default); at
# ``rtol = 1e-10`` the drift stays below that, so neither run projects and
# the two differ only by round-off. ``res.residual`` is max ``|phi|`` at each
# output time. The motion is undamped, so the total energy must stay
# constant; we measure its drift against the peak kinetic energy.

runs = {"svd": res,
        "eigen": fm.simulate(fourbar(), t_end, positions=guess, fixed=["A"], complement="eigen", rtol=1e-10)}
for name, r in runs.items():
    drift = np.abs(r.energy - r.energy[0]).max() / r.kinetic.max()
    print(f"{name:>5}: crank angle at {t_end:g} s {r.coordinate('A')[-1]:.9f} rad, "
          f"max loop residual {r.residual.max():.1e} m, relative energy drift {drift:.1e}, "
          f"{r.n_rhs} right-hand sides, {r.n_projections} projections")

max_residual = max(r.residual.max() for r in runs.values())
energy_drift_rel = max(np.abs(r.energy - r.energy[0]).max() / r.kinetic.max() for r in runs.values())
strategy_difference = np.abs(runs["svd"].x - runs["eigen"].x).max()
print(f"largest difference between the svd and eigen trajectories: {strategy_difference:.1e} rad")

# %%
# A driven crank
# --------------
# A :class:`~flexmb.Driver` prescribes a coordinate as a function of time:
# here the crank turns at one revolution per second from 45 degrees. It adds
# the row ``x_A - theta(t) = 0`` to the constraints, which leaves the
# mechanism no freedom: the simulation follows the prescribed motion, and the
# driver's constraint reaction is the torque the motor must supply,
# ``res.driver_effort("motor")``. Its work equals the change of kinetic plus
# potential energy.

driven = fourbar()
driven.add(fm.Driver.constant_speed("motor", driven["A"], speed=2 * np.pi, start=np.pi / 4))
res_driven = fm.simulate(driven, 1.0, positions=guess, rtol=1e-10, n_out=401)
torque = res_driven.driver_effort("motor")
i_peak = np.argmax(np.abs(torque))
driver_torque_peak = abs(torque[i_peak])
work = cumulative_simpson(torque * res_driven.xd[:, 0], x=res_driven.t, initial=0.0)
gain = res_driven.energy - res_driven.energy[0]
driver_work_error = np.abs(work - gain).max() / np.abs(gain).max()
print(f"driver torque peak {driver_torque_peak:.4f} N m at t = {res_driven.t[i_peak]:.4f} s "
      f"(crank at {np.degrees(res_driven.coordinate('A')[i_peak]) % 360:.1f} deg)")
print(f"driver work vs energy change: largest difference {driver_work_error:.1e} of the energy swing; "
      f"max loop residual {res_driven.residual.max():.1e} m")

# %%
# Plot
# ----
# The free motion (coordinates, energy drift, loop residual) and the motor
# torque of the driven crank.

if __name__ == "__main__":
    import os

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed (pip install -e '.[viz]'): no plot")
    else:
        r = runs["svd"]
        fig, ax = plt.subplots(4, 1, figsize=(7, 10))
        ax[0].plot(r.t, r.x)
        ax[0].legend(r.coordinate_names, fontsize=8)
        ax[0].set_ylabel("coordinates [rad]")
        for name, rr in runs.items():
            ax[1].plot(rr.t, (rr.energy - rr.energy[0]) / rr.kinetic.max(), label=name)
            ax[2].semilogy(rr.t, np.maximum(rr.residual, 1e-18), label=name)
        ax[1].set_ylabel("relative energy drift")
        ax[1].legend(fontsize=8)
        ax[2].set_ylabel("loop residual [m]")
        ax[2].set_xlabel("t [s]")
        ax[3].plot(res_driven.t, torque)
        ax[3].set_ylabel("motor torque [N m]")
        ax[3].set_xlabel("t [s] (driven crank, 1 rev/s)")
        fig.tight_layout()
        os.makedirs("results", exist_ok=True)
        fig.savefig(os.path.join("results", "02_fourbar.png"), dpi=120)
        print("wrote results/02_fourbar.png")
